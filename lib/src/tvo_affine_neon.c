/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the affine refinement's window sums in NEON (aarch64; see tvo_affine.h). The same float
 * operations in the same order as tvo_aff_sums_portable() in tvo_affine.c and the SSE2 kernel of
 * tvo_affine_sse2.c, four pixel columns at a time, so the same bits. aarch64 only: its NEON float
 * arithmetic follows the FPCR (IEEE, denormals kept), where armv7's NEON flushes denormals to zero. */
#include "tinyvo/options.h"
#include "tvo_affine.h"

#if TVO_WITH_AFFINE && TVO_AFF_NEON
#include <arm_neon.h>
#include <string.h>

/* (l0 + l1) + (l2 + l3) of the four lanes of v. */
static inline float hsum(float32x4_t v)
{
    const float32x4_t p = vpaddq_f32(v, v); /* l0 + l1, l2 + l3, ... */
    return vgetq_lane_f32(p, 0) + vgetq_lane_f32(p, 1);
}

/* The 16 bits at p (little-endian: p[0] in the low byte). */
static inline uint16_t load16(const uint8_t *p)
{
    uint16_t v;
    memcpy(&v, p, sizeof(v));
    return v;
}

/* One row of the window, as row_sums() in tvo_affine_sse2.c. */
static inline void row_sums(const tvo_image *img, const float *gx, const float *gy, const float *tf,
                            int32_t cols, float32x4_t bx, float32x4_t by, float32x4_t ax, float32x4_t ay,
                            const float32x4_t *fjs, const float32x4_t *xfs, const uint32x4_t *ins,
                            int in_float, float32x4_t acc[7])
{
    const size_t stride = (size_t)img->stride;
    const float32x4_t fstride = vdupq_n_f32((float)img->stride);
    for (int32_t j = 0, c = 0; j < cols; j += 4, ++c) {
        const float32x4_t px = vaddq_f32(bx, vmulq_f32(ax, fjs[c])),
                          py = vaddq_f32(by, vmulq_f32(ay, fjs[c]));
        const int32x4_t ixv = vcvtq_s32_f32(px), iyv = vcvtq_s32_f32(py); /* truncation, as C's casts */
        const float32x4_t ixf = vcvtq_f32_s32(ixv), iyf = vcvtq_f32_s32(iyv);
        const float32x4_t fx = vsubq_f32(px, ixf), fy = vsubq_f32(py, iyf);
        const uint8_t *p[4];
        uint16_t q[8];
        uint16x8_t w, lo, hi;
        int32x4_t t0, t1, b0, b1;
        float32x4_t top, bot, v, vm, a, b;
        if (in_float) { /* iy stride + ix in float is exact below 2^24 */
            const int32x4_t off = vcvtq_s32_f32(vaddq_f32(vmulq_f32(iyf, fstride), ixf));
            p[0] = img->data + (uint32_t)vgetq_lane_s32(off, 0);
            p[1] = img->data + (uint32_t)vgetq_lane_s32(off, 1);
            p[2] = img->data + (uint32_t)vgetq_lane_s32(off, 2);
            p[3] = img->data + (uint32_t)vgetq_lane_s32(off, 3);
        } else {
            int32_t ix[4], iy[4];
            vst1q_s32(ix, ixv);
            vst1q_s32(iy, iyv);
            for (int l = 0; l < 4; ++l)
                p[l] = img->data + (size_t)iy[l] * stride + (size_t)ix[l];
        }
        for (int l = 0; l < 4; ++l) { /* the pairs (p[0], p[1]), then the pairs below them */
            q[l] = load16(p[l]);
            q[l + 4] = load16(p[l] + stride);
        }
        w = vld1q_u16(q);
        lo = vandq_u16(w, vdupq_n_u16(0xff)); /* p[0] */
        hi = vshrq_n_u16(w, 8);               /* p[1] */
        t0 = vreinterpretq_s32_u32(vmovl_u16(vget_low_u16(lo)));
        t1 = vreinterpretq_s32_u32(vmovl_u16(vget_low_u16(hi)));
        b0 = vreinterpretq_s32_u32(vmovl_u16(vget_high_u16(lo)));
        b1 = vreinterpretq_s32_u32(vmovl_u16(vget_high_u16(hi)));
        top = vaddq_f32(vcvtq_f32_s32(t0), vmulq_f32(fx, vcvtq_f32_s32(vsubq_s32(t1, t0))));
        bot = vaddq_f32(vcvtq_f32_s32(b0), vmulq_f32(fx, vcvtq_f32_s32(vsubq_s32(b1, b0))));
        v = vaddq_f32(top, vmulq_f32(fy, vsubq_f32(bot, top)));
        vm = vreinterpretq_f32_u32(vandq_u32(vreinterpretq_u32_f32(v), ins[c]));
        a = vmulq_f32(vld1q_f32(gx + j), v);
        b = vmulq_f32(vld1q_f32(gy + j), v);
        acc[0] = vaddq_f32(acc[0], a);
        acc[1] = vaddq_f32(acc[1], vmulq_f32(a, xfs[c]));
        acc[2] = vaddq_f32(acc[2], b);
        acc[3] = vaddq_f32(acc[3], vmulq_f32(b, xfs[c]));
        acc[4] = vaddq_f32(acc[4], vm);
        acc[5] = vaddq_f32(acc[5], vmulq_f32(vm, vm));
        acc[6] = vaddq_f32(acc[6], vmulq_f32(vm, vld1q_f32(tf + j)));
    }
}

