/* Minimal 5-point essential matrix solver (Nister's formulation, written from the paper).
 *
 * 1. Each correspondence gives one row of x2^T E x1 = 0 in the 9 entries of E; the 4-dimensional
 *    null space of the 5x9 system (Householder QR of its transpose) gives E = x X + y Y + z Z + W.
 * 2. det(E) = 0 and 2 E E^T E - tr(E E^T) E = 0 give 10 cubic equations in (x, y, z) over 20
 *    monomials; Gauss-Jordan elimination of the first 10 monomials leaves rows of the form
 *    <monomial> + (terms in xz^2 xz x yz^2 yz y z^3 z^2 z 1).
 * 3. Subtracting z times the <x^2>, <y^2>, <xy> rows from the <x^2 z>, <y^2 z>, <xyz> rows gives a
 *    3x3 matrix B(z) with B(z) [x y 1]^T = 0, so det B(z) is a degree-10 polynomial in z.
 * 4. Its real roots (Sturm sequences) give z; x, y follow from the null vector of B(z). */
#include "tinyvo/relpose.h"
#include "tinyvo/linalg.h"

#include <math.h>
#include <string.h>

/* SSE2: two constraint rows per pass (one per lane); TVO_FIVEPT_NO_SIMD (and every other target)
 * uses the C code, same operations per row. */
#if defined(__SSE2__) && !defined(TVO_FIVEPT_NO_SIMD)
#include <emmintrin.h>
#define FP_SSE2 1
#endif

/* The polynomial helpers below are called ~50 times per solve: always inline them (GCC kept them
 * out of line; inlined, a solve takes ~2 % fewer instructions, same results). */
#if defined(__GNUC__)
#define FP_INLINE static inline __attribute__((always_inline))
#else
#define FP_INLINE static inline
#endif
/* The larger written-out helpers (constraint rows, Householder steps) are inlined for speed, but
 * left to the compiler in size-optimised builds (-Os, the Cortex-M configuration): ~3 KB less
 * code there; same operations either way. */
#if defined(__GNUC__) && !defined(__OPTIMIZE_SIZE__)
#define FP_INLINE_BIG static inline __attribute__((always_inline))
#else
#define FP_INLINE_BIG static inline
#endif

/* monomial order: 0 x^3, 1 y^3, 2 x^2y, 3 xy^2, 4 x^2z, 5 x^2, 6 y^2z, 7 y^2, 8 xyz, 9 xy,
 *                 10 xz^2, 11 xz, 12 x, 13 yz^2, 14 yz, 15 y, 16 z^3, 17 z^2, 18 z, 19 1
 * quadratic order: 0 xx, 1 xy, 2 xz, 3 yy, 4 yz, 5 zz, 6 x, 7 y, 8 z, 9 1
 * linear order: 0 x, 1 y, 2 z, 3 1 */
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

/* Lanes: the constraint-row formulas below are written once over fp_v, a double on portable
 * builds (one row per call) and an SSE2 register of two doubles on SSE2 builds (two rows per call,
 * one per lane), with the same operations in the same order in every lane (bit-identical rows). */
#ifdef FP_SSE2
typedef __m128d fp_v;
#define FP_ADD(a, b) _mm_add_pd(a, b)
#define FP_MUL(a, b) _mm_mul_pd(a, b)
#else
typedef double fp_v;
#define FP_ADD(a, b) ((a) + (b))
#define FP_MUL(a, b) ((a) * (b))
#endif
/* terms of one product x * y of coefficient arrays: one, two or three index pairs summed left to
 * right; FP_SUM3 adds the same term group of three products (x0 y0, x1 y1, x2 y2) in order */
#define FP_T1(x, y, a, b) FP_MUL((x)[a], (y)[b])
#define FP_T2(x, y, a, b, c, d) FP_ADD(FP_T1(x, y, a, b), FP_T1(x, y, c, d))
#define FP_T3(x, y, a, b, c, d, e, f) FP_ADD(FP_T2(x, y, a, b, c, d), FP_T1(x, y, e, f))
#define FP_SUM3(T, ...) FP_ADD(FP_ADD(T(x0, y0, __VA_ARGS__), T(x1, y1, __VA_ARGS__)), T(x2, y2, __VA_ARGS__))
/* result k: lane 0 to lo[k], lane 1 to hi[k] (portable builds: the one value to lo[k]) */
#ifdef FP_SSE2
#define FP_OUT(k, v)                                                                              \
    do {                                                                                          \
        const fp_v r_ = (v);                                                                      \
        _mm_storel_pd(lo + (k), r_);                                                              \
        _mm_storeh_pd(hi + (k), r_);                                                              \
    } while (0)
