/* SPDX-License-Identifier: Apache-2.0 */
/* The local map's landmark store (lib/src/tvo_map.c), driven directly with exact tracks of a synthetic
 * scene: after every frame, each observation in the window's keyframes belongs to a live landmark and
 * each live landmark's observation count is the number of observations that name it. A landmark slot is
 * reused by the next landmark made, so an observation left behind by a freed landmark would silently
 * observe another point (a wrong reprojection error of up to the image size in the bundle adjustment)
 * and later decrement that landmark's count. A small landmark store and window make the slots turn over
 * quickly. */
#include "tvo_test.h"

#include <math.h>
#include <string.h>

#include "tinyvo/arena.h"
#include "tinyvo/se3.h"
#include "tinyvo/vo.h"
#include "tvo_map.h"

#define W 320
#define H 240
#define FOCAL 250.0
#define DT_NS 100000000LL
#define MAX_TRACKS 60
#define N_POINTS 4000
#define FRAMES 120

/* deterministic pseudo-random numbers in [0, 1) */
static double rnd(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return (double)(*s >> 8) / 16777216.0;
}

/* the camera drives forward 0.15 m a frame, swaying sideways and in yaw */
static tvo_pose camera(int k)
{
    tvo_pose T_w_c = tvo_pose_identity();
    const double v[3] = {0.0, 0.05 * sin(0.07 * k), 0.0};
    tvo_rotvec_to_rot(v, T_w_c.R);
    T_w_c.t[0] = 0.4 * sin(0.05 * k);
    T_w_c.t[2] = 0.15 * k;
    return tvo_pose_inverse(&T_w_c); /* world -> camera */
}

/* point X seen by T_c_w: 1 and its normalised position when in front and inside the image (5 px margin) */
static int project(const tvo_pose *T_c_w, const double X[3], tvo_point2d *x)
{
    double P[3];
    tvo_pose_transform_point(T_c_w, X, P);
    if (!(P[2] > 0.5))
        return 0;
    x->x = P[0] / P[2];
    x->y = P[1] / P[2];
    return fabs(x->x * FOCAL) < W / 2 - 5 && fabs(x->y * FOCAL) < H / 2 - 5;
}

/* The store's inconsistencies: window observations of a freed landmark, and live landmarks whose count
 * differs from the observations naming them. */
static int count_inconsistencies(const tvo_map *m)
{
    int bad = 0;
    for (int32_t i = 0; i < m->n_kf; ++i) {
        const tvo_map_kf *k = &m->kf[(m->kf_head + i) % m->window];
        for (int32_t o = 0; o < k->n_obs; ++o)
            bad += !m->lm[k->obs_lm[o]].alive;
    }
    for (int32_t j = 0; j < m->max_lm; ++j) {
        int32_t n = 0;
        if (!m->lm[j].alive)
            continue;
        for (int32_t i = 0; i < m->n_kf; ++i) {
            const tvo_map_kf *k = &m->kf[(m->kf_head + i) % m->window];
            for (int32_t o = 0; o < k->n_obs; ++o)
                n += k->obs_lm[o] == j;
        }
        bad += n != m->lm[j].n_obs;
    }
    return bad;
}

/* Drives the map along the road; jump: the chance per frame that a track slides off its point by up to
 * +-8 px in each axis (and stays off: a track that locked onto something else). Asserts the store's
 * consistency and finite poses after every frame, and that the map tracked most frames. */
