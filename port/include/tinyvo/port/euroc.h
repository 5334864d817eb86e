/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo port: EuRoC / ASL dataset folder reader.
 *
 * Layout read (the ASL format of the EuRoC MAV dataset):
 *   DIR/mav0/<cam>/sensor.yaml     intrinsics, distortion model + 4 or 5 coefficients, resolution,
 *                                  rate_hz, T_BS (body <- sensor, 4x4 row-major)
 *   DIR/mav0/<cam>/data.csv        "timestamp_ns,filename" per frame ('#' lines are comments)
 *   DIR/mav0/<cam>/data/<filename> the frames (PNG)
 *   DIR/mav0/state_groundtruth_estimate0/data.csv   optional ground truth: timestamp_ns, p xyz [m],
 *                                  q wxyz (the first 8 columns; further columns are ignored)
 * DIR may also be the mav0 folder itself.
 *
 * The reader reads the csv/yaml files once at open (heap memory, freed by close); frames are decoded
 * on demand with tvo_euroc_read_frame (or by the caller from tvo_euroc_frame_path). Frames keep the
 * order of data.csv: the parser does not reject non-monotonic or duplicated frame timestamps (a replay
 * must detect and report those itself); ground-truth timestamps must be strictly increasing.
 *
 * Parsers never crash on malformed input: they return TVO_ERR_FORMAT (or TVO_ERR_UNSUPPORTED for a
 * well-formed but unsupported camera/distortion model) and write a one-line English message, with the
 * line number where there is one, into err (err may be NULL; messages are truncated to err_size).
 * The parsers work on memory buffers (text, len; no NUL terminator needed) so that fuzz harnesses can
 * call them directly.
 *
 * Not thread-safe per object (read-only queries on one object from several threads are fine). */
#ifndef TINYVO_PORT_EUROC_H
#define TINYVO_PORT_EUROC_H

#include <stddef.h>
#include <stdint.h>
#include "tinyvo/camera.h"
#include "tinyvo/export.h"
#include "tinyvo/se3.h"
#include "tinyvo/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Longest accepted frame file name, bytes including the terminator. */
#define TVO_EUROC_MAX_NAME 256

/* Largest accepted |coordinate| of a ground-truth position or of the T_BS translation, metres. Larger
 * (finite) values are refused with TVO_ERR_FORMAT: interpolating or composing poses near DBL_MAX
 * overflowed to infinite poses. */
#define TVO_EUROC_MAX_COORD 1e9

typedef struct tvo_euroc_frame {
    int64_t t_ns;                  /* timestamp, nanoseconds */
    char file[TVO_EUROC_MAX_NAME]; /* file name inside <cam>/data/ (no '/' or '\\', not "." or "..") */
} tvo_euroc_frame;

typedef struct tvo_euroc_gt_row {
    int64_t t_ns;     /* nanoseconds */
    double p[3];      /* position of the body in the world frame, metres */
    double q_wxyz[4]; /* orientation of the body (T_w_b rotation), unit quaternion w x y z */
} tvo_euroc_gt_row;

typedef struct tvo_euroc tvo_euroc; /* opaque */

/* Open an ASL folder. dir: folder containing mav0/ (or mav0 itself). cam: sub-folder name, e.g.
 * "cam0" (NULL means "cam0"; no '/' allowed). On success *seq owns heap memory: tvo_euroc_close it.
 * Errors: TVO_ERR_NULL, TVO_ERR_ARG (bad cam name, path too long), TVO_ERR_NOT_FOUND (no
 * <cam>/data.csv or sensor.yaml), TVO_ERR_IO, TVO_ERR_FORMAT / TVO_ERR_UNSUPPORTED (a malformed
 * sensor.yaml, data.csv or ground-truth csv: "<path>:<line>: <what>" in err), TVO_ERR_NO_MEMORY.
 * *seq is NULL after an error. */
TVO_API tvo_status tvo_euroc_open(tvo_euroc **seq, const char *dir, const char *cam, char *err,
                                  size_t err_size);

/* Flag of tvo_euroc_open_ex (and tvo_tum_open / tvo_kitti_open, dataset.h): a malformed row of the
 * frame list (data.csv, rgb.txt, times.txt) is skipped instead of failing the open; each one is kept
 * as a message "<path>:<line>: <what>" (tvo_euroc_bad_row). A list with no good row still fails. */
