/* SPDX-License-Identifier: Apache-2.0 */
/* Benchmark: the VO end to end through fast turns with little translation, on rendered frames.
 *
 * A drone that turns on the spot, or a hand-held camera panning, rotates by several degrees a frame
 * while it hardly moves: the landmarks leave the view faster than the baseline grows, and the
 * landmarks made to replace them have little parallax. This program renders the textured box room of
 * test/common/tvo_room.h (320x240, focal 250 px, 20 Hz) along a walk that builds the map (the walk of
 * test/unit/test_map.c), then a yaw turn at a constant rate while creeping along the camera's own axis,
 * for every combination of the given rates and creeps, and runs the whole VO (front end and map) on
 * the frames. For each run it prints the map losses during the turn, the largest rotation error of a
 * turn frame and the rotation error at the last frame (T_w_c against the rendered pose, deg), and the
 * largest position error of a turn frame after one scale factor fitted on the walk (m; the room is 4-10
 * m across); then how many runs end more than --bad degrees off, how many lose the map, and the median
 * and largest of the end rotation errors.
 *
 *   bench_map_turn [--walk N] [--turn N] [--rates R1,R2,...] [--creeps C1,C2,...] [--bad DEG]
 *                  [--verbose] [--preset NAME] [--set NAME=VALUE]...
 *
 * --rates in deg a frame (default 2.6,2.8,...,4.4), --creeps in mm a frame (default 8,9,...,13), --walk
 * frames of the walk (default 60), --turn frames of the turn (default 40), --bad the end rotation error
 * counted as a failed turn (default 4 deg); --verbose prints every turn frame (the map's state, a keyframe,
 * landmarks tracked and made, rotation and scaled position errors). Renders are exact (texture everywhere, no blur, no noise):
 * real turns are harder. Exit 0, 1 on bad input or a configuration the VO refuses. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "settings.h"
#include "tinyvo/linalg.h"
#include "tinyvo/se3.h"
#include "tinyvo/vo.h"
#include "tvo_room.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif
#define W 320
#define H 240
#define FOCAL 250.0
#define DT_NS 50000000LL
#define MAX_LIST 64
#define MAX_FRAMES 2000

/* per frame of a run, for --verbose: the map's state, a keyframe, landmarks tracked and made */
static int state[MAX_FRAMES], kf[MAX_FRAMES], pts[MAX_FRAMES], newp[MAX_FRAMES], kage[MAX_FRAMES];
static tvo_pose rel[MAX_FRAMES]; /* the two-view relative pose T_prev_cur */
static double par[MAX_FRAMES];   /* its parallax, deg */

/* test_map.c's walk: forward and sideways along a gentle curve with a slow yaw sway, 4 cm a frame */
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

static double rot_err_deg(const tvo_pose *a, const tvo_pose *b)
{
    const tvo_pose d = tvo_pose_relative(a, b);
    return tvo_rot_angle(d.R) * 180.0 / M_PI;
}

typedef struct turn_result {
    int losses;
    double max_rot, end_rot, max_pos;
} turn_result;

/* One run: walk frames of the walk, then turn frames turning at rate (rad) and creeping by creep (m)
 * along the camera's axis. 0 when the VO cannot be made or a frame is refused. */
