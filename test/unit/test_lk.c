/* SPDX-License-Identifier: Apache-2.0 */
/* Pyramidal Lucas-Kanade: known shifts, forward-backward check, points outside, bad inputs. */
#include <math.h>
#include <string.h>

#include "tvo_test.h"
#include "tinyvo/lk.h"

#define W 160
#define H 120
#define NWAVES 6
#define TWO_PI 6.283185307179586

/* Smooth texture: sum of plane waves, content translated by (dx, dy). */
static void render(uint8_t *img, int w, int h, double dx, double dy)
{
    static const double fx[NWAVES] = {0.21, -0.13, 0.37, 0.05, -0.29, 0.11};
    static const double fy[NWAVES] = {0.07, 0.31, -0.17, -0.41, 0.23, 0.19};
    static const double ph[NWAVES] = {0.3, 1.1, 2.0, 4.2, 5.1, 0.7};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double v = 128.0;
            for (int k = 0; k < NWAVES; ++k)
                v += 20.0 * sin(fx[k] * (x - dx) + fy[k] * (y - dy) + ph[k]);
            img[y * w + x] = (uint8_t)floor(v + 0.5);
        }
}

typedef struct fixture {
    uint8_t a[W * H], b[W * H];
    uint8_t mem_a[1 << 16], mem_b[1 << 16];
    tvo_pyramid pa, pb;
    tvo_lk_config cfg;
    uint8_t scratch[1 << 15];
} fixture;

static fixture F;

static void build(int levels, double dx, double dy)
{
    tvo_image ia = tvo_image_make(W, H, W, F.a), ib = tvo_image_make(W, H, W, F.b);
    render(F.a, W, H, 0.0, 0.0);
    render(F.b, W, H, dx, dy);
    assert_true(tvo_pyramid_required_size(W, H, levels) <= sizeof(F.mem_a));
    assert_int_equal(tvo_pyramid_init(&F.pa, W, H, levels, F.mem_a, sizeof(F.mem_a)), TVO_OK);
    assert_int_equal(tvo_pyramid_init(&F.pb, W, H, levels, F.mem_b, sizeof(F.mem_b)), TVO_OK);
    assert_int_equal(tvo_pyramid_build(&F.pa, &ia), TVO_OK);
    assert_int_equal(tvo_pyramid_build(&F.pb, &ib), TVO_OK);
    tvo_lk_config_default(&F.cfg);
    F.cfg.max_level = levels - 1;
    assert_true(tvo_lk_scratch_size(&F.cfg) <= sizeof(F.scratch));
}

static void grid_points(tvo_point2f *p, int *n)
{
    int k = 0;
    for (int y = 30; y <= H - 30; y += 15)
        for (int x = 30; x <= W - 30; x += 15)
            p[k++] = (tvo_point2f){(float)x + 0.3f, (float)y + 0.6f};
    *n = k;
}

static void check_shift(double dx, double dy, int levels)
{
    tvo_point2f p0[64], p1[64];
    uint8_t st[64];
    float err[64];
    int n, ok = 0, good = 0;
    build(levels, dx, dy);
    grid_points(p0, &n);
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, err, n, F.scratch, sizeof(F.scratch)),
                     TVO_OK);
    for (int i = 0; i < n; ++i) {
        if (st[i] != TVO_LK_TRACKED)
            continue;
        ++ok;
        if (fabs(p1[i].x - (p0[i].x + dx)) < 0.05 && fabs(p1[i].y - (p0[i].y + dy)) < 0.05)
            ++good;
        assert_true(err[i] >= 0.0f);
        if (fabs(p1[i].x - (p0[i].x + dx)) < 0.05) /* a good match has a small error */
            assert_true(err[i] < 2.0f);
    }
    /* all tracked, all within 0.05 px (at most one exception) */
    assert_true(ok >= n - 1);
    assert_true(good >= n - 1);
}

static void test_known_shifts(void **state)
{
    (void)state;
    check_shift(0.0, 0.0, 1);
    check_shift(0.4, -0.3, 1);
    check_shift(1.7, 0.8, 2);
    check_shift(-6.25, 3.5, 2);
    check_shift(8.6, -5.2, 3);
    check_shift(9.5, 6.5, 3);
}

static void test_identical_images_zero_motion(void **state)
{
    tvo_point2f p0[64], p1[64];
    uint8_t st[64];
    float err[64];
    int n;
    (void)state;
    build(3, 0.0, 0.0);
    grid_points(p0, &n);
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, err, n, F.scratch, sizeof(F.scratch)),
                     TVO_OK);
    for (int i = 0; i < n; ++i) {
        assert_int_equal(st[i], TVO_LK_TRACKED);
        assert_true(fabsf(p1[i].x - p0[i].x) < 1e-3f && fabsf(p1[i].y - p0[i].y) < 1e-3f);
        assert_true(err[i] < 1e-3f);
    }
}

static void test_initial_flow(void **state)
{
    tvo_point2f p0[64], p1[64];
    uint8_t st[64];
    int n;
    (void)state;
    build(1, 9.3, -4.1); /* too far for one level without a guess ... */
    grid_points(p0, &n);
    F.cfg.use_initial_flow = 1;
    for (int i = 0; i < n; ++i)
        p1[i] = (tvo_point2f){p0[i].x + 9.0f, p0[i].y - 4.0f}; /* ... fine with one */
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, NULL, n, F.scratch, sizeof(F.scratch)),
                     TVO_OK);
    for (int i = 0; i < n; ++i) {
        assert_int_equal(st[i], TVO_LK_TRACKED);
        assert_true(fabs(p1[i].x - (p0[i].x + 9.3)) < 0.05 && fabs(p1[i].y - (p0[i].y - 4.1)) < 0.05);
    }
}

