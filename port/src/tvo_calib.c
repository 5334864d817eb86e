/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo port: calibration import (see tinyvo/port/calib.h). */
#include "tinyvo/port/calib.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tvo_yaml.h"

/* Largest |coordinate| of an extrinsic translation, metres (as TVO_EUROC_MAX_COORD). */
#define TVO_CALIB_MAX_COORD 1e9

static void tvo_calib_err(char *err, size_t err_size, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    if (err != NULL && err_size > 0)
        vsnprintf(err, err_size, fmt, ap);
    va_end(ap);
}

const char *tvo_calib_format_name(tvo_calib_format format)
{
    switch (format) {
    case TVO_CALIB_AUTO:
        return "auto";
    case TVO_CALIB_EUROC:
        return "euroc";
    case TVO_CALIB_KALIBR_CAMCHAIN:
        return "kalibr-camchain";
    case TVO_CALIB_KALIBR:
        return "kalibr";
    case TVO_CALIB_OPENCV:
        return "opencv";
    case TVO_CALIB_ROS:
        return "ros";
    default:
        return "unknown";
    }
}

/* The value of node i for a message: at most 40 bytes. */
#define TVO_SHOWN(doc, i) \
    (int)(strlen(tvo_yaml_value(doc, i)) > 40 ? 40 : strlen(tvo_yaml_value(doc, i))), tvo_yaml_value(doc, i)

/* Distortion model names -> the core's model; -1 for a name the core cannot represent. */
static int tvo_calib_dist_name(const char *s)
{
    if (!strcmp(s, "radial-tangential") || !strcmp(s, "radtan") || !strcmp(s, "plumb_bob"))
        return TVO_DIST_RADTAN;
    if (!strcmp(s, "equidistant") || !strcmp(s, "equi") || !strcmp(s, "fisheye"))
        return TVO_DIST_EQUIDISTANT;
    if (!strcmp(s, "none"))
        return TVO_DIST_NONE;
    return -1;
}

/* What a refused Kalibr camera_model is, for the message. */
static const char *tvo_calib_model_what(const char *s)
{
    if (!strcmp(s, "omni"))
        return " (Kalibr's unified omnidirectional model)";
    if (!strcmp(s, "ds"))
        return " (Kalibr's double sphere model)";
    if (!strcmp(s, "eucm"))
        return " (Kalibr's extended unified model)";
    return "";
}

/* The coefficients with the core's model. n: how many were given. The 8/12/14-coefficient OpenCV
 * models are the 5-coefficient one when the extra coefficients are zero. */
static tvo_status tvo_calib_set_dist(tvo_camera *cam, int model, const double *v, int n, int line,
                                     const char *key, const char *model_name, char *err, size_t err_size)
{
    int i;
    if (model == TVO_DIST_RADTAN && (n == 8 || n == 12 || n == 14)) {
        for (i = 5; i < n; ++i)
            if (v[i] != 0.0) {
                tvo_calib_err(err, err_size,
                              "line %d: %s: the %s model (%d coefficients) with non-zero k4.. is not "
                              "supported "
                              "(only k1 k2 p1 p2 k3)",
                              line, key, n == 8 ? "rational" : (n == 12 ? "thin-prism" : "tilted"), n);
                return TVO_ERR_UNSUPPORTED;
            }
        n = 5;
    }
    if (model == TVO_DIST_RADTAN && n != 4 && n != 5) {
        tvo_calib_err(err, err_size, "line %d: %s needs 4 or 5 %s, got %d", line, model_name, key, n);
        return TVO_ERR_FORMAT;
    }
    if (model == TVO_DIST_EQUIDISTANT && n != 4) {
        tvo_calib_err(err, err_size, "line %d: equidistant needs 4 %s, got %d", line, key, n);
        return TVO_ERR_FORMAT;
    }
    if (model == TVO_DIST_NONE) {
        for (i = 0; i < n; ++i)
            if (v[i] != 0.0) {
                tvo_calib_err(err, err_size, "line %d: distortion_model none with non-zero coefficients",
                              line);
                return TVO_ERR_FORMAT;
            }
        n = 0;
    }
    cam->model = (tvo_distortion)model;
    memset(cam->k, 0, sizeof cam->k);
    for (i = 0; i < n; ++i)
        cam->k[i] = v[i];
    return TVO_OK;
}

