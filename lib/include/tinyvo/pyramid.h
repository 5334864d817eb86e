/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: Gaussian image pyramids (8-bit grey) in caller-provided memory.
 *
 * Level 0 is a copy of the input image; level l+1 is level l downsampled by 2 exactly as OpenCV's
 * cv::pyrDown does it: 5x5 Gaussian [1 4 6 4 1]^T [1 4 6 4 1] / 256 centred on source pixel
 * (2x, 2y), BORDER_REFLECT_101 at the image edges, rounding (sum + 128) >> 8, output size
 * ((w + 1) / 2, (h + 1) / 2). The result is bit-identical to cv::pyrDown and to the levels of
 * cv::buildOpticalFlowPyramid (checked by test/oracle/test_lk_oracle.py).
 *
 * Memory: the pyramid owns nothing. tvo_pyramid_init() lays out every level, plus one row buffer
 * used while building, inside the block [mem, mem + mem_size) that the caller keeps alive as long as
 * the pyramid is used. Nothing is allocated. Build cost: about 4/3 * w * h copies plus
 * (25/4 + small) operations per source pixel of every downsampled level, no division.
 *
 * Limits: 1 <= levels <= TVO_MAX_PYR_LEVELS; level 0 obeys the image limits of image.h; every level
 * l >= 1 must be at least TVO_PYR_MIN_LEVEL_DIM pixels wide and high, otherwise the pyramid is
 * "deeper than the image allows" and init / required_size refuse it. */
#ifndef TINYVO_PYRAMID_H
#define TINYVO_PYRAMID_H

#include "tinyvo/image.h"
#include "tinyvo/types.h"
#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Smallest width and height (pixels) a level l >= 1 may have. */
#define TVO_PYR_MIN_LEVEL_DIM 8

typedef struct tvo_pyramid {
    int32_t levels;                     /* levels including level 0, 1..TVO_MAX_PYR_LEVELS */
    int32_t width[TVO_MAX_PYR_LEVELS];  /* pixels; width[l + 1] = (width[l] + 1) / 2 */
    int32_t height[TVO_MAX_PYR_LEVELS]; /* pixels; height[l + 1] = (height[l] + 1) / 2 */
    int32_t stride[TVO_MAX_PYR_LEVELS]; /* bytes between rows, >= width, multiple of 16 (a borrowed
                                              level 0: the stride of the image it points to) */
    uint8_t *data[TVO_MAX_PYR_LEVELS];  /* inside the caller's memory, 16-byte aligned */
    uint16_t *row_tmp;                  /* internal: build row buffer, inside the caller's memory */
    int32_t own0;                       /* internal: 1 level 0 in the caller's memory, 0 borrowed */
} tvo_pyramid;

/* Bytes of memory tvo_pyramid_init() needs for this geometry (any alignment of mem is fine: the
 * figure includes the slack to align). 0 when the geometry is invalid (size out of range, levels
 * out of range, or a level l >= 1 smaller than TVO_PYR_MIN_LEVEL_DIM). */
TVO_API size_t tvo_pyramid_required_size(int32_t width, int32_t height, int32_t levels);

/* Lay out a pyramid for width x height images with `levels` levels in [mem, mem + mem_size).
 * Errors: TVO_ERR_NULL (p or mem NULL), TVO_ERR_SIZE (width/height out of 1..TVO_MAX_IMAGE_DIM),
 * TVO_ERR_ARG (levels out of 1..TVO_MAX_PYR_LEVELS, or deeper than the image allows),
 * TVO_ERR_NO_MEMORY (mem_size < tvo_pyramid_required_size()). On error *p is zeroed (levels = 0). */
TVO_API tvo_status tvo_pyramid_init(tvo_pyramid *p, int32_t width, int32_t height, int32_t levels, void *mem,
                                    size_t mem_size);

/* Copy img into level 0 and compute every further level. img must be a valid view of exactly the
 * size given to init (TVO_ERR_MISMATCH otherwise); TVO_ERR_NULL / TVO_ERR_SIZE for a bad view,
 * TVO_ERR_STATE for a pyramid that was not initialised. img may not overlap the pyramid memory. */
TVO_API tvo_status tvo_pyramid_build(tvo_pyramid *p, const tvo_image *img);

/* A pyramid with a borrowed level 0: the caller holds level 0, the pyramid's memory only levels 1.. and
 * the row buffer (tvo_pyramid_required_size_borrowed: the full size less one width x height level, e.g.
 * 76,800 bytes less at 320x240). For a tracker that keeps one frame's level 0 between calls and reads the
 * current frame's level 0 from the caller's image:
 *   tvo_pyramid_build_borrowed(p, img): level 0 becomes a view of img (not copied: img must stay unchanged
 *     and valid while p is used), levels 1.. are computed from it into p's memory; same pixels as
 *     tvo_pyramid_build. Errors as tvo_pyramid_build; TVO_ERR_STATE for a pyramid of tvo_pyramid_init.
 *   tvo_pyramid_keep_level0(p, dst, dst_stride): copies level 0 into dst (width x height bytes at
 *     dst_stride >= width, not overlapping the image level 0 points to; dst equal to it: no copy) and
 *     points level 0 there, so p no longer depends on img. TVO_ERR_NULL, TVO_ERR_STATE (not a borrowed
 *     pyramid, or not built), TVO_ERR_SIZE (dst_stride below width or above TVO_IMAGE_MAX_STRIDE).
 * tvo_pyramid_build on a borrowed pyramid returns TVO_ERR_STATE. */
TVO_API size_t tvo_pyramid_required_size_borrowed(int32_t width, int32_t height, int32_t levels);
TVO_API tvo_status tvo_pyramid_init_borrowed(tvo_pyramid *p, int32_t width, int32_t height, int32_t levels,
                                             void *mem, size_t mem_size);
TVO_API tvo_status tvo_pyramid_build_borrowed(tvo_pyramid *p, const tvo_image *img);
TVO_API tvo_status tvo_pyramid_keep_level0(tvo_pyramid *p, uint8_t *dst, int32_t dst_stride);

/* A view of one level (its pixels stay owned by the pyramid's memory). An invalid pyramid or a level
 * outside 0..levels-1 gives an empty view (all fields 0, data NULL) that tvo_image_check() refuses. */
TVO_API tvo_image tvo_pyramid_level(const tvo_pyramid *p, int32_t level);

/* One 2x downsampling step as cv::pyrDown (see above), usable without a pyramid: src (w x h) ->
 * dst ((w+1)/2 x (h+1)/2). row_tmp must hold at least w uint16 values. Errors: TVO_ERR_NULL,
 * TVO_ERR_SIZE (bad views), TVO_ERR_MISMATCH (dst size is not ((w+1)/2, (h+1)/2)). */
TVO_API tvo_status tvo_pyr_down(const tvo_image *src, tvo_image *dst, uint16_t *row_tmp);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_PYRAMID_H */