#else
#define FP_OUT(k, v) (lo[k] = (v))
#endif

/* c = x0 y0 + x1 y1 + x2 y2: three quadratic (x, order above) times linear (y) products, cubic
 * monomial order above; per monomial the sum over each product's terms, then the three sums in
 * order (the operations of accumulating the products one by one into a zeroed row, without its
 * loads and stores) */
FP_INLINE_BIG void mul_ql3(const fp_v x0[10], const fp_v y0[4], const fp_v x1[10], const fp_v y1[4],
                           const fp_v x2[10], const fp_v y2[4], double lo[20], double hi[20])
{
    (void)hi; /* NULL on portable builds */
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
    (void)hi; /* NULL on portable builds */
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

#ifdef FP_SSE2
/* pmul in two lanes (two products at once, pmul's operations per lane) */
FP_INLINE void pmul2(const __m128d *a, int da, const __m128d *b, int db, __m128d *r)
{
    for (int i = 0; i <= da + db; ++i)
        r[i] = _mm_setzero_pd();
    for (int i = 0; i <= da; ++i)
        for (int j = 0; j <= db; ++j)
            r[i + j] = _mm_add_pd(r[i + j], _mm_mul_pd(a[i], b[j]));
}
#endif

/* Horner, as tvo_la_poly_eval (same operations), inlined */
FP_INLINE double peval(const double *c, int deg, double t)
{
    double v = c[deg];
    for (int i = deg - 1; i >= 0; --i)
        v = v * t + c[i];
    return v;
}

/* Householder reflector k from x = v[k][k..8] (the column being reduced, filled by the caller), in
 * place: v[k][k] -= alpha with alpha = -sign(x_k) |x|, beta[k] = 2 / |v|^2. Both QR versions below
 * use it. Returns 0 on rank loss (|x| or |v| vanishes). */
FP_INLINE int hh_reflector(double v[5][9], double beta[5], int k)
{
    double norm = 0.0;
    for (int i = k; i < 9; ++i)
        norm += v[k][i] * v[k][i];
    norm = sqrt(norm);
    if (!(norm > 1e-300))
        return 0;
    v[k][k] -= v[k][k] > 0.0 ? -norm : norm;
    double vv = 0.0;
    for (int i = k; i < 9; ++i)
        vv += v[k][i] * v[k][i];
    if (!(vv > 1e-300))
        return 0;
    beta[k] = 2.0 / vv;
    return 1;
}

#ifndef FP_SSE2
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
    return fabs(A[k][k]) > 1e-10 * fabs(A[0][0]);
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
#endif

#ifndef FP_SSE2
/* 4-dim null space of the 5x9 matrix A (rows; overwritten) as the last 4 columns of Q in
 * A^T = Q R, returned transposed: L[i][c] = entry i of null vector c (the entries of E as linear
 * polynomials in x, y, z, 1). */
static int null_space_5x9(double A[5][9], double L[9][4])
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
#else
/* step k (constant) of the SSE2 Householder QR on M = A^T */
FP_INLINE_BIG int hh_step_sse2(double M[9][6], double v[5][9], double beta[5], int k)
{
    for (int i = k; i < 9; ++i)
        v[k][i] = M[i][k];
    if (!hh_reflector(v, beta, k))
        return 0;
    double d = 0.0;
    for (int i = k; i < 9; ++i)
        d += v[k][i] * M[i][k];
    d *= beta[k];
    M[k][k] -= d * v[k][k];
    const __m128d bk = _mm_set1_pd(beta[k]);
    for (int j = k + 1; j <= 4; j += 2) { /* columns j, j + 1 (5: zero padding) */
        __m128d D = _mm_setzero_pd();
        for (int i = k; i < 9; ++i)
            D = _mm_add_pd(D, _mm_mul_pd(_mm_set1_pd(v[k][i]), _mm_loadu_pd(M[i] + j)));
        D = _mm_mul_pd(D, bk);
        for (int i = k; i < 9; ++i)
            _mm_storeu_pd(M[i] + j, _mm_sub_pd(_mm_loadu_pd(M[i] + j), _mm_mul_pd(D, _mm_set1_pd(v[k][i]))));
    }
    /* rank check: the diagonal of R must not vanish relative to the row scale */
    if (!(fabs(M[k][k]) > 1e-10 * fabs(M[0][0])))
        return 0;
    return 1;
}

/* reflector k (constant) applied to the unit vectors in pairs */
FP_INLINE_BIG void hh_apply_sse2(__m128d E01[9], __m128d E23[9], double v[5][9], const double beta[5], int k)
{
    __m128d D01 = _mm_setzero_pd(), D23 = _mm_setzero_pd();
    for (int i = k; i < 9; ++i) {
        const __m128d vi = _mm_set1_pd(v[k][i]);
        D01 = _mm_add_pd(D01, _mm_mul_pd(vi, E01[i]));
        D23 = _mm_add_pd(D23, _mm_mul_pd(vi, E23[i]));
    }
    const __m128d bk = _mm_set1_pd(beta[k]);
    D01 = _mm_mul_pd(D01, bk);
    D23 = _mm_mul_pd(D23, bk);
    for (int i = k; i < 9; ++i) {
        const __m128d vi = _mm_set1_pd(v[k][i]);
        E01[i] = _mm_sub_pd(E01[i], _mm_mul_pd(D01, vi));
        E23[i] = _mm_sub_pd(E23[i], _mm_mul_pd(D23, vi));
    }
}

/* SSE2 version of the same: A^T is stored with the columns of R in pairs (M[i][j], M[i][j + 1]),
 * so a reflector is applied to two columns per instruction, and to the four unit vectors in two
 * pairs (lanes: null vectors 0, 1 and 2, 3). Each lane does the operations of the C version in
 * the same order (the sums over i run in ascending i per lane), so the results are the same. */
static int null_space_5x9(double A[5][9], double L[9][4])
{
    double M[9][6];
    double v[5][9], beta[5];
    for (int i = 0; i < 9; ++i) {
        for (int j = 0; j < 5; ++j)
            M[i][j] = A[j][i];
        M[i][5] = 0.0;
    }
    if (!hh_step_sse2(M, v, beta, 0) || !hh_step_sse2(M, v, beta, 1) || !hh_step_sse2(M, v, beta, 2) ||
        !hh_step_sse2(M, v, beta, 3) || !hh_step_sse2(M, v, beta, 4))
        return 0;
    __m128d E01[9], E23[9];
    for (int i = 0; i < 9; ++i)
        E01[i] = E23[i] = _mm_setzero_pd();
    E01[5] = _mm_set_pd(0.0, 1.0);
    E01[6] = _mm_set_pd(1.0, 0.0);
    E23[7] = _mm_set_pd(0.0, 1.0);
    E23[8] = _mm_set_pd(1.0, 0.0);
    hh_apply_sse2(E01, E23, v, beta, 4);
    hh_apply_sse2(E01, E23, v, beta, 3);
    hh_apply_sse2(E01, E23, v, beta, 2);
    hh_apply_sse2(E01, E23, v, beta, 1);
    hh_apply_sse2(E01, E23, v, beta, 0);
    for (int i = 0; i < 9; ++i) {
        _mm_storeu_pd(L[i], E01[i]);
        _mm_storeu_pd(L[i] + 2, E23[i]);
    }
    return 1;
}
#endif

int tvo_essential_5pt(const double x1[5][2], const double x2[5][2], double E[10][9])
{
    if (x1 == NULL || x2 == NULL || E == NULL)
        return 0;
    double A[5][9];
    double nf = 0.0; /* sum of A_ij * 0: exactly 0 when every entry is finite, NaN otherwise */
    for (int i = 0; i < 5; ++i) {
        double a[3] = {x1[i][0], x1[i][1], 1.0};
        double b[3] = {x2[i][0], x2[i][1], 1.0};
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) {
                A[i][3 * r + c] = b[r] * a[c];
                nf += A[i][3 * r + c] * 0.0;
            }
    }
    if (nf != 0.0)
        return 0;
    /* entries of E as linear polynomials in (x, y, z, 1) */
    double L[9][4];
    if (!null_space_5x9(A, L))
        return 0;
    double M[10][20];
    /* E E^T (symmetric, quadratic entries) */
    double EEt[3][3][10];
#ifdef FP_SSE2
    {
        /* the six entries in pairs, one per lane: (00, 01), (02, 11), (12, 22) */
        static const int ij[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
        for (int p = 0; p < 6; p += 2) {
            const int ia = ij[p][0], ja = ij[p][1], ib = ij[p + 1][0], jb = ij[p + 1][1];
            __m128d Av[3][4], Bv[3][4];
            for (int k = 0; k < 3; ++k)
                for (int c = 0; c < 4; ++c) {
                    Av[k][c] = _mm_set_pd(L[3 * ib + k][c], L[3 * ia + k][c]);
                    Bv[k][c] = _mm_set_pd(L[3 * jb + k][c], L[3 * ja + k][c]);
                }
            mul_ll3(Av[0], Bv[0], Av[1], Bv[1], Av[2], Bv[2], EEt[ia][ja], EEt[ib][jb]);
        }
        for (int i = 0; i < 3; ++i)
            for (int j = i + 1; j < 3; ++j)
                memcpy(EEt[j][i], EEt[i][j], sizeof EEt[i][j]);
    }
#else
    for (int i = 0; i < 3; ++i) {
        for (int j = i; j < 3; ++j) {
            mul_ll3(L[3 * i], L[3 * j], L[3 * i + 1], L[3 * j + 1], L[3 * i + 2], L[3 * j + 2], EEt[i][j], NULL);
            if (j != i)
                memcpy(EEt[j][i], EEt[i][j], sizeof EEt[i][j]);
        }
    }
#endif
    /* Aq = 2 E E^T - tr I (symmetric); rows 0..8: (Aq E)_ij */
    double Aq[3][3][10];
    for (int m = 0; m < 10; ++m) {
        double tr = EEt[0][0][m] + EEt[1][1][m] + EEt[2][2][m];
        for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k)
                Aq[i][k][m] = 2.0 * EEt[i][k][m] - (i == k ? tr : 0.0);
    }
#ifndef FP_SSE2
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            mul_ql3(Aq[i][0], L[j], Aq[i][1], L[3 + j], Aq[i][2], L[6 + j], M[3 * i + j], NULL);
#endif
    /* row 9: det E = sum_j E_0j * cofactor_0j */
    {
        double c0[10], c1[10], c2[10], t0[10], t1[10];
        mul_ll(L[4], L[8], t0);
        mul_ll(L[5], L[7], t1);
        for (int m = 0; m < 10; ++m)
            c0[m] = t0[m] - t1[m];
        mul_ll(L[5], L[6], t0);
        mul_ll(L[3], L[8], t1);
        for (int m = 0; m < 10; ++m)
            c1[m] = t0[m] - t1[m];
        mul_ll(L[3], L[7], t0);
        mul_ll(L[4], L[6], t1);
        for (int m = 0; m < 10; ++m)
            c2[m] = t0[m] - t1[m];
#ifdef FP_SSE2
        /* rows in pairs, one per lane: (j, 3 + j) for j = 0, 1, 2, then (6, 7), then (8, 9) */
        __m128d Q[3][10], Lv[3][4];
        for (int j = 0; j < 3; ++j) {
            for (int k = 0; k < 3; ++k) {
                for (int m = 0; m < 10; ++m)
                    Q[k][m] = _mm_set_pd(Aq[1][k][m], Aq[0][k][m]);
                for (int b = 0; b < 4; ++b)
                    Lv[k][b] = _mm_set1_pd(L[3 * k + j][b]);
            }
            mul_ql3(Q[0], Lv[0], Q[1], Lv[1], Q[2], Lv[2], M[j], M[3 + j]);
        }
        for (int k = 0; k < 3; ++k) {
            for (int m = 0; m < 10; ++m)
                Q[k][m] = _mm_set1_pd(Aq[2][k][m]);
            for (int b = 0; b < 4; ++b)
                Lv[k][b] = _mm_set_pd(L[3 * k + 1][b], L[3 * k][b]);
        }
        mul_ql3(Q[0], Lv[0], Q[1], Lv[1], Q[2], Lv[2], M[6], M[7]);
        const double *cof[3] = {c0, c1, c2};
        for (int k = 0; k < 3; ++k) {
            for (int m = 0; m < 10; ++m)
                Q[k][m] = _mm_set_pd(cof[k][m], Aq[2][k][m]);
            for (int b = 0; b < 4; ++b)
                Lv[k][b] = _mm_set_pd(L[k][b], L[3 * k + 2][b]);
        }
        mul_ql3(Q[0], Lv[0], Q[1], Lv[1], Q[2], Lv[2], M[8], M[9]);
#else
        mul_ql3(c0, L[0], c1, L[1], c2, L[2], M[9], NULL);
#endif
    }
    /* Elimination of the first 10 monomials: LU with partial pivoting (row swaps keep the
     * monomial order of the unknowns), then back-substitution for the last 6 rows only: B(z)
     * needs the reduced rows of x^2z, x^2, y^2z, y^2, xyz, xy (indices 4..9), and back-
     * substitution from the bottom never needs rows 0..3. */
    double scale = 0.0;
    for (int r = 0; r < 10; ++r)
        for (int k = 0; k < 10; ++k)
            if (fabs(M[r][k]) > scale)
                scale = fabs(M[r][k]);
    if (!(scale > 1e-300) || !isfinite(scale))
        return 0;
    double *row[10];
    for (int r = 0; r < 10; ++r)
        row[r] = M[r];
    /* Rows are addressed through pointers (a pivot swap exchanges two pointers). The update of a
     * row starts at an even column (c itself when c is even: that entry is eliminated and never
     * read again), so the loop runs over whole pairs of columns. */
    for (int c = 0; c < 10; ++c) {
        int p = c;
        double pv = fabs(row[c][c]);
        for (int r = c + 1; r < 10; ++r)
            if (fabs(row[r][c]) > pv) {
                pv = fabs(row[r][c]);
                p = r;
            }
        if (!(pv > 1e-14 * scale))
            return 0;
        double *pr = row[p];
        row[p] = row[c];
        row[c] = pr;
        double inv = 1.0 / pr[c];
        int k0 = (c + 1) & ~1;
        for (int r = c + 1; r < 10; ++r) {
            double *rr = row[r];
            double f = rr[c] * inv;
#ifdef FP_SSE2
            /* the pairs of columns k0..19, unrolled (entry point by k0) */
            const __m128d fv = _mm_set1_pd(f);
#define FP_UPD(k) _mm_storeu_pd(rr + (k), _mm_sub_pd(_mm_loadu_pd(rr + (k)), _mm_mul_pd(fv, _mm_loadu_pd(pr + (k)))))
            switch (k0) {
            case 0:
                FP_UPD(0);
                /* fall through */
            case 2:
                FP_UPD(2);
                /* fall through */
            case 4:
                FP_UPD(4);
                /* fall through */
            case 6:
                FP_UPD(6);
                /* fall through */
            case 8:
                FP_UPD(8);
                /* fall through */
            case 10:
                FP_UPD(10);
                /* fall through */
            case 12:
                FP_UPD(12);
                /* fall through */
            case 14:
                FP_UPD(14);
                /* fall through */
            case 16:
                FP_UPD(16);
                /* fall through */
            case 18:
                FP_UPD(18);
            default:
                break;
            }
#undef FP_UPD
#else
            for (int k = k0; k < 20; k += 2) {
                rr[k] -= f * pr[k];
                rr[k + 1] -= f * pr[k + 1];
            }
#endif
        }
    }
    for (int r = 9; r >= 4; --r) {
        double *rr = row[r];
        double inv = 1.0 / rr[r];
#ifdef FP_SSE2
        /* the five column pairs in registers, rows r+1..9 subtracted in the same order */
        __m128d v[5];
        for (int q = 0; q < 5; ++q)
            v[q] = _mm_loadu_pd(rr + 10 + 2 * q);
        for (int j = r + 1; j < 10; ++j) {
            const __m128d fj = _mm_set1_pd(rr[j]);
            const double *rj = row[j] + 10;
            for (int q = 0; q < 5; ++q)
                v[q] = _mm_sub_pd(v[q], _mm_mul_pd(fj, _mm_loadu_pd(rj + 2 * q)));
        }
        const __m128d iv = _mm_set1_pd(inv);
        for (int q = 0; q < 5; ++q)
            _mm_storeu_pd(rr + 10 + 2 * q, _mm_mul_pd(v[q], iv));
#else
        for (int k = 10; k < 20; k += 2) {
            double v0 = rr[k], v1 = rr[k + 1];
            for (int j = r + 1; j < 10; ++j) {
                v0 -= rr[j] * row[j][k];
                v1 -= rr[j] * row[j][k + 1];
            }
            rr[k] = v0 * inv;
            rr[k + 1] = v1 * inv;
        }
#endif
    }
    /* B(z): rows from (x^2z, x^2), (y^2z, y^2), (xyz, xy); ascending coefficients in z */
    double B[3][3][5];
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
    /* det B: degrees 3, 3, 4 per column */
    double poly[11];
#ifdef FP_SSE2
    {
        /* the products in pairs, one per lane (the C code's operations per lane):
         * (B11 B22, B10 B22) - (B12 B21, B12 B20) = (m0, m1); B10 B21 - B11 B20 = m2 (lanes of one
         * product pair); (B00 m0, B01 m1) = (d0, d1); d2 = B02 m2 in C */
        __m128d a[5], b[8], r[12], m01[8];
        double m2[8], d2[12], p1[8], p2[8];
        for (int i = 0; i <= 3; ++i)
            a[i] = _mm_set_pd(B[1][0][i], B[1][1][i]);
        for (int j = 0; j <= 4; ++j)
            b[j] = _mm_set1_pd(B[2][2][j]);
        pmul2(a, 3, b, 4, m01);
        for (int i = 0; i <= 4; ++i)
            a[i] = _mm_set1_pd(B[1][2][i]);
        for (int j = 0; j <= 3; ++j)
            b[j] = _mm_set_pd(B[2][0][j], B[2][1][j]);
        pmul2(a, 4, b, 3, r);
        for (int i = 0; i <= 7; ++i)
            m01[i] = _mm_sub_pd(m01[i], r[i]);
        for (int i = 0; i <= 3; ++i) {
            a[i] = _mm_set_pd(B[1][1][i], B[1][0][i]);
            b[i] = _mm_set_pd(B[2][0][i], B[2][1][i]);
        }
        pmul2(a, 3, b, 3, r);
        for (int i = 0; i <= 6; ++i) {
            _mm_storel_pd(p1 + i, r[i]);
            _mm_storeh_pd(p2 + i, r[i]);
            m2[i] = p1[i] - p2[i];
        }
        m2[7] = 0.0;
        for (int i = 0; i <= 3; ++i)
            a[i] = _mm_set_pd(B[0][1][i], B[0][0][i]);
        pmul2(a, 3, m01, 7, r);
        pmul(B[0][2], 4, m2, 6, d2);
        for (int i = 0; i <= 10; ++i) {
            double d0, d1;
            _mm_storel_pd(&d0, r[i]);
            _mm_storeh_pd(&d1, r[i]);
            poly[i] = d0 - d1 + d2[i];
        }
    }
#else
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
#endif
    double roots[10];
    int nr = tvo_la_poly_real_roots(poly, 10, roots);
    int ns = 0;
    for (int k = 0; k < nr; ++k) {
        double z = roots[k];
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
        if (!(bn > 0.0) || !(fabs(best[2]) > 1e-12 * sqrt(bn)))
            continue;
        double x = best[0] / best[2], y = best[1] / best[2];
        double e[9], nrm = 0.0;
        for (int i = 0; i < 9; ++i) {
            e[i] = x * L[i][0] + y * L[i][1] + z * L[i][2] + L[i][3];
            nrm += e[i] * e[i];
        }
        nrm = sqrt(nrm);
        if (!(nrm > 0.0) || !isfinite(nrm))
            continue;
        for (int i = 0; i < 9; ++i)
            E[ns][i] = e[i] / nrm;
        ++ns;
    }
    return ns;
}
