/* SPDX-License-Identifier: Apache-2.0 */
/* Camera models: validation, known values, distort/undistort round trips, bad input. */
#include <math.h>

#include "tvo_test.h"
#include "tinyvo/camera.h"

static tvo_camera euroc_cam0(void)
{
    tvo_camera c = tvo_camera_make_pinhole(752, 480, 458.654, 457.296, 367.215, 248.375);
    c.model = TVO_DIST_RADTAN;
    c.k[0] = -0.28340811;
    c.k[1] = 0.07395907;
    c.k[2] = 0.00019359;
    c.k[3] = 1.76187114e-05;
    return c;
}

static tvo_camera radtan5(void)
{
    tvo_camera c = tvo_camera_make_pinhole(1280, 720, 700.0, 702.0, 641.3, 359.2);
    c.model = TVO_DIST_RADTAN;
    c.k[0] = -0.30; /* monotonic up to r = 2.05 (r_d = 1.53); the image corners reach r_d = 1.05 */
    c.k[1] = 0.12;
    c.k[2] = -0.0008;
    c.k[3] = 0.0011;
    c.k[4] = -0.015;
    return c;
}

static tvo_camera equi(void)
{
    /* a wide-angle equidistant lens; the image corners are at theta ~ 73 degrees */
    tvo_camera c = tvo_camera_make_pinhole(752, 480, 350.0, 351.0, 376.5, 239.5);
    c.model = TVO_DIST_EQUIDISTANT;
    c.k[0] = -0.01;
    c.k[1] = 0.02;
    c.k[2] = -0.012;
    c.k[3] = 0.003;
    return c;
}

/* TUM-VI-like fisheye (512x512, f = 191): the image corners lie beyond 90 degrees (theta_d ~ 1.9), which a
 * z = 1 normalised point cannot represent: NO_CONVERGENCE there, fine inside the 90-degree circle. */
static void test_fisheye_beyond_90(void **state)
{
    tvo_camera c = tvo_camera_make_pinhole(512, 512, 190.98, 190.97, 254.93, 256.90);
    tvo_point2d xn;
    double u, v;
    (void)state;
    c.model = TVO_DIST_EQUIDISTANT;
    c.k[0] = 0.0034823894;
    c.k[1] = 0.0007150348;
    c.k[2] = -0.0020532361;
    c.k[3] = 0.0002029806;
    assert_int_equal(tvo_camera_undistort_point(&c, 0.0, 0.0, &xn), TVO_ERR_NO_CONVERGENCE);
    assert_int_equal(tvo_camera_undistort_point(&c, 511.0, 0.0, &xn), TVO_ERR_NO_CONVERGENCE);
    assert_int_equal(tvo_camera_undistort_point(&c, 254.93 + 250.0, 256.9, &xn), TVO_OK); /* ~75 deg */
    assert_true(xn.x > 3.0);
    assert_int_equal(tvo_camera_distort_point(&c, &xn, &u, &v), TVO_OK);
    assert_true(fabs(u - (254.93 + 250.0)) < 1e-7 && fabs(v - 256.9) < 1e-7);
}

static void test_check(void **state)
{
    tvo_camera c = euroc_cam0();
    (void)state;
    assert_int_equal(tvo_camera_check(&c), TVO_OK);
    assert_int_equal(tvo_camera_check(NULL), TVO_ERR_NULL);
    c.width = 0;
    assert_int_equal(tvo_camera_check(&c), TVO_ERR_SIZE);
    c = euroc_cam0();
    c.height = TVO_MAX_IMAGE_DIM + 1;
    assert_int_equal(tvo_camera_check(&c), TVO_ERR_SIZE);
    c = euroc_cam0();
    c.fx = 0.0;
    assert_int_equal(tvo_camera_check(&c), TVO_ERR_ARG);
    c = euroc_cam0();
    c.fy = -1.0;
    assert_int_equal(tvo_camera_check(&c), TVO_ERR_ARG);
    c = euroc_cam0();
    c.cx = NAN;
    assert_int_equal(tvo_camera_check(&c), TVO_ERR_NOT_FINITE);
    c = euroc_cam0();
    c.k[4] = INFINITY;
    assert_int_equal(tvo_camera_check(&c), TVO_ERR_NOT_FINITE);
    c = euroc_cam0();
    c.fx = NAN;
    assert_int_equal(tvo_camera_check(&c), TVO_ERR_NOT_FINITE);
    c = euroc_cam0();
    c.model = (tvo_distortion)7;
    assert_int_equal(tvo_camera_check(&c), TVO_ERR_ARG);
}

