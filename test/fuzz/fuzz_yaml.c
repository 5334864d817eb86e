/* SPDX-License-Identifier: Apache-2.0 */
/* Fuzz harness: the sensor.yaml reader (tvo_euroc_parse_sensor_yaml, tinyvo/port/euroc.h), the
 * calibration importer on the same text (tvo_calib_parse, tinyvo/port/calib.h: format detection and
 * each forced format, camchain cameras cam0 and cam1), and the camera models they produce.
 *
 * The input is a sensor.yaml text. Invariants: a documented status (OK, FORMAT, UNSUPPORTED) with a
 * non-empty NUL-terminated message on error (also with a 6-byte message buffer); on success the camera
 * passes tvo_camera_check, T_BS is finite with an orthonormal rotation and rate_hz is 0 or positive.
 * The parsed camera (fuzzed intrinsics and distortion coefficients) then undistorts a grid of pixels
 * over and beyond the image, and the solved points are distorted back: every solved point is finite,
 * and a point that distorts without error lands on a finite pixel. The importer: a documented status
 * (OK, FORMAT, UNSUPPORTED, NOT_FOUND, ARG for a camera name given to a single-camera file) with a
 * message on error, the same status and camera with a 6-byte message buffer, on success a camera that
 * passes tvo_camera_check, a finite T_BS with an orthonormal rotation, identity when has_T_BS is 0,
 * a format that is not AUTO, and the same result as the EuRoC parser whenever that one succeeds. */
#include <math.h>
#include <string.h>

#include "fuzz_common.h"
#include "tinyvo/port/calib.h"
#include "tinyvo/port/euroc.h"

#define GRID 7

static void exercise_camera(const tvo_camera *cam)
{
    tvo_point2f px[GRID * GRID], back[GRID * GRID];
    tvo_point2d xn[GRID * GRID];
    uint8_t ok[GRID * GRID];
    int n = 0;
    for (int j = 0; j < GRID; ++j)
        for (int i = 0; i < GRID; ++i) {
            /* -10% .. 110% of the image in each direction */
            px[n].x = (float)((-0.1 + 1.2 * i / (GRID - 1)) * (cam->width - 1));
            px[n].y = (float)((-0.1 + 1.2 * j / (GRID - 1)) * (cam->height - 1));
            ++n;
        }
    TVO_FUZZ_CHECK(tvo_camera_undistort(cam, px, xn, ok, n) == TVO_OK);
    for (int k = 0; k < n; ++k) {
        tvo_status st;
        if (!ok[k]) {
            TVO_FUZZ_CHECK(xn[k].x == 0.0 && xn[k].y == 0.0);
            continue;
        }
        TVO_FUZZ_CHECK(isfinite(xn[k].x) && isfinite(xn[k].y));
        st = tvo_camera_distort(cam, &xn[k], &back[k], 1);
        TVO_FUZZ_CHECK(st == TVO_OK || st == TVO_ERR_NOT_FINITE);
        if (st == TVO_OK)
            TVO_FUZZ_CHECK(isfinite(back[k].x) && isfinite(back[k].y));
    }
    {
        tvo_point2d d;
        tvo_status st = tvo_camera_undistort_point(cam, cam->cx, cam->cy, &d);
        TVO_FUZZ_CHECK(tvo_fuzz_status_valid(st));
        if (st == TVO_OK)
            TVO_FUZZ_CHECK(isfinite(d.x) && isfinite(d.y));
    }
}

