/* SPDX-License-Identifier: Apache-2.0 */
/* The affine track refinement (tvo_affine.h): a patch rendered under a known affine warp is found to
 * 0.05 px where a translation-only model is off by tenths of a pixel; exposure changes do not move it;
 * flat, one-directional and out-of-image patches are refused; bad arguments leave the warp unchanged. */
#include <math.h>
#include <string.h>

#include "tvo_test.h"
#include "tinyvo/options.h"
#include "tvo_affine.h"

#if TVO_WITH_AFFINE
#define W 160
#define H 120
#define SIDE 21

/* A smooth, corner-rich texture (sums of products of sinusoids and two blobs), in grey levels, at any
 * real position, so that a warped image is rendered exactly instead of resampled. */
static double texture(double x, double y)
{
    double v = 128.0 + 40.0 * sin(0.21 * x + 0.5) * cos(0.17 * y - 0.3) +
            25.0 * sin(0.07 * x * 1.3 + 0.11 * y) + 20.0 * cos(0.31 * y + 0.05 * x);
    v += 50.0 * exp(-((x - 80.0) * (x - 80.0) + (y - 58.0) * (y - 58.0)) / 30.0);
    v -= 40.0 * exp(-((x - 86.0) * (x - 86.0) + (y - 66.0) * (y - 66.0)) / 12.0);
    return v;
}

/* img(x) = gain * texture(M^-1 (x - c) + c0) + bias: the texture moved by the affine map x = M (u - c0) + c */
static void render(uint8_t *img, const double M[4], const double c0[2], const double c[2], double gain,
                   double bias)
{
    const double det = M[0] * M[3] - M[1] * M[2];
    const double Mi[4] = {M[3] / det, -M[1] / det, -M[2] / det, M[0] / det};
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const double dx = x - c[0], dy = y - c[1];
            const double u = Mi[0] * dx + Mi[1] * dy + c0[0], v = Mi[2] * dx + Mi[3] * dy + c0[1];
            const double g = gain * texture(u, v) + bias;
            img[y * W + x] = (uint8_t)(g < 0.0 ? 0.0 : g > 255.0 ? 255.0 : floor(g + 0.5));
        }
}

static float scratch[SIDE * ((SIDE + 3) & ~3) * 3];
static int32_t g_step = 1; /* the sampling step run() takes its templates with */

/* Take the template at p0 in the first image, render the second under (M, point p0 -> p1), start the
 * refinement at p1 + off with A = identity, and return the final point's error (or -1 on failure). */
static double run(const double M[4], const double p1[2], const double off[2], double gain, double bias,
                  tvo_aff_warp *w_out)
{
    static uint8_t a[W * H], b[W * H], tpl[(SIDE + 2) * (SIDE + 2)];
    const double I[4] = {1, 0, 0, 1}, p0[2] = {80.0, 60.0};
    tvo_image ia = tvo_image_make(W, H, W, a), ib = tvo_image_make(W, H, W, b);
    tvo_aff_model model;
    tvo_aff_warp w;
    float x, y, ncc = 0.0f;
    render(a, I, p0, p0, 1.0, 0.0);
    render(b, M, p0, p1, gain, bias);
    assert_int_equal(tvo_aff_take(&ia, (float)p0[0], (float)p0[1], SIDE, g_step, tpl, &model, &w), 1);
    w.t[0] += (float)(p1[0] + off[0] - p0[0]);
    w.t[1] += (float)(p1[1] + off[1] - p0[1]);
    if (tvo_aff_refine(tpl, &model, SIDE, g_step, &ib, &w, 30, 0.01f, scratch, sizeof(scratch), &ncc) != 1)
        return -1.0;
    assert_true(ncc > 0.95f);
    tvo_aff_point(&w, &x, &y);
    if (w_out != NULL)
        *w_out = w;
    return hypot(x - p1[0], y - p1[1]);
}

