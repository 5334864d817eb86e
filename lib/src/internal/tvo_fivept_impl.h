/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo internal: the five-point solver's stages (tvo_fivept.c) and what its portable and SIMD
 * versions (tvo_fivept.c, tvo_fivept_sse2.c) share.
 *
 * Exactly one file defines the four per-architecture stages declared at the end: tvo_fivept_sse2.c
 * when TVO_FIVEPT_SSE2 is set, tvo_fivept.c otherwise. Every version does the operations of the
 * portable one in the same order in every lane (the build uses -ffp-contract=off), so the solutions
 * are bit-identical on every target (test_relpose's digests check it).
 *
 * Monomial order of the cubic constraints:
 *   0 x^3, 1 y^3, 2 x^2y, 3 xy^2, 4 x^2z, 5 x^2, 6 y^2z, 7 y^2, 8 xyz, 9 xy,
 *   10 xz^2, 11 xz, 12 x, 13 yz^2, 14 yz, 15 y, 16 z^3, 17 z^2, 18 z, 19 1
 * quadratic order: 0 xx, 1 xy, 2 xz, 3 yy, 4 yz, 5 zz, 6 x, 7 y, 8 z, 9 1
 * linear order: 0 x, 1 y, 2 z, 3 1 */
#ifndef TVO_FIVEPT_IMPL_H
#define TVO_FIVEPT_IMPL_H

#include <math.h>

/* SSE2: two rows or two columns per instruction (one per lane). TVO_FIVEPT_NO_SIMD, and every target
 * without SSE2, selects the portable C stages. */
#if defined(__SSE2__) && !defined(TVO_FIVEPT_NO_SIMD)
#define TVO_FIVEPT_SSE2 1
#endif

/* The small polynomial helpers are called ~50 times per solve: always inlined (GCC kept them out of
 * line otherwise). The larger written-out helpers (constraint rows, Householder steps) are inlined
 * too, except in size-optimised builds (-Os, the Cortex-M configuration), where that saves ~3 KB of
 * code; the operations are the same either way. */
#if defined(__GNUC__)
#define FP_INLINE static inline __attribute__((always_inline))
#else
#define FP_INLINE static inline
#endif
#if defined(__GNUC__) && !defined(__OPTIMIZE_SIZE__)
#define FP_INLINE_BIG static inline __attribute__((always_inline))
#else
#define FP_INLINE_BIG static inline
#endif

/* Thresholds of the solver (relative to the scale of the quantity they test) */
#define FP_TINY 1e-300     /* a norm or scale at or below this is zero */
#define FP_RANK_REL 1e-10  /* null space: |R_kk| <= this * |R_00| is rank loss */
#define FP_PIVOT_REL 1e-14 /* elimination: a pivot <= this * the largest entry is singular */
#define FP_ROOT_REL 1e-12  /* B(z)'s null vector: |third entry| <= this * its norm has no (x, y) */

/* q = a * b: linear (order above) times linear, quadratic result */
FP_INLINE void mul_ll(const double a[4], const double b[4], double q[10])
{
    q[0] = a[0] * b[0];
    q[1] = a[0] * b[1] + a[1] * b[0];
    q[2] = a[0] * b[2] + a[2] * b[0];
    q[3] = a[1] * b[1];
    q[4] = a[1] * b[2] + a[2] * b[1];
    q[5] = a[2] * b[2];
    q[6] = a[0] * b[3] + a[3] * b[0];
    q[7] = a[1] * b[3] + a[3] * b[1];
    q[8] = a[2] * b[3] + a[3] * b[2];
    q[9] = a[3] * b[3];
}

/* Lanes: the constraint-row formulas below are written once over fp_v, a double in the portable
 * stages (one row per call) and an SSE2 register of two doubles in tvo_fivept_sse2.c (which defines
 * FP_LANES_SSE2 before including this header: two rows per call, one per lane), with the same
 * operations in the same order in every lane. */
#if defined(FP_LANES_SSE2) && defined(TVO_FIVEPT_SSE2)
#include <emmintrin.h>
typedef __m128d fp_v;
#define FP_ADD(a, b) _mm_add_pd(a, b)
#define FP_MUL(a, b) _mm_mul_pd(a, b)
/* result k: lane 0 to lo[k], lane 1 to hi[k] */
#define FP_OUT(k, v)                 \
    do {                             \
        const fp_v r_ = (v);         \
        _mm_storel_pd(lo + (k), r_); \
        _mm_storeh_pd(hi + (k), r_); \
    } while (0)
#else
typedef double fp_v;
#define FP_ADD(a, b) ((a) + (b))
#define FP_MUL(a, b) ((a) * (b))
#define FP_OUT(k, v) (lo[k] = (v)) /* hi is NULL */
#endif
/* terms of one product x * y of coefficient arrays: one, two or three index pairs summed left to
 * right; FP_SUM3 adds the same term group of three products (x0 y0, x1 y1, x2 y2) in order */
#define FP_T1(x, y, a, b) FP_MUL((x)[a], (y)[b])
#define FP_T2(x, y, a, b, c, d) FP_ADD(FP_T1(x, y, a, b), FP_T1(x, y, c, d))
#define FP_T3(x, y, a, b, c, d, e, f) FP_ADD(FP_T2(x, y, a, b, c, d), FP_T1(x, y, e, f))
#define FP_SUM3(T, ...) FP_ADD(FP_ADD(T(x0, y0, __VA_ARGS__), T(x1, y1, __VA_ARGS__)), T(x2, y2, __VA_ARGS__))

/* c = x0 y0 + x1 y1 + x2 y2: three quadratic (x) times linear (y) products, cubic monomial order;
 * per monomial the sum over each product's terms, then the three sums in order (the operations of
 * accumulating the products one by one into a zeroed row, without its loads and stores) */
FP_INLINE_BIG void mul_ql3(const fp_v x0[10], const fp_v y0[4], const fp_v x1[10], const fp_v y1[4],
                           const fp_v x2[10], const fp_v y2[4], double lo[20], double hi[20])
{
    (void)hi;
    FP_OUT(0, FP_SUM3(FP_T1, 0, 0));
    FP_OUT(1, FP_SUM3(FP_T1, 3, 1));
    FP_OUT(2, FP_SUM3(FP_T2, 0, 1, 1, 0));
    FP_OUT(3, FP_SUM3(FP_T2, 1, 1, 3, 0));
    FP_OUT(4, FP_SUM3(FP_T2, 0, 2, 2, 0));
    FP_OUT(5, FP_SUM3(FP_T2, 0, 3, 6, 0));
    FP_OUT(6, FP_SUM3(FP_T2, 3, 2, 4, 1));
    FP_OUT(7, FP_SUM3(FP_T2, 3, 3, 7, 1));
    FP_OUT(8, FP_SUM3(FP_T3, 1, 2, 2, 1, 4, 0));
    FP_OUT(9, FP_SUM3(FP_T3, 1, 3, 6, 1, 7, 0));
    FP_OUT(10, FP_SUM3(FP_T2, 2, 2, 5, 0));
    FP_OUT(11, FP_SUM3(FP_T3, 2, 3, 6, 2, 8, 0));
    FP_OUT(12, FP_SUM3(FP_T2, 6, 3, 9, 0));
    FP_OUT(13, FP_SUM3(FP_T2, 4, 2, 5, 1));
    FP_OUT(14, FP_SUM3(FP_T3, 4, 3, 7, 2, 8, 1));
    FP_OUT(15, FP_SUM3(FP_T2, 7, 3, 9, 1));
    FP_OUT(16, FP_SUM3(FP_T1, 5, 2));
    FP_OUT(17, FP_SUM3(FP_T2, 5, 3, 8, 2));
    FP_OUT(18, FP_SUM3(FP_T2, 8, 3, 9, 2));
    FP_OUT(19, FP_SUM3(FP_T1, 9, 3));
}

/* q = x0 y0 + x1 y1 + x2 y2: three linear-times-linear products per quadratic monomial (mul_ll's
 * terms), summed in the same order as an accumulation from 0 */
FP_INLINE_BIG void mul_ll3(const fp_v x0[4], const fp_v y0[4], const fp_v x1[4], const fp_v y1[4],
                           const fp_v x2[4], const fp_v y2[4], double lo[10], double hi[10])
{
    (void)hi;
    FP_OUT(0, FP_SUM3(FP_T1, 0, 0));
    FP_OUT(1, FP_SUM3(FP_T2, 0, 1, 1, 0));
    FP_OUT(2, FP_SUM3(FP_T2, 0, 2, 2, 0));
    FP_OUT(3, FP_SUM3(FP_T1, 1, 1));
    FP_OUT(4, FP_SUM3(FP_T2, 1, 2, 2, 1));
    FP_OUT(5, FP_SUM3(FP_T1, 2, 2));
    FP_OUT(6, FP_SUM3(FP_T2, 0, 3, 3, 0));
    FP_OUT(7, FP_SUM3(FP_T2, 1, 3, 3, 1));
    FP_OUT(8, FP_SUM3(FP_T2, 2, 3, 3, 2));
    FP_OUT(9, FP_SUM3(FP_T1, 3, 3));
}

/* ascending-coefficient polynomial product: r (deg da+db) = a * b */
FP_INLINE void pmul(const double *a, int da, const double *b, int db, double *r)
{
    for (int i = 0; i <= da + db; ++i)
        r[i] = 0.0;
    for (int i = 0; i <= da; ++i)
        for (int j = 0; j <= db; ++j)
            r[i + j] += a[i] * b[j];
}

/* Householder reflector k from x = v[k][k..8] (the column being reduced, filled by the caller), in
 * place: v[k][k] -= alpha with alpha = -sign(x_k) |x|, beta[k] = 2 / |v|^2. Returns 0 on rank loss
 * (|x| or |v| vanishes). */
FP_INLINE int hh_reflector(double v[5][9], double beta[5], int k)
{
    double norm = 0.0;
    for (int i = k; i < 9; ++i)
        norm += v[k][i] * v[k][i];
    norm = sqrt(norm);
    if (!(norm > FP_TINY))
        return 0;
    v[k][k] -= v[k][k] > 0.0 ? -norm : norm;
    double vv = 0.0;
    for (int i = k; i < 9; ++i)
        vv += v[k][i] * v[k][i];
    if (!(vv > FP_TINY))
        return 0;
    beta[k] = 2.0 / vv;
    return 1;
}

/* The trace constraint's matrix 2 E E^T - tr(E E^T) I (symmetric, quadratic entries) from E E^T */
FP_INLINE void trace_matrix(double EEt[3][3][10], double Aq[3][3][10])
{
    for (int m = 0; m < 10; ++m) {
        double tr = EEt[0][0][m] + EEt[1][1][m] + EEt[2][2][m];
        for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k)
                Aq[i][k][m] = 2.0 * EEt[i][k][m] - (i == k ? tr : 0.0);
    }
}

