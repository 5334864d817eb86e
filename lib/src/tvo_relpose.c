/* SPDX-License-Identifier: Apache-2.0 */
/* Relative pose: RANSAC around the 5-point / 8-point solvers, Sampson scoring, rotation-only
 * model for low parallax, homography model selection for dominant planes, LM refinement on the
 * (R, unit t) manifold and cheirality-based decomposition. See tinyvo/relpose.h. */
#include "tinyvo/relpose.h"
#include "tinyvo/dmath.h"
#include "tinyvo/arena.h"
#include "tinyvo/linalg.h"
#include "tinyvo/ransac.h"

#include <math.h>
#include <string.h>

/* SSE2 MSAC scoring: two points per step with the same operations in the same order as the C
 * loop (-ffp-contract=off), so the costs, counts and early exits are bit-identical to it.
 * TVO_RELPOSE_NO_SIMD selects the C loop. */
#if defined(__SSE2__) && !defined(TVO_RELPOSE_NO_SIMD)
#include <emmintrin.h>
#define RP_SSE2 1
#endif

/* ---- tuning constants: every decision threshold of the estimator, in one place ---------------------
 * Squared factors multiply the squared inlier threshold cfg->threshold^2 (thr2). Changing any of
 * these changes the results (test_relpose's digests). */
#define RP_PI 3.14159265358979323846
#define RP_DEG_PER_RAD (180.0 / RP_PI)
#define RP_MAX_COORD 1e6 /* |coordinate| above this: TVO_ERR_RANGE */
#define RP_MIN_SAMPLE 5  /* the 5-point sample: fewer epipolar inliers is no epipolar model */
#define RP_MIN_SEP2 1e-6 /* sample points closer than this * thr2 (squared) are degenerate */
/* scoring (MSAC on the Sampson error; ORB-SLAM style homography / epipolar scores) */
#define RP_CHI2_1DOF 3.841 /* 95 % chi-square gates, 1 and 2 degrees of freedom */
#define RP_CHI2_2DOF 5.991
#define RP_BAIL_STEP 20 /* points between two bail-out tests (msac_cost, homography_score) */
#define RP_BAIL_Z 3.0   /* bail-out margin in standard deviations */
#define RP_PRE_N 10     /* msac_cost pre-test: points visited ... */
#define RP_PRE_EPS 0.55 /* ... and the best model's inlier ratio from which it applies */
/* local optimisation of new best hypotheses (lo_refine) */
#define RP_LO_ROUNDS_5PT 2 /* rounds at most for 5-point hypotheses ... */
#define RP_LO_ROUNDS_8PT 8 /* ... and for 8-point ones, which start further off */
#define RP_LO_FIRST2 4.0   /* first round selects within 2 thresholds (squared factor) */
#define RP_LO_MIN_POINTS 6 /* fewer selected points: no refinement */
/* final refinement (polish, refine_pose) */
#define RP_POLISH_BAND2 9.0 /* points within 3 thresholds (squared factor) are refined ... */
#define RP_POLISH_K2 (2.5 * 2.5 * 1.4826 * 1.4826) /* ... with a Cauchy scale^2 of this * median r^2 */
#define RP_LM_LAMBDA0 1e-4                         /* initial Levenberg-Marquardt damping */
#define RP_LM_LAMBDA_MIN 1e-10
#define RP_LM_CLOSE 1e-3     /* relative cost change below which the first rejection ends LM */
#define RP_LM_DONE 1e-5      /* relative cost change below which LM has converged */
#define RP_LM_STEP_MIN 1e-10 /* step norm (rad / tangent) below which LM has converged */
/* rotation-only model */
#define RP_ROT_MAX_ITERS 64  /* 2-point rotation RANSAC iterations at most */
#define RP_WIDE2 4.0         /* rotation inliers, plane cheirality counts: within 2 thresholds */
#define RP_ROT_SHARE 0.8     /* share of the epipolar inliers the rotation model must explain */
#define RP_MIN_ROT_INLIERS 3 /* fewer rotation inliers: LOW_CONFIDENCE */
/* homography model selection */
#define RP_H_SEED_SALT 0x486F6DULL /* the homography RANSAC's generator: cfg->seed ^ this */
#define RP_H_SHARE 0.5             /* a plane must hold this share of the epipolar inliers to matter */
#define RP_H_RATIO 0.40            /* ORB-SLAM2's homography / (homography + epipolar) score ratio */
#define RP_H_MIN_ITERS 16          /* homography samples at least */
#define RP_H_SAMPLE_TRIES 32       /* draws to move a sample index onto an epipolar inlier */
#define RP_H_MIN_INLIERS 8         /* a plane with fewer inliers is not decomposed */
#define RP_MIN_GOOD 5              /* a plane pose needs this many points in front of both cameras */
#define RP_TWIN_SHARE 0.85         /* twins whose good counts are within this ratio: AMBIGUOUS */
#define RP_DIFFER_ROT_DEG 0.5      /* two poses differ by more than this rotation ... */
#define RP_DIFFER_T_DEG 2.0        /* ... or this angle between their translations */
/* lm_pass's cost product (exact powers of two, so it neither overflows nor depends on the target) */
#define RP_PROD_EXP 512     /* the product of the cost factors is multiplied by 2^-512 ... */
#define RP_PROD_MAX 0x1p512 /* ... whenever it exceeds 2^512 (each factor is at most 2^100) */
#define RP_PROD_INV 0x1p-512
#if (RP_PRE_N % 2) != 0 || (RP_BAIL_STEP % 2) != 0
#error "msac_cost (SSE2) tests after pairs of points: RP_PRE_N and RP_BAIL_STEP must be even"
#endif

/* ---- small helpers -------------------------------------------------------------------------- */

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* The epipolar terms of a correspondence p1 <-> p2 under E: the first two components of E p1 and of
 * E^T p2 (the epipolar lines' normals in image 2 and 1) and the residual e = p2^T E p1. The SSE2
 * kernels below repeat these operations in this order. */
typedef struct epi_terms {
    double ex0, ex1, et0, et1, e;
} epi_terms;

static inline epi_terms epipolar_terms(const double E[9], const tvo_point2d *p1, const tvo_point2d *p2)
{
    const double a0 = p1->x, a1 = p1->y, b0 = p2->x, b1 = p2->y;
    const double ex2 = E[6] * a0 + E[7] * a1 + E[8];
    epi_terms t;
    t.ex0 = E[0] * a0 + E[1] * a1 + E[2];
    t.ex1 = E[3] * a0 + E[4] * a1 + E[5];
    t.et0 = E[0] * b0 + E[3] * b1 + E[6];
    t.et1 = E[1] * b0 + E[4] * b1 + E[7];
    t.e = b0 * t.ex0 + b1 * t.ex1 + ex2;
    return t;
}

/* Sampson denominator |E p1|_12^2 + |E^T p2|_12^2, summed left to right */
static inline double sampson_den(const epi_terms *t)
{
    return t->ex0 * t->ex0 + t->ex1 * t->ex1 + t->et0 * t->et0 + t->et1 * t->et1;
}

static double sampson2(const double E[9], const tvo_point2d *p1, const tvo_point2d *p2)
{
    const epi_terms t = epipolar_terms(E, p1, p2);
    const double d = sampson_den(&t);
    if (!(d > 1e-300))
        return 1e300;
    return t.e * t.e / d;
}

#ifdef RP_SSE2
/* Correspondences a (p1a <-> p2a) and b (p1b <-> p2b) in lanes 0 and 1: x1 and y1 of image 1 in a0
 * and a1, x2 and y2 of image 2 in b0 and b1 (the SSE2 loops below all start this way). */
static inline void rp_load2(const tvo_point2d *p1a, const tvo_point2d *p2a, const tvo_point2d *p1b,
                            const tvo_point2d *p2b, __m128d *a0, __m128d *a1, __m128d *b0, __m128d *b1)
{
    const __m128d pa = _mm_loadu_pd(&p1a->x), pb = _mm_loadu_pd(&p1b->x); /* (x, y) */
    const __m128d qa = _mm_loadu_pd(&p2a->x), qb = _mm_loadu_pd(&p2b->x);
    *a0 = _mm_unpacklo_pd(pa, pb);
    *a1 = _mm_unpackhi_pd(pa, pb);
    *b0 = _mm_unpacklo_pd(qa, qb);
    *b1 = _mm_unpackhi_pd(qa, qb);
}
#endif

/* sampson2 of the points (p1a, p2a) and (p1b, p2b): r[0], r[1]. SSE2: both in the two lanes with
 * sampson2's operations in the same order (bit-identical). */
static inline void sampson2_2(const double E[9], const tvo_point2d *p1a, const tvo_point2d *p2a,
                              const tvo_point2d *p1b, const tvo_point2d *p2b, double r[2])
{
#ifdef RP_SSE2
    __m128d a0, a1, b0, b1;
    rp_load2(p1a, p2a, p1b, p2b, &a0, &a1, &b0, &b1);
    __m128d E0 = _mm_set1_pd(E[0]), E1 = _mm_set1_pd(E[1]), E3 = _mm_set1_pd(E[3]), E4 = _mm_set1_pd(E[4]);
    __m128d ex0 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(E0, a0), _mm_mul_pd(E1, a1)), _mm_set1_pd(E[2]));
    __m128d ex1 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(E3, a0), _mm_mul_pd(E4, a1)), _mm_set1_pd(E[5]));
    __m128d ex2 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(_mm_set1_pd(E[6]), a0), _mm_mul_pd(_mm_set1_pd(E[7]), a1)),
                             _mm_set1_pd(E[8]));
    __m128d et0 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(E0, b0), _mm_mul_pd(E3, b1)), _mm_set1_pd(E[6]));
    __m128d et1 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(E1, b0), _mm_mul_pd(E4, b1)), _mm_set1_pd(E[7]));
    __m128d e = _mm_add_pd(_mm_add_pd(_mm_mul_pd(b0, ex0), _mm_mul_pd(b1, ex1)), ex2);
    __m128d d = _mm_add_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(ex0, ex0), _mm_mul_pd(ex1, ex1)),
                                      _mm_mul_pd(et0, et0)),
                           _mm_mul_pd(et1, et1));
    __m128d ok = _mm_cmpgt_pd(d, _mm_set1_pd(1e-300));
    __m128d v = _mm_div_pd(_mm_mul_pd(e, e), d);
    _mm_storeu_pd(r, _mm_or_pd(_mm_and_pd(ok, v), _mm_andnot_pd(ok, _mm_set1_pd(1e300))));
#else
    r[0] = sampson2(E, p1a, p2a);
    r[1] = sampson2(E, p1b, p2b);
#endif
}

static void essential_from_pose(const double R[9], const double t[3], double E[9])
{
    double S[9];
    tvo_la_skew(t, S);
    tvo_la_mat3_mul(S, R, E);
}

/* Order in which the scoring visits the points: i = k * stride mod n with a prime stride that does
 * not divide n (so every point is visited once). Trackers emit points grouped by image region; the
 * stride spreads any prefix of the visit over the whole input, which the bail-out test needs. */
static int32_t visit_stride(int32_t n)
{
    static const int32_t primes[] = {97, 89, 83, 79, 73, 71, 67, 61, 59, 53, 47, 43, 41,
                                     37, 31, 29, 23, 19, 17, 13, 11, 7,  5,  3,  2};
    for (size_t k = 0; k < sizeof primes / sizeof primes[0]; ++k)
        if (primes[k] < n && n % primes[k] != 0)
            return primes[k];
    return 1;
}

