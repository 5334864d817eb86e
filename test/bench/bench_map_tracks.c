/* SPDX-License-Identifier: Apache-2.0 */
/* Benchmark: the VO's local map alone, fed with recorded tracks instead of images.
 *
 * The map (lib/src/tvo_map.c: keyframes, triangulation, PnP, windowed bundle adjustment) sees the VO's
 * tracks as normalised image positions. This program gives it tracks from a file, frame by frame, with
 * the ground-truth camera poses for what the rest of the VO would give it: each frame's two-view
 * rotation (exact), and the pose a new map starts from. The map's trajectory is written in TUM format.
 * Fed with the true projections of the tracked points, the map is exact; fed with the tracker's
 * positions, the difference is what the tracks' errors cost (test/bench/bench_map_tracks.py makes both
 * files from a render and compares them).
 *
 *   bench_map_tracks GT.tum TRACKS.txt OUT.tum [--camera W H FX FY CX CY] [--set NAME=VALUE]...
 *
 * GT.tum: the camera poses (t tx ty tz qx qy qz qw, camera to world), one line per frame, in the
 * order of TRACKS' frames. TRACKS.txt: lines "t_ns id age x y", x y normalised and undistorted, grouped
 * by frame in time order; age 0 marks a track detected in that frame (it joins after the frame's map
 * step, as in tvo_vo_process), a track missing from a frame has ended; a line with id -1 only marks a
 * frame (a frame with no track at all). --set: any tvo_vo_config field, as tvo_replay's --set takes it
 * (examples/replay/settings.c; the VO's defaults otherwise; the map reads its map_* fields and max_tracks).
 * --camera: the pinhole camera the map's pixel thresholds refer to (default: 752x480, 458.654 / 457.296 px,
 * the EuRoC cam0's). Prints frames, frames posed, keyframes, losses.
 * Exit 0, 1 on bad input. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "settings.h"
#include "tinyvo/arena.h"
#include "tinyvo/se3.h"
#include "tvo_map.h"

typedef struct row {
    long long t_ns;
    int id, age;
    double x, y;
} row;

typedef struct tracks {
    int n, cap;
    int *id;
    tvo_point2d *x, *tri_x;
    uint8_t *ok, *inlier;
    int32_t *lm, *tri_fr;
} tracks;

static int read_gt(const char *path, double **t, tvo_pose **T_c_w, int *n)
{
    FILE *f = fopen(path, "r");
    int cap = 1024;
    *n = 0;
    *t = malloc((size_t)cap * sizeof(double));
    *T_c_w = malloc((size_t)cap * sizeof(tvo_pose));
    if (f == NULL || *t == NULL || *T_c_w == NULL)
        return 0;
    for (;;) {
        double v[8], q[4], R[9];
        tvo_pose Twc;
        if (fscanf(f, "%lf %lf %lf %lf %lf %lf %lf %lf", v, v + 1, v + 2, v + 3, v + 4, v + 5, v + 6,
                   v + 7) != 8)
            break;
        if (*n == cap) {
            cap *= 2;
            *t = realloc(*t, (size_t)cap * sizeof(double));
            *T_c_w = realloc(*T_c_w, (size_t)cap * sizeof(tvo_pose));
            if (*t == NULL || *T_c_w == NULL)
                return 0;
        }
        {
            const double nq = sqrt(v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]);
            if (!(nq > 0.5 && nq < 2.0))
                return 0;
            for (int c = 0; c < 4; ++c)
                q[c] = v[4 + c] / nq; /* x y z w */
        }
        R[0] = 1 - 2 * (q[1] * q[1] + q[2] * q[2]);
        R[1] = 2 * (q[0] * q[1] - q[2] * q[3]);
        R[2] = 2 * (q[0] * q[2] + q[1] * q[3]);
        R[3] = 2 * (q[0] * q[1] + q[2] * q[3]);
        R[4] = 1 - 2 * (q[0] * q[0] + q[2] * q[2]);
        R[5] = 2 * (q[1] * q[2] - q[0] * q[3]);
        R[6] = 2 * (q[0] * q[2] - q[1] * q[3]);
        R[7] = 2 * (q[1] * q[2] + q[0] * q[3]);
        R[8] = 1 - 2 * (q[0] * q[0] + q[1] * q[1]);
        memcpy(Twc.R, R, sizeof(R));
        memcpy(Twc.t, v + 1, 3 * sizeof(double));
        (*t)[*n] = v[0];
        (*T_c_w)[*n] = tvo_pose_inverse(&Twc);
        ++*n;
    }
    fclose(f);
    return *n > 1;
}

