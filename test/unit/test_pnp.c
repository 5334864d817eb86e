/* SPDX-License-Identifier: Apache-2.0 */
/* PnP: P3P solver, RANSAC, refinement, bad input, determinism and stack use.
 * Synthetic scenes from tvo_pnp_scene.h (f = 450 px, points 2..12 m deep, random camera pose). */
#define _POSIX_C_SOURCE 200809L /* pthread_attr_setstack */
#include "tvo_test.h"
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include "tinyvo/linalg.h"
#include "tinyvo/pnp.h"
#include "tinyvo/se3.h"

#include "tvo_pnp_scene.h"

static double rot_err(const tvo_pose *A, const tvo_pose *B)
{
    return tvo_rot_distance(A->R, B->R);
}

static double t_err(const tvo_pose *A, const tvo_pose *B)
{
    double d0 = A->t[0] - B->t[0], d1 = A->t[1] - B->t[1], d2 = A->t[2] - B->t[2];
    return sqrt(d0 * d0 + d1 * d1 + d2 * d2);
}

/* camera-centre distance (metres) */
static double c_err(const tvo_pose *A, const tvo_pose *B)
{
    tvo_pose Ai = tvo_pose_inverse(A), Bi = tvo_pose_inverse(B);
    return t_err(&Ai, &Bi);
}

static int pose_equal(const tvo_pose *A, const tvo_pose *B)
{
    return memcmp(A, B, sizeof *A) == 0;
}

static double huber_cost(const tvo_pose *T, const pscene *sc, double k)
{
    double c = 0.0;
    for (int i = 0; i < sc->n; ++i) {
        double Xc[3];
        tvo_pose_transform_point(T, sc->X[i], Xc);
        if (!(Xc[2] > 1e-6)) {
            c += k * (1.0 - 0.5 * k);
            continue;
        }
        double du = Xc[0] / Xc[2] - sc->x[i].x, dv = Xc[1] / Xc[2] - sc->x[i].y, e = sqrt(du * du + dv * dv);
        c += e <= k ? 0.5 * e * e : k * (e - 0.5 * k);
    }
    return c;
}

static tvo_pose perturb(const tvo_pose *T, uint64_t seed, double ang, double dt)
{
    uint64_t s = seed * 0x2545F4914F6CDD1DULL + 99;
    double ax[3] = {nrand(&s), nrand(&s), nrand(&s)}, tv[3] = {nrand(&s), nrand(&s), nrand(&s)};
    double na = sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
    double nt = sqrt(tv[0] * tv[0] + tv[1] * tv[1] + tv[2] * tv[2]);
    double w[3] = {ax[0] / na * ang, ax[1] / na * ang, ax[2] / na * ang};
    tvo_pose D;
    tvo_rotvec_to_rot(w, D.R);
    for (int k = 0; k < 3; ++k)
        D.t[k] = tv[k] / nt * dt;
    return tvo_pose_compose(&D, T);
}

static unsigned char g_scratch[8 * MAXN + 64];

/* ---- P3P ---------------------------------------------------------------------------------------- */

static void test_p3p_true_pose_among_solutions(void **state)
{
    (void)state;
    int hits = 0, total = 0, maxsol = 0;
    for (int trial = 0; trial < 500; ++trial) {
        pscene sc;
        make_pscene(&sc, 5000 + (uint64_t)trial, 3, 0.0, 0.0);
        double X[3][3], x[3][2];
        for (int i = 0; i < 3; ++i) {
            memcpy(X[i], sc.X[i], sizeof X[i]);
            x[i][0] = sc.x[i].x;
            x[i][1] = sc.x[i].y;
        }
        tvo_pose T[4];
        int ns = tvo_p3p((const double(*)[3])X, (const double(*)[2])x, T);
        assert_true(ns >= 0 && ns <= 4);
        if (ns > maxsol)
            maxsol = ns;
        double best = 1e9;
        for (int m = 0; m < ns; ++m) {
            assert_true(tvo_pose_is_finite(&T[m]));
            assert_true(tvo_rot_orthogonality_error(T[m].R) < 1e-12);
            /* every solution puts the three points in front and reprojects them */
            for (int i = 0; i < 3; ++i) {
                double Xc[3];
                tvo_pose_transform_point(&T[m], X[i], Xc);
                assert_true(Xc[2] > 0.0);
                assert_true(fabs(Xc[0] / Xc[2] - x[i][0]) < 1e-7 && fabs(Xc[1] / Xc[2] - x[i][1]) < 1e-7);
            }
            double e = rot_err(&T[m], &sc.T) + t_err(&T[m], &sc.T);
            if (e < best)
                best = e;
        }
        ++total;
        if (best < 1e-9)
            ++hits;
    }
    print_message("p3p: true pose (error < 1e-9) among the solutions in %d of %d triples, up to %d "
                  "solutions\n",
                  hits, total, maxsol);
    /* random triples include a few nearly degenerate ones (rays almost coplanar with the triangle) */
    assert_true(hits >= total - 5);
    assert_true(maxsol >= 2);
}

