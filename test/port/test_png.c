/* SPDX-License-Identifier: Apache-2.0 */
/* PNG port: decoding of every colour type / bit depth to grey, corrupt and truncated files, sizes,
 * round trip through the writer, a real EuRoC frame. The test PNGs are written by a tiny independent
 * encoder below (stored deflate blocks, own CRC-32 and Adler-32), so the decoder is checked against
 * files it did not produce. */
#define _POSIX_C_SOURCE 200809L
#include <unistd.h>

#include "tvo_test.h"
#include "tinyvo/port/png.h"
#include "tinyvo/options.h"

/* ---- a minimal PNG encoder for test inputs ----------------------------------------------------- */

static uint32_t crc32_update(uint32_t crc, const uint8_t *p, size_t n)
{
    size_t i;
    int k;
    crc = ~crc;
    for (i = 0; i < n; ++i) {
        crc ^= p[i];
        for (k = 0; k < 8; ++k)
            crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    return ~crc;
}

typedef struct {
    uint8_t *p;
    size_t n, cap;
} bytes;

static void put(bytes *b, const void *src, size_t n)
{
    if (b->n + n > b->cap) {
        b->cap = (b->n + n) * 2 + 64;
        b->p = (uint8_t *)realloc(b->p, b->cap);
        assert_non_null(b->p);
    }
    memcpy(b->p + b->n, src, n);
    b->n += n;
}

static void put32(bytes *b, uint32_t v)
{
    uint8_t x[4] = {(uint8_t)(v >> 24), (uint8_t)(v >> 16), (uint8_t)(v >> 8), (uint8_t)v};
    put(b, x, 4);
}

static void chunk(bytes *b, const char *type, const uint8_t *data, size_t n)
{
    uint32_t crc;
    put32(b, (uint32_t)n);
    put(b, type, 4);
    if (n)
        put(b, data, n);
    crc = crc32_update(0, (const uint8_t *)type, 4);
    crc = crc32_update(crc, data, n);
    put32(b, crc);
}

/* rows: height rows of rowbytes raw (unfiltered) bytes each. */
static bytes make_png(uint32_t w, uint32_t h, int color_type, int bit_depth, const uint8_t *rows,
                      size_t rowbytes, const uint8_t *plte, size_t plte_n)
{
    static const uint8_t sig[8] = {137, 80, 78, 71, 13, 10, 26, 10};
    bytes out = {NULL, 0, 0}, z = {NULL, 0, 0}, raw = {NULL, 0, 0};
    uint8_t ihdr[13];
    uint32_t a = 1, bsum = 0, y;
    size_t i, off;
    put(&out, sig, 8);
    ihdr[0] = (uint8_t)(w >> 24);
    ihdr[1] = (uint8_t)(w >> 16);
    ihdr[2] = (uint8_t)(w >> 8);
    ihdr[3] = (uint8_t)w;
    ihdr[4] = (uint8_t)(h >> 24);
    ihdr[5] = (uint8_t)(h >> 16);
    ihdr[6] = (uint8_t)(h >> 8);
    ihdr[7] = (uint8_t)h;
    ihdr[8] = (uint8_t)bit_depth;
    ihdr[9] = (uint8_t)color_type;
    ihdr[10] = ihdr[11] = ihdr[12] = 0;
    chunk(&out, "IHDR", ihdr, 13);
    if (plte)
        chunk(&out, "PLTE", plte, plte_n);
    if (rows != NULL) {
        for (y = 0; y < h; ++y) {
            const uint8_t f = 0;
            put(&raw, &f, 1);
            put(&raw, rows + y * rowbytes, rowbytes);
        }
        {
            const uint8_t zh[2] = {0x78, 0x01};
            put(&z, zh, 2);
        }
        for (off = 0; off < raw.n || off == 0;) {
            size_t len = raw.n - off > 65535 ? 65535 : raw.n - off;
            uint8_t hdr[5];
            hdr[0] = (uint8_t)(off + len == raw.n ? 1 : 0);
            hdr[1] = (uint8_t)len;
            hdr[2] = (uint8_t)(len >> 8);
            hdr[3] = (uint8_t)~len;
            hdr[4] = (uint8_t)(~len >> 8);
            put(&z, hdr, 5);
            put(&z, raw.p + off, len);
            off += len;
            if (len == 0)
                break;
        }
        for (i = 0; i < raw.n; ++i) {
            a = (a + raw.p[i]) % 65521u;
            bsum = (bsum + a) % 65521u;
        }
        put32(&z, (bsum << 16) | a);
        chunk(&out, "IDAT", z.p, z.n);
    }
    chunk(&out, "IEND", NULL, 0);
    free(z.p);
    free(raw.p);
    return out;
}

static char g_dir[256];

static int setup(void **state)
{
    (void)state;
    strcpy(g_dir, "/tmp/tvo_test_png_XXXXXX");
    return mkdtemp(g_dir) == NULL ? -1 : 0;
}

static int teardown(void **state)
{
    char cmd[300];
    (void)state;
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_dir);
    return system(cmd) == 0 ? 0 : -1;
}

