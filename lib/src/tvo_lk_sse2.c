/* SPDX-License-Identifier: Apache-2.0 */
/* The Lucas-Kanade window kernels in SSE2 (x86; see tvo_lk_impl.h). Same integers as the portable
 * kernels of tvo_lk.c, strip by strip of 8 columns. */
#include "tvo_lk_impl.h"

#if LK_SSE2
#include <emmintrin.h>

/* A strip's int32 lane sums each fit int32 (bounds at the sums below), four of them together need not:
 * they are added, sign-extended, into two int64 lanes (*acc), which lk_hsum_epi64 adds at the end. */
LK_INLINE void lk_acc_epi64(__m128i v, __m128i *acc)
{
    const __m128i sign = _mm_srai_epi32(v, 31);
    *acc = _mm_add_epi64(*acc, _mm_add_epi64(_mm_unpacklo_epi32(v, sign), _mm_unpackhi_epi32(v, sign)));
}

LK_INLINE int64_t lk_hsum_epi64(__m128i v)
{
    int64_t t[2];
    _mm_storeu_si128((__m128i *)t, v);
    return t[0] + t[1];
}

/* Products of the (x, x+1) pairs of 8 int16 values at p with the weight pair w: lanes 0..3 (lo) and 4..7
 * (hi) as int32. */
LK_INLINE void lk_pair_madd_s16(const int16_t *p, __m128i w, __m128i *lo, __m128i *hi)
{
    __m128i a0 = _mm_loadu_si128((const __m128i *)p), a1 = _mm_loadu_si128((const __m128i *)(p + 1));
    *lo = _mm_madd_epi16(_mm_unpacklo_epi16(a0, a1), w);
    *hi = _mm_madd_epi16(_mm_unpackhi_epi16(a0, a1), w);
}

/* Same for 8 uint8 values (9 bytes read). */
LK_INLINE void lk_pair_u8(const uint8_t *p, __m128i *lo, __m128i *hi)
{
    const __m128i z = _mm_setzero_si128();
    __m128i a0 = _mm_unpacklo_epi8(_mm_loadl_epi64((const __m128i *)p), z);
    __m128i a1 = _mm_unpacklo_epi8(_mm_loadl_epi64((const __m128i *)(p + 1)), z);
    *lo = _mm_unpacklo_epi16(a0, a1);
    *hi = _mm_unpackhi_epi16(a0, a1);
}

/* Horizontal Scharr passes of 8 columns of one source row: difference s[x+2] - s[x] and smoothing
 * 3 s[x] + 10 s[x+1] + 3 s[x+2] (10 bytes read). */
LK_INLINE void lk_scharr_h_sse2(const uint8_t *s, __m128i *hd, __m128i *hs)
{
    const __m128i z = _mm_setzero_si128(), k3 = _mm_set1_epi16(3), k10 = _mm_set1_epi16(10);
    __m128i a = _mm_unpacklo_epi8(_mm_loadl_epi64((const __m128i *)s), z);
    __m128i b = _mm_unpacklo_epi8(_mm_loadl_epi64((const __m128i *)(s + 1)), z);
    __m128i c = _mm_unpacklo_epi8(_mm_loadl_epi64((const __m128i *)(s + 2)), z);
    *hd = _mm_sub_epi16(c, a);
    *hs = _mm_add_epi16(_mm_mullo_epi16(_mm_add_epi16(a, c), k3), _mm_mullo_epi16(b, k10));
}

/* Vertical passes from three rows' horizontal ones: dx = 3 hd0 + 10 hd1 + 3 hd2, dy = hs2 - hs0. */
LK_INLINE void lk_scharr_v_sse2(__m128i hd0, __m128i hd1, __m128i hd2, __m128i hs0, __m128i hs2, int16_t *dx,
                                int16_t *dy)
{
    const __m128i k3 = _mm_set1_epi16(3), k10 = _mm_set1_epi16(10);
    _mm_storeu_si128((__m128i *)dx,
                     _mm_add_epi16(_mm_mullo_epi16(_mm_add_epi16(hd0, hd2), k3), _mm_mullo_epi16(hd1, k10)));
    _mm_storeu_si128((__m128i *)dy, _mm_sub_epi16(hs2, hs0));
}

/* One row of a grey strip: top_lo/hi hold the upper source row's products with (w00, w01) plus the
 * rounding term, s is the lower source row; they are replaced by the lower row's. */
