/* SPDX-License-Identifier: Apache-2.0 */
/* Synthetic two-view scenes for the relative-pose tests and benchmark: f = 460 px, 752x480 image,
 * points 1..8 m deep (or on one plane), seeded generator. Used by test/unit/test_relpose.c and
 * test/bench/bench_relpose.c (which does not link cmocka). */
#ifndef TVO_RELPOSE_SCENE_H
#define TVO_RELPOSE_SCENE_H

#include <math.h>
#include <stdint.h>

#include "tinyvo/linalg.h"
#include "tvo_rand.h"

#define F_PX 460.0
#define HALF_W (376.0 / F_PX)
#define HALF_H (240.0 / F_PX)
#define DEG (180.0 / 3.14159265358979323846)

static double urand(uint64_t *s)
{
    return (double)(tvo_test_rand(s) >> 11) * (1.0 / 9007199254740992.0);
}

static double nrand(uint64_t *s)
{
    double u1 = urand(s), u2 = urand(s);
    if (u1 < 1e-300)
        u1 = 1e-300;
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

typedef struct scene {
    double R[9], t[3]; /* ground truth, t unit (or zero) */
    tvo_point2d x1[600], x2[600];
    uint8_t outlier[600];
    int n;
} scene;

/* Correspondence i of sc: the point at depth z on the ray (x, y) of camera 1, seen by camera 2 after the
 * scene's motion (R, base t), both positions with noise_px of noise; 0 (nothing written, nothing drawn)
 * when camera 2 does not see it (closer than 0.5 or outside the image). */
static int scene_put(scene *sc, int i, double x, double y, double z, double base, double noise_px,
                     uint64_t *s)
{
    double X1[3] = {x * z, y * z, z}, X2[3];
    tvo_la_mat3_vec(sc->R, X1, X2);
    for (int k = 0; k < 3; ++k)
        X2[k] += base * sc->t[k];
    if (X2[2] < 0.5)
        return 0;
    double u = X2[0] / X2[2], v = X2[1] / X2[2];
    if (fabs(u) > HALF_W || fabs(v) > HALF_H)
        return 0;
    sc->x1[i].x = x + noise_px / F_PX * nrand(s);
    sc->x1[i].y = y + noise_px / F_PX * nrand(s);
    sc->x2[i].x = u + noise_px / F_PX * nrand(s);
    sc->x2[i].y = v + noise_px / F_PX * nrand(s);
    sc->outlier[i] = 0;
    return 1;
}

/* random rotation of angle <= max_deg, translation of length `base` in a random direction (0 for
 * pure rotation); planar != 0 puts all points on one plane (2: and moves mostly sideways) */
static void make_scene(scene *sc, uint64_t seed, int n, double max_deg, double base, double noise_px,
                       double outlier_ratio, int planar)
{
    uint64_t s = seed * 0x9E3779B97F4A7C15ULL + 12345;
    double w[3], ang = max_deg / DEG * urand(&s);
    double ax[3] = {nrand(&s), nrand(&s), nrand(&s)};
    double na = sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
    for (int k = 0; k < 3; ++k)
        w[k] = ax[k] / na * ang;
    tvo_la_so3_exp(w, sc->R);
    double td[3] = {nrand(&s), nrand(&s), nrand(&s)};
    if (planar == 2)
        td[2] *= 0.2; /* mostly sideways motion: cheirality can rule out the plane's twin solution */
    double nt = sqrt(td[0] * td[0] + td[1] * td[1] + td[2] * td[2]);
    for (int k = 0; k < 3; ++k)
        sc->t[k] = base > 0.0 ? td[k] / nt : 0.0;
    /* plane: normal tilted from the optical axis, 4 m away */
    double pn[3] = {0.3 * nrand(&s), 0.3 * nrand(&s), 1.0};
    double pnn = sqrt(pn[0] * pn[0] + pn[1] * pn[1] + pn[2] * pn[2]);
    for (int k = 0; k < 3; ++k)
        pn[k] /= pnn;
    sc->n = n;
    for (int i = 0; i < n; ++i) {
        for (int tries = 0; tries < 1000; ++tries) {
            double x = (2.0 * urand(&s) - 1.0) * HALF_W, y = (2.0 * urand(&s) - 1.0) * HALF_H;
            double z = planar ? 4.0 / (pn[0] * x + pn[1] * y + pn[2]) : 1.0 + 7.0 * urand(&s);
            if (!(z > 0.5 && z < 50.0))
                continue;
            if (scene_put(sc, i, x, y, z, base, noise_px, &s))
                break;
        }
        if (urand(&s) < outlier_ratio) {
            sc->x2[i].x = (2.0 * urand(&s) - 1.0) * HALF_W;
            sc->x2[i].y = (2.0 * urand(&s) - 1.0) * HALF_H;
            sc->outlier[i] = 1;
        }
    }
}

/* The first n correspondences of sc as the minimal solvers' arrays: a[i] = x1[i], b[i] = x2[i]. */
static void scene_arrays(const scene *sc, int n, double (*a)[2], double (*b)[2])
{
    for (int i = 0; i < n; ++i) {
        a[i][0] = sc->x1[i].x;
        a[i][1] = sc->x1[i].y;
        b[i][0] = sc->x2[i].x;
        b[i][1] = sc->x2[i].y;
    }
}

static double t_err_deg(const double a[3], const double b[3])
{
    double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    double na = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    double nb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    double c = d / (na * nb);
    if (c > 1.0)
        c = 1.0;
    if (c < -1.0)
        c = -1.0;
    return acos(c) * DEG;
}

#endif /* TVO_RELPOSE_SCENE_H */
