/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: small shared value types. */
#ifndef TINYVO_TYPES_H
#define TINYVO_TYPES_H

#include <stddef.h>
#include <stdint.h>
#include "tinyvo/options.h"
#include "tinyvo/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A pixel position: x to the right, y down, origin at the centre of the top-left pixel (OpenCV's
 * convention), in pixels of the image it refers to. */
typedef struct tvo_point2f {
    float x;
    float y;
} tvo_point2f;

/* A point in normalised (undistorted, focal length 1) or metric 2D coordinates. */
typedef struct tvo_point2d {
    double x;
    double y;
} tvo_point2d;

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_TYPES_H */
