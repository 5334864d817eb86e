/* Relative-pose benchmark and accuracy evaluation (not a test).
 *   bench_relpose [trials]   (default 1000)
 * 1. minimal 5-point solve time (median and best of 20 x 1000 calls: the best is the figure least
 *    inflated by other jobs on a shared machine);
 * 2. tvo_relpose_estimate on 300 correspondences with 30 % outliers and 0.5 px noise (f = 460):
 *    median time, with and without the homography model;
 * 3. accuracy over `trials` seeded scenes: median rotation / translation-direction error and
 *    success rate (rotation < 1 deg and translation < 5 deg), noise-free rotation error, pure
 *    rotation (flag set, error <= 0.1 deg).
 * Single thread; the OpenCV ratio is measured by test/bench/bench_relpose.py in one process.
 *   bench_relpose --callgrind   fixed work for instruction counts (see callgrind_mode). */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "tinyvo/linalg.h"
#include "tinyvo/relpose.h"

static inline uint64_t tvo_test_rand(uint64_t *s)
{
    uint64_t x = *s;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    *s = x;
    return x * 0x2545F4914F6CDD1DULL;
}

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
            double X1[3] = {x * z, y * z, z}, X2[3];
            tvo_la_mat3_vec(sc->R, X1, X2);
            for (int k = 0; k < 3; ++k)
                X2[k] += base * sc->t[k];
            if (X2[2] < 0.5)
                continue;
            double u = X2[0] / X2[2], v = X2[1] / X2[2];
            if (fabs(u) > HALF_W || fabs(v) > HALF_H)
                continue;
            sc->x1[i].x = x + noise_px / F_PX * nrand(&s);
            sc->x1[i].y = y + noise_px / F_PX * nrand(&s);
            sc->x2[i].x = u + noise_px / F_PX * nrand(&s);
            sc->x2[i].y = v + noise_px / F_PX * nrand(&s);
            sc->outlier[i] = 0;
            break;
        }
        if (urand(&s) < outlier_ratio) {
            sc->x2[i].x = (2.0 * urand(&s) - 1.0) * HALF_W;
            sc->x2[i].y = (2.0 * urand(&s) - 1.0) * HALF_H;
            sc->outlier[i] = 1;
        }
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

static unsigned char g_scratch[1 << 16];

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Fixed work for instruction counts (valgrind --tool=callgrind --toggle-collect=...): 1000 minimal
 * solves on one sample, then tvo_relpose_estimate with the default configuration on the 20 scenes
 * 5000..5019 of the timing loop (300 points, 30 % outliers, 0.5 px). Divide the collected counts by
 * 1000 and 20 respectively. */
