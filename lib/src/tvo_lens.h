/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the lens's first two radial coefficients refined on the run (internal to the VO object;
 * tvo_vo_config.lens_refine in vo.h says what users see of it).
 *
 * What it estimates. A change dk = (dk1, dk2) of the radial coefficients k1, k2 of the camera (RADTAN, or
 * NONE taken as RADTAN with zero coefficients; EQUIDISTANT is not refined). A monocular VO turns a lens
 * error of a pixel at the image's edges into a trajectory several times worse (docs/camera.md, "How much
 * a lens error costs"), and published calibrations of real cameras carry that much.
 *
 * Where the information comes from. After a keyframe's bundle adjustment, tvo_lens_window() linearises the
 * window's reprojection errors in pixels (each observation's pixel is its normalised position distorted
 * with the camera as it is; Huber weights of cfg.map_ba_huber_px) around the adjusted poses and points,
 * with dk, every pose but the oldest and every point free, and eliminates the points (3x3 Schur
 * complements) and then the poses (a Cholesky of the pose block, regularised by 1e-9 of its largest
 * diagonal entry for the monocular scale, along which dk has no coupling): a Gauss-Newton estimate of
 * dk from the window and its information, scaled by the window's residual variance (a block). The
 * map computes a block only from windows that share no keyframe with the last block's window, so the
 * blocks are nearly independent.
 *
 * When a change is adopted (tvo_lens_decide). The blocks since the last change (at most
 * TVO_LENS_MAX_BLOCKS, the oldest dropped) are combined by their information; the change is adopted when
 *   1. there are at least TVO_LENS_MIN_BLOCKS blocks;
 *   2. the first half of the blocks and the second half agree: for neither coefficient are their
 *      estimates more than TVO_LENS_AGREE_SIGMAS standard errors of their difference apart, or the two
 *      halves' lenses put the image's border points (corners and side middles) less than
 *      TVO_LENS_AGREE_SHARE of the whole estimate's largest border shift apart (the standard errors are
 *      optimistic, since track errors are correlated; this second test keeps a well-estimated change);
 *      a lens that the run sees differently as it goes (a poor model, or a focal length error the
 *      radial terms take up on one stretch and not the next) fails it;
 *   3. the whole estimate is at least TVO_LENS_MIN_SIGMAS standard errors from zero (the Mahalanobis
 *      norm over both coefficients) and moves the border by at least TVO_LENS_MIN_SHIFT_PX and at most
 *      TVO_LENS_MAX_SHIFT_PX pixels;
 *   4. the changed camera is valid and its distortion still undistorts every border point.
 * After a change the blocks start again: a later change needs as many new blocks.
 *
 * This is the online form of tinyvo-lenscheck (tools/tinyvo_tools/lenscheck.py): the same adjustment
 * over the map's window instead of frames spread over a recorded run, and its halves test. */
#ifndef TVO_LENS_H
#define TVO_LENS_H

#include "tinyvo/ba.h"
#include "tinyvo/camera.h"
#include "tinyvo/status.h"

#define TVO_LENS_MAX_BLOCKS 16
#define TVO_LENS_MIN_BLOCKS 2
#define TVO_LENS_AGREE_SIGMAS 3.0
#define TVO_LENS_AGREE_SHARE 0.5
#define TVO_LENS_MIN_SIGMAS 5.0
#define TVO_LENS_MIN_SHIFT_PX 1.0
#define TVO_LENS_MAX_SHIFT_PX 20.0

/* One window's information about dk: I = J^T W J / s2 (after the Schur complements; row-major 2x2)
 * and h = I dk_window (so dk_window = I^-1 h), s2 the window's weighted residual variance (px^2). */
typedef struct tvo_lens_block {
    double I[4], h[2], s2;
    int32_t n_obs; /* observations that took part */
} tvo_lens_block;

/* The running state: the blocks since the last change, and the changes adopted so far. */
typedef struct tvo_lens {
    int32_t n;
    tvo_lens_block b[TVO_LENS_MAX_BLOCKS];
    int32_t updates; /* changes adopted */
    double dk[2];    /* their sum */
} tvo_lens;

/* What tvo_lens_decide() found. */
typedef enum tvo_lens_verdict {
    TVO_LENS_WAIT = 0,     /* fewer than TVO_LENS_MIN_BLOCKS blocks */
    TVO_LENS_DISAGREE = 1, /* the halves disagree (condition 2) */
    TVO_LENS_SMALL = 2,    /* not significant, or below TVO_LENS_MIN_SHIFT_PX (condition 3) */
    TVO_LENS_LARGE = 3,    /* above TVO_LENS_MAX_SHIFT_PX, or the changed camera is not usable */
    TVO_LENS_ADOPT = 4
} tvo_lens_verdict;

/* 1 when the camera's model can be refined (RADTAN, NONE). */
int tvo_lens_supported(const tvo_camera *cam);

/* Scratch bytes for tvo_lens_window() on a problem of at most max_poses poses, max_points points and
 * max_obs observations (0 when a size overflows). */
size_t tvo_lens_scratch_size(int32_t max_poses, int32_t max_points, int32_t max_obs);

/* The block of the problem p (the map's window after its adjustment; p's own fixed flags are not used:
 * pose 0 is held, every other pose is free). 1 when *out was filled; 0 when the camera is not supported,
 * the scratch is too small, too few observations took part (fewer than 50 points seen twice), or the
 * information is not positive definite or not finite. Bounded work: one pass over the observations,
 * one Cholesky of 6 (n_poses - 1) unknowns. */
int tvo_lens_window(const tvo_camera *cam, const tvo_ba_problem *p, double huber_px, void *scratch,
                    size_t scratch_size, tvo_lens_block *out);

/* Forget the blocks (the adopted changes are kept). */
void tvo_lens_clear_blocks(tvo_lens *s);
/* Append a block (dropping the oldest when TVO_LENS_MAX_BLOCKS are held). */
void tvo_lens_add(tvo_lens *s, const tvo_lens_block *blk);

/* The verdict on the blocks held; *dk (when not NULL) receives the whole estimate (0, 0 when there is
 * none) and *shift_px (when not NULL) its largest border shift. With TVO_LENS_ADOPT, *changed (not NULL)
 * receives the camera with dk applied. */
tvo_lens_verdict tvo_lens_decide(const tvo_lens *s, const tvo_camera *cam, double dk[2], double *shift_px,
                                 tvo_camera *changed);

/* The camera with its first two radial coefficients changed by dk (NONE becomes RADTAN). TVO_OK, or
 * tvo_camera_check's error. */
tvo_status tvo_lens_changed(const tvo_camera *cam, const double dk[2], tvo_camera *out);

/* The normalised point x of camera `from` moved to where camera `to` sees the same pixel: distorted
 * with `from`, undistorted with `to`. 0 (x unchanged) when either fails. */
int tvo_lens_remap(const tvo_camera *from, const tvo_camera *to, tvo_point2d *x);

#endif /* TVO_LENS_H */
