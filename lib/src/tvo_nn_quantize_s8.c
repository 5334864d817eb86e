/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the input stage of a branch: normalise float features and quantise them to int8.
 * float32 arithmetic only (each step rounded to float), ties-to-even rounding (rintf in the default
 * rounding mode), so that NumPy's float32 reference gives the same bits. */
#include <math.h>
#include "tinyvo/nn.h"

tvo_status tvo_nn_quantize_input_f32(const float *features, const uint8_t *ids, const float *norm_scale,
                                     const float *norm_offset, float in_scale, int32_t in_zp, int32_t n,
                                     int8_t *x)
{
    int32_t i;
    for (i = 0; i < n; ++i) {
        float f = features[ids[i]];
        float t, u;
        int32_t v;
        if (!(f == f) || f - f != 0.0f) /* NaN or +-inf */
            return TVO_ERR_NOT_FINITE;
        t = f * norm_scale[i];
        t = t + norm_offset[i];
        u = t / in_scale;
        if (u != u)
            return TVO_ERR_NOT_FINITE;
        /* clamp before converting: anything beyond +-512 saturates anyway */
        if (u > 512.0f)
            u = 512.0f;
        else if (u < -512.0f)
            u = -512.0f;
        v = (int32_t)rintf(u) + in_zp;
        v = v < -128 ? -128 : (v > 127 ? 127 : v);
        x[i] = (int8_t)v;
    }
    return TVO_OK;
}