/* A 4x4 rigid transform from 16 numbers v (row-major) named key: last row 0 0 0 1, translation
 * within range, rotation block orthonormal to 1e-3 with det > 0; re-orthonormalised. */
static tvo_status tvo_calib_rigid(const double *v, int line, const char *key, tvo_pose *T, char *err,
                                  size_t err_size)
{
    double d;
    if (fabs(v[12]) > 1e-6 || fabs(v[13]) > 1e-6 || fabs(v[14]) > 1e-6 || fabs(v[15] - 1.0) > 1e-6) {
        tvo_calib_err(err, err_size, "line %d: %s: last row must be [0, 0, 0, 1]", line, key);
        return TVO_ERR_FORMAT;
    }
    if (!(fabs(v[3]) <= TVO_CALIB_MAX_COORD && fabs(v[7]) <= TVO_CALIB_MAX_COORD &&
          fabs(v[11]) <= TVO_CALIB_MAX_COORD)) {
        tvo_calib_err(err, err_size, "line %d: %s: translation beyond +-%g m", line, key,
                      TVO_CALIB_MAX_COORD);
        return TVO_ERR_FORMAT;
    }
    *T = tvo_pose_from_matrix(v);
    d = T->R[0] * (T->R[4] * T->R[8] - T->R[5] * T->R[7]) -
            T->R[1] * (T->R[3] * T->R[8] - T->R[5] * T->R[6]) +
            T->R[2] * (T->R[3] * T->R[7] - T->R[4] * T->R[6]);
    if (!(tvo_rot_orthogonality_error(T->R) < 1e-3) || !(d > 0.0)) {
        tvo_calib_err(err, err_size, "line %d: %s: the rotation block is not a rotation", line, key);
        return TVO_ERR_FORMAT;
    }
    tvo_rot_orthonormalize(T->R);
    return TVO_OK;
}

/* An integer image size in 1..TVO_MAX_IMAGE_DIM. */
static int tvo_calib_dim(double v)
{
    return v == floor(v) && v >= 1 && v <= TVO_MAX_IMAGE_DIM;
}

/* ---- EuRoC / Kalibr: one camera's keys under parent (-1: the top level) --------------------------- */

