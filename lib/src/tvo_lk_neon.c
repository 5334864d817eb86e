/* SPDX-License-Identifier: Apache-2.0 */
/* The Lucas-Kanade window kernels in NEON (aarch64; armv7 built with -mfpu=neon; see tvo_lk_impl.h).
 * Same integers as the portable kernels of tvo_lk.c and the SSE2 ones of tvo_lk_sse2.c. */
#include "tvo_lk_impl.h"

#if LK_NEON
#include <arm_neon.h>

/* NEON kernels (aarch64; armv7 built with -mfpu=neon): the same strips and the same integers as the
 * SSE2 ones of tvo_lk_sse2.c and the portable C path. Differences in form only: products are widening
 * multiply-accumulates by a weight (vmlal_n) instead of pair products (madd), and the descale
 * (v + 2^(n-1)) >> n is one rounding narrowing shift (vrshrn_n), which rounds in wider precision, so
 * no rounding term is carried and, as in the C path, a negative v rounds toward -infinity. */

/* int32 lane sums to the int64 lanes of *acc (pairwise; see lk_acc_epi64 in tvo_lk_sse2.c for why). */
LK_INLINE int64_t lk_hsum_s64_neon(int64x2_t v)
{
    return vgetq_lane_s64(v, 0) + vgetq_lane_s64(v, 1);
}

