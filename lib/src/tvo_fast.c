/* SPDX-License-Identifier: Apache-2.0 */
/* FAST-9 corner detector (16-pixel circle, 9 contiguous), OpenCV-compatible corner set, score and
 * 3x3 non-max suppression. See tinyvo/corners.h for the contract.
 *
 * Structure: rows are scanned one at a time. A pixel is first screened with its 4 compass pixels
 * (0, 4, 8, 12 of the circle): any 9-arc contains two neighbouring compass pixels, so a corner needs two
 * neighbouring compass pixels on the same side. Survivors get the exact 16-bit "brighter" / "darker"
 * masks and a branch-free test for a run of 9 set bits, then OpenCV's score.
 *
 * With SSE2 (x86-64) or NEON (aarch64, and 32-bit ARM built with NEON) 16 pixels are screened at once,
 * and a block that passes gets the exact test and the score of all 16 lanes from saturating byte
 * differences and min / max over the arcs (fast_row). That block is written once over the vector helpers
 * FV_* below, one SSE2 or NEON intrinsic each (two small NEON functions). The row's tail (fewer than 16
 * pixels), builds without SSE2 or NEON, and builds with TVO_CORNERS_NO_SIMD defined run the portable
 * per-pixel code. Every path gives the same corners, scores and order (test_corners compares them). */
#include "tinyvo/corners.h"

#include <string.h>

#if !defined(TVO_CORNERS_NO_SIMD) && (defined(__SSE2__) || defined(_M_X64))
#include <emmintrin.h>
#define TVO_FAST_SSE2 1
#else
#define TVO_FAST_SSE2 0
#endif
#if !defined(TVO_CORNERS_NO_SIMD) && !TVO_FAST_SSE2 && (defined(__ARM_NEON) || defined(__ARM_NEON__))
#include <arm_neon.h>
#define TVO_FAST_NEON 1
#else
#define TVO_FAST_NEON 0
#endif
#define TVO_FAST_SIMD (TVO_FAST_SSE2 || TVO_FAST_NEON)

/* 16 unsigned bytes: unaligned load / store, broadcast, zero, saturating add / subtract, min / max,
 * wrapping subtract, (~a) & b, 0xFF where a lane is 0, "all lanes 0", and the 16-bit mask of the lanes
 * that are 0xFF (FV_MOVEMASK takes compare results only: lanes 0x00 or 0xFF). */
#if TVO_FAST_SSE2
typedef __m128i fast_v16;
#define FV_LOAD(p) _mm_loadu_si128((const __m128i *)(const void *)(p))
#define FV_STORE(p, v) _mm_storeu_si128((__m128i *)(void *)(p), (v))
#define FV_SET1(b) _mm_set1_epi8((char)(uint8_t)(b))
#define FV_ZERO() _mm_setzero_si128()
#define FV_ADDS(a, b) _mm_adds_epu8((a), (b))
#define FV_SUBS(a, b) _mm_subs_epu8((a), (b))
#define FV_MIN(a, b) _mm_min_epu8((a), (b))
#define FV_MAX(a, b) _mm_max_epu8((a), (b))
#define FV_SUB(a, b) _mm_sub_epi8((a), (b))
#define FV_ANDNOT(a, b) _mm_andnot_si128((a), (b))
#define FV_EQ0(a) _mm_cmpeq_epi8((a), _mm_setzero_si128())
#define FV_ALL0(a) (_mm_movemask_epi8(_mm_cmpeq_epi8((a), _mm_setzero_si128())) == 0xFFFF)
#define FV_MOVEMASK(a) ((unsigned)_mm_movemask_epi8(a))
#elif TVO_FAST_NEON
typedef uint8x16_t fast_v16;
#define FV_LOAD(p) vld1q_u8((const uint8_t *)(p))
#define FV_STORE(p, v) vst1q_u8((uint8_t *)(p), (v))
#define FV_SET1(b) vdupq_n_u8((uint8_t)(b))
#define FV_ZERO() vdupq_n_u8(0)
#define FV_ADDS(a, b) vqaddq_u8((a), (b))
#define FV_SUBS(a, b) vqsubq_u8((a), (b))
#define FV_MIN(a, b) vminq_u8((a), (b))
#define FV_MAX(a, b) vmaxq_u8((a), (b))
#define FV_SUB(a, b) vsubq_u8((a), (b))
#define FV_ANDNOT(a, b) vbicq_u8((b), (a))
#define FV_EQ0(a) vceqq_u8((a), vdupq_n_u8(0))
#define FV_ALL0(a) fast_neon_all0(a)
#define FV_MOVEMASK(a) fast_neon_movemask(a)

