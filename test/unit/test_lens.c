/* SPDX-License-Identifier: Apache-2.0 */
/* The lens refined on the run (lib/src/tvo_lens.h, cfg.lens_refine): a window's block recovers a known
 * radial error, the adoption test refuses what it must (too few blocks, halves that drift, a change too
 * small or too large to take), remapping is exact, and the VO's configuration checks. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "tinyvo/options.h"
#include "tinyvo/vo.h"

#if TVO_WITH_LENS
#include "tvo_lens.h"
#include "tvo_lens_scene.h"

typedef tvo_lens_scene scene;

static void make_scene(scene *sc, const tvo_camera *truth, const tvo_camera *cfg, double noise_px)
{
    assert_int_equal(tvo_ls_make(sc, truth, cfg, noise_px), 1);
}

static void block_estimate(const tvo_lens_block *b, double d[2], double se[2])
{
    const double det = b->I[0] * b->I[3] - b->I[1] * b->I[2];
    d[0] = (b->I[3] * b->h[0] - b->I[1] * b->h[1]) / det;
    d[1] = (-b->I[2] * b->h[0] + b->I[0] * b->h[1]) / det;
    se[0] = sqrt(b->I[3] / det);
    se[1] = sqrt(b->I[0] / det);
}

static int window(const tvo_camera *cfg, const scene *sc, tvo_lens_block *b)
{
    const size_t sz = tvo_lens_scratch_size(TVO_LS_POSES, TVO_LS_POINTS, TVO_LS_POSES * TVO_LS_POINTS);
    void *mem = malloc(sz);
    int ok;
    assert_non_null(mem);
    ok = tvo_lens_window(cfg, &sc->p, 2.5, mem, sz, b);
    free(mem);
    return ok;
}

/* Exact pixels of a lens with k1 0.02, k2 -0.01, stored with a lens without distortion: the block is
 * that change (the pixels are linear in k1, k2, and the poses and points are the true ones). */
static void test_window_recovers_change(void **state)
{
    static scene sc;
    const tvo_camera truth = tvo_ls_camera(0.02, -0.01), cfg = tvo_ls_camera(0.0, 0.0);
    tvo_lens_block b;
    double d[2], se[2];
    (void)state;
    make_scene(&sc, &truth, &cfg, 0.0);
    assert_true(sc.p.n_obs > 1500);
    assert_int_equal(window(&cfg, &sc, &b), 1);
    block_estimate(&b, d, se);
    assert_true(fabs(d[0] - 0.02) < 1e-5);
    assert_true(fabs(d[1] + 0.01) < 1e-5);
    /* a NONE camera is refined as RADTAN with zero coefficients: the same block */
    {
        tvo_camera none = cfg;
        tvo_lens_block b2;
        double d2[2], se2[2];
        none.model = TVO_DIST_NONE;
        assert_int_equal(window(&none, &sc, &b2), 1);
        block_estimate(&b2, d2, se2);
        assert_true(fabs(d2[0] - d[0]) < 1e-9 && fabs(d2[1] - d[1]) < 1e-9);
    }
}

/* With 0.3 px of noise the estimate is within 4 of its standard errors of the truth, and with the right
 * lens configured it is within 4 standard errors of zero. */
static void test_window_noise(void **state)
{
    static scene sc;
    const tvo_camera truth = tvo_ls_camera(0.02, -0.01), wrong = tvo_ls_camera(0.0, 0.0);
    tvo_lens_block b;
    double d[2], se[2];
    (void)state;
    make_scene(&sc, &truth, &wrong, 0.3);
    assert_int_equal(window(&wrong, &sc, &b), 1);
    block_estimate(&b, d, se);
    assert_true(se[0] > 0.0 && se[0] < 0.01 && se[1] > 0.0 && se[1] < 0.01);
    assert_true(fabs(d[0] - 0.02) < 4.0 * se[0]);
    assert_true(fabs(d[1] + 0.01) < 4.0 * se[1]);
    assert_true(b.s2 > 0.3 * 0.3 * 0.5 && b.s2 < 0.3 * 0.3 * 2.0); /* the residuals' variance, px^2 */
    make_scene(&sc, &truth, &truth, 0.3);
    assert_int_equal(window(&truth, &sc, &b), 1);
    block_estimate(&b, d, se);
    assert_true(fabs(d[0]) < 4.0 * se[0] && fabs(d[1]) < 4.0 * se[1]);
}

