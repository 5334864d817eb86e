/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the affine refinement's window sums in SSE2 (x86; see tvo_affine.h). The same float
 * operations in the same order as tvo_aff_sums_portable() in tvo_affine.c, four pixel columns at a
 * time, so the same bits: positions bx + ax j, truncation to integers, bilinear sampling from the two
 * byte pairs at each position, the products with the template's arrays, four lane sums per row added
 * as (0 + 1) + (2 + 3), the rows in double.
 *
 * What is not the portable kernel's order is only what gives the same bits any way: ax and ay times
 * the sample columns are the same products in every row and are taken once per window; a chunk whose
 * lanes are all samples skips the mask (v & all ones is v); the last chunk of a window of 4 k + 1
 * samples, whose four lanes sample one pixel, loads that pixel's pairs once; the seven lane sums of a
 * row are added four at a time, and the rows' sums go into the window's two doubles per operation.
 * Reading the pairs of a chunk whose four pixels are consecutive in one row with two 4-byte loads per
 * row, instead of the eight pinsrw, does not pay in instructions: the test costs about what the loads
 * save, and on KITTI 07 it fails for half of the chunks (ax away from 1), 7 % more on the whole. */
#include "tinyvo/options.h"
#include "tvo_affine.h"

#if TVO_WITH_AFFINE && TVO_AFF_SSE2
#include <emmintrin.h>
#include <string.h>

/* The helpers are inlined into a window loop specialised for the way the pixel offsets are found, the
 * window's state (lane sums, row positions) in registers. */
#if defined(__GNUC__)
#define AFF_INLINE static inline __attribute__((always_inline))
#else
#define AFF_INLINE static inline
#endif

/* The 16 bits at p (x86 reads them unaligned). */
static inline int load16(const uint8_t *p)
{
    uint16_t v;
    memcpy(&v, p, sizeof(v));
    return v;
}

/* (l0 + l1) + (l2 + l3) of the four lanes of each of a, b, c, d, in lanes 0..3 (the portable kernel's
 * order): the sums of adjacent lanes of a and b and of c and d, then the sums of adjacent lanes of those. */
AFF_INLINE __m128 hsum4(__m128 a, __m128 b, __m128 c, __m128 d)
{
    const __m128 ab = _mm_add_ps(_mm_shuffle_ps(a, b, _MM_SHUFFLE(2, 0, 2, 0)),
                                 _mm_shuffle_ps(a, b, _MM_SHUFFLE(3, 1, 3, 1))); /* a0+a1 a2+a3 b0+b1 b2+b3 */
    const __m128 cd = _mm_add_ps(_mm_shuffle_ps(c, d, _MM_SHUFFLE(2, 0, 2, 0)),
                                 _mm_shuffle_ps(c, d, _MM_SHUFFLE(3, 1, 3, 1)));
    return _mm_add_ps(_mm_shuffle_ps(ab, cd, _MM_SHUFFLE(2, 0, 2, 0)),
                      _mm_shuffle_ps(ab, cd, _MM_SHUFFLE(3, 1, 3, 1)));
}

/* Kinds of column chunks: four samples (FULL); the row's last chunk, whose lanes past the window's last
 * sample repeat that sample's position (the window's fj), with one sample (LAST_ONE: all four lanes on
 * one pixel) or three (LAST_THREE). */
enum { FULL, LAST_ONE, LAST_THREE };

/* One chunk of four columns: positions px, py, template x xf, inside mask in; the seven products added
 * to the lane sums acc. in_float says how the four pixels' byte offsets are found: in float (exact when
 * every offset is below 2^24), or in integers. */
