/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: SE(3) / SO(3) helpers (see se3.h). */
#include "tinyvo/se3.h"
#include "tinyvo/dmath.h"

#include <math.h>

static int tvo_all_finite(const double *a, int n)
{
    int i;
    for (i = 0; i < n; ++i)
        if (!isfinite(a[i]))
            return 0;
    return 1;
}

static void tvo_mat3_mul(const double *A, const double *B, double *C)
{
    int r, c;
    for (r = 0; r < 3; ++r)
        for (c = 0; c < 3; ++c)
            C[3 * r + c] = A[3 * r] * B[c] + A[3 * r + 1] * B[3 + c] + A[3 * r + 2] * B[6 + c];
}

/* C = A^T B */
static void tvo_mat3_tmul(const double *A, const double *B, double *C)
{
    int r, c;
    for (r = 0; r < 3; ++r)
        for (c = 0; c < 3; ++c)
            C[3 * r + c] = A[r] * B[c] + A[3 + r] * B[3 + c] + A[6 + r] * B[6 + c];
}

static void tvo_set_identity(double *R)
{
    int i;
    for (i = 0; i < 9; ++i)
        R[i] = (i % 4 == 0) ? 1.0 : 0.0;
}

tvo_pose tvo_pose_identity(void)
{
    tvo_pose T;
    tvo_set_identity(T.R);
    T.t[0] = T.t[1] = T.t[2] = 0.0;
    return T;
}

tvo_pose tvo_pose_compose(const tvo_pose *A, const tvo_pose *B)
{
    tvo_pose T;
    int r;
    tvo_mat3_mul(A->R, B->R, T.R);
    for (r = 0; r < 3; ++r)
        T.t[r] = A->R[3 * r] * B->t[0] + A->R[3 * r + 1] * B->t[1] + A->R[3 * r + 2] * B->t[2] + A->t[r];
    return T;
}

tvo_pose tvo_pose_inverse(const tvo_pose *A)
{
    tvo_pose T;
    int r, c;
    for (r = 0; r < 3; ++r)
        for (c = 0; c < 3; ++c)
            T.R[3 * r + c] = A->R[3 * c + r];
    for (r = 0; r < 3; ++r)
        T.t[r] = -(T.R[3 * r] * A->t[0] + T.R[3 * r + 1] * A->t[1] + T.R[3 * r + 2] * A->t[2]);
    return T;
}

tvo_pose tvo_pose_relative(const tvo_pose *T_w_a, const tvo_pose *T_w_b)
{
    tvo_pose T;
    int r;
    double d[3];
    /* inv(T_w_a) T_w_b = (Ra^T Rb, Ra^T (tb - ta)) */
    tvo_mat3_tmul(T_w_a->R, T_w_b->R, T.R);
    for (r = 0; r < 3; ++r)
        d[r] = T_w_b->t[r] - T_w_a->t[r];
    for (r = 0; r < 3; ++r)
        T.t[r] = T_w_a->R[r] * d[0] + T_w_a->R[3 + r] * d[1] + T_w_a->R[6 + r] * d[2];
    return T;
}

void tvo_pose_transform_point(const tvo_pose *T, const double p[3], double p_out[3])
{
    double q[3];
    int r;
    for (r = 0; r < 3; ++r)
        q[r] = T->R[3 * r] * p[0] + T->R[3 * r + 1] * p[1] + T->R[3 * r + 2] * p[2] + T->t[r];
    p_out[0] = q[0];
    p_out[1] = q[1];
    p_out[2] = q[2];
}

tvo_pose tvo_pose_from_quat(const double q_wxyz[4], const double t[3])
{
    tvo_pose T;
    tvo_quat_to_rot(q_wxyz, T.R);
    T.t[0] = t[0];
    T.t[1] = t[1];
    T.t[2] = t[2];
    return T;
}

tvo_pose tvo_pose_from_matrix(const double M[16])
{
    tvo_pose T;
    int r, c;
    for (r = 0; r < 3; ++r) {
        for (c = 0; c < 3; ++c)
            T.R[3 * r + c] = M[4 * r + c];
        T.t[r] = M[4 * r + 3];
    }
    return T;
}

void tvo_pose_to_matrix(const tvo_pose *T, double M[16])
{
    int r, c;
    for (r = 0; r < 3; ++r) {
        for (c = 0; c < 3; ++c)
            M[4 * r + c] = T->R[3 * r + c];
        M[4 * r + 3] = T->t[r];
    }
    M[12] = M[13] = M[14] = 0.0;
    M[15] = 1.0;
}

