/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: SE(3) / SO(3) helpers and the paper's ground-truth transformation.
 *
 * Conventions: T_a_b maps points from frame b to frame a: p_a = R p_b + t. R is a row-major 3x3
 * rotation matrix (R[3*row + col]), t in metres. Quaternions are (w, x, y, z) (Hamilton, EuRoC order),
 * rotation vectors are axis * angle in radians. All functions are pure, reentrant, allocate nothing
 * and cost a few dozen to a few hundred flops. They never produce NaN from finite input. */
#ifndef TINYVO_SE3_H
#define TINYVO_SE3_H

#include "tinyvo/types.h"
#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct tvo_pose {
    double R[9]; /* rotation, row-major */
    double t[3]; /* translation, metres */
} tvo_pose;

TVO_API tvo_pose tvo_pose_identity(void);
/* T_a_c = T_a_b * T_b_c. */
TVO_API tvo_pose tvo_pose_compose(const tvo_pose *T_a_b, const tvo_pose *T_b_c);
/* T_b_a = inv(T_a_b) = (R^T, -R^T t). Assumes R is a rotation. */
TVO_API tvo_pose tvo_pose_inverse(const tvo_pose *T_a_b);
/* T_a_b = inv(T_w_a) * T_w_b: relative pose of b seen from a. */
TVO_API tvo_pose tvo_pose_relative(const tvo_pose *T_w_a, const tvo_pose *T_w_b);
/* p_a = T_a_b * p_b (p_out may alias p). */
TVO_API void tvo_pose_transform_point(const tvo_pose *T_a_b, const double p[3], double p_out[3]);
/* A pose from a quaternion (w, x, y, z; normalised here) and a translation. */
TVO_API tvo_pose tvo_pose_from_quat(const double q_wxyz[4], const double t[3]);
/* A pose from a row-major 4x4 homogeneous matrix (the last row is ignored; R is used as given). */
TVO_API tvo_pose tvo_pose_from_matrix(const double M[16]);
/* Row-major 4x4 homogeneous matrix of T. */
TVO_API void tvo_pose_to_matrix(const tvo_pose *T, double M[16]);

/* Quaternion (w, x, y, z), normalised here -> rotation matrix. A zero or non-finite quaternion gives
 * the identity (callers that read quaternions from files reject those first). */
TVO_API void tvo_quat_to_rot(const double q_wxyz[4], double R[9]);
/* Rotation matrix -> unit quaternion with w >= 0 (Shepperd's method: accurate for every angle). */
TVO_API void tvo_rot_to_quat(const double R[9], double q_wxyz[4]);
/* Rotation vector (axis * angle, radians) -> rotation matrix (Rodrigues, series near 0). A
 * non-finite vector gives the identity. */
TVO_API void tvo_rotvec_to_rot(const double v[3], double R[9]);
/* Rotation matrix -> rotation vector with angle in [0, pi], via the quaternion and atan2: accurate
 * near 0 and near pi (at exactly pi the sign of the axis is arbitrary). */
TVO_API void tvo_rot_to_rotvec(const double R[9], double v[3]);
/* R to the power s: the rotation about R's axis by s times its angle (its rotation vector times s; a
 * constant angular velocity over s of R's intervals). out may be R. */
TVO_API void tvo_rot_pow(const double R[9], double s, double out[9]);
/* Rotation angle of R in radians, [0, pi] (atan2 form: accurate for small angles too). */
TVO_API double tvo_rot_angle(const double R[9]);
/* Replace R by the nearest rotation matrix (Frobenius norm): polar decomposition by Newton's
 * iteration R <- (R + R^-T) / 2, at most 20 iterations; for a matrix with det <= 0 or non-finite
 * entries, the quaternion of R is used instead (which always gives a rotation; identity if nothing
 * better is possible). */
TVO_API void tvo_rot_orthonormalize(double R[9]);
/* 1 when every entry of T is finite, else 0 (0 for NULL). */
TVO_API int tvo_pose_is_finite(const tvo_pose *T);
/* Max |entry| of R^T R - I: how far R is from being a rotation (0 for an exact rotation). */
TVO_API double tvo_rot_orthogonality_error(const double R[9]);

/* The paper's ground-truth transformation: body poses T_w_b(k), T_w_b(k+1) (e.g. EuRoC ground truth)
 * and the camera extrinsics T_b_s (EuRoC T_BS: body <- sensor) -> the camera's relative pose
 * T_ck_ck1 = inv(T_w_b(k) T_BS) * T_w_b(k+1) T_BS (maps points from camera k+1 to camera k). */
TVO_API tvo_pose tvo_pose_body_to_camera_relative(const tvo_pose *T_w_bk, const tvo_pose *T_w_bk1,
                                                  const tvo_pose *T_b_s);

/* Rotation error angle between two rotations, radians in [0, pi]: angle(A^T B). */
TVO_API double tvo_rot_distance(const double A[9], const double B[9]);
/* Angle between two translation directions in radians, [0, pi]; pi/2 if either is (near) zero. */
TVO_API double tvo_translation_angle(const double a[3], const double b[3]);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_SE3_H */
