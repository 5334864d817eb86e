/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo internal: what the pyramidal Lucas-Kanade tracker (tvo_lk.c: the portable reference kernels
 * and the driver) shares with its per-architecture window kernels (tvo_lk_sse2.c, tvo_lk_neon.c).
 *
 * SIMD kernels for the previous-window Scharr rows and interpolation and for the iteration: SSE2 on
 * x86 (x86-64 always has it), NEON on ARM (aarch64 always; 32-bit ARM when built with -mfpu=neon).
 * They compute exactly the same integers as the portable C kernels of tvo_lk.c (exact integer sums), so
 * results are bit-identical; tvo_lk_config.force_portable selects the C kernels, test_lk.c checks the two
 * agree, and test_determinism.c's digests compare the targets. Define TVO_LK_NO_SIMD to compile the SIMD
 * kernels out (both SIMD files are then empty). Exactly one of the two files defines the kernels
 * declared at the end, and only when LK_SIMD is 1.
 *
 * Fixed point: bilinear weights have W_BITS = 14 fractional bits and sum to 1 << 14. Window grey
 * values keep 5 fractional bits (0..8160), Scharr derivatives are raw (|d| <= 16 * 255 = 4080) and
 * interpolated back to integers. */
#ifndef TVO_LK_IMPL_H
#define TVO_LK_IMPL_H

#include <stddef.h>
#include <stdint.h>

#include "tinyvo/lk.h"

#if defined(__SSE2__) && !defined(TVO_LK_NO_SIMD)
#define LK_SSE2 1
#else
#define LK_SSE2 0
#endif
#if !LK_SSE2 && (defined(__ARM_NEON) || defined(__ARM_NEON__)) && !defined(TVO_LK_NO_SIMD)
#define LK_NEON 1
#else
#define LK_NEON 0
#endif
#define LK_SIMD (LK_SSE2 || LK_NEON)

/* The SIMD row helpers are small and called once per row: always inline them (their state lives in
 * registers then, not behind a pointer). */
#if defined(__GNUC__)
#define LK_INLINE static inline __attribute__((always_inline))
#else
#define LK_INLINE static inline
#endif

#define LK_W_BITS 14
#define LK_ONE (1 << LK_W_BITS)
/* Descale of the grey value (5 fractional bits kept): (v + 2^8) >> 9, v >= 0. */
#define LK_I_SHIFT (LK_W_BITS - 5)
#define LK_I_ROUND (1 << (LK_I_SHIFT - 1))
/* Descale of derivatives: (v + 2^13) >> 14 with v >= -4080 * 2^14; bias by 4096 * 2^14. */
#define LK_D_BIAS 4096
#define LK_D_ROUND ((1 << (LK_W_BITS - 1)) + (LK_D_BIAS << LK_W_BITS))
#define LK_FLT_SCALE (1.0f / (float)(1 << 20))

typedef struct lk_work {
    int32_t win;
    uint8_t *patch;   /* (win+3)^2 gathered pixels near borders */
    int16_t *tv0;     /* win+3: vertical Scharr smoothing (portable path) */
    int16_t *tv1;     /* win+3: vertical Scharr difference (portable path) */
    int16_t *gx, *gy; /* (win+1)^2 Scharr derivatives on the integer grid */
    int16_t *iwin;    /* win^2 window grey values, 5 fractional bits */
    int16_t *ixwin;   /* win^2 interpolated d/dx */
    int16_t *iywin;   /* win^2 interpolated d/dy */
    /* the scratch's own window arrays: iwin / ixwin / iywin point into a window store's entry while a
       stored window is used or built (tvo_lk_track_store) */
    int16_t *siwin, *sixwin, *siywin;
    uint8_t *jpatch; /* (win+1+2*LK_JPATCH_MARGIN)^2 gathered next-image pixels near borders, kept while
                         the iterations stay inside it (same bytes as gathering each block anew) */
    const uint8_t *jp_data; /* level the jpatch was gathered from (NULL: none) */
    int32_t jp_x0, jp_y0;   /* its top-left in that level */
} lk_work;

/* Pixels gathered around a border block beyond the (win+1)^2 it needs: Gauss-Newton steps after the
 * first are mostly well under this, so one gather serves the whole level. */
#define LK_JPATCH_MARGIN 4

#if LK_SIMD
/* The kernels of tvo_lk_sse2.c / tvo_lk_neon.c, for win >= 8 (8-column strips), the same integers as
 * the portable ones of tvo_lk.c:
 *   tvo_lk_scharr_simd: the Scharr derivatives of the (win+1)^2 grid whose source block (win+3)^2 starts
 *     at src (stride sstride), into wk->gx / wk->gy;
 *   tvo_lk_prev_interp_simd: the window's grey values and interpolated derivatives from s (the window's
 *     top-left pixel, source block offset +1, +1) and wk->gx / gy, into wk->iwin / ixwin / iywin, and the
 *     gradient sums (a11, a12, a22) into A;
 *   tvo_lk_mismatch_simd: the sums of (J - I) * Ix and * Iy of the (win+1)^2 J block at src. */
void tvo_lk_scharr_simd(const uint8_t *src, int32_t sstride, lk_work *wk);
void tvo_lk_prev_interp_simd(const uint8_t *s, int32_t sstride, const int32_t wt[4], lk_work *wk,
                             int64_t A[3]);
void tvo_lk_mismatch_simd(const uint8_t *src, int32_t sstride, const int32_t wt[4], const lk_work *wk,
                          int64_t *b1, int64_t *b2);
#endif

#endif /* TVO_LK_IMPL_H */
