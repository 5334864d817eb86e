/* SPDX-License-Identifier: Apache-2.0 */
/* Camera pose from landmarks: lambda-twist P3P, MSAC RANSAC over it, Huber-robust Levenberg-Marquardt
 * refinement on SE(3). See tinyvo/pnp.h for the contracts and the algorithm. */
#include "tinyvo/pnp.h"
#include "tinyvo/dmath.h"
#include "tinyvo/linalg.h"
#include "tinyvo/ransac.h"

#include <float.h>
#include <math.h>
#include <string.h>

#define PNP_MIN_Z 1e-6     /* in front: Z_c above this (metres) */
#define PNP_MAX_IMG 1e6    /* |x| above this: the point is skipped */
#define PNP_MAX_WORLD 1e9  /* |X| above this: the point is skipped */
#define PNP_LO_ROUNDS 3    /* refinement rounds of the best RANSAC hypothesis at most */
#define PNP_SAMPLE 4       /* 3 points for P3P and one to check it */
#define PNP_EQ_TOL 1e-6    /* P3P: relative residual of the distance equations to keep a solution */
#define PNP_GN_STEPS 5     /* P3P: Gauss-Newton polish steps at most */
#define PNP_GN_DONE 1e-15  /* P3P: a relative residual at or below this needs no polish step */
#define PNP_FLAT 1e-20     /* P3P: a triangle with |d12 x d13|^2 <= this |d12|^2 |d13|^2 is degenerate */
#define PNP_RAY_COS 1e-15  /* P3P: two bearings with a cosine above 1 - this coincide */
#define PNP_DUP_REL 1e-9   /* P3P: depth solutions closer than this share of their sum (L1) are one */
#define PNP_REL_GAIN 1e-10 /* LM: an accepted step gaining less than this share of the cost ends it */
#define PNP_MU0 1e-4       /* LM: initial damping */
#define PNP_MU_MIN 1e-12
#define PNP_MU_MAX 1e8
#define PNP_TINY 1e-9 /* LM: a step below this (rad; m relative to 1 + |t|) ends it */
#define PNP_MAX_POINTS (1 << 28)

/* ---- small helpers ---------------------------------------------------------------------------- */

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* quadratic form v^T A v of a symmetric 3x3 A */
static double qform(const double A[9], const double v[3])
{
    return A[0] * v[0] * v[0] + A[4] * v[1] * v[1] + A[8] * v[2] * v[2] +
            2.0 * (A[1] * v[0] * v[1] + A[2] * v[0] * v[2] + A[5] * v[1] * v[2]);
}

/* u^T A v of a symmetric 3x3 A */
static double bform(const double A[9], const double u[3], const double v[3])
{
    double Av[3];
    tvo_la_mat3_vec(A, v, Av);
    return dot3(u, Av);
}

static void adj3(const double A[9], double J[9])
{
    J[0] = A[4] * A[8] - A[5] * A[7];
    J[1] = A[2] * A[7] - A[1] * A[8];
    J[2] = A[1] * A[5] - A[2] * A[4];
    J[3] = A[5] * A[6] - A[3] * A[8];
    J[4] = A[0] * A[8] - A[2] * A[6];
    J[5] = A[2] * A[3] - A[0] * A[5];
    J[6] = A[3] * A[7] - A[4] * A[6];
    J[7] = A[1] * A[6] - A[0] * A[7];
    J[8] = A[0] * A[4] - A[1] * A[3];
}

/* trace(A B) */
static double trace_ab(const double A[9], const double B[9])
{
    double s = 0.0;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            s += A[3 * i + j] * B[3 * j + i];
    return s;
}

/* finite and within the bounds (a comparison with NaN is false, |inf| exceeds every bound) */
static int point_usable(const double X[3], const tvo_point2d *x)
{
    return fabs(X[0]) <= PNP_MAX_WORLD && fabs(X[1]) <= PNP_MAX_WORLD && fabs(X[2]) <= PNP_MAX_WORLD &&
            fabs(x->x) <= PNP_MAX_IMG && fabs(x->y) <= PNP_MAX_IMG;
}

/* squared reprojection error of X at T (0 and *front = 0 when behind the camera) */
static double reproj_err2(const tvo_pose *T, const double X[3], const tvo_point2d *x, int *front)
{
    const double *R = T->R;
    double Xc = R[0] * X[0] + R[1] * X[1] + R[2] * X[2] + T->t[0];
    double Yc = R[3] * X[0] + R[4] * X[1] + R[5] * X[2] + T->t[1];
    double Zc = R[6] * X[0] + R[7] * X[1] + R[8] * X[2] + T->t[2];
    if (!(Zc > PNP_MIN_Z)) {
        *front = 0;
        return 0.0;
    }
    double iz = 1.0 / Zc;
    double du = Xc * iz - x->x, dv = Yc * iz - x->y;
    *front = 1;
    return du * du + dv * dv;
}

/* a finite rotation matrix (orthonormal within 1e-6, determinant +1) */
static int prior_ok(const double R[9])
{
    for (int k = 0; k < 9; ++k)
        if (!isfinite(R[k]))
            return 0;
    return tvo_rot_orthogonality_error(R) < 1e-6 && tvo_la_mat3_det(R) > 0.0;
}

static int config_ok(const tvo_pnp_config *c)
{
    return c->threshold > 0.0 && c->threshold < DBL_MAX && c->confidence > 0.0 && c->confidence < 1.0 &&
            c->max_iterations >= 1 && c->refine_iterations >= 1 && c->huber > 0.0 && c->huber < DBL_MAX &&
            c->min_inliers >= 3 && (c->use_guess == 0 || c->use_guess == 1) && c->rot_prior_weight >= 0.0 &&
            c->rot_prior_weight < DBL_MAX && (c->rot_prior_weight == 0.0 || prior_ok(c->rot_prior));
}

/* on error: leave a finite pose as given, replace a non-finite one by the identity */
static void pose_on_error(tvo_pose *T)
{
    if (!tvo_pose_is_finite(T))
        *T = tvo_pose_identity();
}

