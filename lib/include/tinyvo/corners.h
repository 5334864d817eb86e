/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: corner detection. FAST-9 corners, Harris / Shi-Tomasi responses, and a bucketed detector
 * that spreads new corners over the image for tracking.
 *
 * All coordinates are pixels of the image given (x right, y down, origin at the centre of the top-left
 * pixel, as in tinyvo/types.h). Nothing here allocates: each function that needs working memory takes a
 * caller-provided `scratch` block of at least the size its *_scratch_size() call returns (any alignment;
 * the functions align internally). Nothing is kept between calls; all functions are reentrant when
 * given distinct scratch blocks, and all results are deterministic (independent of the SIMD path taken).
 *
 * Definitions follow OpenCV 4.10 exactly where stated (checked by test/oracle/test_corners_oracle.py). */
#ifndef TINYVO_CORNERS_H
#define TINYVO_CORNERS_H

#include "tinyvo/image.h"
#include "tinyvo/types.h"
#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct tvo_corner {
    float x, y;  /* pixels, level-0 coordinates (integers for FAST corners) */
    float score; /* FAST score, or the Harris / Shi-Tomasi response (see tvo_detect_config.score) */
} tvo_corner;

/* ---- FAST-9 ---------------------------------------------------------------------------------------
 * FAST with the 16-pixel Bresenham circle of radius 3 (OpenCV TYPE_9_16): pixel c is a corner when 9
 * contiguous circle pixels p all satisfy I(p) > I(c) + threshold, or all satisfy I(p) < I(c) - threshold.
 * Corners are searched in 3 <= x < width-3, 3 <= y < height-3 (images smaller than 7x7 have none).
 *
 * score: OpenCV's FAST score, the largest threshold for which the pixel is still a corner:
 *   score = max over the 16 arcs A of 9 contiguous circle pixels of  max(min_A(I(c)-I(p)), min_A(I(p)-I(c))) - 1,
 *   an integer in [threshold, 254]. It is filled in with and without non-max suppression (OpenCV reports
 *   0 without non-max suppression; that is the only difference).
 * nonmax != 0: 3x3 non-maximum suppression as OpenCV: a corner is kept when its score is strictly larger
 *   than the score of each of its 8 neighbours (0 where the neighbour is not a corner).
 * Output order: row-major (y, then x), as OpenCV.
 * Cost: one pass over the image, O(width*height) with early rejection; SSE2 / NEON paths when the compiler
 * targets them (define TVO_CORNERS_NO_SIMD to build the portable path only), bit-exact to the portable one. */

/* Which FAST-9 block this build runs: "sse2" (x86), "neon" (aarch64, or 32-bit ARM built with NEON) or
 * "portable" (no SIMD in this build, or built with TVO_CORNERS_NO_SIMD). All give the same corners.
 * Never NULL. */
TVO_API const char *tvo_fast_kernel_name(void);

/* Bytes of scratch tvo_fast9_detect* needs for images `width` pixels wide (0 when width < 1). */
TVO_API size_t tvo_fast_scratch_size(int32_t width);

/* FAST-9 corners of the whole image into out[0 .. *count).
 * threshold in [0, 255] (OpenCV clamps; tinyvo returns TVO_ERR_ARG).
 * Returns TVO_OK; TVO_ERR_NULL (img, img->data, out, count or scratch NULL); TVO_ERR_SIZE (bad image view);
 * TVO_ERR_ARG (threshold out of range, capacity < 0); TVO_ERR_NO_MEMORY when scratch_size is too small
 * (then *count = 0), or when there are more corners than `capacity`: then out holds the first `capacity`
 * corners in row-major order and *count = capacity. */
TVO_API tvo_status tvo_fast9_detect(const tvo_image *img, int32_t threshold, int nonmax, tvo_corner *out,
                                    int32_t capacity, int32_t *count, void *scratch, size_t scratch_size);

/* The same, restricted to the corners with y_begin <= y < y_end: exactly the corners (and scores, and
 * non-max decisions) that tvo_fast9_detect reports in those rows. Lets callers bound memory by detecting in
 * horizontal bands (tvo_detect does). Rows are clamped to the image; an empty range gives 0 corners.
 * Cost: rows y_begin-4 .. y_end+3 are read. Same statuses as tvo_fast9_detect. */
TVO_API tvo_status tvo_fast9_detect_rows(const tvo_image *img, int32_t threshold, int nonmax, int32_t y_begin,
                                         int32_t y_end, tvo_corner *out, int32_t capacity, int32_t *count,
                                         void *scratch, size_t scratch_size);

