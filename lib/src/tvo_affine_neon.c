/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the affine refinement's window sums in NEON (aarch64; see tvo_affine.h). The same float
 * operations in the same order as tvo_aff_sums_portable() in tvo_affine.c and the SSE2 kernel of
 * tvo_affine_sse2.c, four pixel columns at a time, so the same bits, and the same shortcuts around them
 * as the SSE2 kernel (see there). Reading the pairs of four consecutive pixels with 4-byte loads instead
 * of the lane by lane gather does not pay here either: the test costs about what it saves, and it
 * fails for half of the chunks on KITTI 07 (qemu instruction counts: 7 % more). aarch64 only: its NEON
 * float arithmetic follows the FPCR (IEEE, denormals kept), where armv7's NEON flushes denormals to zero. */
#include "tinyvo/options.h"
#include "tvo_affine.h"

#if TVO_WITH_AFFINE && TVO_AFF_NEON
#include <arm_neon.h>
#include <string.h>

/* The helpers are inlined into a window loop specialised for the way the pixel offsets are found, the
 * window's state (lane sums, row positions) in registers. */
#if defined(__GNUC__)
#define AFF_INLINE static inline __attribute__((always_inline))
#else
#define AFF_INLINE static inline
#endif

/* The 16 bits at p (little-endian: p[0] in the low byte). */
static inline uint16_t load16(const uint8_t *p)
{
    uint16_t v;
    memcpy(&v, p, sizeof(v));
    return v;
}

/* (l0 + l1) + (l2 + l3) of the four lanes of each of a, b, c, d, in lanes 0..3 (the portable kernel's
 * order): pairwise sums of a and b and of c and d, then pairwise sums of those. */
AFF_INLINE float32x4_t hsum4(float32x4_t a, float32x4_t b, float32x4_t c, float32x4_t d)
{
    return vpaddq_f32(vpaddq_f32(a, b), vpaddq_f32(c, d));
}

/* Kinds of column chunks, as in tvo_affine_sse2.c: four samples (FULL); the row's last chunk with one
 * sample (LAST_ONE: all four lanes on one pixel) or three (LAST_THREE). */
enum { FULL, LAST_ONE, LAST_THREE };