AFF_INLINE void chunk(const tvo_image *img, const float *gx, const float *gy, const float *tf, __m128 px,
                      __m128 py, __m128 xf, __m128 in, int in_float, int kind, __m128 acc[7])
{
    const size_t stride = (size_t)img->stride;
    const uint8_t *const top = img->data, *const below = img->data + stride;
    const __m128i ixv = _mm_cvttps_epi32(px), iyv = _mm_cvttps_epi32(py);
    const __m128 ixf = _mm_cvtepi32_ps(ixv), iyf = _mm_cvtepi32_ps(iyv);
    const __m128 fx = _mm_sub_ps(px, ixf), fy = _mm_sub_ps(py, iyf);
    const __m128i zero = _mm_setzero_si128(), bytes = _mm_set1_epi32(0xff);
    size_t off[4]; /* the four pixels' byte offsets from the image's first */
    __m128i wt, wb, t0, t1, b0, b1;
    __m128 tv, bv, v, vm, a, b;
    if (in_float) {
        const __m128i o = _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(iyf, _mm_set1_ps((float)img->stride)), ixf));
        off[0] = (uint32_t)_mm_cvtsi128_si32(o);
        off[1] = (uint32_t)_mm_cvtsi128_si32(_mm_shuffle_epi32(o, _MM_SHUFFLE(1, 1, 1, 1)));
        off[2] = (uint32_t)_mm_cvtsi128_si32(_mm_shuffle_epi32(o, _MM_SHUFFLE(2, 2, 2, 2)));
        off[3] = (uint32_t)_mm_cvtsi128_si32(_mm_shuffle_epi32(o, _MM_SHUFFLE(3, 3, 3, 3)));
    } else {
        int32_t ix[4], iy[4];
        _mm_storeu_si128((__m128i *)ix, ixv);
        _mm_storeu_si128((__m128i *)iy, iyv);
        for (int l = 0; l < 4; ++l)
            off[l] = (size_t)iy[l] * stride + (size_t)ix[l];
    }
    if (kind == LAST_ONE) {
        /* the one pixel's pair (p[0], p[1]) in every lane of wt, the pair below it in wb's */
        wt = _mm_shuffle_epi32(_mm_cvtsi32_si128(load16(top + off[0])), 0);
        wb = _mm_shuffle_epi32(_mm_cvtsi32_si128(load16(below + off[0])), 0);
    } else {
        /* lane l of wt: the pair (p[0], p[1]) of pixel l in its low 16 bits, of wb: the pair below */
        wt = _mm_insert_epi16(zero, load16(top + off[0]), 0);
        wb = _mm_insert_epi16(zero, load16(below + off[0]), 0);
        wt = _mm_insert_epi16(wt, load16(top + off[1]), 2);
        wb = _mm_insert_epi16(wb, load16(below + off[1]), 2);
        wt = _mm_insert_epi16(wt, load16(top + off[2]), 4);
        wb = _mm_insert_epi16(wb, load16(below + off[2]), 4);
        wt = _mm_insert_epi16(wt, load16(top + off[3]), 6);
        wb = _mm_insert_epi16(wb, load16(below + off[3]), 6);
    }
    t0 = _mm_and_si128(wt, bytes); /* p[0] (x86 is little-endian) */
    t1 = _mm_srli_epi32(wt, 8);    /* p[1] */
    b0 = _mm_and_si128(wb, bytes);
    b1 = _mm_srli_epi32(wb, 8);
    tv = _mm_add_ps(_mm_cvtepi32_ps(t0), _mm_mul_ps(fx, _mm_cvtepi32_ps(_mm_sub_epi32(t1, t0))));
    bv = _mm_add_ps(_mm_cvtepi32_ps(b0), _mm_mul_ps(fx, _mm_cvtepi32_ps(_mm_sub_epi32(b1, b0))));
    v = _mm_add_ps(tv, _mm_mul_ps(fy, _mm_sub_ps(bv, tv)));
    vm = kind == FULL ? v : _mm_and_ps(v, in); /* a full chunk's mask is all ones */
    a = _mm_mul_ps(_mm_loadu_ps(gx), v);
    b = _mm_mul_ps(_mm_loadu_ps(gy), v);
    acc[0] = _mm_add_ps(acc[0], a);
    acc[1] = _mm_add_ps(acc[1], _mm_mul_ps(a, xf));
    acc[2] = _mm_add_ps(acc[2], b);
    acc[3] = _mm_add_ps(acc[3], _mm_mul_ps(b, xf));
    acc[4] = _mm_add_ps(acc[4], vm);
    acc[5] = _mm_add_ps(acc[5], _mm_mul_ps(vm, vm));
    acc[6] = _mm_add_ps(acc[6], _mm_mul_ps(vm, _mm_loadu_ps(tf)));
}

