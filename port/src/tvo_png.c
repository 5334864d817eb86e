/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo port: PNG <-> 8-bit grey via libspng (see tinyvo/port/png.h). */
#include "tinyvo/port/png.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <spng.h>

#include "tinyvo/options.h"

/* Refuse files above this size (bytes) and chunks above TVO_PNG_MAX_CHUNK: a corrupt or hostile
 * file must not make us allocate without bound. */
#define TVO_PNG_MAX_FILE ((size_t)1 << 30)
#define TVO_PNG_MAX_CHUNK ((size_t)64 << 20)

static tvo_status tvo_png_status_of_errno(int e)
{
    return (e == ENOENT || e == ENOTDIR) ? TVO_ERR_NOT_FOUND : TVO_ERR_IO;
}

static tvo_status tvo_png_status_of_spng(int r)
{
    switch (r) {
    case SPNG_OK:
        return TVO_OK;
    case SPNG_EUSER_WIDTH:
    case SPNG_EUSER_HEIGHT:
        return TVO_ERR_SIZE;
    case SPNG_EMEM:
        return TVO_ERR_NO_MEMORY;
    case SPNG_IO_ERROR:
        return TVO_ERR_IO;
    default:
        return TVO_ERR_FORMAT; /* signature, IHDR, CRC, zlib stream, truncated data (SPNG_IO_EOF), ... */
    }
}

/* The whole file at path in a malloc'ed buffer (caller frees). */
static tvo_status tvo_png_slurp(const char *path, uint8_t **data, size_t *size)
{
    FILE *f;
    uint8_t *buf = NULL;
    size_t cap = 0, len = 0;
    tvo_status st = TVO_OK;
    errno = 0;
    f = fopen(path, "rb");
    if (f == NULL)
        return tvo_png_status_of_errno(errno);
    for (;;) {
        size_t got;
        if (len == cap) {
            size_t ncap = cap == 0 ? (size_t)65536 : cap * 2;
            uint8_t *nb;
            if (cap >= TVO_PNG_MAX_FILE) {
                st = TVO_ERR_FORMAT; /* absurdly large for a frame */
                break;
            }
            nb = (uint8_t *)realloc(buf, ncap);
            if (nb == NULL) {
                st = TVO_ERR_NO_MEMORY;
                break;
            }
            buf = nb;
            cap = ncap;
        }
        got = fread(buf + len, 1, cap - len, f);
        len += got;
        if (got == 0) {
            if (ferror(f))
                st = TVO_ERR_IO;
            break;
        }
    }
    fclose(f);
    if (st != TVO_OK) {
        free(buf);
        return st;
    }
    *data = buf;
    *size = len;
    return TVO_OK;
}

static spng_ctx *tvo_png_new_decoder(void)
{
    spng_ctx *ctx = spng_ctx_new(0);
    if (ctx == NULL)
        return NULL;
    if (spng_set_image_limits(ctx, TVO_MAX_IMAGE_DIM, TVO_MAX_IMAGE_DIM) != 0 ||
        spng_set_chunk_limits(ctx, TVO_PNG_MAX_CHUNK, TVO_PNG_MAX_CHUNK) != 0) {
        spng_ctx_free(ctx);
        return NULL;
    }
    return ctx;
}

/* Y = (4899 R + 9617 G + 1868 B + 2^13) >> 14, OpenCV's RGB2GRAY weights (sum 2^14). */
static uint32_t tvo_luma(uint32_t r, uint32_t g, uint32_t b)
{
    return (4899u * r + 9617u * g + 1868u * b + 8192u) >> 14;
}

tvo_status tvo_png_decode_gray8(const void *png, size_t png_size, uint8_t *buf, size_t capacity,
                                int32_t *width, int32_t *height)
{
    spng_ctx *ctx;
    struct spng_ihdr ihdr;
    size_t npix, out_size;
    int r;
    tvo_status st = TVO_OK;
    if (png == NULL || width == NULL || height == NULL || (buf == NULL && capacity != 0))
        return TVO_ERR_NULL;
    *width = 0;
    *height = 0;
    if (png_size == 0)
        return TVO_ERR_FORMAT;
    ctx = tvo_png_new_decoder();
    if (ctx == NULL)
        return TVO_ERR_NO_MEMORY;
    r = spng_set_png_buffer(ctx, png, png_size);
    if (r == 0)
        r = spng_get_ihdr(ctx, &ihdr);
    if (r != 0) {
        spng_ctx_free(ctx);
        return tvo_png_status_of_spng(r);
    }
    if (ihdr.width < 1 || ihdr.height < 1 || ihdr.width > TVO_MAX_IMAGE_DIM ||
        ihdr.height > TVO_MAX_IMAGE_DIM) {
        spng_ctx_free(ctx);
        return TVO_ERR_SIZE;
    }
    *width = (int32_t)ihdr.width;
    *height = (int32_t)ihdr.height;
    npix = (size_t)ihdr.width * (size_t)ihdr.height;
    if (buf == NULL || capacity < npix) {
        spng_ctx_free(ctx);
        return TVO_ERR_NO_MEMORY;
    }
    if (ihdr.color_type == SPNG_COLOR_TYPE_GRAYSCALE && ihdr.bit_depth <= 8) {
        r = spng_decoded_image_size(ctx, SPNG_FMT_G8, &out_size);
        if (r == 0 && out_size != npix)
            r = SPNG_EINTERNAL;
        if (r == 0)
            r = spng_decode_image(ctx, buf, npix, SPNG_FMT_G8, 0);
        st = tvo_png_status_of_spng(r);
    } else {
        const int wide = ihdr.bit_depth == 16;
        const int fmt = wide ? SPNG_FMT_RGBA16 : SPNG_FMT_RGBA8;
        uint8_t *tmp = NULL;
        r = spng_decoded_image_size(ctx, fmt, &out_size);
        if (r == 0 && out_size / (wide ? 8u : 4u) != npix)
            r = SPNG_EINTERNAL;
        if (r == 0) {
            tmp = (uint8_t *)malloc(out_size);
            if (tmp == NULL)
                r = SPNG_EMEM;
        }
        if (r == 0)
            r = spng_decode_image(ctx, tmp, out_size, fmt, 0);
        st = tvo_png_status_of_spng(r);
        if (st == TVO_OK) {
            size_t i;
            if (wide) {
                for (i = 0; i < npix; ++i) {
                    uint16_t c[4];
                    uint32_t y16;
                    memcpy(c, tmp + 8 * i, sizeof c); /* host-endian 16-bit channels */
                    y16 = tvo_luma(c[0], c[1], c[2]);
                    buf[i] = (uint8_t)((y16 * 255u + 32767u) / 65535u);
                }
            } else {
                for (i = 0; i < npix; ++i) {
                    const uint8_t *p = tmp + 4 * i;
                    buf[i] = (uint8_t)tvo_luma(p[0], p[1], p[2]);
                }
            }
        }
        free(tmp);
    }
    spng_ctx_free(ctx);
    return st;
}