static tvo_status tvo_calib_asl_block(const tvo_yaml_doc *y, int parent, tvo_calib_format fmt, tvo_calib *c,
                                      char *err, size_t err_size)
{
    const char *where = parent >= 0 ? tvo_yaml_key(y, parent) : "";
    const char *in = parent >= 0 ? " in " : "";
    tvo_camera *cam = &c->camera;
    double v[16];
    int n, i, en;
    tvo_status st;

    en = tvo_yaml_find(y, parent, "camera_model", 0);
    if (en >= 0 && !tvo_yaml_is(y, en, "pinhole")) {
        tvo_calib_err(err, err_size, "line %d: camera_model '%.*s'%s not supported (only pinhole)",
                      y->node[en].line, TVO_SHOWN(y, en), tvo_calib_model_what(tvo_yaml_value(y, en)));
        return TVO_ERR_UNSUPPORTED;
    }
    en = tvo_yaml_find(y, parent, "intrinsics", 0);
    if (en < 0) {
        tvo_calib_err(err, err_size, "missing key 'intrinsics'%s%s", in, where);
        return TVO_ERR_FORMAT;
    }
    st = tvo_yaml_numbers(y, en, v, 16, &n, err, err_size);
    if (st != TVO_OK)
        return st;
    if (n != 4) {
        tvo_calib_err(err, err_size, "line %d: intrinsics: expected 4 numbers [fu, fv, cu, cv], got %d",
                      y->node[en].line, n);
        return TVO_ERR_FORMAT;
    }
    cam->fx = v[0];
    cam->fy = v[1];
    cam->cx = v[2];
    cam->cy = v[3];

    en = tvo_yaml_find(y, parent, "resolution", 0);
    if (en < 0) {
        tvo_calib_err(err, err_size, "missing key 'resolution'%s%s", in, where);
        return TVO_ERR_FORMAT;
    }
    st = tvo_yaml_numbers(y, en, v, 16, &n, err, err_size);
    if (st != TVO_OK)
        return st;
    if (n != 2 || !tvo_calib_dim(v[0]) || !tvo_calib_dim(v[1])) {
        tvo_calib_err(err, err_size, "line %d: resolution: expected [width, height], integers in 1..%d",
                      y->node[en].line, TVO_MAX_IMAGE_DIM);
        return TVO_ERR_FORMAT;
    }
    cam->width = (int32_t)v[0];
    cam->height = (int32_t)v[1];

    {
        const int dm = tvo_yaml_find(y, parent, "distortion_model", 0);
        const int dc1 = tvo_yaml_find(y, parent, "distortion_coefficients", 0);
        const int dc2 = tvo_yaml_find(y, parent, "distortion_coeffs", 0);
        const int dc = dc1 >= 0 ? dc1 : dc2;
        const char *key = (dc2 >= 0 && dc1 < 0) || (dc1 < 0 && fmt != TVO_CALIB_EUROC)
                ? "distortion_coeffs"
                : "distortion_coefficients";
        int model;
        if (dc1 >= 0 && dc2 >= 0) {
            tvo_calib_err(err, err_size, "line %d: both distortion_coefficients and distortion_coeffs",
                          y->node[dc2].line);
            return TVO_ERR_FORMAT;
        }
        n = 0;
        if (dc >= 0) {
            st = tvo_yaml_numbers(y, dc, v, 16, &n, err, err_size);
            if (st != TVO_OK)
                return st;
        }
        if (dm < 0) {
            model = n > 0 ? TVO_DIST_RADTAN : TVO_DIST_NONE;
        } else {
            model = tvo_calib_dist_name(tvo_yaml_value(y, dm));
            if (model < 0) {
                tvo_calib_err(err, err_size,
                              "line %d: distortion_model '%.*s' not supported (radtan, equidistant or none)",
                              y->node[dm].line, TVO_SHOWN(y, dm));
                return TVO_ERR_UNSUPPORTED;
            }
        }
        st = tvo_calib_set_dist(cam, model, v, n,
                                dc >= 0 ? y->node[dc].line : (dm >= 0 ? y->node[dm].line : 0), key,
                                "radial-tangential", err, err_size);
        if (st != TVO_OK)
            return st;
    }

    en = tvo_yaml_find(y, parent, "rate_hz", 0);
    if (en >= 0) {
        if (!tvo_yaml_scalar_double(y, en, &c->rate_hz) || !(c->rate_hz > 0.0)) {
            tvo_calib_err(err, err_size, "line %d: rate_hz: expected a positive number", y->node[en].line);
            return TVO_ERR_FORMAT;
        }
    }

    /* extrinsics: EuRoC T_BS {data}, Kalibr T_cam_imu (inverted) or T_imu_cam */
    {
        const int tbs = tvo_yaml_find(y, parent, "T_BS", 0);
        const int tci = tvo_yaml_find(y, parent, "T_cam_imu", 0);
        const int tic = tvo_yaml_find(y, parent, "T_imu_cam", 0);
        int src = -1, data = -1;
        const char *key = "T_BS";
        if (tbs >= 0) {
            src = tbs;
            data = tvo_yaml_find(y, tbs, "data", 0);
            if (data < 0 && y->node[tbs].nchild == 0 && y->node[tbs].vlen > 0)
                data = tbs; /* T_BS: [16 numbers] */
            if (data < 0) {
                tvo_calib_err(err, err_size, "missing key 'T_BS' with 'data: [16 numbers]'");
                return TVO_ERR_FORMAT;
            }
        } else if (tci >= 0) {
            src = data = tci;
            key = "T_cam_imu";
        } else if (tic >= 0) {
            src = data = tic;
            key = "T_imu_cam";
        } else if (fmt == TVO_CALIB_EUROC) {
            tvo_calib_err(err, err_size, "missing key 'T_BS' with 'data: [16 numbers]'");
            return TVO_ERR_FORMAT;
        }
        if (src >= 0) {
            st = tvo_yaml_numbers(y, data, v, 16, &n, err, err_size);
            if (st != TVO_OK)
                return st;
            if (n != 16) {
                tvo_calib_err(err, err_size, "line %d: %s%s: expected 16 numbers, got %d", y->node[data].line,
                              key, data != src ? " data" : "", n);
                return TVO_ERR_FORMAT;
            }
            if (src == tbs) {
                const char *dims[2] = {"rows", "cols"};
                for (i = 0; i < 2; ++i) {
                    const int d = tvo_yaml_find(y, tbs, dims[i], 0);
                    double dv;
                    if (d >= 0 && (!tvo_yaml_scalar_double(y, d, &dv) || dv != 4.0)) {
                        tvo_calib_err(err, err_size, "line %d: T_BS %s must be 4", y->node[d].line, dims[i]);
                        return TVO_ERR_FORMAT;
                    }
                }
            }
            st = tvo_calib_rigid(v, y->node[data].line, key, &c->T_BS, err, err_size);
            if (st != TVO_OK)
                return st;
            if (src == tci)
                c->T_BS = tvo_pose_inverse(&c->T_BS);
            c->has_T_BS = 1;
        }
    }
    return TVO_OK;
}

