/* SPDX-License-Identifier: Apache-2.0 */
/* Calibration import (tinyvo/port/calib.h) on real files of each kind (test/data/calib, SOURCES.md
 * says where each comes from), the EuRoC sample's own sensor.yaml (skipped without TVO_DATA_DIR),
 * edits of the real files that turn them into models the core cannot represent, and truncated /
 * mutated copies. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>

#include "tvo_test.h"
#include "tinyvo/port/calib.h"
#include "tinyvo/port/euroc.h"

/* test/data/calib/<name> as a NUL-terminated heap string (the test fails when it is missing). */
static char *read_calib(const char *name, size_t *len)
{
    char path[4096];
    const char *src = getenv("TVO_SOURCE_DIR");
    FILE *f;
    char *buf;
    long n;
    snprintf(path, sizeof path, "%s/test/data/calib/%s", src != NULL ? src : ".", name);
    f = fopen(path, "rb");
    if (f == NULL)
        fail_msg("%s missing (set TVO_SOURCE_DIR)", path);
    assert_int_equal(fseek(f, 0, SEEK_END), 0);
    n = ftell(f);
    assert_true(n > 0);
    assert_int_equal(fseek(f, 0, SEEK_SET), 0);
    buf = (char *)malloc((size_t)n + 1);
    assert_non_null(buf);
    assert_int_equal(fread(buf, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    buf[n] = '\0';
    if (len != NULL)
        *len = (size_t)n;
    return buf;
}

static void calib_path(const char *name, char *path, size_t size)
{
    const char *src = getenv("TVO_SOURCE_DIR");
    snprintf(path, size, "%s/test/data/calib/%s", src != NULL ? src : ".", name);
}

/* text with the first occurrence of `from` replaced by `to` (heap; the test fails when absent). */
static char *edit(const char *text, const char *from, const char *to)
{
    const char *p = strstr(text, from);
    size_t a, nf = strlen(from), nt = strlen(to), n = strlen(text);
    char *out;
    if (p == NULL)
        fail_msg("'%s' not in the file", from);
    a = (size_t)(p - text);
    out = (char *)malloc(n - nf + nt + 1);
    assert_non_null(out);
    memcpy(out, text, a);
    memcpy(out + a, to, nt);
    memcpy(out + a + nt, p + nf, n - a - nf + 1);
    return out;
}

static tvo_status parse(const char *text, const char *camera, tvo_calib *c, char *err, size_t err_size)
{
    return tvo_calib_parse(text, strlen(text), TVO_CALIB_AUTO, camera, c, err, err_size);
}

/* An edited file must fail with `expect` and a message holding `part`. */
static void expect_refused(char *text, const char *camera, tvo_status expect, const char *part)
{
    tvo_calib c;
    char err[256];
    tvo_status st = parse(text, camera, &c, err, sizeof err);
    if (st != expect || strstr(err, part) == NULL)
        fail_msg("got %s '%s', expected %s with '%s'", tvo_status_str(st), err, tvo_status_str(expect), part);
    free(text);
}

static void assert_near(double a, double b, double tol)
{
    if (!(fabs(a - b) <= tol))
        fail_msg("%.17g != %.17g (tol %g)", a, b, tol);
}

/* T_a * T_b == identity (to tol). */
static void assert_inverse(const tvo_pose *a, const tvo_pose *b, double tol)
{
    tvo_pose p = tvo_pose_compose(a, b);
    int i;
    for (i = 0; i < 9; ++i)
        assert_near(p.R[i], (i % 4 == 0) ? 1.0 : 0.0, tol);
    for (i = 0; i < 3; ++i)
        assert_near(p.t[i], 0.0, tol);
}

static void test_kalibr_camchain_equi(void **state)
{
    /* values as written in the file: T_cam_imu rows and the camera */
    static const double T_cam_imu[16] = {-0.9995184472361309,
                                         0.021876089843145007,
                                         -0.022007051775495362,
                                         0.04246317973602691,
                                         0.025341655517008066,
                                         0.9847584328334349,
                                         -0.1720715823693607,
                                         0.0005184030993907625,
                                         0.017907376422356798,
                                         -0.17254641594832693,
                                         -0.984838596021224,
                                         -0.015973750407470507,
                                         0.0,
                                         0.0,
                                         0.0,
                                         1.0};
    tvo_calib c;
    char err[256], path[4096];
    tvo_pose T;
    (void)state;
    calib_path("kalibr_camchain_imucam_equi.yaml", path, sizeof path);
    assert_int_equal(tvo_calib_load(path, NULL, &c, err, sizeof err), TVO_OK);
    assert_int_equal(c.format, TVO_CALIB_KALIBR_CAMCHAIN);
    assert_string_equal(c.camera_name, "cam0");
    assert_int_equal(c.camera.model, TVO_DIST_EQUIDISTANT);
    assert_int_equal(c.camera.width, 640);
    assert_int_equal(c.camera.height, 480);
    assert_true(c.camera.fx == 274.51623038381354 && c.camera.fy == 275.33528152592356);
    assert_true(c.camera.cx == 313.61364519480173 && c.camera.cy == 251.55631360961928);
    /* the coefficients continue on the next line of the file */
    assert_true(c.camera.k[0] == -0.027396339719770575 && c.camera.k[3] == 0.05123810380038282);
    assert_true(c.has_T_BS);
    T = tvo_pose_from_matrix(T_cam_imu);
    assert_inverse(&c.T_BS, &T, 1e-6); /* T_BS = inv(T_cam_imu) */
    assert_true(c.rate_hz == 0.0);
    /* the camera is asked for by name, too */
    assert_int_equal(tvo_calib_load(path, "cam0", &c, err, sizeof err), TVO_OK);
    assert_int_equal(tvo_calib_load(path, "cam1", &c, err, sizeof err), TVO_ERR_NOT_FOUND);
    assert_non_null(strstr(err, "no camera 'cam1' in the camchain (it has cam0)"));
    assert_non_null(strstr(err, path)); /* load prefixes the path */

    calib_path("kalibr_camchain_equi.yaml", path, sizeof path);
    assert_int_equal(tvo_calib_load(path, NULL, &c, err, sizeof err), TVO_OK);
    assert_int_equal(c.camera.model, TVO_DIST_EQUIDISTANT);
    assert_true(c.camera.fx == 277.95596230891084 && c.camera.k[3] == 0.015501252412920248);
    assert_false(c.has_T_BS);
}

static void test_kalibr_camchain_radtan_and_omni(void **state)
{
    char *text = read_calib("kalibr_wiki_camchain_radtan_omni.yaml", NULL);
    tvo_calib c;
    char err[256];
    (void)state;
    assert_int_equal(parse(text, NULL, &c, err, sizeof err), TVO_OK);
    assert_int_equal(c.format, TVO_CALIB_KALIBR_CAMCHAIN);
    assert_int_equal(c.camera.model, TVO_DIST_RADTAN);
    assert_true(c.camera.fx == 461.629 && c.camera.fy == 460.152 && c.camera.cx == 362.680 &&
                c.camera.cy == 246.049);
    assert_true(c.camera.k[0] == -0.27695497 && c.camera.k[3] == 0.00011556 && c.camera.k[4] == 0.0);
    assert_int_equal(c.camera.width, 752);
    assert_true(c.has_T_BS);
    /* inv(T_cam_imu): the camera centre in the IMU frame is -R^T t */
    assert_near(c.T_BS.t[0], -(0.01779318 * 0.07008565 + -0.9998017 * -0.01771023 + 0.00893160 * 0.00399246),
                1e-5);
    /* cam1 is an omnidirectional camera: refused by name */
    assert_int_equal(parse(text, "cam1", &c, err, sizeof err), TVO_ERR_UNSUPPORTED);
    assert_non_null(strstr(err, "camera_model 'omni'"));
    assert_non_null(strstr(err, "unified omnidirectional"));
    assert_int_equal(parse(text, "cam2", &c, err, sizeof err), TVO_ERR_NOT_FOUND);
    assert_non_null(strstr(err, "(it has cam0, cam1)"));
    assert_int_equal(parse(text, "", &c, err, sizeof err), TVO_ERR_ARG);
    free(text);
}

static void test_kalibr_flat_and_other_models(void **state)
{
    char *text = read_calib("kalibr_wiki_camchain_radtan_omni.yaml", NULL);
    char *flat, *p;
    tvo_calib c;
    char err[256];
    (void)state;
    /* Kalibr's keys at the top level: cam0's block of the real file, dedented */
    flat = (char *)malloc(strlen(text) + 1);
    assert_non_null(flat);
    {
        const char *s = strstr(text, "cam0:\n") + 6, *stop = strstr(text, "cam1:");
        size_t o = 0;
        while (s < stop) {
            if (s[0] == ' ' && s[1] == ' ')
                s += 2;
            while (s < stop && *s != '\n')
                flat[o++] = *s++;
            if (s < stop)
                flat[o++] = *s++;
        }
        flat[o] = '\0';
    }
    assert_int_equal(parse(flat, NULL, &c, err, sizeof err), TVO_OK);
    assert_int_equal(c.format, TVO_CALIB_KALIBR);
    assert_true(c.camera.fx == 461.629 && c.camera.k[1] == 0.06712482 && c.has_T_BS);
    assert_int_equal(parse(flat, "cam0", &c, err, sizeof err), TVO_ERR_ARG); /* one camera: no name */
    assert_non_null(strstr(err, "one camera"));
    /* the failure: Kalibr's distortion_coeffs key read as no coefficients */
    assert_int_equal(c.camera.model, TVO_DIST_RADTAN);
    p = flat;
    expect_refused(edit(p, "camera_model: pinhole", "camera_model: ds"), NULL, TVO_ERR_UNSUPPORTED,
                   "double sphere");
    expect_refused(edit(p, "camera_model: pinhole", "camera_model: eucm"), NULL, TVO_ERR_UNSUPPORTED,
                   "'eucm'");
    expect_refused(edit(p, "distortion_model: radtan", "distortion_model: fov"), NULL, TVO_ERR_UNSUPPORTED,
                   "distortion_model 'fov' not supported");
    expect_refused(edit(p, "0.00011556]", "0.00011556, 0.1, 0.2]"), NULL, TVO_ERR_FORMAT,
                   "needs 4 or 5 distortion_coeffs, got 6");
    expect_refused(edit(p, "distortion_coeffs", "distortion_coefficients: [0,0,0,0]\ndistortion_coeffs"),
                   NULL, TVO_ERR_FORMAT, "both distortion_coefficients and distortion_coeffs");
    expect_refused(edit(p, "[0.0, 0.0, 0.0, 1.0]", "[0.0, 0.0, 0.5, 1.0]"), NULL, TVO_ERR_FORMAT,
                   "T_cam_imu: last row");
    free(flat);
    free(text);
}

static void test_ros_camera_info(void **state)
{
    char *text = read_calib("ros_plumb_bob_euroc_cam0.yaml", NULL);
    char path[4096], err[256];
    tvo_calib c;
    const char *d = tvo_test_data_dir();
    (void)state;
    assert_int_equal(parse(text, NULL, &c, err, sizeof err), TVO_OK);
    assert_int_equal(c.format, TVO_CALIB_ROS);
    assert_int_equal(c.camera.model, TVO_DIST_RADTAN);
    assert_int_equal(c.camera.width, 752);
    assert_int_equal(c.camera.height, 480);
    assert_true(c.camera.fx == 458.654 && c.camera.fy == 457.296 && c.camera.cx == 367.215 &&
                c.camera.cy == 248.375);
    assert_true(c.camera.k[0] == -0.28340811 && c.camera.k[3] == 1.76187114e-05 && c.camera.k[4] == 0.0);
    assert_false(c.has_T_BS);
    /* the same camera as EuRoC's own sensor.yaml, a file written by other people in another format */
    if (d != NULL) {
        tvo_euroc *seq = NULL;
        snprintf(path, sizeof path, "%s/euroc/V1_01_easy_head", d);
        if (tvo_euroc_open(&seq, path, "cam0", err, sizeof err) == TVO_OK) {
            const tvo_camera *e = tvo_euroc_camera(seq);
            assert_memory_equal(e, &c.camera, sizeof c.camera);
            tvo_euroc_close(seq);
        } else {
            fprintf(stderr, "note: %s not found, EuRoC comparison skipped\n", path);
        }
    }
    /* rational_polynomial: accepted when k4..k6 are zero (the same camera), refused otherwise */
    {
        char *r = edit(text, "plumb_bob", "rational_polynomial");
        char *r8 =
                edit(r, "cols: 5\n  data:  [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0]",
                     "cols: 8\n  data:  [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0, 0, 0, 0]");
        tvo_calib c8;
        assert_int_equal(parse(r8, NULL, &c8, err, sizeof err), TVO_OK);
        assert_memory_equal(&c8.camera, &c.camera, sizeof c.camera);
        expect_refused(edit(r8, "0, 0, 0]", "0.5, 0, 0.01]"), NULL, TVO_ERR_UNSUPPORTED,
                       "distortion_model 'rational_polynomial' with non-zero k4 k5 k6");
        expect_refused(r, NULL, TVO_ERR_FORMAT, "rational_polynomial needs 8");
        free(r8);
    }
    expect_refused(edit(text, "plumb_bob", "fisheye_fov"), NULL, TVO_ERR_UNSUPPORTED,
                   "'fisheye_fov' not supported");
    expect_refused(edit(text, "cols: 5", "cols: 4"), NULL, TVO_ERR_FORMAT, "rows x cols");
    expect_refused(edit(text, "[458.654, 0.0,", "[458.654, 0.3,"), NULL, TVO_ERR_UNSUPPORTED, "skew");
    expect_refused(edit(text, "image_width: 752\n", ""), NULL, TVO_ERR_FORMAT, "missing key 'image_width'");
    expect_refused(edit(text, "camera_name: cam0", "camera_name: cam0\ncamera_name: cam1"), NULL,
                   TVO_ERR_FORMAT, "duplicate key 'camera_name'");
    /* the flow-mapping spelling of the same matrix */
    {
        char *fm = edit(text,
                        "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [458.654, 0.0, 367.215, 0.0, 457.296, "
                        "248.375, 0.0, 0.0, 1.0]",
                        "camera_matrix: {rows: 3, cols: 3,\n  data: [458.654, 0.0, 367.215, 0.0, 457.296, "
                        "248.375, "
                        "0.0, 0.0, 1.0]}");
        tvo_calib c2;
        assert_int_equal(parse(fm, NULL, &c2, err, sizeof err), TVO_OK);
        assert_memory_equal(&c2.camera, &c.camera, sizeof c.camera);
        free(fm);
    }
    free(text);

    text = read_calib("ros_equidistant.yaml", NULL);
    assert_int_equal(parse(text, NULL, &c, err, sizeof err), TVO_OK);
    assert_int_equal(c.format, TVO_CALIB_ROS);
    assert_int_equal(c.camera.model, TVO_DIST_EQUIDISTANT);
    assert_true(c.camera.fx == 395.872620767 && c.camera.cy == 214.319312646);
    assert_true(c.camera.k[0] == -0.00453674705911 && c.camera.k[3] == -0.0155084020782);
    expect_refused(edit(text, "cols: 4\n  data: [-0.00453674705911,",
                        "cols: 5\n  data: [0.1, -0.00453674705911,"),
                   NULL, TVO_ERR_FORMAT, "equidistant needs 4");
    free(text);
}

static void test_opencv_filestorage(void **state)
{
    char *text = read_calib("opencv_left_intrinsics.yml", NULL);
    tvo_calib c;
    char err[256];
    (void)state;
    assert_int_equal(parse(text, NULL, &c, err, sizeof err), TVO_OK);
    assert_int_equal(c.format, TVO_CALIB_OPENCV);
    assert_int_equal(c.camera.model, TVO_DIST_RADTAN);
    assert_int_equal(c.camera.width, 640);
    assert_int_equal(c.camera.height, 480);
    assert_true(c.camera.fx == 5.3591573396163199e+02 && c.camera.fy == 5.3591573396163199e+02);
    assert_true(c.camera.cx == 3.4228315473308373e+02 && c.camera.cy == 2.3557082909788173e+02);
    assert_true(c.camera.k[0] == -2.6637260909660682e-01 && c.camera.k[4] == 2.3839153080878486e-01);
    /* an 8-coefficient (rational) OpenCV calibration with non-zero k4.. is refused by name */
    expect_refused(edit(text, "rows: 5\n   cols: 1\n   dt: d\n   data: [ -2.6637260909660682e-01,",
                        "rows: 8\n   cols: 1\n   dt: d\n   data: [ 0.1, 0.2, 0.3, -2.6637260909660682e-01,"),
                   NULL, TVO_ERR_UNSUPPORTED, "rational model (8 coefficients)");
    /* OpenCV's calibration sample writes fisheye_model: 1 for cv::fisheye calibrations */
    {
        char *fe = edit(text, "flags: 2\n", "flags: 2\nfisheye_model: 1\n");
        expect_refused(fe, NULL, TVO_ERR_FORMAT, "equidistant needs 4");
    }
    /* the older sample's capitalised keys (Camera_Matrix, image_Width) */
    {
        char *a = edit(text, "camera_matrix:", "Camera_Matrix:");
        char *b = edit(a, "image_width:", "image_Width:");
        tvo_calib c2;
        assert_int_equal(parse(b, NULL, &c2, err, sizeof err), TVO_OK);
        assert_memory_equal(&c2.camera, &c.camera, sizeof c.camera);
        free(a);
        free(b);
    }
    expect_refused(edit(text, "   data: [ 5.3591573396163199e+02, 0.,", "   data: [ 5.3591573396163199e+02,"),
                   NULL, TVO_ERR_FORMAT, "rows x cols");
    expect_refused(edit(text, "2.3839153080878486e-01 ]", "2.3839153080878486e-01"), NULL, TVO_ERR_FORMAT,
                   "never closed");
    free(text);

    text = read_calib("opencv_charuco.yml", NULL);
    assert_int_equal(parse(text, NULL, &c, err, sizeof err), TVO_OK);
    assert_int_equal(c.format, TVO_CALIB_OPENCV);
    assert_true(c.camera.fx == 4.5251072219637672e+02 && c.camera.fy == 4.5676707935146891e+02);
    assert_true(c.camera.k[1] == -1.0854664722560681e+00 && c.camera.k[4] == 2.9542589406810080e+00);
    free(text);
}

static void test_euroc_sensor_yaml(void **state)
{
    char *text = read_calib("euroc_kimera_d455_left.yaml", NULL);
    tvo_calib c;
    tvo_camera cam;
    tvo_pose T;
    double rate = 0;
    char err[256], path[4096];
    const char *d = tvo_test_data_dir();
    (void)state;
    assert_int_equal(parse(text, NULL, &c, err, sizeof err), TVO_OK);
    assert_int_equal(c.format, TVO_CALIB_EUROC);
    assert_true(c.camera.fx == 377.229220831 && c.camera.k[3] == 0.00324217 && c.rate_hz == 20.0);
    assert_true(c.has_T_BS);
    assert_near(c.T_BS.t[2], 0.02575617, 1e-12);
    /* the EuRoC reader's parser gives the same */
    assert_int_equal(tvo_euroc_parse_sensor_yaml(text, strlen(text), &cam, &T, &rate, err, sizeof err),
                     TVO_OK);
    assert_memory_equal(&cam, &c.camera, sizeof cam);
    assert_true(rate == 20.0);
    free(text);
    if (d == NULL)
        TVO_SKIP("TVO_DATA_DIR not set: the EuRoC sample's sensor.yaml part skipped");
    snprintf(path, sizeof path, "%s/euroc/V1_01_easy_head/mav0/cam1/sensor.yaml", d);
    if (tvo_calib_load(path, NULL, &c, err, sizeof err) == TVO_ERR_NOT_FOUND)
        TVO_SKIP("TVO_DATA_DIR/euroc/V1_01_easy_head not found");
    assert_int_equal(tvo_calib_load(path, NULL, &c, err, sizeof err), TVO_OK);
    assert_int_equal(c.format, TVO_CALIB_EUROC);
    assert_true(c.camera.fx == 457.587 && c.camera.width == 752 && c.rate_hz == 20.0 && c.has_T_BS);
    assert_near(c.T_BS.t[1], 0.0453689425024, 1e-9);
}

static void test_not_a_calibration(void **state)
{
    tvo_calib c;
    char err[256], path[4096];
    (void)state;
    assert_int_equal(parse("rostopic: /imu0\nupdate_rate: 200.0\n", NULL, &c, err, sizeof err),
                     TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "not a calibration file"));
    assert_int_equal(parse("%YAML:1.0\nmodel_type: PINHOLE\nprojection_parameters:\n   fx: 4.6e+02\n", NULL,
                           &c, err, sizeof err),
                     TVO_ERR_UNSUPPORTED);
    assert_non_null(strstr(err, "camodocal"));
    assert_int_equal(parse("", NULL, &c, err, sizeof err), TVO_ERR_FORMAT);
    assert_int_equal(parse("a: |\n  text\n", NULL, &c, err, sizeof err), TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "line 1: block scalars"));
    assert_int_equal(parse("cam0:\n  intrinsics: [1, 2, 3, 4]\n  - 5\n", NULL, &c, err, sizeof err),
                     TVO_ERR_FORMAT);
    assert_non_null(strstr(err, "line 3: sequence item inside a mapping"));
    assert_int_equal(tvo_calib_parse(NULL, 5, TVO_CALIB_AUTO, NULL, &c, err, sizeof err), TVO_ERR_NULL);
    assert_int_equal(tvo_calib_parse("", 0, TVO_CALIB_AUTO, NULL, NULL, err, sizeof err), TVO_ERR_NULL);
    assert_int_equal(tvo_calib_parse("", 0, (tvo_calib_format)9, NULL, &c, err, sizeof err), TVO_ERR_ARG);
    /* a forced format that does not match */
    {
        char *t = read_calib("ros_equidistant.yaml", NULL);
        assert_int_equal(tvo_calib_parse(t, strlen(t), TVO_CALIB_EUROC, NULL, &c, err, sizeof err),
                         TVO_ERR_FORMAT);
        assert_non_null(strstr(err, "missing key 'intrinsics'"));
        free(t);
    }
    calib_path("no_such_file.yaml", path, sizeof path);
    assert_int_equal(tvo_calib_load(path, NULL, &c, err, sizeof err), TVO_ERR_NOT_FOUND);
    assert_non_null(strstr(err, "no_such_file.yaml"));
    assert_string_equal(tvo_calib_format_name(TVO_CALIB_KALIBR_CAMCHAIN), "kalibr-camchain");
    assert_string_equal(tvo_calib_format_name((tvo_calib_format)42), "unknown");
}

