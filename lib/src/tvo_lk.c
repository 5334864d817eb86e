/* SPDX-License-Identifier: Apache-2.0 */
/* Pyramidal Lucas-Kanade tracking, OpenCV-compatible arithmetic (see tinyvo/lk.h): the driver and the
 * portable reference kernels. The SSE2 and NEON kernels are in tvo_lk_sse2.c and tvo_lk_neon.c (what
 * they share with this file: tvo_lk_impl.h); each gives the same integers as the kernels here.
 *
 * Fixed point: bilinear weights have W_BITS = 14 fractional bits and sum to 1 << 14. Window grey
 * values keep 5 fractional bits (0..8160), Scharr derivatives are raw (|d| <= 16 * 255 = 4080) and
 * interpolated back to integers. Products fit int32; a window row of up to 63 products fits int32;
 * the window sums are int64, so the sums are exact. Right shifts of possibly negative values are done
 * on a positive biased value (arithmetic shift of negatives is implementation-defined in C99). */
#include "tinyvo/lk.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "tinyvo/arena.h"
#include "tvo_border.h"
#include "tvo_lk_impl.h"

/* Row kernels kept out of line (see lk_interp_row8()). */
#if defined(__GNUC__)
#define LK_NOINLINE __attribute__((noinline))
#else
#define LK_NOINLINE
#endif

/* 32-bit ARM with the DSP extension (Cortex-M4 and M7, ARMv7-A and later in 32-bit state): two 16-bit
 * products a step (SMLAD) in the row kernels of 16-bit values (the NEON kernels, where there are any,
 * replace them for windows of 8 and more). Exact integers, so the same results as the C loops; off with
 * TVO_LK_NO_SIMD. */
#if defined(__ARM_FEATURE_SIMD32) && !defined(TVO_LK_NO_SIMD)
#include <arm_acle.h>
#define LK_SIMD32 1
/* the two 16-bit values at p (low half: p[0]) */
static inline int16x2_t lk_pair(const int16_t *p)
{
    int16x2_t v;
    memcpy(&v, p, sizeof(v));
    return v;
}
/* a and b as the low and high halves of a pair (both in [0, 1 << 14]: weights and bytes) */
static inline int16x2_t lk_pack(int32_t a, int32_t b)
{
    return (int16x2_t)((uint32_t)a | ((uint32_t)b << 16));
}
#else
#define LK_SIMD32 0
#endif

typedef struct lk_level {
    const uint8_t *data;
    int32_t w, h, stride;
} lk_level;

typedef struct lk_params {
    int32_t win;
    int32_t max_iters;
    double eps2;
    float min_eig;
    int simd; /* use the SIMD kernel (same results) */
} lk_params;

void tvo_lk_config_default(tvo_lk_config *cfg)
{
    if (cfg == NULL)
        return;
    cfg->win_size = 21;
    cfg->max_level = 3;
    cfg->max_iters = 30;
    cfg->epsilon = 0.01f;
    cfg->min_eig_threshold = 1e-4f;
    cfg->use_initial_flow = 0;
    cfg->fb_check = 0;
    cfg->fb_max_error = 1.0f;
    cfg->force_portable = 0;
    cfg->fb_levels = 0;
    cfg->pred_levels = 0;
    cfg->pred_win_size = 0;
    cfg->pred_fb_levels = 0;
    cfg->pred_retry = 0;
}

/* Whether tvo_lk_track() runs the SIMD kernels with this window (they need 8-column strips). */
static int lk_use_simd(const tvo_lk_config *cfg)
{
    return !cfg->force_portable && cfg->win_size >= 8;
}

const char *tvo_lk_kernel_name(const tvo_lk_config *cfg)
{
#if LK_SSE2
    if (cfg == NULL || lk_use_simd(cfg))
        return "sse2";
#elif LK_NEON
    if (cfg == NULL || lk_use_simd(cfg))
        return "neon";
#else
    (void)cfg;
#endif
    return "portable";
}

