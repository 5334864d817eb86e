/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the affine refinement's per-row template work in SSE2 (x86; see tvo_affine.h): tvo_aff_take's
 * integer row sums and tvo_aff_refine's gradients, 8 columns at a time. The row sums are integers, so
 * any order of the additions gives take_row()'s (tvo_affine.c) as long as nothing overflows (bounds
 * below); the gradients are exact floats, computed as gradients() computes them. */
#include "tinyvo/options.h"
#include "tvo_affine.h"

#if TVO_WITH_AFFINE && TVO_AFF_SSE2
#include <emmintrin.h>
#include <string.h>

/* The 8 bytes at p as int16. */
static inline __m128i load8_epi16(const uint8_t *p)
{
    return _mm_unpacklo_epi8(_mm_loadl_epi64((const __m128i *)p), _mm_setzero_si128());
}

/* [sum of a's lanes, b's, c's, d's]. */
static inline __m128i hsum4_epi32(__m128i a, __m128i b, __m128i c, __m128i d)
{
    const __m128i ab = _mm_add_epi32(_mm_unpacklo_epi32(a, b), _mm_unpackhi_epi32(a, b));
    const __m128i cd = _mm_add_epi32(_mm_unpacklo_epi32(c, d), _mm_unpackhi_epi32(c, d));
    return _mm_add_epi32(_mm_unpacklo_epi64(ab, cd), _mm_unpackhi_epi64(ab, cd));
}

/* The sums of 8 columns from column c (template x in the lanes of x) into the int32 lanes of a, in
 * take_row()'s order of r[]; keep masks the lanes that count (dx, dy and T zeroed elsewhere, so every
 * product there is 0). _mm_madd_epi16 adds the products of two lanes: |dx x|, |dy x| <= 255 * 15 = 3825
 * fit int16, each lane of a gets at most 2 products a block and holds a part of the row's sum of their
 * magnitudes, below 2^31 (take_row()). */
static inline void take_block(const uint8_t *p, int32_t s, int32_t c, __m128i x, __m128i keep, __m128i a[19])
{
    const __m128i ones = _mm_set1_epi16(1);
    const __m128i t = _mm_and_si128(load8_epi16(p + c), keep);
    const __m128i dx = _mm_and_si128(_mm_sub_epi16(load8_epi16(p + c + 1), load8_epi16(p + c - 1)), keep);
    const __m128i dy = _mm_and_si128(_mm_sub_epi16(load8_epi16(p + c + s), load8_epi16(p + c - s)), keep);
    const __m128i dxx = _mm_mullo_epi16(dx, x), dyx = _mm_mullo_epi16(dy, x);
    a[0] = _mm_add_epi32(a[0], _mm_madd_epi16(dx, dx));
    a[1] = _mm_add_epi32(a[1], _mm_madd_epi16(dxx, dx));
    a[2] = _mm_add_epi32(a[2], _mm_madd_epi16(dxx, dxx));
    a[3] = _mm_add_epi32(a[3], _mm_madd_epi16(dx, dy));
    a[4] = _mm_add_epi32(a[4], _mm_madd_epi16(dxx, dy));
    a[5] = _mm_add_epi32(a[5], _mm_madd_epi16(dxx, dyx));
    a[6] = _mm_add_epi32(a[6], _mm_madd_epi16(dy, dy));
    a[7] = _mm_add_epi32(a[7], _mm_madd_epi16(dyx, dy));
    a[8] = _mm_add_epi32(a[8], _mm_madd_epi16(dyx, dyx));
    a[9] = _mm_add_epi32(a[9], _mm_madd_epi16(dx, t));
    a[10] = _mm_add_epi32(a[10], _mm_madd_epi16(dxx, t));
    a[11] = _mm_add_epi32(a[11], _mm_madd_epi16(dy, t));
    a[12] = _mm_add_epi32(a[12], _mm_madd_epi16(dyx, t));
    a[13] = _mm_add_epi32(a[13], _mm_madd_epi16(dx, ones));
    a[14] = _mm_add_epi32(a[14], _mm_madd_epi16(dxx, ones));
    a[15] = _mm_add_epi32(a[15], _mm_madd_epi16(dy, ones));
    a[16] = _mm_add_epi32(a[16], _mm_madd_epi16(dyx, ones));
    a[17] = _mm_add_epi32(a[17], _mm_madd_epi16(t, ones));
    a[18] = _mm_add_epi32(a[18], _mm_madd_epi16(t, t));
}