static int32_t run_road(double jump, int32_t max_landmarks)
{
    tvo_camera cam = tvo_camera_make_pinhole(W, H, FOCAL, FOCAL, (W - 1) / 2.0, (H - 1) / 2.0);
    tvo_vo_config cfg;
    static double pts[N_POINTS][3];
    int32_t pid[MAX_TRACKS], life[MAX_TRACKS], lm[MAX_TRACKS], tri_fr[MAX_TRACKS];
    double off[MAX_TRACKS][2];
    tvo_point2d x[MAX_TRACKS], tri_x[MAX_TRACKS];
    uint8_t ok[MAX_TRACKS], inlier[MAX_TRACKS];
    int32_t n = 0, next_point = 0, tracking = 0, keyframes = 0, worst = 0;
    uint32_t seed = 12345u;
    tvo_map m;
    tvo_arena ar;
    size_t ls, ss;
    void *mem, *scratch;
    tvo_vo_config_default(&cfg, &cam);
    cfg.max_tracks = MAX_TRACKS;
    cfg.min_tracks = MAX_TRACKS / 2;
    cfg.map_window = 4;
    cfg.map_ba_fixed = 2;
    cfg.map_max_landmarks = max_landmarks;
    assert_true(tvo_vo_required_size(&cfg) > 0);
    /* points along the road ahead: 2-12 m to the sides and above and below, up to 30 m beyond the end */
    for (int i = 0; i < N_POINTS; ++i) {
        const double side = rnd(&seed) < 0.5 ? -1.0 : 1.0;
        pts[i][0] = side * (1.0 + 5.0 * rnd(&seed));
        pts[i][1] = -3.0 + 6.0 * rnd(&seed);
        pts[i][2] = 2.0 + (0.15 * FRAMES + 30.0) * (double)i / N_POINTS;
    }
    ls = tvo_map_layout_size(&cfg) + TVO_ARENA_ALIGN;
    ss = tvo_map_scratch_size(&cfg);
    mem = malloc(ls);
    scratch = malloc(ss);
    assert_non_null(mem);
    assert_non_null(scratch);
    tvo_arena_init(&ar, mem, ls);
    assert_int_equal(tvo_map_init(&m, &cfg, &ar), TVO_OK);
    memset(ok, 1, sizeof(ok));
    for (int k = 0; k < FRAMES; ++k) {
        const tvo_pose T = camera(k);
        tvo_map_tracks tr;
        tvo_map_frame out;
        double R_cur_prev[9];
        int32_t first, kept = 0;
        /* tracks go on while their point is seen and their life lasts (10-40 frames): the exact
           projections plus up to 0.05 px of noise (and their slide, off) */
        for (int32_t i = 0; i < n; ++i) {
            tvo_point2d p;
            if (--life[i] <= 0 || !project(&T, pts[pid[i]], &p))
                continue;
            pid[kept] = pid[i];
            life[kept] = life[i];
            lm[kept] = lm[i];
            tri_fr[kept] = tri_fr[i];
            tri_x[kept] = tri_x[i];
            off[kept][0] = off[i][0];
            off[kept][1] = off[i][1];
            if (jump > 0.0 && rnd(&seed) < jump) {
                off[kept][0] += (rnd(&seed) - 0.5) * 16.0 / FOCAL;
                off[kept][1] += (rnd(&seed) - 0.5) * 16.0 / FOCAL;
            }
            x[kept].x = p.x + off[kept][0] + (rnd(&seed) - 0.5) * 0.1 / FOCAL;
            x[kept].y = p.y + off[kept][1] + (rnd(&seed) - 0.5) * 0.1 / FOCAL;
            ++kept;
        }
        n = kept;
        if (k > 0) {
            const tvo_pose Tp = camera(k - 1), Twp = tvo_pose_inverse(&Tp), d = tvo_pose_compose(&T, &Twp);
            memcpy(R_cur_prev, d.R, sizeof(R_cur_prev));
        }
        tr = (tvo_map_tracks){n, x, ok, lm, tri_fr, tri_x, inlier, NULL, NULL};
        assert_int_equal(tvo_map_process(&m, &cfg, &tr, 1000000000LL + k * DT_NS, k > 0 ? R_cur_prev : NULL,
                                         0, &T, scratch, ss, &out),
                         TVO_OK);
        tracking += out.state == TVO_MAP_TRACKING;
        if (out.state == TVO_MAP_TRACKING || out.state == TVO_MAP_INITIALISED)
            assert_true(tvo_pose_is_finite(&out.T_c_w));
        keyframes += out.keyframe;
        /* new tracks on the next points in view */
        first = n;
        while (n < MAX_TRACKS && next_point < N_POINTS) {
            tvo_point2d p;
            const int32_t i = next_point++;
            if (!project(&T, pts[i], &p))
                continue;
            pid[n] = i;
            life[n] = 10 + (int32_t)(30.0 * rnd(&seed));
            lm[n] = -1;
            tri_fr[n] = -1;
            off[n][0] = off[n][1] = 0.0;
            x[n] = p;
            ++n;
        }
        tr = (tvo_map_tracks){n, x, ok, lm, tri_fr, tri_x, inlier, NULL, NULL};
        tvo_map_new_tracks(&m, &tr, first);
        {
            int bad = count_inconsistencies(&m);
            for (int32_t i = 0; i < n; ++i) /* a track's landmark is a live one */
                bad += lm[i] >= 0 && (lm[i] >= m.max_lm || !m.lm[lm[i]].alive);
            if (bad > worst)
                worst = bad;
            if (bad > 0 && getenv("TVO_MAP_TEST_VERBOSE"))
                fprintf(stderr, "  frame %d: %d inconsistencies\n", k, bad);
        }
    }
    if (getenv("TVO_MAP_TEST_VERBOSE"))
        fprintf(stderr, "  jump %.2f: tracking %d of %d frames, %d keyframes, %d losses\n", jump, tracking,
                FRAMES, keyframes, (int)m.losses);
    /* the scenario exercises the store: the map tracks most frames and makes many windows' worth of
       keyframes */
    assert_true(tracking > FRAMES / 2);
    assert_true(keyframes > 5 * cfg.map_window);
    assert_int_equal(worst, 0);
    free(mem);
    free(scratch);
    return m.store_full;
}

static void test_store_stays_consistent(void **state)
{
    (void)state;
    run_road(0.0, 64); /* slots reused within a few keyframes */
}

/* Tracks that slide off their points: the PnP and the bundle adjustment's outlier removal drop
 * observations and free landmarks along other paths than tracks that end. */
static void test_store_with_sliding_tracks(void **state)
{
    (void)state;
    run_road(0.03, 64);
}

/* The store's count of keyframes that found it full (map_store_full in the VO's result): 64 slots for a
 * window of 4 keyframes and 60 tracks fill, 600 never do. */
static void test_store_full_counted(void **state)
{
    (void)state;
    assert_true(run_road(0.0, 64) > 0);
    assert_int_equal(run_road(0.0, 600), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_store_stays_consistent),
            cmocka_unit_test(test_store_with_sliding_tracks),
            cmocka_unit_test(test_store_full_counted),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