static inline int fast_neon_all0(uint8x16_t a)
{
#if defined(__aarch64__)
    return vmaxvq_u8(a) == 0;
#else
    uint8x8_t o = vorr_u8(vget_low_u8(a), vget_high_u8(a));
    return vget_lane_u64(vreinterpret_u64_u8(o), 0) == 0u;
#endif
}

/* NEON has no movemask: each 0xFF lane keeps its own bit of a byte, then three pairwise adds gather
 * lanes 0-7 into byte 0 and lanes 8-15 into byte 1 (no carries: the bits are distinct) */
static inline unsigned fast_neon_movemask(uint8x16_t a)
{
    static const uint8_t bit[16] = {1, 2, 4, 8, 16, 32, 64, 128, 1, 2, 4, 8, 16, 32, 64, 128};
    uint8x16_t t = vandq_u8(a, vld1q_u8(bit));
    uint8x8_t p = vpadd_u8(vget_low_u8(t), vget_high_u8(t));
    p = vpadd_u8(p, p);
    p = vpadd_u8(p, p);
    return (unsigned)vget_lane_u8(p, 0) | ((unsigned)vget_lane_u8(p, 1) << 8);
}
#endif

/* circle offsets (dx, dy), clockwise starting at 12 o'clock... as OpenCV's order: (0,3) first. */
static const int8_t fast_circle[16][2] = {{0, 3},  {1, 3},  {2, 2},  {3, 1},   {3, 0},   {3, -1},
                                          {2, -2}, {1, -3}, {0, -3}, {-1, -3}, {-2, -2}, {-3, -1},
                                          {-3, 0}, {-3, 1}, {-2, 2}, {-1, 3}};

static void fast_offsets(int32_t ofs[16], int32_t stride)
{
    int k;
    for (k = 0; k < 16; ++k)
        ofs[k] = (int32_t)fast_circle[k][0] + (int32_t)fast_circle[k][1] * stride;
}

#if TVO_FAST_SIMD
/* index of the lowest set bit of v != 0 (portable de Bruijn multiply); only the SIMD block uses it */
static int fast_ctz(uint32_t v)
{
    static const uint8_t tab[32] = {0,  1,  28, 2,  29, 14, 24, 3, 30, 22, 20, 15, 25, 17, 4,  8,
                                    31, 27, 13, 23, 21, 19, 16, 7, 26, 12, 18, 6,  11, 5,  10, 9};
    return tab[(uint32_t)((v & (0u - v)) * 0x077CB531u) >> 27];
}
#endif

/* 1 when the circular 16-bit mask m has a run of at least 9 set bits. */
static int fast_has_run9(uint32_t m)
{
    uint32_t a = m | (m << 16); /* unrolled circle */
    uint32_t r2 = a & (a >> 1); /* runs of 2 start here */
    uint32_t r4 = r2 & (r2 >> 2);
    uint32_t r8 = r4 & (r4 >> 4);
    uint32_t r9 = r8 & (a >> 8);
    return (r9 & 0xFFFFu) != 0;
}

