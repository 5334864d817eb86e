# SPDX-License-Identifier: Apache-2.0
# Cross build for arm-linux-gnueabihf (Debian cross compiler gcc-arm-linux-gnueabihf), Linux userland.
#   cmake -S . -B build/arm-linux-gnueabihf -G Ninja --toolchain cmake/toolchains/arm-linux-gnueabihf.cmake \
#         -DTVO_BUILD_PORT=OFF -DTVO_BUILD_EXAMPLES=OFF
#   ctest --test-dir build/arm-linux-gnueabihf        (runs every test under qemu-arm, see tools/run-cross.sh)
# Target libraries (cmocka) come from Debian multiarch: libcmocka-dev:armhf in /usr/lib/arm-linux-gnueabihf.
set(CMAKE_SYSTEM_PROCESSOR arm)
set(TVO_CROSS_TRIPLE arm-linux-gnueabihf)
set(TVO_QEMU_NAME qemu-arm)
include(${CMAKE_CURRENT_LIST_DIR}/linux-cross-common.cmake)