static row *read_rows(const char *path, int *n)
{
    FILE *f = fopen(path, "r");
    int cap = 1 << 16;
    row *r = malloc((size_t)cap * sizeof(row));
    *n = 0;
    if (f == NULL || r == NULL)
        return NULL;
    for (;;) {
        row q;
        if (fscanf(f, "%lld %d %d %lf %lf", &q.t_ns, &q.id, &q.age, &q.x, &q.y) != 5)
            break;
        if (*n > 0 && q.t_ns < r[*n - 1].t_ns) {
            fprintf(stderr, "bench_map_tracks: %s: frames out of time order\n", path);
            fclose(f);
            free(r);
            return NULL;
        }
        if (*n == cap) {
            cap *= 2;
            r = realloc(r, (size_t)cap * sizeof(row));
            if (r == NULL)
                return NULL;
        }
        r[(*n)++] = q;
    }
    fclose(f);
    return r;
}

/* The tracks of frame rows [a, b) that continue: kept in slot order with their map state; the others
 * end. Then the frame's map step; then the tracks born in the frame join. */
static void carry(tracks *tk, const row *r, int a, int b)
{
    int w = 0;
    for (int i = 0; i < tk->n; ++i) {
        for (int q = a; q < b; ++q) {
            if (r[q].id != tk->id[i] || r[q].age == 0)
                continue;
            tk->id[w] = tk->id[i];
            tk->x[w].x = r[q].x;
            tk->x[w].y = r[q].y;
            tk->lm[w] = tk->lm[i];
            tk->tri_fr[w] = tk->tri_fr[i];
            tk->tri_x[w] = tk->tri_x[i];
            ++w;
            break;
        }
    }
    tk->n = w;
}

static void write_pose(FILE *o, double t, const tvo_pose *T_c_w)
{
    const tvo_pose E = tvo_pose_inverse(T_c_w);
    const double *R = E.R;
    const double qw = sqrt(fmax(0.0, 1 + R[0] + R[4] + R[8])) / 2;
    const double qx = copysign(sqrt(fmax(0.0, 1 + R[0] - R[4] - R[8])) / 2, R[7] - R[5]);
    const double qy = copysign(sqrt(fmax(0.0, 1 - R[0] + R[4] - R[8])) / 2, R[2] - R[6]);
    const double qz = copysign(sqrt(fmax(0.0, 1 - R[0] - R[4] + R[8])) / 2, R[3] - R[1]);
    fprintf(o, "%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", t, E.t[0], E.t[1], E.t[2], qx, qy, qz, qw);
}

