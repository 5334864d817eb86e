/* SPDX-License-Identifier: Apache-2.0 */
/* Inputs shared by the guarantee tests (test/guarantees): a synthetic scene rendered here, "hostile"
 * frames, the per-DoF paper model, and the shared EuRoC keyframes when present.
 *
 * The scene is a textured corridor (floor, ceiling, two side walls, an end wall) seen by a pinhole
 * camera that moves forward and yaws: several planes at different depths, so the VO sees real
 * parallax (OK states), and the sequence mixes in pure rotation, random noise, black, saturated and
 * alternating frames to reach the ROTATION_ONLY, LOST and re-initialisation paths too. */
#ifndef TVO_GUARANTEE_H
#define TVO_GUARANTEE_H

#include "tvo_test.h"

#include <math.h>

#include "tinyvo/tinyvo.h"

/* 1 in ASan/UBSan or unoptimised builds and cross builds run under qemu (TVO_G_EMULATED), which run the
 * VO 10-50x slower: the tests use fewer frames. */
#if defined(__SANITIZE_ADDRESS__) || !defined(__OPTIMIZE__) || defined(TVO_G_EMULATED)
#define TVO_G_SLOW_BUILD 1
#else
#define TVO_G_SLOW_BUILD 0
#endif

static inline double tvo_g_hash(int32_t x, int32_t y, uint32_t seed)
{
    uint32_t h = (uint32_t)x * 374761393u + (uint32_t)y * 668265263u + seed * 2246822519u;
    h = (h ^ (h >> 13)) * 1274126177u;
    h ^= h >> 16;
    return (double)(h & 0xffffu) / 65535.0;
}

/* two-octave value noise in [0, 1] */
static inline double tvo_g_texture(double u, double v, uint32_t seed)
{
    double s = 0.0, amp = 0.6, freq = 4.0;
    for (int o = 0; o < 2; ++o) {
        const double x = u * freq, y = v * freq, fx = floor(x), fy = floor(y), a = x - fx, b = y - fy;
        const int32_t ix = (int32_t)fx, iy = (int32_t)fy;
        const double h00 = tvo_g_hash(ix, iy, seed + (uint32_t)o),
                     h10 = tvo_g_hash(ix + 1, iy, seed + (uint32_t)o);
        const double h01 = tvo_g_hash(ix, iy + 1, seed + (uint32_t)o),
                     h11 = tvo_g_hash(ix + 1, iy + 1, seed + (uint32_t)o);
        s += amp * ((h00 * (1 - a) + h10 * a) * (1 - b) + (h01 * (1 - a) + h11 * a) * b);
        amp *= 0.4;
        freq *= 2.5;
    }
    return s;
}

/* Corridor |x| <= 1.5, |y| <= 1, z <= 12 seen from camera pose (R = yaw about y, position c). */
static inline void tvo_g_render(uint8_t *img, int32_t w, int32_t h, double focal, double yaw,
                                const double c[3])
{
    const double cy_ = cos(yaw), sy_ = sin(yaw);
    for (int32_t y = 0; y < h; ++y)
        for (int32_t x = 0; x < w; ++x) {
            const double dcx = (x - 0.5 * (w - 1)) / focal, dcy = (y - 0.5 * (h - 1)) / focal;
            const double d[3] = {cy_ * dcx + sy_, dcy, -sy_ * dcx + cy_}; /* R_w_c * (dcx, dcy, 1) */
            double t = 1e30, u = 0.0, v = 0.0;
            uint32_t wall = 0;
            if (d[0] > 1e-9 && (1.5 - c[0]) / d[0] < t) {
                t = (1.5 - c[0]) / d[0];
                wall = 1;
            }
            if (d[0] < -1e-9 && (-1.5 - c[0]) / d[0] < t) {
                t = (-1.5 - c[0]) / d[0];
                wall = 2;
            }
            if (d[1] > 1e-9 && (1.0 - c[1]) / d[1] < t) {
                t = (1.0 - c[1]) / d[1];
                wall = 3;
            }
            if (d[1] < -1e-9 && (-1.0 - c[1]) / d[1] < t) {
                t = (-1.0 - c[1]) / d[1];
                wall = 4;
            }
            if (d[2] > 1e-9 && (12.0 - c[2]) / d[2] < t) {
                t = (12.0 - c[2]) / d[2];
                wall = 5;
            }
            {
                const double p[3] = {c[0] + t * d[0], c[1] + t * d[1], c[2] + t * d[2]};
                if (wall == 1 || wall == 2) {
                    u = p[2];
                    v = p[1];
                } else if (wall == 3 || wall == 4) {
                    u = p[0];
                    v = p[2];
                } else {
                    u = p[0];
                    v = p[1];
                }
            }
            img[(size_t)y * (size_t)w + (size_t)x] = (uint8_t)(30.0 + 200.0 * tvo_g_texture(u, v, wall * 7u));
        }
}