static void test_p3p_degenerate(void **state)
{
    (void)state;
    tvo_pose T[4];
    const double x[3][2] = {{0.1, 0.0}, {0.0, 0.1}, {-0.1, -0.05}};
    const double collinear[3][3] = {{0, 0, 5}, {1, 1, 6}, {2, 2, 7}};
    const double coincident[3][3] = {{1, 2, 5}, {1, 2, 5}, {1, 2, 5}};
    const double two_same[3][3] = {{1, 2, 5}, {1, 2, 5}, {0, 0, 6}};
    const double good[3][3] = {{0.5, 0, 5}, {0, 0.5, 5}, {-0.5, -0.25, 5}};
    assert_int_equal(tvo_p3p(collinear, x, T), 0);
    assert_int_equal(tvo_p3p(coincident, x, T), 0);
    assert_int_equal(tvo_p3p(two_same, x, T), 0);
    double nanX[3][3];
    memcpy(nanX, good, sizeof nanX);
    nanX[1][2] = NAN;
    assert_int_equal(tvo_p3p((const double(*)[3])nanX, x, T), 0);
    double xs[3][2] = {{0.1, 0.0}, {0.1, 0.0}, {-0.1, -0.05}}; /* two identical rays */
    assert_int_equal(tvo_p3p(good, (const double(*)[2])xs, T), 0);
    double xi[3][2] = {{0.1, 0.0}, {INFINITY, 0.1}, {-0.1, -0.05}};
    assert_int_equal(tvo_p3p(good, (const double(*)[2])xi, T), 0);
    assert_int_equal(tvo_p3p(NULL, x, T), 0);
    assert_int_equal(tvo_p3p(good, NULL, T), 0);
    assert_int_equal(tvo_p3p(good, x, NULL), 0);
    /* a valid triple: the points at z = 5 seen at exactly these rays (identity pose) */
    double xg[3][2];
    for (int i = 0; i < 3; ++i) {
        xg[i][0] = good[i][0] / good[i][2];
        xg[i][1] = good[i][1] / good[i][2];
    }
    int ns = tvo_p3p(good, (const double(*)[2])xg, T);
    assert_true(ns >= 1);
    tvo_pose I = tvo_pose_identity();
    int found = 0;
    for (int m = 0; m < ns; ++m)
        found |= rot_err(&T[m], &I) < 1e-9 && t_err(&T[m], &I) < 1e-9;
    assert_true(found);
}

/* ---- RANSAC ------------------------------------------------------------------------------------- */

static void test_ransac_noise_free(void **state)
{
    (void)state;
    for (uint64_t seed = 1; seed <= 12; ++seed) {
        pscene sc;
        make_pscene(&sc, seed, 60 + (int)seed * 10, 0.0, 0.0);
        tvo_pose T = tvo_pose_identity();
        uint8_t inl[MAXN];
        int32_t ni = -1;
        tvo_status st = tvo_pnp_ransac(NULL, (const double(*)[3])sc.X, sc.x, sc.n, &T, inl, &ni, g_scratch,
                                       sizeof g_scratch);
        assert_int_equal(st, TVO_OK);
        assert_int_equal(ni, sc.n);
        assert_true(rot_err(&T, &sc.T) < 1e-9);
        assert_true(t_err(&T, &sc.T) < 1e-9);
        for (int i = 0; i < sc.n; ++i)
            assert_int_equal(inl[i], 1);
    }
}

/* 0.5 px noise at f = 450: rotation within 0.15 deg and camera centre within 5 cm (points 2..12 m) */
static void test_ransac_noisy(void **state)
{
    (void)state;
    double worst_r = 0.0, worst_c = 0.0;
    for (uint64_t seed = 100; seed < 120; ++seed) {
        pscene sc;
        make_pscene(&sc, seed, 200, 0.5, 0.0);
        tvo_pose T = tvo_pose_identity();
        int32_t ni = 0;
        double rms = 0.0;
        assert_int_equal(tvo_pnp_ransac(NULL, (const double(*)[3])sc.X, sc.x, sc.n, &T, NULL, &ni, g_scratch,
                                        sizeof g_scratch),
                         TVO_OK);
        double er = rot_err(&T, &sc.T) * DEG, ec = c_err(&T, &sc.T);
        worst_r = er > worst_r ? er : worst_r;
        worst_c = ec > worst_c ? ec : worst_c;
        assert_true(ni >= 190); /* 1.5 px threshold at 0.5 px noise: ~99 % of the points */
        /* refine on everything from the result: the rms is about the noise (0.5 px * sqrt(2)) */
        assert_int_equal(tvo_pnp_refine(NULL, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &T, NULL, &ni,
                                        &rms),
                         TVO_OK);
        assert_true(rms * F_PX > 0.4 && rms * F_PX < 0.9);
    }
    print_message("ransac 0.5 px: worst rotation error %.4f deg, worst centre error %.4f m\n", worst_r,
                  worst_c);
    assert_true(worst_r < 0.15);
    assert_true(worst_c < 0.05);
}

static void test_ransac_outliers(void **state)
{
    (void)state;
    for (uint64_t seed = 200; seed < 215; ++seed) {
        pscene sc;
        make_pscene(&sc, seed, 200, 0.5, 0.4);
        assert_true(sc.n_out > 60);
        tvo_pose T = tvo_pose_identity();
        uint8_t inl[MAXN];
        int32_t ni = 0;
        assert_int_equal(tvo_pnp_ransac(NULL, (const double(*)[3])sc.X, sc.x, sc.n, &T, inl, &ni, g_scratch,
                                        sizeof g_scratch),
                         TVO_OK);
        assert_true(rot_err(&T, &sc.T) * DEG < 0.2);
        assert_true(c_err(&T, &sc.T) < 0.08);
        int tp = 0, fp = 0, cnt = 0;
        for (int i = 0; i < sc.n; ++i) {
            cnt += inl[i];
            tp += inl[i] && !sc.outlier[i];
            fp += inl[i] && sc.outlier[i];
        }
        assert_int_equal(cnt, ni);
        assert_true(tp >= (sc.n - sc.n_out) * 95 / 100);
        assert_true(fp <= 3); /* random image points that happen to fall within 1.5 px */
    }
}

