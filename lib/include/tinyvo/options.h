/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: library options. Every option has an #ifndef default here; override them on the compiler
 * command line (-DTVO_MAX_IMAGE_DIM=2048), never by editing this file. */
#ifndef TINYVO_OPTIONS_H
#define TINYVO_OPTIONS_H

/* Largest accepted image width or height, in pixels. Larger images are refused with TVO_ERR_SIZE. */
#ifndef TVO_MAX_IMAGE_DIM
#define TVO_MAX_IMAGE_DIM 8192
#endif

/* Deepest image pyramid (levels including the full-resolution level 0). */
#ifndef TVO_MAX_PYR_LEVELS
#define TVO_MAX_PYR_LEVELS 8
#endif

/* 1: the affine track refinement (tvo_vo_config.affine_win_size), the map's inlier gate
 * (tvo_vo_config.map_inlier_sigmas) and the landmarks' priors (tvo_vo_config.map_lm_prior, the bundle
 * adjustment's tvo_ba_problem.prior) are built in; 0: they are left out (9,528 bytes less code on a
 * Cortex-M7), and tvo_vo_init() refuses a configuration that asks for any of them with
 * TVO_ERR_UNSUPPORTED (tvo_ba_solve() a problem with priors).
 * CMake: -DTVO_WITH_AFFINE=OFF (the default of Cortex-M builds; this header's default, 1, is for builds
 * without CMake). */
#ifndef TVO_WITH_AFFINE
#define TVO_WITH_AFFINE 1
#endif

/* 1: the lens's radial coefficients refined on the run (tvo_vo_config.lens_refine) are built in; 0: left
 * out (the default of Cortex-M builds), and tvo_vo_init() refuses a configuration that asks for them with
 * TVO_ERR_UNSUPPORTED. CMake: -DTVO_WITH_LENS=OFF. */
#ifndef TVO_WITH_LENS
#define TVO_WITH_LENS 1
#endif

#endif /* TINYVO_OPTIONS_H */
