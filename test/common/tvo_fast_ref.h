/* SPDX-License-Identifier: Apache-2.0 */
/* Deliberately simple FAST-9 reference for the tests (no table, no SIMD, no early rejection): the
 * corner set and scores tvo_fast9_detect must reproduce (corners.h). Written from the definition:
 *   - the 16-pixel Bresenham circle of radius 3, OpenCV's order starting at (0, 3);
 *   - (x, y), 3 <= x < width-3 and 3 <= y < height-3, is a corner when 9 contiguous circle pixels are
 *     all brighter than v + threshold or all darker than v - threshold;
 *   - its score is OpenCV's: the largest t for which it is still a corner, minus 1, i.e.
 *     max(max over arcs of min(v - p), max over arcs of min(p - v)) - 1 over the 16 arcs of 9;
 *   - with nonmax, a corner is kept when its score is strictly above each of its 8 neighbours' (0 for
 *     neighbours that are not corners).
 * Row-major output order, same statuses as tvo_fast9_detect (it needs no scratch). Slow. */
#ifndef TVO_FAST_REF_H
#define TVO_FAST_REF_H

#include <stdint.h>

#include "tinyvo/corners.h"
#include "tinyvo/image.h"

static const int8_t tvo_ref_circle[16][2] = {{0, 3},  {1, 3},  {2, 2},  {3, 1},   {3, 0},   {3, -1},
                                             {2, -2}, {1, -3}, {0, -3}, {-1, -3}, {-2, -2}, {-3, -1},
                                             {-3, 0}, {-3, 1}, {-2, 2}, {-1, 3}};

/* Score of (x, y) when it is a corner at `threshold`, -1 otherwise (also outside the detection area). */
static inline int tvo_ref_fast_score(const tvo_image *img, int32_t threshold, int32_t x, int32_t y)
{
    int d[16], s, k, best_bright = -1000, best_dark = -1000, corner = 0;
    const uint8_t *p;
    if (x < 3 || y < 3 || x >= img->width - 3 || y >= img->height - 3)
        return -1;
    p = img->data + (size_t)y * (size_t)img->stride + (size_t)x;
    for (k = 0; k < 16; ++k)
        d[k] = (int)p[(ptrdiff_t)tvo_ref_circle[k][1] * img->stride + tvo_ref_circle[k][0]] - (int)p[0];
    for (s = 0; s < 16; ++s) {
        int mn_bright = 1000, mn_dark = 1000;
        for (k = 0; k < 9; ++k) {
            const int q = d[(s + k) % 16];
            mn_bright = q < mn_bright ? q : mn_bright; /* circle brighter by at least this */
            mn_dark = -q < mn_dark ? -q : mn_dark;     /* circle darker by at least this */
        }
        if (mn_bright > threshold || mn_dark > threshold)
            corner = 1;
        best_bright = mn_bright > best_bright ? mn_bright : best_bright;
        best_dark = mn_dark > best_dark ? mn_dark : best_dark;
    }
    if (!corner)
        return -1;
    return (best_bright > best_dark ? best_bright : best_dark) - 1;
}

static inline tvo_status tvo_fast9_detect_ref(const tvo_image *img, int32_t threshold, int nonmax,
                                              tvo_corner *out, int32_t capacity, int32_t *count)
{
    int32_t x, y;
    tvo_status st;
    if (count == NULL || out == NULL)
        return TVO_ERR_NULL;
    *count = 0;
    st = tvo_image_check(img);
    if (st != TVO_OK)
        return st;
    if (threshold < 0 || threshold > 255 || capacity < 0)
        return TVO_ERR_ARG;
    for (y = 3; y < img->height - 3; ++y) {
        for (x = 3; x < img->width - 3; ++x) {
            const int s = tvo_ref_fast_score(img, threshold, x, y);
            int dx, dy, keep = 1;
            if (s < 0)
                continue;
            for (dy = -1; nonmax && dy <= 1 && keep; ++dy)
                for (dx = -1; dx <= 1 && keep; ++dx) {
                    int sn;
                    if (dx == 0 && dy == 0)
                        continue;
                    sn = tvo_ref_fast_score(img, threshold, x + dx, y + dy);
                    keep = s > (sn < 0 ? 0 : sn);
                }
            if (!keep)
                continue;
            if (*count >= capacity)
                return TVO_ERR_NO_MEMORY;
            out[*count].x = (float)x;
            out[*count].y = (float)y;
            out[*count].score = (float)s;
            ++*count;
        }
    }
    return TVO_OK;
}

#endif /* TVO_FAST_REF_H */
