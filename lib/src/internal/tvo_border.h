/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo internal: image border handling shared by the pyramid, the corner responses and LK. */
#ifndef TVO_BORDER_H
#define TVO_BORDER_H

#include <stdint.h>

/* BORDER_REFLECT_101 index (..., 2, 1 | 0, 1, 2, ..., n-1 | n-2, ...) for any i; n >= 1. */
static inline int32_t tvo_reflect101(int32_t i, int32_t n)
{
    if (n == 1)
        return 0;
    while (i < 0 || i >= n) {
        if (i < 0)
            i = -i;
        else
            i = 2 * n - 2 - i;
    }
    return i;
}

#endif /* TVO_BORDER_H */
