/* SPDX-License-Identifier: Apache-2.0 */
/* Small dense linear algebra for the geometry: 3x3 helpers, 3x3 SVD (one-sided Jacobi), symmetric
 * Jacobi eigen-decomposition, Gaussian elimination and Sturm-sequence polynomial root finding. */
#include "tinyvo/linalg.h"
#include "tinyvo/dmath.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

/* SSE2: the degree-10 Newton iterations evaluate p and p' in the two lanes of one register;
 * TVO_LINALG_NO_SIMD (and every other target) uses the C loop, same operations per lane. */
#if defined(__SSE2__) && !defined(TVO_LINALG_NO_SIMD)
#include <emmintrin.h>
#define LA_SSE2 1
#endif

/* The helpers below (the linear solver's, the root finder's and its Sturm chain's) are inlined into
 * their callers, the root finder's into a body specialised for degree 10 (the 5-point solver's case:
 * loops over the degree unroll, same operations in the same order). -Os builds (Cortex-M), which have
 * only the general body, leave them to the compiler: 2,012 bytes less code on the Cortex-M7, the same
 * results. */
#if defined(__GNUC__) && !defined(__OPTIMIZE_SIZE__)
#define LA_INLINE static inline __attribute__((always_inline))
#else
#define LA_INLINE static inline
#endif