tvo_status tvo_png_read_gray8(const char *path, uint8_t *buf, size_t capacity, int32_t *width,
                              int32_t *height)
{
    uint8_t *data = NULL;
    size_t size = 0;
    tvo_status st;
    if (path == NULL || width == NULL || height == NULL || (buf == NULL && capacity != 0))
        return TVO_ERR_NULL;
    *width = 0;
    *height = 0;
    st = tvo_png_slurp(path, &data, &size);
    if (st != TVO_OK)
        return st;
    st = tvo_png_decode_gray8(data, size, buf, capacity, width, height);
    free(data);
    return st;
}

tvo_status tvo_png_size(const char *path, int32_t *width, int32_t *height)
{
    FILE *f;
    spng_ctx *ctx;
    struct spng_ihdr ihdr;
    int r;
    if (path == NULL || width == NULL || height == NULL)
        return TVO_ERR_NULL;
    *width = 0;
    *height = 0;
    errno = 0;
    f = fopen(path, "rb");
    if (f == NULL)
        return tvo_png_status_of_errno(errno);
    ctx = tvo_png_new_decoder();
    if (ctx == NULL) {
        fclose(f);
        return TVO_ERR_NO_MEMORY;
    }
    r = spng_set_png_file(ctx, f);
    if (r == 0)
        r = spng_get_ihdr(ctx, &ihdr);
    spng_ctx_free(ctx);
    if (r == SPNG_IO_ERROR && !ferror(f))
        r = SPNG_IO_EOF;
    fclose(f);
    if (r != 0)
        return tvo_png_status_of_spng(r);
    if (ihdr.width < 1 || ihdr.height < 1 || ihdr.width > TVO_MAX_IMAGE_DIM ||
        ihdr.height > TVO_MAX_IMAGE_DIM)
        return TVO_ERR_SIZE;
    *width = (int32_t)ihdr.width;
    *height = (int32_t)ihdr.height;
    return TVO_OK;
}

tvo_status tvo_png_write_gray8(const char *path, const uint8_t *img, int32_t width, int32_t height,
                               int32_t stride)
{
    FILE *f;
    spng_ctx *ctx;
    struct spng_ihdr ihdr;
    int r;
    int32_t y;
    tvo_status st;
    if (path == NULL || img == NULL)
        return TVO_ERR_NULL;
    if (width < 1 || height < 1 || width > TVO_MAX_IMAGE_DIM || height > TVO_MAX_IMAGE_DIM || stride < width)
        return TVO_ERR_SIZE;
    errno = 0;
    f = fopen(path, "wb");
    if (f == NULL)
        return tvo_png_status_of_errno(errno);
    ctx = spng_ctx_new(SPNG_CTX_ENCODER);
    if (ctx == NULL) {
        fclose(f);
        return TVO_ERR_NO_MEMORY;
    }
    memset(&ihdr, 0, sizeof ihdr);
    ihdr.width = (uint32_t)width;
    ihdr.height = (uint32_t)height;
    ihdr.bit_depth = 8;
    ihdr.color_type = SPNG_COLOR_TYPE_GRAYSCALE;
    r = spng_set_png_file(ctx, f);
    if (r == 0)
        r = spng_set_ihdr(ctx, &ihdr);
    if (r == 0)
        r = spng_encode_image(ctx, NULL, 0, SPNG_FMT_PNG, SPNG_ENCODE_PROGRESSIVE | SPNG_ENCODE_FINALIZE);
    for (y = 0; r == 0 && y < height; ++y) {
        r = spng_encode_row(ctx, img + (size_t)y * (size_t)stride, (size_t)width);
        if (r == SPNG_EOI && y == height - 1)
            r = 0; /* the last row finishes the image */
    }
    spng_ctx_free(ctx);
    st = (r == 0) ? TVO_OK : TVO_ERR_IO;
    if (fclose(f) != 0 && st == TVO_OK)
        st = TVO_ERR_IO;
    if (st != TVO_OK)
        remove(path);
    return st;
}