/* A texture periodic in x (period 8 px): a guess one period off converges to the wrong copy. The
 * backward track starts from the guess's displacement reversed, so it comes back to the start: the
 * forward-backward check tests that a track is consistent, and a guess wrong by a whole period gives a
 * consistent pair (that is a limit of the check, stated in lk.h). A good guess passes too. */
static void test_fb_check_and_periodic_guess(void **state)
{
    tvo_point2f p0[2] = {{80.0f, 60.0f}, {80.0f, 60.0f}}, p1[2];
    uint8_t st[2];
    float err[2];
    tvo_image ia = tvo_image_make(W, H, W, F.a), ib = tvo_image_make(W, H, W, F.b);
    (void)state;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            double v0 = 128 + 60 * sin(TWO_PI * x / 8.0) + 40 * sin(TWO_PI * y / 23.0);
            double v1 = 128 + 60 * sin(TWO_PI * (x - 3.0) / 8.0) + 40 * sin(TWO_PI * y / 23.0);
            F.a[y * W + x] = (uint8_t)floor(v0 + 0.5);
            F.b[y * W + x] = (uint8_t)floor(v1 + 0.5);
        }
    assert_int_equal(tvo_pyramid_init(&F.pa, W, H, 1, F.mem_a, sizeof(F.mem_a)), TVO_OK);
    assert_int_equal(tvo_pyramid_init(&F.pb, W, H, 1, F.mem_b, sizeof(F.mem_b)), TVO_OK);
    assert_int_equal(tvo_pyramid_build(&F.pa, &ia), TVO_OK);
    assert_int_equal(tvo_pyramid_build(&F.pb, &ib), TVO_OK);
    tvo_lk_config_default(&F.cfg);
    F.cfg.max_level = 0;
    F.cfg.use_initial_flow = 1;
    for (int check = 0; check < 2; ++check) {
        F.cfg.fb_check = check;
        F.cfg.fb_max_error = 1.0f;
        p1[0] = (tvo_point2f){80.0f + 10.5f, 60.0f};
        p1[1] = (tvo_point2f){80.0f + 2.5f, 60.0f};
        assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, err, 2, F.scratch, sizeof(F.scratch)),
                         TVO_OK);
        assert_int_equal(st[0], TVO_LK_TRACKED);
        assert_int_equal(st[1], TVO_LK_TRACKED);
        assert_true(fabsf(p1[0].x - 91.0f) < 0.1f); /* the wrong copy (+3 + 8) */
        assert_true(fabsf(p1[1].x - 83.0f) < 0.1f);
    }
}

/* The forward-backward check with a guess: a motion too large for one level without a guess (9.3 px)
 * is tracked with a guess and passes the check, because the way back starts from the guess reversed
 * (from zero displacement it would not reach the start); a point whose content changes between the
 * images (an occluding patch pasted into the second one) is tracked forward but rejected by the check. */
static void test_fb_check_with_guess(void **state)
{
    tvo_point2f p0[64], p1[64], q0[2] = {{60.3f, 45.6f}, {100.3f, 75.6f}}, q1[2];
    uint8_t st[64];
    int n, lost_plain = 0;
    (void)state;
    build(1, 9.3, -4.1);
    grid_points(p0, &n);
    F.cfg.use_initial_flow = 1;
    F.cfg.fb_check = 1;
    F.cfg.fb_max_error = 0.5f;
    for (int i = 0; i < n; ++i)
        p1[i] = (tvo_point2f){p0[i].x + 9.0f, p0[i].y - 4.0f};
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, NULL, n, F.scratch, sizeof(F.scratch)),
                     TVO_OK);
    for (int i = 0; i < n; ++i) {
        assert_int_equal(st[i], TVO_LK_TRACKED);
        assert_true(fabs(p1[i].x - (p0[i].x + 9.3)) < 0.05 && fabs(p1[i].y - (p0[i].y - 4.1)) < 0.05);
    }
    /* without a guess the same motion is not tracked on one level */
    F.cfg.use_initial_flow = 0;
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, NULL, n, F.scratch, sizeof(F.scratch)),
                     TVO_OK);
    for (int i = 0; i < n; ++i)
        lost_plain += st[i] == TVO_LK_LOST || fabs(p1[i].x - (p0[i].x + 9.3)) > 0.5;
    assert_true(lost_plain > n / 2);
    /* occlusion: a 31x31 patch of another texture pasted into the second image around q0[0] + the motion */
    {
        tvo_image ib = tvo_image_make(W, H, W, F.b);
        for (int y = 30; y < 61; ++y)
            for (int x = 54; x < 85; ++x)
                F.b[y * W + x] = (uint8_t)(128 + 90 * sin(0.9 * x) * cos(0.7 * y + 0.4 * x));
        assert_int_equal(tvo_pyramid_build(&F.pb, &ib), TVO_OK);
    }
    F.cfg.use_initial_flow = 1;
    for (int check = 1; check >= 0; --check) { /* without the check the occluded point is accepted */
        F.cfg.fb_check = check;
        for (int i = 0; i < 2; ++i)
            q1[i] = (tvo_point2f){q0[i].x + 9.0f, q0[i].y - 4.0f};
        assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, q0, q1, st, NULL, 2, F.scratch,
                                      sizeof(F.scratch)),
                         TVO_OK);
        assert_int_equal(st[0], check ? TVO_LK_LOST : TVO_LK_TRACKED);
        assert_int_equal(st[1], TVO_LK_TRACKED);
    }
}

