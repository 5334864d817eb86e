/* SPDX-License-Identifier: Apache-2.0 */
/* LK's window store (tvo_lk_track_store): tracking points on over several frames with the store gives
 * the same bits as without it, whatever the configuration; a stored window is used only when its key
 * matches (a moved point, another window side, another pyramid tag, a forgotten entry or a point
 * without an entry build their windows again); bad store arguments are refused. */
#include <math.h>
#include <string.h>

#include "tvo_test.h"
#include "tinyvo/lk.h"

#define W 200
#define H 150
#define NWAVES 6
#define FRAMES 6
#define NPTS 48
#define STORE_BYTES (NPTS * 12000 + 64)

/* Smooth texture with some fine detail, content translated by (dx, dy), grey levels times gain. */
static void render(uint8_t *img, double dx, double dy, double gain)
{
    static const double fx[NWAVES] = {0.21, -0.13, 0.37, 0.05, -0.29, 0.61};
    static const double fy[NWAVES] = {0.07, 0.31, -0.17, -0.41, 0.23, 0.49};
    static const double ph[NWAVES] = {0.3, 1.1, 2.0, 4.2, 5.1, 0.7};
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            double v = 0.0;
            for (int k = 0; k < NWAVES; ++k)
                v += 20.0 * sin(fx[k] * (x - dx) + fy[k] * (y - dy) + ph[k]);
            v = (128.0 + v) * gain;
            img[y * W + x] = (uint8_t)(v < 0.0 ? 0.0 : (v > 255.0 ? 255.0 : floor(v + 0.5)));
        }
}

typedef struct fixture {
    uint8_t img[FRAMES][W * H];
    uint8_t pmem[FRAMES][1 << 16];
    tvo_pyramid pyr[FRAMES];
    uint8_t scratch[1 << 15];
    uint8_t store[STORE_BYTES];
} fixture;

static fixture F;

/* Frame k moves by (1.3 k, -0.7 k) px, frames 2 and 3 are the same picture (no motion), frame 4 is
 * darker. */
static void build_frames(int levels)
{
    for (int k = 0; k < FRAMES; ++k) {
        const double m = k >= 3 ? k - 1 : k;
        tvo_image im = tvo_image_make(W, H, W, F.img[k]);
        render(F.img[k], 1.3 * m, -0.7 * m, k == 4 ? 0.8 : 1.0);
        assert_int_equal(tvo_pyramid_init(&F.pyr[k], W, H, levels, F.pmem[k], sizeof(F.pmem[k])), TVO_OK);
        assert_int_equal(tvo_pyramid_build(&F.pyr[k], &im), TVO_OK);
    }
}

/* Points on a grid, some near or over the borders (gathered windows, points lost on the way). */
static void start_points(tvo_point2f *p)
{
    for (int i = 0; i < NPTS; ++i) {
        p[i].x = (float)(-3 + (i % 8) * 29) + 0.37f * (float)(i % 3);
        p[i].y = (float)(-2 + (i / 8) * 28) + 0.61f * (float)(i % 5);
    }
}

/* Track the points through the frames with and without the store (one entry per point, pred[i] set on
 * every third point), each call's outputs the next call's inputs; all outputs must be the same bits. */
static void track_both(const tvo_lk_config *cfg, int use_pred)
{
    tvo_point2f a[NPTS], b[NPTS], na[NPTS], nb[NPTS];
    uint8_t sa[NPTS], sb[NPTS], pred[NPTS];
    float ea[NPTS], eb[NPTS];
    tvo_lk_store_use use;
    int32_t tracked = 0;
    assert_true(tvo_lk_store_size(cfg, NPTS) <= sizeof(F.store));
    assert_true(tvo_lk_scratch_size(cfg) <= sizeof(F.scratch));
    assert_int_equal(tvo_lk_store_init(cfg, NPTS, F.store, sizeof(F.store)), TVO_OK);
    start_points(a);
    memcpy(b, a, sizeof(a));
    for (int i = 0; i < NPTS; ++i)
        pred[i] = (uint8_t)(use_pred && i % 3 == 0);
    use.store = F.store;
    use.slot = NULL;
    for (int k = 0; k + 1 < FRAMES; ++k) {
        for (int i = 0; i < NPTS; ++i) { /* a guess for use_initial_flow: the true motion, roughly */
            na[i].x = nb[i].x = a[i].x + 1.2f;
            na[i].y = nb[i].y = a[i].y - 0.6f;
        }
        use.prev_gen = (uint32_t)k + 1u;
        use.next_gen = (uint32_t)k + 2u;
        assert_int_equal(tvo_lk_track_pred(cfg, &F.pyr[k], &F.pyr[k + 1], a, na, pred, sa, ea, NPTS,
                                           F.scratch, sizeof(F.scratch)),
                         TVO_OK);
        assert_int_equal(tvo_lk_track_store(cfg, &F.pyr[k], &F.pyr[k + 1], b, nb, pred, sb, eb, NPTS, &use,
                                            F.scratch, sizeof(F.scratch)),
                         TVO_OK);
        assert_memory_equal(na, nb, sizeof(na));
        assert_memory_equal(sa, sb, sizeof(sa));
        assert_memory_equal(ea, eb, sizeof(ea));
        for (int i = 0; i < NPTS; ++i)
            tracked += sa[i];
        /* the tracked points go on from where they were found, the lost ones from where they started */
        for (int i = 0; i < NPTS; ++i)
            if (sa[i]) {
                a[i] = na[i];
                b[i] = nb[i];
            }
    }
    assert_true(tracked > NPTS * (FRAMES - 1) / 3); /* the test tracks something */
}

