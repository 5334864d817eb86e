/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: affine refinement of a track against its template. See tvo_affine.h. */
#include "tvo_affine.h"

#include <math.h>
#include <string.h>

#include "tinyvo/options.h"

#if TVO_WITH_AFFINE

/* packed lower-triangle index of (i, j), j <= i */
#define TRI(i, j) ((i) * ((i) + 1) / 2 + (j))

static int side_ok(int32_t side)
{
    return side >= 3 && side <= TVO_AFF_MAX_SIDE && (side & 1) == 1;
}

size_t tvo_aff_scratch_size(int32_t side)
{
    if (!side_ok(side))
        return 0;
    return (size_t)side * (size_t)tvo_aff_cols(side) * 3 * sizeof(float);
}

/* The template's central-difference gradients and grey values at the window's samples (every step-th
 * pixel of the side x side window, m = tvo_aff_samples(side, step) per row and column), row by row in
 * rows of tvo_aff_cols(m) floats, the padding columns 0 (the kernels read them); gy and tf follow gx in
 * the scratch. Exact values (half-integers and integers), so the SIMD rows (portable 0) give the same.
 * Each row's last 4 columns are zeroed first and its samples written over them: no memset of the whole
 * arrays. */
static void gradients(const uint8_t *tpl, int32_t side, int32_t step, float *gx, float *gy, float *tf,
                      int portable)
{
    const int32_t s = side + 2, m = tvo_aff_samples(side, step), cols = tvo_aff_cols(m);
    (void)portable; /* only the portable rows without SIMD */
    for (int32_t r = 0; r < m; ++r) {
        const uint8_t *p = tpl + (size_t)(r * step + 1) * (size_t)s + 1;
        const size_t o = (size_t)r * (size_t)cols;
        for (int32_t c = cols - 4; c < cols; ++c) {
            gx[o + (size_t)c] = 0.0f;
            gy[o + (size_t)c] = 0.0f;
            tf[o + (size_t)c] = 0.0f;
        }
#if TVO_AFF_SIMD
        if (!portable && step == 1 && m >= TVO_AFF_TPL_SIMD_MIN) {
            tvo_aff_gradients_row_simd(p, s, m, gx + o, gy + o, tf + o);
            continue;
        }
#endif
        for (int32_t c = 0; c < m; ++c) {
            const uint8_t *q = p + c * step;
            gx[o + (size_t)c] = 0.5f * (float)((int)q[1] - (int)q[-1]);
            gy[o + (size_t)c] = 0.5f * (float)((int)q[s] - (int)q[-s]);
            tf[o + (size_t)c] = (float)q[0];
        }
    }
}

void tvo_aff_sums_portable(const tvo_image *img, const float *gx, const float *gy, const float *tf,
                           int32_t side, int32_t step, const double A[4], const double t[2], tvo_aff_sums *s)
{
    const int32_t h = side / 2, m = tvo_aff_samples(side, step), cols = tvo_aff_cols(m);
    const size_t stride = (size_t)img->stride;
    const float ax = (float)A[0], ay = (float)A[2];
    memset(s, 0, sizeof(*s));
    for (int32_t r = 0; r < m; ++r) {
        const int32_t yy = r * step - h;
        const size_t row = (size_t)r * (size_t)cols;
        const float bx = (float)(A[0] * -h + A[1] * yy + t[0]), by = (float)(A[2] * -h + A[3] * yy + t[1]);
        float lane[7][4];
        for (int32_t l = 0; l < 4; ++l) { /* lane l: the columns j = l (mod 4), in order */
            float a0 = 0.0f, a1 = 0.0f, a2 = 0.0f, a3 = 0.0f, a4 = 0.0f, a5 = 0.0f, a6 = 0.0f;
            for (int32_t j = l; j < cols; j += 4) {
                /* a padding column samples the row's last sample and adds zeros */
                const float fj = (float)((j < m ? j : m - 1) * step), xf = (float)(j * step - h);
                const float px = bx + ax * fj, py = by + ay * fj;
                const int32_t ix = (int32_t)px, iy = (int32_t)py;
                const float fx = px - (float)ix, fy = py - (float)iy;
                const uint8_t *p = img->data + (size_t)iy * stride + (size_t)ix;
                const float top = (float)p[0] + fx * (float)((int)p[1] - (int)p[0]);
                const float bot = (float)p[stride] + fx * (float)((int)p[stride + 1] - (int)p[stride]);
                const float v = top + fy * (bot - top), vm = j < m ? v : 0.0f;
                const float a = gx[row + (size_t)j] * v, b = gy[row + (size_t)j] * v;
                a0 += a;
                a1 += a * xf;
                a2 += b;
                a3 += b * xf;
                a4 += vm;
                a5 += vm * vm;
                a6 += vm * tf[row + (size_t)j];
            }
            lane[0][l] = a0;
            lane[1][l] = a1;
            lane[2][l] = a2;
            lane[3][l] = a3;
            lane[4][l] = a4;
            lane[5][l] = a5;
            lane[6][l] = a6;
        }
        {
            float rs[7];
            for (int k = 0; k < 7; ++k)
                rs[k] = (lane[k][0] + lane[k][1]) + (lane[k][2] + lane[k][3]);
            tvo_aff_add_row(s, rs, yy);
        }
    }
}