/* ---- OpenCV FileStorage / ROS camera_info ------------------------------------------------------- */

/* A matrix node: its numbers (child "data", or its own flow value), with rows x cols checked. */
static tvo_status tvo_calib_matrix(const tvo_yaml_doc *y, int m, double *v, int max, int *n, char *err,
                                   size_t err_size)
{
    const int data = y->node[m].nchild > 0 ? tvo_yaml_find(y, m, "data", 1) : m;
    const int rows = tvo_yaml_find(y, m, "rows", 1), cols = tvo_yaml_find(y, m, "cols", 1);
    double r = -1, c = -1;
    tvo_status st;
    if (data < 0) {
        tvo_calib_err(err, err_size, "line %d: %s: missing key 'data'", y->node[m].line, tvo_yaml_key(y, m));
        return TVO_ERR_FORMAT;
    }
    st = tvo_yaml_numbers(y, data, v, max, n, err, err_size);
    if (st != TVO_OK)
        return st;
    if ((rows >= 0 && (!tvo_yaml_scalar_double(y, rows, &r) || r != floor(r) || r < 0)) ||
        (cols >= 0 && (!tvo_yaml_scalar_double(y, cols, &c) || c != floor(c) || c < 0)) ||
        (rows >= 0 && cols >= 0 && r * c != (double)*n)) {
        tvo_calib_err(err, err_size, "line %d: %s: rows x cols does not match the %d data values",
                      y->node[m].line, tvo_yaml_key(y, m), *n);
        return TVO_ERR_FORMAT;
    }
    return TVO_OK;
}