static const char *tmp_path(const char *name)
{
    static char p[400];
    snprintf(p, sizeof p, "%s/%s", g_dir, name);
    return p;
}

static void write_bytes(const char *path, const void *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    if (n)
        assert_int_equal(fwrite(p, 1, n, f), n);
    fclose(f);
}

static uint8_t luma(uint32_t r, uint32_t g, uint32_t b)
{
    return (uint8_t)((4899u * r + 9617u * g + 1868u * b + 8192u) >> 14);
}

/* ---- tests ------------------------------------------------------------------------------------ */

static void test_gray8(void **state)
{
    enum { W = 37, H = 23 };
    uint8_t px[W * H], out[W * H];
    int32_t w = -1, h = -1;
    bytes png;
    int i;
    (void)state;
    for (i = 0; i < W * H; ++i)
        px[i] = (uint8_t)(i * 7 + (i / W) * 13);
    png = make_png(W, H, 0, 8, px, W, NULL, 0);
    assert_int_equal(tvo_png_decode_gray8(png.p, png.n, out, sizeof out, &w, &h), TVO_OK);
    assert_int_equal(w, W);
    assert_int_equal(h, H);
    assert_memory_equal(out, px, sizeof px);
    /* via a file, and its size */
    write_bytes(tmp_path("g8.png"), png.p, png.n);
    memset(out, 0, sizeof out);
    assert_int_equal(tvo_png_read_gray8(tmp_path("g8.png"), out, sizeof out, &w, &h), TVO_OK);
    assert_memory_equal(out, px, sizeof px);
    w = h = 0;
    assert_int_equal(tvo_png_size(tmp_path("g8.png"), &w, &h), TVO_OK);
    assert_int_equal(w, W);
    assert_int_equal(h, H);
    /* buffer too small: NO_MEMORY, size still reported */
    w = h = 0;
    assert_int_equal(tvo_png_read_gray8(tmp_path("g8.png"), out, W * H - 1, &w, &h), TVO_ERR_NO_MEMORY);
    assert_int_equal(w, W);
    assert_int_equal(h, H);
    assert_int_equal(tvo_png_read_gray8(tmp_path("g8.png"), NULL, 0, &w, &h), TVO_ERR_NO_MEMORY);
    assert_int_equal(w, W);
    free(png.p);
}

static void test_gray_low_bit_depths(void **state)
{
    /* 1-bit: 10 px per row -> 2 bytes; pattern 1010110011 */
    const uint8_t rows1[2 * 2] = {0xAC, 0xC0, 0x53, 0x00};
    const uint8_t expect1[20] = {255, 0,   255, 0,   255, 255, 0,   0,   255, 255,
                                 0,   255, 0,   255, 0,   0,   255, 255, 0,   0};
    /* 4-bit: values 0..15 scale by 17 */
    const uint8_t rows4[2] = {0x0F, 0x7A};
    const uint8_t expect4[4] = {0, 255, 119, 170};
    uint8_t out[20];
    int32_t w, h;
    bytes png;
    (void)state;
    png = make_png(10, 2, 0, 1, rows1, 2, NULL, 0);
    assert_int_equal(tvo_png_decode_gray8(png.p, png.n, out, sizeof out, &w, &h), TVO_OK);
    assert_int_equal(w, 10);
    assert_memory_equal(out, expect1, 20);
    free(png.p);
    png = make_png(4, 1, 0, 4, rows4, 2, NULL, 0);
    assert_int_equal(tvo_png_decode_gray8(png.p, png.n, out, sizeof out, &w, &h), TVO_OK);
    assert_memory_equal(out, expect4, 4);
    free(png.p);
}