/* The cofactors of the first row of E (quadratic entries): det E = sum_j E_0j * cof[j] */
FP_INLINE void det_cofactors(double L[9][4], double cof[3][10])
{
    double t0[10], t1[10];
    mul_ll(L[4], L[8], t0);
    mul_ll(L[5], L[7], t1);
    for (int m = 0; m < 10; ++m)
        cof[0][m] = t0[m] - t1[m];
    mul_ll(L[5], L[6], t0);
    mul_ll(L[3], L[8], t1);
    for (int m = 0; m < 10; ++m)
        cof[1][m] = t0[m] - t1[m];
    mul_ll(L[3], L[7], t0);
    mul_ll(L[4], L[6], t1);
    for (int m = 0; m < 10; ++m)
        cof[2][m] = t0[m] - t1[m];
}

/* The largest |entry| of the first 10 columns of M (the elimination's scale); 0 when it is not
 * finite or vanishes */
FP_INLINE double elim_scale(double M[10][20])
{
    double scale = 0.0;
    for (int r = 0; r < 10; ++r)
        for (int k = 0; k < 10; ++k)
            if (fabs(M[r][k]) > scale)
                scale = fabs(M[r][k]);
    return (scale > FP_TINY) && isfinite(scale) ? scale : 0.0;
}

