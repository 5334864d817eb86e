/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo port: dataset folders besides EuRoC, read into the sequence object of euroc.h (every
 * tvo_euroc_* query applies: frames, times, paths, camera, rate, ground truth, bad rows; close with
 * tvo_euroc_close).
 *
 * TUM RGB-D (Sturm et al., IROS 2012), a folder such as rgbd_dataset_freiburg1_xyz/:
 *   rgb.txt          "timestamp filename" per frame, timestamp in seconds with a decimal fraction
 *                    (read exactly to the ns), filename relative to the folder ("rgb/<t>.png");
 *                    '#' lines are comments. Required.
 *   rgb/<t>.png      colour frames; tvo_euroc_read_frame / tvo_png_read_gray8 convert them to grey.
 *   groundtruth.txt  "timestamp tx ty tz qx qy qz qw" (seconds, metres, unit quaternion x y z w): the
 *                    pose of the colour camera's optical centre in the world, T_w_c, at about 100 Hz,
 *                    not at frame times (use tvo_euroc_groundtruth_interp). Optional.
 *   The folder holds no calibration: the camera is the caller's, or (camera NULL) the published
 *   intrinsics of the RGB camera named by "freiburg1", "freiburg2" or "freiburg3" in the folder's
 *   name (tvo_tum_camera). T_BS is the identity (ground truth is already the camera's pose).
 *
 * KITTI odometry (Geiger et al., CVPR 2012), a sequence folder such as sequences/06/:
 *   times.txt        one time per frame in seconds ("1.036000e-01"), frame i is image_0/%06d.png.
 *                    Required.
 *   calib.txt        "P0: 12 numbers", the 3x4 projection of the rectified left grey camera
 *                    (fx 0 cx 0 / 0 fy cy 0 / 0 0 1 0); other lines are ignored. Required.
 *   image_0/<i>.png  rectified grey frames; their size (the first one's) is the camera's.
 *   poses            "12 numbers" per line, the row-major 3x4 pose T_w_c of camera 0 at frame i in
 *                    the first frame's camera frame (KITTI's poses/<seq>.txt). The file given, else
 *                    <dir>/poses.txt, else <dir>/../../poses/<name of dir>.txt; none: no ground truth.
 *                    The row count must equal the line count of times.txt.
 *   The camera has no distortion (rectified images); T_BS is the identity.
 *
 * Errors of the openers: TVO_ERR_NULL, TVO_ERR_ARG (path too long), TVO_ERR_NOT_FOUND (a required
 * file missing: the message names it and says what it holds; a poses file given but missing; no
 * camera for a TUM folder), TVO_ERR_FORMAT ("<path>: line N: what"), TVO_ERR_MISMATCH (a given
 * camera's size is not the frames' size: both in the message), TVO_ERR_IO, TVO_ERR_NO_MEMORY; *seq is
 * NULL after an error. flags: 0 or TVO_EUROC_SKIP_BAD_ROWS (malformed rows of rgb.txt / times.txt
 * are skipped and recorded; ground-truth files are always strict). */
#ifndef TINYVO_PORT_DATASET_H
#define TINYVO_PORT_DATASET_H

#include <stddef.h>
#include <stdint.h>
#include "tinyvo/camera.h"
#include "tinyvo/export.h"
#include "tinyvo/port/euroc.h"
#include "tinyvo/se3.h"
#include "tinyvo/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The published calibration of the TUM RGB-D colour camera named in dir's last path component
 * ("freiburg1" / "freiburg2": 640x480 with 5 radial-tangential coefficients; "freiburg3": 640x480, no
 * distortion, the images are undistorted). TVO_ERR_NULL, TVO_ERR_NOT_FOUND (no such name). */
TVO_API tvo_status tvo_tum_camera(const char *dir, tvo_camera *cam);

/* Open a TUM RGB-D folder. camera: the calibration (its size must be the frames'), or NULL for
 * tvo_tum_camera(dir). */
TVO_API tvo_status tvo_tum_open(tvo_euroc **seq, const char *dir, const tvo_camera *camera, unsigned flags,
                                char *err, size_t err_size);

/* Open a KITTI odometry sequence folder. poses: the poses file, or NULL to look for one. */
TVO_API tvo_status tvo_kitti_open(tvo_euroc **seq, const char *dir, const char *poses, unsigned flags,
                                  char *err, size_t err_size);

/* ---- parsers on memory buffers (also for fuzzing); capacity semantics as tvo_euroc_parse_groundtruth */

/* TUM groundtruth.txt: fields separated by blanks (or ','), the first 8 required: t [s] tx ty tz qx qy
 * qz qw; quaternion norm 1 +- 0.01 (normalised); strictly increasing times; positions within
 * +-TVO_EUROC_MAX_COORD. Rows come out as tvo_euroc_gt_row (t in ns, q reordered to w x y z). */
TVO_API tvo_status tvo_tum_parse_groundtruth(const char *text, size_t len, tvo_euroc_gt_row *rows,
                                             int32_t capacity, int32_t *count, char *err, size_t err_size);

/* KITTI calib.txt: the 12 numbers of the "P0:" line into P0 (row-major 3x4). Checked: fx, fy > 0,
 * no skew, last row 0 0 1 0, no translation column (P0[3] = P0[7] = 0). */
TVO_API tvo_status tvo_kitti_parse_calib(const char *text, size_t len, double P0[12], char *err,
                                         size_t err_size);

/* A KITTI poses file: 12 numbers per line (blank lines skipped), each a rigid 3x4 T_w_c (rotation
 * orthonormal to 1e-3, re-orthonormalised; translation within +-TVO_EUROC_MAX_COORD). */
TVO_API tvo_status tvo_kitti_parse_poses(const char *text, size_t len, tvo_pose *poses, int32_t capacity,
                                         int32_t *count, char *err, size_t err_size);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_PORT_DATASET_H */