static void test_gray16(void **state)
{
    enum { W = 5, H = 2 };
    const uint16_t v[W * H] = {0, 65535, 257, 128, 129, 32896, 1000, 60000, 385, 384};
    uint8_t rows[W * H * 2], out[W * H];
    int32_t w, h;
    bytes png;
    int i;
    (void)state;
    for (i = 0; i < W * H; ++i) {
        rows[2 * i] = (uint8_t)(v[i] >> 8); /* PNG is big-endian */
        rows[2 * i + 1] = (uint8_t)v[i];
    }
    png = make_png(W, H, 0, 16, rows, W * 2, NULL, 0);
    write_bytes(tmp_path("g16.png"), png.p, png.n);
    assert_int_equal(tvo_png_read_gray8(tmp_path("g16.png"), out, sizeof out, &w, &h), TVO_OK);
    assert_int_equal(w, W);
    assert_int_equal(h, H);
    for (i = 0; i < W * H; ++i) {
        const int e = (int)((v[i] * 255u + 32767u) / 65535u); /* round(v / 257) */
        assert_int_equal(out[i], e);
    }
    assert_int_equal(out[1], 255);
    assert_int_equal(out[2], 1);
    free(png.p);
}

static void test_rgb_rgba_palette(void **state)
{
    enum { W = 4, H = 3 };
    uint8_t rgb[W * H * 3], rgba[W * H * 4], ga[W * H * 2], idx[W * H], out[W * H];
    const uint8_t plte[3 * 3] = {255, 0, 0, 0, 255, 0, 10, 20, 250};
    int32_t w, h;
    bytes png;
    int i;
    (void)state;
    for (i = 0; i < W * H; ++i) {
        rgb[3 * i] = rgba[4 * i] = (uint8_t)(i * 20);
        rgb[3 * i + 1] = rgba[4 * i + 1] = (uint8_t)(255 - i * 9);
        rgb[3 * i + 2] = rgba[4 * i + 2] = (uint8_t)(i * i);
        rgba[4 * i + 3] = (uint8_t)(i * 17); /* alpha: ignored */
        ga[2 * i] = (uint8_t)(i * 21);
        ga[2 * i + 1] = 3;
        idx[i] = (uint8_t)(i % 3);
    }
    png = make_png(W, H, 2, 8, rgb, W * 3, NULL, 0);
    write_bytes(tmp_path("rgb.png"), png.p, png.n);
    assert_int_equal(tvo_png_read_gray8(tmp_path("rgb.png"), out, sizeof out, &w, &h), TVO_OK);
    assert_int_equal(w, W);
    for (i = 0; i < W * H; ++i)
        assert_int_equal(out[i], luma(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]));
    free(png.p);
    png = make_png(W, H, 6, 8, rgba, W * 4, NULL, 0);
    assert_int_equal(tvo_png_decode_gray8(png.p, png.n, out, sizeof out, &w, &h), TVO_OK);
    for (i = 0; i < W * H; ++i)
        assert_int_equal(out[i], luma(rgba[4 * i], rgba[4 * i + 1], rgba[4 * i + 2]));
    free(png.p);
    png = make_png(W, H, 4, 8, ga, W * 2, NULL, 0);
    assert_int_equal(tvo_png_decode_gray8(png.p, png.n, out, sizeof out, &w, &h), TVO_OK);
    for (i = 0; i < W * H; ++i)
        assert_int_equal(out[i], ga[2 * i]);
    free(png.p);
    png = make_png(W, H, 3, 8, idx, W, plte, sizeof plte);
    assert_int_equal(tvo_png_decode_gray8(png.p, png.n, out, sizeof out, &w, &h), TVO_OK);
    for (i = 0; i < W * H; ++i) {
        const uint8_t *c = plte + 3 * idx[i];
        assert_int_equal(out[i], luma(c[0], c[1], c[2]));
    }
    free(png.p);
    /* 16-bit RGB: channels combined, then scaled */
    {
        uint8_t rgb16[2 * 3 * 2];
        const uint16_t c[6] = {65535, 0, 0, 1000, 50000, 65535};
        for (i = 0; i < 6; ++i) {
            rgb16[2 * i] = (uint8_t)(c[i] >> 8);
            rgb16[2 * i + 1] = (uint8_t)c[i];
        }
        png = make_png(2, 1, 2, 16, rgb16, 12, NULL, 0);
        assert_int_equal(tvo_png_decode_gray8(png.p, png.n, out, sizeof out, &w, &h), TVO_OK);
        for (i = 0; i < 2; ++i) {
            uint32_t y16 = (4899u * c[3 * i] + 9617u * c[3 * i + 1] + 1868u * c[3 * i + 2] + 8192u) >> 14;
            assert_int_equal(out[i], (int)((y16 * 255u + 32767u) / 65535u));
        }
        assert_int_equal(out[0], 76); /* pure red: 0.299 * 255 */
        free(png.p);
    }
}

