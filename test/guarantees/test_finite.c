/* SPDX-License-Identifier: Apache-2.0 */
/* Guarantee: never a NaN or infinite pose, whatever the input.
 *
 * tvo_vo_process is fed random, black, white, constant, alternating and checkerboard frames and the
 * synthetic corridor, at tiny, extreme-aspect and large sizes (within TVO_MAX_IMAGE_DIM), with huge,
 * zero, equal, backwards and extreme (INT64_MIN .. INT64_MAX) timestamps. Every call must return TVO_OK
 * or a documented error (TVO_ERR_ARG for a non-increasing timestamp), and every result must be finite
 * with a valid state (tvo_g_result_ok: pose, parallax, features, counts); an error result is LOST with
 * the identity pose. The networks (tvo_nn_run, tvo_vo_refine) and the trajectory integration
 * (tvo_traj_step, with scales from denormal to DBL_MAX, negative, NaN and infinite) are checked as well:
 * the trajectory stays finite, refusing (TVO_ERR_NOT_FINITE) and staying unchanged when a step would
 * leave the finite range. */
#include "tvo_guarantee.h"

#include <float.h>

typedef struct runner {
    int32_t w, h;
    void *mem;
    tvo_vo *vo;
    uint8_t *img;
    tvo_g_model model;
    tvo_traj traj;
    int states[TVO_VO_STATE_COUNT];
    int rescues; /* frames whose predicted tracks were rescued (cfg.pred_rescue) */
    int errors;
} runner;

/* Open a VO for w x h; small images need fewer pyramid levels (the default config asks for 4). Returns
 * 0 when no level count is accepted (then the size is below what the VO supports). */
static int runner_open(runner *r, int32_t w, int32_t h)
{
    const tvo_camera cam = tvo_g_camera(w, h, 0.8 * (w > h ? w : h));
    tvo_vo_config cfg;
    size_t need = 0;
    memset(r, 0, sizeof *r);
    r->w = w;
    r->h = h;
    tvo_vo_config_default(&cfg, &cam);
    static int opened = 0;
    const int k = opened++;
    cfg.track_prediction = k & 1; /* every other VO opened with the track prediction on */
    cfg.affine_win_size = TVO_WITH_AFFINE && (k & 2)
            ? 21
            : 0; /* and every other pair with the affine refinement */
    if (k & 4)   /* every other quadruple with the map's predicted tracks, half of those with the retry */
        tvo_g_predicted_tracks(&cfg, (k >> 3) & 1);
    cfg.lens_refine = TVO_WITH_LENS && (k & 16) == 0; /* and the lens refined on the run, 16 in 32 */
    cfg.map_lm_prior = TVO_WITH_AFFINE && k % 3 == 1 ? 1.0 : 0.0; /* and the landmarks' priors, 1 in 3 */
    while (cfg.lk.max_level >= 0 && (need = tvo_vo_required_size(&cfg)) == 0)
        cfg.lk.max_level--;
    if (need == 0)
        return 0;
    r->mem = malloc(need);
    r->img = malloc((size_t)w * (size_t)h);
    assert_non_null(r->mem);
    assert_non_null(r->img);
    assert_int_equal(tvo_vo_init(&r->vo, &cfg, r->mem, need), TVO_OK);
    assert_true(tvo_g_load_model(&r->model, "paper.tvonn"));
    tvo_traj_init(&r->traj, NULL);
    return 1;
}

static void runner_close(runner *r)
{
    free(r->mem);
    free(r->img);
    tvo_g_free_model(&r->model);
}

static void check_pose_finite(const tvo_pose *T)
{
    assert_true(tvo_pose_is_finite(T));
}

