/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: evaluating a bundle adjustment's point prior (tvo_ba_problem.prior, ba.h) outside the solver:
 * the local map judges its landmarks' priors with it (cfg.map_lm_prior_gate). Builds with the affine
 * refinement only (TVO_WITH_AFFINE, options.h), as the priors themselves. */
#ifndef TINYVO_BA_PRIOR_H
#define TINYVO_BA_PRIOR_H

#include "tinyvo/ba.h"
#include "tinyvo/options.h"

#ifdef __cplusplus
extern "C" {
#endif

#if TVO_WITH_AFFINE
/* 1/2 X^T L X + g^T X + c of the point prior q at X: the solver's own evaluation. ~20 flops. */
double tvo_ba_prior_cost(const double q[TVO_BA_PRIOR_SIZE], const double X[3]);
#endif

#ifdef __cplusplus
}
#endif

#endif
