/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo internal: what the RANSAC loops of the relative pose and PnP share: a deterministic generator
 * (its draws depend on the seed alone, the same on every target, so a run repeats bit for bit with the
 * same seed) and the iterations a confidence needs. */
#ifndef TVO_RANSAC_H
#define TVO_RANSAC_H

#include <stdint.h>

typedef struct tvo_rng {
    uint64_t s; /* xorshift64* state, never 0 */
} tvo_rng;

/* The state from a seed (a splitmix64 step, so that any seed, 0 included, gives a good start). */
void tvo_rng_seed(tvo_rng *r, uint64_t seed);
/* An index in [0, n), n >= 1, from the next draw. */
int32_t tvo_rng_index(tvo_rng *r, int32_t n);
/* k distinct indices in [0, n), n >= k: up to 64 draws for each; after that (practically never) the
 * smallest index not taken yet. */
void tvo_rng_sample(tvo_rng *r, int32_t n, int k, int32_t *idx);

/* The iterations needed to draw one all-inlier sample of s points with the given confidence when
 * `inliers` of the n points are inliers (w = inliers / n), at most max_iters (and at least 1 once any
 * inlier is known). w^s is taken by multiplication and the logarithm from dmath.h: the same count on
 * every target. */
int32_t tvo_ransac_needed(double confidence, int32_t inliers, int32_t n, int s, int32_t max_iters);

#endif /* TVO_RANSAC_H */
