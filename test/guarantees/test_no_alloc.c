/* SPDX-License-Identifier: Apache-2.0 */
/* Guarantee: no heap allocation after init in the per-frame path.
 *
 * This executable defines malloc, calloc, realloc, free and the aligned allocators itself; they forward
 * to glibc's __libc_* entry points and count calls while `g_counting` is set. Because the symbols are
 * defined in the executable, they also replace the allocator for calls made inside libc (qsort,
 * stdio, ...) and every shared library, so an allocation hidden in a libc call is counted too.
 *
 * Counted: tvo_vo_process over the scripted synthetic sequence of tvo_guarantee.h (all VO states, re-
 * detection, hostile frames), over the EuRoC keyframes and head frames of the data folder (TVO_DATA_DIR)
 * when present (decoded BEFORE counting starts), tvo_vo_reset, tvo_vo_refine, tvo_nn_run of the paper model
 * and tvo_traj_step. Everything that may allocate (VO/model memory, PNG decoding, cmocka) happens
 * outside the counting windows. Not built with TVO_SANITIZE (ASan owns the allocator there). */
#include "tvo_guarantee.h"

#include "tvo_guarantee_euroc.h"

extern void *__libc_malloc(size_t size);
extern void *__libc_calloc(size_t n, size_t size);
extern void *__libc_realloc(void *p, size_t size);
extern void *__libc_memalign(size_t align, size_t size);
extern void __libc_free(void *p);

static volatile int g_counting;
static volatile long g_allocs, g_frees;

void *malloc(size_t size)
{
    if (g_counting)
        g_allocs++;
    return __libc_malloc(size);
}
void *calloc(size_t n, size_t size)
{
    if (g_counting)
        g_allocs++;
    return __libc_calloc(n, size);
}
void *realloc(void *p, size_t size)
{
    if (g_counting)
        g_allocs++;
    return __libc_realloc(p, size);
}
void free(void *p)
{
    if (g_counting && p != NULL)
        g_frees++;
    __libc_free(p);
}
void *aligned_alloc(size_t align, size_t size)
{
    if (g_counting)
        g_allocs++;
    return __libc_memalign(align, size);
}
void *memalign(size_t align, size_t size)
{
    if (g_counting)
        g_allocs++;
    return __libc_memalign(align, size);
}
int posix_memalign(void **out, size_t align, size_t size)
{
    void *p;
    if (g_counting)
        g_allocs++;
    p = __libc_memalign(align, size);
    if (p == NULL)
        return 12; /* ENOMEM */
    *out = p;
    return 0;
}

static void count_begin(void)
{
    g_allocs = 0;
    g_frees = 0;
    g_counting = 1;
}
static long count_end(void)
{
    g_counting = 0;
    return g_allocs + g_frees;
}

/* The counter works: an allocation made in the window is seen (so a zero below means something). */
static void test_counter_sees_allocations(void **state)
{
    void *(*volatile alloc)(size_t) = malloc;
    void (*volatile release)(void *) = free;
    void *p;
    long n;
    (void)state;
    count_begin();
    p = alloc(100);
    release(p);
    n = count_end();
    assert_int_equal(n, 2);
}

typedef struct vo_box {
    void *mem;
    tvo_vo *vo;
} vo_box;

static void vo_open(vo_box *b, const tvo_camera *cam)
{
    tvo_vo_config cfg;
    size_t need;
    tvo_vo_config_default(&cfg, cam);
    /* the affine refinement's path too (it adds to LK's, it replaces nothing) */
    cfg.affine_win_size = TVO_WITH_AFFINE ? 21 : 0;
    tvo_g_predicted_tracks(&cfg, 1); /* and the map's predicted tracks (the balanced preset's LK) */
    cfg.lens_refine = TVO_WITH_LENS; /* and the lens refined on the run (its blocks at keyframes) */
    cfg.map_lm_prior = TVO_WITH_AFFINE ? 1.0 : 0.0; /* and the landmarks' priors (at keyframes) */
    need = tvo_vo_required_size(&cfg);
    assert_true(need > 0);
    b->mem = malloc(need);
    assert_non_null(b->mem);
    assert_int_equal(tvo_vo_init(&b->vo, &cfg, b->mem, need), TVO_OK);
}