/* Hand-computed distortion values. */
static void test_known_values(void **state)
{
    tvo_camera c = tvo_camera_make_pinhole(100, 100, 100.0, 200.0, 50.0, 40.0);
    tvo_point2d x = {0.1, -0.2};
    double u, v;
    (void)state;
    assert_int_equal(tvo_camera_distort_point(&c, &x, &u, &v), TVO_OK);
    assert_true(fabs(u - 60.0) < 1e-12 && fabs(v - 0.0) < 1e-12);
    /* radtan: x=0.1, y=-0.2, r2=0.05, k1=0.1,k2=0.01,p1=0.001,p2=0.002,k3=0.001
     * radial = 1 + 0.005 + 0.000025 + 0.000000125 = 1.005025125
     * xd = 0.1005025125 + 2*0.001*(-0.02) + 0.002*(0.05+0.02) = 0.1005025125 - 0.00004 + 0.00014 = 0.1006025125
     * yd = -0.201005025 + 0.001*(0.05+0.08) + 2*0.002*(-0.02) = -0.201005025 + 0.00013 - 0.00008 = -0.200955025 */
    c.model = TVO_DIST_RADTAN;
    c.k[0] = 0.1;
    c.k[1] = 0.01;
    c.k[2] = 0.001;
    c.k[3] = 0.002;
    c.k[4] = 0.001;
    assert_int_equal(tvo_camera_distort_point(&c, &x, &u, &v), TVO_OK);
    assert_true(fabs(u - (50.0 + 100.0 * 0.1006025125)) < 1e-10);
    assert_true(fabs(v - (40.0 + 200.0 * -0.200955025)) < 1e-10);
    /* equidistant: x=(1,0): theta = pi/4, theta_d = theta(1 + k1 theta^2), k1 = 0.1 */
    {
        tvo_point2d e = {1.0, 0.0};
        const double th = 0.78539816339744830962;
        c.model = TVO_DIST_EQUIDISTANT;
        c.k[0] = 0.1;
        c.k[1] = c.k[2] = c.k[3] = c.k[4] = 0.0;
        assert_int_equal(tvo_camera_distort_point(&c, &e, &u, &v), TVO_OK);
        assert_true(fabs(u - (50.0 + 100.0 * th * (1 + 0.1 * th * th))) < 1e-10);
        assert_true(fabs(v - 40.0) < 1e-12);
        e.x = 0.0; /* the centre stays the centre */
        assert_int_equal(tvo_camera_distort_point(&c, &e, &u, &v), TVO_OK);
        assert_true(u == 50.0 && v == 40.0);
    }
}

static void roundtrip_grid(const tvo_camera *c, double margin)
{
    int i, j, n = 0;
    for (j = 0; j <= 24; ++j) {
        for (i = 0; i <= 24; ++i) {
            const double u = -margin + (c->width - 1 + 2 * margin) * i / 24.0;
            const double v = -margin + (c->height - 1 + 2 * margin) * j / 24.0;
            tvo_point2d xn;
            double u2, v2;
            tvo_status st = tvo_camera_undistort_point(c, u, v, &xn);
            if (st != TVO_OK)
                fprintf(stderr, "undistort failed at (%g, %g): %s\n", u, v, tvo_status_str(st));
            assert_int_equal(st, TVO_OK);
            assert_int_equal(tvo_camera_distort_point(c, &xn, &u2, &v2), TVO_OK);
            assert_true(fabs(u2 - u) < 1e-7 && fabs(v2 - v) < 1e-7);
            ++n;
        }
    }
    assert_int_equal(n, 625);
}