static void test_recovers_affine(void **state)
{
    /* 8 % zoom, 4 deg rotation and a shear, point moved by (3.4, -2.2), start 0.8 px off */
    const double c = cos(0.07), s = sin(0.07);
    const double M[4] = {1.08 * c - 0.03 * s, -1.08 * s + 0.03 * c, 1.08 * s, 1.08 * c};
    const double p1[2] = {83.4, 57.8}, off[2] = {0.6, -0.5};
    tvo_aff_warp w;
    double e = run(M, p1, off, 1.0, 0.0, &w);
    (void)state;
    assert_true(e >= 0.0 && e < 0.05);
    for (int i = 0; i < 4; ++i)
        assert_true(fabs((double)w.A[i] - M[i]) < 0.01);
}

/* The same with every other pixel of the window (an 11 x 11 grid): as accurate on this texture, and a
 * step that does not divide the half window, or exceeds it, is refused. */
static void test_recovers_affine_step2(void **state)
{
    const double c = cos(0.07), s = sin(0.07);
    const double M[4] = {1.08 * c - 0.03 * s, -1.08 * s + 0.03 * c, 1.08 * s, 1.08 * c};
    const double p1[2] = {83.4, 57.8}, off[2] = {0.6, -0.5};
    static uint8_t img[W * H], tpl[(SIDE + 2) * (SIDE + 2)];
    tvo_image im = tvo_image_make(W, H, W, img);
    tvo_aff_model model;
    tvo_aff_warp w;
    double e;
    (void)state;
    g_step = 2;
    e = run(M, p1, off, 1.0, 0.0, &w);
    g_step = 1;
    print_message("step 2: error %.4f px\n", e);
    assert_true(e >= 0.0 && e < 0.05);
    for (int i = 0; i < 4; ++i)
        assert_true(fabs((double)w.A[i] - M[i]) < 0.01);
    memset(img, 128, sizeof(img));
    for (int i = 0; i < W * H; ++i)
        img[i] = (uint8_t)((i * 37 + (i / W) * 11) & 0xff);
    assert_int_equal(tvo_aff_take(&im, 80.0f, 60.0f, SIDE, 5, tpl, &model, &w), 1);
    assert_int_equal(tvo_aff_take(&im, 80.0f, 60.0f, SIDE, 3, tpl, &model, &w), 0);
    assert_int_equal(tvo_aff_take(&im, 80.0f, 60.0f, SIDE, 0, tpl, &model, &w), 0);
    assert_int_equal(tvo_aff_take(&im, 80.0f, 60.0f, SIDE, 20, tpl, &model, &w), 0);
}

static void test_exposure_change(void **state)
{
    const double M[4] = {1.05, 0.0, 0.0, 1.05}, p1[2] = {81.0, 61.5}, off[2] = {-0.4, 0.3};
    double e = run(M, p1, off, 0.75, 30.0, NULL);
    (void)state;
    assert_true(e >= 0.0 && e < 0.05);
}

static void test_refused(void **state)
{
    static uint8_t img[W * H], tpl[(SIDE + 2) * (SIDE + 2)];
    tvo_image im = tvo_image_make(W, H, W, img);
    tvo_aff_model model;
    tvo_aff_warp w;
    (void)state;
    /* flat */
    memset(img, 100, sizeof(img));
    assert_int_equal(tvo_aff_take(&im, 80.0f, 60.0f, SIDE, 1, tpl, &model, &w), 0);
    /* stripes: texture in one direction only (the 6x6 system is singular) */
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x)
            img[y * W + x] = (uint8_t)(128.0 + 100.0 * sin(0.4 * x));
    assert_int_equal(tvo_aff_take(&im, 80.0f, 60.0f, SIDE, 1, tpl, &model, &w), 0);
    /* too near the border, outside, not finite */
    {
        const double I[4] = {1, 0, 0, 1}, p0[2] = {80.0, 60.0};
        render(img, I, p0, p0, 1.0, 0.0);
    }
    assert_int_equal(tvo_aff_take(&im, 10.4f, 60.0f, SIDE, 1, tpl, &model, &w), 0);
    assert_int_equal(tvo_aff_take(&im, 80.0f, (float)H + 3.0f, SIDE, 1, tpl, &model, &w), 0);
    assert_int_equal(tvo_aff_take(&im, NAN, 60.0f, SIDE, 1, tpl, &model, &w), 0);
    assert_int_equal(tvo_aff_take(&im, 80.0f, INFINITY, SIDE, 1, tpl, &model, &w), 0);
    /* sides: even, too small, too large */
    assert_int_equal(tvo_aff_take(&im, 80.0f, 60.0f, 20, 1, tpl, &model, &w), 0);
    assert_int_equal(tvo_aff_take(&im, 80.0f, 60.0f, 1, 1, tpl, &model, &w), 0);
    assert_int_equal(tvo_aff_take(&im, 80.0f, 60.0f, TVO_AFF_MAX_SIDE + 2, 1, tpl, &model, &w), 0);
    assert_int_equal(tvo_aff_scratch_size(20), 0);
    assert_true(tvo_aff_scratch_size(SIDE) <= sizeof(scratch));
    /* NULLs */
    assert_int_equal(tvo_aff_take(NULL, 80.0f, 60.0f, SIDE, 1, tpl, &model, &w), 0);
    assert_int_equal(tvo_aff_take(&im, 80.0f, 60.0f, SIDE, 1, NULL, &model, &w), 0);
    assert_int_equal(tvo_aff_take(&im, 80.0f, 60.0f, SIDE, 1, tpl, NULL, &w), 0);
    assert_int_equal(tvo_aff_take(&im, 80.0f, 60.0f, SIDE, 1, tpl, &model, NULL), 0);
}