/* The short way back (fb_levels): a large motion through 3 levels is checked on level 0 only, from the
 * start point; good tracks pass, the occluded one fails as with the full check, and the forward
 * positions are those of the full check (the way back only decides the status). */
static void test_fb_levels(void **state)
{
    tvo_point2f p0[64], full[64], shrt[64], q0[2] = {{60.3f, 45.6f}, {100.3f, 75.6f}}, q1[2];
    uint8_t st_full[64], st_short[64], st[2];
    int n;
    (void)state;
    build(3, 7.4, -5.2);
    grid_points(p0, &n);
    F.cfg.fb_check = 1;
    F.cfg.fb_max_error = 0.5f;
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, full, st_full, NULL, n, F.scratch,
                                  sizeof(F.scratch)),
                     TVO_OK);
    F.cfg.fb_levels = 1;
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, shrt, st_short, NULL, n, F.scratch,
                                  sizeof(F.scratch)),
                     TVO_OK);
    for (int i = 0; i < n; ++i) {
        assert_int_equal(st_full[i], TVO_LK_TRACKED);
        assert_int_equal(st_short[i], TVO_LK_TRACKED);
        assert_memory_equal(&full[i], &shrt[i], sizeof(tvo_point2f));
    }
    {
        tvo_image ib = tvo_image_make(W, H, W, F.b);
        for (int y = 30; y < 61; ++y)
            for (int x = 54; x < 85; ++x)
                F.b[y * W + x] = (uint8_t)(128 + 90 * sin(0.9 * x) * cos(0.7 * y + 0.4 * x));
        assert_int_equal(tvo_pyramid_build(&F.pb, &ib), TVO_OK);
    }
    for (int lv = 0; lv <= 2; ++lv) {
        F.cfg.fb_levels = lv;
        assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, q0, q1, st, NULL, 2, F.scratch,
                                      sizeof(F.scratch)),
                         TVO_OK);
        assert_int_equal(st[0], TVO_LK_LOST);
        assert_int_equal(st[1], TVO_LK_TRACKED);
    }
    F.cfg.fb_check = 0; /* the forward track alone accepts the occluded point */
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, q0, q1, st, NULL, 2, F.scratch, sizeof(F.scratch)),
                     TVO_OK);
    assert_int_equal(st[0], TVO_LK_TRACKED);
}

/* Predicted points (tvo_lk_track_pred, pred_* fields): with pred == NULL or the pred_* fields at 0 the
 * results are tvo_lk_track()'s, bit for bit; a point flagged with a good guess is tracked on level 0 alone
 * with a smaller window and the short way back, and lands where the full track does (within 0.05 px); the
 * same guess without the flag, or an unflagged point in the same call, is tracked as by tvo_lk_track(). */
static void test_predicted_points(void **state)
{
    tvo_point2f p0[64], g[64], ref[64], out[64];
    uint8_t st_ref[64], st[64], pred[64];
    float e_ref[64], e[64];
    int n;
    (void)state;
    build(3, 7.4, -5.2);
    grid_points(p0, &n);
    F.cfg.fb_check = 1;
    F.cfg.use_initial_flow = 1;
    for (int i = 0; i < n; ++i) {
        g[i] = (tvo_point2f){p0[i].x + 6.9f, p0[i].y - 4.6f}; /* within 1 px of the motion */
        pred[i] = (uint8_t)(i & 1);
    }
    memcpy(ref, g, sizeof(ref));
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, ref, st_ref, e_ref, n, F.scratch,
                                  sizeof(F.scratch)),
                     TVO_OK);
    /* the pred_* fields at 0: the flags change nothing */
    memcpy(out, g, sizeof(out));
    assert_int_equal(tvo_lk_track_pred(&F.cfg, &F.pa, &F.pb, p0, out, pred, st, e, n, F.scratch,
                                       sizeof(F.scratch)),
                     TVO_OK);
    assert_memory_equal(out, ref, (size_t)n * sizeof(tvo_point2f));
    assert_memory_equal(st, st_ref, (size_t)n);
    assert_memory_equal(e, e_ref, (size_t)n * sizeof(float));
    /* pred == NULL with pred_* set: tvo_lk_track() */
    F.cfg.pred_levels = 1;
    F.cfg.pred_win_size = 13;
    F.cfg.pred_fb_levels = 1;
    assert_true(tvo_lk_scratch_size(&F.cfg) <= sizeof(F.scratch));
    memcpy(out, g, sizeof(out));
    assert_int_equal(tvo_lk_track_pred(&F.cfg, &F.pa, &F.pb, p0, out, NULL, st, e, n, F.scratch,
                                       sizeof(F.scratch)),
                     TVO_OK);
    assert_memory_equal(out, ref, (size_t)n * sizeof(tvo_point2f));
    assert_memory_equal(st, st_ref, (size_t)n);
    /* flagged points: level 0, 13x13, the short way back; the others exactly as before */
    memcpy(out, g, sizeof(out));
    assert_int_equal(tvo_lk_track_pred(&F.cfg, &F.pa, &F.pb, p0, out, pred, st, e, n, F.scratch,
                                       sizeof(F.scratch)),
                     TVO_OK);
    for (int i = 0; i < n; ++i) {
        assert_int_equal(st_ref[i], TVO_LK_TRACKED);
        assert_int_equal(st[i], TVO_LK_TRACKED);
        if (pred[i]) {
            assert_true(fabs(out[i].x - ref[i].x) < 0.05 && fabs(out[i].y - ref[i].y) < 0.05);
        } else {
            assert_memory_equal(&out[i], &ref[i], sizeof(tvo_point2f));
            assert_memory_equal(&e[i], &e_ref[i], sizeof(float));
        }
    }
    /* a window larger than win_size for the flagged points needs more scratch */
    F.cfg.pred_win_size = 31;
    {
        tvo_lk_config c = F.cfg;
        c.pred_win_size = 0;
        assert_true(tvo_lk_scratch_size(&F.cfg) > tvo_lk_scratch_size(&c));
    }
    /* bad values */
    {
        tvo_lk_config c = F.cfg;
        c.pred_win_size = 14;
        assert_int_equal(tvo_lk_config_check(&c), TVO_ERR_ARG);
        c.pred_win_size = 1;
        assert_int_equal(tvo_lk_config_check(&c), TVO_ERR_ARG);
        c.pred_win_size = TVO_LK_MAX_WIN_SIZE + 2;
        assert_int_equal(tvo_lk_config_check(&c), TVO_ERR_ARG);
        c = F.cfg;
        c.pred_levels = -1;
        assert_int_equal(tvo_lk_config_check(&c), TVO_ERR_ARG);
        c.pred_levels = TVO_MAX_PYR_LEVELS + 1;
        assert_int_equal(tvo_lk_config_check(&c), TVO_ERR_ARG);
        c = F.cfg;
        c.pred_fb_levels = -1;
        assert_int_equal(tvo_lk_config_check(&c), TVO_ERR_ARG);
        c.pred_fb_levels = TVO_MAX_PYR_LEVELS + 1;
        assert_int_equal(tvo_lk_config_check(&c), TVO_ERR_ARG);
        c.pred_fb_levels = TVO_MAX_PYR_LEVELS;
        assert_int_equal(tvo_lk_config_check(&c), TVO_OK);
    }
}