void tvo_aff_take_row_simd(const uint8_t *p, int32_t s, int32_t m, int32_t h, int32_t r[19])
{
    const __m128i iota = _mm_setr_epi16(0, 1, 2, 3, 4, 5, 6, 7), eight = _mm_set1_epi16(8);
    __m128i a[19], v[5], x = _mm_add_epi16(_mm_set1_epi16((short)-h), iota);
    int32_t c = 0, out[20];
    for (int k = 0; k < 19; ++k)
        a[k] = _mm_setzero_si128();
    for (; c + 8 <= m; c += 8, x = _mm_add_epi16(x, eight))
        take_block(p, s, c, x, _mm_set1_epi16(-1), a);
    if (c < m) {
        /* the last block ends at column m - 1: its lanes before column c were summed already */
        const __m128i cols = _mm_add_epi16(_mm_set1_epi16((short)(m - 8)), iota);
        take_block(p, s, m - 8, _mm_sub_epi16(x, _mm_set1_epi16((short)(c + 8 - m))),
                   _mm_cmpgt_epi16(cols, _mm_set1_epi16((short)(c - 1))), a);
    }
    v[0] = hsum4_epi32(a[0], a[1], a[2], a[3]);
    v[1] = hsum4_epi32(a[4], a[5], a[6], a[7]);
    v[2] = hsum4_epi32(a[8], a[9], a[10], a[11]);
    v[3] = hsum4_epi32(a[12], a[13], a[14], a[15]);
    v[4] = hsum4_epi32(a[16], a[17], a[18], _mm_setzero_si128());
    for (int k = 0; k < 5; ++k)
        _mm_storeu_si128((__m128i *)(out + 4 * k), v[k]);
    memcpy(r, out, 19 * sizeof(int32_t));
}

/* Lanes 0..3 (lo) or 4..7 (hi) of the int16 v as float. */
static inline __m128 lo_ps(__m128i v)
{
    return _mm_cvtepi32_ps(_mm_srai_epi32(_mm_unpacklo_epi16(v, v), 16));
}

static inline __m128 hi_ps(__m128i v)
{
    return _mm_cvtepi32_ps(_mm_srai_epi32(_mm_unpackhi_epi16(v, v), 16));
}

void tvo_aff_gradients_row_simd(const uint8_t *p, int32_t s, int32_t m, float *gx, float *gy, float *tf)
{
    const __m128 half = _mm_set1_ps(0.5f);
    const __m128i z = _mm_setzero_si128();
    for (int32_t c0 = 0; c0 < m; c0 += 8) {
        /* the last block ends at column m - 1, writing some columns again with the same values */
        const int32_t c = c0 + 8 <= m ? c0 : m - 8;
        const __m128i t = load8_epi16(p + c);
        const __m128i dx = _mm_sub_epi16(load8_epi16(p + c + 1), load8_epi16(p + c - 1));
        const __m128i dy = _mm_sub_epi16(load8_epi16(p + c + s), load8_epi16(p + c - s));
        _mm_storeu_ps(gx + c, _mm_mul_ps(half, lo_ps(dx)));
        _mm_storeu_ps(gx + c + 4, _mm_mul_ps(half, hi_ps(dx)));
        _mm_storeu_ps(gy + c, _mm_mul_ps(half, lo_ps(dy)));
        _mm_storeu_ps(gy + c + 4, _mm_mul_ps(half, hi_ps(dy)));
        _mm_storeu_ps(tf + c, _mm_cvtepi32_ps(_mm_unpacklo_epi16(t, z))); /* T >= 0 */
        _mm_storeu_ps(tf + c + 4, _mm_cvtepi32_ps(_mm_unpackhi_epi16(t, z)));
    }
}
#else
/* without SSE2 (or the affine refinement) the portable code of tvo_affine.c is the only one; ISO C
 * wants a declaration in every translation unit */
typedef int tvo_affine_tpl_sse2_left_out;
#endif
