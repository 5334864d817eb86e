/* SPDX-License-Identifier: Apache-2.0 */
/* The VO object end to end on frames rendered here from a textured 3D box room with known poses,
 * plus its bad-input contract. */
#include "tvo_test.h"

#include <math.h>

#include "tinyvo/options.h"
#include "tinyvo/vo.h"
#include "tvo_room.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif
#define W 320
#define H 240
#define FOCAL 250.0

/* the textured box room of test/common/tvo_room.h */
static void render(const tvo_pose *T_w_c, uint8_t *img)
{
    tvo_room_render(T_w_c, W, H, FOCAL, img);
}

static tvo_camera test_camera(void)
{
    return tvo_camera_make_pinhole(W, H, FOCAL, FOCAL, (W - 1) / 2.0, (H - 1) / 2.0);
}

typedef struct fixture {
    tvo_vo_config cfg;
    void *mem;
    tvo_vo *vo;
    uint8_t img[W * H];
} fixture;

/* The VO of f->cfg in a block of its required size. */
static void open_vo(fixture *f)
{
    const size_t need = tvo_vo_required_size(&f->cfg);
    assert_true(need > 0);
    f->mem = malloc(need);
    assert_non_null(f->mem);
    assert_int_equal(tvo_vo_init(&f->vo, &f->cfg, f->mem, need), TVO_OK);
}

static int setup(void **state)
{
    fixture *f = calloc(1, sizeof(fixture));
    tvo_camera cam = test_camera();
    assert_non_null(f);
    tvo_vo_config_default(&f->cfg, &cam);
    open_vo(f);
    *state = f;
    return 0;
}

/* The same with the basic preset (translation-only LK on every track): for the tests whose figures are
 * the tracker's own, measured without the affine refinement and the map's predicted tracks. */
static int setup_basic(void **state)
{
    fixture *f = calloc(1, sizeof(fixture));
    tvo_camera cam = test_camera();
    assert_non_null(f);
    assert_int_equal(tvo_vo_config_preset(&f->cfg, &cam, TVO_VO_PRESET_BASIC), TVO_OK);
    open_vo(f);
    *state = f;
    return 0;
}

static int teardown(void **state)
{
    fixture *f = *state;
    free(f->mem);
    free(f);
    return 0;
}

/* The distance between two positions (a step of the trajectory). */
static double dist3(const double a[3], const double b[3])
{
    const double d[3] = {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    return sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

static double angle_between(const double a[3], const double b[3])
{
    const double na = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    const double nb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    double c = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (na * nb);
    c = c > 1 ? 1 : (c < -1 ? -1 : c);
    return acos(c);
}

static double rot_err_deg(const tvo_pose *est, const tvo_pose *gt)
{
    tvo_pose d = tvo_pose_relative(est, gt);
    return tvo_rot_angle(d.R) * 180.0 / M_PI;
}

/* Camera pose k of a smooth motion: translation `step` per frame along dir, yaw `yaw_deg` per frame. */
static tvo_pose motion(int k, const double dir[3], double step, double yaw_deg)
{
    tvo_pose T = tvo_pose_identity();
    const double v[3] = {0.0, yaw_deg * M_PI / 180.0 * k, 0.02 * sin(0.3 * k)};
    tvo_rotvec_to_rot(v, T.R);
    for (int i = 0; i < 3; ++i)
        T.t[i] = dir[i] * step * k;
    return T;
}

static void run_sequence(fixture *f, const double dir[3], double step, double yaw_deg, int frames,
                         int expect_translation)
{
    tvo_pose prev = tvo_pose_identity();
    int ok_frames = 0, rot_frames = 0;
    for (int k = 0; k < frames; ++k) {
        tvo_pose T = motion(k, dir, step, yaw_deg);
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, f->img);
        render(&T, f->img);
        assert_int_equal(tvo_vo_process(f->vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_prev_cur));
        if (k == 0) {
            assert_int_equal(res.state, TVO_VO_INITIALISING);
            assert_true(res.tracks > 100);
        } else {
            tvo_pose gt = tvo_pose_relative(&prev, &T);
            assert_true(res.state == TVO_VO_OK || res.state == TVO_VO_ROTATION_ONLY);
            assert_true(rot_err_deg(&res.T_prev_cur, &gt) < 0.2);
            if (res.state == TVO_VO_OK) {
                ok_frames++;
                assert_true(angle_between(res.T_prev_cur.t, gt.t) * 180.0 / M_PI < 5.0);
            } else {
                rot_frames++;
                assert_true(res.T_prev_cur.t[0] == 0.0 && res.T_prev_cur.t[1] == 0.0 &&
                            res.T_prev_cur.t[2] == 0.0);
            }
            assert_true(res.tracks >= f->cfg.min_tracks || res.new_corners > 0 || res.tracks > 50);
        }
        prev = T;
    }
    if (expect_translation)
        assert_true(ok_frames >= (frames - 1) * 8 / 10);
    else
        assert_true(rot_frames >= (frames - 1) * 8 / 10);
}

static void test_translating_camera(void **state)
{
    const double dir[3] = {0.8, 0.1, 0.6};
    run_sequence(*state, dir, 0.10, 0.3, 12, 1);
}

/* Detections fill the track list up to max_tracks whatever detect.max_corners says (vo.h): with more
 * tracks than detect.max_corners and no map (whose scratch would otherwise be the largest), the scratch
 * must still hold a detection of max_tracks corners, or every frame finds none and stays LOST. */
static void test_more_tracks_than_max_corners(void **state)
{
    const double dir[3] = {0.8, 0.1, 0.6};
    fixture *f = *state;
    free(f->mem);
    f->cfg.map = 0;
    f->cfg.max_tracks = 2 * f->cfg.detect.max_corners;
    f->cfg.min_tracks = f->cfg.detect.max_corners;
    open_vo(f);
    run_sequence(f, dir, 0.10, 0.3, 8, 1);
}

static void test_pure_rotation_reports_rotation_only(void **state)
{
    const double dir[3] = {0.0, 0.0, 0.0};
    run_sequence(*state, dir, 0.0, 0.8, 10, 0);
}

/* A camera in front of one wall of the room, so that it sees a single plane, moving while it turns.
 * A plane has two poses (the "twins") that explain the tracks equally well; relpose flags them
 * AMBIGUOUS. With no track off the plane tvo_relpose_twin_choice refuses to choose, and the VO picks the
 * twin that continues the recent motion; without one, the epipolar model's choice (still flagged: in a
 * scene that is one plane and nothing else, two views cannot tell).
 * Never a lost frame (that integrated an identity rotation), never an unflagged wrong twin. */
static void run_plane(fixture *f, const double dir[3], double step, int frames, int *ok_frames,
                      int *ambiguous, int *wrong, double *max_rot_err)
{
    tvo_pose prev = tvo_pose_identity();
    *ok_frames = *ambiguous = *wrong = 0;
    *max_rot_err = 0.0;
    for (int k = 0; k < frames; ++k) {
        tvo_pose T = motion(k, dir, step, 0.25);
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, f->img);
        T.t[2] += 3.6; /* 2.4 m in front of the wall at z = 6: only that wall is in view */
        render(&T, f->img);
        assert_int_equal(tvo_vo_process(f->vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_prev_cur));
        if (k > 0) {
            tvo_pose gt = tvo_pose_relative(&prev, &T);
            double re = rot_err_deg(&res.T_prev_cur, &gt);
            assert_true(res.state == TVO_VO_OK || res.state == TVO_VO_ROTATION_ONLY);
            *max_rot_err = re > *max_rot_err ? re : *max_rot_err;
            if (res.relpose_flags & TVO_RELPOSE_FLAG_AMBIGUOUS)
                (*ambiguous)++;
            if (res.state == TVO_VO_OK) {
                (*ok_frames)++;
                if (angle_between(res.T_prev_cur.t, gt.t) * 180.0 / M_PI >= 5.0) {
                    /* a wrong direction only ever comes out flagged */
                    assert_true(res.relpose_flags & TVO_RELPOSE_FLAG_AMBIGUOUS);
                    (*wrong)++;
                }
            }
        }
        prev = T;
    }
}

static void test_single_plane_twins(void **state)
{
    int ok, amb, wrong;
    double rmax;
    /* mostly sideways: some frames ambiguous, resolved by the motion of the frames before them
       (29 of 29 frames with a translation, 6 ambiguous, 0.009 deg max rotation error) */
    const double side[3] = {1.0, 0.2, 0.3};
    run_plane(*state, side, 0.04, 30, &ok, &amb, &wrong, &rmax);
    fprintf(stderr,
            "plane, sideways: %d of 29 frames with a translation (%d wrong), %d ambiguous, max rot err "
            "%.3f deg\n",
            ok, wrong, amb, rmax);
    assert_true(amb > 0);
    assert_true(ok == 29);
    assert_int_equal(wrong, 0);
    assert_true(rmax < 0.1);
}

static void test_single_plane_unresolved(void **state)
{
    int ok, amb, wrong;
    double rmax;
    /* oblique towards the wall: every frame ambiguous from the start, no motion to resolve them with:
       the frames keep their rotation and a flagged translation (when written: 29 of 29 frames with a
       translation, 29 ambiguous; which twin comes out is the epipolar model's choice) */
    const double oblique[3] = {0.6, 0.0, 0.8};
    run_plane(*state, oblique, 0.04, 30, &ok, &amb, &wrong, &rmax);
    fprintf(stderr,
            "plane, oblique: %d of 29 frames with a translation (%d wrong, all flagged), %d ambiguous, "
            "max rot err %.3f deg\n",
            ok, wrong, amb, rmax);
    assert_true(amb >= 25);
    assert_true(rmax < 1.5);
}

/* Relative scale: a camera translating with known, varying step lengths (and a slow yaw) through the
 * room; rel_scale must give |t_k| / |t_(k-1)| within a few percent on the frames where it is available,
 * be unavailable (0, never NaN) on the first two frames and after a reset, and after rotation-only
 * frames. Steps 4-12 cm at 20-60 px of flow keep most tracks inside the 320x240 view. With the basic
 * preset's tracker (setup_basic): the default's predicted tracks give a worst frame of 6.0 % here. */
static const double scale_steps[] = {0.08, 0.05, 0.10,  0.07, 0.12, 0.06, 0.09, 0.045,
                                     0.08, 0.11, 0.055, 0.09, 0.07, 0.10, 0.06, 0.08};
#define SCALE_FRAMES ((int)(sizeof(scale_steps) / sizeof(scale_steps[0])) + 1)

static tvo_pose scale_pose(int k, const double dir[3])
{
    tvo_pose T = tvo_pose_identity();
    double s = 0.0;
    const double v[3] = {0.01 * sin(0.5 * k), 0.004 * k, 0.0};
    for (int j = 0; j < k; ++j)
        s += scale_steps[j];
    tvo_rotvec_to_rot(v, T.R);
    for (int i = 0; i < 3; ++i)
        T.t[i] = dir[i] * s;
    return T;
}

/* Frame k of the relative-scale sequence, rendered and processed (1 s + k x 50 ms). */
static void scale_frame(fixture *f, int k, const double dir[3], tvo_vo_result *res)
{
    tvo_pose T = scale_pose(k, dir);
    tvo_image img = tvo_image_make(W, H, W, f->img);
    render(&T, f->img);
    assert_int_equal(tvo_vo_process(f->vo, &img, 1000000000LL + k * 50000000LL, res), TVO_OK);
}

