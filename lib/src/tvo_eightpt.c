/* Normalised 8-point algorithm (Hartley) on normalised image coordinates, projected onto the
 * essential manifold. */
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

int tvo_essential_8pt(const double (*x1)[2], const double (*x2)[2], int32_t n, double E[9])
{
    if (x1 == NULL || x2 == NULL || E == NULL || n < 8)
        return 0;
    double T1[9], T2[9];
    if (!hartley(x1, n, T1) || !hartley(x2, n, T2))
        return 0;
    double AtA[81];
    memset(AtA, 0, sizeof AtA);
    for (int32_t i = 0; i < n; ++i) {
        double a0 = T1[0] * x1[i][0] + T1[2], a1 = T1[4] * x1[i][1] + T1[5];
        double b0 = T2[0] * x2[i][0] + T2[2], b1 = T2[4] * x2[i][1] + T2[5];
        double r[9] = {b0 * a0, b0 * a1, b0, b1 * a0, b1 * a1, b1, a0, a1, 1.0};
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
    double Fn[9], tmp[9], F[9];
    for (int k = 0; k < 9; ++k)
        Fn[k] = V[9 * k + 0];
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
