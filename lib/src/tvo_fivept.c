/* SPDX-License-Identifier: Apache-2.0 */
/* Minimal 5-point essential matrix solver (Nister's formulation, written from the paper).
 *
 * 1. Each correspondence gives one row of x2^T E x1 = 0 in the 9 entries of E; the 4-dimensional
 *    null space of the 5x9 system (Householder QR of its transpose) gives E = x X + y Y + z Z + W.
 * 2. det(E) = 0 and 2 E E^T E - tr(E E^T) E = 0 give 10 cubic equations in (x, y, z) over 20
 *    monomials; Gauss-Jordan elimination of the first 10 monomials leaves rows of the form
 *    <monomial> + (terms in xz^2 xz x yz^2 yz y z^3 z^2 z 1).
 * 3. Subtracting z times the <x^2>, <y^2>, <xy> rows from the <x^2 z>, <y^2 z>, <xyz> rows gives a
 *    3x3 matrix B(z) with B(z) [x y 1]^T = 0, so det B(z) is a degree-10 polynomial in z.
 * 4. Its real roots (Sturm sequences) give z; x, y follow from the null vector of B(z).
 *
 * This file holds the driver, the shared stages and the portable versions of the four stages that
 * have a SIMD version (tvo_fivept_sse2.c; see tvo_fivept_impl.h). */
#include "tinyvo/relpose.h"
#include "tinyvo/linalg.h"
#include "tvo_fivept_impl.h"

#include <math.h>
#include <string.h>

/* Horner, as tvo_la_poly_eval (same operations), inlined */
FP_INLINE double peval(const double *c, int deg, double t)
{
    double v = c[deg];
    for (int i = deg - 1; i >= 0; --i)
        v = v * t + c[i];
    return v;
}

/* Stage 1: the 5x9 epipolar system, row i = (x2_i x1_i^T) flattened. Returns 0 when an entry is not
 * finite (the sum of every entry times 0 is exactly 0 only then). */
static int epipolar_rows(const double x1[5][2], const double x2[5][2], double A[5][9])
{
    double nf = 0.0;
    for (int i = 0; i < 5; ++i) {
        double a[3] = {x1[i][0], x1[i][1], 1.0};
        double b[3] = {x2[i][0], x2[i][1], 1.0};
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) {
                A[i][3 * r + c] = b[r] * a[c];
                nf += A[i][3 * r + c] * 0.0;
            }
    }
    return nf == 0.0;
}

#ifndef TVO_FIVEPT_SSE2
/* Householder step k of the QR factorisation of A^T, on the rows of A (row j of A is column j of
 * A^T): reflector v[k] (entries k..8), beta[k] = 2 / |v|^2, applied to rows k..4. Of row k only the
 * diagonal entry is computed (the rank check's R_kk; the entries it zeroes are never read). Called
 * with constant k, so that every loop has constant bounds. Returns 0 on rank loss. */
FP_INLINE_BIG int hh_step(double A[5][9], double v[5][9], double beta[5], int k)
{
    for (int i = k; i < 9; ++i)
        v[k][i] = A[k][i];
    if (!hh_reflector(v, beta, k))
        return 0;
    for (int j = k; j < 5; ++j) {
        double d = 0.0;
        for (int i = k; i < 9; ++i)
            d += v[k][i] * A[j][i];
        d *= beta[k];
        if (j == k) {
            A[k][k] -= d * v[k][k];
            continue;
        }
        for (int i = k; i < 9; ++i)
            A[j][i] -= d * v[k][i];
    }
    /* rank check: the diagonal of R must not vanish relative to the row scale (R_00 is final
     * after step 0) */
    return fabs(A[k][k]) > FP_RANK_REL * fabs(A[0][0]);
}

/* e = H_k e (reflector k of hh_step), constant k */
FP_INLINE_BIG void hh_apply(double e[9], double v[5][9], const double beta[5], int k)
{
    double d = 0.0;
    for (int i = k; i < 9; ++i)
        d += v[k][i] * e[i];
    d *= beta[k];
    for (int i = k; i < 9; ++i)
        e[i] -= d * v[k][i];
}