tvo_status tvo_lk_config_check(const tvo_lk_config *cfg)
{
    if (cfg == NULL)
        return TVO_ERR_NULL;
    if (cfg->win_size < TVO_LK_MIN_WIN_SIZE || cfg->win_size > TVO_LK_MAX_WIN_SIZE ||
        (cfg->win_size & 1) == 0)
        return TVO_ERR_ARG;
    if (cfg->max_level < 0 || cfg->max_level > TVO_MAX_PYR_LEVELS - 1)
        return TVO_ERR_ARG;
    if (cfg->max_iters < 0 || cfg->max_iters > TVO_LK_MAX_ITERS)
        return TVO_ERR_ARG;
    if (!isfinite(cfg->epsilon) || !isfinite(cfg->min_eig_threshold) ||
        (cfg->fb_check && !isfinite(cfg->fb_max_error)))
        return TVO_ERR_NOT_FINITE;
    if (cfg->epsilon < 0.0f || cfg->epsilon > 10.0f || cfg->min_eig_threshold < 0.0f)
        return TVO_ERR_ARG;
    if (cfg->fb_check && !(cfg->fb_max_error > 0.0f))
        return TVO_ERR_ARG;
    if (cfg->fb_levels < 0 || cfg->fb_levels > TVO_MAX_PYR_LEVELS)
        return TVO_ERR_ARG;
    if (cfg->pred_levels < 0 || cfg->pred_levels > TVO_MAX_PYR_LEVELS)
        return TVO_ERR_ARG;
    if (cfg->pred_win_size != 0 &&
        (cfg->pred_win_size < TVO_LK_MIN_WIN_SIZE || cfg->pred_win_size > TVO_LK_MAX_WIN_SIZE ||
         (cfg->pred_win_size & 1) == 0))
        return TVO_ERR_ARG;
    if (cfg->pred_fb_levels < 0 || cfg->pred_fb_levels > TVO_MAX_PYR_LEVELS)
        return TVO_ERR_ARG;
    return TVO_OK;
}

#define LK_NBLOCKS 9
/* Block sizes of the scratch, in the order they are carved. */
static void lk_blocks(int32_t win, size_t sz[LK_NBLOCKS])
{
    size_t p = (size_t)win + 3u, g = (size_t)win + 1u, w = (size_t)win;
    size_t q = (size_t)win + 1u + 2u * LK_JPATCH_MARGIN;
    sz[0] = p * p;
    sz[1] = p * sizeof(int16_t);
    sz[2] = p * sizeof(int16_t);
    sz[3] = g * g * sizeof(int16_t);
    sz[4] = g * g * sizeof(int16_t);
    sz[5] = w * w * sizeof(int16_t);
    sz[6] = w * w * sizeof(int16_t);
    sz[7] = w * w * sizeof(int16_t);
    sz[8] = q * q;
}

/* The larger of the two windows (the scratch is laid out for it; the other uses a part of it). */
static int32_t lk_max_win(const tvo_lk_config *cfg)
{
    return cfg->pred_win_size > cfg->win_size ? cfg->pred_win_size : cfg->win_size;
}

size_t tvo_lk_scratch_size(const tvo_lk_config *cfg)
{
    size_t sz[LK_NBLOCKS], total = TVO_ARENA_ALIGN - 1u;
    int i;
    if (tvo_lk_config_check(cfg) != TVO_OK)
        return 0;
    lk_blocks(lk_max_win(cfg), sz);
    for (i = 0; i < LK_NBLOCKS; ++i)
        total = tvo_size_add(total, tvo_arena_round(sz[i]));
    return total;
}

static tvo_status lk_work_init(lk_work *wk, int32_t win, void *scratch, size_t scratch_size)
{
    size_t sz[LK_NBLOCKS];
    void *b[LK_NBLOCKS];
    tvo_arena arena;
    int i;
    lk_blocks(win, sz);
    tvo_arena_init(&arena, scratch, scratch_size);
    for (i = 0; i < LK_NBLOCKS; ++i) {
        b[i] = tvo_arena_alloc(&arena, sz[i]);
        if (b[i] == NULL)
            return TVO_ERR_NO_MEMORY;
    }
    wk->win = win;
    wk->patch = (uint8_t *)b[0];
    wk->tv0 = (int16_t *)b[1];
    wk->tv1 = (int16_t *)b[2];
    wk->gx = (int16_t *)b[3];
    wk->gy = (int16_t *)b[4];
    wk->iwin = (int16_t *)b[5];
    wk->ixwin = (int16_t *)b[6];
    wk->iywin = (int16_t *)b[7];
    wk->jpatch = (uint8_t *)b[8];
    wk->jp_data = NULL; /* the images may have changed since the last call */
    wk->jp_x0 = wk->jp_y0 = 0;
    return TVO_OK;
}

/* Largest block lk_gather() copies: the (win+3)^2 patch or the (win+1+2*margin)^2 jpatch. */
#define LK_GATHER_MAX (TVO_LK_MAX_WIN_SIZE + 3 + 2 * LK_JPATCH_MARGIN)

/* Copy the size x size block whose top-left is (x0, y0) (may lie outside) into dst, reflecting. */
static void lk_gather(const lk_level *lv, int32_t x0, int32_t y0, int32_t size, uint8_t *dst)
{
    int32_t map[LK_GATHER_MAX]; /* source column of each block column outside the image */
    int32_t r, c, c_lo, c_hi;
    /* columns c_lo..c_hi-1 are inside the image: copied as a run; the others through map */
    c_lo = x0 < 0 ? (-x0 < size ? -x0 : size) : 0;
    c_hi = lv->w - x0 < size ? lv->w - x0 : size;
    if (c_hi < c_lo)
        c_hi = c_lo;
    for (c = 0; c < c_lo; ++c)
        map[c] = tvo_reflect101(x0 + c, lv->w);
    for (c = c_hi; c < size; ++c)
        map[c] = tvo_reflect101(x0 + c, lv->w);
    for (r = 0; r < size; ++r) {
        const uint8_t *row = lv->data + (size_t)tvo_reflect101(y0 + r, lv->h) * (size_t)lv->stride;
        uint8_t *out = dst + (size_t)r * (size_t)size;
        for (c = 0; c < c_lo; ++c)
            out[c] = row[map[c]];
        if (c_hi > c_lo)
            memcpy(out + c_lo, row + x0 + c_lo, (size_t)(c_hi - c_lo));
        for (c = c_hi; c < size; ++c)
            out[c] = row[map[c]];
    }
}