static int run(const tvo_vo_config *cfg, int walk_n, int turn_n, double rate, double creep, int verbose,
               uint8_t *img, tvo_pose *gt, tvo_pose *est, turn_result *out)
{
    const size_t need = tvo_vo_required_size(cfg);
    void *mem = need > 0 ? malloc(need) : NULL;
    tvo_vo *vo = NULL;
    const tvo_pose W0 = walk(walk_n - 1);
    tvo_image im = tvo_image_make(W, H, W, img);
    double num = 0.0, den = 0.0, s;
    int losses0 = 0, ok = 1;
    tvo_vo_result res;
    memset(out, 0, sizeof(*out));
    if (mem == NULL || tvo_vo_init(&vo, cfg, mem, need) != TVO_OK) {
        free(mem);
        return 0;
    }
    for (int k = 0; k < walk_n + turn_n && ok; ++k) {
        tvo_pose T = W0;
        if (k < walk_n) {
            T = walk(k);
        } else {
            const int j = k - walk_n + 1;
            const double v[3] = {0.0, rate * j, 0.0};
            double Ry[9];
            tvo_rotvec_to_rot(v, Ry);
            tvo_la_mat3_mul(Ry, W0.R, T.R);
            for (int c = 0; c < 3; ++c)
                T.t[c] = W0.t[c] + creep * j * T.R[3 * c + 2];
        }
        tvo_room_render(&T, W, H, FOCAL, img);
        ok = tvo_vo_process(vo, &im, 1000000000LL + k * DT_NS, &res) == TVO_OK &&
                tvo_pose_is_finite(&res.T_w_c);
        gt[k] = T;
        est[k] = res.T_w_c;
        state[k] = (int)res.map_state;
        kf[k] = (int)res.keyframe;
        pts[k] = (int)res.map_points;
        newp[k] = (int)res.map_new_points;
        kage[k] = res.state == TVO_VO_OK ? (int)res.keyframe_age : -1;
        rel[k] = res.T_prev_cur;
        par[k] = res.parallax_deg;
        if (k == walk_n - 1)
            losses0 = (int)res.map_losses;
        if (k >= walk_n) {
            const double r = rot_err_deg(&res.T_w_c, &T);
            out->max_rot = r > out->max_rot ? r : out->max_rot;
            out->end_rot = r;
        }
    }
    out->losses = (int)res.map_losses - losses0;
    /* one scale over the walk (both worlds start at the identity), applied to the turn's positions */
    for (int k = 0; k < walk_n; ++k)
        for (int c = 0; c < 3; ++c) {
            num += gt[k].t[c] * est[k].t[c];
            den += est[k].t[c] * est[k].t[c];
        }
    s = den > 0.0 ? num / den : 0.0;
    for (int k = walk_n; k < walk_n + turn_n && ok; ++k) {
        double e2 = 0.0;
        for (int c = 0; c < 3; ++c)
            e2 += (gt[k].t[c] - s * est[k].t[c]) * (gt[k].t[c] - s * est[k].t[c]);
        out->max_pos = sqrt(e2) > out->max_pos ? sqrt(e2) : out->max_pos;
        if (verbose) {
            /* the frame-to-frame rotation error of the map's poses and of the two-view estimate */
            const tvo_pose me = tvo_pose_relative(&est[k - 1], &est[k]),
                           mt = tvo_pose_relative(&gt[k - 1], &gt[k]);
            printf("  frame %3d  map %d  kf %d  points %3d  new %3d  rot err %6.3f  pos err %.3f  step rot "
                   "err "
                   "map %.3f  two-view %.3f (age %d, parallax %.3f)  pos %.3f %.3f %.3f  true %.3f %.3f "
                   "%.3f\n",
                   k, state[k], kf[k], pts[k], newp[k], rot_err_deg(&est[k], &gt[k]), sqrt(e2),
                   rot_err_deg(&me, &mt), kage[k] == 0 ? rot_err_deg(&rel[k], &mt) : -1.0, kage[k], par[k],
                   s * est[k].t[0], s * est[k].t[1], s * est[k].t[2], gt[k].t[0], gt[k].t[1], gt[k].t[2]);
        }
    }
    free(mem);
    return ok;
}