void tvo_pnp_config_default(tvo_pnp_config *cfg)
{
    if (cfg == NULL)
        return;
    memset(cfg, 0, sizeof *cfg);
    cfg->threshold = 1.5 / 458.0;
    cfg->confidence = 0.999;
    cfg->max_iterations = 200;
    cfg->refine_iterations = 10;
    cfg->huber = cfg->threshold;
    cfg->min_inliers = 12;
    cfg->seed = 0x5eedULL;
    cfg->use_guess = 0;
    cfg->rot_prior[0] = cfg->rot_prior[4] = cfg->rot_prior[8] = 1.0;
    cfg->rot_prior_weight = 0.0;
}

size_t tvo_pnp_scratch_size(int32_t max_points)
{
    if (max_points < 0 || max_points > PNP_MAX_POINTS)
        return 0;
    return (size_t)max_points * 6u + 16u;
}

/* ---- P3P (lambda twist) ------------------------------------------------------------------------ */

typedef struct p3p_eq {
    double a12, a13, a23; /* squared world distances */
    double c12, c13, c23; /* cosines between the unit bearings */
} p3p_eq;

/* residuals of the three distance equations at depths l */
static void p3p_residual(const p3p_eq *q, const double l[3], double f[3])
{
    f[0] = l[0] * l[0] + l[1] * l[1] - 2.0 * q->c12 * l[0] * l[1] - q->a12;
    f[1] = l[0] * l[0] + l[2] * l[2] - 2.0 * q->c13 * l[0] * l[2] - q->a13;
    f[2] = l[1] * l[1] + l[2] * l[2] - 2.0 * q->c23 * l[1] * l[2] - q->a23;
}

static double p3p_relres(const p3p_eq *q, const double l[3])
{
    double f[3];
    p3p_residual(q, l, f);
    double r0 = fabs(f[0]) / q->a12, r1 = fabs(f[1]) / q->a13, r2 = fabs(f[2]) / q->a23;
    double r = r0 > r1 ? r0 : r1;
    return r > r2 ? r : r2;
}

/* Gauss-Newton on the three equations; keeps the best iterate. Returns its relative residual. */
static double p3p_polish(const p3p_eq *q, double l[3])
{
    double best = p3p_relres(q, l);
    for (int it = 0; it < PNP_GN_STEPS && best > PNP_GN_DONE; ++it) {
        double f[3], J[9], A[9], d[3], ln[3];
        p3p_residual(q, l, f);
        J[0] = 2.0 * (l[0] - q->c12 * l[1]);
        J[1] = 2.0 * (l[1] - q->c12 * l[0]);
        J[2] = 0.0;
        J[3] = 2.0 * (l[0] - q->c13 * l[2]);
        J[4] = 0.0;
        J[5] = 2.0 * (l[2] - q->c13 * l[0]);
        J[6] = 0.0;
        J[7] = 2.0 * (l[1] - q->c23 * l[2]);
        J[8] = 2.0 * (l[2] - q->c23 * l[1]);
        double det = tvo_la_mat3_det(J);
        if (!(fabs(det) > 0.0) || !isfinite(det))
            break;
        adj3(J, A);
        tvo_la_mat3_vec(A, f, d);
        for (int k = 0; k < 3; ++k)
            ln[k] = l[k] - d[k] / det;
        double r = p3p_relres(q, ln);
        if (!(r < best))
            break;
        best = r;
        l[0] = ln[0];
        l[1] = ln[1];
        l[2] = ln[2];
    }
    return best;
}

/* real roots of c[0] + c[1] g + c[2] g^2 + c[3] g^3 (at most 3, unordered): one root of the monic cubic
 * by Newton's method safeguarded by bisection inside Cauchy's bound, the others from the deflated
 * quadratic, polished by two Newton steps. A vanishing leading coefficient lowers the degree. */
static double cubic_eval(double b, double c, double d, double g)
{
    return ((g + b) * g + c) * g + d;
}

static double cubic_newton(double b, double c, double d, double g)
{
    double fp = (3.0 * g + 2.0 * b) * g + c;
    return fp != 0.0 ? g - cubic_eval(b, c, d, g) / fp : g;
}

static int quad_roots(double a, double b, double c, double r[2])
{
    if (a == 0.0) {
        if (b == 0.0)
            return 0;
        r[0] = -c / b;
        return 1;
    }
    double disc = b * b - 4.0 * a * c;
    if (disc < 0.0)
        return 0;
    double q = -0.5 * (b + (b >= 0.0 ? sqrt(disc) : -sqrt(disc)));
    if (q == 0.0) {
        r[0] = 0.0;
        return 1;
    }
    r[0] = q / a;
    r[1] = c / q;
    return r[1] == r[0] ? 1 : 2;
}

static int cubic_roots(const double cf[4], double r[3])
{
    double cmax = 0.0;
    for (int i = 0; i < 4; ++i) {
        if (!isfinite(cf[i]))
            return 0;
        cmax = fabs(cf[i]) > cmax ? fabs(cf[i]) : cmax;
    }
    if (!(cmax > 0.0))
        return 0;
    if (fabs(cf[3]) <= 1e-14 * cmax)
        return quad_roots(fabs(cf[2]) <= 1e-14 * cmax ? 0.0 : cf[2], cf[1], cf[0], r);
    const double b = cf[2] / cf[3], c = cf[1] / cf[3], d = cf[0] / cf[3];
    double B = fabs(b) > fabs(c) ? fabs(b) : fabs(c);
    B = 1.0 + (fabs(d) > B ? fabs(d) : B);
    double lo = -B, hi = B; /* f(lo) < 0 < f(hi) */
    /* start near an outer root: beside the stationary points when there are two, else at the inflection */
    double g = -b / 3.0, disc = b * b - 3.0 * c;
    if (disc > 0.0) {
        double v = sqrt(disc), t1 = (-b - v) / 3.0, t2 = (-b + v) / 3.0;
        g = cubic_eval(b, c, d, t1) > 0.0 ? t1 - v : t2 + v;
    }
    if (!(g > lo && g < hi))
        g = 0.5 * (lo + hi);
    for (int it = 0; it < 200; ++it) {
        double f = cubic_eval(b, c, d, g);
        if (f == 0.0)
            break;
        if (f < 0.0)
            lo = g;
        else
            hi = g;
        double gn = cubic_newton(b, c, d, g);
        if (!(gn > lo && gn < hi))
            gn = 0.5 * (lo + hi);
        double step = fabs(gn - g);
        g = gn;
        if (step <= 1e-16 * (1.0 + fabs(g)) || !(hi - lo > 1e-16 * (1.0 + fabs(g))))
            break;
    }
    r[0] = g;
    double q[2];
    int nq = quad_roots(1.0, b + g, c + g * (b + g), q);
    int nr = 1;
    for (int i = 0; i < nq; ++i) {
        double h = q[i];
        for (int it = 0; it < 2; ++it) {
            double hn = cubic_newton(b, c, d, h);
            if (fabs(cubic_eval(b, c, d, hn)) < fabs(cubic_eval(b, c, d, h)))
                h = hn;
        }
        r[nr++] = h;
    }
    return nr;
}

