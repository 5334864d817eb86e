/* SPDX-License-Identifier: Apache-2.0 */
/* A synthetic road for driving the VO's map module (lib/src/tvo_map.h, internal) directly with exact
 * tracks: test_map_store checks the map's landmark store on it, bench_map_road measures the map's drift.
 *
 * A camera drives 0.15 m a frame (10 Hz) down a road, swaying 0.4 m sideways and 3 degrees in yaw, among
 * points 1-6 m to the sides and 3 m above and below, spread along the road to 30 m beyond its end. Each
 * track follows one point for 10-40 frames (or until it leaves the 320x240 image, focal 250 px, 5 px
 * margin) and new tracks on the next points in view fill up to max_tracks. A track's position is the
 * point's projection plus its offset (a random walk of drift_px a frame, and a jump of up to +-8 px per
 * axis with probability jump_prob a frame, which stays) plus noise_px of independent noise; every width
 * is the full width of a uniform distribution. The map gets the exact two-view rotations and the true
 * pose as the pose a new map starts from. Deterministic for a seed. Needs the include paths of lib/src. */
#ifndef TVO_ROAD_H
#define TVO_ROAD_H

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "tinyvo/se3.h"
#include "tvo_map.h"

#define TVO_ROAD_WIDTH 320
#define TVO_ROAD_HEIGHT 240
#define TVO_ROAD_FOCAL 250.0
#define TVO_ROAD_DT_NS 100000000LL
#define TVO_ROAD_STEP_M 0.15

typedef struct tvo_road {
    int32_t frames, max_tracks, n_points;
    double noise_px, drift_px, jump_prob;
    int prior_flags; /* TVO_MAP_PRIOR_* bits of the next frames' two-view rotation (0 after open) */
    uint32_t seed;   /* the generator's state */
    double (*pts)[3];
    /* the tracks, n of them, in the layout tvo_map_tracks views */
    int32_t n, next_point;
    int32_t *pid, *life, *lm, *tri_fr;
    tvo_point2d *x, *tri_x, *off;
    uint8_t *ok, *inlier;
} tvo_road;

/* the road's generator: a linear congruential sequence, uniform in [0, 1) */
static inline double tvo_road_rnd(uint32_t *s)
{
    *s = *s * 1664525u + 1013904223u;
    return (double)(*s >> 8) / 16777216.0;
}

/* the camera of frame k, world -> camera */
static inline tvo_pose tvo_road_camera(int k)
{
    tvo_pose T_w_c = tvo_pose_identity();
    const double v[3] = {0.0, 0.05 * sin(0.07 * k), 0.0};
    tvo_rotvec_to_rot(v, T_w_c.R);
    T_w_c.t[0] = 0.4 * sin(0.05 * k);
    T_w_c.t[2] = TVO_ROAD_STEP_M * k;
    return tvo_pose_inverse(&T_w_c);
}

/* point X seen by T_c_w: 1 and its normalised position when in front and inside the image */
static inline int tvo_road_project(const tvo_pose *T_c_w, const double X[3], tvo_point2d *x)
{
    double P[3];
    tvo_pose_transform_point(T_c_w, X, P);
    if (!(P[2] > 0.5))
        return 0;
    x->x = P[0] / P[2];
    x->y = P[1] / P[2];
    return fabs(x->x * TVO_ROAD_FOCAL) < TVO_ROAD_WIDTH / 2 - 5 &&
            fabs(x->y * TVO_ROAD_FOCAL) < TVO_ROAD_HEIGHT / 2 - 5;
}

static inline void tvo_road_close(tvo_road *r)
{
    free(r->pts);
    free(r->pid);
    free(r->life);
    free(r->lm);
    free(r->tri_fr);
    free(r->x);
    free(r->tri_x);
    free(r->off);
    free(r->ok);
    free(r->inlier);
    memset(r, 0, sizeof(*r));
}