void tvo_la_mat3_mul(const double A[9], const double B[9], double C[9])
{
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

void tvo_la_mat3_mul_bt(const double A[9], const double B[9], double C[9])
{
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            C[3 * i + j] = A[3 * i] * B[3 * j] + A[3 * i + 1] * B[3 * j + 1] + A[3 * i + 2] * B[3 * j + 2];
}

void tvo_la_mat3_mul_at(const double A[9], const double B[9], double C[9])
{
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            C[3 * i + j] = A[i] * B[j] + A[3 + i] * B[3 + j] + A[6 + i] * B[6 + j];
}

void tvo_la_mat3_vec(const double A[9], const double x[3], double y[3])
{
    y[0] = A[0] * x[0] + A[1] * x[1] + A[2] * x[2];
    y[1] = A[3] * x[0] + A[4] * x[1] + A[5] * x[2];
    y[2] = A[6] * x[0] + A[7] * x[1] + A[8] * x[2];
}

void tvo_la_mat3_tvec(const double A[9], const double x[3], double y[3])
{
    y[0] = A[0] * x[0] + A[3] * x[1] + A[6] * x[2];
    y[1] = A[1] * x[0] + A[4] * x[1] + A[7] * x[2];
    y[2] = A[2] * x[0] + A[5] * x[1] + A[8] * x[2];
}

double tvo_la_mat3_det(const double A[9])
{
    return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
            A[2] * (A[3] * A[7] - A[4] * A[6]);
}

void tvo_la_skew(const double v[3], double S[9])
{
    S[0] = 0.0;
    S[1] = -v[2];
    S[2] = v[1];
    S[3] = v[2];
    S[4] = 0.0;
    S[5] = -v[0];
    S[6] = -v[1];
    S[7] = v[0];
    S[8] = 0.0;
}

void tvo_la_cross(const double a[3], const double b[3], double c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

void tvo_la_so3_exp(const double w[3], double R[9])
{
    double th2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    double a, b;
    if (th2 < 1e-16) {
        a = 1.0 - th2 / 6.0;
        b = 0.5 - th2 / 24.0;
    } else {
        double th = sqrt(th2);
        a = tvo_dm_sin(th) / th;
        b = (1.0 - tvo_dm_cos(th)) / th2;
    }
    /* R = I + a [w] + b [w]^2, [w]^2 = w w^T - th2 I */
    R[0] = 1.0 + b * (w[0] * w[0] - th2);
    R[4] = 1.0 + b * (w[1] * w[1] - th2);
    R[8] = 1.0 + b * (w[2] * w[2] - th2);
    R[1] = b * w[0] * w[1] - a * w[2];
    R[3] = b * w[0] * w[1] + a * w[2];
    R[2] = b * w[0] * w[2] + a * w[1];
    R[6] = b * w[0] * w[2] - a * w[1];
    R[5] = b * w[1] * w[2] - a * w[0];
    R[7] = b * w[1] * w[2] + a * w[0];
}

double tvo_la_rot_angle(const double R[9])
{
    double c = 0.5 * (R[0] + R[4] + R[8] - 1.0);
    double vx = R[7] - R[5], vy = R[2] - R[6], vz = R[3] - R[1];
    double s = 0.5 * sqrt(vx * vx + vy * vy + vz * vz);
    if (c > 1.0)
        c = 1.0;
    if (c < -1.0)
        c = -1.0;
    return tvo_dm_atan2(s, c);
}

double tvo_la_rot_dist(const double Ra[9], const double Rb[9])
{
    double D[9];
    tvo_la_mat3_mul_at(Ra, Rb, D);
    return tvo_la_rot_angle(D);
}

static void any_orthogonal(const double u[3], double v[3])
{
    /* a unit vector orthogonal to unit u */
    double a[3] = {0.0, 0.0, 0.0};
    int k = 0;
    if (fabs(u[1]) < fabs(u[k]))
        k = 1;
    if (fabs(u[2]) < fabs(u[k]))
        k = 2;
    a[k] = 1.0;
    tvo_la_cross(u, a, v);
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    v[0] /= n;
    v[1] /= n;
    v[2] /= n;
}

void tvo_la_svd3(const double A[9], double U[9], double s[3], double V[9])
{
    double B[9];
    memcpy(B, A, sizeof B);
    for (int i = 0; i < 9; ++i)
        V[i] = (i % 4 == 0) ? 1.0 : 0.0;
    for (int sweep = 0; sweep < 30; ++sweep) {
        int rotated = 0;
        for (int p = 0; p < 2; ++p) {
            for (int q = p + 1; q < 3; ++q) {
                double al = 0.0, be = 0.0, ga = 0.0;
                for (int i = 0; i < 3; ++i) {
                    al += B[3 * i + p] * B[3 * i + p];
                    be += B[3 * i + q] * B[3 * i + q];
                    ga += B[3 * i + p] * B[3 * i + q];
                }
                if (fabs(ga) <= 1e-15 * sqrt(al * be) || ga == 0.0)
                    continue;
                rotated = 1;
                double zeta = (be - al) / (2.0 * ga);
                double t = (zeta >= 0.0 ? 1.0 : -1.0) / (fabs(zeta) + sqrt(1.0 + zeta * zeta));
                double c = 1.0 / sqrt(1.0 + t * t), sn = c * t;
                for (int i = 0; i < 3; ++i) {
                    double bp = B[3 * i + p], bq = B[3 * i + q];
                    B[3 * i + p] = c * bp - sn * bq;
                    B[3 * i + q] = sn * bp + c * bq;
                    double vp = V[3 * i + p], vq = V[3 * i + q];
                    V[3 * i + p] = c * vp - sn * vq;
                    V[3 * i + q] = sn * vp + c * vq;
                }
            }
        }
        if (!rotated)
            break;
    }
    double nrm[3];
    int ord[3] = {0, 1, 2};
    for (int j = 0; j < 3; ++j)
        nrm[j] = sqrt(B[j] * B[j] + B[3 + j] * B[3 + j] + B[6 + j] * B[6 + j]);
    for (int a = 0; a < 2; ++a)
        for (int b = a + 1; b < 3; ++b)
            if (nrm[ord[b]] > nrm[ord[a]]) {
                int tmp = ord[a];
                ord[a] = ord[b];
                ord[b] = tmp;
            }
    double Vs[9], u[3][3];
    for (int j = 0; j < 3; ++j) {
        int k = ord[j];
        s[j] = nrm[k];
        for (int i = 0; i < 3; ++i)
            Vs[3 * i + j] = V[3 * i + k];
        for (int i = 0; i < 3; ++i)
            u[j][i] = s[j] > 0.0 ? B[3 * i + k] / s[j] : 0.0;
    }
    memcpy(V, Vs, sizeof Vs);
    if (s[0] <= 1e-300) {
        u[0][0] = 1.0;
        u[0][1] = 0.0;
        u[0][2] = 0.0;
        u[1][0] = 0.0;
        u[1][1] = 1.0;
        u[1][2] = 0.0;
    } else if (s[1] <= 1e-13 * s[0]) {
        any_orthogonal(u[0], u[1]);
    }
    {
        double c[3];
        tvo_la_cross(u[0], u[1], c);
        double dot = c[0] * u[2][0] + c[1] * u[2][1] + c[2] * u[2][2];
        if (s[2] > 1e-13 * s[0] && dot < 0.0) {
            c[0] = -c[0];
            c[1] = -c[1];
            c[2] = -c[2];
        }
        u[2][0] = c[0];
        u[2][1] = c[1];
        u[2][2] = c[2];
    }
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i)
            U[3 * i + j] = u[j][i];
}

void tvo_la_orthonormalize(const double M[9], double R[9])
{
    double U[9], s[3], V[9];
    tvo_la_svd3(M, U, s, V);
    tvo_la_mat3_mul_bt(U, V, R);
    if (tvo_la_mat3_det(R) < 0.0) {
        U[2] = -U[2];
        U[5] = -U[5];
        U[8] = -U[8];
        tvo_la_mat3_mul_bt(U, V, R);
    }
}

tvo_status tvo_la_sym_eig(double *A, int n, double *w, double *V)
{
    if (A == NULL || w == NULL || V == NULL)
        return TVO_ERR_NULL;
    if (n < 1 || n > 10)
        return TVO_ERR_ARG;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            V[i * n + j] = (i == j) ? 1.0 : 0.0;
    for (int sweep = 0; sweep < 50; ++sweep) {
        double off = 0.0, diag = 0.0;
        for (int i = 0; i < n; ++i) {
            diag += A[i * n + i] * A[i * n + i];
            for (int j = i + 1; j < n; ++j)
                off += A[i * n + j] * A[i * n + j];
        }
        if (off <= 1e-30 * diag || off == 0.0)
            break;
        for (int p = 0; p < n - 1; ++p) {
            for (int q = p + 1; q < n; ++q) {
                double apq = A[p * n + q];
                if (apq == 0.0)
                    continue;
                double app = A[p * n + p], aqq = A[q * n + q];
                double theta = (aqq - app) / (2.0 * apq);
                double t = (theta >= 0.0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(1.0 + theta * theta));
                double c = 1.0 / sqrt(1.0 + t * t), s = t * c;
                for (int k = 0; k < n; ++k) {
                    double akp = A[k * n + p], akq = A[k * n + q];
                    A[k * n + p] = c * akp - s * akq;
                    A[k * n + q] = s * akp + c * akq;
                }
                for (int k = 0; k < n; ++k) {
                    double apk = A[p * n + k], aqk = A[q * n + k];
                    A[p * n + k] = c * apk - s * aqk;
                    A[q * n + k] = s * apk + c * aqk;
                }
                for (int k = 0; k < n; ++k) {
                    double vkp = V[k * n + p], vkq = V[k * n + q];
                    V[k * n + p] = c * vkp - s * vkq;
                    V[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    for (int i = 0; i < n; ++i)
        w[i] = A[i * n + i];
    /* sort ascending (selection sort, swapping eigenvector columns) */
    for (int i = 0; i < n - 1; ++i) {
        int m = i;
        for (int j = i + 1; j < n; ++j)
            if (w[j] < w[m])
                m = j;
        if (m != i) {
            double t = w[i];
            w[i] = w[m];
            w[m] = t;
            for (int k = 0; k < n; ++k) {
                t = V[k * n + i];
                V[k * n + i] = V[k * n + m];
                V[k * n + m] = t;
            }
        }
    }
    return TVO_OK;
}

/* Gaussian elimination with partial pivoting; inlined into bodies for n = 5 (the LM steps of the
 * relative pose) and n = 8 (homography refits), whose loops unroll: same operations, same order */
LA_INLINE tvo_status la_solve_n(double *A, double *b, int n, double *x)
{
    double amax = 0.0;
    for (int i = 0; i < n * n; ++i)
        if (fabs(A[i]) > amax)
            amax = fabs(A[i]);
    double tiny = amax * 1e-14;
    if (tiny < 1e-300)
        tiny = 1e-300;
    for (int k = 0; k < n; ++k) {
        int p = k;
        for (int i = k + 1; i < n; ++i)
            if (fabs(A[i * n + k]) > fabs(A[p * n + k]))
                p = i;
        if (!(fabs(A[p * n + k]) > tiny))
            return TVO_ERR_DEGENERATE;
        if (p != k) {
            for (int j = 0; j < n; ++j) {
                double t = A[k * n + j];
                A[k * n + j] = A[p * n + j];
                A[p * n + j] = t;
            }
            double t = b[k];
            b[k] = b[p];
            b[p] = t;
        }
        for (int i = k + 1; i < n; ++i) {
            double f = A[i * n + k] / A[k * n + k];
            if (f == 0.0)
                continue;
            for (int j = k; j < n; ++j)
                A[i * n + j] -= f * A[k * n + j];
            b[i] -= f * b[k];
        }
    }
    for (int i = n - 1; i >= 0; --i) {
        double s = b[i];
        for (int j = i + 1; j < n; ++j)
            s -= A[i * n + j] * x[j];
        x[i] = s / A[i * n + i];
    }
    return TVO_OK;
}

tvo_status tvo_la_solve(double *A, double *b, int n, double *x)
{
    if (A == NULL || b == NULL || x == NULL)
        return TVO_ERR_NULL;
    if (n < 1 || n > 10)
        return TVO_ERR_ARG;
    if (n == 5)
        return la_solve_n(A, b, 5, x);
    if (n == 8)
        return la_solve_n(A, b, 8, x);
    return la_solve_n(A, b, n, x);
}

LA_INLINE double poly_eval(const double *c, int deg, double t)
{
    double v = c[deg];
    for (int i = deg - 1; i >= 0; --i)
        v = v * t + c[i];
    return v;
}

double tvo_la_poly_eval(const double *c, int deg, double t)
{
    double v = c[deg];
    for (int i = deg - 1; i >= 0; --i)
        v = v * t + c[i];
    return v;
}

/* ---- Sturm sequences ------------------------------------------------------------------------ */

/* Two representations of the Sturm chain p0 = p, p1 = p', p(k+1) = -rem(p(k-1), p(k)):
 * - generic (fast): every remainder drops exactly one degree, so p(k-1) = (q0 + q1 t) p(k) + c p(k+1)
 *   with c < 0 and the whole chain evaluates at t by a three-term recurrence (about 3 flops per
 *   member, ~30 for degree 10) instead of one Horner evaluation per member (~65 for degree 10);
 * - general: the explicit polynomials, used when a remainder loses more than one degree (multiple
 *   roots, exact gcds, special coefficient patterns). */
typedef struct sturm_chain {
    double p[11][11]; /* general: p[k][i], coefficient of t^i of the k-th polynomial */
    int deg[11];
    int len;
    int fast;        /* 1: the recurrence below is valid */
    double q[10][3]; /* fast: q[k] = {q0, q1, c} for k = 1..deg-1 */
    double lin[2];   /* fast: p(deg-1) = lin[0] + lin[1] t */
    double cst;      /* fast: p(deg), a non-zero constant */
    int n;           /* fast: degree of p */
} sturm_chain;

LA_INLINE int sign_changes(const double *f, int len)
{
    int changes = 0, zero = 0;
    for (int k = 0; k < len; ++k)
        zero |= f[k] == 0.0;
    if (!zero) { /* the usual case: no member vanishes, count without branches */
        for (int k = 1; k < len; ++k)
            changes += (f[k] > 0.0) != (f[k - 1] > 0.0);
        return changes;
    }
    double prev = 0.0;
    for (int k = 0; k < len; ++k) {
        double v = f[k];
        if (v == 0.0)
            continue;
        if (prev != 0.0 && ((v > 0.0) != (prev > 0.0)))
            ++changes;
        prev = v;
    }
    return changes;
}

LA_INLINE int sturm_changes(const sturm_chain *s, int n, double t)
{
    double f[11];
    if (s->fast) {
        f[n] = s->cst;
        f[n - 1] = s->lin[0] + s->lin[1] * t;
        for (int k = n - 1; k >= 1; --k)
            f[k - 1] = (s->q[k][0] + s->q[k][1] * t) * f[k] + s->q[k][2] * f[k + 1];
        return sign_changes(f, n + 1);
    }
    for (int k = 0; k < s->len; ++k)
        f[k] = poly_eval(s->p[k], s->deg[k], t);
    return sign_changes(f, s->len);
}

/* one step of the fast chain: u = p(k-1) (degree d + 1), v = p(k) (degree d) -> w = p(k+1);
 * 0 when the remainder is not generic */
LA_INLINE int sturm_fast_step(sturm_chain *s, const double *u, const double *v, double *w, int k, int d)
{
    double q1 = u[d + 1] / v[d];
    double q0 = (u[d] - q1 * v[d - 1]) / v[d];
    double m = 0.0;
    for (int j = 0; j < d; ++j) {
        double r = u[j] - q0 * v[j] - (j > 0 ? q1 * v[j - 1] : 0.0);
        w[j] = r;
        if (fabs(r) > m)
            m = fabs(r);
    }
    double lead = fabs(w[d - 1]);
    if (!(lead > 1e-10 * m) || !isfinite(q0) || !isfinite(q1))
        return 0; /* degree drops by more than one (or an exact division): general chain */
    for (int j = 0; j < d; ++j)
        w[j] = -w[j] / lead; /* p(k+1) = -rem / |lead|, so p(k-1) = (q0 + q1 t) p(k) - lead p(k+1) */
    s->q[k][0] = q0;
    s->q[k][1] = q1;
    s->q[k][2] = -lead;
    return 1;
}

/* fast chain of a monic polynomial a of degree deg >= 2; 0 when some remainder is not generic */
LA_INLINE int sturm_build_fast(sturm_chain *s, const double *a, int deg)
{
    double buf[3][11];
    double *u = buf[0], *v = buf[1], *w = buf[2];
    for (int i = 0; i <= deg; ++i)
        u[i] = a[i];
    for (int i = 1; i <= deg; ++i)
        v[i - 1] = (double)i * a[i] / (double)deg; /* p' / deg: monic */
    s->n = deg;
    if (deg == 10) {
        /* the same steps with constant k (constant loop bounds), buffers rotating as below */
        if (!sturm_fast_step(s, buf[0], buf[1], buf[2], 1, 9) ||
            !sturm_fast_step(s, buf[1], buf[2], buf[0], 2, 8) ||
            !sturm_fast_step(s, buf[2], buf[0], buf[1], 3, 7) ||
            !sturm_fast_step(s, buf[0], buf[1], buf[2], 4, 6) ||
            !sturm_fast_step(s, buf[1], buf[2], buf[0], 5, 5) ||
            !sturm_fast_step(s, buf[2], buf[0], buf[1], 6, 4) ||
            !sturm_fast_step(s, buf[0], buf[1], buf[2], 7, 3) ||
            !sturm_fast_step(s, buf[1], buf[2], buf[0], 8, 2) ||
            !sturm_fast_step(s, buf[2], buf[0], buf[1], 9, 1))
            return 0;
        u = buf[0]; /* after 9 steps: u = p(9), v = p(10) */
        v = buf[1];
    } else {
        for (int k = 1; k < deg; ++k) {
            if (!sturm_fast_step(s, u, v, w, k, deg - k))
                return 0;
            double *tmp = u;
            u = v;
            v = w;
            w = tmp;
        }
    }
    /* now u = p(deg-1) (linear), v = p(deg) (constant) */
    s->lin[0] = u[0];
    s->lin[1] = u[1];
    s->cst = v[0];
    if (!(v[0] != 0.0) || !isfinite(v[0]))
        return 0;
    s->fast = 1;
    return 1;
}

LA_INLINE void sturm_build(sturm_chain *s, const double *a, int deg)
{
    s->fast = 0;
    s->len = 0;
    if (deg >= 2 && sturm_build_fast(s, a, deg))
        return;
    s->fast = 0;
    memset(s->p, 0, sizeof s->p);
    for (int i = 0; i <= deg; ++i)
        s->p[0][i] = a[i];
    s->deg[0] = deg;
    for (int i = 1; i <= deg; ++i)
        s->p[1][i - 1] = (double)i * a[i];
    s->deg[1] = deg - 1;
    s->len = 2;
    while (s->len < 11 && s->deg[s->len - 1] > 0) {
        const double *num = s->p[s->len - 2];
        const double *den = s->p[s->len - 1];
        int dn = s->deg[s->len - 2], dd = s->deg[s->len - 1];
        double r[11];
        double scale = 0.0;
        for (int i = 0; i <= dn; ++i) {
            r[i] = num[i];
            if (fabs(num[i]) > scale)
                scale = fabs(num[i]);
        }
        for (int k = dn - dd; k >= 0; --k) {
            double q = r[k + dd] / den[dd];
            for (int i = 0; i <= dd; ++i)
                r[k + i] -= q * den[i];
            r[k + dd] = 0.0;
        }
        int dr = dd - 1;
        while (dr >= 0 && fabs(r[dr]) <= 1e-13 * scale)
            --dr;
        if (dr < 0)
            break; /* exact division: the chain ends at the gcd (multiple roots) */
        /* next = -remainder, normalised to unit max coefficient to keep the scale sane */
        double m = 0.0;
        for (int i = 0; i <= dr; ++i)
            if (fabs(r[i]) > m)
                m = fabs(r[i]);
        for (int i = 0; i <= dr; ++i)
            s->p[s->len][i] = -r[i] / m;
        s->deg[s->len] = dr;
        s->len++;
    }
}

LA_INLINE double refine_root(const double *a, int deg, double lo, double hi, double flo, double fhi)
{
    /* the root lies in (lo, hi]; flo = p(lo), fhi = p(hi) (the caller's values) */
    if (fhi == 0.0)
        return hi;
    if (flo == 0.0) { /* lo is a different root, excluded: step just inside */
        lo += 1e-9 * (hi - lo);
        flo = poly_eval(a, deg, lo);
        if (flo == 0.0)
            return lo;
    }
    if ((flo > 0.0) == (fhi > 0.0))
        return 0.5 * (lo + hi); /* no sign change (even multiplicity): caller bisected already */
    /* Safeguarded Newton ("rtsafe"): a Newton step is taken only when it stays inside the bracket
     * and at least halves the step before it; otherwise the bracket is bisected. Far from the root
     * a degree-10 polynomial makes plain Newton crawl (steps of ~x/10), hence the halving test.
     * Converged when a Newton step is below 1e-10 (relative): the iterate after that step is returned,
 * whose error is of the order of the step squared for a simple root (1e-13 cost ~1 more iteration
 * per root for no difference that matters: the hypotheses are scored and refined afterwards). */
    double x = 0.5 * (lo + hi), dx_old = hi - lo, dx = dx_old;
    /* degree 10: p and p' side by side, pd[i] = {a[i], i+1 coefficient of p'} (p' padded with a
     * zero degree-10 coefficient, which adds an exact 0) */
    double pd[11][2];
    if (deg == 10) {
        for (int i = 0; i < 10; ++i) {
            pd[i][0] = a[i];
            pd[i][1] = (double)(i + 1) * a[i + 1];
        }
        pd[10][0] = a[10];
        pd[10][1] = 0.0;
    }
    for (int it = 0; it < 100; ++it) {
        double f, df;
        if (deg == 10) {
            /* Estrin's scheme: p and p' in a few independent chains (Horner's single chain of 10
             * dependent multiply-adds per polynomial was most of the solver's time), the two
             * polynomials in the two lanes of an SSE2 register (same operations per lane) */
#ifdef LA_SSE2
            __m128d X = _mm_set1_pd(x);
            __m128d X2 = _mm_mul_pd(X, X), X4 = _mm_mul_pd(X2, X2), X8 = _mm_mul_pd(X4, X4);
#define LA_LIN(i) _mm_add_pd(_mm_loadu_pd(pd[i]), _mm_mul_pd(_mm_loadu_pd(pd[(i) + 1]), X))
            __m128d u0 = _mm_add_pd(LA_LIN(0), _mm_mul_pd(LA_LIN(2), X2));
            __m128d u1 = _mm_add_pd(LA_LIN(4), _mm_mul_pd(LA_LIN(6), X2));
            __m128d u2 = _mm_add_pd(LA_LIN(8), _mm_mul_pd(_mm_loadu_pd(pd[10]), X2));
#undef LA_LIN
            __m128d r = _mm_add_pd(_mm_add_pd(u0, _mm_mul_pd(u1, X4)), _mm_mul_pd(u2, X8));
            f = _mm_cvtsd_f64(r);
            df = _mm_cvtsd_f64(_mm_unpackhi_pd(r, r));
#else
            double x2 = x * x, x4 = x2 * x2, x8 = x4 * x4, v[2];
            for (int l = 0; l < 2; ++l)
                v[l] = ((pd[0][l] + pd[1][l] * x) + (pd[2][l] + pd[3][l] * x) * x2) +
                        ((pd[4][l] + pd[5][l] * x) + (pd[6][l] + pd[7][l] * x) * x2) * x4 +
                        ((pd[8][l] + pd[9][l] * x) + pd[10][l] * x2) * x8;
            f = v[0];
            df = v[1];
#endif
        } else {
            f = a[deg];
            df = 0.0;
            for (int i = deg - 1; i >= 0; --i) {
                df = df * x + f;
                f = f * x + a[i];
            }
        }
        if (f == 0.0)
            return x;
        if ((f > 0.0) == (flo > 0.0))
            lo = x;
        else
            hi = x;
        /* f != 0 here, so df == 0 gives an infinite xn, which fails the convergence test and the
         * bracket test (no separate df == 0 tests) */
        double xn = x - f / df, ax = 1.0 + fabs(x);
        if (fabs(xn - x) <= 1e-10 * ax)
            return xn; /* converged (tested first: the bracket may still be wide on one side) */
        if (!(xn > lo && xn < hi) || fabs(2.0 * f) > fabs(dx_old * df))
            xn = 0.5 * (lo + hi);
        dx_old = dx;
        dx = xn - x;
        if (fabs(dx) <= 1e-13 * ax || hi - lo <= 1e-15 * ax)
            return xn;
        x = xn;
    }
    return x;
}

/* real roots of the monic a (degree deg) in [-bound, bound], sorted */
LA_INLINE int roots_monic(const double *a, int deg, double bound, double *roots)
{
    sturm_chain s;
    sturm_build(&s, a, deg);

    struct {
        double lo, hi;
        int vlo, vhi, depth;
    } stack[160];
    int sp = 0, nroots = 0;
    stack[sp].lo = -bound;
    stack[sp].hi = bound;
    stack[sp].vlo = sturm_changes(&s, deg, -bound);
    stack[sp].vhi = sturm_changes(&s, deg, bound);
    stack[sp].depth = 0;
    ++sp;
    while (sp > 0 && nroots < deg) {
        --sp;
        double lo = stack[sp].lo, hi = stack[sp].hi;
        int vlo = stack[sp].vlo, vhi = stack[sp].vhi, depth = stack[sp].depth;
        int cnt = vlo - vhi;
        if (cnt <= 0)
            continue;
        double mid = 0.5 * (lo + hi);
        if (cnt == 1) {
            double flo = poly_eval(a, deg, lo), fhi = poly_eval(a, deg, hi);
            if ((flo > 0.0) != (fhi > 0.0) || flo == 0.0 || fhi == 0.0 || depth >= 64) {
                roots[nroots++] = refine_root(a, deg, lo, hi, flo, fhi);
                continue;
            }
        } else if (depth >= 64 || !(hi - lo > 1e-14 * (1.0 + fabs(mid)))) {
            roots[nroots++] = mid;
            continue;
        }
        if (sp + 2 > 160) {
            roots[nroots++] = mid;
            continue;
        }
        int vmid = sturm_changes(&s, deg, mid);
        stack[sp].lo = mid;
        stack[sp].hi = hi;
        stack[sp].vlo = vmid;
        stack[sp].vhi = vhi;
        stack[sp].depth = depth + 1;
        ++sp;
        stack[sp].lo = lo;
        stack[sp].hi = mid;
        stack[sp].vlo = vlo;
        stack[sp].vhi = vmid;
        stack[sp].depth = depth + 1;
        ++sp;
    }
    for (int i = 1; i < nroots; ++i) {
        double v = roots[i];
        int j = i - 1;
        while (j >= 0 && roots[j] > v) {
            roots[j + 1] = roots[j];
            --j;
        }
        roots[j + 1] = v;
    }
    return nroots;
}

int tvo_la_poly_real_roots(const double *c, int deg, double *roots)
{
    if (c == NULL || roots == NULL || deg < 1 || deg > 10)
        return 0;
    double cmax = 0.0;
    for (int i = 0; i <= deg; ++i) {
        if (!isfinite(c[i]))
            return 0;
        if (fabs(c[i]) > cmax)
            cmax = fabs(c[i]);
    }
    if (cmax == 0.0)
        return 0;
    while (deg > 0 && fabs(c[deg]) <= 1e-14 * cmax)
        --deg;
    if (deg < 1)
        return 0;
    double a[11];
    for (int i = 0; i <= deg; ++i)
        a[i] = c[i] / c[deg];
    /* Fujiwara's bound |root| <= 2 max_i |a[deg-i]|^(1/i), rounded up to a power of two with
     * integer exponent arithmetic (no pow): r = 2^k with k*i >= exponent of |a[deg-i]|. It is
     * usually far tighter than Cauchy's 1 + max |a[i]|, which saves bisection levels. The exponents
     * are read from the IEEE-754 bits (frexp's e for normal numbers; a subnormal counts as 2^-1022,
     * which can only widen the bound), and the bound is built the same way: the values frexp and
     * ldexp gave, without their two libm calls per coefficient. */
    int k2 = -1022;
    for (int i = 1; i <= deg; ++i) {
        double v = fabs(a[deg - i]);
        if (v == 0.0)
            continue;
        uint64_t bits;
        memcpy(&bits, &v, sizeof bits);
        int e = (int)((bits >> 52) & 0x7ff) - 1022; /* v < 2^e */
        int k = e >= 0 ? (e + i - 1) / i : -((-e) / i);
        if (k > k2)
            k2 = k;
    }
    if (k2 < -60)
        k2 = -60;
    if (k2 > 1022)
        k2 = 1022;
    uint64_t bbits = (uint64_t)(k2 + 1 + 1023) << 52; /* 2^(k2+1) */
    double bound;
    memcpy(&bound, &bbits, sizeof bound);
#if !defined(__OPTIMIZE_SIZE__)
    /* a second body with the degree constant (the 5-point solver's case: loops unroll); -Os builds
       (Cortex-M) keep only the general body, which takes the same degree-10 branches at run time */
    if (deg == 10)
        return roots_monic(a, 10, bound, roots);
#endif
    return roots_monic(a, deg, bound, roots);
}

/* k-th smallest of a[0..n) (0 <= k < n), reordering a: quickselect with a median-of-three pivot
 * (deterministic; O(n) expected). */
double tvo_la_select_kth(double *a, int32_t n, int32_t k)
{
    int32_t lo = 0, hi = n - 1;
    while (hi > lo) {
        const int32_t mid = lo + (hi - lo) / 2;
        double p, t;
        int32_t i = lo, j = hi;
        if (a[mid] < a[lo]) {
            t = a[mid];
            a[mid] = a[lo];
            a[lo] = t;
        }
        if (a[hi] < a[lo]) {
            t = a[hi];
            a[hi] = a[lo];
            a[lo] = t;
        }
        if (a[hi] < a[mid]) {
            t = a[hi];
            a[hi] = a[mid];
            a[mid] = t;
        }
        p = a[mid];
        while (i <= j) {
            while (a[i] < p)
                ++i;
            while (a[j] > p)
                --j;
            if (i <= j) {
                t = a[i];
                a[i] = a[j];
                a[j] = t;
                ++i;
                --j;
            }
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            break;
    }
    return a[k];
}

/* ---- Cholesky (the bundle adjustment's and the lens refinement's systems) ----------------------- */

int tvo_la_chol3_inv(const double A[9], double rel, double Ai[9])
{
    double l00, l10, l11, l20, l21, l22, d;
    double m00, m10, m11, m20, m21, m22; /* L^-1 (lower) */
    if (!(A[0] > 0.0 && A[4] > 0.0 && A[8] > 0.0))
        return 0;
    if (!(A[0] > rel * A[0]))
        return 0;
    l00 = sqrt(A[0]);
    l10 = A[3] / l00;
    l20 = A[6] / l00;
    d = A[4] - l10 * l10;
    if (!(d > rel * A[4]))
        return 0;
    l11 = sqrt(d);
    l21 = (A[7] - l20 * l10) / l11;
    d = A[8] - l20 * l20 - l21 * l21;
    if (!(d > rel * A[8]))
        return 0;
    l22 = sqrt(d);
    m00 = 1.0 / l00;
    m11 = 1.0 / l11;
    m22 = 1.0 / l22;
    m10 = -l10 * m00 / l11;
    m21 = -l21 * m11 / l22;
    m20 = -(l20 * m00 + l21 * m10) / l22;
    /* A^-1 = M^T M */
    Ai[0] = m00 * m00 + m10 * m10 + m20 * m20;
    Ai[1] = m10 * m11 + m20 * m21;
    Ai[2] = m20 * m22;
    Ai[4] = m11 * m11 + m21 * m21;
    Ai[5] = m21 * m22;
    Ai[8] = m22 * m22;
    Ai[3] = Ai[1];
    Ai[6] = Ai[2];
    Ai[7] = Ai[5];
    for (int i = 0; i < 9; ++i)
        if (!isfinite(Ai[i]))
            return 0;
    return 1;
}

int tvo_la_chol(double *A, int n, int ld, double rel)
{
    for (int j = 0; j < n; ++j) {
        double *rj = A + (size_t)j * (size_t)ld;
        double d = rj[j];
        const double diag = rj[j];
        for (int k = 0; k < j; ++k)
            d -= rj[k] * rj[k];
        if (!(diag > 0.0 && d > rel * diag && isfinite(d)))
            return 0;
        d = sqrt(d);
        rj[j] = d;
        for (int i = j + 1; i < n; ++i) {
            double *ri = A + (size_t)i * (size_t)ld;
            double s = ri[j];
            for (int k = 0; k < j; ++k)
                s -= ri[k] * rj[k];
            ri[j] = s / d;
        }
    }
    return 1;
}

void tvo_la_chol_solve(const double *L, int n, int ld, const double *b, double *x)
{
    for (int i = 0; i < n; ++i) {
        const double *ri = L + (size_t)i * (size_t)ld;
        double s = b[i];
        for (int k = 0; k < i; ++k)
            s -= ri[k] * x[k];
        x[i] = s / ri[i];
    }
    for (int i = n - 1; i >= 0; --i) {
        double s = x[i];
        for (int k = i + 1; k < n; ++k)
            s -= L[(size_t)k * (size_t)ld + (size_t)i] * x[k];
        x[i] = s / L[(size_t)i * (size_t)ld + (size_t)i];
    }
}