static void test_relative_scale(void **state)
{
    fixture *f = *state;
    const double dir[3] = {0.6, 0.1, -0.79}; /* sideways and backwards: the far wall stays in view */
    double worst = 0.0, prop = scale_steps[0], prop_worst = 0.0;
    int avail = 0;
    for (int k = 0; k < SCALE_FRAMES; ++k) {
        tvo_vo_result res;
        scale_frame(f, k, dir, &res);
        assert_true(isfinite(res.rel_scale) && res.rel_scale >= 0.0);
        if (k < 2) {
            assert_true(res.rel_scale == TVO_VO_REL_SCALE_NONE);
            continue;
        }
        if (getenv("TVO_TEST_VERBOSE") != NULL)
            fprintf(stderr, "frame %2d: state %d tracked %d inliers %d rel_scale %g points %d\n", k,
                    (int)res.state, (int)res.tracked, (int)res.inliers, res.rel_scale,
                    (int)res.rel_scale_points);
        if (res.rel_scale != TVO_VO_REL_SCALE_NONE) {
            const double truth = scale_steps[k - 1] / scale_steps[k - 2];
            const double e = fabs(res.rel_scale / truth - 1.0);
            fprintf(stderr, "frame %2d: rel_scale %.4f truth %.4f (%+.2f %%) from %d tracks\n", k,
                    res.rel_scale, truth, 100.0 * (res.rel_scale / truth - 1.0), (int)res.rel_scale_points);
            assert_int_equal(res.state, TVO_VO_OK);
            assert_true(res.rel_scale_points >= f->cfg.min_scale_points);
            worst = e > worst ? e : worst;
            avail++;
            /* propagated from the first step: s_k = r_k s_(k-1) */
            prop *= res.rel_scale;
            {
                const double pe = fabs(prop / scale_steps[k - 1] - 1.0);
                prop_worst = pe > prop_worst ? pe : prop_worst;
            }
        } else {
            prop = scale_steps[k - 1]; /* (not reached when every frame has one) */
        }
    }
    fprintf(stderr,
            "relative scale: %d of %d frames, worst error %.2f %%; propagated from the first step: worst "
            "%.2f %%\n",
            avail, SCALE_FRAMES - 2, 100.0 * worst, 100.0 * prop_worst);
    assert_true(avail >= (SCALE_FRAMES - 2) * 8 / 10);
    assert_true(worst < 0.06);
    assert_true(prop_worst < 0.06);

    /* after a reset: the first two frames have none again */
    tvo_vo_reset(f->vo);
    for (int k = 0; k < 3; ++k) {
        tvo_pose T = scale_pose(k, dir);
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, f->img);
        render(&T, f->img);
        assert_int_equal(tvo_vo_process(f->vo, &img, 5000000000LL + k * 50000000LL, &res), TVO_OK);
        if (k < 2)
            assert_true(res.rel_scale == TVO_VO_REL_SCALE_NONE && res.rel_scale_points == 0);
        else
            assert_true(res.rel_scale > 0.0);
    }
}

/* cfg.chain_scale_sigmas: the frames without a map pose (here every frame: a map that needs 30 deg of
 * parallax never starts) are placed by the two-view chain. With 0 each step is one unit long, whatever the
 * camera did; with 3 the steps follow the relative scale's changes beyond 3 standard errors, so their
 * lengths over the first one's follow the true ones (the steps of test_relative_scale change by 30-100 %
 * from frame to frame, far beyond the scale's noise). */
static void test_chain_scale(void **state)
{
    fixture *f = *state; /* the basic preset (setup_basic), opened again for each pass */
    const double dir[3] = {0.6, 0.1, -0.79};
    double worst[2] = {0.0, 0.0};
    for (int pass = 0; pass < 2; ++pass) {
        double first = 0.0, prev_c[3] = {0.0, 0.0, 0.0};
        int steps = 0;
        f->cfg.map_init_parallax_deg = 30.0;
        f->cfg.chain_scale_sigmas = pass == 0 ? 0.0 : 3.0;
        free(f->mem);
        open_vo(f);
        for (int k = 0; k < SCALE_FRAMES; ++k) {
            tvo_vo_result res;
            scale_frame(f, k, dir, &res);
            assert_true(tvo_pose_is_finite(&res.T_w_c));
            assert_int_equal(res.map_state, TVO_MAP_INITIALISING);
            if (k > 0 && res.state == TVO_VO_OK) {
                const double len = dist3(res.T_w_c.t, prev_c);
                double e;
                if (first == 0.0)
                    first = len;
                e = fabs((len / first) / (scale_steps[k - 1] / scale_steps[0]) - 1.0);
                worst[pass] = e > worst[pass] ? e : worst[pass];
                if (pass == 0)
                    assert_true(fabs(len - 1.0) < 1e-9); /* one unit a frame */
                steps++;
            }
            memcpy(prev_c, res.T_w_c.t, sizeof(prev_c));
        }
        fprintf(stderr, "chain_scale_sigmas %g: %d steps, worst step length error %.1f %%\n",
                f->cfg.chain_scale_sigmas, steps, 100.0 * worst[pass]);
        assert_true(steps >= (SCALE_FRAMES - 1) * 8 / 10);
    }
    assert_true(worst[0] > 0.5); /* unit steps: 0.12 m against 0.08 m, 0.045 against 0.08 ... */
    assert_true(worst[1] < 0.1);
}

/* Frames dropped and frames lost before the first map (a map that needs 30 deg of parallax never
 * starts, so every pose is the two-view chain's): a camera moving 0.06 m every 50 ms, a slow turn; frames
 * 6, 7 and 14 are not delivered (a gap of 150 ms at frame 8, of 100 ms at frame 15), frame 20 is black.
 * The chain's step is one unit per its first frame interval, so the step after a gap is 3 (or 2) units
 * and the ones after it 1 again, with the relative scale followed (chain_scale_sigmas 3, the default) or
 * not (0: steps counted in frames would be 1 unit after a gap); the black frame is LOST and moves on by
 * the last step instead of standing still; the frames after it are posed again, one unit a frame. */
static void test_dropped_and_lost_frames(void **state)
{
    fixture *f = *state;
    const double dir[3] = {0.6, 0.1, -0.79};
    for (int pass = 0; pass < 2; ++pass) {
        double prev[3] = {0.0, 0.0, 0.0};
        int64_t t_prev = 0;
        int lost = 0, checked = 0;
        f->cfg.map_init_parallax_deg = 30.0;
        f->cfg.chain_scale_sigmas = pass == 0 ? 3.0 : 0.0;
        free(f->mem);
        open_vo(f);
        for (int k = 0; k < 32; ++k) {
            const int64_t t = 1000000000LL + k * 50000000LL;
            const double v[3] = {0.0, 0.003 * k, 0.0};
            tvo_pose T = tvo_pose_identity();
            tvo_image img = tvo_image_make(W, H, W, f->img);
            tvo_vo_result res;
            if (k == 6 || k == 7 || k == 14)
                continue;
            tvo_rotvec_to_rot(v, T.R);
            for (int i = 0; i < 3; ++i)
                T.t[i] = dir[i] * 0.06 * k;
            if (k == 20)
                memset(f->img, 0, sizeof(f->img));
            else
                render(&T, f->img);
            assert_int_equal(tvo_vo_process(f->vo, &img, t, &res), TVO_OK);
            assert_true(tvo_pose_is_finite(&res.T_w_c));
            assert_int_equal(res.map_state, TVO_MAP_INITIALISING);
            if (k > 0) {
                const double len = dist3(res.T_w_c.t, prev);
                const double frames = (double)(t - t_prev) / 50000000.0; /* the interval in frame periods */
                if (getenv("TVO_TEST_VERBOSE") != NULL)
                    fprintf(stderr, "sigmas %g frame %2d: state %d step %.3f over %.0f frame(s)\n",
                            f->cfg.chain_scale_sigmas, k, (int)res.state, len, frames);
                if (k == 20) {
                    assert_int_equal(res.state, TVO_VO_LOST);
                    assert_true(fabs(len - 1.0) < 0.1); /* moved on by the last step, one unit */
                    lost++;
                } else if (res.state == TVO_VO_OK && k != 21) {
                    assert_true(fabs(len / frames - 1.0) < 0.1); /* 1, 2 or 3 units: one per 50 ms */
                    checked++;
                }
            }
            memcpy(prev, res.T_w_c.t, sizeof(prev));
            t_prev = t;
        }
        assert_int_equal(lost, 1);
        assert_true(checked >= 20);
    }
}

/* Timestamps that jitter around a steady rate (a driver's stamps, up to 5 ms of a 50 ms interval, so
 * intervals of 40-60 ms) while the camera moves at a constant speed: before the first map every step is
 * one unit, as the frames show, not the jittered intervals (steps of 0.8-1.2 units, and with
 * chain_scale_sigmas a speed that wanders). */
static void test_timestamp_jitter(void **state)
{
    fixture *f = *state;
    const double dir[3] = {0.6, 0.1, -0.79};
    const int jitter[12] = {0, 4, -3, 5, -5, 2, -4, 4, -1, 5, -3, 3}; /* milliseconds of 50 */
    for (int pass = 0; pass < 2; ++pass) {
        double prev[3] = {0.0, 0.0, 0.0};
        int checked = 0;
        f->cfg.map_init_parallax_deg = 30.0;
        f->cfg.chain_scale_sigmas = pass == 0 ? 0.0 : 3.0;
        free(f->mem);
        open_vo(f);
        for (int k = 0; k < 30; ++k) {
            const int64_t t = 1000000000LL + k * 50000000LL + (k == 0 ? 0 : jitter[k % 12] * 1000000LL);
            tvo_pose T = tvo_pose_identity();
            tvo_image img = tvo_image_make(W, H, W, f->img);
            tvo_vo_result res;
            for (int i = 0; i < 3; ++i)
                T.t[i] = dir[i] * 0.06 * k;
            render(&T, f->img);
            assert_int_equal(tvo_vo_process(f->vo, &img, t, &res), TVO_OK);
            assert_true(tvo_pose_is_finite(&res.T_w_c));
            assert_int_equal(res.map_state, TVO_MAP_INITIALISING);
            if (k > 1 && res.state == TVO_VO_OK) {
                const double len = dist3(res.T_w_c.t, prev);
                if (getenv("TVO_TEST_VERBOSE") != NULL)
                    fprintf(stderr, "jitter, sigmas %g frame %2d: step %.3f\n", f->cfg.chain_scale_sigmas, k,
                            len);
                /* sigmas 3: the relative scale's own noise beyond its threshold (as without jitter) */
                assert_true(fabs(len - 1.0) < (pass == 0 ? 1e-6 : 0.1));
                checked++;
            }
            memcpy(prev, res.T_w_c.t, sizeof(prev));
        }
        assert_true(checked >= 20);
    }
}

/* A first frame interval far shorter than the rest (a duplicated frame 1 us after the first): before the
 * first map the chain's unit is that interval, so every later step would be 50,000 units; it takes at
 * most 10 (the LOST frames' bound), finite, and the map still starts. */