/* pred_retry: a flagged point whose guess is too far for the short way (level 0, 13x13) is lost without
 * the retry, and with it is tracked again the configuration's way from the same guess: the result of
 * tvo_lk_track() from that guess, bit for bit; flagged points the short way tracks are not touched. */
static void test_predicted_points_retry(void **state)
{
    tvo_point2f p0[64], g[64], ref[64], out[64], shrt[64];
    uint8_t st_ref[64], st[64], st_short[64], pred[64];
    float e_ref[64], e[64];
    int n, lost = 0;
    (void)state;
    build(3, 7.4, -5.2);
    grid_points(p0, &n);
    F.cfg.fb_check = 1;
    F.cfg.use_initial_flow = 1;
    for (int i = 0; i < n; ++i) {
        const int far = (i % 3) == 0; /* 12 px off the motion: beyond a 13x13 window on level 0 */
        g[i] = (tvo_point2f){p0[i].x + 7.4f + (far ? 12.0f : 0.4f), p0[i].y - 5.2f + (far ? -9.0f : 0.3f)};
        pred[i] = (uint8_t)(i & 1);
    }
    memcpy(ref, g, sizeof(ref));
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, ref, st_ref, e_ref, n, F.scratch,
                                  sizeof(F.scratch)),
                     TVO_OK);
    F.cfg.pred_levels = 1;
    F.cfg.pred_win_size = 13;
    memcpy(shrt, g, sizeof(shrt));
    assert_int_equal(tvo_lk_track_pred(&F.cfg, &F.pa, &F.pb, p0, shrt, pred, st_short, NULL, n, F.scratch,
                                       sizeof(F.scratch)),
                     TVO_OK);
    F.cfg.pred_retry = 1;
    memcpy(out, g, sizeof(out));
    assert_int_equal(tvo_lk_track_pred(&F.cfg, &F.pa, &F.pb, p0, out, pred, st, e, n, F.scratch,
                                       sizeof(F.scratch)),
                     TVO_OK);
    for (int i = 0; i < n; ++i) {
        if (pred[i] && st_short[i] == TVO_LK_TRACKED) { /* the short way's result, untouched */
            assert_int_equal(st[i], TVO_LK_TRACKED);
            assert_memory_equal(&out[i], &shrt[i], sizeof(tvo_point2f));
        } else { /* unflagged, or lost by the short way and tracked again: tvo_lk_track()'s */
            assert_int_equal(st[i], st_ref[i]);
            assert_memory_equal(&out[i], &ref[i], sizeof(tvo_point2f));
            assert_memory_equal(&e[i], &e_ref[i], sizeof(float));
        }
        if (pred[i] && (i % 3) != 0)
            assert_int_equal(st_short[i], TVO_LK_TRACKED);
        /* rescued: lost the short way, tracked by the retry */
        lost += pred[i] && st_short[i] == TVO_LK_LOST && st[i] == TVO_LK_TRACKED;
    }
    assert_true(lost > 0); /* some far guesses fail the short way and the retry brings them in */
}