static inline tvo_camera tvo_g_camera(int32_t w, int32_t h, double focal)
{
    tvo_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.width = w;
    cam.height = h;
    cam.fx = cam.fy = focal;
    cam.cx = 0.5 * (w - 1);
    cam.cy = 0.5 * (h - 1);
    cam.model = TVO_DIST_NONE;
    return cam;
}

/* Kinds of frame in the scripted sequence. */
enum { TVO_G_SCENE = 0, TVO_G_NOISE, TVO_G_BLACK, TVO_G_WHITE, TVO_G_GREY, TVO_G_CHECKER };

/* Frame k of the scripted sequence (n_frames = TVO_G_SEQ_FRAMES): forward motion with yaw, a pure
 * rotation stretch, then hostile frames, then the scene again (re-initialisation). */
#define TVO_G_SEQ_FRAMES 40
static inline int tvo_g_seq_kind(int k)
{
    static const int kinds[TVO_G_SEQ_FRAMES] = {
            0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, /* 0..19 motion, 14..19 rotation */
            1, 0, 2, 2, 0, 3, 0, 5, 5, 0, 1, 1, 4, 0, 0, 0, 0, 0, 0, 0,
    };
    return kinds[k];
}

static inline void tvo_g_seq_frame(int k, uint8_t *img, int32_t w, int32_t h, double focal, uint64_t *rng)
{
    const int kind = tvo_g_seq_kind(k);
    const size_t n = (size_t)w * (size_t)h;
    switch (kind) {
    case TVO_G_NOISE:
        for (size_t i = 0; i < n; ++i)
            img[i] = (uint8_t)(tvo_test_rand(rng) >> 56);
        return;
    case TVO_G_BLACK:
        memset(img, 0, n);
        return;
    case TVO_G_WHITE:
        memset(img, 255, n);
        return;
    case TVO_G_GREY:
        memset(img, 128, n);
        return;
    case TVO_G_CHECKER:
        for (int32_t y = 0; y < h; ++y)
            for (int32_t x = 0; x < w; ++x)
                img[(size_t)y * (size_t)w + (size_t)x] = (uint8_t)((((x >> 3) + (y >> 3) + k) & 1) ? 255 : 0);
        return;
    default: {
        /* forward 4 cm a frame with a slow yaw; frames 14..19 rotate in place (rotation-only) */
        const int km = k < 14 ? k : 14;
        const double c[3] = {0.02 * sin(0.3 * k), 0.0, 0.04 * km};
        const double yaw = 0.004 * k;
        tvo_g_render(img, w, h, focal, yaw, c);
    }
    }
}

/* The per-DoF paper model (test/data/nn/paper.tvonn) loaded into malloc'd memory, or NULL. */
typedef struct tvo_g_model {
    void *file, *mem;
    tvo_nn *nn;
} tvo_g_model;

static inline int tvo_g_load_model(tvo_g_model *m, const char *name)
{
    size_t sz = 0, need = 0;
    memset(m, 0, sizeof *m);
    m->file = tvo_test_read_nn_file(name, 0, &sz);
    if (m->file == NULL || tvo_nn_required_size(m->file, sz, &need) != TVO_OK)
        return 0;
    m->mem = malloc(need);
    return m->mem != NULL && tvo_nn_load(&m->nn, m->file, sz, m->mem, need) == TVO_OK;
}

static inline void tvo_g_free_model(tvo_g_model *m)
{
    free(m->file);
    free(m->mem);
    memset(m, 0, sizeof *m);
}

/* The map's predicted tracks as the balanced preset tracks them (neighbours' depths, 2 levels, 11x11
 * windows, the rescue after a frame that loses more than half of them: cfg.pred_rescue's default), with
 * or without the retry of the lost ones. */
static inline void tvo_g_predicted_tracks(tvo_vo_config *cfg, int retry)
{
    cfg->map_prediction = 2;
    cfg->lk.pred_levels = 2;
    cfg->lk.pred_win_size = 11;
    cfg->lk.pred_retry = retry;
}

/* Every field of a result is finite and the state is a valid one. */
static inline int tvo_g_result_ok(const tvo_vo_result *r)
{
    if (!((int)r->state >= 0 && (int)r->state < TVO_VO_STATE_COUNT))
        return 0;
    if (!tvo_pose_is_finite(&r->T_prev_cur) || !isfinite(r->parallax_deg))
        return 0;
    for (int i = 0; i < TVO_FEAT_COUNT; ++i)
        if (!isfinite(r->features[i]))
            return 0;
    if (r->tracked < 0 || r->inliers < 0 || r->inliers > r->tracked || r->tracks < 0 || r->new_corners < 0)
        return 0;
    if ((uint32_t)r->gain_retry > 1u || (uint32_t)r->pred_rescue > 1u)
        return 0;
    return 1;
}

#endif
