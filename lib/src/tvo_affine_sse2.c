/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the affine refinement's window sums in SSE2 (x86; see tvo_affine.h). The same float
 * operations in the same order as tvo_aff_sums_portable() in tvo_affine.c, four pixel columns at a
 * time, so the same bits: positions bx + ax j, truncation to integers, bilinear sampling from the two
 * byte pairs at each position, the products with the template's arrays, four lane sums per row added
 * as (0 + 1) + (2 + 3), the rows in double. */
#include "tinyvo/options.h"
#include "tvo_affine.h"

#if TVO_WITH_AFFINE && TVO_AFF_SSE2
#include <emmintrin.h>
#include <string.h>

/* (l0 + l1) + (l2 + l3) of the four lanes of v. */
static inline float hsum(__m128 v)
{
    const __m128 s = _mm_add_ps(v, _mm_shuffle_ps(v, v, _MM_SHUFFLE(2, 3, 0, 1)));
    return _mm_cvtss_f32(_mm_add_ss(s, _mm_movehl_ps(s, s)));
}

/* The 16 bits at p (x86 reads them unaligned). */
static inline int load16(const uint8_t *p)
{
    uint16_t v;
    memcpy(&v, p, sizeof(v));
    return v;
}

/* One row of the window: column positions bx + ax fj, by + ay fj (fj, xf, in: the chunks' sample
 * columns, template x and inside masks); the four lane sums of the seven products into acc. in_float
 * says how the four pixels' byte offsets are found: in float (exact when every offset is below 2^24),
 * or in integers. */
static inline void row_sums(const tvo_image *img, const float *gx, const float *gy, const float *tf,
                            int32_t cols, __m128 bx, __m128 by, __m128 ax, __m128 ay, const __m128 *fjs,
                            const __m128 *xfs, const __m128 *ins, int in_float, __m128 acc[7])
{
    const size_t stride = (size_t)img->stride;
    const __m128 fstride = _mm_set1_ps((float)img->stride);
    const __m128i bytes = _mm_set1_epi16(0xff), zero = _mm_setzero_si128();
    for (int32_t j = 0, c = 0; j < cols; j += 4, ++c) {
        const __m128 px = _mm_add_ps(bx, _mm_mul_ps(ax, fjs[c])), py = _mm_add_ps(by, _mm_mul_ps(ay, fjs[c]));
        const __m128i ixv = _mm_cvttps_epi32(px), iyv = _mm_cvttps_epi32(py);
        const __m128 ixf = _mm_cvtepi32_ps(ixv), iyf = _mm_cvtepi32_ps(iyv);
        const __m128 fx = _mm_sub_ps(px, ixf), fy = _mm_sub_ps(py, iyf);
        const uint8_t *p0, *p1, *p2, *p3;
        __m128i w = zero, lo, hi, t0, t1, b0, b1;
        __m128 top, bot, v, vm, a, b;
        if (in_float) {
            const __m128i off = _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(iyf, fstride), ixf));
            p0 = img->data + (uint32_t)_mm_cvtsi128_si32(off);
            p1 = img->data + (uint32_t)_mm_cvtsi128_si32(_mm_shuffle_epi32(off, _MM_SHUFFLE(1, 1, 1, 1)));
            p2 = img->data + (uint32_t)_mm_cvtsi128_si32(_mm_shuffle_epi32(off, _MM_SHUFFLE(2, 2, 2, 2)));
            p3 = img->data + (uint32_t)_mm_cvtsi128_si32(_mm_shuffle_epi32(off, _MM_SHUFFLE(3, 3, 3, 3)));
        } else {
            int32_t ix[4], iy[4];
            _mm_storeu_si128((__m128i *)ix, ixv);
            _mm_storeu_si128((__m128i *)iy, iyv);
            p0 = img->data + (size_t)iy[0] * stride + (size_t)ix[0];
            p1 = img->data + (size_t)iy[1] * stride + (size_t)ix[1];
            p2 = img->data + (size_t)iy[2] * stride + (size_t)ix[2];
            p3 = img->data + (size_t)iy[3] * stride + (size_t)ix[3];
        }
        /* words 0..3: the pairs (p[0], p[1]) of the four pixels, words 4..7: the pairs below them */
        w = _mm_insert_epi16(w, load16(p0), 0);
        w = _mm_insert_epi16(w, load16(p1), 1);
        w = _mm_insert_epi16(w, load16(p2), 2);
        w = _mm_insert_epi16(w, load16(p3), 3);
        w = _mm_insert_epi16(w, load16(p0 + stride), 4);
        w = _mm_insert_epi16(w, load16(p1 + stride), 5);
        w = _mm_insert_epi16(w, load16(p2 + stride), 6);
        w = _mm_insert_epi16(w, load16(p3 + stride), 7);
        lo = _mm_and_si128(w, bytes); /* p[0] (x86 is little-endian) */
        hi = _mm_srli_epi16(w, 8);    /* p[1] */
        t0 = _mm_unpacklo_epi16(lo, zero);
        t1 = _mm_unpacklo_epi16(hi, zero);
        b0 = _mm_unpackhi_epi16(lo, zero);
        b1 = _mm_unpackhi_epi16(hi, zero);
        top = _mm_add_ps(_mm_cvtepi32_ps(t0), _mm_mul_ps(fx, _mm_cvtepi32_ps(_mm_sub_epi32(t1, t0))));
        bot = _mm_add_ps(_mm_cvtepi32_ps(b0), _mm_mul_ps(fx, _mm_cvtepi32_ps(_mm_sub_epi32(b1, b0))));
        v = _mm_add_ps(top, _mm_mul_ps(fy, _mm_sub_ps(bot, top)));
        vm = _mm_and_ps(v, ins[c]);
        a = _mm_mul_ps(_mm_loadu_ps(gx + j), v);
        b = _mm_mul_ps(_mm_loadu_ps(gy + j), v);
        acc[0] = _mm_add_ps(acc[0], a);
        acc[1] = _mm_add_ps(acc[1], _mm_mul_ps(a, xfs[c]));
        acc[2] = _mm_add_ps(acc[2], b);
        acc[3] = _mm_add_ps(acc[3], _mm_mul_ps(b, xfs[c]));
        acc[4] = _mm_add_ps(acc[4], vm);
        acc[5] = _mm_add_ps(acc[5], _mm_mul_ps(vm, vm));
        acc[6] = _mm_add_ps(acc[6], _mm_mul_ps(vm, _mm_loadu_ps(tf + j)));
    }
}