static void test_points_outside_and_at_borders(void **state)
{
    tvo_point2f p0[12] = {{-100.0f, 10.0f}, {1e30f, 5.0f},        {5.0f, -1e30f},   {W + 50.0f, H / 2.0f},
                          {0.0f, 0.0f},     {W - 1.0f, H - 1.0f}, {0.5f, H / 2.0f}, {W / 2.0f, 0.2f},
                          {-3.0f, -3.0f},   {W + 2.0f, H + 2.0f}, {3e9f, 3e9f},     {-2e9f, 7.0f}};
    tvo_point2f p1[12];
    uint8_t st[12];
    float err[12];
    (void)state;
    build(3, 4.2, -2.7);
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, err, 12, F.scratch, sizeof(F.scratch)),
                     TVO_OK);
    assert_int_equal(st[0], TVO_LK_LOST);
    assert_int_equal(st[1], TVO_LK_LOST);
    assert_int_equal(st[2], TVO_LK_LOST);
    assert_int_equal(st[3], TVO_LK_LOST);
    assert_int_equal(st[10], TVO_LK_LOST);
    assert_int_equal(st[11], TVO_LK_LOST);
    assert_true(err[0] == 0.0f);
    for (int i = 0; i < 12; ++i) {
        if (st[i] == TVO_LK_TRACKED) { /* tracked points end inside the image */
            assert_true(p1[i].x >= 0.0f && p1[i].x <= W - 1.0f && p1[i].y >= 0.0f && p1[i].y <= H - 1.0f);
        }
    }
    /* forward-backward on the same points exercises border windows in both directions */
    F.cfg.fb_check = 1;
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, err, 12, F.scratch, sizeof(F.scratch)),
                     TVO_OK);
    assert_int_equal(st[0], TVO_LK_LOST);
}

static void test_random_points_everywhere(void **state)
{
    tvo_point2f p0[500], p1[500];
    uint8_t st[500];
    float err[500];
    uint64_t seed = 4242;
    int tracked = 0;
    (void)state;
    build(3, -3.3, 5.1);
    for (int i = 0; i < 500; ++i) {
        p0[i].x = (float)((double)(tvo_test_rand(&seed) >> 11) / 9007199254740992.0 * (W + 80) - 40);
        p0[i].y = (float)((double)(tvo_test_rand(&seed) >> 11) / 9007199254740992.0 * (H + 80) - 40);
    }
    F.cfg.fb_check = 1;
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, err, 500, F.scratch, sizeof(F.scratch)),
                     TVO_OK);
    for (int i = 0; i < 500; ++i) {
        assert_true(st[i] == TVO_LK_TRACKED || st[i] == TVO_LK_LOST);
        if (st[i] == TVO_LK_TRACKED) {
            ++tracked;
            assert_true(isfinite(p1[i].x) && isfinite(p1[i].y) && isfinite(err[i]));
        }
    }
    assert_true(tracked > 150);
}

static void test_small_image_skips_small_levels(void **state)
{
    /* 64x48 with 3 levels: level 2 (16x12) is not larger than the 21 px window and is not used */
    static uint8_t a[64 * 48], b[64 * 48], ma[1 << 13], mb[1 << 13];
    tvo_pyramid pa, pb;
    tvo_lk_config cfg;
    tvo_point2f p0[1] = {{32.0f, 24.0f}}, p1[1];
    uint8_t st[1];
    tvo_image ia = tvo_image_make(64, 48, 64, a), ib = tvo_image_make(64, 48, 64, b);
    (void)state;
    render(a, 64, 48, 0.0, 0.0);
    render(b, 64, 48, 2.5, 1.5);
    assert_int_equal(tvo_pyramid_init(&pa, 64, 48, 3, ma, sizeof(ma)), TVO_OK);
    assert_int_equal(tvo_pyramid_init(&pb, 64, 48, 3, mb, sizeof(mb)), TVO_OK);
    assert_int_equal(tvo_pyramid_build(&pa, &ia), TVO_OK);
    assert_int_equal(tvo_pyramid_build(&pb, &ib), TVO_OK);
    tvo_lk_config_default(&cfg);
    cfg.max_level = 2;
    assert_int_equal(tvo_lk_track(&cfg, &pa, &pb, p0, p1, st, NULL, 1, F.scratch, sizeof(F.scratch)), TVO_OK);
    assert_int_equal(st[0], TVO_LK_TRACKED);
    assert_true(fabsf(p1[0].x - 34.5f) < 0.05f && fabsf(p1[0].y - 25.5f) < 0.05f);
}