LK_INLINE void lk_grey_row_sse2(__m128i *top_lo, __m128i *top_hi, const uint8_t *s, int16_t *iw, __m128i w01,
                                __m128i w23)
{
    const __m128i rnd = _mm_set1_epi32(LK_I_ROUND);
    __m128i plo, phi, lo, hi;
    lk_pair_u8(s, &plo, &phi);
    lo = _mm_srai_epi32(_mm_add_epi32(_mm_madd_epi16(plo, w23), *top_lo), LK_I_SHIFT);
    hi = _mm_srai_epi32(_mm_add_epi32(_mm_madd_epi16(phi, w23), *top_hi), LK_I_SHIFT);
    *top_lo = _mm_add_epi32(_mm_madd_epi16(plo, w01), rnd);
    *top_hi = _mm_add_epi32(_mm_madd_epi16(phi, w01), rnd);
    _mm_storeu_si128((__m128i *)iw, _mm_packs_epi32(lo, hi));
}

/* Grey values (5 fractional bits) of one 8-column window strip, rows 0..win-1 from source rows s,
 * s + sstride, ...; each source row is widened and paired once (see lk_mismatch_strip_sse2). */
static void lk_grey_strip_sse2(const uint8_t *s, int32_t sstride, int16_t *iw, int32_t win, __m128i w01,
                               __m128i w23)
{
    const __m128i rnd = _mm_set1_epi32(LK_I_ROUND);
    __m128i plo, phi, top_lo, top_hi;
    int32_t y;
    lk_pair_u8(s, &plo, &phi);
    top_lo = _mm_add_epi32(_mm_madd_epi16(plo, w01), rnd);
    top_hi = _mm_add_epi32(_mm_madd_epi16(phi, w01), rnd);
    for (y = 0; y + 2 <= win; y += 2) {
        lk_grey_row_sse2(&top_lo, &top_hi, s + sstride, iw, w01, w23);
        lk_grey_row_sse2(&top_lo, &top_hi, s + 2 * (size_t)sstride, iw + win, w01, w23);
        s += 2 * (size_t)sstride;
        iw += 2 * win;
    }
    if (y < win)
        lk_grey_row_sse2(&top_lo, &top_hi, s + sstride, iw, w01, w23);
}

/* The G sums below add per strip and lane two products of |d| <= 4080 per row into int32: at most
 * 63 rows * 2 * 4080^2 = 2,097,446,400 < 2^31; the lanes are added in int64 (lk_acc_epi64). */
#if TVO_LK_MAX_WIN_SIZE > 63
#error "lk_deriv_strip_sse2: int32 strip sums need win_size <= 63"
#endif

/* One interpolated row of an int16 grid strip: top_lo/hi hold the upper grid row's products with
 * (w00, w01) plus the rounding term, g1 is the lower grid row; returns the 8 values (descaled by 2^14
 * with floor = the biased shift of the C path) and replaces top by the lower row's products. */
LK_INLINE __m128i lk_interp_row_s16(__m128i *top_lo, __m128i *top_hi, const int16_t *g1, __m128i w01,
                                    __m128i w23)
{
    const __m128i rnd = _mm_set1_epi32(1 << (LK_W_BITS - 1));
    __m128i a0 = _mm_loadu_si128((const __m128i *)g1), a1 = _mm_loadu_si128((const __m128i *)(g1 + 1));
    __m128i plo = _mm_unpacklo_epi16(a0, a1), phi = _mm_unpackhi_epi16(a0, a1);
    __m128i lo = _mm_srai_epi32(_mm_add_epi32(_mm_madd_epi16(plo, w23), *top_lo), LK_W_BITS);
    __m128i hi = _mm_srai_epi32(_mm_add_epi32(_mm_madd_epi16(phi, w23), *top_hi), LK_W_BITS);
    *top_lo = _mm_add_epi32(_mm_madd_epi16(plo, w01), rnd);
    *top_hi = _mm_add_epi32(_mm_madd_epi16(phi, w01), rnd);
    return _mm_packs_epi32(lo, hi);
}

/* State of one strip of lk_deriv_strip_sse2 between rows. */
typedef struct lk_dv_state {
    __m128i xt_lo, xt_hi, yt_lo, yt_hi; /* upper grid rows' products (see lk_interp_row_s16) */
    __m128i c11, c12, c22;              /* G lane sums */
} lk_dv_state;

