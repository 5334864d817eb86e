/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: pinhole camera models with radial-tangential (OpenCV "plumb bob") or equidistant (OpenCV
 * fisheye / Kalibr "equidistant") lens distortion.
 *
 * Coordinates:
 *   pixels      (u, v): OpenCV convention, origin at the centre of the top-left pixel, x right, y down.
 *   normalised  (x, y): undistorted ray (x, y, 1) in the camera frame (z forward), focal length 1.
 *
 * Models (fx, fy, cx, cy in pixels; no skew):
 *   NONE:         u = fx x + cx,  v = fy y + cy.
 *   RADTAN:       r2 = x^2 + y^2, radial = 1 + k1 r2 + k2 r2^2 + k3 r2^3,
 *                 xd = x radial + 2 p1 x y + p2 (r2 + 2 x^2),  yd = y radial + p1 (r2 + 2 y^2) + 2 p2 x y,
 *                 u = fx xd + cx, v = fy yd + cy.  k[] = {k1, k2, p1, p2, k3} (OpenCV order; EuRoC
 *                 sensor.yaml files give 4 coefficients, then k3 = 0). Same as cv2.projectPoints.
 *   EQUIDISTANT:  r = |(x, y)|, theta = atan(r), theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6
 *                 + k4 theta^8), (xd, yd) = (theta_d / r) (x, y)   ((x, y) when r = 0),
 *                 k[] = {k1, k2, k3, k4, unused}. Same as cv2.fisheye.projectPoints (skew 0).
 *
 * Undistortion solves the distortion equations for (x, y) with Newton's method (2x2 Jacobian for
 * RADTAN, 1D in theta for EQUIDISTANT), started at the distorted normalised point, with a step-halving
 * safeguard and at most TVO_CAMERA_MAX_ITERS iterations. It converges to the root on the branch where
 * the distortion map is locally invertible (positive Jacobian determinant); the result is accepted
 * only when re-distorting it reproduces the input to TVO_CAMERA_UNDISTORT_TOL (normalised units,
 * 5e-7 px for f = 500; converged points reach ~1e-15).
 *
 * Accuracy: converged points agree with OpenCV's undistortPointsIter / fisheye.undistortPoints run to
 * convergence (plain undistortPoints stops after five fixed-point iterations, short of the root towards
 * the image corners); distort() agrees with cv2.projectPoints / cv2.fisheye.projectPoints, the float
 * array version rounded to float. test/oracle/test_camera_oracle.py checks both (docs/design.md).
 * Cost: distort ~30 flops per point; undistort typically 3-6 Newton iterations (~300 flops) per point.
 * No memory beyond the arguments; all functions are reentrant. */
#ifndef TINYVO_CAMERA_H
#define TINYVO_CAMERA_H

#include "tinyvo/types.h"
#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Upper bound on Newton iterations per undistorted point (override with -DTVO_CAMERA_MAX_ITERS=n). */
#ifndef TVO_CAMERA_MAX_ITERS
#define TVO_CAMERA_MAX_ITERS 30
#endif

/* Largest accepted re-distortion residual of an undistorted point, normalised units. */
#ifndef TVO_CAMERA_UNDISTORT_TOL
#define TVO_CAMERA_UNDISTORT_TOL 1e-9
#endif

typedef enum tvo_distortion {
    TVO_DIST_NONE = 0,
    TVO_DIST_RADTAN = 1,
    TVO_DIST_EQUIDISTANT = 2
} tvo_distortion;

typedef struct tvo_camera {
    int32_t width, height; /* pixels, 1 .. TVO_MAX_IMAGE_DIM */
    double fx, fy, cx, cy; /* pixels; fx, fy > 0 */
    tvo_distortion model;
    double k[5]; /* RADTAN: k1 k2 p1 p2 k3 (OpenCV order; k3 = 0 when 4 given);
                                     EQUIDISTANT: k1 k2 k3 k4 (k[4] unused); NONE: unused */
} tvo_camera;

/* TVO_OK when cam is usable: TVO_ERR_NULL for NULL; TVO_ERR_SIZE for a width/height outside
 * 1..TVO_MAX_IMAGE_DIM; TVO_ERR_NOT_FINITE for a NaN/inf intrinsic or coefficient; TVO_ERR_ARG for
 * fx or fy <= 0 or an unknown model. */
TVO_API tvo_status tvo_camera_check(const tvo_camera *cam);

/* A pinhole camera without distortion (k all zero). Does not validate: use tvo_camera_check. */
TVO_API tvo_camera tvo_camera_make_pinhole(int32_t width, int32_t height, double fx, double fy, double cx,
                                           double cy);

/* Pixels -> undistorted normalised coordinates (z = 1), for n points (n >= 0; px and xn must not
 * overlap). Points need not lie inside the image.
 * With ok != NULL: ok[i] = 1 for a solved point, 0 for a point that is not finite or does not
 * converge (then xn[i] = (0, 0)); the call returns TVO_OK unless its arguments are invalid.
 * With ok == NULL: the call stops at the first bad point and returns TVO_ERR_NOT_FINITE (non-finite
 * input) or TVO_ERR_NO_CONVERGENCE (no root within TVO_CAMERA_MAX_ITERS, or the root lies beyond
 * the fold of the distortion map, or for EQUIDISTANT a ray at or beyond 90 degrees).
 * Argument errors: TVO_ERR_NULL, TVO_ERR_ARG (n < 0), and tvo_camera_check's codes. */
TVO_API tvo_status tvo_camera_undistort(const tvo_camera *cam, const tvo_point2f *px, tvo_point2d *xn,
                                        uint8_t *ok, int32_t n);

/* Normalised (undistorted) coordinates -> distorted pixels, for n >= 0 points. Fails with
 * TVO_ERR_NOT_FINITE at the first point that is not finite or whose pixel position is not finite
 * or not representable as float; the points before it are written. Other errors as undistort. */
TVO_API tvo_status tvo_camera_distort(const tvo_camera *cam, const tvo_point2d *xn, tvo_point2f *px,
                                      int32_t n);

/* One point in double precision (same semantics as the array versions, ok == NULL). */
TVO_API tvo_status tvo_camera_undistort_point(const tvo_camera *cam, double u, double v, tvo_point2d *xn);
TVO_API tvo_status tvo_camera_distort_point(const tvo_camera *cam, const tvo_point2d *xn, double *u,
                                            double *v);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_CAMERA_H */
