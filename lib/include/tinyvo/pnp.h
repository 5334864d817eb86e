/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: camera pose from 3D landmarks and their image points (PnP).
 *
 * Conventions
 *   - X[i]: landmark i in metres in any world frame "w"; x[i]: its undistorted NORMALISED image point
 *     (x = X_c / Z_c, y = Y_c / Z_c, focal length 1): pixel u = fx * x + cx. Pixel thresholds are
 *     converted with the focal length (1 px ~ 1 / fx).
 *   - The pose T_c_w maps world points into the camera: X_c = R X_w + t (tvo_pose, se3.h).
 *   - A point is "in front" when Z_c > 1e-6 (metres). Its reprojection error is the Euclidean norm
 *     of (X_c / Z_c, Y_c / Z_c) - x, in normalised units.
 *   - A point whose X or x has a non-finite entry, |x| > 1e6 or |X| > 1e9 is skipped (never used,
 *     never an inlier); that alone is not an error.
 *   - Everything is double precision, uses only + - * / and sqrt and the library's deterministic
 *     elementary functions (tvo_dm_*), allocates nothing and is deterministic for a given seed (no
 *     global state), so the same call gives the same bits on every IEEE-754 target. Stack below 4 KB
 *     per call (measured by test/unit/test_pnp.c).
 *
 * tvo_p3p: the minimal solver (lambda twist, Persson & Nordberg, ECCV 2018, written from the
 * paper's derivation). With unit bearings y_i, depths l_i and a_ij = |X_i - X_j|^2, b_ij = -2
 * y_i.y_j, the three distance equations l_i^2 + l_j^2 + b_ij l_i l_j = a_ij are quadrics l^T M_ij l
 * = a_ij. The two homogeneous combinations D1 = a23 M12 - a12 M23 and D2 = a23 M13 - a13 M23 vanish
 * on the solution; a real root g of the cubic det(D1 + g D2) = 0 (Newton with bisection, then the
 * deflated quadratic; the best-conditioned root whose pencil is indefinite) gives a rank-2 D0 = D1
 * + g D2 = s1 e1 e1^T + s2 e2 e2^T (closed form, Jacobi when that is ill-conditioned) with s1 s2 <
 * 0, which factors into the two planes (e1 -+ sqrt(-s2 / s1) e2) . l = 0. In each plane a
 * homogeneous 2x2 quadric gives up to two depth directions, the sum of the three distance equations
 * their scale; positive depths are polished by Gauss-Newton on the three equations (at most 5
 * steps) and kept when every equation holds to 1e-6 relative. The pose follows from the orthonormal
 * frames of the world triangle and of the camera triangle l_i y_i (exactly a rotation). At most 4
 * poses.
 *
 * tvo_pnp_ransac: RANSAC (MSAC cost: sum of min(e^2, threshold^2), a point behind the camera costs
 * threshold^2; exact bail-out when a hypothesis' partial cost exceeds the best) over P3P on random
 * 3-point samples of the usable points; a 4th sampled point must be an inlier of a P3P solution for
 * it to be scored (with use_guess, the given pose is scored first). The iteration count adapts to
 * the best inlier ratio w (log(1 - confidence) / log(1 - w^4)) and never exceeds max_iterations.
 * The best hypothesis is refined (tvo_pnp_refine's step, Huber kernel) on its inliers, the inliers
 * are re-selected on all usable points and it is refined once more while the inlier count grows (at
 * most 3 rounds); a refinement is kept only when its MSAC cost is not above the hypothesis'.
 *
 * tvo_pnp_refine: iteratively re-weighted Levenberg-Marquardt on the Huber-robust reprojection cost
 * sum rho(e_i), rho(e) = e^2 / 2 for e <= huber, huber * (e - huber / 2) above, over the selected
 * usable points; a point behind the camera is left out of the step and costs rho(1) (the cost of a
 * reprojection error of 1, ~450 px: a step gains nothing by pushing a reasonably placed point
 * behind the camera). The increment d = [omega, v] is applied on the left with the SE(3)
 * exponential: T <- exp(d) T (rotation part by tvo_rotvec_to_rot). The 6x6 normal equations (J^T W
 * J + mu diag(J^T W J)) d = -J^T W r are solved by Gaussian elimination; mu starts at 1e-4 and is
 * divided by 10 after an accepted step; a step that raises the robust cost is rejected (the pose
 * restored) and mu multiplied by 10. Each solve counts as one iteration (at most
 * refine_iterations); it stops early after a tiny step (|omega| < 1e-9 rad and |v| < 1e-9 (1 + |t|)
 * m, accepted or not), an accepted step that lowers the cost by less than 1e-10 of it, or when mu
 * exceeds 1e8. The output's robust cost is never above the input's.
 *
 * Cost: instruction counts (callgrind, x86-64 gcc -O3, test/bench/bench_pnp.c; scenes of 200 points,
 * f = 450, 0.5 px noise, default configuration): tvo_p3p ~2.6k; tvo_pnp_refine from 1 deg / 5 cm
 * off ~360k (about 250 per point and LM iteration, 5-6 iterations); tvo_pnp_ransac with 30 %
 * outliers ~710k, half of it the refinement of the best hypothesis.
 */
#ifndef TINYVO_PNP_H
#define TINYVO_PNP_H

#include "tinyvo/types.h"
#include "tinyvo/se3.h"
#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct tvo_pnp_config {
    double threshold;          /* inlier threshold on the reprojection error in NORMALISED image units
                                  (pixels / focal), finite and > 0; default 1.5 / 458 */
    double confidence;         /* RANSAC success probability, (0, 1); default 0.999 */
    int32_t max_iterations;    /* RANSAC hypothesis (sample) cap, >= 1; default 200 */
    int32_t refine_iterations; /* Levenberg-Marquardt iteration cap, >= 1; default 10 */
    double huber;              /* Huber kernel width in normalised units, finite and > 0; default =
                                  threshold */
    int32_t min_inliers;       /* fewer inliers -> TVO_ERR_TOO_FEW; >= 3; default 12 */
    uint64_t seed;             /* seed of the deterministic generator (splitmix64-seeded xorshift, the
                                  scheme of relpose); default 0x5eed */
    int32_t use_guess;         /* tvo_pnp_ransac: 1 = the pose passed in *T_c_w (when finite) is scored
                                  as the first hypothesis, before any sample (a motion-model prediction:
                                  with many inliers the adaptive count then stops after a few samples);
                                  0 = *T_c_w is output only; 0 or 1, default 0 */
    double rot_prior[9];       /* a rotation R_p (row-major) the refinement pulls the pose's rotation
                                  toward, e.g. the previous pose turned by a gyroscope's or a two-view
                                  estimate's rotation: the cost gains rot_prior_weight / 2 |log(R R_p^T)|^2
                                  (rotation vector, rad). Used when rot_prior_weight > 0 */
    double rot_prior_weight;   /* >= 0 and finite, in normalised image units^2 per rad^2: a weight w
                                  counts as much as one point's reprojection error with sigma_obs^2 =
                                  1 / w per rad^2 of rotation; default 0 (no prior) */
} tvo_pnp_config;

/* Fill cfg with the defaults above. NULL is ignored. */
TVO_API void tvo_pnp_config_default(tvo_pnp_config *cfg);

/* Bytes of scratch tvo_pnp_ransac needs for up to max_points points (6 bytes per point plus 16;
 * any alignment). 0 for max_points < 0 or > 2^28. */
TVO_API size_t tvo_pnp_scratch_size(int32_t max_points);

/* Minimal solver: 3 world points X (metres) and their normalised image points x -> up to 4 poses
 * T_c_w (every one places the three points in front of the camera and reprojects them exactly).
 * Returns the count, 0 when degenerate: NULL pointers, non-finite input, coincident or collinear
 * world points (|d12 x d13| < 1e-10 |d12| |d13|), coincident image rays, or no real solution. Entries
 * of T_c_w beyond the count are not written. Cost ~2.6k instructions. */
TVO_API int tvo_p3p(const double X[3][3], const double x[3][2], tvo_pose T_c_w[4]);

/* RANSAC over P3P, then refinement of the best hypothesis on its inliers (see above). cfg: NULL ->
 * the defaults. X[n], x[n]: correspondences (n >= 4 usable ones needed). *T_c_w: output only (the
 * pose is estimated from scratch), unless cfg->use_guess: then also a first hypothesis. inliers[n]
 * (may be NULL): 1 for inliers of the result (reprojection error < threshold and in front), else 0;
 * all 0 on error. *n_inliers: their count, 0 on error. scratch: at least tvo_pnp_scratch_size(n)
 * bytes, owned by the caller. Returns TVO_OK, TVO_ERR_NULL (X, x, T_c_w, n_inliers or scratch
 * NULL), TVO_ERR_ARG (a config value out of range or NaN, n < 0), TVO_ERR_TOO_FEW (n < 4, fewer
 * than 4 usable points, or fewer than min_inliers inliers for the best hypothesis, also when no
 * hypothesis passed the 4th-point test), TVO_ERR_NO_MEMORY (scratch too small), TVO_ERR_DEGENERATE
 * (every sample was degenerate: P3P gave no solution, e.g. all points collinear or coincident, and
 * no guess was scored). On error *T_c_w is left as given when it is finite, else set to the
 * identity. The output pose is never NaN. Cost: bounded by max_iterations samples (each a P3P and
 * at most 4 scorings of O(n)) and 3 refinements. */
TVO_API tvo_status tvo_pnp_ransac(const tvo_pnp_config *cfg, const double (*X)[3], const tvo_point2d *x,
                                  int32_t n, tvo_pose *T_c_w, uint8_t *inliers, int32_t *n_inliers,
                                  void *scratch, size_t scratch_size);

/* Refinement from an initial pose (*T_c_w in, refined out; see above).
 * cfg: NULL -> the defaults (threshold, huber, refine_iterations, min_inliers are used). use[n] (may be
 * NULL: all) selects the points (nonzero = use). inliers[n] (may be NULL): 1 for the selected usable
 * points with reprojection error < threshold at the output pose and in front, else 0. *n_inliers: their
 * count (required). rms (may be NULL): root mean square reprojection error of those inliers
 * (normalised units; 0 when there is none or on error).
 * Returns TVO_OK, TVO_ERR_NULL (X, x, T_c_w or n_inliers NULL), TVO_ERR_ARG (bad config, n < 0),
 * TVO_ERR_NOT_FINITE (a non-finite entry in *T_c_w), TVO_ERR_TOO_FEW (fewer than 3 selected usable
 * points, or fewer than min_inliers inliers at the output pose, e.g. all points behind the camera).
 * On error *T_c_w is left as given when finite (the identity when it was not), *n_inliers = 0 and the
 * inlier flags are 0. Cost: O(n) per iteration, at most refine_iterations iterations. */
TVO_API tvo_status tvo_pnp_refine(const tvo_pnp_config *cfg, const double (*X)[3], const tvo_point2d *x,
                                  const uint8_t *use, int32_t n, tvo_pose *T_c_w, uint8_t *inliers,
                                  int32_t *n_inliers, double *rms);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_PNP_H */