static void test_ransac_nan_points_skipped(void **state)
{
    (void)state;
    pscene sc;
    make_pscene(&sc, 300, 150, 0.0, 0.0);
    for (int i = 0; i < sc.n; i += 5) {
        if ((i / 5) % 3 == 0)
            sc.X[i][1] = NAN;
        else if ((i / 5) % 3 == 1)
            sc.x[i].x = INFINITY;
        else
            sc.x[i].y = NAN;
    }
    tvo_pose T = tvo_pose_identity();
    uint8_t inl[MAXN];
    int32_t ni = 0;
    assert_int_equal(tvo_pnp_ransac(NULL, (const double(*)[3])sc.X, sc.x, sc.n, &T, inl, &ni, g_scratch,
                                    sizeof g_scratch),
                     TVO_OK);
    assert_int_equal(ni, sc.n - sc.n / 5);
    for (int i = 0; i < sc.n; ++i)
        assert_int_equal(inl[i], i % 5 != 0);
    assert_true(rot_err(&T, &sc.T) < 1e-9 && t_err(&T, &sc.T) < 1e-9);
    /* refine skips them too */
    tvo_pose T2 = perturb(&sc.T, 1, 0.02, 0.05);
    double rms = 1.0;
    assert_int_equal(tvo_pnp_refine(NULL, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &T2, inl, &ni, &rms),
                     TVO_OK);
    assert_int_equal(ni, sc.n - sc.n / 5);
    assert_true(rot_err(&T2, &sc.T) < 1e-9 && t_err(&T2, &sc.T) < 1e-9 && rms < 1e-9);
}

static void test_ransac_deterministic(void **state)
{
    (void)state;
    pscene sc;
    make_pscene(&sc, 400, 200, 0.5, 0.3);
    tvo_pose A = tvo_pose_identity(), B = tvo_pose_identity(), C = tvo_pose_identity();
    int32_t na = 0, nb = 0, nc = 0;
    tvo_pnp_config cfg;
    tvo_pnp_config_default(&cfg);
    assert_int_equal(tvo_pnp_ransac(&cfg, (const double(*)[3])sc.X, sc.x, sc.n, &A, NULL, &na, g_scratch,
                                    sizeof g_scratch),
                     TVO_OK);
    assert_int_equal(tvo_pnp_ransac(&cfg, (const double(*)[3])sc.X, sc.x, sc.n, &B, NULL, &nb, g_scratch,
                                    sizeof g_scratch),
                     TVO_OK);
    assert_true(pose_equal(&A, &B) && na == nb);
    cfg.seed = 12345;
    assert_int_equal(tvo_pnp_ransac(&cfg, (const double(*)[3])sc.X, sc.x, sc.n, &C, NULL, &nc, g_scratch,
                                    sizeof g_scratch),
                     TVO_OK);
    assert_true(rot_err(&C, &sc.T) * DEG < 0.2 && c_err(&C, &sc.T) < 0.08);
    /* scratch at any alignment */
    tvo_pose D = tvo_pose_identity();
    int32_t nd = 0;
    assert_int_equal(tvo_pnp_ransac(NULL, (const double(*)[3])sc.X, sc.x, sc.n, &D, NULL, &nd, g_scratch + 3,
                                    tvo_pnp_scratch_size(sc.n)),
                     TVO_OK);
    assert_true(pose_equal(&A, &D) && na == nd);
}

/* the adaptive iteration count stops well below the cap on an easy scene, and the cap bounds the work */
static void test_ransac_bounded(void **state)
{
    (void)state;
    pscene sc;
    make_pscene(&sc, 500, 200, 0.5, 0.3);
    tvo_pnp_config cfg;
    tvo_pnp_config_default(&cfg);
    cfg.max_iterations = 1;
    tvo_pose T = tvo_pose_identity();
    int32_t ni = 0;
    tvo_status st = tvo_pnp_ransac(&cfg, (const double(*)[3])sc.X, sc.x, sc.n, &T, NULL, &ni, g_scratch,
                                   sizeof g_scratch);
    /* one sample: either a good hypothesis or too few inliers, never anything else */
    assert_true(st == TVO_OK || st == TVO_ERR_TOO_FEW);
    assert_true(tvo_pose_is_finite(&T));
    if (st == TVO_OK)
        assert_true(ni >= cfg.min_inliers);
}

/* all points on one plane (a floor or a wall: common in VO), and a far scene (20..80 m, a road) */
static void test_ransac_planar_and_far(void **state)
{
    (void)state;
    for (uint64_t seed = 1400; seed < 1410; ++seed) {
        pscene sc;
        make_pscene(&sc, seed, 150, 0.5, 0.2);
        tvo_pose Twc = tvo_pose_inverse(&sc.T);
        uint64_t s = seed;
        for (int i = 0; i < sc.n; ++i) {
            /* re-place point i on the plane z_c = 4 + 0.5 x_c (tilted), or 20..80 m deep for odd seeds */
            double u = (2.0 * urand(&s) - 1.0) * HALF_W, v = (2.0 * urand(&s) - 1.0) * HALF_H;
            double z = (seed & 1) ? 20.0 + 60.0 * urand(&s) : 4.0 / (1.0 - 0.5 * u);
            double Xc[3] = {u * z, v * z, z};
            tvo_pose_transform_point(&Twc, Xc, sc.X[i]);
            if (!sc.outlier[i]) {
                sc.x[i].x = u + 0.5 / F_PX * nrand(&s);
                sc.x[i].y = v + 0.5 / F_PX * nrand(&s);
            }
        }
        tvo_pose T = tvo_pose_identity();
        int32_t ni = 0;
        assert_int_equal(tvo_pnp_ransac(NULL, (const double(*)[3])sc.X, sc.x, sc.n, &T, NULL, &ni, g_scratch,
                                        sizeof g_scratch),
                         TVO_OK);
        assert_true(ni >= (sc.n - sc.n_out) * 9 / 10);
        /* (seen: planar up to 0.06 deg / 4 mm, far up to 0.03 deg / 2.3 cm) */
        assert_true(rot_err(&T, &sc.T) * DEG < 0.15);
        assert_true(c_err(&T, &sc.T) < ((seed & 1) ? 0.15 : 0.02));
    }
}

/* use_guess: a prediction near the truth is the first hypothesis, so one sample is enough even at 40 %
 * outliers; a non-finite guess is ignored (the same result as without one); the result is refined */
