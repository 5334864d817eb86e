/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo port: PNG frames via libspng (port layer only; lib/ never sees a file format).
 *
 * Every colour type and bit depth that libspng decodes is accepted (grey 1/2/4/8/16 bit, grey+alpha,
 * RGB, RGBA, palette, interlaced or not) and converted to 8-bit grey:
 *   - grey <= 8 bit: the grey value scaled to 0..255 (exact, as libspng's SPNG_FMT_G8);
 *   - 16-bit grey: round(v / 257);
 *   - colour (RGB, RGBA, palette): BT.601 luma Y = 0.299 R + 0.587 G + 0.114 B with OpenCV's
 *     cvtColor(RGB2GRAY) fixed-point weights (4899, 9617, 1868) / 2^14, rounded; 16-bit colour
 *     channels are combined first, then scaled like 16-bit grey;
 *   - alpha is ignored (no compositing), gamma / colour chunks are ignored.
 * Images wider or taller than TVO_MAX_IMAGE_DIM are refused with TVO_ERR_SIZE.
 * Output is packed: pixel (x, y) at buf[y * width + x].
 *
 * Memory: grey <= 8-bit files decode straight into buf; other kinds use one temporary heap buffer of
 * width * height * 4 (8-bit) or * 8 (16-bit) bytes, freed before return. Files are read whole into a
 * heap buffer first. Not meant for a hard real-time loop on a microcontroller: this is the desktop /
 * Linux port. All functions are reentrant. */
#ifndef TINYVO_PORT_PNG_H
#define TINYVO_PORT_PNG_H

#include <stddef.h>
#include <stdint.h>
#include "tinyvo/export.h"
#include "tinyvo/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Decode the PNG file at path into buf (capacity bytes) as 8-bit grey, width * height bytes.
 * *width and *height are set as soon as the header is read (also when buf is too small, so a caller
 * can size its buffer and retry; tvo_png_size does that without decoding).
 * Errors: TVO_ERR_NULL (a NULL argument; buf may be NULL only with capacity 0), TVO_ERR_NOT_FOUND (no
 * such file), TVO_ERR_IO (cannot open/read), TVO_ERR_FORMAT (not a PNG, corrupt, truncated, bad CRC),
 * TVO_ERR_NO_MEMORY (capacity < width * height, or a temporary allocation failed), TVO_ERR_SIZE (a
 * dimension above TVO_MAX_IMAGE_DIM). */
TVO_API tvo_status tvo_png_read_gray8(const char *path, uint8_t *buf, size_t capacity, int32_t *width,
                                      int32_t *height);

/* Same, from a PNG held in memory (png_size bytes at png). */
TVO_API tvo_status tvo_png_decode_gray8(const void *png, size_t png_size, uint8_t *buf, size_t capacity,
                                        int32_t *width, int32_t *height);

/* Width and height of the PNG file at path, reading only its header. Errors as tvo_png_read_gray8. */
TVO_API tvo_status tvo_png_size(const char *path, int32_t *width, int32_t *height);

/* Write an 8-bit grey image (row y at img + y * stride, stride >= width) as a grey 8-bit PNG.
 * Errors: TVO_ERR_NULL, TVO_ERR_SIZE (width/height outside 1..TVO_MAX_IMAGE_DIM, stride < width),
 * TVO_ERR_NOT_FOUND (the folder does not exist), TVO_ERR_IO (cannot create/write the file). */
TVO_API tvo_status tvo_png_write_gray8(const char *path, const uint8_t *img, int32_t width, int32_t height,
                                       int32_t stride);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_PORT_PNG_H */