/* cvRound for 0 <= v < 2^23: round half to even, without relying on the FPU rounding mode. */
static int32_t lk_round(float v)
{
    int32_t i = (int32_t)v; /* = floor(v) for v >= 0 */
    float d = v - (float)i; /* exact */
    if (d > 0.5f || (d == 0.5f && (i & 1) != 0))
        ++i;
    return i;
}

/* floor(v) as an integer for -2^31 < v < 2^31 (window corners that passed lk_corner_ok()); cheaper
 * than floorf() without SSE4.1. */
static int32_t lk_floor_i(float v)
{
    int32_t i = (int32_t)v; /* truncates toward 0 */
    return (float)i > v ? i - 1 : i;
}

/* Bilinear weights for the fractional offsets a, b in [0, 1), as OpenCV computes them. */
static void lk_weights(float a, float b, int32_t w[4])
{
    w[0] = lk_round((1.f - a) * (1.f - b) * (float)LK_ONE);
    w[1] = lk_round(a * (1.f - b) * (float)LK_ONE);
    w[2] = lk_round((1.f - a) * b * (float)LK_ONE);
    w[3] = LK_ONE - w[0] - w[1] - w[2];
}

/* Row kernels of the portable path, kept out of line: on a 32-bit core without SIMD kernels (Cortex-M at
 * -Os) a loop over the whole window keeps more values live than the core's registers hold and reloads
 * them from the stack for every pixel. On the Cortex-M7 model's QVGA replay (tools/run-mcu.sh) the core
 * runs 88.9 M instructions per frame with one loop over the window, 73.7 M with the row kernels in plain
 * C and 60.9 M with their SMLAD forms. Each gives the integers OpenCV's arithmetic gives. */

/* win bilinear samples of the byte rows s0 and s1 = s0 + one stride (weights wt, 5 fractional bits kept)
 * into out; each pixel's right-hand bytes are the next one's left-hand bytes. */
static LK_NOINLINE void lk_interp_row8(const uint8_t *s0, const uint8_t *s1, const int32_t wt[4],
                                       int16_t *out, int32_t win)
{
    const int16_t *const end = out + win;
#if LK_SIMD32
    /* a column's two bytes as a pair, times the left and the right column's weights */
    const int16x2_t left = lk_pack(wt[0], wt[2]), right = lk_pack(wt[1], wt[3]);
    int16x2_t c = lk_pack(*s0++, *s1++);
    do {
        const int16x2_t n = lk_pack(*s0++, *s1++);
        *out++ = (int16_t)((__smlad(n, right, __smuad(c, left)) + LK_I_ROUND) >> LK_I_SHIFT);
        c = n;
    } while (out != end);
#else
    const int32_t w00 = wt[0], w01 = wt[1], w10 = wt[2], w11 = wt[3];
    int32_t t0 = *s0++, t1 = *s1++;
    do {
        const int32_t u0 = *s0++, u1 = *s1++;
        *out++ = (int16_t)((t0 * w00 + u0 * w01 + t1 * w10 + u1 * w11 + LK_I_ROUND) >> LK_I_SHIFT);
        t0 = u0;
        t1 = u1;
    } while (out != end);
#endif
}

/* win bilinear samples of the derivative rows g0 and g1 (weights wt, descaled to integers) into out. */
static LK_NOINLINE void lk_interp_row16(const int16_t *g0, const int16_t *g1, const int32_t wt[4],
                                        int16_t *out, int32_t win)
{
    const int16_t *const end = out + win;
#if LK_SIMD32
    /* the pairs g0[x], g0[x + 1] and g1[x], g1[x + 1] times the weights' pairs */
    const int16x2_t top = lk_pack(wt[0], wt[1]), bottom = lk_pack(wt[2], wt[3]);
    do {
        const int32_t v = __smlad(lk_pair(g1++), bottom, __smuad(lk_pair(g0++), top));
        *out++ = (int16_t)(((v + LK_D_ROUND) >> LK_W_BITS) - LK_D_BIAS);
    } while (out != end);
#else
    const int32_t w00 = wt[0], w01 = wt[1], w10 = wt[2], w11 = wt[3];
    int32_t t0 = *g0++, t1 = *g1++;
    do {
        const int32_t u0 = *g0++, u1 = *g1++;
        *out++ = (int16_t)(((t0 * w00 + u0 * w01 + t1 * w10 + u1 * w11 + LK_D_ROUND) >> LK_W_BITS) -
                           LK_D_BIAS);
        t0 = u0;
        t1 = u1;
    } while (out != end);
#endif
}

