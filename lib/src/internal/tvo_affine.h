/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: affine refinement of a track against the patch it was detected on (internal to the VO).
 *
 * Translation-only LK follows a patch's gradient energy, and a corner holds that energy off its centre:
 * as the camera moves, the patch scales and shears, and the tracked point drifts with the deformation
 * since detection (docs/evaluation.md, "Track accuracy on the renders"). Here each track keeps the
 * (side + 2)^2 pixels around the integer pixel nearest to where it was detected (its template), and
 * every frame the translation LK found is refined by aligning that template to the frame under an
 * affine warp: inverse-compositional Gauss-Newton (Baker and Matthews), whose 6x6 matrix depends on
 * the template alone and is factored once, when the template is taken; the patch's mean and contrast
 * are normalised so that a change of exposure does not move the point.
 *
 * Arithmetic is float with the steps in double, in a fixed order, without libm beyond sqrt: the results
 * are the same on every target built with -ffp-contract=off, and the SIMD kernels (SSE2, aarch64 NEON)
 * give the portable kernel's bits. No allocation; the caller's scratch holds the per-window arrays. */
#ifndef TVO_AFFINE_H
#define TVO_AFFINE_H

#include <stddef.h>
#include <stdint.h>

#include "tinyvo/image.h"

/* The warp of one track: image position = A (x - 0) + t for template coordinates x (pixels, relative
 * to the template's centre pixel); the track's point is at template coordinates d. */
typedef struct tvo_aff_warp {
    float A[4]; /* row-major 2x2 */
    float t[2];
    float d[2];
} tvo_aff_warp;

/* What the steps need of a template, computed once when it is taken: the Cholesky factor of the 6x6
 * Gauss-Newton matrix H = sum sd sd^T (sd: the steepest-descent row [gx x, gx y, gy x, gy y, gx, gy] of
 * each pixel), sum sd T, sum sd, and the template's sum and centred sum of squares. */
typedef struct tvo_aff_model {
    double L[21]; /* packed lower triangle, row by row */
    double sdt[6], sd1[6];
    double sum_t, var_t;
} tvo_aff_model;

/* Largest accepted window side (odd), and the bytes of one template of side `side`. */
#define TVO_AFF_MAX_SIDE 31
static inline size_t tvo_aff_template_bytes(int32_t side)
{
    return (size_t)(side + 2) * (size_t)(side + 2);
}

/* 1 when a window of side `side` can be sampled every `step` pixels: step divides side / 2, so the
 * samples reach the window's edges (tvo_aff_take, tvo_aff_refine and the VO's configuration check). */
static inline int tvo_aff_step_ok(int32_t side, int32_t step)
{
    return step >= 1 && step <= side / 2 && (side / 2) % step == 0;
}

/* Samples per row and column of a window of side `side` sampled every `step` pixels. */
static inline int32_t tvo_aff_samples(int32_t side, int32_t step)
{
    return 2 * ((side / 2) / step) + 1;
}

/* Columns of the per-window float arrays: n samples rounded up to a multiple of 4 (the sums run over
 * lanes of 4 pixels; the padding columns hold zeros and add nothing). */
static inline int32_t tvo_aff_cols(int32_t n)
{
    return (n + 3) & ~3;
}

/* The sums one Gauss-Newton step needs over the warped window: sum sd I (the steepest-descent rows
 * times the patch), sum I, sum I^2 and sum I T. */
typedef struct tvo_aff_sums {
    double sdi[6];
    double sum_i, sum_i2, sum_it;
} tvo_aff_sums;

/* Adds one row's sums r (sum gx I, sum gx I x, sum gy I, sum gy I x, sum I, sum I^2, sum I T; x, y the
 * template coordinates, y = yy for this row) to the window's, in double. */
static inline void tvo_aff_add_row(tvo_aff_sums *s, const float r[7], int32_t yy)
{
    s->sdi[0] += (double)r[1];
    s->sdi[1] += (double)r[0] * yy;
    s->sdi[2] += (double)r[3];
    s->sdi[3] += (double)r[2] * yy;
    s->sdi[4] += (double)r[0];
    s->sdi[5] += (double)r[2];
    s->sum_i += (double)r[4];
    s->sum_i2 += (double)r[5];
    s->sum_it += (double)r[6];
}

