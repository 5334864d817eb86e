/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: pyramidal Lucas-Kanade sparse optical flow (8-bit grey), OpenCV-compatible.
 *
 * The algorithm is the one of cv::calcOpticalFlowPyrLK (Bouguet's pyramidal LK) with the same
 * numbers, so that results agree with OpenCV to well under 0.05 px:
 *   - per level, from max_level down to 0: the point is scaled by 2^-level; the guess starts at the
 *     point (or at next_pts when use_initial_flow) on the top level and is doubled on the way down;
 *   - a win_size x win_size window of the previous level, sampled bilinearly with 14-bit fixed-point
 *     weights (values kept with 5 fractional bits), and its Scharr derivatives (3 10 3), computed
 *     per window on the fly; outside the image, pixels follow BORDER_REFLECT_101 and derivatives are 0;
 *   - the 2x2 gradient matrix G; the point is dropped when its smallest eigenvalue / win_size^2 is
 *     below min_eig_threshold or det(G) < FLT_EPSILON;
 *   - Gauss-Newton steps on the next level, at most max_iters, stopping when |step| <= epsilon or
 *     when two steps cancel out (then the point goes back by half the last step);
 *   - err as OpenCV's default: mean |J - I| over the window at the final position, in grey levels.
 * All window arithmetic is integer (exact, identical on every platform); per-point sums are int64.
 * Everything is computed per point: no allocation, no per-image derivative buffers, any image size.
 *
 * Status per point: TVO_LK_TRACKED (1) or TVO_LK_LOST (0). A point is lost when, at level 0,
 *   - its window lies (almost) outside the previous or next image (OpenCV's bounds: window corner
 *     more than win_size px outside), or the final position is outside the level-0 image
 *     [0, width-1] x [0, height-1] (stricter than OpenCV, which keeps such points);
 *   - the window is too flat (min eigenvalue below min_eig_threshold, or det(G) < FLT_EPSILON);
 *   - with fb_check: tracking back from the found position does not return within fb_max_error px
 *     of the start (or the backward track is lost itself); with use_initial_flow the way back starts
 *     from the guess's displacement reversed (found position - (guess - start)), without it at zero
 *     displacement, so a guessed large motion is checked as far as it was tracked. With fb_levels
 *     k > 0 the way back runs on levels k-1..0 only and starts at the start point itself.
 * At coarser levels a failure only means that level adds nothing (OpenCV's behaviour). */
#ifndef TINYVO_LK_H
#define TINYVO_LK_H

#include "tinyvo/pyramid.h"
#include "tinyvo/types.h"
#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

#define TVO_LK_LOST 0
#define TVO_LK_TRACKED 1

/* Accepted window sides (odd). The upper bound keeps every per-row sum inside int32. */
#define TVO_LK_MIN_WIN_SIZE 3
#define TVO_LK_MAX_WIN_SIZE 63
/* Largest max_iters accepted (as OpenCV's clamp). */
#define TVO_LK_MAX_ITERS 100

typedef struct tvo_lk_config {
    int32_t win_size;        /* odd window side in px, TVO_LK_MIN_WIN_SIZE..TVO_LK_MAX_WIN_SIZE, default 21 */
    int32_t max_level;       /* as OpenCV's maxLevel: levels used above 0, 0..TVO_MAX_PYR_LEVELS-1; the
                                pyramids need >= max_level+1 levels; default 3. Levels whose width or
                                height is <= win_size are not used (as OpenCV, which does not build them) */
    int32_t max_iters;       /* Gauss-Newton steps per level, 0..TVO_LK_MAX_ITERS, default 30 */
    float epsilon;           /* px, stop when the step is at most this long; 0..10, default 0.01 */
    float min_eig_threshold; /* as OpenCV's minEigThreshold (min eigenvalue of G / win_size^2, with
                                derivatives in units of 32 grey levels per px); >= 0, default 1e-4 */
    int32_t use_initial_flow; /* nonzero: next_pts holds the initial guess (level-0 px) */
    int32_t fb_check;         /* nonzero: forward-backward check (doubles the cost) */
    float fb_max_error;       /* px, > 0, largest accepted forward-backward distance; default 1.0 */
    int32_t force_portable;   /* nonzero: only the portable C kernels, no SIMD; the results are
                                bit-identical either way (all window sums are exact integers); default 0 */
    int32_t fb_levels;        /* with fb_check: pyramid levels the way back uses, 0..TVO_MAX_PYR_LEVELS;
                                0: all of the forward track's (the full check); k > 0: levels k-1..0 only,
                                starting from the start point (prev_pts, scaled), which costs about k /
                                (max_level + 1) of a full backward track. A point that drifted fails it
                                as the full check; one that jumped onto a repeated pattern may pass it;
                                default 0 */
    /* Predicted points (tvo_lk_track_pred() with pred[i] nonzero: the caller's guess in next_pts is a
       prediction it trusts, e.g. a map point projected with a motion model) can be tracked with less work.
       All three at 0 (the defaults), and always in tvo_lk_track(), every point is tracked as above. */
    int32_t pred_levels;    /* 0..TVO_MAX_PYR_LEVELS; 0: as the other points; k > 0: the predicted points
                               use levels min(k-1, max_level)..0 only, starting at the guess; default 0 */
    int32_t pred_win_size;  /* 0: win_size; else their odd window side, TVO_LK_MIN_WIN_SIZE..
                               TVO_LK_MAX_WIN_SIZE (below 8: the portable kernels for them); default 0 */
    int32_t pred_fb_levels; /* with fb_check: 0: as fb_levels (fb_levels 0: the way back on the levels of
                               their forward track); k > 0: their way back on levels k-1..0, from the start
                               point; default 0 */
    int32_t pred_retry;     /* nonzero: a predicted point that the shorter way loses (or fails the
                               forward-backward check) is tracked again as the other points are, from the
                               same guess; default 0 */
} tvo_lk_config;

/* The defaults above (OpenCV's defaults for win 21, 3 levels, fb check off). */
TVO_API void tvo_lk_config_default(tvo_lk_config *cfg);

/* Which window kernels tvo_lk_track() runs with cfg: "sse2" (x86), "neon" (aarch64, or 32-bit ARM built
 * with -mfpu=neon), or "portable" (the C kernels: force_portable, win_size < 8, no SIMD in this build,
 * or built with -DTVO_LK_NO_SIMD). All give the same results. cfg == NULL: the SIMD kernels compiled
 * in ("portable" when none). Never NULL. */
TVO_API const char *tvo_lk_kernel_name(const tvo_lk_config *cfg);

/* TVO_OK, TVO_ERR_NULL, TVO_ERR_ARG (a field out of its range, even win_size) or TVO_ERR_NOT_FINITE
 * (NaN / infinite epsilon, threshold or fb_max_error). */
TVO_API tvo_status tvo_lk_config_check(const tvo_lk_config *cfg);

/* Bytes of scratch tvo_lk_track() needs (independent of image size and point count; about
 * 8 * (w + 3)^2 bytes, w the larger of win_size and pred_win_size: 3.9 KB for 21). 0 for an invalid cfg. */
TVO_API size_t tvo_lk_scratch_size(const tvo_lk_config *cfg);

/* Track n points from prev to next.
 *   prev_pts[n]  level-0 pixel positions in prev (read only).
 *   next_pts[n]  out: positions in next (level-0 px); in: the guess when cfg->use_initial_flow.
 *                For lost points it holds the last estimate (meaningless).
 *   status[n]    out: TVO_LK_TRACKED or TVO_LK_LOST (reasons above).
 *   err[n]       out, may be NULL: OpenCV's error (mean abs difference over the window, grey levels)
 *                for tracked points, 0 for lost ones.
 *   scratch      at least tvo_lk_scratch_size(cfg) bytes, any alignment.
 * Errors (nothing tracked, status[] set to 0 when status is not NULL): TVO_ERR_NULL, TVO_ERR_SIZE
 * (n < 0, or a pyramid with inconsistent sizes), TVO_ERR_ARG / TVO_ERR_NOT_FINITE (bad cfg),
 * TVO_ERR_ARG (a pyramid with fewer than max_level+1 levels), TVO_ERR_MISMATCH (prev and next
 * levels differ in size), TVO_ERR_NO_MEMORY (scratch too small), TVO_ERR_NOT_FINITE (a NaN or
 * infinite prev point, or guess when use_initial_flow). Finite points far outside are just lost.
 * Cost: per point and level about win_size^2 * (30 + 10 * iterations) integer operations; twice
 * that with fb_check. Thread-safe for distinct scratch/outputs; pyramids are only read. */
TVO_API tvo_status tvo_lk_track(const tvo_lk_config *cfg, const tvo_pyramid *prev, const tvo_pyramid *next,
                                const tvo_point2f *prev_pts, tvo_point2f *next_pts, uint8_t *status,
                                float *err, int32_t n, void *scratch, size_t scratch_size);

/* tvo_lk_track() with a per-point flag: pred[n] nonzero marks a point whose guess (next_pts, with
 * use_initial_flow) is a trusted prediction; those points are tracked with the pred_* fields of cfg, the
 * others as by tvo_lk_track(). pred == NULL, or all pred_* fields 0: exactly tvo_lk_track(). */
TVO_API tvo_status tvo_lk_track_pred(const tvo_lk_config *cfg, const tvo_pyramid *prev,
                                     const tvo_pyramid *next, const tvo_point2f *prev_pts,
                                     tvo_point2f *next_pts, const uint8_t *pred, uint8_t *status, float *err,
                                     int32_t n, void *scratch, size_t scratch_size);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_LK_H */