/* The vertical Scharr passes of one grid row from the byte rows s0, s0 + stride and s0 + 2 strides, n
 * columns: the smoothing 3 (top + bottom) + 10 middle into t0, the difference bottom - top into t1. */
static LK_NOINLINE void lk_scharr_v(const uint8_t *s0, int32_t stride, int16_t *t0, int16_t *t1, int32_t n)
{
    const int16_t *const end = t0 + n;
    do {
        const int32_t a = s0[0], b = s0[stride], c = s0[2 * stride];
        *t0++ = (int16_t)(3 * (a + c) + 10 * b);
        *t1++ = (int16_t)(c - a);
        ++s0;
    } while (t0 != end);
}

/* The horizontal Scharr passes of one grid row, n columns: dx = t0[c + 2] - t0[c], dy = 3 (t1[c] +
 * t1[c + 2]) + 10 t1[c + 1]. */
static LK_NOINLINE void lk_scharr_h(const int16_t *t0, const int16_t *t1, int16_t *dx, int16_t *dy, int32_t n)
{
    const int16_t *const end = dx + n;
    do {
        *dx++ = (int16_t)(t0[2] - t0[0]);
        *dy++ = (int16_t)(3 * (t1[0] + t1[2]) + 10 * t1[1]);
        ++t0;
        ++t1;
    } while (dx != end);
}

/* The gradient sums of one window row: sum dx^2, dx dy, dy^2 into r[0..2] (int32: at most 63 products of
 * |d| <= 4080). */
static LK_NOINLINE void lk_grad_row(const int16_t *dx, const int16_t *dy, int32_t win, int32_t r[3])
{
    const int16_t *const end = dx + win;
    int32_t r11 = 0, r12 = 0, r22 = 0;
    do {
        const int32_t a = *dx++, b = *dy++;
        r11 += a * a;
        r12 += a * b;
        r22 += b * b;
    } while (dx != end);
    r[0] = r11;
    r[1] = r12;
    r[2] = r22;
}

/* Previous-image window: grey values and interpolated Scharr derivatives at (ix + a, iy + b) + (x, y)
 * for x, y in 0..win-1, into wk->iwin / ixwin / iywin; the gradient sums into A[3]. */
static void lk_prev_window(const lk_level *lv, int32_t ix, int32_t iy, const int32_t wt[4], lk_work *wk,
                           int64_t A[3], int simd)
{
    const int32_t win = wk->win, g = win + 1, p = win + 3;
    const uint8_t *src;
    int32_t sstride, r, c, y;
    int inside = ix >= 1 && iy >= 1 && ix + win + 1 <= lv->w - 1 && iy + win + 1 <= lv->h - 1;
    int64_t a11 = 0, a12 = 0, a22 = 0;
    (void)simd; /* unused without SIMD kernels */

    if (inside) {
        src = lv->data + (size_t)(iy - 1) * (size_t)lv->stride + (size_t)(ix - 1);
        sstride = lv->stride;
    } else {
        lk_gather(lv, ix - 1, iy - 1, p, wk->patch);
        src = wk->patch;
        sstride = p;
    }

    /* Scharr derivatives on the (win+1)^2 integer grid whose top-left is (ix, iy) */
#if LK_SIMD
    if (simd)
        tvo_lk_scharr_simd(src, sstride, wk);
    else
#endif
        for (r = 0; r < g; ++r) {
            lk_scharr_v(src + (size_t)r * (size_t)sstride, sstride, wk->tv0, wk->tv1, p);
            lk_scharr_h(wk->tv0, wk->tv1, wk->gx + (size_t)r * (size_t)g, wk->gy + (size_t)r * (size_t)g, g);
        }
    if (!inside) { /* derivatives outside the image are 0 (OpenCV's BORDER_CONSTANT) */
        /* grid columns c_lo..c_hi-1 are inside the image */
        const int32_t c_lo = ix < 0 ? (-ix < g ? -ix : g) : 0;
        const int32_t c_hi = lv->w - ix < g ? (lv->w - ix > c_lo ? lv->w - ix : c_lo) : g;
        for (r = 0; r < g; ++r) {
            int16_t *dx = wk->gx + (size_t)r * (size_t)g, *dy = wk->gy + (size_t)r * (size_t)g;
            if (iy + r < 0 || iy + r >= lv->h) {
                memset(dx, 0, (size_t)g * sizeof(int16_t));
                memset(dy, 0, (size_t)g * sizeof(int16_t));
                continue;
            }
            for (c = 0; c < c_lo; ++c)
                dx[c] = dy[c] = 0;
            for (c = c_hi; c < g; ++c)
                dx[c] = dy[c] = 0;
        }
    }

#if LK_SIMD
    if (simd) {
        tvo_lk_prev_interp_simd(src + sstride + 1, sstride, wt, wk, A);
        return;
    }
#endif
    for (y = 0; y < win; ++y) {
        const uint8_t *s0 = src + (size_t)(y + 1) * (size_t)sstride + 1;
        const int16_t *gx0 = wk->gx + (size_t)y * (size_t)g, *gy0 = wk->gy + (size_t)y * (size_t)g;
        const size_t o = (size_t)y * (size_t)win;
        int32_t sums[3];
        lk_interp_row8(s0, s0 + sstride, wt, wk->iwin + o, win);
        lk_interp_row16(gx0, gx0 + g, wt, wk->ixwin + o, win);
        lk_interp_row16(gy0, gy0 + g, wt, wk->iywin + o, win);
        lk_grad_row(wk->ixwin + o, wk->iywin + o, win, sums);
        a11 += sums[0];
        a12 += sums[1];
        a22 += sums[2];
    }
    A[0] = a11;
    A[1] = a12;
    A[2] = a22;
}