/* MSAC cost of E (truncated Sampson error) with three early exits:
 * - exact: the cost so far exceeds `bound` (the best cost: this E cannot win);
 * - a pre-test (in the spirit of Matas & Chum's T(d,d) and SPRT tests): at most 1 inlier among the
 *   first RP_PRE_N points while the best model's inlier ratio is at least RP_PRE_EPS;
 * - statistical bail-out (Capel, "An effective bail-out test for RANSAC consensus scoring", BMVC
 *   2005): every RP_BAIL_STEP points, reject when the inlier count is more than RP_BAIL_Z standard
 *   deviations below what a model with the best model's inlier ratio `eps` would show. A random
 *   hypothesis has few inliers and is dropped after ~20 points (most after 10 with the pre-test)
 *   instead of ~half the data.
 * Returns INFINITY for a rejected E; *inl gets the inlier count when the pass completed. */
static double msac_cost(const double E[9], const tvo_point2d *x1, const tvo_point2d *x2, int32_t n,
                        int32_t stride, double thr2, double bound, double eps, int32_t *inl)
{
    double cost = 0.0;
    int32_t cnt = 0, i = 0, check = RP_BAIL_STEP;
    const double sd = eps > 0.0 && eps < 1.0 ? RP_BAIL_Z * sqrt(eps * (1.0 - eps)) : 0.0;
    int32_t k = 0;
#ifdef RP_SSE2
    /* Points k and k + 1 (k even) per step. All early exits return INFINITY and the cost only grows,
     * so testing the bound after the pair exits exactly when the C loop does; the pre-test (after
     * point 10) and the bail-out (every 20 points) fall on the second point of a pair. */
    {
        const __m128d E0 = _mm_set1_pd(E[0]), E1 = _mm_set1_pd(E[1]), E2 = _mm_set1_pd(E[2]);
        const __m128d E3 = _mm_set1_pd(E[3]), E4 = _mm_set1_pd(E[4]), E5 = _mm_set1_pd(E[5]);
        const __m128d E6 = _mm_set1_pd(E[6]), E7 = _mm_set1_pd(E[7]), E8 = _mm_set1_pd(E[8]);
        const __m128d T2 = _mm_set1_pd(thr2);
        for (; k + 1 < n; k += 2) {
            int32_t j = i + stride;
            if (j >= n)
                j -= n;
            __m128d a0, a1, b0, b1;
            rp_load2(&x1[i], &x2[i], &x1[j], &x2[j], &a0, &a1, &b0, &b1);
            __m128d ex0 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(E0, a0), _mm_mul_pd(E1, a1)), E2);
            __m128d ex1 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(E3, a0), _mm_mul_pd(E4, a1)), E5);
            __m128d ex2 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(E6, a0), _mm_mul_pd(E7, a1)), E8);
            __m128d et0 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(E0, b0), _mm_mul_pd(E3, b1)), E6);
            __m128d et1 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(E1, b0), _mm_mul_pd(E4, b1)), E7);
            __m128d e = _mm_add_pd(_mm_add_pd(_mm_mul_pd(b0, ex0), _mm_mul_pd(b1, ex1)), ex2);
            __m128d d = _mm_add_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(ex0, ex0), _mm_mul_pd(ex1, ex1)),
                                              _mm_mul_pd(et0, et0)),
                                   _mm_mul_pd(et1, et1));
            __m128d e2 = _mm_mul_pd(e, e);
            __m128d in = _mm_cmplt_pd(e2, _mm_mul_pd(T2, d));
            /* inliers add e^2 / d, outliers thr2 (the division of an outlier lane is discarded) */
            __m128d term = _mm_or_pd(_mm_and_pd(in, _mm_div_pd(e2, d)), _mm_andnot_pd(in, T2));
            int m = _mm_movemask_pd(in);
            cost += _mm_cvtsd_f64(term);
            cost += _mm_cvtsd_f64(_mm_unpackhi_pd(term, term));
            cnt += (m & 1) + (m >> 1);
            if (cost > bound)
                return INFINITY;
            check -= 2;
            if (check == 0) {
                check = RP_BAIL_STEP;
                double mm = (double)(k + 2);
                if (sd > 0.0 && (double)cnt < mm * eps - sd * sqrt(mm))
                    return INFINITY;
            }
            if (k + 1 == RP_PRE_N - 1 && cnt <= 1 && eps >= RP_PRE_EPS)
                return INFINITY;
            i = j + stride;
            if (i >= n)
                i -= n;
        }
    }
#endif
    for (; k < n; ++k) {
        const epi_terms t = epipolar_terms(E, &x1[i], &x2[i]);
        double d = sampson_den(&t);
        double e2 = t.e * t.e;
        if (e2 < thr2 * d) { /* Sampson e^2 / d < thr2 without dividing for outliers */
            cost += e2 / d;
            ++cnt;
        } else {
            cost += thr2;
        }
        if (cost > bound)
            return INFINITY;
        if (--check == 0) {
            check = RP_BAIL_STEP;
            double m = (double)(k + 1);
            if (sd > 0.0 && (double)cnt < m * eps - sd * sqrt(m))
                return INFINITY;
        }
        /* pre-test: at most one inlier among the first 10 points visited, while the best model
         * explains at least 55 % of the points; a model as good as the best fails it with
         * probability below 0.5 % (0.45^10 + 10 * 0.55 * 0.45^9), a wrong one almost always */
        if (k == RP_PRE_N - 1 && cnt <= 1 && eps >= RP_PRE_EPS)
            return INFINITY;
        i += stride;
        if (i >= n)
            i -= n;
    }
    *inl = cnt;
    return cost;
}

static int32_t mark_inliers(const double E[9], const tvo_point2d *x1, const tvo_point2d *x2, int32_t n,
                            double thr2, uint8_t *mask)
{
    int32_t cnt = 0, i = 0;
    for (; i + 1 < n; i += 2) {
        double r[2];
        sampson2_2(E, &x1[i], &x2[i], &x1[i + 1], &x2[i + 1], r);
        int in0 = r[0] < thr2, in1 = r[1] < thr2;
        mask[i] = (uint8_t)in0;
        mask[i + 1] = (uint8_t)in1;
        cnt += in0 + in1;
    }
    for (; i < n; ++i) {
        int in = sampson2(E, &x1[i], &x2[i]) < thr2;
        mask[i] = (uint8_t)in;
        cnt += in;
    }
    return cnt;
}

/* depth signs of the midpoint triangulation: 1 both positive, 2 both negative, 0 otherwise (also for
 * rays ~parallel). The depths are linear in t: the pose (R, -t) swaps 1 and 2 exactly (the same
 * products with flipped signs), so one pass counts the points in front of both cameras for +t and -t. */
static int cheiral_sign(const double R[9], const double t[3], const tvo_point2d *p1, const tvo_point2d *p2)
{
    const double b[3] = {p2->x, p2->y, 1.0};
    /* a = R (x1, y1, 1), written out (bit-identical to tvo_la_mat3_vec, which is not inlined) */
    const double a[3] = {R[0] * p1->x + R[1] * p1->y + R[2], R[3] * p1->x + R[4] * p1->y + R[5],
                         R[6] * p1->x + R[7] * p1->y + R[8]};
    double aa = dot3(a, a), bb = dot3(b, b), ab = dot3(a, b), at = dot3(a, t), bt = dot3(b, t);
    double det = aa * bb - ab * ab;
    if (!(det > 1e-10 * aa * bb))
        return 0;
    double l1 = (-at * bb + ab * bt) / det;
    double l2 = (aa * bt - ab * at) / det;
    return (l1 > 0.0 && l2 > 0.0) ? 1 : (l1 < 0.0 && l2 < 0.0) ? 2 : 0;
}

/* points of the mask in front of both cameras for (R, t); *neg gets the count for (R, -t) */
static int32_t cheiral_count(const double R[9], const double t[3], const tvo_point2d *x1,
                             const tvo_point2d *x2, int32_t n, const uint8_t *mask, int32_t *neg)
{
    int32_t g[3] = {0, 0, 0};
    for (int32_t i = 0; i < n; ++i)
        if (mask == NULL || mask[i])
            ++g[cheiral_sign(R, t, &x1[i], &x2[i])];
    *neg = g[2];
    return g[1];
}

/* E = U diag(1, 1, 0) V^T with U, V proper rotations (det +1): the factors both pose decompositions
 * start from. */
static void essential_uv(const double E[9], double U[9], double V[9])
{
    double sv[3];
    tvo_la_svd3(E, U, sv, V);
    if (tvo_la_mat3_det(U) < 0.0)
        for (int i = 0; i < 9; ++i)
            U[i] = -U[i];
    if (tvo_la_mat3_det(V) < 0.0)
        for (int i = 0; i < 9; ++i)
            V[i] = -V[i];
}