static void normalize3(double v[3])
{
    double n = sqrt(dot3(v, v));
    if (n > 0.0) {
        v[0] /= n;
        v[1] /= n;
        v[2] /= n;
    }
}

/* directions mu in the plane {l : u . l = 0} with mu^T D mu = 0 (D symmetric); returns 0..2 */
static int plane_directions(const double u[3], const double D1[9], const double D2[9], double mu[2][3])
{
    /* an orthonormal basis e, f of the plane */
    double ax[3] = {0.0, 0.0, 0.0}, e[3], f[3];
    int k = 0;
    if (fabs(u[1]) < fabs(u[k]))
        k = 1;
    if (fabs(u[2]) < fabs(u[k]))
        k = 2;
    ax[k] = 1.0;
    cross3(u, ax, e);
    normalize3(e);
    cross3(u, e, f);
    normalize3(f);
    /* D1 and D2 are proportional on the plane: use the one with the larger restriction */
    double p11 = qform(D1, e), p12 = bform(D1, e, f), p22 = qform(D1, f);
    double r11 = qform(D2, e), r12 = bform(D2, e, f), r22 = qform(D2, f);
    double np = fabs(p11) + fabs(p12) + fabs(p22), nr = fabs(r11) + fabs(r12) + fabs(r22);
    double q11 = np >= nr ? p11 : r11, q12 = np >= nr ? p12 : r12, q22 = np >= nr ? p22 : r22;
    double scale = np >= nr ? np : nr;
    if (!(scale > 0.0))
        return 0;
    double disc = q12 * q12 - q11 * q22;
    if (disc < 0.0) {
        if (disc < -1e-12 * scale * scale)
            return 0;
        disc = 0.0;
    }
    double sd = sqrt(disc);
    int swap = fabs(q22) > fabs(q11);
    double lead = swap ? q22 : q11, tail = swap ? q11 : q22;
    const double *b0 = swap ? f : e, *b1 = swap ? e : f; /* mu = r b0 + b1 */
    int m = 0;
    if (!(fabs(lead) > 1e-14 * scale)) {
        /* 2 q12 a b = 0 (q11, q22 ~ 0): the two basis directions */
        for (int i = 0; i < 3; ++i) {
            mu[0][i] = e[i];
            mu[1][i] = f[i];
        }
        return 2;
    }
    double qq = -(q12 + (q12 >= 0.0 ? sd : -sd)); /* stable roots: r1 = qq / lead, r2 = tail / qq */
    double r[2];
    r[m++] = qq / lead;
    if (qq != 0.0 && sd > 0.0)
        r[m++] = tail / qq;
    for (int j = 0; j < m; ++j)
        for (int i = 0; i < 3; ++i)
            mu[j][i] = r[j] * b0[i] + b1[i];
    return m;
}

/* unit null vector of a rank-2 symmetric 3x3 M: the longest cross product of two rows; 0 if M ~ 0 */
static int null_vector(const double M[9], double v[3])
{
    double c[3][3], best = 0.0;
    int bi = -1;
    cross3(M, M + 3, c[0]);
    cross3(M, M + 6, c[1]);
    cross3(M + 3, M + 6, c[2]);
    for (int i = 0; i < 3; ++i) {
        double nn = dot3(c[i], c[i]);
        if (nn > best) {
            best = nn;
            bi = i;
        }
    }
    if (bi < 0 || !(best < DBL_MAX))
        return 0;
    double inv = 1.0 / sqrt(best);
    v[0] = c[bi][0] * inv;
    v[1] = c[bi][1] * inv;
    v[2] = c[bi][2] * inv;
    return 1;
}

/* The two non-null eigenpairs of a singular symmetric 3x3 D (|*sa| >= |*sb|, unit eigenvectors).
 * Closed form: with the third eigenvalue 0 the others solve s^2 - trace s + m2 = 0 (m2: the sum of
 * the principal 2x2 minors), their eigenvectors are null vectors of D - s I. When the two are close or
 * the smaller is ~0 (the closed form loses accuracy), Jacobi (tvo_la_sym_eig) instead. 0 if D ~ 0. */
