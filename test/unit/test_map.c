/* SPDX-License-Identifier: Apache-2.0 */
/* The VO's local map end to end on frames rendered from the textured box room of test/common/tvo_room.h:
 * one consistent scale over a long run, keyframes and landmarks, pure rotation before and after the map
 * exists, a loss and the new map that continues the trajectory, the tracks view, and the map's config
 * and memory contract. */
#include "tvo_test.h"

#include <math.h>

#include "tinyvo/linalg.h"
#include "tinyvo/options.h"
#include "tinyvo/vo.h"
#include "tvo_room.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif
#define W 320
#define H 240
#define FOCAL 250.0
#define DT_NS 50000000LL

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

/* A fixture with the default configuration (map on or off); the VO is not made yet, so that a test can
 * change f->cfg before start_vo(). */
static fixture *new_fixture(int map)
{
    fixture *f = calloc(1, sizeof(fixture));
    tvo_camera cam = test_camera();
    assert_non_null(f);
    tvo_vo_config_default(&f->cfg, &cam);
    f->cfg.map = map;
    return f;
}

static void start_vo(fixture *f)
{
    const size_t need = tvo_vo_required_size(&f->cfg);
    assert_true(need > 0);
    f->mem = malloc(need);
    assert_non_null(f->mem);
    assert_int_equal(tvo_vo_init(&f->vo, &f->cfg, f->mem, need), TVO_OK);
}

static fixture *open_vo(int map)
{
    fixture *f = new_fixture(map);
    start_vo(f);
    return f;
}

static void close_vo(fixture *f)
{
    free(f->mem);
    free(f);
}

static double rot_err_deg(const tvo_pose *a, const tvo_pose *b)
{
    tvo_pose d = tvo_pose_relative(a, b);
    return tvo_rot_angle(d.R) * 180.0 / M_PI;
}

/* A walk through the room: forward and sideways along a gentle curve with a slow yaw sway, 4 cm a
 * frame (about 0.5 m/s at 20 Hz). Frame 0 is the identity, so the VO's world is the ground truth's up to the
 * scale. */
static tvo_pose walk(int k)
{
    tvo_pose T = tvo_pose_identity();
    const double s = 0.025 * k;
    const double v[3] = {0.01 * sin(0.05 * k), 0.25 * sin(0.02 * k), 0.0};
    tvo_rotvec_to_rot(v, T.R);
    T.t[0] = 0.6 * sin(0.4 * s);
    T.t[1] = 0.05 * sin(0.7 * s);
    T.t[2] = 0.9 * s - 1.0 * (1.0 - cos(0.1 * s));
    return T;
}

static tvo_status step(fixture *f, const tvo_pose *T, int k, tvo_vo_result *res)
{
    tvo_image img = tvo_image_make(W, H, W, f->img);
    tvo_status st;
    tvo_room_render(T, W, H, FOCAL, f->img);
    st = tvo_vo_process(f->vo, &img, 1000000000LL + k * DT_NS, res);
    if (getenv("TVO_MAP_TEST_VERBOSE"))
        fprintf(stderr,
                "  frame %d: state %d map %d kf %d points %d new %d landmarks %d tracks %d losses %d "
                "rot err %.3f t %.3f %.3f %.3f gt %.3f %.3f %.3f\n",
                k, (int)res->state, (int)res->map_state, (int)res->keyframe, (int)res->map_points,
                (int)res->map_new_points, (int)res->map_landmarks, (int)res->tracks, (int)res->map_losses,
                rot_err_deg(&res->T_w_c, T), res->T_w_c.t[0], res->T_w_c.t[1], res->T_w_c.t[2], T->t[0],
                T->t[1], T->t[2]);
    return st;
}

/* Frame k of the walk rendered and processed: TVO_OK and a finite world pose. */
static void walk_step(fixture *f, int k, tvo_vo_result *res)
{
    const tvo_pose T = walk(k);
    assert_int_equal(step(f, &T, k, res), TVO_OK);
    assert_true(tvo_pose_is_finite(&res->T_w_c));
}

/* least-squares scale s minimising sum |gt - s est|^2 over frames [a, b) (both worlds start at the
 * identity) */
static double best_scale(const tvo_pose *gt, const tvo_pose *est, int a, int b)
{
    double num = 0.0, den = 0.0;
    for (int k = a; k < b; ++k)
        for (int c = 0; c < 3; ++c) {
            num += gt[k].t[c] * est[k].t[c];
            den += est[k].t[c] * est[k].t[c];
        }
    return den > 0.0 ? num / den : 0.0;
}