static void test_corrupt(void **state)
{
    enum { W = 16, H = 16 };
    uint8_t px[W * H], out[W * H];
    int32_t w, h;
    bytes png;
    size_t n;
    (void)state;
    memset(px, 100, sizeof px);
    png = make_png(W, H, 0, 8, px, W, NULL, 0);
    n = png.n;
    /* truncated at many lengths: never OK, never a crash */
    {
        size_t cut;
        for (cut = 0; cut < n - 12; cut += 7) {
            tvo_status st = tvo_png_decode_gray8(png.p, cut, out, sizeof out, &w, &h);
            assert_true(st == TVO_ERR_FORMAT);
        }
        write_bytes(tmp_path("trunc.png"), png.p, n / 2);
        assert_int_equal(tvo_png_read_gray8(tmp_path("trunc.png"), out, sizeof out, &w, &h), TVO_ERR_FORMAT);
        write_bytes(tmp_path("empty.png"), png.p, 0);
        assert_int_equal(tvo_png_read_gray8(tmp_path("empty.png"), out, sizeof out, &w, &h), TVO_ERR_FORMAT);
        assert_int_equal(tvo_png_size(tmp_path("empty.png"), &w, &h), TVO_ERR_FORMAT);
        write_bytes(tmp_path("hdr.png"), png.p, 20); /* cut inside IHDR */
        assert_int_equal(tvo_png_size(tmp_path("hdr.png"), &w, &h), TVO_ERR_FORMAT);
    }
    /* a flipped byte in the image data: CRC mismatch */
    png.p[n - 30] ^= 0x5A;
    write_bytes(tmp_path("crc.png"), png.p, n);
    assert_int_equal(tvo_png_read_gray8(tmp_path("crc.png"), out, sizeof out, &w, &h), TVO_ERR_FORMAT);
    png.p[n - 30] ^= 0x5A;
    /* bad signature */
    png.p[1] = 'X';
    assert_int_equal(tvo_png_decode_gray8(png.p, n, out, sizeof out, &w, &h), TVO_ERR_FORMAT);
    free(png.p);
    /* not a PNG at all */
    write_bytes(tmp_path("text.png"), "hello, world, this is not a png file", 36);
    assert_int_equal(tvo_png_read_gray8(tmp_path("text.png"), out, sizeof out, &w, &h), TVO_ERR_FORMAT);
    assert_int_equal(tvo_png_size(tmp_path("text.png"), &w, &h), TVO_ERR_FORMAT);
    /* random garbage after a valid signature */
    {
        uint8_t junk[300];
        uint64_t s = 77;
        int i, k;
        for (k = 0; k < 50; ++k) {
            memcpy(junk, "\x89PNG\r\n\x1a\n", 8);
            for (i = 8; i < 300; ++i)
                junk[i] = (uint8_t)tvo_test_rand(&s);
            assert_int_not_equal(tvo_png_decode_gray8(junk, sizeof junk, out, sizeof out, &w, &h), TVO_OK);
        }
    }
    /* an IDAT whose zlib stream holds fewer bytes than the image needs */
    png = make_png(W, H, 0, 8, px, W / 2, NULL, 0); /* rows half as long as declared */
    assert_int_equal(tvo_png_decode_gray8(png.p, png.n, out, sizeof out, &w, &h), TVO_ERR_FORMAT);
    free(png.p);
}