static int pencil_eig(const double D[9], double *sa, double *sb, double ea[3], double eb[3])
{
    double tr = D[0] + D[4] + D[8];
    double m2 = D[0] * D[4] - D[1] * D[1] + D[0] * D[8] - D[2] * D[2] + D[4] * D[8] - D[5] * D[5];
    double disc = tr * tr - 4.0 * m2;
    disc = disc > 0.0 ? disc : 0.0;
    double q = 0.5 * (tr + (tr >= 0.0 ? sqrt(disc) : -sqrt(disc)));
    if (q != 0.0) {
        double r1 = q, r2 = m2 / q;
        double a = fabs(r1) >= fabs(r2) ? r1 : r2, b = fabs(r1) >= fabs(r2) ? r2 : r1;
        if (fabs(a - b) > 1e-6 * fabs(a) && fabs(b) > 1e-6 * fabs(a)) {
            double M[9];
            memcpy(M, D, sizeof M);
            M[0] -= a;
            M[4] -= a;
            M[8] -= a;
            int ok = null_vector(M, ea);
            memcpy(M, D, sizeof M);
            M[0] -= b;
            M[4] -= b;
            M[8] -= b;
            if (ok && null_vector(M, eb)) {
                *sa = a;
                *sb = b;
                return 1;
            }
        }
    }
    double A[9], w[3], V[9];
    memcpy(A, D, sizeof A);
    if (tvo_la_sym_eig(A, 3, w, V) != TVO_OK)
        return 0;
    int z = 0;
    for (int k = 1; k < 3; ++k)
        if (fabs(w[k]) < fabs(w[z]))
            z = k;
    int ia = (z + 1) % 3, ib = (z + 2) % 3;
    if (fabs(w[ib]) > fabs(w[ia])) {
        int tmp = ia;
        ia = ib;
        ib = tmp;
    }
    if (!(fabs(w[ia]) > 0.0))
        return 0;
    *sa = w[ia];
    *sb = w[ib];
    for (int k = 0; k < 3; ++k) {
        ea[k] = V[3 * k + ia];
        eb[k] = V[3 * k + ib];
    }
    return 1;
}

/* unit bearings y of the image points x and the world triangle's equations q; d12 = X0 - X1 and nw =
 * d12 x (X0 - X2) are kept for the pose. 0 when a point is unusable or the triangle or the rays
 * degenerate. */
static int p3p_setup(const double X[3][3], const double x[3][2], double y[3][3], double d12[3], double nw[3],
                     p3p_eq *q)
{
    for (int i = 0; i < 3; ++i) {
        tvo_point2d p;
        p.x = x[i][0];
        p.y = x[i][1];
        if (!point_usable(X[i], &p))
            return 0;
        double nn = sqrt(p.x * p.x + p.y * p.y + 1.0);
        y[i][0] = p.x / nn;
        y[i][1] = p.y / nn;
        y[i][2] = 1.0 / nn;
    }
    double d13[3], d23[3];
    for (int k = 0; k < 3; ++k) {
        d12[k] = X[0][k] - X[1][k];
        d13[k] = X[0][k] - X[2][k];
        d23[k] = X[1][k] - X[2][k];
    }
    q->a12 = dot3(d12, d12);
    q->a13 = dot3(d13, d13);
    q->a23 = dot3(d23, d23);
    cross3(d12, d13, nw);
    if (!(dot3(nw, nw) > PNP_FLAT * q->a12 * q->a13) || !(q->a23 > 0.0))
        return 0; /* coincident or collinear */
    q->c12 = dot3(y[0], y[1]);
    q->c13 = dot3(y[0], y[2]);
    q->c23 = dot3(y[1], y[2]);
    if (q->c12 > 1.0 - PNP_RAY_COS || q->c13 > 1.0 - PNP_RAY_COS || q->c23 > 1.0 - PNP_RAY_COS)
        return 0; /* coincident rays */
    return 1;
}

/* the homogeneous quadrics D1, D2: l^T D1 l = 0, l^T D2 l = 0 on the solution */
static void p3p_conics(const p3p_eq *q, double D1[9], double D2[9])
{
    D1[0] = q->a23;
    D1[1] = -q->a23 * q->c12;
    D1[2] = 0.0;
    D1[3] = -q->a23 * q->c12;
    D1[4] = q->a23 - q->a12;
    D1[5] = q->a12 * q->c23;
    D1[6] = 0.0;
    D1[7] = q->a12 * q->c23;
    D1[8] = -q->a12;
    D2[0] = q->a23;
    D2[1] = 0.0;
    D2[2] = -q->a23 * q->c13;
    D2[3] = 0.0;
    D2[4] = -q->a13;
    D2[5] = q->a13 * q->c23;
    D2[6] = -q->a23 * q->c13;
    D2[7] = q->a13 * q->c23;
    D2[8] = q->a23 - q->a13;
}

/* The rank-2 pencil D0 = D1 + g D2 (g a real root of det(D0) = 0) and its non-null eigenpairs
 * (|*sa| >= |*sb|): the candidate roots are tried best-conditioned first (|p'(g)| / (1 + g^2)), the
 * first indefinite pencil wins, else the first that decomposes; D2 alone when the cubic has no real
 * root (its leading coefficient vanished: the root went to infinity). 0 if no candidate decomposes. */
static int p3p_pencil(const double D1[9], const double D2[9], double *sa, double *sb, double ea[3],
                      double eb[3])
{
    double J1[9], J2[9], c[4], roots[3];
    adj3(D1, J1);
    adj3(D2, J2);
    c[0] = D1[0] * J1[0] + D1[1] * J1[3] + D1[2] * J1[6];
    c[1] = trace_ab(J1, D2);
    c[2] = trace_ab(D1, J2);
    c[3] = D2[0] * J2[0] + D2[1] * J2[3] + D2[2] * J2[6];
    int nr = cubic_roots(c, roots);

    double gs[3], score[3];
    int ng = 0;
    for (int i = 0; i < nr; ++i) {
        double g = roots[i];
        double dp = c[1] + g * (2.0 * c[2] + g * 3.0 * c[3]);
        double sc = fabs(dp) / (1.0 + g * g);
        int pos = ng++;
        while (pos > 0 && score[pos - 1] < sc) {
            gs[pos] = gs[pos - 1];
            score[pos] = score[pos - 1];
            --pos;
        }
        gs[pos] = g;
        score[pos] = sc;
    }
    int have = 0, found = 0;
    for (int cand = 0; cand < (ng > 0 ? ng : 1) && !found; ++cand) {
        double D0[9], ca, cb, va[3], vb[3];
        for (int k = 0; k < 9; ++k)
            D0[k] = ng > 0 ? D1[k] + gs[cand] * D2[k] : D2[k];
        if (!pencil_eig(D0, &ca, &cb, va, vb))
            continue;
        int indefinite = ca * cb < 0.0;
        if (indefinite || !have) {
            *sa = ca;
            *sb = cb;
            memcpy(ea, va, 3 * sizeof *ea);
            memcpy(eb, vb, 3 * sizeof *eb);
            have = 1;
            found = indefinite;
        }
    }
    return have;
}

