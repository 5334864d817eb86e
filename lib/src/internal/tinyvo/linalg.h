/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: small dense linear-algebra helpers used by the geometry (relative pose, 5/8-point).
 *
 * All matrices are row-major double arrays of the stated fixed size; no function allocates, none
 * aborts. Sizes are tiny (3x3, up to 10x10), so everything is plain loops: cost is stated per call.
 * Inputs are assumed finite; outputs are finite whenever inputs are (functions that could divide
 * by zero report it). Names are prefixed tvo_la_ so they do not clash with the SE(3) module. */
#ifndef TINYVO_LINALG_H
#define TINYVO_LINALG_H

#include "tinyvo/types.h"

#ifdef __cplusplus
extern "C" {
#endif

/* C = A * B for 3x3 matrices. C may alias neither A nor B. ~27 mul. */
void tvo_la_mat3_mul(const double A[9], const double B[9], double C[9]);
/* C = A * B^T (3x3). C may alias neither. */
void tvo_la_mat3_mul_bt(const double A[9], const double B[9], double C[9]);
/* C = A^T * B (3x3). C may alias neither. */
void tvo_la_mat3_mul_at(const double A[9], const double B[9], double C[9]);
/* y = A x (3x3 times 3-vector); y may not alias x. */
void tvo_la_mat3_vec(const double A[9], const double x[3], double y[3]);
/* y = A^T x; y may not alias x. */
void tvo_la_mat3_tvec(const double A[9], const double x[3], double y[3]);
/* Determinant of a 3x3 matrix. */
double tvo_la_mat3_det(const double A[9]);
/* [v]_x: the skew-symmetric matrix with [v]_x w = v x w. */
void tvo_la_skew(const double v[3], double S[9]);
/* c = a x b; c may not alias a or b. */
void tvo_la_cross(const double a[3], const double b[3], double c[3]);

/* Rotation matrix exp([w]_x) of a rotation vector w (radians; Rodrigues, with a series near 0). */
void tvo_la_so3_exp(const double w[3], double R[9]);
/* Rotation angle of a rotation matrix, in radians [0, pi]; robust near 0 and pi. */
double tvo_la_rot_angle(const double R[9]);
/* Angle between two rotations, angle(Ra^T Rb), radians. */
double tvo_la_rot_dist(const double Ra[9], const double Rb[9]);
/* Closest rotation (Frobenius) to a 3x3 matrix, via SVD; det(R) = +1. */
void tvo_la_orthonormalize(const double M[9], double R[9]);

/* SVD of a 3x3 matrix: A = U diag(s) V^T, s[0] >= s[1] >= s[2] >= 0, U and V orthogonal (their
 * determinants may be -1). One-sided Jacobi, at most 30 sweeps (typically 4-6), ~1 us. Columns of U
 * belonging to zero singular values are completed to an orthonormal basis. */
void tvo_la_svd3(const double A[9], double U[9], double s[3], double V[9]);

/* Eigen-decomposition of a symmetric n x n matrix (1 <= n <= 10, row-major with row stride n) by
 * cyclic Jacobi: eigenvalues to w[] in ascending order, eigenvectors to the COLUMNS of V (n x n,
 * row stride n). A is overwritten. At most 50 sweeps; cost O(n^3) per sweep (~20 us for n = 9).
 * Returns TVO_ERR_ARG for a bad n, TVO_ERR_NULL for NULL pointers. */
tvo_status tvo_la_sym_eig(double *A, int n, double *w, double *V);

/* Solve A x = b for n x n A (1 <= n <= 10, row stride n) by Gaussian elimination with partial
 * pivoting; A and b are overwritten, x may alias b. Returns TVO_ERR_DEGENERATE when a pivot is
 * below 1e-300 or relative 1e-14 of the largest matrix entry. O(n^3). */
tvo_status tvo_la_solve(double *A, double *b, int n, double *x);

/* Inverse of a symmetric 3x3 A by Cholesky: 1, or 0 when a diagonal entry is not positive, a pivot is not
 * above rel * its diagonal entry, or an entry of Ai is not finite. */
int tvo_la_chol3_inv(const double A[9], double rel, double Ai[9]);
/* In-place Cholesky L L^T of the leading n x n block of A (row stride ld >= n; the lower triangle is
 * read and overwritten). 1, or 0 when a pivot is not above rel * its diagonal entry or is not finite.
 * O(n^3 / 6). */
int tvo_la_chol(double *A, int n, int ld, double rel);
/* Solves L L^T x = b with L from tvo_la_chol (n, ld as there); x may alias b. O(n^2). */
void tvo_la_chol_solve(const double *L, int n, int ld, const double *b, double *x);

/* Real roots of the polynomial c[0] + c[1] t + ... + c[deg] t^deg (deg <= 10) by Sturm sequences,
 * bisection and a safeguarded Newton polish. Writes at most deg roots, ascending, to roots[] and
 * returns their count (0 for a constant or all-zero polynomial). Multiple roots are reported once.
 * Bounded: at most 64 bisection levels per root. ~2-5 us for deg 10. */
int tvo_la_poly_real_roots(const double *c, int deg, double *roots);

/* Value of c[0] + c[1] t + ... + c[deg] t^deg (Horner). */
double tvo_la_poly_eval(const double *c, int deg, double t);

/* The k-th smallest of a[0..n) (0 <= k < n; k = n / 2 gives the median used by relpose and the VO),
 * reordering a in place: quickselect with a median-of-three pivot, deterministic, O(n) expected. The
 * values must not be NaN. */
double tvo_la_select_kth(double *a, int32_t n, int32_t k);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_LINALG_H */