/* The same, restricted to the corners with x_begin <= x < x_end and y_begin <= y < y_end: exactly the
 * corners (and scores, and non-max decisions) that tvo_fast9_detect reports in that rectangle, in
 * row-major order. Lets callers skip the parts of an image where they want no corners (tvo_detect skips
 * its full cells). The range is clamped to the image; an empty range gives 0 corners. Cost: the pixels
 * of columns x_begin-4 .. x_end+3 in rows y_begin-4 .. y_end+3 are read. Same statuses as
 * tvo_fast9_detect. */
TVO_API tvo_status tvo_fast9_detect_rect(const tvo_image *img, int32_t threshold, int nonmax, int32_t x_begin,
                                         int32_t x_end, int32_t y_begin, int32_t y_end, tvo_corner *out,
                                         int32_t capacity, int32_t *count, void *scratch,
                                         size_t scratch_size);

/* OpenCV's FAST-9 score (definition above) of pixel (x, y); x, y must be >= 3 inside the image (no check
 * beyond that; returns -1 for a pixel outside that range or a bad view). Meaningful for corners only:
 * for a non-corner it returns max(..)-1 over the arcs, which may be below any threshold. */
TVO_API int32_t tvo_fast9_score_at(const tvo_image *img, int32_t x, int32_t y);

/* ---- Harris / Shi-Tomasi -------------------------------------------------------------------------- */
typedef enum tvo_score_kind {
    TVO_SCORE_FAST = 0,      /* FAST score (integer, see above) */
    TVO_SCORE_HARRIS = 1,    /* det(M) - k trace(M)^2, as cv::cornerHarris */
    TVO_SCORE_SHI_TOMASI = 2 /* smaller eigenvalue of M, as cv::cornerMinEigenVal */
} tvo_score_kind;

/* Largest accepted block_size (also the smallest is 1). Keeps the integer sums exact in int32. */
#define TVO_CORNER_MAX_BLOCK 31

/* Dense response maps equal to cv::cornerHarris(img, block_size, 3, k, BORDER_REFLECT_101) and
 * cv::cornerMinEigenVal(img, block_size, 3, BORDER_REFLECT_101):
 *   Ix, Iy = 3x3 Sobel derivatives (image border reflected, 101), scaled by s = 1 / (4 * block_size * 255);
 *   M = sum over the block_size x block_size window (anchor block_size/2, border reflected 101) of
 *       [Ix*Ix  Ix*Iy; Ix*Iy  Iy*Iy];
 *   Harris = det(M) - k * trace(M)^2;  Shi-Tomasi = (a+c)/2 - sqrt(((a-c)/2)^2 + b^2), M = [a b; b c].
 * tinyvo sums the integer Sobel products exactly (int32) and evaluates the formula in double, then rounds
 * to float: it agrees with OpenCV (float arithmetic) per pixel within
 *   |tvo - cv| <= 1e-4 * |cv| + 1e-6 * S,  S = the largest over the image of |cv| and of trace(M)
 *   (Shi-Tomasi) or trace(M)^2 (Harris), the scale of OpenCV's float cancellation error
 * (the tolerance the oracle test states; OpenCV's own float rounding is the difference).
 * block_size in [1, TVO_CORNER_MAX_BLOCK] (even sizes as OpenCV: window x - block_size/2 .. + block_size-1);
 * harris_k finite (ignored for Shi-Tomasi); kind HARRIS or SHI_TOMASI (FAST -> TVO_ERR_ARG).
 * out: width*height floats, row y at out + y*out_stride, out_stride >= width (floats).
 * Cost: O(width*height), independent of block_size. */
TVO_API size_t tvo_corner_response_scratch_size(int32_t width, int32_t block_size);
TVO_API tvo_status tvo_corner_response(const tvo_image *img, tvo_score_kind kind, int32_t block_size,
                                       float harris_k, float *out, int32_t out_stride, void *scratch,
                                       size_t scratch_size);

/* The same response at one pixel (for scoring FAST corners cheaply): exactly the value
 * tvo_corner_response writes at (x, y). The pixel must be at least block_size/2 + 1 inside the image
 * (x - block_size/2 - 1 >= 0 and x + (block_size-1-block_size/2) + 1 < width, same for y), where no border
 * reflection happens. Returns 0.0f for a bad view, kind, block_size, non-finite k or a pixel too close to the
 * border. Cost: O(block_size^2). */
