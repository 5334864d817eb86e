#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Where the Cortex-M7 model's QVGA replay spends its instructions, per function: the bare-metal
# counterpart of callgrind's function list (tools/profile-replay.sh).
#   tools/mcu-profile.sh [TOP]          (default TOP 12)
# Runs the firmware tools/run-mcu.sh built (BUILD/replay/m7/mcu_replay.elf, BUILD default build/mcu, with
# its 10- and 30-frame inputs) under qemu-system-arm -M mps2-an500 with a small TCG plugin that counts the
# guest instructions of every translation block, attributes each block to the ELF function it starts in
# (arm-none-eabi-nm), and prints the TOP functions by instructions per frame over frames 11..30 (the
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
cat >"$TMP/tbcount.c" <<'EOF'
/* qemu TCG plugin, API version 1 (qemu 7.2): executed guest instructions per translation block start
 * address, written to out= at exit as "address count" lines. Only the few API declarations it uses. */
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
typedef uint64_t qemu_plugin_id_t;
typedef struct qemu_info_t qemu_info_t;
struct qemu_plugin_tb;
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
#define EXPORT __attribute__((visibility("default")))
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t, void (*)(qemu_plugin_id_t, struct qemu_plugin_tb *));
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *, enum qemu_plugin_op, void *, uint64_t);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *);
uint64_t qemu_plugin_tb_vaddr(const struct qemu_plugin_tb *);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t, void (*)(qemu_plugin_id_t, void *), void *);
EXPORT int qemu_plugin_version = 1;
#define SLOTS (1u << 20) /* open addressing; a firmware has far fewer blocks */
static uint64_t *count, *key; /* key: address + 1 (0: empty) */
static const char *out = "tbcount.txt";
static void trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    const uint64_t va = qemu_plugin_tb_vaddr(tb);
    uint32_t h = (uint32_t)((va >> 1) % SLOTS), probes = 0;
    (void)id;
    while (key[h] != 0 && key[h] != va + 1 && ++probes < SLOTS)
        h = (h + 1) % SLOTS;
    if (probes == SLOTS)
        return; /* full: not counted */
    key[h] = va + 1;
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &count[h],
                                             qemu_plugin_tb_n_insns(tb));
}
static void done(qemu_plugin_id_t id, void *p)
{
    FILE *f = fopen(out, "w");
    (void)id;
    (void)p;
    if (f == NULL)
        return;
    for (uint32_t h = 0; h < SLOTS; ++h)
        if (key[h] != 0 && count[h] != 0)
            fprintf(f, "%" PRIx64 " %" PRIu64 "\n", key[h] - 1, count[h]);
    fclose(f);
}
EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv)
{
    (void)info;
    for (int i = 0; i < argc; ++i)
        if (strncmp(argv[i], "out=", 4) == 0)
            out = argv[i] + 4;
    count = calloc(SLOTS, sizeof *count);
    key = calloc(SLOTS, sizeof *key);
    if (count == NULL || key == NULL)
        return -1;
    qemu_plugin_register_vcpu_tb_trans_cb(id, trans);
    qemu_plugin_register_atexit_cb(id, done, NULL);
    return 0;
}
EOF
gcc -O2 -shared -fPIC -fvisibility=hidden -o "$TMP/libtbcount.so" "$TMP/tbcount.c"
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