#define TVO_EUROC_SKIP_BAD_ROWS 1u
/* Skipped rows whose messages are kept (all are counted); message length, bytes with terminator. */
#define TVO_EUROC_MAX_BAD_ROWS 256
#define TVO_EUROC_BAD_ROW_MSG 320
/* tvo_euroc_open with flags (0 or TVO_EUROC_SKIP_BAD_ROWS). tvo_euroc_open(...) = flags 0. */
TVO_API tvo_status tvo_euroc_open_ex(tvo_euroc **seq, const char *dir, const char *cam, unsigned flags,
                                     char *err, size_t err_size);
/* Frame-list rows skipped at open (0 for NULL), and the message of skipped row i (i below the count
 * and below TVO_EUROC_MAX_BAD_ROWS; else NULL). Owned by seq. */
TVO_API int32_t tvo_euroc_bad_row_count(const tvo_euroc *seq);
TVO_API const char *tvo_euroc_bad_row(const tvo_euroc *seq, int32_t i);
TVO_API void tvo_euroc_close(tvo_euroc *seq); /* NULL is fine */

/* Number of frames (0 for NULL). */
TVO_API int32_t tvo_euroc_frame_count(const tvo_euroc *seq);
/* Timestamp of frame i in ns, or -1 when seq is NULL or i is out of range. */
TVO_API int64_t tvo_euroc_frame_time(const tvo_euroc *seq, int32_t i);
/* File name of frame i (inside <cam>/data/), or NULL when out of range. Owned by seq. */
TVO_API const char *tvo_euroc_frame_file(const tvo_euroc *seq, int32_t i);
/* Full path of frame i into path[size] (<cam>/data/<file>; for TUM and KITTI sequences the folder's
 * <file>, dataset.h). TVO_ERR_NULL, TVO_ERR_RANGE (bad i), TVO_ERR_NO_MEMORY (size
 * too small; path then holds an empty string). */
TVO_API tvo_status tvo_euroc_frame_path(const tvo_euroc *seq, int32_t i, char *path, size_t size);
/* Decode frame i into buf (capacity >= width * height of the camera) as 8-bit grey, packed.
 * TVO_ERR_MISMATCH when the PNG's size is not the camera's resolution; otherwise the statuses of
 * tvo_png_read_gray8 (TVO_ERR_NOT_FOUND for a missing file, TVO_ERR_FORMAT for a corrupt one, ...). */
TVO_API tvo_status tvo_euroc_read_frame(const tvo_euroc *seq, int32_t i, uint8_t *buf, size_t capacity);

/* The camera from sensor.yaml (checked with tvo_camera_check), owned by seq; NULL for NULL seq. */
TVO_API const tvo_camera *tvo_euroc_camera(const tvo_euroc *seq);
/* T_BS: body <- sensor (camera) extrinsics, rotation re-orthonormalised. Identity for NULL seq. */
TVO_API tvo_pose tvo_euroc_T_BS(const tvo_euroc *seq);
/* rate_hz from sensor.yaml, 0 when absent (or NULL seq). */
TVO_API double tvo_euroc_rate_hz(const tvo_euroc *seq);
/* The folder holding <cam>/ (the mav0 folder), owned by seq. */
TVO_API const char *tvo_euroc_base_dir(const tvo_euroc *seq);

/* 1 when ground truth is loaded (from mav0/state_groundtruth_estimate0/data.csv at open, or by
 * tvo_euroc_load_groundtruth_file), else 0. */
TVO_API int tvo_euroc_has_groundtruth(const tvo_euroc *seq);
TVO_API int32_t tvo_euroc_groundtruth_count(const tvo_euroc *seq);
/* Row i of the ground truth (sorted by strictly increasing time). TVO_ERR_NULL, TVO_ERR_RANGE. */
TVO_API tvo_status tvo_euroc_groundtruth_row(const tvo_euroc *seq, int32_t i, tvo_euroc_gt_row *row);
/* Body pose T_w_b at t_ns: the NEAREST ground-truth row (no interpolation), if it lies within tol_ns
 * (tol_ns >= 0) of t_ns. EuRoC ground truth and image timestamps differ by up to a few hundred ns, so
 * a tolerance of 1 ms is typical. Errors: TVO_ERR_NULL, TVO_ERR_ARG (tol_ns < 0), TVO_ERR_STATE (no
 * ground truth loaded), TVO_ERR_RANGE (no row within tol_ns). O(log n). */
