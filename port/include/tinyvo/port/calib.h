/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo port: camera calibration import from the files calibration tools write.
 *
 * Formats read (docs/calibration.md has an example of each):
 *   EUROC           ASL/EuRoC sensor.yaml: intrinsics [fu, fv, cu, cv], resolution [w, h],
 *                   distortion_model, distortion_coefficients, T_BS {rows, cols, data: 16 numbers},
 *                   rate_hz.
 *   KALIBR_CAMCHAIN Kalibr camchain.yaml / camchain-imucam.yaml: one mapping per camera (cam0, cam1,
 *                   ...) with camera_model, intrinsics, distortion_model, distortion_coeffs,
 *                   resolution, T_cam_imu (4x4 as four rows); the camera is chosen by name.
 *   KALIBR          the same keys at the top level of the file (one camera, no camN mapping);
 *                   T_cam_imu or T_imu_cam if present.
 *   OPENCV          OpenCV FileStorage YAML ("%YAML:1.0"): image_width, image_height,
 *                   camera_matrix and distortion_coefficients as !!opencv-matrix {rows, cols, dt,
 *                   data}; keys matched without regard to case (OpenCV's old sample writes
 *                   Camera_Matrix, image_Width, ...); fisheye_model: 1 selects the equidistant model.
 *   ROS             ROS camera_info YAML (camera_calibration_parsers): image_width, image_height,
 *                   camera_matrix {rows, cols, data}, distortion_model plumb_bob | equidistant |
 *                   rational_polynomial, distortion_coefficients {rows, cols, data}.
 * The YAML subset understood is the one these tools write (port/src/tvo_yaml.h: indentation-nested
 * mappings, block and flow sequences, flow mappings, comments, tags on mapping lines).
 *
 * Camera models: the core (tinyvo/camera.h) represents a pinhole camera without skew with no
 * distortion, radial-tangential (k1 k2 p1 p2 [k3]) or equidistant (k1..k4) distortion. Anything
 * else is refused with TVO_ERR_UNSUPPORTED and a message naming the model: Kalibr omni, ds
 * (double sphere), eucm, fov, the OpenCV rational / thin-prism / tilted models (8, 12, 14
 * coefficients) unless their extra coefficients are all zero (then the 5-coefficient model is the
 * same camera and is used), a non-zero skew, and any distortion_model name not listed here.
 * Distortion model names accepted: radtan, radial-tangential, plumb_bob (radial-tangential);
 * equidistant, equi, fisheye (equidistant); none.
 *
 * Errors: TVO_ERR_FORMAT (malformed or incomplete file: "line N: what" or "missing key 'k'" in err),
 * TVO_ERR_UNSUPPORTED (a model the core cannot represent, or a format that is not one of these:
 * the message names it), TVO_ERR_NOT_FOUND (the chosen camera is not in the camchain: the message
 * lists the ones that are; or a missing file), TVO_ERR_ARG (a camera name given for a single-camera
 * file, or a bad name), TVO_ERR_IO, TVO_ERR_NO_MEMORY. Messages are one English line, truncated to
 * err_size (err may be NULL). The parser never crashes on malformed input (fuzzed:
 * test/fuzz/fuzz_yaml.c). Reentrant; heap memory is used only during a call. */
#ifndef TINYVO_PORT_CALIB_H
#define TINYVO_PORT_CALIB_H

#include <stddef.h>
#include <stdint.h>
#include "tinyvo/camera.h"
#include "tinyvo/export.h"
#include "tinyvo/se3.h"
#include "tinyvo/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum tvo_calib_format {
    TVO_CALIB_AUTO = 0, /* detect from the keys (for tvo_calib_parse's format argument) */
    TVO_CALIB_EUROC = 1,
    TVO_CALIB_KALIBR_CAMCHAIN = 2,
    TVO_CALIB_KALIBR = 3,
    TVO_CALIB_OPENCV = 4,
    TVO_CALIB_ROS = 5
} tvo_calib_format;

/* Longest camera name in a camchain, bytes including the terminator. */
#define TVO_CALIB_MAX_NAME 64
/* Largest file tvo_calib_load reads. */
#define TVO_CALIB_MAX_FILE ((size_t)4 << 20)

typedef struct tvo_calib {
    tvo_camera camera;                    /* checked with tvo_camera_check */
    tvo_calib_format format;              /* the format that was read */
    int has_T_BS;                         /* 1 when the file gives the camera's pose in a body/IMU frame */
    tvo_pose T_BS;                        /* body <- camera: EuRoC T_BS, Kalibr inv(T_cam_imu) or T_imu_cam;
                                 rotation re-orthonormalised; identity when has_T_BS is 0 */
    double rate_hz;                       /* frame rate when the file gives one (EuRoC rate_hz), else 0 */
    char camera_name[TVO_CALIB_MAX_NAME]; /* the camchain entry read ("cam0"), "" for other formats */
} tvo_calib;

/* Parse a calibration file's text[0..len) (no NUL terminator needed).
 * format: TVO_CALIB_AUTO to detect it, or the one expected (a file of another kind then fails with
 * TVO_ERR_FORMAT naming the key that is missing; TVO_CALIB_EUROC also requires T_BS, as a EuRoC
 * sensor.yaml always has one). camera: the camchain entry to read (NULL: "cam0"); must be NULL for
 * the single-camera formats. out is written only on success. */
TVO_API tvo_status tvo_calib_parse(const char *text, size_t len, tvo_calib_format format, const char *camera,
                                   tvo_calib *out, char *err, size_t err_size);

/* Read and parse the file at path (at most TVO_CALIB_MAX_FILE bytes) with format detection. Errors
 * as tvo_calib_parse plus TVO_ERR_NOT_FOUND / TVO_ERR_IO for the file; parse messages are prefixed
 * with "path: ". */
TVO_API tvo_status tvo_calib_load(const char *path, const char *camera, tvo_calib *out, char *err,
                                  size_t err_size);

/* "euroc", "kalibr-camchain", "kalibr", "opencv", "ros", "auto"; "unknown" for other values. */
TVO_API const char *tvo_calib_format_name(tvo_calib_format format);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_PORT_CALIB_H */
