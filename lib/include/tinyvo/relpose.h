/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: two-view relative pose from normalised correspondences.
 *
 * Conventions
 *   - Inputs are undistorted NORMALISED image coordinates (x/z, y/z of the ray, focal length 1):
 *     pixel u = fx * x + cx. Convert pixel thresholds with the focal length (1 px ~ 1/fx).
 *   - The pose maps frame-1 points to frame 2: X2 = R * X1 + t (OpenCV recoverPose convention),
 *     so the essential matrix is E = [t]_x R and x2^T E x1 = 0. R is row-major, t has unit norm
 *     (the scale is unobservable) or is all zero for a rotation-only result.
 *   - Everything is double precision and deterministic for a given seed (no global state).
 *
 * What tvo_relpose_estimate does (docs/design.md, "Relative pose", gives the reasons)
 *   1. checks the input (NULLs, n, NaN/Inf, |x| > 1e6, fewer than 5 distinct points, all points
 *      collinear in either image -> error status);
 *   2. RANSAC (MSAC scoring of the Sampson error with an exact and a statistical bail-out,
 *      adaptive iteration count, seeded xorshift generator, local optimisation of every new best
 *      model) around the 5-point (Nister-style, up to 10 solutions) or the normalised 8-point
 *      solver;
 *   3. a rotation-only model (Kabsch on bearing vectors, seeded by the epipolar inliers; a 2-point
 *      RANSAC when the epipolar model failed): the median angle between R_rot * f1 and f2 over the
 *      epipolar inliers is the rotation-compensated parallax; below cfg->min_parallax_deg, when
 *      the rotation also explains at least 80 % of the epipolar inliers, the result is
 *      rotation-only (t = 0, R from the rotation model) with LOW_PARALLAX | ROTATION_ONLY: no
 *      translation is made up and no twisted pair can come out;
 *   4. otherwise a homography RANSAC (4-point DLT, samples from the epipolar inliers) is scored
 *      against the epipolar model (ORB-SLAM style scores); when the plane holds at least half of
 *      the epipolar inliers its decompositions, chosen by cheirality, compete with the epipolar
 *      pose and HOMOGRAPHY is set when one wins;
 *   5. the pose is refined by Levenberg-Marquardt on the Sampson error over the (R, unit t)
 *      manifold (5 parameters), the inliers are re-selected and the pose refined again;
 *   6. R, t are chosen among the four decompositions of E by cheirality (triangulated depth > 0
 *      in both views).
 * Fewer than cfg->min_inliers inliers (or too few points in front of both cameras) sets
 * LOW_CONFIDENCE. A result is never NaN: on any numerical failure R = I, t = 0 and LOW_CONFIDENCE.
 */
#ifndef TINYVO_RELPOSE_H
#define TINYVO_RELPOSE_H

#include "tinyvo/types.h"
#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum tvo_relpose_method {
    TVO_RELPOSE_5PT = 0, /* minimal 5-point essential matrix solver in RANSAC (default) */
    TVO_RELPOSE_8PT = 1  /* normalised 8-point (fundamental matrix on normalised coordinates,
                            projected onto the essential manifold) in RANSAC */
} tvo_relpose_method;

typedef struct tvo_relpose_config {
    tvo_relpose_method method; /* default TVO_RELPOSE_5PT */
    double threshold;          /* inlier threshold on the Sampson error, in NORMALISED image units
                                   (pixels / focal length), > 0; default 1.0 / 460 */
    double confidence;         /* RANSAC confidence p in (0, 1); default 0.999 */
    int32_t max_iters;         /* hard bound on RANSAC iterations, >= 1; default 1000 */
    uint64_t seed;             /* seed of the deterministic generator; default 0x5eed */
    double min_parallax_deg;   /* median rotation-compensated parallax (degrees) below which the
                                   result is rotation-only; >= 0, 0 disables; default 0.5 */
    int32_t min_inliers;       /* fewer inliers -> LOW_CONFIDENCE; >= 0; default 15 */
    int32_t use_homography;    /* 1: score a homography for dominant planes (default); 0: never */
    int32_t refine_iters;      /* Levenberg-Marquardt iterations per refinement round, 0..100;
                                   default 10 (0 disables the refinement) */
} tvo_relpose_config;

/* Fill cfg with the defaults above. NULL is ignored. */
TVO_API void tvo_relpose_config_default(tvo_relpose_config *cfg);

enum {
    TVO_RELPOSE_FLAG_LOW_PARALLAX = 1,   /* parallax below cfg->min_parallax_deg */
    TVO_RELPOSE_FLAG_ROTATION_ONLY = 2,  /* t is zero; R from the rotation-only model */
    TVO_RELPOSE_FLAG_HOMOGRAPHY = 4,     /* a homography (dominant plane) chose the pose */
    TVO_RELPOSE_FLAG_LOW_CONFIDENCE = 8, /* too few inliers / cheirality-consistent points, or AMBIGUOUS */
    TVO_RELPOSE_FLAG_AMBIGUOUS = 16      /* two clearly different poses (a plane's twin solutions) explain
                                            the data about equally well and nothing else is wrong: R, t has
                                            the more cheirality-consistent points, R_alt, t_alt is the twin.
                                            LOW_CONFIDENCE is set too: choose with the points off the plane
                                            (tvo_relpose_twin_choice), with outside knowledge (e.g. the
                                            previous motion, as tvo_vo does next) or use neither */
};