/* The positive depths l (sols, distinct, at most 4) in the planes (ea -+ s eb) . l = 0, s = sqrt(-sb /
 * sa): in each plane the directions where l^T D1 l = l^T D2 l = 0, scaled by the sum of the three
 * distance equations, polished by Gauss-Newton and kept when every equation holds to PNP_EQ_TOL. */
static int p3p_depths(const p3p_eq *q, const double D1[9], const double D2[9], double sa, double sb,
                      const double ea[3], const double eb[3], double sols[4][3])
{
    const double S[9] = {2.0, -q->c12, -q->c13, -q->c12, 2.0, -q->c23, -q->c13, -q->c23, 2.0};
    double s = -sb / sa;
    s = s > 0.0 ? sqrt(s) : 0.0;
    int nsol = 0;
    for (int sign = 0; sign < 2; ++sign) {
        double u[3], mu[2][3];
        for (int k = 0; k < 3; ++k)
            u[k] = ea[k] + (sign == 0 ? s : -s) * eb[k];
        if (sign == 1 && s == 0.0)
            break; /* the same plane twice */
        int nm = plane_directions(u, D1, D2, mu);
        for (int j = 0; j < nm; ++j) {
            double den = qform(S, mu[j]);
            if (!(den > 0.0))
                continue;
            double kk = sqrt((q->a12 + q->a13 + q->a23) / den);
            double l[3] = {kk * mu[j][0], kk * mu[j][1], kk * mu[j][2]};
            if (l[0] + l[1] + l[2] < 0.0) {
                l[0] = -l[0];
                l[1] = -l[1];
                l[2] = -l[2];
            }
            if (!(l[0] > 0.0 && l[1] > 0.0 && l[2] > 0.0))
                continue;
            if (!(p3p_polish(q, l) <= PNP_EQ_TOL))
                continue;
            if (!(l[0] > 0.0 && l[1] > 0.0 && l[2] > 0.0))
                continue;
            int dup = 0;
            for (int o = 0; o < nsol && !dup; ++o) {
                double dd = fabs(sols[o][0] - l[0]) + fabs(sols[o][1] - l[1]) + fabs(sols[o][2] - l[2]);
                dup = dd <= PNP_DUP_REL * (l[0] + l[1] + l[2]);
            }
            if (dup)
                continue;
            memcpy(sols[nsol++], l, sizeof l);
        }
    }
    return nsol;
}

/* the poses of the depth solutions: R maps the world triangle's orthonormal frame (from d12 and its
 * normal nw) onto the camera triangle's, t the world centroid onto the camera one; a degenerate or
 * non-finite pose is left out. y and sols are only read. Returns the number written to T_c_w. */
static int p3p_poses(const double X[3][3], double y[3][3], const double d12[3], const double nw[3],
                     double sols[4][3], int nsol, tvo_pose T_c_w[4])
{
    double w1[3], w2[3], w3[3];
    memcpy(w1, d12, sizeof w1);
    normalize3(w1);
    memcpy(w3, nw, sizeof w3);
    normalize3(w3);
    cross3(w3, w1, w2);
    int nout = 0;
    for (int m = 0; m < nsol; ++m) {
        double P[3][3], p12[3], p13[3], nc[3], e1[3], e2[3], e3[3];
        for (int i = 0; i < 3; ++i)
            for (int k = 0; k < 3; ++k)
                P[i][k] = sols[m][i] * y[i][k];
        for (int k = 0; k < 3; ++k) {
            p12[k] = P[0][k] - P[1][k];
            p13[k] = P[0][k] - P[2][k];
        }
        cross3(p12, p13, nc);
        if (!(dot3(nc, nc) > PNP_FLAT * dot3(p12, p12) * dot3(p13, p13)))
            continue;
        memcpy(e1, p12, sizeof e1);
        normalize3(e1);
        memcpy(e3, nc, sizeof e3);
        normalize3(e3);
        cross3(e3, e1, e2);
        tvo_pose T;
        for (int r = 0; r < 3; ++r)
            for (int k = 0; k < 3; ++k)
                T.R[3 * r + k] = e1[r] * w1[k] + e2[r] * w2[k] + e3[r] * w3[k];
        for (int r = 0; r < 3; ++r) {
            double pc = (P[0][r] + P[1][r] + P[2][r]) / 3.0;
            double xc = (T.R[3 * r] * (X[0][0] + X[1][0] + X[2][0]) +
                         T.R[3 * r + 1] * (X[0][1] + X[1][1] + X[2][1]) +
                         T.R[3 * r + 2] * (X[0][2] + X[1][2] + X[2][2])) /
                    3.0;
            T.t[r] = pc - xc;
        }
        if (!tvo_pose_is_finite(&T))
            continue;
        T_c_w[nout++] = T;
    }
    return nout;
}

int tvo_p3p(const double X[3][3], const double x[3][2], tvo_pose T_c_w[4])
{
    if (X == NULL || x == NULL || T_c_w == NULL)
        return 0;
    double y[3][3], d12[3], nw[3], D1[9], D2[9];
    p3p_eq q;
    if (!p3p_setup(X, x, y, d12, nw, &q))
        return 0;
    p3p_conics(&q, D1, D2);
    double sa = 0.0, sb = 0.0, ea[3] = {0.0, 0.0, 0.0}, eb[3] = {0.0, 0.0, 0.0};
    if (!p3p_pencil(D1, D2, &sa, &sb, ea, eb))
        return 0;
    double sols[4][3];
    int nsol = p3p_depths(&q, D1, D2, sa, sb, ea, eb, sols);
    return p3p_poses(X, y, d12, nw, sols, nsol, T_c_w);
}

/* ---- refinement --------------------------------------------------------------------------------- */