LK_INLINE void lk_deriv_row_sse2(lk_dv_state *st, const int16_t *gx1, const int16_t *gy1, int16_t *ixw,
                                 int16_t *iyw, __m128i w01, __m128i w23, int masked, __m128i mask)
{
    __m128i dx = lk_interp_row_s16(&st->xt_lo, &st->xt_hi, gx1, w01, w23);
    __m128i dy = lk_interp_row_s16(&st->yt_lo, &st->yt_hi, gy1, w01, w23);
    __m128i mx = masked ? _mm_and_si128(dx, mask) : dx;
    __m128i my = masked ? _mm_and_si128(dy, mask) : dy;
    _mm_storeu_si128((__m128i *)ixw, dx);
    _mm_storeu_si128((__m128i *)iyw, dy);
    st->c11 = _mm_add_epi32(_mm_madd_epi16(mx, dx), st->c11);
    st->c12 = _mm_add_epi32(_mm_madd_epi16(mx, dy), st->c12);
    st->c22 = _mm_add_epi32(_mm_madd_epi16(my, dy), st->c22);
}

/* Interpolated d/dx, d/dy of one 8-column window strip (rows 0..win-1) from the Scharr grid at gx, gy
 * (stride g); the G sums (a11, a12, a22) are added to the int64 lanes of A[3], when masked only
 * those of the lanes in mask. Each grid row is paired once (as in lk_grey_strip_sse2); rows go in
 * pairs. */
static void lk_deriv_strip_sse2(const int16_t *gx, const int16_t *gy, int32_t g, int16_t *ixw, int16_t *iyw,
                                int32_t win, __m128i w01, __m128i w23, int masked, __m128i mask, __m128i A[3])
{
    const __m128i rnd = _mm_set1_epi32(1 << (LK_W_BITS - 1));
    lk_dv_state st;
    int32_t y;
    lk_pair_madd_s16(gx, w01, &st.xt_lo, &st.xt_hi);
    lk_pair_madd_s16(gy, w01, &st.yt_lo, &st.yt_hi);
    st.xt_lo = _mm_add_epi32(st.xt_lo, rnd);
    st.xt_hi = _mm_add_epi32(st.xt_hi, rnd);
    st.yt_lo = _mm_add_epi32(st.yt_lo, rnd);
    st.yt_hi = _mm_add_epi32(st.yt_hi, rnd);
    st.c11 = st.c12 = st.c22 = _mm_setzero_si128();
    for (y = 0; y + 2 <= win; y += 2) {
        lk_deriv_row_sse2(&st, gx + g, gy + g, ixw, iyw, w01, w23, masked, mask);
        lk_deriv_row_sse2(&st, gx + 2 * g, gy + 2 * g, ixw + win, iyw + win, w01, w23, masked, mask);
        gx += 2 * g;
        gy += 2 * g;
        ixw += 2 * win;
        iyw += 2 * win;
    }
    if (y < win)
        lk_deriv_row_sse2(&st, gx + g, gy + g, ixw, iyw, w01, w23, masked, mask);
    lk_acc_epi64(st.c11, &A[0]);
    lk_acc_epi64(st.c12, &A[1]);
    lk_acc_epi64(st.c22, &A[2]);
}

/* SSE2 version of the window interpolation of lk_prev_window (win >= 8), same integers, in 8-column
 * strips. s is the window's top-left pixel (patch offset +1, +1). The last strip overlaps the previous
 * one: stores are idempotent and the gradient sums mask the repeated lanes. */