/* Every real file cut at every length and with random byte mutations: a documented status, a
 * message on failure, a usable camera on success. */
static void test_truncated_and_mutated(void **state)
{
    static const char *const files[] = {"kalibr_camchain_imucam_equi.yaml",
                                        "kalibr_camchain_equi.yaml",
                                        "kalibr_wiki_camchain_radtan_omni.yaml",
                                        "ros_plumb_bob_euroc_cam0.yaml",
                                        "ros_equidistant.yaml",
                                        "opencv_left_intrinsics.yml",
                                        "opencv_charuco.yml",
                                        "euroc_kimera_d455_left.yaml"};
    uint64_t rng = 12345;
    size_t f;
    (void)state;
    for (f = 0; f < sizeof files / sizeof files[0]; ++f) {
        size_t len, cut;
        char *text = read_calib(files[f], &len);
        char *buf = (char *)malloc(len);
        int ok_cuts = 0, k;
        assert_non_null(buf);
        for (cut = 0; cut <= len; ++cut) {
            tvo_calib c;
            char err[128];
            tvo_status st = tvo_calib_parse(text, cut, TVO_CALIB_AUTO, NULL, &c, err, sizeof err);
            if (st == TVO_OK) {
                assert_int_equal(tvo_camera_check(&c.camera), TVO_OK);
                ok_cuts++;
            } else {
                if (st != TVO_ERR_FORMAT && st != TVO_ERR_UNSUPPORTED && st != TVO_ERR_NOT_FOUND)
                    fail_msg("%s cut at %zu: %s", files[f], cut, tvo_status_str(st));
                assert_true(err[0] != '\0');
            }
        }
        assert_true(ok_cuts >= 1); /* the whole file at least */
        for (k = 0; k < 300; ++k) {
            tvo_calib c;
            char err[64];
            int m, j;
            tvo_status st;
            memcpy(buf, text, len);
            m = 1 + (int)(tvo_test_rand(&rng) % 4);
            for (j = 0; j < m; ++j)
                buf[tvo_test_rand(&rng) % len] = (char)(tvo_test_rand(&rng) & 0xff);
            st = tvo_calib_parse(buf, len, TVO_CALIB_AUTO, (k & 1) ? "cam1" : NULL, &c, err, sizeof err);
            if (st == TVO_OK)
                assert_int_equal(tvo_camera_check(&c.camera), TVO_OK);
            else
                assert_true(st == TVO_ERR_FORMAT || st == TVO_ERR_UNSUPPORTED || st == TVO_ERR_NOT_FOUND ||
                            st == TVO_ERR_ARG);
        }
        free(buf);
        free(text);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_kalibr_camchain_equi),
            cmocka_unit_test(test_kalibr_camchain_radtan_and_omni),
            cmocka_unit_test(test_kalibr_flat_and_other_models),
            cmocka_unit_test(test_ros_camera_info),
            cmocka_unit_test(test_opencv_filestorage),
            cmocka_unit_test(test_euroc_sensor_yaml),
            cmocka_unit_test(test_not_a_calibration),
            cmocka_unit_test(test_truncated_and_mutated),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
