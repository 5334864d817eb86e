/* SPDX-License-Identifier: Apache-2.0 */
/* Bucketed corner detection: FAST-9 with non-max suppression, a per-cell shortlist by FAST score,
 * Harris / Shi-Tomasi ranking of the shortlist, and greedy selection with a minimum spacing.
 * See tinyvo/corners.h for the contract. */
#include "tinyvo/corners.h"
#include "tinyvo/arena.h"

#include <math.h>
#include <string.h>

#define DET_BAND \
    8                          /* rows per FAST band: the band buffer holds (width + 1) / 2 * DET_BAND / 2
                                   corners (7.7 KB at 320 px, 18 KB at 752 px); the result does not depend
                                   on it (non-max reads the rows around each band) */
#define DET_MIN_GRID_CELL 8.0f /* smallest cell of the spacing grid, px */
#define DET_MAX_CORNERS (1 << 20)
#define DET_MAX_CANDIDATES 4096
/* 1 only in a test build: FAST runs in every cell, the full ones too, as it did before the full cells
 * were skipped (test_corners compares the two builds' results bit for bit) */
#ifndef TVO_DETECT_FAST_IN_FULL_CELLS
#define TVO_DETECT_FAST_IN_FULL_CELLS 0
#endif

typedef struct det_cand {
    int32_t x, y;
    float score;   /* FAST score, then the ranking score */
    int32_t order; /* y * width + x: raster order, unique */
} det_cand;

typedef struct det_pick {
    float x, y, score;
    int32_t rank, cell, order;
} det_pick;

typedef struct det_box {
    float x0, y0, x1, y1; /* bounding box of the points in a spacing cell; empty when x0 > x1 */
} det_box;

/* derived sizes of one configuration on one image */
typedef struct det_layout {
    int32_t border, inner_w, inner_h, ncells, quota, ncand;
    int32_t band_cap;
    int32_t gw, gh; /* spacing grid (0 x 0 when min_distance == 0) */
    float gcell;
    size_t off_fast, off_band, off_cand, off_ncand, off_nexist, off_cursor, off_grid, off_picks, total;
    int32_t npicks_max;
} det_layout;

void tvo_detect_config_default(tvo_detect_config *cfg)
{
    if (cfg == NULL)
        return;
    cfg->fast_threshold = 20;
    cfg->score = TVO_SCORE_SHI_TOMASI;
    cfg->block_size = 5;
    cfg->harris_k = 0.04f;
    cfg->grid_cols = 8;
    cfg->grid_rows = 6;
    cfg->max_corners = 300;
    cfg->max_per_cell = 0;
    cfg->min_distance = 10.0f;
    cfg->border = 8;
    cfg->candidates_per_cell = 0;
}

tvo_status tvo_detect_config_check(const tvo_detect_config *cfg)
{
    if (cfg == NULL)
        return TVO_ERR_NULL;
    if (!isfinite(cfg->harris_k) || !isfinite(cfg->min_distance))
        return TVO_ERR_NOT_FINITE;
    if (cfg->fast_threshold < 0 || cfg->fast_threshold > 255)
        return TVO_ERR_ARG;
    if (cfg->score != TVO_SCORE_FAST && cfg->score != TVO_SCORE_HARRIS && cfg->score != TVO_SCORE_SHI_TOMASI)
        return TVO_ERR_ARG;
    if (cfg->block_size < 1 || cfg->block_size > TVO_CORNER_MAX_BLOCK)
        return TVO_ERR_ARG;
    if (cfg->grid_cols < 1 || cfg->grid_cols > 256 || cfg->grid_rows < 1 || cfg->grid_rows > 256)
        return TVO_ERR_ARG;
    if (cfg->max_corners < 0 || cfg->max_corners > DET_MAX_CORNERS || cfg->max_per_cell < 0 ||
        cfg->max_per_cell > DET_MAX_CORNERS)
        return TVO_ERR_ARG;
    if (cfg->min_distance < 0.0f || cfg->min_distance > (float)TVO_MAX_IMAGE_DIM)
        return TVO_ERR_ARG;
    if (cfg->border < 0 || cfg->border > TVO_MAX_IMAGE_DIM)
        return TVO_ERR_ARG;
    if (cfg->candidates_per_cell < 0 || cfg->candidates_per_cell > DET_MAX_CANDIDATES)
        return TVO_ERR_ARG;
    return TVO_OK;
}

