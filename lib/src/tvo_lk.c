/* Pyramidal Lucas-Kanade tracking, OpenCV-compatible arithmetic (see tinyvo/lk.h).
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

/* SIMD kernels for the previous-window Scharr rows and interpolation and for the iteration: SSE2 on
 * x86 (x86-64 always has it), NEON on ARM (aarch64 always; 32-bit ARM when built with -mfpu=neon).
 * They compute exactly the same integers as the portable C kernels (exact integer sums), so results
 * are bit-identical; cfg->force_portable selects the C kernels, and test_lk.c checks the two agree.
 * Define TVO_LK_NO_SIMD to compile the SIMD kernels out. */
#if defined(__SSE2__) && !defined(TVO_LK_NO_SIMD)
#include <emmintrin.h>
#define LK_SSE2 1
#else
#define LK_SSE2 0
#endif
#if !LK_SSE2 && (defined(__ARM_NEON) || defined(__ARM_NEON__)) && !defined(TVO_LK_NO_SIMD)
#include <arm_neon.h>
#define LK_NEON 1
#else
#define LK_NEON 0
#endif

/* The SSE2 row helpers are small and called once per row: always inline them (their state lives in
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

typedef struct lk_level {
    const uint8_t *data;
    int32_t w, h, stride;
} lk_level;

typedef struct lk_work {
    int32_t win;
    uint8_t *patch;   /* (win+3)^2 gathered pixels near borders */
    int16_t *tv0;     /* win+3: vertical Scharr smoothing (portable path) */
    int16_t *tv1;     /* win+3: vertical Scharr difference (portable path) */
    int16_t *gx, *gy; /* (win+1)^2 Scharr derivatives on the integer grid */
    int16_t *iwin;    /* win^2 window grey values, 5 fractional bits */
    int16_t *ixwin;   /* win^2 interpolated d/dx */
    int16_t *iywin;   /* win^2 interpolated d/dy */
    uint8_t *jpatch;  /* (win+1+2*LK_JPATCH_MARGIN)^2 gathered next-image pixels near borders, kept while
                         the iterations stay inside it (same bytes as gathering each block anew) */
    const uint8_t *jp_data; /* level the jpatch was gathered from (NULL: none) */
    int32_t jp_x0, jp_y0;   /* its top-left in that level */
} lk_work;

/* Pixels gathered around a border block beyond the (win+1)^2 it needs: Gauss-Newton steps after the
 * first are mostly well under this, so one gather serves the whole level. */
#define LK_JPATCH_MARGIN 4

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

size_t tvo_lk_scratch_size(const tvo_lk_config *cfg)
{
    size_t sz[LK_NBLOCKS], total = TVO_ARENA_ALIGN - 1u;
    int i;
    if (tvo_lk_config_check(cfg) != TVO_OK)
        return 0;
    lk_blocks(cfg->win_size, sz);
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

#if LK_SSE2
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
    _mm_storeu_si128((__m128i *)dx, _mm_add_epi16(_mm_mullo_epi16(_mm_add_epi16(hd0, hd2), k3),
                                                  _mm_mullo_epi16(hd1, k10)));
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
LK_INLINE __m128i lk_interp_row_s16(__m128i *top_lo, __m128i *top_hi, const int16_t *g1, __m128i w01, __m128i w23)
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

LK_INLINE void lk_deriv_row_sse2(lk_dv_state *st, const int16_t *gx1, const int16_t *gy1, int16_t *ixw, int16_t *iyw,
                              __m128i w01, __m128i w23, int masked, __m128i mask)
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
        lk_deriv_strip_sse2(wk->gx + x, wk->gy + x, g, wk->ixwin + x, wk->iywin + x, win, w01, w23, 0, mask, acc);
    }
    if (tail > 0) {
        lk_grey_strip_sse2(s + last, sstride, wk->iwin + last, win, w01, w23);
        lk_deriv_strip_sse2(wk->gx + last, wk->gy + last, g, wk->ixwin + last, wk->iywin + last, win, w01, w23,
                            1, mask, acc);
    }
    A[0] = lk_hsum_epi64(acc[0]);
    A[1] = lk_hsum_epi64(acc[1]);
    A[2] = lk_hsum_epi64(acc[2]);
}
#endif