/* One frame from r->img; checks the result, runs the networks and integrates. */
static void step(runner *r, int64_t t_ns, tvo_status expect_or_ok)
{
    tvo_image img = tvo_image_make(r->w, r->h, r->w, r->img);
    tvo_vo_result res;
    tvo_pose refined;
    float out[6];
    tvo_status st;
    memset(&res, 0xA5, sizeof res); /* garbage in: the call must overwrite everything */
    st = tvo_vo_process(r->vo, &img, t_ns, &res);
    if (st != TVO_OK) {
        if (st != expect_or_ok)
            fail_msg("%dx%d t=%lld: status %d (%s), expected %d", (int)r->w, (int)r->h, (long long)t_ns,
                     (int)st, tvo_status_str(st), (int)expect_or_ok);
        assert_int_equal(res.state, TVO_VO_LOST);
        r->errors++;
    }
    if (!tvo_g_result_ok(&res))
        fail_msg("%dx%d t=%lld: non-finite or invalid result (state %d)", (int)r->w, (int)r->h,
                 (long long)t_ns, (int)res.state);
    if (res.state == TVO_VO_ROTATION_ONLY)
        assert_true(res.T_prev_cur.t[0] == 0.0 && res.T_prev_cur.t[1] == 0.0 && res.T_prev_cur.t[2] == 0.0);
    r->states[res.state]++;
    r->rescues += res.pred_rescue;
    st = tvo_nn_run(r->model.nn, res.features, out);
    assert_int_equal(st, TVO_OK); /* features are finite, so the networks must run */
    for (int i = 0; i < 6; ++i)
        if ((tvo_nn_output_mask(r->model.nn) >> i) & 1)
            assert_true(isfinite(out[i]));
    assert_int_equal(tvo_vo_refine(r->model.nn, &res, &refined), TVO_OK);
    check_pose_finite(&refined);
    st = tvo_traj_step(&r->traj, &refined, 1.0);
    assert_true(st == TVO_OK || st == TVO_ERR_NOT_FINITE);
    check_pose_finite(&r->traj.T_w_c);
}

static void fill(runner *r, int kind, uint64_t *rng, int k)
{
    const size_t n = (size_t)r->w * (size_t)r->h;
    switch (kind) {
    case 0:
        for (size_t i = 0; i < n; ++i)
            r->img[i] = (uint8_t)(tvo_test_rand(rng) >> 56);
        break; /* noise */
    case 1:
        memset(r->img, 0, n);
        break; /* black */
    case 2:
        memset(r->img, 255, n);
        break; /* saturated */
    case 3:
        memset(r->img, 77, n);
        break; /* constant */
    case 4:
        memset(r->img, (k & 1) ? 255 : 0, n);
        break; /* alternating */
    case 5:    /* checker, flips */
        for (int32_t y = 0; y < r->h; ++y)
            for (int32_t x = 0; x < r->w; ++x)
                r->img[(size_t)y * (size_t)r->w + (size_t)x] = (uint8_t)((((x >> 2) ^ (y >> 2) ^ k) & 1) *
                                                                         255);
        break;
    case 6: /* sparse salt and pepper on black */
        memset(r->img, 0, n);
        for (size_t i = 0; i < n / 50 + 1; ++i)
            r->img[tvo_test_rand(rng) % n] = 255;
        break;
    default: { /* the corridor, moving */
        const double c[3] = {0.0, 0.0, 0.05 * k};
        tvo_g_render(r->img, r->w, r->h, 0.8 * (r->w > r->h ? r->w : r->h), 0.01 * k, c);
    }
    }
}