static int callgrind_mode(void)
{
    static scene sc;
    double a[5][2], b[5][2], E[10][9];
    make_scene(&sc, 1, 5, 20.0, 1.0, 0.0, 0.0, 0);
    for (int i = 0; i < 5; ++i) {
        a[i][0] = sc.x1[i].x;
        a[i][1] = sc.x1[i].y;
        b[i][0] = sc.x2[i].x;
        b[i][1] = sc.x2[i].y;
    }
    int sink = 0;
    for (int k = 0; k < 1000; ++k)
        sink += tvo_essential_5pt((const double (*)[2])a, (const double (*)[2])b, E);
    long iters = 0;
    for (int k = 0; k < 20; ++k) {
        tvo_relpose_config cfg;
        tvo_relpose out;
        tvo_relpose_config_default(&cfg);
        cfg.seed = (uint64_t)k;
        make_scene(&sc, 5000 + (uint64_t)k, 300, 20.0, 1.0, 0.5, 0.3, 0);
        tvo_relpose_estimate(&cfg, sc.x1, sc.x2, sc.n, &out, NULL, g_scratch, sizeof g_scratch);
        iters += out.iterations;
    }
    printf("callgrind mode: 1000 minimal solves, 20 RANSAC calls (mean %.1f iterations)\n", iters / 20.0);
    return sink < 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "--callgrind") == 0)
        return callgrind_mode();
    int trials = argc > 1 ? atoi(argv[1]) : 1000;
    if (trials < 1 || trials > 100000)
        trials = 1000;
    double *re = malloc(sizeof(double) * (size_t)trials), *te = malloc(sizeof(double) * (size_t)trials);
    double *tm = malloc(sizeof(double) * (size_t)trials);
    if (re == NULL || te == NULL || tm == NULL)
        return 1;
    /* 1. minimal solver */
    scene sc;
    make_scene(&sc, 1, 5, 20.0, 1.0, 0.0, 0.0, 0);
    double a[5][2], b[5][2], E[10][9], rep[20];
    for (int i = 0; i < 5; ++i) {
        a[i][0] = sc.x1[i].x;
        a[i][1] = sc.x1[i].y;
        b[i][0] = sc.x2[i].x;
        b[i][1] = sc.x2[i].y;
    }
    volatile int sink = 0;
    for (int r = 0; r < 20; ++r) {
        double t0 = now_s();
        for (int k = 0; k < 1000; ++k)
            sink += tvo_essential_5pt((const double (*)[2])a, (const double (*)[2])b, E);
        rep[r] = (now_s() - t0) / 1000.0;
    }
    qsort(rep, 20, sizeof(double), cmp_double);
    printf("5-point minimal solve: median %.2f us, best %.2f us of 20 x 1000 calls (%d solutions)\n", rep[10] * 1e6,
           rep[0] * 1e6,
           tvo_essential_5pt((const double (*)[2])a, (const double (*)[2])b, E));
    /* 2 + 3. RANSAC time and accuracy */
    for (int mode = 0; mode < 3; ++mode) {
        tvo_relpose_config cfg;
        tvo_relpose_config_default(&cfg);
        if (mode == 1)
            cfg.use_homography = 0;
        if (mode == 2)
            cfg.method = TVO_RELPOSE_8PT;
        int success = 0, iters = 0;
        for (int k = 0; k < trials; ++k) {
            tvo_relpose out;
            make_scene(&sc, 5000 + (uint64_t)k, 300, 20.0, 1.0, 0.5, 0.3, 0);
            cfg.seed = (uint64_t)k;
            double t0 = now_s();
            tvo_relpose_estimate(&cfg, sc.x1, sc.x2, sc.n, &out, NULL, g_scratch, sizeof g_scratch);
            tm[k] = now_s() - t0;
            re[k] = tvo_la_rot_dist(out.R, sc.R) * DEG;
            te[k] = (out.flags & TVO_RELPOSE_FLAG_ROTATION_ONLY) ? 180.0 : t_err_deg(out.t, sc.t);
            success += re[k] < 1.0 && te[k] < 5.0;
            iters += out.iterations;
        }
        qsort(re, (size_t)trials, sizeof(double), cmp_double);
        qsort(te, (size_t)trials, sizeof(double), cmp_double);
        qsort(tm, (size_t)trials, sizeof(double), cmp_double);
        printf("%s, 300 pts, 30%% outliers, 0.5 px: median %.3f ms (p90 %.3f), mean RANSAC iters %.1f | "
               "median rot %.4f deg, t %.4f deg, success %d/%d (%.2f%%)\n",
               mode == 0 ? "5pt + H model" : mode == 1 ? "5pt, no H model" : "8pt + H model", tm[trials / 2] * 1e3,
               tm[trials * 9 / 10] * 1e3, (double)iters / trials, re[trials / 2], te[trials / 2], success, trials,
               100.0 * success / trials);
    }
    /* noise-free and pure rotation */
    double worst_nf = 0.0, worst_rot = 0.0;
    int flagged = 0;
    for (int k = 0; k < trials; ++k) {
        tvo_relpose out;
        tvo_relpose_config cfg;
        tvo_relpose_config_default(&cfg);
        cfg.seed = (uint64_t)k;
        make_scene(&sc, 70000 + (uint64_t)k, 300, 20.0, 1.0, 0.0, 0.3, 0);
        tvo_relpose_estimate(&cfg, sc.x1, sc.x2, sc.n, &out, NULL, g_scratch, sizeof g_scratch);
        double e = tvo_la_rot_dist(out.R, sc.R);
        if (e > worst_nf)
            worst_nf = e;
        make_scene(&sc, 90000 + (uint64_t)k, 300, 20.0, 0.0, 0.5, 0.3, 0);
        tvo_relpose_estimate(&cfg, sc.x1, sc.x2, sc.n, &out, NULL, g_scratch, sizeof g_scratch);
        e = tvo_la_rot_dist(out.R, sc.R) * DEG;
        if (e > worst_rot)
            worst_rot = e;
        flagged += (out.flags & TVO_RELPOSE_FLAG_LOW_PARALLAX) != 0;
    }
    printf("noise-free, 30%% outliers: worst rotation error %.2e rad over %d trials\n", worst_nf, trials);
    printf("pure rotation, 0.5 px, 30%% outliers: worst rotation error %.4f deg, low-parallax flag %d/%d\n",
           worst_rot, flagged, trials);
    free(re);
    free(te);
    free(tm);
    return sink < 0;
}
