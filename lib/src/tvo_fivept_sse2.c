/* SPDX-License-Identifier: Apache-2.0 */
/* The five-point solver's SSE2 stages (see tvo_fivept_impl.h; the portable versions are in
 * tvo_fivept.c). Two rows, two columns or two products per instruction, one per lane, each lane with
 * the operations of the portable stage in the same order, so the results are bit-identical. */
#define FP_LANES_SSE2 1
#include "tvo_fivept_impl.h"

#ifdef TVO_FIVEPT_SSE2
#include <emmintrin.h>
#include <string.h>

/* Householder step k (constant) on M = A^T, whose columns are stored in pairs (M[i][j], M[i][j + 1];
 * column 5 is zero padding): the reflector is applied to two columns per instruction. */
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
    for (int j = k + 1; j <= 4; j += 2) {
        __m128d D = _mm_setzero_pd();
        for (int i = k; i < 9; ++i)
            D = _mm_add_pd(D, _mm_mul_pd(_mm_set1_pd(v[k][i]), _mm_loadu_pd(M[i] + j)));
        D = _mm_mul_pd(D, bk);
        for (int i = k; i < 9; ++i)
            _mm_storeu_pd(M[i] + j, _mm_sub_pd(_mm_loadu_pd(M[i] + j), _mm_mul_pd(D, _mm_set1_pd(v[k][i]))));
    }
    /* rank check: the diagonal of R must not vanish relative to the row scale */
    if (!(fabs(M[k][k]) > FP_RANK_REL * fabs(M[0][0])))
        return 0;
    return 1;
}

/* reflector k (constant) applied to the four unit vectors in two pairs (lanes: null vectors 0, 1 and
 * 2, 3) */
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

int tvo_fivept_null_space(double A[5][9], double L[9][4])
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

/* E E^T: the six entries in pairs, one per lane: (00, 01), (02, 11), (12, 22) */
static void eet_sse2(double L[9][4], double EEt[3][3][10])
{
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

/* The constraint rows in pairs, one per lane: (j, 3 + j) for j = 0, 1, 2, then (6, 7), then (8, 9) */
void tvo_fivept_constraints(double L[9][4], double M[10][20])
{
    double EEt[3][3][10], Aq[3][3][10], cof[3][10];
    eet_sse2(L, EEt);
    trace_matrix(EEt, Aq);
    det_cofactors(L, cof);
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
    for (int k = 0; k < 3; ++k) {
        for (int m = 0; m < 10; ++m)
            Q[k][m] = _mm_set_pd(cof[k][m], Aq[2][k][m]);
        for (int b = 0; b < 4; ++b)
            Lv[k][b] = _mm_set_pd(L[k][b], L[3 * k + 2][b]);
    }
    mul_ql3(Q[0], Lv[0], Q[1], Lv[1], Q[2], Lv[2], M[8], M[9]);
}

/* rr[k0..19] -= f * pr[k0..19] in column pairs, unrolled (entry point by the even k0) */
FP_INLINE void row_update_sse2(double *rr, const double *pr, double f, int k0)
{
    const __m128d fv = _mm_set1_pd(f);
#define FP_UPD(k) \
    _mm_storeu_pd(rr + (k), _mm_sub_pd(_mm_loadu_pd(rr + (k)), _mm_mul_pd(fv, _mm_loadu_pd(pr + (k)))))
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
}

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
        for (int r = c + 1; r < 10; ++r)
            row_update_sse2(row[r], pr, row[r][c] * inv, k0);
    }
    /* back-substitution: the five column pairs in registers, rows r+1..9 subtracted in order */
    for (int r = 9; r >= 4; --r) {
        double *rr = row[r];
        double inv = 1.0 / rr[r];
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
    }
    return 1;
}

/* pmul in two lanes (two products at once, pmul's operations per lane) */
FP_INLINE void pmul2(const __m128d *a, int da, const __m128d *b, int db, __m128d *r)
{
    for (int i = 0; i <= da + db; ++i)
        r[i] = _mm_setzero_pd();
    for (int i = 0; i <= da; ++i)
        for (int j = 0; j <= db; ++j)
            r[i + j] = _mm_add_pd(r[i + j], _mm_mul_pd(a[i], b[j]));
}

/* The products in pairs, one per lane: (B11 B22, B10 B22) - (B12 B21, B12 B20) = (m0, m1);
 * B10 B21 - B11 B20 = m2 (the lanes of one product pair); (B00 m0, B01 m1) = (d0, d1); d2 = B02 m2
 * in C */
void tvo_fivept_det_poly(double B[3][3][5], double poly[11])
{
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
typedef int tvo_fivept_sse2_unused; /* ISO C forbids an empty translation unit */
#endif /* TVO_FIVEPT_SSE2 */