/* What the window refuses: an unsupported model, too little scratch, too few points. */
static void test_window_refuses(void **state)
{
    static scene sc;
    const tvo_camera truth = tvo_ls_camera(0.0, 0.0);
    tvo_camera fish = truth;
    tvo_lens_block b;
    uint8_t small[64];
    (void)state;
    make_scene(&sc, &truth, &truth, 0.0);
    fish.model = TVO_DIST_EQUIDISTANT;
    assert_int_equal(tvo_lens_supported(&fish), 0);
    assert_int_equal(window(&fish, &sc, &b), 0);
    assert_int_equal(tvo_lens_window(&truth, &sc.p, 2.5, small, sizeof(small), &b), 0);
    sc.p.n_points = 20; /* the observations of the others are ignored (out of range) */
    {
        const size_t sz = tvo_lens_scratch_size(TVO_LS_POSES, TVO_LS_POINTS, TVO_LS_POSES * TVO_LS_POINTS);
        void *mem = malloc(sz);
        int32_t keep = 0;
        for (int32_t o = 0; o < sc.p.n_obs; ++o)
            if (sc.obs[o].point < 20)
                sc.obs[keep++] = sc.obs[o];
        sc.p.n_obs = keep;
        assert_int_equal(tvo_lens_window(&truth, &sc.p, 2.5, mem, sz, &b), 0);
        free(mem);
    }
}

/* a block of estimate (d0, d1) with standard errors (s0, s1), uncorrelated */
static tvo_lens_block blk(double d0, double d1, double s0, double s1)
{
    tvo_lens_block b;
    memset(&b, 0, sizeof(b));
    b.I[0] = 1.0 / (s0 * s0);
    b.I[3] = 1.0 / (s1 * s1);
    b.h[0] = b.I[0] * d0;
    b.h[1] = b.I[3] * d1;
    b.s2 = 0.1;
    b.n_obs = 1000;
    return b;
}

/* KITTI's camera (1226 x 370, f 707, no distortion) */
static tvo_camera cam_kitti(void)
{
    return tvo_camera_make_pinhole(1226, 370, 707.0912, 707.0912, 601.8873, 183.1104);
}

static tvo_lens_verdict decide(const tvo_lens_block *b, int n, double dk[2], double *shift, tvo_camera *out)
{
    tvo_lens s;
    const tvo_camera cam = cam_kitti();
    memset(&s, 0, sizeof(s));
    for (int i = 0; i < n; ++i)
        tvo_lens_add(&s, &b[i]);
    return tvo_lens_decide(&s, &cam, dk, shift, out);
}

/* Two agreeing blocks as KITTI 07's first two windows: adopted, the camera changed by their combination. */
static void test_decide_adopts(void **state)
{
    const tvo_lens_block b[2] = {blk(0.0226, -0.0092, 0.0015, 0.0015), blk(0.0244, -0.0051, 0.0020, 0.0023)};
    tvo_camera c;
    double dk[2], shift;
    (void)state;
    assert_int_equal(decide(b, 1, dk, &shift, &c), TVO_LENS_WAIT);
    assert_int_equal(decide(b, 2, dk, &shift, &c), TVO_LENS_ADOPT);
    assert_true(dk[0] > 0.0226 && dk[0] < 0.0244);
    assert_true(dk[1] > -0.0092 && dk[1] < -0.0051);
    assert_int_equal(c.model, TVO_DIST_RADTAN);
    assert_true(fabs(c.k[0] - dk[0]) < 1e-15 && fabs(c.k[1] - dk[1]) < 1e-15);
    assert_true(shift > 5.0 && shift < 15.0); /* KITTI 07's measured change: 9.3 px at the border */
}

/* Blocks that drift as KITTI 01's windows did (+0.047, +0.021, +0.012, standard errors 0.002-0.005): the
 * halves disagree and nothing is adopted, however many follow. */
static void test_decide_drift_refused(void **state)
{
    const tvo_lens_block b[6] = {blk(0.047, 0.0, 0.002, 0.003), blk(0.021, 0.0, 0.005, 0.006),
                                 blk(0.012, 0.0, 0.003, 0.004), blk(0.006, 0.0, 0.003, 0.004),
                                 blk(0.002, 0.0, 0.003, 0.004), blk(0.001, 0.0, 0.003, 0.004)};
    double dk[2];
    (void)state;
    for (int n = 2; n <= 6; ++n)
        assert_int_equal(decide(b, n, dk, NULL, NULL), TVO_LENS_DISAGREE);
}

/* Halves several standard errors apart but close next to the change they agree on: adopted (the
 * standard errors are optimistic). */
static void test_decide_close_halves(void **state)
{
    const tvo_lens_block b[2] = {blk(0.024, 0.0, 0.0005, 0.0005), blk(0.021, 0.0, 0.0005, 0.0005)};
    double dk[2];
    (void)state;
    assert_int_equal(decide(b, 2, dk, NULL, NULL), TVO_LENS_ADOPT);
}

/* Too small (a render's 0.3 px), not significant, too large, or a lens that folds: not adopted. */
static void test_decide_small_large(void **state)
{
    const tvo_lens_block tiny[2] = {blk(-0.0004, 0.0004, 0.0003, 0.0002),
                                    blk(-0.0004, 0.0005, 0.0004, 0.0002)};
    const tvo_lens_block loose[2] = {blk(0.02, 0.0, 0.02, 0.01), blk(0.025, 0.0, 0.02, 0.01)};
    const tvo_lens_block huge[2] = {blk(0.2, 0.0, 0.002, 0.002), blk(0.2, 0.0, 0.002, 0.002)};
    const tvo_lens_block fold[2] = {blk(-0.9, 0.0, 0.002, 0.002), blk(-0.9, 0.0, 0.002, 0.002)};
    double dk[2], shift;
    (void)state;
    assert_int_equal(decide(tiny, 2, dk, &shift, NULL), TVO_LENS_SMALL);
    assert_true(shift < 1.0);
    assert_int_equal(decide(loose, 2, dk, NULL, NULL), TVO_LENS_SMALL);
    assert_int_equal(decide(huge, 2, dk, &shift, NULL), TVO_LENS_LARGE);
    assert_true(shift > 20.0);
    assert_int_equal(decide(fold, 2, dk, NULL, NULL), TVO_LENS_LARGE);
}