void tvo_aff_sums_simd(const tvo_image *img, const float *gx, const float *gy, const float *tf, int32_t side,
                       int32_t step, const double A[4], const double t[2], tvo_aff_sums *s)
{
    static const float lanes[4] = {0.0f, 1.0f, 2.0f, 3.0f};
    const int32_t h = side / 2, m = tvo_aff_samples(side, step), cols = tvo_aff_cols(m);
    const float32x4_t ax = vdupq_n_f32((float)A[0]), ay = vdupq_n_f32((float)A[2]);
    /* every byte offset of the image below 2^24: the pixel offsets are computed in float, exactly */
    const int in_float = (double)img->stride * (double)img->height < 16777216.0;
    float32x4_t fjs[TVO_AFF_MAX_SIDE / 4 + 1], xfs[TVO_AFF_MAX_SIDE / 4 + 1];
    uint32x4_t ins[TVO_AFF_MAX_SIDE / 4 + 1];
    for (int32_t j = 0, c = 0; j < cols; j += 4, ++c) {
        const float32x4_t jv = vaddq_f32(vdupq_n_f32((float)j), vld1q_f32(lanes));
        fjs[c] = vmulq_f32(vminq_f32(jv, vdupq_n_f32((float)(m - 1))), vdupq_n_f32((float)step));
        xfs[c] = vsubq_f32(vmulq_f32(jv, vdupq_n_f32((float)step)), vdupq_n_f32((float)h));
        ins[c] = vcltq_f32(jv, vdupq_n_f32((float)m));
    }
    memset(s, 0, sizeof(*s));
    for (int32_t r = 0; r < m; ++r) {
        const int32_t yy = r * step - h;
        const size_t row = (size_t)r * (size_t)cols;
        const float32x4_t bx = vdupq_n_f32((float)(A[0] * -h + A[1] * yy + t[0]));
        const float32x4_t by = vdupq_n_f32((float)(A[2] * -h + A[3] * yy + t[1]));
        float32x4_t acc[7];
        float rs[7];
        for (int k = 0; k < 7; ++k)
            acc[k] = vdupq_n_f32(0.0f);
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
/* not aarch64 (or the affine refinement left out): ISO C wants a declaration in every translation unit */
typedef int tvo_affine_neon_left_out;
#endif