static void test_ransac_guess(void **state)
{
    (void)state;
    tvo_pnp_config cfg;
    tvo_pnp_config_default(&cfg);
    cfg.max_iterations = 1;
    cfg.use_guess = 1;
    int plain_ok = 0;
    for (uint64_t seed = 1300; seed < 1320; ++seed) {
        pscene sc;
        make_pscene(&sc, seed, 200, 0.5, 0.4);
        tvo_pose T = perturb(&sc.T, seed, 0.002, 0.01); /* ~0.1 deg, 1 cm: a good prediction */
        int32_t ni = 0;
        assert_int_equal(tvo_pnp_ransac(&cfg, (const double(*)[3])sc.X, sc.x, sc.n, &T, NULL, &ni, g_scratch,
                                        sizeof g_scratch),
                         TVO_OK);
        assert_true(rot_err(&T, &sc.T) * DEG < 0.2 && c_err(&T, &sc.T) < 0.08);
        assert_true(ni >= (sc.n - sc.n_out) * 95 / 100);
        /* the same single sample without the guess */
        tvo_pnp_config c0 = cfg;
        c0.use_guess = 0;
        tvo_pose P = tvo_pose_identity();
        int32_t np = 0;
        plain_ok += tvo_pnp_ransac(&c0, (const double(*)[3])sc.X, sc.x, sc.n, &P, NULL, &np, g_scratch,
                                   sizeof g_scratch) == TVO_OK &&
                rot_err(&P, &sc.T) * DEG < 0.2;
        /* a NaN guess: as without a guess */
        tvo_pose G = tvo_pose_identity(), Q = T;
        Q.R[0] = NAN;
        int32_t nq = 0;
        tvo_status sq = tvo_pnp_ransac(&cfg, (const double(*)[3])sc.X, sc.x, sc.n, &Q, NULL, &nq, g_scratch,
                                       sizeof g_scratch);
        tvo_status sg = tvo_pnp_ransac(&c0, (const double(*)[3])sc.X, sc.x, sc.n, &G, NULL, &np, g_scratch,
                                       sizeof g_scratch);
        assert_int_equal(sq, sg);
        assert_true(pose_equal(&Q, &G) && nq == (sq == TVO_OK ? np : 0));
    }
    print_message("ransac with max_iterations = 1: 20 of 20 with a guess, %d of 20 without\n", plain_ok);
    assert_true(plain_ok < 20); /* at 40 % outliers one random sample is often not enough */
}

/* ---- bad input ---------------------------------------------------------------------------------- */

static void expect_unchanged(const tvo_pose *before, const tvo_pose *after, int32_t ni)
{
    assert_true(pose_equal(before, after));
    assert_int_equal(ni, 0);
}

static void test_ransac_bad_input(void **state)
{
    (void)state;
    pscene sc;
    make_pscene(&sc, 600, 100, 0.0, 0.0);
    const double(*X)[3] = (const double(*)[3])sc.X;
    tvo_pose T0 = perturb(&sc.T, 3, 0.3, 1.0), T = T0;
    uint8_t inl[MAXN];
    int32_t ni = 7;
    tvo_pnp_config cfg;

    assert_int_equal(tvo_pnp_ransac(NULL, NULL, sc.x, sc.n, &T, inl, &ni, g_scratch, sizeof g_scratch),
                     TVO_ERR_NULL);
    expect_unchanged(&T0, &T, ni);
    assert_int_equal(tvo_pnp_ransac(NULL, X, NULL, sc.n, &T, inl, &ni, g_scratch, sizeof g_scratch),
                     TVO_ERR_NULL);
    assert_int_equal(tvo_pnp_ransac(NULL, X, sc.x, sc.n, NULL, inl, &ni, g_scratch, sizeof g_scratch),
                     TVO_ERR_NULL);
    assert_int_equal(tvo_pnp_ransac(NULL, X, sc.x, sc.n, &T, inl, NULL, g_scratch, sizeof g_scratch),
                     TVO_ERR_NULL);
    assert_int_equal(tvo_pnp_ransac(NULL, X, sc.x, sc.n, &T, inl, &ni, NULL, sizeof g_scratch), TVO_ERR_NULL);
    expect_unchanged(&T0, &T, ni);

    /* config values: zero, NaN, out of range */
    for (int c = 0; c < 14; ++c) {
        tvo_pnp_config_default(&cfg);
        switch (c) {
        case 0:
            cfg.threshold = 0.0;
            break;
        case 1:
            cfg.threshold = NAN;
            break;
        case 2:
            cfg.confidence = 0.0;
            break;
        case 3:
            cfg.confidence = 1.0;
            break;
        case 4:
            cfg.confidence = NAN;
            break;
        case 5:
            cfg.max_iterations = 0;
            break;
        case 6:
            cfg.refine_iterations = 0;
            break;
        case 7:
            cfg.huber = 0.0;
            break;
        case 8:
            cfg.huber = NAN;
            break;
        case 9:
            cfg.min_inliers = 2;
            break;
        case 10:
            cfg.threshold = INFINITY;
            break;
        case 11:
            cfg.use_guess = 2;
            break;
        case 12:
            cfg.use_guess = -1;
            break;
        default:
            cfg.huber = -1.0;
            break;
        }
        ni = 5;
        memset(inl, 1, sizeof inl);
        assert_int_equal(tvo_pnp_ransac(&cfg, X, sc.x, sc.n, &T, inl, &ni, g_scratch, sizeof g_scratch),
                         TVO_ERR_ARG);
        expect_unchanged(&T0, &T, ni);
        assert_int_equal(inl[0], 0);
        ni = 5;
        assert_int_equal(tvo_pnp_refine(&cfg, X, sc.x, NULL, sc.n, &T, inl, &ni, NULL), TVO_ERR_ARG);
        expect_unchanged(&T0, &T, ni);
    }
    assert_int_equal(tvo_pnp_ransac(NULL, X, sc.x, -1, &T, inl, &ni, g_scratch, sizeof g_scratch),
                     TVO_ERR_ARG);
    expect_unchanged(&T0, &T, ni);
    /* n = 3, n = 0 */
    assert_int_equal(tvo_pnp_ransac(NULL, X, sc.x, 3, &T, inl, &ni, g_scratch, sizeof g_scratch),
                     TVO_ERR_TOO_FEW);
    expect_unchanged(&T0, &T, ni);
    assert_int_equal(tvo_pnp_ransac(NULL, X, sc.x, 0, &T, inl, &ni, g_scratch, sizeof g_scratch),
                     TVO_ERR_TOO_FEW);
    /* scratch one byte short */
    assert_int_equal(tvo_pnp_ransac(NULL, X, sc.x, sc.n, &T, inl, &ni, g_scratch,
                                    tvo_pnp_scratch_size(sc.n) - 1),
                     TVO_ERR_NO_MEMORY);
    expect_unchanged(&T0, &T, ni);
    assert_true(tvo_pnp_scratch_size(-1) == 0);
    assert_true(tvo_pnp_scratch_size(100) > 0);
    /* fewer than 4 usable points */
    pscene bad = sc;
    for (int i = 3; i < bad.n; ++i)
        bad.x[i].x = NAN;
    assert_int_equal(tvo_pnp_ransac(NULL, (const double(*)[3])bad.X, bad.x, bad.n, &T, inl, &ni, g_scratch,
                                    sizeof g_scratch),
                     TVO_ERR_TOO_FEW);
    expect_unchanged(&T0, &T, ni);
    /* more inliers required than there are points */
    tvo_pnp_config_default(&cfg);
    cfg.min_inliers = sc.n + 1;
    assert_int_equal(tvo_pnp_ransac(&cfg, X, sc.x, sc.n, &T, inl, &ni, g_scratch, sizeof g_scratch),
                     TVO_ERR_TOO_FEW);
    expect_unchanged(&T0, &T, ni);
    /* a non-finite pose given to RANSAC (output only) comes back as the identity on error */
    tvo_pose Tn = T0;
    Tn.t[1] = NAN;
    assert_int_equal(tvo_pnp_ransac(NULL, X, sc.x, 3, &Tn, inl, &ni, g_scratch, sizeof g_scratch),
                     TVO_ERR_TOO_FEW);
    tvo_pose I = tvo_pose_identity();
    assert_true(pose_equal(&Tn, &I));
}