static tvo_status tvo_calib_opencv(const tvo_yaml_doc *y, int km, tvo_calib *c, char *err, size_t err_size)
{
    tvo_camera *cam = &c->camera;
    double v[16], K[9];
    int n, i, model;
    tvo_status st;
    const char *dims[2] = {"image_width", "image_height"};
    for (i = 0; i < 2; ++i) {
        const int d = tvo_yaml_find(y, -1, dims[i], 1);
        double dv;
        if (d < 0) {
            tvo_calib_err(err, err_size, "missing key '%s' (the calibration's image size)", dims[i]);
            return TVO_ERR_FORMAT;
        }
        if (!tvo_yaml_scalar_double(y, d, &dv) || !tvo_calib_dim(dv)) {
            tvo_calib_err(err, err_size, "line %d: %s: expected an integer in 1..%d", y->node[d].line,
                          dims[i], TVO_MAX_IMAGE_DIM);
            return TVO_ERR_FORMAT;
        }
        if (i == 0)
            cam->width = (int32_t)dv;
        else
            cam->height = (int32_t)dv;
    }
    st = tvo_calib_matrix(y, km, K, 9, &n, err, err_size);
    if (st != TVO_OK)
        return st;
    if (n != 9) {
        tvo_calib_err(err, err_size, "line %d: camera_matrix: expected 9 numbers (3x3), got %d",
                      y->node[km].line, n);
        return TVO_ERR_FORMAT;
    }
    if (K[3] != 0.0 || K[6] != 0.0 || K[7] != 0.0 || K[8] != 1.0) {
        tvo_calib_err(err, err_size, "line %d: camera_matrix: expected [fx 0 cx; 0 fy cy; 0 0 1]",
                      y->node[km].line);
        return TVO_ERR_FORMAT;
    }
    if (K[1] != 0.0) {
        tvo_calib_err(err, err_size,
                      "line %d: camera_matrix: a skew of %g is not supported (the core's pinhole has none)",
                      y->node[km].line, K[1]);
        return TVO_ERR_UNSUPPORTED;
    }
    cam->fx = K[0];
    cam->cx = K[2];
    cam->fy = K[4];
    cam->cy = K[5];

    {
        const int dc = tvo_yaml_find(y, -1, "distortion_coefficients", 1);
        const int dm = tvo_yaml_find(y, -1, "distortion_model", 1);
        const int fe = tvo_yaml_find(y, -1, "fisheye_model", 1);
        const int line = dc >= 0 ? y->node[dc].line : (dm >= 0 ? y->node[dm].line : 0);
        n = 0;
        if (dc >= 0) {
            st = tvo_calib_matrix(y, dc, v, 16, &n, err, err_size);
            if (st != TVO_OK)
                return st;
        }
        if (dm >= 0) {
            const char *s = tvo_yaml_value(y, dm);
            model = tvo_calib_dist_name(s);
            if (!strcmp(s, "rational_polynomial")) {
                model = TVO_DIST_RADTAN;
                if (n != 8) {
                    tvo_calib_err(err, err_size,
                                  "line %d: rational_polynomial needs 8 distortion_coefficients, got %d",
                                  line, n);
                    return TVO_ERR_FORMAT;
                }
                for (i = 5; i < 8; ++i)
                    if (v[i] != 0.0) {
                        tvo_calib_err(err, err_size,
                                      "line %d: distortion_model 'rational_polynomial' with non-zero k4 k5 "
                                      "k6 is not "
                                      "supported (only k1 k2 p1 p2 k3)",
                                      y->node[dm].line);
                        return TVO_ERR_UNSUPPORTED;
                    }
            } else if (model < 0) {
                tvo_calib_err(err, err_size,
                              "line %d: distortion_model '%.*s' not supported (plumb_bob, equidistant, or "
                              "rational_polynomial with k4..k6 zero)",
                              y->node[dm].line, TVO_SHOWN(y, dm));
                return TVO_ERR_UNSUPPORTED;
            }
        } else if (fe >= 0) {
            double f;
            if (!tvo_yaml_scalar_double(y, fe, &f)) {
                tvo_calib_err(err, err_size, "line %d: fisheye_model: expected 0 or 1", y->node[fe].line);
                return TVO_ERR_FORMAT;
            }
            model = f != 0.0 ? TVO_DIST_EQUIDISTANT : (n > 0 ? TVO_DIST_RADTAN : TVO_DIST_NONE);
        } else {
            model = n > 0 ? TVO_DIST_RADTAN : TVO_DIST_NONE;
        }
        if (model == TVO_DIST_RADTAN && n != 4 && n != 5 && n != 8 && n != 12 && n != 14) {
            tvo_calib_err(err, err_size,
                          "line %d: distortion_coefficients: expected 4, 5, 8, 12 or 14 numbers, got %d",
                          line, n);
            return TVO_ERR_FORMAT;
        }
        st = tvo_calib_set_dist(cam, model, v, n, line, "distortion_coefficients", "plumb_bob", err,
                                err_size);
        if (st != TVO_OK)
            return st;
    }
    return TVO_OK;
}

/* ---- detection ------------------------------------------------------------------------------------ */

/* "cam" followed by one or more digits. */
static int tvo_calib_is_cam_name(const char *s)
{
    if (strncmp(s, "cam", 3) != 0 || s[3] == '\0')
        return 0;
    for (s += 3; *s; ++s)
        if (*s < '0' || *s > '9')
            return 0;
    return 1;
}

