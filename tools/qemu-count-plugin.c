/* SPDX-License-Identifier: Apache-2.0 */
/* A qemu TCG plugin (API version 1, qemu 7.2) that counts executed guest instructions, for
 * tools/qemu-insn-count.sh and tools/mcu-profile.sh, which build it with the host gcc:
 *   gcc -O2 -shared -fPIC -fvisibility=hidden -o libcount.so tools/qemu-count-plugin.c
 *   qemu-... -plugin libcount.so[,lo=ADDR,hi=ADDR][,out=FILE] ...
 * At exit it prints "insncount: total N range M" to stderr: all instructions, and those of the
 * translation blocks starting in [lo, hi) (0 without lo and hi). With out=FILE it also writes, per
 * translation block start address, the instructions executed in blocks starting there ("address count"
 * lines, hexadecimal address). Only the few API declarations it uses are declared here. */
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
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t,
                                           void (*)(qemu_plugin_id_t, struct qemu_plugin_tb *));
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *, enum qemu_plugin_op, void *, uint64_t);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *);
uint64_t qemu_plugin_tb_vaddr(const struct qemu_plugin_tb *);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t, void (*)(qemu_plugin_id_t, void *), void *);
EXPORT int qemu_plugin_version = 1;

static uint64_t total, inside, lo, hi;
/* per block start (with out=): open addressing, key = address + 1 (0: empty) */
#define SLOTS (1u << 20)
static uint64_t *count, *key;
static const char *out;

static void trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    const uint64_t n = qemu_plugin_tb_n_insns(tb), va = qemu_plugin_tb_vaddr(tb);
    (void)id;
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &total, n);
    if (va >= lo && va < hi)
        qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &inside, n);
    if (out != NULL) {
        uint32_t h = (uint32_t)((va >> 1) % SLOTS), probes = 0;
        while (key[h] != 0 && key[h] != va + 1 && ++probes < SLOTS)
            h = (h + 1) % SLOTS;
        if (probes == SLOTS)
            return; /* full: counted in the total only */
        key[h] = va + 1;
        qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &count[h], n);
    }
}

static void done(qemu_plugin_id_t id, void *p)
{
    (void)id;
    (void)p;
    fprintf(stderr, "insncount: total %" PRIu64 " range %" PRIu64 "\n", total, inside);
    if (out != NULL) {
        FILE *f = fopen(out, "w");
        if (f == NULL)
            return;
        for (uint32_t h = 0; h < SLOTS; ++h)
            if (key[h] != 0 && count[h] != 0)
                fprintf(f, "%" PRIx64 " %" PRIu64 "\n", key[h] - 1, count[h]);
        fclose(f);
    }
}

EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv)
{
    (void)info;
    for (int i = 0; i < argc; ++i) {
        if (strncmp(argv[i], "lo=", 3) == 0)
            lo = strtoull(argv[i] + 3, NULL, 0);
        if (strncmp(argv[i], "hi=", 3) == 0)
            hi = strtoull(argv[i] + 3, NULL, 0);
        if (strncmp(argv[i], "out=", 4) == 0)
            out = argv[i] + 4;
    }
    if (out != NULL) {
        count = calloc(SLOTS, sizeof *count);
        key = calloc(SLOTS, sizeof *key);
        if (count == NULL || key == NULL)
            return -1;
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, trans);
    qemu_plugin_register_atexit_cb(id, done, NULL);
    return 0;
}