/* All frame kinds in a row and interleaved, at one size, with well-behaved timestamps. */
static void torture_size(int32_t w, int32_t h, int frames_per_kind)
{
    runner r;
    uint64_t rng = 0x9E3779B97F4A7C15ULL ^ (uint64_t)(w * 131 + h);
    int64_t t = 0;
    if (!runner_open(&r, w, h))
        fail_msg("%dx%d refused by every pyramid depth", (int)w, (int)h);
    for (int kind = 0; kind <= 7; ++kind)
        for (int k = 0; k < frames_per_kind; ++k) {
            fill(&r, kind, &rng, k);
            t += 33000000;
            step(&r, t, TVO_OK);
        }
    for (int k = 0; k < 8 * frames_per_kind; ++k) { /* interleaved: a different kind every frame */
        fill(&r, (int)(tvo_test_rand(&rng) % 8), &rng, k);
        t += 33000000;
        step(&r, t, TVO_OK);
    }
    assert_int_equal(r.errors, 0);
    fprintf(stderr, "%dx%d: ok %d rot-only %d lost %d init %d, predicted tracks rescued %d\n", (int)w, (int)h,
            r.states[0], r.states[2], r.states[3], r.states[1], r.rescues);
    runner_close(&r);
}

static void test_small_sizes(void **state)
{
    (void)state;
    torture_size(32, 24, 3);
    torture_size(48, 48, 3);
    torture_size(64, 16, 3);
}

static void test_usual_sizes(void **state)
{
    (void)state;
    torture_size(320, 240, TVO_G_SLOW_BUILD ? 2 : 4);
    if (!TVO_G_SLOW_BUILD)
        torture_size(752, 480, 2);
}

static void test_extreme_aspect(void **state)
{
    (void)state;
    torture_size(TVO_MAX_IMAGE_DIM, 24, TVO_G_SLOW_BUILD ? 1 : 2);
    torture_size(24, TVO_MAX_IMAGE_DIM, TVO_G_SLOW_BUILD ? 1 : 2);
    if (!TVO_G_SLOW_BUILD)
        torture_size(2048, 1536, 1);
}

/* The smallest images the VO accepts: below them tvo_vo_required_size says 0 (documented refusal). */
static void test_tiny_sizes(void **state)
{
    int accepted = 0;
    (void)state;
    for (int32_t w = 1; w <= 16; w += 3)
        for (int32_t h = 1; h <= 16; h += 5) {
            runner r;
            uint64_t rng = 7;
            if (!runner_open(&r, w, h))
                continue;
            accepted++;
            for (int k = 0; k < 16; ++k) {
                fill(&r, k % 8, &rng, k);
                step(&r, 1000 + k, TVO_OK);
            }
            runner_close(&r);
        }
    fprintf(stderr, "tiny sizes accepted: %d of 24\n", accepted);
}

static void test_timestamps(void **state)
{
    runner r;
    uint64_t rng = 99;
    static const int64_t ts[] = {
            INT64_MIN, INT64_MIN + 1, -1, 0, 1, 2, 1000000000LL, INT64_MAX / 2, INT64_MAX - 1, INT64_MAX,
    };
    (void)state;
    assert_true(runner_open(&r, 160, 120));
    /* strictly increasing but wildly spaced, including a jump of the whole int64 range */
    for (size_t i = 0; i < sizeof ts / sizeof ts[0]; ++i) {
        fill(&r, 7, &rng, (int)i);
        step(&r, ts[i], TVO_OK);
    }
    /* from now on every timestamp is <= INT64_MAX: equal and backwards ones are refused, state LOST */
    for (int k = 0; k < 6; ++k) {
        fill(&r, k % 2 ? 7 : 0, &rng, k);
        step(&r, k % 2 ? INT64_MAX : INT64_MIN + k, TVO_ERR_ARG);
    }
    assert_int_equal(r.errors, 6);
    /* after a reset the sequence may start anywhere again, even in the past */
    tvo_vo_reset(r.vo);
    r.errors = 0;
    for (int k = 0; k < 6; ++k) {
        fill(&r, 7, &rng, k);
        step(&r, -5000 + k, TVO_OK);
    }
    assert_int_equal(r.errors, 0);
    runner_close(&r);
}