/* OpenCV's FAST score: max over the 16 arcs of 9 of max(min(d), -max(d)) - 1, d = I(c) - I(p). */
static int fast_score(const uint8_t *p, const int32_t ofs[16])
{
    int d[26];
    int k, s, v = p[0];
    int best_min = -1000, best_max = 1000;
    for (k = 0; k < 16; ++k)
        d[k] = v - (int)p[ofs[k]];
    for (k = 16; k < 26; ++k)
        d[k] = d[k - 16];
    for (s = 0; s < 16; s += 2) {
        int mn = d[s + 1], mx = d[s + 1], t;
        for (k = s + 2; k <= s + 8; ++k) {
            mn = d[k] < mn ? d[k] : mn;
            mx = d[k] > mx ? d[k] : mx;
        }
        /* arcs s .. s+8 and s+1 .. s+9 */
        t = d[s] < mn ? d[s] : mn;
        best_min = t > best_min ? t : best_min;
        t = d[s + 9] < mn ? d[s + 9] : mn;
        best_min = t > best_min ? t : best_min;
        t = d[s] > mx ? d[s] : mx;
        best_max = t < best_max ? t : best_max;
        t = d[s + 9] > mx ? d[s + 9] : mx;
        best_max = t < best_max ? t : best_max;
    }
    return (best_min > -best_max ? best_min : -best_max) - 1;
}

/* Exact corner test of pixel p (centre value v) with the threshold table tab (1 = darker, 2 = brighter). */
static int fast_is_corner(const uint8_t *p, const int32_t ofs[16], const uint8_t *tab)
{
    uint32_t bright = 0, dark = 0;
    int k;
    for (k = 0; k < 16; ++k) {
        uint32_t t = tab[p[ofs[k]]];
        dark |= (t & 1u) << k;
        bright |= (t >> 1) << k;
    }
    return fast_has_run9(bright) || fast_has_run9(dark);
}

/* Detect the corners of one row (y fixed) at x in [x0, x1), 3 <= x0, x1 <= width - 3: positions into
 * pos[], scores into the score row (zeroed first over [x0 - 1, x1 + 1), all that the non-max test of
 * these pixels and their neighbours reads). Returns the number of corners. */