static void test_ransac_degenerate_scenes(void **state)
{
    (void)state;
    pscene sc;
    make_pscene(&sc, 700, 50, 0.0, 0.0);
    tvo_pose T0 = perturb(&sc.T, 4, 0.1, 0.2), T;
    uint8_t inl[MAXN];
    int32_t ni = 3;
    /* all points on one line (image points of the line) */
    for (int i = 0; i < sc.n; ++i) {
        double a = (double)i / sc.n;
        double Xc[3] = {-1.0 + 2.0 * a, 0.5 - a, 4.0 + 3.0 * a};
        tvo_pose Twc = tvo_pose_inverse(&sc.T);
        tvo_pose_transform_point(&Twc, Xc, sc.X[i]);
        sc.x[i].x = Xc[0] / Xc[2];
        sc.x[i].y = Xc[1] / Xc[2];
    }
    T = T0;
    assert_int_equal(tvo_pnp_ransac(NULL, (const double(*)[3])sc.X, sc.x, sc.n, &T, inl, &ni, g_scratch,
                                    sizeof g_scratch),
                     TVO_ERR_DEGENERATE);
    expect_unchanged(&T0, &T, ni);
    /* all points coincident */
    for (int i = 1; i < sc.n; ++i) {
        memcpy(sc.X[i], sc.X[0], sizeof sc.X[0]);
        sc.x[i] = sc.x[0];
    }
    T = T0;
    assert_int_equal(tvo_pnp_ransac(NULL, (const double(*)[3])sc.X, sc.x, sc.n, &T, inl, &ni, g_scratch,
                                    sizeof g_scratch),
                     TVO_ERR_DEGENERATE);
    expect_unchanged(&T0, &T, ni);
    /* points behind the camera: no rigid pose explains them with positive depths */
    pscene bh;
    make_pscene(&bh, 701, 60, 0.0, 0.0);
    tvo_pose Twc = tvo_pose_inverse(&bh.T);
    for (int i = 0; i < bh.n; ++i) {
        double Xc[3];
        tvo_pose_transform_point(&bh.T, bh.X[i], Xc);
        Xc[0] = -Xc[0];
        Xc[1] = -Xc[1];
        Xc[2] = -Xc[2]; /* same image point, behind */
        tvo_pose_transform_point(&Twc, Xc, bh.X[i]);
    }
    T = T0;
    assert_int_equal(tvo_pnp_ransac(NULL, (const double(*)[3])bh.X, bh.x, bh.n, &T, inl, &ni, g_scratch,
                                    sizeof g_scratch),
                     TVO_ERR_TOO_FEW);
    expect_unchanged(&T0, &T, ni);
    /* refine from the true pose: every point behind the camera */
    T = bh.T;
    assert_int_equal(tvo_pnp_refine(NULL, (const double(*)[3])bh.X, bh.x, NULL, bh.n, &T, inl, &ni, NULL),
                     TVO_ERR_TOO_FEW);
    expect_unchanged(&bh.T, &T, ni);
}

/* ---- refinement --------------------------------------------------------------------------------- */

