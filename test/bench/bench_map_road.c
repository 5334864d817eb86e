/* SPDX-License-Identifier: Apache-2.0 */
/* Benchmark: the local map's own drift, on exact tracks of a synthetic road.
 *
 * The VO's figures on renders and real frames move by chance with any change (a different RANSAC sample,
 * a different rounding, a different first map: docs/budget.md, "A second rule"), and their error is
 * mostly the tracks' (docs/evaluation.md, "What the tracks' errors cost the map"). This program takes
 * the front end away: it drives the map module (lib/src/tvo_map.c) alone with the exact projections of
 * a synthetic scene plus uniform noise of a chosen size, the exact two-view rotations, and the true
 * pose as the pose a new map starts from (so the map's world and unit are the truth's: a new map's first
 * baseline is the true distance). What is left is the map's estimator: its keyframes, triangulation,
 * PnP and windowed bundle adjustment, and the drift they add. Over many noise seeds the figures are
 * stable, so a change to the map can be judged here before the chaotic figures of whole sequences.
 *
 * The scene: a camera driving along a straight road at 0.15 m a frame (10 Hz), swaying 0.4 m sideways
 * and 3 degrees in yaw, among points 1-6 m to the sides, 3 m above and below, spread along the road;
 * each track follows one point for 10-40 frames (or until it leaves the 320x240 image, focal 250 px),
 * and new tracks fill up to --tracks.
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

#define W 320
#define H 240
#define FOCAL 250.0
#define DT_NS 100000000LL
#define STEP_M 0.15
#define MAX_SEEDS 1000

static double rnd(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return (double)(*s >> 8) / 16777216.0;
}

/* world -> camera pose of frame k */
static tvo_pose camera(int k)
{
    tvo_pose T_w_c = tvo_pose_identity();
    const double v[3] = {0.0, 0.05 * sin(0.07 * k), 0.0};
    tvo_rotvec_to_rot(v, T_w_c.R);
    T_w_c.t[0] = 0.4 * sin(0.05 * k);
    T_w_c.t[2] = STEP_M * k;
    return tvo_pose_inverse(&T_w_c);
}

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
    const int nt = rd->max_tracks, np = rd->n_points;
    double(*pts)[3] = malloc((size_t)np * sizeof(*pts));
    int32_t *pid = malloc((size_t)nt * sizeof(int32_t)), *life = malloc((size_t)nt * sizeof(int32_t));
    tvo_point2d *off = malloc((size_t)nt * sizeof(tvo_point2d)); /* each track's walk, normalised */
    int32_t *lm = malloc((size_t)nt * sizeof(int32_t)), *tri_fr = malloc((size_t)nt * sizeof(int32_t));
    tvo_point2d *x = malloc((size_t)nt * sizeof(tvo_point2d)),
                *tri_x = malloc((size_t)nt * sizeof(tvo_point2d));
    uint8_t *ok = malloc((size_t)nt), *inlier = malloc((size_t)nt);
    tvo_pose *est = malloc((size_t)rd->frames * sizeof(tvo_pose));
    int *has = calloc((size_t)rd->frames, sizeof(int));
    const size_t ls = tvo_map_layout_size(cfg) + TVO_ARENA_ALIGN, ss = tvo_map_scratch_size(cfg);
    void *mem = malloc(ls), *scratch = malloc(ss);
    int32_t n = 0, next_point = 0, good = 1, last = -1, half = -1;
    tvo_map m;
    tvo_arena ar;
    memset(res, 0, sizeof(*res));
    if (!pts || !pid || !life || !off || !lm || !tri_fr || !x || !tri_x || !ok || !inlier || !est || !has ||
        !mem || !scratch) {
        good = 0;
        goto done;
    }
    memset(ok, 1, (size_t)nt);
    for (int i = 0; i < np; ++i) {
        const double side = rnd(&seed) < 0.5 ? -1.0 : 1.0;
        pts[i][0] = side * (1.0 + 5.0 * rnd(&seed));
        pts[i][1] = -3.0 + 6.0 * rnd(&seed);
        pts[i][2] = 2.0 + (STEP_M * rd->frames + 30.0) * (double)i / np;
    }
    tvo_arena_init(&ar, mem, ls);
    if (tvo_map_init(&m, cfg, &ar) != TVO_OK) {
        good = 0;
        goto done;
    }
    for (int k = 0; k < rd->frames; ++k) {
        const tvo_pose T = camera(k);
        tvo_map_tracks tr;
        tvo_map_frame out;
        double R_cur_prev[9];
        int32_t first, kept = 0;
        for (int32_t i = 0; i < n; ++i) {
            tvo_point2d p;
            if (--life[i] <= 0 || !project(&T, pts[pid[i]], &p))
                continue;
            pid[kept] = pid[i];
            life[kept] = life[i];
            lm[kept] = lm[i];
            tri_fr[kept] = tri_fr[i];
            tri_x[kept] = tri_x[i];
            off[kept].x = off[i].x + (rnd(&seed) - 0.5) * rd->drift / FOCAL;
            off[kept].y = off[i].y + (rnd(&seed) - 0.5) * rd->drift / FOCAL;
            x[kept].x = p.x + off[kept].x + (rnd(&seed) - 0.5) * rd->noise / FOCAL;
            x[kept].y = p.y + off[kept].y + (rnd(&seed) - 0.5) * rd->noise / FOCAL;
            ++kept;
        }
        n = kept;
        if (k > 0) {
            const tvo_pose Tp = camera(k - 1), Twp = tvo_pose_inverse(&Tp), d = tvo_pose_compose(&T, &Twp);
            memcpy(R_cur_prev, d.R, sizeof(R_cur_prev));
        }
        tr = (tvo_map_tracks){n, x, ok, lm, tri_fr, tri_x, inlier, NULL, NULL};
        if (tvo_map_process(&m, cfg, &tr, 1000000000LL + k * DT_NS, k > 0 ? R_cur_prev : NULL, 0, &T, scratch,
                            ss, &out) != TVO_OK) {
            good = 0;
            goto done;
        }
        if ((out.state == TVO_MAP_TRACKING || out.state == TVO_MAP_INITIALISED) &&
            tvo_pose_is_finite(&out.T_c_w)) {
            est[k] = out.T_c_w;
            has[k] = 1;
            res->posed++;
            last = k;
            if (half < 0 && k >= rd->frames / 2)
                half = k;
        }
        first = n;
        while (n < nt && next_point < np) {
            tvo_point2d p;
            const int32_t i = next_point++;
            if (!project(&T, pts[i], &p))
                continue;
            pid[n] = i;
            life[n] = 10 + (int32_t)(30.0 * rnd(&seed));
            lm[n] = -1;
            tri_fr[n] = -1;
            off[n].x = off[n].y = 0.0;
            x[n] = p;
            ++n;
        }
        tr = (tvo_map_tracks){n, x, ok, lm, tri_fr, tri_x, inlier, NULL, NULL};
        tvo_map_new_tracks(&m, &tr, first);
    }
    res->losses = m.losses;
    if (last >= 0 && half >= 0 && last > half) {
        const tvo_pose Tl = camera(last), Th = camera(half);
        const tvo_pose Gl = tvo_pose_inverse(&Tl), Gh = tvo_pose_inverse(&Th);
        const tvo_pose El = tvo_pose_inverse(&est[last]), Eh = tvo_pose_inverse(&est[half]);
        const tvo_pose dR = tvo_pose_relative(&Gl, &El);
        const double path = STEP_M * last; /* the sway adds under 0.1 % */
        res->end_err_pct = 100.0 * dist3(Gl.t, El.t) / path;
        res->scale = dist3(El.t, Eh.t) / dist3(Gl.t, Gh.t);
        res->rot_err_deg = tvo_rot_angle(dR.R) * 180.0 / 3.14159265358979323846;
    } else {
        res->end_err_pct = res->scale = res->rot_err_deg = NAN;
    }
done:
    free(pts);
    free(pid);
    free(life);
    free(off);
    free(lm);
    free(tri_fr);
    free(x);
    free(tri_x);
    free(ok);
    free(inlier);
    free(est);
    free(has);
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
    tvo_camera cam = tvo_camera_make_pinhole(W, H, FOCAL, FOCAL, (W - 1) / 2.0, (H - 1) / 2.0);
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
           rd.frames, STEP_M * rd.frames, rd.max_tracks, rd.noise, rd.drift, cfg.map_window,
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
