#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Static analysis of lib/, port/ and examples/: cppcheck and clang-tidy from Debian, with the
# checked-in configuration (.clang-tidy at the top, tools/cppcheck-suppressions.txt with a reason per
# line). Any finding fails the script. Run by tools/run-tests.sh after the ASan stage.
#   - configures build/static (Release, no tests/benchmarks) only to get its compile_commands.json
#   - installs cppcheck / clang-tidy when missing and running as root
# Usage: tools/run-static.sh          (from anywhere; about 2 minutes on 2 cores)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
JOBS="${JOBS:-2}"

. "$ROOT/tools/apt-lib.sh"
tvo_apt_ensure run-static cppcheck clang-tidy clang-format || exit 1   # clang-tidy brings run-clang-tidy

echo "== clang-format $(clang-format --version | sed -n 's/.*version \([0-9.]*\).*/\1/p' | head -1) (.clang-format)"
# every C source and header of the repository is formatted; fix with: clang-format -i FILE
if git rev-parse --git-dir >/dev/null 2>&1; then
  git ls-files -z '*.c' '*.h' | xargs -0 clang-format --dry-run --Werror
else
  find lib port examples test -name '*.c' -o -name '*.h' | xargs clang-format --dry-run --Werror
fi

BUILD=build/static
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_EXPORT_COMPILE_COMMANDS=ON \
      -DTVO_BUILD_TESTS=OFF -DTVO_BUILD_BENCH=OFF >/dev/null
# compile_commands.json lists only lib/, port/ and examples/ sources with tests and benchmarks off.

echo "== cppcheck $(cppcheck --version | awk '{print $2}')"
cppcheck --project="$BUILD/compile_commands.json" --std=c99 \
         --enable=warning,style,performance,portability --inline-suppr \
         --suppressions-list=tools/cppcheck-suppressions.txt \
         -j"$JOBS" --quiet --error-exitcode=1 \
         --template='{file}:{line}: {severity}: {message} [{id}]'

echo "== clang-tidy $(clang-tidy --version | sed -n 's/.*version \([0-9.]*\).*/\1/p' | head -1) (.clang-tidy)"
# run-clang-tidy exits non-zero when a check fires (WarningsAsErrors: '*' in .clang-tidy).
log="$BUILD/clang-tidy.log"
if ! run-clang-tidy -j "$JOBS" -quiet -p "$BUILD" "$ROOT/(lib|port|examples)/" >"$log" 2>&1; then
  sed 's/\x1b\[[0-9;]*m//g' "$log" | grep -E '(warning|error):' | sort -u >&2 || true
  echo "[run-static] clang-tidy found problems (full log: $log)" >&2
  exit 1
fi
echo "== static analysis clean"
