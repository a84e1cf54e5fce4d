# The firmware library cross-compiled for the microcontrollers it claims to run
# on, each a separate CMake build of robot_link/firmware with its toolchain
# file (a project has one C compiler): ATmega328P (avr-gcc, avr-libc) and the
# LM3S6965 Cortex-M3 (arm-none-eabi-gcc, newlib). Each builds the board image
# the emulated tests run, the examples and the footprint programs.
#
# Footprint budgets (bytes; robot_link/firmware/footprint, docs/protocol.md):
#   AVR flash 9216: measured 8.6 KiB with LTO as the Arduino IDE builds it. An
#     8-bit CPU spends four instructions on every 32-bit operation and the
#     protocol is mostly 32-bit (CRC-32, ticks, checksums); the same source is
#     4.4 KiB on the Cortex-M3. 9 KiB is 28 % of an Uno's 32 KiB and fails the
#     build on ~5 % growth.
#   AVR RAM 640: the 428-byte context (the caller's static), the parameter table
#     and its names (avr-gcc keeps constants in RAM): 556 B measured, a quarter
#     of the Uno's 2 KiB. The issue's 512 B would need the names in program
#     memory, which the portable C library does not do.
#   Cortex-M3: flash 6144, RAM 1024 (roomy parts; the budget only catches growth).
option(ODOCAL_BUILD_FIRMWARE_TARGETS
       "Cross-build the firmware library for AVR and Cortex-M3 and test it in simavr and QEMU" ON)
if(NOT ODOCAL_BUILD_FIRMWARE_TARGETS)
  return()
endif()

include(ExternalProject)
set(_missing "")
foreach(_tool avr-gcc avr-size arm-none-eabi-gcc arm-none-eabi-size qemu-system-arm)
  find_program(_found_${_tool} ${_tool})
  if(NOT _found_${_tool})
    list(APPEND _missing ${_tool})
  endif()
endforeach()
if(NOT TARGET odocal-avr-board)  # robot_link/emu/avr: built when simavr's library and headers are there
  list(APPEND _missing "libsimavr-dev")
endif()
if(_missing)
  list(JOIN _missing ", " _missing)
  message(FATAL_ERROR "The firmware targets need ${_missing}: run scripts/install-deps.sh "
                      "(Debian: gcc-avr avr-libc simavr libsimavr-dev arduino-core-avr "
                      "gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm), or configure with "
                      "-DODOCAL_BUILD_FIRMWARE_TARGETS=OFF to build without them.")
endif()

set(ODOCAL_FIRMWARE_DIR ${CMAKE_BINARY_DIR}/firmware)
function(odocal_firmware_target name toolchain flash_budget ram_budget)
  ExternalProject_Add(firmware_${name}
    SOURCE_DIR ${PROJECT_SOURCE_DIR}/robot_link/firmware
    BINARY_DIR ${ODOCAL_FIRMWARE_DIR}/${name}
    CMAKE_ARGS -DCMAKE_TOOLCHAIN_FILE=${PROJECT_SOURCE_DIR}/cmake/${toolchain}
               -DODOLINK_TARGET=${name}
               -DODOLINK_FLASH_BUDGET=${flash_budget}
               -DODOLINK_RAM_BUDGET=${ram_budget}
    INSTALL_COMMAND ""
    BUILD_ALWAYS ON
    USES_TERMINAL_BUILD ON)
endfunction()
odocal_firmware_target(avr toolchain-avr.cmake 9216 640)
odocal_firmware_target(lm3s6965 toolchain-arm-none-eabi.cmake 6144 1024)
