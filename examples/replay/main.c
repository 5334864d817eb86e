/* SPDX-License-Identifier: Apache-2.0 */
/* tvo_replay: replay a dataset sequence (EuRoC/ASL, TUM RGB-D or KITTI odometry) through the tinyvo
 * VO and write the trajectory.
 *
 *   tvo_replay (--euroc DIR [--cam cam0|cam1] | --tum DIR | --kitti DIR [--poses FILE]) --out TRAJ.txt
 *              [--calib FILE [--calib-cam NAME]] [--scale gt|model|propagate|const|none] [--model FILE]
 *              [--scale-alpha A] [--step M] [--frame camera|body] [--stats STATS.json]
 *              [--max-frames N] [--strict] [--quiet]
 *
 * The trajectory is written in TUM format (t tx ty tz qx qy qz qw, seconds). Bad frames (missing,
 * corrupt, wrong size, non-increasing timestamps) and malformed rows of the frame list (data.csv,
 * rgb.txt, times.txt) are reported ("file:line: what" for a row), counted in the stats and skipped, and
 * so are gaps (intervals longer than 1.5 frame periods); the VO tracks across them, as across the frames
 * a camera drops, and keeps its map and its unit (--gap-reset S re-initialises it after gaps longer than
 * S seconds). --strict turns each of them into a non-zero exit instead.
 * Exit codes: 0 done, 1 a runtime error (one line on stderr), 2 a usage error (one line naming the
 * option).
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "tinyvo/nn.h"
#include "tinyvo/port/calib.h"
#include "tinyvo/port/clock.h"
#include "tinyvo/port/dataset.h"
#include "tinyvo/port/euroc.h"
#include "tinyvo/port/png.h"
#include "tinyvo/version.h"
#include "tinyvo/vo.h"

#include "map_scale.h"
#include "settings.h"

enum scale_mode { SCALE_NONE, SCALE_GT, SCALE_MODEL, SCALE_PROPAGATE, SCALE_CONST };
static const char *const scale_names[5] = {"none", "gt", "model", "propagate", "const"};
enum skip_kind { SKIP_MISSING, SKIP_CORRUPT, SKIP_SIZE, SKIP_TIMESTAMP, SKIP_BAD_ROW, SKIP_COUNT };
static const char *const skip_names[SKIP_COUNT] = {"missing", "corrupt", "wrong_size", "timestamp",
                                                   "bad_row"};
enum source_kind { SRC_EUROC, SRC_TUM, SRC_KITTI };
static const char *const source_names[3] = {"euroc", "tum", "kitti"};
static const char *const state_names[TVO_VO_STATE_COUNT] = {"ok", "initialising", "rotation_only", "lost"};
static const char *const feature_names[TVO_FEAT_COUNT] = {"rx",       "ry", "rz",           "tx",
                                                          "ty",       "tz", "inlier_ratio", "parallax_deg",
                                                          "tracks_k", "dt", "rot_only"};
static const char *const stage_names[TVO_STAGE_COUNT] = {"pyramid", "track", "undistort", "pose",
                                                         "detect",  "map",   "total"};
static const char *const map_state_names[TVO_MAP_STATE_COUNT] = {"off", "initialising", "initialised",
                                                                 "tracking", "lost"};

#define TVO_REPLAY_MAX_SETS 64

typedef struct options {
    const char *dir, *cam, *out, *model, *stats, *features, *tracks;
    const char *poses, *calib, *calib_cam;
    enum source_kind source;
    enum scale_mode scale;
    double alpha, step; /* --scale-alpha (< 0: not given), --step */
    double gap_reset;   /* --gap-reset S: reset the VO after a gap longer than S s (0: never) */
    int body_frame, strict, quiet, print_memory;
    int keyframe;         /* --keyframe 0|1 (< 0: the library's default) */
    int track_prediction; /* --track-prediction 0|1 (< 0: the library's default) */
    int map;              /* --map 0|1 (< 0: the library's default) */
    tvo_vo_preset preset; /* --preset */
    long max_frames;
    const char *sets[TVO_REPLAY_MAX_SETS]; /* --set NAME=VALUE, in order */
    int n_sets, list_settings;
} options;

/* The replayed camera's folder name: the EuRoC camera given, or the TUM and KITTI layouts' one. */
static const char *camera_name(const options *o)
{
    return o->source == SRC_EUROC ? o->cam : (o->source == SRC_TUM ? "rgb" : "image_0");
}

