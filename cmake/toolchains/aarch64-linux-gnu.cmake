# SPDX-License-Identifier: Apache-2.0
# Cross build for aarch64-linux-gnu (Debian cross compiler gcc-aarch64-linux-gnu), Linux userland.
#   cmake -S . -B build/aarch64-linux-gnu -G Ninja --toolchain cmake/toolchains/aarch64-linux-gnu.cmake \
#         -DTVO_BUILD_PORT=OFF -DTVO_BUILD_EXAMPLES=OFF
#   ctest --test-dir build/aarch64-linux-gnu        (runs every test under qemu-aarch64, see tools/run-cross.sh)
# Target libraries (cmocka) come from Debian multiarch: libcmocka-dev:arm64 in /usr/lib/aarch64-linux-gnu.
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(TVO_CROSS_TRIPLE aarch64-linux-gnu)
set(TVO_QEMU_NAME qemu-aarch64)
include(${CMAKE_CURRENT_LIST_DIR}/linux-cross-common.cmake)