static size_t det_round(size_t n)
{
    return tvo_arena_round(n); /* saturates at SIZE_MAX */
}

/* TVO_OK and *L filled, or an error for a bad config / size */
static tvo_status det_plan(const tvo_detect_config *cfg, int32_t width, int32_t height, det_layout *L)
{
    tvo_status st = tvo_detect_config_check(cfg);
    int32_t b, q;
    size_t n;
    if (st != TVO_OK)
        return st;
    if (width < 1 || height < 1 || width > TVO_MAX_IMAGE_DIM || height > TVO_MAX_IMAGE_DIM)
        return TVO_ERR_SIZE;
    memset(L, 0, sizeof(*L));
    b = cfg->border > 3 ? cfg->border : 3;
    if (cfg->score != TVO_SCORE_FAST && b < cfg->block_size / 2 + 2)
        b = cfg->block_size / 2 + 2;
    L->border = b;
    L->inner_w = width - 2 * b > 0 ? width - 2 * b : 0;
    L->inner_h = height - 2 * b > 0 ? height - 2 * b : 0;
    L->ncells = cfg->grid_cols * cfg->grid_rows;
    q = cfg->max_per_cell;
    if (q == 0)
        q = (cfg->max_corners + L->ncells - 1) / L->ncells;
    L->quota = q;
    L->ncand = cfg->candidates_per_cell;
    if (L->ncand == 0)
        L->ncand = 3 * q > 12 ? (3 * q > DET_MAX_CANDIDATES ? DET_MAX_CANDIDATES : 3 * q) : 12;
    L->band_cap = ((width + 1) / 2) * ((DET_BAND + 1) / 2);
    if (cfg->min_distance > 0.0f) {
        L->gcell = cfg->min_distance > DET_MIN_GRID_CELL ? cfg->min_distance : DET_MIN_GRID_CELL;
        L->gw = (int32_t)ceilf((float)width / L->gcell);
        L->gh = (int32_t)ceilf((float)height / L->gcell);
        if (L->gw < 1)
            L->gw = 1;
        if (L->gh < 1)
            L->gh = 1;
    }
    /* layout: offsets from a 16-aligned base */
    n = 0;
    L->off_fast = n;
    n = tvo_size_add(n, det_round(tvo_fast_scratch_size(width)));
    L->off_band = n;
    n = tvo_size_add(n, det_round((size_t)L->band_cap * sizeof(tvo_corner)));
    L->off_cand = n;
    n = tvo_size_add(n,
                     det_round(tvo_size_mul(tvo_size_mul((size_t)L->ncells, (size_t)L->ncand),
                                            sizeof(det_cand))));
    L->off_ncand = n;
    n = tvo_size_add(n, det_round((size_t)L->ncells * sizeof(int32_t)));
    L->off_nexist = n;
    n = tvo_size_add(n, det_round((size_t)L->ncells * sizeof(int32_t)));
    L->off_cursor = n;
    n = tvo_size_add(n, det_round(tvo_size_mul((size_t)L->ncells, 2u * sizeof(int32_t))));
    L->off_grid = n;
    n = tvo_size_add(n, det_round((size_t)L->gw * (size_t)L->gh * sizeof(det_box)));
    L->off_picks = n;
    L->npicks_max = (int32_t)((int64_t)L->ncells * L->quota > cfg->max_corners ? (int64_t)L->ncells * L->quota
                                                                               : cfg->max_corners);
    n = tvo_size_add(n, det_round(tvo_size_mul((size_t)L->npicks_max, sizeof(det_pick))));
    L->total = tvo_size_add(n, 16u); /* alignment slack */
    return TVO_OK;
}

size_t tvo_detect_scratch_size(const tvo_detect_config *cfg, int32_t width, int32_t height)
{
    det_layout L;
    if (det_plan(cfg, width, height, &L) != TVO_OK)
        return 0;
    return L.total >= SIZE_MAX / 2 ? 0 : L.total;
}

/* min-heap of candidates: the root is the worst (lowest score; among equal scores, the latest) */
static int det_worse(const det_cand *a, const det_cand *b)
{
    return a->score < b->score || (a->score == b->score && a->order > b->order);
}

