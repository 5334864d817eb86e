/* SPDX-License-Identifier: Apache-2.0 */
/* Fuzz harness: the visual odometry (tinyvo/vo.h) fed with arbitrary image bytes and timestamps.
 *
 * Input layout (bytes past the end read as zero):
 *   header, 8 bytes:
 *     [0] width  = 16 + b % 81   (16..96 px)        [1] height = 16 + b % 81
 *     [2] bits 0-1 distortion (0 none, 1 radtan, 2 equidistant, 3 none); bits 2-7 fx = 30 + 8 * v px
 *     [3] distortion strength (int8: k1 = s / 256 for radtan, s / 512 for equidistant)
 *     [4] max_tracks = 16 + b (16..271); min_pose_tracks = 8 + b % 23
 *     [5] bits 0-1 lk.max_level (reduced while the image is too small for it); bits 2-7 fast threshold * 4
 *     [6] texture seed                 [7] bits 0-2: lk.win_size = 5 + 4 * v; bit 3: portable kernels;
 *       bits 4-7 v: detect grid (1 + v % 8) x (1 + v % 6), min_distance v & 7 px, border 3 or 8 (bit 7)
 *   then up to MAX_FRAMES frames, each: an op byte and its payload:
 *     op bits 0-1 frame kind: 0 raw w*h bytes from the input; 1 a procedural texture (seeded by the
 *       header) moved by dx, dy (int8 / 16 px) and zoomed by 1 + int8 / 512 (3 payload bytes), so that
 *       tracking and pose estimation really run; 2 the previous frame with n (u8) byte patches (u16
 *       position, u8 value each); 3 a flat frame of one grey value (u8).
 *     op bits 2-3 timestamp: 0 +50 ms; 1 + u16 us (0 repeats the timestamp); 2 a raw int64 (8 bytes);
 *       3 - u16 ns (goes back in time)
 *     op bit 4: tvo_vo_reset before the frame; bits 5-7: row stride = width + v (padding filled with 0xA5)
 * Invariants checked after every frame: the status is TVO_OK, or TVO_ERR_ARG exactly when the timestamp
 * does not increase; an error result is LOST with an identity pose; the state is valid; the pose is
 * finite with an orthonormal rotation; OK has a unit translation, ROTATION_ONLY a zero one,
 * INITIALISING / LOST the identity; counts are within their bounds; the features are finite; the
 * trajectory integrated with tvo_traj_step stays finite. The VO lives in an exact-size heap block so
 * that ASan reports any access past it. */
#include <math.h>
#include <string.h>

#include "fuzz_common.h"
#include "tinyvo/vo.h"

#define MAX_FRAMES 12

typedef struct scene {
    int32_t w, h;
    uint32_t seed;
} scene;

static uint32_t hash3(int32_t x, int32_t y, uint32_t seed)
{
    uint32_t v = (uint32_t)x * 0x9E3779B1u ^ (uint32_t)y * 0x85EBCA77u ^ seed * 0xC2B2AE3Du;
    v ^= v >> 15;
    v *= 0x2C1B3C6Du;
    v ^= v >> 12;
    v *= 0x297A2D39u;
    v ^= v >> 15;
    return v;
}

/* Blocky random texture (4 px blocks, plenty of corners), sampled bilinearly at (x, y). */
static double texture(const scene *s, double x, double y)
{
    const double fx = floor(x), fy = floor(y), ax = x - fx, ay = y - fy;
    const int32_t ix = (int32_t)fx, iy = (int32_t)fy;
    double v[4];
    for (int k = 0; k < 4; ++k) {
        const int32_t px = ix + (k & 1), py = iy + (k >> 1);
        /* floor division by 4 for negative coordinates too */
        const int32_t bx = px >= 0 ? px / 4 : -((-px + 3) / 4), by = py >= 0 ? py / 4 : -((-py + 3) / 4);
        v[k] = (double)(hash3(bx, by, s->seed) & 0xFFu);
    }
    return (1 - ay) * ((1 - ax) * v[0] + ax * v[1]) + ay * ((1 - ax) * v[2] + ax * v[3]);
}