static void test_sizes(void **state)
{
    uint8_t out[16];
    int32_t w, h;
    bytes png;
    (void)state;
    /* header claims more than TVO_MAX_IMAGE_DIM: refused before any decoding */
    png = make_png(TVO_MAX_IMAGE_DIM + 1, 4, 0, 8, NULL, 0, NULL, 0);
    assert_int_equal(tvo_png_decode_gray8(png.p, png.n, out, sizeof out, &w, &h), TVO_ERR_SIZE);
    write_bytes(tmp_path("wide.png"), png.p, png.n);
    assert_int_equal(tvo_png_size(tmp_path("wide.png"), &w, &h), TVO_ERR_SIZE);
    free(png.p);
    png = make_png(4, TVO_MAX_IMAGE_DIM + 1, 0, 8, NULL, 0, NULL, 0);
    assert_int_equal(tvo_png_decode_gray8(png.p, png.n, out, sizeof out, &w, &h), TVO_ERR_SIZE);
    free(png.p);
    /* zero width is invalid PNG */
    png = make_png(0, 4, 0, 8, NULL, 0, NULL, 0);
    assert_int_not_equal(tvo_png_decode_gray8(png.p, png.n, out, sizeof out, &w, &h), TVO_OK);
    free(png.p);
    /* a bit depth that does not exist for the colour type */
    png = make_png(2, 2, 2, 4, NULL, 0, NULL, 0);
    assert_int_equal(tvo_png_decode_gray8(png.p, png.n, out, sizeof out, &w, &h), TVO_ERR_FORMAT);
    free(png.p);
}

static void test_args_and_missing(void **state)
{
    uint8_t out[4];
    int32_t w, h;
    (void)state;
    assert_int_equal(tvo_png_read_gray8(NULL, out, 4, &w, &h), TVO_ERR_NULL);
    assert_int_equal(tvo_png_read_gray8("x.png", out, 4, NULL, &h), TVO_ERR_NULL);
    assert_int_equal(tvo_png_read_gray8("x.png", out, 4, &w, NULL), TVO_ERR_NULL);
    assert_int_equal(tvo_png_read_gray8("x.png", NULL, 4, &w, &h), TVO_ERR_NULL);
    assert_int_equal(tvo_png_decode_gray8(NULL, 10, out, 4, &w, &h), TVO_ERR_NULL);
    assert_int_equal(tvo_png_decode_gray8(out, 0, out, 4, &w, &h), TVO_ERR_FORMAT);
    assert_int_equal(tvo_png_size(NULL, &w, &h), TVO_ERR_NULL);
    assert_int_equal(tvo_png_read_gray8(tmp_path("nope.png"), out, 4, &w, &h), TVO_ERR_NOT_FOUND);
    assert_int_equal(tvo_png_read_gray8("/nonexistent_dir_tvo/x.png", out, 4, &w, &h), TVO_ERR_NOT_FOUND);
    assert_int_equal(tvo_png_size(tmp_path("nope.png"), &w, &h), TVO_ERR_NOT_FOUND);
    /* a folder is not a file */
    assert_int_equal(tvo_png_read_gray8(g_dir, out, 4, &w, &h), TVO_ERR_IO);
    assert_int_equal(tvo_png_write_gray8(NULL, out, 2, 2, 2), TVO_ERR_NULL);
    assert_int_equal(tvo_png_write_gray8(tmp_path("w.png"), NULL, 2, 2, 2), TVO_ERR_NULL);
    assert_int_equal(tvo_png_write_gray8(tmp_path("w.png"), out, 0, 2, 2), TVO_ERR_SIZE);
    assert_int_equal(tvo_png_write_gray8(tmp_path("w.png"), out, 2, -1, 2), TVO_ERR_SIZE);
    assert_int_equal(tvo_png_write_gray8(tmp_path("w.png"), out, 2, 2, 1), TVO_ERR_SIZE);
    assert_int_equal(tvo_png_write_gray8("/nonexistent_dir_tvo/w.png", out, 2, 2, 2), TVO_ERR_NOT_FOUND);
}

