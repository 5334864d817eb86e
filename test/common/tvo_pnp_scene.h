/* SPDX-License-Identifier: Apache-2.0 */
/* Synthetic PnP scenes for test/unit/test_pnp.c and test/bench/bench_pnp.c (which does not link
 * cmocka): f = 450 px, 752x480 image, points 2..12 m in front of a camera at a random pose (any
 * rotation, centre within +-5 m of the world origin), Gaussian pixel noise, outliers as random image
 * points; seeded generator. */
#ifndef TVO_PNP_SCENE_H
#define TVO_PNP_SCENE_H

#include <math.h>
#include <stdint.h>

#include "tinyvo/se3.h"
#include "tvo_rand.h"

#define F_PX 450.0
#define HALF_W (376.0 / F_PX)
#define HALF_H (240.0 / F_PX)
#define MAXN 400
#define DEG (180.0 / 3.14159265358979323846)

static inline double urand(uint64_t *s)
{
    return (double)(tvo_test_rand(s) >> 11) * (1.0 / 9007199254740992.0);
}

static inline double nrand(uint64_t *s)
{
    double u1 = urand(s), u2 = urand(s);
    if (u1 < 1e-300)
        u1 = 1e-300;
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

typedef struct pscene {
    tvo_pose T; /* ground truth T_c_w */
    double X[MAXN][3];
    tvo_point2d x[MAXN];
    uint8_t outlier[MAXN];
    int n, n_out;
} pscene;

static inline void random_pose(uint64_t *s, double max_angle, double box, tvo_pose *T)
{
    double ax[3] = {nrand(s), nrand(s), nrand(s)};
    double na = sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]), ang = max_angle * urand(s), w[3], C[3];
    for (int k = 0; k < 3; ++k) {
        w[k] = ax[k] / na * ang;
        C[k] = box * (2.0 * urand(s) - 1.0);
    }
    tvo_rotvec_to_rot(w, T->R);
    for (int r = 0; r < 3; ++r)
        T->t[r] = -(T->R[3 * r] * C[0] + T->R[3 * r + 1] * C[1] + T->R[3 * r + 2] * C[2]);
}

/* n points in front of the true camera; noise in pixels; outliers: random image points */
static inline void make_pscene(pscene *sc, uint64_t seed, int n, double noise_px, double outlier_ratio)
{
    uint64_t s = seed * 0x9E3779B97F4A7C15ULL + 777;
    random_pose(&s, 3.14159, 5.0, &sc->T);
    tvo_pose Twc = tvo_pose_inverse(&sc->T);
    sc->n = n;
    sc->n_out = 0;
    for (int i = 0; i < n; ++i) {
        double u = (2.0 * urand(&s) - 1.0) * HALF_W, v = (2.0 * urand(&s) - 1.0) * HALF_H;
        double z = 2.0 + 10.0 * urand(&s);
        double Xc[3] = {u * z, v * z, z};
        tvo_pose_transform_point(&Twc, Xc, sc->X[i]);
        sc->outlier[i] = (uint8_t)(urand(&s) < outlier_ratio);
        if (sc->outlier[i]) {
            sc->x[i].x = (2.0 * urand(&s) - 1.0) * HALF_W;
            sc->x[i].y = (2.0 * urand(&s) - 1.0) * HALF_H;
            sc->n_out++;
        } else {
            sc->x[i].x = u + noise_px / F_PX * nrand(&s);
            sc->x[i].y = v + noise_px / F_PX * nrand(&s);
        }
    }
}

#endif /* TVO_PNP_SCENE_H */