static void test_refine_converges(void **state)
{
    (void)state;
    for (uint64_t seed = 800; seed < 810; ++seed) {
        pscene sc;
        make_pscene(&sc, seed, 200, 0.0, 0.0);
        tvo_pose T = perturb(&sc.T, seed, 0.05 + 0.01 * (double)(seed - 800), 0.3);
        uint8_t inl[MAXN];
        int32_t ni = 0;
        double rms = 1.0;
        tvo_pnp_config cfg;
        tvo_pnp_config_default(&cfg);
        cfg.refine_iterations = 20;
        cfg.huber = 0.05; /* the start is tens of pixels off: a wider kernel converges faster */
        assert_int_equal(tvo_pnp_refine(&cfg, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &T, inl, &ni, &rms),
                         TVO_OK);
        assert_true(rot_err(&T, &sc.T) < 1e-9 && t_err(&T, &sc.T) < 1e-9);
        assert_int_equal(ni, sc.n);
        assert_true(rms < 1e-9);
    }
    /* with outliers and the default kernel, the `use` mask selects the true inliers */
    pscene sc;
    make_pscene(&sc, 820, 200, 0.5, 0.3);
    uint8_t use[MAXN], inl[MAXN];
    for (int i = 0; i < sc.n; ++i)
        use[i] = (uint8_t)!sc.outlier[i];
    tvo_pose T = perturb(&sc.T, 5, 0.01, 0.05);
    int32_t ni = 0;
    double rms = 0.0;
    assert_int_equal(tvo_pnp_refine(NULL, (const double(*)[3])sc.X, sc.x, use, sc.n, &T, inl, &ni, &rms),
                     TVO_OK);
    assert_true(rot_err(&T, &sc.T) * DEG < 0.2 && c_err(&T, &sc.T) < 0.05);
    for (int i = 0; i < sc.n; ++i)
        if (!use[i])
            assert_int_equal(inl[i], 0);
    assert_true(ni >= (sc.n - sc.n_out) * 95 / 100);
}

/* The rotation prior (cfg.rot_prior, rot_prior_weight): with weight 0 it changes nothing whatever it
 * holds; the true rotation as a strong prior lowers the rotation error of a noisy 12-point pose on
 * average; a prior 10 deg off with the weight of one point moves a 200-point pose by a small fraction of
 * that; bad prior values are refused. */
static void test_refine_rotation_prior(void **state)
{
    double sum_plain = 0.0, sum_prior = 0.0;
    (void)state;
    for (uint64_t seed = 900; seed < 930; ++seed) {
        pscene sc;
        tvo_pnp_config c0, cw;
        tvo_pose T0, Tw, Tz;
        int32_t n0 = 0, nw = 0, nz = 0;
        make_pscene(&sc, seed, 12, 1.0, 0.0);
        tvo_pnp_config_default(&c0);
        c0.min_inliers = 6;
        c0.threshold = c0.huber = 4.0 / 450.0;
        T0 = Tw = Tz = perturb(&sc.T, seed, 0.01, 0.05);
        assert_int_equal(tvo_pnp_refine(&c0, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &T0, NULL, &n0,
                                        NULL),
                         TVO_OK);
        /* weight 0: the prior's content is ignored (bit for bit) */
        cw = c0;
        for (int k = 0; k < 9; ++k)
            cw.rot_prior[k] = 0.5 * (double)k;
        assert_int_equal(tvo_pnp_refine(&cw, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &Tz, NULL, &nz,
                                        NULL),
                         TVO_OK);
        assert_memory_equal(&Tz, &T0, sizeof(T0));
        /* the true rotation, weighted as much as 10,000 points */
        cw = c0;
        memcpy(cw.rot_prior, sc.T.R, sizeof(cw.rot_prior));
        cw.rot_prior_weight = 1e4;
        assert_int_equal(tvo_pnp_refine(&cw, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &Tw, NULL, &nw,
                                        NULL),
                         TVO_OK);
        assert_true(rot_err(&Tw, &sc.T) * DEG < 0.01);
        sum_plain += rot_err(&T0, &sc.T);
        sum_prior += rot_err(&Tw, &sc.T);
    }
    assert_true(sum_prior < 0.2 * sum_plain);
    {
        /* a prior 10 degrees off, weight 1 (one point's worth), on 200 noise-free points */
        pscene sc;
        tvo_pnp_config c;
        tvo_pose T;
        int32_t ni = 0;
        const double w[3] = {0.0, 10.0 / DEG, 0.0};
        double Rd[9];
        make_pscene(&sc, 950, 200, 0.0, 0.0);
        tvo_pnp_config_default(&c);
        tvo_rotvec_to_rot(w, Rd);
        tvo_la_mat3_mul(Rd, sc.T.R, c.rot_prior);
        c.rot_prior_weight = 1.0;
        T = perturb(&sc.T, 3, 0.01, 0.05);
        assert_int_equal(tvo_pnp_refine(&c, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &T, NULL, &ni, NULL),
                         TVO_OK);
        /* one point's worth against 200 points: pulled, but by a small fraction of the offset (measured
           0.107 deg, twice 10/201 deg, as the rotation trades partly against the translation) */
        assert_true(rot_err(&T, &sc.T) * DEG > 0.01 && rot_err(&T, &sc.T) * DEG < 0.5);
    }
    {
        pscene sc;
        tvo_pnp_config c;
        tvo_pose T;
        int32_t ni = 0;
        make_pscene(&sc, 951, 50, 0.0, 0.0);
        T = sc.T;
        tvo_pnp_config_default(&c);
        c.rot_prior_weight = -1.0;
        assert_int_equal(tvo_pnp_refine(&c, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &T, NULL, &ni, NULL),
                         TVO_ERR_ARG);
        c.rot_prior_weight = NAN;
        assert_int_equal(tvo_pnp_refine(&c, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &T, NULL, &ni, NULL),
                         TVO_ERR_ARG);
        c.rot_prior_weight = 1.0;
        c.rot_prior[0] = 2.0; /* not a rotation */
        assert_int_equal(tvo_pnp_refine(&c, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &T, NULL, &ni, NULL),
                         TVO_ERR_ARG);
        c.rot_prior[0] = NAN;
        assert_int_equal(tvo_pnp_refine(&c, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &T, NULL, &ni, NULL),
                         TVO_ERR_ARG);
        assert_true(tvo_pose_is_finite(&T));
    }
}