/* Top-level camchain entries: camN mappings holding intrinsics or camera_model. */
static int tvo_calib_is_cam_entry(const tvo_yaml_doc *y, int i)
{
    return y->node[i].parent == -1 && tvo_calib_is_cam_name(tvo_yaml_key(y, i)) && y->node[i].nchild > 0 &&
            (tvo_yaml_find(y, i, "intrinsics", 0) >= 0 || tvo_yaml_find(y, i, "camera_model", 0) >= 0);
}

static tvo_status tvo_calib_camchain(const tvo_yaml_doc *y, const char *camera, tvo_calib *c, char *err,
                                     size_t err_size)
{
    char names[160];
    size_t used = 0;
    int i, pick = -1;
    for (i = 0; i < y->count; ++i)
        if (tvo_calib_is_cam_entry(y, i) && !strcmp(tvo_yaml_key(y, i), camera))
            pick = i;
    if (pick < 0) {
        names[0] = '\0';
        for (i = 0; i < y->count; ++i)
            if (tvo_calib_is_cam_entry(y, i)) {
                int w = snprintf(names + used, sizeof names - used, "%s%s", used ? ", " : "",
                                 tvo_yaml_key(y, i));
                if (w < 0 || (size_t)w >= sizeof names - used)
                    break;
                used += (size_t)w;
            }
        tvo_calib_err(err, err_size, "no camera '%s' in the camchain (it has %s)", camera,
                      names[0] ? names : "none");
        return TVO_ERR_NOT_FOUND;
    }
    snprintf(c->camera_name, sizeof c->camera_name, "%s", camera);
    return tvo_calib_asl_block(y, pick, TVO_CALIB_KALIBR_CAMCHAIN, c, err, err_size);
}

tvo_status tvo_calib_parse(const char *text, size_t len, tvo_calib_format format, const char *camera,
                           tvo_calib *out, char *err, size_t err_size)
{
    tvo_yaml_doc y;
    tvo_calib c;
    tvo_status st;
    int i, km;
    if (err != NULL && err_size > 0)
        err[0] = '\0';
    if ((text == NULL && len > 0) || out == NULL) {
        tvo_calib_err(err, err_size, "NULL argument");
        return TVO_ERR_NULL;
    }
    if ((int)format < TVO_CALIB_AUTO || (int)format > TVO_CALIB_ROS) {
        tvo_calib_err(err, err_size, "unknown calibration format %d", (int)format);
        return TVO_ERR_ARG;
    }
    if (camera != NULL && (camera[0] == '\0' || strlen(camera) >= TVO_CALIB_MAX_NAME)) {
        tvo_calib_err(err, err_size, "bad camera name");
        return TVO_ERR_ARG;
    }
    st = tvo_yaml_load(&y, text, len, err, err_size);
    if (st != TVO_OK) {
        tvo_yaml_free(&y);
        return st;
    }
    memset(&c, 0, sizeof c);
    c.T_BS = tvo_pose_identity();
    km = tvo_yaml_find(&y, -1, "camera_matrix", 1);
    if (format == TVO_CALIB_AUTO) {
        int chain = 0;
        for (i = 0; i < y.count && !chain; ++i)
            chain = tvo_calib_is_cam_entry(&y, i);
        if (km >= 0) {
            format = (y.node[km].tagged || (len >= 6 && memcmp(text, "%YAML:", 6) == 0)) ? TVO_CALIB_OPENCV
                                                                                         : TVO_CALIB_ROS;
        } else if (chain) {
            format = TVO_CALIB_KALIBR_CAMCHAIN;
        } else if (tvo_yaml_find(&y, -1, "intrinsics", 0) >= 0) {
            format = (tvo_yaml_find(&y, -1, "T_BS", 0) >= 0 ||
                      tvo_yaml_find(&y, -1, "distortion_coefficients", 0) >= 0 ||
                      tvo_yaml_find(&y, -1, "sensor_type", 0) >= 0)
                    ? TVO_CALIB_EUROC
                    : TVO_CALIB_KALIBR;
        } else if (tvo_yaml_find(&y, -1, "model_type", 0) >= 0 &&
                   tvo_yaml_find(&y, -1, "projection_parameters", 0) >= 0) {
            tvo_calib_err(err, err_size,
                          "a camodocal (VINS) camera file is not one of the formats read "
                          "(EuRoC, Kalibr, OpenCV, ROS camera_info)");
            st = TVO_ERR_UNSUPPORTED;
            goto done;
        } else {
            tvo_calib_err(err, err_size,
                          "not a calibration file tinyvo reads: no 'intrinsics', 'camera_matrix' "
                          "or 'cam0' key (EuRoC, Kalibr, OpenCV, ROS camera_info)");
            st = TVO_ERR_FORMAT;
            goto done;
        }
    }
    if (camera != NULL && format != TVO_CALIB_KALIBR_CAMCHAIN) {
        tvo_calib_err(err, err_size,
                      "a camera name ('%s') applies to Kalibr camchains; this is a %s file with one camera",
                      camera, tvo_calib_format_name(format));
        st = TVO_ERR_ARG;
        goto done;
    }
    c.format = format;
    switch (format) {
    case TVO_CALIB_OPENCV:
    case TVO_CALIB_ROS:
        if (km < 0) {
            tvo_calib_err(err, err_size, "missing key 'camera_matrix'");
            st = TVO_ERR_FORMAT;
            goto done;
        }
        st = tvo_calib_opencv(&y, km, &c, err, err_size);
        break;
    case TVO_CALIB_KALIBR_CAMCHAIN:
        st = tvo_calib_camchain(&y, camera != NULL ? camera : "cam0", &c, err, err_size);
        break;
    default:
        st = tvo_calib_asl_block(&y, -1, format, &c, err, err_size);
        break;
    }
    if (st != TVO_OK)
        goto done;
    st = tvo_camera_check(&c.camera);
    if (st != TVO_OK) {
        tvo_calib_err(err, err_size, "invalid camera (%s): need fu, fv > 0 and finite values",
                      tvo_status_str(st));
        st = TVO_ERR_FORMAT;
        goto done;
    }
    *out = c;
done:
    tvo_yaml_free(&y);
    return st;
}

