/* SPDX-License-Identifier: Apache-2.0 */
/* Benchmark: the local map's own drift, on exact tracks of a synthetic road.
 *
 * The VO's figures on renders and real frames move by chance with any change (a different RANSAC sample,
 * a different rounding, a different first map: docs/rules.md, "A second rule"), and their error is
 * mostly the tracks' (docs/evaluation.md, "What the tracks' errors cost the map"). This program takes
 * the front end away: it drives the map module (lib/src/tvo_map.c) alone with the exact projections of
 * a synthetic scene plus uniform noise of a chosen size, the exact two-view rotations, and the true
 * pose as the pose a new map starts from (so the map's world and unit are the truth's: a new map's first
 * baseline is the true distance). What is left is the map's estimator: its keyframes, triangulation,
 * PnP and windowed bundle adjustment, and the drift they add. Over many noise seeds the figures are
 * stable, so a change to the map can be judged here before the chaotic figures of whole sequences.
 *
 * The scene is test/common/tvo_road.h's: a camera driving down a straight road at 0.15 m a frame
 * (10 Hz), tracks of 10-40 frames, new tracks filling up to --tracks.
 *
 *   bench_map_road [--frames N] [--noise PX] [--drift PX] [--tracks N] [--seeds N] [--preset NAME]
 *                  [--set NAME=VALUE]...
 *
 * --noise: each observation's error, each coordinate uniform in +-PX/2, independent from frame to frame;
 * --drift: a track's random walk off its point, each frame's step uniform in +-PX/2 per coordinate (the
 * tracker's error that adds up along a track: docs/evaluation.md, "Track accuracy on the renders").
 * Defaults: 400 frames (60 m), noise 0.3 px, no drift, 150 tracks, 10 seeds; the
 * VO's default configuration (the map reads its map_* fields and max_tracks). For each seed it prints
 * the frames the map posed, the map's losses, the position error at the last posed frame over the path
 * length, the scale drift (the distance travelled over the run's second half, estimated over true), and
 * the rotation error at the last posed frame; then the median and the largest over the seeds whose map
 * was never lost. A run with a loss is left out of them: its new map starts from the true pose and unit,
 * which would hide the drift (a store of landmarks too small for the window, map_max_landmarks, makes
 * the map lose its points: --set map_max_landmarks=N).
 * Exit 0, 1 on bad input or a configuration the VO refuses. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "settings.h"
#include "tinyvo/arena.h"
#include "tinyvo/se3.h"
#include "tvo_map.h"
#include "tvo_road.h"

#define MAX_SEEDS 1000

static double dist3(const double a[3], const double b[3])
{
    const double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
    return sqrt(d0 * d0 + d1 * d1 + d2 * d2);
}

typedef struct run_result {
    int posed, losses;
    double end_err_pct; /* position error at the last posed frame, % of the path */
    double scale;       /* estimated / true distance over the second half */
    double rot_err_deg; /* rotation error at the last posed frame */
} run_result;

typedef struct road {
    int frames, max_tracks, n_points;
    double noise; /* px, full width of the uniform noise */
    double drift; /* px, full width of each frame's uniform step of a track's random walk off its point */
} road;

