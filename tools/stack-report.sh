#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Per-function stack frames of the C core from GCC's -fstack-usage (docs/limits.md).
# Configures build/stack (Release, -fstack-usage, core only), builds it, and prints the largest frames
# of lib/ from the .su files: bytes, qualifier and function. "static" is a fixed frame; "dynamic,bounded"
# is a frame GCC adjusts around calls by a bounded amount (the figure includes it); a plain "dynamic"
# frame (alloca, VLA) would be unbounded: the script fails if one appears.
# The real high-water mark of the per-frame path (call chains included) is measured by
# test/guarantees/test_stack.c.
# Usage: tools/stack-report.sh [N]     (N largest frames, default 25)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
N="${1:-25}"
BUILD=build/stack
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DTVO_CORE_ONLY=ON \
      -DCMAKE_C_FLAGS="-fstack-usage" >/dev/null
cmake --build "$BUILD" -j2 >/dev/null
mapfile -t files < <(find "$BUILD/lib" -name '*.su' | sort)
if [ ${#files[@]} -eq 0 ]; then
  echo "no .su files under $BUILD/lib (compiler without -fstack-usage?)" >&2
  exit 1
fi
# .su lines: file:line:col:function<TAB>bytes<TAB>qualifier
echo "largest stack frames in lib/ ($(cc --version | head -1), Release):"
printf '%8s  %-8s  %s\n' bytes kind function
cat "${files[@]}" | awk -F'\t' '{ n = split($1, a, ":"); printf "%8d  %-8s  %s (%s:%s)\n", $2, $3, a[n], a[1], a[2] }' \
  | sed "s|$ROOT/||" | sort -rn | head -n "$N"
total=$(cat "${files[@]}" | wc -l)
dyn=$(cat "${files[@]}" | awk -F'\t' '$3 == "dynamic"' | wc -l)
echo "$total functions; $dyn with an unbounded (dynamic) frame"
if [ "$dyn" -gt 0 ]; then
  cat "${files[@]}" | awk -F'\t' '$3 == "dynamic"' >&2
  echo "dynamic stack frames found (alloca / VLA): the stack bound does not hold" >&2
  exit 1
fi
