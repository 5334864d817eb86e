/* SPDX-License-Identifier: Apache-2.0 */
/* Benchmark of the windowed bundle adjustment (tvo_ba_solve) on a bench-like local map: 6 poses along a
 * path (the 2 oldest fixed), 300 points 4..10 m ahead, each seen by 4 consecutive poses (1200
 * observations), 0.5 px noise (f = 458 px), 5 % outliers of 15..40 px, free poses perturbed by ~0.6 deg /
 * 3 cm and points by 10 cm; default config with max_iterations = 5. Every call starts from the same
 * perturbed state. Prints the report of one call, the median / p90 microseconds per call and a
 * checksum of the result.
 *
 *   bench_ba [--poses N] [calls]              default 6 poses, 200 calls
 *   bench_ba [--poses N] --callgrind [calls]  no timing (default 10 calls), for
 *       valgrind --tool=callgrind --toggle-collect=tvo_ba_solve bench_ba --callgrind   (total / calls)
 * --poses N (4..10): a longer window along the same path with 50 N points (still 4 views each). */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "tinyvo/ba.h"
#include "tvo_rand.h"

#define NPOSE_MAX 10
#define NPT_MAX 500
#define NVIEW 4
#define NOBS_MAX (NPT_MAX * NVIEW)
#define FOCAL 458.0