/* the output's robust cost is never above the input's, from near and far starts and 1..3 iterations */
static void test_refine_never_worse(void **state)
{
    (void)state;
    tvo_pnp_config cfg;
    tvo_pnp_config_default(&cfg);
    cfg.min_inliers = 3;
    int improved = 0;
    for (uint64_t seed = 900; seed < 960; ++seed) {
        pscene sc;
        make_pscene(&sc, seed, 100, 0.5, 0.3);
        /* starts from close to far (up to ~1 rad, 3 m) */
        tvo_pose T0 = perturb(&sc.T, seed, 0.02 * (double)(seed - 900), 0.05 * (double)(seed - 900)), T = T0;
        int32_t ni = 0;
        cfg.refine_iterations = 1 + (int32_t)(seed % 3);
        tvo_status st = tvo_pnp_refine(&cfg, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &T, NULL, &ni, NULL);
        assert_true(st == TVO_OK || st == TVO_ERR_TOO_FEW);
        assert_true(tvo_pose_is_finite(&T));
        double c0 = huber_cost(&T0, &sc, cfg.huber), c1 = huber_cost(&T, &sc, cfg.huber);
        assert_true(c1 <= c0 * (1.0 + 1e-12));
        if (c1 < c0 * 0.999)
            ++improved;
    }
    print_message("refine: %d of 60 starts improved\n", improved);
    assert_true(improved >= 10);

    /* noise-free data and the exact pose: nothing to gain, the pose stays within rounding */
    pscene sc;
    make_pscene(&sc, 970, 100, 0.0, 0.0);
    tvo_pose T = sc.T;
    int32_t ni = 0;
    assert_int_equal(tvo_pnp_refine(NULL, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &T, NULL, &ni, NULL),
                     TVO_OK);
    assert_true(rot_err(&T, &sc.T) < 1e-14 && t_err(&T, &sc.T) < 1e-13);
}

/* A step that would raise the robust cost is undone. Built so that the Gauss-Newton step must be bad:
 * three points 5 cm in front of the start pose T0 = I, almost on its optical axis, are exact (the
 * start's only inliers, and a forward motion hardly moves their image); 30 points 4..6 m away are seen
 * from T1, 10 cm further forward. The linearised step moves the camera about 10 cm forward, which puts
 * the three near points behind it: their cost rises from 0 to rho(1) each, far more than the far points
 * gain. With refine_iterations = 1 that step is rejected: TVO_OK, the pose bit for bit as given, the
 * start's inliers. With more iterations the damping grows until a shorter step helps: the cost falls and
 * the near points stay in front. */
static void test_refine_restores(void **state)
{
    (void)state;
    pscene sc;
    uint64_t s = 4242;
    sc.n = 33;
    const double near[3][3] = {{5e-5, 0.0, 0.05}, {-4e-5, 3e-5, 0.05}, {0.0, -5e-5, 0.05}};
    for (int i = 0; i < 3; ++i) {
        memcpy(sc.X[i], near[i], sizeof sc.X[i]);
        sc.x[i].x = near[i][0] / near[i][2];
        sc.x[i].y = near[i][1] / near[i][2];
    }
    for (int i = 3; i < sc.n; ++i) {
        double z = 4.0 + 2.0 * urand(&s);
        sc.X[i][0] = (2.0 * urand(&s) - 1.0) * HALF_W * z;
        sc.X[i][1] = (2.0 * urand(&s) - 1.0) * HALF_H * z;
        sc.X[i][2] = z;
        sc.x[i].x = sc.X[i][0] / (z - 0.1); /* seen from 10 cm further forward */
        sc.x[i].y = sc.X[i][1] / (z - 0.1);
    }
    tvo_pnp_config cfg;
    tvo_pnp_config_default(&cfg);
    cfg.min_inliers = 3;
    cfg.refine_iterations = 1;
    const tvo_pose T0 = tvo_pose_identity();
    tvo_pose T = T0;
    uint8_t inl[MAXN];
    int32_t ni = 0;
    double rms = 1.0;
    assert_int_equal(tvo_pnp_refine(&cfg, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &T, inl, &ni, &rms),
                     TVO_OK);
    assert_true(pose_equal(&T, &T0));
    int expect = 0; /* the near points and the far ones near the image centre (within 1.5 px at T0) */
    for (int i = 0; i < sc.n; ++i) {
        double du = sc.X[i][0] / sc.X[i][2] - sc.x[i].x, dv = sc.X[i][1] / sc.X[i][2] - sc.x[i].y;
        expect += sqrt(du * du + dv * dv) < cfg.threshold;
    }
    assert_int_equal(ni, expect);
    assert_true(inl[0] && inl[1] && inl[2] && rms < 1.5 / F_PX);
    /* more iterations: a damped step that helps, never one that pushes the near points behind */
    cfg.refine_iterations = 10;
    assert_int_equal(tvo_pnp_refine(&cfg, (const double(*)[3])sc.X, sc.x, NULL, sc.n, &T, inl, &ni, &rms),
                     TVO_OK);
    assert_false(pose_equal(&T, &T0));
    assert_true(huber_cost(&T, &sc, cfg.huber) < huber_cost(&T0, &sc, cfg.huber));
    for (int i = 0; i < 3; ++i) {
        double Xc[3];
        tvo_pose_transform_point(&T, sc.X[i], Xc);
        assert_true(Xc[2] > 1e-6);
    }
}

