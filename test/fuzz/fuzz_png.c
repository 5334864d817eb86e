/* SPDX-License-Identifier: Apache-2.0 */
/* Fuzz harness: PNG frame loading (tvo_png_decode_gray8, tinyvo/port/png.h; libspng underneath).
 *
 * The input is a PNG file. A first call without a buffer reads the header (TVO_ERR_NO_MEMORY with the
 * size, or a documented error); a call with a buffer one byte short must also refuse; then the frame
 * is decoded into an exact-size heap buffer (ASan catches a write past it). Frames above
 * FUZZ_MAX_PIXELS (4 Mpixel) are only sized, not decoded, to keep the fuzzer fast; the sizes up to
 * TVO_MAX_IMAGE_DIM are covered by the header path. Invariants: documented statuses only; width and
 * height set exactly when the header was valid; a decoded frame reports the header's size. The same
 * bytes go through tvo_png_read_gray8 via a temporary file when they decode (the file path is one
 * slurp away from the memory path). Each input runs as given and, when its chunk CRCs do not match,
 * once more with them rewritten (else nearly every mutation stops at libspng's CRC check). libspng itself is a system library, not instrumented: coverage
 * feedback comes from tinyvo's code only (docs/fuzzing.md). */
#define _POSIX_C_SOURCE 200809L
#include <string.h>
#include <unistd.h>

#include "fuzz_common.h"
#include "tinyvo/options.h"
#include "tinyvo/port/png.h"

#define FUZZ_MAX_PIXELS ((size_t)1 << 22)

static char g_path[64];

static int status_expected(tvo_status st)
{
    return st == TVO_OK || st == TVO_ERR_FORMAT || st == TVO_ERR_SIZE || st == TVO_ERR_NO_MEMORY;
}

/* CRC-32 (IEEE) as PNG uses it, bitwise: fine for fuzz inputs of a few kB. */
static uint32_t crc32_png(const uint8_t *p, size_t n)
{
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; ++i) {
        c ^= p[i];
        for (int k = 0; k < 8; ++k)
            c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
    }
    return ~c;
}

/* Rewrite the CRC of every complete chunk after the 8-byte signature, so that mutations of chunk
 * contents reach libspng's decoder instead of its CRC check. Returns 1 when something changed. */
static int fix_chunk_crcs(uint8_t *p, size_t n)
{
    size_t off = 8;
    int changed = 0;
    while (off + 12 <= n) {
        const uint32_t len = (uint32_t)p[off] << 24 | (uint32_t)p[off + 1] << 16 | (uint32_t)p[off + 2] << 8 |
                p[off + 3];
        uint32_t crc, old;
        if (len > n - off - 12)
            break;
        crc = crc32_png(p + off + 4, (size_t)len + 4);
        old = (uint32_t)p[off + 8 + len] << 24 | (uint32_t)p[off + 9 + len] << 16 |
                (uint32_t)p[off + 10 + len] << 8 | p[off + 11 + len];
        if (crc != old) {
            p[off + 8 + len] = (uint8_t)(crc >> 24);
            p[off + 9 + len] = (uint8_t)(crc >> 16);
            p[off + 10 + len] = (uint8_t)(crc >> 8);
            p[off + 11 + len] = (uint8_t)crc;
            changed = 1;
        }
        off += (size_t)len + 12;
    }
    return changed;
}

static void decode_one(const uint8_t *data, size_t size);

/* The input as given, then (when its chunk CRCs are wrong) with them rewritten. */
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint8_t *copy;
    decode_one(data, size);
    if (size < 8 + 12)
        return 0;
    copy = (uint8_t *)malloc(size);
    if (copy == NULL)
        return 0;
    memcpy(copy, data, size);
    if (fix_chunk_crcs(copy, size))
        decode_one(copy, size);
    free(copy);
    return 0;
}

static void decode_one(const uint8_t *data, size_t size)
{
    int32_t w = -1, h = -1, w2 = -1, h2 = -1;
    size_t npix;
    uint8_t *buf;
    tvo_status st = tvo_png_decode_gray8(data, size, NULL, 0, &w, &h);
    TVO_FUZZ_CHECK(status_expected(st) && st != TVO_OK);
    if (st != TVO_ERR_NO_MEMORY) {
        TVO_FUZZ_CHECK(w == 0 && h == 0);
        return;
    }
    TVO_FUZZ_CHECK(w >= 1 && h >= 1 && w <= TVO_MAX_IMAGE_DIM && h <= TVO_MAX_IMAGE_DIM);
    npix = (size_t)w * (size_t)h;
    if (npix > FUZZ_MAX_PIXELS)
        return;
    buf = (uint8_t *)malloc(npix);
    if (buf == NULL)
        return;
    st = tvo_png_decode_gray8(data, size, buf, npix - 1, &w2, &h2);
    TVO_FUZZ_CHECK(st == TVO_ERR_NO_MEMORY && w2 == w && h2 == h);
    st = tvo_png_decode_gray8(data, size, buf, npix, &w2, &h2);
    TVO_FUZZ_CHECK(status_expected(st) && w2 == w && h2 == h);
    if (st == TVO_OK) {
        /* the file path: same bytes, same pixels */
        uint8_t *buf2 = (uint8_t *)malloc(npix);
        FILE *f;
        int32_t w3 = -1, h3 = -1;
        if (g_path[0] == '\0')
            snprintf(g_path, sizeof g_path, "/tmp/tvo_fuzz_png_%ld.png", (long)getpid());
        f = fopen(g_path, "wb");
        TVO_FUZZ_CHECK(f != NULL && buf2 != NULL);
        TVO_FUZZ_CHECK(fwrite(data, 1, size, f) == size);
        TVO_FUZZ_CHECK(fclose(f) == 0);
        TVO_FUZZ_CHECK(tvo_png_size(g_path, &w3, &h3) == TVO_OK && w3 == w && h3 == h);
        st = tvo_png_read_gray8(g_path, buf2, npix, &w3, &h3);
        TVO_FUZZ_CHECK(st == TVO_OK && w3 == w && h3 == h);
        TVO_FUZZ_CHECK(memcmp(buf, buf2, npix) == 0);
        remove(g_path);
        free(buf2);
    }
    free(buf);
}