/* In-place Cholesky of a packed symmetric 6x6 matrix. 0 when it is not clearly positive definite (a
 * flat template, or texture in one direction only). */
static int chol6(double L[21])
{
    for (int j = 0; j < 6; ++j) {
        double d = L[TRI(j, j)];
        const double d0 = d;
        for (int k = 0; k < j; ++k)
            d -= L[TRI(j, k)] * L[TRI(j, k)];
        if (!(d > 1e-9 * d0) || !(d0 > 0.0))
            return 0;
        d = sqrt(d);
        L[TRI(j, j)] = d;
        for (int i = j + 1; i < 6; ++i) {
            double v = L[TRI(i, j)];
            for (int k = 0; k < j; ++k)
                v -= L[TRI(i, k)] * L[TRI(j, k)];
            L[TRI(i, j)] = v / d;
        }
    }
    return 1;
}

static void chol6_solve(const double L[21], const double b[6], double x[6])
{
    double y[6] = {0, 0, 0, 0, 0, 0};
    for (int i = 0; i < 6; ++i) {
        double v = b[i];
        for (int k = 0; k < i; ++k)
            v -= L[TRI(i, k)] * y[k];
        y[i] = v / L[TRI(i, i)];
    }
    for (int i = 5; i >= 0; --i) {
        double v = y[i];
        for (int k = i + 1; k < 6; ++k)
            v -= L[TRI(k, i)] * x[k];
        x[i] = v / L[TRI(i, i)];
    }
}

/* One row of samples' sums over x, in int32, for the products P = dx dx, dx dy, dy dy (r[0..8]: sum P,
 * sum P x, sum P x^2 of each), dx T and dy T (r[9..12]: sum, sum x of each), dx and dy (r[13..16]: the
 * same) and T (r[17], r[18]: sum T, sum T^2). p is the row's first sample, s the template's row stride,
 * m the samples, x = c step - h at sample c. Bounds (|P| <= 255^2, |x| <= 15, at most 31 samples):
 * sum |P x^2| <= 255^2 * 2 * (1^2 + ... + 15^2) = 161,262,000 < 2^31, and every other row sum less. */
static void take_row(const uint8_t *p, int32_t s, int32_t m, int32_t step, int32_t h, int32_t r[19])
{
    int32_t a[19] = {0};
    for (int32_t c = 0; c < m; ++c) {
        const uint8_t *q = p + c * step;
        const int32_t x = c * step - h, dx = (int32_t)q[1] - (int32_t)q[-1],
                      dy = (int32_t)q[s] - (int32_t)q[-s];
        const int32_t t = q[0], xx = dx * dx, xy = dx * dy, yy = dy * dy, xt = dx * t, yt = dy * t;
        a[0] += xx;
        a[1] += xx * x;
        a[2] += xx * x * x;
        a[3] += xy;
        a[4] += xy * x;
        a[5] += xy * x * x;
        a[6] += yy;
        a[7] += yy * x;
        a[8] += yy * x * x;
        a[9] += xt;
        a[10] += xt * x;
        a[11] += yt;
        a[12] += yt * x;
        a[13] += dx;
        a[14] += dx * x;
        a[15] += dy;
        a[16] += dy * x;
        a[17] += t;
        a[18] += t * t;
    }
    memcpy(r, a, sizeof(a));
}