/* The road's points and empty tracks; 0 when out of memory (r closed). */
static inline int tvo_road_open(tvo_road *r, int32_t frames, int32_t max_tracks, int32_t n_points,
                                double noise_px, double drift_px, double jump_prob, uint32_t seed)
{
    const size_t nt = (size_t)max_tracks;
    memset(r, 0, sizeof(*r));
    r->frames = frames;
    r->max_tracks = max_tracks;
    r->n_points = n_points;
    r->noise_px = noise_px;
    r->drift_px = drift_px;
    r->jump_prob = jump_prob;
    r->seed = seed;
    r->pts = malloc((size_t)n_points * sizeof(*r->pts));
    r->pid = malloc(nt * sizeof(int32_t));
    r->life = malloc(nt * sizeof(int32_t));
    r->lm = malloc(nt * sizeof(int32_t));
    r->tri_fr = malloc(nt * sizeof(int32_t));
    r->x = malloc(nt * sizeof(tvo_point2d));
    r->tri_x = malloc(nt * sizeof(tvo_point2d));
    r->off = malloc(nt * sizeof(tvo_point2d));
    r->ok = malloc(nt);
    r->inlier = malloc(nt);
    if (!r->pts || !r->pid || !r->life || !r->lm || !r->tri_fr || !r->x || !r->tri_x || !r->off || !r->ok ||
        !r->inlier) {
        tvo_road_close(r);
        return 0;
    }
    memset(r->ok, 1, nt);
    for (int32_t i = 0; i < n_points; ++i) {
        const double side = tvo_road_rnd(&r->seed) < 0.5 ? -1.0 : 1.0;
        r->pts[i][0] = side * (1.0 + 5.0 * tvo_road_rnd(&r->seed));
        r->pts[i][1] = -3.0 + 6.0 * tvo_road_rnd(&r->seed);
        r->pts[i][2] = 2.0 + (TVO_ROAD_STEP_M * frames + 30.0) * (double)i / n_points;
    }
    return 1;
}

static inline tvo_map_tracks tvo_road_tracks(tvo_road *r)
{
    return (tvo_map_tracks){r->n, r->x, r->ok, r->lm, r->tri_fr, r->tri_x, r->inlier, NULL, NULL};
}

/* Frame k: the tracks go on (or end), the map processes them, new tracks fill up and start waiting in the
 * map. Returns tvo_map_process's status (the new tracks are not added after an error). */
static inline tvo_status tvo_road_frame(tvo_road *r, tvo_map *m, const tvo_vo_config *cfg, int k,
                                        void *scratch, size_t scratch_size, tvo_map_frame *out)
{
    const tvo_pose T = tvo_road_camera(k);
    const double f = TVO_ROAD_FOCAL;
    tvo_map_tracks tr;
    double R_cur_prev[9];
    int32_t first, kept = 0;
    tvo_status st;
    for (int32_t i = 0; i < r->n; ++i) {
        tvo_point2d p;
        if (--r->life[i] <= 0 || !tvo_road_project(&T, r->pts[r->pid[i]], &p))
            continue;
        r->pid[kept] = r->pid[i];
        r->life[kept] = r->life[i];
        r->lm[kept] = r->lm[i];
        r->tri_fr[kept] = r->tri_fr[i];
        r->tri_x[kept] = r->tri_x[i];
        r->off[kept].x = r->off[i].x + (tvo_road_rnd(&r->seed) - 0.5) * r->drift_px / f;
        r->off[kept].y = r->off[i].y + (tvo_road_rnd(&r->seed) - 0.5) * r->drift_px / f;
        if (r->jump_prob > 0.0 && tvo_road_rnd(&r->seed) < r->jump_prob) {
            r->off[kept].x += (tvo_road_rnd(&r->seed) - 0.5) * 16.0 / f;
            r->off[kept].y += (tvo_road_rnd(&r->seed) - 0.5) * 16.0 / f;
        }
        r->x[kept].x = p.x + r->off[kept].x + (tvo_road_rnd(&r->seed) - 0.5) * r->noise_px / f;
        r->x[kept].y = p.y + r->off[kept].y + (tvo_road_rnd(&r->seed) - 0.5) * r->noise_px / f;
        ++kept;
    }
    r->n = kept;
    if (k > 0) {
        const tvo_pose Tp = tvo_road_camera(k - 1), Twp = tvo_pose_inverse(&Tp),
                       d = tvo_pose_compose(&T, &Twp);
        memcpy(R_cur_prev, d.R, sizeof(R_cur_prev));
    }
    tr = tvo_road_tracks(r);
    st = tvo_map_process(m, cfg, &tr, 1000000000LL + k * TVO_ROAD_DT_NS, k > 0 ? R_cur_prev : NULL,
                         r->prior_flags, &T, scratch, scratch_size, out);
    if (st != TVO_OK)
        return st;
    first = r->n;
    while (r->n < r->max_tracks && r->next_point < r->n_points) {
        tvo_point2d p;
        const int32_t i = r->next_point++;
        if (!tvo_road_project(&T, r->pts[i], &p))
            continue;
        r->pid[r->n] = i;
        r->life[r->n] = 10 + (int32_t)(30.0 * tvo_road_rnd(&r->seed));
        r->lm[r->n] = -1;
        r->tri_fr[r->n] = -1;
        r->off[r->n].x = r->off[r->n].y = 0.0;
        r->x[r->n] = p;
        r->n++;
    }
    tr = tvo_road_tracks(r);
    tvo_map_new_tracks(m, &tr, first);
    return TVO_OK;
}

#endif /* TVO_ROAD_H */
