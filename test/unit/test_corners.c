/* SPDX-License-Identifier: Apache-2.0 */
/* Corner module: FAST-9 (vs the simple reference, SIMD vs portable path, synthetic known corners, bands,
 * capacity),
 * Harris / Shi-Tomasi responses, bucketed detection (spread, spacing, existing points, determinism),
 * and bad input. The OpenCV comparison lives in test/oracle/test_corners_oracle.py. */
#include "tvo_test.h"

#include <math.h>

#include "tinyvo/corners.h"
#include "tvo_fast_ref.h"
#include "tvo_room.h"

/* the portable FAST-9 path, built into this test from lib/src/tvo_fast.c (fast_portable.c) */
const char *tvo_fast_kernel_name_portable(void);
size_t tvo_fast_scratch_size_portable(int32_t width);
tvo_status tvo_fast9_detect_rows_portable(const tvo_image *img, int32_t threshold, int nonmax,
                                          int32_t y_begin, int32_t y_end, tvo_corner *out, int32_t capacity,
                                          int32_t *count, void *scratch, size_t scratch_size);
/* the detector with FAST in every cell, full ones too, built into this test from lib/src/tvo_detect.c
 * (detect_all_cells.c) */
tvo_status tvo_detect_all_cells(const tvo_detect_config *cfg, const tvo_image *img,
                                const tvo_point2f *existing, int32_t n_existing, tvo_corner *out,
                                int32_t capacity, int32_t *count, void *scratch, size_t scratch_size);
size_t tvo_detect_scratch_size_all_cells(const tvo_detect_config *cfg, int32_t width, int32_t height);
tvo_status tvo_fast9_detect_rect_portable(const tvo_image *img, int32_t threshold, int nonmax,
                                          int32_t x_begin, int32_t x_end, int32_t y_begin, int32_t y_end,
                                          tvo_corner *out, int32_t capacity, int32_t *count, void *scratch,
                                          size_t scratch_size);

/* ---- helpers ------------------------------------------------------------------------------------- */

typedef struct test_img {
    uint8_t *buf;
    tvo_image img;
} test_img;

static test_img img_new(int32_t w, int32_t h, int32_t stride, uint8_t fill)
{
    test_img t;
    tvo_image v = tvo_image_make(w, h, stride, NULL);
    size_t n = (size_t)stride * (size_t)(h > 0 ? h : 1);
    t.buf = (uint8_t *)malloc(n);
    assert_non_null(t.buf);
    memset(t.buf, fill, n);
    memcpy(&t.img, &v, sizeof v);
    t.img.data = t.buf;
    return t;
}

static void img_free(test_img *t)
{
    free(t->buf);
}

static void px(test_img *t, int32_t x, int32_t y, uint8_t v)
{
    t->buf[(size_t)y * (size_t)t->img.stride + (size_t)x] = v;
}

/* random image smoothed with a 3x3 box (so that corners have structure), or raw noise */
static void img_random(test_img *t, uint64_t seed, int smooth)
{
    int32_t x, y, w = t->img.width, h = t->img.height, st = t->img.stride;
    uint8_t *tmp = (uint8_t *)malloc((size_t)w * (size_t)h);
    assert_non_null(tmp);
    for (y = 0; y < h; ++y)
        for (x = 0; x < w; ++x)
            tmp[(size_t)y * (size_t)w + (size_t)x] = (uint8_t)(tvo_test_rand(&seed) >> 56);
    for (y = 0; y < h; ++y)
        for (x = 0; x < w; ++x) {
            int s = 0, n = 0, dx, dy;
            if (!smooth) {
                t->buf[(size_t)y * (size_t)st + (size_t)x] = tmp[(size_t)y * (size_t)w + (size_t)x];
                continue;
            }
            for (dy = -1; dy <= 1; ++dy)
                for (dx = -1; dx <= 1; ++dx) {
                    int32_t u = x + dx, v = y + dy;
                    if (u < 0 || v < 0 || u >= w || v >= h)
                        continue;
                    s += tmp[(size_t)v * (size_t)w + (size_t)u];
                    ++n;
                }
            t->buf[(size_t)y * (size_t)st + (size_t)x] = (uint8_t)(s / n);
        }
    free(tmp);
}

/* a textured scene: bright and dark rectangles on a mid-grey background, in every part of the image */
static void img_blocks(test_img *t, uint64_t seed)
{
    int32_t w = t->img.width, h = t->img.height, i, x, y;
    memset(t->buf, 128, (size_t)t->img.stride * (size_t)h);
    for (i = 0; i < w * h / 300; ++i) {
        int32_t x0 = (int32_t)(tvo_test_rand(&seed) % (uint64_t)w);
        int32_t y0 = (int32_t)(tvo_test_rand(&seed) % (uint64_t)h);
        int32_t bw = 4 + (int32_t)(tvo_test_rand(&seed) % 12u),
                bh = 4 + (int32_t)(tvo_test_rand(&seed) % 12u);
        uint8_t v = (uint8_t)(tvo_test_rand(&seed) % 2u ? 230 - tvo_test_rand(&seed) % 40u
                                                        : 20 + tvo_test_rand(&seed) % 40u);
        for (y = y0; y < y0 + bh && y < h; ++y)
            for (x = x0; x < x0 + bw && x < w; ++x)
                px(t, x, y, v);
    }
    /* mild noise breaks the score plateaus of flat rectangles (strict non-max removes equal neighbours) */
    for (y = 0; y < h; ++y)
        for (x = 0; x < w; ++x)
            t->buf[(size_t)y * (size_t)t->img.stride + (size_t)x] =
                    (uint8_t)(t->buf[(size_t)y * (size_t)t->img.stride + (size_t)x] +
                              tvo_test_rand(&seed) % 9u);
}

static tvo_status run_fast(const tvo_image *img, int32_t thr, int nonmax, tvo_corner *out, int32_t cap,
                           int32_t *n)
{
    size_t ss = tvo_fast_scratch_size(img->width);
    void *s = malloc(ss + 1);
    tvo_status st;
    assert_non_null(s);
    /* misaligned scratch on purpose */
    st = tvo_fast9_detect(img, thr, nonmax, out, cap, n, (uint8_t *)s + 1, ss);
    free(s);
    return st;
}

static void assert_same_corners(const tvo_corner *a, int32_t na, const tvo_corner *b, int32_t nb)
{
    int32_t i;
    assert_int_equal(na, nb);
    for (i = 0; i < na; ++i) {
        assert_true(a[i].x == b[i].x);
        assert_true(a[i].y == b[i].y);
        assert_true(a[i].score == b[i].score);
    }
}

/* ---- FAST ---------------------------------------------------------------------------------------- */