static int32_t fast_row(const uint8_t *row, int32_t x0, int32_t x1, const int32_t ofs[16],
                        const uint8_t *ttab, int32_t threshold, uint8_t *score_row, int32_t *pos)
{
    int32_t n = 0, x = x0;
    const int32_t o0 = ofs[0], o4 = ofs[4], o8 = ofs[8], o12 = ofs[12];
    memset(score_row + x0 - 1, 0, (size_t)x1 - (size_t)x0 + 2u);
    (void)threshold; /* read by the SIMD block only; the portable path works from ttab */
#if TVO_FAST_SIMD
    {
        const fast_v16 thr = FV_SET1(threshold);
        for (; x + 16 <= x1; x += 16) {
            const uint8_t *p = row + x;
            fast_v16 c = FV_LOAD(p);
            /* screen: q brighter iff sat(q - sat(c + t)) != 0, darker iff sat(sat(c - t) - q) != 0
             * (exactly q > c + t and q < c - t); a corner needs a neighbouring compass pair on one side */
            fast_v16 hi = FV_ADDS(c, thr), lo = FV_SUBS(c, thr);
            fast_v16 q0 = FV_LOAD(p + o0), q4 = FV_LOAD(p + o4), q8 = FV_LOAD(p + o8), q12 = FV_LOAD(p + o12);
            fast_v16 b0 = FV_SUBS(q0, hi), b4 = FV_SUBS(q4, hi), b8 = FV_SUBS(q8, hi), b12 = FV_SUBS(q12, hi);
            fast_v16 d0 = FV_SUBS(lo, q0), d4 = FV_SUBS(lo, q4), d8 = FV_SUBS(lo, q8), d12 = FV_SUBS(lo, q12);
            fast_v16 m = FV_MAX(FV_MAX(FV_MAX(FV_MIN(b0, b4), FV_MIN(b4, b8)),
                                       FV_MAX(FV_MIN(b8, b12), FV_MIN(b12, b0))),
                                FV_MAX(FV_MAX(FV_MIN(d0, d4), FV_MIN(d4, d8)),
                                       FV_MAX(FV_MIN(d8, d12), FV_MIN(d12, d0))));
            unsigned bits;
            if (FV_ALL0(m))
                continue;
            {
                /* exact test and score of all 16 lanes: with bright = sat(q - c), dark = sat(c - q)
                 * (unsigned saturating), best = max over the 16 arcs of 9 of max(min_arc bright,
                 * min_arc dark). Lane is a corner iff best > threshold, and then best - 1 is OpenCV's score
                 * (saturation at 0 cannot change a maximum that is >= threshold + 1 >= 1). */
                fast_v16 xb[16], xd[16], r2b[8], r2d[8], r4b[8], r4d[8];
                fast_v16 bestb = FV_ZERO(), bestd = FV_ZERO(), best, notcorner;
                int k;
                for (k = 0; k < 16; ++k) {
                    fast_v16 q = FV_LOAD(p + ofs[k]);
                    xb[k] = FV_SUBS(q, c);
                    xd[k] = FV_SUBS(c, q);
                }
                /* runs starting at even e: R2_e = min(x_e, x_e+1), R4_e = min(R2_e, R2_e+2),
                 * R8_e = min(R4_e, R4_e+4); the 9-arcs are e..e+8 = min(R8_e, x_e+8) and
                 * e-1..e+7 = min(x_e-1, R8_e), so best = max_e min(R8_e, max(x_e+8, x_e-1)). */
                for (k = 0; k < 8; ++k) {
                    r2b[k] = FV_MIN(xb[2 * k], xb[2 * k + 1]);
                    r2d[k] = FV_MIN(xd[2 * k], xd[2 * k + 1]);
                }
                for (k = 0; k < 8; ++k) {
                    r4b[k] = FV_MIN(r2b[k], r2b[(k + 1) & 7]);
                    r4d[k] = FV_MIN(r2d[k], r2d[(k + 1) & 7]);
                }
                for (k = 0; k < 8; ++k) {
                    int e = 2 * k;
                    fast_v16 r8b = FV_MIN(r4b[k], r4b[(k + 2) & 7]);
                    fast_v16 r8d = FV_MIN(r4d[k], r4d[(k + 2) & 7]);
                    fast_v16 endb = FV_MAX(xb[(e + 8) & 15], xb[(e + 15) & 15]);
                    fast_v16 endd = FV_MAX(xd[(e + 8) & 15], xd[(e + 15) & 15]);
                    bestb = FV_MAX(bestb, FV_MIN(r8b, endb));
                    bestd = FV_MAX(bestd, FV_MIN(r8d, endd));
                }
                best = FV_MAX(bestb, bestd);
                notcorner = FV_EQ0(FV_SUBS(best, thr));
                bits = FV_MOVEMASK(notcorner) ^ 0xFFFFu;
                if (bits == 0u)
                    continue;
                FV_STORE(score_row + x, FV_ANDNOT(notcorner, FV_SUB(best, FV_SET1(1))));
                while (bits != 0u) {
                    pos[n++] = x + fast_ctz(bits);
                    bits &= bits - 1u;
                }
            }
        }
    }
#endif
    for (; x < x1; ++x) {
        const uint8_t *p = row + x;
        const uint8_t *tab = ttab + 255 - p[0];
        unsigned t0 = tab[p[o0]], t4 = tab[p[o4]], t8 = tab[p[o8]], t12 = tab[p[o12]];
        if (((t0 & t4) | (t4 & t8) | (t8 & t12) | (t12 & t0)) == 0u)
            continue;
        if (fast_is_corner(p, ofs, tab)) {
            score_row[x] = (uint8_t)fast_score(p, ofs);
            pos[n++] = x;
        }
    }
    return n;
}