/* One row of lk_mismatch(): with d = jv - iw, the sums of d times ixw and d times iyw into r[0], r[1]. */
static LK_NOINLINE void lk_dot_row(const int16_t *jv, const int16_t *iw, const int16_t *ixw,
                                   const int16_t *iyw, int32_t win, int32_t r[2])
{
    int32_t r1 = 0, r2 = 0, x = 0;
#if LK_SIMD32
    /* two pixels a step; the differences are within int16 (|d| <= 8160) */
    for (; x + 1 < win; x += 2) {
        const int16x2_t d = __ssub16(lk_pair(jv + x), lk_pair(iw + x));
        r1 = __smlad(d, lk_pair(ixw + x), r1);
        r2 = __smlad(d, lk_pair(iyw + x), r2);
    }
#endif
    for (; x < win; ++x) {
        const int32_t d = jv[x] - iw[x];
        r1 += d * ixw[x];
        r2 += d * iyw[x];
    }
    r[0] = r1;
    r[1] = r2;
}

/* Sums of (J(window) - I) * Ix and * Iy with J sampled at (jx + a, jy + b) (weights wt), src the
 * top-left of the (win+1)^2 J block with its stride. Each row in two passes, each a row kernel: J's
 * samples into wk->tv0 (free during the iterations: the previous window's Scharr rows are done), then
 * the differences' products. The same integers as one pass over the window: exact sums, an int32 per
 * row (at most 63 products of |d| <= 8160 and |Ix| <= 4080, in any order) and int64 over the rows. */
static void lk_mismatch(const uint8_t *src, int32_t sstride, const int32_t wt[4], const lk_work *wk,
                        int64_t *b1, int64_t *b2)
{
    const int32_t win = wk->win;
    int64_t s1 = 0, s2 = 0;
    int32_t y, r[2];
    for (y = 0; y < win; ++y) {
        const uint8_t *j0 = src + (size_t)y * (size_t)sstride;
        const size_t o = (size_t)y * (size_t)win;
        lk_interp_row8(j0, j0 + sstride, wt, wk->tv0, win);
        lk_dot_row(wk->tv0, wk->iwin + o, wk->ixwin + o, wk->iywin + o, win, r);
        s1 += r[0];
        s2 += r[1];
    }
    *b1 = s1;
    *b2 = s2;
}

/* Sum of |J(window) - I| (OpenCV's error before scaling). */
static int32_t lk_abs_error(const uint8_t *src, int32_t sstride, const int32_t wt[4], const lk_work *wk)
{
    const int32_t win = wk->win;
    int32_t x, y, s = 0;
    for (y = 0; y < win; ++y) {
        const uint8_t *j0 = src + (size_t)y * (size_t)sstride;
        const int16_t *iw = wk->iwin + (size_t)y * (size_t)win;
        lk_interp_row8(j0, j0 + sstride, wt, wk->tv0, win); /* J's samples, as in lk_mismatch() */
        for (x = 0; x < win; ++x) {
            const int32_t d = wk->tv0[x] - iw[x];
            s += d < 0 ? -d : d;
        }
    }
    return s;
}

/* OpenCV's bounds test on a window corner: inside when -win <= floor(v) < n, NaN is outside. */
static int lk_corner_ok(float v, int32_t win, int32_t n)
{
    return v >= (float)-win && v < (float)n;
}