/* The four (R, t) of E; picks the one with most points in front of both cameras among mask. */
static int32_t decompose_essential(const double E[9], const tvo_point2d *x1, const tvo_point2d *x2, int32_t n,
                                   const uint8_t *mask, double R[9], double t[3])
{
    double U[9], V[9];
    essential_uv(E, U, V);
    static const double W[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
    double UW[9], UWt[9], Ra[9], Rb[9];
    tvo_la_mat3_mul(U, W, UW);
    tvo_la_mat3_mul_bt(U, W, UWt);
    tvo_la_mat3_mul_bt(UW, V, Ra);
    tvo_la_mat3_mul_bt(UWt, V, Rb);
    double tu[3] = {U[2], U[5], U[8]};
    int32_t best = -1, gk[4];
    gk[0] = cheiral_count(Ra, tu, x1, x2, n, mask, &gk[1]);
    gk[2] = cheiral_count(Rb, tu, x1, x2, n, mask, &gk[3]);
    for (int k = 0; k < 4; ++k) {
        const double *Rc = (k < 2) ? Ra : Rb;
        double tc[3] = {tu[0], tu[1], tu[2]};
        if (k & 1) {
            tc[0] = -tc[0];
            tc[1] = -tc[1];
            tc[2] = -tc[2];
        }
        int32_t g = gk[k];
        if (g > best) {
            best = g;
            memcpy(R, Rc, 9 * sizeof(double));
            memcpy(t, tc, 3 * sizeof(double));
        }
    }
    return best;
}

static int pose_finite(const double R[9], const double t[3]);

/* ---- refinement: LM on the Sampson error over (R, unit t) ----------------------------------- */

static void tangent_basis(const double t[3], double b1[3], double b2[3])
{
    double a[3] = {0.0, 0.0, 0.0};
    int k = 0;
    if (fabs(t[1]) < fabs(t[k]))
        k = 1;
    if (fabs(t[2]) < fabs(t[k]))
        k = 2;
    a[k] = 1.0;
    tvo_la_cross(t, a, b1);
    double nb = sqrt(dot3(b1, b1));
    b1[0] /= nb;
    b1[1] /= nb;
    b1[2] /= nb;
    tvo_la_cross(t, b1, b2);
}

/* one point of lm_pass: adds its terms to acc (g[0..4], then the upper triangle of H row by row) and
 * its cost factor to *prod / *scaled */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void
lm_point(const double R[9], const double t[3], const double b1[3], const double b2[3], double a0, double a1,
         double q0, double q1, double c2, int want_cost, double *prod, int32_t *scaled, double acc[20])
{
    /* written out (the linalg helpers live in another translation unit and would not be
     * inlined): u = R f1, c = u x f2, e = t . c, f2t = f2 x t, de/dw = u x f2t,
     * E f1 = t x u, E^T f2 = R^T f2t (first two components) */
    const double u0 = R[0] * a0 + R[1] * a1 + R[2];
    const double u1 = R[3] * a0 + R[4] * a1 + R[5];
    const double u2 = R[6] * a0 + R[7] * a1 + R[8];
    const double c[3] = {u1 - u2 * q1, u2 * q0 - u0, u0 * q1 - u1 * q0};
    const double e = dot3(t, c);
    const double f2t0 = q1 * t[2] - t[1], f2t1 = t[0] - q0 * t[2], f2t2 = q0 * t[1] - q1 * t[0];
    const double gw[3] = {u1 * f2t2 - u2 * f2t1, u2 * f2t0 - u0 * f2t2, u0 * f2t1 - u1 * f2t0};
    const double ex0 = t[1] * u2 - t[2] * u1, ex1 = t[2] * u0 - t[0] * u2;
    const double et0 = R[0] * f2t0 + R[3] * f2t1 + R[6] * f2t2;
    const double et1 = R[1] * f2t0 + R[4] * f2t1 + R[7] * f2t2;
    double d = ex0 * ex0 + ex1 * ex1 + et0 * et0 + et1 * et1;
    if (!(d > 1e-300))
        return;
    double e2 = e * e;
    double q = d + e2 / c2; /* d (1 + r^2 / c2) */
    if (want_cost) {
        double opu = q / d;
        if (!(opu < 0x1p100))
            opu = 0x1p100;
        *prod *= opu;
        if (*prod > RP_PROD_MAX) {
            *prod *= RP_PROD_INV;
            ++*scaled;
        }
    }
    double J[5] = {gw[0], gw[1], gw[2], dot3(b1, c), dot3(b2, c)};
    double wgt = 1.0 / q; /* IRLS weight of the Cauchy loss on r = e / sqrt(d) */
    for (int p = 0, m = 5; p < 5; ++p) {
        double wj = wgt * J[p];
        acc[p] += wj * e;
        for (int k = p; k < 5; ++k)
            acc[m++] += wj * J[k];
    }
}

#ifdef RP_SSE2
/* lm_pass's SSE2 loop, second half: the cost factors and the weighted normal-equation terms of the
 * pair (residuals e, Sampson denominators d, the Jacobian's rotation part J[0..2]), added to acc as
 * lm_point adds them, the first point's terms then the second's */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void
lm_pair_accumulate(__m128d e, __m128d d, __m128d J[5], __m128d c0, __m128d c1, __m128d cc2,
                   const double b1[3], const double b2[3], double c2, int want_cost, double *prod,
                   int32_t *scaled, double acc[20])
{
    const __m128d B10 = _mm_set1_pd(b1[0]), B11 = _mm_set1_pd(b1[1]), B12 = _mm_set1_pd(b1[2]);
    const __m128d B20 = _mm_set1_pd(b2[0]), B21 = _mm_set1_pd(b2[1]), B22 = _mm_set1_pd(b2[2]);
    const __m128d C2 = _mm_set1_pd(c2), ONE = _mm_set1_pd(1.0);
    __m128d e2 = _mm_mul_pd(e, e);
    __m128d q = _mm_add_pd(d, _mm_div_pd(e2, C2));
    if (want_cost) {
        __m128d opu = _mm_div_pd(q, d);
        double o[2];
        _mm_storeu_pd(o, opu);
        for (int l = 0; l < 2; ++l) {
            double v = o[l];
            if (!(v < 0x1p100))
                v = 0x1p100;
            *prod *= v;
            if (*prod > RP_PROD_MAX) {
                *prod *= RP_PROD_INV;
                ++*scaled;
            }
        }
    }
    J[3] = _mm_add_pd(_mm_add_pd(_mm_mul_pd(B10, c0), _mm_mul_pd(B11, c1)), _mm_mul_pd(B12, cc2));
    J[4] = _mm_add_pd(_mm_add_pd(_mm_mul_pd(B20, c0), _mm_mul_pd(B21, c1)), _mm_mul_pd(B22, cc2));
    __m128d wgt = _mm_div_pd(ONE, q);
    __m128d P[20];
    for (int p = 0, m = 5; p < 5; ++p) {
        __m128d wj = _mm_mul_pd(wgt, J[p]);
        P[p] = _mm_mul_pd(wj, e);
        for (int k = p; k < 5; ++k)
            P[m++] = _mm_mul_pd(wj, J[k]);
    }
    /* the first point's terms, then the second's (entry pairs m, m + 1 per vector) */
    for (int m = 0; m < 20; m += 2) {
        __m128d s = _mm_loadu_pd(&acc[m]);
        s = _mm_add_pd(s, _mm_unpacklo_pd(P[m], P[m + 1]));
        s = _mm_add_pd(s, _mm_unpackhi_pd(P[m], P[m + 1]));
        _mm_storeu_pd(&acc[m], s);
    }
}

/* lm_pass's SSE2 loop: two masked points per step, the per-point arithmetic in the two lanes with
 * lm_point's operations in the same order. Returns the index from which the C loop continues (at
 * most one masked point is left). */
static int32_t lm_pairs_sse2(const double R[9], const double t[3], const double b1[3], const double b2[3],
                             const tvo_point2d *x1, const tvo_point2d *x2, int32_t n, const uint8_t *mask,
                             double c2, int want_cost, double *prod, int32_t *scaled, double acc[20])
{
    int32_t i = 0, sc = *scaled;
    double pr = *prod; /* local: stores through acc could alias *prod */
    const __m128d R0 = _mm_set1_pd(R[0]), R1 = _mm_set1_pd(R[1]), R2 = _mm_set1_pd(R[2]);
    const __m128d R3 = _mm_set1_pd(R[3]), R4 = _mm_set1_pd(R[4]), R5 = _mm_set1_pd(R[5]);
    const __m128d R6 = _mm_set1_pd(R[6]), R7 = _mm_set1_pd(R[7]), R8 = _mm_set1_pd(R[8]);
    const __m128d T0 = _mm_set1_pd(t[0]), T1 = _mm_set1_pd(t[1]), T2 = _mm_set1_pd(t[2]);
    for (;;) {
        while (i < n && !mask[i])
            ++i;
        int32_t j = i + 1;
        while (j < n && !mask[j])
            ++j;
        if (j >= n)
            break; /* at most one masked point left: the C loop below */
        __m128d a0, a1, q0, q1;
        rp_load2(&x1[i], &x2[i], &x1[j], &x2[j], &a0, &a1, &q0, &q1);
        __m128d u0 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(R0, a0), _mm_mul_pd(R1, a1)), R2);
        __m128d u1 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(R3, a0), _mm_mul_pd(R4, a1)), R5);
        __m128d u2 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(R6, a0), _mm_mul_pd(R7, a1)), R8);
        __m128d c0 = _mm_sub_pd(u1, _mm_mul_pd(u2, q1));
        __m128d c1 = _mm_sub_pd(_mm_mul_pd(u2, q0), u0);
        __m128d cc2 = _mm_sub_pd(_mm_mul_pd(u0, q1), _mm_mul_pd(u1, q0));
        __m128d e = _mm_add_pd(_mm_add_pd(_mm_mul_pd(T0, c0), _mm_mul_pd(T1, c1)), _mm_mul_pd(T2, cc2));
        __m128d f0 = _mm_sub_pd(_mm_mul_pd(q1, T2), T1);
        __m128d f1 = _mm_sub_pd(T0, _mm_mul_pd(q0, T2));
        __m128d f2 = _mm_sub_pd(_mm_mul_pd(q0, T1), _mm_mul_pd(q1, T0));
        __m128d J[5];
        J[0] = _mm_sub_pd(_mm_mul_pd(u1, f2), _mm_mul_pd(u2, f1));
        J[1] = _mm_sub_pd(_mm_mul_pd(u2, f0), _mm_mul_pd(u0, f2));
        J[2] = _mm_sub_pd(_mm_mul_pd(u0, f1), _mm_mul_pd(u1, f0));
        __m128d ex0 = _mm_sub_pd(_mm_mul_pd(T1, u2), _mm_mul_pd(T2, u1));
        __m128d ex1 = _mm_sub_pd(_mm_mul_pd(T2, u0), _mm_mul_pd(T0, u2));
        __m128d et0 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(R0, f0), _mm_mul_pd(R3, f1)), _mm_mul_pd(R6, f2));
        __m128d et1 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(R1, f0), _mm_mul_pd(R4, f1)), _mm_mul_pd(R7, f2));
        __m128d d = _mm_add_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(ex0, ex0), _mm_mul_pd(ex1, ex1)),
                                          _mm_mul_pd(et0, et0)),
                               _mm_mul_pd(et1, et1));
        if (_mm_movemask_pd(_mm_cmpgt_pd(d, _mm_set1_pd(1e-300))) != 3) {
            /* a degenerate point in the pair (rare): both through the C code, in order */
            lm_point(R, t, b1, b2, x1[i].x, x1[i].y, x2[i].x, x2[i].y, c2, want_cost, &pr, &sc, acc);
            lm_point(R, t, b1, b2, x1[j].x, x1[j].y, x2[j].x, x2[j].y, c2, want_cost, &pr, &sc, acc);
            i = j + 1;
            continue;
        }
        lm_pair_accumulate(e, d, J, c0, c1, cc2, b1, b2, c2, want_cost, &pr, &sc, acc);
        i = j + 1;
    }
    *prod = pr;
    *scaled = sc;
    return i;
}

#endif

/* One pass over the masked points at the pose (R, t): the Gauss-Newton normal equations H dx = -g
 * of the IRLS-weighted Sampson error (Cauchy loss of scale c2 = c^2) in the 5 parameters (rotation
 * increment, two tangent directions b1, b2 of t), and the robust cost sum log(1 + r^2 / c2) when
 * want_cost (else 0). Residual e = t . (R f1 x f2), Sampson r^2 = e^2 / d. The cost is the log of
 * the product of the (1 + r^2 / c2), one multiplication per point instead of one log1p (which was
 * a third of a pass): the product is rescaled by exact powers of two, and a factor is capped at
 * 2^100 (a point adds at most 100 ln 2), so it neither overflows nor depends on the target.
 * SSE2: two masked points per step, the per-point arithmetic in the two lanes with the C code's
 * operations in the same order, the sums and the product updated with the first point's terms
 * and then the second's, as the C loop does: bit-identical. */
static double lm_pass(const double Rp[9], const double tp[3], const double b1p[3], const double b2p[3],
                      const tvo_point2d *x1, const tvo_point2d *x2, int32_t n, const uint8_t *mask, double c2,
                      int want_cost, double H[25], double g[5])
{
    double prod = 1.0;
    int32_t scaled = 0; /* the cost is log(prod) + scaled * RP_PROD_EXP * log(2) */
    /* local copies of the pose and local sums: stores through H and g could alias the inputs, so
     * the compiler would otherwise reload R, t, b1, b2 and H, g from memory for every point */
    double R[9], t[3], b1[3], b2[3], acc[20];
    memcpy(R, Rp, sizeof R);
    memcpy(t, tp, sizeof t);
    memcpy(b1, b1p, sizeof b1);
    memcpy(b2, b2p, sizeof b2);
    for (int p = 0; p < 20; ++p)
        acc[p] = 0.0;
    int32_t i = 0;
#ifdef RP_SSE2
    i = lm_pairs_sse2(R, t, b1, b2, x1, x2, n, mask, c2, want_cost, &prod, &scaled, acc);
#endif
    for (; i < n; ++i) {
        if (!mask[i])
            continue;
        lm_point(R, t, b1, b2, x1[i].x, x1[i].y, x2[i].x, x2[i].y, c2, want_cost, &prod, &scaled, acc);
    }
    for (int p = 0; p < 5; ++p)
        g[p] = acc[p];
    for (int p = 0, m = 5; p < 5; ++p)
        for (int k = p; k < 5; ++k, ++m)
            H[5 * p + k] = H[5 * k + p] = acc[m];
    if (!want_cost)
        return 0.0;
    return tvo_dm_log1p(prod - 1.0) + (double)scaled * (RP_PROD_EXP * 0.69314718055994530942);
}

/* (R, t) moved by dx = (rotation increment, tangent steps along b1, b2); 0 when not finite */
static int apply_step(const double R[9], const double t[3], const double b1[3], const double b2[3],
                      const double dx[5], double Rn[9], double tn[3])
{
    double dR[9];
    tvo_la_so3_exp(dx, dR);
    tvo_la_mat3_mul(dR, R, Rn);
    for (int k = 0; k < 3; ++k)
        tn[k] = t[k] + dx[3] * b1[k] + dx[4] * b2[k];
    double nt = sqrt(dot3(tn, tn));
    if (!(nt > 0.0) || !isfinite(nt))
        return 0;
    tn[0] /= nt;
    tn[1] /= nt;
    tn[2] /= nt;
    return 1;
}