static void det_sift_down(det_cand *h, int32_t n, int32_t i)
{
    for (;;) {
        int32_t l = 2 * i + 1, r = l + 1, m = i;
        det_cand t;
        if (l < n && det_worse(&h[l], &h[m]))
            m = l;
        if (r < n && det_worse(&h[r], &h[m]))
            m = r;
        if (m == i)
            return;
        t = h[i];
        h[i] = h[m];
        h[m] = t;
        i = m;
    }
}

static void det_heap_push(det_cand *h, int32_t *n, int32_t cap, const det_cand *c)
{
    if (*n < cap) {
        int32_t i = (*n)++;
        h[i] = *c;
        while (i > 0) {
            int32_t p = (i - 1) / 2;
            det_cand t;
            if (!det_worse(&h[i], &h[p]))
                break;
            t = h[i];
            h[i] = h[p];
            h[p] = t;
            i = p;
        }
    } else if (cap > 0 && det_worse(&h[0], c)) {
        h[0] = *c;
        det_sift_down(h, *n, 0);
    }
}

/* a before b in the ranking: stronger first, then raster order (a total order: keys are unique) */
static int det_cand_before(const det_cand *a, const det_cand *b)
{
    if (a->score != b->score)
        return a->score > b->score;
    return a->order < b->order;
}

/* a before b in the output: by rank within the cell, stronger first, then cell, then raster order */
static int det_pick_before(const det_pick *a, const det_pick *b)
{
    if (a->rank != b->rank)
        return a->rank < b->rank;
    if (a->score != b->score)
        return a->score > b->score;
    if (a->cell != b->cell)
        return a->cell < b->cell;
    return a->order < b->order;
}

/* in-place heapsorts (no allocation, unlike qsort on some libcs; deterministic as the orders are total) */
/* NOLINTBEGIN(bugprone-macro-parentheses): `type` is a type name, which cannot be parenthesised */
#define DET_HEAPSORT(name, type, before)             \
    static void name(type *v, int32_t n)             \
    {                                                \
        int32_t start, end;                          \
        for (start = n / 2 - 1; start >= 0; --start) \
            name##_sift(v, start, n);                \
        for (end = n - 1; end > 0; --end) {          \
            type t = v[0];                           \
            v[0] = v[end];                           \
            v[end] = t;                              \
            name##_sift(v, 0, end);                  \
        }                                            \
    }
#define DET_SIFT(name, type, before)                       \
    static void name##_sift(type *v, int32_t i, int32_t n) \
    {                                                      \
        for (;;) {                                         \
            int32_t l = 2 * i + 1, r = l + 1, m = i;       \
            type t;                                        \
            if (l < n && before(&v[m], &v[l]))             \
                m = l;                                     \
            if (r < n && before(&v[m], &v[r]))             \
                m = r;                                     \
            if (m == i)                                    \
                return;                                    \
            t = v[i];                                      \
            v[i] = v[m];                                   \
            v[m] = t;                                      \
            i = m;                                         \
        }                                                  \
    }
DET_SIFT(det_sort_cands, det_cand, det_cand_before)
DET_HEAPSORT(det_sort_cands, det_cand, det_cand_before)
DET_SIFT(det_sort_picks, det_pick, det_pick_before)
DET_HEAPSORT(det_sort_picks, det_pick, det_pick_before)
/* NOLINTEND(bugprone-macro-parentheses) */

static int32_t det_clampi(int32_t v, int32_t lo, int32_t hi)
{
    return v < lo ? lo : (v > hi ? hi : v);
}

/* 1 when (x, y) keeps min_distance from every point in the spacing grid */
static int det_far_enough(const det_box *grid, const det_layout *L, float md2, float x, float y)
{
    int32_t gx = det_clampi((int32_t)(x / L->gcell), 0, L->gw - 1);
    int32_t gy = det_clampi((int32_t)(y / L->gcell), 0, L->gh - 1);
    int32_t i, j;
    for (j = gy - 1; j <= gy + 1; ++j) {
        if (j < 0 || j >= L->gh)
            continue;
        for (i = gx - 1; i <= gx + 1; ++i) {
            const det_box *b;
            float dx, dy;
            if (i < 0 || i >= L->gw)
                continue;
            b = &grid[(size_t)j * (size_t)L->gw + (size_t)i];
            if (b->x0 > b->x1)
                continue;
            dx = b->x0 - x > 0.0f ? b->x0 - x : (x - b->x1 > 0.0f ? x - b->x1 : 0.0f);
            dy = b->y0 - y > 0.0f ? b->y0 - y : (y - b->y1 > 0.0f ? y - b->y1 : 0.0f);
            if (dx * dx + dy * dy < md2)
                return 0;
        }
    }
    return 1;
}

