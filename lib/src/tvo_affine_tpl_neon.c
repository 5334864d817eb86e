/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the affine refinement's per-row template work in NEON (aarch64; see tvo_affine.h), as
 * tvo_affine_tpl_sse2.c: tvo_aff_take's integer row sums (the same integers as take_row() in
 * tvo_affine.c, in any order, nothing overflowing) and tvo_aff_refine's gradients (exact floats),
 * 8 columns at a time. Built where the affine SIMD kernels are (TVO_AFF_NEON: aarch64). */
#include "tinyvo/options.h"
#include "tvo_affine.h"

#if TVO_WITH_AFFINE && TVO_AFF_NEON
#include <arm_neon.h>

/* The differences a[j] - b[j] of 8 bytes as int16 (the uint16 difference's bits). */
static inline int16x8_t diff8(const uint8_t *a, const uint8_t *b)
{
    return vreinterpretq_s16_u16(vsubl_u8(vld1_u8(a), vld1_u8(b)));
}

/* acc plus the products of the int16 lanes of a and b, lanes j and j + 4 into int32 lane j. */
static inline int32x4_t mac(int32x4_t acc, int16x8_t a, int16x8_t b)
{
    return vmlal_high_s16(vmlal_s16(acc, vget_low_s16(a), vget_low_s16(b)), a, b);
}

/* The sums of 8 columns from column c, as take_block() in tvo_affine_tpl_sse2.c: each int32 lane of a
 * gets at most 2 products (or 2 values, vpadalq) a block and holds a part of the row's sum of their
 * magnitudes, below 2^31 (take_row()). */
static inline void take_block(const uint8_t *p, int32_t s, int32_t c, int16x8_t x, int16x8_t keep,
                              int32x4_t a[19])
{
    const int16x8_t t = vandq_s16(vreinterpretq_s16_u16(vmovl_u8(vld1_u8(p + c))), keep);
    const int16x8_t dx = vandq_s16(diff8(p + c + 1, p + c - 1), keep);
    const int16x8_t dy = vandq_s16(diff8(p + c + s, p + c - s), keep);
    const int16x8_t dxx = vmulq_s16(dx, x), dyx = vmulq_s16(dy, x);
    a[0] = mac(a[0], dx, dx);
    a[1] = mac(a[1], dxx, dx);
    a[2] = mac(a[2], dxx, dxx);
    a[3] = mac(a[3], dx, dy);
    a[4] = mac(a[4], dxx, dy);
    a[5] = mac(a[5], dxx, dyx);
    a[6] = mac(a[6], dy, dy);
    a[7] = mac(a[7], dyx, dy);
    a[8] = mac(a[8], dyx, dyx);
    a[9] = mac(a[9], dx, t);
    a[10] = mac(a[10], dxx, t);
    a[11] = mac(a[11], dy, t);
    a[12] = mac(a[12], dyx, t);
    a[13] = vpadalq_s16(a[13], dx);
    a[14] = vpadalq_s16(a[14], dxx);
    a[15] = vpadalq_s16(a[15], dy);
    a[16] = vpadalq_s16(a[16], dyx);
    a[17] = vpadalq_s16(a[17], t);
    a[18] = mac(a[18], t, t);
}

void tvo_aff_take_row_simd(const uint8_t *p, int32_t s, int32_t m, int32_t h, int32_t r[19])
{
    static const int16_t iota_s16[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    const int16x8_t iota = vld1q_s16(iota_s16), eight = vdupq_n_s16(8);
    int16x8_t x = vaddq_s16(vdupq_n_s16((int16_t)-h), iota);
    int32x4_t a[19];
    int32_t c = 0;
    for (int k = 0; k < 19; ++k)
        a[k] = vdupq_n_s32(0);
    for (; c + 8 <= m; c += 8, x = vaddq_s16(x, eight))
        take_block(p, s, c, x, vdupq_n_s16(-1), a);
    if (c < m) {
        /* the last block ends at column m - 1: its lanes before column c were summed already */
        const int16x8_t cols = vaddq_s16(vdupq_n_s16((int16_t)(m - 8)), iota);
        take_block(p, s, m - 8, vsubq_s16(x, vdupq_n_s16((int16_t)(c + 8 - m))),
                   vreinterpretq_s16_u16(vcgtq_s16(cols, vdupq_n_s16((int16_t)(c - 1)))), a);
    }
    for (int k = 0; k < 19; ++k)
        r[k] = vaddvq_s32(a[k]);
}

void tvo_aff_gradients_row_simd(const uint8_t *p, int32_t s, int32_t m, float *gx, float *gy, float *tf)
{
    const float32x4_t half = vdupq_n_f32(0.5f);
    for (int32_t c0 = 0; c0 < m; c0 += 8) {
        /* the last block ends at column m - 1, writing some columns again with the same values */
        const int32_t c = c0 + 8 <= m ? c0 : m - 8;
        const uint16x8_t t = vmovl_u8(vld1_u8(p + c));
        const int16x8_t dx = diff8(p + c + 1, p + c - 1), dy = diff8(p + c + s, p + c - s);
        vst1q_f32(gx + c, vmulq_f32(half, vcvtq_f32_s32(vmovl_s16(vget_low_s16(dx)))));
        vst1q_f32(gx + c + 4, vmulq_f32(half, vcvtq_f32_s32(vmovl_high_s16(dx))));
        vst1q_f32(gy + c, vmulq_f32(half, vcvtq_f32_s32(vmovl_s16(vget_low_s16(dy)))));
        vst1q_f32(gy + c + 4, vmulq_f32(half, vcvtq_f32_s32(vmovl_high_s16(dy))));
        vst1q_f32(tf + c, vcvtq_f32_u32(vmovl_u16(vget_low_u16(t))));
        vst1q_f32(tf + c + 4, vcvtq_f32_u32(vmovl_high_u16(t)));
    }
}
#else
/* without aarch64 NEON (or the affine refinement) the portable code of tvo_affine.c or the SSE2 one is
 * built; ISO C wants a declaration in every translation unit */
typedef int tvo_affine_tpl_neon_left_out;
#endif