static void test_write_roundtrip(void **state)
{
    enum { W = 61, H = 17, S = 64 };
    uint8_t img[S * H], out[W * H];
    int32_t w, h, x, y;
    uint64_t s = 5;
    (void)state;
    for (x = 0; x < S * H; ++x)
        img[x] = (uint8_t)tvo_test_rand(&s);
    assert_int_equal(tvo_png_write_gray8(tmp_path("rt.png"), img, W, H, S), TVO_OK);
    assert_int_equal(tvo_png_read_gray8(tmp_path("rt.png"), out, sizeof out, &w, &h), TVO_OK);
    assert_int_equal(w, W);
    assert_int_equal(h, H);
    for (y = 0; y < H; ++y)
        for (x = 0; x < W; ++x)
            assert_int_equal(out[y * W + x], img[y * S + x]);
}

static void test_real_euroc_frame(void **state)
{
    const char *d = tvo_test_data_dir();
    char path[600];
    uint8_t *buf;
    int32_t w = 0, h = 0, i;
    double mean = 0;
    int lo = 255, hi = 0;
    (void)state;
    if (d == NULL)
        TVO_SKIP("TVO_DATA_DIR not set");
    snprintf(path, sizeof path, "%s/euroc/V1_01_easy_head/mav0/cam0/data/1403715273262142976.png", d);
    if (access(path, R_OK) != 0)
        TVO_SKIP("EuRoC sample frame not found under TVO_DATA_DIR");
    assert_int_equal(tvo_png_size(path, &w, &h), TVO_OK);
    assert_int_equal(w, 752);
    assert_int_equal(h, 480);
    buf = (uint8_t *)malloc(752 * 480);
    assert_non_null(buf);
    assert_int_equal(tvo_png_read_gray8(path, buf, 752 * 480, &w, &h), TVO_OK);
    for (i = 0; i < 752 * 480; ++i) {
        mean += buf[i];
        lo = buf[i] < lo ? buf[i] : lo;
        hi = buf[i] > hi ? buf[i] : hi;
    }
    mean /= 752 * 480;
    assert_true(mean > 20 && mean < 235);
    assert_true(hi - lo > 100);
    /* write it back and read it again: identical */
    {
        uint8_t *b2 = (uint8_t *)malloc(752 * 480);
        assert_non_null(b2);
        assert_int_equal(tvo_png_write_gray8(tmp_path("euroc.png"), buf, 752, 480, 752), TVO_OK);
        assert_int_equal(tvo_png_read_gray8(tmp_path("euroc.png"), b2, 752 * 480, &w, &h), TVO_OK);
        assert_memory_equal(buf, b2, 752 * 480);
        free(b2);
    }
    free(buf);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_gray8),
            cmocka_unit_test(test_gray_low_bit_depths),
            cmocka_unit_test(test_gray16),
            cmocka_unit_test(test_rgb_rgba_palette),
            cmocka_unit_test(test_corrupt),
            cmocka_unit_test(test_sizes),
            cmocka_unit_test(test_args_and_missing),
            cmocka_unit_test(test_write_roundtrip),
            cmocka_unit_test(test_real_euroc_frame),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
