# Cross build for aarch64-linux-gnu (Debian cross compiler gcc-aarch64-linux-gnu), Linux userland.
#   cmake -S . -B build/aarch64-linux-gnu -G Ninja --toolchain cmake/toolchains/aarch64-linux-gnu.cmake \
#         -DTVO_BUILD_PORT=OFF -DTVO_BUILD_EXAMPLES=OFF
#   ctest --test-dir build/aarch64-linux-gnu        (runs every test under qemu-aarch64, see tools/run-cross.sh)
# Target libraries (cmocka) come from Debian multiarch: libcmocka-dev:arm64 in /usr/lib/aarch64-linux-gnu.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(TVO_CROSS_TRIPLE aarch64-linux-gnu)

set(CMAKE_C_COMPILER ${TVO_CROSS_TRIPLE}-gcc)
set(CMAKE_LIBRARY_ARCHITECTURE ${TVO_CROSS_TRIPLE})

# Libraries and headers: the cross sysroot /usr/aarch64-linux-gnu first, then the multiarch host
# directories (/usr/lib/aarch64-linux-gnu, /usr/include), never host programs.
set(CMAKE_FIND_ROOT_PATH /usr/${TVO_CROSS_TRIPLE})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/${TVO_CROSS_TRIPLE}/pkgconfig:/usr/share/pkgconfig")

# ctest and add_custom_command run target programs under user-mode emulation; -L makes the
# emulated dynamic loader find the target's libc (multiarch libraries in /lib/aarch64-linux-gnu are
# found through the host path fallback).
find_program(TVO_QEMU qemu-aarch64)
if(TVO_QEMU)
  set(CMAKE_CROSSCOMPILING_EMULATOR ${TVO_QEMU} -L /usr/${TVO_CROSS_TRIPLE})
else()
  message(WARNING "qemu-aarch64 not found (apt-get install qemu-user): tests cannot run")
endif()