static void det_grid_add(det_box *grid, const det_layout *L, float x, float y)
{
    int32_t gx = det_clampi((int32_t)(x / L->gcell), 0, L->gw - 1);
    int32_t gy = det_clampi((int32_t)(y / L->gcell), 0, L->gh - 1);
    det_box *b = &grid[(size_t)gy * (size_t)L->gw + (size_t)gx];
    if (b->x0 > b->x1) {
        b->x0 = b->x1 = x;
        b->y0 = b->y1 = y;
    } else {
        b->x0 = x < b->x0 ? x : b->x0;
        b->x1 = x > b->x1 ? x : b->x1;
        b->y0 = y < b->y0 ? y : b->y0;
        b->y1 = y > b->y1 ? y : b->y1;
    }
}

/* take candidate h of cell c when it keeps the spacing; returns 1 when taken */
static int det_try_take(det_box *grid, const det_layout *L, float md2, const det_cand *h, int32_t c,
                        int32_t *taken, det_pick *picks, int32_t *npicks)
{
    float x = (float)h->x, y = (float)h->y;
    det_pick *p;
    if (L->gw > 0) {
        if (!det_far_enough(grid, L, md2, x, y))
            return 0;
        det_grid_add(grid, L, x, y);
    }
    p = &picks[*npicks];
    p->x = x;
    p->y = y;
    p->score = h->score;
    p->rank = (*taken)++;
    p->cell = c;
    p->order = h->order;
    ++*npicks;
    return 1;
}

/* the buffers of one call, carved from the caller's scratch by det_bind */
typedef struct det_work {
    void *fast_mem;
    tvo_corner *band;
    det_cand *cand; /* ncells shortlists (heaps, then sorted) of L.ncand candidates each */
    int32_t *ncand, *nexist, *cursor, *taken_n; /* per cell */
    det_box *grid;                              /* gw x gh spacing grid */
    det_pick *picks;
} det_work;

/* carve the buffers of layout L from scratch (16-aligned), zero the per-cell counters, empty the grid */
static void det_bind(const det_layout *L, void *scratch, det_work *w)
{
    uint8_t *base;
    int32_t i;
    {
        size_t mis = (size_t)((uintptr_t)scratch % 16u);
        base = (uint8_t *)scratch + (mis ? 16u - mis : 0);
    }
    w->fast_mem = base + L->off_fast;
    w->band = (tvo_corner *)(void *)(base + L->off_band);
    w->cand = (det_cand *)(void *)(base + L->off_cand);
    w->ncand = (int32_t *)(void *)(base + L->off_ncand);
    w->nexist = (int32_t *)(void *)(base + L->off_nexist);
    w->cursor = (int32_t *)(void *)(base + L->off_cursor);
    w->taken_n = w->cursor + L->ncells;
    w->grid = (det_box *)(void *)(base + L->off_grid);
    w->picks = (det_pick *)(void *)(base + L->off_picks);
    memset(w->ncand, 0, (size_t)L->ncells * sizeof(int32_t));
    memset(w->nexist, 0, (size_t)L->ncells * sizeof(int32_t));
    memset(w->cursor, 0, 2u * (size_t)L->ncells * sizeof(int32_t));
    for (i = 0; i < L->gw * L->gh; ++i) {
        w->grid[i].x0 = 1.0f;
        w->grid[i].x1 = 0.0f;
        w->grid[i].y0 = w->grid[i].y1 = 0.0f;
    }
}

/* existing points: per-cell counts (inside the inner region) and the spacing grid (inside the image) */
static void det_add_existing(const tvo_detect_config *cfg, const det_layout *L, int32_t W, int32_t H,
                             const tvo_point2f *existing, int32_t n_existing, det_work *w)
{
    int32_t i, B = L->border;
    for (i = 0; i < n_existing; ++i) {
        float x = existing[i].x, y = existing[i].y;
        if (!(x >= 0.0f && y >= 0.0f && x < (float)W && y < (float)H))
            continue;
        if (L->gw > 0)
            det_grid_add(w->grid, L, x, y);
        {
            int32_t u = (int32_t)x - B, v = (int32_t)y - B;
            if (x >= (float)B && y >= (float)B && u < L->inner_w && v < L->inner_h) {
                int32_t cx = (int32_t)(((int64_t)u * cfg->grid_cols) / L->inner_w);
                int32_t cy = (int32_t)(((int64_t)v * cfg->grid_rows) / L->inner_h);
                w->nexist[cy * cfg->grid_cols + cx]++;
            }
        }
    }
}