static void test_same_bits_over_frames(void **state)
{
    tvo_lk_config cfg;
    (void)state;
    build_frames(4);
    tvo_lk_config_default(&cfg);
    cfg.fb_check = 1; /* the VO's default: the full way back */
    track_both(&cfg, 0);
    cfg.max_level = 2;
    track_both(&cfg, 0);
    cfg.force_portable = 1;
    track_both(&cfg, 0);
    cfg.force_portable = 0;
    cfg.use_initial_flow = 1;
    track_both(&cfg, 0);
    cfg.fb_levels = 2; /* the short way back: windows on levels 1..0 only */
    track_both(&cfg, 0);
    cfg.fb_levels = 0;
    cfg.pred_levels = 2; /* the map prediction's configuration: two windows, two level counts */
    cfg.pred_win_size = 11;
    track_both(&cfg, 1);
    cfg.pred_fb_levels = 1;
    track_both(&cfg, 1);
    cfg.win_size = 7; /* portable kernels */
    cfg.pred_win_size = 9;
    track_both(&cfg, 1);
    tvo_lk_config_default(&cfg); /* no fb check: nothing is stored, nothing changes */
    track_both(&cfg, 0);
}

/* One call that fills the store from frame 1 to 2 (tags 1, 2); then frame 2's pixels change while its
 * tag stays (what a caller must not do): a call that uses a stored window shows it, as its result then
 * differs from the one without the store. */
static void fill_and_spoil(const tvo_lk_config *cfg, tvo_point2f *p1)
{
    tvo_point2f p0[NPTS];
    uint8_t st[NPTS];
    tvo_lk_store_use use;
    tvo_image im = tvo_image_make(W, H, W, F.img[2]);
    build_frames(4);
    start_points(p0);
    assert_int_equal(tvo_lk_store_init(cfg, NPTS, F.store, sizeof(F.store)), TVO_OK);
    use.store = F.store;
    use.slot = NULL;
    use.prev_gen = 1;
    use.next_gen = 2;
    assert_int_equal(tvo_lk_track_store(cfg, &F.pyr[1], &F.pyr[2], p0, p1, NULL, st, NULL, NPTS, &use,
                                        F.scratch, sizeof(F.scratch)),
                     TVO_OK);
    for (int i = 0; i < NPTS; ++i) /* the lost points go on from where they started */
        if (!st[i])
            p1[i] = p0[i];
    render(F.img[2], 2.6, -1.4, 0.7); /* frame 2 darker: other windows */
    assert_int_equal(tvo_pyramid_build(&F.pyr[2], &im), TVO_OK);
}

/* Frame 2 -> 3 from p with the store as `use` and cfg2, against the same without the store: 1 when all
 * outputs are the same bits. */
static int same_as_without(const tvo_lk_config *cfg2, const tvo_point2f *p, const tvo_lk_store_use *use)
{
    tvo_point2f na[NPTS], nb[NPTS];
    uint8_t sa[NPTS], sb[NPTS];
    float ea[NPTS], eb[NPTS];
    assert_int_equal(tvo_lk_track_pred(cfg2, &F.pyr[2], &F.pyr[3], p, na, NULL, sa, ea, NPTS, F.scratch,
                                       sizeof(F.scratch)),
                     TVO_OK);
    assert_int_equal(tvo_lk_track_store(cfg2, &F.pyr[2], &F.pyr[3], p, nb, NULL, sb, eb, NPTS, use, F.scratch,
                                        sizeof(F.scratch)),
                     TVO_OK);
    return memcmp(na, nb, sizeof(na)) == 0 && memcmp(sa, sb, sizeof(sa)) == 0 &&
            memcmp(ea, eb, sizeof(ea)) == 0;
}