static void test_bad_inputs(void **state)
{
    tvo_point2f p0[3] = {{50.0f, 50.0f}, {60.0f, 60.0f}, {70.0f, 70.0f}}, p1[3];
    uint8_t st[3];
    float err[3];
    tvo_lk_config c;
    tvo_pyramid other;
    static uint8_t mem[1 << 16], pix[162 * H];
    void *s = F.scratch;
    size_t ss = sizeof(F.scratch);
    (void)state;
    build(3, 1.0, 1.0);
    c = F.cfg;
    /* NULL pointers */
    assert_int_equal(tvo_lk_track(NULL, &F.pa, &F.pb, p0, p1, st, err, 3, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_lk_track(&c, NULL, &F.pb, p0, p1, st, err, 3, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_lk_track(&c, &F.pa, NULL, p0, p1, st, err, 3, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, NULL, p1, st, err, 3, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, NULL, st, err, 3, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, NULL, err, 3, s, ss), TVO_ERR_NULL);
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, st, err, 3, NULL, ss), TVO_ERR_NULL);
    /* err may be NULL, n may be 0 */
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, st, NULL, 3, s, ss), TVO_OK);
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, st, err, 0, s, ss), TVO_OK);
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, st, err, -1, s, ss), TVO_ERR_SIZE);
    /* window size: even, too small, too big */
    c.win_size = 20;
    assert_int_equal(tvo_lk_config_check(&c), TVO_ERR_ARG);
    assert_int_equal(tvo_lk_scratch_size(&c), 0);
    memset(st, 7, sizeof(st));
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, st, err, 3, s, ss), TVO_ERR_ARG);
    assert_int_equal(st[0], TVO_LK_LOST); /* status cleared on error */
    c.win_size = 1;
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, st, err, 3, s, ss), TVO_ERR_ARG);
    c.win_size = TVO_LK_MAX_WIN_SIZE + 2;
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, st, err, 3, s, ss), TVO_ERR_ARG);
    c.win_size = TVO_LK_MAX_WIN_SIZE; /* largest allowed: fine, needs more scratch */
    assert_true(tvo_lk_scratch_size(&c) > tvo_lk_scratch_size(&F.cfg));
    /* other fields */
    c = F.cfg;
    c.max_iters = -1;
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, st, err, 3, s, ss), TVO_ERR_ARG);
    c = F.cfg;
    c.max_iters = TVO_LK_MAX_ITERS + 1;
    assert_int_equal(tvo_lk_config_check(&c), TVO_ERR_ARG);
    c = F.cfg;
    c.epsilon = NAN;
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, st, err, 3, s, ss), TVO_ERR_NOT_FINITE);
    c = F.cfg;
    c.min_eig_threshold = -1.0f;
    assert_int_equal(tvo_lk_config_check(&c), TVO_ERR_ARG);
    c = F.cfg;
    c.fb_check = 1;
    c.fb_max_error = 0.0f;
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, st, err, 3, s, ss), TVO_ERR_ARG);
    c.fb_max_error = INFINITY;
    assert_int_equal(tvo_lk_config_check(&c), TVO_ERR_NOT_FINITE);
    c = F.cfg;
    c.fb_levels = -1;
    assert_int_equal(tvo_lk_config_check(&c), TVO_ERR_ARG);
    c.fb_levels = TVO_MAX_PYR_LEVELS + 1;
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, st, err, 3, s, ss), TVO_ERR_ARG);
    c.fb_levels = TVO_MAX_PYR_LEVELS;
    assert_int_equal(tvo_lk_config_check(&c), TVO_OK);
    assert_int_equal(tvo_lk_config_check(NULL), TVO_ERR_NULL);
    assert_int_equal(tvo_lk_scratch_size(NULL), 0);
    /* not enough levels: pyramids have 3, max_level 3 needs 4 */
    c = F.cfg;
    c.max_level = 3;
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, st, err, 3, s, ss), TVO_ERR_ARG);
    c.max_level = TVO_MAX_PYR_LEVELS;
    assert_int_equal(tvo_lk_config_check(&c), TVO_ERR_ARG);
    /* pyramid mismatch: next is 162 wide */
    {
        tvo_image img = tvo_image_make(162, H, 162, pix);
        assert_int_equal(tvo_pyramid_init(&other, 162, H, 3, mem, sizeof(mem)), TVO_OK);
        assert_int_equal(tvo_pyramid_build(&other, &img), TVO_OK);
        assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &other, p0, p1, st, err, 3, s, ss), TVO_ERR_MISMATCH);
    }
    /* uninitialised / corrupted pyramids */
    memset(&other, 0, sizeof(other));
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &other, p0, p1, st, err, 3, s, ss), TVO_ERR_SIZE);
    other = F.pb;
    other.data[1] = NULL;
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &other, p0, p1, st, err, 3, s, ss), TVO_ERR_NULL);
    other = F.pb;
    other.width[2] = 7;
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &other, p0, p1, st, err, 3, s, ss), TVO_ERR_SIZE);
    /* scratch too small */
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, err, 3, s,
                                  tvo_lk_scratch_size(&F.cfg) - 1),
                     TVO_ERR_NO_MEMORY);
    /* NaN / infinite points */
    p0[1].x = NAN;
    memset(st, 1, sizeof(st));
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, err, 3, s, ss), TVO_ERR_NOT_FINITE);
    assert_int_equal(st[0], TVO_LK_LOST);
    assert_int_equal(st[2], TVO_LK_LOST);
    p0[1].x = 60.0f;
    p0[2].y = -INFINITY;
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, err, 3, s, ss), TVO_ERR_NOT_FINITE);
    p0[2].y = 70.0f;
    c = F.cfg;
    c.use_initial_flow = 1;
    p1[0] = p0[0];
    p1[1] = p0[1];
    p1[2] = (tvo_point2f){NAN, 1.0f};
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, st, err, 3, s, ss), TVO_ERR_NOT_FINITE);
    /* NaN guesses are fine when the guess is not used */
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, err, 3, s, ss), TVO_OK);
}

static void test_scratch_alignment_any(void **state)
{
    tvo_point2f p0[1] = {{80.0f, 60.0f}}, p1[1], q1[1];
    uint8_t st[1];
    size_t need;
    (void)state;
    build(2, 1.25, 0.5);
    need = tvo_lk_scratch_size(&F.cfg);
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, p1, st, NULL, 1, F.scratch, need), TVO_OK);
    assert_int_equal(tvo_lk_track(&F.cfg, &F.pa, &F.pb, p0, q1, st, NULL, 1, F.scratch + 5, need), TVO_OK);
    assert_memory_equal(p1, q1, sizeof(p1));
}

/* The SIMD kernels this build must have (the same macros as lib/src/tvo_lk.c): the identity tests
 * below compare them with the portable ones, so a build that silently lost them would compare the
 * portable kernels with themselves. */