/* One counted frame: VO, then the networks, refinement and trajectory. Returns the calls counted. */
static long counted_frame(vo_box *b, const tvo_g_model *m, tvo_traj *traj, const uint8_t *pix, int32_t w,
                          int32_t h, int64_t t_ns, int reset, int *states)
{
    tvo_image img = tvo_image_make(w, h, w, (uint8_t *)(uintptr_t)pix);
    tvo_vo_result res;
    tvo_pose step;
    float out[6];
    tvo_status st;
    long n;
    count_begin();
    st = tvo_vo_process(b->vo, &img, t_ns, &res);
    if (st == TVO_OK && m->nn != NULL) {
        (void)tvo_nn_run(m->nn, res.features, out);
        (void)tvo_vo_refine(m->nn, &res, &step);
        (void)tvo_traj_step(traj, &step, 1.0);
    } else if (st == TVO_OK) {
        (void)tvo_traj_step(traj, &res.T_prev_cur, 0.05);
    }
    if (reset)
        tvo_vo_reset(b->vo);
    n = count_end();
    assert_int_equal(st, TVO_OK);
    states[res.state]++;
    return n;
}

static void test_synthetic_sequence(void **state)
{
    const int32_t w = 320, h = 240;
    uint8_t *frames = malloc((size_t)TVO_G_SEQ_FRAMES * (size_t)w * (size_t)h);
    tvo_camera cam = tvo_g_camera(w, h, 250.0);
    tvo_g_model m;
    vo_box b;
    tvo_traj traj;
    uint64_t rng = 12345;
    int states[TVO_VO_STATE_COUNT] = {0};
    long total = 0;
    (void)state;
    assert_non_null(frames);
    for (int k = 0; k < TVO_G_SEQ_FRAMES; ++k)
        tvo_g_seq_frame(k, frames + (size_t)k * (size_t)w * (size_t)h, w, h, 250.0, &rng);
    assert_true(tvo_g_load_model(&m, "paper.tvonn"));
    vo_open(&b, &cam);
    tvo_traj_init(&traj, NULL);
    for (int pass = 0; pass < 2; ++pass)
        for (int k = 0; k < TVO_G_SEQ_FRAMES; ++k) {
            const int64_t t = 1000000000LL + (int64_t)(pass * TVO_G_SEQ_FRAMES + k) * 50000000LL;
            const long n = counted_frame(&b, &m, &traj, frames + (size_t)k * (size_t)w * (size_t)h, w, h, t,
                                         pass == 1 && k == 30, states);
            if (n != 0)
                fail_msg("%ld allocator calls during frame %d (pass %d)", n, k, pass);
            total += n;
        }
    fprintf(stderr, "synthetic: %d frames, states ok %d rot-only %d lost %d init %d, allocator calls %ld\n",
            2 * TVO_G_SEQ_FRAMES, states[TVO_VO_OK], states[TVO_VO_ROTATION_ONLY], states[TVO_VO_LOST],
            states[TVO_VO_INITIALISING], total);
    /* the sequence must have reached every state, or the test covers less than it claims */
    assert_true(states[TVO_VO_OK] > 0 && states[TVO_VO_ROTATION_ONLY] > 0 && states[TVO_VO_LOST] > 0 &&
                states[TVO_VO_INITIALISING] > 1);
    free(b.mem);
    tvo_g_free_model(&m);
    free(frames);
}

static void run_euroc(const char *name, int max_frames)
{
    tvo_g_frames f;
    tvo_g_model m;
    vo_box b;
    tvo_traj traj;
    int states[TVO_VO_STATE_COUNT] = {0};
    if (!tvo_g_frames_load(&f, name, max_frames))
        return;
    assert_true(tvo_g_load_model(&m, "paper.tvonn"));
    vo_open(&b, f.cam);
    tvo_traj_init(&traj, NULL);
    for (int32_t i = 0; i < f.n; ++i) {
        const long c = counted_frame(&b, &m, &traj, f.pix + (size_t)i * f.fsz, f.cam->width, f.cam->height,
                                     f.t[i], 0, states);
        if (c != 0)
            fail_msg("%ld allocator calls during %s frame %d", c, name, (int)i);
    }
    fprintf(stderr, "%s: %d frames, states ok %d rot-only %d lost %d init %d, no allocator call\n", name,
            (int)f.n, states[TVO_VO_OK], states[TVO_VO_ROTATION_ONLY], states[TVO_VO_LOST],
            states[TVO_VO_INITIALISING]);
    free(b.mem);
    tvo_g_free_model(&m);
    tvo_g_frames_free(&f);
}

static void test_euroc_keyframes(void **state)
{
    (void)state;
    run_euroc("V1_01_easy_keyframes", TVO_G_SLOW_BUILD ? 10 : 40);
}

static void test_euroc_head(void **state)
{
    (void)state;
    run_euroc("V1_01_easy_head", TVO_G_SLOW_BUILD ? 10 : 40);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_counter_sees_allocations),
            cmocka_unit_test(test_synthetic_sequence),
            cmocka_unit_test(test_euroc_keyframes),
            cmocka_unit_test(test_euroc_head),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
