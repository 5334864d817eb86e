/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: what the RANSAC loops share (internal/tinyvo/ransac.h). */
#include "tinyvo/ransac.h"
#include "tinyvo/dmath.h"

#include <math.h>

void tvo_rng_seed(tvo_rng *r, uint64_t seed)
{
    uint64_t z = seed + 0x9E3779B97F4A7C15ULL; /* splitmix64 step: never a zero state */
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    r->s = z != 0 ? z : 0x2545F4914F6CDD1DULL;
}

/* The next 32 random bits (xorshift64*). */
static uint32_t rng_next(tvo_rng *r)
{
    uint64_t x = r->s;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    r->s = x;
    return (uint32_t)((x * 0x2545F4914F6CDD1DULL) >> 32);
}

int32_t tvo_rng_index(tvo_rng *r, int32_t n)
{
    return (int32_t)(((uint64_t)rng_next(r) * (uint64_t)n) >> 32);
}

void tvo_rng_sample(tvo_rng *r, int32_t n, int k, int32_t *idx)
{
    for (int i = 0; i < k; ++i) {
        int32_t v = 0;
        int ok = 0;
        for (int tries = 0; tries < 64 && !ok; ++tries) {
            v = tvo_rng_index(r, n);
            ok = 1;
            for (int j = 0; j < i; ++j)
                if (idx[j] == v)
                    ok = 0;
        }
        if (!ok) { /* practically unreachable: the next free index from 0 */
            v = 0;
            for (;;) {
                int used = 0;
                for (int j = 0; j < i; ++j)
                    if (idx[j] == v)
                        used = 1;
                if (!used)
                    break;
                ++v;
            }
        }
        idx[i] = v;
    }
}

int32_t tvo_ransac_needed(double confidence, int32_t inliers, int32_t n, int s, int32_t max_iters)
{
    if (inliers <= 0)
        return max_iters;
    double w = (double)inliers / (double)n;
    if (w >= 1.0)
        return 1;
    double ws = w; /* w^s by multiplication: no libm pow (determinism across targets) */
    for (int k = 1; k < s; ++k)
        ws *= w;
    double denom = tvo_dm_log1p(-ws);
    if (!(denom < 0.0))
        return max_iters;
    double need = ceil(tvo_dm_log1p(-confidence) / denom);
    if (!(need < (double)max_iters))
        return max_iters;
    return need < 1.0 ? 1 : (int32_t)need;
}