static double urand(uint64_t *s) /* [-1, 1) */
{
    return (double)(tvo_test_rand(s) >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

static double nrand(uint64_t *s)
{
    double a = 0.0;
    for (int i = 0; i < 12; ++i)
        a += 0.5 * (urand(s) + 1.0);
    return a - 6.0;
}

static double now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e6 + (double)ts.tv_nsec * 1e-3;
}

static int cmp_d(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void left_rotate(tvo_pose *T, const double rv[3], const double dt[3])
{
    double Rd[9], R[9];
    tvo_rotvec_to_rot(rv, Rd);
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            R[3 * r + c] = Rd[3 * r] * T->R[c] + Rd[3 * r + 1] * T->R[3 + c] + Rd[3 * r + 2] * T->R[6 + c];
    memcpy(T->R, R, sizeof R);
    for (int a = 0; a < 3; ++a)
        T->t[a] += dt[a];
}

int main(int argc, char **argv)
{
    static tvo_pose T0[NPOSE_MAX], T[NPOSE_MAX];
    static double X_true[NPT_MAX][3], X0[NPT_MAX][3], X[NPT_MAX][3];
    static tvo_ba_obs obs[NOBS_MAX];
    static uint8_t fixed[NPOSE_MAX] = {1, 1};
    int callgrind = 0, calls, n_obs = 0, n_pose = 6, n_pt;
    uint64_t rng = 42;
    tvo_ba_config cfg;
    tvo_ba_problem p;
    tvo_ba_report rep;
    size_t size;
    void *mem;
    double *t_us, sum = 0.0;
    if (argc > 2 && strcmp(argv[1], "--poses") == 0) {
        n_pose = atoi(argv[2]);
        if (n_pose < NVIEW || n_pose > NPOSE_MAX) {
            fprintf(stderr, "bench_ba: --poses must be %d..%d\n", NVIEW, NPOSE_MAX);
            return 2;
        }
        argc -= 2;
        argv += 2;
    }
    n_pt = 50 * n_pose;
    if (argc > 1 && strcmp(argv[1], "--callgrind") == 0) {
        callgrind = 1;
        argc--;
        argv++;
    }
    calls = argc > 1 ? atoi(argv[1]) : (callgrind ? 10 : 200);
    if (calls < 1)
        calls = 1;
    for (int i = 0; i < n_pose; ++i) {
        const double rv[3] = {0.01 * sin(0.7 * i), 0.03 * i - 0.07, 0.005 * i};
        const double c[3] = {0.25 * i, 0.03 * sin(1.3 * i), 0.02 * i};
        tvo_rotvec_to_rot(rv, T0[i].R);
        for (int r = 0; r < 3; ++r)
            T0[i].t[r] = -(T0[i].R[3 * r] * c[0] + T0[i].R[3 * r + 1] * c[1] + T0[i].R[3 * r + 2] * c[2]);
    }
    for (int j = 0; j < n_pt; ++j) {
        const double z = 4.0 + 3.0 * (urand(&rng) + 1.0);
        const int first = j % (n_pose - NVIEW + 1);
        X_true[j][0] = 0.6 + 0.5 * z * urand(&rng);
        X_true[j][1] = 0.4 * z * urand(&rng);
        X_true[j][2] = z;
        for (int v = 0; v < NVIEW; ++v) {
            tvo_ba_obs *o = &obs[n_obs++];
            double P[3];
            tvo_pose_transform_point(&T0[first + v], X_true[j], P);
            o->pose = first + v;
            o->point = j;
            o->x = P[0] / P[2] + 0.5 / FOCAL * nrand(&rng);
            o->y = P[1] / P[2] + 0.5 / FOCAL * nrand(&rng);
            if (urand(&rng) < -0.9) { /* 5 % */
                const double a = 3.14159265358979 * urand(&rng), m = (27.5 + 12.5 * urand(&rng)) / FOCAL;
                o->x += m * cos(a);
                o->y += m * sin(a);
            }
        }
    }
    for (int i = 2; i < n_pose; ++i) {
        const double rv[3] = {0.01 * urand(&rng), 0.01 * urand(&rng), 0.01 * urand(&rng)};
        const double dt[3] = {0.03 * urand(&rng), 0.03 * urand(&rng), 0.03 * urand(&rng)};
        left_rotate(&T0[i], rv, dt);
    }
    for (int j = 0; j < n_pt; ++j)
        for (int a = 0; a < 3; ++a)
            X0[j][a] = X_true[j][a] + 0.1 * urand(&rng);

    tvo_ba_config_default(&cfg);
    cfg.max_iterations = 5;
    cfg.max_poses = n_pose;
    cfg.max_points = n_pt;
    cfg.max_obs = n_pt * NVIEW;
    size = tvo_ba_scratch_size(&cfg);
    mem = malloc(size);
    t_us = (double *)malloc((size_t)calls * sizeof *t_us);
    if (mem == NULL || t_us == NULL)
        return 1;
    p.n_poses = n_pose;
    p.T_c_w = T;
    p.pose_fixed = fixed;
    p.n_points = n_pt;
    p.X = X;
    p.point_fixed = NULL;
    p.n_obs = n_obs;
    p.obs = obs;
    p.n_rot = 0; /* no rotation priors */
    p.rot = NULL;
    p.prior = NULL; /* no point priors */
    for (int c = 0; c < calls; ++c) {
        double t0;
        tvo_status st;
        memcpy(T, T0, sizeof T);
        memcpy(X, X0, sizeof X);
        t0 = callgrind ? 0.0 : now_us();
        st = tvo_ba_solve(&cfg, &p, mem, size, &rep);
        t_us[c] = callgrind ? 0.0 : now_us() - t0;
        if (st != TVO_OK) {
            fprintf(stderr, "bench_ba: tvo_ba_solve returned %d\n", (int)st);
            return 1;
        }
    }
    for (int i = 0; i < n_pose; ++i)
        for (int a = 0; a < 3; ++a)
            sum += T[i].t[a];
    for (int j = 0; j < n_pt; ++j)
        sum += X[j][0] + X[j][1] + X[j][2];
    printf("bench_ba: %d poses (2 fixed), %d points, %d observations, scratch %zu bytes\n", n_pose, n_pt,
           n_obs, size);
    printf("report: iterations %d accepted %d flags %d points_skipped %d obs_skipped %d cost %.6g -> %.6g\n",
           rep.iterations, rep.accepted, rep.flags, rep.points_skipped, rep.obs_skipped, rep.cost_initial,
           rep.cost_final);
    if (!callgrind) {
        qsort(t_us, (size_t)calls, sizeof *t_us, cmp_d);
        printf("%d calls: median %.1f us, p90 %.1f us\n", calls, t_us[calls / 2], t_us[(calls * 9) / 10]);
    }
    printf("checksum %.12g\n", sum);
    free(t_us);
    free(mem);
    return 0;
}
