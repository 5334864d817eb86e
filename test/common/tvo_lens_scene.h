/* SPDX-License-Identifier: Apache-2.0 */
/* A bundle-adjustment window for the lens refinement's tests (lib/src/tvo_lens.h): 6 poses of a camera
 * moving forward and turning, 400 points in front, each point's pixel taken with one lens (plus Gaussian
 * noise) and stored as the VO stores it, undistorted with another. Only + - * / sqrt and the core's own
 * tvo_la_so3_exp / tvo_dm_* are used, so the window is the same bits on every target
 * (test_determinism's "lens" stage). */
#ifndef TVO_LENS_SCENE_H
#define TVO_LENS_SCENE_H

#include <stdint.h>
#include <string.h>

#include "tinyvo/ba.h"
#include "tinyvo/camera.h"
#include "tinyvo/dmath.h"
#include "tinyvo/linalg.h"

#define TVO_LS_POSES 6
#define TVO_LS_POINTS 400

typedef struct tvo_lens_scene {
    tvo_pose T[TVO_LS_POSES];
    uint8_t fixed[TVO_LS_POSES];
    double X[TVO_LS_POINTS][3];
    tvo_ba_obs obs[TVO_LS_POSES * TVO_LS_POINTS];
    tvo_ba_problem p;
} tvo_lens_scene;

/* a 640 x 480 RADTAN camera, f = 500, with k1, k2 */
static inline tvo_camera tvo_ls_camera(double k1, double k2)
{
    tvo_camera c = tvo_camera_make_pinhole(640, 480, 500.0, 500.0, 319.5, 239.5);
    c.model = TVO_DIST_RADTAN;
    c.k[0] = k1;
    c.k[1] = k2;
    return c;
}

/* uniform in [a, b) from a fixed LCG */
static inline double tvo_ls_uniform(uint32_t *s, double a, double b)
{
    *s = *s * 1664525u + 1013904223u;
    return a + (b - a) * (double)(*s >> 8) / 16777216.0;
}

/* standard Gaussian (Box-Muller with the core's deterministic log and cos) */
static inline double tvo_ls_gauss(uint32_t *s)
{
    const double u = tvo_ls_uniform(s, 1e-12, 1.0), v = tvo_ls_uniform(s, 0.0, 1.0);
    return sqrt(-2.0 * tvo_dm_log(u)) * tvo_dm_cos(6.283185307179586 * v);
}

/* The window: pixels of lens `truth` plus noise_px of noise, stored undistorted with lens `cfg`; poses 0
 * and 1 flagged fixed. 0 when a library call fails. */
static inline int tvo_ls_make(tvo_lens_scene *sc, const tvo_camera *truth, const tvo_camera *cfg,
                              double noise_px)
{
    uint32_t s = 12345u;
    int32_t no = 0;
    for (int i = 0; i < TVO_LS_POSES; ++i) {
        const double w[3] = {0.0, 0.03 * i, 0.0}, C[3] = {0.2 * i, 0.0, 0.5 * i};
        tvo_la_so3_exp(w, sc->T[i].R);
        for (int r = 0; r < 3; ++r) /* t = -R C */
            sc->T[i].t[r] = -(sc->T[i].R[3 * r] * C[0] + sc->T[i].R[3 * r + 1] * C[1] +
                              sc->T[i].R[3 * r + 2] * C[2]);
        sc->fixed[i] = (uint8_t)(i < 2);
    }
    for (int j = 0; j < TVO_LS_POINTS; ++j) {
        sc->X[j][0] = tvo_ls_uniform(&s, -6.0, 7.0);
        sc->X[j][1] = tvo_ls_uniform(&s, -4.0, 4.0);
        sc->X[j][2] = tvo_ls_uniform(&s, 7.0, 16.0);
        for (int i = 0; i < TVO_LS_POSES; ++i) {
            double P[3], u, v;
            tvo_point2d x, xn;
            for (int r = 0; r < 3; ++r)
                P[r] = sc->T[i].R[3 * r] * sc->X[j][0] + sc->T[i].R[3 * r + 1] * sc->X[j][1] +
                        sc->T[i].R[3 * r + 2] * sc->X[j][2] + sc->T[i].t[r];
            x.x = P[0] / P[2];
            x.y = P[1] / P[2];
            if (tvo_camera_distort_point(truth, &x, &u, &v) != TVO_OK)
                return 0;
            u += noise_px * tvo_ls_gauss(&s);
            v += noise_px * tvo_ls_gauss(&s);
            if (u < 0.0 || v < 0.0 || u > 639.0 || v > 479.0)
                continue;
            if (tvo_camera_undistort_point(cfg, u, v, &xn) != TVO_OK)
                return 0;
            sc->obs[no].pose = i;
            sc->obs[no].point = j;
            sc->obs[no].x = xn.x;
            sc->obs[no].y = xn.y;
            ++no;
        }
    }
    memset(&sc->p, 0, sizeof(sc->p));
    sc->p.n_poses = TVO_LS_POSES;
    sc->p.T_c_w = sc->T;
    sc->p.pose_fixed = sc->fixed;
    sc->p.n_points = TVO_LS_POINTS;
    sc->p.X = sc->X;
    sc->p.n_obs = no;
    sc->p.obs = sc->obs;
    return 1;
}

#endif /* TVO_LENS_SCENE_H */