static void test_refine_failures_leave_warp(void **state)
{
    static uint8_t img[W * H], tpl[(SIDE + 2) * (SIDE + 2)];
    const double I[4] = {1, 0, 0, 1}, p0[2] = {80.0, 60.0};
    tvo_image im = tvo_image_make(W, H, W, img);
    tvo_aff_model model;
    tvo_aff_warp w, w0;
    float ncc = -2.0f;
    (void)state;
    render(img, I, p0, p0, 1.0, 0.0);
    assert_int_equal(tvo_aff_take(&im, 80.3f, 59.8f, SIDE, 1, tpl, &model, &w), 1);
    assert_true(fabsf(w.d[0] - 0.3f) < 1e-4f && fabsf(w.d[1] + 0.2f) < 1e-4f);
    /* the same image: found where it was taken, correlation 1 */
    w0 = w;
    assert_int_equal(tvo_aff_refine(tpl, &model, SIDE, 1, &im, &w, 10, 0.01f, scratch, sizeof(scratch), &ncc),
                     1);
    assert_true(ncc > 0.999f);
    assert_true(fabsf(w.t[0] - w0.t[0]) < 0.01f && fabsf(w.t[1] - w0.t[1]) < 0.01f);
    /* a window that leaves the image: told apart from a failed match */
    w0 = w;
    w.t[0] = 5.0f;
    w0.t[0] = 5.0f;
    assert_int_equal(tvo_aff_refine(tpl, &model, SIDE, 1, &im, &w, 10, 0.01f, scratch, sizeof(scratch), &ncc),
                     TVO_AFF_AT_BORDER);
    assert_memory_equal(&w, &w0, sizeof(w));
    /* no convergence in one step from 3 px away */
    w.t[0] = 83.0f;
    w0 = w;
    assert_int_equal(tvo_aff_refine(tpl, &model, SIDE, 1, &im, &w, 1, 0.01f, scratch, sizeof(scratch), &ncc),
                     0);
    assert_memory_equal(&w, &w0, sizeof(w));
    /* bad arguments */
    assert_int_equal(tvo_aff_refine(tpl, &model, SIDE, 1, &im, &w, 10, 0.01f, scratch, 16, &ncc), 0);
    assert_int_equal(tvo_aff_refine(tpl, &model, SIDE, 1, &im, &w, 0, 0.01f, scratch, sizeof(scratch), &ncc),
                     0);
    assert_int_equal(tvo_aff_refine(tpl, &model, SIDE, 1, &im, &w, 10, 0.0f, scratch, sizeof(scratch), &ncc),
                     0);
    assert_int_equal(tvo_aff_refine(tpl, &model, SIDE, 1, &im, &w, 10, NAN, scratch, sizeof(scratch), &ncc),
                     0);
    assert_int_equal(tvo_aff_refine(NULL, &model, SIDE, 1, &im, &w, 10, 0.01f, scratch, sizeof(scratch),
                                    &ncc),
                     0);
    assert_int_equal(tvo_aff_refine(tpl, NULL, SIDE, 1, &im, &w, 10, 0.01f, scratch, sizeof(scratch), &ncc),
                     0);
    assert_int_equal(tvo_aff_refine(tpl, &model, SIDE, 1, NULL, &w, 10, 0.01f, scratch, sizeof(scratch),
                                    &ncc),
                     0);
    assert_int_equal(tvo_aff_refine(tpl, &model, SIDE, 1, &im, NULL, 10, 0.01f, scratch, sizeof(scratch),
                                    &ncc),
                     0);
    assert_memory_equal(&w, &w0, sizeof(w));
}

