/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: 256-entry int8 lookup-table activation. */
#include "tinyvo/nn.h"

void tvo_nn_lut_s8(int8_t *x, int32_t n, const int8_t lut[256])
{
    int32_t i;
    for (i = 0; i < n; ++i)
        x[i] = lut[(int32_t)x[i] + 128];
}