static void test_roundtrip(void **state)
{
    tvo_camera c;
    (void)state;
    c = euroc_cam0();
    roundtrip_grid(&c, 0.0);
    roundtrip_grid(&c, 20.0);
    c = radtan5();
    roundtrip_grid(&c, 0.0);
    c = equi();
    roundtrip_grid(&c, 0.0);
    c = tvo_camera_make_pinhole(640, 480, 500, 500, 320, 240);
    roundtrip_grid(&c, 100.0);
}

/* Array versions, float pixels: distort(undistort(p)) == p to float rounding. */
static void test_arrays(void **state)
{
    tvo_camera c = euroc_cam0();
    tvo_point2f px[64], px2[64];
    tvo_point2d xn[64];
    uint8_t ok[64];
    uint64_t s = 1;
    int i;
    (void)state;
    for (i = 0; i < 64; ++i) {
        px[i].x = (float)((tvo_test_rand(&s) % 75200) / 100.0);
        px[i].y = (float)((tvo_test_rand(&s) % 48000) / 100.0);
    }
    px[0].x = 0.0f;
    px[0].y = 0.0f;
    px[1].x = 751.0f;
    px[1].y = 479.0f;
    memset(ok, 7, sizeof ok);
    assert_int_equal(tvo_camera_undistort(&c, px, xn, ok, 64), TVO_OK);
    for (i = 0; i < 64; ++i)
        assert_int_equal(ok[i], 1);
    assert_int_equal(tvo_camera_undistort(&c, px, xn, NULL, 64), TVO_OK);
    assert_int_equal(tvo_camera_distort(&c, xn, px2, 64), TVO_OK);
    for (i = 0; i < 64; ++i) {
        assert_true(fabsf(px2[i].x - px[i].x) <= 1e-4f);
        assert_true(fabsf(px2[i].y - px[i].y) <= 1e-4f);
    }
    /* corners of the image are strongly distorted: normalised radius grows */
    assert_true(xn[0].x < (0.0 - c.cx) / c.fx && xn[0].y < (0.0 - c.cy) / c.fy);
    /* n = 0 is fine, with NULL arrays too */
    assert_int_equal(tvo_camera_undistort(&c, NULL, NULL, NULL, 0), TVO_OK);
    assert_int_equal(tvo_camera_distort(&c, NULL, NULL, 0), TVO_OK);
}

static void test_bad_input(void **state)
{
    tvo_camera c = euroc_cam0(), bad = euroc_cam0();
    tvo_point2f px[3] = {{10.0f, 10.0f}, {NAN, 5.0f}, {20.0f, INFINITY}};
    tvo_point2d xn[3];
    uint8_t ok[3];
    double u, v;
    (void)state;
    bad.fx = -1;
    assert_int_equal(tvo_camera_undistort(NULL, px, xn, ok, 3), TVO_ERR_NULL);
    assert_int_equal(tvo_camera_undistort(&bad, px, xn, ok, 3), TVO_ERR_ARG);
    assert_int_equal(tvo_camera_undistort(&c, NULL, xn, ok, 3), TVO_ERR_NULL);
    assert_int_equal(tvo_camera_undistort(&c, px, NULL, ok, 3), TVO_ERR_NULL);
    assert_int_equal(tvo_camera_undistort(&c, px, xn, ok, -1), TVO_ERR_ARG);
    assert_int_equal(tvo_camera_distort(&c, xn, NULL, 3), TVO_ERR_NULL);
    assert_int_equal(tvo_camera_distort(&c, NULL, px, 3), TVO_ERR_NULL);
    assert_int_equal(tvo_camera_distort(&c, xn, px, -2), TVO_ERR_ARG);
    assert_int_equal(tvo_camera_distort(&bad, xn, px, 1), TVO_ERR_ARG);
    /* non-finite points: flagged with ok, fail without */
    assert_int_equal(tvo_camera_undistort(&c, px, xn, ok, 3), TVO_OK);
    assert_int_equal(ok[0], 1);
    assert_int_equal(ok[1], 0);
    assert_int_equal(ok[2], 0);
    assert_true(xn[1].x == 0.0 && xn[1].y == 0.0 && xn[2].x == 0.0);
    assert_int_equal(tvo_camera_undistort(&c, px, xn, NULL, 3), TVO_ERR_NOT_FINITE);
    {
        tvo_point2d q[2] = {{0.1, 0.1}, {NAN, 0.0}};
        tvo_point2f o[2];
        assert_int_equal(tvo_camera_distort(&c, q, o, 2), TVO_ERR_NOT_FINITE);
        q[1].x = 1e300; /* overflows */
        assert_int_equal(tvo_camera_distort(&c, q, o, 2), TVO_ERR_NOT_FINITE);
        q[1].x = 1e37; /* pixel beyond float range (fx * 1e37 > FLT_MAX) */
        q[1].y = 0.0;
        c.model = TVO_DIST_NONE;
        assert_int_equal(tvo_camera_distort(&c, q, o, 2), TVO_ERR_NOT_FINITE);
        c = euroc_cam0();
    }
    assert_int_equal(tvo_camera_undistort_point(&c, 1, 1, NULL), TVO_ERR_NULL);
    assert_int_equal(tvo_camera_distort_point(&c, NULL, &u, &v), TVO_ERR_NULL);
    assert_int_equal(tvo_camera_undistort_point(&c, NAN, 1, xn), TVO_ERR_NOT_FINITE);
}