static int solve_damped(const double H[25], const double g[5], double lambda, double dx[5])
{
    double A[25], rhs[5];
    memcpy(A, H, sizeof A);
    for (int p = 0; p < 5; ++p) {
        A[6 * p] += lambda * (H[6 * p] > 1e-12 ? H[6 * p] : 1e-12);
        rhs[p] = -g[p];
    }
    return tvo_la_solve(A, rhs, 5, dx) == TVO_OK;
}

/* Levenberg-Marquardt on the robust Sampson cost over the masked points. One pass per iteration:
 * the pass at a trial pose gives both its cost (accept / reject) and, when accepted, the normal
 * equations of the next step. */
static void refine_pose(double R[9], double t[3], const tvo_point2d *x1, const tvo_point2d *x2, int32_t n,
                        const uint8_t *mask, int iters, double c2)
{
    double H[25], g[5], b1[3], b2[3];
    tangent_basis(t, b1, b2);
    double cost = lm_pass(R, t, b1, b2, x1, x2, n, mask, c2, 1, H, g);
    double lambda = RP_LM_LAMBDA0;
    /* `iters` accepted steps at most; rejected trials (lambda x 10) do not count. Three rejections
     * in a row end it: the normal equations treat the Sampson denominator as constant, so close to
     * the optimum their step is not an exact descent direction of the cost, and further damping
     * only buys changes far below the noise. Once an accepted step changed the cost by less than
     * 1e-3 (relative) the pose is that close to the optimum, and the first rejection ends it. */
    for (int it = 0, rejected = 0, limit = 3; it < iters && rejected < limit;) {
        double dx[5], Rn[9], tn[3], Hn[25], gn[5], nb1[3], nb2[3];
        if (!solve_damped(H, g, lambda, dx))
            break;
        /* converged: a step below 1e-10 (radians / unit-vector tangent) changes nothing that
         * matters, and trial costs at that scale differ only by rounding */
        if (dot3(dx, dx) + dx[3] * dx[3] + dx[4] * dx[4] < 1e-20)
            break;
        if (!apply_step(R, t, b1, b2, dx, Rn, tn))
            break;
        tangent_basis(tn, nb1, nb2);
        double cn = lm_pass(Rn, tn, nb1, nb2, x1, x2, n, mask, c2, 1, Hn, gn);
        if (cn < cost && isfinite(cn)) {
            double step = sqrt(dot3(dx, dx) + dx[3] * dx[3] + dx[4] * dx[4]);
            double rel = (cost - cn) / (cost > 1e-300 ? cost : 1e-300);
            memcpy(R, Rn, sizeof Rn);
            memcpy(t, tn, sizeof tn);
            memcpy(H, Hn, sizeof Hn);
            memcpy(g, gn, sizeof gn);
            memcpy(b1, nb1, sizeof nb1);
            memcpy(b2, nb2, sizeof nb2);
            cost = cn;
            lambda = lambda * 0.1 > RP_LM_LAMBDA_MIN ? lambda * 0.1 : RP_LM_LAMBDA_MIN;
            ++it;
            rejected = 0;
            limit = rel < RP_LM_CLOSE ? 1 : 3;
            /* converged for every purpose: a relative cost change below 1e-5 moves the pose by
               orders of magnitude less than the noise (0.04 deg median error at 0.5 px; the steps
               shrink by ~0.4 per iteration there, so the pose is within ~1e-5 rad of the limit) */
            if (step < RP_LM_STEP_MIN || rel < RP_LM_DONE)
                break;
        } else {
            lambda *= 10.0;
            ++rejected;
        }
    }
    /* keep R exactly orthonormal */
    double Ro[9];
    tvo_la_orthonormalize(R, Ro);
    memcpy(R, Ro, sizeof Ro);
}

/* ---- rotation-only model (bearing vectors, Kabsch) ------------------------------------------ */

static void bearing(const tvo_point2d *p, double f[3])
{
    double n = sqrt(p->x * p->x + p->y * p->y + 1.0);
    f[0] = p->x / n;
    f[1] = p->y / n;
    f[2] = 1.0 / n;
}

static double rot_residual2(const double R[9], const tvo_point2d *p1, const tvo_point2d *p2)
{
    double f1[3], f2[3], u[3];
    bearing(p1, f1);
    bearing(p2, f2);
    tvo_la_mat3_vec(R, f1, u);
    double dx = u[0] - f2[0], dy = u[1] - f2[1], dz = u[2] - f2[2];
    return dx * dx + dy * dy + dz * dz;
}

/* R maximising sum f2^T R f1 over the mask (or over idx[0..k) when idx != NULL) */
static void kabsch(const tvo_point2d *x1, const tvo_point2d *x2, int32_t n, const uint8_t *mask,
                   const int32_t *idx, int k, double R[9])
{
    double M[9] = {0};
    int32_t count = idx != NULL ? k : n;
    for (int32_t j = 0; j < count; ++j) {
        int32_t i = idx != NULL ? idx[j] : j;
        if (idx == NULL && !mask[i])
            continue;
        double f1[3], f2[3];
        bearing(&x1[i], f1);
        bearing(&x2[i], f2);
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                M[3 * r + c] += f2[r] * f1[c];
    }
    tvo_la_orthonormalize(M, R);
}

static int32_t rot_inliers(const double R[9], const tvo_point2d *x1, const tvo_point2d *x2, int32_t n,
                           double thr2, uint8_t *mask)
{
    int32_t cnt = 0;
    for (int32_t i = 0; i < n; ++i) {
        int in = rot_residual2(R, &x1[i], &x2[i]) < thr2;
        if (mask != NULL)
            mask[i] = (uint8_t)in;
        cnt += in;
    }
    return cnt;
}