/* The (win+1)^2 block of lv at (jx, jy): a pointer into the image, or into the gathered patch. */
static const uint8_t *lk_next_block(const lk_level *lv, int32_t jx, int32_t jy, lk_work *wk, int32_t *sstride)
{
    const int32_t win = wk->win;
    if (jx >= 0 && jy >= 0 && jx + win <= lv->w - 1 && jy + win <= lv->h - 1) {
        *sstride = lv->stride;
        return lv->data + (size_t)jy * (size_t)lv->stride + (size_t)jx;
    }
    {
        const int32_t q = win + 1 + 2 * LK_JPATCH_MARGIN;
        if (wk->jp_data != lv->data || jx < wk->jp_x0 || jy < wk->jp_y0 || jx + win + 1 > wk->jp_x0 + q ||
            jy + win + 1 > wk->jp_y0 + q) {
            wk->jp_x0 = jx - LK_JPATCH_MARGIN;
            wk->jp_y0 = jy - LK_JPATCH_MARGIN;
            wk->jp_data = lv->data;
            lk_gather(lv, wk->jp_x0, wk->jp_y0, q, wk->jpatch);
        }
        *sstride = q;
        return wk->jpatch + (size_t)(jy - wk->jp_y0) * (size_t)q + (size_t)(jx - wk->jp_x0);
    }
}

/* One level of one point. (px, py): point in prev at this level; (*nx, *ny): in = guess, out =
 * estimate (OpenCV's nextPts). Returns 1, or 0 when the point is lost at this level. When err is not
 * NULL (level 0), the final error is stored there. */
static int lk_track_level(const lk_params *prm, const lk_level *I, const lk_level *J, float px, float py,
                          float *nx, float *ny, lk_work *wk, float *err)
{
    const int32_t win = prm->win;
    const float half = (float)(win - 1) * 0.5f;
    int32_t ix, iy, wt[4], j, sstride;
    int64_t A[3], ib1, ib2;
    float a11, a12, a22, det, min_eig, inv_det, cx, cy, pdx = 0.f, pdy = 0.f;
    float outx = *nx, outy = *ny;
    const uint8_t *blk;
    int ok = 1;

    px -= half;
    py -= half;
    if (!lk_corner_ok(px, win, I->w) || !lk_corner_ok(py, win, I->h))
        return 0;
    ix = lk_floor_i(px);
    iy = lk_floor_i(py);
    lk_weights(px - (float)ix, py - (float)iy, wt);
    lk_prev_window(I, ix, iy, wt, wk, A, prm->simd);

    a11 = (float)A[0] * LK_FLT_SCALE;
    a12 = (float)A[1] * LK_FLT_SCALE;
    a22 = (float)A[2] * LK_FLT_SCALE;
    det = a11 * a22 - a12 * a12;
    min_eig = (a22 + a11 - sqrtf((a11 - a22) * (a11 - a22) + 4.f * a12 * a12)) / (float)(2 * win * win);
    if (min_eig < prm->min_eig || det < FLT_EPSILON)
        return 0;
    inv_det = 1.f / det;

    cx = *nx - half;
    cy = *ny - half;
    for (j = 0; j < prm->max_iters; ++j) {
        float b1, b2, dx, dy;
        if (!lk_corner_ok(cx, win, J->w) || !lk_corner_ok(cy, win, J->h)) {
            ok = 0;
            break;
        }
        ix = lk_floor_i(cx);
        iy = lk_floor_i(cy);
        lk_weights(cx - (float)ix, cy - (float)iy, wt);
        blk = lk_next_block(J, ix, iy, wk, &sstride);
#if LK_SIMD
        if (prm->simd)
            tvo_lk_mismatch_simd(blk, sstride, wt, wk, &ib1, &ib2);
        else
#endif
            lk_mismatch(blk, sstride, wt, wk, &ib1, &ib2);
        b1 = (float)ib1 * LK_FLT_SCALE;
        b2 = (float)ib2 * LK_FLT_SCALE;
        dx = (a12 * b2 - a22 * b1) * inv_det;
        dy = (a12 * b1 - a11 * b2) * inv_det;
        cx += dx;
        cy += dy;
        outx = cx + half;
        outy = cy + half;
        if ((double)dx * (double)dx + (double)dy * (double)dy <= prm->eps2)
            break;
        if (j > 0 && fabs((double)(dx + pdx)) < 0.01 && fabs((double)(dy + pdy)) < 0.01) {
            outx -= dx * 0.5f;
            outy -= dy * 0.5f;
            break;
        }
        pdx = dx;
        pdy = dy;
    }
    *nx = outx;
    *ny = outy;
    if (!ok)
        return 0;

    if (err != NULL) {
        float fx = outx - half, fy = outy - half;
        if (!lk_corner_ok(fx, win, J->w) || !lk_corner_ok(fy, win, J->h))
            return 0;
        ix = lk_floor_i(fx);
        iy = lk_floor_i(fy);
        lk_weights(fx - (float)ix, fy - (float)iy, wt);
        blk = lk_next_block(J, ix, iy, wk, &sstride);
        *err = (float)lk_abs_error(blk, sstride, wt, wk) * (1.f / (float)(32 * win * win));
    }
    return 1;
}

/* Track one point through the levels top..0 from pyramid I to J. (*nx, *ny): in = level-0 guess
 * (used when use_guess), out = level-0 estimate. Returns 1 tracked, 0 lost. */