int main(int argc, char **argv)
{
    tvo_camera cam = tvo_camera_make_pinhole(752, 480, 458.654, 457.296, 367.215, 248.375);
    tvo_vo_config cfg;
    double *ts = NULL;
    tvo_pose *Tcw = NULL;
    int nf = 0, nr = 0, keyframes = 0, frames = 0;
    row *r;
    tracks tk;
    tvo_map m;
    tvo_arena ar;
    size_t ls, ss;
    void *mem, *scratch;
    FILE *o;
    if (argc < 4) {
        fprintf(stderr,
                "usage: bench_map_tracks GT.tum TRACKS.txt OUT.tum [--camera W H FX FY CX CY]\n"
                "       [--preset NAME] [--set NAME=VALUE]...\n");
        return 1;
    }
    for (int a = 4; a + 6 < argc; ++a)
        if (strcmp(argv[a], "--camera") == 0) {
            const double v[6] = {atof(argv[a + 1]), atof(argv[a + 2]), atof(argv[a + 3]),
                                 atof(argv[a + 4]), atof(argv[a + 5]), atof(argv[a + 6])};
            if (!(v[0] >= 16 && v[1] >= 16 && v[2] > 0 && v[3] > 0)) {
                fprintf(stderr, "bench_map_tracks: bad --camera\n");
                return 1;
            }
            cam = tvo_camera_make_pinhole((int32_t)v[0], (int32_t)v[1], v[2], v[3], v[4], v[5]);
        }
    tvo_vo_config_default(&cfg, &cam);
    for (int a = 4; a + 1 < argc; ++a) /* the preset first: --set applies on top of it */
        if (strcmp(argv[a], "--preset") == 0) {
            tvo_vo_preset p;
            if (tvo_replay_preset_from_name(argv[a + 1], &p) != 0 ||
                tvo_vo_config_preset(&cfg, &cam, p) != TVO_OK) {
                fprintf(stderr, "bench_map_tracks: bad --preset %s\n", argv[a + 1]);
                return 1;
            }
        }
    for (int a = 4; a < argc; ++a) {
        if (strcmp(argv[a], "--camera") == 0 && a + 6 < argc) {
            a += 6;
            continue;
        }
        if (strcmp(argv[a], "--preset") == 0 && a + 1 < argc) {
            ++a;
            continue;
        }
        if (strcmp(argv[a], "--set") != 0 || a + 1 >= argc ||
            tvo_replay_setting_apply(&cfg, argv[a + 1]) != 0) {
            fprintf(stderr, "bench_map_tracks: bad option %s\n", argv[a]);
            return 1;
        }
        ++a;
    }
    if (tvo_vo_required_size(&cfg) == 0) {
        fprintf(stderr,
                "bench_map_tracks: the --set values make a configuration the VO refuses (vo.h ranges)\n");
        return 1;
    }
    if (cfg.map_max_landmarks == 0)
        cfg.map_max_landmarks = 2 * cfg.max_tracks;
    if (!read_gt(argv[1], &ts, &Tcw, &nf) || (r = read_rows(argv[2], &nr)) == NULL || nr == 0) {
        fprintf(stderr, "bench_map_tracks: cannot read %s or %s\n", argv[1], argv[2]);
        return 1;
    }
    tk.cap = cfg.max_tracks;
    tk.n = 0;
    tk.id = malloc((size_t)tk.cap * sizeof(int));
    tk.x = malloc((size_t)tk.cap * sizeof(tvo_point2d));
    tk.tri_x = malloc((size_t)tk.cap * sizeof(tvo_point2d));
    tk.ok = malloc((size_t)tk.cap);
    tk.inlier = malloc((size_t)tk.cap);
    tk.lm = malloc((size_t)tk.cap * sizeof(int32_t));
    tk.tri_fr = malloc((size_t)tk.cap * sizeof(int32_t));
    ls = tvo_map_layout_size(&cfg) + TVO_ARENA_ALIGN;
    ss = tvo_map_scratch_size(&cfg);
    mem = malloc(ls);
    scratch = malloc(ss);
    o = fopen(argv[3], "w");
    if (!tk.id || !tk.x || !tk.tri_x || !tk.ok || !tk.inlier || !tk.lm || !tk.tri_fr || !mem || !scratch ||
        !o)
        return 1;
    memset(tk.ok, 1, (size_t)tk.cap);
    tvo_arena_init(&ar, mem, ls);
    if (tvo_map_init(&m, &cfg, &ar) != TVO_OK) {
        fprintf(stderr, "bench_map_tracks: map init failed\n");
        return 1;
    }
    for (int k = 0, q = 0; k < nf && q < nr; ++k) {
        const long long t_ns = r[q].t_ns;
        int q1 = q, first;
        tvo_map_tracks tr;
        tvo_map_frame mf;
        double R_cur_prev[9];
        while (q1 < nr && r[q1].t_ns == t_ns)
            ++q1;
        carry(&tk, r, q, q1);
        if (k > 0) {
            const tvo_pose Twp = tvo_pose_inverse(&Tcw[k - 1]), d = tvo_pose_compose(&Tcw[k], &Twp);
            memcpy(R_cur_prev, d.R, sizeof(R_cur_prev));
        }
        tr = (tvo_map_tracks){tk.n, tk.x, tk.ok, tk.lm, tk.tri_fr, tk.tri_x, tk.inlier, NULL, NULL};
        (void)tvo_map_process(&m, &cfg, &tr, (int64_t)t_ns, k > 0 ? R_cur_prev : NULL, 0, &Tcw[k], scratch,
                              ss, &mf);
        keyframes += mf.keyframe;
        if (mf.state == TVO_MAP_TRACKING || mf.state == TVO_MAP_INITIALISED) {
            write_pose(o, ts[k], &mf.T_c_w);
            ++frames;
        }
        first = tk.n;
        for (int j = q; j < q1 && tk.n < tk.cap; ++j) {
            if (r[j].age != 0 || r[j].id < 0)
                continue;
            tk.id[tk.n] = r[j].id;
            tk.x[tk.n].x = r[j].x;
            tk.x[tk.n].y = r[j].y;
            ++tk.n;
        }
        tr = (tvo_map_tracks){tk.n, tk.x, tk.ok, tk.lm, tk.tri_fr, tk.tri_x, tk.inlier, NULL, NULL};
        tvo_map_new_tracks(&m, &tr, first);
        q = q1;
    }
    fclose(o);
    printf("frames %d posed %d keyframes %d losses %d\n", nf, frames, keyframes, (int)m.losses);
    return 0;
}
