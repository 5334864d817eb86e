/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: windowed bundle adjustment (poses + points of a local map).
 *
 * Minimises the Huber-robust reprojection error in normalised image coordinates over the free camera
 * poses and the free world points of a small window (a few keyframes, a few hundred landmarks) with
 * Levenberg-Marquardt and the Schur complement on the poses.
 *
 * Model. Observation k of point j in camera i: P = R_i X_j + t_i (T_c_w = (R_i, t_i)), predicted
 * (P_x / P_z, P_y / P_z), residual r_k = predicted - (x, y). The Huber function is applied to each of
 * the two components separately (as scipy.optimize.least_squares(loss='huber', f_scale=huber) does):
 *     cost = 1/2 sum_components rho(r^2),  rho(s) = s for sqrt(s) <= huber, 2 huber sqrt(s) - huber^2
 * above (normalised units^2). The normal equations use the IRLS weights w = min(1, huber / |r|), whose
 * gradient J^T W r is the exact gradient of the cost. Optional relative-rotation priors (tvo_ba_rot_prior,
 * e.g. a gyroscope's or chained two-view rotations) add 1/2 weight |log(R_b R_a^T R_ba^T)|^2 each; their
 * Jacobians under the left steps below are taken at first order (I for b, -R_b R_a^T for a), and with two
 * free poses they add a 3x3 block between the two in the reduced system.
 *
 * Parametrisation. A pose step d = [omega, v] (6) is applied on the left as
 *     R <- R_d R,  t <- R_d t + v,   R_d = tvo_rotvec_to_rot(omega)
 * (the first-order "left perturbation" of exp(d) T: its derivative at d = 0 is the one of the SE(3)
 * exponential, dP/d omega = -[P]x, dP/dv = I). A point step is X <- X + dx.
 *
 * Step. Damping is Marquardt's: every diagonal entry of the pose blocks and the 3x3 point blocks is
 * multiplied by (1 + lambda). The point blocks are inverted (3x3 Cholesky) and eliminated; the reduced
 * camera system (6 x free poses) is solved by a dense Cholesky. A step is accepted only when it lowers
 * the robust cost by more than 1e-12 of it (smaller changes are rounding, not progress) and every value
 * is finite and every used observation stays at Z_c >= min_depth; otherwise the state is restored
 * bit-for-bit and lambda is multiplied by 10 (divided by 10 after an accepted step, floor 1e-12).
 * Stops: max_iterations steps tried (accepted + rejected), an accepted step that lowered the cost by
 * less than 1e-6 of it (converged), a solved step whose decrease predicted by the damped model,
 * 1/2 d^T (lambda D d - g), is at most 1e-12 of the cost (a stationary point: the step is not tried and
 * not counted, so an optimal input returns with 0 iterations, untouched and without a flag), a cost at
 * or below 1e-24 per used observation (RMS residual 1e-12: converged before any step), or lambda
 * above 1e12. With gross outliers the IRLS iteration gains little per step after the first few (the
 * cost still falls by ~1e-5 of itself per step): ITER_CAP at the default 10 iterations is normal there,
 * and the next call (the next keyframe's window) goes on from the result.
 *
 * Held points. A free point is held fixed for a step (its observations still constrain the poses, as
 * a fixed point's do) when it has fewer than 2 usable observations (from free or fixed poses), or when
 * its undamped 3x3 block V is ill-conditioned: a Cholesky pivot below 1e-12 of its diagonal entry, or
 * the estimate trace(V) * ||V^-1||_F (between the 2-norm condition number and 3 sqrt(3) times it)
 * above cfg->max_point_cond (default 1e6: a point seen with a parallax of about 0.06 degree or less,
 * e.g. a landmark nearly at infinity). Decided again at every linearisation.
 * An observation is usable when x, y are finite and its point has Z_c >= min_depth in that camera at
 * the input state; that set stays fixed for the call (a step that would take one of them below
 * min_depth is rejected; one that brings another in front of its camera does not add it), so the
 * costs reported are over the same observations and cost_final <= cost_initial.
 *
 * Gauge. The caller fixes at least one pose (two for a monocular window, else the scale is free).
 * A free pose with no usable observation is held fixed. When the undamped reduced camera system at
 * the start is not positive definite (a Cholesky pivot below 1e-10 of its diagonal entry: a free
 * pose is not determined by what it sees, or the scale gauge is free) TVO_BA_FLAG_SINGULAR is set and
 * the solve goes on with damped steps (the undetermined directions stay near their start values).
 *
 * Cost. On the bench-like window of test/bench/bench_ba.c (6 poses, 2 of them fixed, 300 points each seen
 * by 4 poses, 1200 observations, 0.5 px noise and 5 % outliers, 5 iterations all accepted): 13.6 M
 * instructions per call (callgrind, x86-64, gcc -O3: `valgrind --tool=callgrind
 * --toggle-collect=tvo_ba_solve bench_ba --callgrind`, total / 10 calls), of which 71 % build and solve
 * the systems (6 of them: 5 damped steps and the undamped check; 21 % of the total recomputes the
 * observations' Jacobians and W blocks there, see Memory), 25 % linearise (5 times). A 10-pose window (500 points,
 * 2000 observations, `bench_ba --poses 10`): 27.3 M instructions per call.
 * Scaling per iteration: O(obs) to linearise, to evaluate a trial step and for each system build and
 * back-substitution, O(points) for the 3x3 point blocks, O(sum over points of poses_per_point^2)
 * (<= O(obs * poses)) for the Schur complement, O((6 free poses)^3 / 6) for the reduced system's
 * Cholesky.
 *
 * Memory. Nothing is stored per observation but a 4-byte index (the observations grouped by point,
 * by a stable counting sort at the start of the call) and a usable flag. The observations' Jacobians,
 * IRLS weights and pose-point blocks W = Jc^T W Jx are recomputed from the state, point by point, for
 * each system build (summed per pose of the point, then W V^-1 W^T goes straight into the 6x6 blocks of
 * the reduced system) and again in the back-substitution; they are bit-identical to the
 * linearisation's since the state is then the linearisation point, so the robust weights are the same
 * within an iteration without being stored. Per point: V (upper triangle), its gradient, its step,
 * the backup for the bit-exact restore (V^-1 is recomputed in the back-substitution). Sizes in
 * tvo_ba_scratch_size().
 * No allocation (everything lives in the caller's scratch), stack below 4 KB (1,408 B measured by test_ba
 * on x86-64 -O3), no recursion, only + - * / sqrt and tvo_dm_* (bit-identical on
 * every IEEE-754 double target). Reentrant: no global state. */
#ifndef TINYVO_BA_H
#define TINYVO_BA_H

#include "tinyvo/se3.h"
#include "tinyvo/types.h"
#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Largest cfg->max_poses (the reduced system is 6 * max_poses square, dense). */
#define TVO_BA_MAX_POSES 32
/* Largest cfg->max_points and cfg->max_obs. */
#define TVO_BA_MAX_POINTS (1 << 20)
#define TVO_BA_MAX_OBS (1 << 22)
/* Largest cfg->max_iterations. */
#define TVO_BA_MAX_ITERATIONS 1000
/* Value tvo_ba_obs_errors() gives an observation that cannot be measured (point at Z_c <= 0, or a
 * non-finite observation or projection). */
#define TVO_BA_ERR_INVALID 1e30

/* Doubles per point of tvo_ba_problem.prior. */
#define TVO_BA_PRIOR_SIZE 10

typedef struct tvo_ba_obs {
    int32_t pose, point; /* indices into the problem's poses and points */
    double x, y;         /* normalised image coordinates x = X_c / Z_c, y = Y_c / Z_c */
} tvo_ba_obs;

typedef struct tvo_ba_config {
    int32_t max_iterations; /* LM iterations cap (accepted + rejected steps), 1..TVO_BA_MAX_ITERATIONS; default 10 */
    double huber;           /* Huber width in normalised units, finite > 0; default 2.0 / 458 */
    double lambda_init; /* initial LM damping (relative to the diagonal), finite in (0, 1e12]; default 1e-3 */
    double min_depth;   /* an observation whose point has Z_c below this is left out of the step
                               (counted in obs_skipped); finite > 0; default 1e-3 (world units) */
    int32_t max_poses;  /* capacities the scratch is sized for: 1..TVO_BA_MAX_POSES, */
    int32_t max_points; /* 1..TVO_BA_MAX_POINTS, */
    int32_t max_obs;    /* 1..TVO_BA_MAX_OBS; defaults 10, 1024, 4096 */
    double max_point_cond; /* (added) condition estimate above which a point is held fixed, finite >= 1;
                               default 1e6 (see "Held points" above) */
} tvo_ba_config;

/* Fills the defaults listed above. cfg == NULL does nothing. */
TVO_API void tvo_ba_config_default(tvo_ba_config *cfg);

/* A prior on the rotation between two poses (a gyroscope's, or a chain of two-view rotations): cost
 * 1/2 weight |log(R_b R_a^T R_ba^T)|^2 (rad^2, the unit of the normalised reprojection errors' squares)
 * added to the reprojection cost. */
typedef struct tvo_ba_rot_prior {
    int32_t pose_a, pose_b; /* indices into the problem's poses, different */
    /* the measured rotation from camera a to camera b (X_b = R_ba X_a + ...): a rotation matrix (any other
       gives a meaningless prior; the adjustment still never writes a non-finite value) */
    double R_ba[9];
    double weight; /* finite, >= 0 */
} tvo_ba_rot_prior;

typedef struct tvo_ba_problem {
    int32_t n_poses;            /* 1..cfg->max_poses */
    tvo_pose *T_c_w;            /* in/out [n_poses]: camera poses (world -> camera); R must be a rotation */
    const uint8_t *pose_fixed;  /* [n_poses], nonzero = held constant (the gauge: the caller fixes at least 1,
                                  normally the 2 oldest for a monocular window to hold the scale) */
    int32_t n_points;           /* 0..cfg->max_points */
    double (*X)[3];             /* in/out [n_points]: world points */
    const uint8_t *point_fixed; /* [n_points], nonzero = held constant; or NULL (all free) */
    int32_t n_obs;              /* 0..cfg->max_obs */
    const tvo_ba_obs *obs;      /* [n_obs]; the order does not matter (results do not depend on it
                                  except for rounding) */
    int32_t n_rot;              /* 0..n_poses: relative-rotation priors (0: none, as before) */
    const tvo_ba_rot_prior *rot; /* [n_rot] */
    /* (added) a quadratic prior on each point (NULL: none, as before; zero the struct before filling
       it): cost 1/2 X^T L X + g^T X + c added for point j, prior[j] = {L00 L01 L02 L11 L12 L22, g0 g1 g2,
       c} with L symmetric positive semidefinite: observations linearised at a pose no longer in the
       problem (tvo_ba_point_prior_add), or any Gaussian belief about the point. It adds to the point's
       3x3 block; a point still needs 2 usable observations to be optimised */
    const double (*prior)[TVO_BA_PRIOR_SIZE];
} tvo_ba_problem;

enum {
    TVO_BA_FLAG_COST_ROSE = 1,     /* no step lowered the cost: the state is unchanged (bit-identical) */
    TVO_BA_FLAG_SINGULAR = 2,      /* the undamped reduced system at the start, or a damped one, was not
                                       positive definite, or a free pose had no usable observation */
    TVO_BA_FLAG_ITER_CAP = 4,      /* stopped by max_iterations before converging */
    TVO_BA_FLAG_POINTS_SKIPPED = 8 /* some free points had < 2 usable observations or an ill-conditioned
                                       3x3 block and were held fixed (points_skipped says how many) */
};

typedef struct tvo_ba_report {
    int32_t iterations;     /* steps tried (accepted + rejected), <= max_iterations */
    int32_t accepted;       /* steps accepted */
    int32_t flags;          /* TVO_BA_FLAG_* */
    int32_t points_skipped; /* free points held fixed at the last linearisation */
    double cost_initial;    /* robust cost of the input state over the usable observations */
    double cost_final;      /* robust cost of the output state over the same observations (<= cost_initial) */
    int32_t obs_skipped;    /* (added) observations left out (not usable at the input state: non-finite
                                x, y or Z_c < min_depth) */
    int32_t poses_free;     /* (added) free poses that were optimised at the last linearisation */
} tvo_ba_report;

/* Adds to prior (TVO_BA_PRIOR_SIZE doubles, see tvo_ba_problem.prior) the observation (x, y) of the point
 * X by a camera held at T_c_w, linearised at X: the reprojection error's Gauss-Newton quadratic in the
 * point, with the Huber weight (width huber, normalised units) of the error at X times weight. What an
 * observation in a keyframe that leaves a window would have added to the point's cost had the keyframe
 * stayed, fixed. Returns 0 (prior unchanged) when the point is not in front of the camera (Z_c below
 * 1e-3 world units) or an input is not finite, else 1. */
TVO_API int tvo_ba_point_prior_add(double prior[TVO_BA_PRIOR_SIZE], const tvo_pose *T_c_w, const double X[3],
                                   double x, double y, double huber, double weight);

/* Bytes of scratch tvo_ba_solve() needs for problems within cfg's capacities; 0 for an invalid (or
 * NULL) config. 5 B per max_obs + 129 B per max_points + 832 B per max_poses + (6 max_poses)^2 doubles
 * (the reduced system), each array rounded up to 16 B, + 16 B: 60,128 B for 6 poses, 300 points, 1200
 * observations; 39,296 B for 6 / 150 / 900; 189,760 B for the defaults. */
TVO_API size_t tvo_ba_scratch_size(const tvo_ba_config *cfg);

/* Runs the bundle adjustment on p (poses and points updated in place; on any error status or with
 * TVO_BA_FLAG_COST_ROSE nothing is written). scratch: at least tvo_ba_scratch_size(cfg) bytes, any
 * alignment; its contents are not needed between calls. rep may be NULL.
 * Returns TVO_OK (see rep->flags), or
 *   TVO_ERR_NULL       cfg, p, scratch, T_c_w, pose_fixed, or X / obs with n_points / n_obs > 0 NULL
 *   TVO_ERR_ARG        invalid config; n_poses < 1, n_points < 0, n_obs < 0; an observation whose pose or
 *                      point index is out of range
 *   TVO_ERR_NO_MEMORY  n_poses, n_points or n_obs above cfg's capacities, or scratch_size too small
 *   TVO_ERR_NOT_FINITE a pose or point with a non-finite entry
 *   TVO_ERR_TOO_FEW    no free pose and no free point, or n_obs == 0
 * Non-finite observations are not an error: they are left out and counted in rep->obs_skipped. */
TVO_API tvo_status tvo_ba_solve(const tvo_ba_config *cfg, tvo_ba_problem *p, void *scratch,
                                size_t scratch_size, tvo_ba_report *rep);

/* Squared reprojection error |predicted - (x, y)|^2 of each observation (normalised units^2) to
 * err2[n_obs], so that the caller can drop outliers; TVO_BA_ERR_INVALID for a point at Z_c <= 0 in that
 * camera or a non-finite observation. No capacity limits, O(n_obs), no scratch.
 * Returns TVO_ERR_NULL (p, err2, T_c_w, or X / obs with n > 0), TVO_ERR_ARG (negative counts, an index out
 * of range: nothing written). */
TVO_API tvo_status tvo_ba_obs_errors(const tvo_ba_problem *p, double *err2);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_BA_H */