static int lk_track_point(const lk_params *prm, const tvo_pyramid *I, const tvo_pyramid *J, int32_t top,
                          float x0, float y0, int use_guess, float *nx, float *ny, lk_work *wk, float *err)
{
    /* err != NULL: compute the level-0 error into *err (0 when lost) */
    int32_t l;
    float gx = 0.f, gy = 0.f, e = 0.f;
    int st = 1;
    for (l = top; l >= 0; --l) {
        const float s = 1.f / (float)(1 << l);
        lk_level li, lj;
        float px = x0 * s, py = y0 * s;
        li.data = I->data[l];
        li.w = I->width[l];
        li.h = I->height[l];
        li.stride = I->stride[l];
        lj.data = J->data[l];
        lj.w = J->width[l];
        lj.h = J->height[l];
        lj.stride = J->stride[l];
        if (l == top) {
            if (use_guess) {
                gx = *nx * s;
                gy = *ny * s;
            } else {
                gx = px;
                gy = py;
            }
        } else {
            gx *= 2.f;
            gy *= 2.f;
        }
        st = lk_track_level(prm, &li, &lj, px, py, &gx, &gy, wk, (l == 0 && err != NULL) ? &e : NULL);
    }
    *nx = gx;
    *ny = gy;
    if (st && !(gx >= 0.f && gy >= 0.f && gx <= (float)(J->width[0] - 1) && gy <= (float)(J->height[0] - 1)))
        st = 0; /* left the image */
    if (err != NULL)
        *err = st ? e : 0.f;
    return st;
}

static tvo_status lk_check_pyramid(const tvo_pyramid *p, int32_t max_level)
{
    int32_t l;
    if (p->levels < 1 || p->levels > TVO_MAX_PYR_LEVELS)
        return TVO_ERR_SIZE;
    if (p->levels < max_level + 1)
        return TVO_ERR_ARG;
    for (l = 0; l <= max_level; ++l) {
        if (p->data[l] == NULL)
            return TVO_ERR_NULL;
        if (p->width[l] < 1 || p->height[l] < 1 || p->width[l] > TVO_MAX_IMAGE_DIM ||
            p->height[l] > TVO_MAX_IMAGE_DIM || p->stride[l] < p->width[l])
            return TVO_ERR_SIZE;
        if (l > 0 && (p->width[l] != (p->width[l - 1] + 1) / 2 || p->height[l] != (p->height[l - 1] + 1) / 2))
            return TVO_ERR_SIZE;
    }
    return TVO_OK;
}

static tvo_status lk_validate(const tvo_lk_config *cfg, const tvo_pyramid *prev, const tvo_pyramid *next,
                              const tvo_point2f *prev_pts, tvo_point2f *next_pts, int32_t n, void *scratch,
                              size_t scratch_size)
{
    tvo_status st;
    int32_t l, i;
    if (cfg == NULL || prev == NULL || next == NULL || prev_pts == NULL || next_pts == NULL ||
        scratch == NULL)
        return TVO_ERR_NULL;
    st = tvo_lk_config_check(cfg);
    if (st != TVO_OK)
        return st;
    if (n < 0)
        return TVO_ERR_SIZE;
    st = lk_check_pyramid(prev, cfg->max_level);
    if (st != TVO_OK)
        return st;
    st = lk_check_pyramid(next, cfg->max_level);
    if (st != TVO_OK)
        return st;
    for (l = 0; l <= cfg->max_level; ++l)
        if (prev->width[l] != next->width[l] || prev->height[l] != next->height[l])
            return TVO_ERR_MISMATCH;
    if (scratch_size < tvo_lk_scratch_size(cfg))
        return TVO_ERR_NO_MEMORY;
    for (i = 0; i < n; ++i) {
        if (!isfinite(prev_pts[i].x) || !isfinite(prev_pts[i].y))
            return TVO_ERR_NOT_FINITE;
        if (cfg->use_initial_flow && (!isfinite(next_pts[i].x) || !isfinite(next_pts[i].y)))
            return TVO_ERR_NOT_FINITE;
    }
    return TVO_OK;
}

/* One of the two ways a point is tracked: the configuration's, or the predicted points' (pred_*). */
typedef struct lk_mode {
    lk_params prm;
    lk_work wk;
    int32_t top, fb_top, fb_levels;
} lk_mode;

static void lk_mode_init(lk_mode *md, const tvo_lk_config *cfg, const tvo_pyramid *prev, int32_t win,
                         int32_t levels, int32_t fb_levels)
{
    tvo_lk_config c = *cfg;
    c.win_size = win;
    md->prm.win = win;
    md->prm.max_iters = cfg->max_iters;
    md->prm.eps2 = (double)cfg->epsilon * (double)cfg->epsilon;
    md->prm.min_eig = cfg->min_eig_threshold;
    md->prm.simd = lk_use_simd(&c);
    /* as OpenCV: levels whose size is <= the window are not used */
    md->top = cfg->max_level;
    if (levels > 0 && levels - 1 < md->top)
        md->top = levels - 1;
    while (md->top > 0 && (prev->width[md->top] <= win || prev->height[md->top] <= win))
        --md->top;
    md->fb_levels = fb_levels;
    md->fb_top = fb_levels - 1 < md->top ? fb_levels - 1 : md->top;
}