/* One run with noise seed `seed`; 0 on an allocation or map error. */
static int run(const tvo_vo_config *cfg, const road *rd, uint32_t seed, run_result *res)
{
    tvo_pose *est = malloc((size_t)rd->frames * sizeof(tvo_pose));
    const size_t ls = tvo_map_layout_size(cfg) + TVO_ARENA_ALIGN, ss = tvo_map_scratch_size(cfg);
    void *mem = malloc(ls), *scratch = malloc(ss);
    int32_t good = 1, last = -1, half = -1;
    tvo_road r;
    tvo_map m;
    tvo_arena ar;
    memset(res, 0, sizeof(*res));
    if (!tvo_road_open(&r, rd->frames, rd->max_tracks, rd->n_points, rd->noise, rd->drift, 0.0, seed)) {
        free(est);
        free(mem);
        free(scratch);
        return 0;
    }
    if (!est || !mem || !scratch) {
        good = 0;
        goto done;
    }
    tvo_arena_init(&ar, mem, ls);
    if (tvo_map_init(&m, cfg, &ar) != TVO_OK) {
        good = 0;
        goto done;
    }
    for (int k = 0; k < rd->frames; ++k) {
        tvo_map_frame out;
        if (tvo_road_frame(&r, &m, cfg, k, scratch, ss, &out) != TVO_OK) {
            good = 0;
            goto done;
        }
        if ((out.state == TVO_MAP_TRACKING || out.state == TVO_MAP_INITIALISED) &&
            tvo_pose_is_finite(&out.T_c_w)) {
            est[k] = out.T_c_w;
            res->posed++;
            last = k;
            if (half < 0 && k >= rd->frames / 2)
                half = k;
        }
    }
    res->losses = m.losses;
    if (last >= 0 && half >= 0 && last > half) {
        const tvo_pose Tl = tvo_road_camera(last), Th = tvo_road_camera(half);
        const tvo_pose Gl = tvo_pose_inverse(&Tl), Gh = tvo_pose_inverse(&Th);
        const tvo_pose El = tvo_pose_inverse(&est[last]), Eh = tvo_pose_inverse(&est[half]);
        const tvo_pose dR = tvo_pose_relative(&Gl, &El);
        const double path = TVO_ROAD_STEP_M * last; /* the sway adds under 0.1 % */
        res->end_err_pct = 100.0 * dist3(Gl.t, El.t) / path;
        res->scale = dist3(El.t, Eh.t) / dist3(Gl.t, Gh.t);
        res->rot_err_deg = tvo_rot_angle(dR.R) * 180.0 / 3.14159265358979323846;
    } else {
        res->end_err_pct = res->scale = res->rot_err_deg = NAN;
    }
done:
    tvo_road_close(&r);
    free(est);
    free(mem);
    free(scratch);
    return good;
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* median and largest of v[0..n) (sorted in place); NaNs sort last and count as the largest */
static void med_max(double *v, int n, double *med, double *max)
{
    for (int i = 0; i < n; ++i)
        if (isnan(v[i]))
            v[i] = INFINITY;
    qsort(v, (size_t)n, sizeof(double), cmp_double);
    *med = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
    *max = v[n - 1];
}

int main(int argc, char **argv)
{
    tvo_camera cam = tvo_camera_make_pinhole(TVO_ROAD_WIDTH, TVO_ROAD_HEIGHT, TVO_ROAD_FOCAL, TVO_ROAD_FOCAL,
                                             (TVO_ROAD_WIDTH - 1) / 2.0, (TVO_ROAD_HEIGHT - 1) / 2.0);
    tvo_vo_config cfg;
    road rd = {400, 150, 0, 0.3, 0.0};
    int seeds = 10;
    static double err[MAX_SEEDS], dscale[MAX_SEEDS], rot[MAX_SEEDS];
    int kept = 0, with_loss = 0;
    tvo_vo_config_default(&cfg, &cam);
    for (int a = 1; a < argc; ++a) /* the preset first: --set applies on top of it */
        if (strcmp(argv[a], "--preset") == 0 && a + 1 < argc) {
            tvo_vo_preset p;
            if (tvo_replay_preset_from_name(argv[a + 1], &p) != 0 ||
                tvo_vo_config_preset(&cfg, &cam, p) != TVO_OK) {
                fprintf(stderr, "bench_map_road: bad --preset %s\n", argv[a + 1]);
                return 1;
            }
        }
    for (int a = 1; a < argc; ++a) {
        const char *v = a + 1 < argc ? argv[a + 1] : NULL;
        if (v == NULL) {
            fprintf(stderr, "bench_map_road: %s needs a value\n", argv[a]);
            return 1;
        }
        if (strcmp(argv[a], "--frames") == 0)
            rd.frames = atoi(v);
        else if (strcmp(argv[a], "--noise") == 0)
            rd.noise = atof(v);
        else if (strcmp(argv[a], "--drift") == 0)
            rd.drift = atof(v);
        else if (strcmp(argv[a], "--tracks") == 0)
            rd.max_tracks = atoi(v);
        else if (strcmp(argv[a], "--seeds") == 0)
            seeds = atoi(v);
        else if (strcmp(argv[a], "--preset") == 0)
            ;
        else if (strcmp(argv[a], "--set") != 0 || tvo_replay_setting_apply(&cfg, v) != 0) {
            fprintf(stderr, "bench_map_road: bad option %s\n", argv[a]);
            return 1;
        }
        ++a;
    }
    if (rd.frames < 20 || rd.frames > 100000 || rd.max_tracks < 20 || rd.max_tracks > 5000 ||
        !(rd.noise >= 0.0 && rd.noise <= 20.0) || !(rd.drift >= 0.0 && rd.drift <= 20.0) || seeds < 1 ||
        seeds > MAX_SEEDS) {
        fprintf(stderr,
                "bench_map_road: --frames 20..100000, --tracks 20..5000, --noise 0..20, --seeds 1..%d\n",
                MAX_SEEDS);
        return 1;
    }
    cfg.max_tracks = rd.max_tracks;
    if (cfg.min_tracks > cfg.max_tracks)
        cfg.min_tracks = cfg.max_tracks / 2;
    if (tvo_vo_required_size(&cfg) == 0) {
        fprintf(stderr, "bench_map_road: the options make a configuration the VO refuses (vo.h ranges)\n");
        return 1;
    }
    if (cfg.map_max_landmarks == 0)
        cfg.map_max_landmarks = 2 * cfg.max_tracks;
    rd.n_points = (int)(rd.frames * 30.0 * rd.max_tracks / 150.0) + 1000;
    printf("road: %d frames (%.0f m), %d tracks, noise %.2f px, drift %.2f px a frame, window %d with %d "
           "fixed\n",
           rd.frames, TVO_ROAD_STEP_M * rd.frames, rd.max_tracks, rd.noise, rd.drift, cfg.map_window,
           cfg.map_ba_fixed);
    printf("seed  posed  losses  end error %% of path  scale, 2nd half  rotation error, deg\n");
    for (int s = 0; s < seeds; ++s) {
        run_result r;
        if (!run(&cfg, &rd, 1000u + (uint32_t)s, &r)) {
            fprintf(stderr, "bench_map_road: out of memory or the map refused its input\n");
            return 1;
        }
        printf("%4d  %5d  %6d  %20.4f  %15.5f  %19.4f%s\n", s, r.posed, r.losses, r.end_err_pct, r.scale,
               r.rot_err_deg, r.losses > 0 ? "  (lost: left out)" : "");
        if (r.losses > 0) {
            with_loss++;
            continue;
        }
        err[kept] = r.end_err_pct;
        dscale[kept] = fabs(r.scale - 1.0);
        rot[kept] = r.rot_err_deg;
        kept++;
    }
    if (kept == 0) {
        printf("every run lost its map: no figures\n");
        return 0;
    }
    {
        double m1, x1, m2, x2, m3, x3;
        med_max(err, kept, &m1, &x1);
        med_max(dscale, kept, &m2, &x2);
        med_max(rot, kept, &m3, &x3);
        printf("%d of %d runs without a loss; median / largest: end error %.4f / %.4f %% of path, |scale - "
               "1| "
               "%.5f / %.5f, rotation %.4f / %.4f deg\n",
               kept, seeds, m1, x1, m2, x2, m3, x3);
    }
    return 0;
}
