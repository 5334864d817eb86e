#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Cortex-M build of the C core and its size report.
#   tools/size-report.sh [m7|m4 ...]        (default: m7 m4)
# For each core: configures build/cortex-<core> with cmake/toolchains/cortex-<core>.cmake and
# -DTVO_CORE_ONLY=ON (Release: -Os), builds libtinyvo.a, then
#   1. prints .text/.data/.bss per object and the total (arm-none-eabi-size -t),
#   2. link check: links a minimal main() against the WHOLE archive (--whole-archive) with
#      --specs=nosys.specs -lm -lc; this fails if any core object needs a symbol beyond libc/libm,
#   3. lists the external symbols the core uses (all must be libc/libm),
#   4. checks core .text <= 96 KiB on Cortex-M7 (exit 1 otherwise): the budget of the core with the local
#      map (keyframes, landmarks, bundle adjustment), as a Cortex-M build makes it by default (without the
#      affine track refinement, CMakeLists.txt),
#   5. prints the core's .text with the affine track refinement built in (-DTVO_WITH_AFFINE=ON).
# TVO_WERROR=ON in the environment makes warnings errors (off by default: this is a size report).
# Needs gcc-arm-none-eabi and libnewlib-arm-none-eabi (installed as root if missing).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
CORES=("$@")
[ ${#CORES[@]} -eq 0 ] && CORES=(m7 m4)
LIMIT_M7=$((96 * 1024))

. "$ROOT/tools/apt-lib.sh"
tvo_apt_ensure size-report gcc-arm-none-eabi libnewlib-arm-none-eabi cmake ninja-build || exit 1

status=0
echo "tinyvo core size report, commit $(git rev-parse --short HEAD 2>/dev/null || echo '?'), $(date -u +%Y-%m-%d)"
for core in "${CORES[@]}"; do
  tc="cmake/toolchains/cortex-${core}.cmake"
  bdir="build/cortex-${core}"
  [ -f "$tc" ] || { echo "no toolchain file $tc" >&2; exit 2; }
  cmake -S . -B "$bdir" -G Ninja --toolchain "$tc" -DCMAKE_BUILD_TYPE=Release -DTVO_CORE_ONLY=ON \
        -DTVO_WERROR="${TVO_WERROR:-OFF}" >/dev/null
  cmake --build "$bdir" --target tinyvo >/dev/null
  lib="$bdir/lib/libtinyvo.a"
  echo
  echo "== Cortex-${core^^} ($(grep -o '"-mcpu[^"]*"' "$tc" | tr -d '"'), -Os)"
  arm-none-eabi-size -t "$lib" | awk 'NR==1 || /TOTALS/ {print; next} {printf "%s\n", $0}' \
    | sed "s#(ex $lib)##"
  read -r text data bss <<<"$(arm-none-eabi-size -t "$lib" | awk '/TOTALS/ {print $1, $2, $3}')"
  printf 'core total: .text %d B (%.1f KiB)  .data %d B  .bss %d B\n' "$text" "$(echo "$text/1024" | bc -l)" "$data" "$bss"

  # link check
  cat > "$bdir/link_check.c" <<'C'
#include "tinyvo/tinyvo.h"
int main(void)
{
    return tvo_status_str(TVO_OK)[0] == 'o' ? 0 : 1;
}
C
  flags=$(sed -n 's/^set(TVO_CPU_FLAGS "\(.*\)")/\1/p' "$tc")
  # shellcheck disable=SC2086
  if arm-none-eabi-gcc $flags -Os -std=c99 -Ilib/include "$bdir/link_check.c" \
       -Wl,--whole-archive "$lib" -Wl,--no-whole-archive --specs=nosys.specs -lm -lc \
       -o "$bdir/link_check.elf" 2> "$bdir/link_check.log"; then
    echo "link check: OK (whole core archive + nosys: no undefined symbols beyond libc/libm)"
  else
    echo "link check: FAILED"; cat "$bdir/link_check.log"; status=1
  fi
  defined=$(arm-none-eabi-nm -g --defined-only "$lib" | awk 'NF==3 {print $3}' | sort -u)
  ext=$(arm-none-eabi-nm -u "$lib" | awk 'NF==2 {print $2}' | sort -u | comm -23 - <(echo "$defined"))
  echo "external symbols used by the core: $(echo $ext)"
  if [ "$core" = m7 ] && [ "$text" -gt "$LIMIT_M7" ]; then
    echo "FAIL: core .text $text B > $LIMIT_M7 B target on Cortex-M7"; status=1
  fi
  # the same core with the affine track refinement built in (-DTVO_WITH_AFFINE=ON), for the record
  cmake -S . -B "$bdir-affine" -G Ninja --toolchain "$tc" -DCMAKE_BUILD_TYPE=Release -DTVO_CORE_ONLY=ON \
        -DTVO_WITH_AFFINE=ON -DTVO_WERROR="${TVO_WERROR:-OFF}" >/dev/null
  cmake --build "$bdir-affine" --target tinyvo >/dev/null
  text_a=$(arm-none-eabi-size -t "$bdir-affine/lib/libtinyvo.a" | awk '/TOTALS/ {print $1}')
  printf 'core with the affine refinement (-DTVO_WITH_AFFINE=ON): .text %d B (%.1f KiB)\n' "$text_a" \
    "$(echo "$text_a/1024" | bc -l)"
done
exit $status
