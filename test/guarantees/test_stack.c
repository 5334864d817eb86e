/* SPDX-License-Identifier: Apache-2.0 */
/* Guarantee: bounded stack in the per-frame path (figures and bound in docs/limits.md).
 *
 * The per-frame work (tvo_vo_process, tvo_nn_run, tvo_vo_refine, tvo_traj_step) runs in a pthread whose
 * stack this test allocates and paints with a pattern; afterwards the lowest overwritten byte gives the
 * real high-water mark. A thread that only returns gives the baseline (glibc keeps the thread
 * descriptor and TLS at the top of a user-supplied stack); the figure reported and bounded is the
 * high-water mark minus that baseline. Frames: the scripted synthetic sequence (all VO states) at
 * 320x240 and 752x480, hostile frames at the widest size, and the shared EuRoC keyframes when present.
 *
 * Bound: TVO_STACK_BOUND bytes (below). tools/stack-report.sh gives the per-function frames from
 * -fstack-usage for comparison. */
#define _POSIX_C_SOURCE 200809L /* pthread_attr_setstack, posix_memalign */
#include "tvo_guarantee.h"

#include <pthread.h>

#include "tvo_guarantee_euroc.h"

/* The bound is for optimised builds without sanitizers (docs/limits.md). ASan puts red zones around
 * every stack object and -O0 keeps every temporary in memory: there the figure is reported and held to
 * a looser bound, so that the test still catches a runaway (recursion, a large local array). */
#if defined(__SANITIZE_ADDRESS__) || !defined(__OPTIMIZE__)
#define TVO_STACK_BOUND (256 * 1024)
#else
#define TVO_STACK_BOUND (32 * 1024)
#endif
#define STACK_SIZE (1024 * 1024)
#define PATTERN 0xA5u

typedef struct job {
    const tvo_camera *cam;
    const uint8_t *frames; /* n frames, decoded beforehand */
    const int64_t *t;
    int n;
    void *vo_mem;
    const tvo_g_model *model;
    int ok_states;
    int rescues; /* frames whose predicted tracks were rescued (cfg.pred_rescue) */
    int failures;
} job;

/* the default configuration, with fewer pyramid levels when the image is too small for 4 */
static size_t config_for(const tvo_camera *cam, tvo_vo_config *cfg)
{
    size_t need = 0;
    tvo_vo_config_default(cfg, cam);
    /* the affine refinement's path too (called after LK, not inside it) */
    cfg->affine_win_size = TVO_WITH_AFFINE ? 21 : 0;
    tvo_g_predicted_tracks(cfg, 1);   /* and the map's predicted tracks (the balanced preset's LK) */
    cfg->lens_refine = TVO_WITH_LENS; /* and the lens refined on the run (its blocks at keyframes) */
    cfg->map_lm_prior = TVO_WITH_AFFINE ? 1.0 : 0.0; /* and the landmarks' priors (at keyframes) */
    while (cfg->lk.max_level >= 0 && (need = tvo_vo_required_size(cfg)) == 0)
        cfg->lk.max_level--;
    return need;
}

static void *idle_thread(void *arg)
{
    return arg;
}

static void *work_thread(void *arg)
{
    job *j = (job *)arg;
    tvo_vo_config cfg;
    tvo_vo *vo = NULL;
    tvo_traj traj;
    size_t need;
    const size_t fsz = (size_t)j->cam->width * (size_t)j->cam->height;
    need = config_for(j->cam, &cfg);
    if (tvo_vo_init(&vo, &cfg, j->vo_mem, need) != TVO_OK) {
        j->failures++;
        return NULL;
    }
    tvo_traj_init(&traj, NULL);
    for (int k = 0; k < j->n; ++k) {
        tvo_image img = tvo_image_make(j->cam->width, j->cam->height, j->cam->width,
                                       (uint8_t *)(uintptr_t)(j->frames + (size_t)k * fsz));
        tvo_vo_result res;
        float out[6];
        tvo_pose stp;
        if (tvo_vo_process(vo, &img, j->t[k], &res) != TVO_OK) {
            j->failures++;
            continue;
        }
        j->ok_states += res.state == TVO_VO_OK;
        j->rescues += res.pred_rescue;
        (void)tvo_nn_run(j->model->nn, res.features, out);
        if (tvo_vo_refine(j->model->nn, &res, &stp) == TVO_OK)
            (void)tvo_traj_step(&traj, &stp, 1.0);
    }
    return NULL;
}

