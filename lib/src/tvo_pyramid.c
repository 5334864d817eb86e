/* SPDX-License-Identifier: Apache-2.0 */
/* Gaussian image pyramid, bit-exact with cv::pyrDown (see tinyvo/pyramid.h). */
#include "tinyvo/pyramid.h"

#include <string.h>

#include "tinyvo/arena.h"
#include "tvo_border.h"

/* Row stride of a level: width rounded up to 16 bytes (keeps every row 16-byte aligned). */
static int32_t pyr_stride(int32_t width)
{
    return (width + 15) & ~15;
}

/* Fills w[] and h[] for the geometry; TVO_OK or the error of tvo_pyramid_init(). */
static tvo_status pyr_geometry(int32_t width, int32_t height, int32_t levels, int32_t *w, int32_t *h)
{
    int32_t l;
    if (width < 1 || height < 1 || width > TVO_MAX_IMAGE_DIM || height > TVO_MAX_IMAGE_DIM)
        return TVO_ERR_SIZE;
    if (levels < 1 || levels > TVO_MAX_PYR_LEVELS)
        return TVO_ERR_ARG;
    w[0] = width;
    h[0] = height;
    for (l = 1; l < levels; ++l) {
        w[l] = (w[l - 1] + 1) / 2;
        h[l] = (h[l - 1] + 1) / 2;
        if (w[l] < TVO_PYR_MIN_LEVEL_DIM || h[l] < TVO_PYR_MIN_LEVEL_DIM)
            return TVO_ERR_ARG;
    }
    return TVO_OK;
}

/* Bytes of the layout, with (own0 = 1) or without (0) a level 0 of its own. */
static size_t pyr_required(int32_t width, int32_t height, int32_t levels, int own0)
{
    int32_t w[TVO_MAX_PYR_LEVELS], h[TVO_MAX_PYR_LEVELS], l;
    size_t total = TVO_ARENA_ALIGN - 1u; /* slack to align the caller's block */
    if (pyr_geometry(width, height, levels, w, h) != TVO_OK)
        return 0;
    for (l = own0 ? 0 : 1; l < levels; ++l)
        total = tvo_size_add(total, tvo_arena_round(tvo_size_mul((size_t)pyr_stride(w[l]), (size_t)h[l])));
    total = tvo_size_add(total, tvo_arena_round(tvo_size_mul((size_t)width, sizeof(uint16_t))));
    return total == SIZE_MAX ? 0 : total;
}

size_t tvo_pyramid_required_size(int32_t width, int32_t height, int32_t levels)
{
    return pyr_required(width, height, levels, 1);
}

size_t tvo_pyramid_required_size_borrowed(int32_t width, int32_t height, int32_t levels)
{
    return pyr_required(width, height, levels, 0);
}

static tvo_status pyr_init(tvo_pyramid *p, int32_t width, int32_t height, int32_t levels, void *mem,
                           size_t mem_size, int own0)
{
    int32_t w[TVO_MAX_PYR_LEVELS], h[TVO_MAX_PYR_LEVELS], l;
    tvo_arena arena;
    tvo_status st;
    size_t need;
    if (p == NULL)
        return TVO_ERR_NULL;
    memset(p, 0, sizeof(*p));
    if (mem == NULL)
        return TVO_ERR_NULL;
    st = pyr_geometry(width, height, levels, w, h);
    if (st != TVO_OK)
        return st;
    need = pyr_required(width, height, levels, own0);
    if (need == 0 || mem_size < need)
        return TVO_ERR_NO_MEMORY;
    tvo_arena_init(&arena, mem, mem_size);
    for (l = 0; l < levels; ++l) {
        p->width[l] = w[l];
        p->height[l] = h[l];
        p->stride[l] = pyr_stride(w[l]);
        if (l == 0 && !own0)
            continue; /* borrowed: set by tvo_pyramid_build_borrowed / tvo_pyramid_keep_level0 */
        p->data[l] = (uint8_t *)tvo_arena_alloc(&arena, (size_t)p->stride[l] * (size_t)h[l]);
        if (p->data[l] == NULL) { /* cannot happen after the size check; stay safe anyway */
            memset(p, 0, sizeof(*p));
            return TVO_ERR_NO_MEMORY;
        }
    }
    p->row_tmp = (uint16_t *)tvo_arena_alloc(&arena, (size_t)width * sizeof(uint16_t));
    if (p->row_tmp == NULL) {
        memset(p, 0, sizeof(*p));
        return TVO_ERR_NO_MEMORY;
    }
    p->levels = levels;
    p->own0 = own0;
    return TVO_OK;
}

