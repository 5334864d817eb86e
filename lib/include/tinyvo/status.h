/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the one status enum shared by every module.
 *
 * Functions that can fail return tvo_status: TVO_OK (0) on success, a negative code otherwise.
 * Library code never aborts, exits or prints; it returns one of these. */
#ifndef TINYVO_STATUS_H
#define TINYVO_STATUS_H

#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum tvo_status {
    TVO_OK = 0,
    TVO_ERR_NULL = -1,           /* a required pointer argument is NULL */
    TVO_ERR_ARG = -2,            /* an argument is out of its documented range */
    TVO_ERR_SIZE = -3,           /* an image size, stride or count is invalid */
    TVO_ERR_NO_MEMORY = -4,      /* caller-provided memory or capacity is too small */
    TVO_ERR_DEGENERATE = -5,     /* input is geometrically degenerate (collinear, duplicated, ...) */
    TVO_ERR_NOT_FINITE = -6,     /* a NaN or infinite value was given or would be produced */
    TVO_ERR_TOO_FEW = -7,        /* too few points/correspondences for the requested operation */
    TVO_ERR_NO_CONVERGENCE = -8, /* an iterative method did not converge within its bound */
    TVO_ERR_FORMAT = -9,         /* malformed file or buffer contents (magic, layout, syntax) */
    TVO_ERR_VERSION = -10,       /* unsupported file format version */
    TVO_ERR_CRC = -11,           /* checksum mismatch */
    TVO_ERR_RANGE = -12,         /* an offset, index or value lies outside its valid range */
    TVO_ERR_UNSUPPORTED = -13,   /* valid but unsupported request (model, format, feature) */
    TVO_ERR_STATE = -14,         /* call made in the wrong state (not initialised, ...) */
    TVO_ERR_IO = -15,            /* an I/O error (port layer only) */
    TVO_ERR_NOT_FOUND = -16,     /* a file, key or device does not exist (port layer only) */
    TVO_ERR_BUSY = -17,          /* a device is busy (port layer only) */
    TVO_ERR_TIMEOUT = -18,       /* a wait timed out (port layer only) */
    TVO_ERR_AGAIN = -19,         /* try again: no data available yet (port layer only) */
    TVO_ERR_DEVICE_LOST = -20,   /* the device disappeared (port layer only) */
    TVO_ERR_MISMATCH = -21       /* two inputs that must agree do not (model vs features, ...) */
} tvo_status;

/* A static English description of a status code ("ok", "null pointer", ...). Never NULL. */
TVO_API const char *tvo_status_str(tvo_status status);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_STATUS_H */
