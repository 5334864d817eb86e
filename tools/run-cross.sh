#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Cross builds for ARM Linux, unit tests run under qemu-user:
#   tools/run-cross.sh [aarch64-linux-gnu] [arm-linux-gnueabihf] [arm-linux-gnueabihf-neon]   (default: all three)
# For each target: configures build/<triple> with cmake/toolchains/<triple>.cmake (core library,
# PNG + EuRoC port, V4L2 port, unit and port tests incl. test_determinism; examples and benchmarks
# off), builds it, and runs ctest: CMAKE_CROSSCOMPILING_EMULATOR makes ctest start every test under
# qemu-aarch64 / qemu-arm -L /usr/<triple>. arm-linux-gnueabihf-neon is armhf with -mfpu=neon (the NEON
# LK and FAST kernels): only test_lk and test_corners (NEON vs portable kernels) and test_determinism
# (same digests) are built and run there, the rest is the plain armhf code. TVO_EXPECT_LK_KERNEL and
# TVO_EXPECT_FAST_KERNEL tell test_lk and test_corners which LK and FAST-9 kernels each build must have
# compiled in (neon on aarch64 and armhf-neon, portable on plain armhf).
# Installs what it needs when run as root (apt-get update first): the Debian cross compilers,
# qemu-user, cmocka for the target through Debian multiarch (libcmocka-dev:arm64/armhf), and the
# target's libspng runtime (libspng0:arm64/armhf). Not libspng-dev:<arch>: it pulls zlib1g-dev and
# libc6-dev for the target, whose Multi-Arch: same versions must equal the host's exactly (linux-libc-dev,
# libssl3), which a host with newer security updates than the mirror's arm lists cannot satisfy. The
# header comes from the host's libspng-dev (identical for every architecture) and the library is linked
# as /usr/lib/<triple>/libspng.so.0.
# Environment: TVO_WERROR=OFF to let warnings pass (default ON, as in CI); JOBS (default 2).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
TARGETS=("$@")
[ ${#TARGETS[@]} -eq 0 ] && TARGETS=(aarch64-linux-gnu arm-linux-gnueabihf arm-linux-gnueabihf-neon)
JOBS="${JOBS:-2}"

debarch() {
  case "$1" in
    aarch64-linux-gnu) echo arm64 ;;
    arm-linux-gnueabihf|arm-linux-gnueabihf-neon) echo armhf ;;
    *) echo "unknown target $1" >&2; exit 2 ;;
  esac
}

. "$ROOT/tools/apt-lib.sh"
installed() { tvo_deb_installed "$1"; }

need=()
for p in cmake ninja-build qemu-user libspng-dev; do installed "$p" || need+=("$p"); done
for t in "${TARGETS[@]}"; do
  a=$(debarch "$t")
  installed "gcc-${t%-neon}" || need+=("gcc-${t%-neon}")
  # the target's C runtime and headers (crt1.o, crti.o, libc.so): only a Recommends of the cross gcc,
  # which --no-install-recommends leaves out
  installed "libc6-dev-$a-cross" || need+=("libc6-dev-$a-cross")
  installed "libcmocka-dev:$a" || need+=("libcmocka-dev:$a")
  installed "libspng0:$a" || need+=("libspng0:$a")
done
if [ ${#need[@]} -gt 0 ]; then
  if [ "$(id -u)" -ne 0 ]; then
    echo "[run-cross] missing packages (run as root to install): ${need[*]}" >&2
    exit 1
  fi
  for t in "${TARGETS[@]}"; do
    a=$(debarch "$t")
    dpkg --print-foreign-architectures | grep -qx "$a" || dpkg --add-architecture "$a"
  done
  # A mirror caught mid-sync fails one index now and then: retry, then go on with what we have.
  apt-get update -qq || { sleep 10; apt-get update -qq; } || echo "[run-cross] apt-get update incomplete, continuing" >&2
  echo "[run-cross] apt-get install ${need[*]}"
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
fi

start_all=$(date +%s)
for t in "${TARGETS[@]}"; do
  start=$(date +%s)
  triple="${t%-neon}"
  only=()
  case "$t" in
    arm-linux-gnueabihf) export TVO_EXPECT_LK_KERNEL=portable TVO_EXPECT_FAST_KERNEL=portable ;;
    arm-linux-gnueabihf-neon)
      export TVO_EXPECT_LK_KERNEL=neon TVO_EXPECT_FAST_KERNEL=neon; only=(test_lk test_corners test_determinism) ;;
    *) export TVO_EXPECT_LK_KERNEL=neon TVO_EXPECT_FAST_KERNEL=neon ;;
  esac
  echo "== $t: build${only[*]:+ (${only[*]})}"
  cmake -S . -B "build/$t" -G Ninja --toolchain "cmake/toolchains/$t.cmake" \
        -DCMAKE_BUILD_TYPE=Release -DTVO_WERROR="${TVO_WERROR:-ON}" \
        -DTVO_BUILD_PORT=ON -DSPNG_INCLUDE_DIR=/usr/include -DSPNG_LIBRARY="/usr/lib/$triple/libspng.so.0" \
        -DTVO_BUILD_EXAMPLES=OFF -DTVO_BUILD_BENCH=OFF >/dev/null
  cmake --build "build/$t" -j"$JOBS" ${only[@]:+--target "${only[@]}"}
  echo "== $t: unit tests under $(grep -o 'qemu-[a-z0-9]*' "cmake/toolchains/$triple.cmake" | head -1)"
  if [ ${#only[@]} -gt 0 ]; then
    ctest --test-dir "build/$t" -j"$JOBS" --output-on-failure -R "^($(IFS='|'; echo "${only[*]}"))\$"
  else
    ctest --test-dir "build/$t" -j"$JOBS" --output-on-failure
  fi
  echo "== $t: done in $(( $(date +%s) - start )) s"
done
echo "== cross targets passed (${TARGETS[*]}) in $(( $(date +%s) - start_all )) s"