tvo_status tvo_pyramid_init(tvo_pyramid *p, int32_t width, int32_t height, int32_t levels, void *mem,
                            size_t mem_size)
{
    return pyr_init(p, width, height, levels, mem, mem_size, 1);
}

tvo_status tvo_pyramid_init_borrowed(tvo_pyramid *p, int32_t width, int32_t height, int32_t levels, void *mem,
                                     size_t mem_size)
{
    return pyr_init(p, width, height, levels, mem, mem_size, 0);
}

static uint8_t pyr_down_border(const uint16_t *tmp, int32_t w, int32_t x)
{
    int32_t c = 2 * x;
    uint32_t s = (uint32_t)tmp[tvo_reflect101(c - 2, w)] + tmp[tvo_reflect101(c + 2, w)] +
            4u * ((uint32_t)tmp[tvo_reflect101(c - 1, w)] + tmp[tvo_reflect101(c + 1, w)]) +
            6u * tmp[tvo_reflect101(c, w)];
    return (uint8_t)((s + 128u) >> 8);
}

/* One output row of pyrDown: vertical [1 4 6 4 1] into tmp (w values), then horizontal with
 * decimation and rounding. */
static void pyr_down_row(const uint8_t *s0, const uint8_t *s1, const uint8_t *s2, const uint8_t *s3,
                         const uint8_t *s4, int32_t w, uint8_t *out, int32_t dw, uint16_t *tmp)
{
    int32_t x, x_end;
    for (x = 0; x < w; ++x)
        tmp[x] = (uint16_t)(s0[x] + s4[x] + 4 * (s1[x] + s3[x]) + 6 * s2[x]);

    /* interior: source columns 2x-2 .. 2x+2 all inside [0, w) for 1 <= x < x_end */
    x_end = w >= 3 ? (w - 3) / 2 + 1 : 1;
    if (x_end > dw)
        x_end = dw;
    if (x_end < 1)
        x_end = 1;
    for (x = 1; x < x_end; ++x) {
        const uint16_t *t = tmp + 2 * x;
        uint32_t s = (uint32_t)t[-2] + t[2] + 4u * ((uint32_t)t[-1] + t[1]) + 6u * t[0];
        out[x] = (uint8_t)((s + 128u) >> 8);
    }
    /* borders with BORDER_REFLECT_101: x = 0 and x_end .. dw-1 */
    out[0] = pyr_down_border(tmp, w, 0);
    for (x = x_end; x < dw; ++x)
        out[x] = pyr_down_border(tmp, w, x);
}

static void pyr_down_raw(const uint8_t *src, int32_t w, int32_t h, int32_t sstride, uint8_t *dst, int32_t dw,
                         int32_t dh, int32_t dstride, uint16_t *tmp)
{
    int32_t y;
    for (y = 0; y < dh; ++y) {
        int32_t c = 2 * y;
        const uint8_t *r0, *r1, *r2, *r3, *r4;
        if (c - 2 >= 0 && c + 2 < h) {
            r0 = src + (size_t)(c - 2) * (size_t)sstride;
            r1 = r0 + sstride;
            r2 = r1 + sstride;
            r3 = r2 + sstride;
            r4 = r3 + sstride;
        } else {
            r0 = src + (size_t)tvo_reflect101(c - 2, h) * (size_t)sstride;
            r1 = src + (size_t)tvo_reflect101(c - 1, h) * (size_t)sstride;
            r2 = src + (size_t)tvo_reflect101(c, h) * (size_t)sstride;
            r3 = src + (size_t)tvo_reflect101(c + 1, h) * (size_t)sstride;
            r4 = src + (size_t)tvo_reflect101(c + 2, h) * (size_t)sstride;
        }
        pyr_down_row(r0, r1, r2, r3, r4, w, dst + (size_t)y * (size_t)dstride, dw, tmp);
    }
}