#if LK_NEON
/* NEON kernels (aarch64; armv7 built with -mfpu=neon): the same strips and the same integers as the
 * SSE2 ones above and the portable C path. Differences in form only: products are widening
 * multiply-accumulates by a weight (vmlal_n) instead of pair products (madd), and the descale
 * (v + 2^(n-1)) >> n is one rounding narrowing shift (vrshrn_n), which rounds in wider precision, so
 * no rounding term is carried and, as in the C path, a negative v rounds toward -infinity. */

/* int32 lane sums to the int64 lanes of *acc (pairwise; see lk_acc_epi64 for why). */
LK_INLINE int64_t lk_hsum_s64_neon(int64x2_t v)
{
    return vgetq_lane_s64(v, 0) + vgetq_lane_s64(v, 1);
}

/* Lanes 8 - tail .. 7 of the overlapping last strip are new pixels: all ones there. */
LK_INLINE int16x8_t lk_tail_mask_neon(int32_t tail)
{
    static const int16_t lane[8] = { 0, 1, 2, 3, 4, 5, 6, 7 };
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
        c11 = vmlal_s16(vmlal_s16(c11, vget_low_s16(mx), vget_low_s16(dx)), vget_high_s16(mx), vget_high_s16(dx));
        c12 = vmlal_s16(vmlal_s16(c12, vget_low_s16(mx), vget_low_s16(dy)), vget_high_s16(mx), vget_high_s16(dy));
        c22 = vmlal_s16(vmlal_s16(c22, vget_low_s16(my), vget_low_s16(dy)), vget_high_s16(my), vget_high_s16(dy));
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
        lk_deriv_strip_neon(wk->gx + last, wk->gy + last, g, wk->ixwin + last, wk->iywin + last, win, w, 1, mask,
                            acc);
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
            d = vsubq_s16(vcombine_s16(vrshrn_n_s32(lo, LK_I_SHIFT), vrshrn_n_s32(hi, LK_I_SHIFT)), vld1q_s16(iw));
            if (masked)
                d = vandq_s16(d, mask);
            ix = vld1q_s16(ixw);
            iy = vld1q_s16(iyw);
            acc1 = vmlal_s16(vmlal_s16(acc1, vget_low_s16(ix), vget_low_s16(d)), vget_high_s16(ix), vget_high_s16(d));
            acc2 = vmlal_s16(vmlal_s16(acc2, vget_low_s16(iy), vget_low_s16(d)), vget_high_s16(iy), vget_high_s16(d));
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
        lk_mismatch_strip_neon(src + x, sstride, wk->iwin + x, wk->ixwin + x, wk->iywin + x, win, w, 0, mask, &s1,
                               &s2);
    if (tail > 0)
        lk_mismatch_strip_neon(src + last, sstride, wk->iwin + last, wk->ixwin + last, wk->iywin + last, win, w, 1,
                               mask, &s1, &s2);
    *b1 = lk_hsum_s64_neon(s1);
    *b2 = lk_hsum_s64_neon(s2);
}
#endif

/* The SIMD kernels of this build (same integers as the portable C ones). */
#if LK_SSE2
#define LK_SIMD 1
typedef __m128i lk_v16; /* eight int16 lanes */
#define lk_scharr_h_simd lk_scharr_h_sse2
#define lk_scharr_v_simd lk_scharr_v_sse2
#define lk_prev_interp_simd lk_prev_interp_sse2
#define lk_mismatch_simd lk_mismatch_sse2
#elif LK_NEON
#define LK_SIMD 1
typedef int16x8_t lk_v16;
#define lk_scharr_h_simd lk_scharr_h_neon
#define lk_scharr_v_simd lk_scharr_v_neon
#define lk_prev_interp_simd lk_prev_interp_neon
#define lk_mismatch_simd lk_mismatch_neon
#else
#define LK_SIMD 0
#endif

#if LK_SIMD
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
static void lk_scharr_simd(const uint8_t *src, int32_t sstride, lk_work *wk)
{
    const int32_t g = wk->win + 1;
    int32_t x;
    for (x = 0; x + 8 <= g; x += 8)
        lk_scharr_strip_simd(src + x, sstride, wk->gx + x, wk->gy + x, g, g);
    if (g & 7)
        lk_scharr_strip_simd(src + g - 8, sstride, wk->gx + g - 8, wk->gy + g - 8, g, g);
}
#endif

/* Previous-image window: grey values and interpolated Scharr derivatives at (ix + a, iy + b) + (x, y)
 * for x, y in 0..win-1, into wk->iwin / ixwin / iywin; the gradient sums into A[3]. */