static int32_t rotation_ransac(const tvo_relpose_config *cfg, const tvo_point2d *x1, const tvo_point2d *x2,
                               int32_t n, double thr2, double R[9], uint8_t *mask)
{
    tvo_rng rng;
    tvo_rng_seed(&rng, cfg->seed ^ 0x526F74ULL);
    /* the rotation model only matters when it explains most points (low parallax), where a
     * 2-point RANSAC converges in a few iterations: bounded by RP_ROT_MAX_ITERS */
    int32_t cap = cfg->max_iters < RP_ROT_MAX_ITERS ? cfg->max_iters : RP_ROT_MAX_ITERS;
    int32_t best = -1, need = cap;
    double Rb[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    for (int32_t it = 0; it < need && it < cap; ++it) {
        int32_t idx[2];
        double Rc[9];
        tvo_rng_sample(&rng, n, 2, idx);
        kabsch(x1, x2, n, NULL, idx, 2, Rc);
        int32_t c = rot_inliers(Rc, x1, x2, n, thr2, NULL);
        if (c > best) {
            best = c;
            memcpy(Rb, Rc, sizeof Rc);
            need = tvo_ransac_needed(cfg->confidence, best, n, 2, cap);
        }
    }
    int32_t cnt = rot_inliers(Rb, x1, x2, n, thr2, mask);
    /* least-squares refit on the inliers (always accepted: the 2-point model is noisier even when
     * it happens to count a few more inliers) */
    for (int round = 0; round < 3 && cnt >= 2; ++round) {
        double Rc[9];
        kabsch(x1, x2, n, mask, NULL, 0, Rc);
        int32_t c2 = rot_inliers(Rc, x1, x2, n, thr2, NULL);
        if (c2 < 2)
            break;
        memcpy(Rb, Rc, sizeof Rc);
        cnt = rot_inliers(Rb, x1, x2, n, thr2, mask);
    }
    memcpy(R, Rb, sizeof Rb);
    return cnt;
}

/* Rotation-only model seeded by the epipolar inliers: with little parallax every point that fits
 * the rotation also fits the epipolar model (x2 ~ R x1 satisfies x2 . (t x R x1) = 0 for any t), so
 * a least-squares rotation on the epipolar inliers followed by re-selection of the rotation
 * inliers (threshold thr2 on the chord between bearings) and refits converges to the rotation
 * model's consensus set without a separate RANSAC. With real parallax the rotation explains few
 * points and the parallax test below rejects it anyway. */
static int32_t rotation_from_inliers(const double E[9], const tvo_point2d *x1, const tvo_point2d *x2,
                                     int32_t n, double thr2, const uint8_t *mask_e, double R[9],
                                     uint8_t *mask)
{
    /* seeds: the least-squares rotation of the epipolar inliers (biased by the few outliers that
     * happen to lie on their epipolar lines), and the two rotations of E's decompositions (one of
     * them is the rotation itself when the parallax is small); the one with most rotation inliers
     * starts the refits */
    double Rb[9], seeds[3][9];
    int ns = 1;
    kabsch(x1, x2, n, mask_e, NULL, 0, seeds[0]);
    {
        double U[9], sv[3], V[9], UW[9];
        tvo_la_svd3(E, U, sv, V);
        if (tvo_la_mat3_det(U) < 0.0)
            for (int i = 0; i < 9; ++i)
                U[i] = -U[i];
        if (tvo_la_mat3_det(V) < 0.0)
            for (int i = 0; i < 9; ++i)
                V[i] = -V[i];
        static const double W[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
        tvo_la_mat3_mul(U, W, UW);
        tvo_la_mat3_mul_bt(UW, V, seeds[1]);
        tvo_la_mat3_mul_bt(U, W, UW);
        tvo_la_mat3_mul_bt(UW, V, seeds[2]);
        if (pose_finite(seeds[1], sv) && pose_finite(seeds[2], sv))
            ns = 3;
    }
    int32_t cnt = -1;
    for (int k = 0; k < ns; ++k) {
        int32_t c = rot_inliers(seeds[k], x1, x2, n, thr2, NULL);
        if (c > cnt) {
            cnt = c;
            memcpy(Rb, seeds[k], sizeof Rb);
        }
    }
    cnt = rot_inliers(Rb, x1, x2, n, thr2, mask);
    for (int round = 0; round < 3 && cnt >= 2; ++round) {
        double Rc[9];
        kabsch(x1, x2, n, mask, NULL, 0, Rc);
        int32_t c2 = rot_inliers(Rc, x1, x2, n, thr2, NULL);
        if (c2 < 2)
            break;
        memcpy(Rb, Rc, sizeof Rc);
        int32_t prev = cnt;
        cnt = rot_inliers(Rb, x1, x2, n, thr2, mask);
        if (cnt == prev && round > 0)
            break;
    }
    memcpy(R, Rb, sizeof Rb);
    return cnt;
}

/* ---- homography ----------------------------------------------------------------------------- */

static int homography_4pt(const tvo_point2d *x1, const tvo_point2d *x2, const int32_t *idx, double H[9])
{
    double A[64], b[8], h[8];
    for (int k = 0; k < 4; ++k) {
        double a0 = x1[idx[k]].x, a1 = x1[idx[k]].y, u = x2[idx[k]].x, v = x2[idx[k]].y;
        double *r0 = &A[16 * k], *r1 = &A[16 * k + 8];
        r0[0] = a0;
        r0[1] = a1;
        r0[2] = 1;
        r0[3] = 0;
        r0[4] = 0;
        r0[5] = 0;
        r0[6] = -u * a0;
        r0[7] = -u * a1;
        r1[0] = 0;
        r1[1] = 0;
        r1[2] = 0;
        r1[3] = a0;
        r1[4] = a1;
        r1[5] = 1;
        r1[6] = -v * a0;
        r1[7] = -v * a1;
        b[2 * k] = u;
        b[2 * k + 1] = v;
    }
    if (tvo_la_solve(A, b, 8, h) != TVO_OK)
        return 0;
    for (int k = 0; k < 8; ++k) {
        if (!isfinite(h[k]))
            return 0;
        H[k] = h[k];
    }
    H[8] = 1.0;
    return 1;
}

static void adjugate3(const double A[9], double B[9])
{
    B[0] = A[4] * A[8] - A[5] * A[7];
    B[1] = A[2] * A[7] - A[1] * A[8];
    B[2] = A[1] * A[5] - A[2] * A[4];
    B[3] = A[5] * A[6] - A[3] * A[8];
    B[4] = A[0] * A[8] - A[2] * A[6];
    B[5] = A[2] * A[3] - A[0] * A[5];
    B[6] = A[3] * A[7] - A[4] * A[6];
    B[7] = A[1] * A[6] - A[0] * A[7];
    B[8] = A[0] * A[4] - A[1] * A[3];
}

static double transfer2(const double H[9], const tvo_point2d *a, const tvo_point2d *b)
{
    double w = H[6] * a->x + H[7] * a->y + H[8];
    if (!(fabs(w) > 1e-12))
        return 1e300;
    double u = (H[0] * a->x + H[1] * a->y + H[2]) / w - b->x;
    double v = (H[3] * a->x + H[4] * a->y + H[5]) / w - b->y;
    return u * u + v * v;
}

/* ORB-SLAM style score of H (both transfer directions, chi-square 2 dof gate). Without a mask the
 * points are visited in stride order with two early exits (returning -1): the score cannot reach
 * `best` any more, or the inlier count is RP_BAIL_Z deviations below a model with inlier ratio eps
 * (the bail-out test of msac_cost). With a mask every point is scored in index order. */
static double homography_score(const double H[9], const double Hi[9], const tvo_point2d *x1,
                               const tvo_point2d *x2, int32_t n, double inv_s2, double best, uint8_t *mask,
                               int32_t *inl, int32_t stride, double eps)
{
    double score = 0.0, remaining = 2.0 * RP_CHI2_2DOF * (double)n;
    int32_t cnt = 0, i = 0, check = RP_BAIL_STEP;
    if (mask != NULL) {
        stride = 1;
        eps = 0.0;
    }
    const double sd = eps > 0.0 && eps < 1.0 ? RP_BAIL_Z * sqrt(eps * (1.0 - eps)) : 0.0;
    for (int32_t k = 0; k < n; ++k) {
        double c1 = transfer2(H, &x1[i], &x2[i]) * inv_s2;
        double c2 = transfer2(Hi, &x2[i], &x1[i]) * inv_s2;
        int in = 1;
        if (c1 < RP_CHI2_2DOF)
            score += RP_CHI2_2DOF - c1;
        else
            in = 0;
        if (c2 < RP_CHI2_2DOF)
            score += RP_CHI2_2DOF - c2;
        else
            in = 0;
        if (mask != NULL)
            mask[i] = (uint8_t)in;
        cnt += in;
        remaining -= 2.0 * RP_CHI2_2DOF;
        if (mask == NULL) {
            if (score + remaining < best)
                return -1.0;
            if (--check == 0) {
                check = RP_BAIL_STEP;
                double m = (double)(k + 1);
                if (sd > 0.0 && (double)cnt < m * eps - sd * sqrt(m))
                    return -1.0;
            }
        }
        i += stride;
        if (i >= n)
            i -= n;
    }
    *inl = cnt;
    return score;
}

static double essential_score(const double E[9], const tvo_point2d *x1, const tvo_point2d *x2, int32_t n,
                              double inv_s2)
{
    double score = 0.0;
    for (int32_t i = 0; i < n; ++i) {
        const epi_terms t = epipolar_terms(E, &x1[i], &x2[i]);
        const double e = t.e;
        double d2 = t.ex0 * t.ex0 + t.ex1 * t.ex1, d1 = t.et0 * t.et0 + t.et1 * t.et1;
        if (d2 > 1e-300) {
            double c = e * e / d2 * inv_s2;
            if (c < RP_CHI2_1DOF)
                score += RP_CHI2_2DOF - c;
        }
        if (d1 > 1e-300) {
            double c = e * e / d1 * inv_s2;
            if (c < RP_CHI2_1DOF)
                score += RP_CHI2_2DOF - c;
        }
    }
    return score;
}

/* least-squares H over the mask (Hartley-normalised DLT); 0 on failure */
static int homography_dlt(const tvo_point2d *x1, const tvo_point2d *x2, int32_t n, const uint8_t *mask,
                          double H[9])
{
    double c1x = 0, c1y = 0, c2x = 0, c2y = 0, s1 = 0, s2 = 0;
    int32_t m = 0;
    for (int32_t i = 0; i < n; ++i)
        if (mask[i]) {
            c1x += x1[i].x;
            c1y += x1[i].y;
            c2x += x2[i].x;
            c2y += x2[i].y;
            ++m;
        }
    if (m < 4)
        return 0;
    c1x /= m;
    c1y /= m;
    c2x /= m;
    c2y /= m;
    for (int32_t i = 0; i < n; ++i)
        if (mask[i]) {
            s1 += tvo_dm_hypot(x1[i].x - c1x, x1[i].y - c1y);
            s2 += tvo_dm_hypot(x2[i].x - c2x, x2[i].y - c2y);
        }
    if (!(s1 > 1e-12) || !(s2 > 1e-12))
        return 0;
    s1 = sqrt(2.0) * m / s1;
    s2 = sqrt(2.0) * m / s2;
    double AtA[81] = {0};
    for (int32_t i = 0; i < n; ++i) {
        if (!mask[i])
            continue;
        double a0 = (x1[i].x - c1x) * s1, a1 = (x1[i].y - c1y) * s1;
        double u = (x2[i].x - c2x) * s2, v = (x2[i].y - c2y) * s2;
        double r0[9] = {a0, a1, 1, 0, 0, 0, -u * a0, -u * a1, -u};
        double r1[9] = {0, 0, 0, a0, a1, 1, -v * a0, -v * a1, -v};
        for (int p = 0; p < 9; ++p)
            for (int q = p; q < 9; ++q)
                AtA[9 * p + q] += r0[p] * r0[q] + r1[p] * r1[q];
    }
    for (int p = 0; p < 9; ++p)
        for (int q = 0; q < p; ++q)
            AtA[9 * p + q] = AtA[9 * q + p];
    double w[9], V[81];
    if (tvo_la_sym_eig(AtA, 9, w, V) != TVO_OK)
        return 0;
    double Hn[9], T1[9] = {s1, 0, -s1 * c1x, 0, s1, -s1 * c1y, 0, 0, 1};
    double T2i[9] = {1.0 / s2, 0, c2x, 0, 1.0 / s2, c2y, 0, 0, 1}, tmp[9];
    for (int k = 0; k < 9; ++k)
        Hn[k] = V[9 * k];
    tvo_la_mat3_mul(Hn, T1, tmp);
    tvo_la_mat3_mul(T2i, tmp, H);
    for (int k = 0; k < 9; ++k)
        if (!isfinite(H[k]))
            return 0;
    return 1;
}

/* Faugeras decomposition of H ~ R + t n^T: up to 8 (R, t) candidates, each also with -t (16). */
static int decompose_homography(const double H[9], double Rs[16][9], double ts[16][3])
{
    double U[9], d[3], V[9];
    tvo_la_svd3(H, U, d, V);
    if (!(d[2] > 0.0))
        return 0;
    if (d[0] / d[1] < 1.00001 || d[1] / d[2] < 1.00001)
        return 0;
    double s = tvo_la_mat3_det(U) * tvo_la_mat3_det(V);
    double d1 = d[0], d2 = d[1], d3 = d[2];
    double a1 = sqrt((d1 * d1 - d2 * d2) / (d1 * d1 - d3 * d3));
    double a3 = sqrt((d2 * d2 - d3 * d3) / (d1 * d1 - d3 * d3));
    double x1s[4] = {a1, a1, -a1, -a1}, x3s[4] = {a3, -a3, a3, -a3};
    double root = sqrt((d1 * d1 - d2 * d2) * (d2 * d2 - d3 * d3));
    int nc = 0;
    for (int sign = 0; sign < 2; ++sign) {
        double cth, sth;
        if (sign == 0) {
            sth = root / ((d1 + d3) * d2);
            cth = (d2 * d2 + d1 * d3) / ((d1 + d3) * d2);
        } else {
            sth = root / ((d1 - d3) * d2);
            cth = (d1 * d3 - d2 * d2) / ((d1 - d3) * d2);
        }
        for (int i = 0; i < 4; ++i) {
            double st = (i == 0 || i == 3) ? sth : -sth;
            double Rp[9], tp[3], tmp[9], R[9], t[3];
            if (sign == 0) {
                double r[9] = {cth, 0, -st, 0, 1, 0, st, 0, cth};
                memcpy(Rp, r, sizeof r);
                tp[0] = x1s[i] * (d1 - d3);
                tp[1] = 0.0;
                tp[2] = -x3s[i] * (d1 - d3);
            } else {
                double r[9] = {cth, 0, st, 0, -1, 0, st, 0, -cth};
                memcpy(Rp, r, sizeof r);
                tp[0] = x1s[i] * (d1 + d3);
                tp[1] = 0.0;
                tp[2] = x3s[i] * (d1 + d3);
            }
            tvo_la_mat3_mul_bt(Rp, V, tmp);
            tvo_la_mat3_mul(U, tmp, R);
            for (int k = 0; k < 9; ++k)
                R[k] *= s;
            tvo_la_mat3_vec(U, tp, t);
            double nt = sqrt(dot3(t, t));
            if (!(nt > 1e-12))
                continue;
            for (int pm = 0; pm < 2; ++pm) {
                double f = (pm == 0 ? 1.0 : -1.0) / nt;
                memcpy(Rs[nc], R, sizeof R);
                ts[nc][0] = t[0] * f;
                ts[nc][1] = t[1] * f;
                ts[nc][2] = t[2] * f;
                ++nc;
            }
        }
    }
    return nc;
}

/* R equal to Rb entry by entry (as values: the pairs decompose_homography emits share one R) */
static int same_rotation(const double Ra[9], const double Rb[9])
{
    for (int i = 0; i < 9; ++i)
        if (!(Ra[i] == Rb[i]))
            return 0;
    return 1;
}

/* points that are Sampson inliers of [t]x R AND in front of both cameras; with neg != NULL also the
 * count for the pose (R, -t) in the same pass (same Sampson error, depth signs swapped) */
static int32_t good_count2(const double R[9], const double t[3], const tvo_point2d *x1, const tvo_point2d *x2,
                           int32_t n, double thr2, const uint8_t *mask, int32_t *neg)
{
    double E[9];
    int32_t g[3] = {0, 0, 0};
    essential_from_pose(R, t, E);
    for (int32_t i = 0; i < n; ++i) {
        if (mask != NULL && !mask[i])
            continue;
        if (sampson2(E, &x1[i], &x2[i]) < thr2)
            ++g[cheiral_sign(R, t, &x1[i], &x2[i])];
    }
    if (neg != NULL)
        *neg = g[2];
    return g[1];
}

static int32_t good_count(const double R[9], const double t[3], const tvo_point2d *x1, const tvo_point2d *x2,
                          int32_t n, double thr2, const uint8_t *mask)
{
    return good_count2(R, t, x1, x2, n, thr2, mask, NULL);
}

static int poses_differ(const double Ra[9], const double ta[3], const double Rb[9], const double tb[3])
{
    double c = dot3(ta, tb);
    return tvo_la_rot_dist(Ra, Rb) > RP_DIFFER_ROT_DEG * RP_PI / 180.0 ||
            c < tvo_dm_cos(RP_DIFFER_T_DEG * RP_PI / 180.0);
}

/* ---- public API ----------------------------------------------------------------------------- */

void tvo_relpose_config_default(tvo_relpose_config *cfg)
{
    if (cfg == NULL)
        return;
    cfg->method = TVO_RELPOSE_5PT;
    cfg->threshold = 1.0 / 460.0;
    cfg->confidence = 0.999;
    cfg->max_iters = 1000;
    cfg->seed = 0x5eedULL;
    cfg->min_parallax_deg = 0.5;
    cfg->min_inliers = 15;
    cfg->use_homography = 1;
    cfg->refine_iters = 10;
}

size_t tvo_relpose_scratch_size(int32_t max_points)
{
    size_t n = max_points > 0 ? (size_t)max_points : 0;
    size_t s = TVO_ARENA_ALIGN;
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(double))));
    for (int k = 0; k < 4; ++k)
        s = tvo_size_add(s, tvo_arena_round(n));
    return s;
}