/* The window's sums for the warp (A, t), which window_inside() accepted: gx, gy and tf are the
 * template's gradients and grey values at the samples, m = tvo_aff_samples(side, step) rows of
 * tvo_aff_cols(m) floats. Each row is summed in
 * 4 float lanes (pixel column j in lane j % 4), the lanes added as (0 + 1) + (2 + 3), the rows in double:
 * tvo_affine.c holds the portable kernel, tvo_affine_sse2.c (x86) and tvo_affine_neon.c (aarch64) the
 * SIMD ones, which give the same bits (test_affine checks it). */
void tvo_aff_sums_portable(const tvo_image *img, const float *gx, const float *gy, const float *tf,
                           int32_t side, int32_t step, const double A[4], const double t[2], tvo_aff_sums *s);
#if defined(__SSE2__) && !defined(TVO_LK_NO_SIMD)
#define TVO_AFF_SSE2 1
#else
#define TVO_AFF_SSE2 0
#endif
#if !TVO_AFF_SSE2 && defined(__aarch64__) && !defined(TVO_LK_NO_SIMD)
#define TVO_AFF_NEON 1 /* aarch64 only: its NEON float arithmetic is IEEE's, armv7's flushes denormals */
#else
#define TVO_AFF_NEON 0
#endif
#define TVO_AFF_SIMD (TVO_AFF_SSE2 || TVO_AFF_NEON)
#if TVO_AFF_SIMD
/* The SIMD kernel of the target (tvo_affine_sse2.c or tvo_affine_neon.c): the portable kernel's bits. */
void tvo_aff_sums_simd(const tvo_image *img, const float *gx, const float *gy, const float *tf, int32_t side,
                       int32_t step, const double A[4], const double t[2], tvo_aff_sums *s);
#endif

/* The template's per-row work at step 1 in SIMD (tvo_affine_tpl_sse2.c, tvo_affine_tpl_neon.c), for rows
 * of m >= 8 samples (the last 8 columns are read as a block ending at column m - 1); both give the
 * portable code's values (integers, and floats that are exact): tvo_aff_take's row sums r[19] of the
 * row whose first sample is at p (take_row() in tvo_affine.c: template stride s, x = c - h at column
 * c), and tvo_aff_refine's gradients and grey values of that row (columns 0..m-1 of gx, gy, tf). */
#define TVO_AFF_TPL_SIMD_MIN 8
#if TVO_AFF_SIMD
void tvo_aff_take_row_simd(const uint8_t *p, int32_t s, int32_t m, int32_t h, int32_t r[19]);
void tvo_aff_gradients_row_simd(const uint8_t *p, int32_t s, int32_t m, float *gx, float *gy, float *tf);
#endif

/* Bytes of scratch tvo_aff_refine needs for side. */
size_t tvo_aff_scratch_size(int32_t side);

/* Copy the template of a point at (x, y) in img and compute its model over every step-th pixel of the
 * window (step divides side / 2): 1 and w set (A = identity) when the (side + 2)^2 pixels around the
 * nearest integer pixel lie inside the image and have texture in two directions, else 0. */
int tvo_aff_take(const tvo_image *img, float x, float y, int32_t side, int32_t step, uint8_t *tpl,
                 tvo_aff_model *model, tvo_aff_warp *w);

/* The track's point under w. */
void tvo_aff_point(const tvo_aff_warp *w, float *x, float *y);

/* tvo_aff_refine's result when the window reaches the image's border (which says nothing against the
 * match: the caller may treat it apart from a failure). */
#define TVO_AFF_AT_BORDER (-1)

/* Refine w so that the template matches img, starting from w as given (its t moved by the caller to
 * where translation LK put the point); side and step as the model was taken with. At most max_iters
 * steps, stopping when a step moves no window corner by more than eps pixels. 1 on success with w
 * updated and *ncc the normalised correlation of the final patch with the template; w unchanged and
 * TVO_AFF_AT_BORDER when the window leaves the image (at the start, during the steps or at the end), 0
 * when an argument is bad, the template is flat, the warp degenerates (determinant outside [1/4, 4]) or
 * does not converge. */
int tvo_aff_refine(const uint8_t *tpl, const tvo_aff_model *model, int32_t side, int32_t step,
                   const tvo_image *img, tvo_aff_warp *w, int32_t max_iters, float eps, void *scratch,
                   size_t scratch_size, float *ncc);

/* tvo_aff_refine with the portable code for the sums and the template's gradients (portable != 0) or
 * the fastest built in (0): the same results (and return values) either way. */
int tvo_aff_refine_kernel(const uint8_t *tpl, const tvo_aff_model *model, int32_t side, int32_t step,
                          const tvo_image *img, tvo_aff_warp *w, int32_t max_iters, float eps, void *scratch,
                          size_t scratch_size, float *ncc, int portable);

#endif
