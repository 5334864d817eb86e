# SPDX-License-Identifier: Apache-2.0
# Shared part of the bare-metal Cortex-M toolchain files (cortex-m7.cmake, cortex-m4.cmake).
# Needs TVO_CPU_FLAGS set by the including file. Builds the C core only:
#   cmake -S . -B build/cortex-m7 -G Ninja --toolchain cmake/toolchains/cortex-m7.cmake -DTVO_CORE_ONLY=ON
# (tools/size-report.sh does this for M7 and M4 and prints .text/.data/.bss.)
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-none-eabi-gcc)
set(CMAKE_AR arm-none-eabi-ar CACHE FILEPATH "")
set(CMAKE_RANLIB arm-none-eabi-ranlib CACHE FILEPATH "")
set(CMAKE_SIZE arm-none-eabi-size CACHE FILEPATH "")
# No OS to link a test program against during compiler checks.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

# -Os and section-per-function so a firmware link keeps only what it calls.
set(CMAKE_C_FLAGS_INIT "${TVO_CPU_FLAGS} -ffunction-sections -fdata-sections")
# Release means -Os here (CMake's default Release flags would append -O3).
set(CMAKE_C_FLAGS_RELEASE "-Os -fno-schedule-insns2 -fno-tree-loop-distribute-patterns -DNDEBUG" CACHE STRING "Release flags for Cortex-M")
set(CMAKE_EXE_LINKER_FLAGS_INIT "${TVO_CPU_FLAGS} --specs=nosys.specs -Wl,--gc-sections")

set(CMAKE_FIND_ROOT_PATH /usr/lib/arm-none-eabi)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