/* tvo_aff_take's sums, in integers. With dx = q[1] - q[-1] and dy = q[s] - q[-s] (twice the gradients gx,
 * gy: byte differences, |dx|, |dy| <= 255) and the template coordinates x, y (|x|, |y| <= h <= 15), the
 * steepest-descent row is sd = S / 2 with the integer row S = [dx x, dx y, dy x, dy y, dx, dy], |S| <= 255 *
 * 15 = 3825, and the model's sums are H = sum S S^T / 4, sum sd T = sum S T / 2, sum sd = sum S / 2. The
 * double sums pixel by pixel these replace (test_affine keeps them as its reference) were exact: each term
 * is a multiple of 1/4 (of 1/2 for sum sd T and sum sd) and so is each partial sum, at most 31^2 * 3825^2 /
 * 4 < 2^32 in magnitude, which a double holds exactly (34 significant bits). So they were these integers
 * scaled by 1/4 or 1/2, whatever the order, and (double)w * 0.25 and (double)w * 0.5 (exact: |w| < 2^53, a
 * power of 2) give their bits, +0 for a zero sum as the double sums, which started at +0, gave.
 * Over the rows of take_row()'s sums r (or tvo_aff_take_row_simd()'s at step 1: the same integers): sum r
 * (w0), sum y r (w1) for the r[] that y multiplies in S S^T, S T and S (yk), and sum y^2 r (w2) for r[0],
 * r[3], r[6] (sum P). A row sum times y or y^2 stays below 2^31 (at most 15^2 * 31 * 255^2 = 453,650,625,
 * y^2 sum P); the sums over the rows need 64 bits (sum S S^T up to 31^2 * 3825^2 < 2^34). H gets sum S S^T /
 * 4, model its other sums (sum T^2 in var_t). */
static void take_sums(const uint8_t *tpl, int32_t side, int32_t step, double H[21], tvo_aff_model *model)
{
    static const int8_t yk[10] = {0, 1, 3, 4, 6, 7, 9, 11, 13, 15};
    const int32_t h = side / 2, s = side + 2, m = tvo_aff_samples(side, step);
    int64_t w0[19], w1[10], w2[3];
    memset(w0, 0, sizeof(w0));
    memset(w1, 0, sizeof(w1));
    memset(w2, 0, sizeof(w2));
    for (int32_t y = -h; y <= h; y += step) {
        const uint8_t *p = tpl + (size_t)(y + h + 1) * (size_t)s + 1;
        int32_t r[19];
#if TVO_AFF_SIMD
        if (step == 1 && m >= TVO_AFF_TPL_SIMD_MIN)
            tvo_aff_take_row_simd(p, s, m, h, r);
        else
#endif
            take_row(p, s, m, step, h, r);
        for (int i = 0; i < 19; ++i)
            w0[i] += r[i];
        for (int i = 0; i < 10; ++i)
            w1[i] += y * r[yk[i]];
        w2[0] += y * y * r[0];
        w2[1] += y * y * r[3];
        w2[2] += y * y * r[6];
    }
    /* S = [dx x, dx y, dy x, dy y, dx, dy]: S_i S_j is P x^a y^b (a + b <= 2), S_i T and S_i are dx T,
       dy T, dx, dy times x or y or 1 */
    H[TRI(0, 0)] = (double)w0[2] * 0.25;
    H[TRI(1, 0)] = (double)w1[1] * 0.25;
    H[TRI(1, 1)] = (double)w2[0] * 0.25;
    H[TRI(2, 0)] = (double)w0[5] * 0.25;
    H[TRI(2, 1)] = (double)w1[3] * 0.25;
    H[TRI(2, 2)] = (double)w0[8] * 0.25;
    H[TRI(3, 0)] = (double)w1[3] * 0.25;
    H[TRI(3, 1)] = (double)w2[1] * 0.25;
    H[TRI(3, 2)] = (double)w1[5] * 0.25;
    H[TRI(3, 3)] = (double)w2[2] * 0.25;
    H[TRI(4, 0)] = (double)w0[1] * 0.25;
    H[TRI(4, 1)] = (double)w1[0] * 0.25;
    H[TRI(4, 2)] = (double)w0[4] * 0.25;
    H[TRI(4, 3)] = (double)w1[2] * 0.25;
    H[TRI(4, 4)] = (double)w0[0] * 0.25;
    H[TRI(5, 0)] = (double)w0[4] * 0.25;
    H[TRI(5, 1)] = (double)w1[2] * 0.25;
    H[TRI(5, 2)] = (double)w0[7] * 0.25;
    H[TRI(5, 3)] = (double)w1[4] * 0.25;
    H[TRI(5, 4)] = (double)w0[3] * 0.25;
    H[TRI(5, 5)] = (double)w0[6] * 0.25;
    model->sdt[0] = (double)w0[10] * 0.5;
    model->sdt[1] = (double)w1[6] * 0.5;
    model->sdt[2] = (double)w0[12] * 0.5;
    model->sdt[3] = (double)w1[7] * 0.5;
    model->sdt[4] = (double)w0[9] * 0.5;
    model->sdt[5] = (double)w0[11] * 0.5;
    model->sd1[0] = (double)w0[14] * 0.5;
    model->sd1[1] = (double)w1[8] * 0.5;
    model->sd1[2] = (double)w0[16] * 0.5;
    model->sd1[3] = (double)w1[9] * 0.5;
    model->sd1[4] = (double)w0[13] * 0.5;
    model->sd1[5] = (double)w0[15] * 0.5;
    model->sum_t = (double)w0[17];
    model->var_t = (double)w0[18];
}

