/* SPDX-License-Identifier: Apache-2.0 */
/* SE(3)/SO(3) helpers: identities, round trips (incl. near 0 and pi), the ground-truth transformation. */
#include <math.h>

#include "tvo_test.h"
#include "tinyvo/linalg.h"
#include "tinyvo/se3.h"

#define PI 3.14159265358979323846

static double urand(uint64_t *s) /* [-1, 1) */
{
    return (double)(tvo_test_rand(s) >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

static double mat_diff(const double *A, const double *B, int n)
{
    double e = 0.0;
    int i;
    for (i = 0; i < n; ++i)
        e = fmax(e, fabs(A[i] - B[i]));
    return e;
}

static double pose_diff(const tvo_pose *A, const tvo_pose *B)
{
    return fmax(mat_diff(A->R, B->R, 9), mat_diff(A->t, B->t, 3));
}

static tvo_pose random_pose(uint64_t *s)
{
    double v[3], t[3];
    tvo_pose T;
    int i;
    for (i = 0; i < 3; ++i) {
        v[i] = urand(s) * 1.8;
        t[i] = urand(s) * 5.0;
    }
    tvo_rotvec_to_rot(v, T.R);
    T.t[0] = t[0];
    T.t[1] = t[1];
    T.t[2] = t[2];
    return T;
}

static void test_identity_inverse_compose(void **state)
{
    uint64_t s = 12345;
    int k;
    (void)state;
    for (k = 0; k < 200; ++k) {
        tvo_pose A = random_pose(&s), B = random_pose(&s), C = random_pose(&s);
        tvo_pose I = tvo_pose_identity();
        tvo_pose Ai = tvo_pose_inverse(&A);
        tvo_pose AAi = tvo_pose_compose(&A, &Ai);
        tvo_pose AiA = tvo_pose_compose(&Ai, &A);
        tvo_pose AI = tvo_pose_compose(&A, &I);
        tvo_pose AB = tvo_pose_compose(&A, &B), BC = tvo_pose_compose(&B, &C);
        tvo_pose AB_C = tvo_pose_compose(&AB, &C), A_BC = tvo_pose_compose(&A, &BC);
        tvo_pose rel = tvo_pose_relative(&A, &B);
        tvo_pose rel2 = tvo_pose_compose(&Ai, &B);
        tvo_pose back = tvo_pose_compose(&A, &rel);
        double p[3] = {urand(&s), urand(&s), urand(&s)}, q[3], r[3];
        assert_true(pose_diff(&AAi, &I) < 1e-12);
        assert_true(pose_diff(&AiA, &I) < 1e-12);
        assert_true(pose_diff(&AI, &A) == 0.0);
        assert_true(pose_diff(&AB_C, &A_BC) < 1e-12);
        assert_true(pose_diff(&rel, &rel2) < 1e-12);
        assert_true(pose_diff(&back, &B) < 1e-12);
        /* transform_point agrees with compose: (A B) p = A (B p) */
        tvo_pose_transform_point(&B, p, q);
        tvo_pose_transform_point(&A, q, q); /* aliasing allowed */
        tvo_pose_transform_point(&AB, p, r);
        assert_true(mat_diff(q, r, 3) < 1e-12);
        assert_true(tvo_rot_orthogonality_error(AB_C.R) < 1e-13);
    }
}

static void test_matrix_roundtrip(void **state)
{
    uint64_t s = 99;
    double M[16];
    tvo_pose A = random_pose(&s), B;
    (void)state;
    tvo_pose_to_matrix(&A, M);
    assert_true(M[15] == 1.0 && M[12] == 0.0 && M[13] == 0.0 && M[14] == 0.0);
    assert_true(M[3] == A.t[0] && M[7] == A.t[1] && M[11] == A.t[2]);
    B = tvo_pose_from_matrix(M);
    assert_true(pose_diff(&A, &B) == 0.0);
}

static void test_quat(void **state)
{
    uint64_t s = 7;
    int k;
    (void)state;
    /* known value: 90 degrees about z */
    {
        const double q[4] = {cos(PI / 4), 0, 0, sin(PI / 4)};
        const double Rz[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
        double R[9], q2[4], q3[4] = {2 * cos(PI / 4), 0, 0, 2 * sin(PI / 4)};
        tvo_quat_to_rot(q, R);
        assert_true(mat_diff(R, Rz, 9) < 1e-15);
        tvo_quat_to_rot(q3, R); /* normalised */
        assert_true(mat_diff(R, Rz, 9) < 1e-15);
        tvo_rot_to_quat(Rz, q2);
        assert_true(mat_diff(q, q2, 4) < 1e-15);
    }
    for (k = 0; k < 1000; ++k) {
        double q[4] = {urand(&s), urand(&s), urand(&s), urand(&s)}, n, R[9], q2[4], R2[9];
        int i;
        n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        if (n < 0.1)
            continue;
        if (k % 4 == 0)
            q[0] = 0.0; /* angle exactly pi: all of Shepperd's other branches */
        if (k % 8 == 1)
            q[0] = 1e-9;
        n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        for (i = 0; i < 4; ++i)
            q[i] /= (q[0] < 0 ? -n : n);
        tvo_quat_to_rot(q, R);
        assert_true(tvo_rot_orthogonality_error(R) < 1e-14);
        tvo_rot_to_quat(R, q2);
        assert_true(q2[0] >= 0.0);
        if (q[0] == 0.0) { /* q and -q are the same rotation */
            double a = mat_diff(q, q2, 4);
            double qn[4] = {-q[0], -q[1], -q[2], -q[3]};
            assert_true(fmin(a, mat_diff(qn, q2, 4)) < 1e-14);
        } else {
            assert_true(mat_diff(q, q2, 4) < 1e-14);
        }
        tvo_quat_to_rot(q2, R2);
        assert_true(mat_diff(R, R2, 9) < 1e-14);
    }
}

static void test_quat_degenerate(void **state)
{
    const double z[4] = {0, 0, 0, 0};
    const double bad[4] = {NAN, 0, 0, 0};
    const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    const double Z[9] = {0};
    const double NaNR[9] = {NAN, 0, 0, 0, 1, 0, 0, 0, 1};
    double R[9], q[4], v[3];
    (void)state;
    tvo_quat_to_rot(z, R);
    assert_true(mat_diff(R, I, 9) == 0.0);
    tvo_quat_to_rot(bad, R);
    assert_true(mat_diff(R, I, 9) == 0.0);
    tvo_rot_to_quat(Z, q);
    assert_true(q[0] == 1.0 && q[1] == 0.0 && q[2] == 0.0 && q[3] == 0.0);
    tvo_rot_to_quat(NaNR, q);
    assert_true(q[0] == 1.0 && q[1] == 0.0);
    tvo_rot_to_rotvec(NaNR, v);
    assert_true(v[0] == 0.0 && v[1] == 0.0 && v[2] == 0.0);
    {
        const double vn[3] = {INFINITY, 0, 0};
        tvo_rotvec_to_rot(vn, R);
        assert_true(mat_diff(R, I, 9) == 0.0);
    }
}

static void check_rotvec_roundtrip(const double v[3], double tol_abs)
{
    double R[9], w[3], R2[9], th = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    tvo_rotvec_to_rot(v, R);
    assert_true(tvo_rot_orthogonality_error(R) < 1e-14);
    assert_true(fabs(tvo_rot_angle(R) - th) < tol_abs + 1e-15);
    tvo_rot_to_rotvec(R, w);
    tvo_rotvec_to_rot(w, R2);
    assert_true(mat_diff(R, R2, 9) < 1e-13);
    if (th < PI - 1e-6) { /* unique below pi */
        if (mat_diff(v, w, 3) >= tol_abs)
            fprintf(stderr, "rotvec (%.17g %.17g %.17g) -> (%.17g %.17g %.17g)\n", v[0], v[1], v[2], w[0],
                    w[1], w[2]);
        assert_true(mat_diff(v, w, 3) < tol_abs);
    } else { /* near/at pi: v or -v (same rotation when |v| = pi) */
        double wn[3] = {-w[0], -w[1], -w[2]};
        assert_true(fmin(mat_diff(v, w, 3), mat_diff(v, wn, 3)) < 1e-7);
    }
}

/* R^s: s times the angle about the same axis; R^1 = R, R^0 = I, R^2 = R R, R^0.5 twice = R; in place. */
static void test_rot_pow(void **state)
{
    uint64_t seed = 77;
    (void)state;
    for (int k = 0; k < 200; ++k) {
        const double v[3] = {urand(&seed), urand(&seed), urand(&seed)};
        double R[9], P[9], Q[9], RR[9], w[3];
        tvo_rotvec_to_rot(v, R);
        tvo_rot_pow(R, 1.0, P);
        assert_true(mat_diff(P, R, 9) < 1e-13);
        tvo_rot_pow(R, 0.0, P);
        assert_true(tvo_rot_angle(P) == 0.0);
        tvo_rot_pow(R, 2.0, P);
        tvo_la_mat3_mul(R, R, RR);
        assert_true(mat_diff(P, RR, 9) < 1e-12);
        tvo_rot_pow(R, 0.5, P);
        tvo_la_mat3_mul(P, P, Q);
        assert_true(mat_diff(Q, R, 9) < 1e-12);
        tvo_rot_pow(R, -1.0, P); /* the inverse */
        tvo_rot_to_rotvec(P, w);
        assert_true(fabs(w[0] + v[0]) + fabs(w[1] + v[1]) + fabs(w[2] + v[2]) < 1e-12);
        memcpy(Q, R, sizeof(Q));
        tvo_rot_pow(Q, 3.0, Q); /* out may be R */
        tvo_rot_pow(R, 3.0, P);
        assert_true(mat_diff(Q, P, 9) == 0.0);
    }
}

static void test_rotvec(void **state)
{
    uint64_t s = 4242;
    int k;
    (void)state;
    {
        const double v[3] = {0, 0, PI / 2};
        const double Rz[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
        double R[9];
        tvo_rotvec_to_rot(v, R);
        assert_true(mat_diff(R, Rz, 9) < 1e-15);
    }
    {
        const double zero[3] = {0, 0, 0};
        double R[9], w[3] = {1, 1, 1};
        tvo_rotvec_to_rot(zero, R);
        assert_true(tvo_rot_angle(R) == 0.0);
        tvo_rot_to_rotvec(R, w);
        assert_true(w[0] == 0.0 && w[1] == 0.0 && w[2] == 0.0);
    }
    for (k = 0; k < 1000; ++k) {
        double ax[3] = {urand(&s), urand(&s), urand(&s)}, n, v[3], th;
        int i;
        n = sqrt(ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2]);
        if (n < 0.05)
            continue;
        switch (k % 5) {
        case 0:
            th = 1e-12 * (1 + urand(&s));
            break; /* tiny */
        case 1:
            th = 1e-7 * (1 + urand(&s));
            break; /* around the series switch */
        case 2:
            th = PI - 1e-9;
            break; /* near pi */
        case 3:
            th = PI;
            break; /* exactly pi */
        default:
            th = PI * 0.5 * (1 + urand(&s));
            break;
        }
        for (i = 0; i < 3; ++i)
            v[i] = ax[i] / n * th;
        /* relative accuracy for tiny angles, absolute elsewhere */
        check_rotvec_roundtrip(v, th < 1e-6 ? th * 1e-9 : 1e-12);
    }
}

static void test_orthonormalize(void **state)
{
    uint64_t s = 555;
    int k;
    (void)state;
    for (k = 0; k < 200; ++k) {
        tvo_pose A = random_pose(&s);
        double R[9], X[9];
        int i;
        for (i = 0; i < 9; ++i)
            R[i] = A.R[i] + 1e-3 * urand(&s);
        for (i = 0; i < 9; ++i)
            X[i] = R[i];
        tvo_rot_orthonormalize(X);
        assert_true(tvo_rot_orthogonality_error(X) < 1e-13);
        assert_true(mat_diff(X, A.R, 9) < 3e-3);
        /* already a rotation: unchanged up to rounding */
        for (i = 0; i < 9; ++i)
            X[i] = A.R[i];
        tvo_rot_orthonormalize(X);
        assert_true(mat_diff(X, A.R, 9) < 1e-15);
    }
    {
        /* a reflection and a zero matrix still give rotations */
        double M[9] = {1, 0, 0, 0, 1, 0, 0, 0, -1}, Z[9] = {0};
        tvo_rot_orthonormalize(M);
        assert_true(tvo_rot_orthogonality_error(M) < 1e-14);
        tvo_rot_orthonormalize(Z);
        assert_true(tvo_rot_orthogonality_error(Z) < 1e-14);
    }
    {
        /* the polar factor of a scaled rotation is the rotation */
        const double v[3] = {0.3, -0.2, 0.9};
        double R[9], X[9];
        int i;
        tvo_rotvec_to_rot(v, R);
        for (i = 0; i < 9; ++i)
            X[i] = 3.0 * R[i];
        tvo_rot_orthonormalize(X);
        assert_true(mat_diff(X, R, 9) < 1e-14);
    }
}

static void test_finite(void **state)
{
    tvo_pose T = tvo_pose_identity();
    (void)state;
    assert_true(tvo_pose_is_finite(&T));
    T.t[2] = NAN;
    assert_false(tvo_pose_is_finite(&T));
    T.t[2] = 0;
    T.R[4] = INFINITY;
    assert_false(tvo_pose_is_finite(&T));
    assert_false(tvo_pose_is_finite(NULL));
}

static void test_angles(void **state)
{
    const double a[3] = {1, 0, 0}, b[3] = {0, 2, 0}, c[3] = {-3, 0, 0}, z[3] = {0, 0, 0};
    const double v1[3] = {0.1, 0.2, 0.3}, v2[3] = {0.1, 0.2, 0.35};
    double R1[9], R2[9];
    (void)state;
    assert_true(fabs(tvo_translation_angle(a, b) - PI / 2) < 1e-15);
    assert_true(fabs(tvo_translation_angle(a, c) - PI) < 1e-15);
    assert_true(tvo_translation_angle(a, a) == 0.0);
    assert_true(fabs(tvo_translation_angle(a, z) - PI / 2) < 1e-15);
    tvo_rotvec_to_rot(v1, R1);
    tvo_rotvec_to_rot(v2, R2);
    assert_true(tvo_rot_distance(R1, R1) < 1e-15);
    /* about the same axis direction-ish: distance is positive and below |v2 - v1| + small */
    assert_true(tvo_rot_distance(R1, R2) > 0.04 && tvo_rot_distance(R1, R2) < 0.06);
}

/* Hand-computed ground-truth transformation cases. */
static void test_body_to_camera(void **state)
{
    const double Rz90[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
    tvo_pose Twb0 = tvo_pose_identity(), Twb1 = tvo_pose_identity(), Tbs = tvo_pose_identity(), rel;
    (void)state;
    /* 1. body moves 1 m along body x; camera rotated +90 deg about z in the body:
     *    camera k+1 seen from camera k is translated by R_bs^T (1,0,0) = (0,-1,0), no rotation. */
    Twb1.t[0] = 1.0;
    memcpy(Tbs.R, Rz90, sizeof Rz90);
    rel = tvo_pose_body_to_camera_relative(&Twb0, &Twb1, &Tbs);
    {
        const tvo_pose expect = {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, -1, 0}};
        assert_true(pose_diff(&rel, &expect) < 1e-15);
    }
    /* 2. body turns +90 deg about z in place; camera 1 m along body x, not rotated:
     *    camera k at (1,0,0), camera k+1 at Rz90 (1,0,0) = (0,1,0), rotated by Rz90:
     *    T_ck_ck1 = (Rz90, (0,1,0) - (1,0,0)) = (Rz90, (-1,1,0)). */
    Twb1 = tvo_pose_identity();
    memcpy(Twb1.R, Rz90, sizeof Rz90);
    Tbs = tvo_pose_identity();
    Tbs.t[0] = 1.0;
    rel = tvo_pose_body_to_camera_relative(&Twb0, &Twb1, &Tbs);
    {
        const tvo_pose expect = {{0, -1, 0, 1, 0, 0, 0, 0, 1}, {-1, 1, 0}};
        assert_true(pose_diff(&rel, &expect) < 1e-15);
    }
    /* 3. generic: equals inv(T_BS) * inv(T_w_bk) T_w_bk1 * T_BS */
    {
        uint64_t s = 31337;
        int k;
        for (k = 0; k < 100; ++k) {
            tvo_pose A = random_pose(&s), B = random_pose(&s), X = random_pose(&s);
            tvo_pose rb = tvo_pose_relative(&A, &B), Xi = tvo_pose_inverse(&X);
            tvo_pose t1 = tvo_pose_compose(&Xi, &rb), expect = tvo_pose_compose(&t1, &X);
            rel = tvo_pose_body_to_camera_relative(&A, &B, &X);
            assert_true(pose_diff(&rel, &expect) < 1e-12);
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_identity_inverse_compose),
            cmocka_unit_test(test_matrix_roundtrip),
            cmocka_unit_test(test_quat),
            cmocka_unit_test(test_quat_degenerate),
            cmocka_unit_test(test_rotvec),
            cmocka_unit_test(test_rot_pow),
            cmocka_unit_test(test_orthonormalize),
            cmocka_unit_test(test_finite),
            cmocka_unit_test(test_angles),
            cmocka_unit_test(test_body_to_camera),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