static int selected(const uint8_t *use, int32_t i, const double (*X)[3], const tvo_point2d *x)
{
    return (use == NULL || use[i] != 0) && point_usable(X[i], &x[i]);
}

static double huber_rho(double e2, double k)
{
    if (e2 <= k * k)
        return 0.5 * e2;
    return k * (sqrt(e2) - 0.5 * k);
}

/* T <- exp(d) T, d = [omega, v] (SE(3) exponential) */
static void se3_left_update(const double d[6], tvo_pose *T)
{
    const double *w = d, *v = d + 3;
    double th2 = dot3(w, w), B, C, Rd[9], wv[3], wwv[3], tv[3], Rn[9], tn[3];
    if (th2 < 1e-8) {
        B = 0.5 - th2 / 24.0;
        C = 1.0 / 6.0 - th2 / 120.0;
    } else {
        double th = sqrt(th2);
        B = (1.0 - tvo_dm_cos(th)) / th2;
        C = (th - tvo_dm_sin(th)) / (th2 * th);
    }
    tvo_rotvec_to_rot(w, Rd);
    cross3(w, v, wv);
    cross3(w, wv, wwv);
    for (int k = 0; k < 3; ++k)
        tv[k] = v[k] + B * wv[k] + C * wwv[k];
    tvo_la_mat3_mul(Rd, T->R, Rn);
    tvo_la_mat3_vec(Rd, T->t, tn);
    memcpy(T->R, Rn, sizeof Rn);
    for (int k = 0; k < 3; ++k)
        T->t[k] = tn[k] + tv[k];
}

/* Robust cost of the selected points at T (a point behind the camera costs rho(1)) and the IRLS normal
 * equations H d = -g of the points in front; returns their count. */
static int32_t evaluate(const tvo_pose *T, const double (*X)[3], const tvo_point2d *x, const uint8_t *use,
                        int32_t n, double k, const tvo_pnp_config *cfg, double H[36], double g[6],
                        double *cost)
{
    const double pen = huber_rho(1.0, k), k2 = k * k;
    int32_t used = 0;
    double c = 0.0;
    memset(H, 0, 36 * sizeof(double));
    memset(g, 0, 6 * sizeof(double));
    const double *R = T->R;
    for (int32_t i = 0; i < n; ++i) {
        if (!selected(use, i, X, x))
            continue;
        const double *P = X[i];
        double Xc = R[0] * P[0] + R[1] * P[1] + R[2] * P[2] + T->t[0];
        double Yc = R[3] * P[0] + R[4] * P[1] + R[5] * P[2] + T->t[1];
        double Zc = R[6] * P[0] + R[7] * P[1] + R[8] * P[2] + T->t[2];
        if (!(Zc > PNP_MIN_Z)) {
            c += pen;
            continue;
        }
        double iz = 1.0 / Zc, xn = Xc * iz, yn = Yc * iz;
        double ru = xn - x[i].x, rv = yn - x[i].y, e2 = ru * ru + rv * rv, wgt = 1.0;
        if (e2 <= k2) {
            c += 0.5 * e2;
        } else {
            double e = sqrt(e2);
            c += k * (e - 0.5 * k);
            wgt = k / e;
        }
        /* J_u = [a b c p 0 q], J_v = [d e f 0 p r] (d = [omega, v], left increment); the upper
         * triangle of w (J_u^T J_u + J_v^T J_v) without the products by zero */
        double a = -xn * yn, bb = 1.0 + xn * xn, cc = -yn, dd = -(1.0 + yn * yn), e = xn * yn, f = xn;
        double p = iz, q = -xn * iz, r = -yn * iz;
        double wa = wgt * a, wb = wgt * bb, wc = wgt * cc, wd = wgt * dd, we = wgt * e, wf = wgt * f;
        double wp = wgt * p, wq = wgt * q, wr = wgt * r;
        g[0] += wa * ru + wd * rv;
        g[1] += wb * ru + we * rv;
        g[2] += wc * ru + wf * rv;
        g[3] += wp * ru;
        g[4] += wp * rv;
        g[5] += wq * ru + wr * rv;
        H[0] += wa * a + wd * dd;
        H[1] += wa * bb + wd * e;
        H[2] += wa * cc + wd * f;
        H[3] += wa * p;
        H[4] += wd * p;
        H[5] += wa * q + wd * r;
        H[7] += wb * bb + we * e;
        H[8] += wb * cc + we * f;
        H[9] += wb * p;
        H[10] += we * p;
        H[11] += wb * q + we * r;
        H[14] += wc * cc + wf * f;
        H[15] += wc * p;
        H[16] += wf * p;
        H[17] += wc * q + wf * r;
        H[21] += wp * p;
        H[23] += wp * q;
        H[28] += wp * p;
        H[29] += wp * r;
        H[35] += wq * q + wr * r;
        ++used;
    }
    if (cfg->rot_prior_weight > 0.0) {
        /* r = log(R R_p^T); for the left increment exp(w) R, dr/dw = I to first order */
        const double wp = cfg->rot_prior_weight;
        double D[9], r[3];
        tvo_la_mat3_mul_bt(R, cfg->rot_prior, D);
        tvo_rot_to_rotvec(D, r);
        c += 0.5 * wp * dot3(r, r);
        for (int a = 0; a < 3; ++a) {
            g[a] += wp * r[a];
            H[7 * a] += wp;
        }
    }
    for (int ia = 0; ia < 6; ++ia)
        for (int ib = 0; ib < ia; ++ib)
            H[6 * ia + ib] = H[6 * ib + ia];
    *cost = c;
    return used;
}