static void usage(FILE *f)
{
    fprintf(f,
            "usage: tvo_replay (--euroc DIR | --tum DIR | --kitti DIR) --out TRAJ.txt [options]\n"
            "  --euroc DIR          EuRoC/ASL sequence (folder holding mav0/)\n"
            "  --cam cam0|cam1      EuRoC camera to replay (default cam0)\n"
            "  --tum DIR            TUM RGB-D sequence (rgb.txt, rgb/, groundtruth.txt); the camera\n"
            "                       from --calib, else the published freiburg1/2/3 one named by DIR\n"
            "  --kitti DIR          KITTI odometry sequence (image_0/, times.txt, calib.txt)\n"
            "  --poses FILE         KITTI ground-truth poses (default: DIR/poses.txt or\n"
            "                       DIR/../../poses/<seq>.txt when present)\n"
            "  --calib FILE         camera calibration replacing the dataset's: EuRoC sensor.yaml,\n"
            "                       Kalibr camchain, OpenCV or ROS camera_info YAML\n"
            "                       (docs/calibration.md); its size must be the frames'\n"
            "  --calib-cam NAME     camera of a Kalibr camchain (default cam0)\n"
            "  --out FILE           trajectory in TUM format (t tx ty tz qx qy qz qw) after one\n"
            "                       '#' line naming the frame, camera and scale (tinyvo-eval\n"
            "                       reads it)\n"
            "  --scale MODE         the metric scale of the map's trajectory (one unknown\n"
            "                       factor for the whole run): none (the map's own unit, the\n"
            "                       first baseline; default), gt (set at every keyframe from\n"
            "                       the ground-truth path length so far), model (the same\n"
            "                       with the per-DoF networks' step lengths, --model),\n"
            "                       const (the same with --step per frame), propagate (set\n"
            "                       once, at the map's first keyframes, from ground truth).\n"
            "                       Until a keyframe sets the factor (before the first map,\n"
            "                       after a reset) each step takes the source's own length\n"
            "                       With --map 0, each frame's step length instead (docs)\n"
            "  --model FILE         tinyvo weights file (needed by --scale model)\n"
            "  --scale-alpha A      with model or const: the factor follows each keyframe\n"
            "                       interval's length ratio r as log s = (1-A) log s + A log r\n"
            "                       instead of the ratio of the whole path; A in [0, 1]\n"
            "                       (with --map 0: the per-step filter of vo.h)\n"
            "  --step M             constant step length in metres for --scale const\n"
            "  --frame camera|body  pose written: camera (default) or body (through T_BS; needs\n"
            "                       a metric --scale: T_BS is in metres)\n"
            "  --stats FILE         JSON with frame counts, status counts, stage timings and\n"
            "                       the tracks kept from frame to frame (tracks: new / old,\n"
            "                       those detected in the previous frame / older, and how\n"
            "                       many of each were still tracked)\n"
            "  --features FILE      CSV of the per-frame front-end features (nn.h layout), for\n"
            "                       the dataset builder: t_ns,state,relpose_flags,\n"
            "                       pose_status,inliers,<feature names>,rel_scale,\n"
            "                       rel_scale_points\n"
            "  --preset NAME        default (balanced in a build with the affine refinement,\n"
            "                       else basic), balanced (tracks re-aligned to their first\n"
            "                       patch, the map's predicted tracks on 2 levels), accurate\n"
            "                       (balanced with the full tracker on every track: more\n"
            "                       accurate on real frames, 1.7x balanced's instructions),\n"
            "                       basic (translation-only LK, no prediction: the least\n"
            "                       memory) or small (a QVGA microcontroller's configuration);\n"
            "                       the switches below and --set apply on top (vo.h)\n");
    fprintf(f,
            "  --map 0|1            local map (keyframes, landmarks, bundle adjustment) on or\n"
            "                       off (vo.h; default: the library's, on)\n"
            "  --tracks FILE        CSV of the tracks after every frame: t_ns,id,x,y,age,flags\n"
            "                       (pixels; flags: 1 pose inlier, 2 map landmark, 4 keyframe)\n"
            "  --keyframe 0|1       keyframe rotation on or off (vo.h; default: the library's)\n"
            "  --track-prediction 0|1\n"
            "                       LK guesses from the previous frame's rotation on or off\n"
            "                       (vo.h; default: the library's)\n"
            "  --max-frames N       stop after N frames\n"
            "  --gap-reset S        re-initialise the VO after a gap of more than S seconds\n"
            "                       between two frames (default 0: never; the VO tracks\n"
            "                       across dropped frames and keeps the map and its unit)\n"
            "  --strict             exit non-zero at the first bad frame or row instead of skipping it\n"
            "  --quiet              no progress line and no summary (errors and skipped frames\n"
            "                       are still reported)\n"
            "  --print-memory       print the VO working-memory size for the sequence and exit\n"
            "  --set NAME=VALUE     set a field of tvo_vo_config (vo.h) by name, e.g. map_window=8,\n"
            "                       lk.win_size=15; repeatable, applied after the switches above\n"
            "  --list-settings      print every NAME --set knows, its type and default, and exit\n"
            "  --version            print the version and exit\n"
            "  --help               this text\n"
            "Exit codes: 0 done, 1 runtime error, 2 usage error.\n");
}

/* A 0|1 switch's value into *out; -1 with a message naming the option otherwise. */
static int parse_switch(const char *opt, const char *v, int *out)
{
    if (strcmp(v, "0") != 0 && strcmp(v, "1") != 0) {
        fprintf(stderr, "tvo_replay: %s must be 0 or 1 (got '%s')\n", opt, v);
        return -1;
    }
    *out = v[0] - '0';
    return 0;
}