/* Stage 2 (portable): the null space as the last 4 columns of Q in A^T = Q R */
int tvo_fivept_null_space(double A[5][9], double L[9][4])
{
    double v[5][9];
    double beta[5];
    if (!hh_step(A, v, beta, 0) || !hh_step(A, v, beta, 1) || !hh_step(A, v, beta, 2) ||
        !hh_step(A, v, beta, 3) || !hh_step(A, v, beta, 4))
        return 0;
    for (int c = 0; c < 4; ++c) {
        double e[9] = {0};
        e[5 + c] = 1.0;
        hh_apply(e, v, beta, 4);
        hh_apply(e, v, beta, 3);
        hh_apply(e, v, beta, 2);
        hh_apply(e, v, beta, 1);
        hh_apply(e, v, beta, 0);
        for (int i = 0; i < 9; ++i)
            L[i][c] = e[i];
    }
    return 1;
}

/* Stage 3 (portable): E E^T (symmetric), the trace constraint's rows and the determinant row */
void tvo_fivept_constraints(double L[9][4], double M[10][20])
{
    double EEt[3][3][10], Aq[3][3][10], cof[3][10];
    for (int i = 0; i < 3; ++i) {
        for (int j = i; j < 3; ++j) {
            mul_ll3(L[3 * i], L[3 * j], L[3 * i + 1], L[3 * j + 1], L[3 * i + 2], L[3 * j + 2], EEt[i][j],
                    NULL);
            if (j != i)
                memcpy(EEt[j][i], EEt[i][j], sizeof EEt[i][j]);
        }
    }
    trace_matrix(EEt, Aq);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            mul_ql3(Aq[i][0], L[j], Aq[i][1], L[3 + j], Aq[i][2], L[6 + j], M[3 * i + j], NULL);
    det_cofactors(L, cof);
    mul_ql3(cof[0], L[0], cof[1], L[1], cof[2], L[2], M[9], NULL);
}

/* Stage 4 (portable). Rows are addressed through pointers (a pivot swap exchanges two pointers). The
 * update of a row starts at an even column (c itself when c is even: that entry is eliminated and
 * never read again), so the loops run over whole pairs of columns. Back-substitution from the bottom
 * never needs rows 0..3. */
int tvo_fivept_eliminate(double M[10][20], double *row[10])
{
    const double scale = elim_scale(M);
    if (scale == 0.0)
        return 0;
    for (int r = 0; r < 10; ++r)
        row[r] = M[r];
    for (int c = 0; c < 10; ++c) {
        if (!elim_pivot(row, c, scale))
            return 0;
        const double *pr = row[c];
        double inv = 1.0 / pr[c];
        int k0 = (c + 1) & ~1;
        for (int r = c + 1; r < 10; ++r) {
            double *rr = row[r];
            double f = rr[c] * inv;
            for (int k = k0; k < 20; k += 2) {
                rr[k] -= f * pr[k];
                rr[k + 1] -= f * pr[k + 1];
            }
        }
    }
    for (int r = 9; r >= 4; --r) {
        double *rr = row[r];
        double inv = 1.0 / rr[r];
        for (int k = 10; k < 20; k += 2) {
            double v0 = rr[k], v1 = rr[k + 1];
            for (int j = r + 1; j < 10; ++j) {
                v0 -= rr[j] * row[j][k];
                v1 -= rr[j] * row[j][k + 1];
            }
            rr[k] = v0 * inv;
            rr[k + 1] = v1 * inv;
        }
    }
    return 1;
}

