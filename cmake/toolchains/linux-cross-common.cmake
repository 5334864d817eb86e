# SPDX-License-Identifier: Apache-2.0
# Shared part of the ARM Linux cross toolchains (aarch64-linux-gnu.cmake, arm-linux-gnueabihf.cmake):
# the including file sets CMAKE_SYSTEM_PROCESSOR, TVO_CROSS_TRIPLE (Debian cross compiler prefix) and
# TVO_QEMU_NAME (qemu-user binary for the target).
set(CMAKE_SYSTEM_NAME Linux)

set(CMAKE_C_COMPILER ${TVO_CROSS_TRIPLE}-gcc)
set(CMAKE_LIBRARY_ARCHITECTURE ${TVO_CROSS_TRIPLE})

# Libraries and headers: the cross sysroot /usr/<triple> first, then the multiarch host directories
# (/usr/lib/<triple>, /usr/include), never host programs.
set(CMAKE_FIND_ROOT_PATH /usr/${TVO_CROSS_TRIPLE})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/${TVO_CROSS_TRIPLE}/pkgconfig:/usr/share/pkgconfig")

# ctest and add_custom_command run target programs under user-mode emulation; -L makes the
# emulated dynamic loader find the target's libc (multiarch libraries in /lib/<triple> are found
# through the host path fallback).
find_program(TVO_QEMU ${TVO_QEMU_NAME})
if(TVO_QEMU)
  set(CMAKE_CROSSCOMPILING_EMULATOR ${TVO_QEMU} -L /usr/${TVO_CROSS_TRIPLE})
else()
  message(WARNING "${TVO_QEMU_NAME} not found (apt-get install qemu-user): tests cannot run")
endif()