/* Lanes 8 - tail .. 7 of the overlapping last strip are new pixels: all ones there. */
LK_INLINE int16x8_t lk_tail_mask_neon(int32_t tail)
{
    static const int16_t lane[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    return vreinterpretq_s16_u16(vcgtq_s16(vld1q_s16(lane), vdupq_n_s16((int16_t)(7 - tail))));
}

/* Horizontal Scharr passes of 8 columns of one source row (10 bytes read), as lk_scharr_h_sse2. */
LK_INLINE void lk_scharr_h_neon(const uint8_t *s, int16x8_t *hd, int16x8_t *hs)
{
    const uint8x8_t a = vld1_u8(s), b = vld1_u8(s + 1), c = vld1_u8(s + 2);
    *hd = vreinterpretq_s16_u16(vsubl_u8(c, a)); /* modulo 2^16: the signed difference */
    *hs = vreinterpretq_s16_u16(vmlal_u8(vmulq_n_u16(vaddl_u8(a, c), 3), b, vdup_n_u8(10)));
}

LK_INLINE void lk_scharr_v_neon(int16x8_t hd0, int16x8_t hd1, int16x8_t hd2, int16x8_t hs0, int16x8_t hs2,
                                int16_t *dx, int16_t *dy)
{
    vst1q_s16(dx, vmlaq_n_s16(vmulq_n_s16(vaddq_s16(hd0, hd2), 3), hd1, 10));
    vst1q_s16(dy, vsubq_s16(hs2, hs0));
}

/* Bilinear weights as lane scalars: (w00, w01) for the upper row, (w10, w11) for the lower one. They
 * fit int16 (0..2^14, and w11 can be -1 when the rounded others add up to more than 2^14), so pixels
 * are widened to int16 and all products are signed, as in the C path and SSE2's madd. */
typedef struct lk_wt_neon {
    int16_t s0, s1, s2, s3;
} lk_wt_neon;

LK_INLINE lk_wt_neon lk_wt_make_neon(const int32_t wt[4])
{
    lk_wt_neon w;
    w.s0 = (int16_t)wt[0];
    w.s1 = (int16_t)wt[1];
    w.s2 = (int16_t)wt[2];
    w.s3 = (int16_t)wt[3];
    return w;
}

/* Grey row of 8 columns: p[x] * wa + p[x+1] * wb for the pixels at p (9 bytes read), added to lo/hi. */
LK_INLINE int16x8_t lk_widen_u8_neon(const uint8_t *p)
{
    return vreinterpretq_s16_u16(vmovl_u8(vld1_u8(p)));
}

/* The products of a source row with the lower weights (w10, w11) are added to lo/hi (this window row),
 * those with the upper weights (w00, w01) go to nlo/nhi (the next window row). */
LK_INLINE void lk_u8_row_neon(const uint8_t *p, lk_wt_neon w, int32x4_t *lo, int32x4_t *hi, int32x4_t *nlo,
                              int32x4_t *nhi)
{
    const int16x8_t a0 = lk_widen_u8_neon(p), a1 = lk_widen_u8_neon(p + 1);
    *lo = vmlal_n_s16(vmlal_n_s16(*lo, vget_low_s16(a0), w.s2), vget_low_s16(a1), w.s3);
    *hi = vmlal_n_s16(vmlal_n_s16(*hi, vget_high_s16(a0), w.s2), vget_high_s16(a1), w.s3);
    *nlo = vmlal_n_s16(vmull_n_s16(vget_low_s16(a0), w.s0), vget_low_s16(a1), w.s1);
    *nhi = vmlal_n_s16(vmull_n_s16(vget_high_s16(a0), w.s0), vget_high_s16(a1), w.s1);
}

/* The first source row of a strip: its products with the upper weights. */
LK_INLINE void lk_u8_top_neon(const uint8_t *p, lk_wt_neon w, int32x4_t *lo, int32x4_t *hi)
{
    const int16x8_t a0 = lk_widen_u8_neon(p), a1 = lk_widen_u8_neon(p + 1);
    *lo = vmlal_n_s16(vmull_n_s16(vget_low_s16(a0), w.s0), vget_low_s16(a1), w.s1);
    *hi = vmlal_n_s16(vmull_n_s16(vget_high_s16(a0), w.s0), vget_high_s16(a1), w.s1);
}

/* Grey values (5 fractional bits) of one 8-column window strip, as lk_grey_strip_sse2: top_lo/hi carry
 * the upper source row's products with (w00, w01). */
static void lk_grey_strip_neon(const uint8_t *s, int32_t sstride, int16_t *iw, int32_t win, lk_wt_neon w)
{
    int32x4_t top_lo, top_hi;
    int32_t y;
    lk_u8_top_neon(s, w, &top_lo, &top_hi);
    for (y = 0; y < win; ++y) {
        int32x4_t lo = top_lo, hi = top_hi;
        s += sstride;
        lk_u8_row_neon(s, w, &lo, &hi, &top_lo, &top_hi);
        vst1q_s16(iw, vcombine_s16(vrshrn_n_s32(lo, LK_I_SHIFT), vrshrn_n_s32(hi, LK_I_SHIFT)));
        iw += win;
    }
}

/* One interpolated row of an int16 grid strip (see lk_interp_row_s16): top_lo/hi hold the upper grid
 * row's products with (w00, w01); returns the 8 values and replaces top by the lower row's. */
LK_INLINE int16x8_t lk_interp_row_neon(int32x4_t *top_lo, int32x4_t *top_hi, const int16_t *g1, lk_wt_neon w)
{
    const int16x8_t a0 = vld1q_s16(g1), a1 = vld1q_s16(g1 + 1);
    const int32x4_t lo = vmlal_n_s16(vmlal_n_s16(*top_lo, vget_low_s16(a0), w.s2), vget_low_s16(a1), w.s3);
    const int32x4_t hi = vmlal_n_s16(vmlal_n_s16(*top_hi, vget_high_s16(a0), w.s2), vget_high_s16(a1), w.s3);
    *top_lo = vmlal_n_s16(vmull_n_s16(vget_low_s16(a0), w.s0), vget_low_s16(a1), w.s1);
    *top_hi = vmlal_n_s16(vmull_n_s16(vget_high_s16(a0), w.s0), vget_high_s16(a1), w.s1);
    return vcombine_s16(vrshrn_n_s32(lo, LK_W_BITS), vrshrn_n_s32(hi, LK_W_BITS));
}

/* Interpolated d/dx, d/dy of one 8-column window strip with the G sums, as lk_deriv_strip_sse2: each
 * lane adds two products per row (lanes x and x+4), at most 63 * 2 * 4080^2 < 2^31 per strip. */
static void lk_deriv_strip_neon(const int16_t *gx, const int16_t *gy, int32_t g, int16_t *ixw, int16_t *iyw,
                                int32_t win, lk_wt_neon w, int masked, int16x8_t mask, int64x2_t A[3])
{
    const int16x8_t x0 = vld1q_s16(gx), x1 = vld1q_s16(gx + 1), y0 = vld1q_s16(gy), y1 = vld1q_s16(gy + 1);
    int32x4_t xt_lo = vmlal_n_s16(vmull_n_s16(vget_low_s16(x0), w.s0), vget_low_s16(x1), w.s1);
    int32x4_t xt_hi = vmlal_n_s16(vmull_n_s16(vget_high_s16(x0), w.s0), vget_high_s16(x1), w.s1);
    int32x4_t yt_lo = vmlal_n_s16(vmull_n_s16(vget_low_s16(y0), w.s0), vget_low_s16(y1), w.s1);
    int32x4_t yt_hi = vmlal_n_s16(vmull_n_s16(vget_high_s16(y0), w.s0), vget_high_s16(y1), w.s1);
    int32x4_t c11 = vdupq_n_s32(0), c12 = vdupq_n_s32(0), c22 = vdupq_n_s32(0);
    int32_t y;
    for (y = 0; y < win; ++y) {
        int16x8_t dx, dy, mx, my;
        gx += g;
        gy += g;
        dx = lk_interp_row_neon(&xt_lo, &xt_hi, gx, w);
        dy = lk_interp_row_neon(&yt_lo, &yt_hi, gy, w);
        mx = masked ? vandq_s16(dx, mask) : dx;
        my = masked ? vandq_s16(dy, mask) : dy;
        vst1q_s16(ixw, dx);
        vst1q_s16(iyw, dy);
        c11 = vmlal_s16(vmlal_s16(c11, vget_low_s16(mx), vget_low_s16(dx)), vget_high_s16(mx),
                        vget_high_s16(dx));
        c12 = vmlal_s16(vmlal_s16(c12, vget_low_s16(mx), vget_low_s16(dy)), vget_high_s16(mx),
                        vget_high_s16(dy));
        c22 = vmlal_s16(vmlal_s16(c22, vget_low_s16(my), vget_low_s16(dy)), vget_high_s16(my),
                        vget_high_s16(dy));
        ixw += win;
        iyw += win;
    }
    A[0] = vpadalq_s32(A[0], c11);
    A[1] = vpadalq_s32(A[1], c12);
    A[2] = vpadalq_s32(A[2], c22);
}

/* NEON version of the window interpolation of lk_prev_window (win >= 8), as lk_prev_interp_sse2. */
static void lk_prev_interp_neon(const uint8_t *s, int32_t sstride, const int32_t wt[4], lk_work *wk,
                                int64_t A[3])
{
    const int32_t win = wk->win, g = win + 1;
    const int32_t full = win & ~7, tail = win - full, last = win - 8;
    const lk_wt_neon w = lk_wt_make_neon(wt);
    const int16x8_t mask = lk_tail_mask_neon(tail);
    int64x2_t acc[3];
    int32_t x;
    acc[0] = acc[1] = acc[2] = vdupq_n_s64(0);
    for (x = 0; x < full; x += 8) {
        lk_grey_strip_neon(s + x, sstride, wk->iwin + x, win, w);
        lk_deriv_strip_neon(wk->gx + x, wk->gy + x, g, wk->ixwin + x, wk->iywin + x, win, w, 0, mask, acc);
    }
    if (tail > 0) {
        lk_grey_strip_neon(s + last, sstride, wk->iwin + last, win, w);
        lk_deriv_strip_neon(wk->gx + last, wk->gy + last, g, wk->ixwin + last, wk->iywin + last, win, w, 1,
                            mask, acc);
    }
    A[0] = lk_hsum_s64_neon(acc[0]);
    A[1] = lk_hsum_s64_neon(acc[1]);
    A[2] = lk_hsum_s64_neon(acc[2]);
}

/* Rows of one strip whose int32 lane sums of (J - I) * Ix cannot overflow: each lane adds two products
 * per row (lanes x and x+4), the bound of LK_MISMATCH_STRIP_ROWS of the SSE2 path. */
#define LK_MISMATCH_STRIP_ROWS_NEON 32

/* The (J - I) * Ix and * Iy sums of one 8-column strip of the window, as lk_mismatch_strip_sse2. */
static void lk_mismatch_strip_neon(const uint8_t *j, int32_t sstride, const int16_t *iw, const int16_t *ixw,
                                   const int16_t *iyw, int32_t win, lk_wt_neon w, int masked, int16x8_t mask,
                                   int64x2_t *s1, int64x2_t *s2)
{
    int32x4_t top_lo, top_hi;
    int32_t y = 0;
    lk_u8_top_neon(j, w, &top_lo, &top_hi);
    while (y < win) {
        const int32_t end = win - y > LK_MISMATCH_STRIP_ROWS_NEON ? y + LK_MISMATCH_STRIP_ROWS_NEON : win;
        int32x4_t acc1 = vdupq_n_s32(0), acc2 = vdupq_n_s32(0);
        for (; y < end; ++y) {
            int32x4_t lo = top_lo, hi = top_hi;
            int16x8_t d, ix, iy;
            j += sstride;
            lk_u8_row_neon(j, w, &lo, &hi, &top_lo, &top_hi);
            d = vsubq_s16(vcombine_s16(vrshrn_n_s32(lo, LK_I_SHIFT), vrshrn_n_s32(hi, LK_I_SHIFT)),
                          vld1q_s16(iw));
            if (masked)
                d = vandq_s16(d, mask);
            ix = vld1q_s16(ixw);
            iy = vld1q_s16(iyw);
            acc1 = vmlal_s16(vmlal_s16(acc1, vget_low_s16(ix), vget_low_s16(d)), vget_high_s16(ix),
                             vget_high_s16(d));
            acc2 = vmlal_s16(vmlal_s16(acc2, vget_low_s16(iy), vget_low_s16(d)), vget_high_s16(iy),
                             vget_high_s16(d));
            iw += win;
            ixw += win;
            iyw += win;
        }
        *s1 = vpadalq_s32(*s1, acc1);
        *s2 = vpadalq_s32(*s2, acc2);
    }
}

/* Same sums as lk_mismatch() for win >= 8, as lk_mismatch_sse2 (never reads outside the block). */
static void lk_mismatch_neon(const uint8_t *src, int32_t sstride, const int32_t wt[4], const lk_work *wk,
                             int64_t *b1, int64_t *b2)
{
    const int32_t win = wk->win;
    const int32_t full = win & ~7, tail = win - full, last = win - 8;
    const lk_wt_neon w = lk_wt_make_neon(wt);
    const int16x8_t mask = lk_tail_mask_neon(tail);
    int64x2_t s1 = vdupq_n_s64(0), s2 = vdupq_n_s64(0);
    int32_t x;
    for (x = 0; x < full; x += 8)
        lk_mismatch_strip_neon(src + x, sstride, wk->iwin + x, wk->ixwin + x, wk->iywin + x, win, w, 0, mask,
                               &s1, &s2);
    if (tail > 0)
        lk_mismatch_strip_neon(src + last, sstride, wk->iwin + last, wk->ixwin + last, wk->iywin + last, win,
                               w, 1, mask, &s1, &s2);
    *b1 = lk_hsum_s64_neon(s1);
    *b2 = lk_hsum_s64_neon(s2);
}

/* The strip code below is shared in form with tvo_lk_sse2.c. */
typedef int16x8_t lk_v16;
#define lk_scharr_h_simd lk_scharr_h_neon
#define lk_scharr_v_simd lk_scharr_v_neon

/* One 8-column strip of the Scharr grid (rows 0..rows-1, from source rows 0..rows+1): the horizontal
 * passes once per source row, then the vertical ones from the last three rows; the same integers as the
 * vertical-then-horizontal C path (|values| <= 4080 fit int16). Rows go in threes so that the three
 * carried rows rotate through fixed registers. */
static void lk_scharr_strip_simd(const uint8_t *s, int32_t sstride, int16_t *dx, int16_t *dy, int32_t g,
                                 int32_t rows)
{
    lk_v16 hd0, hd1, hd2, hs0, hs1, hs2;
    int32_t r = 0;
    lk_scharr_h_simd(s, &hd0, &hs0);
    lk_scharr_h_simd(s + sstride, &hd1, &hs1);
    s += 2 * (size_t)sstride;
    for (; r + 3 <= rows; r += 3) {
        lk_scharr_h_simd(s, &hd2, &hs2);
        lk_scharr_v_simd(hd0, hd1, hd2, hs0, hs2, dx, dy);
        lk_scharr_h_simd(s + sstride, &hd0, &hs0);
        lk_scharr_v_simd(hd1, hd2, hd0, hs1, hs0, dx + g, dy + g);
        lk_scharr_h_simd(s + 2 * (size_t)sstride, &hd1, &hs1);
        lk_scharr_v_simd(hd2, hd0, hd1, hs2, hs1, dx + 2 * g, dy + 2 * g);
        s += 3 * (size_t)sstride;
        dx += 3 * g;
        dy += 3 * g;
    }
    for (; r < rows; ++r) {
        lk_scharr_h_simd(s, &hd2, &hs2);
        lk_scharr_v_simd(hd0, hd1, hd2, hs0, hs2, dx, dy);
        hd0 = hd1;
        hd1 = hd2;
        hs0 = hs1;
        hs1 = hs2;
        s += sstride;
        dx += g;
        dy += g;
    }
}

/* SIMD version of the Scharr rows of lk_prev_window (win >= 8), same integers, in 8-column strips of
 * the g = win + 1 grid columns; the last strip overlaps the previous one (idempotent stores). */
static void lk_scharr_grid(const uint8_t *src, int32_t sstride, lk_work *wk)
{
    const int32_t g = wk->win + 1;
    int32_t x;
    for (x = 0; x + 8 <= g; x += 8)
        lk_scharr_strip_simd(src + x, sstride, wk->gx + x, wk->gy + x, g, g);
    if (g & 7)
        lk_scharr_strip_simd(src + g - 8, sstride, wk->gx + g - 8, wk->gy + g - 8, g, g);
}

void tvo_lk_scharr_simd(const uint8_t *src, int32_t sstride, lk_work *wk)
{
    lk_scharr_grid(src, sstride, wk);
}

void tvo_lk_prev_interp_simd(const uint8_t *s, int32_t sstride, const int32_t wt[4], lk_work *wk,
                             int64_t A[3])
{
    lk_prev_interp_neon(s, sstride, wt, wk, A);
}

void tvo_lk_mismatch_simd(const uint8_t *src, int32_t sstride, const int32_t wt[4], const lk_work *wk,
                          int64_t *b1, int64_t *b2)
{
    lk_mismatch_neon(src, sstride, wt, wk, b1, b2);
}
#else
typedef int tvo_lk_neon_unused; /* ISO C needs a declaration in every translation unit */
#endif