tvo_status tvo_lk_track_pred(const tvo_lk_config *cfg, const tvo_pyramid *prev, const tvo_pyramid *next,
                             const tvo_point2f *prev_pts, tvo_point2f *next_pts, const uint8_t *pred,
                             uint8_t *status, float *err, int32_t n, void *scratch, size_t scratch_size)
{
    lk_mode mode[2];
    int32_t i, last = -1;
    int two;
    tvo_status st;

    if (status == NULL)
        return TVO_ERR_NULL;
    st = lk_validate(cfg, prev, next, prev_pts, next_pts, n, scratch, scratch_size);
    if (st == TVO_OK)
        st = lk_work_init(&mode[0].wk, cfg->win_size, scratch, scratch_size);
    /* the predicted points' way differs from the others' only with some pred_* field set */
    two = pred != NULL && (cfg->pred_levels > 0 || cfg->pred_win_size > 0 || cfg->pred_fb_levels > 0);
    if (st == TVO_OK && two)
        st = lk_work_init(&mode[1].wk, cfg->pred_win_size > 0 ? cfg->pred_win_size : cfg->win_size, scratch,
                          scratch_size);
    if (st != TVO_OK) {
        if (n > 0)
            memset(status, TVO_LK_LOST, (size_t)n);
        return st;
    }
    lk_mode_init(&mode[0], cfg, prev, cfg->win_size, 0, cfg->fb_levels);
    if (two)
        lk_mode_init(&mode[1], cfg, prev, cfg->pred_win_size > 0 ? cfg->pred_win_size : cfg->win_size,
                     cfg->pred_levels, cfg->pred_fb_levels > 0 ? cfg->pred_fb_levels : cfg->fb_levels);

    for (i = 0; i < n; ++i) {
        const int32_t k0 = two && pred[i] ? 1 : 0;
        const int32_t k_last = cfg->pred_retry ? 0 : k0; /* the retry: a lost predicted point, mode 0 */
        const float x0 = prev_pts[i].x, y0 = prev_pts[i].y;
        const float gx0 = next_pts[i].x, gy0 = next_pts[i].y;
        const float gx = gx0 - x0, gy = gy0 - y0; /* the guess's displacement (use_initial_flow) */
        float nx = gx0, ny = gy0, e = 0.f;
        int ok = 0;
        for (int32_t k = k0; k >= k_last && !ok; --k) {
            lk_mode *md = &mode[k];
            nx = gx0;
            ny = gy0;
            e = 0.f;
            if (k != last) { /* the two modes share the scratch: the other one's cached block is gone */
                md->wk.jp_data = NULL;
                last = k;
            }
            ok = lk_track_point(&md->prm, prev, next, md->top, x0, y0, cfg->use_initial_flow != 0, &nx, &ny,
                                &md->wk, err != NULL ? &e : NULL);
            if (ok && cfg->fb_check) {
                /* the way back starts at the guess's displacement reversed (no displacement without a
                   guess) */
                float bx = cfg->use_initial_flow ? nx - gx : nx, by = cfg->use_initial_flow ? ny - gy : ny,
                      ddx, ddy;
                int back;
                if (md->fb_levels > 0) { /* the short way back: from the start point, on the finest levels */
                    bx = x0;
                    by = y0;
                    back = lk_track_point(&md->prm, next, prev, md->fb_top, nx, ny, 1, &bx, &by, &md->wk,
                                          NULL);
                } else
                    back = lk_track_point(&md->prm, next, prev, md->top, nx, ny, cfg->use_initial_flow != 0,
                                          &bx, &by, &md->wk, NULL);
                ddx = bx - x0;
                ddy = by - y0;
                if (!back ||
                    !((double)ddx * ddx + (double)ddy * ddy <=
                      (double)cfg->fb_max_error * (double)cfg->fb_max_error)) {
                    ok = 0;
                    e = 0.f;
                }
            }
        }
        next_pts[i].x = nx;
        next_pts[i].y = ny;
        status[i] = ok ? TVO_LK_TRACKED : TVO_LK_LOST;
        if (err != NULL)
            err[i] = e;
    }
    return TVO_OK;
}

tvo_status tvo_lk_track(const tvo_lk_config *cfg, const tvo_pyramid *prev, const tvo_pyramid *next,
                        const tvo_point2f *prev_pts, tvo_point2f *next_pts, uint8_t *status, float *err,
                        int32_t n, void *scratch, size_t scratch_size)
{
    return tvo_lk_track_pred(cfg, prev, next, prev_pts, next_pts, NULL, status, err, n, scratch,
                             scratch_size);
}