static void test_mismatched_entries_not_used(void **state)
{
    tvo_lk_config cfg, cfg15;
    tvo_lk_store_use use;
    tvo_point2f p1[NPTS], moved[NPTS];
    int32_t slot[NPTS];
    (void)state;
    tvo_lk_config_default(&cfg);
    cfg.fb_check = 1;
    use.store = F.store;
    use.slot = NULL;
    use.prev_gen = 2;
    use.next_gen = 3;

    /* the control: matching entries are used (the spoilt frame shows) */
    fill_and_spoil(&cfg, p1);
    assert_false(same_as_without(&cfg, p1, &use));

    /* a moved point (by a quarter pixel) */
    fill_and_spoil(&cfg, p1);
    for (int i = 0; i < NPTS; ++i) {
        moved[i].x = p1[i].x + 0.25f;
        moved[i].y = p1[i].y;
    }
    assert_true(same_as_without(&cfg, moved, &use));
    /* moved by one bit of x, the points keep their windows' corners and weights (the key): their windows
       are the same integers, and the entries are used */
    fill_and_spoil(&cfg, p1);
    for (int i = 0; i < NPTS; ++i)
        moved[i] = (tvo_point2f){nextafterf(p1[i].x, 1e9f), p1[i].y};
    assert_false(same_as_without(&cfg, moved, &use));

    /* another window side (the same store layout: 21 is the larger side of both) */
    fill_and_spoil(&cfg, p1);
    cfg15 = cfg;
    cfg15.win_size = 15;
    cfg15.pred_win_size = 21;
    assert_true(same_as_without(&cfg15, p1, &use));

    /* another pyramid tag */
    fill_and_spoil(&cfg, p1);
    use.prev_gen = 7;
    assert_true(same_as_without(&cfg, p1, &use));
    use.prev_gen = 2;

    /* forgotten entries, and points without an entry */
    fill_and_spoil(&cfg, p1);
    for (int i = 0; i < NPTS; ++i)
        assert_int_equal(tvo_lk_store_forget(F.store, i), TVO_OK);
    assert_true(same_as_without(&cfg, p1, &use));
    fill_and_spoil(&cfg, p1);
    for (int i = 0; i < NPTS; ++i)
        slot[i] = -1;
    use.slot = slot;
    assert_true(same_as_without(&cfg, p1, &use));

    /* entries of other points (slots shifted by one) */
    fill_and_spoil(&cfg, p1);
    for (int i = 0; i < NPTS; ++i)
        slot[i] = (i + 1) % NPTS;
    assert_true(same_as_without(&cfg, p1, &use));

    /* the right entries through a slot table: used again */
    fill_and_spoil(&cfg, p1);
    for (int i = 0; i < NPTS; ++i)
        slot[i] = i;
    assert_false(same_as_without(&cfg, p1, &use));
}