static void test_fast_square_corners(void **state)
{
    /* a bright 20x20 square at (20..39, 20..39) on dark: FAST finds its 4 corners and nothing else */
    test_img t = img_new(64, 64, 64, 40);
    tvo_corner out[64];
    int32_t n = 0, i, x, y, k;
    const int32_t cx[4] = {20, 39, 20, 39}, cy[4] = {20, 20, 39, 39};
    (void)state;
    for (y = 20; y < 40; ++y)
        for (x = 20; x < 40; ++x)
            px(&t, x, y, 200);
    /* without non-max: the square's flat corners give equal scores to neighbouring pixels, and the
     * strict non-max (as OpenCV's) would remove them all */
    assert_int_equal(run_fast(&t.img, 30, 0, out, 64, &n), TVO_OK);
    assert_true(n >= 4);
    for (k = 0; k < 4; ++k) {
        int found = 0;
        for (i = 0; i < n; ++i)
            if (fabsf(out[i].x - (float)cx[k]) <= 1.0f && fabsf(out[i].y - (float)cy[k]) <= 1.0f)
                found = 1;
        assert_true(found);
    }
    for (i = 0; i < n; ++i) {
        /* nothing away from the square's corners */
        int near = 0;
        for (k = 0; k < 4; ++k)
            near |= fabsf(out[i].x - (float)cx[k]) <= 2.0f && fabsf(out[i].y - (float)cy[k]) <= 2.0f;
        assert_true(near);
        assert_true(out[i].score >= 30.0f && out[i].score <= 254.0f);
    }
    /* flat image: nothing */
    memset(t.buf, 77, 64 * 64);
    assert_int_equal(run_fast(&t.img, 0, 0, out, 64, &n), TVO_OK);
    assert_int_equal(n, 0);
    img_free(&t);
}

static void test_fast_matches_reference(void **state)
{
    /* odd sizes, stride > width, raw noise (saturating values) and smooth noise, thresholds 0..255 */
    const int32_t sizes[][3] = {{7, 7, 7}, {8, 9, 11}, {33, 20, 40}, {100, 61, 100}, {171, 45, 180}};
    const int32_t thr[] = {0, 1, 7, 20, 60, 254, 255};
    size_t si, ti;
    int nonmax, smooth;
    (void)state;
    for (si = 0; si < sizeof sizes / sizeof sizes[0]; ++si) {
        test_img t = img_new(sizes[si][0], sizes[si][1], sizes[si][2], 0);
        int32_t cap = sizes[si][0] * sizes[si][1];
        tvo_corner *a = (tvo_corner *)malloc(sizeof(tvo_corner) * (size_t)cap);
        tvo_corner *b = (tvo_corner *)malloc(sizeof(tvo_corner) * (size_t)cap);
        assert_non_null(a);
        assert_non_null(b);
        for (smooth = 0; smooth <= 1; ++smooth) {
            img_random(&t, 1234u + si, smooth);
            for (ti = 0; ti < sizeof thr / sizeof thr[0]; ++ti)
                for (nonmax = 0; nonmax <= 1; ++nonmax) {
                    int32_t na = -1, nb = -1;
                    assert_int_equal(run_fast(&t.img, thr[ti], nonmax, a, cap, &na), TVO_OK);
                    assert_int_equal(tvo_fast9_detect_ref(&t.img, thr[ti], nonmax, b, cap, &nb), TVO_OK);
                    assert_same_corners(a, na, b, nb);
                }
        }
        free(a);
        free(b);
        img_free(&t);
    }
}

/* The library's FAST-9 (SSE2 / NEON block of 16 pixels, then the portable tail) against the portable path
 * alone on the same view, whole image and one band: same corners, scores and order. */
static void assert_simd_is_portable(const tvo_image *img, int32_t thr, int nonmax, tvo_corner *a,
                                    tvo_corner *b, int32_t cap)
{
    size_t ss = tvo_fast_scratch_size(img->width);
    uint8_t *s = (uint8_t *)malloc(ss + 1);
    int32_t na = -1, nb = -1, y0 = img->height / 3, y1 = img->height / 3 + 3;
    assert_non_null(s);
    assert_true(ss == tvo_fast_scratch_size_portable(img->width));
    assert_int_equal(tvo_fast9_detect(img, thr, nonmax, a, cap, &na, s + 1, ss), TVO_OK);
    assert_int_equal(tvo_fast9_detect_rows_portable(img, thr, nonmax, 0, img->height, b, cap, &nb, s + 1, ss),
                     TVO_OK);
    assert_same_corners(a, na, b, nb);
    assert_int_equal(tvo_fast9_detect_rows(img, thr, nonmax, y0, y1, a, cap, &na, s, ss), TVO_OK);
    assert_int_equal(tvo_fast9_detect_rows_portable(img, thr, nonmax, y0, y1, b, cap, &nb, s, ss), TVO_OK);
    assert_same_corners(a, na, b, nb);
    free(s);
}

static void test_fast_simd_matches_portable(void **state)
{
    /* widths: tiny (no 16-pixel block: x in [3, w-3) holds fewer than 16 pixels up to w = 21), one block
     * exactly (22) or with tails of 1 and 15 pixels (23, 37), two blocks (38), and wider ones with tails;
     * views inside a larger buffer, so rows are unaligned and the stride exceeds the width */
    const int32_t widths[] = {7, 8, 16, 21, 22, 23, 24, 37, 38, 39, 53, 64, 101, 190};
    const int32_t BW = 200, BH = 150;
    test_img src = img_new(BW, BH, BW, 0);
    tvo_corner *a = (tvo_corner *)malloc(sizeof(tvo_corner) * (size_t)(BW * BH));
    tvo_corner *b = (tvo_corner *)malloc(sizeof(tvo_corner) * (size_t)(BW * BH));
    tvo_pose T = tvo_pose_identity();
    uint64_t seed = 77u;
    int kind, nonmax;
    size_t wi;
    int32_t thr, i, total = 0;
    (void)state;
    assert_non_null(a);
    assert_non_null(b);
    print_message("FAST kernel compared with the portable path: %s\n", tvo_fast_kernel_name());
    for (kind = 0; kind < 5; ++kind) {
        /* raw noise, smoothed noise, blocks, the rendered room, and 0 / 255 noise (saturated differences) */
        if (kind == 0 || kind == 1)
            img_random(&src, 4321u + (uint64_t)kind, kind);
        else if (kind == 2)
            img_blocks(&src, 5u);
        else if (kind == 3) {
            T.t[0] = 0.1;
            T.t[1] = -0.05;
            tvo_room_render(&T, BW, BH, 120.0, src.buf);
        } else
            for (i = 0; i < BW * BH; ++i)
                src.buf[i] = (uint8_t)(tvo_test_rand(&seed) >> 63 ? 255 : 0);
        for (wi = 0; wi < sizeof widths / sizeof widths[0]; ++wi) {
            int32_t w = widths[wi], h = wi % 2 ? 9 : 20, x0 = (int32_t)(wi % 5), y0 = (int32_t)(wi * 7 % 40);
            tvo_image v = tvo_image_make(w, h, BW, src.buf + (size_t)y0 * (size_t)BW + (size_t)x0);
            for (thr = 0; thr <= 255; ++thr)
                for (nonmax = 0; nonmax <= 1; ++nonmax)
                    assert_simd_is_portable(&v, thr, nonmax, a, b, BW * BH);
        }
        /* the whole buffer, every 3rd threshold and the extremes */
        for (thr = 0; thr <= 255; thr += thr < 3 || thr >= 252 ? 1 : 3)
            for (nonmax = 0; nonmax <= 1; ++nonmax) {
                int32_t n = -1;
                assert_simd_is_portable(&src.img, thr, nonmax, a, b, BW * BH);
                assert_int_equal(run_fast(&src.img, thr, nonmax, a, BW * BH, &n), TVO_OK);
                total += n;
            }
    }
    assert_true(total > 10000); /* the comparisons had corners to compare */
    free(a);
    free(b);
    img_free(&src);
}