/* What the refinement is for: under a 12 % zoom a translation-only Lucas-Kanade fit of a window whose
 * texture is off its centre is tenths of a pixel off (the fit below: Gauss-Newton on the exact images
 * to convergence), while the affine refinement finds the point to 0.05 px. */
static void test_translation_only_is_worse(void **state)
{
    const double M[4] = {1.12, 0.0, 0.0, 1.12}, p1[2] = {80.0, 60.0};
    static uint8_t a[W * H], b[W * H];
    const double I[4] = {1, 0, 0, 1}, p0[2] = {86.0, 66.0}; /* a corner of the blobs, energy off centre */
    double num[2] = {0, 0}, den = 0.0, e_aff;
    (void)state;
    /* translation-only Lucas-Kanade at p0 (one window, Gauss-Newton to convergence, on the exact
       images): the shift that best aligns the undeformed window */
    render(a, I, p1, p1, 1.0, 0.0);
    render(b, M, p1, p1, 1.0, 0.0);
    {
        double gxx = 0, gxy = 0, gyy = 0, dx = 0.0, dy = 0.0;
        for (int it = 0; it < 50; ++it) {
            double bx = 0, by = 0;
            gxx = gxy = gyy = 0;
            for (int y = -10; y <= 10; ++y)
                for (int x = -10; x <= 10; ++x) {
                    const int ax = (int)p0[0] + x, ay = (int)p0[1] + y;
                    const double ix = 0.5 * (a[ay * W + ax + 1] - a[ay * W + ax - 1]);
                    const double iy = 0.5 * (a[(ay + 1) * W + ax] - a[(ay - 1) * W + ax]);
                    /* bilinear sample of b at (ax + dx, ay + dy) */
                    const double px = ax + dx, py = ay + dy;
                    const int x0 = (int)floor(px), y0 = (int)floor(py);
                    const double fx = px - x0, fy = py - y0;
                    const double v = (1 - fy) * ((1 - fx) * b[y0 * W + x0] + fx * b[y0 * W + x0 + 1]) +
                            fy * ((1 - fx) * b[(y0 + 1) * W + x0] + fx * b[(y0 + 1) * W + x0 + 1]);
                    const double e = v - a[ay * W + ax];
                    gxx += ix * ix;
                    gxy += ix * iy;
                    gyy += iy * iy;
                    bx += ix * e;
                    by += iy * e;
                }
            den = gxx * gyy - gxy * gxy;
            num[0] = (gyy * bx - gxy * by) / den;
            num[1] = (gxx * by - gxy * bx) / den;
            dx -= num[0];
            dy -= num[1];
        }
        /* the true position of p0 in b: M (p0 - p1) + p1 */
        {
            const double tx = M[0] * (p0[0] - p1[0]) + p1[0] - p0[0],
                         ty = M[3] * (p0[1] - p1[1]) + p1[1] - p0[1];
            const double e_lk = hypot(dx - tx, dy - ty);
            print_message("translation-only error %.3f px\n", e_lk);
            assert_true(e_lk > 0.15); /* the translation-only fit is pulled off by the zoom */
        }
    }
    /* the affine refinement on a point with the same deformation */
    {
        const double q1[2] = {80.0 + 0.4, 60.0 - 0.3}, o[2] = {0.5, 0.5};
        e_aff = run(M, q1, o, 1.0, 0.0, NULL);
        assert_true(e_aff >= 0.0 && e_aff < 0.05);
    }
}

/* The template's gradients and grey values at every st-th pixel of the window, as the refinement's
 * scratch holds them (rows of tvo_aff_cols(m) floats, the padding columns 0). */