/* Stage 6 (portable): cofactor expansion along the first row */
void tvo_fivept_det_poly(double B[3][3][5], double poly[11])
{
    double p1[8], p2[8], m0[8], m1[8], m2[8], d0[12], d1[12], d2[12];
    pmul(B[1][1], 3, B[2][2], 4, p1);
    pmul(B[1][2], 4, B[2][1], 3, p2);
    for (int i = 0; i <= 7; ++i)
        m0[i] = p1[i] - p2[i];
    pmul(B[1][0], 3, B[2][2], 4, p1);
    pmul(B[1][2], 4, B[2][0], 3, p2);
    for (int i = 0; i <= 7; ++i)
        m1[i] = p1[i] - p2[i];
    pmul(B[1][0], 3, B[2][1], 3, p1);
    pmul(B[1][1], 3, B[2][0], 3, p2);
    for (int i = 0; i <= 6; ++i)
        m2[i] = p1[i] - p2[i];
    m2[7] = 0.0;
    pmul(B[0][0], 3, m0, 7, d0);
    pmul(B[0][1], 3, m1, 7, d1);
    pmul(B[0][2], 4, m2, 6, d2);
    for (int i = 0; i <= 10; ++i)
        poly[i] = d0[i] - d1[i] + d2[i];
}
#endif /* !TVO_FIVEPT_SSE2 */

/* Stage 5: B(z) from the reduced rows (x^2z, x^2), (y^2z, y^2), (xyz, xy); ascending coefficients in z */
static void hidden_variable_matrix(double *const row[10], double B[3][3][5])
{
    static const int pairs[3][2] = {{4, 5}, {6, 7}, {8, 9}};
    for (int r = 0; r < 3; ++r) {
        const double *a = row[pairs[r][0]];
        const double *b = row[pairs[r][1]];
        B[r][0][0] = a[12];
        B[r][0][1] = a[11] - b[12];
        B[r][0][2] = a[10] - b[11];
        B[r][0][3] = -b[10];
        B[r][0][4] = 0.0;
        B[r][1][0] = a[15];
        B[r][1][1] = a[14] - b[15];
        B[r][1][2] = a[13] - b[14];
        B[r][1][3] = -b[13];
        B[r][1][4] = 0.0;
        B[r][2][0] = a[19];
        B[r][2][1] = a[18] - b[19];
        B[r][2][2] = a[17] - b[18];
        B[r][2][3] = a[16] - b[17];
        B[r][2][4] = -b[16];
    }
}

/* Stage 7: the essential matrix of root z (Frobenius norm 1) in e: (x, y) from the null vector of
 * B(z), the largest of the three row cross products. Returns 0 when B(z) gives no (x, y). */
static int solution_at(double z, double B[3][3][5], double L[9][4], double e[9])
{
    double Bz[3][3];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            Bz[r][c] = peval(B[r][c], c == 2 ? 4 : 3, z);
    double best[3] = {0, 0, 0}, bn = 0.0;
    for (int a = 0; a < 3; ++a) {
        const double *u = Bz[a], *w = Bz[a == 2 ? 0 : a + 1];
        double cr[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
        double nn = cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2];
        if (nn > bn) {
            bn = nn;
            memcpy(best, cr, sizeof best);
        }
    }
    if (!(bn > 0.0) || !(fabs(best[2]) > FP_ROOT_REL * sqrt(bn)))
        return 0;
    double x = best[0] / best[2], y = best[1] / best[2];
    double nrm = 0.0;
    for (int i = 0; i < 9; ++i) {
        e[i] = x * L[i][0] + y * L[i][1] + z * L[i][2] + L[i][3];
        nrm += e[i] * e[i];
    }
    nrm = sqrt(nrm);
    if (!(nrm > 0.0) || !isfinite(nrm))
        return 0;
    for (int i = 0; i < 9; ++i)
        e[i] /= nrm;
    return 1;
}

int tvo_essential_5pt(const double x1[5][2], const double x2[5][2], double E[10][9])
{
    if (x1 == NULL || x2 == NULL || E == NULL)
        return 0;
    double A[5][9], L[9][4], M[10][20], B[3][3][5], poly[11], roots[10];
    double *row[10];
    if (!epipolar_rows(x1, x2, A) || !tvo_fivept_null_space(A, L))
        return 0;
    tvo_fivept_constraints(L, M);
    if (!tvo_fivept_eliminate(M, row))
        return 0;
    hidden_variable_matrix(row, B);
    tvo_fivept_det_poly(B, poly);
    int nr = tvo_la_poly_real_roots(poly, 10, roots);
    int ns = 0;
    for (int k = 0; k < nr; ++k)
        ns += solution_at(roots[k], B, L, E[ns]);
    return ns;
}