void tvo_quat_to_rot(const double q_wxyz[4], double R[9])
{
    double n = sqrt(q_wxyz[0] * q_wxyz[0] + q_wxyz[1] * q_wxyz[1] + q_wxyz[2] * q_wxyz[2] +
                    q_wxyz[3] * q_wxyz[3]);
    double w, x, y, z;
    if (!isfinite(n) || !(n > 1e-150) || !tvo_all_finite(q_wxyz, 4)) {
        tvo_set_identity(R);
        return;
    }
    w = q_wxyz[0] / n;
    x = q_wxyz[1] / n;
    y = q_wxyz[2] / n;
    z = q_wxyz[3] / n;
    R[0] = 1.0 - 2.0 * (y * y + z * z);
    R[1] = 2.0 * (x * y - w * z);
    R[2] = 2.0 * (x * z + w * y);
    R[3] = 2.0 * (x * y + w * z);
    R[4] = 1.0 - 2.0 * (x * x + z * z);
    R[5] = 2.0 * (y * z - w * x);
    R[6] = 2.0 * (x * z - w * y);
    R[7] = 2.0 * (y * z + w * x);
    R[8] = 1.0 - 2.0 * (x * x + y * y);
}

void tvo_rot_to_quat(const double R[9], double q[4])
{
    const double tr = R[0] + R[4] + R[8];
    double s, n;
    int i, br;
    if (!tvo_all_finite(R, 9)) {
        q[0] = 1.0;
        q[1] = q[2] = q[3] = 0.0;
        return;
    }
    /* Shepperd: take the square root of the largest of 4w^2, 4x^2, 4y^2, 4z^2. */
    if (tr >= R[0] && tr >= R[4] && tr >= R[8])
        br = 0;
    else if (R[0] >= R[4] && R[0] >= R[8])
        br = 1;
    else if (R[4] >= R[8])
        br = 2;
    else
        br = 3;
    if (br == 0)
        s = 2.0 * sqrt(fmax(1.0 + tr, 0.0));
    else if (br == 1)
        s = 2.0 * sqrt(fmax(1.0 + R[0] - R[4] - R[8], 0.0));
    else if (br == 2)
        s = 2.0 * sqrt(fmax(1.0 - R[0] + R[4] - R[8], 0.0));
    else
        s = 2.0 * sqrt(fmax(1.0 - R[0] - R[4] + R[8], 0.0));
    if (!(s > 1e-150)) {
        /* possible only for a matrix far from a rotation (e.g. all zeros) */
        q[0] = 1.0;
        q[1] = q[2] = q[3] = 0.0;
        return;
    }
    if (br == 0) {
        q[0] = 0.25 * s;
        q[1] = (R[7] - R[5]) / s;
        q[2] = (R[2] - R[6]) / s;
        q[3] = (R[3] - R[1]) / s;
    } else if (br == 1) {
        q[0] = (R[7] - R[5]) / s;
        q[1] = 0.25 * s;
        q[2] = (R[1] + R[3]) / s;
        q[3] = (R[2] + R[6]) / s;
    } else if (br == 2) {
        q[0] = (R[2] - R[6]) / s;
        q[1] = (R[1] + R[3]) / s;
        q[2] = 0.25 * s;
        q[3] = (R[5] + R[7]) / s;
    } else {
        q[0] = (R[3] - R[1]) / s;
        q[1] = (R[2] + R[6]) / s;
        q[2] = (R[5] + R[7]) / s;
        q[3] = 0.25 * s;
    }
    n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(n > 1e-150) || !isfinite(n) || !tvo_all_finite(q, 4)) {
        q[0] = 1.0;
        q[1] = q[2] = q[3] = 0.0;
        return;
    }
    if (q[0] < 0.0)
        n = -n;
    for (i = 0; i < 4; ++i)
        q[i] /= n;
}

void tvo_rotvec_to_rot(const double v[3], double R[9])
{
    const double th2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    const double th = sqrt(th2);
    double a, b, K[9], K2[9];
    int i;
    if (!tvo_all_finite(v, 3) || !isfinite(th2)) {
        tvo_set_identity(R);
        return;
    }
    if (th < 1e-6) {
        a = 1.0 - th2 / 6.0;
        b = 0.5 - th2 / 24.0;
    } else {
        const double h = tvo_dm_sin(0.5 * th) / (0.5 * th);
        a = tvo_dm_sin(th) / th;
        b = 0.5 * h * h; /* (1 - cos th) / th^2 without cancellation */
    }
    K[0] = 0.0;
    K[1] = -v[2];
    K[2] = v[1];
    K[3] = v[2];
    K[4] = 0.0;
    K[5] = -v[0];
    K[6] = -v[1];
    K[7] = v[0];
    K[8] = 0.0;
    tvo_mat3_mul(K, K, K2);
    for (i = 0; i < 9; ++i)
        R[i] = ((i % 4 == 0) ? 1.0 : 0.0) + a * K[i] + b * K2[i];
}

