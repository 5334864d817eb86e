/* SPDX-License-Identifier: Apache-2.0 */
#include "tinyvo/image.h"

#include <stddef.h>
#include <stdint.h>

tvo_image tvo_image_make(int32_t width, int32_t height, int32_t stride, uint8_t *data)
{
    tvo_image img = {width, height, stride, data};
    return img;
}

tvo_status tvo_image_check(const tvo_image *img)
{
    if (img == NULL || img->data == NULL)
        return TVO_ERR_NULL;
    if (img->width < 1 || img->height < 1 || img->width > TVO_MAX_IMAGE_DIM ||
        img->height > TVO_MAX_IMAGE_DIM || img->stride < img->width)
        return TVO_ERR_SIZE;
    /* Kernels form pixel offsets such as 3 * stride in int32 (FAST's circle), and address the last row
     * at (height - 1) * stride: bound both so that neither overflows (int32, and size_t / ptrdiff_t on
     * 32-bit targets). */
    if (img->stride > TVO_IMAGE_MAX_STRIDE ||
        (uint64_t)(img->height - 1) * (uint64_t)img->stride + (uint64_t)img->width > (uint64_t)PTRDIFF_MAX)
        return TVO_ERR_SIZE;
    return TVO_OK;
}