static void template_arrays(const uint8_t *tpl, int32_t st, float *gx, float *gy, float *tf)
{
    const int32_t m = tvo_aff_samples(SIDE, st), cols = tvo_aff_cols(m);
    for (int r = 0; r < m; ++r)
        for (int c = 0; c < cols; ++c) {
            const uint8_t *q = tpl + (r * st + 1) * (SIDE + 2) + c * st + 1;
            gx[r * cols + c] = c < m ? 0.5f * (float)(q[1] - q[-1]) : 0.0f;
            gy[r * cols + c] = c < m ? 0.5f * (float)(q[SIDE + 2] - q[-(SIDE + 2)]) : 0.0f;
            tf[r * cols + c] = c < m ? (float)q[0] : 0.0f;
        }
}

/* The SIMD kernel of the window sums gives the portable kernel's bits (on a target without one both
 * calls run the portable kernel): every sum over many warps and sub-pixel positions, a whole refinement
 * from several starts, a window that ends 1/64 px from the image's last column, and (with a SIMD kernel)
 * an image view whose byte offsets pass 2^24. */
static void test_kernels_agree(void **state)
{
    static uint8_t a[W * H], b[W * H], tpl[(SIDE + 2) * (SIDE + 2)];
    const double I[4] = {1, 0, 0, 1}, M[4] = {1.07, 0.05, -0.04, 0.95}, p0[2] = {80.0, 60.0},
                 p1[2] = {81.3, 58.6};
    tvo_image ia = tvo_image_make(W, H, W, a), ib = tvo_image_make(W, H, W, b);
    tvo_aff_model model;
    tvo_aff_warp w;
    float *gx = scratch, *gy, *tf;
    int compared = 0;
    (void)state;
    render(a, I, p0, p0, 1.0, 0.0);
    render(b, M, p0, p1, 1.1, -7.0);
    assert_int_equal(tvo_aff_take(&ia, (float)p0[0], (float)p0[1], SIDE, 1, tpl, &model, &w), 1);
    for (int32_t st = 1; st <= 2; ++st) { /* every pixel, every other pixel */
        const int32_t m = tvo_aff_samples(SIDE, st), cols = tvo_aff_cols(m);
        gy = gx + m * cols;
        tf = gy + m * cols;
        template_arrays(tpl, st, gx, gy, tf);
        for (int k = 0; k < 200; ++k) {
            const double A[4] = {1.0 + 0.003 * (k % 7) - 0.01, 0.002 * (k % 5) - 0.004,
                                 0.0015 * (k % 3) - 0.002, 1.0 - 0.002 * (k % 11) + 0.01};
            double t[2] = {40.0 + 0.37 * k + 0.013 * k * k / 10.0, 30.0 + 0.29 * k};
            tvo_aff_sums sp, ss;
            t[0] = fmod(t[0], (double)W - 40.0) + 15.0;
            t[1] = fmod(t[1], (double)H - 40.0) + 15.0;
            tvo_aff_sums_portable(&ib, gx, gy, tf, SIDE, st, A, t, &sp);
#if TVO_AFF_SIMD
            tvo_aff_sums_simd(&ib, gx, gy, tf, SIDE, st, A, t, &ss);
#else
            tvo_aff_sums_portable(&ib, gx, gy, tf, SIDE, st, A, t, &ss);
#endif
            assert_memory_equal(&sp, &ss, sizeof(sp));
            ++compared;
        }
    }
    gy = gx + SIDE * tvo_aff_cols(SIDE);
    tf = gy + SIDE * tvo_aff_cols(SIDE);
    /* whole refinements from several starts, through the public entry and the portable one */
    for (int k = 0; k < 9; ++k) {
        tvo_aff_warp wf = w, wp = w;
        float nf = 0.0f, np = 0.0f;
        int of, op;
        wf.t[0] = wp.t[0] = w.t[0] + (float)(p1[0] - p0[0]) + 0.3f * (float)(k % 3 - 1);
        wf.t[1] = wp.t[1] = w.t[1] + (float)(p1[1] - p0[1]) + 0.3f * (float)(k / 3 - 1);
        of = tvo_aff_refine_kernel(tpl, &model, SIDE, 1, &ib, &wf, 10, 0.01f, scratch, sizeof(scratch), &nf,
                                   0);
        op = tvo_aff_refine_kernel(tpl, &model, SIDE, 1, &ib, &wp, 10, 0.01f, scratch, sizeof(scratch), &np,
                                   1);
        assert_int_equal(of, op);
        assert_int_equal(of, 1);
        assert_memory_equal(&wf, &wp, sizeof(wf));
        assert_memory_equal(&nf, &np, sizeof(nf));
    }
    /* a window whose right edge lies 1/64 px or less inside the last column is refused; the kernels agree on
       one just inside that limit */
    {
        const double A[4] = {1, 0, 0, 1}, t[2] = {(double)(W - 1) - 10.0 - 1.0 / 128.0, 60.0},
                     t2[2] = {(double)(W - 1) - 10.0 - 1.0 / 32.0, 60.0};
        tvo_aff_warp edge = w;
        tvo_aff_sums sp, ss;
        float n = 0.0f;
        edge.t[0] = (float)t[0];
        edge.t[1] = (float)t[1];
        assert_int_equal(tvo_aff_refine(tpl, &model, SIDE, 1, &ib, &edge, 1, 100.0f, scratch, sizeof(scratch),
                                        &n),
                         TVO_AFF_AT_BORDER);
        tvo_aff_sums_portable(&ib, gx, gy, tf, SIDE, 1, A, t2, &sp);
#if TVO_AFF_SIMD
        tvo_aff_sums_simd(&ib, gx, gy, tf, SIDE, 1, A, t2, &ss);
#else
        tvo_aff_sums_portable(&ib, gx, gy, tf, SIDE, 1, A, t2, &ss);
#endif
        assert_memory_equal(&sp, &ss, sizeof(sp));
    }
    /* the same image in a view whose byte offsets pass 2^24, where the SIMD kernels find the pixels'
       offsets in integers instead of float; only where there is a SIMD kernel to compare (without one
       both calls are the portable kernel, and the 17 MB view does not fit a microcontroller's RAM) */
#if TVO_AFF_SIMD
    {
        const int32_t stride = (1 << 24) / (H - 1) + 1;
        uint8_t *big = malloc((size_t)(H - 1) * (size_t)stride + W);
        tvo_image ig = tvo_image_make(W, H, stride, big);
        assert_non_null(big);
        assert_true((double)stride * H >= 16777216.0);
        for (int y = 0; y < H; ++y)
            memcpy(big + (size_t)y * (size_t)stride, b + y * W, W);
        for (int32_t st = 1; st <= 2; ++st) {
            const int32_t m = tvo_aff_samples(SIDE, st), cols = tvo_aff_cols(m);
            gy = gx + m * cols;
            tf = gy + m * cols;
            template_arrays(tpl, st, gx, gy, tf);
            for (int k = 0; k < 50; ++k) {
                const double A[4] = {1.0 + 0.003 * (k % 7) - 0.01, 0.002 * (k % 5) - 0.004,
                                     0.0015 * (k % 3) - 0.002, 1.0 - 0.002 * (k % 11) + 0.01};
                const double t[2] = {15.0 + fmod(0.37 * k * 7.0, (double)W - 40.0),
                                     15.0 + fmod(0.29 * k * 5.0, (double)H - 40.0)};
                tvo_aff_sums sp, ss;
                tvo_aff_sums_portable(&ig, gx, gy, tf, SIDE, st, A, t, &sp);
                tvo_aff_sums_simd(&ig, gx, gy, tf, SIDE, st, A, t, &ss);
                assert_memory_equal(&sp, &ss, sizeof(sp));
                ++compared;
            }
        }
        free(big);
    }
#endif
    print_message("kernels: %d window sums and 9 refinements identical (%s)\n", compared,
                  TVO_AFF_SIMD ? "simd against portable" : "portable only");
}