/* a comma-separated list of numbers; its length, or -1 */
static int parse_list(const char *s, double *v)
{
    int n = 0;
    while (*s != '\0') {
        char *end;
        if (n == MAX_LIST)
            return -1;
        v[n] = strtod(s, &end);
        if (end == s || !isfinite(v[n]) || (*end != ',' && *end != '\0'))
            return -1;
        ++n;
        s = *end == ',' ? end + 1 : end;
    }
    return n;
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    tvo_camera cam = tvo_camera_make_pinhole(W, H, FOCAL, FOCAL, (W - 1) / 2.0, (H - 1) / 2.0);
    tvo_vo_config cfg;
    double rates[MAX_LIST], creeps[MAX_LIST], bad = 4.0;
    static double ends[MAX_LIST * MAX_LIST];
    static tvo_pose gt[MAX_FRAMES], est[MAX_FRAMES];
    static uint8_t img[W * H];
    int n_rates = 10, n_creeps = 6, walk_n = 60, turn_n = 40, n = 0, n_bad = 0, n_lost = 0, verbose = 0;
    for (int i = 0; i < n_rates; ++i)
        rates[i] = 2.6 + 0.2 * i;
    for (int i = 0; i < n_creeps; ++i)
        creeps[i] = 8.0 + i;
    tvo_vo_config_default(&cfg, &cam);
    for (int a = 1; a < argc; ++a) /* the preset first: --set applies on top of it */
        if (strcmp(argv[a], "--preset") == 0 && a + 1 < argc) {
            tvo_vo_preset p;
            if (tvo_replay_preset_from_name(argv[a + 1], &p) != 0 ||
                tvo_vo_config_preset(&cfg, &cam, p) != TVO_OK) {
                fprintf(stderr, "bench_map_turn: bad --preset %s\n", argv[a + 1]);
                return 1;
            }
        }
    for (int a = 1; a < argc; ++a) {
        const char *v = a + 1 < argc ? argv[a + 1] : NULL;
        if (strcmp(argv[a], "--verbose") == 0) {
            verbose = 1;
            continue;
        }
        if (v == NULL) {
            fprintf(stderr, "bench_map_turn: %s needs a value\n", argv[a]);
            return 1;
        }
        if (strcmp(argv[a], "--walk") == 0)
            walk_n = atoi(v);
        else if (strcmp(argv[a], "--turn") == 0)
            turn_n = atoi(v);
        else if (strcmp(argv[a], "--bad") == 0)
            bad = atof(v);
        else if (strcmp(argv[a], "--rates") == 0)
            n_rates = parse_list(v, rates);
        else if (strcmp(argv[a], "--creeps") == 0)
            n_creeps = parse_list(v, creeps);
        else if (strcmp(argv[a], "--preset") == 0)
            ;
        else if (strcmp(argv[a], "--set") != 0 || tvo_replay_setting_apply(&cfg, v) != 0) {
            fprintf(stderr, "bench_map_turn: bad option %s\n", argv[a]);
            return 1;
        }
        ++a;
    }
    if (walk_n < 20 || turn_n < 1 || walk_n + turn_n > MAX_FRAMES || n_rates < 1 || n_creeps < 1 ||
        !(bad > 0.0)) {
        fprintf(stderr,
                "bench_map_turn: --walk 20.., --turn 1.. (%d frames in all), --rates and --creeps "
                "lists of at most %d numbers, --bad above 0\n",
                MAX_FRAMES, MAX_LIST);
        return 1;
    }
    if (tvo_vo_required_size(&cfg) == 0) {
        fprintf(stderr, "bench_map_turn: the options make a configuration the VO refuses (vo.h ranges)\n");
        return 1;
    }
    printf("room: walk %d frames, then turn %d frames; %d rates x %d creeps\n", walk_n, turn_n, n_rates,
           n_creeps);
    printf("rate deg  creep mm  losses  max rot deg  end rot deg  max pos m\n");
    for (int i = 0; i < n_rates; ++i)
        for (int j = 0; j < n_creeps; ++j) {
            turn_result r;
            if (!run(&cfg, walk_n, turn_n, rates[i] * M_PI / 180.0, creeps[j] * 1e-3, verbose, img, gt, est,
                     &r)) {
                fprintf(stderr, "bench_map_turn: the VO refused the configuration or a frame\n");
                return 1;
            }
            printf("%8.2f  %8.1f  %6d  %11.3f  %11.3f  %9.3f\n", rates[i], creeps[j], r.losses, r.max_rot,
                   r.end_rot, r.max_pos);
            fflush(stdout);
            ends[n++] = r.end_rot;
            n_bad += r.end_rot > bad;
            n_lost += r.losses > 0;
        }
    qsort(ends, (size_t)n, sizeof(ends[0]), cmp_double);
    printf("runs %d: %d end more than %.1f deg off, %d lose the map; end rotation error median %.3f, "
           "largest %.3f deg\n",
           n, n_bad, bad, n_lost, 0.5 * (ends[(n - 1) / 2] + ends[n / 2]), ends[n - 1]);
    return 0;
}