static void render(const scene *s, double dx, double dy, double zoom, uint8_t *img)
{
    const double cx = 0.5 * (s->w - 1), cy = 0.5 * (s->h - 1);
    for (int32_t y = 0; y < s->h; ++y)
        for (int32_t x = 0; x < s->w; ++x) {
            double v = texture(s, cx + (x - cx) * zoom + dx + 1000.0, cy + (y - cy) * zoom + dy + 1000.0);
            img[(size_t)y * (size_t)s->w + (size_t)x] = (uint8_t)(v + 0.5);
        }
}

static int is_identity(const tvo_pose *T)
{
    static const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    return memcmp(T->R, I, sizeof I) == 0 && T->t[0] == 0.0 && T->t[1] == 0.0 && T->t[2] == 0.0;
}

static void check_result(const tvo_vo_config *cfg, const tvo_vo_result *r)
{
    const tvo_pose *T = &r->T_prev_cur;
    TVO_FUZZ_CHECK((int)r->state >= 0 && (int)r->state < (int)TVO_VO_STATE_COUNT);
    TVO_FUZZ_CHECK(tvo_pose_is_finite(T));
    TVO_FUZZ_CHECK(tvo_rot_orthogonality_error(T->R) < 1e-6);
    TVO_FUZZ_CHECK(tvo_fuzz_status_valid(r->pose_status));
    switch (r->state) {
    case TVO_VO_OK: {
        const double n = sqrt(T->t[0] * T->t[0] + T->t[1] * T->t[1] + T->t[2] * T->t[2]);
        TVO_FUZZ_CHECK(fabs(n - 1.0) < 1e-6);
        break;
    }
    case TVO_VO_ROTATION_ONLY:
        TVO_FUZZ_CHECK(T->t[0] == 0.0 && T->t[1] == 0.0 && T->t[2] == 0.0);
        break;
    default:
        TVO_FUZZ_CHECK(is_identity(T));
        break;
    }
    TVO_FUZZ_CHECK(r->tracked >= 0 && r->tracked <= cfg->max_tracks);
    TVO_FUZZ_CHECK(r->inliers >= 0 && r->inliers <= r->tracked);
    TVO_FUZZ_CHECK(r->new_corners >= 0 && r->new_corners <= cfg->max_tracks);
    TVO_FUZZ_CHECK(r->tracks >= 0 && r->tracks <= cfg->max_tracks);
    TVO_FUZZ_CHECK(r->map_refound >= 0 && r->map_refound <= r->tracks &&
                   (cfg->map_refind > 0 || r->map_refound == 0));
    TVO_FUZZ_CHECK(isfinite(r->parallax_deg) && r->parallax_deg >= 0.0);
    TVO_FUZZ_CHECK(r->dt_ns >= 0);
    for (int i = 0; i < TVO_FEAT_COUNT; ++i)
        TVO_FUZZ_CHECK(isfinite(r->features[i]));
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    tvo_fuzz_reader rd = {data, size, 0};
    tvo_camera cam;
    tvo_vo_config cfg;
    scene sc;
    uint8_t hdr[8], *img, *prev, *strided;
    size_t need, npix;
    void *mem;
    tvo_vo *vo = NULL;
    tvo_traj traj;
    int64_t t = 1000000000, t_prev = 0;
    int has_prev = 0;
    const int verbose = getenv("TVO_FUZZ_VERBOSE") != NULL; /* per-frame states on stderr */

    for (int i = 0; i < 8; ++i)
        hdr[i] = tvo_fuzz_u8(&rd);
    sc.w = 16 + hdr[0] % 81;
    sc.h = 16 + hdr[1] % 81;
    sc.seed = hdr[6];
    {
        const double f = 30.0 + 8.0 * (hdr[2] >> 2), s = (double)(int8_t)hdr[3];
        cam = tvo_camera_make_pinhole(sc.w, sc.h, f, f * 1.01, 0.5 * sc.w + 0.3, 0.5 * sc.h - 0.2);
        switch (hdr[2] & 3u) {
        case 1:
            cam.model = TVO_DIST_RADTAN;
            cam.k[0] = s / 256.0;
            cam.k[1] = -0.3 * s / 256.0;
            cam.k[2] = s / 65536.0;
            cam.k[3] = -s / 65536.0;
            break;
        case 2:
            cam.model = TVO_DIST_EQUIDISTANT;
            cam.k[0] = s / 512.0;
            cam.k[1] = s / 4096.0;
            break;
        default:
            break;
        }
    }
    tvo_vo_config_default(&cfg, &cam);
    cfg.track_prediction = (hdr[0] / 81) & 1; /* hdr[0]'s bits above the width's */
    /* the bundle adjustment's turn check: for about a third of the inputs a bound that refuses every
       adjustment that turns the newest keyframe at all */
    cfg.map_ba_max_turn_deg = ((hdr[0] / 81) & 2) ? 1e-6 : 0.5;
    /* the affine refinement for half the inputs (hdr[1]'s bits above the height's), windows 3..17 */
    cfg.affine_win_size = TVO_WITH_AFFINE && ((hdr[1] / 81) & 1) ? 3 + 2 * (int32_t)(hdr[3] & 7u) : 0;
    /* ...sampled every other pixel when the half window allows it, for half of those */
    cfg.affine_step = ((hdr[3] >> 3) & 1) && (cfg.affine_win_size / 2) % 2 == 0 ? 2 : 1;
    /* ...and at the map's keyframes only (its refine hook) for half of all inputs */
    cfg.affine_at_keyframes = (hdr[3] >> 4) & 1;
    /* the smaller first map after a wait: none, a wait of 0.1 s (a few frames), or of 1 s */
    cfg.map_init_wait_s = ((hdr[3] >> 5) & 3u) == 1 ? 0.1 : (((hdr[3] >> 5) & 3u) == 2 ? 1.0 : 0.0);
    cfg.max_tracks = 16 + hdr[4];
    cfg.min_tracks = cfg.max_tracks * 2 / 3;
    cfg.min_pose_tracks = 8 + hdr[4] % 23;
    if (cfg.min_pose_tracks > cfg.max_tracks)
        cfg.min_pose_tracks = cfg.max_tracks;
    cfg.detect.fast_threshold = 4 * (hdr[5] >> 2);
    /* small frames: finer bucketing grid, thinner border and spacing than the 752x480 defaults */
    cfg.detect.grid_cols = 1 + (hdr[7] >> 4) % 8;
    cfg.detect.grid_rows = 1 + (hdr[7] >> 4) % 6;
    cfg.detect.border = 3 + (hdr[7] >> 7) * 5;
    cfg.detect.min_distance = (float)((hdr[7] >> 4) & 7);
    cfg.lk.win_size = 5 + 4 * (hdr[7] & 7u);
    cfg.lk.force_portable = (hdr[7] >> 3) & 1;
    cfg.lk.max_level = hdr[5] & 3;
    /* the map's predicted tracks (the balanced preset's way) for half the inputs: from the landmarks
       alone or with their neighbours' depths, on 1 or 2 levels with 11x11 windows, the lost ones tracked
       again or not, each lost one or, after a frame that loses more than half, all of them (the rescue) */
    cfg.map_prediction = ((hdr[1] / 81) & 2) ? 1 + (int32_t)((hdr[3] >> 7) & 1u) : 0;
    cfg.lk.pred_levels = 1 + (int32_t)((hdr[3] >> 6) & 1u);
    cfg.lk.pred_win_size = 11;
    cfg.lk.pred_retry = (hdr[6] >> 1) & 1;
    /* the rescue: a bit of the retry's and of the FAST threshold's */
    cfg.pred_rescue = ((hdr[6] >> 1) ^ (hdr[5] >> 7)) & 1;
    /* the local map: on for three inputs in four, with windows of 3..6 keyframes and landmark capacities
       from below to above the track count (header byte 6's bits, beside the scene seed) */
    cfg.map = (hdr[6] & 3u) != 0;
    cfg.map_window = 3 + (int32_t)((hdr[6] >> 2) & 3u);
    cfg.map_ba_fixed = 2; /* the smallest valid for every window here (the default, 4, needs 5 or more) */
    cfg.map_max_landmarks = 16 + (int32_t)(hdr[4] * ((hdr[6] >> 4) & 3u));
    cfg.map_min_points = 6 + (int32_t)((hdr[6] >> 6) * 4u);
    /* the bundle adjustment's options: the two-view rotations as priors between keyframes (weight 100)
       for half the inputs, a 0.5 px Huber width for another half (bits of the track count's and the
       window's bytes) */
    cfg.map_ba_rot_prior = ((hdr[4] >> 1) ^ (hdr[7] >> 6)) & 1 ? 100.0 : 0.0;
    cfg.map_ba_huber_px = ((hdr[4] >> 2) ^ (hdr[7] >> 5)) & 1 ? 0.5 : 2.5;
    /* the chain's steps following the relative scale (beyond 3 standard errors, or every change) */
    cfg.chain_scale_sigmas = ((hdr[4] >> 3) ^ (hdr[7] >> 4)) & 1 ? (((hdr[5] & 1) != 0) ? 3.0 : 1e-9) : 0.0;
    /* landmarks found again, with the map and the affine refinement, for half of those inputs: stores of
       1..16 entries, so that the ring wraps */
    cfg.map_refind = cfg.map && cfg.affine_win_size > 0 && (((hdr[4] >> 4) ^ (hdr[7] >> 3)) & 1)
            ? 1 + (int32_t)(hdr[5] & 15u)
            : 0;
    cfg.map_refind_rescue = (hdr[5] >> 4) & 1; /* ...looking on every frame or only when the map runs short */
    cfg.map_rot_prior_obs = ((hdr[6] >> 2) ^ (hdr[5] >> 5)) & 1
            ? 3
            : 0; /* a weak prior judged by checked landmarks */
    cfg.map_rot_prior_obs_frames = ((hdr[4] >> 5) ^ (hdr[6] >> 3)) & 1 ? 1 + (int32_t)(hdr[5] & 31u)
                                                                       : 0; /* ...after a jerk */
    /* the lens refined on the run, with the map, for half the inputs */
    cfg.lens_refine = TVO_WITH_LENS && cfg.map && (((hdr[4] >> 6) ^ (hdr[7] >> 2)) & 1);
    /* the map's inlier gate at 4 sigmas, or a near-zero one that the 0.5 px floor holds, for half the inputs
       of a build that has it */
    cfg.map_inlier_sigmas = TVO_WITH_AFFINE && (((hdr[4] >> 7) ^ (hdr[6] >> 1)) & 1)
            ? ((hdr[5] >> 6) & 1 ? 1e-9 : 4.0)
            : 0.0;
    /* the landmarks' priors, full or faint, for half the inputs of a build that has them */
    cfg.map_lm_prior = TVO_WITH_AFFINE && cfg.map && (((hdr[5] >> 7) ^ (hdr[7] >> 3)) & 1)
            ? ((hdr[6] >> 7) & 1 ? 1.0 : 1e-12)
            : 0.0;
    /* their gate at the default 2 times the median, or one that its 0.1 px floor holds */
    cfg.map_lm_prior_gate = ((hdr[6] >> 6) ^ (hdr[5] >> 5)) & 1 ? 1e-9 : 2.0;
    while ((need = tvo_vo_required_size(&cfg)) == 0 && cfg.lk.max_level > 0)
        cfg.lk.max_level--;
    TVO_FUZZ_CHECK(need > 0); /* every size from 16x16 up is valid with one level */
    mem = malloc(need);
    npix = (size_t)sc.w * (size_t)sc.h;
    img = (uint8_t *)calloc(npix, 1);
    prev = (uint8_t *)calloc(npix, 1);
    strided = (uint8_t *)malloc((size_t)(sc.w + 7) * (size_t)sc.h);
    if (mem == NULL || img == NULL || prev == NULL || strided == NULL)
        goto out;
    TVO_FUZZ_CHECK(tvo_vo_init(&vo, &cfg, mem, need - 1) == TVO_ERR_NO_MEMORY && vo == NULL);
    TVO_FUZZ_CHECK(tvo_vo_init(&vo, &cfg, mem, need) == TVO_OK && vo != NULL);
    tvo_traj_init(&traj, NULL);

    for (int f = 0; f < MAX_FRAMES && tvo_fuzz_left(&rd) > 0; ++f) {
        const uint8_t op = tvo_fuzz_u8(&rd);
        const int32_t stride = sc.w + (op >> 5);
        tvo_vo_result res;
        tvo_status st;
        int expect_arg;
        switch (op & 3u) {
        case 0:
            memset(img, 0, npix);
            for (size_t i = 0; i < npix && tvo_fuzz_left(&rd) > 0; ++i)
                img[i] = tvo_fuzz_u8(&rd);
            break;
        case 1: {
            const double dx = (int8_t)tvo_fuzz_u8(&rd) / 16.0, dy = (int8_t)tvo_fuzz_u8(&rd) / 16.0;
            const double zoom = 1.0 + (int8_t)tvo_fuzz_u8(&rd) / 512.0;
            render(&sc, dx, dy, zoom, img);
            break;
        }
        case 2: {
            const int n = tvo_fuzz_u8(&rd);
            memcpy(img, prev, npix);
            for (int i = 0; i < n; ++i) {
                const uint32_t pos = tvo_fuzz_u8(&rd) | (uint32_t)tvo_fuzz_u8(&rd) << 8;
                img[pos % npix] = tvo_fuzz_u8(&rd);
            }
            break;
        }
        default:
            memset(img, tvo_fuzz_u8(&rd), npix);
            break;
        }
        switch ((op >> 2) & 3u) {
        case 0:
            t = (int64_t)((uint64_t)t + 50000000u);
            break;
        case 1:
            t = (int64_t)((uint64_t)t +
                          1000u * (uint64_t)(tvo_fuzz_u8(&rd) | (uint32_t)tvo_fuzz_u8(&rd) << 8));
            break;
        case 2: {
            uint64_t u = tvo_fuzz_u32(&rd);
            u |= (uint64_t)tvo_fuzz_u32(&rd) << 32;
            t = (int64_t)u; /* two's complement on every target we build for */
            break;
        }
        default:
            t = (int64_t)((uint64_t)t - (uint64_t)(tvo_fuzz_u8(&rd) | (uint32_t)tvo_fuzz_u8(&rd) << 8));
            break;
        }
        if (op & 16u) {
            tvo_vo_reset(vo);
            has_prev = 0;
        }
        for (int32_t y = 0; y < sc.h; ++y) {
            memcpy(strided + (size_t)y * (size_t)stride, img + (size_t)y * (size_t)sc.w, (size_t)sc.w);
            memset(strided + (size_t)y * (size_t)stride + sc.w, 0xA5, (size_t)(stride - sc.w));
        }
        {
            const tvo_image frame = tvo_image_make(sc.w, sc.h, stride, strided);
            expect_arg = has_prev && t <= t_prev;
            st = tvo_vo_process(vo, &frame, t, &res);
        }
        if (expect_arg) {
            TVO_FUZZ_CHECK(st == TVO_ERR_ARG);
            TVO_FUZZ_CHECK(res.state == TVO_VO_LOST && is_identity(&res.T_prev_cur));
        } else {
            TVO_FUZZ_CHECK(st == TVO_OK);
            check_result(&cfg, &res);
            if (verbose)
                fprintf(stderr, "fuzz_vo: %dx%d frame %d t=%lld state %d tracked %d inliers %d tracks %d\n",
                        sc.w, sc.h, f, (long long)t, (int)res.state, res.tracked, res.inliers, res.tracks);
            has_prev = 1;
            t_prev = t;
            st = tvo_traj_step(&traj, &res.T_prev_cur, res.state == TVO_VO_OK ? 1.0 : 0.0);
            TVO_FUZZ_CHECK(st == TVO_OK && tvo_pose_is_finite(&traj.T_w_c));
        }
        memcpy(prev, img, npix);
    }
out:
    free(strided);
    free(prev);
    free(img);
    free(mem);
    return 0;
}