static int parse_args(int argc, char **argv, options *o)
{
    memset(o, 0, sizeof(*o));
    o->cam = "cam0";
    o->scale = SCALE_NONE;
    o->alpha = -1.0;
    o->step = -1.0;
    o->max_frames = -1;
    o->keyframe = -1;
    o->track_prediction = -1;
    o->map = -1;
    o->preset = TVO_VO_PRESET_DEFAULT;
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
#define NEED_VALUE()                                              \
    do {                                                          \
        if (v == NULL) {                                          \
            fprintf(stderr, "tvo_replay: %s needs a value\n", a); \
            return -1;                                            \
        }                                                         \
        ++i;                                                      \
    } while (0)
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            exit(0);
        } else if (!strcmp(a, "--version")) {
            printf("tvo_replay %s\n", tvo_version());
            exit(0);
        } else if (!strcmp(a, "--euroc") || !strcmp(a, "--tum") || !strcmp(a, "--kitti")) {
            NEED_VALUE();
            if (o->dir != NULL) {
                fprintf(stderr, "tvo_replay: %s: only one of --euroc, --tum, --kitti\n", a);
                return -1;
            }
            o->dir = v;
            o->source = !strcmp(a, "--euroc") ? SRC_EUROC : (!strcmp(a, "--tum") ? SRC_TUM : SRC_KITTI);
        } else if (!strcmp(a, "--poses")) {
            NEED_VALUE();
            o->poses = v;
        } else if (!strcmp(a, "--calib")) {
            NEED_VALUE();
            o->calib = v;
        } else if (!strcmp(a, "--calib-cam")) {
            NEED_VALUE();
            o->calib_cam = v;
        } else if (!strcmp(a, "--cam")) {
            NEED_VALUE();
            o->cam = v;
        } else if (!strcmp(a, "--out")) {
            NEED_VALUE();
            o->out = v;
        } else if (!strcmp(a, "--model")) {
            NEED_VALUE();
            o->model = v;
        } else if (!strcmp(a, "--features")) {
            NEED_VALUE();
            o->features = v;
        } else if (!strcmp(a, "--stats")) {
            NEED_VALUE();
            o->stats = v;
        } else if (!strcmp(a, "--scale")) {
            NEED_VALUE();
            if (!strcmp(v, "gt"))
                o->scale = SCALE_GT;
            else if (!strcmp(v, "model"))
                o->scale = SCALE_MODEL;
            else if (!strcmp(v, "none"))
                o->scale = SCALE_NONE;
            else if (!strcmp(v, "propagate"))
                o->scale = SCALE_PROPAGATE;
            else if (!strcmp(v, "const"))
                o->scale = SCALE_CONST;
            else {
                fprintf(stderr,
                        "tvo_replay: --scale must be gt, model, propagate, const or none (got '%s')\n", v);
                return -1;
            }
        } else if (!strcmp(a, "--scale-alpha") || !strcmp(a, "--step")) {
            char *end = NULL;
            double x;
            NEED_VALUE();
            x = strtod(v, &end);
            if (end == v || *end != '\0' || !isfinite(x) ||
                (!strcmp(a, "--step") ? !(x > 0.0) : !(x >= 0.0 && x <= 1.0))) {
                fprintf(stderr, "tvo_replay: %s needs a number %s (got '%s')\n", a,
                        !strcmp(a, "--step") ? "> 0" : "in [0, 1]", v);
                return -1;
            }
            if (!strcmp(a, "--step"))
                o->step = x;
            else
                o->alpha = x;
        } else if (!strcmp(a, "--gap-reset")) {
            char *end = NULL;
            NEED_VALUE();
            o->gap_reset = strtod(v, &end);
            if (end == v || *end != '\0' || !isfinite(o->gap_reset) || !(o->gap_reset >= 0.0)) {
                fprintf(stderr, "tvo_replay: --gap-reset needs seconds >= 0 (got '%s')\n", v);
                return -1;
            }
        } else if (!strcmp(a, "--frame")) {
            NEED_VALUE();
            if (!strcmp(v, "body"))
                o->body_frame = 1;
            else if (!strcmp(v, "camera"))
                o->body_frame = 0;
            else {
                fprintf(stderr, "tvo_replay: --frame must be camera or body (got '%s')\n", v);
                return -1;
            }
        } else if (!strcmp(a, "--max-frames")) {
            char *end = NULL;
            NEED_VALUE();
            o->max_frames = strtol(v, &end, 10);
            if (end == v || *end != '\0' || o->max_frames < 0) {
                fprintf(stderr, "tvo_replay: --max-frames needs a non-negative integer (got '%s')\n", v);
                return -1;
            }
        } else if (!strcmp(a, "--preset")) {
            tvo_vo_config check;
            NEED_VALUE();
            if (tvo_replay_preset_from_name(v, &o->preset) != 0) {
                fprintf(stderr,
                        "tvo_replay: --preset must be default, balanced, accurate, basic or small (got "
                        "'%s')\n",
                        v);
                return -1;
            }
            if (tvo_vo_config_preset(&check, NULL, o->preset) == TVO_ERR_UNSUPPORTED) {
                fprintf(stderr,
                        "tvo_replay: --preset %s needs the affine refinement, which this build of the "
                        "library leaves out (TVO_WITH_AFFINE off)\n",
                        v);
                return -1;
            }
        } else if (!strcmp(a, "--map")) {
            NEED_VALUE();
            if (parse_switch(a, v, &o->map) != 0)
                return -1;
        } else if (!strcmp(a, "--tracks")) {
            NEED_VALUE();
            o->tracks = v;
        } else if (!strcmp(a, "--keyframe") || !strcmp(a, "--track-prediction")) {
            NEED_VALUE();
            if (parse_switch(a, v, !strcmp(a, "--keyframe") ? &o->keyframe : &o->track_prediction) != 0)
                return -1;
        } else if (!strcmp(a, "--strict")) {
            o->strict = 1;
        } else if (!strcmp(a, "--quiet")) {
            o->quiet = 1;
        } else if (!strcmp(a, "--print-memory")) {
            o->print_memory = 1;
        } else if (!strcmp(a, "--set")) {
            tvo_vo_config check;
            NEED_VALUE();
            tvo_vo_config_default(&check, NULL);
            if (tvo_replay_setting_apply(&check, v) != 0)
                return -1;
            if (o->n_sets == TVO_REPLAY_MAX_SETS) {
                fprintf(stderr, "tvo_replay: at most %d --set options\n", TVO_REPLAY_MAX_SETS);
                return -1;
            }
            o->sets[o->n_sets++] = v;
        } else if (!strcmp(a, "--list-settings")) {
            o->list_settings = 1;
        } else {
            fprintf(stderr, "tvo_replay: unknown option '%s' (see --help)\n", a);
            return -1;
        }
#undef NEED_VALUE
    }
    if (o->list_settings)
        return 0;
    if (o->dir == NULL) {
        fprintf(stderr, "tvo_replay: one of --euroc, --tum, --kitti is required (see --help)\n");
        return -1;
    }
    if (o->out == NULL && !o->print_memory) {
        fprintf(stderr, "tvo_replay: --out is required (see --help)\n");
        return -1;
    }
    if (o->poses != NULL && o->source != SRC_KITTI) {
        fprintf(stderr, "tvo_replay: --poses goes with --kitti\n");
        return -1;
    }
    if (o->calib_cam != NULL && o->calib == NULL) {
        fprintf(stderr, "tvo_replay: --calib-cam goes with --calib\n");
        return -1;
    }
    if (o->scale == SCALE_MODEL && o->model == NULL) {
        fprintf(stderr, "tvo_replay: --scale model needs --model FILE\n");
        return -1;
    }
    if (o->scale == SCALE_CONST && o->step < 0.0) {
        fprintf(stderr, "tvo_replay: --scale const needs --step M\n");
        return -1;
    }
    if (o->alpha >= 0.0 && o->scale != SCALE_MODEL && o->scale != SCALE_CONST) {
        fprintf(stderr, "tvo_replay: --scale-alpha goes with --scale model or const\n");
        return -1;
    }
    if (o->body_frame && o->scale == SCALE_NONE) {
        /* T_BS's translation is in metres, the trajectory in the map's unit: the body's position would be
           the camera's with the lever arm shrunk or grown by the unknown scale */
        fprintf(stderr,
                "tvo_replay: --frame body needs a metric --scale (gt, model, const or propagate): "
                "with --scale none the trajectory is in the map's unit and T_BS in metres\n");
        return -1;
    }
    return 0;
}