/* The kernel's name: one of the three, the portable copy's "portable", and the one a cross build expects
 * (TVO_EXPECT_FAST_KERNEL, set by tools/run-cross.sh) so that a build that silently lost its SIMD block
 * fails here. */
static void test_fast_kernel_name(void **state)
{
    const char *name = tvo_fast_kernel_name();
    (void)state;
    assert_non_null(name);
    assert_true(strcmp(name, "sse2") == 0 || strcmp(name, "neon") == 0 || strcmp(name, "portable") == 0);
    assert_string_equal(tvo_fast_kernel_name_portable(), "portable");
    if (getenv("TVO_EXPECT_FAST_KERNEL") != NULL)
        assert_string_equal(name, getenv("TVO_EXPECT_FAST_KERNEL"));
}

static void test_fast_rows_and_capacity(void **state)
{
    test_img t = img_new(120, 90, 128, 0);
    tvo_corner all[120 * 90], part[120 * 90];
    int32_t nall = 0, total = 0, y0, np, i;
    size_t ss = tvo_fast_scratch_size(120);
    void *s = malloc(ss);
    (void)state;
    assert_non_null(s);
    img_random(&t, 99u, 1);
    assert_int_equal(tvo_fast9_detect(&t.img, 5, 1, all, 120 * 90, &nall, s, ss), TVO_OK);
    assert_true(nall > 20);
    /* bands of 7 rows reproduce the full result, in order */
    for (y0 = -5; y0 < 100; y0 += 7) {
        assert_int_equal(tvo_fast9_detect_rows(&t.img, 5, 1, y0, y0 + 7, part, 120 * 90, &np, s, ss), TVO_OK);
        for (i = 0; i < np; ++i) {
            assert_true(total + i < nall);
            assert_true(part[i].x == all[total + i].x && part[i].y == all[total + i].y &&
                        part[i].score == all[total + i].score);
        }
        total += np;
    }
    assert_int_equal(total, nall);
    /* empty range */
    assert_int_equal(tvo_fast9_detect_rows(&t.img, 5, 1, 50, 50, part, 10, &np, s, ss), TVO_OK);
    assert_int_equal(np, 0);
    /* capacity too small: TVO_ERR_NO_MEMORY, the first `capacity` corners */
    assert_int_equal(tvo_fast9_detect(&t.img, 5, 1, part, 10, &np, s, ss), TVO_ERR_NO_MEMORY);
    assert_int_equal(np, 10);
    for (i = 0; i < 10; ++i)
        assert_true(part[i].x == all[i].x && part[i].y == all[i].y);
    assert_int_equal(tvo_fast9_detect(&t.img, 5, 0, part, 0, &np, s, ss), TVO_ERR_NO_MEMORY);
    assert_int_equal(np, 0);
    /* score_at agrees with the detector */
    for (i = 0; i < nall; ++i)
        assert_int_equal(tvo_fast9_score_at(&t.img, (int32_t)all[i].x, (int32_t)all[i].y),
                         (int32_t)all[i].score);
    assert_int_equal(tvo_fast9_score_at(&t.img, 2, 10), -1);
    assert_int_equal(tvo_fast9_score_at(&t.img, 10, 87), -1);
    free(s);
    img_free(&t);
}

/* Rectangles: exactly the whole image's corners that lie in the rectangle, in the same order, with the
 * same scores (the non-max test sees the neighbours outside it), from the SIMD build and the portable
 * path; rectangles of every width from 1 to past the 16-pixel block, at every offset near the borders,
 * clamped ones and empty ones. */
static void test_fast_rect(void **state)
{
    enum { RW = 131, RH = 60 };
    test_img t = img_new(RW, RH, RW + 5, 0);
    tvo_corner *all = (tvo_corner *)malloc(3 * sizeof(tvo_corner) * RW * RH), *part = all + RW * RH,
               *pp = part + RW * RH;
    size_t ss = tvo_fast_scratch_size(RW);
    void *s = malloc(ss);
    uint64_t seed = 5u;
    int32_t kind, nonmax, checked = 0;
    (void)state;
    assert_non_null(all);
    assert_non_null(s);
    for (kind = 0; kind < 3; ++kind) {
        if (kind < 2)
            img_random(&t, 31u + (uint64_t)kind, kind);
        else
            img_blocks(&t, 3u);
        for (nonmax = 0; nonmax <= 1; ++nonmax) {
            int32_t nall = 0, thr = kind == 0 ? 40 : 8, trial;
            assert_int_equal(tvo_fast9_detect(&t.img, thr, nonmax, all, RW * RH, &nall, s, ss), TVO_OK);
            assert_true(nall > 30);
            for (trial = 0; trial < 400; ++trial) {
                /* x0 in [-4, RW), widths 0..40 (and the whole width now and then), y the same way */
                int32_t x0 = (int32_t)(tvo_test_rand(&seed) % (RW + 4)) - 4;
                int32_t w = trial % 9 == 0 ? RW + 8 : (int32_t)(tvo_test_rand(&seed) % 41);
                int32_t y0 = (int32_t)(tvo_test_rand(&seed) % (RH + 4)) - 4;
                int32_t h = (int32_t)(tvo_test_rand(&seed) % 25), np = -1, nq = -1, i, k = 0;
                assert_int_equal(tvo_fast9_detect_rect(&t.img, thr, nonmax, x0, x0 + w, y0, y0 + h, part,
                                                       RW * RH, &np, s, ss),
                                 TVO_OK);
                assert_int_equal(tvo_fast9_detect_rect_portable(&t.img, thr, nonmax, x0, x0 + w, y0, y0 + h,
                                                                pp, RW * RH, &nq, s, ss),
                                 TVO_OK);
                assert_same_corners(part, np, pp, nq);
                for (i = 0; i < nall; ++i) {
                    const int32_t x = (int32_t)all[i].x, y = (int32_t)all[i].y;
                    if (x < x0 || x >= x0 + w || y < y0 || y >= y0 + h)
                        continue;
                    assert_true(k < np);
                    assert_true(part[k].x == all[i].x && part[k].y == all[i].y &&
                                part[k].score == all[i].score);
                    ++k;
                }
                assert_int_equal(k, np);
                checked += np;
            }
        }
    }
    assert_true(checked > 1000); /* the rectangles had corners to compare */
    free(all);
    free(s);
    img_free(&t);
}