static void set_identity_result(tvo_relpose *out)
{
    memset(out, 0, sizeof *out);
    out->R[0] = out->R[4] = out->R[8] = 1.0;
    out->R_alt[0] = out->R_alt[4] = out->R_alt[8] = 1.0;
    out->R_rot[0] = out->R_rot[4] = out->R_rot[8] = 1.0;
    out->flags = TVO_RELPOSE_FLAG_LOW_CONFIDENCE;
}

static int pose_finite(const double R[9], const double t[3])
{
    for (int k = 0; k < 9; ++k)
        if (!isfinite(R[k]))
            return 0;
    for (int k = 0; k < 3; ++k)
        if (!isfinite(t[k]))
            return 0;
    return 1;
}

static tvo_status check_config(const tvo_relpose_config *c)
{
    if (c->method != TVO_RELPOSE_5PT && c->method != TVO_RELPOSE_8PT)
        return TVO_ERR_ARG;
    if (!(c->threshold > 0.0) || !isfinite(c->threshold))
        return TVO_ERR_ARG;
    if (!(c->confidence > 0.0 && c->confidence < 1.0))
        return TVO_ERR_ARG;
    if (c->max_iters < 1 || c->min_inliers < 0)
        return TVO_ERR_ARG;
    if (!(c->min_parallax_deg >= 0.0) || !isfinite(c->min_parallax_deg))
        return TVO_ERR_ARG;
    if (c->use_homography != 0 && c->use_homography != 1)
        return TVO_ERR_ARG;
    if (c->refine_iters < 0 || c->refine_iters > 100)
        return TVO_ERR_ARG;
    return TVO_OK;
}

/* smallest / largest eigenvalue ratio of the 2x2 scatter of the points: 0 when collinear */
static int collinear(const tvo_point2d *x, int32_t n)
{
    double mx = 0, my = 0, sxx = 0, sxy = 0, syy = 0;
    for (int32_t i = 0; i < n; ++i) {
        mx += x[i].x;
        my += x[i].y;
    }
    mx /= n;
    my /= n;
    for (int32_t i = 0; i < n; ++i) {
        double dx = x[i].x - mx, dy = x[i].y - my;
        sxx += dx * dx;
        sxy += dx * dy;
        syy += dy * dy;
    }
    double tr = sxx + syy, det = sxx * syy - sxy * sxy;
    if (!(tr > 1e-24))
        return 1;
    double disc = sqrt(fmax(0.0, 0.25 * tr * tr - det));
    double lmin = 0.5 * tr - disc;
    return lmin <= 1e-12 * tr;
}