tvo_status tvo_calib_load(const char *path, const char *camera, tvo_calib *out, char *err, size_t err_size)
{
    FILE *f;
    char *buf;
    size_t n;
    tvo_status st;
    if (err != NULL && err_size > 0)
        err[0] = '\0';
    if (path == NULL || out == NULL) {
        tvo_calib_err(err, err_size, "NULL argument");
        return TVO_ERR_NULL;
    }
    errno = 0;
    f = fopen(path, "rb");
    if (f == NULL) {
        int e = errno;
        tvo_calib_err(err, err_size, "%s: %s", path, strerror(e));
        return (e == ENOENT || e == ENOTDIR) ? TVO_ERR_NOT_FOUND : TVO_ERR_IO;
    }
    buf = (char *)malloc(TVO_CALIB_MAX_FILE + 1);
    if (buf == NULL) {
        fclose(f);
        tvo_calib_err(err, err_size, "%s: out of memory", path);
        return TVO_ERR_NO_MEMORY;
    }
    n = fread(buf, 1, TVO_CALIB_MAX_FILE + 1, f);
    if (ferror(f)) {
        fclose(f);
        free(buf);
        tvo_calib_err(err, err_size, "%s: read error", path);
        return TVO_ERR_IO;
    }
    fclose(f);
    if (n > TVO_CALIB_MAX_FILE) {
        free(buf);
        tvo_calib_err(err, err_size, "%s: larger than %zu bytes: not a calibration file", path,
                      TVO_CALIB_MAX_FILE);
        return TVO_ERR_FORMAT;
    }
    st = tvo_calib_parse(buf, n, TVO_CALIB_AUTO, camera, out, err, err_size);
    free(buf);
    if (st != TVO_OK && st != TVO_ERR_NULL && err != NULL && err_size > 0) {
        char tmp[512];
        snprintf(tmp, sizeof tmp, "%s", err);
        snprintf(err, err_size, "%s: %s", path, tmp);
    }
    return st;
}