tvo_status tvo_pyr_down(const tvo_image *src, tvo_image *dst, uint16_t *row_tmp)
{
    tvo_status st;
    if (src == NULL || dst == NULL || row_tmp == NULL)
        return TVO_ERR_NULL;
    st = tvo_image_check(src);
    if (st != TVO_OK)
        return st;
    st = tvo_image_check(dst);
    if (st != TVO_OK)
        return st;
    if (dst->width != (src->width + 1) / 2 || dst->height != (src->height + 1) / 2)
        return TVO_ERR_MISMATCH;
    pyr_down_raw(src->data, src->width, src->height, src->stride, dst->data, dst->width, dst->height,
                 dst->stride, row_tmp);
    return TVO_OK;
}

/* Checks shared by the builds: a laid-out pyramid and a valid view of its size. */
static tvo_status pyr_build_check(const tvo_pyramid *p, const tvo_image *img)
{
    tvo_status st;
    if (p == NULL || img == NULL)
        return TVO_ERR_NULL;
    if (p->levels < 1 || p->levels > TVO_MAX_PYR_LEVELS || p->row_tmp == NULL)
        return TVO_ERR_STATE;
    st = tvo_image_check(img);
    if (st != TVO_OK)
        return st;
    if (img->width != p->width[0] || img->height != p->height[0])
        return TVO_ERR_MISMATCH;
    return TVO_OK;
}

static void pyr_build_upper(tvo_pyramid *p)
{
    int32_t l;
    for (l = 1; l < p->levels; ++l)
        pyr_down_raw(p->data[l - 1], p->width[l - 1], p->height[l - 1], p->stride[l - 1], p->data[l],
                     p->width[l], p->height[l], p->stride[l], p->row_tmp);
}

tvo_status tvo_pyramid_build(tvo_pyramid *p, const tvo_image *img)
{
    tvo_status st = pyr_build_check(p, img);
    int32_t y;
    if (st != TVO_OK)
        return st;
    if (p->own0 == 0)
        return TVO_ERR_STATE;
    for (y = 0; y < img->height; ++y)
        memcpy(p->data[0] + (size_t)y * (size_t)p->stride[0], img->data + (size_t)y * (size_t)img->stride,
               (size_t)img->width);
    pyr_build_upper(p);
    return TVO_OK;
}

tvo_status tvo_pyramid_build_borrowed(tvo_pyramid *p, const tvo_image *img)
{
    tvo_status st = pyr_build_check(p, img);
    if (st != TVO_OK)
        return st;
    if (p->own0 != 0)
        return TVO_ERR_STATE;
    p->data[0] = img->data;
    p->stride[0] = img->stride;
    pyr_build_upper(p);
    return TVO_OK;
}

tvo_status tvo_pyramid_keep_level0(tvo_pyramid *p, uint8_t *dst, int32_t dst_stride)
{
    int32_t y;
    if (p == NULL || dst == NULL)
        return TVO_ERR_NULL;
    if (p->levels < 1 || p->own0 != 0 || p->data[0] == NULL)
        return TVO_ERR_STATE;
    if (dst_stride < p->width[0] || dst_stride > TVO_IMAGE_MAX_STRIDE)
        return TVO_ERR_SIZE;
    if (dst != p->data[0]) {
        for (y = 0; y < p->height[0]; ++y)
            memcpy(dst + (size_t)y * (size_t)dst_stride, p->data[0] + (size_t)y * (size_t)p->stride[0],
                   (size_t)p->width[0]);
    }
    p->data[0] = dst;
    p->stride[0] = dst_stride;
    return TVO_OK;
}

tvo_image tvo_pyramid_level(const tvo_pyramid *p, int32_t level)
{
    if (p == NULL || level < 0 || level >= p->levels || p->levels > TVO_MAX_PYR_LEVELS ||
        p->data[level] == NULL)
        return tvo_image_make(0, 0, 0, NULL);
    return tvo_image_make(p->width[level], p->height[level], p->stride[level], p->data[level]);
}