/* First pixel of cell column (row) c of n over the inner region [B, B + inner): the smallest u with
 * u n / inner >= c, the inverse of the cell index computed below. It is the ceiling: the next cell row
 * then starts after any pixel of this one, so det_shortlist's sub-bands always advance. */
static int32_t det_cell_start(int32_t c, int32_t n, int32_t inner, int32_t B)
{
    return B + (int32_t)(((int64_t)c * inner + n - 1) / n);
}

/* FAST's corners of rows [y0, y1) of cell row cy, in the columns of the cells that are not yet full of
 * existing points (those cells' corners would be dropped: not computing them gives the same shortlist,
 * as the shortlists are sorted by a total order afterwards): one rectangle per run of such cells. */
static tvo_status det_fast_runs(const tvo_detect_config *cfg, const tvo_image *img, const det_layout *L,
                                det_work *w, int32_t cy, int32_t y0, int32_t y1, int32_t *nb)
{
    const int32_t gc = cfg->grid_cols, *full = w->nexist + (size_t)cy * (size_t)gc;
    int32_t c = 0;
    *nb = 0;
    while (c < gc) {
        int32_t e, got = 0;
        tvo_status st;
        if (!TVO_DETECT_FAST_IN_FULL_CELLS && full[c] >= L->quota) {
            ++c;
            continue;
        }
        for (e = c + 1; e < gc && (TVO_DETECT_FAST_IN_FULL_CELLS || full[e] < L->quota); ++e) {
        }
        st = tvo_fast9_detect_rect(img, cfg->fast_threshold, 1, det_cell_start(c, gc, L->inner_w, L->border),
                                   det_cell_start(e, gc, L->inner_w, L->border), y0, y1, w->band + *nb,
                                   L->band_cap - *nb, &got, w->fast_mem, tvo_fast_scratch_size(img->width));
        if (st != TVO_OK && st != TVO_ERR_NO_MEMORY)
            return st;
        *nb += got;
        c = e;
    }
    return TVO_OK;
}

/* FAST in bands of rows, each band split where a cell row ends; shortlist the strongest per cell (FAST
 * runs only in the cells not already full of existing points) */
static tvo_status det_shortlist(const tvo_detect_config *cfg, const tvo_image *img, const det_layout *L,
                                det_work *w)
{
    int32_t W = img->width, H = img->height, B = L->border, y0, ys;
    for (y0 = B; y0 < H - B; y0 += DET_BAND) {
        int32_t y1 = y0 + DET_BAND < H - B ? y0 + DET_BAND : H - B;
        for (ys = y0; ys < y1;) {
            const int32_t crow = (int32_t)(((int64_t)(ys - B) * cfg->grid_rows) / L->inner_h);
            const int32_t ce = det_cell_start(crow + 1, cfg->grid_rows, L->inner_h, B);
            const int32_t ye = ce < y1 ? ce : y1;
            int32_t nb = 0, k;
            tvo_status st = det_fast_runs(cfg, img, L, w, crow, ys, ye, &nb);
            if (st != TVO_OK)
                return st;
            ys = ye;
            for (k = 0; k < nb; ++k) { /* every corner lies in [B, W - B): the rectangles do */
                int32_t x = (int32_t)w->band[k].x, y = (int32_t)w->band[k].y, cx, cy, cell;
                det_cand cd;
                cx = (int32_t)(((int64_t)(x - B) * cfg->grid_cols) / L->inner_w);
                cy = (int32_t)(((int64_t)(y - B) * cfg->grid_rows) / L->inner_h);
                cell = cy * cfg->grid_cols + cx;
                if (w->nexist[cell] >= L->quota)
                    continue;
                cd.x = x;
                cd.y = y;
                cd.score = w->band[k].score;
                cd.order = y * W + x;
                det_heap_push(w->cand + (size_t)cell * (size_t)L->ncand, &w->ncand[cell], L->ncand, &cd);
            }
        }
    }
    return TVO_OK;
}

