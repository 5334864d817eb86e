# SPDX-License-Identifier: Apache-2.0
# Cortex-M7 with double-precision FPU (e.g. STM32H7, i.MX RT), hard-float ABI, core library only.
# See arm-none-eabi-common.cmake.
set(TVO_CPU_FLAGS "-mcpu=cortex-m7 -mthumb -mfpu=fpv5-d16 -mfloat-abi=hard")
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi-common.cmake)