/* Runs fn(arg) on a painted stack; returns the bytes touched. */
static size_t painted_run(void *(*fn)(void *), void *arg)
{
    pthread_attr_t attr;
    pthread_t th;
    uint8_t *stack = NULL;
    size_t i;
    assert_int_equal(posix_memalign((void **)&stack, 4096, STACK_SIZE), 0);
    memset(stack, PATTERN, STACK_SIZE);
    assert_int_equal(pthread_attr_init(&attr), 0);
    assert_int_equal(pthread_attr_setstack(&attr, stack, STACK_SIZE), 0);
    assert_int_equal(pthread_create(&th, &attr, fn, arg), 0);
    assert_int_equal(pthread_join(th, NULL), 0);
    pthread_attr_destroy(&attr);
    for (i = 0; i < STACK_SIZE && stack[i] == PATTERN; ++i) {
    }
    free(stack);
    assert_true(i > 4096); /* the run never came near the end of the test stack */
    return STACK_SIZE - i;
}

static size_t measure(const tvo_camera *cam, const uint8_t *frames, const int64_t *t, int n, const char *name)
{
    tvo_vo_config cfg;
    tvo_g_model m;
    job j;
    size_t base, used;
    memset(&j, 0, sizeof j);
    assert_true(tvo_g_load_model(&m, "paper.tvonn"));
    j.cam = cam;
    j.frames = frames;
    j.t = t;
    j.n = n;
    j.model = &m;
    j.vo_mem = malloc(config_for(cam, &cfg));
    assert_non_null(j.vo_mem);
    base = painted_run(idle_thread, NULL);
    used = painted_run(work_thread, &j);
    assert_int_equal(j.failures, 0);
    fprintf(stderr,
            "%s (%dx%d, %d frames, %d OK, %d rescued): stack high-water %zu bytes (thread baseline %zu), "
            "bound %d\n",
            name, (int)cam->width, (int)cam->height, n, j.ok_states, j.rescues, used - base, base,
            TVO_STACK_BOUND);
    if (used - base > (size_t)TVO_STACK_BOUND)
        fail_msg("%s: per-frame path used %zu bytes of stack, bound %d", name, used - base, TVO_STACK_BOUND);
    free(j.vo_mem);
    tvo_g_free_model(&m);
    return used - base;
}

static void synthetic(int32_t w, int32_t h, double focal)
{
    const tvo_camera cam = tvo_g_camera(w, h, focal);
    const size_t fsz = (size_t)w * (size_t)h;
    uint8_t *frames = malloc((size_t)TVO_G_SEQ_FRAMES * fsz);
    int64_t t[TVO_G_SEQ_FRAMES];
    uint64_t rng = 1;
    char name[64];
    assert_non_null(frames);
    for (int k = 0; k < TVO_G_SEQ_FRAMES; ++k) {
        tvo_g_seq_frame(k, frames + (size_t)k * fsz, w, h, focal, &rng);
        t[k] = (int64_t)(k + 1) * 50000000LL;
    }
    snprintf(name, sizeof name, "synthetic");
    (void)measure(&cam, frames, t, TVO_G_SEQ_FRAMES, name);
    free(frames);
}

static void test_synthetic_320(void **state)
{
    (void)state;
    synthetic(320, 240, 250.0);
}

static void test_synthetic_752(void **state)
{
    (void)state;
    if (TVO_G_SLOW_BUILD) {
        TVO_SKIP("slow build (sanitizer, -O0 or qemu): the 320x240 and widest runs measure");
        return;
    }
    synthetic(752, 480, 460.0);
}

static void test_widest(void **state)
{
    (void)state;
    synthetic(TVO_MAX_IMAGE_DIM, 32, 4000.0);
}

static void test_euroc_keyframes(void **state)
{
    tvo_g_frames f;
    (void)state;
    if (TVO_G_SLOW_BUILD) {
        TVO_SKIP("slow build (sanitizer, -O0 or qemu): the 320x240 and widest runs measure");
        return;
    }
    if (!tvo_g_frames_load(&f, "V1_01_easy_keyframes", 30))
        return;
    (void)measure(f.cam, f.pix, f.t, (int)f.n, "V1_01_easy_keyframes");
    tvo_g_frames_free(&f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_synthetic_320),
            cmocka_unit_test(test_synthetic_752),
            cmocka_unit_test(test_widest),
            cmocka_unit_test(test_euroc_keyframes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
