/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the 8-bit grey image view.
 *
 * A view does not own its pixels. width, height and stride are const: a view is made once with
 * tvo_image_make() (or an initialiser) and its geometry never changes afterwards. Pixel (x, y) is
 * data[y * stride + x]. Valid views have 1 <= width, height <= TVO_MAX_IMAGE_DIM,
 * width <= stride <= TVO_IMAGE_MAX_STRIDE, (height - 1) * stride + width <= PTRDIFF_MAX (the view's
 * extent fits the address space; matters on 32-bit targets) and data != NULL; tvo_image_check() tells. */
#ifndef TINYVO_IMAGE_H
#define TINYVO_IMAGE_H

#include "tinyvo/types.h"
#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Largest accepted stride in bytes: keeps pixel offsets like 3 * stride inside int32. */
#define TVO_IMAGE_MAX_STRIDE (INT32_MAX / 4)

typedef struct tvo_image {
    const int32_t width;  /* pixels */
    const int32_t height; /* pixels */
    const int32_t stride; /* bytes from one row to the next, >= width */
    uint8_t *data;        /* first pixel; owned by the caller */
} tvo_image;

/* Make a view. Does not validate: pass the result to tvo_image_check(). */
TVO_API tvo_image tvo_image_make(int32_t width, int32_t height, int32_t stride, uint8_t *data);

/* TVO_OK for a valid view; TVO_ERR_NULL for a NULL view or data; TVO_ERR_SIZE for a bad size/stride. */
TVO_API tvo_status tvo_image_check(const tvo_image *img);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_IMAGE_H */