/* The model as tvo_aff_take computed it before its sums went to integers: every sum in double, pixel by
 * pixel, then the same Cholesky factorisation. tvo_aff_take must give these bits. */
static int ref_chol6(double L[21])
{
    for (int j = 0; j < 6; ++j) {
        double d = L[j * (j + 1) / 2 + j];
        const double d0 = d;
        for (int k = 0; k < j; ++k)
            d -= L[j * (j + 1) / 2 + k] * L[j * (j + 1) / 2 + k];
        if (!(d > 1e-9 * d0) || !(d0 > 0.0))
            return 0;
        d = sqrt(d);
        L[j * (j + 1) / 2 + j] = d;
        for (int i = j + 1; i < 6; ++i) {
            double v = L[i * (i + 1) / 2 + j];
            for (int k = 0; k < j; ++k)
                v -= L[i * (i + 1) / 2 + k] * L[j * (j + 1) / 2 + k];
            L[i * (i + 1) / 2 + j] = v / d;
        }
    }
    return 1;
}

static int ref_model(const uint8_t *tpl, int32_t side, int32_t step, tvo_aff_model *model)
{
    const int32_t h = side / 2, s = side + 2, n = tvo_aff_samples(side, step) * tvo_aff_samples(side, step);
    double hm[21]; /* H, the window height's name here */
    memset(hm, 0, sizeof(hm));
    memset(model, 0, sizeof(*model));
    for (int32_t yy = -h; yy <= h; yy += step) {
        const uint8_t *p = tpl + (size_t)(yy + h + 1) * (size_t)s + 1;
        for (int32_t xx = -h; xx <= h; xx += step) {
            const int32_t c = xx + h;
            const double gx = 0.5 * (double)((int)p[c + 1] - (int)p[c - 1]);
            const double gy = 0.5 * (double)((int)p[c + s] - (int)p[c - s]);
            const double tv = (double)p[c];
            const double sd[6] = {gx * xx, gx * yy, gy * xx, gy * yy, gx, gy};
            for (int i = 0; i < 6; ++i) {
                for (int j = 0; j <= i; ++j)
                    hm[i * (i + 1) / 2 + j] += sd[i] * sd[j];
                model->sdt[i] += sd[i] * tv;
                model->sd1[i] += sd[i];
            }
            model->sum_t += tv;
            model->var_t += tv * tv;
        }
    }
    model->var_t -= model->sum_t * model->sum_t / (double)n;
    if (!(model->var_t > (double)n) || !ref_chol6(hm))
        return 0;
    memcpy(model->L, hm, sizeof(hm));
    return 1;
}