/* Points that cannot be undistorted: beyond the fold of a strongly barrel-distorted radtan model
 * (r_d(r) = r (1 + k1 r^2) with k1 = -0.5 peaks at r = sqrt(2/3), r_d = 0.544), and beyond 90
 * degrees for a fisheye. No crash, no endless loop, NO_CONVERGENCE. */
static void test_no_convergence(void **state)
{
    tvo_camera c = tvo_camera_make_pinhole(640, 480, 100.0, 100.0, 320.0, 240.0);
    tvo_point2f px[2] = {{320.0f + 50.0f, 240.0f}, {320.0f + 60.0f, 240.0f}};
    tvo_point2d xn[2];
    uint8_t ok[2];
    (void)state;
    c.model = TVO_DIST_RADTAN;
    c.k[0] = -0.5;
    assert_int_equal(tvo_camera_undistort(&c, px, xn, ok, 2), TVO_OK);
    assert_int_equal(ok[0], 1); /* r_d = 0.5 < 0.544: solvable */
    assert_true(fabs(xn[0].x * (1 - 0.5 * xn[0].x * xn[0].x) - 0.5) < 1e-12);
    assert_true(xn[0].x < sqrt(2.0 / 3.0)); /* on the invertible branch */
    assert_int_equal(ok[1], 0);             /* r_d = 0.6: no solution */
    assert_int_equal(tvo_camera_undistort(&c, px, xn, NULL, 2), TVO_ERR_NO_CONVERGENCE);
    /* fisheye without distortion: theta_d = theta; a distorted radius of 2 rad > pi/2 is behind */
    c.model = TVO_DIST_EQUIDISTANT;
    c.k[0] = 0.0;
    px[0].x = 320.0f + 100.0f; /* theta = 1 rad: fine */
    px[1].x = 320.0f + 200.0f; /* theta = 2 rad: behind the camera */
    assert_int_equal(tvo_camera_undistort(&c, px, xn, ok, 2), TVO_OK);
    assert_int_equal(ok[0], 1);
    assert_true(fabs(xn[0].x - tan(1.0)) < 1e-12);
    assert_int_equal(ok[1], 0);
}

static void test_none_model(void **state)
{
    tvo_camera c = tvo_camera_make_pinhole(640, 480, 500.0, 400.0, 320.0, 240.0);
    tvo_point2d xn;
    (void)state;
    assert_int_equal(tvo_camera_undistort_point(&c, 820.0, 40.0, &xn), TVO_OK);
    assert_true(xn.x == 1.0 && xn.y == -0.5);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_check),      cmocka_unit_test(test_known_values),
            cmocka_unit_test(test_roundtrip),  cmocka_unit_test(test_arrays),
            cmocka_unit_test(test_bad_input),  cmocka_unit_test(test_no_convergence),
            cmocka_unit_test(test_none_model), cmocka_unit_test(test_fisheye_beyond_90),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