const char *tvo_fast_kernel_name(void)
{
#if TVO_FAST_SSE2
    return "sse2";
#elif TVO_FAST_NEON
    return "neon";
#else
    return "portable";
#endif
}

size_t tvo_fast_scratch_size(int32_t width)
{
    size_t w;
    if (width < 1 || width > TVO_MAX_IMAGE_DIM)
        return 0;
    w = (size_t)width;
    /* 3 score rows + 3 position lists, plus alignment slack */
    return 3u * w + 3u * w * sizeof(int32_t) + 16u;
}

static tvo_status fast_check(const tvo_image *img, int32_t threshold, const tvo_corner *out, int32_t capacity,
                             const int32_t *count)
{
    tvo_status st;
    if (count == NULL || out == NULL)
        return TVO_ERR_NULL;
    st = tvo_image_check(img);
    if (st != TVO_OK)
        return st;
    if (threshold < 0 || threshold > 255 || capacity < 0)
        return TVO_ERR_ARG;
    return TVO_OK;
}

/* Emit the corners of row y (positions pos[0..n)) with xa <= x < xb into out; with nonmax, keep those
 * whose score is strictly above their 8 neighbours in rows above/cur/below. Returns 0, or 1 when out is
 * full. */
static int fast_emit(int32_t y, const int32_t *pos, int32_t n, int32_t xa, int32_t xb, const uint8_t *above,
                     const uint8_t *cur, const uint8_t *below, int nonmax, tvo_corner *out, int32_t capacity,
                     int32_t *count)
{
    int32_t i;
    for (i = 0; i < n; ++i) {
        int32_t x = pos[i];
        int s = cur[x];
        if (x < xa || x >= xb)
            continue;
        if (nonmax &&
            !(s > cur[x - 1] && s > cur[x + 1] && s > above[x - 1] && s > above[x] && s > above[x + 1] &&
              s > below[x - 1] && s > below[x] && s > below[x + 1]))
            continue;
        if (*count >= capacity)
            return 1;
        out[*count].x = (float)x;
        out[*count].y = (float)y;
        out[*count].score = (float)s;
        ++*count;
    }
    return 0;
}

