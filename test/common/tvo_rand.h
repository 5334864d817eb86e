/* SPDX-License-Identifier: Apache-2.0 */
/* Deterministic xorshift64* generator for test and benchmark inputs (no cmocka needed). */
#ifndef TVO_RAND_H
#define TVO_RAND_H

#include <stdint.h>

static inline uint64_t tvo_test_rand(uint64_t *s)
{
    uint64_t x = *s;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    *s = x;
    return x * 0x2545F4914F6CDD1DULL;
}

#endif /* TVO_RAND_H */
