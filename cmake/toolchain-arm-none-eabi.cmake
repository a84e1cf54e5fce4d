# Cross-compiling for an ARM Cortex-M3 with the GNU Arm Embedded toolchain
# (Debian: gcc-arm-none-eabi, libnewlib-arm-none-eabi).
#
#   cmake -S robot_link/firmware -B build/fw-arm \
#         -DCMAKE_TOOLCHAIN_FILE=cmake/toolchain-arm-none-eabi.cmake \
#         -DODOLINK_TARGET=lm3s6965
#
# Bare metal: no OS, newlib-nano as the C library. The board's CMakeLists
# adds its own startup code and linker script (-nostartfiles, -T).
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)

set(ODOLINK_ARM_PREFIX "arm-none-eabi-" CACHE STRING "Prefix of the cross tools")
set(CMAKE_C_COMPILER ${ODOLINK_ARM_PREFIX}gcc)
set(CMAKE_CXX_COMPILER ${ODOLINK_ARM_PREFIX}g++)
set(CMAKE_ASM_COMPILER ${ODOLINK_ARM_PREFIX}gcc)
find_program(CMAKE_OBJCOPY ${ODOLINK_ARM_PREFIX}objcopy)
find_program(CMAKE_SIZE ${ODOLINK_ARM_PREFIX}size)

# A test program cannot link without a board's startup and linker script.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

set(ODOLINK_ARM_CPU_FLAGS "-mcpu=cortex-m3 -mthumb")
set(CMAKE_C_FLAGS_INIT "${ODOLINK_ARM_CPU_FLAGS} -Os -ffunction-sections -fdata-sections")
set(CMAKE_CXX_FLAGS_INIT "${CMAKE_C_FLAGS_INIT}")
set(CMAKE_ASM_FLAGS_INIT "${ODOLINK_ARM_CPU_FLAGS}")
set(CMAKE_EXE_LINKER_FLAGS_INIT "${ODOLINK_ARM_CPU_FLAGS} --specs=nano.specs -Wl,--gc-sections")

# Headers and libraries come from the cross sysroot only; programs from the host.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