typedef struct tvo_relpose {
    double R[9];         /* row-major rotation, X2 = R * X1 + t (frame 1 -> frame 2) */
    double t[3];         /* unit translation direction; all zero when ROTATION_ONLY */
    int32_t inliers;     /* inlier count of the chosen model */
    int32_t flags;       /* TVO_RELPOSE_FLAG_* */
    double parallax_deg; /* median rotation-compensated parallax angle of the inliers (degrees),
                           compensated with the best rotation-only model */
    int32_t iterations;  /* RANSAC iterations run (epipolar model) */
    double R_alt[9]; /* with TVO_RELPOSE_FLAG_AMBIGUOUS: the twin pose (unit t_alt); else a copy of R, t */
    double t_alt[3];
    double R_rot[9]; /* the rotation-only model fitted on the same points (identity when none): a
                           sanity reference for R at low parallax, whatever model was chosen */
} tvo_relpose;

/* Minimal 5-point solver (Nister's formulation: null space of the 5x9 epipolar system,
 * LU elimination of the 10x20 cubic constraints, degree-10 hidden-variable polynomial solved by
 * Sturm sequences). x1, x2: normalised coordinates of 5 correspondences (x2^T E x1 = 0).
 * Writes up to 10 essential matrices (row-major, Frobenius norm 1) to E and returns how many;
 * 0 for a degenerate sample or NULL pointers. Cost: about 19k instructions (x86-64 with SSE2), no
 * memory beyond the arguments. */
TVO_API int tvo_essential_5pt(const double x1[5][2], const double x2[5][2], double E[10][9]);

/* Normalised 8-point: E from >= 8 correspondences (Hartley-normalised; exactly 8: null vector of
 * the 8x9 system by Gaussian elimination with complete pivoting, refused below rank 8; more:
 * least squares, smallest eigenvector of the 9x9 normal matrix), then projected onto the essential
 * manifold with singular values (1, 1, 0). x1, x2: n normalised points as x[i][0], x[i][1]. Returns
 * 1 on success, 0 for n < 8, NULL pointers or degenerate input. Cost: n = 8, one elimination of the
 * 8x9 system; n > 8, O(n) to build the 9x9 normal matrix plus its Jacobi eigen-decomposition, about
 * 15 times the cost of n = 8. */
TVO_API int tvo_essential_8pt(const double (*x1)[2], const double (*x2)[2], int32_t n, double E[9]);

/* Bytes of scratch memory tvo_relpose_estimate needs for up to max_points correspondences
 * (saturates at SIZE_MAX; 12 bytes per point plus 80). */
TVO_API size_t tvo_relpose_scratch_size(int32_t max_points);

/* Estimate the relative pose of frame 2 with respect to frame 1.
 * x1[i], x2[i]: undistorted NORMALISED coordinates (z = 1) of the same point in frames 1 and 2.
 * n >= 5 (>= 8 for TVO_RELPOSE_8PT). inlier_mask (may be NULL) gets n entries, 1 for inliers.
 * scratch: at least tvo_relpose_scratch_size(n) bytes, any alignment, owned by the caller.
 * cfg NULL -> the defaults.
 * Returns TVO_OK (check out->flags), or TVO_ERR_NULL, TVO_ERR_ARG (bad config), TVO_ERR_TOO_FEW,
 * TVO_ERR_NO_MEMORY (scratch too small), TVO_ERR_NOT_FINITE (a NaN/Inf coordinate),
 * TVO_ERR_RANGE (|coordinate| > 1e6), TVO_ERR_DEGENERATE (fewer than 5 distinct points or all
 * points collinear in one image); on error *out is R = I, t = 0, LOW_CONFIDENCE and the mask is 0.
 * Cost: about 2.75M instructions (x86-64 with SSE2) for 300 points with 30 % outliers and the default
 * configuration (docs/evaluation.md); at most cfg->max_iters RANSAC iterations, each linear in n. */
TVO_API tvo_status tvo_relpose_estimate(const tvo_relpose_config *cfg, const tvo_point2d *x1,
                                        const tvo_point2d *x2, int32_t n, tvo_relpose *out,
                                        uint8_t *inlier_mask, void *scratch, size_t scratch_size);

/* Which of an AMBIGUOUS result's twins the correspondences favour. The twins explain the plane's
 * points equally well, but points off the plane fit only the true twin's epipolar geometry: each
 * correspondence i (the same x1, x2, n as the estimate's) gets d_i, the difference of its truncated
 * Sampson costs min(s^2, threshold^2) / threshold^2 under (R, t) and under (R_alt, t_alt) (1 for a
 * distance that cannot be measured, e.g. a non-finite point). With D = sum d_i, a twin is chosen only
 * when the evidence is clear: |D| >= 1 (a whole point's worth) and D^2 >= 9 sum d_i^2 (D at least 3
 * times the spread the sum would have if the d_i were noise of either sign: on one plane and nothing
 * else the costs differ by noise alone). threshold: the inlier distance in normalised units (the
 * estimate's cfg->threshold).
 * Returns 0 when (R, t) fits better, 1 when (R_alt, t_alt) does, -1 when neither clearly does or for
 * NULL pointers, n < 1, a threshold that is not finite and > 0, or a result without the AMBIGUOUS flag.
 * Cost: two Sampson distances per correspondence, about 140 instructions (33 K per call on the V1_01
 * render, callgrind). Over two runs of each of the 8 EuRoC renders and KITTI 07 it chose in 3,147 of
 * 3,366 ambiguous frames, each time the twin nearer the ground truth (docs/design.md, "Plane twins"). */
TVO_API int tvo_relpose_twin_choice(const tvo_relpose *r, const tvo_point2d *x1, const tvo_point2d *x2,
                                    int32_t n, double threshold);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_RELPOSE_H */
