# SPDX-License-Identifier: Apache-2.0
# Cross build for arm-linux-gnueabihf with NEON (ARMv7-A cores that have it: Cortex-A7, A8, A9, A15,
# and ARMv8 cores in 32-bit mode). Same as arm-linux-gnueabihf.cmake plus -mfpu=neon, which defines
# __ARM_NEON and so compiles in tinyvo's NEON kernels (LK tracking, FAST-9). Debian's armhf compiler
# defaults to -mfpu=vfpv3-d16 (no NEON), so the plain armhf build runs the portable C kernels: it is the
# one for NEON-less cores. Results are bit-identical either way (docs/ports.md, "Determinism across
# targets").
#   cmake -S . -B build/arm-linux-gnueabihf-neon -G Ninja --toolchain cmake/toolchains/arm-linux-gnueabihf-neon.cmake \
#         -DTVO_BUILD_PORT=OFF -DTVO_BUILD_EXAMPLES=OFF
#   ctest --test-dir build/arm-linux-gnueabihf-neon        (runs the tests under qemu-arm)
set(CMAKE_C_FLAGS_INIT "-mfpu=neon")
include(${CMAKE_CURRENT_LIST_DIR}/arm-linux-gnueabihf.cmake)