tvo_status tvo_fast9_detect_rect(const tvo_image *img, int32_t threshold, int nonmax, int32_t x_begin,
                                 int32_t x_end, int32_t y_begin, int32_t y_end, tvo_corner *out,
                                 int32_t capacity, int32_t *count, void *scratch, size_t scratch_size)
{
    uint8_t ttab[511];
    int32_t ofs[16];
    uint8_t *srow[3];
    int32_t *plist[3];
    int32_t npos[3];
    int32_t W, H, r, r0, r1, i, c0, c1;
    size_t need;
    uint8_t *mem;
    tvo_status st = fast_check(img, threshold, out, capacity, count);
    if (count != NULL)
        *count = 0;
    if (st != TVO_OK)
        return st;
    if (scratch == NULL)
        return TVO_ERR_NULL;
    need = tvo_fast_scratch_size(img->width);
    if (scratch_size < need)
        return TVO_ERR_NO_MEMORY;
    W = img->width;
    H = img->height;
    if (y_begin < 3)
        y_begin = 3;
    if (y_end > H - 3)
        y_end = H - 3;
    if (x_begin < 3)
        x_begin = 3;
    if (x_end > W - 3)
        x_end = W - 3;
    if (W < 7 || H < 7 || y_begin >= y_end || x_begin >= x_end)
        return TVO_OK;

    for (i = 0; i < 511; ++i) {
        int d = i - 255;
        ttab[i] = (uint8_t)(d < -threshold ? 1 : d > threshold ? 2 : 0);
    }
    fast_offsets(ofs, img->stride);

    mem = (uint8_t *)scratch;
    {
        /* align the int lists to 4 bytes */
        size_t mis = (size_t)((uintptr_t)mem % sizeof(int32_t));
        uint8_t *lists = mem + (mis ? sizeof(int32_t) - mis : 0);
        for (i = 0; i < 3; ++i)
            plist[i] = (int32_t *)(void *)(lists + (size_t)i * (size_t)W * sizeof(int32_t));
        mem = lists + 3u * (size_t)W * sizeof(int32_t);
        for (i = 0; i < 3; ++i) {
            srow[i] = mem + (size_t)i * (size_t)W;
            memset(srow[i], 0, (size_t)W);
            npos[i] = 0;
        }
    }

    nonmax = nonmax != 0;
    /* the columns evaluated: the range, and with non-max the neighbours its corners are compared with */
    c0 = x_begin - nonmax < 3 ? 3 : x_begin - nonmax;
    c1 = x_end + nonmax > W - 3 ? W - 3 : x_end + nonmax;
    r0 = y_begin - nonmax;
    if (r0 < 3)
        r0 = 3;
    r1 = y_end - 1 + nonmax;
    if (r1 > H - 4)
        r1 = H - 4;

    for (r = r0; r <= r1; ++r) {
        int slot = r % 3;
        npos[slot] = fast_row(img->data + (size_t)r * (size_t)img->stride, c0, c1, ofs, ttab, threshold,
                              srow[slot], plist[slot]);
        if (!nonmax) {
            if (fast_emit(r, plist[slot], npos[slot], x_begin, x_end, NULL, srow[slot], NULL, 0, out,
                          capacity, count))
                return TVO_ERR_NO_MEMORY;
        } else if (r - 1 >= y_begin && r - 1 >= r0) {
            int ps = (r - 1) % 3, pps = (r - 2) % 3;
            if (r - 2 < r0) /* never evaluated: no corners there */
                memset(srow[pps], 0, (size_t)W);
            if (fast_emit(r - 1, plist[ps], npos[ps], x_begin, x_end, srow[pps], srow[ps], srow[slot], 1, out,
                          capacity, count))
                return TVO_ERR_NO_MEMORY;
        }
    }
    if (nonmax && r1 >= r0 && r1 < y_end && r1 >= y_begin) {
        /* last evaluated row: the row below it has no corners (image border or outside the range) */
        int s = r1 % 3, as = (r1 + 2) % 3, bs = (r1 + 1) % 3;
        if (r1 - 1 < r0)
            memset(srow[as], 0, (size_t)W);
        memset(srow[bs], 0, (size_t)W);
        if (fast_emit(r1, plist[s], npos[s], x_begin, x_end, srow[as], srow[s], srow[bs], 1, out, capacity,
                      count))
            return TVO_ERR_NO_MEMORY;
    }
    return TVO_OK;
}

tvo_status tvo_fast9_detect_rows(const tvo_image *img, int32_t threshold, int nonmax, int32_t y_begin,
                                 int32_t y_end, tvo_corner *out, int32_t capacity, int32_t *count,
                                 void *scratch, size_t scratch_size)
{
    return tvo_fast9_detect_rect(img, threshold, nonmax, 0, TVO_MAX_IMAGE_DIM, y_begin, y_end, out, capacity,
                                 count, scratch, scratch_size);
}

tvo_status tvo_fast9_detect(const tvo_image *img, int32_t threshold, int nonmax, tvo_corner *out,
                            int32_t capacity, int32_t *count, void *scratch, size_t scratch_size)
{
    return tvo_fast9_detect_rows(img, threshold, nonmax, 0, TVO_MAX_IMAGE_DIM, out, capacity, count, scratch,
                                 scratch_size);
}

int32_t tvo_fast9_score_at(const tvo_image *img, int32_t x, int32_t y)
{
    int32_t ofs[16];
    if (tvo_image_check(img) != TVO_OK)
        return -1;
    if (x < 3 || y < 3 || x >= img->width - 3 || y >= img->height - 3)
        return -1;
    fast_offsets(ofs, img->stride);
    return fast_score(img->data + (size_t)y * (size_t)img->stride + (size_t)x, ofs);
}