#if defined(__SSE2__) && !defined(TVO_LK_NO_SIMD)
#define LK_TEST_SIMD "sse2"
#elif (defined(__ARM_NEON) || defined(__ARM_NEON__)) && !defined(TVO_LK_NO_SIMD)
#define LK_TEST_SIMD "neon"
#else
#define LK_TEST_SIMD "portable"
#endif

/* The kernel the identity tests compare with the portable one, for window c->win_size. */
static void expect_simd_kernel(const tvo_lk_config *c)
{
    tvo_lk_config p = *c;
    p.force_portable = 1;
    assert_string_equal(tvo_lk_kernel_name(c), c->win_size >= 8 ? LK_TEST_SIMD : "portable");
    assert_string_equal(tvo_lk_kernel_name(&p), "portable");
}

/* Tracks the n points p0 (n <= 300) with c's SIMD kernels (checking they are the ones compiled in)
 * and with the portable ones, both starting from guess when c.use_initial_flow (else guess may be
 * NULL), and asserts bit-identical positions, statuses and errors. */
static void expect_simd_matches_portable(tvo_lk_config c, const tvo_point2f *p0, const tvo_point2f *guess,
                                         int n)
{
    static tvo_point2f p1[300], q1[300];
    static uint8_t s1[300], s2[300];
    static float e1[300], e2[300];
    static uint8_t big_scratch[1 << 17];
    assert_true(n <= 300);
    assert_true(tvo_lk_scratch_size(&c) <= sizeof(big_scratch));
    if (guess != NULL) {
        memcpy(p1, guess, sizeof(p1[0]) * (size_t)n);
        memcpy(q1, guess, sizeof(q1[0]) * (size_t)n);
    }
    c.force_portable = 0;
    expect_simd_kernel(&c);
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, p1, s1, e1, n, big_scratch, sizeof(big_scratch)),
                     TVO_OK);
    c.force_portable = 1;
    assert_int_equal(tvo_lk_track(&c, &F.pa, &F.pb, p0, q1, s2, e2, n, big_scratch, sizeof(big_scratch)),
                     TVO_OK);
    assert_memory_equal(p1, q1, sizeof(p1[0]) * (size_t)n);
    assert_memory_equal(s1, s2, sizeof(s1[0]) * (size_t)n);
    assert_memory_equal(e1, e2, sizeof(e1[0]) * (size_t)n);
}

static void test_kernel_name(void **state)
{
    tvo_lk_config c;
    (void)state;
    tvo_lk_config_default(&c);
    assert_string_equal(tvo_lk_kernel_name(NULL), LK_TEST_SIMD);
    assert_string_equal(tvo_lk_kernel_name(&c), LK_TEST_SIMD); /* win 21 */
    c.win_size = 7;                                            /* below one 8-column strip */
    assert_string_equal(tvo_lk_kernel_name(&c), "portable");
    c.win_size = 9;
    c.force_portable = 1;
    assert_string_equal(tvo_lk_kernel_name(&c), "portable");
#if defined(__aarch64__) && !defined(TVO_LK_NO_SIMD)
    assert_string_equal(LK_TEST_SIMD, "neon"); /* aarch64 always has NEON */
#endif
    /* set by tools/run-cross.sh per target, so that a build that lost its SIMD flags fails here */
    if (getenv("TVO_EXPECT_LK_KERNEL") != NULL)
        assert_string_equal(tvo_lk_kernel_name(NULL), getenv("TVO_EXPECT_LK_KERNEL"));
}

/* The SIMD kernels (when compiled in) and the portable C kernels give bit-identical results, for
 * every tail length of the 8-pixel groups and with border windows. */
static void test_portable_and_simd_identical(void **state)
{
    static tvo_point2f p0[300];
    static const int wins[] = {3, 7, 9, 11, 13, 15, 17, 21, 23, 31, 63};
    uint64_t seed = 777;
    (void)state;
    build(3, 2.7, -1.9);
    for (int i = 0; i < 300; ++i) {
        p0[i].x = (float)((double)(tvo_test_rand(&seed) >> 11) / 9007199254740992.0 * (W + 20) - 10);
        p0[i].y = (float)((double)(tvo_test_rand(&seed) >> 11) / 9007199254740992.0 * (H + 20) - 10);
    }
    for (size_t k = 0; k < sizeof(wins) / sizeof(wins[0]); ++k) {
        tvo_lk_config c = F.cfg;
        c.win_size = wins[k];
        c.fb_check = 1;
        expect_simd_matches_portable(c, p0, NULL, 300);
    }
}

/* Extreme contrast: binary (0 / 255) images whose Scharr derivatives reach +-4080 (the largest there
 * are) and |J - I| 255 * 32. Variant 0: prev of 2-px stripes with random flips, next its random binary
 * cousin. Variant 1: prev of 2-px stripes crossed by 2-px bands every 16 rows, next the same moved
 * left by one pixel, points on integer positions: J - I and d/dx are correlated, so at win 21 an
 * 8-column strip's sum of (J - I) * Ix in the first iteration is ~2.5e9 and of Ix^2 more: above 2^31.
 * The SIMD strips keep int32 lane sums (32 rows per reduction for the iteration sums, whole strips for
 * G) and add lanes in int64; they must still match the portable path bit for bit, also for windows
 * above 32 rows. */