static void lk_prev_interp_sse2(const uint8_t *s, int32_t sstride, const int32_t wt[4], lk_work *wk,
                                int64_t A[3])
{
    const int32_t win = wk->win, g = win + 1;
    const int32_t full = win & ~7, tail = win - full, last = win - 8;
    const __m128i w01 = _mm_set1_epi32((int32_t)((uint32_t)wt[0] | ((uint32_t)wt[1] << 16)));
    const __m128i w23 = _mm_set1_epi32((int32_t)((uint32_t)wt[2] | ((uint32_t)wt[3] << 16)));
    const __m128i lane = _mm_set_epi16(7, 6, 5, 4, 3, 2, 1, 0);
    const __m128i mask = _mm_cmpgt_epi16(lane, _mm_set1_epi16((int16_t)(7 - tail)));
    int32_t x;
    __m128i acc[3];
    acc[0] = acc[1] = acc[2] = _mm_setzero_si128();
    for (x = 0; x < full; x += 8) {
        lk_grey_strip_sse2(s + x, sstride, wk->iwin + x, win, w01, w23);
        lk_deriv_strip_sse2(wk->gx + x, wk->gy + x, g, wk->ixwin + x, wk->iywin + x, win, w01, w23, 0, mask,
                            acc);
    }
    if (tail > 0) {
        lk_grey_strip_sse2(s + last, sstride, wk->iwin + last, win, w01, w23);
        lk_deriv_strip_sse2(wk->gx + last, wk->gy + last, g, wk->ixwin + last, wk->iywin + last, win, w01,
                            w23, 1, mask, acc);
    }
    A[0] = lk_hsum_epi64(acc[0]);
    A[1] = lk_hsum_epi64(acc[1]);
    A[2] = lk_hsum_epi64(acc[2]);
}

/* Rows of one 8-column strip whose int32 lane sums of (J - I) * Ix (or * Iy) cannot overflow: per row a
 * lane adds two products of |J - I| <= 255 * 32 = 8160 and |Ix| <= 16 * 255 = 4080, 66,585,600; 32 rows
 * make 2,130,739,200 < 2^31 (the four lanes are added in int64). Even, as the rows go in pairs. */
#define LK_MISMATCH_STRIP_ROWS 32

/* State of one strip of lk_mismatch_strip_sse2 between rows. */
typedef struct lk_mm_state {
    __m128i top_lo, top_hi; /* the previous J row's products with (w00, w01), plus the rounding term */
    __m128i acc1, acc2;     /* lane sums of (J - I) * Ix and * Iy */
} lk_mm_state;

/* One window row of a strip: j is the J row below it (its top J row is in st). */
LK_INLINE void lk_mismatch_row_sse2(lk_mm_state *st, const uint8_t *j, const int16_t *iw, const int16_t *ixw,
                                    const int16_t *iyw, __m128i w01, __m128i w23, int masked, __m128i mask)
{
    const __m128i z = _mm_setzero_si128(), rnd = _mm_set1_epi32(LK_I_ROUND);
    __m128i b0 = _mm_unpacklo_epi8(_mm_loadl_epi64((const __m128i *)j), z);
    __m128i b1 = _mm_unpacklo_epi8(_mm_loadl_epi64((const __m128i *)(j + 1)), z);
    __m128i plo = _mm_unpacklo_epi16(b0, b1), phi = _mm_unpackhi_epi16(b0, b1);
    __m128i lo = _mm_add_epi32(_mm_madd_epi16(plo, w23), st->top_lo);
    __m128i hi = _mm_add_epi32(_mm_madd_epi16(phi, w23), st->top_hi);
    __m128i d;
    st->top_lo = _mm_add_epi32(_mm_madd_epi16(plo, w01), rnd);
    st->top_hi = _mm_add_epi32(_mm_madd_epi16(phi, w01), rnd);
    lo = _mm_srai_epi32(lo, LK_I_SHIFT); /* non-negative: exact */
    hi = _mm_srai_epi32(hi, LK_I_SHIFT);
    d = _mm_sub_epi16(_mm_packs_epi32(lo, hi), _mm_loadu_si128((const __m128i *)iw));
    if (masked)
        d = _mm_and_si128(d, mask);
    st->acc1 = _mm_add_epi32(_mm_madd_epi16(_mm_loadu_si128((const __m128i *)ixw), d), st->acc1);
    st->acc2 = _mm_add_epi32(_mm_madd_epi16(_mm_loadu_si128((const __m128i *)iyw), d), st->acc2);
}

/* The (J - I) * Ix and * Iy sums of one 8-column strip of the window (rows 0..win-1), added to the
 * int64 lanes of *s1 and *s2. j: top-left of the strip in the J block; iw / ixw / iyw: the strip's
 * column in the window buffers. Each J row is widened and paired (J[x], J[x+1]) once: its products
 * with (w00, w01) are kept for the next row, with (w10, w11) used for this one; the sums are the same
 * integers as lk_mismatch(). When masked, only the lanes in mask count (the new lanes of the
 * overlapping last strip). Rows go in pairs (fewer register copies between loop-carried values). */