static void test_refine_bad_input(void **state)
{
    (void)state;
    pscene sc;
    make_pscene(&sc, 1100, 30, 0.0, 0.0);
    const double(*X)[3] = (const double(*)[3])sc.X;
    tvo_pose T0 = perturb(&sc.T, 2, 0.01, 0.01), T = T0;
    uint8_t inl[MAXN];
    int32_t ni = 5;
    double rms = 3.0;
    assert_int_equal(tvo_pnp_refine(NULL, NULL, sc.x, NULL, sc.n, &T, inl, &ni, &rms), TVO_ERR_NULL);
    expect_unchanged(&T0, &T, ni);
    assert_true(rms == 0.0);
    assert_int_equal(tvo_pnp_refine(NULL, X, NULL, NULL, sc.n, &T, inl, &ni, &rms), TVO_ERR_NULL);
    assert_int_equal(tvo_pnp_refine(NULL, X, sc.x, NULL, sc.n, NULL, inl, &ni, &rms), TVO_ERR_NULL);
    assert_int_equal(tvo_pnp_refine(NULL, X, sc.x, NULL, sc.n, &T, inl, NULL, &rms), TVO_ERR_NULL);
    assert_int_equal(tvo_pnp_refine(NULL, X, sc.x, NULL, -2, &T, inl, &ni, &rms), TVO_ERR_ARG);
    expect_unchanged(&T0, &T, ni);
    /* n = 2, or 2 selected points */
    assert_int_equal(tvo_pnp_refine(NULL, X, sc.x, NULL, 2, &T, inl, &ni, &rms), TVO_ERR_TOO_FEW);
    expect_unchanged(&T0, &T, ni);
    uint8_t use[MAXN] = {0};
    use[4] = use[9] = 1;
    assert_int_equal(tvo_pnp_refine(NULL, X, sc.x, use, sc.n, &T, inl, &ni, &rms), TVO_ERR_TOO_FEW);
    expect_unchanged(&T0, &T, ni);
    /* NaN pose in: an error, and the identity comes out */
    tvo_pose Tn = T0;
    Tn.R[4] = NAN;
    assert_int_equal(tvo_pnp_refine(NULL, X, sc.x, NULL, sc.n, &Tn, inl, &ni, &rms), TVO_ERR_NOT_FINITE);
    tvo_pose I = tvo_pose_identity();
    assert_true(pose_equal(&Tn, &I));
    assert_int_equal(ni, 0);
    /* fewer inliers than min_inliers (default 12) at the output: TOO_FEW, pose as given */
    for (int i = 0; i < sc.n; ++i)
        use[i] = (uint8_t)(i < 8);
    assert_int_equal(tvo_pnp_refine(NULL, X, sc.x, use, sc.n, &T, inl, &ni, &rms), TVO_ERR_TOO_FEW);
    expect_unchanged(&T0, &T, ni);
    for (int i = 0; i < sc.n; ++i)
        assert_int_equal(inl[i], 0);
    /* exactly 3 points with min_inliers = 3 is enough */
    tvo_pnp_config cfg;
    tvo_pnp_config_default(&cfg);
    cfg.min_inliers = 3;
    cfg.refine_iterations = 30;
    assert_int_equal(tvo_pnp_refine(&cfg, X, sc.x, NULL, 3, &T, inl, &ni, &rms), TVO_OK);
    assert_int_equal(ni, 3);
}

/* ---- stack -------------------------------------------------------------------------------------- */

#define STK_SIZE (256 * 1024)
#if defined(__SANITIZE_ADDRESS__) || !defined(__OPTIMIZE__)
#define PNP_STACK_BOUND (64 * 1024)
#else
#define PNP_STACK_BOUND (4 * 1024)
#endif

typedef struct stk_job {
    pscene *sc;
    int ok;
} stk_job;

static void *stk_idle(void *arg)
{
    return arg;
}

static void *stk_work(void *arg)
{
    stk_job *j = (stk_job *)arg;
    tvo_pose T = tvo_pose_identity();
    int32_t ni = 0;
    double rms;
    uint8_t *inl = g_scratch + 8 * MAXN / 2; /* not on this stack */
    j->ok = tvo_pnp_ransac(NULL, (const double(*)[3])j->sc->X, j->sc->x, j->sc->n, &T, NULL, &ni, g_scratch,
                           tvo_pnp_scratch_size(j->sc->n)) == TVO_OK;
    j->ok &= tvo_pnp_refine(NULL, (const double(*)[3])j->sc->X, j->sc->x, NULL, j->sc->n, &T, inl, &ni,
                            &rms) == TVO_OK;
    return NULL;
}

static size_t stack_used(void *(*fn)(void *), void *arg)
{
    unsigned char *stk = NULL;
    if (posix_memalign((void **)&stk, 4096, STK_SIZE) != 0)
        return (size_t)-1;
    memset(stk, 0xA5, STK_SIZE);
    pthread_attr_t attr;
    pthread_t th;
    pthread_attr_init(&attr);
    pthread_attr_setstack(&attr, stk, STK_SIZE);
    size_t used = (size_t)-1;
    if (pthread_create(&th, &attr, fn, arg) == 0) {
        pthread_join(th, NULL);
        size_t lo = 0;
        while (lo < STK_SIZE && stk[lo] == 0xA5)
            ++lo;
        used = STK_SIZE - lo;
    }
    pthread_attr_destroy(&attr);
    free(stk);
    return used;
}

static void test_stack(void **state)
{
    (void)state;
    static pscene sc;
    make_pscene(&sc, 1200, 200, 0.5, 0.3);
    stk_job j = {&sc, 0};
    size_t base = stack_used(stk_idle, NULL), used = stack_used(stk_work, &j);
    assert_true(base != (size_t)-1 && used != (size_t)-1);
    assert_true(j.ok);
    print_message("pnp: stack %zu bytes above the thread baseline (bound %d)\n", used - base,
                  PNP_STACK_BOUND);
    assert_true(used - base < PNP_STACK_BOUND);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_p3p_true_pose_among_solutions),
            cmocka_unit_test(test_p3p_degenerate),
            cmocka_unit_test(test_ransac_noise_free),
            cmocka_unit_test(test_ransac_noisy),
            cmocka_unit_test(test_ransac_outliers),
            cmocka_unit_test(test_ransac_nan_points_skipped),
            cmocka_unit_test(test_ransac_deterministic),
            cmocka_unit_test(test_ransac_bounded),
            cmocka_unit_test(test_ransac_guess),
            cmocka_unit_test(test_ransac_planar_and_far),
            cmocka_unit_test(test_ransac_bad_input),
            cmocka_unit_test(test_ransac_degenerate_scenes),
            cmocka_unit_test(test_refine_converges),
            cmocka_unit_test(test_refine_never_worse),
            cmocka_unit_test(test_refine_restores),
            cmocka_unit_test(test_refine_rotation_prior),
            cmocka_unit_test(test_refine_bad_input),
            cmocka_unit_test(test_stack),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