void tvo_rot_to_rotvec(const double R[9], double v[3])
{
    double q[4], s, f;
    tvo_rot_to_quat(R, q);
    s = sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (s == 0.0) {
        v[0] = v[1] = v[2] = 0.0;
        return;
    }
    f = 2.0 * tvo_dm_atan2(s, q[0]) / s;
    v[0] = f * q[1];
    v[1] = f * q[2];
    v[2] = f * q[3];
}

void tvo_rot_pow(const double R[9], double s, double out[9])
{
    double v[3];
    tvo_rot_to_rotvec(R, v);
    v[0] *= s;
    v[1] *= s;
    v[2] *= s;
    tvo_rotvec_to_rot(v, out);
}

double tvo_rot_angle(const double R[9])
{
    double q[4];
    tvo_rot_to_quat(R, q);
    return 2.0 * tvo_dm_atan2(sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]), fabs(q[0]));
}

double tvo_rot_distance(const double A[9], const double B[9])
{
    double D[9];
    tvo_mat3_tmul(A, B, D);
    return tvo_rot_angle(D);
}

double tvo_translation_angle(const double a[3], const double b[3])
{
    const double na = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    const double nb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    double c[3], d;
    if (!(na > 1e-300) || !(nb > 1e-300) || !isfinite(na) || !isfinite(nb))
        return 1.57079632679489661923;
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
    d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    return tvo_dm_atan2(sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]), d);
}

double tvo_rot_orthogonality_error(const double R[9])
{
    double P[9], e = 0.0;
    int i;
    tvo_mat3_tmul(R, R, P);
    for (i = 0; i < 9; ++i) {
        double d = fabs(P[i] - ((i % 4 == 0) ? 1.0 : 0.0));
        if (!(d <= e))
            e = d; /* also propagates NaN */
    }
    return e;
}

static double tvo_det3(const double *M)
{
    return M[0] * (M[4] * M[8] - M[5] * M[7]) - M[1] * (M[3] * M[8] - M[5] * M[6]) +
            M[2] * (M[3] * M[7] - M[4] * M[6]);
}

void tvo_rot_orthonormalize(double R[9])
{
    double X[9], q[4];
    int it, i;
    for (i = 0; i < 9; ++i)
        X[i] = R[i];
    if (tvo_all_finite(R, 9) && tvo_det3(R) > 0.0) {
        for (it = 0; it < 20; ++it) {
            double C[9], det = tvo_det3(X), change = 0.0;
            if (!(det > 1e-300) || !isfinite(det))
                break;
            /* cofactor matrix = det * X^-T */
            C[0] = X[4] * X[8] - X[5] * X[7];
            C[1] = X[5] * X[6] - X[3] * X[8];
            C[2] = X[3] * X[7] - X[4] * X[6];
            C[3] = X[2] * X[7] - X[1] * X[8];
            C[4] = X[0] * X[8] - X[2] * X[6];
            C[5] = X[1] * X[6] - X[0] * X[7];
            C[6] = X[1] * X[5] - X[2] * X[4];
            C[7] = X[2] * X[3] - X[0] * X[5];
            C[8] = X[0] * X[4] - X[1] * X[3];
            for (i = 0; i < 9; ++i) {
                double n = 0.5 * (X[i] + C[i] / det);
                change = fmax(change, fabs(n - X[i]));
                X[i] = n;
            }
            if (change < 1e-15)
                break;
        }
        if (tvo_all_finite(X, 9) && tvo_rot_orthogonality_error(X) < 1e-12 && tvo_det3(X) > 0.0) {
            for (i = 0; i < 9; ++i)
                R[i] = X[i];
            return;
        }
    }
    tvo_rot_to_quat(R, q);
    tvo_quat_to_rot(q, R);
}

int tvo_pose_is_finite(const tvo_pose *T)
{
    if (T == NULL)
        return 0;
    return tvo_all_finite(T->R, 9) && tvo_all_finite(T->t, 3);
}

tvo_pose tvo_pose_body_to_camera_relative(const tvo_pose *T_w_bk, const tvo_pose *T_w_bk1,
                                          const tvo_pose *T_b_s)
{
    const tvo_pose T_w_ck = tvo_pose_compose(T_w_bk, T_b_s);
    const tvo_pose T_w_ck1 = tvo_pose_compose(T_w_bk1, T_b_s);
    return tvo_pose_relative(&T_w_ck, &T_w_ck1);
}
