#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Guest instructions executed by a cross-built program under qemu-user, in total and inside one object
# file's .text (e.g. tvo_lk.c.o): the ARM counterpart of the callgrind counts of tools/profile-replay.sh.
#   tools/qemu-insn-count.sh TRIPLE MAPFILE OBJECT -- PROGRAM [ARGS...]
#   tools/qemu-insn-count.sh arm-none-eabi MAPFILE START:END -- FIRMWARE.elf
# TRIPLE: aarch64-linux-gnu or arm-linux-gnueabihf (qemu-aarch64 / qemu-arm -L /usr/TRIPLE). PROGRAM must
# be linked non-PIE with a link map (cmake ... -DCMAKE_EXE_LINKER_FLAGS="-no-pie -Wl,-Map=/abs/prog.map"),
# so that OBJECT's .text has fixed addresses; MAPFILE is that map.
# arm-none-eabi: a bare-metal firmware on the Cortex-M7 model (qemu-system-arm -M mps2-an500, semihosting
# on, run in the current folder); the range is given by two symbols of the link map instead of an object
# (test/mcu/mps2_an500.ld defines __tvo_text_start:__tvo_text_end around the tinyvo core's code).
# Prints one line to stderr:
#   insncount: total N range M          (M: instructions in translation blocks starting in OBJECT's .text;
#                                        calls out of it, e.g. memcpy, count in total only)
# Counts come from a small TCG plugin (tools/qemu-count-plugin.c; qemu >= 7.2 with plugin support, API
# version 1) built here with the host gcc. They count guest instructions, not time: no cache or pipeline
# model.
set -euo pipefail
TRIPLE="${1:?usage: tools/qemu-insn-count.sh TRIPLE MAPFILE OBJECT -- PROGRAM [ARGS...]}"
MAP="${2:?map file}"
OBJ="${3:?object name, e.g. tvo_lk.c.o}"
shift 3
[ "${1:-}" = "--" ] && shift
case "$TRIPLE" in
  aarch64-linux-gnu) QEMU=(qemu-aarch64 -L "/usr/$TRIPLE") ;;
  arm-linux-gnueabihf) QEMU=(qemu-arm -L "/usr/$TRIPLE") ;;
  arm-none-eabi) QEMU=(qemu-system-arm -M mps2-an500 -display none -monitor none -serial none
                       -semihosting-config enable=on,target=native) ;;
  *) echo "qemu-insn-count: unknown triple $TRIPLE" >&2; exit 2 ;;
esac
if [ "$TRIPLE" = arm-none-eabi ]; then
  sym() { awk -v s="$1" '$2 == s && $1 ~ /^0x/ { print $1; exit }' "$MAP"; }
  lo=$(sym "${OBJ%%:*}")
  hi=$(sym "${OBJ##*:}")
  [ -n "$lo" ] && [ -n "$hi" ] || { echo "qemu-insn-count: no symbols $OBJ in $MAP" >&2; exit 1; }
else
  range=$(awk -v obj="$OBJ" '$1 == ".text" && $4 ~ ("\\(" obj "\\)$") { print $2, $3; exit }' "$MAP")
  [ -n "$range" ] || { echo "qemu-insn-count: no .text of $OBJ in $MAP" >&2; exit 1; }
  read -r lo size <<<"$range"
  hi=$(printf '%#x' $(( lo + size )))
fi
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
gcc -O2 -shared -fPIC -fvisibility=hidden -o "$TMP/libinsncount.so" "$(dirname "${BASH_SOURCE[0]}")/qemu-count-plugin.c"
if [ "$TRIPLE" = arm-none-eabi ]; then
  "${QEMU[@]}" -plugin "$TMP/libinsncount.so,lo=$lo,hi=$hi" -kernel "$@"
else
  "${QEMU[@]}" -plugin "$TMP/libinsncount.so,lo=$lo,hi=$hi" "$@"
fi
