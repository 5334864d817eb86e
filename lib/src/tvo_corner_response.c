/* SPDX-License-Identifier: Apache-2.0 */
/* Harris and Shi-Tomasi (minimum eigenvalue) corner responses, OpenCV-compatible (ksize 3 Sobel,
 * BORDER_REFLECT_101). See tinyvo/corners.h.
 *
 * The Sobel derivatives of an 8-bit image are integers in [-1020, 1020]; their products summed over a
 * window of at most 31x31 stay below 2^31, so the structure tensor sums are exact in int32. The scale
 * (1 / (4 * block_size * 255))^2 and the formula are applied in double at the end, then rounded to float.
 * The dense map and the single-pixel version therefore give identical values. */
#include "tinyvo/corners.h"
#include "tvo_border.h"

#include <math.h>
#include <string.h>

static int cr_kind_ok(tvo_score_kind kind)
{
    return kind == TVO_SCORE_HARRIS || kind == TVO_SCORE_SHI_TOMASI;
}

/* the response from the exact integer sums a = sum Ix^2, b = sum Ix*Iy, c = sum Iy^2 */
static float cr_response(int64_t a, int64_t b, int64_t c, double s2, tvo_score_kind kind, double k)
{
    double A = (double)a * s2, B = (double)b * s2, C = (double)c * s2;
    if (kind == TVO_SCORE_HARRIS) {
        double t = A + C;
        return (float)(A * C - B * B - k * t * t);
    } else {
        double h = (A - C) * 0.5;
        return (float)((A + C) * 0.5 - sqrt(h * h + B * B));
    }
}

static double cr_scale2(int32_t block_size)
{
    double s = 1.0 / (4.0 * (double)block_size * 255.0);
    return s * s;
}

float tvo_corner_score_at(const tvo_image *img, int32_t x, int32_t y, tvo_score_kind kind, int32_t block_size,
                          float harris_k)
{
    int32_t lo, hi, u, v;
    int32_t a = 0, b = 0, c = 0;
    size_t st;
    if (tvo_image_check(img) != TVO_OK || !cr_kind_ok(kind) || block_size < 1 ||
        block_size > TVO_CORNER_MAX_BLOCK || !isfinite(harris_k))
        return 0.0f;
    lo = block_size / 2;
    hi = block_size - 1 - lo;
    if (x - lo - 1 < 0 || y - lo - 1 < 0 || x + hi + 1 >= img->width || y + hi + 1 >= img->height)
        return 0.0f;
    st = (size_t)img->stride;
    for (v = y - lo; v <= y + hi; ++v) {
        const uint8_t *r0 = img->data + (size_t)(v - 1) * st;
        const uint8_t *r1 = r0 + st;
        const uint8_t *r2 = r1 + st;
        for (u = x - lo; u <= x + hi; ++u) {
            int32_t gx = ((int32_t)r0[u + 1] - r0[u - 1]) + 2 * ((int32_t)r1[u + 1] - r1[u - 1]) +
                    ((int32_t)r2[u + 1] - r2[u - 1]);
            int32_t gy = ((int32_t)r2[u - 1] + 2 * (int32_t)r2[u] + r2[u + 1]) -
                    ((int32_t)r0[u - 1] + 2 * (int32_t)r0[u] + r0[u + 1]);
            a += gx * gx;
            b += gx * gy;
            c += gy * gy;
        }
    }
    return cr_response(a, b, c, cr_scale2(block_size), kind, (double)harris_k);
}

size_t tvo_corner_response_scratch_size(int32_t width, int32_t block_size)
{
    size_t w, bs, n;
    if (width < 1 || width > TVO_MAX_IMAGE_DIM || block_size < 1 || block_size > TVO_CORNER_MAX_BLOCK)
        return 0;
    w = (size_t)width;
    bs = (size_t)block_size;
    /* ring of block_size product rows (3 x int32 each), 3 column-sum rows padded by block_size,
     * 2 gradient rows (int32) and a reflected column index table, plus alignment slack */
    n = 3u * bs * w + 3u * (w + bs) + 2u * w + (w + 2u);
    return n * sizeof(int32_t) + 16u;
}

/* products of the Sobel derivatives of (real) row r into pa, pb, pc (width each) */
static void cr_products(const tvo_image *img, int32_t r, const int32_t *xm, const int32_t *xp, int32_t *pa,
                        int32_t *pb, int32_t *pc)
{
    int32_t H = img->height, W = img->width, x;
    const uint8_t *r0 = img->data + (size_t)tvo_reflect101(r - 1, H) * (size_t)img->stride;
    const uint8_t *r1 = img->data + (size_t)r * (size_t)img->stride;
    const uint8_t *r2 = img->data + (size_t)tvo_reflect101(r + 1, H) * (size_t)img->stride;
    for (x = 0; x < W; ++x) {
        int32_t l = xm[x], rr = xp[x];
        int32_t gx = ((int32_t)r0[rr] - r0[l]) + 2 * ((int32_t)r1[rr] - r1[l]) + ((int32_t)r2[rr] - r2[l]);
        int32_t gy = ((int32_t)r2[l] + 2 * (int32_t)r2[x] + r2[rr]) -
                ((int32_t)r0[l] + 2 * (int32_t)r0[x] + r0[rr]);
        pa[x] = gx * gx;
        pb[x] = gx * gy;
        pc[x] = gy * gy;
    }
}