static void test_traj_extreme_scales(void **state)
{
    static const double scales[] = {
            0.0, -0.0, 1e-320 /* denormal */, DBL_MIN, 1e-9, 1.0, -1.0, 1e9, 1e150, 1e300, DBL_MAX, -DBL_MAX,
    };
    tvo_traj traj;
    tvo_pose stp = tvo_pose_identity();
    const double rv[3] = {0.3, -0.2, 0.1};
    (void)state;
    tvo_rotvec_to_rot(rv, stp.R);
    stp.t[0] = 0.6;
    stp.t[1] = 0.0;
    stp.t[2] = 0.8;
    tvo_traj_init(&traj, NULL);
    for (int rep = 0; rep < 50; ++rep)
        for (size_t i = 0; i < sizeof scales / sizeof scales[0]; ++i) {
            const tvo_traj before = traj;
            const tvo_status st = tvo_traj_step(&traj, &stp, scales[i]);
            assert_true(st == TVO_OK || st == TVO_ERR_NOT_FINITE);
            if (st != TVO_OK)
                assert_memory_equal(&before, &traj, sizeof traj); /* refused: unchanged */
            check_pose_finite(&traj.T_w_c);
            /* the rotation stays a rotation */
            assert_true(tvo_rot_orthogonality_error(traj.T_w_c.R) < 1e-9);
        }
    /* non-finite scale or step: refused */
    assert_int_equal(tvo_traj_step(&traj, &stp, NAN), TVO_ERR_NOT_FINITE);
    assert_int_equal(tvo_traj_step(&traj, &stp, INFINITY), TVO_ERR_NOT_FINITE);
    assert_int_equal(tvo_traj_step(&traj, &stp, -INFINITY), TVO_ERR_NOT_FINITE);
    stp.t[1] = NAN;
    assert_int_equal(tvo_traj_step(&traj, &stp, 1.0), TVO_ERR_NOT_FINITE);
    stp.t[1] = 0.0;
    stp.R[4] = INFINITY;
    assert_int_equal(tvo_traj_step(&traj, &stp, 1.0), TVO_ERR_NOT_FINITE);
    check_pose_finite(&traj.T_w_c);
}

/* tvo_vo_refine / tvo_nn_run with non-finite or huge features: an error and a finite raw step, never NaN. */
static void test_refine_bad_features(void **state)
{
    tvo_g_model m;
    tvo_vo_result res;
    tvo_pose step_out;
    float out[6];
    static const float bad[] = {NAN, INFINITY, -INFINITY};
    static const float huge[] = {FLT_MAX, -FLT_MAX, 1e30f, -1e30f, 1e-45f};
    (void)state;
    assert_true(tvo_g_load_model(&m, "paper.tvonn"));
    memset(&res, 0, sizeof res);
    res.state = TVO_VO_OK;
    res.T_prev_cur = tvo_pose_identity();
    for (int f = 0; f < TVO_FEAT_COUNT; ++f) {
        for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
            for (int j = 0; j < TVO_FEAT_COUNT; ++j)
                res.features[j] = 0.1f;
            res.features[f] = bad[i];
            assert_int_equal(tvo_vo_refine(m.nn, &res, &step_out), tvo_nn_run(m.nn, res.features, out));
            check_pose_finite(&step_out);
        }
        for (size_t i = 0; i < sizeof huge / sizeof huge[0]; ++i) {
            tvo_status st;
            for (int j = 0; j < TVO_FEAT_COUNT; ++j)
                res.features[j] = 0.1f;
            res.features[f] = huge[i];
            st = tvo_vo_refine(m.nn, &res, &step_out);
            assert_true(st == TVO_OK || st == TVO_ERR_NOT_FINITE);
            check_pose_finite(&step_out);
        }
    }
    tvo_g_free_model(&m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_small_sizes),         cmocka_unit_test(test_usual_sizes),
            cmocka_unit_test(test_extreme_aspect),      cmocka_unit_test(test_tiny_sizes),
            cmocka_unit_test(test_timestamps),          cmocka_unit_test(test_traj_extreme_scales),
            cmocka_unit_test(test_refine_bad_features),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