/* Any one (R, t) with [t]x R = E up to scale (no cheirality: all four give the same Sampson error) */
static int pose_any(const double E[9], double R[9], double t[3])
{
    double U[9], V[9];
    essential_uv(E, U, V);
    static const double W[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
    double UW[9];
    tvo_la_mat3_mul(U, W, UW);
    tvo_la_mat3_mul_bt(UW, V, R);
    t[0] = U[2];
    t[1] = U[5];
    t[2] = U[8];
    return pose_finite(R, t);
}

/* Local optimisation of a new best hypothesis (LO-RANSAC, Chum, Matas & Kittler 2003): rounds of
 * inlier selection and two Gauss-Newton steps of the Cauchy-weighted Sampson error. A model fitted to
 * 5 noisy points under-counts the inliers of the true model, so the adaptive stopping criterion
 * would run far more iterations than the real inlier ratio needs; the refined model counts them
 * (and seeds the final refinement better). The first round selects within 2 thresholds (a model
 * fitted to 5 noisy points is often off by more than the threshold over part of the image), the
 * second within the threshold of the improved model; up to max_rounds rounds continue while that
 * selection grows: RP_LO_ROUNDS_5PT rounds for 5-point hypotheses (more rounds save RANSAC iterations
 * but no time), up to RP_LO_ROUNDS_8PT for 8-point ones, which start further off (after 2 rounds LO
 * often stops on part of the inliers, and raw hypotheses rarely beat that, so the RANSAC would run to
 * max_iters). mask: n bytes of scratch. Returns 0 on failure. */
static int lo_refine(const double E[9], const tvo_point2d *x1, const tvo_point2d *x2, int32_t n, double thr2,
                     int max_rounds, uint8_t *mask, double Eout[9])
{
    double R[9], t[3];
    if (!pose_any(E, R, t))
        return 0;
    essential_from_pose(R, t, Eout);
    int32_t prev = 0;
    for (int round = 0; round < max_rounds; ++round) {
        int32_t m = mark_inliers(Eout, x1, x2, n, round == 0 ? RP_LO_FIRST2 * thr2 : thr2, mask);
        if (m < RP_LO_MIN_POINTS)
            return 0;
        if (round >= 2 && m <= prev)
            break;
        prev = round == 0 ? 0 : m;
        for (int it = 0; it < 2; ++it) {
            double H[25], g[5], b1[3], b2[3], dx[5], Rn[9], tn[3];
            tangent_basis(t, b1, b2);
            lm_pass(R, t, b1, b2, x1, x2, n, mask, thr2, 0, H, g);
            if (!solve_damped(H, g, 1e-6, dx) || !apply_step(R, t, b1, b2, dx, Rn, tn))
                return 0;
            memcpy(R, Rn, sizeof Rn);
            memcpy(t, tn, sizeof tn);
        }
        essential_from_pose(R, t, Eout);
    }
    for (int k = 0; k < 9; ++k)
        if (!isfinite(Eout[k]))
            return 0;
    return 1;
}

/* epipolar RANSAC; returns the best E's inlier count (0 when no model). mask: n bytes of scratch */
static int32_t essential_ransac(const tvo_relpose_config *cfg, const tvo_point2d *x1, const tvo_point2d *x2,
                                int32_t n, double thr2, double Ebest[9], int32_t *iters_out, uint8_t *mask)
{
    tvo_rng rng;
    tvo_rng_seed(&rng, cfg->seed);
    int s = cfg->method == TVO_RELPOSE_8PT ? 8 : 5;
    double best_cost = INFINITY, eps = 0.0;
    int32_t best_inl = 0, need = cfg->max_iters, it;
    const int32_t stride = visit_stride(n);
    double min_sep2 = RP_MIN_SEP2 * thr2;
    for (it = 0; it < need && it < cfg->max_iters; ++it) {
        int32_t idx[8];
        double a[8][2], b[8][2];
        tvo_rng_sample(&rng, n, s, idx);
        int degenerate = 0;
        for (int k = 0; k < s; ++k) {
            a[k][0] = x1[idx[k]].x;
            a[k][1] = x1[idx[k]].y;
            b[k][0] = x2[idx[k]].x;
            b[k][1] = x2[idx[k]].y;
            for (int j = 0; j < k; ++j) {
                double d1 = (a[k][0] - a[j][0]) * (a[k][0] - a[j][0]) +
                        (a[k][1] - a[j][1]) * (a[k][1] - a[j][1]);
                double d2 = (b[k][0] - b[j][0]) * (b[k][0] - b[j][0]) +
                        (b[k][1] - b[j][1]) * (b[k][1] - b[j][1]);
                if (d1 < min_sep2 || d2 < min_sep2)
                    degenerate = 1;
            }
        }
        if (degenerate)
            continue;
        double Es[10][9];
        int ns;
        if (s == 5)
            ns = tvo_essential_5pt((const double(*)[2])a, (const double(*)[2])b, Es);
        else
            ns = tvo_essential_8pt((const double(*)[2])a, (const double(*)[2])b, 8, Es[0]);
        for (int m = 0; m < ns; ++m) {
            int32_t inl = 0;
            double c = msac_cost(Es[m], x1, x2, n, stride, thr2, best_cost, eps, &inl);
            if (!(c < best_cost))
                continue;
            best_cost = c;
            best_inl = inl;
            memcpy(Ebest, Es[m], 9 * sizeof(double));
            double Elo[9];
            if (best_inl >= 2 * s &&
                lo_refine(Ebest, x1, x2, n, thr2, s == 8 ? RP_LO_ROUNDS_8PT : RP_LO_ROUNDS_5PT, mask, Elo)) {
                int32_t inl2 = 0;
                double c2 = msac_cost(Elo, x1, x2, n, stride, thr2, best_cost, 0.0, &inl2);
                if (c2 < best_cost) {
                    best_cost = c2;
                    best_inl = inl2;
                    memcpy(Ebest, Elo, sizeof Elo);
                }
            }
            eps = (double)best_inl / (double)n;
            need = tvo_ransac_needed(cfg->confidence, best_inl, n, s, cfg->max_iters);
        }
    }
    *iters_out = it;
    return best_inl;
}

/* re-select inliers of (R, t) and refine, twice; returns the final inlier count in mask.
 * The refinement uses the points within 3 thresholds with a Cauchy loss whose scale follows the
 * robust spread of their residuals (2.5 * 1.4826 * median |r|, at most the threshold): the hard
 * RANSAC threshold would cut the tails of the inlier noise, and a fixed scale would let the few
 * outliers that fall near an epipolar line bias noise-free data. buf: n doubles. */
static int32_t polish(const tvo_relpose_config *cfg, double R[9], double t[3], const tvo_point2d *x1,
                      const tvo_point2d *x2, int32_t n, double thr2, uint8_t *mask, double *buf)
{
    double E[9], c2_prev = INFINITY;
    /* two rounds; up to two more while the scale keeps collapsing (near noise-free data: the
     * Cauchy weights leave the outliers of the 3-threshold band a pull proportional to c2). A
     * round whose point set is unchanged and whose scale moved by less than 10 % would solve the
     * problem just solved: it is skipped. */
    for (int round = 0; round < 4; ++round) {
        essential_from_pose(R, t, E);
        int32_t m = 0, changed = 0;
        double rr[2] = {0.0, 0.0};
        for (int32_t i = 0; i < n; ++i) {
            if ((i & 1) == 0) { /* two at a time */
                if (i + 1 < n)
                    sampson2_2(E, &x1[i], &x2[i], &x1[i + 1], &x2[i + 1], rr);
                else
                    rr[0] = sampson2(E, &x1[i], &x2[i]);
            }
            double r2 = rr[i & 1];
            uint8_t in = (uint8_t)(r2 < RP_POLISH_BAND2 * thr2);
            changed += round > 0 && in != mask[i];
            mask[i] = in;
            if (in)
                buf[m++] = r2;
        }
        if (m < RP_LO_MIN_POINTS || cfg->refine_iters == 0)
            break;
        double med = tvo_la_select_kth(buf, m, m / 2);
        double c2 = RP_POLISH_K2 * med;
        if (c2 > thr2)
            c2 = thr2;
        if (!(c2 > 1e-24))
            c2 = 1e-24;
        if (round >= 2 && !(c2 < 1e-2 * c2_prev))
            break;
        if (round == 1 && changed == 0 && c2 > 0.9 * c2_prev && c2 < 1.1 * c2_prev)
            break;
        c2_prev = c2;
        refine_pose(R, t, x1, x2, n, mask, cfg->refine_iters, c2);
    }
    essential_from_pose(R, t, E);
    return mark_inliers(E, x1, x2, n, thr2, mask);
}

/* ---- the estimator's stages ------------------------------------------------------------------- */

/* The working state of one tvo_relpose_estimate call: the input, the squared threshold and the
 * scratch arrays (n doubles, four masks of n bytes) */
typedef struct rp_work {
    const tvo_relpose_config *cfg;
    const tvo_point2d *x1, *x2;
    int32_t n;
    double thr2;
    double *buf;
    uint8_t *mask_e; /* inliers of the chosen pose */
    uint8_t *mask_r; /* inliers of the rotation-only model */
    uint8_t *mask_h; /* inliers of the homography, then of the plane's twin */
    uint8_t *mask_c; /* candidate pose's inliers (and the epipolar RANSAC's scratch) */
} rp_work;

/* The pose chosen so far and what the homography stage found */
typedef struct rp_choice {
    double R[9], t[3];
    int32_t inl;                 /* inliers (mask_e) */
    int32_t good;                /* inliers in front of both cameras */
    int use_h;                   /* the homography's decomposition was chosen */
    int ambiguous;               /* the plane's twins explain the data about equally well */
    double Rtw[2][9], ttw[2][3]; /* the twins, polished, when ambiguous */
} rp_choice;

/* Stage 0: the input checks of relpose.h in their order, then the scratch arrays */
static tvo_status prepare(const tvo_relpose_config *cfg, const tvo_point2d *x1, const tvo_point2d *x2,
                          int32_t n, void *scratch, size_t scratch_size, rp_work *w)
{
    tvo_status st = check_config(cfg);
    if (st != TVO_OK)
        return st;
    if (n < (cfg->method == TVO_RELPOSE_8PT ? 8 : 5))
        return TVO_ERR_TOO_FEW;
    if (scratch_size < tvo_relpose_scratch_size(n))
        return TVO_ERR_NO_MEMORY;
    for (int32_t i = 0; i < n; ++i) {
        if (!isfinite(x1[i].x) || !isfinite(x1[i].y) || !isfinite(x2[i].x) || !isfinite(x2[i].y))
            return TVO_ERR_NOT_FINITE;
        if (fabs(x1[i].x) > RP_MAX_COORD || fabs(x1[i].y) > RP_MAX_COORD || fabs(x2[i].x) > RP_MAX_COORD ||
            fabs(x2[i].y) > RP_MAX_COORD)
            return TVO_ERR_RANGE;
    }
    if (collinear(x1, n) || collinear(x2, n))
        return TVO_ERR_DEGENERATE;
    tvo_arena arena;
    tvo_arena_init(&arena, scratch, scratch_size);
    w->buf = (double *)tvo_arena_alloc(&arena, (size_t)n * sizeof(double));
    w->mask_e = (uint8_t *)tvo_arena_alloc(&arena, (size_t)n);
    w->mask_r = (uint8_t *)tvo_arena_alloc(&arena, (size_t)n);
    w->mask_h = (uint8_t *)tvo_arena_alloc(&arena, (size_t)n);
    w->mask_c = (uint8_t *)tvo_arena_alloc(&arena, (size_t)n);
    if (w->buf == NULL || w->mask_e == NULL || w->mask_r == NULL || w->mask_h == NULL || w->mask_c == NULL)
        return TVO_ERR_NO_MEMORY;
    w->cfg = cfg;
    w->x1 = x1;
    w->x2 = x2;
    w->n = n;
    w->thr2 = cfg->threshold * cfg->threshold;
    return TVO_OK;
}

/* Stage 2: the rotation-only model (seeded by the e_inl epipolar inliers of E when there are enough,
 * else its own 2-point RANSAC) in Rrot with its inliers in mask_r; the rotation-compensated parallax
 * (median angle between Rrot f1 and f2 over the epipolar inliers, degrees) and R_rot go to out.
 * Returns the rotation model's inlier count. */
static int32_t rotation_stage(const rp_work *w, const double E[9], int32_t e_inl, double Rrot[9],
                              tvo_relpose *out)
{
    const int seeded = e_inl >= RP_MIN_SAMPLE;
    const double wide2 = RP_WIDE2 * w->thr2;
    int32_t r_inl = seeded ? rotation_from_inliers(E, w->x1, w->x2, w->n, wide2, w->mask_e, Rrot, w->mask_r)
                           : rotation_ransac(w->cfg, w->x1, w->x2, w->n, wide2, Rrot, w->mask_r);
    const uint8_t *pmask = seeded ? w->mask_e : w->mask_r;
    int32_t m = 0;
    for (int32_t i = 0; i < w->n; ++i) {
        if (!pmask[i])
            continue;
        double f1[3], f2[3], u[3], c[3];
        bearing(&w->x1[i], f1);
        bearing(&w->x2[i], f2);
        tvo_la_mat3_vec(Rrot, f1, u);
        tvo_la_cross(u, f2, c);
        w->buf[m++] = tvo_dm_atan2(sqrt(dot3(c, c)), dot3(u, f2));
    }
    out->parallax_deg = m > 0 ? tvo_la_select_kth(w->buf, m, m / 2) * RP_DEG_PER_RAD : 0.0;
    if (pose_finite(Rrot, out->t))
        memcpy(out->R_rot, Rrot, 9 * sizeof(double));
    return r_inl;
}

/* Rotation-only when the rotation-compensated parallax is low AND the rotation model explains most
 * of the epipolar inliers (at twice the threshold), or when the epipolar model failed. The median
 * parallax alone is not enough: a rotation absorbs the mean flow of a translation (sideways motion
 * looks like a turn for distant points), and the median of what remains can fall below the bound
 * while most points still contradict the rotation model (a narrow stereo baseline at a few metres:
 * test_sideways_baseline). Under pure rotation or a tiny baseline the rotation inliers (2 px chord)
 * contain about all epipolar inliers (1 px Sampson), so RP_ROT_SHARE leaves those rotation-only. */
static int rotation_only(const tvo_relpose_config *cfg, double parallax, int32_t r_inl, int32_t e_inl)
{
    int rot_explains = (double)r_inl >= RP_ROT_SHARE * (double)e_inl;
    return (parallax < cfg->min_parallax_deg && rot_explains) || e_inl < RP_MIN_SAMPLE;
}

/* Stage 2's result: t = 0, R from the rotation model, its inliers in the mask */
static void rotation_result(const rp_work *w, const double Rrot[9], int32_t r_inl, int32_t e_inl,
                            tvo_relpose *out, uint8_t *inlier_mask)
{
    if (!pose_finite(Rrot, out->t))
        return; /* identity + LOW_CONFIDENCE already set */
    const double parallax = out->parallax_deg, min_par = w->cfg->min_parallax_deg;
    memcpy(out->R, Rrot, 9 * sizeof(double));
    memcpy(out->R_alt, Rrot, 9 * sizeof(double));
    out->t[0] = out->t[1] = out->t[2] = 0.0;
    out->inliers = r_inl;
    out->flags = TVO_RELPOSE_FLAG_ROTATION_ONLY;
    if (parallax < min_par)
        out->flags |= TVO_RELPOSE_FLAG_LOW_PARALLAX;
    if (r_inl < w->cfg->min_inliers || r_inl < RP_MIN_ROT_INLIERS ||
        (e_inl < RP_MIN_SAMPLE && parallax >= min_par))
        out->flags |= TVO_RELPOSE_FLAG_LOW_CONFIDENCE;
    if (inlier_mask != NULL)
        memcpy(inlier_mask, w->mask_r, (size_t)w->n);
}

/* Stage 3: the pose of E chosen by cheirality over its inliers, polished */
static void epipolar_pose(const rp_work *w, const double E[9], rp_choice *c)
{
    memset(c, 0, sizeof *c);
    decompose_essential(E, w->x1, w->x2, w->n, w->mask_e, c->R, c->t);
    c->inl = polish(w->cfg, c->R, c->t, w->x1, w->x2, w->n, w->thr2, w->mask_e, w->buf);
    c->good = good_count(c->R, c->t, w->x1, w->x2, w->n, w->thr2, w->mask_e);
}

/* A 4-point sample with each index moved to an epipolar inlier (bounded tries, no duplicates) */
static void sample_from_inliers(tvo_rng *rng, int32_t n, const uint8_t *mask, int32_t idx[4])
{
    tvo_rng_sample(rng, n, 4, idx);
    for (int k = 0; k < 4; ++k)
        for (int tries = 0; tries < RP_H_SAMPLE_TRIES && !mask[idx[k]]; ++tries) {
            int32_t v = tvo_rng_index(rng, n);
            int dup = 0;
            for (int j = 0; j < 4; ++j)
                dup |= j != k && idx[j] == v;
            if (!dup)
                idx[k] = v;
        }
}

/* Stage 4a: homography RANSAC. A plane matters only when it holds a large share (RP_H_SHARE) of the
 * inl epipolar inliers: then either it is the dominant structure, or the epipolar RANSAC itself may
 * have picked the plane's twin (whose inliers are the plane's points). Its points are epipolar
 * inliers too, so the samples are drawn from them; the iteration bound is what a 4-point sample needs
 * at the epipolar inlier ratio (at least RP_H_MIN_ITERS: with every point an epipolar inlier the
 * bound is 1, and one degenerate sample would miss the plane), the adaptive count uses the plane's
 * share of the epipolar inliers, and hypotheses are dropped by the bail-out test as soon as they fall
 * clearly below that share. Returns the best score (<= 0: no plane), the model in Hb. */
static double homography_ransac(const rp_work *w, int32_t inl, double Hb[9])
{
    const tvo_relpose_config *cfg = w->cfg;
    const int32_t n = w->n, stride = visit_stride(n);
    memset(Hb, 0, 9 * sizeof(double)); /* written with the first model that scores above -1 */
    tvo_rng rng;
    tvo_rng_seed(&rng, cfg->seed ^ RP_H_SEED_SALT);
    double inv_s2 = 1.0 / w->thr2, best = -1.0;
    int32_t cap = tvo_ransac_needed(cfg->confidence, inl, n, 4, cfg->max_iters);
    if (cap < RP_H_MIN_ITERS)
        cap = RP_H_MIN_ITERS < cfg->max_iters ? RP_H_MIN_ITERS : cfg->max_iters;
    int32_t need = cap, h_inl = 0;
    const double eps_min = RP_H_SHARE * (double)inl / (double)n;
    for (int32_t it = 0; it < need && it < cap; ++it) {
        int32_t idx[4], c = 0;
        double H[9], Hi[9];
        sample_from_inliers(&rng, n, w->mask_e, idx);
        if (!homography_4pt(w->x1, w->x2, idx, H))
            continue;
        adjugate3(H, Hi);
        double eps = (double)h_inl / (double)n;
        double sc = homography_score(H, Hi, w->x1, w->x2, n, inv_s2, best, NULL, &c, stride,
                                     eps > eps_min ? eps : eps_min);
        if (sc > best) {
            best = sc;
            h_inl = c;
            memcpy(Hb, H, sizeof H);
            need = tvo_ransac_needed(cfg->confidence, h_inl, inl > 0 ? inl : n, 4, cap);
        }
    }
    return best;
}

/* Stage 4b: the inliers of Hb (mask_h, *h_inl), and a DLT refit on them that replaces Hb when it
 * scores at least as well. Returns Hb's score. */
static double homography_refit(const rp_work *w, double Hb[9], double best, int32_t *h_inl)
{
    const double inv_s2 = 1.0 / w->thr2;
    double Hi[9], Hr[9];
    adjugate3(Hb, Hi);
    homography_score(Hb, Hi, w->x1, w->x2, w->n, inv_s2, -1.0, w->mask_h, h_inl, 1, 0.0);
    if (!homography_dlt(w->x1, w->x2, w->n, w->mask_h, Hr))
        return best;
    double Hri[9];
    int32_t c2 = 0;
    adjugate3(Hr, Hri);
    double s2 = homography_score(Hr, Hri, w->x1, w->x2, w->n, inv_s2, -1.0, NULL, &c2, 1, 0.0);
    if (s2 >= best) {
        best = s2;
        memcpy(Hb, Hr, sizeof Hr);
        homography_score(Hb, Hri, w->x1, w->x2, w->n, inv_s2, -1.0, w->mask_h, h_inl, 1, 0.0);
    }
    return best;
}

/* Stage 4c: Hb's decompositions (up to 16) with the count of the plane's inliers in front of both
 * cameras (gk, at twice the threshold); *kb the best, *kb2 the best clearly different one (the
 * plane's "twin" solution), -1 when none. Returns the number of decompositions. */
static int plane_candidates(const rp_work *w, const double Hb[9], double Rs[16][9], double ts[16][3],
                            int32_t gk[16], int *kb, int *kb2)
{
    const double wide2 = RP_WIDE2 * w->thr2;
    int nc = decompose_homography(Hb, Rs, ts);
    for (int k = 0; k < 16; ++k)
        gk[k] = -1;
    *kb = *kb2 = -1;
    for (int k = 0; k < nc; ++k) {
        /* decompose_homography emits each (R, t) followed by (R, -t): one pass for both */
        if (k % 2 == 0 && k + 1 < nc && same_rotation(Rs[k], Rs[k + 1]) && ts[k + 1][0] == -ts[k][0] &&
            ts[k + 1][1] == -ts[k][1] && ts[k + 1][2] == -ts[k][2])
            gk[k] = good_count2(Rs[k], ts[k], w->x1, w->x2, w->n, wide2, w->mask_h, &gk[k + 1]);
        else if (gk[k] < 0)
            gk[k] = good_count(Rs[k], ts[k], w->x1, w->x2, w->n, wide2, w->mask_h);
        if (*kb < 0 || gk[k] > gk[*kb])
            *kb = k;
    }
    for (int k = 0; *kb >= 0 && k < nc; ++k)
        if (poses_differ(Rs[k], ts[k], Rs[*kb], ts[*kb]) && (*kb2 < 0 || gk[k] > gk[*kb2]))
            *kb2 = k;
    return nc;
}

/* A candidate pose (R, t) of the plane with its inlier count, cheirality-consistent count and
 * inliers (in mask) */
typedef struct rp_cand {
    double R[9], t[3];
    int32_t inl, good;
} rp_cand;

static void polish_candidate(const rp_work *w, const double R[9], const double t[3], uint8_t *mask,
                             rp_cand *c)
{
    memcpy(c->R, R, sizeof c->R);
    memcpy(c->t, t, sizeof c->t);
    c->inl = polish(w->cfg, c->R, c->t, w->x1, w->x2, w->n, w->thr2, mask, w->buf);
    c->good = good_count(c->R, c->t, w->x1, w->x2, w->n, w->thr2, mask);
}

/* Stage 4d: the best decomposition kb (inliers in mask_c) and its twin kb2 (mask_h) polished. When
 * both explain the data about equally well (RP_TWIN_SHARE of each other's and of the epipolar pose's
 * good count) the choice is ambiguous and the twins go to ch. Returns in h the better of the two,
 * its inliers in mask_c. */
static void plane_pose(const rp_work *w, rp_choice *ch, double Rs[16][9], double ts[16][3],
                       const int32_t gk[16], int kb, int kb2, rp_cand *h)
{
    polish_candidate(w, Rs[kb], ts[kb], w->mask_c, h);
    if (kb2 < 0 || gk[kb2] < RP_MIN_GOOD)
        return;
    rp_cand tw;
    polish_candidate(w, Rs[kb2], ts[kb2], w->mask_h, &tw);
    if (poses_differ(tw.R, tw.t, h->R, h->t) && (double)tw.good >= RP_TWIN_SHARE * h->good &&
        (double)h->good >= RP_TWIN_SHARE * tw.good && (double)tw.good >= RP_TWIN_SHARE * ch->good) {
        ch->ambiguous = 1;
        memcpy(ch->Rtw[0], h->R, sizeof h->R);
        memcpy(ch->ttw[0], h->t, sizeof h->t);
        memcpy(ch->Rtw[1], tw.R, sizeof tw.R);
        memcpy(ch->ttw[1], tw.t, sizeof tw.t);
    }
    if (tw.good > h->good && pose_finite(tw.R, tw.t)) {
        *h = tw;
        memcpy(w->mask_c, w->mask_h, (size_t)w->n);
    }
}

/* Stage 4: homography model selection (dominant plane). The homography's decompositions are always
 * tried when the plane holds RP_H_SHARE of the epipolar inliers (a plane's twin solution can win the
 * epipolar RANSAC); they replace the epipolar pose when they put more points in front of both
 * cameras, or as many when the homography explains the data (score ratio above RP_H_RATIO). */
static void homography_stage(const rp_work *w, rp_choice *ch)
{
    double Hb[9], Ecur[9];
    double best = homography_ransac(w, ch->inl, Hb);
    if (!(best > 0.0))
        return;
    essential_from_pose(ch->R, ch->t, Ecur);
    double se = essential_score(Ecur, w->x1, w->x2, w->n, 1.0 / w->thr2);
    int32_t h_inl = 0;
    best = homography_refit(w, Hb, best, &h_inl);
    int h_wins = best / (best + se) > RP_H_RATIO;
    if (!(h_inl >= RP_H_MIN_INLIERS && (double)h_inl >= RP_H_SHARE * (double)ch->inl))
        return;
    double Rs[16][9], ts[16][3];
    int32_t gk[16];
    int kb, kb2;
    plane_candidates(w, Hb, Rs, ts, gk, &kb, &kb2);
    if (kb < 0 || gk[kb] < RP_MIN_GOOD)
        return;
    rp_cand h;
    plane_pose(w, ch, Rs, ts, gk, kb, kb2, &h);
    if ((h.good > ch->good || (h_wins && h.good >= ch->good)) && pose_finite(h.R, h.t)) {
        memcpy(ch->R, h.R, sizeof h.R);
        memcpy(ch->t, h.t, sizeof h.t);
        memcpy(w->mask_e, w->mask_c, (size_t)w->n);
        ch->inl = h.inl;
        ch->good = h.good;
        ch->use_h = 1;
    }
}

/* Stage 5: the chosen pose (unit t), its flags, the twin when ambiguous, the inlier mask */
static void pose_result(const rp_work *w, const rp_choice *ch, tvo_relpose *out, uint8_t *inlier_mask)
{
    if (!pose_finite(ch->R, ch->t))
        return; /* identity + LOW_CONFIDENCE */
    double nt = sqrt(dot3(ch->t, ch->t));
    if (!(nt > 0.0))
        return;
    memcpy(out->R, ch->R, sizeof out->R);
    for (int j = 0; j < 3; ++j)
        out->t[j] = ch->t[j] / nt;
    out->inliers = ch->inl;
    out->flags = ch->use_h ? TVO_RELPOSE_FLAG_HOMOGRAPHY : 0;
    memcpy(out->R_alt, out->R, sizeof out->R);
    memcpy(out->t_alt, out->t, sizeof out->t);
    if (ch->inl < w->cfg->min_inliers || ch->inl < RP_MIN_SAMPLE || ch->good < ch->inl / 2) {
        out->flags |= TVO_RELPOSE_FLAG_LOW_CONFIDENCE;
    } else if (ch->ambiguous) {
        /* the twin that is not the chosen pose (the chosen one may be the epipolar pose) */
        int k = poses_differ(ch->Rtw[0], ch->ttw[0], ch->R, ch->t) ? 0 : 1;
        double na = sqrt(dot3(ch->ttw[k], ch->ttw[k]));
        out->flags |= TVO_RELPOSE_FLAG_LOW_CONFIDENCE;
        if (na > 0.0 && pose_finite(ch->Rtw[k], ch->ttw[k]) &&
            poses_differ(ch->Rtw[k], ch->ttw[k], ch->R, ch->t)) {
            out->flags |= TVO_RELPOSE_FLAG_AMBIGUOUS;
            memcpy(out->R_alt, ch->Rtw[k], sizeof out->R_alt);
            for (int j = 0; j < 3; ++j)
                out->t_alt[j] = ch->ttw[k][j] / na;
        }
    }
    if (inlier_mask != NULL)
        memcpy(inlier_mask, w->mask_e, (size_t)w->n);
}

tvo_status tvo_relpose_estimate(const tvo_relpose_config *cfg_in, const tvo_point2d *x1,
                                const tvo_point2d *x2, int32_t n, tvo_relpose *out, uint8_t *inlier_mask,
                                void *scratch, size_t scratch_size)
{
    if (out == NULL)
        return TVO_ERR_NULL;
    set_identity_result(out);
    if (inlier_mask != NULL && n > 0)
        memset(inlier_mask, 0, (size_t)n);
    if (x1 == NULL || x2 == NULL || scratch == NULL)
        return TVO_ERR_NULL;
    tvo_relpose_config cfg;
    if (cfg_in != NULL)
        cfg = *cfg_in;
    else
        tvo_relpose_config_default(&cfg);
    rp_work w;
    tvo_status st = prepare(&cfg, x1, x2, n, scratch, scratch_size, &w);
    if (st != TVO_OK)
        return st;

    /* 1. epipolar RANSAC */
    double E[9];
    int32_t iters = 0;
    int32_t e_inl = essential_ransac(&cfg, x1, x2, n, w.thr2, E, &iters, w.mask_c);
    out->iterations = iters;
    if (e_inl > 0)
        mark_inliers(E, x1, x2, n, w.thr2, w.mask_e);
    else
        memset(w.mask_e, 0, (size_t)n);

    /* 2. rotation-only model, rotation-compensated parallax, rotation-only result */
    double Rrot[9];
    int32_t r_inl = rotation_stage(&w, E, e_inl, Rrot, out);
    if (rotation_only(&cfg, out->parallax_deg, r_inl, e_inl)) {
        rotation_result(&w, Rrot, r_inl, e_inl, out, inlier_mask);
        return TVO_OK;
    }

    /* 3. pose from the epipolar model, refined; 4. a dominant plane's pose competes with it */
    rp_choice ch;
    epipolar_pose(&w, E, &ch);
    if (cfg.use_homography)
        homography_stage(&w, &ch);

    /* 5. the result */
    pose_result(&w, &ch, out, inlier_mask);
    return TVO_OK;
}

/* The truncated Sampson cost of one correspondence under E: min(s^2, thr2) / thr2, 1 when s^2 is not a
 * number below thr2 (sampson2's 1e300 for an unmeasurable distance, a NaN from a non-finite point). */
static double twin_term(const double E[9], const tvo_point2d *p1, const tvo_point2d *p2, double thr2)
{
    const double s2 = sampson2(E, p1, p2);
    return s2 < thr2 ? s2 / thr2 : 1.0;
}

int tvo_relpose_twin_choice(const tvo_relpose *r, const tvo_point2d *x1, const tvo_point2d *x2, int32_t n,
                            double threshold)
{
    double E0[9], E1[9], thr2, sum = 0.0, sum2 = 0.0;
    if (r == NULL || x1 == NULL || x2 == NULL || n < 1 || !(threshold > 0.0) || !isfinite(threshold) ||
        !(r->flags & TVO_RELPOSE_FLAG_AMBIGUOUS))
        return -1;
    essential_from_pose(r->R, r->t, E0);
    essential_from_pose(r->R_alt, r->t_alt, E1);
    thr2 = threshold * threshold;
    for (int32_t i = 0; i < n; ++i) {
        const double d = twin_term(E0, &x1[i], &x2[i], thr2) - twin_term(E1, &x1[i], &x2[i], thr2);
        sum += d;
        sum2 += d * d;
    }
    /* sum < 0: (R, t) has the lower cost */
    if (!(fabs(sum) >= 1.0 && sum * sum >= 9.0 * sum2))
        return -1;
    return sum < 0.0 ? 0 : 1;
}