/* tvo_aff_take's model (its integer sums, and the SIMD ones where built in) is the double reference's,
 * bit for bit, for every odd side 3..31 and every step it accepts, on textures that reach the largest
 * sums: random grey levels, random 0 / 255 pixels, and 2 x 2 blocks of 0 and 255 in a checkerboard, whose
 * gradients are +-255/2 at every pixel in both directions (the largest |sd| and sum sd sd^T), at several
 * phases; plus a smooth texture and a flat one. */
static void test_take_matches_double_sums(void **state)
{
    static uint8_t img[W * H], tpl[(TVO_AFF_MAX_SIDE + 2) * (TVO_AFF_MAX_SIDE + 2)];
    tvo_image im = tvo_image_make(W, H, W, img);
    uint64_t seed = 0x9e3779b97f4a7c15ULL;
    int compared = 0, taken = 0;
    (void)state;
    for (int pat = 0; pat < 8; ++pat) {
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                uint8_t v;
                if (pat == 0)
                    v = (uint8_t)(tvo_test_rand(&seed) >> 56);
                else if (pat == 1)
                    v = (tvo_test_rand(&seed) >> 63) ? 255 : 0;
                else if (pat < 6) /* phases (0, 0), (1, 0), (0, 1), (1, 1) */
                    v = ((((x + (pat - 2) % 2) >> 1) ^ ((y + (pat - 2) / 2) >> 1)) & 1) ? 255 : 0;
                else if (pat == 6)
                    v = (uint8_t)floor(texture(x, y) + 0.5);
                else
                    v = 77;
                img[y * W + x] = v;
            }
        for (int32_t side = 3; side <= TVO_AFF_MAX_SIDE; side += 2)
            for (int32_t step = 1; step <= side / 2; ++step) {
                if (!tvo_aff_step_ok(side, step))
                    continue;
                for (int k = 0; k < 3; ++k) {
                    const float x = 40.0f + 31.3f * (float)k, y = 30.0f + 27.6f * (float)k;
                    tvo_aff_model mt, mr;
                    tvo_aff_warp w;
                    int ot, orf;
                    memset(&mt, 0xa5, sizeof(mt));
                    ot = tvo_aff_take(&im, x, y, side, step, tpl, &mt, &w);
                    orf = ref_model(tpl, side, step, &mr);
                    assert_int_equal(ot, orf);
                    assert_memory_equal(&mt, &mr, sizeof(mt));
                    ++compared;
                    taken += ot;
                }
            }
    }
    print_message("take: %d models identical to the double sums (%d taken)\n", compared, taken);
    assert_true(taken > compared / 2);
}