/* the column sums v += p of the product row entering the window (width w) */
static void cr_columns_add(size_t w, const int32_t *pa, const int32_t *pb, const int32_t *pc, int32_t *va,
                           int32_t *vb, int32_t *vc)
{
    for (size_t x = 0; x < w; ++x) {
        va[x] += pa[x];
        vb[x] += pb[x];
        vc[x] += pc[x];
    }
}

/* the column sums v -= p of the product row leaving the window (width w) */
static void cr_columns_sub(size_t w, const int32_t *pa, const int32_t *pb, const int32_t *pc, int32_t *va,
                           int32_t *vb, int32_t *vc)
{
    for (size_t x = 0; x < w; ++x) {
        va[x] -= pa[x];
        vb[x] -= pb[x];
        vc[x] -= pc[x];
    }
}

/* one output row o from its column sums: horizontal window sums (columns x-lo .. x+hi, reflected) as a
 * running sum over x, then the response of each */
static void cr_row_responses(int32_t W, int32_t lo, int32_t hi, const int32_t *va, const int32_t *vb,
                             const int32_t *vc, double s2, tvo_score_kind kind, float harris_k, float *o)
{
    int32_t sa = 0, sb = 0, sc = 0, i, x;
    for (i = -lo; i <= hi; ++i) {
        int32_t j = tvo_reflect101(i, W);
        sa += va[j];
        sb += vb[j];
        sc += vc[j];
    }
    for (x = 0;; ++x) {
        int32_t jo, jn;
        o[x] = cr_response(sa, sb, sc, s2, kind, (double)harris_k);
        if (x + 1 >= W)
            break;
        jo = tvo_reflect101(x - lo, W);
        jn = tvo_reflect101(x + hi + 1, W);
        sa += va[jn] - va[jo];
        sb += vb[jn] - vb[jo];
        sc += vc[jn] - vc[jo];
    }
}

tvo_status tvo_corner_response(const tvo_image *img, tvo_score_kind kind, int32_t block_size, float harris_k,
                               float *out, int32_t out_stride, void *scratch, size_t scratch_size)
{
    tvo_status st;
    int32_t W, H, bs, lo, hi, x, y, t;
    size_t w;
    int32_t *mem, *ring, *va, *vb, *vc, *xm, *xp;
    double s2;
    if (out == NULL || scratch == NULL)
        return TVO_ERR_NULL;
    st = tvo_image_check(img);
    if (st != TVO_OK)
        return st;
    if (!cr_kind_ok(kind) || block_size < 1 || block_size > TVO_CORNER_MAX_BLOCK)
        return TVO_ERR_ARG;
    if (!isfinite(harris_k))
        return TVO_ERR_NOT_FINITE;
    if (out_stride < img->width)
        return TVO_ERR_SIZE;
    if (scratch_size < tvo_corner_response_scratch_size(img->width, block_size))
        return TVO_ERR_NO_MEMORY;

    W = img->width;
    H = img->height;
    w = (size_t)W;
    bs = block_size;
    lo = bs / 2;
    hi = bs - 1 - lo;
    s2 = cr_scale2(bs);
    {
        uintptr_t p = (uintptr_t)scratch;
        size_t mis = (size_t)(p % sizeof(int32_t));
        mem = (int32_t *)(void *)((uint8_t *)scratch + (mis ? sizeof(int32_t) - mis : 0));
    }
    ring = mem;                      /* bs slots x 3 rows x W */
    va = ring + 3u * (size_t)bs * w; /* column sums, W + bs each (padded for the row pass) */
    vb = va + (w + (size_t)bs);
    vc = vb + (w + (size_t)bs);
    xm = vc + (w + (size_t)bs); /* reflected x-1 */
    xp = xm + w;                /* reflected x+1 */
    for (x = 0; x < W; ++x) {
        xm[x] = tvo_reflect101(x - 1, W);
        xp[x] = tvo_reflect101(x + 1, W);
    }
    memset(va, 0, w * sizeof(int32_t));
    memset(vb, 0, w * sizeof(int32_t));
    memset(vc, 0, w * sizeof(int32_t));

    /* virtual product rows t = -lo .. H-1+hi, each = products of real row reflect(t); slot (t+lo) % bs.
     * Column sums for output row y cover virtual rows y-lo .. y+hi. */
    for (t = -lo; t < hi; ++t) {
        int32_t *pa = ring + (size_t)((t + lo) % bs) * 3u * w, *pb = pa + w, *pc = pb + w;
        cr_products(img, tvo_reflect101(t, H), xm, xp, pa, pb, pc);
        cr_columns_add(w, pa, pb, pc, va, vb, vc);
    }
    for (y = 0; y < H; ++y) {
        int32_t tn = y + hi; /* the row entering the window */
        int32_t *pa = ring + (size_t)((tn + lo) % bs) * 3u * w, *pb = pa + w, *pc = pb + w;
        /* the slot of tn holds row tn - bs (= y - lo - 1), which leaves the window: subtract it first */
        if (y > 0)
            cr_columns_sub(w, pa, pb, pc, va, vb, vc);
        cr_products(img, tvo_reflect101(tn, H), xm, xp, pa, pb, pc);
        cr_columns_add(w, pa, pb, pc, va, vb, vc);
        cr_row_responses(W, lo, hi, va, vb, vc, s2, kind, harris_k, out + (size_t)y * (size_t)out_stride);
    }
    return TVO_OK;
}