/* One chunk of four columns, as chunk() in tvo_affine_sse2.c. */
AFF_INLINE void chunk(const tvo_image *img, const float *gx, const float *gy, const float *tf, float32x4_t px,
                      float32x4_t py, float32x4_t xf, uint32x4_t in, int in_float, int kind,
                      float32x4_t acc[7])
{
    const size_t stride = (size_t)img->stride;
    const uint8_t *const top = img->data, *const below = img->data + stride;
    const int32x4_t ixv = vcvtq_s32_f32(px), iyv = vcvtq_s32_f32(py); /* truncation, as C's casts */
    const float32x4_t ixf = vcvtq_f32_s32(ixv), iyf = vcvtq_f32_s32(iyv);
    const float32x4_t fx = vsubq_f32(px, ixf), fy = vsubq_f32(py, iyf);
    size_t off[4]; /* the four pixels' byte offsets from the image's first */
    uint16x8_t w, lo, hi;
    int32x4_t t0, t1, b0, b1;
    float32x4_t tv, bv, v, vm, a, b;
    if (in_float) { /* iy stride + ix in float is exact below 2^24 */
        const int32x4_t o = vcvtq_s32_f32(vaddq_f32(vmulq_n_f32(iyf, (float)img->stride), ixf));
        off[0] = (uint32_t)vgetq_lane_s32(o, 0);
        off[1] = (uint32_t)vgetq_lane_s32(o, 1);
        off[2] = (uint32_t)vgetq_lane_s32(o, 2);
        off[3] = (uint32_t)vgetq_lane_s32(o, 3);
    } else {
        int32_t ix[4], iy[4];
        vst1q_s32(ix, ixv);
        vst1q_s32(iy, iyv);
        for (int l = 0; l < 4; ++l)
            off[l] = (size_t)iy[l] * stride + (size_t)ix[l];
    }
    if (kind == LAST_ONE) { /* the one pixel's pair (p[0], p[1]) in lanes 0..3, the pair below in 4..7 */
        w = vcombine_u16(vdup_n_u16(load16(top + off[0])), vdup_n_u16(load16(below + off[0])));
    } else { /* the pairs of the four pixels, then the pairs below them */
        uint16_t q[8];
        for (int l = 0; l < 4; ++l) {
            q[l] = load16(top + off[l]);
            q[l + 4] = load16(below + off[l]);
        }
        w = vld1q_u16(q);
    }
    lo = vandq_u16(w, vdupq_n_u16(0xff)); /* p[0] */
    hi = vshrq_n_u16(w, 8);               /* p[1] */
    t0 = vreinterpretq_s32_u32(vmovl_u16(vget_low_u16(lo)));
    t1 = vreinterpretq_s32_u32(vmovl_u16(vget_low_u16(hi)));
    b0 = vreinterpretq_s32_u32(vmovl_u16(vget_high_u16(lo)));
    b1 = vreinterpretq_s32_u32(vmovl_u16(vget_high_u16(hi)));
    tv = vaddq_f32(vcvtq_f32_s32(t0), vmulq_f32(fx, vcvtq_f32_s32(vsubq_s32(t1, t0))));
    bv = vaddq_f32(vcvtq_f32_s32(b0), vmulq_f32(fx, vcvtq_f32_s32(vsubq_s32(b1, b0))));
    v = vaddq_f32(tv, vmulq_f32(fy, vsubq_f32(bv, tv)));
    /* a full chunk's mask is all ones */
    vm = kind == FULL ? v : vreinterpretq_f32_u32(vandq_u32(vreinterpretq_u32_f32(v), in));
    a = vmulq_f32(vld1q_f32(gx), v);
    b = vmulq_f32(vld1q_f32(gy), v);
    acc[0] = vaddq_f32(acc[0], a);
    acc[1] = vaddq_f32(acc[1], vmulq_f32(a, xf));
    acc[2] = vaddq_f32(acc[2], b);
    acc[3] = vaddq_f32(acc[3], vmulq_f32(b, xf));
    acc[4] = vaddq_f32(acc[4], vm);
    acc[5] = vaddq_f32(acc[5], vmulq_f32(vm, vm));
    acc[6] = vaddq_f32(acc[6], vmulq_f32(vm, vld1q_f32(tf)));
}