/* tvo_aff_refine's template arrays from the SIMD rows (step 1, sides of 8 samples or more) give the
 * portable code's results, for every side and step, from a scratch whose floats are all NaN before each
 * call (so a padding column left unwritten would spoil the sums): the same outcome, warp and correlation,
 * and a refinement that succeeds on most of them. */
static void test_refine_kernels_all_sides(void **state)
{
    static uint8_t a[W * H], b[W * H], tpl[(TVO_AFF_MAX_SIDE + 2) * (TVO_AFF_MAX_SIDE + 2)];
    static float big[TVO_AFF_MAX_SIDE * ((TVO_AFF_MAX_SIDE + 3) & ~3) * 3];
    const double I[4] = {1, 0, 0, 1}, M[4] = {1.04, 0.02, -0.03, 0.98}, p0[2] = {80.0, 60.0},
                 p1[2] = {80.6, 59.5};
    tvo_image ia = tvo_image_make(W, H, W, a), ib = tvo_image_make(W, H, W, b);
    int cases = 0, refined = 0;
    (void)state;
    render(a, I, p0, p0, 1.0, 0.0);
    render(b, M, p0, p1, 0.9, 12.0);
    for (int32_t side = 3; side <= TVO_AFF_MAX_SIDE; side += 2)
        for (int32_t step = 1; step <= side / 2; ++step) {
            tvo_aff_model model;
            tvo_aff_warp w, ws, wp;
            float ns = 0.0f, np = 0.0f;
            int os, op;
            if (!tvo_aff_step_ok(side, step) ||
                !tvo_aff_take(&ia, (float)p0[0], (float)p0[1], side, step, tpl, &model, &w))
                continue;
            w.t[0] += (float)(p1[0] - p0[0]) + 0.2f;
            w.t[1] += (float)(p1[1] - p0[1]) - 0.2f;
            ws = wp = w;
            memset(big, 0xff, sizeof(big));
            os = tvo_aff_refine_kernel(tpl, &model, side, step, &ib, &ws, 20, 0.01f, big, sizeof(big), &ns,
                                       0);
            memset(big, 0xff, sizeof(big));
            op = tvo_aff_refine_kernel(tpl, &model, side, step, &ib, &wp, 20, 0.01f, big, sizeof(big), &np,
                                       1);
            assert_int_equal(os, op);
            assert_memory_equal(&ws, &wp, sizeof(ws));
            assert_memory_equal(&ns, &np, sizeof(ns));
            ++cases;
            refined += os == 1;
        }
    print_message("refine: %d sides and steps identical (%d refined; %s)\n", cases, refined,
                  TVO_AFF_SIMD ? "simd rows against portable" : "portable only");
    assert_true(refined >= cases * 3 / 4);
}

#endif

int main(void)
{
#if TVO_WITH_AFFINE
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_recovers_affine),
            cmocka_unit_test(test_recovers_affine_step2),
            cmocka_unit_test(test_exposure_change),
            cmocka_unit_test(test_refused),
            cmocka_unit_test(test_refine_failures_leave_warp),
            cmocka_unit_test(test_translation_only_is_worse),
            cmocka_unit_test(test_kernels_agree),
            cmocka_unit_test(test_take_matches_double_sums),
            cmocka_unit_test(test_refine_kernels_all_sides),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
#else
    /* left out of this build (TVO_WITH_AFFINE 0): test_vo checks that the VO refuses to use it */
    printf("test_affine: the affine refinement is left out of this build (TVO_WITH_AFFINE 0)\n");
    return 0;
#endif
}
