/* SPDX-License-Identifier: Apache-2.0 */
/* PnP benchmark (not a test): fixed work for callgrind instruction counts.
 *   bench_pnp p3p      1000 tvo_p3p calls on one noise-free triple
 *   bench_pnp refine   20 x tvo_pnp_refine, 200 points, 0.5 px noise (f = 450), no outliers, default
 *                      configuration, the start 1 degree and 5 cm off the true pose
 *   bench_pnp ransac   20 x tvo_pnp_ransac, 200 points, 0.5 px noise, 30 % outliers, default
 *                      configuration
 * Count only the call of interest, then divide by the number of calls (1000 / 20 / 20):
 *   valgrind --tool=callgrind --toggle-collect=tvo_pnp_ransac bench_pnp ransac
 * It also prints the mean inlier count and pose errors, as a check that the work was the real one. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "tinyvo/pnp.h"
#include "tinyvo/se3.h"

#define MAXN 400
#include "tvo_pnp_scene.h"

static unsigned char g_scratch[8 * MAXN + 64];
static pscene g_sc;

static tvo_pose perturbed(const tvo_pose *T, double ang, double dt)
{
    double w[3] = {ang * 0.6, -ang * 0.8, 0.0};
    tvo_pose D;
    tvo_rotvec_to_rot(w, D.R);
    D.t[0] = dt * 0.6;
    D.t[1] = 0.0;
    D.t[2] = -dt * 0.8;
    return tvo_pose_compose(&D, T);
}

int main(int argc, char **argv)
{
    const char *mode = argc > 1 ? argv[1] : "";
    double rsum = 0.0, csum = 0.0;
    long isum = 0;
    int calls = 0, fails = 0;
    if (strcmp(mode, "p3p") == 0) {
        make_pscene(&g_sc, 1, 3, 0.0, 0.0);
        double X[3][3], x[3][2];
        for (int i = 0; i < 3; ++i) {
            memcpy(X[i], g_sc.X[i], sizeof X[i]);
            x[i][0] = g_sc.x[i].x;
            x[i][1] = g_sc.x[i].y;
        }
        tvo_pose T[4];
        for (int k = 0; k < 1000; ++k)
            isum += tvo_p3p((const double(*)[3])X, (const double(*)[2])x, T);
        printf("p3p: 1000 calls, %ld solutions in all\n", isum);
        return 0;
    }
    if (strcmp(mode, "refine") != 0 && strcmp(mode, "ransac") != 0) {
        fprintf(stderr, "usage: bench_pnp p3p|refine|ransac\n");
        return 2;
    }
    int ransac = strcmp(mode, "ransac") == 0;
    for (int k = 0; k < 20; ++k) {
        make_pscene(&g_sc, 7000 + (uint64_t)k, 200, 0.5, ransac ? 0.3 : 0.0);
        tvo_pose T = ransac ? tvo_pose_identity() : perturbed(&g_sc.T, 1.0 * 3.14159265358979 / 180.0, 0.05);
        int32_t ni = 0;
        tvo_status st;
        if (ransac)
            st = tvo_pnp_ransac(NULL, (const double(*)[3])g_sc.X, g_sc.x, g_sc.n, &T, NULL, &ni, g_scratch,
                                sizeof g_scratch);
        else
            st = tvo_pnp_refine(NULL, (const double(*)[3])g_sc.X, g_sc.x, NULL, g_sc.n, &T, NULL, &ni, NULL);
        ++calls;
        if (st != TVO_OK) {
            ++fails;
            continue;
        }
        tvo_pose Ti = tvo_pose_inverse(&T), Tg = tvo_pose_inverse(&g_sc.T);
        double dc = sqrt((Ti.t[0] - Tg.t[0]) * (Ti.t[0] - Tg.t[0]) +
                         (Ti.t[1] - Tg.t[1]) * (Ti.t[1] - Tg.t[1]) +
                         (Ti.t[2] - Tg.t[2]) * (Ti.t[2] - Tg.t[2]));
        rsum += tvo_rot_distance(T.R, g_sc.T.R) * 180.0 / 3.14159265358979;
        csum += dc;
        isum += ni;
    }
    int ok = calls - fails;
    printf("%s: %d calls, %d failed; mean inliers %.1f, mean rotation error %.4f deg, mean centre error %.4f "
           "m\n",
           mode, calls, fails, ok > 0 ? (double)isum / ok : 0.0, ok > 0 ? rsum / ok : 0.0,
           ok > 0 ? csum / ok : 0.0);
    return fails == 0 ? 0 : 1;
}
