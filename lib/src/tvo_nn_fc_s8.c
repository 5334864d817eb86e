/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: fully connected int8 kernels (int8 x int8 -> int32), portable C.
 *
 * The inner loop is a plain dot product over contiguous rows that GCC and Clang vectorise at -O2/-O3
 * (widening multiplies + horizontal add); four output rows are processed at once so that each input
 * vector load is shared. Integer arithmetic is exact, so any loop order gives the same result. */
#include "tinyvo/nn.h"

static int32_t tvo_dot_s8(const int8_t *a, const int8_t *b, int32_t n)
{
    int32_t acc = 0;
    int32_t i;
    for (i = 0; i < n; ++i)
        acc += (int32_t)a[i] * (int32_t)b[i];
    return acc;
}

static void tvo_fc_acc(const int8_t *x, const int8_t *w, const int32_t *bias, int32_t n_in, int32_t n_out,
                       int32_t *acc)
{
    int32_t o = 0;
    for (; o + 4 <= n_out; o += 4) {
        const int8_t *w0 = w + (size_t)o * (size_t)n_in;
        const int8_t *w1 = w0 + n_in;
        const int8_t *w2 = w1 + n_in;
        const int8_t *w3 = w2 + n_in;
        int32_t a0 = 0, a1 = 0, a2 = 0, a3 = 0;
        int32_t i;
        for (i = 0; i < n_in; ++i) {
            int32_t xi = x[i];
            a0 += (int32_t)w0[i] * xi;
            a1 += (int32_t)w1[i] * xi;
            a2 += (int32_t)w2[i] * xi;
            a3 += (int32_t)w3[i] * xi;
        }
        acc[o] = bias[o] + a0;
        acc[o + 1] = bias[o + 1] + a1;
        acc[o + 2] = bias[o + 2] + a2;
        acc[o + 3] = bias[o + 3] + a3;
    }
    for (; o < n_out; ++o)
        acc[o] = bias[o] + tvo_dot_s8(w + (size_t)o * (size_t)n_in, x, n_in);
}

void tvo_nn_fc_s8(const int8_t *x, const int8_t *w, const int32_t *bias, const int32_t *mult,
                  const int32_t *shift, int32_t out_zp, int32_t n_in, int32_t n_out, int8_t *y)
{
    int32_t acc[4];
    int32_t o = 0;
    while (o < n_out) {
        int32_t k, m = n_out - o < 4 ? n_out - o : 4;
        tvo_fc_acc(x, w + (size_t)o * (size_t)n_in, bias + o, n_in, m, acc);
        for (k = 0; k < m; ++k) {
            int32_t v = tvo_nn_requantize(acc[k], mult[o + k], shift[o + k]) + out_zp;
            v = v < -128 ? -128 : (v > 127 ? 127 : v);
            y[o + k] = (int8_t)v;
        }
        o += m;
    }
}

void tvo_nn_fc_s8_f32(const int8_t *x, const int8_t *w, const int32_t *bias, const float *scale, int32_t n_in,
                      int32_t n_out, float *y)
{
    int32_t o;
    for (o = 0; o < n_out; ++o) {
        int32_t acc = bias[o] + tvo_dot_s8(w + (size_t)o * (size_t)n_in, x, n_in);
        float a = (float)acc;
        y[o] = a * scale[o];
    }
}

void tvo_nn_fc_s8_cols(const int8_t *x, const int8_t *wt, const int32_t *bias, const int32_t *mult,
                       const int32_t *shift, int32_t out_zp, int32_t n_in, int32_t n_out, int8_t *y)
{
    int32_t acc[64];
    int32_t o0, o, i;
    for (o0 = 0; o0 < n_out; o0 += 64) {
        int32_t m = n_out - o0 < 64 ? n_out - o0 : 64;
        for (o = 0; o < m; ++o)
            acc[o] = bias[o0 + o];
        for (i = 0; i < n_in; ++i) {
            const int8_t *r = wt + (size_t)i * (size_t)n_out + o0;
            int32_t xi = x[i];
            for (o = 0; o < m; ++o)
                acc[o] += (int32_t)r[o] * xi;
        }
        for (o = 0; o < m; ++o) {
            int32_t v = tvo_nn_requantize(acc[o], mult[o0 + o], shift[o0 + o]) + out_zp;
            v = v < -128 ? -128 : (v > 127 ? 127 : v);
            y[o0 + o] = (int8_t)v;
        }
    }
}
