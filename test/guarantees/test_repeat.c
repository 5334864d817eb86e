/* SPDX-License-Identifier: Apache-2.0 */
/* Guarantee: identical output for identical input, within one build.
 *
 * The same frames go through two fresh VO objects whose memory blocks were filled with different garbage
 * (0x00 and 0xFF) and start at different alignments, and through the same object again after
 * tvo_vo_reset; every result (state, counts, flags, pose, parallax, features: the whole struct, compared
 * byte for byte, no clock so the timings are zero) and the networks' outputs and integrated trajectory
 * must be bit-identical. This catches reads of uninitialised memory, dependence on addresses or
 * alignment, and state that tvo_vo_reset does not clear. (test/unit/test_determinism.c compares digests
 * across targets; this test needs no checked-in value.) Inputs: the scripted synthetic sequence with
 * hostile frames, and the shared EuRoC keyframes when present. */
#include "tvo_guarantee.h"

#include "tvo_guarantee_euroc.h"

typedef struct outcome {
    tvo_status st;
    tvo_vo_result res;
    float nn_out[6];
    tvo_status nn_st;
    tvo_pose traj;
} outcome;

/* Runs n frames through a VO laid out at mem + offset (block filled with `fill` first). */
static void run(const tvo_camera *cam, const uint8_t *frames, const int64_t *t, int n, int fill,
                size_t offset, const tvo_g_model *m, outcome *out, int reset_and_repeat)
{
    tvo_vo_config cfg;
    size_t need;
    uint8_t *block;
    tvo_vo *vo = NULL;
    tvo_traj traj;
    const size_t fsz = (size_t)cam->width * (size_t)cam->height;
    tvo_vo_config_default(&cfg, cam);
    /* its templates live in the block too: garbage there must not matter */
    cfg.affine_win_size = TVO_WITH_AFFINE ? 21 : 0;
    tvo_g_predicted_tracks(&cfg, 0); /* and the map's predicted tracks (the balanced preset's LK) */
    cfg.map_lm_prior = TVO_WITH_AFFINE ? 1.0 : 0.0; /* and the landmarks' priors: garbage there too */
    need = tvo_vo_required_size(&cfg);
    assert_true(need > 0);
    block = malloc(need + 64);
    assert_non_null(block);
    memset(block, fill, need + 64);
    assert_int_equal(tvo_vo_init(&vo, &cfg, block + offset, need), TVO_OK);
    for (int pass = 0; pass <= reset_and_repeat; ++pass) {
        if (pass > 0)
            tvo_vo_reset(vo);
        tvo_traj_init(&traj, NULL);
        for (int k = 0; k < n; ++k) {
            outcome *o = &out[k];
            tvo_image img = tvo_image_make(cam->width, cam->height, cam->width,
                                           (uint8_t *)(uintptr_t)(frames + (size_t)k * fsz));
            tvo_pose stp;
            memset(o, 0, sizeof *o);
            /* after a reset, time continues (timestamps must increase only while tracking) */
            o->st = tvo_vo_process(vo, &img, t[k], &o->res);
            o->nn_st = tvo_nn_run(m->nn, o->res.features, o->nn_out);
            if (tvo_vo_refine(m->nn, &o->res, &stp) == TVO_OK)
                (void)tvo_traj_step(&traj, &stp, 1.0);
            o->traj = traj.T_w_c;
        }
    }
    free(block);
}

static void compare(const outcome *a, const outcome *b, int n, const char *what)
{
    for (int k = 0; k < n; ++k)
        if (memcmp(&a[k], &b[k], sizeof a[k]) != 0)
            fail_msg("%s: frame %d differs (state %d vs %d, tracked %d vs %d)", what, k, (int)a[k].res.state,
                     (int)b[k].res.state, (int)a[k].res.tracked, (int)b[k].res.tracked);
}

static void check_repeatable(const tvo_camera *cam, const uint8_t *frames, const int64_t *t, int n,
                             const char *name)
{
    tvo_g_model m;
    outcome *a = calloc((size_t)n, sizeof *a), *b = calloc((size_t)n, sizeof *b),
            *c = calloc((size_t)n, sizeof *c);
    int ok = 0;
    assert_true(a != NULL && b != NULL && c != NULL);
    assert_true(tvo_g_load_model(&m, "paper.tvonn"));
    run(cam, frames, t, n, 0x00, 0, &m, a, 0);
    run(cam, frames, t, n, 0xFF, 8, &m, b, 0);
    run(cam, frames, t, n, 0x5A, 3, &m, c, 1); /* second pass after tvo_vo_reset */
    compare(a, b, n, "fresh object, other garbage and alignment");
    compare(a, c, n, "same object after tvo_vo_reset");
    for (int k = 0; k < n; ++k)
        ok += a[k].res.state == TVO_VO_OK;
    fprintf(stderr, "%s: %d frames bit-identical in 3 runs (%d with state OK)\n", name, n, ok);
    assert_true(ok > 0); /* the comparison covered real pose estimates */
    tvo_g_free_model(&m);
    free(a);
    free(b);
    free(c);
}

static void test_synthetic(void **state)
{
    /* 320x240; half that in sanitizer / -O0 builds, which run 10-50x slower */
    const int32_t w = TVO_G_SLOW_BUILD ? 160 : 320, h = TVO_G_SLOW_BUILD ? 120 : 240;
    const double focal = TVO_G_SLOW_BUILD ? 125.0 : 250.0;
    const tvo_camera cam = tvo_g_camera(w, h, focal);
    uint8_t *frames = malloc((size_t)TVO_G_SEQ_FRAMES * (size_t)w * (size_t)h);
    int64_t t[TVO_G_SEQ_FRAMES];
    uint64_t rng = 4242;
    (void)state;
    assert_non_null(frames);
    for (int k = 0; k < TVO_G_SEQ_FRAMES; ++k) {
        tvo_g_seq_frame(k, frames + (size_t)k * (size_t)w * (size_t)h, w, h, focal, &rng);
        t[k] = 5000000000LL + (int64_t)k * 50000000LL;
    }
    check_repeatable(&cam, frames, t, TVO_G_SEQ_FRAMES, "synthetic");
    free(frames);
}

static void test_euroc_keyframes(void **state)
{
    tvo_g_frames f;
    (void)state;
    if (!tvo_g_frames_load(&f, "V1_01_easy_keyframes", TVO_G_SLOW_BUILD ? 8 : 30))
        return;
    check_repeatable(f.cam, f.pix, f.t, (int)f.n, "V1_01_easy_keyframes");
    tvo_g_frames_free(&f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_synthetic),
            cmocka_unit_test(test_euroc_keyframes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
