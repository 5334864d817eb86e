/* SPDX-License-Identifier: Apache-2.0 */
/* Relative-pose benchmark and accuracy evaluation (not a test).
 *   bench_relpose [trials]   (default 1000)
 * 1. minimal 5-point solve time (median and best of 20 x 1000 calls: the best is the figure least
 *    inflated by other jobs on a shared machine);
 * 2. tvo_relpose_estimate on 300 correspondences with 30 % outliers and 0.5 px noise (f = 460):
 *    median time, with and without the homography model, with the 8-point solver, and the RANSAC
 *    stage with pose recovery only (no homography model, no final LM polish: the work of OpenCV's
 *    findEssentialMat + recoverPose, plus LO and the rotation-only model);
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
#include "tvo_relpose_scene.h"

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
    scene_arrays(&sc, 5, a, b);
    int sink = 0;
    for (int k = 0; k < 1000; ++k)
        sink += tvo_essential_5pt((const double(*)[2])a, (const double(*)[2])b, E);
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
    scene_arrays(&sc, 5, a, b);
    volatile int sink = 0;
    for (int r = 0; r < 20; ++r) {
        double t0 = now_s();
        for (int k = 0; k < 1000; ++k)
            sink += tvo_essential_5pt((const double(*)[2])a, (const double(*)[2])b, E);
        rep[r] = (now_s() - t0) / 1000.0;
    }
    qsort(rep, 20, sizeof(double), cmp_double);
    printf("5-point minimal solve: median %.2f us, best %.2f us of 20 x 1000 calls (%d solutions)\n",
           rep[10] * 1e6, rep[0] * 1e6, tvo_essential_5pt((const double(*)[2])a, (const double(*)[2])b, E));
    /* 2 + 3. RANSAC time and accuracy */
    static const char *const mode_name[4] = {"5pt + H model", "5pt, no H model", "8pt + H model",
                                             "5pt RANSAC + pose only (no H model, no LM polish)"};
    for (int mode = 0; mode < 4; ++mode) {
        tvo_relpose_config cfg;
        tvo_relpose_config_default(&cfg);
        if (mode == 1 || mode == 3)
            cfg.use_homography = 0;
        if (mode == 2)
            cfg.method = TVO_RELPOSE_8PT;
        if (mode == 3)
            cfg.refine_iters = 0; /* what findEssentialMat + recoverPose do, plus LO and the rotation model */
        int success = 0, iters = 0, capped = 0;
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
            capped += out.iterations >= cfg.max_iters;
        }
        qsort(re, (size_t)trials, sizeof(double), cmp_double);
        qsort(te, (size_t)trials, sizeof(double), cmp_double);
        qsort(tm, (size_t)trials, sizeof(double), cmp_double);
        printf("%s, 300 pts, 30%% outliers, 0.5 px: median %.3f ms (p90 %.3f), mean RANSAC iters %.1f (%d at "
               "max_iters) | median rot %.4f deg, t %.4f deg, success %d/%d (%.2f%%)\n",
               mode_name[mode], tm[trials / 2] * 1e3, tm[trials * 9 / 10] * 1e3, (double)iters / trials,
               capped, re[trials / 2], te[trials / 2], success, trials, 100.0 * success / trials);
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