static void lk_prev_window(const lk_level *lv, int32_t ix, int32_t iy, const int32_t wt[4],
                           lk_work *wk, int64_t A[3], int simd)
{
    const int32_t win = wk->win, g = win + 1, p = win + 3;
    const uint8_t *src;
    int32_t sstride, r, c, x, y;
    int inside = ix >= 1 && iy >= 1 && ix + win + 1 <= lv->w - 1 && iy + win + 1 <= lv->h - 1;
    const int32_t w00 = wt[0], w01 = wt[1], w10 = wt[2], w11 = wt[3];
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
        lk_scharr_simd(src, sstride, wk);
    else
#endif
    for (r = 0; r < g; ++r) {
        const uint8_t *s0 = src + (size_t)r * (size_t)sstride;
        const uint8_t *s1 = s0 + sstride;
        const uint8_t *s2 = s1 + sstride;
        int16_t *t0 = wk->tv0, *t1 = wk->tv1;
        int16_t *dx = wk->gx + (size_t)r * (size_t)g, *dy = wk->gy + (size_t)r * (size_t)g;
        for (c = 0; c < p; ++c) {
            t0[c] = (int16_t)(3 * (s0[c] + s2[c]) + 10 * s1[c]);
            t1[c] = (int16_t)(s2[c] - s0[c]);
        }
        for (c = 0; c < g; ++c) {
            dx[c] = (int16_t)(t0[c + 2] - t0[c]);
            dy[c] = (int16_t)(3 * (t1[c] + t1[c + 2]) + 10 * t1[c + 1]);
        }
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
        lk_prev_interp_simd(src + sstride + 1, sstride, wt, wk, A);
        return;
    }
#endif
    for (y = 0; y < win; ++y) {
        const uint8_t *s0 = src + (size_t)(y + 1) * (size_t)sstride + 1;
        const uint8_t *s1 = s0 + sstride;
        const int16_t *gx0 = wk->gx + (size_t)y * (size_t)g, *gx1 = gx0 + g;
        const int16_t *gy0 = wk->gy + (size_t)y * (size_t)g, *gy1 = gy0 + g;
        int16_t *iw = wk->iwin + (size_t)y * (size_t)win;
        int16_t *ixw = wk->ixwin + (size_t)y * (size_t)win;
        int16_t *iyw = wk->iywin + (size_t)y * (size_t)win;
        int32_t r11 = 0, r12 = 0, r22 = 0;
        for (x = 0; x < win; ++x) {
            int32_t iv = (s0[x] * w00 + s0[x + 1] * w01 + s1[x] * w10 + s1[x + 1] * w11 + LK_I_ROUND) >> LK_I_SHIFT;
            int32_t dxv = ((gx0[x] * w00 + gx0[x + 1] * w01 + gx1[x] * w10 + gx1[x + 1] * w11 + LK_D_ROUND) >> LK_W_BITS) - LK_D_BIAS;
            int32_t dyv = ((gy0[x] * w00 + gy0[x + 1] * w01 + gy1[x] * w10 + gy1[x + 1] * w11 + LK_D_ROUND) >> LK_W_BITS) - LK_D_BIAS;
            iw[x] = (int16_t)iv;
            ixw[x] = (int16_t)dxv;
            iyw[x] = (int16_t)dyv;
            r11 += dxv * dxv;
            r12 += dxv * dyv;
            r22 += dyv * dyv;
        }
        a11 += r11;
        a12 += r12;
        a22 += r22;
    }
    A[0] = a11;
    A[1] = a12;
    A[2] = a22;
}

/* Sums of (J(window) - I) * Ix and * Iy with J sampled at (jx + a, jy + b) (weights wt), src the
 * top-left of the (win+1)^2 J block with its stride. */
static void lk_mismatch(const uint8_t *src, int32_t sstride, const int32_t wt[4], const lk_work *wk,
                        int64_t *b1, int64_t *b2)
{
    const int32_t win = wk->win;
    const int32_t w00 = wt[0], w01 = wt[1], w10 = wt[2], w11 = wt[3];
    int64_t s1 = 0, s2 = 0;
    int32_t x, y;
    for (y = 0; y < win; ++y) {
        const uint8_t *j0 = src + (size_t)y * (size_t)sstride, *j1 = j0 + sstride;
        const int16_t *iw = wk->iwin + (size_t)y * (size_t)win;
        const int16_t *ixw = wk->ixwin + (size_t)y * (size_t)win;
        const int16_t *iyw = wk->iywin + (size_t)y * (size_t)win;
        int32_t r1 = 0, r2 = 0;
        for (x = 0; x < win; ++x) {
            int32_t jv = (j0[x] * w00 + j0[x + 1] * w01 + j1[x] * w10 + j1[x + 1] * w11 + LK_I_ROUND) >> LK_I_SHIFT;
            int32_t d = jv - iw[x];
            r1 += d * ixw[x];
            r2 += d * iyw[x];
        }
        s1 += r1;
        s2 += r2;
    }
    *b1 = s1;
    *b2 = s2;
}

