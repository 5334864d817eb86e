# SPDX-License-Identifier: Apache-2.0
# Cortex-M4F with single-precision FPU (e.g. STM32F4, nRF52), hard-float ABI, core library only.
# Double arithmetic is emulated in software on this part (libgcc's IEEE routines): the geometry is
# double everywhere, so results are those of the other targets, only slower. See arm-none-eabi-common.cmake.
set(TVO_CPU_FLAGS "-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard")
include(${CMAKE_CURRENT_LIST_DIR}/arm-none-eabi-common.cmake)
