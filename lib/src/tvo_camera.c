/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: pinhole camera models with radial-tangential or equidistant distortion (see camera.h). */
#include "tinyvo/camera.h"
#include "tinyvo/dmath.h"
#include "tinyvo/options.h"

#include <float.h>
#include <math.h>

#define TVO_HALF_PI 1.57079632679489661923

static int tvo_finite(double v)
{
    return isfinite(v) != 0;
}

tvo_camera tvo_camera_make_pinhole(int32_t width, int32_t height, double fx, double fy, double cx, double cy)
{
    tvo_camera c;
    int i;
    c.width = width;
    c.height = height;
    c.fx = fx;
    c.fy = fy;
    c.cx = cx;
    c.cy = cy;
    c.model = TVO_DIST_NONE;
    for (i = 0; i < 5; ++i)
        c.k[i] = 0.0;
    return c;
}

tvo_status tvo_camera_check(const tvo_camera *cam)
{
    int i;
    if (cam == NULL)
        return TVO_ERR_NULL;
    if (cam->width < 1 || cam->height < 1 || cam->width > TVO_MAX_IMAGE_DIM ||
        cam->height > TVO_MAX_IMAGE_DIM)
        return TVO_ERR_SIZE;
    if (!tvo_finite(cam->fx) || !tvo_finite(cam->fy) || !tvo_finite(cam->cx) || !tvo_finite(cam->cy))
        return TVO_ERR_NOT_FINITE;
    for (i = 0; i < 5; ++i)
        if (!tvo_finite(cam->k[i]))
            return TVO_ERR_NOT_FINITE;
    if (!(cam->fx > 0.0) || !(cam->fy > 0.0))
        return TVO_ERR_ARG;
    if (cam->model != TVO_DIST_NONE && cam->model != TVO_DIST_RADTAN && cam->model != TVO_DIST_EQUIDISTANT)
        return TVO_ERR_ARG;
    return TVO_OK;
}

/* ---- radial-tangential ---------------------------------------------------------------------- */

/* Distort normalised (x, y); optionally the Jacobian J = d(xd, yd)/d(x, y), row-major 2x2. */
static void tvo_radtan(const double *k, double x, double y, double *xd, double *yd, double *J)
{
    const double k1 = k[0], k2 = k[1], p1 = k[2], p2 = k[3], k3 = k[4];
    const double x2 = x * x, y2 = y * y, xy = x * y, r2 = x2 + y2;
    const double rad = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    *xd = x * rad + 2.0 * p1 * xy + p2 * (r2 + 2.0 * x2);
    *yd = y * rad + p1 * (r2 + 2.0 * y2) + 2.0 * p2 * xy;
    if (J != NULL) {
        const double drad = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2); /* d rad / d r2 */
        const double cross = 2.0 * xy * drad + 2.0 * p1 * x + 2.0 * p2 * y;
        J[0] = rad + 2.0 * x2 * drad + 2.0 * p1 * y + 6.0 * p2 * x;
        J[1] = cross;
        J[2] = cross;
        J[3] = rad + 2.0 * y2 * drad + 6.0 * p1 * y + 2.0 * p2 * x;
    }
}

