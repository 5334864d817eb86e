/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo fuzz harnesses: shared helpers (test/fuzz/, see docs/fuzzing.md).
 *
 * Every harness defines LLVMFuzzerTestOneInput(). Built with clang and -DTVO_BUILD_FUZZ=ON it links
 * libFuzzer; otherwise replay_main.c supplies main() and runs every file of the directories (or the
 * files) named on the command line, so the seed corpus and every crash input found stay regression
 * tests under ctest. A broken invariant aborts through TVO_FUZZ_CHECK in both modes. */
#ifndef TVO_FUZZ_COMMON_H
#define TVO_FUZZ_COMMON_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "tinyvo/status.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define TVO_FUZZ_CHECK(cond)                                                                  \
    do {                                                                                      \
        if (!(cond)) {                                                                        \
            fprintf(stderr, "%s:%d: fuzz invariant failed: %s\n", __FILE__, __LINE__, #cond); \
            abort();                                                                          \
        }                                                                                     \
    } while (0)

/* Every value of enum tvo_status (status.h), so a harness can tell a documented error from garbage. */
static inline int tvo_fuzz_status_valid(tvo_status st)
{
    return st <= 0 && st >= TVO_ERR_MISMATCH;
}

/* A tiny reader over the fuzz input: bytes past the end read as zero. */
typedef struct tvo_fuzz_reader {
    const uint8_t *p;
    size_t n, pos;
} tvo_fuzz_reader;

static inline uint8_t tvo_fuzz_u8(tvo_fuzz_reader *r)
{
    return r->pos < r->n ? r->p[r->pos++] : 0u;
}

static inline uint32_t tvo_fuzz_u32(tvo_fuzz_reader *r)
{
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i)
        v |= (uint32_t)tvo_fuzz_u8(r) << (8 * i);
    return v;
}

static inline size_t tvo_fuzz_left(const tvo_fuzz_reader *r)
{
    return r->pos < r->n ? r->n - r->pos : 0u;
}

#endif /* TVO_FUZZ_COMMON_H */
