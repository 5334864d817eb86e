/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: a bump allocator over caller-provided memory.
 *
 * Modules carve their working memory out of the block the caller hands to their *_init() call; the
 * caller learns the size with the module's *_required_size() call. Nothing is ever freed
 * individually and nothing touches the heap. */
#ifndef TINYVO_ARENA_H
#define TINYVO_ARENA_H

#include "tinyvo/types.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Alignment every arena block gets (bytes): enough for double and for 128-bit SIMD loads. */
#define TVO_ARENA_ALIGN 16u

typedef struct tvo_arena {
    uint8_t *base;
    size_t size;
    size_t used;
} tvo_arena;

/* Start an arena over [mem, mem + size). mem may be NULL only with size 0. */
void tvo_arena_init(tvo_arena *arena, void *mem, size_t size);

/* bytes rounded up to TVO_ARENA_ALIGN, saturating at SIZE_MAX. */
size_t tvo_arena_round(size_t bytes);

/* A block of `bytes` aligned to TVO_ARENA_ALIGN, or NULL when the arena is exhausted (the arena is
 * then unchanged). bytes == 0 gives a valid, aligned, empty block. */
void *tvo_arena_alloc(tvo_arena *arena, size_t bytes);

/* a * b, or SIZE_MAX if it overflows: use it in *_required_size() computations. */
size_t tvo_size_mul(size_t a, size_t b);
/* a + b, or SIZE_MAX if it overflows. */
size_t tvo_size_add(size_t a, size_t b);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_ARENA_H */