/* Partial pivoting for column c: the row of largest |entry| among rows c..9 is swapped (as pointers)
 * into place c. Returns 0 when the pivot is singular relative to scale. */
FP_INLINE int elim_pivot(double *row[10], int c, double scale)
{
    int p = c;
    double pv = fabs(row[c][c]);
    for (int r = c + 1; r < 10; ++r)
        if (fabs(row[r][c]) > pv) {
            pv = fabs(row[r][c]);
            p = r;
        }
    if (!(pv > FP_PIVOT_REL * scale))
        return 0;
    double *pr = row[p];
    row[p] = row[c];
    row[c] = pr;
    return 1;
}

/* ---- per-architecture stages (tvo_fivept.c portable, tvo_fivept_sse2.c) ---- */

/* 4-dim null space of the 5x9 epipolar system A (rows; overwritten) by Householder QR of A^T,
 * L[i][c] = entry i of null vector c (the entries of E as linear polynomials in x, y, z, 1).
 * Returns 0 on rank loss. */
int tvo_fivept_null_space(double A[5][9], double L[9][4]);

/* The 10 cubic constraints over the 20 monomials: rows 0..8 (2 E E^T - tr(E E^T) I) E = 0, row 9
 * det E = 0. */
void tvo_fivept_constraints(double L[9][4], double M[10][20]);

/* Elimination of the first 10 monomials of M (LU with partial pivoting; row[] gets the rows in pivot
 * order), then back-substitution of rows 4..9 only, the rows B(z) needs. Returns 0 when singular. */
int tvo_fivept_eliminate(double M[10][20], double *row[10]);

/* det B(z), B with ascending coefficients in z of degrees 3, 3, 4 per column: degree 10 */
void tvo_fivept_det_poly(double B[3][3][5], double poly[11]);

#endif /* TVO_FIVEPT_IMPL_H */