/* The window's sums (tvo_aff_sums_simd), the pixel offsets found as in_float says (see chunk()). */
AFF_INLINE void window(const tvo_image *img, const float *gx, const float *gy, const float *tf, int32_t side,
                       int32_t step, const double A[4], const double t[2], int in_float, tvo_aff_sums *s)
{
    const int32_t h = side / 2, m = tvo_aff_samples(side, step), cols = tvo_aff_cols(m), full = m / 4;
    const int last = m % 4 == 1 ? LAST_ONE : LAST_THREE; /* m is odd */
    const __m128 ax = _mm_set1_ps((float)A[0]), ay = _mm_set1_ps((float)A[2]);
    /* x in the low lane, y in the high one: A[0] -h and A[2] -h, A[1] and A[3], t */
    const __m128d ah = _mm_mul_pd(_mm_setr_pd(A[0], A[2]), _mm_set1_pd((double)-h));
    const __m128d av = _mm_setr_pd(A[1], A[3]), tv = _mm_loadu_pd(t);
    __m128 axf[TVO_AFF_MAX_SIDE / 4 + 1], ayf[TVO_AFF_MAX_SIDE / 4 + 1], xfs[TVO_AFF_MAX_SIDE / 4 + 1],
            ins[TVO_AFF_MAX_SIDE / 4 + 1];
    /* the window's sums: sdi[0..1], sdi[2..3], sdi[4..5], sum_i and sum_i2, sum_it (low lane) */
    __m128d s01 = _mm_setzero_pd(), s23 = s01, s45 = s01, si = s01, sit = s01;
    /* per chunk of four columns: ax and ay times the sample's column in the window (a padding column
       repeats the last sample), its template x, and whether it is a sample at all */
    for (int32_t j = 0, c = 0; j < cols; j += 4, ++c) {
        const __m128 jv = _mm_add_ps(_mm_set1_ps((float)j), _mm_setr_ps(0.0f, 1.0f, 2.0f, 3.0f));
        const __m128 fj = _mm_mul_ps(_mm_min_ps(jv, _mm_set1_ps((float)(m - 1))), _mm_set1_ps((float)step));
        axf[c] = _mm_mul_ps(ax, fj);
        ayf[c] = _mm_mul_ps(ay, fj);
        xfs[c] = _mm_sub_ps(_mm_mul_ps(jv, _mm_set1_ps((float)step)), _mm_set1_ps((float)h));
        ins[c] = _mm_cmplt_ps(jv, _mm_set1_ps((float)m));
    }
    for (int32_t r = 0; r < m; ++r) {
        const int32_t yy = r * step - h;
        const float *const rx = gx + (size_t)r * (size_t)cols, *const ry = gy + (size_t)r * (size_t)cols,
                           *const rt = tf + (size_t)r * (size_t)cols;
        const __m128d yd = _mm_set1_pd((double)yy);
        /* bx, by: A[0] -h + A[1] yy + t[0] and the same for y, in double, rounded to float */
        const __m128 b = _mm_cvtpd_ps(_mm_add_pd(_mm_add_pd(ah, _mm_mul_pd(av, yd)), tv));
        const __m128 bx = _mm_shuffle_ps(b, b, _MM_SHUFFLE(0, 0, 0, 0)),
                     by = _mm_shuffle_ps(b, b, _MM_SHUFFLE(1, 1, 1, 1));
        __m128 acc[7], r03, r46;
        __m128d d01, d23, m01, m23;
        int32_t c;
        for (int k = 0; k < 7; ++k)
            acc[k] = _mm_setzero_ps();
        for (c = 0; c < full; ++c)
            chunk(img, rx + 4 * c, ry + 4 * c, rt + 4 * c, _mm_add_ps(bx, axf[c]), _mm_add_ps(by, ayf[c]),
                  xfs[c], ins[c], in_float, FULL, acc);
        chunk(img, rx + 4 * c, ry + 4 * c, rt + 4 * c, _mm_add_ps(bx, axf[c]), _mm_add_ps(by, ayf[c]), xfs[c],
              ins[c], in_float, last, acc);
        /* the row's sums r[0..3] and r[4..6] (tvo_aff_add_row), added to the window's in double */
        r03 = hsum4(acc[0], acc[1], acc[2], acc[3]);
        r46 = hsum4(acc[4], acc[5], acc[6], _mm_setzero_ps());
        d01 = _mm_cvtps_pd(r03);
        d23 = _mm_cvtps_pd(_mm_movehl_ps(r03, r03));
        m01 = _mm_mul_sd(d01, yd);                          /* r[0] yy, r[1] */
        m23 = _mm_mul_sd(d23, yd);                          /* r[2] yy, r[3] */
        s01 = _mm_add_pd(s01, _mm_shuffle_pd(m01, m01, 1)); /* sdi[0] += r[1], sdi[1] += r[0] yy */
        s23 = _mm_add_pd(s23, _mm_shuffle_pd(m23, m23, 1)); /* sdi[2] += r[3], sdi[3] += r[2] yy */
        s45 = _mm_add_pd(s45, _mm_unpacklo_pd(d01, d23));   /* sdi[4] += r[0], sdi[5] += r[2] */
        si = _mm_add_pd(si, _mm_cvtps_pd(r46));
        sit = _mm_add_sd(sit, _mm_cvtps_pd(_mm_movehl_ps(r46, r46)));
    }
    _mm_storeu_pd(s->sdi, s01);
    _mm_storeu_pd(s->sdi + 2, s23);
    _mm_storeu_pd(s->sdi + 4, s45);
    _mm_storel_pd(&s->sum_i, si);
    _mm_storeh_pd(&s->sum_i2, si);
    _mm_storel_pd(&s->sum_it, sit);
}

void tvo_aff_sums_simd(const tvo_image *img, const float *gx, const float *gy, const float *tf, int32_t side,
                       int32_t step, const double A[4], const double t[2], tvo_aff_sums *s)
{
    /* every byte offset of the image below 2^24: the pixel offsets are computed in float, exactly */
    if ((double)img->stride * (double)img->height < 16777216.0)
        window(img, gx, gy, tf, side, step, A, t, 1, s);
    else
        window(img, gx, gy, tf, side, step, A, t, 0, s);
}
#else
/* without SSE2 (or the affine refinement) the portable kernel of tvo_affine.c is the only one; ISO C
 * wants a declaration in every translation unit */
typedef int tvo_affine_sse2_left_out;
#endif