/* Levenberg-Marquardt on the Huber cost (see pnp.h); T in/out, never worse than the input */
static void refine_core(const tvo_pnp_config *cfg, const double (*X)[3], const tvo_point2d *x,
                        const uint8_t *use, int32_t n, tvo_pose *T)
{
    const double k = cfg->huber;
    double H[36], g[6], Hn[36], gn[6], mu = PNP_MU0, cost;
    int32_t used = evaluate(T, X, x, use, n, k, cfg, H, g, &cost);
    for (int32_t it = 0; it < cfg->refine_iterations && used >= 3; ++it) {
        double A[36], b[6], d[6];
        memcpy(A, H, sizeof A);
        for (int a = 0; a < 6; ++a) {
            A[7 * a] += mu * H[7 * a];
            b[a] = -g[a];
        }
        if (tvo_la_solve(A, b, 6, d) != TVO_OK ||
            !(isfinite(d[0]) && isfinite(d[1]) && isfinite(d[2]) && isfinite(d[3]) && isfinite(d[4]) &&
              isfinite(d[5]))) {
            mu *= 10.0;
            if (mu > PNP_MU_MAX)
                return;
            continue;
        }
        tvo_pose Tn = *T;
        se3_left_update(d, &Tn);
        double cn = DBL_MAX;
        int32_t usedn = tvo_pose_is_finite(&Tn) ? evaluate(&Tn, X, x, use, n, k, cfg, Hn, gn, &cn) : 0;
        double nw = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        double nv = sqrt(d[3] * d[3] + d[4] * d[4] + d[5] * d[5]);
        int tiny = nw < PNP_TINY && nv < PNP_TINY * (1.0 + sqrt(dot3(T->t, T->t)));
        if (cn <= cost) {
            tiny |= cost - cn <= PNP_REL_GAIN * cost;
            *T = Tn;
            cost = cn;
            memcpy(H, Hn, sizeof H);
            memcpy(g, gn, sizeof g);
            used = usedn;
            mu = mu * 0.1 > PNP_MU_MIN ? mu * 0.1 : PNP_MU_MIN;
        } else {
            mu *= 10.0;
        }
        if (tiny || mu > PNP_MU_MAX)
            return; /* converged (tiny step or gain, or at the rounding level), or no step helps */
    }
}

/* inlier flags (selected, in front, e < threshold) for all n; returns the count, rms optional */
static int32_t mark_inliers(const tvo_pose *T, const double (*X)[3], const tvo_point2d *x, const uint8_t *use,
                            int32_t n, double th, uint8_t *mask, double *rms)
{
    int32_t cnt = 0;
    double th2 = th * th, s2 = 0.0;
    for (int32_t i = 0; i < n; ++i) {
        int in = 0;
        if (selected(use, i, X, x)) {
            int front;
            double e2 = reproj_err2(T, X[i], &x[i], &front);
            if (front && e2 < th2) {
                in = 1;
                s2 += e2;
            }
        }
        if (mask != NULL)
            mask[i] = (uint8_t)in;
        cnt += in;
    }
    if (rms != NULL)
        *rms = cnt > 0 ? sqrt(s2 / (double)cnt) : 0.0;
    return cnt;
}

tvo_status tvo_pnp_refine(const tvo_pnp_config *cfg, const double (*X)[3], const tvo_point2d *x,
                          const uint8_t *use, int32_t n, tvo_pose *T_c_w, uint8_t *inliers,
                          int32_t *n_inliers, double *rms)
{
    tvo_pnp_config def;
    if (rms != NULL)
        *rms = 0.0;
    if (n_inliers != NULL)
        *n_inliers = 0;
    if (inliers != NULL && n > 0)
        memset(inliers, 0, (size_t)n);
    if (X == NULL || x == NULL || T_c_w == NULL || n_inliers == NULL) {
        if (T_c_w != NULL)
            pose_on_error(T_c_w);
        return TVO_ERR_NULL;
    }
    if (cfg == NULL) {
        tvo_pnp_config_default(&def);
        cfg = &def;
    }
    if (!config_ok(cfg) || n < 0) {
        pose_on_error(T_c_w);
        return TVO_ERR_ARG;
    }
    if (!tvo_pose_is_finite(T_c_w)) {
        pose_on_error(T_c_w);
        return TVO_ERR_NOT_FINITE;
    }
    int32_t m = 0;
    for (int32_t i = 0; i < n && m < 3; ++i)
        m += selected(use, i, X, x);
    if (m < 3)
        return TVO_ERR_TOO_FEW;
    tvo_pose T = *T_c_w;
    refine_core(cfg, X, x, use, n, &T);
    double r = 0.0;
    int32_t cnt = mark_inliers(&T, X, x, use, n, cfg->threshold, inliers, &r);
    if (cnt < cfg->min_inliers || !tvo_pose_is_finite(&T)) {
        if (inliers != NULL && n > 0)
            memset(inliers, 0, (size_t)n);
        return TVO_ERR_TOO_FEW;
    }
    *T_c_w = T;
    *n_inliers = cnt;
    if (rms != NULL)
        *rms = r;
    return TVO_OK;
}

/* ---- RANSAC ------------------------------------------------------------------------------------- */

/* MSAC cost over the usable points idx[0..m); stops once above bail (then *ninl is partial) */
static double msac_cost(const tvo_pose *T, const double (*X)[3], const tvo_point2d *x, const int32_t *idx,
                        int32_t m, double th2, double bail, int32_t *ninl)
{
    double cost = 0.0;
    int32_t cnt = 0;
    for (int32_t k = 0; k < m; ++k) {
        int32_t i = idx[k];
        int front;
        double e2 = reproj_err2(T, X[i], &x[i], &front);
        if (front && e2 < th2) {
            cost += e2;
            ++cnt;
        } else {
            cost += th2;
        }
        if (cost > bail)
            break;
    }
    *ninl = cnt;
    return cost;
}

/* The RANSAC hypothesis search over the m usable points idx: the guess *best scored first when
 * use_guess (guess_finite: it was a finite pose), then P3P on random 3-point samples whose 4th point
 * is an inlier of a solution, each scored by its MSAC cost (bailing out above the best), the iteration
 * count adapted to the best inlier ratio. *best and *best_cost: the lowest-cost hypothesis. TVO_OK
 * when there is one, else TVO_ERR_TOO_FEW (P3P had solutions) or TVO_ERR_DEGENERATE (it never had). */