static void lk_mismatch_strip_sse2(const uint8_t *j, int32_t sstride, const int16_t *iw, const int16_t *ixw,
                                   const int16_t *iyw, int32_t win, __m128i w01, __m128i w23, int masked,
                                   __m128i mask, __m128i *s1, __m128i *s2)
{
    const __m128i z = _mm_setzero_si128(), rnd = _mm_set1_epi32(LK_I_ROUND);
    __m128i a0 = _mm_unpacklo_epi8(_mm_loadl_epi64((const __m128i *)j), z);
    __m128i a1 = _mm_unpacklo_epi8(_mm_loadl_epi64((const __m128i *)(j + 1)), z);
    lk_mm_state st;
    int32_t y = 0;
    st.top_lo = _mm_add_epi32(_mm_madd_epi16(_mm_unpacklo_epi16(a0, a1), w01), rnd);
    st.top_hi = _mm_add_epi32(_mm_madd_epi16(_mm_unpackhi_epi16(a0, a1), w01), rnd);
    while (y < win) {
        const int32_t end = win - y > LK_MISMATCH_STRIP_ROWS ? y + LK_MISMATCH_STRIP_ROWS : win;
        st.acc1 = st.acc2 = z;
        for (; y + 2 <= end; y += 2) {
            lk_mismatch_row_sse2(&st, j + sstride, iw, ixw, iyw, w01, w23, masked, mask);
            lk_mismatch_row_sse2(&st, j + 2 * sstride, iw + win, ixw + win, iyw + win, w01, w23, masked,
                                 mask);
            j += 2 * sstride;
            iw += 2 * win;
            ixw += 2 * win;
            iyw += 2 * win;
        }
        if (y < end) {
            lk_mismatch_row_sse2(&st, j + sstride, iw, ixw, iyw, w01, w23, masked, mask);
            j += sstride;
            iw += win;
            ixw += win;
            iyw += win;
            ++y;
        }
        lk_acc_epi64(st.acc1, s1);
        lk_acc_epi64(st.acc2, s2);
    }
}

/* Same sums as lk_mismatch() for win >= 8, strip by strip; never reads outside the (win+1)^2 block:
 * the last strip overlaps the previous one and its repeated lanes are masked out. */
static void lk_mismatch_sse2(const uint8_t *src, int32_t sstride, const int32_t wt[4], const lk_work *wk,
                             int64_t *b1, int64_t *b2)
{
    const int32_t win = wk->win;
    const int32_t full = win & ~7, tail = win - full, last = win - 8;
    const __m128i w01 = _mm_set1_epi32((int32_t)((uint32_t)wt[0] | ((uint32_t)wt[1] << 16)));
    const __m128i w23 = _mm_set1_epi32((int32_t)((uint32_t)wt[2] | ((uint32_t)wt[3] << 16)));
    /* lanes 8 - tail .. 7 of the last strip are new pixels */
    const __m128i lane = _mm_set_epi16(7, 6, 5, 4, 3, 2, 1, 0);
    const __m128i mask = _mm_cmpgt_epi16(lane, _mm_set1_epi16((int16_t)(7 - tail)));
    __m128i s1 = _mm_setzero_si128(), s2 = _mm_setzero_si128();
    int32_t x;
    for (x = 0; x < full; x += 8)
        lk_mismatch_strip_sse2(src + x, sstride, wk->iwin + x, wk->ixwin + x, wk->iywin + x, win, w01, w23, 0,
                               mask, &s1, &s2);
    if (tail > 0)
        lk_mismatch_strip_sse2(src + last, sstride, wk->iwin + last, wk->ixwin + last, wk->iywin + last, win,
                               w01, w23, 1, mask, &s1, &s2);
    *b1 = lk_hsum_epi64(s1);
    *b2 = lk_hsum_epi64(s2);
}

/* The strip code below is shared in form with tvo_lk_neon.c. */
typedef __m128i lk_v16; /* eight int16 lanes */
#define lk_scharr_h_simd lk_scharr_h_sse2
#define lk_scharr_v_simd lk_scharr_v_sse2

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
    lk_prev_interp_sse2(s, sstride, wt, wk, A);
}

void tvo_lk_mismatch_simd(const uint8_t *src, int32_t sstride, const int32_t wt[4], const lk_work *wk,
                          int64_t *b1, int64_t *b2)
{
    lk_mismatch_sse2(src, sstride, wt, wk, b1, b2);
}
#else
typedef int tvo_lk_sse2_unused; /* ISO C needs a declaration in every translation unit */
#endif