/* The window's sums (tvo_aff_sums_simd), the pixel offsets found as in_float says (see chunk()). */
AFF_INLINE void window(const tvo_image *img, const float *gx, const float *gy, const float *tf, int32_t side,
                       int32_t step, const double A[4], const double t[2], int in_float, tvo_aff_sums *s)
{
    static const float lanes[4] = {0.0f, 1.0f, 2.0f, 3.0f};
    const int32_t h = side / 2, m = tvo_aff_samples(side, step), cols = tvo_aff_cols(m), full = m / 4;
    const int last = m % 4 == 1 ? LAST_ONE : LAST_THREE; /* m is odd */
    const float32x4_t ax = vdupq_n_f32((float)A[0]), ay = vdupq_n_f32((float)A[2]);
    /* x in lane 0, y in lane 1: A[0] -h and A[2] -h, A[1] and A[3], t */
    const float64x2_t ah = vmulq_n_f64(vcombine_f64(vdup_n_f64(A[0]), vdup_n_f64(A[2])), (double)-h);
    const float64x2_t av = vcombine_f64(vdup_n_f64(A[1]), vdup_n_f64(A[3])), tv = vld1q_f64(t);
    /* (r[1], r[0]) times (1, yy): r[1] 1 is r[1] exactly, r[0] yy is tvo_aff_add_row's product */
    float64x2_t one_yy = vdupq_n_f64(1.0);
    float32x4_t axf[TVO_AFF_MAX_SIDE / 4 + 1], ayf[TVO_AFF_MAX_SIDE / 4 + 1], xfs[TVO_AFF_MAX_SIDE / 4 + 1];
    uint32x4_t ins[TVO_AFF_MAX_SIDE / 4 + 1];
    /* the window's sums: sdi[0..1], sdi[2..3], sdi[4..5], sum_i and sum_i2, sum_it (lane 0) */
    float64x2_t s01 = vdupq_n_f64(0.0), s23 = s01, s45 = s01, si = s01, sit = s01;
    /* per chunk of four columns: ax and ay times the sample's column in the window (a padding column
       repeats the last sample), its template x, and whether it is a sample at all */
    for (int32_t j = 0, c = 0; j < cols; j += 4, ++c) {
        const float32x4_t jv = vaddq_f32(vdupq_n_f32((float)j), vld1q_f32(lanes));
        const float32x4_t fj = vmulq_f32(vminq_f32(jv, vdupq_n_f32((float)(m - 1))),
                                         vdupq_n_f32((float)step));
        axf[c] = vmulq_f32(ax, fj);
        ayf[c] = vmulq_f32(ay, fj);
        xfs[c] = vsubq_f32(vmulq_f32(jv, vdupq_n_f32((float)step)), vdupq_n_f32((float)h));
        ins[c] = vcltq_f32(jv, vdupq_n_f32((float)m));
    }
    for (int32_t r = 0; r < m; ++r) {
        const int32_t yy = r * step - h;
        const float *const rx = gx + (size_t)r * (size_t)cols, *const ry = gy + (size_t)r * (size_t)cols,
                           *const rt = tf + (size_t)r * (size_t)cols;
        /* bx, by: A[0] -h + A[1] yy + t[0] and the same for y, in double, rounded to float */
        const float32x2_t b = vcvt_f32_f64(vaddq_f64(vaddq_f64(ah, vmulq_n_f64(av, (double)yy)), tv));
        const float32x4_t bx = vdupq_lane_f32(b, 0), by = vdupq_lane_f32(b, 1);
        float32x4_t acc[7], r03, r46;
        float64x2_t d01, d23;
        int32_t c;
        for (int k = 0; k < 7; ++k)
            acc[k] = vdupq_n_f32(0.0f);
        for (c = 0; c < full; ++c)
            chunk(img, rx + 4 * c, ry + 4 * c, rt + 4 * c, vaddq_f32(bx, axf[c]), vaddq_f32(by, ayf[c]),
                  xfs[c], ins[c], in_float, FULL, acc);
        chunk(img, rx + 4 * c, ry + 4 * c, rt + 4 * c, vaddq_f32(bx, axf[c]), vaddq_f32(by, ayf[c]), xfs[c],
              ins[c], in_float, last, acc);
        /* the row's sums r[0..3] and r[4..6] (tvo_aff_add_row), added to the window's in double */
        r03 = hsum4(acc[0], acc[1], acc[2], acc[3]);
        r46 = hsum4(acc[4], acc[5], acc[6], vdupq_n_f32(0.0f));
        d01 = vcvt_f64_f32(vget_low_f32(r03));
        d23 = vcvt_high_f64_f32(r03);
        one_yy = vsetq_lane_f64((double)yy, one_yy, 1);
        s01 = vaddq_f64(s01,
                        vmulq_f64(vextq_f64(d01, d01, 1), one_yy)); /* sdi[0] += r[1], sdi[1] += r[0] yy */
        s23 = vaddq_f64(s23,
                        vmulq_f64(vextq_f64(d23, d23, 1), one_yy)); /* sdi[2] += r[3], sdi[3] += r[2] yy */
        s45 = vaddq_f64(s45, vzip1q_f64(d01, d23));                 /* sdi[4] += r[0], sdi[5] += r[2] */
        si = vaddq_f64(si, vcvt_f64_f32(vget_low_f32(r46)));
        sit = vaddq_f64(sit, vcvt_high_f64_f32(r46));
    }
    vst1q_f64(s->sdi, s01);
    vst1q_f64(s->sdi + 2, s23);
    vst1q_f64(s->sdi + 4, s45);
    s->sum_i = vgetq_lane_f64(si, 0);
    s->sum_i2 = vgetq_lane_f64(si, 1);
    s->sum_it = vgetq_lane_f64(sit, 0);
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
/* not aarch64 (or the affine refinement left out): ISO C wants a declaration in every translation unit */
typedef int tvo_affine_neon_left_out;
#endif