static void check_calib(const char *text, size_t size, tvo_calib_format format, const char *camera,
                        const tvo_camera *euroc_cam)
{
    tvo_calib c, c2;
    char err[256], small[6];
    tvo_status st = tvo_calib_parse(text, size, format, camera, &c, err, sizeof err), st2;
    TVO_FUZZ_CHECK(st == TVO_OK || st == TVO_ERR_FORMAT || st == TVO_ERR_UNSUPPORTED ||
                   st == TVO_ERR_NOT_FOUND || st == TVO_ERR_ARG);
    TVO_FUZZ_CHECK(memchr(err, '\0', sizeof err) != NULL);
    st2 = tvo_calib_parse(text, size, format, camera, &c2, small, sizeof small);
    TVO_FUZZ_CHECK(st2 == st && memchr(small, '\0', sizeof small) != NULL);
    if (st != TVO_OK) {
        TVO_FUZZ_CHECK(err[0] != '\0');
        return;
    }
    TVO_FUZZ_CHECK(memcmp(&c.camera, &c2.camera, sizeof c.camera) == 0 && c.format == c2.format);
    TVO_FUZZ_CHECK(c.format != TVO_CALIB_AUTO && (format == TVO_CALIB_AUTO || c.format == format));
    TVO_FUZZ_CHECK(tvo_camera_check(&c.camera) == TVO_OK);
    TVO_FUZZ_CHECK(tvo_pose_is_finite(&c.T_BS));
    TVO_FUZZ_CHECK(tvo_rot_orthogonality_error(c.T_BS.R) < 1e-9);
    if (!c.has_T_BS) {
        const tvo_pose I = tvo_pose_identity();
        TVO_FUZZ_CHECK(memcmp(&c.T_BS, &I, sizeof I) == 0);
    }
    TVO_FUZZ_CHECK(c.rate_hz == 0.0 || (c.rate_hz > 0.0 && isfinite(c.rate_hz)));
    TVO_FUZZ_CHECK(memchr(c.camera_name, '\0', sizeof c.camera_name) != NULL);
    if (format == TVO_CALIB_EUROC && euroc_cam != NULL)
        TVO_FUZZ_CHECK(memcmp(&c.camera, euroc_cam, sizeof c.camera) == 0);
    exercise_camera(&c.camera);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *text = (const char *)data;
    tvo_camera cam, cam2;
    tvo_pose T_BS;
    double rate = -1.0;
    char err[256], small[6];
    tvo_status st = tvo_euroc_parse_sensor_yaml(text, size, &cam, &T_BS, &rate, err, sizeof err), st2;
    TVO_FUZZ_CHECK(st == TVO_OK || st == TVO_ERR_FORMAT || st == TVO_ERR_UNSUPPORTED);
    TVO_FUZZ_CHECK(memchr(err, '\0', sizeof err) != NULL);
    st2 = tvo_euroc_parse_sensor_yaml(text, size, &cam2, NULL, NULL, small, sizeof small);
    TVO_FUZZ_CHECK(st2 == st && memchr(small, '\0', sizeof small) != NULL);
    check_calib(text, size, TVO_CALIB_AUTO, NULL, st == TVO_OK ? &cam : NULL);
    check_calib(text, size, TVO_CALIB_AUTO, "cam1", NULL);
    for (int f = TVO_CALIB_EUROC; f <= TVO_CALIB_ROS; ++f)
        check_calib(text, size, (tvo_calib_format)f, NULL, st == TVO_OK ? &cam : NULL);
    if (st != TVO_OK) {
        TVO_FUZZ_CHECK(err[0] != '\0');
        return 0;
    }
    TVO_FUZZ_CHECK(cam.width == cam2.width && cam.height == cam2.height && cam.model == cam2.model);
    TVO_FUZZ_CHECK(cam.fx == cam2.fx && cam.fy == cam2.fy && cam.cx == cam2.cx && cam.cy == cam2.cy);
    TVO_FUZZ_CHECK(memcmp(cam.k, cam2.k, sizeof cam.k) == 0);
    TVO_FUZZ_CHECK(tvo_camera_check(&cam) == TVO_OK);
    TVO_FUZZ_CHECK(tvo_pose_is_finite(&T_BS));
    TVO_FUZZ_CHECK(tvo_rot_orthogonality_error(T_BS.R) < 1e-9);
    TVO_FUZZ_CHECK(rate == 0.0 || (rate > 0.0 && isfinite(rate)));
    exercise_camera(&cam);
    return 0;
}