static int64_t clock_cb(void *user)
{
    (void)user;
    return tvo_clock_now_ns();
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* median and 90th percentile (nearest rank) of v[0..n), sorting v in place */
static void percentiles(double *v, long n, double *median, double *p90)
{
    if (n <= 0) {
        *median = *p90 = 0.0;
        return;
    }
    qsort(v, (size_t)n, sizeof(double), cmp_double);
    *median = (n % 2) ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
    *p90 = v[(long)ceil(0.9 * (double)n) - 1];
}

static void write_pose(FILE *f, int64_t t_ns, const tvo_pose *T)
{
    double q[4];
    tvo_rot_to_quat(T->R, q);
    fprintf(f, "%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", (double)t_ns * 1e-9, T->t[0], T->t[1], T->t[2],
            q[1], q[2], q[3], q[0]);
}

static void *read_file(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    void *buf = NULL;
    long n;
    if (f == NULL)
        return NULL;
    if (fseek(f, 0, SEEK_END) == 0 && (n = ftell(f)) >= 0 && fseek(f, 0, SEEK_SET) == 0) {
        buf = malloc(n > 0 ? (size_t)n : 1);
        if (buf != NULL && fread(buf, 1, (size_t)n, f) != (size_t)n) {
            free(buf);
            buf = NULL;
        }
        *size = (size_t)n;
    }
    fclose(f);
    return buf;
}

int main(int argc, char **argv)
{
    options o;
    char err[512] = "";
    tvo_euroc *seq = NULL;
    tvo_calib calib;
    tvo_camera camera;
    tvo_vo_config cfg;
    tvo_vo *vo = NULL;
    tvo_traj traj;
    tvo_scale_filter filt;
    tvo_pose T_bs, T_sb;
    void *vo_mem = NULL, *nn_file = NULL, *nn_mem = NULL;
    tvo_nn *nn = NULL;
    uint8_t *frame = NULL;
    double *timing[TVO_STAGE_COUNT + 1] = {0};
    long counts_state[TVO_VO_STATE_COUNT] = {0}, counts_skip[SKIP_COUNT] = {0};
    long keyframe_frames = 0; /* frames whose rotation is the keyframe rotation */
    long lens_updates = 0;
    double lens_dk[2] = {0.0, 0.0};
    long counts_map[TVO_MAP_STATE_COUNT] = {0}, map_keyframes = 0, ba_turn_refused = 0, map_store_full = 0,
         gain_retries = 0, pred_rescues = 0, map_refound = 0;
    long affine_tried = 0, affine_refined = 0, affine_ended = 0; /* the affine refinement's attempts,
                                                                      successes and tracks ended */
    /* tracks kept from one processed frame to the next: those detected in the previous frame (age 0
       there) that are still tracked (age 1), and the older ones (age >= 1 there, >= 2 here) */
    long kept_new = 0, from_new = 0, kept_old = 0, from_old = 0, prev_new = 0, prev_old = 0;
    tvo_map_scale msc;
    tvo_pose T_w_c_vo_prev = {{0}, {0}}; /* the VO's world pose of the previous frame (map on) */
    int vo_reset_pending =
            0; /* the VO was reset: its next T_w_c starts again from the identity, in a new unit */
    tvo_vo_track *trk = NULL;
    FILE *tracks = NULL;
    long n_frames, processed = 0, gaps = 0, gap_resets = 0, gt_missing = 0, timed = 0;
    int64_t t_last = INT64_MIN, period_ns;
    int have_gt, have_prev_gt = 0, rc = 1, tty;
    size_t vo_size, frame_cap;
    tvo_pose T_w_b_prev;
    FILE *out = NULL, *feat = NULL;
    double t_start;
    tvo_status st;

    if (parse_args(argc, argv, &o) != 0)
        return 2;
    if (o.list_settings) {
        tvo_vo_config_default(&cfg, NULL);
        tvo_replay_settings_print(stdout, &cfg);
        return 0;
    }
    tty = !o.quiet && isatty(STDERR_FILENO);

    memset(&calib, 0, sizeof(calib));
    if (o.calib != NULL) {
        st = tvo_calib_load(o.calib, o.calib_cam, &calib, err, sizeof(err));
        if (st != TVO_OK) {
            fprintf(stderr, "tvo_replay: calibration refused (%s): %s\n", tvo_status_str(st), err);
            return 1;
        }
    }
    {
        /* --strict: a malformed row of the frame list fails the open; else it is reported and skipped */
        const unsigned flags = o.strict ? 0u : TVO_EUROC_SKIP_BAD_ROWS;
        if (o.source == SRC_TUM)
            st = tvo_tum_open(&seq, o.dir, o.calib != NULL ? &calib.camera : NULL, flags, err, sizeof(err));
        else if (o.source == SRC_KITTI)
            st = tvo_kitti_open(&seq, o.dir, o.poses, flags, err, sizeof(err));
        else
            st = tvo_euroc_open_ex(&seq, o.dir, o.cam, flags, err, sizeof(err));
    }
    if (st != TVO_OK) {
        fprintf(stderr, "tvo_replay: cannot open %s (%s): %s\n", o.dir, tvo_status_str(st), err);
        return 1;
    }
    counts_skip[SKIP_BAD_ROW] = tvo_euroc_bad_row_count(seq);
    for (int32_t k = 0; k < tvo_euroc_bad_row_count(seq) && tvo_euroc_bad_row(seq, k) != NULL; ++k)
        fprintf(stderr, "tvo_replay: %s: row skipped\n", tvo_euroc_bad_row(seq, k));
    if (tvo_euroc_bad_row_count(seq) > TVO_EUROC_MAX_BAD_ROWS)
        fprintf(stderr, "tvo_replay: %ld more malformed rows skipped\n",
                (long)tvo_euroc_bad_row_count(seq) - TVO_EUROC_MAX_BAD_ROWS);
    camera = *tvo_euroc_camera(seq);
    if (o.calib != NULL) {
        /* the calibration replaces the folder's camera; one for another size is refused before the
           first frame */
        char path0[1024];
        int32_t w0 = 0, h0 = 0;
        if (tvo_euroc_frame_path(seq, 0, path0, sizeof(path0)) == TVO_OK &&
            tvo_png_size(path0, &w0, &h0) == TVO_OK &&
            (w0 != calib.camera.width || h0 != calib.camera.height)) {
            fprintf(stderr, "tvo_replay: the calibration %s is for %dx%d but the frames of %s are %dx%d\n",
                    o.calib, (int)calib.camera.width, (int)calib.camera.height, o.dir, (int)w0, (int)h0);
            goto cleanup;
        }
        camera = calib.camera;
    }
    have_gt = tvo_euroc_has_groundtruth(seq);
    if ((o.scale == SCALE_GT || o.scale == SCALE_PROPAGATE) && !have_gt) {
        fprintf(stderr, "tvo_replay: --scale %s needs ground truth, and %s has none (%s)\n",
                o.scale == SCALE_GT ? "gt" : "propagate", o.dir,
                o.source == SRC_EUROC
                        ? "no mav0/state_groundtruth_estimate0/data.csv"
                        : (o.source == SRC_TUM ? "no groundtruth.txt"
                                               : "no poses file: --poses FILE, DIR/poses.txt or "
                                                 "DIR/../../poses/<seq>.txt"));
        goto cleanup;
    }
    (void)tvo_scale_filter_init(&filt, o.alpha >= 0.0 ? o.alpha : 0.0);
    tvo_map_scale_reset(&msc);
    T_bs = calib.has_T_BS ? calib.T_BS : tvo_euroc_T_BS(seq);
    T_sb = tvo_pose_inverse(&T_bs);
    period_ns = (int64_t)llround(1e9 / (tvo_euroc_rate_hz(seq) > 0 ? tvo_euroc_rate_hz(seq) : 20.0));

    (void)tvo_vo_config_preset(&cfg, &camera, o.preset); /* checked by parse_args */
    cfg.clock = clock_cb;
    if (o.keyframe >= 0)
        cfg.keyframe = o.keyframe;
    if (o.track_prediction >= 0)
        cfg.track_prediction = o.track_prediction;
    if (o.map >= 0)
        cfg.map = o.map;
    for (int k = 0; k < o.n_sets; ++k)
        (void)tvo_replay_setting_apply(&cfg, o.sets[k]); /* checked by parse_args */
    vo_size = tvo_vo_required_size(&cfg);
    if (vo_size == 0) {
        tvo_vo *probe = NULL;
        uint8_t probe_mem[1];
        if (tvo_vo_init(&probe, &cfg, probe_mem, sizeof(probe_mem)) == TVO_ERR_UNSUPPORTED) {
            if (!TVO_WITH_LENS && cfg.lens_refine != 0)
                fprintf(stderr,
                        "tvo_replay: this build of the library leaves out the lens refinement "
                        "(TVO_WITH_LENS off): lens_refine must be 0\n");
            else
                fprintf(stderr,
                        "tvo_replay: this build of the library leaves out the affine refinement "
                        "(TVO_WITH_AFFINE off): affine_win_size must be 0\n");
            goto cleanup;
        }
        fprintf(stderr,
                "tvo_replay: the configuration is not usable for %s (check the calibration and the --set "
                "values: vo.h gives each field's range)\n",
                o.dir);
        goto cleanup;
    }
    if (o.print_memory) {
        printf("VO working memory for %dx%d: %zu bytes\n", (int)cfg.camera.width, (int)cfg.camera.height,
               vo_size);
        rc = 0;
        goto cleanup;
    }
    vo_mem = malloc(vo_size);
    frame_cap = (size_t)cfg.camera.width * (size_t)cfg.camera.height;
    frame = (uint8_t *)malloc(frame_cap);
    n_frames = tvo_euroc_frame_count(seq);
    if (o.max_frames >= 0 && o.max_frames < n_frames)
        n_frames = o.max_frames;
    for (int s = 0; s <= TVO_STAGE_COUNT; ++s)
        timing[s] = (double *)calloc((size_t)(n_frames > 0 ? n_frames : 1), sizeof(double));
    if (vo_mem == NULL || frame == NULL || timing[TVO_STAGE_COUNT] == NULL || timing[0] == NULL) {
        fprintf(stderr, "tvo_replay: out of memory\n");
        goto cleanup;
    }
    for (int s = 1; s < TVO_STAGE_COUNT; ++s)
        if (timing[s] == NULL) {
            fprintf(stderr, "tvo_replay: out of memory\n");
            goto cleanup;
        }
    st = tvo_vo_init(&vo, &cfg, vo_mem, vo_size);
    if (st != TVO_OK) {
        fprintf(stderr, "tvo_replay: VO init failed: %s\n", tvo_status_str(st));
        goto cleanup;
    }
    if (o.model != NULL) {
        size_t fsize = 0, need = 0;
        nn_file = read_file(o.model, &fsize);
        if (nn_file == NULL) {
            fprintf(stderr, "tvo_replay: cannot read model %s\n", o.model);
            goto cleanup;
        }
        st = tvo_nn_required_size(nn_file, fsize, &need);
        if (st == TVO_OK) {
            nn_mem = malloc(need > 0 ? need : 1);
            st = nn_mem != NULL ? tvo_nn_load(&nn, nn_file, fsize, nn_mem, need) : TVO_ERR_NO_MEMORY;
        }
        if (st != TVO_OK) {
            fprintf(stderr, "tvo_replay: model %s refused: %s\n", o.model, tvo_status_str(st));
            goto cleanup;
        }
    }
    if (o.tracks != NULL || o.stats != NULL) {
        trk = (tvo_vo_track *)malloc((size_t)cfg.max_tracks * sizeof(tvo_vo_track));
        if (trk == NULL) {
            fprintf(stderr, "tvo_replay: out of memory\n");
            goto cleanup;
        }
    }
    if (o.tracks != NULL) {
        tracks = fopen(o.tracks, "w");
        if (tracks == NULL) {
            fprintf(stderr, "tvo_replay: cannot write %s\n", o.tracks);
            goto cleanup;
        }
        fprintf(tracks, "t_ns,id,x,y,age,flags\n");
    }
    out = fopen(o.out, "w");
    if (out == NULL) {
        fprintf(stderr, "tvo_replay: cannot write %s\n", o.out);
        goto cleanup;
    }
    /* A comment line (TUM readers and evo skip '#' lines) that says whose pose each row is, so that
     * tinyvo-eval moves the ground truth to the camera that was replayed and not to cam0. */
    fprintf(out, "# tvo_replay frame=%s source=%s camera=%s scale=%s: t tx ty tz qx qy qz qw\n",
            o.body_frame ? "body" : "camera", source_names[o.source], camera_name(&o), scale_names[o.scale]);

    if (o.features != NULL) {
        feat = fopen(o.features, "w");
        if (feat == NULL) {
            fprintf(stderr, "tvo_replay: cannot write %s\n", o.features);
            goto cleanup;
        }
        fprintf(feat, "t_ns,state,relpose_flags,pose_status,inliers");
        for (int k = 0; k < TVO_FEAT_COUNT; ++k)
            fprintf(feat, ",%s", feature_names[k]);
        fprintf(feat, ",rel_scale,rel_scale_points\n");
    }
    t_start = (double)tvo_clock_now_ns() * 1e-9;
    for (long i = 0; i < n_frames; ++i) {
        char path[1024];
        int32_t w = 0, h = 0;
        const int64_t t_ns = tvo_euroc_frame_time(seq, (int32_t)i);
        int64_t t_dec;
        tvo_vo_result res;
        tvo_pose step, T_w_b;
        int skip = -1;

        t_dec = tvo_clock_now_ns();
        if (t_ns <= t_last) {
            skip = SKIP_TIMESTAMP;
        } else if (tvo_euroc_frame_path(seq, (int32_t)i, path, sizeof(path)) != TVO_OK) {
            skip = SKIP_MISSING;
        } else {
            st = tvo_png_read_gray8(path, frame, frame_cap, &w, &h);
            if (st == TVO_ERR_NOT_FOUND || st == TVO_ERR_IO)
                skip = SKIP_MISSING;
            else if (st == TVO_ERR_NO_MEMORY || st == TVO_ERR_SIZE ||
                     (st == TVO_OK && (w != cfg.camera.width || h != cfg.camera.height)))
                skip = SKIP_SIZE;
            else if (st != TVO_OK)
                skip = SKIP_CORRUPT;
        }
        if (skip >= 0) {
            counts_skip[skip]++;
            if (tty)
                fputc('\n', stderr);
            fprintf(stderr, "tvo_replay: frame %ld (t=%lld): %s, skipped%s\n", i, (long long)t_ns,
                    skip_names[skip], o.strict ? " (--strict: stopping)" : "");
            if (o.strict)
                goto cleanup;
            continue; /* the next good frame comes after a gap (below) */
        }
        t_dec = tvo_clock_now_ns() - t_dec;
        if (t_last != INT64_MIN && t_ns - t_last > period_ns + period_ns / 2) {
            /* Dropped frames: the VO tracks across them (a reset would start a new map in a unit of its
               own, and one unit for the whole run is what a monocular trajectory has). */
            const double gap_s = (double)(t_ns - t_last) * 1e-9;
            const int reset = o.gap_reset > 0.0 && gap_s > o.gap_reset;
            gaps++;
            fprintf(stderr, "%stvo_replay: gap of %.3f s before frame %ld%s\n", tty ? "\n" : "", gap_s, i,
                    o.strict        ? " (--strict: stopping)"
                            : reset ? ": re-initialising (--gap-reset)"
                                    : "");
            if (o.strict)
                goto cleanup;
            if (reset) {
                tvo_vo_reset(vo); /* the next frame starts new tracks (and a new map) */
                vo_reset_pending = 1;
                prev_new = prev_old = 0; /* no track is carried over */
                gap_resets++;
            }
        }
        t_last = t_ns;

        {
            const tvo_image img = tvo_image_make(w, h, w, frame);
            st = tvo_vo_process(vo, &img, t_ns, &res);
        }
        if (st != TVO_OK) {
            counts_skip[SKIP_CORRUPT]++;
            fprintf(stderr, "tvo_replay: frame %ld: VO refused it: %s\n", i, tvo_status_str(st));
            if (o.strict)
                goto cleanup;
            continue;
        }
        counts_state[res.state]++;
        counts_map[res.map_state]++;
        map_keyframes += res.keyframe;
        ba_turn_refused += (res.ba_flags & TVO_VO_BA_TURN_REFUSED) != 0;
        map_store_full = res.map_store_full; /* counted by the VO since init */
        lens_updates = res.lens_updates;     /* likewise */
        lens_dk[0] = res.lens_dk[0];
        lens_dk[1] = res.lens_dk[1];
        if (res.lens_update && !o.quiet)
            fprintf(stderr,
                    "tvo_replay: lens refined at t=%lld ns: k1 %+.5f, k2 %+.5f from the calibration's\n",
                    (long long)t_ns, res.lens_dk[0], res.lens_dk[1]);
        gain_retries += res.gain_retry != 0;
        pred_rescues += res.pred_rescue != 0;
        affine_tried += res.affine_tried;
        affine_refined += res.affine_refined;
        affine_ended += res.affine_ended;
        map_refound += res.map_refound;
        if (res.keyframe_age > 0)
            keyframe_frames++;
        if (trk != NULL) {
            int32_t nt = 0;
            long a0 = 0, a1 = 0, a2 = 0;
            if (tvo_vo_tracks(vo, trk, cfg.max_tracks, &nt) != TVO_OK)
                nt = 0;
            for (int32_t k = 0; k < nt && k < cfg.max_tracks; ++k) {
                a0 += trk[k].age == 0;
                a1 += trk[k].age == 1;
                a2 += trk[k].age >= 2;
                if (tracks != NULL)
                    fprintf(tracks, "%lld,%u,%.2f,%.2f,%d,%d\n", (long long)t_ns, (unsigned)trk[k].id,
                            (double)trk[k].x, (double)trk[k].y, (int)trk[k].age,
                            (trk[k].inlier ? 1 : 0) | (trk[k].landmark ? 2 : 0) | (res.keyframe ? 4 : 0));
            }
            kept_new += a1;
            from_new += prev_new;
            kept_old += a2;
            from_old += prev_old;
            prev_new = a0;
            prev_old = a1 + a2;
        }
        if (feat != NULL) {
            fprintf(feat, "%lld,%d,%d,%d,%d", (long long)t_ns, (int)res.state, (int)res.relpose_flags,
                    (int)res.pose_status, (int)res.inliers);
            for (int k = 0; k < TVO_FEAT_COUNT; ++k)
                fprintf(feat, ",%.9g", (double)res.features[k]);
            fprintf(feat, ",%.9g,%d\n", res.rel_scale, (int)res.rel_scale_points);
        }
        for (int s = 0; s < TVO_STAGE_COUNT; ++s)
            timing[s][timed] = (double)res.stage_ns[s] * 1e-3;
        timing[TVO_STAGE_COUNT][timed] = (double)t_dec * 1e-3;
        timed++;

        /* the first frame anchors the trajectory at the ground-truth camera pose when there is one */
        T_w_b = tvo_pose_identity();
        {
            int gt_ok = have_gt && tvo_euroc_groundtruth_interp(seq, t_ns, 100000000, &T_w_b) == TVO_OK;
            if (!gt_ok)
                gt_missing += have_gt;
            if (processed == 0) {
                tvo_pose T_w_c0 = gt_ok ? tvo_pose_compose(&T_w_b, &T_bs) : tvo_pose_identity();
                tvo_traj_init(&traj, &T_w_c0);
            }
            step = res.T_prev_cur;
            if (cfg.map) {
                /* the map's pose: integrate the VO's world motion with the map's scale factor */
                double gt_len = -1.0, src = -1.0, vo_len;
                tvo_pose rel;
                if (vo_reset_pending) {
                    /* the trajectory goes on from its last pose; the new map's unit is its own, so the
                       scale source sets the factor again */
                    T_w_c_vo_prev = tvo_pose_identity();
                    tvo_map_scale_reset(&msc);
                    vo_reset_pending = 0;
                }
                rel = processed == 0 ? tvo_pose_identity() : tvo_pose_relative(&T_w_c_vo_prev, &res.T_w_c);
                vo_len = sqrt(rel.t[0] * rel.t[0] + rel.t[1] * rel.t[1] + rel.t[2] * rel.t[2]);
                if (gt_ok && have_prev_gt) {
                    tvo_pose g = tvo_pose_body_to_camera_relative(&T_w_b_prev, &T_w_b, &T_bs);
                    gt_len = sqrt(g.t[0] * g.t[0] + g.t[1] * g.t[1] + g.t[2] * g.t[2]);
                }
                if (o.scale == SCALE_GT || o.scale == SCALE_PROPAGATE) {
                    src = gt_len;
                } else if (o.scale == SCALE_CONST) {
                    src = processed > 0 ? o.step : -1.0;
                } else if (o.scale == SCALE_MODEL && res.state == TVO_VO_OK) {
                    tvo_pose refined;
                    if (tvo_vo_refine(nn, &res, &refined) == TVO_OK)
                        src = sqrt(refined.t[0] * refined.t[0] + refined.t[1] * refined.t[1] +
                                   refined.t[2] * refined.t[2]);
                }
                /* metres per map unit: 1 with --scale none, else the source's factor for this step */
                const double map_unit = o.scale == SCALE_NONE
                        ? 1.0
                        : tvo_map_scale_frame(&msc,
                                              o.scale == SCALE_PROPAGATE ? TVO_MAP_SCALE_ONCE
                                                      : o.alpha >= 0.0   ? TVO_MAP_SCALE_FILTER
                                                                         : TVO_MAP_SCALE_WHOLE_PATH,
                                              o.alpha, vo_len, src, res.keyframe);
                T_w_c_vo_prev = res.T_w_c;
                if (tvo_traj_step(&traj, &rel, map_unit) != TVO_OK)
                    counts_state[TVO_VO_LOST]++;
            } else if (res.state == TVO_VO_OK || res.state == TVO_VO_ROTATION_ONLY) {
                double scale = 1.0, gt_len = -1.0;
                if (gt_ok && have_prev_gt) {
                    tvo_pose rel = tvo_pose_body_to_camera_relative(&T_w_b_prev, &T_w_b, &T_bs);
                    gt_len = sqrt(rel.t[0] * rel.t[0] + rel.t[1] * rel.t[1] + rel.t[2] * rel.t[2]);
                }
                if (o.scale == SCALE_GT) {
                    scale = gt_len >= 0.0 ? gt_len : 0.0;
                } else if (o.scale == SCALE_PROPAGATE) {
                    /* the first frame with a translation takes the ground-truth length, later ones
                       r_k s_(k-1) (s_(k-1) when r_k is not available); rotation-only frames have t = 0 */
                    scale = 0.0;
                    if (res.state == TVO_VO_OK) {
                        if (!filt.has_s) {
                            if (gt_len > 0.0 && tvo_scale_filter_seed(&filt, gt_len) == TVO_OK)
                                scale = gt_len;
                        } else {
                            (void)tvo_scale_filter_update(&filt, res.rel_scale, 0.0, &scale);
                        }
                    }
                } else if (o.scale == SCALE_CONST && o.alpha < 0.0) {
                    scale = o.step;
                } else if (o.scale == SCALE_MODEL && o.alpha < 0.0) {
                    if (tvo_vo_refine(nn, &res, &step) != TVO_OK)
                        scale = 0.0;
                } else if (o.scale == SCALE_MODEL || o.scale == SCALE_CONST) {
                    /* the filter: prior n_k = |t| of the networks (or --step) along the raw direction;
                       networks' rotation when the model has rotation branches */
                    double prior = o.step;
                    scale = 0.0;
                    if (o.scale == SCALE_MODEL) {
                        tvo_pose refined;
                        prior = 0.0;
                        if (tvo_vo_refine(nn, &res, &refined) == TVO_OK) {
                            /* |t| of tx ty tz, or the step-length branch's s (|s u| = s, u unit) */
                            if ((tvo_nn_output_mask(nn) & 0x47) != 0)
                                prior = sqrt(refined.t[0] * refined.t[0] + refined.t[1] * refined.t[1] +
                                             refined.t[2] * refined.t[2]);
                            memcpy(step.R, refined.R, sizeof(step.R));
                        }
                    }
                    if (res.state == TVO_VO_OK)
                        (void)tvo_scale_filter_update(&filt, res.rel_scale, prior, &scale);
                }
                if (tvo_traj_step(&traj, &step, scale) != TVO_OK)
                    counts_state[TVO_VO_LOST]++;
            }
            have_prev_gt = gt_ok;
            if (gt_ok)
                T_w_b_prev = T_w_b;
        }
        if (o.body_frame) {
            tvo_pose Twb = tvo_pose_compose(&traj.T_w_c, &T_sb);
            write_pose(out, t_ns, &Twb);
        } else {
            write_pose(out, t_ns, &traj.T_w_c);
        }
        processed++;
        if (tty && (processed % 10 == 0 || i + 1 == n_frames)) {
            const double el = (double)tvo_clock_now_ns() * 1e-9 - t_start;
            fprintf(stderr, "\rframe %ld/%ld  %.1f frames/s  %-13s tracks %4d inliers %4d", i + 1, n_frames,
                    el > 0 ? (double)processed / el : 0.0, state_names[res.state], (int)res.tracks,
                    (int)res.inliers);
        }
    }
    if (tty)
        fputc('\n', stderr);
    if (fclose(out) != 0) {
        out = NULL;
        fprintf(stderr, "tvo_replay: error writing %s\n", o.out);
        goto cleanup;
    }
    out = NULL;

    {
        long skipped = 0;
        for (int k = 0; k < SKIP_COUNT; ++k)
            skipped += counts_skip[k];
        if (!o.quiet)
            fprintf(stderr,
                    "tvo_replay: %ld frames processed (%ld ok, %ld rotation-only, %ld lost), %ld skipped, "
                    "%ld gaps -> %s\n",
                    processed, counts_state[TVO_VO_OK], counts_state[TVO_VO_ROTATION_ONLY],
                    counts_state[TVO_VO_LOST], skipped, gaps, o.out);
        if (o.stats != NULL) {
            FILE *js = fopen(o.stats, "w");
            if (js == NULL) {
                fprintf(stderr, "tvo_replay: cannot write %s\n", o.stats);
                goto cleanup;
            }
            fprintf(js, "{\n  \"sequence\": \"%s\",\n  \"dataset\": \"%s\",\n  \"camera\": \"%s\",\n", o.dir,
                    source_names[o.source], camera_name(&o));
            fprintf(js, "  \"width\": %d,\n  \"height\": %d,\n  \"vo_memory_bytes\": %zu,\n",
                    (int)cfg.camera.width, (int)cfg.camera.height, vo_size);
            fprintf(js,
                    "  \"frames\": {\"total\": %ld, \"processed\": %ld, \"skipped\": %ld, \"lost\": %ld},\n",
                    n_frames, processed, skipped, counts_state[TVO_VO_LOST]);
            fprintf(js, "  \"skipped\": {");
            for (int k = 0; k < SKIP_COUNT; ++k)
                fprintf(js, "%s\"%s\": %ld", k ? ", " : "", skip_names[k], counts_skip[k]);
            fprintf(js,
                    "},\n  \"gaps\": %ld,\n  \"gap_resets\": %ld,\n  \"groundtruth_missing\": %ld,\n  "
                    "\"status\": {",
                    gaps, gap_resets, gt_missing);
            for (int k = 0; k < TVO_VO_STATE_COUNT; ++k)
                fprintf(js, "%s\"%s\": %ld", k ? ", " : "", state_names[k], counts_state[k]);
            fprintf(js, "},\n  \"keyframe_rotation_frames\": %ld,\n  \"gain_retries\": %ld,\n",
                    keyframe_frames, gain_retries);
            fprintf(js, "  \"pred_rescues\": %ld,\n", pred_rescues);
            fprintf(js, "  \"lens\": {\"refine\": %d, \"updates\": %ld, \"dk1\": %.9g, \"dk2\": %.9g},\n",
                    (int)cfg.lens_refine, lens_updates, lens_dk[0], lens_dk[1]);
            fprintf(js, "  \"affine\": {\"tried\": %ld, \"refined\": %ld, \"ended\": %ld},\n", affine_tried,
                    affine_refined, affine_ended);
            fprintf(js, "  \"tracks\": {\"new\": %ld, \"new_kept\": %ld, \"old\": %ld, \"old_kept\": %ld},\n",
                    from_new, kept_new, from_old, kept_old);
            fprintf(js,
                    "  \"map\": {\"enabled\": %d, \"keyframes\": %ld, \"losses\": %ld, "
                    "\"ba_turn_refused\": %ld, \"store_full\": %ld, \"refound\": %ld, \"scale\": %.9g, "
                    "\"states\": {",
                    (int)cfg.map, map_keyframes, counts_map[TVO_MAP_LOST], ba_turn_refused, map_store_full,
                    map_refound, o.scale == SCALE_NONE ? 1.0 : msc.s);
            for (int k = 0; k < TVO_MAP_STATE_COUNT; ++k)
                fprintf(js, "%s\"%s\": %ld", k ? ", " : "", map_state_names[k], counts_map[k]);
            fprintf(js, "}},\n  \"timing_us\": {\n");
            for (int s = 0; s <= TVO_STAGE_COUNT; ++s) {
                double med, p90;
                percentiles(timing[s], timed, &med, &p90);
                fprintf(js, "    \"%s\": {\"median\": %.1f, \"p90\": %.1f}%s\n",
                        s < TVO_STAGE_COUNT ? stage_names[s] : "png_decode", med, p90,
                        s < TVO_STAGE_COUNT ? "," : "");
            }
            fprintf(js, "  }\n}\n");
            if (fclose(js) != 0) {
                fprintf(stderr, "tvo_replay: error writing %s\n", o.stats);
                goto cleanup;
            }
        }
        rc = 0;
    }

cleanup:
    if (out != NULL)
        fclose(out);
    if (tracks != NULL && fclose(tracks) != 0) {
        fprintf(stderr, "tvo_replay: error writing %s\n", o.tracks);
        rc = 1;
    }
    free(trk);
    if (feat != NULL && fclose(feat) != 0) {
        fprintf(stderr, "tvo_replay: error writing %s\n", o.features);
        rc = 1;
    }
    for (int s = 0; s <= TVO_STAGE_COUNT; ++s)
        free(timing[s]);
    free(frame);
    free(vo_mem);
    free(nn_mem);
    free(nn_file);
    tvo_euroc_close(seq);
    return rc;
}