static tvo_status tvo_radtan_undistort(const double *k, double xd, double yd, double *xo, double *yo)
{
    double x = xd, y = yd, fx_, fy_, J[4];
    double ex, ey, err;
    int it;
    tvo_radtan(k, x, y, &fx_, &fy_, J);
    ex = fx_ - xd;
    ey = fy_ - yd;
    err = ex * ex + ey * ey;
    for (it = 0; it < TVO_CAMERA_MAX_ITERS && err > 0.0; ++it) {
        const double det = J[0] * J[3] - J[1] * J[2];
        double dx, dy, step = 1.0;
        int h;
        if (!(det > 0.0) || !tvo_finite(det))
            return TVO_ERR_NO_CONVERGENCE; /* beyond the fold of the distortion map */
        dx = -(J[3] * ex - J[1] * ey) / det;
        dy = -(-J[2] * ex + J[0] * ey) / det;
        /* Step halving: accept the first step that reduces the residual (at most 10 halvings). */
        for (h = 0; h < 10; ++h, step *= 0.5) {
            double nx = x + step * dx, ny = y + step * dy, px_, py_, nJ[4], nex, ney, nerr;
            tvo_radtan(k, nx, ny, &px_, &py_, nJ);
            nex = px_ - xd;
            ney = py_ - yd;
            nerr = nex * nex + ney * ney;
            if (nerr < err && tvo_finite(nerr)) {
                x = nx;
                y = ny;
                ex = nex;
                ey = ney;
                err = nerr;
                J[0] = nJ[0];
                J[1] = nJ[1];
                J[2] = nJ[2];
                J[3] = nJ[3];
                break;
            }
        }
        if (h == 10)
            break; /* no further decrease possible: at the floating-point floor (or stuck) */
        if (fabs(step * dx) + fabs(step * dy) <= 1e-15 * (1.0 + fabs(x) + fabs(y)))
            break;
    }
    if (!tvo_finite(x) || !tvo_finite(y))
        return TVO_ERR_NOT_FINITE;
    if (!(sqrt(err) <= TVO_CAMERA_UNDISTORT_TOL))
        return TVO_ERR_NO_CONVERGENCE;
    if (!(J[0] * J[3] - J[1] * J[2] > 0.0))
        return TVO_ERR_NO_CONVERGENCE;
    *xo = x;
    *yo = y;
    return TVO_OK;
}

/* ---- equidistant ---------------------------------------------------------------------------- */

static void tvo_equi_theta(const double *k, double th, double *thd, double *dthd)
{
    const double t2 = th * th;
    *thd = th * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
    if (dthd != NULL)
        *dthd = 1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])));
}

static void tvo_equi_distort(const double *k, double x, double y, double *xd, double *yd)
{
    const double r = sqrt(x * x + y * y);
    double s = 1.0;
    if (r > 1e-8) {
        double thd;
        tvo_equi_theta(k, tvo_dm_atan(r), &thd, NULL);
        s = thd / r;
    }
    *xd = x * s;
    *yd = y * s;
}

static tvo_status tvo_equi_undistort(const double *k, double xd, double yd, double *xo, double *yo)
{
    const double thd = sqrt(xd * xd + yd * yd);
    double th, g, dg, err, r;
    int it;
    if (thd == 0.0) {
        *xo = 0.0;
        *yo = 0.0;
        return TVO_OK;
    }
    th = thd < TVO_HALF_PI ? thd : 0.5 * TVO_HALF_PI;
    tvo_equi_theta(k, th, &g, &dg);
    err = fabs(g - thd);
    for (it = 0; it < TVO_CAMERA_MAX_ITERS && err > 0.0; ++it) {
        double d, step = 1.0;
        int h;
        if (!(dg > 0.0))
            return TVO_ERR_NO_CONVERGENCE;
        d = -(g - thd) / dg;
        for (h = 0; h < 10; ++h, step *= 0.5) {
            double nt = th + step * d, ng, ndg;
            if (!(nt >= 0.0 && nt < TVO_HALF_PI))
                continue;
            tvo_equi_theta(k, nt, &ng, &ndg);
            if (fabs(ng - thd) < err) {
                th = nt;
                g = ng;
                dg = ndg;
                err = fabs(ng - thd);
                break;
            }
        }
        if (h == 10)
            break;
        if (fabs(step * d) <= 1e-16 * (1.0 + th))
            break;
    }
    if (!(err <= TVO_CAMERA_UNDISTORT_TOL) || !(dg > 0.0) || !(th < TVO_HALF_PI))
        return TVO_ERR_NO_CONVERGENCE;
    r = tvo_dm_tan(th);
    if (!tvo_finite(r))
        return TVO_ERR_NO_CONVERGENCE;
    *xo = xd * (r / thd);
    *yo = yd * (r / thd);
    if (!tvo_finite(*xo) || !tvo_finite(*yo))
        return TVO_ERR_NOT_FINITE;
    return TVO_OK;
}

/* ---- public --------------------------------------------------------------------------------- */