int tvo_aff_take(const tvo_image *img, float x, float y, int32_t side, int32_t step, uint8_t *tpl,
                 tvo_aff_model *model, tvo_aff_warp *w)
{
    const int32_t h = side / 2, s = side + 2;
    int32_t cx, cy;
    double H[21];
    int32_t n;
    if (img == NULL || img->data == NULL || tpl == NULL || model == NULL || w == NULL || !side_ok(side) ||
        !tvo_aff_step_ok(side, step))
        return 0;
    n = tvo_aff_samples(side, step) * tvo_aff_samples(side, step);
    if (!(x >= 0.0f && y >= 0.0f && x <= (float)(img->width - 1) && y <= (float)(img->height - 1)))
        return 0;
    cx = (int32_t)floorf(x + 0.5f);
    cy = (int32_t)floorf(y + 0.5f);
    if (cx - h - 1 < 0 || cy - h - 1 < 0 || cx + h + 1 > img->width - 1 || cy + h + 1 > img->height - 1)
        return 0;
    for (int32_t r = 0; r < s; ++r)
        memcpy(tpl + (size_t)r * (size_t)s,
               img->data + (size_t)(cy - h - 1 + r) * (size_t)img->stride + (cx - h - 1), (size_t)s);
    memset(model, 0, sizeof(*model));
    take_sums(tpl, side, step, H, model);
    model->var_t -= model->sum_t * model->sum_t / (double)n;
    if (!(model->var_t > (double)n)) /* contrast below 1 grey level */
        return 0;
    if (!chol6(H))
        return 0;
    memcpy(model->L, H, sizeof(H));
    w->A[0] = 1.0f;
    w->A[1] = 0.0f;
    w->A[2] = 0.0f;
    w->A[3] = 1.0f;
    w->t[0] = (float)cx;
    w->t[1] = (float)cy;
    w->d[0] = x - (float)cx;
    w->d[1] = y - (float)cy;
    return 1;
}

void tvo_aff_point(const tvo_aff_warp *w, float *x, float *y)
{
    *x = w->A[0] * w->d[0] + w->A[1] * w->d[1] + w->t[0];
    *y = w->A[2] * w->d[0] + w->A[3] * w->d[1] + w->t[1];
}

/* 1 when the warped window (a parallelogram) lies where bilinear sampling has its 4 taps: its corners
 * in [0, width - 1) x [0, height - 1), with a margin of 1/64 px on the far sides so that no pixel
 * position rounded in float reaches the last column or row. */
static int window_inside(const double A[4], const double t[2], int32_t h, const tvo_image *img)
{
    const double xmax = (double)(img->width - 1) - 1.0 / 64.0, ymax = (double)(img->height - 1) - 1.0 / 64.0;
    for (int c = 0; c < 4; ++c) {
        const double cx = (c & 1) ? h : -h, cy = (c & 2) ? h : -h;
        const double px = A[0] * cx + A[1] * cy + t[0], py = A[2] * cx + A[3] * cy + t[1];
        if (!(px >= 0.0 && py >= 0.0 && px < xmax && py < ymax))
            return 0;
    }
    return 1;
}

/* W <- W o W(dp)^-1 for the warp (A, t) and the step W(dp) = [1+dp0 dp1 dp4; dp2 1+dp3 dp5]; 0 when the
 * step degenerates (determinant outside [1/4, 4]) or the result is not finite. */
static int compose_inverse(double A[4], double t[2], const double dp[6])
{
    double Mi[4], ti[2], An[4];
    const double det = (1.0 + dp[0]) * (1.0 + dp[3]) - dp[1] * dp[2];
    if (!(det > 0.25 && det < 4.0))
        return 0;
    Mi[0] = (1.0 + dp[3]) / det;
    Mi[1] = -dp[1] / det;
    Mi[2] = -dp[2] / det;
    Mi[3] = (1.0 + dp[0]) / det;
    ti[0] = -(Mi[0] * dp[4] + Mi[1] * dp[5]);
    ti[1] = -(Mi[2] * dp[4] + Mi[3] * dp[5]);
    An[0] = A[0] * Mi[0] + A[1] * Mi[2];
    An[1] = A[0] * Mi[1] + A[1] * Mi[3];
    An[2] = A[2] * Mi[0] + A[3] * Mi[2];
    An[3] = A[2] * Mi[1] + A[3] * Mi[3];
    t[0] += A[0] * ti[0] + A[1] * ti[1];
    t[1] += A[2] * ti[0] + A[3] * ti[1];
    memcpy(A, An, sizeof(An));
    return isfinite(A[0]) && isfinite(A[1]) && isfinite(A[2]) && isfinite(A[3]) && isfinite(t[0]) &&
            isfinite(t[1]);
}