static void extreme_images(int variant, uint64_t *seed)
{
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            int v;
            if (variant == 0) {
                v = ((x >> 1) & 1) ? 255 : 0;
                if ((tvo_test_rand(seed) & 15) == 0)
                    v = 255 - v;
                F.a[y * W + x] = (uint8_t)v;
                F.b[y * W + x] = (tvo_test_rand(seed) & 1) ? (uint8_t)(255 - v) : (uint8_t)v;
            } else {
                F.a[y * W + x] = ((y & 15) < 2 || ((x >> 1) & 1)) ? 255 : 0;
                F.b[y * W + x] = ((y & 15) < 2 || (((x + 1) >> 1) & 1)) ? 255 : 0;
            }
        }
}

static void test_portable_and_simd_identical_extreme(void **state)
{
    static tvo_point2f p0[200];
    static const int wins[] = {21, 33, 47, 63};
    tvo_image ia = tvo_image_make(W, H, W, F.a), ib = tvo_image_make(W, H, W, F.b);
    uint64_t seed = 4242;
    (void)state;
    build(3, 0.0, 0.0);
    for (int variant = 0; variant < 2; ++variant) {
        extreme_images(variant, &seed);
        assert_int_equal(tvo_pyramid_build(&F.pa, &ia), TVO_OK);
        assert_int_equal(tvo_pyramid_build(&F.pb, &ib), TVO_OK);
        for (int i = 0; i < 200; ++i) {
            if (variant == 0) {
                p0[i].x = (float)((double)(tvo_test_rand(&seed) >> 11) / 9007199254740992.0 * (W + 20) - 10);
                p0[i].y = (float)((double)(tvo_test_rand(&seed) >> 11) / 9007199254740992.0 * (H + 20) - 10);
            } else {
                p0[i].x = (float)(10 + (i % 20) * 7);
                p0[i].y = (float)(10 + (i / 20) * 10);
            }
        }
        for (size_t k = 0; k < sizeof(wins) / sizeof(wins[0]); ++k) {
            tvo_lk_config c = F.cfg;
            c.win_size = wins[k];
            c.fb_check = 1;
            c.min_eig_threshold = 0.0f; /* keep every window, however odd */
            expect_simd_matches_portable(c, p0, NULL, 200);
        }
    }
}

static int lk_test_round(float v)
{
    int i = (int)v;
    float d = v - (float)i;
    if (d > 0.5f || (d == 0.5f && (i & 1) != 0))
        ++i;
    return i;
}

static int lk_test_w11(float a, float b)
{
    return (1 << 14) - lk_test_round((1.f - a) * (1.f - b) * 16384.f) -
            lk_test_round(a * (1.f - b) * 16384.f) - lk_test_round((1.f - a) * b * 16384.f);
}

/* Windows whose bilinear weight w11 is -1 (fractional offsets found by a search over multiples of
 * 2^-18; they occur at about 1 in 10^5 random positions): a SIMD kernel that took the weights as
 * unsigned would read it as 65535. Both the previous window (prev point) and the first iteration
 * (the guess, use_initial_flow) sample with these weights; the portable and SIMD results must agree. */
static void test_portable_and_simd_identical_negative_weight(void **state)
{
    static const int frac[][2] = {{3819, 9}, {46187, 13}, {3980, 93}, {1869, 107}, {27, 11867}, {9, 20046}};
    enum { NF = sizeof(frac) / sizeof(frac[0]), NP = NF * 4 };
    static const int wins[] = {9, 15, 21, 31};
    tvo_point2f p0[NP], guess[NP];
    (void)state;
    build(1, 1.5, -0.75);
    for (int k = 0; k < NP; ++k) {
        /* integer parts in [32, 64): float has 2^-18 resolution there, so the fractions are exact */
        const float fx = (float)frac[k % NF][0] / 262144.f, fy = (float)frac[k % NF][1] / 262144.f;
        p0[k].x = (float)(34 + 7 * (k / NF)) + fx;
        p0[k].y = (float)(40 + 5 * (k / NF)) + fy;
        assert_int_equal(lk_test_w11(p0[k].x - (float)(int)p0[k].x, p0[k].y - (float)(int)p0[k].y), -1);
    }
    for (size_t w = 0; w < sizeof(wins) / sizeof(wins[0]); ++w) {
        tvo_lk_config c = F.cfg;
        c.win_size = wins[w];
        c.max_level = 0;
        c.use_initial_flow = 1; /* guess = the point moved by whole pixels: same fractions */
        c.max_iters = 3;
        for (int k = 0; k < NP; ++k)
            guess[k] = (tvo_point2f){p0[k].x + 2.f, p0[k].y - 1.f};
        expect_simd_matches_portable(c, p0, guess, NP);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_known_shifts),
            cmocka_unit_test(test_identical_images_zero_motion),
            cmocka_unit_test(test_initial_flow),
            cmocka_unit_test(test_fb_check_and_periodic_guess),
            cmocka_unit_test(test_fb_check_with_guess),
            cmocka_unit_test(test_fb_levels),
            cmocka_unit_test(test_predicted_points),
            cmocka_unit_test(test_predicted_points_retry),
            cmocka_unit_test(test_points_outside_and_at_borders),
            cmocka_unit_test(test_random_points_everywhere),
            cmocka_unit_test(test_small_image_skips_small_levels),
            cmocka_unit_test(test_bad_inputs),
            cmocka_unit_test(test_scratch_alignment_any),
            cmocka_unit_test(test_portable_and_simd_identical),
            cmocka_unit_test(test_portable_and_simd_identical_extreme),
            cmocka_unit_test(test_portable_and_simd_identical_negative_weight),
            cmocka_unit_test(test_kernel_name),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