static void test_short_first_interval(void **state)
{
    fixture *f = *state;
    const double dir[3] = {0.6, 0.1, -0.79};
    double prev[3] = {0.0, 0.0, 0.0};
    int checked = 0, mapped = 0;
    f->cfg.chain_scale_sigmas = 0.0; /* steps of one length: 10 units, not 10 times a gain */
    free(f->mem);
    open_vo(f);
    for (int k = 0; k < 40; ++k) {
        const int64_t t = k == 0 ? 1000000000LL : 1000001000LL + (k - 1) * 50000000LL;
        tvo_pose T = tvo_pose_identity();
        tvo_image img = tvo_image_make(W, H, W, f->img);
        tvo_vo_result res;
        for (int i = 0; i < 3; ++i)
            T.t[i] = dir[i] * 0.06 * (k == 0 ? 0.0 : (double)(k - 1) + 1e-5);
        render(&T, f->img);
        assert_int_equal(tvo_vo_process(f->vo, &img, t, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        if (res.map_state == TVO_MAP_TRACKING)
            mapped++;
        if (k > 1 && res.state == TVO_VO_OK && res.map_state == TVO_MAP_INITIALISING) {
            const double len = dist3(res.T_w_c.t, prev);
            if (getenv("TVO_TEST_VERBOSE") != NULL)
                fprintf(stderr, "short first interval, frame %2d: step %.3f\n", k, len);
            assert_true(len <= 10.0 + 1e-9);
            checked++;
        }
        memcpy(prev, res.T_w_c.t, sizeof(prev));
    }
    assert_true(checked >= 5);
    assert_true(mapped > 0);
}

/* Pure rotation: no translation, so never a relative scale. */
static void test_relative_scale_rotation_only(void **state)
{
    fixture *f = *state;
    const double dir[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k < 8; ++k) {
        tvo_pose T = motion(k, dir, 0.0, 0.8);
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, f->img);
        render(&T, f->img);
        assert_int_equal(tvo_vo_process(f->vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        if (res.state != TVO_VO_OK)
            assert_true(res.rel_scale == TVO_VO_REL_SCALE_NONE);
        assert_true(isfinite(res.rel_scale));
    }
}

/* Keyframe rotation (cfg.keyframe): the camera moves sideways-forward through the room while it turns
 * (step > 0), or only turns (step 0), optionally with uniform grey-level noise of +-noise on every
 * frame. The same frames run with the keyframe rotation off and on; the integrated rotation is compared
 * with ground truth at the end. Off must be the plain frame-to-frame VO (keyframe_age always 0); on
 * must take the keyframe rotation on most frames and keep every step finite and close to the truth.
 * What the room shows (measured when written, and reported rather than asserted): here, with sharp
 * noise-free renders, the frame-to-frame rotation is already ~0.01 deg per step, and the keyframe
 * estimate, made from tracks chained over up to ~20 frames, is not more accurate than chaining:
 * 40 frames of 3 cm, 0.5 deg/frame: 0.11 deg off, 0.27 deg on at the end; 30 frames of pure rotation:
 * 0.027 / 0.031 deg;
 * with +-8 grey levels of noise, 60 frames of 2 cm: 0.35 / 0.22 deg, 40 frames of 5 cm: 0.12 / 0.43 deg.
 * The gain measured on the EuRoC renders (docs/geometry.md, "Keyframe rotation") comes from
 * frame-to-frame rotation errors of ~0.1-0.3 deg per step that do not average out. */
static void run_chain(int keyframe, int frames, double step, int noise, double *end_err, double *max_dir_err,
                      int *kf_frames)
{
    tvo_camera cam = test_camera();
    tvo_vo_config cfg;
    tvo_vo *vo = NULL;
    uint8_t *img_px = malloc(W * H);
    void *mem;
    size_t need;
    tvo_pose prev = tvo_pose_identity(), T0 = tvo_pose_identity();
    tvo_traj traj;
    const double dir[3] = {0.5, 0.05, 0.86};
    uint64_t seed = 7;
    tvo_vo_config_default(&cfg, &cam);
    cfg.keyframe = keyframe;
    need = tvo_vo_required_size(&cfg);
    mem = malloc(need);
    assert_non_null(mem);
    assert_non_null(img_px);
    assert_int_equal(tvo_vo_init(&vo, &cfg, mem, need), TVO_OK);
    *max_dir_err = 0.0;
    *kf_frames = 0;
    for (int k = 0; k < frames; ++k) {
        tvo_pose T = motion(k, dir, step, 0.5);
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, img_px);
        T.t[2] -= 1.5; /* start near the back wall, looking at the far one */
        if (k == 0) {
            T0 = T;
            tvo_traj_init(&traj, &T0);
        }
        render(&T, img_px);
        for (int i = 0; i < W * H && noise > 0; ++i) {
            const int v = img_px[i] + (int)(tvo_test_rand(&seed) % (uint64_t)(2 * noise + 1)) - noise;
            img_px[i] = (uint8_t)(v < 0 ? 0 : (v > 255 ? 255 : v));
        }
        assert_int_equal(tvo_vo_process(vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        if (k > 0) {
            tvo_pose gt = tvo_pose_relative(&prev, &T);
            const double len = sqrt(gt.t[0] * gt.t[0] + gt.t[1] * gt.t[1] + gt.t[2] * gt.t[2]);
            assert_true(res.state == TVO_VO_OK || res.state == TVO_VO_ROTATION_ONLY);
            if (res.state == TVO_VO_OK) {
                const double e = angle_between(res.T_prev_cur.t, gt.t) * 180.0 / M_PI;
                *max_dir_err = e > *max_dir_err ? e : *max_dir_err;
            }
            if (!keyframe)
                assert_int_equal(res.keyframe_age, 0);
            *kf_frames += res.keyframe_age > 0;
            assert_int_equal(tvo_traj_step(&traj, &res.T_prev_cur, len), TVO_OK);
            assert_true(rot_err_deg(&res.T_prev_cur, &gt) < 0.2);
            if (getenv("TVO_TEST_VERBOSE") != NULL)
                fprintf(stderr,
                        "kf %d frame %2d: state %d age %d par %.3f step rot err %.4f chained %.4f dir %.2f "
                        "inl %d\n",
                        keyframe, k, (int)res.state, (int)res.keyframe_age, res.parallax_deg,
                        rot_err_deg(&res.T_prev_cur, &gt), rot_err_deg(&traj.T_w_c, &T),
                        res.state == TVO_VO_OK ? angle_between(res.T_prev_cur.t, gt.t) * 180.0 / M_PI : 0.0,
                        (int)res.inliers);
        }
        prev = T;
    }
    *end_err = rot_err_deg(&traj.T_w_c, &prev);
    free(mem);
    free(img_px);
}

static void test_keyframe_rotation(void **state)
{
    /* step (m), noise (grey levels), frames; the end errors noted above are printed */
    static const struct {
        double step;
        int noise, frames;
    } runs[] = {{0.03, 0, 40}, {0.0, 0, 30}, {0.02, 8, 60}};
    (void)state;
    for (size_t r = 0; r < sizeof(runs) / sizeof(runs[0]); ++r) {
        double off_err, on_err, off_dir, on_dir;
        int off_kf, on_kf;
        const int frames = runs[r].frames;
        run_chain(0, frames, runs[r].step, runs[r].noise, &off_err, &off_dir, &off_kf);
        run_chain(1, frames, runs[r].step, runs[r].noise, &on_err, &on_dir, &on_kf);
        fprintf(stderr,
                "keyframe rotation, step %.2f m, noise %d: rotation error after %d frames %.4f deg off, "
                "%.4f deg on (%d frames with the keyframe rotation); max direction error %.2f / %.2f deg\n",
                runs[r].step, runs[r].noise, frames, off_err, on_err, on_kf, off_dir, on_dir);
        assert_int_equal(off_kf, 0);
        assert_true(on_kf >= (frames - 1) * 3 / 4);
        assert_true(on_err < 1.0 && off_err < 1.0);
        if (runs[r].step > 0.0 && runs[r].noise == 0)
            assert_true(on_dir < 15.0);
    }
}

/* Track prediction (cfg.track_prediction): a camera yawing 7 deg a frame (31 px at f = 250) while it moves,
 * with LK on level 0 only (no pyramid: it reaches about 20-25 px without a guess here). With the
 * prediction every frame after the first two (the second one gives the first rotation) has a pose with a
 * rotation within 0.5 deg; without it most are lost. Gives the frames with a pose and the worst rotation
 * error over them. */
#define YAW_DEG 7.0
static void run_fast_yaw(int predict, int frames, int *posed, double *max_err)
{
    tvo_vo_config cfg;
    tvo_camera cam = test_camera();
    tvo_vo *vo;
    void *mem;
    uint8_t *px = malloc(W * H);
    const double dir[3] = {0.3, 0.0, 1.0};
    tvo_pose prev = tvo_pose_identity();
    assert_non_null(px);
    tvo_vo_config_default(&cfg, &cam);
    assert_int_equal(cfg.track_prediction, 0);
    cfg.lk.max_level = 0;
    cfg.track_prediction = predict;
    mem = malloc(tvo_vo_required_size(&cfg));
    assert_non_null(mem);
    assert_int_equal(tvo_vo_init(&vo, &cfg, mem, tvo_vo_required_size(&cfg)), TVO_OK);
    *posed = 0;
    *max_err = 0.0;
    for (int k = 0; k < frames; ++k) {
        tvo_pose T = motion(k, dir, 0.02, YAW_DEG);
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, px);
        render(&T, px);
        assert_int_equal(tvo_vo_process(vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_prev_cur));
        if (k >= 2 && (res.state == TVO_VO_OK || res.state == TVO_VO_ROTATION_ONLY)) {
            tvo_pose gt = tvo_pose_relative(&prev, &T);
            double e = rot_err_deg(&res.T_prev_cur, &gt);
            (*posed)++;
            *max_err = e > *max_err ? e : *max_err;
        }
        prev = T;
    }
    free(mem);
    free(px);
}

static void test_track_prediction(void **state)
{
    int on, off;
    double on_err, off_err;
    (void)state;
    run_fast_yaw(1, 14, &on, &on_err);
    run_fast_yaw(0, 14, &off, &off_err);
    fprintf(stderr,
            "fast yaw, 12 frames after the first two: %d with a pose (max rotation error %.3f deg) with "
            "the prediction, %d (%.3f deg) without\n",
            on, on_err, off, off_err);
    assert_int_equal(on, 12);
    assert_true(on_err < 0.5);
    assert_true(off < 6);
}

#if TVO_WITH_AFFINE
/* The room point a pixel of camera T_w_c sees (tvo_room_cast, the renderer's geometry), and the pixel a
 * world point projects to. */
static void room_point(const tvo_pose *T_w_c, double x, double y, double X[3])
{
    const double dc[3] = {(x - (W - 1) / 2.0) / FOCAL, (y - (H - 1) / 2.0) / FOCAL, 1.0};
    double d[3], u, v;
    uint32_t wall;
    const double len = tvo_room_cast(T_w_c, dc, d, &u, &v, &wall);
    for (int i = 0; i < 3; ++i)
        X[i] = T_w_c->t[i] + len * d[i];
}

static void room_project(const tvo_pose *T_w_c, const double X[3], double *x, double *y)
{
    const tvo_pose T_c_w = tvo_pose_inverse(T_w_c);
    double q[3];
    tvo_pose_transform_point(&T_c_w, X, q);
    *x = FOCAL * q[0] / q[2] + (W - 1) / 2.0;
    *y = FOCAL * q[1] / q[2] + (H - 1) / 2.0;
}

/* A walk towards the far wall (2 cm a frame, 60 frames, a slow sway): each track's distance from where
 * the room point it was detected on projects, for the tracks at least 20 frames old at the end. Returns
 * the median of those distances and their count. */
#define AFF_FRAMES 60
#define AFF_MAX_IDS 4096

/* The walk's camera at frame k. */
static tvo_pose walk_pose(int k)
{
    const double dir[3] = {0.1, 0.05, 1.0};
    return motion(k, dir, 0.02, 0.2);
}
static double run_walk_tracks(int32_t affine, int32_t at_keyframes, double end_share, int *count, long aff[3])
{
    static double X0[AFF_MAX_IDS][3];
    static uint8_t have[AFF_MAX_IDS];
    double err[300];
    int ne = 0;
    fixture f;
    tvo_camera cam = test_camera();
    tvo_vo_track t[300];
    int32_t n = 0;
    tvo_pose T = tvo_pose_identity();
    memset(have, 0, sizeof(have));
    aff[0] = aff[1] = aff[2] = 0;
    tvo_vo_config_default(&f.cfg, &cam);
    f.cfg.affine_win_size = affine;
    f.cfg.affine_at_keyframes = at_keyframes;
    f.cfg.affine_end_share = end_share;
    open_vo(&f);
    for (int k = 0; k < AFF_FRAMES; ++k) {
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, f.img);
        T = walk_pose(k);
        render(&T, f.img);
        assert_int_equal(tvo_vo_process(f.vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        assert_true(res.affine_refined >= 0 && res.affine_refined <= res.affine_tried);
        /* a track is ended only when its alignment failed, and only in a frame where at most end_share of
           the alignments failed (the border cases, counted in tried, make that share smaller still) */
        assert_true(res.affine_ended >= 0 && res.affine_ended <= res.affine_tried - res.affine_refined);
        assert_true(res.affine_ended == 0 || res.affine_ended <= end_share * res.affine_tried);
        aff[0] += res.affine_tried;
        aff[1] += res.affine_refined;
        aff[2] += res.affine_ended;
        assert_int_equal(tvo_vo_tracks(f.vo, t, 300, &n), TVO_OK);
        for (int32_t i = 0; i < n && i < 300; ++i)
            if (t[i].age == 0 && t[i].id < AFF_MAX_IDS) {
                room_point(&T, t[i].x, t[i].y, X0[t[i].id]);
                have[t[i].id] = 1;
            }
    }
    for (int32_t i = 0; i < n && i < 300; ++i) {
        double x, y;
        if (t[i].age < 20 || t[i].id >= AFF_MAX_IDS || !have[t[i].id])
            continue;
        room_project(&T, X0[t[i].id], &x, &y);
        err[ne++] = hypot(t[i].x - x, t[i].y - y);
    }
    free(f.mem);
    *count = ne;
    if (ne == 0)
        return 1e9;
    for (int i = 1; i < ne; ++i) /* insertion sort: a few hundred values */
        for (int j = i; j > 0 && err[j] < err[j - 1]; --j) {
            const double e = err[j];
            err[j] = err[j - 1];
            err[j - 1] = e;
        }
    return err[ne / 2];
}

/* The affine refinement (cfg.affine_win_size) keeps tracks on the points they were detected on while the
 * camera walks towards a wall (the patches grow by 30 % over the walk); translation-only LK drifts. At
 * keyframes only (cfg.affine_at_keyframes), the drift since the last keyframe is left: less than
 * without the refinement, more than with it on every frame. */
static void test_affine_refinement(void **state)
{
    int n_on, n_off, n_kf, n_end;
    long a_on[3], a_off[3], a_kf[3], a_end[3];
    const double on = run_walk_tracks(21, 0, 0.0, &n_on, a_on),
                 off = run_walk_tracks(0, 0, 0.0, &n_off, a_off);
    const double kf = run_walk_tracks(21, 1, 0.0, &n_kf, a_kf);
    const double end = run_walk_tracks(21, 0, 0.1, &n_end, a_end);
    (void)state;
    fprintf(stderr,
            "walk, affine refinements (tried / refined): %ld / %ld every frame, %ld / %ld at keyframes\n",
            a_on[0], a_on[1], a_kf[0], a_kf[1]);
    /* the result counts the refinement's attempts and successes: none without it, most of them on this
       textured scene, and at keyframes only a fraction of the attempts of every frame */
    assert_true(a_off[0] == 0 && a_off[1] == 0);
    assert_true(a_on[0] > 1000 && a_on[1] >= a_on[0] * 9 / 10);
    assert_true(a_kf[0] > 0 && a_kf[0] < a_on[0] / 2 && a_kf[1] <= a_kf[0]);
    fprintf(stderr,
            "walk, tracks at least 20 frames old: median error %.3f px (%d tracks) with the affine "
            "refinement, %.3f px (%d) with it at keyframes only, %.3f px (%d) without\n",
            on, n_on, kf, n_kf, off, n_off);
    assert_true(n_on >= 50 && n_off >= 50 && n_kf >= 50);
    assert_true(on < 0.15);
    assert_true(on < 0.5 * off);
    assert_true(kf < 0.3 * off);
    /* cfg.affine_end_share: off, no track is ended; at 0.1 on this sharp scene the few tracks whose
       alignment fails are ended, and the tracks that stay are as accurate */
    fprintf(stderr,
            "walk, affine_end_share 0.1: %ld of %ld alignments failed, %ld tracks ended; "
            "median error %.3f px (%d tracks)\n",
            a_end[0] - a_end[1], a_end[0], a_end[2], end, n_end);
    assert_true(a_on[2] == 0 && a_kf[2] == 0 && a_off[2] == 0);
    assert_true(a_end[2] > 0 && a_end[2] <= a_end[0] - a_end[1]);
    assert_true(n_end >= 50);
    assert_true(end < 0.15);
}

/* cfg.map_refind (and map_refind_rescue): the walk of run_walk_tracks with a flat bar `bar` pixels wide
 * from a quarter of the frame on, for two frames (frames 36 and 37), which ends the tracks under it. Counts the landmarks found again and, for each
 * track that carries a landmark from its first frame on (a landmark found again: a detected track waits
 * for its triangulation), its distance from the nearest point seen before the bar by a landmark track
 * that the bar ended (err[]: the truth, from the renderer's geometry, projected into that frame). */
#define OCC_FIRST 36
#define OCC_FRAMES 2
static void run_occluded_walk(int32_t refind, int32_t rescue, int bar, long *refound, int *lost_frames,
                              double *err, int *ne)
{
    static double X0[AFF_MAX_IDS][3];
    static uint8_t have[AFF_MAX_IDS], ended[AFF_MAX_IDS];
    fixture f;
    tvo_camera cam = test_camera();
    tvo_vo_track t[300];
    int32_t n = 0;
    uint32_t before[300];
    int32_t nb = 0;
    memset(have, 0, sizeof(have));
    memset(ended, 0, sizeof(ended));
    *refound = 0;
    *lost_frames = 0;
    *ne = 0;
    tvo_vo_config_default(&f.cfg, &cam);
    f.cfg.map_refind = refind;
    f.cfg.map_refind_rescue = rescue;
    open_vo(&f);
    for (int k = 0; k < AFF_FRAMES; ++k) {
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, f.img);
        const tvo_pose T = walk_pose(k);
        render(&T, f.img);
        if (k >= OCC_FIRST && k < OCC_FIRST + OCC_FRAMES)
            for (int y = 0; y < H; ++y)
                memset(f.img + (size_t)y * W + W / 4, 128, (size_t)bar);
        assert_int_equal(tvo_vo_process(f.vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        assert_true(res.map_refound >= 0 && res.map_refound <= res.tracks);
        assert_true(refind > 0 || res.map_refound == 0);
        *refound += res.map_refound;
        *lost_frames += res.map_state != TVO_MAP_TRACKING && res.map_state != TVO_MAP_INITIALISED && k > 20;
        assert_int_equal(tvo_vo_tracks(f.vo, t, 300, &n), TVO_OK);
        for (int32_t i = 0; i < n && i < 300; ++i) {
            if (t[i].id >= AFF_MAX_IDS)
                continue;
            if (t[i].age == 0) {
                room_point(&T, t[i].x, t[i].y, X0[t[i].id]);
                have[t[i].id] = 1;
            }
            if (t[i].age == 0 && t[i].landmark && k >= OCC_FIRST && *ne < 300) {
                /* a landmark found again: the nearest of the points the bar took from the map's tracks */
                double best = 1e9;
                for (uint32_t id = 0; id < AFF_MAX_IDS; ++id) {
                    double x, y;
                    if (!ended[id])
                        continue;
                    room_project(&T, X0[id], &x, &y);
                    if (hypot(t[i].x - x, t[i].y - y) < best)
                        best = hypot(t[i].x - x, t[i].y - y);
                }
                err[(*ne)++] = best;
            }
        }
        if (k == OCC_FIRST - 1) { /* the landmark tracks before the bar */
            nb = 0;
            for (int32_t i = 0; i < n && i < 300; ++i)
                if (t[i].landmark && t[i].id < AFF_MAX_IDS && have[t[i].id])
                    before[nb++] = t[i].id;
        }
        if (k == OCC_FIRST + OCC_FRAMES - 1) /* ...and those the bar ended */
            for (int32_t b = 0; b < nb; ++b) {
                int alive = 0;
                for (int32_t i = 0; i < n && i < 300 && !alive; ++i)
                    alive = t[i].id == before[b];
                ended[before[b]] = (uint8_t)!alive;
            }
    }
    free(f.mem);
}

/* cfg.map_refind: the landmarks whose tracks the bar ended are found again where they are when it
 * leaves, on the points they were made from; off, none is. */
static void test_map_refind(void **state)
{
    static double err_on[300], err_off[300];
    long found_on, found_off;
    int lost_on, lost_off, n_on, n_off, within = 0;
    (void)state;
    run_occluded_walk(64, 0, W / 4, &found_on, &lost_on, err_on, &n_on);
    run_occluded_walk(0, 0, W / 4, &found_off, &lost_off, err_off, &n_off);
    for (int i = 1; i < n_on; ++i) /* insertion sort: a few dozen values */
        for (int j = i; j > 0 && err_on[j] < err_on[j - 1]; --j) {
            const double e = err_on[j];
            err_on[j] = err_on[j - 1];
            err_on[j - 1] = e;
        }
    for (int i = 0; i < n_on; ++i)
        within += err_on[i] < 1.0;
    fprintf(stderr,
            "occluded walk, map_refind 64: %ld landmarks found again, %d of them within 1 px of a point the "
            "bar took (median %.3f px); off: %ld found, %d tracks born with a landmark\n",
            found_on, within, n_on > 0 ? err_on[n_on / 2] : -1.0, found_off, n_off);
    assert_int_equal(lost_on, 0);
    assert_int_equal(lost_off, 0);
    assert_int_equal(found_off, 0);
    assert_int_equal(n_off, 0);
    assert_true(found_on >= 10);
    assert_int_equal(n_on, found_on);
    assert_true(within >= n_on * 9 / 10);
    assert_true(err_on[n_on / 2] < 0.3);
}

/* cfg.map_refind_rescue: the landmarks are looked for only while the map runs short of points. A bar over
 * a quarter of the frame leaves the map enough: nothing is found again. One over three quarters leaves
 * it short: they are found again, on their points. */
static void test_map_refind_rescue(void **state)
{
    static double err[300];
    long found_quarter, found_most;
    int lost_quarter, lost_most, n_quarter, n_most, within = 0;
    (void)state;
    run_occluded_walk(64, 1, W / 4, &found_quarter, &lost_quarter, err, &n_quarter);
    run_occluded_walk(64, 1, W * 3 / 4, &found_most, &lost_most, err, &n_most);
    for (int i = 0; i < n_most; ++i)
        within += err[i] < 1.0;
    fprintf(stderr,
            "occluded walk, map_refind 64 as a rescue: a quarter hidden, %ld found again; three quarters, "
            "%ld "
            "found again, %d of them within 1 px of a point the bar took\n",
            found_quarter, found_most, within);
    assert_int_equal(lost_quarter, 0);
    assert_int_equal(lost_most, 0);
    assert_int_equal(found_quarter, 0);
    assert_true(found_most >= 10);
    assert_int_equal(n_most, found_most);
    assert_true(within >= n_most * 9 / 10);
}
#else
/* A build without the affine refinement (TVO_WITH_AFFINE 0) refuses a configuration that asks for it,
 * with its own status, and runs without it. */
static void test_affine_refinement(void **state)
{
    tvo_camera cam = test_camera();
    tvo_vo_config cfg;
    tvo_vo *vo = NULL;
    uint8_t mem[64];
    (void)state;
    tvo_vo_config_default(&cfg, &cam);
    assert_int_equal(cfg.affine_win_size, 0);
    assert_true(tvo_vo_required_size(&cfg) > 0);
    cfg.affine_win_size = 21;
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
    assert_int_equal(tvo_vo_init(&vo, &cfg, mem, sizeof(mem)), TVO_ERR_UNSUPPORTED);
    assert_null(vo);
    /* the map's inlier gate is left out with it */
    tvo_vo_config_default(&cfg, &cam);
    cfg.map_inlier_sigmas = 4.0;
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
    assert_int_equal(tvo_vo_init(&vo, &cfg, mem, sizeof(mem)), TVO_ERR_UNSUPPORTED);
    assert_null(vo);
    /* and so are the landmarks' priors */
    tvo_vo_config_default(&cfg, &cam);
    cfg.map_lm_prior = 1.0;
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
    assert_int_equal(tvo_vo_init(&vo, &cfg, mem, sizeof(mem)), TVO_ERR_UNSUPPORTED);
    assert_null(vo);
}
#endif

/* Cells of an 8 x 6 grid over the frame that hold one of the VO's tracks. */
static int covered_cells(const tvo_vo *vo)
{
    tvo_vo_track t[300];
    int32_t n = 0;
    int cells[48] = {0}, c = 0;
    assert_int_equal(tvo_vo_tracks(vo, t, 300, &n), TVO_OK);
    for (int32_t i = 0; i < n && i < 300; ++i) {
        const int cx = (int)(t[i].x * 8.0f / W), cy = (int)(t[i].y * 6.0f / H);
        cells[(cy < 5 ? cy : 5) * 8 + (cx < 7 ? cx : 7)] = 1;
    }
    for (int i = 0; i < 48; ++i)
        c += cells[i];
    return c;
}

/* A steady turn (1 deg a frame, 30 frames): the tracks leave on one side and the other side empties while
 * their count stays above min_tracks. With cfg.redetect_coverage the VO re-detects into the empty side;
 * without it no corner is added and the tracks end up on part of the frame. */
static void run_turn(double coverage, int *redetections, int *min_cells, int *last_cells)
{
    fixture f;
    tvo_camera cam = test_camera();
    tvo_pose prev = tvo_pose_identity();
    tvo_vo_config_default(&f.cfg, &cam);
    f.cfg.min_tracks = 100;
    f.cfg.redetect_coverage = coverage;
    open_vo(&f);
    *redetections = 0;
    *min_cells = 48;
    for (int k = 0; k < 30; ++k) {
        const double zero[3] = {0.0, 0.0, 0.0};
        tvo_pose T = motion(k, zero, 0.0, 1.0);
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, f.img);
        int c;
        render(&T, f.img);
        assert_int_equal(tvo_vo_process(f.vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        if (k > 0) {
            tvo_pose gt = tvo_pose_relative(&prev, &T);
            assert_true(res.state == TVO_VO_OK || res.state == TVO_VO_ROTATION_ONLY);
            assert_true(rot_err_deg(&res.T_prev_cur, &gt) < 0.2);
            assert_true(res.tracked >= f.cfg.min_tracks); /* the count alone never asks for corners */
            *redetections += res.new_corners > 0;
        }
        c = covered_cells(f.vo);
        *min_cells = c < *min_cells ? c : *min_cells;
        *last_cells = c;
        prev = T;
    }
    free(f.mem);
}

/* Frame k of the walk of run_exposure_step() (motion() along (0.1, 0.05, 1), 2 cm a frame, 0.3 deg of yaw)
 * into img, every grey level times `gain` (rounded, saturated; 1: as rendered); returns its pose. */
static tvo_pose render_walk(int k, double gain, uint8_t *img)
{
    const double dir[3] = {0.1, 0.05, 1.0};
    const tvo_pose T = motion(k, dir, 0.02, 0.3);
    render(&T, img);
    if (gain != 1.0)
        for (int i = 0; i < W * H; ++i) {
            const double v = floor(img[i] * gain + 0.5);
            img[i] = (uint8_t)(v > 255.0 ? 255.0 : v);
        }
    return T;
}

/* A walk with an exposure step: from frame 10 on every frame's grey levels are times `gain` (rounded,
 * saturated). Counts the LOST frames and the frames re-tracked after the step; *step_tracked: the tracks
 * LK kept into frame 10 of those into frame 9; *rot_err: the largest rotation error of the two-view
 * steps from frame 8 on (deg). */
static void run_exposure_step(int32_t retry, double gain, int *lost, int *retried, double *step_tracked,
                              double *rot_err)
{
    int32_t before = 0;
    fixture f;
    tvo_camera cam = test_camera();
    tvo_pose T_prev = tvo_pose_identity();
    tvo_vo_config_default(&f.cfg, &cam);
    assert_int_equal(f.cfg.gain_retry, 1);
    f.cfg.gain_retry = retry;
    open_vo(&f);
    *lost = *retried = 0;
    *rot_err = 0.0;
    for (int k = 0; k < 20; ++k) {
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, f.img);
        const tvo_pose T = render_walk(k, k >= 10 ? gain : 1.0, f.img);
        assert_int_equal(tvo_vo_process(f.vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        *lost += k > 0 && res.state == TVO_VO_LOST;
        *retried += res.gain_retry;
        if (k == 9)
            before = res.tracks;
        if (k == 10)
            *step_tracked = (double)res.tracked / (double)before;
        if (k >= 8 && (res.state == TVO_VO_OK || res.state == TVO_VO_ROTATION_ONLY)) {
            const tvo_pose inv = tvo_pose_inverse(&T_prev), truth = tvo_pose_compose(&inv, &T);
            const double e = rot_err_deg(&res.T_prev_cur, &truth);
            *rot_err = e > *rot_err ? e : *rot_err;
        }
        T_prev = T;
    }
    free(f.mem);
}

/* An exposure step of 0.6 (a light switched off) makes LK lose most tracks without the gain retry; with
 * it (the default) the frame is tracked again on the scaled previous pyramid and keeps nearly all. A
 * step of 1.05 LK holds by itself (more than 90 % of the tracks kept), so the retry does not run: this
 * case checks that a small step leaves the frame alone, not the retry's 10 % bound, which only a frame
 * where LK lost more than half of the tracks reaches. */
static void test_gain_retry(void **state)
{
    int lost_on, lost_off, retried_on, retried_off, lost_small, retried_small;
    double rot_on, rot_off, rot_small, kept_on = 0.0, kept_off = 0.0, kept_small = 0.0;
    (void)state;
    run_exposure_step(1, 0.6, &lost_on, &retried_on, &kept_on, &rot_on);
    run_exposure_step(0, 0.6, &lost_off, &retried_off, &kept_off, &rot_off);
    run_exposure_step(1, 1.05, &lost_small, &retried_small, &kept_small, &rot_small);
    fprintf(stderr,
            "exposure step 0.6 at frame 10 of 20: %.0f %% of the tracks kept, %d re-tracked, %d LOST, max "
            "rotation error %.3f deg with the gain retry; %.0f %%, %d, %d, %.3f deg without; step 1.05: "
            "%.0f %%, %d re-tracked\n",
            100.0 * kept_on, retried_on, lost_on, rot_on, 100.0 * kept_off, retried_off, lost_off, rot_off,
            100.0 * kept_small, retried_small);
    assert_int_equal(retried_off, 0);
    assert_true(kept_off < 0.5);
    assert_int_equal(retried_on, 1);
    assert_true(kept_on > 0.9);
    assert_int_equal(lost_on, 0);
    assert_true(rot_on < 0.2);
    assert_int_equal(retried_small, 0);
    assert_true(kept_small > 0.9);
}

/* The walk's first frame with every grey level times `gain` (render_walk()): the corners the VO starts
 * with, with fast_range_ref `ref`; *tracked: the tracks LK keeps into the second frame, 2 cm on. */
static int32_t dark_first_corners(double gain, int32_t ref, int32_t *tracked)
{
    fixture f;
    tvo_camera cam = test_camera();
    int32_t corners = 0;
    tvo_vo_config_default(&f.cfg, &cam);
    f.cfg.fast_range_ref = ref;
    open_vo(&f);
    for (int k = 0; k < 2; ++k) {
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, f.img);
        (void)render_walk(k, gain, f.img);
        assert_int_equal(tvo_vo_process(f.vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        if (k == 0)
            corners = res.new_corners;
        else
            *tracked = res.tracked;
    }
    free(f.mem);
    return corners;
}

/* fast_range_ref: a frame at a fifth of its exposure keeps its corners when the FAST thresholds follow
 * the frame's grey-level range (255), and loses nearly half of them with fixed thresholds (0). */
static void test_dark_frames(void **state)
{
    int32_t tr[4] = {0, 0, 0, 0};
    const int32_t bright0 = dark_first_corners(1.0, 0, &tr[0]), dark0 = dark_first_corners(0.2, 0, &tr[1]);
    const int32_t bright = dark_first_corners(1.0, 255, &tr[2]), dark = dark_first_corners(0.2, 255, &tr[3]);
    tvo_vo_config cfg;
    tvo_camera cam = test_camera();
    (void)state;
    fprintf(stderr,
            "first frame's corners (tracked into the second), fixed thresholds: %d (%d) bright, %d (%d) at "
            "0.2; following the range: %d (%d), %d (%d)\n",
            bright0, tr[0], dark0, tr[1], bright, tr[2], dark, tr[3]);
    assert_true(dark0 <= bright0 * 6 / 10); /* measured: 163 of 300 */
    assert_true(dark >= bright * 8 / 10);
    assert_true(tr[3] >= tr[2] * 8 / 10);
    /* the setting's range */
    tvo_vo_config_default(&cfg, &cam);
    assert_int_equal(cfg.fast_range_ref, 0);
    cfg.fast_range_ref = 256;
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
    cfg.fast_range_ref = -1;
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
}

/* The walk of render_walk() for 40 frames with the bottom third of every frame blinking: fresh noise on
 * even frames, a flat grey on odd ones (every corner found there dies in the next frame), with
 * redetect_cell_kept `share`: the corners detected from frame 10 on in that strip and above it, the
 * frames LOST and the largest rotation error of the steps. */
static void run_blink(double share, int32_t *strip, int32_t *above, int *lost, double *rot_err)
{
    enum { TOP = 2 * H / 3 };
    fixture f;
    tvo_camera cam = test_camera();
    tvo_pose T_prev = tvo_pose_identity();
    tvo_vo_track *tk;
    uint64_t rs = 7;
    tvo_vo_config_default(&f.cfg, &cam);
    assert_true(f.cfg.redetect_cell_kept == 0.0);
    f.cfg.redetect_cell_kept = share;
    f.cfg.max_tracks = f.cfg.min_tracks = 500; /* room for new corners on every frame, as on KITTI */
    open_vo(&f);
    tk = malloc((size_t)f.cfg.max_tracks * sizeof(*tk));
    assert_non_null(tk);
    *strip = *above = *lost = 0;
    *rot_err = 0.0;
    for (int k = 0; k < 40; ++k) {
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, f.img);
        const tvo_pose T = render_walk(k, 1.0, f.img);
        int32_t nt = 0;
        for (int i = TOP * W; i < W * H; ++i) { /* noise on even frames, flat grey on odd ones */
            rs = rs * 6364136223846793005ULL + 1442695040888963407ULL;
            f.img[i] = (uint8_t)(k % 2 ? 128 : rs >> 56);
        }
        assert_int_equal(tvo_vo_process(f.vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        *lost += k > 0 && res.state == TVO_VO_LOST;
        assert_int_equal(tvo_vo_tracks(f.vo, tk, f.cfg.max_tracks, &nt), TVO_OK);
        for (int32_t i = 0; i < nt && k >= 10; ++i) {
            if (tk[i].age == 0) {
                if (tk[i].y >= (float)TOP)
                    ++*strip;
                else
                    ++*above;
            }
        }
        if (k > 0 && (res.state == TVO_VO_OK || res.state == TVO_VO_ROTATION_ONLY)) {
            const tvo_pose inv = tvo_pose_inverse(&T_prev), truth = tvo_pose_compose(&inv, &T);
            const double e = rot_err_deg(&res.T_prev_cur, &truth);
            *rot_err = e > *rot_err ? e : *rot_err;
        }
        T_prev = T;
    }
    free(tk);
    free(f.mem);
}

/* redetect_cell_kept: with a blinking strip across the bottom of every frame, the default (0) detects
 * corners there on every other frame, and they die at once; with 0.15 the strip's cells close and take a few
 * corners only when they open again, while the corners above it and the poses are as good as before.
 * The setting's range. */
static void test_redetect_cell_kept(void **state)
{
    int32_t strip_off, above_off, strip_on, above_on;
    int lost_off, lost_on;
    double rot_off, rot_on;
    tvo_vo_config cfg;
    tvo_camera cam = test_camera();
    (void)state;
    run_blink(0.0, &strip_off, &above_off, &lost_off, &rot_off);
    run_blink(0.15, &strip_on, &above_on, &lost_on, &rot_on);
    fprintf(stderr,
            "a blinking strip, frames 10-39: corners detected in it / above it %d / %d (max rotation error "
            "%.3f deg, %d LOST) with every cell open; %d / %d (%.3f deg, %d LOST) with cells closed "
            "below 15 %% kept\n",
            strip_off, above_off, rot_off, lost_off, strip_on, above_on, rot_on, lost_on);
    /* measured: 1342 in the strip with every cell open (every noise frame refills it), 338 with the
       cells closed (they take a few corners when they open again) */
    assert_true(strip_off >= 15 * 30);
    assert_true(strip_on * 3 <= strip_off);
    assert_true(above_on * 10 >= above_off * 8);
    assert_int_equal(lost_on, 0);
    assert_true(rot_on < 0.2);
    tvo_vo_config_default(&cfg, &cam);
    cfg.redetect_cell_kept = 1.0;
    assert_true(tvo_vo_required_size(&cfg) > 0);
    cfg.redetect_cell_kept = 1.5;
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
    cfg.redetect_cell_kept = -0.1;
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
    cfg.redetect_cell_kept = NAN;
    assert_int_equal(tvo_vo_required_size(&cfg), 0);
}

static void test_redetect_coverage(void **state)
{
    int on_det, on_min, on_last, off_det, off_min, off_last;
    (void)state;
    run_turn(0.75, &on_det, &on_min, &on_last);
    run_turn(0.0, &off_det, &off_min, &off_last);
    fprintf(stderr,
            "turn, 30 frames: %d re-detections, %d-%d of 48 cells covered (last %d) with the coverage "
            "rule; %d, %d-%d (last %d) without\n",
            on_det, on_min, 48, on_last, off_det, off_min, 48, off_last);
    /* measured: 1 re-detection, at least 36 cells covered with the rule; 29 cells at the end without */
    assert_true(on_det >= 1);
    assert_true(on_min >= 33);
    assert_int_equal(off_det, 0);
    assert_true(off_last <= 32);
}

/* The step-length filter: propagation, the prior's pull, its log/exp against libm, bad input. */
static void test_scale_filter(void **state)
{
    tvo_scale_filter f;
    double s = -1.0;
    (void)state;
    /* propagation (alpha 0) from a seed: s_k = r_k s_(k-1); r not available: carried */
    assert_int_equal(tvo_scale_filter_init(&f, 0.0), TVO_OK);
    assert_int_equal(tvo_scale_filter_update(&f, 1.5, 0.0, &s), TVO_ERR_RANGE); /* nothing to start from */
    assert_true(s == 0.0);
    assert_int_equal(tvo_scale_filter_seed(&f, 0.04), TVO_OK);
    assert_int_equal(tvo_scale_filter_update(&f, 1.5, 0.0, &s), TVO_OK);
    assert_true(fabs(s - 0.06) < 1e-14);
    assert_int_equal(tvo_scale_filter_update(&f, TVO_VO_REL_SCALE_NONE, 0.0, &s), TVO_OK);
    assert_true(fabs(s - 0.06) < 1e-14);
    assert_int_equal(tvo_scale_filter_update(&f, NAN, 0.0, &s), TVO_OK); /* treated as not available */
    assert_true(fabs(s - 0.06) < 1e-14);
    assert_int_equal(tvo_scale_filter_update(&f, 0.25, 1.0, &s), TVO_OK); /* alpha 0 ignores the prior */
    assert_true(fabs(s - 0.015) < 1e-14);
    /* without a seed the prior starts it; alpha 1 is the prior alone; 0 < alpha < 1: geometric blend */
    assert_int_equal(tvo_scale_filter_init(&f, 1.0), TVO_OK);
    assert_int_equal(tvo_scale_filter_update(&f, 2.0, 0.03, &s), TVO_OK);
    assert_true(fabs(s - 0.03) < 1e-14);
    assert_int_equal(tvo_scale_filter_update(&f, 2.0, 0.05, &s), TVO_OK);
    assert_true(fabs(s - 0.05) < 1e-14);
    assert_int_equal(tvo_scale_filter_init(&f, 0.25), TVO_OK);
    assert_int_equal(tvo_scale_filter_seed(&f, 0.02), TVO_OK);
    assert_int_equal(tvo_scale_filter_update(&f, 1.1, 0.05, &s), TVO_OK);
    assert_true(fabs(s - pow(0.022, 0.75) * pow(0.05, 0.25)) < 1e-14);
    assert_int_equal(f.steps, 1);
    /* a long run of one ratio converges to the fixed point n r^((1-a)/a) */
    for (int k = 0; k < 400; ++k)
        assert_int_equal(tvo_scale_filter_update(&f, 1.1, 0.05, &s), TVO_OK);
    assert_true(fabs(s / (0.05 * pow(1.1, 3.0)) - 1.0) < 1e-9);
    /* the deterministic log/exp over a wide range of seeds: within 1e-14 of libm */
    for (double x = 1e-8; x < 900.0; x *= 1.37) {
        assert_int_equal(tvo_scale_filter_init(&f, 0.0), TVO_OK);
        assert_int_equal(tvo_scale_filter_seed(&f, x), TVO_OK);
        assert_true(fabs(f.log_s - log(x)) < 1e-13);
        assert_int_equal(tvo_scale_filter_update(&f, 1.0, 0.0, &s), TVO_OK);
        assert_true(fabs(s / x - 1.0) < 1e-13);
    }
    /* runaway ratios saturate at 1e3 m / 1e-9 m, never inf or 0 */
    assert_int_equal(tvo_scale_filter_init(&f, 0.0), TVO_OK);
    assert_int_equal(tvo_scale_filter_seed(&f, 1.0), TVO_OK);
    for (int k = 0; k < 50; ++k)
        assert_int_equal(tvo_scale_filter_update(&f, 1e30, 0.0, &s), TVO_OK);
    assert_true(isfinite(s) && fabs(s / 1e3 - 1.0) < 1e-9);
    for (int k = 0; k < 50; ++k)
        assert_int_equal(tvo_scale_filter_update(&f, 1e-30, 0.0, &s), TVO_OK);
    assert_true(s > 0.0 && fabs(s / 1e-9 - 1.0) < 1e-9);
    /* bad input */
    assert_int_equal(tvo_scale_filter_init(NULL, 0.5), TVO_ERR_NULL);
    assert_int_equal(tvo_scale_filter_init(&f, -0.1), TVO_ERR_ARG);
    assert_int_equal(tvo_scale_filter_init(&f, 1.5), TVO_ERR_ARG);
    assert_int_equal(tvo_scale_filter_init(&f, NAN), TVO_ERR_ARG);
    assert_int_equal(tvo_scale_filter_update(&f, 1.0, 0.05, &s), TVO_ERR_ARG); /* left unusable */
    assert_int_equal(tvo_scale_filter_init(&f, 0.5), TVO_OK);
    assert_int_equal(tvo_scale_filter_seed(&f, 0.0), TVO_ERR_ARG);
    assert_int_equal(tvo_scale_filter_seed(&f, INFINITY), TVO_ERR_ARG);
    assert_int_equal(tvo_scale_filter_seed(NULL, 1.0), TVO_ERR_NULL);
    assert_int_equal(f.has_s, 0);
    assert_int_equal(tvo_scale_filter_update(&f, 1.0, 0.05, NULL), TVO_ERR_NULL);
    assert_int_equal(tvo_scale_filter_update(NULL, 1.0, 0.05, &s), TVO_ERR_NULL);
    assert_true(s == 0.0);
}

/* A weights file of test/data/nn loaded into malloc'd memory (NULL if missing). */
static tvo_nn *load_nn(const char *name, void **mem)
{
    size_t n = 0, need = 0;
    uint8_t *buf = tvo_test_read_nn_file(name, 0, &n);
    tvo_nn *nn = NULL;
    *mem = NULL;
    if (buf != NULL && tvo_nn_required_size(buf, n, &need) == TVO_OK && (*mem = malloc(need)) != NULL &&
        tvo_nn_load(&nn, buf, n, *mem, need) != TVO_OK)
        nn = NULL;
    free(buf);
    return nn;
}

/* tvo_vo_refine with a step-length model (format 1.1): t = s u along the raw unit translation u, s the
 * model's step (tvo_nn_run_all); a negative linear step gives t = 0; the rotation branches of step.tvonn
 * replace R; a log-step model never gives t = 0 for a unit u. */
static void test_refine_step_length(void **state)
{
    void *mem_lin = NULL, *mem_log = NULL;
    tvo_nn *lin = load_nn("steplin.tvonn", &mem_lin), *lg = load_nn("step.tvonn", &mem_log);
    int pos = 0, neg = 0;
    (void)state;
    assert_non_null(lin);
    assert_non_null(lg);
    for (int k = 0; k < 200; ++k) {
        tvo_vo_result res;
        tvo_pose step;
        float y[TVO_NN_OUT_COUNT];
        const double a = 0.1 * k, u[3] = {cos(a) * 0.6, sin(a) * 0.6, 0.8};
        memset(&res, 0, sizeof res);
        res.T_prev_cur = tvo_pose_identity();
        memcpy(res.T_prev_cur.t, u, sizeof u);
        for (int i = 0; i < TVO_FEAT_COUNT; ++i)
            res.features[i] = (float)(0.3 * sin(0.7 * k + 1.3 * i) * (1 + i));
        assert_int_equal(tvo_nn_run_all(lin, res.features, y), TVO_OK);
        assert_int_equal(tvo_vo_refine(lin, &res, &step), TVO_OK);
        for (int j = 0; j < 3; ++j) {
            const double want = y[TVO_NN_STEP] > 0.0f ? (double)y[TVO_NN_STEP] * u[j] : 0.0;
            assert_true(step.t[j] == want);
        }
        assert_memory_equal(step.R, res.T_prev_cur.R, sizeof step.R); /* no rotation branches */
        if (y[TVO_NN_STEP] > 0.0f)
            ++pos;
        else
            ++neg;
        assert_int_equal(tvo_nn_run_all(lg, res.features, y), TVO_OK);
        assert_int_equal(tvo_vo_refine(lg, &res, &step), TVO_OK);
        assert_true(y[TVO_NN_STEP] > 0.0f);
        for (int j = 0; j < 3; ++j)
            assert_true(step.t[j] == (double)y[TVO_NN_STEP] * u[j]);
        {
            const double v[3] = {y[TVO_NN_RX], y[TVO_NN_RY], y[TVO_NN_RZ]};
            double R[9];
            tvo_rotvec_to_rot(v, R);
            assert_memory_equal(step.R, R, sizeof R);
        }
    }
    assert_true(pos > 10 && neg > 10); /* both branches of the rule were exercised */
    free(mem_lin);
    free(mem_log);
}

/* A configuration outside its documented ranges: no size, and init refuses it (vo.h). */
static void assert_refused(const tvo_vo_config *cfg, void *mem)
{
    tvo_vo *vo = NULL;
    assert_int_equal(tvo_vo_required_size(cfg), 0);
    assert_int_equal(tvo_vo_init(&vo, cfg, mem, 10), TVO_ERR_ARG);
}

/* Each of the values (of type T) in field F of a copy of f's configuration is refused (assert_refused). */
#define ASSERT_EACH_REFUSED(f, T, F, ...)                            \
    do {                                                             \
        const T v_[] = {__VA_ARGS__};                                \
        for (size_t i_ = 0; i_ < sizeof(v_) / sizeof(v_[0]); ++i_) { \
            tvo_vo_config b_ = (f)->cfg;                             \
            b_.F = v_[i_];                                           \
            assert_refused(&b_, (f)->mem);                           \
        }                                                            \
    } while (0)

/* Every field out of its range, on the basic preset (setup_basic: the checks below start from its
 * values). */
static void test_bad_input(void **state)
{
    fixture *f = *state;
    tvo_vo_result res;
    uint8_t small[16 * 16];
    tvo_image img = tvo_image_make(W, H, W, f->img);
    tvo_image wrong = tvo_image_make(16, 16, 16, small);
    tvo_vo *vo2 = NULL;
    tvo_vo_config bad = f->cfg;
    tvo_pose T = tvo_pose_identity();
    memset(f->img, 0, sizeof(f->img));

    assert_int_equal(tvo_vo_process(NULL, &img, 1, &res), TVO_ERR_NULL);
    assert_int_equal(res.state, TVO_VO_LOST);
    assert_int_equal(tvo_vo_process(f->vo, NULL, 1, &res), TVO_ERR_NULL);
    assert_int_equal(tvo_vo_process(f->vo, &img, 1, NULL), TVO_ERR_NULL);
    assert_int_equal(tvo_vo_process(f->vo, &wrong, 1, &res), TVO_ERR_SIZE);
    assert_true(tvo_pose_is_finite(&res.T_prev_cur));

    /* black frames: no corners, never a NaN pose */
    assert_int_equal(tvo_vo_process(f->vo, &img, 100, &res), TVO_OK);
    assert_int_equal(tvo_vo_process(f->vo, &img, 200, &res), TVO_OK);
    assert_int_equal(res.state, TVO_VO_LOST);
    assert_true(tvo_pose_is_finite(&res.T_prev_cur));
    /* timestamps must increase */
    assert_int_equal(tvo_vo_process(f->vo, &img, 200, &res), TVO_ERR_ARG);
    assert_int_equal(tvo_vo_process(f->vo, &img, 150, &res), TVO_ERR_ARG);

    /* random noise frames: whatever happens, finite */
    {
        uint64_t s = 42;
        for (int k = 0; k < 4; ++k) {
            for (int i = 0; i < W * H; ++i)
                f->img[i] = (uint8_t)(tvo_test_rand(&s) >> 56);
            assert_int_equal(tvo_vo_process(f->vo, &img, 300 + k, &res), TVO_OK);
            assert_true(tvo_pose_is_finite(&res.T_prev_cur));
        }
    }

    /* config and memory checks */
    assert_int_equal(tvo_vo_init(NULL, &f->cfg, f->mem, 10), TVO_ERR_NULL);
    assert_int_equal(tvo_vo_init(&vo2, &f->cfg, f->mem, 10), TVO_ERR_NO_MEMORY);
    bad.max_tracks = 3;
    assert_refused(&bad, f->mem);
    bad = f->cfg;
    bad.camera.fx = NAN;
    assert_int_equal(tvo_vo_required_size(&bad), 0);
    bad = f->cfg;
    bad.pose_threshold_px = -1.0;
    assert_int_equal(tvo_vo_required_size(&bad), 0);
    {
        const double cov[3] = {-0.1, 1.5, NAN}; /* redetect_coverage outside [0, 1] */
        for (int i = 0; i < 3; ++i) {
            bad = f->cfg;
            bad.redetect_coverage = cov[i];
            assert_int_equal(tvo_vo_required_size(&bad), 0);
        }
        bad = f->cfg;
        bad.redetect_coverage = 0.0; /* off is valid */
        assert_int_equal(tvo_vo_required_size(&bad), tvo_vo_required_size(&f->cfg));
    }
    /* keyframe rotation, track and map prediction and rescue settings out of their documented ranges
       (vo.h) */
    {
        tvo_vo_config kb[13];
        for (int i = 0; i < 13; ++i)
            kb[i] = f->cfg;
        kb[0].keyframe = 2;
        kb[1].keyframe = -1;
        kb[2].keyframe_min_tracks = -1;
        kb[3].keyframe_max_parallax_deg = 0.0;
        kb[4].keyframe_max_parallax_deg = NAN;
        kb[5].keyframe_max_rot_deg = 181.0;
        kb[6].keyframe_translation = 3;
        kb[7].track_prediction = 2;
        kb[8].track_prediction = -1;
        kb[9].map_prediction = 3;
        kb[10].map_prediction = -1;
        kb[11].pred_rescue = 2;
        kb[12].pred_rescue = -1;
        for (int i = 0; i < 13; ++i)
            assert_refused(&kb[i], f->mem);
        bad = f->cfg;
        bad.keyframe = 0; /* off is valid and needs the same memory (the buffers are there either way) */
        assert_int_equal(tvo_vo_required_size(&bad), tvo_vo_required_size(&f->cfg));
        bad.track_prediction = 0; /* likewise */
        assert_int_equal(tvo_vo_required_size(&bad), tvo_vo_required_size(&f->cfg));
        bad.map_prediction = 2; /* the map prediction uses the same buffers */
        bad.lk.pred_levels = 2;
        bad.lk.pred_win_size = 13;
        assert_int_equal(tvo_vo_required_size(&bad), tvo_vo_required_size(&f->cfg));
    }
    /* fixed keyframes of the bundle adjustment: [2, map_window - 1] */
    {
        assert_int_equal(f->cfg.map_ba_fixed, 2);
        assert_int_equal(f->cfg.map_window, 6);
        ASSERT_EACH_REFUSED(f, int32_t, map_ba_fixed, 1, 0, -1, 6);
        bad = f->cfg;
        bad.map_ba_fixed = 5;
        assert_int_equal(tvo_vo_required_size(&bad), tvo_vo_required_size(&f->cfg));
        bad.map_window = 4; /* the limit follows the window */
        assert_int_equal(tvo_vo_required_size(&bad), 0);
    }
    /* affine refinement window: odd in [3, TVO_AFF_MAX_SIDE = 31], or 0 (off, the default, and without
       its memory: (w + 2)^2 + 313 bytes a track) */
    {
        const int32_t ws[5] = {-1, 1, 2, 20, 33};
        assert_int_equal(f->cfg.affine_win_size, 0);
        for (int i = 0; i < 5; ++i) {
            bad = f->cfg;
            bad.affine_win_size = ws[i];
#if TVO_WITH_AFFINE
            assert_refused(&bad, f->mem);
#else
            {
                tvo_vo *vo = NULL; /* left out of the build: refused as unsupported, whatever the size */
                assert_int_equal(tvo_vo_required_size(&bad), 0);
                assert_int_equal(tvo_vo_init(&vo, &bad, f->mem, 10), TVO_ERR_UNSUPPORTED);
            }
#endif
        }
        /* the refinement at keyframes only: 0 or 1 */
        {
            assert_int_equal(f->cfg.affine_at_keyframes, 0);
            ASSERT_EACH_REFUSED(f, int32_t, affine_at_keyframes, -1, 2, 255);
        }
        /* the share of failed alignments below which their tracks are ended: [0, 1], 0 (off) by default */
        {
            assert_true(f->cfg.affine_end_share == 0.0);
            ASSERT_EACH_REFUSED(f, double, affine_end_share, -0.01, 1.01, NAN, INFINITY);
        }
        /* landmarks found again: [0, 4096], 0 (off) in the basic preset; without the map or the affine
           refinement's templates it does nothing and takes no memory */
        {
            assert_int_equal(f->cfg.map_refind, 0);
            ASSERT_EACH_REFUSED(f, int32_t, map_refind, -1, 4097, INT32_MAX);
            /* the landmarks that judge a weak rotation prior: 0 (all) or [2, TVO_VO_MAX_WINDOW]; 3 by
               default, and all of them take no other memory */
            assert_int_equal(f->cfg.map_rot_prior_obs, 3);
            ASSERT_EACH_REFUSED(f, int32_t, map_rot_prior_obs, -1, 1, TVO_VO_MAX_WINDOW + 1, INT32_MAX);
            bad = f->cfg;
            bad.map_rot_prior_obs = 0;
            assert_true(tvo_vo_required_size(&bad) == tvo_vo_required_size(&f->cfg));
            /* ...only after a jerk: 0 (every weak frame) or [1, 100000] frames */
            assert_int_equal(f->cfg.map_rot_prior_obs_frames, 30);
            ASSERT_EACH_REFUSED(f, int32_t, map_rot_prior_obs_frames, -1, 100001, INT32_MIN);
            bad = f->cfg;
            bad.map_rot_prior_obs_frames = 100000;
            assert_true(tvo_vo_required_size(&bad) == tvo_vo_required_size(&f->cfg));
            /* the rescue: 0 or 1 */
            assert_int_equal(f->cfg.map_refind_rescue, 0);
            ASSERT_EACH_REFUSED(f, int32_t, map_refind_rescue, -1, 2, 255);
            bad = f->cfg;
            bad.affine_win_size = 0;
            bad.map_refind = 64;
            assert_true(tvo_vo_required_size(&bad) == tvo_vo_required_size(&f->cfg));
#if TVO_WITH_AFFINE
            bad.affine_win_size = 21;
            bad.map = 0;
            {
                tvo_vo_config off = bad;
                off.map_refind = 0;
                assert_true(tvo_vo_required_size(&bad) == tvo_vo_required_size(&off));
                /* with both, its store is in the required size: 64 templates and more */
                bad.map = 1;
                off.map = 1;
                assert_true(tvo_vo_required_size(&bad) >=
                            tvo_vo_required_size(&off) + 64 * (size_t)(23 * 23 + sizeof(double) * 35));
            }
#endif
        }
        /* the refinement's sampling step: [1, 15], and it divides affine_win_size / 2 */
        {
            ASSERT_EACH_REFUSED(f, int32_t, affine_step, 0, -2, 16);
        }
#if TVO_WITH_AFFINE
        bad = f->cfg;
        bad.affine_win_size = 21;
        bad.affine_step = 3; /* does not divide 10 */
        assert_refused(&bad, f->mem);
        bad.affine_step = 5;
        assert_true(tvo_vo_required_size(&bad) > 0);
        bad.affine_step = 2;
        assert_true(tvo_vo_required_size(&bad) > 0);
        bad.affine_step = 1;
        assert_true(tvo_vo_required_size(&bad) >=
                    tvo_vo_required_size(&f->cfg) + (size_t)bad.max_tracks * (23 * 23 + 313));
        /* ... plus at most the refinement's scratch (three float arrays of 21 rows of 24; shared with
           the other stages' scratch, so it adds only where it is the largest, as in this small camera) */
        assert_true(tvo_vo_required_size(&bad) <= tvo_vo_required_size(&f->cfg) +
                            (size_t)bad.max_tracks * (23 * 23 + 313) + 4 * 64 + 3 * 21 * 24 * sizeof(float));
        bad.affine_win_size = 31;
        assert_true(tvo_vo_required_size(&bad) >
                    tvo_vo_required_size(&f->cfg) + (size_t)bad.max_tracks * (33 * 33 + 313));
#endif
    }

    /* trajectory integration refuses non-finite input and keeps its state */
    {
        tvo_traj traj;
        tvo_pose step = tvo_pose_identity();
        tvo_traj_init(&traj, &T);
        step.t[0] = 1.0;
        assert_int_equal(tvo_traj_step(&traj, &step, 2.0), TVO_OK);
        assert_true(fabs(traj.T_w_c.t[0] - 2.0) < 1e-12);
        assert_int_equal(tvo_traj_step(&traj, &step, NAN), TVO_ERR_NOT_FINITE);
        step.t[1] = INFINITY;
        assert_int_equal(tvo_traj_step(&traj, &step, 1.0), TVO_ERR_NOT_FINITE);
        assert_true(fabs(traj.T_w_c.t[0] - 2.0) < 1e-12);
        assert_int_equal(traj.steps, 1);
    }
}

/* The tracker, window and chain fields the presets set (vo.h); the rest of every preset is the basic
 * preset's. */
static void expect_tracker(const tvo_vo_config *c, int32_t affine, int32_t window, int32_t fixed,
                           int32_t pred, int32_t pred_levels, int32_t pred_win, double chain_sigmas)
{
    assert_true(c->chain_scale_sigmas == chain_sigmas);
    assert_int_equal(c->affine_win_size, affine);
    assert_int_equal(c->map_window, window);
    assert_int_equal(c->map_ba_fixed, fixed);
    assert_int_equal(c->map_prediction, pred);
    assert_int_equal(c->lk.pred_levels, pred_levels);
    assert_int_equal(c->lk.pred_win_size, pred_win);
    /* the presets with the refinement find the landmarks of ended tracks again as a rescue */
    assert_int_equal(c->map_refind, affine > 0 ? 64 : 0);
    assert_int_equal(c->map_refind_rescue, affine > 0);
}

/* c with the tracker and window fields of `from` */
static void copy_tracker(tvo_vo_config *c, const tvo_vo_config *from)
{
    c->affine_win_size = from->affine_win_size;
    c->map_window = from->map_window;
    c->map_ba_fixed = from->map_ba_fixed;
    c->map_prediction = from->map_prediction;
    c->lk.pred_levels = from->lk.pred_levels;
    c->lk.pred_win_size = from->lk.pred_win_size;
    c->chain_scale_sigmas = from->chain_scale_sigmas;
    c->map_refind = from->map_refind;
    c->map_refind_rescue = from->map_refind_rescue;
}

/* The presets (vo.h): the default is the balanced preset in a build with the affine refinement and the
 * basic preset without it; each preset differs from the basic one in its own fields only and is a
 * configuration the VO accepts; an unknown preset, and the accurate or balanced one in a build without the
 * affine refinement, leave the defaults. */
static void test_presets(void **state)
{
    const tvo_camera cam = tvo_camera_make_pinhole(320, 240, 260.0, 260.0, 159.5, 119.5);
    tvo_vo_config def, basic, c;
    (void)state;
    tvo_vo_config_default(&def, &cam);
    assert_int_equal(tvo_vo_config_preset(&c, &cam, TVO_VO_PRESET_DEFAULT), TVO_OK);
    assert_memory_equal(&c, &def, sizeof(c));

    assert_int_equal(tvo_vo_config_preset(&basic, &cam, TVO_VO_PRESET_BASIC), TVO_OK);
    expect_tracker(&basic, 0, 6, 2, 0, 0, 0, 0.0);
    assert_true(tvo_vo_required_size(&basic) > 0);
    c = basic;
    copy_tracker(&c, &def);
    assert_memory_equal(&c, &def, sizeof(c)); /* the default differs from basic in the tracker only */

    assert_int_equal(tvo_vo_config_preset(&c, &cam, TVO_VO_PRESET_SMALL), TVO_OK);
    expect_tracker(&c, 0, 5, 2, 0, 0, 0, 0.0);
    assert_int_equal(c.max_tracks, 120);
    assert_int_equal(c.min_tracks, 80);
    assert_int_equal(c.keyframe_min_tracks, 40);
    assert_int_equal(c.detect.max_corners, 120);
    assert_int_equal(c.lk.max_level, 2);
    assert_int_equal(c.map_max_landmarks, 160);
    assert_true(tvo_vo_required_size(&c) > 0);
    assert_true(tvo_vo_required_size(&c) < tvo_vo_required_size(&basic));
    print_message("320x240: %lu bytes small, %lu basic, %lu default\n",
                  (unsigned long)tvo_vo_required_size(&c), (unsigned long)tvo_vo_required_size(&basic),
                  (unsigned long)tvo_vo_required_size(&def));
    c.max_tracks = basic.max_tracks; /* the rest is the basic preset */
    c.min_tracks = basic.min_tracks;
    c.keyframe_min_tracks = basic.keyframe_min_tracks;
    c.detect.max_corners = basic.detect.max_corners;
    c.lk.max_level = basic.lk.max_level;
    c.map_window = basic.map_window;
    c.map_max_landmarks = basic.map_max_landmarks;
    assert_int_equal(c.lens_refine, 0); /* the lens as configured: a microcontroller build leaves it out */
    c.lens_refine = basic.lens_refine;
    assert_memory_equal(&c, &basic, sizeof(c));

#if TVO_WITH_AFFINE
    expect_tracker(&def, 21, 8, 4, 2, 2, 11, 3.0);
    assert_true(tvo_vo_required_size(&def) > tvo_vo_required_size(&basic));

    assert_int_equal(tvo_vo_config_preset(&c, &cam, TVO_VO_PRESET_BALANCED), TVO_OK);
    assert_memory_equal(&c, &def, sizeof(c));

    assert_int_equal(tvo_vo_config_preset(&c, &cam, TVO_VO_PRESET_ACCURATE), TVO_OK);
    expect_tracker(&c, 21, 8, 4, 0, 0, 0, 3.0);
    assert_int_equal(tvo_vo_required_size(&c), tvo_vo_required_size(&def));
    copy_tracker(&c, &basic);
    assert_memory_equal(&c, &basic, sizeof(c));
#else
    assert_memory_equal(&def, &basic, sizeof(def));
    memset(&c, 0xa5, sizeof(c));
    assert_int_equal(tvo_vo_config_preset(&c, &cam, TVO_VO_PRESET_ACCURATE), TVO_ERR_UNSUPPORTED);
    assert_memory_equal(&c, &def, sizeof(c));
    memset(&c, 0xa5, sizeof(c));
    assert_int_equal(tvo_vo_config_preset(&c, &cam, TVO_VO_PRESET_BALANCED), TVO_ERR_UNSUPPORTED);
    assert_memory_equal(&c, &def, sizeof(c));
#endif
    memset(&c, 0xa5, sizeof(c));
    assert_int_equal(tvo_vo_config_preset(&c, &cam, (tvo_vo_preset)7), TVO_ERR_ARG);
    assert_memory_equal(&c, &def, sizeof(c));
    assert_int_equal(tvo_vo_config_preset(NULL, &cam, TVO_VO_PRESET_SMALL), TVO_ERR_NULL);
}

/* LK's pyramid follows the frame's size (vo.h, tvo_vo_config_default): 3 levels above the frame up to
 * 1280 px on the larger side, one more for each doubling beyond, whichever side is the larger, while the
 * new level's smaller side stays above LK's window (21 px); 3 without a camera; every preset but the small
 * one keeps it, and the VO accepts each. */
static void test_levels_follow_frame_size(void **state)
{
    static const struct {
        int32_t w, h, levels;
    } cases[] = {{320, 240, 3},   {752, 480, 3},   {1226, 370, 3},  {1280, 720, 3},  {1281, 720, 4},
                 {2452, 740, 4},  {1080, 1920, 4}, {2560, 1440, 4}, {2561, 1440, 5}, {3840, 2160, 5},
                 {8192, 8192, 6}, {100, 5121, 3},  {5000, 300, 3},  {5000, 400, 4}};
    tvo_vo_config c;
    (void)state;
    tvo_vo_config_default(&c, NULL);
    assert_int_equal(c.lk.max_level, 3);
    for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); ++i) {
        const tvo_camera cam = tvo_camera_make_pinhole(cases[i].w, cases[i].h, 500.0, 500.0,
                                                       0.5 * cases[i].w - 0.5, 0.5 * cases[i].h - 0.5);
        tvo_vo_config_default(&c, &cam);
        assert_int_equal(c.lk.max_level, cases[i].levels);
        assert_true(tvo_vo_required_size(&c) > 0);
        assert_int_equal(tvo_vo_config_preset(&c, &cam, TVO_VO_PRESET_BASIC), TVO_OK);
        assert_int_equal(c.lk.max_level, cases[i].levels);
        assert_int_equal(tvo_vo_config_preset(&c, &cam, TVO_VO_PRESET_SMALL), TVO_OK);
        assert_int_equal(c.lk.max_level, 2); /* the small preset's own */
    }
}

/* A shake: the camera walks towards the far wall (2 cm a frame, 0.2 deg of yaw a frame) with the map's
 * predicted tracks on 2 levels and 11x11 windows (the balanced preset's tracker), and at frame `shake` it
 * turns `deg` further and back at the next frame: the map's constant-velocity pose puts the predicted
 * tracks 4 deg away from where they are. Returns the share of the previous frame's tracks kept at the
 * shake, the rescues, the map's losses, and the frames after the shake that the map posed. */
static void run_shake(int32_t rescue, double deg, double *kept, int *rescued, int *losses, int *posed)
{
    fixture f;
    tvo_camera cam = test_camera();
    const int frames = 40, shake = 24;
    int32_t before = 0;
    tvo_vo_config_default(&f.cfg, &cam);
    f.cfg.map_prediction = 2;
    f.cfg.lk.pred_levels = 2;
    f.cfg.lk.pred_win_size = 11;
    f.cfg.pred_rescue = rescue;
    open_vo(&f);
    *kept = 0.0;
    *rescued = *losses = *posed = 0;
    for (int k = 0; k < frames; ++k) {
        const double dir[3] = {0.2, 0.0, 1.0};
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, f.img);
        tvo_pose T = motion(k, dir, 0.02, 0.2);
        if (k == shake) { /* T_w_c then a turn about the camera's y axis */
            const double v[3] = {0.0, deg * M_PI / 180.0, 0.0};
            tvo_pose turn = tvo_pose_identity();
            tvo_rotvec_to_rot(v, turn.R);
            T = tvo_pose_compose(&T, &turn);
        }
        render(&T, f.img);
        assert_int_equal(tvo_vo_process(f.vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        assert_true(res.pred_rescue == 0 || res.pred_rescue == 1);
        *rescued += res.pred_rescue;
        *losses += res.map_state == TVO_MAP_LOST;
        if (k == shake)
            *kept = before > 0 ? (double)res.tracked / (double)before : 0.0;
        if (k > shake && res.map_state == TVO_MAP_TRACKING)
            ++*posed;
        before = res.tracks;
    }
    free(f.mem);
}

/* The shake scene of run_shake with the rescue on and the weak prior's judges set: the world poses of
 * its frames into T (frames entries) and the frame of the first rescue into *first (-1: none). */
static void shake_poses(double deg, int32_t prior_obs, int32_t prior_obs_frames, tvo_pose *T, int frames,
                        int *first)
{
    fixture f;
    tvo_camera cam = test_camera();
    tvo_vo_config_default(&f.cfg, &cam);
    f.cfg.map_prediction = 2;
    f.cfg.lk.pred_levels = 2;
    f.cfg.lk.pred_win_size = 11;
    f.cfg.pred_rescue = 1;
    f.cfg.map_rot_prior_obs = prior_obs;
    f.cfg.map_rot_prior_obs_frames = prior_obs_frames;
    open_vo(&f);
    *first = -1;
    for (int k = 0; k < frames; ++k) {
        const double dir[3] = {0.2, 0.0, 1.0};
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, f.img);
        tvo_pose P = motion(k, dir, 0.02, 0.2);
        if (k == 24) {
            const double v[3] = {0.0, deg * M_PI / 180.0, 0.0};
            tvo_pose turn = tvo_pose_identity();
            tvo_rotvec_to_rot(v, turn.R);
            P = tvo_pose_compose(&P, &turn);
        }
        render(&P, f.img);
        assert_int_equal(tvo_vo_process(f.vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        T[k] = res.T_w_c;
        if (res.pred_rescue && *first < 0)
            *first = k;
    }
    free(f.mem);
}

static int same_poses(const tvo_pose *a, const tvo_pose *b, int n)
{
    return memcmp(a, b, (size_t)n * sizeof(*a)) == 0;
}

/* cfg.map_rot_prior_obs_frames: the weak prior's test is judged by the checked landmarks only within that
 * many frames of a prediction rescue. In the shake scene the first rescue comes at the shake (frame 24):
 * before it the poses are those of the test judged by all the landmarks (map_rot_prior_obs 0), to the
 * bit; the 15 frames after it lie within 30 frames of it, where the poses are those of the checked
 * landmarks judging every weak frame (map_rot_prior_obs_frames 0), to the bit, and not all the
 * landmarks' (a weak frame after the shake is decided otherwise). */
static void test_prior_obs_after_a_rescue(void **state)
{
    enum { N = 40 };
    tvo_pose all[N], gated[N], every[N];
    int first_all, first_gated, first_every;
    (void)state;
    shake_poses(4.0, 0, 0, all, N, &first_all);
    shake_poses(4.0, 3, 30, gated, N, &first_gated);
    shake_poses(4.0, 3, 0, every, N, &first_every);
    fprintf(stderr,
            "first rescue at frame %d / %d / %d (all landmarks / after a rescue / every frame); the poses "
            "after a rescue: %s all the landmarks' before it, %s every frame's, %s all the landmarks' over "
            "the run\n",
            first_all, first_gated, first_every, same_poses(all, gated, first_all) ? "the same as" : "not",
            same_poses(gated, every, N) ? "the same as" : "not",
            same_poses(all, gated, N) ? "the same as" : "not");
    assert_true(first_all == 24 && first_gated == 24 && first_every == 24);
    assert_true(same_poses(all, gated, first_all));
    assert_true(same_poses(gated, every, N));
    assert_false(same_poses(all, gated, N));
}

/* cfg.pred_rescue: after a shake the map's prediction misses, the short way loses most predicted tracks,
 * and the rescue tracks them again the default way: the map keeps tracking. Without it the frame keeps
 * fewer than half of its tracks and the map is lost. Smooth frames never call for it. */
static void test_pred_rescue(void **state)
{
    double kept_on, kept_off, kept_smooth;
    int res_on, res_off, res_smooth, loss_on, loss_off, loss_smooth, posed_on, posed_off, posed_smooth;
    (void)state;
    run_shake(1, 4.0, &kept_on, &res_on, &loss_on, &posed_on);
    run_shake(0, 4.0, &kept_off, &res_off, &loss_off, &posed_off);
    run_shake(1, 0.0, &kept_smooth, &res_smooth, &loss_smooth, &posed_smooth);
    fprintf(stderr,
            "shake of 4 deg at frame 24 of 40: %.0f %% of the tracks kept, %d rescues, %d map losses, %d "
            "of the 15 later frames posed by the map with the rescue; %.0f %%, %d, %d, %d without; no "
            "shake: %.0f %%, %d rescues\n",
            100.0 * kept_on, res_on, loss_on, posed_on, 100.0 * kept_off, res_off, loss_off, posed_off,
            100.0 * kept_smooth, res_smooth);
    assert_int_equal(res_off, 0);
    assert_true(kept_off < 0.5);
    assert_true(loss_off >= 1); /* the shake is one the short way cannot follow */
    assert_true(res_on >= 1);
    assert_true(kept_on > kept_off + 0.2);
    assert_int_equal(loss_on, 0);
    assert_int_equal(posed_on, 15);
    assert_int_equal(res_smooth, 0);
    assert_int_equal(loss_smooth, 0);
    assert_true(kept_smooth > 0.9);
}

int main(void)
{
    const struct CMUnitTest tests[] =
    { cmocka_unit_test_setup_teardown(test_translating_camera, setup, teardown),
      cmocka_unit_test_setup_teardown(test_more_tracks_than_max_corners, setup, teardown),
      cmocka_unit_test_setup_teardown(test_pure_rotation_reports_rotation_only, setup, teardown),
      cmocka_unit_test_setup_teardown(test_single_plane_twins, setup, teardown),
      cmocka_unit_test_setup_teardown(test_single_plane_unresolved, setup, teardown),
      cmocka_unit_test_setup_teardown(test_relative_scale, setup_basic, teardown),
      cmocka_unit_test_setup_teardown(test_relative_scale_rotation_only, setup, teardown),
      cmocka_unit_test_setup_teardown(test_chain_scale, setup_basic, teardown),
      cmocka_unit_test_setup_teardown(test_dropped_and_lost_frames, setup, teardown),
      cmocka_unit_test_setup_teardown(test_short_first_interval, setup, teardown),
      cmocka_unit_test_setup_teardown(test_timestamp_jitter, setup, teardown),
      cmocka_unit_test(test_keyframe_rotation),
      cmocka_unit_test(test_track_prediction),
      cmocka_unit_test(test_redetect_coverage),
      cmocka_unit_test(test_redetect_cell_kept),
      cmocka_unit_test(test_gain_retry),
      cmocka_unit_test(test_dark_frames),
      cmocka_unit_test(test_pred_rescue),
      cmocka_unit_test(test_prior_obs_after_a_rescue),
      cmocka_unit_test(test_affine_refinement),
#if TVO_WITH_AFFINE
      cmocka_unit_test(test_map_refind),
      cmocka_unit_test(test_map_refind_rescue),
#endif
      cmocka_unit_test(test_scale_filter),
      cmocka_unit_test(test_presets),
      cmocka_unit_test(test_levels_follow_frame_size),
      cmocka_unit_test(test_refine_step_length),
      cmocka_unit_test_setup_teardown(test_bad_input, setup_basic, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