/* the length of the ground-truth path over frames [0, n) */
static double path_length(const tvo_pose *gt, int n)
{
    double path = 0.0;
    for (int k = 1; k < n; ++k) {
        const tvo_pose d = tvo_pose_relative(&gt[k - 1], &gt[k]);
        path += sqrt(d.t[0] * d.t[0] + d.t[1] * d.t[1] + d.t[2] * d.t[2]);
    }
    return path;
}

/* the RMS position error over frames [a, b) of est scaled by s against gt */
static double scaled_ate(const tvo_pose *gt, const tvo_pose *est, int a, int b, double s)
{
    double err2 = 0.0;
    for (int k = a; k < b; ++k)
        for (int c = 0; c < 3; ++c) {
            const double e = gt[k].t[c] - s * est[k].t[c];
            err2 += e * e;
        }
    return sqrt(err2 / (b - a));
}

#define LONG_RUN 160

/* One scale for the whole run: the position error after one scale factor stays within 2 % of the path,
 * the scale fitted to the first and to the last third agree within 3 %, the rotation error stays within
 * 2 deg (the two-view chain of the same frames, cfg.map = 0, ends 1.9 deg off), and every frame after
 * the initialisation is posed by the map. */
static void test_map_consistent_scale(void **state)
{
    fixture *f = open_vo(1);
    static tvo_pose gt[LONG_RUN], est[LONG_RUN];
    int tracking = 0, keyframes = 0, init_frame = -1, losses = 0;
    double path, err2, max_rot = 0.0, s, s1, s3;
    (void)state;
    for (int k = 0; k < LONG_RUN; ++k) {
        tvo_vo_result res;
        gt[k] = walk(k);
        assert_int_equal(step(f, &gt[k], k, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        est[k] = res.T_w_c;
        tracking += res.map_state == TVO_MAP_TRACKING;
        keyframes += res.keyframe;
        losses = res.map_losses;
        if (res.map_state == TVO_MAP_INITIALISED && init_frame < 0)
            init_frame = k;
        if (res.map_state == TVO_MAP_TRACKING) {
            assert_true(res.map_points >= f->cfg.map_min_points);
            assert_true(res.map_landmarks >= res.map_points);
        }
    }
    assert_true(init_frame > 0 && init_frame < 30);
    assert_int_equal(losses, 0);
    assert_int_equal(tracking, LONG_RUN - 1 - init_frame);
    assert_true(keyframes >= 4);
    s = best_scale(gt, est, init_frame, LONG_RUN);
    s1 = best_scale(gt, est, init_frame, LONG_RUN / 3);
    s3 = best_scale(gt, est, 2 * LONG_RUN / 3, LONG_RUN);
    path = path_length(gt, LONG_RUN);
    err2 = scaled_ate(gt, est, init_frame, LONG_RUN, s);
    for (int k = init_frame; k < LONG_RUN; ++k) {
        const double r = rot_err_deg(&est[k], &gt[k]);
        max_rot = r > max_rot ? r : max_rot;
    }
    fprintf(stderr,
            "map walk: init at frame %d, %d keyframes, path %.2f m, ATE %.4f m (%.2f %%), scale %.4f "
            "first third %.4f last third %.4f, max rotation error %.3f deg\n",
            init_frame, keyframes, path, err2, 100.0 * err2 / path, s, s1, s3, max_rot);
    assert_true(err2 < 0.02 * path);
    assert_true(fabs(s1 / s3 - 1.0) < 0.03);
    assert_true(max_rot < 2.0);
    close_vo(f);
}

/* The bundle adjustment's turn check (cfg.map_ba_max_turn_deg): on the walk the adjustments turn the
 * newest keyframe by hundredths of a degree and the default bound (0.5 deg) refuses none; a bound of
 * 1e-9 deg refuses every adjustment that moved it, flags those frames, and the map still poses every
 * frame (from the windows as tracked), finite, within 2 % of the path. */
static void test_map_ba_turn_check(void **state)
{
    for (int pass = 0; pass < 2; ++pass) {
        fixture *f = new_fixture(1);
        static tvo_pose gt[LONG_RUN], est[LONG_RUN];
        int refused = 0, adjusted = 0, tracking = 0, init_frame = -1;
        double err2, path;
        (void)state;
        assert_true(f->cfg.map_ba_max_turn_deg == 0.5);
        if (pass == 1)
            f->cfg.map_ba_max_turn_deg = 1e-9;
        start_vo(f);
        for (int k = 0; k < LONG_RUN; ++k) {
            tvo_vo_result res;
            gt[k] = walk(k);
            assert_int_equal(step(f, &gt[k], k, &res), TVO_OK);
            assert_true(tvo_pose_is_finite(&res.T_w_c));
            est[k] = res.T_w_c;
            refused += (res.ba_flags & TVO_VO_BA_TURN_REFUSED) != 0;
            adjusted += res.ba_iterations > 0;
            tracking += res.map_state == TVO_MAP_TRACKING;
            if (res.map_state == TVO_MAP_INITIALISED && init_frame < 0)
                init_frame = k;
        }
        assert_true(init_frame > 0 && init_frame < 30);
        path = path_length(gt, LONG_RUN);
        err2 = scaled_ate(gt, est, init_frame, LONG_RUN, best_scale(gt, est, init_frame, LONG_RUN));
        fprintf(stderr, "map walk, turn bound %g deg: %d of %d adjustments refused, ATE %.4f m (%.2f %%)\n",
                f->cfg.map_ba_max_turn_deg, refused, adjusted, err2, 100.0 * err2 / path);
        assert_int_equal(tracking, LONG_RUN - 1 - init_frame);
        assert_true(adjusted >= 3);
        if (pass == 0)
            assert_int_equal(refused, 0);
        else
            assert_true(refused >= adjusted - 1); /* all but one that left the newest keyframe as it was */
        assert_true(err2 < 0.02 * path);
        close_vo(f);
    }
}

/* The map off: T_w_c is the two-view chain with unit steps, and the map fields stay empty. */
static void test_map_off(void **state)
{
    fixture *f = open_vo(0);
    tvo_pose prev = tvo_pose_identity();
    int ok = 0;
    (void)state;
    for (int k = 0; k < 20; ++k) {
        tvo_vo_result res;
        const tvo_pose T = walk(k);
        assert_int_equal(step(f, &T, k, &res), TVO_OK);
        assert_int_equal(res.map_state, TVO_MAP_OFF);
        assert_int_equal(res.keyframe, 0);
        assert_int_equal(res.map_landmarks, 0);
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        if (k > 0) {
            /* the chain's step is the two-view step: its rotation, and a unit translation or none */
            const tvo_pose d = tvo_pose_relative(&prev, &res.T_w_c);
            const double len = sqrt(d.t[0] * d.t[0] + d.t[1] * d.t[1] + d.t[2] * d.t[2]);
            assert_true(rot_err_deg(&d, &res.T_prev_cur) < 1e-9);
            if (res.state == TVO_VO_OK) {
                assert_true(fabs(len - 1.0) < 1e-9);
                ++ok;
            } else {
                assert_true(len == 0.0);
            }
        }
        prev = res.T_w_c;
    }
    assert_true(ok > 10);
    close_vo(f);
}

/* A camera that only rotates (a slow pan and tilt) for 200 frames from the start: the map never
 * initialises (nothing to triangulate), the pose keeps the two-view rotation and no translation. */
static void test_map_pure_rotation(void **state)
{
    fixture *f = open_vo(1);
    double max_rot = 0.0, max_t = 0.0;
    (void)state;
    for (int k = 0; k < 200; ++k) {
        tvo_vo_result res;
        tvo_pose T = tvo_pose_identity();
        const double v[3] = {0.15 * sin(0.03 * k), 0.5 * sin(0.02 * k), 0.0};
        tvo_rotvec_to_rot(v, T.R);
        assert_int_equal(step(f, &T, k, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        assert_true(res.map_state == TVO_MAP_INITIALISING);
        {
            const double r = rot_err_deg(&res.T_w_c, &T);
            const double t = sqrt(res.T_w_c.t[0] * res.T_w_c.t[0] + res.T_w_c.t[1] * res.T_w_c.t[1] +
                                  res.T_w_c.t[2] * res.T_w_c.t[2]);
            max_rot = r > max_rot ? r : max_rot;
            max_t = t > max_t ? t : max_t;
        }
    }
    fprintf(stderr, "map pure rotation: max rotation error %.3f deg, max position %.4f\n", max_rot, max_t);
    assert_true(max_rot < 1.0);
    assert_true(max_t == 0.0);
    close_vo(f);
}

/* Walk, then turn on the spot for 150 frames, then walk on: finite poses throughout, the rotation stays
 * right, the camera stays where it stopped (within 5 % of the distance walked), and the map is there
 * again (tracking) at the end. */
static void test_map_rotation_after_map(void **state)
{
    fixture *f = open_vo(1);
    const int walk1 = 60, turn = 150, walk2 = 80;
    tvo_pose T_stop = tvo_pose_identity(), est_stop = tvo_pose_identity();
    double max_rot = 0.0, max_drift = 0.0, walked = 0.0;
    tvo_vo_result res;
    (void)state;
    for (int k = 0; k < walk1 + turn + walk2; ++k) {
        tvo_pose T;
        if (k < walk1) {
            T = walk(k);
        } else if (k < walk1 + turn) {
            /* a turn of +-34 deg about the vertical and back, on the spot (ends where it started) */
            const double a = 0.6 * sin(2.0 * M_PI * (k - walk1 + 1) / turn);
            const tvo_pose W0 = walk(walk1 - 1);
            const double v[3] = {0.0, a, 0.0};
            double Ry[9];
            T = T_stop;
            tvo_rotvec_to_rot(v, Ry);
            tvo_la_mat3_mul(Ry, W0.R, T.R);
        } else {
            const tvo_pose W0 = walk(walk1 - 1);
            T = walk(k - turn);
            for (int c = 0; c < 3; ++c)
                T.t[c] += T_stop.t[c] - W0.t[c];
        }
        assert_int_equal(step(f, &T, k, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        {
            const double r = rot_err_deg(&res.T_w_c, &T);
            max_rot = r > max_rot ? r : max_rot;
        }
        if (k == walk1 - 1) {
            T_stop = T;
            est_stop = res.T_w_c;
            walked = sqrt(est_stop.t[0] * est_stop.t[0] + est_stop.t[1] * est_stop.t[1] +
                          est_stop.t[2] * est_stop.t[2]);
        } else if (k >= walk1 && k < walk1 + turn) {
            double d2 = 0.0;
            for (int c = 0; c < 3; ++c)
                d2 += (res.T_w_c.t[c] - est_stop.t[c]) * (res.T_w_c.t[c] - est_stop.t[c]);
            max_drift = sqrt(d2) > max_drift ? sqrt(d2) : max_drift;
        }
    }
    fprintf(stderr,
            "map walk-turn-walk: max rotation error %.3f deg, drift while turning %.4f of %.4f walked, "
            "%d losses, end state %d\n",
            max_rot, max_drift, walked, (int)res.map_losses, (int)res.map_state);
    assert_true(max_rot < 2.0);
    assert_true(max_drift < 0.05 * walked);
    assert_int_equal(res.map_state, TVO_MAP_TRACKING);
    close_vo(f);
}

/* Frame k of the walk's first walk1 frames, then of a yaw turn from where the walk ended: rate (rad) a
 * frame about the vertical while creeping by creep (m) a frame along the camera's own axis. */
static tvo_pose walk_then_turn(int k, int walk1, double rate, double creep)
{
    const tvo_pose W0 = walk(walk1 - 1);
    tvo_pose T = W0;
    if (k < walk1)
        return walk(k);
    {
        const int j = k - walk1 + 1;
        const double v[3] = {0.0, rate * j, 0.0};
        double Ry[9];
        tvo_rotvec_to_rot(v, Ry);
        tvo_la_mat3_mul(Ry, W0.R, T.R);
        for (int c = 0; c < 3; ++c) /* along the camera's own axis */
            T.t[c] = W0.t[c] + creep * j * T.R[3 * c + 2];
    }
    return T;
}

/* Walk to build the map, then turn at 2.5 deg a frame while creeping forward 5 mm a frame for 50 frames:
 * the landmarks leave the view faster than the baseline grows, so no keyframe comes for 18 frames while
 * the landmarks tracked fall from 136 to 35, and the keyframes made then (the map running out of points)
 * must get new landmarks from the tracks born since the last keyframe, triangulated from the frames they
 * were born in (without that the map is lost at frame 83). The map keeps tracking every frame, rotation
 * within 2 deg (1.76 measured); in a build without the affine refinement (the basic preset's tracker, whose
 * map here survives the turn either way) within 4.5 deg (3.83 measured). */
static void test_map_fast_turn(void **state)
{
    fixture *f = open_vo(1);
    const int walk1 = 60, turn = 50;
    const double rate = 2.5 * M_PI / 180.0, creep = 0.005;
    double max_rot = 0.0;
    int rescue_points = 0, min_points = 1 << 30;
    tvo_vo_result res;
    (void)state;
    for (int k = 0; k < walk1 + turn; ++k) {
        const tvo_pose T = walk_then_turn(k, walk1, rate, creep);
        assert_int_equal(step(f, &T, k, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        if (k >= walk1) {
            const double r = rot_err_deg(&res.T_w_c, &T);
            max_rot = r > max_rot ? r : max_rot;
            assert_int_equal(res.map_state, TVO_MAP_TRACKING);
            min_points = res.map_points < min_points ? res.map_points : min_points;
            if (res.keyframe && res.map_points < 2 * f->cfg.map_min_points)
                rescue_points += res.map_new_points;
        }
    }
    fprintf(stderr,
            "map fast turn: %d losses, fewest landmarks tracked %d, %d landmarks made at keyframes of a map "
            "running out, max rotation error %.3f deg\n",
            (int)res.map_losses, min_points, rescue_points, max_rot);
    assert_int_equal(res.map_losses, 0);
    assert_true(min_points < 2 * f->cfg.map_min_points); /* the turn does take the map to its rescue */
    assert_true(rescue_points > 0);
#if TVO_WITH_AFFINE
    assert_true(max_rot < 2.0);
#else
    assert_true(max_rot < 4.5);
#endif
    close_vo(f);
}

/* Walk to build the map, then turn at 4 deg a frame for 40 frames while the camera creeps 12 mm a frame
 * along its own axis from where the walk ended (a spiral: the step turns sideways, 28 mm a frame at the
 * end). The view is mostly one wall, so the two-view pose has a plane's twin that the tracks off the
 * plane often cannot tell apart; choosing by the last two-view directions, the choice drifts to the
 * wrong twin (its translation flips sideways, its rotation is off by up to 0.6 deg a frame) and the
 * default ends 12.6 deg off (docs/evaluation.md, "Fast turns in the test room"). With map_twin_dir the
 * map's last step tells the twins apart: no map loss, the rotation error within 1.5 deg over the turn
 * (0.52 measured at its worst, 0.40 at the end). Skipped without the affine refinement. */
static void test_map_twin_dir_turn(void **state)
{
#if !TVO_WITH_AFFINE
    /* the basic tracker (translation-only LK) ends about 10 deg off with or without map_twin_dir: its
       tracks, not the twins, fail this turn (docs/evaluation.md, "Fast turns in the test room") */
    skip();
#endif
    fixture *f = new_fixture(1);
    const int walk1 = 60, turn = 40;
    const double rate = 4.0 * M_PI / 180.0, creep = 0.012;
    double max_rot = 0.0;
    tvo_vo_result res;
    (void)state;
    f->cfg.map_twin_dir = 1;
    start_vo(f);
    for (int k = 0; k < walk1 + turn; ++k) {
        const tvo_pose T = walk_then_turn(k, walk1, rate, creep);
        assert_int_equal(step(f, &T, k, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        if (k >= walk1) {
            const double r = rot_err_deg(&res.T_w_c, &T);
            max_rot = r > max_rot ? r : max_rot;
        }
    }
    fprintf(stderr, "map twin dir turn: %d losses, max rotation error %.3f deg\n", (int)res.map_losses,
            max_rot);
    assert_int_equal(res.map_losses, 0);
    assert_true(max_rot < 1.5);
    close_vo(f);
}

/* Walk to build the map, then hover for 120 frames: the camera drifts sideways by 8 mm a frame (and up
 * and down by 3 cm, in yaw by 1.7 deg, slowly) facing the room's far wall, 4.7 m away. The two-view
 * estimate of every hover frame is rotation-only (the drift's flow, 0.1 deg a frame, is mostly a turn's
 * to two views), its rotation biased by what it absorbed; the map's landmarks have depth and tell the
 * two apart. The hover's per-frame rotation (T_w_c of consecutive frames against the ground truth)
 * must come out unbiased: the mean of its error vectors within 0.002 deg, their RMS within 0.045 deg,
 * the rotation error accumulated over the hover within 0.15 deg, with the map tracking every frame.
 * (With the two-view rotation as a fixed-weight prior the figures were 0.0029, 0.062 and 0.35 deg.) */
static void test_map_hover(void **state)
{
    fixture *f = open_vo(1);
    const int walk1 = 60, hover = 120;
    tvo_pose T_prev = tvo_pose_identity(), E_prev = tvo_pose_identity(), T0 = T_prev, E0 = T_prev;
    double drift, sum[3] = {0.0, 0.0, 0.0}, sum2v[3] = {0.0, 0.0, 0.0}, sq = 0.0, mean, mean2v;
    int n = 0, tracking = 0, rot_only = 0;
    (void)state;
    for (int k = 0; k < walk1 + hover; ++k) {
        tvo_vo_result res;
        tvo_pose T;
        if (k < walk1) {
            T = walk(k);
        } else {
            const tvo_pose W0 = walk(walk1 - 1);
            const double ph = 2.0 * M_PI * (k - walk1 + 1) / hover;
            const double v[3] = {0.0, 0.03 * sin(ph), 0.0};
            double Ry[9];
            T = W0;
            tvo_rotvec_to_rot(v, Ry);
            tvo_la_mat3_mul(Ry, W0.R, T.R);
            T.t[0] += 0.008 * (k - walk1 + 1);
            T.t[1] += 0.03 * sin(ph);
        }
        assert_int_equal(step(f, &T, k, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        if (k == walk1) {
            T0 = T;
            E0 = res.T_w_c;
        } else if (k > walk1) {
            /* the error of the frame's rotation step: R_gt_step^T R_est_step, as a rotation vector */
            const tvo_pose dg = tvo_pose_relative(&T_prev, &T), de = tvo_pose_relative(&E_prev, &res.T_w_c);
            double Re[9], v[3], v2[3];
            tvo_la_mat3_mul_at(dg.R, de.R, Re);
            tvo_rot_to_rotvec(Re, v);
            tvo_la_mat3_mul_at(dg.R, res.T_prev_cur.R, Re); /* the two-view step's, for the report */
            tvo_rot_to_rotvec(Re, v2);
            for (int c = 0; c < 3; ++c) {
                sum[c] += v[c];
                sum2v[c] += v2[c];
                sq += v[c] * v[c];
            }
            ++n;
            tracking += res.map_state == TVO_MAP_TRACKING;
            rot_only += res.state == TVO_VO_ROTATION_ONLY;
        }
        T_prev = T;
        E_prev = res.T_w_c;
    }
    mean = sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]) / n * 180.0 / M_PI;
    mean2v = sqrt(sum2v[0] * sum2v[0] + sum2v[1] * sum2v[1] + sum2v[2] * sum2v[2]) / n * 180.0 / M_PI;
    {
        /* the rotation error accumulated over the hover */
        const tvo_pose dg = tvo_pose_relative(&T0, &T_prev), de = tvo_pose_relative(&E0, &E_prev);
        drift = rot_err_deg(&de, &dg);
    }
    sq = sqrt(sq / n) * 180.0 / M_PI;
    fprintf(stderr,
            "map hover: %d frames, %d rotation-only, %d tracked by the map; per-frame rotation error mean "
            "%.4f deg, RMS %.4f deg (the two-view steps' mean %.4f deg); accumulated %.3f deg\n",
            n, rot_only, tracking, mean, sq, mean2v, drift);
    assert_int_equal(tracking, n);
    assert_true(mean < 0.002);
    assert_true(sq < 0.045);
    assert_true(drift < 0.15);
    close_vo(f);
}

/* Three blank frames in the middle of a walk lose the tracks and the map; the VO reports the loss, makes a
 * new map, and the trajectory continues in the same unit: the scale fitted after the loss is within 25 %
 * of the one before it. */
static void test_map_loss_and_new_map(void **state)
{
    fixture *f = open_vo(1);
    static tvo_pose gt[LONG_RUN], est[LONG_RUN];
    int lost_frame = -1, reinit = -1;
    double s_before, s_after;
    tvo_vo_result res;
    (void)state;
    for (int k = 0; k < LONG_RUN; ++k) {
        gt[k] = walk(k);
        if (k >= 70 && k < 73) {
            tvo_image img = tvo_image_make(W, H, W, f->img);
            memset(f->img, 128, sizeof(f->img));
            assert_int_equal(tvo_vo_process(f->vo, &img, 1000000000LL + k * DT_NS, &res), TVO_OK);
        } else {
            assert_int_equal(step(f, &gt[k], k, &res), TVO_OK);
        }
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        est[k] = res.T_w_c;
        if (res.map_state == TVO_MAP_LOST && lost_frame < 0)
            lost_frame = k;
        if (lost_frame >= 0 && reinit < 0 && res.map_state == TVO_MAP_INITIALISED)
            reinit = k;
    }
    fprintf(stderr, "map loss: lost at %d, new map at %d, %d losses\n", lost_frame, reinit,
            (int)res.map_losses);
    assert_true(lost_frame >= 70 && lost_frame < 74);
    assert_true(reinit > lost_frame && reinit < lost_frame + 40);
    assert_true(res.map_losses >= 1);
    assert_int_equal(res.map_state, TVO_MAP_TRACKING);
    {
        /* scales of the displacement from the loss: the new map's positions relative to the pose where the
           old one ended */
        double num = 0.0, den = 0.0;
        s_before = best_scale(gt, est, 30, lost_frame);
        for (int k = reinit + 5; k < LONG_RUN; ++k)
            for (int c = 0; c < 3; ++c) {
                const double g = gt[k].t[c] - gt[reinit].t[c], e = est[k].t[c] - est[reinit].t[c];
                num += g * e;
                den += e * e;
            }
        s_after = den > 0.0 ? num / den : 0.0;
    }
    fprintf(stderr, "map loss: scale before %.4f after %.4f\n", s_before, s_after);
    assert_true(s_after > 0.0 && fabs(s_after / s_before - 1.0) < 0.25);
    close_vo(f);
}

/* The tracks view: counts, unique ids, landmark flags that agree with the map's count, bad arguments. */
static void test_tracks_view(void **state)
{
    fixture *f = open_vo(1);
    tvo_vo_track *t = calloc((size_t)f->cfg.max_tracks, sizeof(tvo_vo_track));
    int32_t n = -1, small = -1;
    tvo_vo_result res;
    (void)state;
    assert_non_null(t);
    for (int k = 0; k < 40; ++k) {
        const tvo_pose T = walk(k);
        assert_int_equal(step(f, &T, k, &res), TVO_OK);
    }
    assert_int_equal(res.map_state, TVO_MAP_TRACKING);
    assert_int_equal(tvo_vo_tracks(f->vo, t, f->cfg.max_tracks, &n), TVO_OK);
    assert_int_equal(n, res.tracks);
    {
        int lm = 0, inl = 0;
        for (int32_t i = 0; i < n; ++i) {
            assert_true(t[i].x >= 0.0f && t[i].x <= (float)(W - 1) && t[i].y >= 0.0f &&
                        t[i].y <= (float)(H - 1));
            assert_true(t[i].age >= 0 && t[i].age < 40);
            lm += t[i].landmark;
            inl += t[i].inlier;
            for (int32_t j = 0; j < i; ++j)
                assert_true(t[i].id != t[j].id);
        }
        /* the frame's PnP inliers that are still tracked carry landmarks; new tracks carry none */
        assert_true(lm >= res.map_points / 2 && lm <= res.map_landmarks);
        assert_true(inl <= lm + res.map_new_points);
    }
    assert_int_equal(tvo_vo_tracks(f->vo, t, 3, &small), TVO_OK);
    assert_int_equal(small, n);
    assert_int_equal(tvo_vo_tracks(f->vo, NULL, 0, &small), TVO_OK);
    assert_int_equal(tvo_vo_tracks(NULL, t, 3, &small), TVO_ERR_NULL);
    assert_int_equal(tvo_vo_tracks(f->vo, NULL, 3, &small), TVO_ERR_NULL);
    assert_int_equal(tvo_vo_tracks(f->vo, t, 3, NULL), TVO_ERR_NULL);
    assert_int_equal(tvo_vo_tracks(f->vo, t, -1, &small), TVO_ERR_ARG);
    free(t);
    close_vo(f);
}

/* The map's configuration: each out-of-range field is refused (size 0, init TVO_ERR_ARG); the map's
 * memory is part of tvo_vo_required_size and grows with the window. */
/* cfg.map_init_wait_s: with a FAST threshold of 52 (and no low-contrast retry) the room gives fewer than
 * 100 tracks, so no pair of frames gives the 100 landmarks a map needs with 300 tracks, and without the
 * wait the VO stays on the two-view chain for the whole run; with a wait of 1 s (20 frames) the map
 * starts after it, on 50, and poses the frames from there on. Every pose finite either way. */
static void test_map_init_wait(void **state)
{
    (void)state;
    for (int pass = 0; pass < 2; ++pass) {
        fixture *f = new_fixture(1);
        int init_frame = -1, tracking = 0, max_tracks = 0;
        f->cfg.detect.fast_threshold = 52;
        f->cfg.fast_min_threshold = 0;
        f->cfg.map_init_wait_s = pass == 0 ? 0.0 : 1.0;
        start_vo(f);
        for (int k = 0; k < 60; ++k) {
            tvo_vo_result res;
            walk_step(f, k, &res);
            max_tracks = res.tracks > max_tracks ? res.tracks : max_tracks;
            if (res.map_state == TVO_MAP_INITIALISED && init_frame < 0)
                init_frame = k;
            tracking += res.map_state == TVO_MAP_TRACKING;
        }
        fprintf(stderr, "map_init_wait_s %.1f: at most %d tracks, map from frame %d, %d frames tracked\n",
                f->cfg.map_init_wait_s, max_tracks, init_frame, tracking);
        assert_true(max_tracks <= 100);
        if (pass == 0) {
            assert_int_equal(init_frame, -1);
            assert_int_equal(tracking, 0);
        } else {
            assert_true(init_frame >= 20 && init_frame < 40);
            assert_int_equal(tracking, 59 - init_frame);
        }
        close_vo(f);
    }
}

/* The first map needs its points at map_tri_parallax_deg like every landmark, but falls back to 0.5 deg
 * when fewer than it needs reach a higher threshold: with 5 deg (which few of the first pair's points
 * reach) the map starts on the same frame with the same landmarks as with the default 0.5 deg, and goes
 * on tracking. */
static void test_map_init_fallback(void **state)
{
    int init_frame[2] = {-1, -1}, init_points[2] = {0, 0}, tracking[2] = {0, 0};
    (void)state;
    for (int pass = 0; pass < 2; ++pass) {
        fixture *f = new_fixture(1);
        f->cfg.map_tri_parallax_deg = pass == 0 ? 0.5 : 5.0;
        start_vo(f);
        for (int k = 0; k < 60; ++k) {
            tvo_vo_result res;
            walk_step(f, k, &res);
            if (res.map_state == TVO_MAP_INITIALISED && init_frame[pass] < 0) {
                init_frame[pass] = k;
                init_points[pass] = res.map_new_points;
            }
            tracking[pass] += res.map_state == TVO_MAP_TRACKING;
        }
        fprintf(stderr, "map_tri_parallax_deg %.1f: map from frame %d on %d landmarks, %d frames tracked\n",
                f->cfg.map_tri_parallax_deg, init_frame[pass], init_points[pass], tracking[pass]);
        close_vo(f);
    }
    assert_true(init_frame[0] >= 0);
    assert_int_equal(init_frame[1], init_frame[0]);
    assert_int_equal(init_points[1], init_points[0]);
    assert_int_equal(tracking[1], 59 - init_frame[1]);
}

static void test_map_config(void **state)
{
    tvo_camera cam = test_camera();
    tvo_vo_config c0, c;
    size_t with, without, wide;
    (void)state;
    tvo_vo_config_default(&c0, &cam);
    with = tvo_vo_required_size(&c0);
    c = c0;
    c.map = 0;
    without = tvo_vo_required_size(&c);
    c = c0;
    c.map_window = TVO_VO_MAX_WINDOW;
    wide = tvo_vo_required_size(&c);
    assert_true(with > without && wide > with);
#define REFUSED(field, value)                                                  \
    do {                                                                       \
        tvo_vo *vo = NULL;                                                     \
        static uint8_t mem[64];                                                \
        c = c0;                                                                \
        c.field = value;                                                       \
        assert_int_equal(tvo_vo_required_size(&c), 0);                         \
        assert_int_equal(tvo_vo_init(&vo, &c, mem, sizeof(mem)), TVO_ERR_ARG); \
    } while (0)
    REFUSED(map, 2);
    REFUSED(map, -1);
    REFUSED(map_window, 2);
    REFUSED(map_window, TVO_VO_MAX_WINDOW + 1);
    REFUSED(map_max_landmarks, 15);
    REFUSED(map_max_landmarks, -1);
    REFUSED(map_min_points, 5);
    REFUSED(map_min_points, 100001);
    REFUSED(map_init_parallax_deg, 0.0);
    REFUSED(map_init_parallax_deg, NAN);
    REFUSED(map_init_wait_s, -1.0);
    REFUSED(map_init_wait_s, 86401.0);
    REFUSED(map_init_wait_s, NAN);
    REFUSED(chain_scale_sigmas, -1.0);
    REFUSED(chain_scale_sigmas, 100.5);
    REFUSED(chain_scale_sigmas, NAN);
    REFUSED(map_inlier_sigmas, -1.0);
    REFUSED(map_inlier_sigmas, NAN);
#if TVO_WITH_AFFINE
    REFUSED(map_inlier_sigmas, 100.5);
#endif
    REFUSED(map_lm_prior, -0.1);
    REFUSED(map_lm_prior, NAN);
#if TVO_WITH_AFFINE
    REFUSED(map_lm_prior, 1.5);
#endif
    REFUSED(map_lm_prior_gate, -0.5);
    REFUSED(map_lm_prior_gate, NAN);
    REFUSED(map_lm_prior_gate, 100.5);
    REFUSED(map_lm_prior_gate, INFINITY);
    REFUSED(map_tri_parallax_deg, 31.0);
    REFUSED(map_kf_baseline, 0.0);
    REFUSED(map_kf_baseline, INFINITY);
    REFUSED(map_kf_points_ratio, -0.1);
    REFUSED(map_kf_points_ratio, 1.1);
    REFUSED(map_kf_max_frames, 0);
    REFUSED(map_ba_iterations, 0);
    REFUSED(map_ba_iterations, 101);
    REFUSED(map_ba_max_turn_deg, 0.0);
    REFUSED(map_ba_max_turn_deg, -1.0);
    REFUSED(map_ba_max_turn_deg, 180.5);
    REFUSED(map_ba_max_turn_deg, NAN);
    REFUSED(map_ba_huber_px, 0.0);
    REFUSED(map_ba_huber_px, -1.0);
    REFUSED(map_ba_huber_px, 100.5);
    REFUSED(map_ba_huber_px, NAN);
    REFUSED(map_ba_huber_px, INFINITY);
    REFUSED(map_ba_rot_prior, -1.0);
    REFUSED(map_ba_rot_prior, 1.1e12);
    REFUSED(map_ba_rot_prior, NAN);
#undef REFUSED
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_map_consistent_scale), cmocka_unit_test(test_map_off),
            cmocka_unit_test(test_map_pure_rotation),    cmocka_unit_test(test_map_rotation_after_map),
            cmocka_unit_test(test_map_fast_turn),        cmocka_unit_test(test_map_twin_dir_turn),
            cmocka_unit_test(test_map_loss_and_new_map), cmocka_unit_test(test_tracks_view),
            cmocka_unit_test(test_map_config),           cmocka_unit_test(test_map_hover),
            cmocka_unit_test(test_map_ba_turn_check),    cmocka_unit_test(test_map_init_wait),
            cmocka_unit_test(test_map_init_fallback),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