/* The store keeps the newest TVO_LENS_MAX_BLOCKS blocks; clearing keeps the adopted changes. */
static void test_blocks_ring(void **state)
{
    tvo_lens s;
    (void)state;
    memset(&s, 0, sizeof(s));
    s.updates = 2;
    for (int i = 0; i < TVO_LENS_MAX_BLOCKS + 3; ++i) {
        const tvo_lens_block b = blk(0.001 * i, 0.0, 0.01, 0.01);
        tvo_lens_add(&s, &b);
    }
    assert_int_equal(s.n, TVO_LENS_MAX_BLOCKS);
    assert_true(fabs(s.b[0].h[0] / s.b[0].I[0] - 0.003) < 1e-12);
    tvo_lens_clear_blocks(&s);
    assert_int_equal(s.n, 0);
    assert_int_equal(s.updates, 2);
}

/* A normalised point moved to another lens and back is where it was; a point the lens cannot take is
 * left unchanged. */
static void test_remap(void **state)
{
    const tvo_camera a = tvo_ls_camera(0.0, 0.0), b = tvo_ls_camera(0.03, -0.01);
    (void)state;
    for (int i = 0; i < 20; ++i) {
        tvo_point2d x = {-0.6 + 0.06 * i, 0.45 - 0.04 * i}, y = x;
        double ua, va, ub, vb;
        assert_int_equal(tvo_lens_remap(&a, &b, &y), 1);
        assert_int_equal(tvo_camera_distort_point(&a, &x, &ua, &va), TVO_OK);
        assert_int_equal(tvo_camera_distort_point(&b, &y, &ub, &vb), TVO_OK);
        assert_true(fabs(ua - ub) < 1e-6 && fabs(va - vb) < 1e-6); /* the same pixel */
        assert_int_equal(tvo_lens_remap(&b, &a, &y), 1);
        assert_true(fabs(y.x - x.x) < 1e-9 && fabs(y.y - x.y) < 1e-9);
    }
    {
        tvo_point2d x = {NAN, 0.0};
        assert_int_equal(tvo_lens_remap(&a, &b, &x), 0);
        assert_true(isnan(x.x));
    }
}
#endif

/* The VO's switch: on by default where the build has it (off in the small preset), 0 and 1 accepted (1
 * costs the lens blocks' scratch), anything else refused; a build without the refinement refuses 1 as
 * unsupported. */
static void test_vo_config(void **state)
{
    const tvo_camera cam = tvo_camera_make_pinhole(320, 240, 250.0, 250.0, 159.5, 119.5);
    tvo_vo_config cfg;
    size_t off, on;
    (void)state;
    tvo_vo_config_default(&cfg, &cam);
    assert_int_equal(cfg.lens_refine, TVO_WITH_LENS); /* on where the build has it */
    assert_int_equal(tvo_vo_config_preset(&cfg, &cam, TVO_VO_PRESET_SMALL), TVO_OK);
    assert_int_equal(cfg.lens_refine, 0); /* the microcontroller's preset: off */
    tvo_vo_config_default(&cfg, &cam);
    cfg.lens_refine = 0;
    off = tvo_vo_required_size(&cfg);
    assert_true(off > 0);
    cfg.lens_refine = 2;
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
    cfg.lens_refine = -1;
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
    cfg.lens_refine = 1;
    on = tvo_vo_required_size(&cfg);
    if (TVO_WITH_LENS) {
        void *mem;
        tvo_vo *vo = NULL;
        assert_true(on >= off);
        mem = malloc(on);
        assert_non_null(mem);
        assert_int_equal(tvo_vo_init(&vo, &cfg, mem, on), TVO_OK);
        free(mem);
    } else {
        uint8_t mem[16];
        tvo_vo *vo = NULL;
        assert_int_equal(on, 0);
        assert_int_equal(tvo_vo_init(&vo, &cfg, mem, sizeof(mem)), TVO_ERR_UNSUPPORTED);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
#if TVO_WITH_LENS
        cmocka_unit_test(test_window_recovers_change),
        cmocka_unit_test(test_window_noise),
        cmocka_unit_test(test_window_refuses),
        cmocka_unit_test(test_decide_adopts),
        cmocka_unit_test(test_decide_drift_refused),
        cmocka_unit_test(test_decide_close_halves),
        cmocka_unit_test(test_decide_small_large),
        cmocka_unit_test(test_blocks_ring),
        cmocka_unit_test(test_remap),
#endif
        cmocka_unit_test(test_vo_config),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