#if LK_SSE2
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
            lk_mismatch_row_sse2(&st, j + 2 * sstride, iw + win, ixw + win, iyw + win, w01, w23, masked, mask);
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
#endif

/* Sum of |J(window) - I| (OpenCV's error before scaling). */
static int32_t lk_abs_error(const uint8_t *src, int32_t sstride, const int32_t wt[4], const lk_work *wk)
{
    const int32_t win = wk->win;
    int32_t x, y, s = 0;
    for (y = 0; y < win; ++y) {
        const uint8_t *j0 = src + (size_t)y * (size_t)sstride, *j1 = j0 + sstride;
        const int16_t *iw = wk->iwin + (size_t)y * (size_t)win;
        for (x = 0; x < win; ++x) {
            int32_t jv = (j0[x] * wt[0] + j0[x + 1] * wt[1] + j1[x] * wt[2] + j1[x + 1] * wt[3] + LK_I_ROUND) >> LK_I_SHIFT;
            int32_t d = jv - iw[x];
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
static const uint8_t *lk_next_block(const lk_level *lv, int32_t jx, int32_t jy, lk_work *wk,
                                    int32_t *sstride)
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
            lk_mismatch_simd(blk, sstride, wt, wk, &ib1, &ib2);
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
                              const tvo_point2f *prev_pts, tvo_point2f *next_pts, int32_t n,
                              void *scratch, size_t scratch_size)
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

tvo_status tvo_lk_track(const tvo_lk_config *cfg, const tvo_pyramid *prev, const tvo_pyramid *next,
                        const tvo_point2f *prev_pts, tvo_point2f *next_pts, uint8_t *status, float *err,
                        int32_t n, void *scratch, size_t scratch_size)
{
    lk_work wk;
    lk_params prm;
    int32_t i, top;
    tvo_status st;

    if (status == NULL)
        return TVO_ERR_NULL;
    st = lk_validate(cfg, prev, next, prev_pts, next_pts, n, scratch, scratch_size);
    if (st == TVO_OK)
        st = lk_work_init(&wk, cfg->win_size, scratch, scratch_size);
    if (st != TVO_OK) {
        if (n > 0)
            memset(status, TVO_LK_LOST, (size_t)n);
        return st;
    }

    prm.win = cfg->win_size;
    prm.max_iters = cfg->max_iters;
    prm.eps2 = (double)cfg->epsilon * (double)cfg->epsilon;
    prm.min_eig = cfg->min_eig_threshold;
    prm.simd = lk_use_simd(cfg);

    /* as OpenCV: levels whose size is <= the window are not used */
    top = cfg->max_level;
    while (top > 0 && (prev->width[top] <= prm.win || prev->height[top] <= prm.win))
        --top;

    for (i = 0; i < n; ++i) {
        float x0 = prev_pts[i].x, y0 = prev_pts[i].y;
        float nx = next_pts[i].x, ny = next_pts[i].y;
        const float gx = nx - x0, gy = ny - y0; /* the guess's displacement (use_initial_flow) */
        float e = 0.f;
        int ok = lk_track_point(&prm, prev, next, top, x0, y0, cfg->use_initial_flow != 0, &nx, &ny, &wk,
                                err != NULL ? &e : NULL);
        if (ok && cfg->fb_check) {
            /* the way back starts at the guess's displacement reversed (no displacement without a guess) */
            float bx = cfg->use_initial_flow ? nx - gx : nx, by = cfg->use_initial_flow ? ny - gy : ny, ddx, ddy;
            int back = lk_track_point(&prm, next, prev, top, nx, ny, cfg->use_initial_flow != 0, &bx, &by, &wk, NULL);
            ddx = bx - x0;
            ddy = by - y0;
            if (!back || !((double)ddx * ddx + (double)ddy * ddy <=
                           (double)cfg->fb_max_error * (double)cfg->fb_max_error)) {
                ok = 0;
                e = 0.f;
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