/* pass 1: rank each cell's shortlist and pick greedily up to the cell's quota; cursor: where it stopped */
static void det_pick_per_cell(const tvo_detect_config *cfg, const tvo_image *img, const det_layout *L,
                              float md2, det_work *w, int32_t *npicks)
{
    int32_t c;
    for (c = 0; c < L->ncells; ++c) {
        det_cand *h = w->cand + (size_t)c * (size_t)L->ncand;
        int32_t n = w->ncand[c], q = L->quota - w->nexist[c], k;
        if (n == 0 || q <= 0)
            continue;
        if (cfg->score != TVO_SCORE_FAST)
            for (k = 0; k < n; ++k)
                h[k].score = tvo_corner_score_at(img, h[k].x, h[k].y, cfg->score, cfg->block_size,
                                                 cfg->harris_k);
        det_sort_cands(h, n);
        for (k = 0; k < n && w->taken_n[c] < q; ++k)
            det_try_take(w->grid, L, md2, &h[k], c, &w->taken_n[c], w->picks, npicks);
        w->cursor[c] = k;
    }
}

/* pass 2: too few corners overall: the non-full cells give their next best in turns, up to limit */
static void det_pick_in_turns(const det_layout *L, float md2, int32_t limit, det_work *w, int32_t *npicks)
{
    int32_t c;
    for (;;) {
        int progress = 0;
        for (c = 0; c < L->ncells && *npicks < limit; ++c) {
            det_cand *h = w->cand + (size_t)c * (size_t)L->ncand;
            if (L->quota - w->nexist[c] <= 0)
                continue;
            while (w->cursor[c] < w->ncand[c]) {
                int took = det_try_take(w->grid, L, md2, &h[w->cursor[c]], c, &w->taken_n[c], w->picks,
                                        npicks);
                ++w->cursor[c];
                if (took) {
                    progress = 1;
                    break;
                }
            }
        }
        if (!progress || *npicks >= limit)
            break;
    }
}

tvo_status tvo_detect(const tvo_detect_config *cfg, const tvo_image *img, const tvo_point2f *existing,
                      int32_t n_existing, tvo_corner *out, int32_t capacity, int32_t *count, void *scratch,
                      size_t scratch_size)
{
    det_layout L;
    det_work w;
    tvo_status st;
    int32_t i, npicks = 0, limit;
    float md, md2;

    if (count != NULL)
        *count = 0;
    if (cfg == NULL || img == NULL || out == NULL || count == NULL || scratch == NULL ||
        (existing == NULL && n_existing > 0))
        return TVO_ERR_NULL;
    st = tvo_detect_config_check(cfg);
    if (st != TVO_OK)
        return st;
    if (capacity < 0 || n_existing < 0)
        return TVO_ERR_ARG;
    st = tvo_image_check(img);
    if (st != TVO_OK)
        return st;
    st = det_plan(cfg, img->width, img->height, &L);
    if (st != TVO_OK)
        return st;
    if (scratch_size < L.total)
        return TVO_ERR_NO_MEMORY;
    for (i = 0; i < n_existing; ++i)
        if (!isfinite(existing[i].x) || !isfinite(existing[i].y))
            return TVO_ERR_NOT_FINITE;

    limit = capacity < cfg->max_corners ? capacity : cfg->max_corners;
    if (L.inner_w <= 0 || L.inner_h <= 0 || limit == 0 || L.quota == 0)
        return TVO_OK;

    det_bind(&L, scratch, &w);
    md = cfg->min_distance;
    md2 = md * md;
    det_add_existing(cfg, &L, img->width, img->height, existing, n_existing, &w);
    st = det_shortlist(cfg, img, &L, &w);
    if (st != TVO_OK)
        return st;
    det_pick_per_cell(cfg, img, &L, md2, &w, &npicks);
    det_pick_in_turns(&L, md2, limit, &w, &npicks);

    det_sort_picks(w.picks, npicks);
    if (npicks > limit)
        npicks = limit;
    for (i = 0; i < npicks; ++i) {
        out[i].x = w.picks[i].x;
        out[i].y = w.picks[i].y;
        out[i].score = w.picks[i].score;
    }
    *count = npicks;
    return TVO_OK;
}
