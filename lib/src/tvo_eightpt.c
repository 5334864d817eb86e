/* SPDX-License-Identifier: Apache-2.0 */
/* Normalised 8-point algorithm (Hartley) on normalised image coordinates, projected onto the
 * essential manifold. With exactly 8 correspondences (the RANSAC sample) the null vector of the 8x9
 * system comes from Gaussian elimination with complete pivoting; with more, from the smallest
 * eigenvector of the 9x9 normal matrix (least squares). */
#include "tinyvo/relpose.h"
#include "tinyvo/linalg.h"

#include <math.h>
#include <string.h>

/* similarity T (3x3) moving the centroid to 0 and the mean distance to sqrt(2); 0 if degenerate */
static int hartley(const double (*x)[2], int32_t n, double T[9])
{
    double cx = 0.0, cy = 0.0, d = 0.0;
    for (int32_t i = 0; i < n; ++i) {
        cx += x[i][0];
        cy += x[i][1];
    }
    cx /= (double)n;
    cy /= (double)n;
    for (int32_t i = 0; i < n; ++i)
        d += sqrt((x[i][0] - cx) * (x[i][0] - cx) + (x[i][1] - cy) * (x[i][1] - cy));
    d /= (double)n;
    if (!(d > 1e-12) || !isfinite(d))
        return 0;
    double s = sqrt(2.0) / d;
    memset(T, 0, 9 * sizeof(double));
    T[0] = s;
    T[2] = -s * cx;
    T[4] = s;
    T[5] = -s * cy;
    T[8] = 1.0;
    return 1;
}

/* Row i of the epipolar system on Hartley-normalised points: x2n^T F x1n = 0 in F's 9 entries. */
static void epi_row(const double (*x1)[2], const double (*x2)[2], int32_t i, const double T1[9],
                    const double T2[9], double r[9])
{
    const double a0 = T1[0] * x1[i][0] + T1[2], a1 = T1[4] * x1[i][1] + T1[5];
    const double b0 = T2[0] * x2[i][0] + T2[2], b1 = T2[4] * x2[i][1] + T2[5];
    r[0] = b0 * a0;
    r[1] = b0 * a1;
    r[2] = b0;
    r[3] = b1 * a0;
    r[4] = b1 * a1;
    r[5] = b1;
    r[6] = a0;
    r[7] = a1;
    r[8] = 1.0;
}

/* Null vector of the 8x9 system A f = 0 by Gaussian elimination with complete pivoting (~400
 * multiply-adds; the Jacobi eigen-decomposition of the normal matrix costs ~20x more). Returns 0
 * when the rank is below 8: a pivot below 1e-10 of the first (largest) one, e.g. points on a plane
 * or a line without noise. f is normalised to unit length. */
static int null_vector_8x9(double A[8][9], double f[9])
{
    int col[9];
    double p0 = 0.0;
    for (int c = 0; c < 9; ++c)
        col[c] = c;
    for (int k = 0; k < 8; ++k) {
        int pr = k, pc = k;
        double best = 0.0;
        for (int r = k; r < 8; ++r)
            for (int c = k; c < 9; ++c)
                if (fabs(A[r][c]) > best) {
                    best = fabs(A[r][c]);
                    pr = r;
                    pc = c;
                }
        if (k == 0)
            p0 = best;
        if (!(best > 1e-10 * p0) || !isfinite(best))
            return 0;
        if (pr != k)
            for (int c = 0; c < 9; ++c) {
                double t = A[k][c];
                A[k][c] = A[pr][c];
                A[pr][c] = t;
            }
        if (pc != k) {
            for (int r = 0; r < 8; ++r) {
                double t = A[r][k];
                A[r][k] = A[r][pc];
                A[r][pc] = t;
            }
            int t = col[k];
            col[k] = col[pc];
            col[pc] = t;
        }
        const double inv = 1.0 / A[k][k];
        for (int r = k + 1; r < 8; ++r) {
            const double m = A[r][k] * inv;
            for (int c = k + 1; c < 9; ++c)
                A[r][c] -= m * A[k][c];
        }
    }
    /* upper triangular in the permuted columns: the last one is free (1), back-substitute */
    double y[9], nrm = 1.0;
    y[8] = 1.0;
    for (int k = 7; k >= 0; --k) {
        double s = A[k][8];
        for (int c = k + 1; c < 8; ++c)
            s += A[k][c] * y[c];
        y[k] = -s / A[k][k];
        nrm += y[k] * y[k];
    }
    nrm = sqrt(nrm);
    if (!isfinite(nrm))
        return 0;
    for (int c = 0; c < 9; ++c)
        f[col[c]] = y[c] / nrm;
    return 1;
}

/* Least-squares null vector for n >= 8 correspondences: the eigenvector of the smallest eigenvalue
 * of the 9x9 normal matrix. Returns 0 when the null space has dimension > 1 (degenerate input). */
static int null_vector_normal(const double (*x1)[2], const double (*x2)[2], int32_t n, const double T1[9],
                              const double T2[9], double Fn[9])
{
    double AtA[81];
    memset(AtA, 0, sizeof AtA);
    for (int32_t i = 0; i < n; ++i) {
        double r[9];
        epi_row(x1, x2, i, T1, T2, r);
        for (int p = 0; p < 9; ++p)
            for (int q = p; q < 9; ++q)
                AtA[9 * p + q] += r[p] * r[q];
    }
    for (int p = 0; p < 9; ++p)
        for (int q = 0; q < p; ++q)
            AtA[9 * p + q] = AtA[9 * q + p];
    for (int k = 0; k < 81; ++k)
        if (!isfinite(AtA[k]))
            return 0;
    double w[9], V[81];
    if (tvo_la_sym_eig(AtA, 9, w, V) != TVO_OK)
        return 0;
    if (!(w[8] > 0.0) || !(w[1] > 1e-14 * w[8]))
        return 0; /* null space of dimension > 1: degenerate configuration */
    for (int k = 0; k < 9; ++k)
        Fn[k] = V[9 * k + 0];
    return 1;
}

int tvo_essential_8pt(const double (*x1)[2], const double (*x2)[2], int32_t n, double E[9])
{
    if (x1 == NULL || x2 == NULL || E == NULL || n < 8)
        return 0;
    double T1[9], T2[9];
    if (!hartley(x1, n, T1) || !hartley(x2, n, T2))
        return 0;
    double Fn[9];
    if (n == 8) {
        double A[8][9];
        for (int32_t i = 0; i < 8; ++i)
            epi_row(x1, x2, i, T1, T2, A[i]);
        if (!null_vector_8x9(A, Fn))
            return 0;
    } else if (!null_vector_normal(x1, x2, n, T1, T2, Fn)) {
        return 0;
    }
    double tmp[9], F[9];
    /* F = T2^T Fn T1 */
    tvo_la_mat3_mul(Fn, T1, tmp);
    tvo_la_mat3_mul_at(T2, tmp, F);
    double U[9], s[3], Vt[9];
    tvo_la_svd3(F, U, s, Vt);
    if (!(s[0] > 0.0))
        return 0;
    /* E = U diag(1,1,0) V^T / sqrt(2) */
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            E[3 * i + j] = (U[3 * i] * Vt[3 * j] + U[3 * i + 1] * Vt[3 * j + 1]) / sqrt(2.0);
    for (int k = 0; k < 9; ++k)
        if (!isfinite(E[k]))
            return 0;
    return 1;
}