TVO_API tvo_status tvo_euroc_groundtruth(const tvo_euroc *seq, int64_t t_ns, int64_t tol_ns, tvo_pose *T_w_b);
/* Body pose T_w_b at t_ns INTERPOLATED between the two rows around t_ns (linear in position,
 * slerp in rotation) when they are at most max_gap_ns apart; an exact match returns that row.
 * Errors as tvo_euroc_groundtruth; TVO_ERR_RANGE when t_ns is outside the ground truth's time span
 * or the bracketing rows are more than max_gap_ns apart. */
TVO_API tvo_status tvo_euroc_groundtruth_interp(const tvo_euroc *seq, int64_t t_ns, int64_t max_gap_ns,
                                                tvo_pose *T_w_b);
/* Replace the ground truth by the file at path: a csv (as state_groundtruth_estimate0/data.csv) or
 * a space-separated text file `t px py pz qw qx qy qz` (the layout of some EuRoC trajectory exports;
 * timestamps in ns, a fractional part is rounded). On error the previous ground truth is kept.
 * Errors: TVO_ERR_NULL, TVO_ERR_NOT_FOUND, TVO_ERR_IO, TVO_ERR_FORMAT (message in err),
 * TVO_ERR_NO_MEMORY. */
TVO_API tvo_status tvo_euroc_load_groundtruth_file(tvo_euroc *seq, const char *path, char *err,
                                                   size_t err_size);

/* ---- parsers on memory buffers (also for fuzzing) ----------------------------------------------- */

/* A camera sensor.yaml (tvo_calib_parse with TVO_CALIB_EUROC, tinyvo/port/calib.h: the YAML subset
 * calibration tools write: nested "key: value" mappings, flow sequences "[a, b, ...]" that may span
 * lines, '#' comments, "%YAML" directives). The Kalibr key distortion_coeffs is accepted as well.
 * Required: intrinsics [fu, fv, cu, cv], resolution [w, h], T_BS with data of 16 numbers (rows/cols
 * 4 if given, last row 0 0 0 1, a rotation block orthonormal to 1e-3, a translation within
 * +-TVO_EUROC_MAX_COORD). distortion_model:
 * radial-tangential (alias radtan, plumb_bob; 4 or 5 coefficients k1 k2 p1 p2 [k3]), equidistant
 * (alias fisheye, equi; 4 coefficients) or none; absent with coefficients present means
 * radial-tangential; absent without coefficients means none. camera_model must be pinhole if given.
 * rate_hz optional (> 0). cam is required; T_BS and rate_hz may be NULL. */
TVO_API tvo_status tvo_euroc_parse_sensor_yaml(const char *text, size_t len, tvo_camera *cam, tvo_pose *T_BS,
                                               double *rate_hz, char *err, size_t err_size);

/* A <cam>/data.csv: lines "timestamp_ns,filename" (spaces around fields allowed, CRLF allowed, '#'
 * lines and blank lines skipped). With frames == NULL: only validates and counts (*count).
 * Otherwise fills frames[0..*count) and fails with TVO_ERR_NO_MEMORY (and *count = the number
 * needed) when capacity is too small. */
TVO_API tvo_status tvo_euroc_parse_frames_csv(const char *text, size_t len, tvo_euroc_frame *frames,
                                              int32_t capacity, int32_t *count, char *err, size_t err_size);

/* A ground-truth table: fields separated by ',' and/or blanks; the first 8 fields t_ns px py pz qw qx
 * qy qz are required (t an integer number of ns, optionally with a fractional part that is rounded),
 * further fields ignored. Positions within +-TVO_EUROC_MAX_COORD. Quaternions must have norm 1 +- 0.01
 * (they are normalised). Timestamps must be strictly increasing. frames == NULL / capacity semantics as tvo_euroc_parse_frames_csv. */
TVO_API tvo_status tvo_euroc_parse_groundtruth(const char *text, size_t len, tvo_euroc_gt_row *rows,
                                               int32_t capacity, int32_t *count, char *err, size_t err_size);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_PORT_EUROC_H */