static void test_store_bad_inputs(void **state)
{
    tvo_lk_config cfg, other;
    tvo_lk_store_use use;
    tvo_point2f p0[NPTS], p1[NPTS];
    uint8_t st[NPTS];
    int32_t slot[NPTS];
    (void)state;
    build_frames(4);
    start_points(p0);
    tvo_lk_config_default(&cfg);
    cfg.fb_check = 1;
    /* sizes: (levels) x (64 + 6 w^2 rounded up to 16) */
    assert_int_equal(tvo_lk_store_point_size(&cfg), 4u * (64u + 2656u));
    assert_true(tvo_lk_store_size(&cfg, NPTS) >= NPTS * tvo_lk_store_point_size(&cfg));
    assert_int_equal(tvo_lk_store_size(&cfg, 0), 0u);
    assert_int_equal(tvo_lk_store_point_size(NULL), 0u);
    other = cfg;
    other.win_size = 4;
    assert_int_equal(tvo_lk_store_point_size(&other), 0u);
    assert_int_equal(tvo_lk_store_init(&other, 4, F.store, sizeof(F.store)), TVO_ERR_ARG);
    assert_int_equal(tvo_lk_store_init(NULL, 4, F.store, sizeof(F.store)), TVO_ERR_NULL);
    assert_int_equal(tvo_lk_store_init(&cfg, 4, NULL, sizeof(F.store)), TVO_ERR_NULL);
    assert_int_equal(tvo_lk_store_init(&cfg, 0, F.store, sizeof(F.store)), TVO_ERR_SIZE);
    assert_int_equal(tvo_lk_store_init(&cfg, 4, F.store, tvo_lk_store_size(&cfg, 4) - 1), TVO_ERR_NO_MEMORY);
    /* any alignment of the memory */
    assert_int_equal(tvo_lk_store_init(&cfg, 4, F.store + 3, tvo_lk_store_size(&cfg, 4)), TVO_OK);
    assert_int_equal(tvo_lk_store_forget(F.store + 3, 3), TVO_OK);
    assert_int_equal(tvo_lk_store_forget(F.store + 3, 4), TVO_ERR_ARG);
    assert_int_equal(tvo_lk_store_forget(F.store + 3, -1), TVO_ERR_ARG);
    assert_int_equal(tvo_lk_store_forget(NULL, 0), TVO_ERR_NULL);

    use.store = F.store + 3;
    use.slot = NULL;
    use.prev_gen = 1;
    use.next_gen = 2;
    /* slot NULL: n <= slots */
    assert_int_equal(tvo_lk_track_store(&cfg, &F.pyr[0], &F.pyr[1], p0, p1, NULL, st, NULL, 5, &use,
                                        F.scratch, sizeof(F.scratch)),
                     TVO_ERR_SIZE);
    assert_int_equal(st[0], TVO_LK_LOST);
    assert_int_equal(tvo_lk_track_store(&cfg, &F.pyr[0], &F.pyr[1], p0, p1, NULL, st, NULL, 4, &use,
                                        F.scratch, sizeof(F.scratch)),
                     TVO_OK);
    /* slots outside -1..slots-1 */
    for (int i = 0; i < NPTS; ++i)
        slot[i] = i % 4;
    use.slot = slot;
    assert_int_equal(tvo_lk_track_store(&cfg, &F.pyr[0], &F.pyr[1], p0, p1, NULL, st, NULL, NPTS, &use,
                                        F.scratch, sizeof(F.scratch)),
                     TVO_OK);
    slot[7] = 4;
    assert_int_equal(tvo_lk_track_store(&cfg, &F.pyr[0], &F.pyr[1], p0, p1, NULL, st, NULL, NPTS, &use,
                                        F.scratch, sizeof(F.scratch)),
                     TVO_ERR_ARG);
    slot[7] = -2;
    assert_int_equal(tvo_lk_track_store(&cfg, &F.pyr[0], &F.pyr[1], p0, p1, NULL, st, NULL, NPTS, &use,
                                        F.scratch, sizeof(F.scratch)),
                     TVO_ERR_ARG);
    slot[7] = -1;
    /* a store laid out for another configuration: more levels, a larger window */
    other = cfg;
    other.max_level = 2;
    assert_int_equal(tvo_lk_track_store(&other, &F.pyr[0], &F.pyr[1], p0, p1, NULL, st, NULL, NPTS, &use,
                                        F.scratch, sizeof(F.scratch)),
                     TVO_ERR_MISMATCH);
    other = cfg;
    other.pred_win_size = 23;
    assert_int_equal(tvo_lk_track_store(&other, &F.pyr[0], &F.pyr[1], p0, p1, NULL, st, NULL, NPTS, &use,
                                        F.scratch, sizeof(F.scratch)),
                     TVO_ERR_MISMATCH);
    /* no store, memory that is not a store */
    assert_int_equal(tvo_lk_track_store(&cfg, &F.pyr[0], &F.pyr[1], p0, p1, NULL, st, NULL, NPTS, NULL,
                                        F.scratch, sizeof(F.scratch)),
                     TVO_ERR_NULL);
    use.store = NULL;
    assert_int_equal(tvo_lk_track_store(&cfg, &F.pyr[0], &F.pyr[1], p0, p1, NULL, st, NULL, NPTS, &use,
                                        F.scratch, sizeof(F.scratch)),
                     TVO_ERR_NULL);
    memset(F.store, 0, 64);
    use.store = F.store;
    assert_int_equal(tvo_lk_track_store(&cfg, &F.pyr[0], &F.pyr[1], p0, p1, NULL, st, NULL, NPTS, &use,
                                        F.scratch, sizeof(F.scratch)),
                     TVO_ERR_ARG);
    assert_int_equal(tvo_lk_store_forget(F.store, 0), TVO_ERR_ARG);
    /* the other checks come first, as in tvo_lk_track_pred */
    assert_int_equal(tvo_lk_track_store(&cfg, &F.pyr[0], &F.pyr[1], NULL, p1, NULL, st, NULL, NPTS, &use,
                                        F.scratch, sizeof(F.scratch)),
                     TVO_ERR_NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_same_bits_over_frames),
            cmocka_unit_test(test_mismatched_entries_not_used),
            cmocka_unit_test(test_store_bad_inputs),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
