/* SPDX-License-Identifier: Apache-2.0 */
#include "tinyvo/arena.h"

void tvo_arena_init(tvo_arena *arena, void *mem, size_t size)
{
    if (arena == NULL)
        return;
    arena->base = (uint8_t *)mem;
    arena->size = mem != NULL ? size : 0;
    arena->used = 0;
}

size_t tvo_size_mul(size_t a, size_t b)
{
    if (a != 0 && b > SIZE_MAX / a)
        return SIZE_MAX;
    return a * b;
}

size_t tvo_size_add(size_t a, size_t b)
{
    return a > SIZE_MAX - b ? SIZE_MAX : a + b;
}

size_t tvo_arena_round(size_t bytes)
{
    if (bytes > SIZE_MAX - (TVO_ARENA_ALIGN - 1u))
        return SIZE_MAX;
    return (bytes + (TVO_ARENA_ALIGN - 1u)) & ~(size_t)(TVO_ARENA_ALIGN - 1u);
}

void *tvo_arena_alloc(tvo_arena *arena, size_t bytes)
{
    size_t pad, need;
    uintptr_t addr;
    if (arena == NULL || arena->base == NULL)
        return NULL;
    addr = (uintptr_t)(arena->base + arena->used);
    pad = (size_t)((TVO_ARENA_ALIGN - (addr % TVO_ARENA_ALIGN)) % TVO_ARENA_ALIGN);
    need = tvo_size_add(pad, bytes);
    if (need > arena->size - arena->used)
        return NULL;
    arena->used += need;
    return arena->base + arena->used - bytes;
}