int tvo_aff_refine_kernel(const uint8_t *tpl, const tvo_aff_model *model, int32_t side, int32_t step,
                          const tvo_image *img, tvo_aff_warp *w, int32_t max_iters, float eps, void *scratch,
                          size_t scratch_size, float *ncc, int portable)
{
    const int32_t h = side / 2;
    int32_t n, m;
    float *gx, *gy, *tf;
    double A[4], t[2], det, corr = 0.0, mean_t;
    int converged = 0;
    if (tpl == NULL || model == NULL || img == NULL || img->data == NULL || w == NULL || scratch == NULL ||
        !side_ok(side) || scratch_size < tvo_aff_scratch_size(side) || max_iters < 1 || !(eps > 0.0f) ||
        !tvo_aff_step_ok(side, step))
        return 0;
    m = tvo_aff_samples(side, step);
    n = m * m;
    gx = (float *)scratch;
    gy = gx + (size_t)m * (size_t)tvo_aff_cols(m);
    tf = gy + (size_t)m * (size_t)tvo_aff_cols(m);
    gradients(tpl, side, step, gx, gy, tf, portable);
    mean_t = model->sum_t / (double)n;
    for (int i = 0; i < 4; ++i)
        A[i] = (double)w->A[i];
    t[0] = (double)w->t[0];
    t[1] = (double)w->t[1];
    for (int32_t it = 0; it < max_iters && !converged; ++it) {
        tvo_aff_sums sm;
        double b[6], dp[6], g, mean_i, var_i;
        if (!window_inside(A, t, h, img))
            return TVO_AFF_AT_BORDER;
            /* one pass over the warped window: the patch's sums, its correlation with the template and
           sum sd I */
#if TVO_AFF_SIMD
        if (!portable)
            tvo_aff_sums_simd(img, gx, gy, tf, side, step, A, t, &sm);
        else
#endif
            tvo_aff_sums_portable(img, gx, gy, tf, side, step, A, t, &sm);
        mean_i = sm.sum_i / (double)n;
        var_i = sm.sum_i2 - sm.sum_i * mean_i;
        if (!(var_i > 1e-6 * model->var_t))
            return 0;
        corr = (sm.sum_it - sm.sum_i * mean_t) / sqrt(var_i * model->var_t);
        g = sqrt(model->var_t / var_i);
        /* b = sum sd e, e = (I - mean_i) g - (T - mean_t): the patch's mean and contrast matched to the
           template's */
        for (int i = 0; i < 6; ++i)
            b[i] = g * (sm.sdi[i] - mean_i * model->sd1[i]) - (model->sdt[i] - mean_t * model->sd1[i]);
        chol6_solve(model->L, b, dp);
        if (!compose_inverse(A, t, dp))
            return 0;
        /* the largest move of a window corner, bounded above */
        converged = sqrt(dp[4] * dp[4] + dp[5] * dp[5]) +
                        (double)h * (fabs(dp[0]) + fabs(dp[1]) + fabs(dp[2]) + fabs(dp[3])) <=
                (double)eps;
    }
    det = A[0] * A[3] - A[1] * A[2];
    if (!converged || !(det > 0.25 && det < 4.0))
        return 0;
    if (!window_inside(A, t, h, img))
        return TVO_AFF_AT_BORDER;
    if (ncc != NULL)
        *ncc = (float)corr; /* of the patch before the last step, which moved no corner by more than eps */
    for (int i = 0; i < 4; ++i)
        w->A[i] = (float)A[i];
    w->t[0] = (float)t[0];
    w->t[1] = (float)t[1];
    return 1;
}

int tvo_aff_refine(const uint8_t *tpl, const tvo_aff_model *model, int32_t side, int32_t step,
                   const tvo_image *img, tvo_aff_warp *w, int32_t max_iters, float eps, void *scratch,
                   size_t scratch_size, float *ncc)
{
    return tvo_aff_refine_kernel(tpl, model, side, step, img, w, max_iters, eps, scratch, scratch_size, ncc,
                                 0);
}
#else
/* left out of this build (TVO_WITH_AFFINE 0); ISO C wants a declaration in every translation unit */
typedef int tvo_affine_left_out;
#endif
