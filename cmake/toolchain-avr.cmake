# CMake toolchain file: avr-gcc for an ATmega328P at 16 MHz (Arduino Uno/Nano
# class boards).
#
#   cmake -S robot_link/firmware -B build-fw-avr \
#         -DCMAKE_TOOLCHAIN_FILE=cmake/toolchain-avr.cmake -DODOLINK_TARGET=avr
#
# Override the part or the clock with -DAVR_MCU=... -DAVR_F_CPU=... (the
# values land in every compile and link line, so the library and the board
# agree).
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR avr)

set(AVR_MCU "atmega328p" CACHE STRING "avr-gcc -mmcu value")
set(AVR_F_CPU "16000000UL" CACHE STRING "CPU clock in Hz, as a C constant (F_CPU)")

find_program(AVR_GCC avr-gcc REQUIRED)
find_program(AVR_GXX avr-g++)
find_program(AVR_OBJCOPY avr-objcopy REQUIRED)
find_program(AVR_SIZE avr-size REQUIRED)
set(CMAKE_C_COMPILER ${AVR_GCC})
if(AVR_GXX)
  set(CMAKE_CXX_COMPILER ${AVR_GXX})
endif()
set(CMAKE_ASM_COMPILER ${AVR_GCC})
set(CMAKE_OBJCOPY ${AVR_OBJCOPY} CACHE FILEPATH "objcopy for the target" FORCE)
set(CMAKE_SIZE ${AVR_SIZE} CACHE FILEPATH "size for the target" FORCE)

# No host sysroot, no test executables: the compiler checks must not try to
# link and run a host program.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)

# -flto and -mcall-prologues as the Arduino IDE builds (its platform.txt):
# the library is ~600 B smaller with them. LTO objects in a static library need
# the plugin-aware archiver (avr-gcc-ar), or the link sees empty archives.
find_program(AVR_GCC_AR avr-gcc-ar REQUIRED)
find_program(AVR_GCC_RANLIB avr-gcc-ranlib REQUIRED)
set(CMAKE_AR ${AVR_GCC_AR} CACHE FILEPATH "LTO-aware ar" FORCE)
set(CMAKE_C_COMPILER_AR ${AVR_GCC_AR} CACHE FILEPATH "" FORCE)
set(CMAKE_CXX_COMPILER_AR ${AVR_GCC_AR} CACHE FILEPATH "" FORCE)
set(CMAKE_RANLIB ${AVR_GCC_RANLIB} CACHE FILEPATH "LTO-aware ranlib" FORCE)
set(CMAKE_C_COMPILER_RANLIB ${AVR_GCC_RANLIB} CACHE FILEPATH "" FORCE)
set(CMAKE_CXX_COMPILER_RANLIB ${AVR_GCC_RANLIB} CACHE FILEPATH "" FORCE)

set(_avr_flags "-mmcu=${AVR_MCU} -DF_CPU=${AVR_F_CPU} -Os -flto -mcall-prologues -ffunction-sections -fdata-sections")
set(CMAKE_C_FLAGS_INIT "${_avr_flags}")
set(CMAKE_CXX_FLAGS_INIT "${_avr_flags} -fno-exceptions -fno-rtti -fno-threadsafe-statics")
set(CMAKE_ASM_FLAGS_INIT "-mmcu=${AVR_MCU} -DF_CPU=${AVR_F_CPU}")
set(CMAKE_EXE_LINKER_FLAGS_INIT "-mmcu=${AVR_MCU} -Os -flto -mcall-prologues -Wl,--gc-sections")
# -Os is in the flags above for every build type; keep the build types from
# adding -O3 / -g on top.
set(CMAKE_C_FLAGS_RELEASE_INIT "-DNDEBUG")
set(CMAKE_CXX_FLAGS_RELEASE_INIT "-DNDEBUG")