void tvo_aff_sums_simd(const tvo_image *img, const float *gx, const float *gy, const float *tf, int32_t side,
                       int32_t step, const double A[4], const double t[2], tvo_aff_sums *s)
{
    const int32_t h = side / 2, m = tvo_aff_samples(side, step), cols = tvo_aff_cols(m);
    const __m128 ax = _mm_set1_ps((float)A[0]), ay = _mm_set1_ps((float)A[2]);
    /* every byte offset of the image below 2^24: the pixel offsets are computed in float, exactly */
    const int in_float = (double)img->stride * (double)img->height < 16777216.0;
    __m128 fjs[TVO_AFF_MAX_SIDE / 4 + 1], xfs[TVO_AFF_MAX_SIDE / 4 + 1], ins[TVO_AFF_MAX_SIDE / 4 + 1];
    /* per chunk of four columns: the sample's column in the window (a padding column repeats the last
       sample), its template x, and whether it is a sample at all */
    for (int32_t j = 0, c = 0; j < cols; j += 4, ++c) {
        const __m128 jv = _mm_add_ps(_mm_set1_ps((float)j), _mm_setr_ps(0.0f, 1.0f, 2.0f, 3.0f));
        fjs[c] = _mm_mul_ps(_mm_min_ps(jv, _mm_set1_ps((float)(m - 1))), _mm_set1_ps((float)step));
        xfs[c] = _mm_sub_ps(_mm_mul_ps(jv, _mm_set1_ps((float)step)), _mm_set1_ps((float)h));
        ins[c] = _mm_cmplt_ps(jv, _mm_set1_ps((float)m));
    }
    memset(s, 0, sizeof(*s));
    for (int32_t r = 0; r < m; ++r) {
        const int32_t yy = r * step - h;
        const size_t row = (size_t)r * (size_t)cols;
        const __m128 bx = _mm_set1_ps((float)(A[0] * -h + A[1] * yy + t[0]));
        const __m128 by = _mm_set1_ps((float)(A[2] * -h + A[3] * yy + t[1]));
        __m128 acc[7];
        float rs[7];
        for (int k = 0; k < 7; ++k)
            acc[k] = _mm_setzero_ps();
        if (in_float)
            row_sums(img, gx + row, gy + row, tf + row, cols, bx, by, ax, ay, fjs, xfs, ins, 1, acc);
        else
            row_sums(img, gx + row, gy + row, tf + row, cols, bx, by, ax, ay, fjs, xfs, ins, 0, acc);
        for (int k = 0; k < 7; ++k)
            rs[k] = hsum(acc[k]);
        tvo_aff_add_row(s, rs, yy);
    }
}
#else
/* without SSE2 (or the affine refinement) the portable kernel of tvo_affine.c is the only one; ISO C
 * wants a declaration in every translation unit */
typedef int tvo_affine_sse2_left_out;
#endif