static void test_fast_bad_input(void **state)
{
    test_img t = img_new(32, 32, 32, 0);
    tvo_corner out[16];
    int32_t n = 5;
    uint8_t s[4096];
    size_t ss = tvo_fast_scratch_size(32);
    tvo_image bad_stride = tvo_image_make(32, 32, 31, t.buf);
    tvo_image zero = tvo_image_make(0, 32, 32, t.buf);
    tvo_image nodata = tvo_image_make(32, 32, 32, NULL);
    (void)state;
    assert_true(ss > 0 && ss <= sizeof s);
    assert_int_equal(tvo_fast_scratch_size(0), 0);
    assert_int_equal(tvo_fast_scratch_size(-3), 0);
    assert_int_equal(tvo_fast9_detect(NULL, 10, 1, out, 16, &n, s, ss), TVO_ERR_NULL);
    assert_int_equal(n, 0);
    assert_int_equal(tvo_fast9_detect(&nodata, 10, 1, out, 16, &n, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_fast9_detect(&t.img, 10, 1, NULL, 16, &n, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_fast9_detect(&t.img, 10, 1, out, 16, NULL, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_fast9_detect(&t.img, 10, 1, out, 16, &n, NULL, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_fast9_detect(&t.img, 10, 1, out, 16, &n, s, ss - 1), TVO_ERR_NO_MEMORY);
    assert_int_equal(tvo_fast9_detect(&bad_stride, 10, 1, out, 16, &n, s, ss), TVO_ERR_SIZE);
    assert_int_equal(tvo_fast9_detect(&zero, 10, 1, out, 16, &n, s, ss), TVO_ERR_SIZE);
    assert_int_equal(tvo_fast9_detect(&t.img, -1, 1, out, 16, &n, s, ss), TVO_ERR_ARG);
    assert_int_equal(tvo_fast9_detect(&t.img, 256, 1, out, 16, &n, s, ss), TVO_ERR_ARG);
    assert_int_equal(tvo_fast9_detect(&t.img, 10, 1, out, -1, &n, s, ss), TVO_ERR_ARG);
    assert_int_equal(tvo_fast9_detect_rect(NULL, 10, 1, 0, 32, 0, 32, out, 16, &n, s, ss), TVO_ERR_NULL);
    assert_int_equal(n, 0);
    assert_int_equal(tvo_fast9_detect_rect(&t.img, 10, 1, 0, 32, 0, 32, NULL, 16, &n, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_fast9_detect_rect(&t.img, 10, 1, 0, 32, 0, 32, out, 16, &n, s, ss - 1),
                     TVO_ERR_NO_MEMORY);
    assert_int_equal(tvo_fast9_detect_rect(&bad_stride, 10, 1, 0, 32, 0, 32, out, 16, &n, s, ss),
                     TVO_ERR_SIZE);
    assert_int_equal(tvo_fast9_detect_rect(&t.img, 300, 1, 0, 32, 0, 32, out, 16, &n, s, ss), TVO_ERR_ARG);
    {
        /* extreme and reversed ranges: clamped to the image, no overflow; an empty one gives no corner */
        tvo_corner all[32 * 32], part[32 * 32];
        int32_t na = 0, np = -1;
        img_random(&t, 11u, 0);
        assert_int_equal(tvo_fast9_detect(&t.img, 20, 1, all, 32 * 32, &na, s, ss), TVO_OK);
        assert_true(na > 3);
        assert_int_equal(tvo_fast9_detect_rect(&t.img, 20, 1, INT32_MIN, INT32_MAX, INT32_MIN, INT32_MAX,
                                               part, 32 * 32, &np, s, ss),
                         TVO_OK);
        assert_same_corners(all, na, part, np);
        assert_int_equal(tvo_fast9_detect_rect(&t.img, 20, 1, 20, 10, 0, 32, part, 32 * 32, &np, s, ss),
                         TVO_OK);
        assert_int_equal(np, 0);
        assert_int_equal(tvo_fast9_detect_rect(&t.img, 20, 1, INT32_MAX, INT32_MIN, 0, 32, part, 32 * 32, &np,
                                               s, ss),
                         TVO_OK);
        assert_int_equal(np, 0);
        /* capacity: TVO_ERR_NO_MEMORY and the first corners, as tvo_fast9_detect */
        assert_int_equal(tvo_fast9_detect_rect(&t.img, 20, 1, 0, 32, 0, 32, part, 2, &np, s, ss),
                         TVO_ERR_NO_MEMORY);
        assert_int_equal(np, 2);
        assert_same_corners(all, 2, part, 2);
    }
    assert_int_equal(tvo_fast9_detect_ref(&t.img, 10, 1, NULL, 16, &n), TVO_ERR_NULL);
    assert_int_equal(tvo_fast9_detect_ref(&bad_stride, 10, 1, out, 16, &n), TVO_ERR_SIZE);
    assert_int_equal(tvo_fast9_score_at(NULL, 5, 5), -1);
    /* tiny images: no corners, no error */
    {
        tvo_image tiny = tvo_image_make(6, 32, 32, t.buf), one = tvo_image_make(1, 1, 1, t.buf);
        img_random(&t, 5u, 0);
        assert_int_equal(tvo_fast9_detect(&tiny, 0, 0, out, 16, &n, s, ss), TVO_OK);
        assert_int_equal(n, 0);
        assert_int_equal(tvo_fast9_detect(&one, 0, 1, out, 16, &n, s, ss), TVO_OK);
        assert_int_equal(n, 0);
    }
    img_free(&t);
}

/* ---- Harris / Shi-Tomasi ------------------------------------------------------------------------- */

static void test_response_dense_vs_point(void **state)
{
    test_img t = img_new(57, 43, 60, 0);
    const int32_t blocks[] = {1, 2, 3, 5, 7, 31};
    size_t bi;
    int kind;
    (void)state;
    img_random(&t, 42u, 1);
    for (bi = 0; bi < sizeof blocks / sizeof blocks[0]; ++bi)
        for (kind = TVO_SCORE_HARRIS; kind <= TVO_SCORE_SHI_TOMASI; ++kind) {
            int32_t bs = blocks[bi], lo = bs / 2, hi = bs - 1 - lo, x, y, stride = 61;
            size_t ss = tvo_corner_response_scratch_size(57, bs);
            void *s = malloc(ss + 3);
            float *out = (float *)malloc(sizeof(float) * (size_t)stride * 43u);
            assert_non_null(s);
            assert_non_null(out);
            assert_int_equal(tvo_corner_response(&t.img, (tvo_score_kind)kind, bs, 0.04f, out, stride,
                                                 (uint8_t *)s + 3, ss),
                             TVO_OK);
            for (y = 0; y < 43; ++y)
                for (x = 0; x < 57; ++x) {
                    float v = tvo_corner_score_at(&t.img, x, y, (tvo_score_kind)kind, bs, 0.04f);
                    int inside = x - lo - 1 >= 0 && y - lo - 1 >= 0 && x + hi + 1 < 57 && y + hi + 1 < 43;
                    assert_true(isfinite(out[y * stride + x]));
                    if (inside)
                        assert_true(v == out[y * stride + x]);
                    else
                        assert_true(v == 0.0f);
                }
            free(out);
            free(s);
        }
    img_free(&t);
}

static void test_response_known_structures(void **state)
{
    /* corner of a bright quadrant vs a straight edge vs flat: Shi-Tomasi corner > edge ~ 0 = flat;
     * Harris: corner > 0 > edge */
    test_img t = img_new(40, 40, 40, 30);
    int32_t x, y;
    float sc, se, sf, hc, he;
    (void)state;
    for (y = 20; y < 40; ++y)
        for (x = 20; x < 40; ++x)
            px(&t, x, y, 220);
    for (y = 0; y < 12; ++y) /* a vertical edge at x = 30 in the top rows */
        for (x = 30; x < 40; ++x)
            px(&t, x, y, 220);
    sc = tvo_corner_score_at(&t.img, 20, 20, TVO_SCORE_SHI_TOMASI, 3, 0.04f);
    se = tvo_corner_score_at(&t.img, 30, 5, TVO_SCORE_SHI_TOMASI, 3, 0.04f);
    sf = tvo_corner_score_at(&t.img, 8, 8, TVO_SCORE_SHI_TOMASI, 3, 0.04f);
    hc = tvo_corner_score_at(&t.img, 20, 20, TVO_SCORE_HARRIS, 3, 0.04f);
    he = tvo_corner_score_at(&t.img, 30, 5, TVO_SCORE_HARRIS, 3, 0.04f);
    assert_true(sc > 0.01f);
    assert_true(fabsf(se) < 1e-6f);
    assert_true(sf == 0.0f);
    assert_true(hc > 0.0f);
    assert_true(he < 0.0f);
    img_free(&t);
}

static void test_response_bad_input(void **state)
{
    test_img t = img_new(16, 16, 16, 9);
    float out[16 * 16];
    uint8_t s[16384];
    size_t ss = tvo_corner_response_scratch_size(16, 3);
    tvo_image bad_stride = tvo_image_make(16, 16, 15, t.buf);
    (void)state;
    assert_true(ss > 0 && ss <= sizeof s);
    assert_int_equal(tvo_corner_response_scratch_size(0, 3), 0);
    assert_int_equal(tvo_corner_response_scratch_size(16, 0), 0);
    assert_int_equal(tvo_corner_response_scratch_size(16, TVO_CORNER_MAX_BLOCK + 1), 0);
    assert_int_equal(tvo_corner_response(NULL, TVO_SCORE_HARRIS, 3, 0.04f, out, 16, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_corner_response(&t.img, TVO_SCORE_HARRIS, 3, 0.04f, NULL, 16, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_corner_response(&t.img, TVO_SCORE_HARRIS, 3, 0.04f, out, 16, NULL, ss),
                     TVO_ERR_NULL);
    assert_int_equal(tvo_corner_response(&bad_stride, TVO_SCORE_HARRIS, 3, 0.04f, out, 16, s, ss),
                     TVO_ERR_SIZE);
    assert_int_equal(tvo_corner_response(&t.img, TVO_SCORE_FAST, 3, 0.04f, out, 16, s, ss), TVO_ERR_ARG);
    assert_int_equal(tvo_corner_response(&t.img, (tvo_score_kind)7, 3, 0.04f, out, 16, s, ss), TVO_ERR_ARG);
    assert_int_equal(tvo_corner_response(&t.img, TVO_SCORE_HARRIS, 0, 0.04f, out, 16, s, ss), TVO_ERR_ARG);
    assert_int_equal(tvo_corner_response(&t.img, TVO_SCORE_HARRIS, 32, 0.04f, out, 16, s, ss), TVO_ERR_ARG);
    assert_int_equal(tvo_corner_response(&t.img, TVO_SCORE_HARRIS, 3, NAN, out, 16, s, ss),
                     TVO_ERR_NOT_FINITE);
    assert_int_equal(tvo_corner_response(&t.img, TVO_SCORE_HARRIS, 3, 0.04f, out, 15, s, ss), TVO_ERR_SIZE);
    assert_int_equal(tvo_corner_response(&t.img, TVO_SCORE_HARRIS, 3, 0.04f, out, 16, s, ss - 1),
                     TVO_ERR_NO_MEMORY);
    assert_true(tvo_corner_score_at(NULL, 8, 8, TVO_SCORE_HARRIS, 3, 0.04f) == 0.0f);
    assert_true(tvo_corner_score_at(&t.img, 8, 8, TVO_SCORE_FAST, 3, 0.04f) == 0.0f);
    assert_true(tvo_corner_score_at(&t.img, 8, 8, TVO_SCORE_HARRIS, 3, NAN) == 0.0f);
    assert_true(tvo_corner_score_at(&t.img, 1, 8, TVO_SCORE_HARRIS, 3, 0.04f) == 0.0f);
    assert_true(tvo_corner_score_at(&t.img, 8, 14, TVO_SCORE_HARRIS, 3, 0.04f) == 0.0f);
    img_free(&t);
}

/* ---- bucketed detection -------------------------------------------------------------------------- */

typedef struct det_run {
    tvo_corner out[2048];
    int32_t n;
} det_run;

static tvo_status run_detect(const tvo_detect_config *cfg, const tvo_image *img, const tvo_point2f *ex,
                             int32_t nex, det_run *r, int32_t cap)
{
    size_t ss = tvo_detect_scratch_size(cfg, img->width, img->height);
    void *s = malloc(ss + 5);
    tvo_status st;
    assert_true(ss > 0);
    assert_non_null(s);
    st = tvo_detect(cfg, img, ex, nex, r->out, cap, &r->n, (uint8_t *)s + 5, ss);
    free(s);
    return st;
}

static int32_t cell_of(const tvo_detect_config *cfg, int32_t w, int32_t h, float x, float y)
{
    int32_t b = cfg->border > 4 ? cfg->border : 4; /* block 5 -> block/2 + 2 = 4 */
    int32_t cx = ((int32_t)x - b) * cfg->grid_cols / (w - 2 * b);
    int32_t cy = ((int32_t)y - b) * cfg->grid_rows / (h - 2 * b);
    return cy * cfg->grid_cols + cx;
}

static void check_spacing(const tvo_corner *c, int32_t n, float md)
{
    int32_t i, j;
    for (i = 0; i < n; ++i)
        for (j = i + 1; j < n; ++j) {
            float dx = c[i].x - c[j].x, dy = c[i].y - c[j].y;
            assert_true(dx * dx + dy * dy >= md * md);
        }
}

static void test_detect_spreads(void **state)
{
    const int32_t sizes[][2] = {{752, 480}, {640, 480}, {1280, 384}, {97, 61}};
    size_t si;
    (void)state;
    for (si = 0; si < sizeof sizes / sizeof sizes[0]; ++si) {
        int32_t w = sizes[si][0], h = sizes[si][1], i;
        test_img t = img_new(w, h, w + 3, 0);
        tvo_detect_config cfg;
        det_run *r = (det_run *)malloc(sizeof(det_run)), *r2 = (det_run *)malloc(sizeof(det_run));
        int32_t per_cell[48] = {0};
        assert_non_null(r);
        assert_non_null(r2);
        img_blocks(&t, 7u + si);
        tvo_detect_config_default(&cfg);
        assert_int_equal(tvo_detect_config_check(&cfg), TVO_OK);
        assert_int_equal(run_detect(&cfg, &t.img, NULL, 0, r, 2048), TVO_OK);
        assert_true(r->n > 0 && r->n <= cfg.max_corners);
        if (w > 200)
            assert_true(r->n >= 250); /* a well textured image gives about max_corners */
        check_spacing(r->out, r->n, cfg.min_distance);
        for (i = 0; i < r->n; ++i) {
            int32_t c = cell_of(&cfg, w, h, r->out[i].x, r->out[i].y);
            assert_true(c >= 0 && c < 48);
            per_cell[c]++;
            assert_true(r->out[i].x >= (float)cfg.border && r->out[i].x < (float)(w - cfg.border));
            assert_true(r->out[i].y >= (float)cfg.border && r->out[i].y < (float)(h - cfg.border));
        }
        if (w > 200)
            for (i = 0; i < 48; ++i)
                assert_true(per_cell[i] > 0); /* every cell (all are textured) gets corners */
        /* deterministic */
        assert_int_equal(run_detect(&cfg, &t.img, NULL, 0, r2, 2048), TVO_OK);
        assert_same_corners(r->out, r->n, r2->out, r2->n);
        /* capacity limits the count */
        assert_int_equal(run_detect(&cfg, &t.img, NULL, 0, r2, 10), TVO_OK);
        assert_true(r2->n <= 10);
        assert_int_equal(run_detect(&cfg, &t.img, NULL, 0, r2, 0), TVO_OK);
        assert_int_equal(r2->n, 0);
        /* strongest first within a cell */
        for (i = 0; i < r->n; ++i) {
            int32_t j;
            for (j = i + 1; j < r->n; ++j)
                if (cell_of(&cfg, w, h, r->out[i].x, r->out[i].y) ==
                    cell_of(&cfg, w, h, r->out[j].x, r->out[j].y))
                    assert_true(r->out[i].score >= r->out[j].score);
        }
        free(r);
        free(r2);
        img_free(&t);
    }
}

static void test_detect_empty_cells(void **state)
{
    /* texture only in the left half: right cells stay empty, left cells all get corners */
    test_img t = img_new(400, 300, 400, 0);
    tvo_detect_config cfg;
    det_run *r = (det_run *)malloc(sizeof(det_run));
    int32_t i, x, y, per_cell[48] = {0};
    (void)state;
    assert_non_null(r);
    img_blocks(&t, 3u);
    for (y = 0; y < 300; ++y)
        for (x = 200; x < 400; ++x)
            px(&t, x, y, 128);
    tvo_detect_config_default(&cfg);
    assert_int_equal(run_detect(&cfg, &t.img, NULL, 0, r, 2048), TVO_OK);
    for (i = 0; i < r->n; ++i) {
        assert_true(r->out[i].x < 204.0f);
        per_cell[cell_of(&cfg, 400, 300, r->out[i].x, r->out[i].y)]++;
    }
    for (y = 0; y < 6; ++y)
        for (x = 0; x < 3; ++x)
            assert_true(per_cell[y * 8 + x] > 0);
    /* the empty right half's quota goes to the textured cells: more than 7 per cell there */
    assert_true(r->n > 3 * 6 * 7);
    check_spacing(r->out, r->n, cfg.min_distance);
    free(r);
    img_free(&t);
}

static void test_detect_existing(void **state)
{
    test_img t = img_new(320, 240, 320, 0);
    tvo_detect_config cfg;
    det_run *r = (det_run *)malloc(sizeof(det_run)), *r0 = (det_run *)malloc(sizeof(det_run));
    tvo_point2f ex[200];
    int32_t nex = 0, i, j, x, y;
    (void)state;
    assert_non_null(r);
    assert_non_null(r0);
    img_blocks(&t, 11u);
    tvo_detect_config_default(&cfg);
    cfg.max_corners = 96; /* 2 per cell */
    assert_int_equal(run_detect(&cfg, &t.img, NULL, 0, r0, 2048), TVO_OK);
    assert_true(r0->n > 60);
    /* the corners just found, given back as existing points: none of them (nor anything within
     * min_distance) is found again, and cell 0, filled with extra existing points, gets nothing */
    for (i = 0; i < r0->n; ++i) {
        ex[nex].x = r0->out[i].x;
        ex[nex].y = r0->out[i].y;
        ++nex;
    }
    for (y = 0; y < 2; ++y)
        for (x = 0; x < 2; ++x) {
            ex[nex].x = 12.0f + 10.0f * (float)x;
            ex[nex].y = 12.0f + 10.0f * (float)y;
            ++nex;
        }
    ex[nex].x = -50.0f; /* outside: ignored */
    ex[nex].y = 10.0f;
    ++nex;
    cfg.max_corners = 4 * 48; /* 4 per cell: about 2 new ones where 2 exist, none in cell 0 */
    assert_int_equal(run_detect(&cfg, &t.img, ex, nex, r, 2048), TVO_OK);
    assert_true(r->n > 40);
    for (i = 0; i < r->n; ++i) {
        assert_true(cell_of(&cfg, 320, 240, r->out[i].x, r->out[i].y) != 0);
        for (j = 0; j < nex; ++j) {
            float dx = r->out[i].x - ex[j].x, dy = r->out[i].y - ex[j].y;
            assert_true(dx * dx + dy * dy >= cfg.min_distance * cfg.min_distance);
        }
    }
    /* NaN existing point */
    ex[0].x = NAN;
    assert_int_equal(run_detect(&cfg, &t.img, ex, nex, r, 2048), TVO_ERR_NOT_FINITE);
    free(r);
    free(r0);
    img_free(&t);
}

/* FAST only in the cells not full of existing points gives what FAST everywhere gave (the corners of full
 * cells were dropped): the same corners, scores and order, on textured, smooth and rendered images, with
 * existing points that fill a random share of the cells (some cells over their quota, some at it, some
 * below), several grids, quotas, spacings and scores. */
static void test_detect_skips_full_cells(void **state)
{
    test_img t = img_new(331, 247, 340, 0);
    det_run *a = (det_run *)malloc(sizeof(det_run)), *b = (det_run *)malloc(sizeof(det_run));
    tvo_point2f ex[600];
    tvo_pose T = tvo_pose_identity();
    uint64_t seed = 99u;
    int32_t trial, compared = 0, with_full = 0;
    (void)state;
    assert_non_null(a);
    assert_non_null(b);
    for (trial = 0; trial < 60; ++trial) {
        tvo_detect_config cfg;
        int32_t nex = 0, c, full = 0, ncell, quota, counts[64 * 64];
        size_t ss, ss2;
        void *s;
        tvo_status st, st2;
        tvo_image view = tvo_image_make(331, 247, 340, t.buf);
        if (trial % 3 == 0)
            img_blocks(&t, 3u + (uint64_t)trial);
        else if (trial % 3 == 1)
            img_random(&t, 7u + (uint64_t)trial, 1);
        else { /* the rendered room, rows of 331 pixels */
            const tvo_image room = tvo_image_make(331, 247, 331, t.buf);
            T.t[0] = 0.01 * trial;
            tvo_room_render(&T, 331, 247, 200.0, t.buf);
            memcpy(&view, &room, sizeof view);
        }
        tvo_detect_config_default(&cfg);
        cfg.grid_cols = 4 + (int32_t)(tvo_test_rand(&seed) % 9);
        cfg.grid_rows = 3 + (int32_t)(tvo_test_rand(&seed) % 7);
        cfg.max_corners = 50 + (int32_t)(tvo_test_rand(&seed) % 400);
        cfg.min_distance = (float)(tvo_test_rand(&seed) % 3) * 5.0f;
        cfg.fast_threshold = 10 + (int32_t)(tvo_test_rand(&seed) % 20);
        cfg.score = trial % 4 == 3 ? TVO_SCORE_FAST : TVO_SCORE_SHI_TOMASI;
        ncell = cfg.grid_cols * cfg.grid_rows;
        quota = (cfg.max_corners + ncell - 1) / ncell; /* the detector's per-cell quota */
        /* existing points: clusters in about half the cells, with 0-2 x the quota each, and a few anywhere */
        for (c = 0; c < ncell; ++c) {
            const int32_t k = tvo_test_rand(&seed) % 2 ? (int32_t)(tvo_test_rand(&seed) % (2 * quota + 1))
                                                       : 0;
            const float cw = 331.0f / (float)cfg.grid_cols, ch = 247.0f / (float)cfg.grid_rows;
            for (int32_t q = 0; q < k && nex < 560; ++q) {
                ex[nex].x = cw *
                        ((float)(c % cfg.grid_cols) + 0.1f +
                         0.8f * (float)(tvo_test_rand(&seed) % 1000) / 1000.0f);
                ex[nex].y = ch *
                        ((float)(c / cfg.grid_cols) + 0.1f +
                         0.8f * (float)(tvo_test_rand(&seed) % 1000) / 1000.0f);
                ++nex;
            }
        }
        for (c = 0; c < 20; ++c, ++nex) {
            ex[nex].x = (float)(tvo_test_rand(&seed) % 3310) / 10.0f;
            ex[nex].y = (float)(tvo_test_rand(&seed) % 2470) / 10.0f;
        }
        /* how many cells are full (the share FAST skips): counted as the detector counts them */
        memset(counts, 0, sizeof(counts));
        for (c = 0; c < nex; ++c) /* the points inside the cells' region (border 8) */
            if (ex[c].x >= 8.0f && ex[c].y >= 8.0f && ex[c].x < 331.0f - 8.0f && ex[c].y < 247.0f - 8.0f)
                counts[cell_of(&cfg, 331, 247, ex[c].x, ex[c].y)]++;
        for (c = 0; c < ncell; ++c)
            full += counts[c] >= quota;
        ss = tvo_detect_scratch_size(&cfg, 331, 247);
        ss2 = tvo_detect_scratch_size_all_cells(&cfg, 331, 247);
        assert_true(ss > 0 && ss == ss2);
        s = malloc(ss);
        assert_non_null(s);
        st = tvo_detect(&cfg, &view, ex, nex, a->out, 2048, &a->n, s, ss);
        st2 = tvo_detect_all_cells(&cfg, &view, ex, nex, b->out, 2048, &b->n, s, ss);
        free(s);
        assert_int_equal(st, TVO_OK);
        assert_int_equal(st2, TVO_OK);
        assert_same_corners(a->out, a->n, b->out, b->n);
        compared += a->n;
        with_full += full > 0 && full < ncell;
    }
    assert_true(compared > 2000); /* the runs had corners to compare */
    assert_true(with_full > 40);  /* and most had full cells beside others */
    free(a);
    free(b);
    img_free(&t);
}

static void test_detect_bad_input(void **state)
{
    test_img t = img_new(64, 48, 64, 0);
    tvo_detect_config cfg, bad;
    tvo_corner out[8];
    tvo_point2f ex[1] = {{1.0f, 1.0f}};
    int32_t n = 3;
    uint8_t *s;
    size_t ss;
    (void)state;
    img_blocks(&t, 1u);
    tvo_detect_config_default(&cfg);
    ss = tvo_detect_scratch_size(&cfg, 64, 48);
    assert_true(ss > 0);
    s = (uint8_t *)malloc(ss);
    assert_non_null(s);
    assert_int_equal(tvo_detect(&cfg, &t.img, NULL, 0, out, 8, &n, s, ss), TVO_OK);
    assert_int_equal(tvo_detect(NULL, &t.img, NULL, 0, out, 8, &n, s, ss), TVO_ERR_NULL);
    assert_int_equal(n, 0);
    assert_int_equal(tvo_detect(&cfg, NULL, NULL, 0, out, 8, &n, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_detect(&cfg, &t.img, NULL, 1, out, 8, &n, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_detect(&cfg, &t.img, NULL, 0, NULL, 8, &n, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_detect(&cfg, &t.img, NULL, 0, out, 8, NULL, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_detect(&cfg, &t.img, NULL, 0, out, 8, &n, NULL, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_detect(&cfg, &t.img, NULL, 0, out, 8, &n, s, ss - 1), TVO_ERR_NO_MEMORY);
    assert_int_equal(tvo_detect(&cfg, &t.img, ex, -1, out, 8, &n, s, ss), TVO_ERR_ARG);
    assert_int_equal(tvo_detect(&cfg, &t.img, NULL, 0, out, -1, &n, s, ss), TVO_ERR_ARG);
    {
        tvo_image bs = tvo_image_make(64, 48, 63, t.buf), z = tvo_image_make(64, 0, 64, t.buf);
        assert_int_equal(tvo_detect(&cfg, &bs, NULL, 0, out, 8, &n, s, ss), TVO_ERR_SIZE);
        assert_int_equal(tvo_detect(&cfg, &z, NULL, 0, out, 8, &n, s, ss), TVO_ERR_SIZE);
    }
    /* bad config values, one at a time */
#define BAD_CFG(field, value, expect)                                                   \
    do {                                                                                \
        bad = cfg;                                                                      \
        bad.field = value;                                                              \
        assert_int_equal(tvo_detect_config_check(&bad), expect);                        \
        assert_int_equal(tvo_detect_scratch_size(&bad, 64, 48), 0);                     \
        assert_int_equal(tvo_detect(&bad, &t.img, NULL, 0, out, 8, &n, s, ss), expect); \
    } while (0)
    BAD_CFG(fast_threshold, -1, TVO_ERR_ARG);
    BAD_CFG(fast_threshold, 256, TVO_ERR_ARG);
    BAD_CFG(score, (tvo_score_kind)3, TVO_ERR_ARG);
    BAD_CFG(block_size, 0, TVO_ERR_ARG);
    BAD_CFG(block_size, TVO_CORNER_MAX_BLOCK + 1, TVO_ERR_ARG);
    BAD_CFG(harris_k, NAN, TVO_ERR_NOT_FINITE);
    BAD_CFG(grid_cols, 0, TVO_ERR_ARG);
    BAD_CFG(grid_rows, 257, TVO_ERR_ARG);
    BAD_CFG(max_corners, -1, TVO_ERR_ARG);
    BAD_CFG(max_per_cell, -2, TVO_ERR_ARG);
    BAD_CFG(min_distance, -1.0f, TVO_ERR_ARG);
    BAD_CFG(min_distance, INFINITY, TVO_ERR_NOT_FINITE);
    BAD_CFG(border, -1, TVO_ERR_ARG);
    BAD_CFG(candidates_per_cell, -1, TVO_ERR_ARG);
#undef BAD_CFG
    assert_int_equal(tvo_detect_config_check(NULL), TVO_ERR_NULL);
    assert_int_equal(tvo_detect_scratch_size(NULL, 64, 48), 0);
    assert_int_equal(tvo_detect_scratch_size(&cfg, 0, 48), 0);
    tvo_detect_config_default(NULL); /* no crash */
    free(s);
    /* tiny images: 0 corners, TVO_OK */
    {
        tvo_image tiny = tvo_image_make(10, 10, 64, t.buf), one = tvo_image_make(1, 1, 1, t.buf);
        ss = tvo_detect_scratch_size(&cfg, 10, 10);
        s = (uint8_t *)malloc(ss);
        assert_non_null(s);
        assert_int_equal(tvo_detect(&cfg, &tiny, NULL, 0, out, 8, &n, s, ss), TVO_OK);
        assert_int_equal(n, 0);
        free(s);
        ss = tvo_detect_scratch_size(&cfg, 1, 1);
        s = (uint8_t *)malloc(ss);
        assert_non_null(s);
        assert_int_equal(tvo_detect(&cfg, &one, NULL, 0, out, 8, &n, s, ss), TVO_OK);
        assert_int_equal(n, 0);
        free(s);
    }
    img_free(&t);
}

static void test_detect_scores_and_options(void **state)
{
    /* FAST and Harris ranking, min_distance 0, explicit max_per_cell and candidates */
    test_img t = img_new(200, 150, 200, 0);
    tvo_detect_config cfg;
    det_run *r = (det_run *)malloc(sizeof(det_run));
    int32_t i;
    (void)state;
    assert_non_null(r);
    img_blocks(&t, 21u);
    tvo_detect_config_default(&cfg);
    cfg.score = TVO_SCORE_FAST;
    cfg.min_distance = 0.0f;
    cfg.grid_cols = 4;
    cfg.grid_rows = 3;
    cfg.max_per_cell = 3;
    cfg.max_corners = 30;
    assert_int_equal(run_detect(&cfg, &t.img, NULL, 0, r, 2048), TVO_OK);
    assert_true(r->n > 0 && r->n <= 30);
    for (i = 0; i < r->n; ++i) {
        assert_true(r->out[i].score >= 20.0f);
        assert_true(r->out[i].score ==
                    (float)tvo_fast9_score_at(&t.img, (int32_t)r->out[i].x, (int32_t)r->out[i].y));
    }
    cfg.score = TVO_SCORE_HARRIS;
    cfg.block_size = 7;
    cfg.candidates_per_cell = 5;
    assert_int_equal(run_detect(&cfg, &t.img, NULL, 0, r, 2048), TVO_OK);
    assert_true(r->n > 0);
    for (i = 0; i < r->n; ++i)
        assert_true(r->out[i].score ==
                    tvo_corner_score_at(&t.img, (int32_t)r->out[i].x, (int32_t)r->out[i].y, TVO_SCORE_HARRIS,
                                        7, cfg.harris_k));
    free(r);
    img_free(&t);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_fast_square_corners),
            cmocka_unit_test(test_fast_matches_reference),
            cmocka_unit_test(test_fast_simd_matches_portable),
            cmocka_unit_test(test_fast_rect),
            cmocka_unit_test(test_fast_kernel_name),
            cmocka_unit_test(test_fast_rows_and_capacity),
            cmocka_unit_test(test_fast_bad_input),
            cmocka_unit_test(test_response_dense_vs_point),
            cmocka_unit_test(test_response_known_structures),
            cmocka_unit_test(test_response_bad_input),
            cmocka_unit_test(test_detect_spreads),
            cmocka_unit_test(test_detect_empty_cells),
            cmocka_unit_test(test_detect_existing),
            cmocka_unit_test(test_detect_skips_full_cells),
            cmocka_unit_test(test_detect_bad_input),
            cmocka_unit_test(test_detect_scores_and_options),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
