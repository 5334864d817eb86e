#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The test command (README, .ci/run): installs what is needed, then builds and runs every test:
#   1. Release build with -Werror, all ctest tests (unit, port, guarantees, fuzz-corpus replays; -j2)
#   2. the OpenCV oracle tests (pytest, test/oracle) and the Python tool tests (test/python) against it
#      install + external project (test/external/run.sh: find_package and pkg-config from a moved
#      non-default prefix, static and shared libraries); pip install of the tools into a fresh venv
#      and every console script's --help (tools/check-pip-install.sh)
#   3. an ASan+UBSan build running the ctest tests again
#   4. a -Os (MinSizeRel) build running the ctest tests again, a build without the affine track
#      refinement nor the lens refinement (-DTVO_WITH_AFFINE=OFF -DTVO_WITH_LENS=OFF) running them again, a shared-library build
#      (-DBUILD_SHARED_LIBS=ON) running them again, and the Cortex-M size report
#      (tools/size-report.sh: arm-none-eabi core builds, link check, Cortex-M7 .text <= 96 KiB)
#   5. cppcheck + clang-tidy with the checked-in configuration (tools/run-static.sh)
#   6. aarch64 / armhf cross builds, their tests under qemu-user (tools/run-cross.sh)
#   7. the Cortex-M7 model (qemu-system-arm -M mps2-an500): unit tests and the QVGA replay, bit-identical
#      to the host (tools/run-mcu.sh)
# Tests that need recorded data read it from $TVO_DATA_DIR (default ../shared/data beside the repository)
# and skip with a message when it is absent.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
bash tools/install-deps.sh
JOBS=2

echo "== release build + unit tests"
cmake -S . -B build/release -G Ninja -DCMAKE_BUILD_TYPE=Release -DTVO_WERROR=ON >/dev/null
cmake --build build/release -j$JOBS
ctest --test-dir build/release -j$JOBS --output-on-failure

echo "== oracle tests (OpenCV)"
TVO_BUILD_DIR="$ROOT/build/release" "$ROOT/.venv/bin/python" -m pytest -q -rs test/oracle
TVO_BUILD_DIR="$ROOT/build/release" "$ROOT/.venv/bin/python" -m pytest -q test/python

echo "== install to a non-default prefix, external project (find_package + pkg-config; static, shared + SONAME)"
bash test/external/run.sh

echo "== pip install ./tools into a fresh venv, every console script's --help (tools/check-pip-install.sh)"
bash tools/check-pip-install.sh

echo "== ASan + UBSan build + unit tests"
cmake -S . -B build/asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DTVO_SANITIZE=ON -DTVO_WERROR=ON \
      -DTVO_BUILD_BENCH=OFF >/dev/null
cmake --build build/asan -j$JOBS
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build/asan -j$JOBS --output-on-failure

echo "== -Os build (the Cortex-M optimisation level) + unit tests: same digests as the -O3 build"
cmake -S . -B build/minsize -G Ninja -DCMAKE_BUILD_TYPE=MinSizeRel -DTVO_WERROR=ON -DTVO_BUILD_BENCH=OFF >/dev/null
cmake --build build/minsize -j$JOBS
ctest --test-dir build/minsize -j$JOBS --output-on-failure

echo "== a build without the affine track refinement and the lens refinement (-DTVO_WITH_AFFINE=OFF -DTVO_WITH_LENS=OFF) + unit tests"
cmake -S . -B build/noaffine -G Ninja -DCMAKE_BUILD_TYPE=Release -DTVO_WITH_AFFINE=OFF -DTVO_WITH_LENS=OFF -DTVO_WERROR=ON \
      -DTVO_BUILD_BENCH=OFF >/dev/null
cmake --build build/noaffine -j$JOBS
ctest --test-dir build/noaffine -j$JOBS --output-on-failure

echo "== a shared build (BUILD_SHARED_LIBS=ON) + unit tests"
# the unit tests link a test-only static copy of the core (test/CMakeLists.txt: TVO_TEST_CORE), the port,
# guarantee and fuzz-corpus tests and the examples the shared libraries
cmake -S . -B build/shared -G Ninja -DCMAKE_BUILD_TYPE=Release -DBUILD_SHARED_LIBS=ON -DTVO_WERROR=ON \
      -DTVO_BUILD_BENCH=OFF >/dev/null
cmake --build build/shared -j$JOBS
ctest --test-dir build/shared -j$JOBS --output-on-failure

echo "== Cortex-M7 / M4 core builds, link check, M7 .text <= 96 KiB (tools/size-report.sh)"
TVO_WERROR=ON bash tools/size-report.sh

echo "== static analysis (cppcheck + clang-tidy, tools/run-static.sh; ~3 min)"
# an SPDX licence line in every source file (tools/spdx.sh --add inserts it in new ones)
bash tools/spdx.sh --check
bash tools/run-static.sh

echo "== ARM cross builds, unit tests under qemu-user (aarch64, armhf; ~7 min)"
bash tools/run-cross.sh

echo "== Cortex-M7 model: unit tests and QVGA replay under qemu-system-arm (tools/run-mcu.sh; ~10 min)"
bash tools/run-mcu.sh

echo "== all tests passed"
