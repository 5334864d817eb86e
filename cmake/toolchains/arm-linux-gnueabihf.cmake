# Cross build for arm-linux-gnueabihf (Debian cross compiler gcc-arm-linux-gnueabihf), Linux userland.
#   cmake -S . -B build/arm-linux-gnueabihf -G Ninja --toolchain cmake/toolchains/arm-linux-gnueabihf.cmake \
#         -DTVO_BUILD_PORT=OFF -DTVO_BUILD_EXAMPLES=OFF
#   ctest --test-dir build/arm-linux-gnueabihf        (runs every test under qemu-arm, see tools/run-cross.sh)
# Target libraries (cmocka) come from Debian multiarch: libcmocka-dev:armhf in /usr/lib/arm-linux-gnueabihf.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(TVO_CROSS_TRIPLE arm-linux-gnueabihf)

set(CMAKE_C_COMPILER ${TVO_CROSS_TRIPLE}-gcc)
set(CMAKE_LIBRARY_ARCHITECTURE ${TVO_CROSS_TRIPLE})

# Libraries and headers: the cross sysroot /usr/arm-linux-gnueabihf first, then the multiarch host
# directories (/usr/lib/arm-linux-gnueabihf, /usr/include), never host programs.
set(CMAKE_FIND_ROOT_PATH /usr/${TVO_CROSS_TRIPLE})
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/${TVO_CROSS_TRIPLE}/pkgconfig:/usr/share/pkgconfig")

# ctest and add_custom_command run target programs under user-mode emulation; -L makes the
# emulated dynamic loader find the target's libc (multiarch libraries in /lib/arm-linux-gnueabihf are
# found through the host path fallback).
find_program(TVO_QEMU qemu-arm)
if(TVO_QEMU)
  set(CMAKE_CROSSCOMPILING_EMULATOR ${TVO_QEMU} -L /usr/${TVO_CROSS_TRIPLE})
else()
  message(WARNING "qemu-arm not found (apt-get install qemu-user): tests cannot run")
endif()
