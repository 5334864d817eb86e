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

/* The byte pair (p[0], p[1]) of each of four pointers, as two int32 vectors (x86 is little-endian). */
static inline void pairs(const uint8_t *const p[4], size_t off, __m128i *lo, __m128i *hi)
{
    uint16_t q[4];
    __m128i v;
    for (int l = 0; l < 4; ++l)
        memcpy(&q[l], p[l] + off, sizeof(q[l]));
    v = _mm_setr_epi32(q[0], q[1], q[2], q[3]);
    *lo = _mm_and_si128(v, _mm_set1_epi32(0xff));
    *hi = _mm_srli_epi32(v, 8);
}

void tvo_aff_sums_sse2(const tvo_image *img, const float *gx, const float *gy, const float *tf, int32_t side,
                       int32_t step, const double A[4], const double t[2], tvo_aff_sums *s)
{
    const int32_t h = side / 2, m = tvo_aff_samples(side, step), cols = tvo_aff_cols(m);
    const size_t stride = (size_t)img->stride;
    const __m128 ax = _mm_set1_ps((float)A[0]), ay = _mm_set1_ps((float)A[2]);
    const __m128 last = _mm_set1_ps((float)(m - 1)), nm = _mm_set1_ps((float)m),
                 fstep = _mm_set1_ps((float)step);
    const __m128 lanes = _mm_setr_ps(0.0f, 1.0f, 2.0f, 3.0f);
    const __m128 fstride = _mm_set1_ps((float)img->stride);
    /* every offset of the image below 2^24: the pixel offsets are computed in float, exactly */
    const int small = (double)img->stride * (double)img->height < 16777216.0;
    memset(s, 0, sizeof(*s));
    for (int32_t r = 0; r < m; ++r) {
        const int32_t yy = r * step - h;
        const size_t row = (size_t)r * (size_t)cols;
        const __m128 bx = _mm_set1_ps((float)(A[0] * -h + A[1] * yy + t[0]));
        const __m128 by = _mm_set1_ps((float)(A[2] * -h + A[3] * yy + t[1]));
        __m128 acc[7];
        for (int k = 0; k < 7; ++k)
            acc[k] = _mm_setzero_ps();
        for (int32_t j = 0; j < cols; j += 4) {
            const __m128 jv = _mm_add_ps(_mm_set1_ps((float)j), lanes);
            const __m128 fj = _mm_mul_ps(_mm_min_ps(jv, last), fstep);
            const __m128 xf = _mm_sub_ps(_mm_mul_ps(jv, fstep), _mm_set1_ps((float)h));
            const __m128 inside = _mm_cmplt_ps(jv, nm);
            const __m128 px = _mm_add_ps(bx, _mm_mul_ps(ax, fj)), py = _mm_add_ps(by, _mm_mul_ps(ay, fj));
            const __m128i ixv = _mm_cvttps_epi32(px), iyv = _mm_cvttps_epi32(py);
            const __m128 fx = _mm_sub_ps(px, _mm_cvtepi32_ps(ixv)), fy = _mm_sub_ps(py, _mm_cvtepi32_ps(iyv));
            const uint8_t *p[4];
            __m128i t0, t1, b0, b1;
            __m128 top, bot, v, vm, a, b;
            if (small) { /* iy stride + ix in float is exact below 2^24 */
                const __m128i off = _mm_cvttps_epi32(
                        _mm_add_ps(_mm_mul_ps(_mm_cvtepi32_ps(iyv), fstride), _mm_cvtepi32_ps(ixv)));
                p[0] = img->data + _mm_cvtsi128_si32(off);
                p[1] = img->data + _mm_cvtsi128_si32(_mm_shuffle_epi32(off, _MM_SHUFFLE(1, 1, 1, 1)));
                p[2] = img->data + _mm_cvtsi128_si32(_mm_shuffle_epi32(off, _MM_SHUFFLE(2, 2, 2, 2)));
                p[3] = img->data + _mm_cvtsi128_si32(_mm_shuffle_epi32(off, _MM_SHUFFLE(3, 3, 3, 3)));
            } else {
                int32_t ix[4], iy[4];
                _mm_storeu_si128((__m128i *)ix, ixv);
                _mm_storeu_si128((__m128i *)iy, iyv);
                for (int l = 0; l < 4; ++l)
                    p[l] = img->data + (size_t)iy[l] * stride + (size_t)ix[l];
            }
            pairs(p, 0, &t0, &t1);
            pairs(p, stride, &b0, &b1);
            top = _mm_add_ps(_mm_cvtepi32_ps(t0), _mm_mul_ps(fx, _mm_cvtepi32_ps(_mm_sub_epi32(t1, t0))));
            bot = _mm_add_ps(_mm_cvtepi32_ps(b0), _mm_mul_ps(fx, _mm_cvtepi32_ps(_mm_sub_epi32(b1, b0))));
            v = _mm_add_ps(top, _mm_mul_ps(fy, _mm_sub_ps(bot, top)));
            vm = _mm_and_ps(v, inside);
            a = _mm_mul_ps(_mm_loadu_ps(gx + row + (size_t)j), v);
            b = _mm_mul_ps(_mm_loadu_ps(gy + row + (size_t)j), v);
            acc[0] = _mm_add_ps(acc[0], a);
            acc[1] = _mm_add_ps(acc[1], _mm_mul_ps(a, xf));
            acc[2] = _mm_add_ps(acc[2], b);
            acc[3] = _mm_add_ps(acc[3], _mm_mul_ps(b, xf));
            acc[4] = _mm_add_ps(acc[4], vm);
            acc[5] = _mm_add_ps(acc[5], _mm_mul_ps(vm, vm));
            acc[6] = _mm_add_ps(acc[6], _mm_mul_ps(vm, _mm_loadu_ps(tf + row + (size_t)j)));
        }
        {
            float rs[7];
            for (int k = 0; k < 7; ++k)
                rs[k] = hsum(acc[k]);
            tvo_aff_add_row(s, rs, yy);
        }
    }
}
#else
/* without SSE2 (or the affine refinement) the portable kernel of tvo_affine.c is the only one; ISO C
 * wants a declaration in every translation unit */
typedef int tvo_affine_sse2_left_out;
#endif