TVO_API float tvo_corner_score_at(const tvo_image *img, int32_t x, int32_t y, tvo_score_kind kind,
                                  int32_t block_size, float harris_k);

/* ---- bucketed detector ----------------------------------------------------------------------------- */
typedef struct tvo_detect_config {
    int32_t fast_threshold;       /* FAST threshold, [0, 255]; default 20 */
    tvo_score_kind score;         /* ranking score; default TVO_SCORE_SHI_TOMASI */
    int32_t block_size;           /* Harris/Shi-Tomasi window, [1, TVO_CORNER_MAX_BLOCK]; default 5 */
    float harris_k;               /* finite; default 0.04 */
    int32_t grid_cols, grid_rows; /* bucketing grid, each [1, 256]; default 8 x 6 */
    int32_t max_corners;          /* total new corners wanted, >= 0; default 300 */
    int32_t max_per_cell;         /* >= 0; 0 = ceil(max_corners / (grid_cols*grid_rows)); default 0 */
    float min_distance;           /* px between kept corners and from existing points, finite, >= 0;
                                 0 disables the check; default 10 */
    int32_t border;               /* px ignored at the image border, >= 0; default 8. The effective border is
                                 at least 3 (FAST) and block_size/2 + 2 (Harris/Shi-Tomasi). */
    int32_t candidates_per_cell;  /* FAST corners kept per cell (the strongest by FAST score) before the
                                    ranking score is computed, [0, 4096]; 0 = 3 * per-cell quota (min 12);
                                    default 0. Bounds the Harris/Shi-Tomasi evaluations. */
} tvo_detect_config;

/* Fill *cfg with the defaults above. */
TVO_API void tvo_detect_config_default(tvo_detect_config *cfg);

/* TVO_OK when every field of *cfg is in range; TVO_ERR_NULL / TVO_ERR_ARG / TVO_ERR_NOT_FINITE otherwise. */
TVO_API tvo_status tvo_detect_config_check(const tvo_detect_config *cfg);

/* Bytes of scratch tvo_detect needs for this config and image size; 0 for a bad config or size. */
TVO_API size_t tvo_detect_scratch_size(const tvo_detect_config *cfg, int32_t width, int32_t height);

/* FAST-9 + non-max suppression + ranking score + grid bucketing. Returns up to min(capacity, max_corners)
 * NEW corners in out[0 .. *count):
 *  - the image inside the border is split into grid_cols x grid_rows cells (integer pixel bounds
 *    x0 = border + c * (width - 2*border) / grid_cols); each cell gets at most its quota
 *    max(0, per_cell - (existing points inside the cell)) new corners;
 *  - per cell, the `candidates_per_cell` strongest FAST corners (ties: row-major order) are scored with
 *    cfg->score, then taken strongest first (ties: row-major) while no kept corner and no existing point is
 *    closer than min_distance (a conservative test: a corner may be refused a little farther away than
 *    min_distance when several points share one cell of the spacing grid, never accepted closer);
 *  - when the quotas give fewer than min(capacity, max_corners) corners (low texture in some cells), the
 *    cells that are not full of existing points give their next best shortlisted corners in turns (one
 *    per cell per round, cell order) until that many are reached or the shortlists run out;
 *  - when the cells offer more than min(capacity, max_corners), the cells' best corners win, then their
 *    second best, ... (ties: stronger first, then cell order).
 *  Output order: by rank within the cell, then score (descending), then cell: so within a cell, strongest
 *  first. Existing points outside the image are ignored; NaN points give TVO_ERR_NOT_FINITE.
 * Images too small for the border give 0 corners and TVO_OK.
 * Returns TVO_OK; TVO_ERR_NULL (cfg, img, out, count, scratch, or existing with n_existing > 0);
 * TVO_ERR_ARG (bad config, capacity < 0, n_existing < 0); TVO_ERR_SIZE (bad view);
 * TVO_ERR_NO_MEMORY (scratch_size < tvo_detect_scratch_size()). *count is 0 on any error.
 * Cost: one FAST pass plus about grid_cols*grid_rows*candidates_per_cell score evaluations. */
TVO_API tvo_status tvo_detect(const tvo_detect_config *cfg, const tvo_image *img, const tvo_point2f *existing,
                              int32_t n_existing, tvo_corner *out, int32_t capacity, int32_t *count,
                              void *scratch, size_t scratch_size);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_CORNERS_H */
