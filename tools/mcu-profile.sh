#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Where the Cortex-M7 model's QVGA replay spends its instructions, per function: the bare-metal
# counterpart of callgrind's function list (tools/profile-replay.sh).
#   tools/mcu-profile.sh [TOP]          (default TOP 12)
# Runs the firmware tools/run-mcu.sh built (BUILD/replay/m7/mcu_replay.elf, BUILD default build/mcu, with
# its 10- and 30-frame inputs) under qemu-system-arm -M mps2-an500 with a small TCG plugin
# (tools/qemu-count-plugin.c) that counts the guest instructions of every translation block, attributes
# each block to the ELF function it starts in (arm-none-eabi-nm), and prints the TOP functions by instructions per frame over frames 11..30 (the
# difference of the 30- and the 10-frame run over 20, as tools/run-mcu.sh counts the core), with their
# share of all instructions (newlib and the semihosting file reads included). Counts, not time: qemu models
# no pipeline or memory. Needs qemu >= 7.2 with plugin support and gcc for the plugin. Exit 2 when
# tools/run-mcu.sh has not built the firmware, 1 when a run fails.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
TOP="${1:-12}"
BUILD="${BUILD:-build/mcu}"
case "$BUILD" in /*) R="$BUILD/replay" ;; *) R="$ROOT/$BUILD/replay" ;; esac
ELF="$R/m7/mcu_replay.elf"
for f in "$ELF" "$R/frames10.bin" "$R/frames30.bin" "$R/m7/model.tvonn"; do
  [ -f "$f" ] || { echo "mcu-profile: $f missing (run tools/run-mcu.sh first)" >&2; exit 2; }
done
[[ "$TOP" =~ ^[1-9][0-9]*$ ]] || { echo "mcu-profile: TOP must be a positive integer" >&2; exit 2; }
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
gcc -O2 -shared -fPIC -fvisibility=hidden -o "$TMP/libtbcount.so" "$ROOT/tools/qemu-count-plugin.c"
for n in 10 30; do
  mkdir -p "$TMP/run$n"
  cp "$ELF" "$R/m7/model.tvonn" "$TMP/run$n/"
  cp "$R/frames$n.bin" "$TMP/run$n/frames.bin"
  (cd "$TMP/run$n" && timeout 900 qemu-system-arm -M mps2-an500 -display none -monitor none -serial none \
     -semihosting-config enable=on,target=native -plugin "$TMP/libtbcount.so,out=$TMP/tb$n.txt" \
     -kernel mcu_replay.elf > out.txt 2>&1) || true
  grep -q '^mcu: PASS' "$TMP/run$n/out.txt" && [ -s "$TMP/tb$n.txt" ] ||
    { echo "mcu-profile: the $n-frame run failed" >&2; cat "$TMP/run$n/out.txt" >&2; exit 1; }
done
arm-none-eabi-nm -S --defined-only "$ELF" > "$TMP/syms.txt"
python3 - "$TMP" "$TOP" <<'PY'
import bisect
import sys

tmp, top = sys.argv[1], int(sys.argv[2])
funcs = []  # (start, size, name) of the text symbols (Thumb addresses have bit 0 set)
for line in open(f"{tmp}/syms.txt"):
    p = line.split()
    if len(p) == 4 and p[2] in "tTwW":
        funcs.append((int(p[0], 16) & ~1, int(p[1], 16), p[3]))
funcs.sort()
starts = [f[0] for f in funcs]


def per_function(path):
    out = {}
    for line in open(path):
        a, c = line.split()
        a, c = int(a, 16), int(c)
        i = bisect.bisect_right(starts, a) - 1
        name = funcs[i][2] if i >= 0 and a < funcs[i][0] + funcs[i][1] else "(outside any function)"
        out[name] = out.get(name, 0) + c
    return out


f10, f30 = per_function(f"{tmp}/tb10.txt"), per_function(f"{tmp}/tb30.txt")
frame = {k: (f30.get(k, 0) - f10.get(k, 0)) / 20 for k in set(f10) | set(f30)}
total = sum(frame.values())
print(f"guest instructions per frame (frames 11..30): {total / 1e6:.1f} M; the {top} costliest functions:")
for name, c in sorted(frame.items(), key=lambda kv: -kv[1])[:top]:
    print(f"  {c / 1e6:9.2f} M  {100 * c / total:5.1f} %  {name}")
PY