static tvo_status tvo_undistort_one(const tvo_camera *cam, double u, double v, tvo_point2d *out)
{
    double xd, yd, x = 0.0, y = 0.0;
    tvo_status st = TVO_OK;
    if (!tvo_finite(u) || !tvo_finite(v))
        return TVO_ERR_NOT_FINITE;
    xd = (u - cam->cx) / cam->fx;
    yd = (v - cam->cy) / cam->fy;
    switch (cam->model) {
    case TVO_DIST_RADTAN:
        st = tvo_radtan_undistort(cam->k, xd, yd, &x, &y);
        break;
    case TVO_DIST_EQUIDISTANT:
        st = tvo_equi_undistort(cam->k, xd, yd, &x, &y);
        break;
    default:
        x = xd;
        y = yd;
        break;
    }
    if (st != TVO_OK)
        return st;
    if (!tvo_finite(x) || !tvo_finite(y))
        return TVO_ERR_NOT_FINITE;
    out->x = x;
    out->y = y;
    return TVO_OK;
}

static tvo_status tvo_distort_one(const tvo_camera *cam, const tvo_point2d *xn, double *u, double *v)
{
    double xd = xn->x, yd = xn->y;
    if (!tvo_finite(xd) || !tvo_finite(yd))
        return TVO_ERR_NOT_FINITE;
    if (cam->model == TVO_DIST_RADTAN)
        tvo_radtan(cam->k, xn->x, xn->y, &xd, &yd, NULL);
    else if (cam->model == TVO_DIST_EQUIDISTANT)
        tvo_equi_distort(cam->k, xn->x, xn->y, &xd, &yd);
    *u = cam->fx * xd + cam->cx;
    *v = cam->fy * yd + cam->cy;
    if (!tvo_finite(*u) || !tvo_finite(*v))
        return TVO_ERR_NOT_FINITE;
    return TVO_OK;
}

tvo_status tvo_camera_undistort(const tvo_camera *cam, const tvo_point2f *px, tvo_point2d *xn, uint8_t *ok,
                                int32_t n)
{
    int32_t i;
    tvo_status st = tvo_camera_check(cam);
    if (st != TVO_OK)
        return st;
    if (n < 0)
        return TVO_ERR_ARG;
    if (n > 0 && (px == NULL || xn == NULL))
        return TVO_ERR_NULL;
    for (i = 0; i < n; ++i) {
        st = tvo_undistort_one(cam, (double)px[i].x, (double)px[i].y, &xn[i]);
        if (ok != NULL) {
            ok[i] = (uint8_t)(st == TVO_OK);
            if (st != TVO_OK) {
                xn[i].x = 0.0;
                xn[i].y = 0.0;
            }
        } else if (st != TVO_OK) {
            return st;
        }
    }
    return TVO_OK;
}

tvo_status tvo_camera_distort(const tvo_camera *cam, const tvo_point2d *xn, tvo_point2f *px, int32_t n)
{
    int32_t i;
    tvo_status st = tvo_camera_check(cam);
    if (st != TVO_OK)
        return st;
    if (n < 0)
        return TVO_ERR_ARG;
    if (n > 0 && (px == NULL || xn == NULL))
        return TVO_ERR_NULL;
    for (i = 0; i < n; ++i) {
        double u, v;
        st = tvo_distort_one(cam, &xn[i], &u, &v);
        if (st != TVO_OK)
            return st;
        if (!(fabs(u) <= FLT_MAX) || !(fabs(v) <= FLT_MAX))
            return TVO_ERR_NOT_FINITE;
        px[i].x = (float)u;
        px[i].y = (float)v;
    }
    return TVO_OK;
}

tvo_status tvo_camera_undistort_point(const tvo_camera *cam, double u, double v, tvo_point2d *xn)
{
    tvo_status st = tvo_camera_check(cam);
    if (st != TVO_OK)
        return st;
    if (xn == NULL)
        return TVO_ERR_NULL;
    return tvo_undistort_one(cam, u, v, xn);
}

tvo_status tvo_camera_distort_point(const tvo_camera *cam, const tvo_point2d *xn, double *u, double *v)
{
    tvo_status st = tvo_camera_check(cam);
    if (st != TVO_OK)
        return st;
    if (xn == NULL || u == NULL || v == NULL)
        return TVO_ERR_NULL;
    return tvo_distort_one(cam, xn, u, v);
}

#if TVO_WITH_LENS
#include "tinyvo/camera_impl.h"

void tvo_camera_radtan(const double *k, double x, double y, double *xd, double *yd, double *J)
{
    tvo_radtan(k, x, y, xd, yd, J);
}
#endif