static tvo_status ransac_search(const tvo_pnp_config *cfg, const double (*X)[3], const tvo_point2d *x,
                                const int32_t *idx, int32_t m, int guess_finite, tvo_pose *best,
                                double *best_cost)
{
    const double th = cfg->threshold, th2 = th * th;
    tvo_rng rng;
    tvo_rng_seed(&rng, cfg->seed);
    *best_cost = DBL_MAX;
    int32_t best_inl = 0, need_it = cfg->max_iterations;
    int have = 0, any = 0;
    if (cfg->use_guess && guess_finite) {
        int32_t cnt;
        double cost = msac_cost(best, X, x, idx, m, th2, DBL_MAX, &cnt);
        if (cnt > 0) {
            *best_cost = cost;
            best_inl = cnt;
            have = 1;
            need_it = tvo_ransac_needed(cfg->confidence, best_inl, m, PNP_SAMPLE, cfg->max_iterations);
        }
    }
    for (int32_t it = 0; it < need_it; ++it) {
        int32_t s[PNP_SAMPLE] = {0, 0, 0, 0};
        double Xs[3][3], xs[3][2];
        tvo_pose sol[4];
        tvo_rng_sample(&rng, m, PNP_SAMPLE, s);
        for (int j = 0; j < 3; ++j) {
            int32_t i = idx[s[j]];
            memcpy(Xs[j], X[i], sizeof Xs[j]);
            xs[j][0] = x[i].x;
            xs[j][1] = x[i].y;
        }
        int ns = tvo_p3p((const double(*)[3])Xs, (const double(*)[2])xs, sol);
        if (ns == 0)
            continue;
        any = 1;
        int32_t i4 = idx[s[3]];
        for (int h = 0; h < ns; ++h) {
            int front;
            double e2 = reproj_err2(&sol[h], X[i4], &x[i4], &front);
            if (!front || !(e2 < th2))
                continue;
            int32_t cnt;
            double cost = msac_cost(&sol[h], X, x, idx, m, th2, *best_cost, &cnt);
            if (cost < *best_cost) {
                *best = sol[h];
                *best_cost = cost;
                best_inl = cnt;
                have = 1;
                need_it = tvo_ransac_needed(cfg->confidence, best_inl, m, PNP_SAMPLE, cfg->max_iterations);
            }
        }
    }
    if (!have)
        return any ? TVO_ERR_TOO_FEW : TVO_ERR_DEGENERATE;
    return TVO_OK;
}

/* Local optimisation of the best hypothesis: refine on its inliers, re-select them on all n points,
 * while the inlier set grows (PNP_LO_ROUNDS at most); a refinement is kept only when its MSAC cost
 * over idx is not above the best's. mask: the final inliers. Returns their count. */
static int32_t ransac_local_opt(const tvo_pnp_config *cfg, const double (*X)[3], const tvo_point2d *x,
                                int32_t n, const int32_t *idx, int32_t m, tvo_pose *best, double best_cost,
                                uint8_t *mask)
{
    const double th = cfg->threshold, th2 = th * th;
    int32_t cnt = mark_inliers(best, X, x, NULL, n, th, mask, NULL);
    for (int round = 0; round < PNP_LO_ROUNDS && cnt >= 3; ++round) {
        tvo_pose Tr = *best;
        int32_t cr;
        refine_core(cfg, X, x, mask, n, &Tr);
        double cost = msac_cost(&Tr, X, x, idx, m, th2, DBL_MAX, &cr);
        if (!(cost <= best_cost) || !tvo_pose_is_finite(&Tr))
            break;
        *best = Tr;
        best_cost = cost;
        int32_t prev = cnt;
        cnt = mark_inliers(best, X, x, NULL, n, th, mask, NULL);
        if (cnt <= prev)
            break;
    }
    return cnt;
}

tvo_status tvo_pnp_ransac(const tvo_pnp_config *cfg, const double (*X)[3], const tvo_point2d *x, int32_t n,
                          tvo_pose *T_c_w, uint8_t *inliers, int32_t *n_inliers, void *scratch,
                          size_t scratch_size)
{
    tvo_pnp_config def;
    if (n_inliers != NULL)
        *n_inliers = 0;
    if (inliers != NULL && n > 0)
        memset(inliers, 0, (size_t)n);
    if (X == NULL || x == NULL || T_c_w == NULL || n_inliers == NULL || scratch == NULL) {
        if (T_c_w != NULL)
            pose_on_error(T_c_w);
        return TVO_ERR_NULL;
    }
    const int guess_finite = tvo_pose_is_finite(T_c_w);
    pose_on_error(T_c_w);
    if (cfg == NULL) {
        tvo_pnp_config_default(&def);
        cfg = &def;
    }
    if (!config_ok(cfg) || n < 0)
        return TVO_ERR_ARG;
    if (n < PNP_SAMPLE)
        return TVO_ERR_TOO_FEW;
    size_t need = tvo_pnp_scratch_size(n);
    if (need == 0 || scratch_size < need)
        return TVO_ERR_NO_MEMORY;
    uintptr_t base = (uintptr_t)scratch;
    uintptr_t al = (base + 7u) & ~(uintptr_t)7u;
    int32_t *idx = (int32_t *)(void *)(al);
    uint8_t *mask = (uint8_t *)(void *)(al + (uintptr_t)n * 4u);

    int32_t m = 0;
    for (int32_t i = 0; i < n; ++i)
        if (point_usable(X[i], &x[i]))
            idx[m++] = i;
    if (m < PNP_SAMPLE)
        return TVO_ERR_TOO_FEW;

    tvo_pose best = *T_c_w;
    double best_cost;
    tvo_status st = ransac_search(cfg, X, x, idx, m, guess_finite, &best, &best_cost);
    if (st != TVO_OK)
        return st;
    int32_t cnt = ransac_local_opt(cfg, X, x, n, idx, m, &best, best_cost, mask);
    if (cnt < cfg->min_inliers)
        return TVO_ERR_TOO_FEW;
    *T_c_w = best;
    *n_inliers = cnt;
    if (inliers != NULL)
        memcpy(inliers, mask, (size_t)n);
    return TVO_OK;
}
