/* SPDX-License-Identifier: Apache-2.0 */
/* Determinism across targets: the same synthetic input gives bit-identical corners, tracks, camera
 * undistortion, relative poses, network outputs and VO poses on x86-64, aarch64 and armhf.
 *
 * A 24-frame sequence of the textured box room (test/common/tvo_room.h) is rendered here with poses made
 * from + - * / and sqrt only (no libm transcendentals, so the input itself is identical everywhere).
 * Each stage is run on its own fixed input and hashed (64-bit FNV-1a over the exact bit patterns of its
 * outputs, serialised little-endian; every NaN hashed as one canonical value), and each digest is
 * compared with the value checked in below:
 *
 *   input      the rendered frames (a change here means the test itself changed)
 *   corners    tvo_detect (FAST-9 + Shi-Tomasi/Harris + bucketing) on every 4th frame
 *   tracks     pyramids + tvo_lk_track (forward-backward) of frame k's corners into frame k+1, k even
 *   undistort  tvo_camera_undistort of those corners with an EuRoC-like radtan and a fisheye camera
 *   relpose    tvo_relpose_estimate on the tracked pairs (pinhole)
 *   nn         tvo_nn_run of test/data/nn/paper.tvonn (6 branches) on generated feature vectors
 *   vo         the whole tvo_vo_process over the sequence: states, counts, raw relative poses, features,
 *              and the trajectory integrated with ground-truth step lengths
 *   map        the same run's world poses and what the local map did
 *   refind     the same sequence with a flat bar over most of two frames: the map short of points, the
 *              landmarks of the ended tracks found again by their templates (the default's rescue)
 *   lens       the lens refinement's block of a noisy window (test/common/tvo_lens_scene.h) and the
 *              adoption test on it (builds with TVO_WITH_LENS)
 *   ba_prior   the bundle adjustment of that window with one camera's observations as point priors
 *              (tvo_ba_point_prior_add; cfg.map_lm_prior's path, builds with TVO_WITH_AFFINE)
 *   vo_prior   the room sequence with a short window, the landmarks' priors and their gate
 *              (cfg.map_lm_prior, map_lm_prior_gate; builds with TVO_WITH_AFFINE)
 *
 * The stages upstream of a change keep their digests: a relative-pose change moves `relpose` and `vo`,
 * a VO change only `vo`, a tracker change `tracks`, `relpose` and `vo`. When an intended change moves a
 * digest, the failure message prints the new value: paste it into the EXPECTED DIGESTS block, and run
 * tools/run-cross.sh to confirm aarch64 and armhf agree (docs/ports.md, "Determinism across targets").
 * TVO_DETERMINISM_VERBOSE=1 prints a digest per frame / item, to diff two targets' output and find the
 * first item that differs. */
#include "tvo_test.h"

#include <math.h>

#include "tinyvo/tinyvo.h"
#include "tvo_room.h"
#if TVO_WITH_LENS
#include "tvo_lens.h"
#endif
#include "tvo_lens_scene.h" /* the lens stage's window, and the ba_prior stage's */

/* ==== EXPECTED DIGESTS: the one block to update when an intended algorithm change moves a digest ==== */
#define EXPECT_INPUT 0x6d857fe5cc926e22ULL
#define EXPECT_CORNERS 0x70955b5fe38f147bULL
#define EXPECT_TRACKS 0x3c025d200a047acbULL
#define EXPECT_UNDISTORT 0x766733049b5c9f1cULL
#define EXPECT_RELPOSE 0x738ab310f9910f06ULL
#define EXPECT_NN 0x7780412f62c17499ULL
/* the VO and the map with the defaults: the balanced preset's tracker, or the basic preset's in a build
   without the affine refinement (TVO_WITH_AFFINE 0) */
#if TVO_WITH_AFFINE
#define EXPECT_VO 0xb5edd1663c767326ULL
#define EXPECT_MAP 0xd78c0f2b5143e3ceULL
#define EXPECT_REFIND 0x6f534d86e3b6f473ULL
#else
#define EXPECT_VO 0xca2d97807cbf5eabULL
#define EXPECT_MAP 0x6019563258239bf5ULL
#define EXPECT_REFIND 0x52168ec1eae3de0eULL
#endif
#define EXPECT_LENS 0xbe0451d01a103c0eULL
#define EXPECT_BA_PRIOR 0x82ddecdb2ce7654aULL
#define EXPECT_VO_PRIOR 0xeede9bb74f7dcadeULL
/* ==== end of EXPECTED DIGESTS ==== */

#define W 320
#define H 240
#define FOCAL 250.0
#define FRAMES 24

/* ---- 64-bit FNV-1a over explicitly serialised values (little-endian, independent of the host) ---- */
typedef struct digest {
    uint64_t h;
} digest;

static void dg_init(digest *d)
{
    d->h = 0xcbf29ce484222325ULL;
}

static void dg_bytes(digest *d, const uint8_t *p, size_t n)
{
    for (size_t i = 0; i < n; ++i) {
        d->h ^= p[i];
        d->h *= 0x100000001b3ULL;
    }
}

static void dg_u64(digest *d, uint64_t v)
{
    uint8_t b[8];
    for (int i = 0; i < 8; ++i)
        b[i] = (uint8_t)(v >> (8 * i));
    dg_bytes(d, b, 8);
}

static void dg_i32(digest *d, int32_t v)
{
    dg_u64(d, (uint64_t)(uint32_t)v);
}

/* NaN payloads and signs differ between x86 and ARM when NaNs come from arithmetic: hash them as one. */
static void dg_f32(digest *d, float v)
{
    uint32_t u;
    if (isnan(v))
        u = 0x7fc00000u;
    else
        memcpy(&u, &v, sizeof(u));
    dg_u64(d, u);
}

static void dg_f64(digest *d, double v)
{
    uint64_t u;
    if (isnan(v))
        u = 0x7ff8000000000000ULL;
    else
        memcpy(&u, &v, sizeof(u));
    dg_u64(d, u);
}

static void dg_pose(digest *d, const tvo_pose *T)
{
    for (int i = 0; i < 9; ++i)
        dg_f64(d, T->R[i]);
    for (int i = 0; i < 3; ++i)
        dg_f64(d, T->t[i]);
}

static int verbose(void)
{
    const char *v = getenv("TVO_DETERMINISM_VERBOSE");
    return v != NULL && v[0] != '\0' && v[0] != '0';
}

/* Per-item trace (verbose only): the running digest after each item, to diff between targets. */
static void trace(const char *stage, int item, const digest *d)
{
    if (verbose())
        printf("trace %-9s %3d %016llx\n", stage, item, (unsigned long long)d->h);
}

static int check_digest(const char *stage, const char *macro, uint64_t got, uint64_t expected)
{
    printf("digest %-9s 0x%016llxULL\n", stage, (unsigned long long)got);
    if (got == expected)
        return 1;
    fprintf(stderr,
            "determinism: stage '%s' digest 0x%016llxULL differs from the checked-in 0x%016llxULL.\n"
            "  If an intended algorithm change moved it, set %s to 0x%016llxULL in the EXPECTED DIGESTS\n"
            "  block of test/unit/test_determinism.c and run tools/run-cross.sh (aarch64 + armhf must "
            "agree).\n"
            "  If nothing in that stage changed, this target computes differently: see docs/ports.md.\n",
            stage, (unsigned long long)got, (unsigned long long)expected, macro, (unsigned long long)got);
    return 0;
}

/* ---- the synthetic sequence --------------------------------------------------------------------- */

/* Camera pose of frame k, from arithmetic and sqrt only: a rotation from a normalised quaternion
 * (yaw growing linearly, a triangle-wave wobble in pitch and roll) and a translation along a slanted
 * line with a parabolic bump in height. */
static tvo_pose seq_pose(int k)
{
    tvo_pose T;
    const double tri = (double)((k % 8) < 4 ? (k % 8) : 8 - (k % 8)) / 4.0 - 0.5; /* -0.5 .. 0.5 */
    double q[4] = {1.0, 0.004 * tri, 0.0035 * k, 0.003 * tri}; /* w x y z, half-angles in rad */
    const double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    double w, x, y, z;
    for (int i = 0; i < 4; ++i)
        q[i] /= n;
    w = q[0], x = q[1], y = q[2], z = q[3];
    T.R[0] = 1 - 2 * (y * y + z * z), T.R[1] = 2 * (x * y - w * z), T.R[2] = 2 * (x * z + w * y);
    T.R[3] = 2 * (x * y + w * z), T.R[4] = 1 - 2 * (x * x + z * z), T.R[5] = 2 * (y * z - w * x);
    T.R[6] = 2 * (x * z - w * y), T.R[7] = 2 * (y * z + w * x), T.R[8] = 1 - 2 * (x * x + y * y);
    T.t[0] = 0.045 * k - 0.6;
    T.t[1] = 0.0004 * (k - 16) * (k - 16) - 0.1;
    T.t[2] = 0.03 * k - 0.5;
    return T;
}

static tvo_camera pinhole(void)
{
    return tvo_camera_make_pinhole(W, H, FOCAL, FOCAL, (W - 1) / 2.0, (H - 1) / 2.0);
}

/* tracked corner pairs of frames k -> k+1 */
typedef struct tracked_pairs {
    tvo_point2f p1[FRAMES - 1][300], p2[FRAMES - 1][300];
    int32_t n[FRAMES - 1];
} tracked_pairs;

typedef struct seq {
    uint8_t img[FRAMES][W * H];
    tvo_pose gt[FRAMES];
    /* corners of every frame (default detector), the input of the tracking stage */
    tvo_corner corners[FRAMES][300];
    int32_t ncorners[FRAMES];
    tracked_pairs pairs; /* filled by the tracks stage */
    int pairs_done;
} seq;

static tvo_status detect_default(const uint8_t *pixels, tvo_score_kind kind, tvo_corner *out, int32_t cap,
                                 int32_t *count)
{
    tvo_detect_config cfg;
    tvo_image img = tvo_image_make(W, H, W, (uint8_t *)pixels);
    size_t need;
    void *scratch;
    tvo_status st;
    tvo_detect_config_default(&cfg);
    cfg.score = kind;
    need = tvo_detect_scratch_size(&cfg, W, H);
    scratch = malloc(need);
    if (scratch == NULL)
        return TVO_ERR_NO_MEMORY;
    st = tvo_detect(&cfg, &img, NULL, 0, out, cap, count, scratch, need);
    free(scratch);
    return st;
}

static int group_setup(void **state)
{
    seq *s = calloc(1, sizeof(seq));
    if (s == NULL)
        return -1;
    for (int k = 0; k < FRAMES; ++k) {
        s->gt[k] = seq_pose(k);
        tvo_room_render(&s->gt[k], W, H, FOCAL, s->img[k]);
        if (detect_default(s->img[k], TVO_SCORE_SHI_TOMASI, s->corners[k], 300, &s->ncorners[k]) != TVO_OK)
            return -1;
    }
    *state = s;
    return 0;
}

static int group_teardown(void **state)
{
    free(*state);
    return 0;
}

/* ---- stages --------------------------------------------------------------------------------------- */

static void test_input(void **state)
{
    seq *s = *state;
    digest d;
    dg_init(&d);
    for (int k = 0; k < FRAMES; ++k) {
        dg_bytes(&d, s->img[k], W * H);
        trace("input", k, &d);
    }
    assert_true(check_digest("input", "EXPECT_INPUT", d.h, EXPECT_INPUT));
}

static void test_corners(void **state)
{
    seq *s = *state;
    digest d;
    dg_init(&d);
    for (int k = 0; k < FRAMES; k += 4) {
        tvo_corner harris[300];
        int32_t nh = 0;
        assert_true(s->ncorners[k] > 150); /* a textured room: plenty of corners */
        dg_i32(&d, s->ncorners[k]);
        for (int i = 0; i < s->ncorners[k]; ++i) {
            dg_f32(&d, s->corners[k][i].x);
            dg_f32(&d, s->corners[k][i].y);
            dg_f32(&d, s->corners[k][i].score);
        }
        assert_int_equal(detect_default(s->img[k], TVO_SCORE_HARRIS, harris, 300, &nh), TVO_OK);
        assert_true(nh > 150);
        dg_i32(&d, nh);
        for (int i = 0; i < nh; ++i) {
            dg_f32(&d, harris[i].x);
            dg_f32(&d, harris[i].y);
            dg_f32(&d, harris[i].score);
        }
        trace("corners", k, &d);
    }
    assert_true(check_digest("corners", "EXPECT_CORNERS", d.h, EXPECT_CORNERS));
}

/* Track frame k's corners into frame k+1 for every even k (default LK, forward-backward check), hash
 * the results, and keep the tracked pairs (pixels) for the relpose stage. */
static void run_tracks(seq *s, digest *d, tracked_pairs *tp)
{
    const int levels = 4;
    size_t pyr_need = tvo_pyramid_required_size(W, H, levels);
    void *m0 = malloc(pyr_need), *m1 = malloc(pyr_need);
    tvo_pyramid pa, pb;
    tvo_pyramid *const prev = &pa, *const next = &pb;
    tvo_lk_config cfg;
    size_t lk_need;
    void *scratch;
    tvo_lk_config_default(&cfg);
    cfg.fb_check = 1;
    lk_need = tvo_lk_scratch_size(&cfg);
    scratch = malloc(lk_need);
    assert_non_null(m0);
    assert_non_null(m1);
    assert_non_null(scratch);
    assert_int_equal(tvo_pyramid_init(&pa, W, H, levels, m0, pyr_need), TVO_OK);
    assert_int_equal(tvo_pyramid_init(&pb, W, H, levels, m1, pyr_need), TVO_OK);
    for (int k = 0; k + 1 < FRAMES; k += 2) {
        tvo_point2f pts[300], nxt[300];
        uint8_t status[300];
        float err[300];
        int32_t n = s->ncorners[k], good = 0;
        tvo_image img0 = tvo_image_make(W, H, W, s->img[k]), img = tvo_image_make(W, H, W, s->img[k + 1]);
        assert_int_equal(tvo_pyramid_build(prev, &img0), TVO_OK);
        assert_int_equal(tvo_pyramid_build(next, &img), TVO_OK);
        if (k == 0) { /* the pyramid itself, once: every level's pixels */
            for (int l = 0; l < levels; ++l)
                for (int y = 0; y < next->height[l]; ++y)
                    dg_bytes(d, next->data[l] + (size_t)y * (size_t)next->stride[l], (size_t)next->width[l]);
        }
        for (int i = 0; i < n; ++i) {
            pts[i].x = s->corners[k][i].x;
            pts[i].y = s->corners[k][i].y;
        }
        assert_int_equal(tvo_lk_track(&cfg, prev, next, pts, nxt, status, err, n, scratch, lk_need), TVO_OK);
        dg_i32(d, n);
        for (int i = 0; i < n; ++i) {
            dg_i32(d, status[i]);
            if (status[i] == TVO_LK_TRACKED) {
                dg_f32(d, nxt[i].x);
                dg_f32(d, nxt[i].y);
                dg_f32(d, err[i]);
                if (tp != NULL) {
                    tp->p1[k][good] = pts[i];
                    tp->p2[k][good] = nxt[i];
                }
                ++good;
            }
        }
        assert_true(good > n / 2); /* smooth motion: most corners survive */
        if (tp != NULL)
            tp->n[k] = good;
        trace("tracks", k, d);
    }
    free(m0);
    free(m1);
    free(scratch);
}

static void test_tracks(void **state)
{
    seq *s = *state;
    digest d;
    dg_init(&d);
    run_tracks(s, &d, &s->pairs);
    s->pairs_done = 1;
    assert_true(check_digest("tracks", "EXPECT_TRACKS", d.h, EXPECT_TRACKS));
}

static void test_undistort(void **state)
{
    seq *s = *state;
    /* EuRoC cam0-like radial-tangential, and an equidistant (fisheye) model of the same size */
    tvo_camera cams[2];
    digest d;
    cams[0] = pinhole();
    cams[0].model = TVO_DIST_RADTAN;
    cams[0].k[0] = -0.28340811, cams[0].k[1] = 0.07395907, cams[0].k[2] = 0.00019359,
    cams[0].k[3] = 1.76187114e-05;
    cams[1] = pinhole();
    cams[1].model = TVO_DIST_EQUIDISTANT;
    cams[1].k[0] = -0.013, cams[1].k[1] = 0.021, cams[1].k[2] = -0.017, cams[1].k[3] = 0.0045;
    dg_init(&d);
    for (int c = 0; c < 2; ++c) {
        for (int k = 0; k < FRAMES; k += 8) {
            tvo_point2f px[300], back[300];
            tvo_point2d xn[300];
            uint8_t ok[300];
            int32_t n = s->ncorners[k], nok = 0;
            for (int i = 0; i < n; ++i) {
                px[i].x = s->corners[k][i].x;
                px[i].y = s->corners[k][i].y;
            }
            assert_int_equal(tvo_camera_undistort(&cams[c], px, xn, ok, n), TVO_OK);
            for (int i = 0; i < n; ++i) {
                dg_i32(&d, ok[i]);
                if (ok[i]) {
                    dg_f64(&d, xn[i].x);
                    dg_f64(&d, xn[i].y);
                    back[nok] = px[i];
                    xn[nok++] = xn[i];
                }
            }
            assert_true(nok > n * 9 / 10);
            /* and back to pixels: a round trip within 1e-3 px */
            {
                tvo_point2f rp[300];
                assert_int_equal(tvo_camera_distort(&cams[c], xn, rp, nok), TVO_OK);
                for (int i = 0; i < nok; ++i) {
                    dg_f32(&d, rp[i].x);
                    dg_f32(&d, rp[i].y);
                    assert_true(fabsf(rp[i].x - back[i].x) < 1e-3f && fabsf(rp[i].y - back[i].y) < 1e-3f);
                }
            }
            trace("undistort", c * FRAMES + k, &d);
        }
    }
    assert_true(check_digest("undistort", "EXPECT_UNDISTORT", d.h, EXPECT_UNDISTORT));
}

static void test_relpose(void **state)
{
    seq *s = *state;
    tracked_pairs *tp = &s->pairs;
    const tvo_camera cam = pinhole();
    tvo_relpose_config cfg;
    size_t need = tvo_relpose_scratch_size(300);
    void *scratch = malloc(need);
    digest d, dt;
    int ok_pairs = 0, pairs = 0;
    assert_non_null(scratch);
    if (!s->pairs_done) { /* run alone: track first (the tracks digest is checked by test_tracks) */
        dg_init(&dt);
        run_tracks(s, &dt, tp);
        s->pairs_done = 1;
    }
    tvo_relpose_config_default(&cfg);
    cfg.threshold = 1.0 / FOCAL;
    dg_init(&d);
    for (int k = 0; k + 1 < FRAMES; k += 2) {
        tvo_point2d x1[300], x2[300];
        uint8_t mask[300];
        tvo_relpose rp;
        tvo_status st;
        const int32_t n = tp->n[k];
        for (int i = 0; i < n; ++i) {
            assert_int_equal(tvo_camera_undistort_point(&cam, tp->p1[k][i].x, tp->p1[k][i].y, &x1[i]),
                             TVO_OK);
            assert_int_equal(tvo_camera_undistort_point(&cam, tp->p2[k][i].x, tp->p2[k][i].y, &x2[i]),
                             TVO_OK);
        }
        st = tvo_relpose_estimate(&cfg, x1, x2, n, &rp, mask, scratch, need);
        dg_i32(&d, st);
        dg_i32(&d, rp.inliers);
        dg_i32(&d, rp.flags);
        dg_i32(&d, rp.iterations);
        dg_f64(&d, rp.parallax_deg);
        for (int i = 0; i < 9; ++i)
            dg_f64(&d, rp.R[i]);
        for (int i = 0; i < 3; ++i)
            dg_f64(&d, rp.t[i]);
        for (int i = 0; i < n; ++i)
            dg_i32(&d, mask[i]);
        if (st == TVO_OK) {
            /* rotation within 0.5 deg of the truth (T_prev_cur of the rendered poses: X2 = R X1 + t) */
            tvo_pose rel = tvo_pose_relative(&s->gt[k + 1], &s->gt[k]);
            double tr = 0.0;
            for (int i = 0; i < 3; ++i)
                for (int j = 0; j < 3; ++j)
                    tr += rp.R[3 * i + j] * rel.R[3 * i + j];
            if (tr > 1.0 + 2.0 * (1.0 - 3.8e-5)) /* cos(0.5 deg) = 1 - 3.8e-5 */
                ++ok_pairs;
        }
        ++pairs;
        trace("relpose", k, &d);
    }
    assert_true(ok_pairs >= pairs * 8 / 10);
    free(scratch);
    assert_true(check_digest("relpose", "EXPECT_RELPOSE", d.h, EXPECT_RELPOSE));
}

static void test_nn(void **state)
{
    size_t fsize = 0, need = 0;
    void *file = tvo_test_read_nn_file("paper.tvonn", 0, &fsize), *mem;
    tvo_nn *nn = NULL;
    uint64_t rs = 0x6a09e667f3bcc909ULL;
    digest d;
    int32_t mask;
    (void)state;
    if (file == NULL)
        fail_msg("cannot read test/data/nn/paper.tvonn (TVO_SOURCE_DIR=%s)", getenv("TVO_SOURCE_DIR"));
    assert_int_equal(tvo_nn_required_size(file, fsize, &need), TVO_OK);
    mem = malloc(need);
    assert_non_null(mem);
    assert_int_equal(tvo_nn_load(&nn, file, fsize, mem, need), TVO_OK);
    mask = tvo_nn_output_mask(nn);
    assert_true(mask != 0);
    dg_init(&d);
    dg_i32(&d, mask);
    for (int v = 0; v < 512; ++v) {
        float f[TVO_FEAT_COUNT], out[6];
        /* features in and beyond their usual ranges (exercises saturation), as exact binary fractions */
        for (int i = 0; i < TVO_FEAT_COUNT; ++i) {
            const int32_t r = (int32_t)(tvo_test_rand(&rs) >> 44) - (1 << 19); /* [-2^19, 2^19) */
            f[i] = (float)r / (float)(1 << 17);                                /* [-4, 4) */
        }
        assert_int_equal(tvo_nn_run(nn, f, out), TVO_OK);
        for (int i = 0; i < 6; ++i) {
            assert_true(((mask >> i) & 1) ? isfinite(out[i]) : isnan(out[i]));
            dg_f32(&d, out[i]);
        }
        if ((v & 63) == 63)
            trace("nn", v, &d);
    }
    free(mem);
    free(file);
    assert_true(check_digest("nn", "EXPECT_NN", d.h, EXPECT_NN));
}

/* A VO with cfg in memory of its own (returned: the caller frees it). */
static void *open_vo(const tvo_vo_config *cfg, tvo_vo **vo)
{
    const size_t need = tvo_vo_required_size(cfg);
    void *mem = malloc(need);
    assert_non_null(mem);
    assert_int_equal(tvo_vo_init(vo, cfg, mem, need), TVO_OK);
    return mem;
}

/* The default VO for the pinhole camera, in memory the caller frees. */
static void *open_default_vo(tvo_vo **vo)
{
    const tvo_camera cam = pinhole();
    tvo_vo_config cfg;
    tvo_vo_config_default(&cfg, &cam);
    return open_vo(&cfg, vo);
}

static void test_vo(void **state)
{
    seq *s = *state;
    tvo_vo *vo = NULL;
    void *mem = open_default_vo(&vo);
    tvo_traj traj;
    digest d, dm;
    int ok_frames = 0, map_frames = 0;
    tvo_traj_init(&traj, &s->gt[0]);
    dg_init(&d);
    dg_init(&dm);
    for (int k = 0; k < FRAMES; ++k) {
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, s->img[k]);
        assert_int_equal(tvo_vo_process(vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        dg_i32(&d, (int32_t)res.state);
        dg_i32(&d, res.relpose_flags);
        dg_i32(&d, (int32_t)res.pose_status);
        dg_pose(&d, &res.T_prev_cur);
        dg_i32(&d, res.tracked);
        dg_i32(&d, res.inliers);
        dg_i32(&d, res.new_corners);
        dg_i32(&d, res.tracks);
        dg_f64(&d, res.parallax_deg);
        dg_u64(&d, (uint64_t)res.dt_ns);
        for (int i = 0; i < TVO_FEAT_COUNT; ++i)
            dg_f32(&d, res.features[i]);
        if (k > 0) {
            /* integrate with the ground-truth step length */
            const tvo_pose rel = tvo_pose_relative(&s->gt[k - 1], &s->gt[k]);
            const double len = sqrt(rel.t[0] * rel.t[0] + rel.t[1] * rel.t[1] + rel.t[2] * rel.t[2]);
            assert_int_equal(tvo_traj_step(&traj, &res.T_prev_cur, len), TVO_OK);
            if (res.state == TVO_VO_OK)
                ++ok_frames;
        }
        dg_pose(&d, &traj.T_w_c);
        trace("vo", k, &d);
        /* the local map: the world pose and what the map did */
        dg_pose(&dm, &res.T_w_c);
        dg_i32(&dm, (int32_t)res.map_state);
        dg_i32(&dm, res.keyframe);
        dg_i32(&dm, res.map_points);
        dg_i32(&dm, res.map_new_points);
        dg_i32(&dm, res.map_landmarks);
        dg_i32(&dm, res.map_losses);
        dg_i32(&dm, res.ba_iterations);
        dg_i32(&dm, res.ba_flags);
        trace("map", k, &dm);
        map_frames += res.map_state == TVO_MAP_TRACKING;
        if (verbose()) {
            printf("  vo %d: state %d flags %d tracked %d inliers %d new %d tracks %d parallax %a\n", k,
                   (int)res.state, (int)res.relpose_flags, (int)res.tracked, (int)res.inliers,
                   (int)res.new_corners, (int)res.tracks, res.parallax_deg);
            printf("  vo %d: R %a %a %a t %a %a %a\n", k, res.T_prev_cur.R[0], res.T_prev_cur.R[1],
                   res.T_prev_cur.R[2], res.T_prev_cur.t[0], res.T_prev_cur.t[1], res.T_prev_cur.t[2]);
            printf("  vo %d: features", k);
            for (int i = 0; i < TVO_FEAT_COUNT; ++i)
                printf(" %a", (double)res.features[i]);
            printf("\n");
        }
    }
    /* a sane run: mostly OK frames, and the integrated position within 0.15 m of the truth */
    assert_true(ok_frames >= (FRAMES - 1) * 7 / 10);
    {
        const tvo_pose *g = &s->gt[FRAMES - 1];
        const double dx = traj.T_w_c.t[0] - g->t[0], dy = traj.T_w_c.t[1] - g->t[1],
                     dz = traj.T_w_c.t[2] - g->t[2];
        assert_true(sqrt(dx * dx + dy * dy + dz * dz) < 0.15);
    }
    /* ...and the map tracks most of the frames */
    assert_true(map_frames >= FRAMES / 2);
    free(mem);
    assert_true(check_digest("vo", "EXPECT_VO", d.h, EXPECT_VO));
    assert_true(check_digest("map", "EXPECT_MAP", dm.h, EXPECT_MAP));
}

/* The map's rescue path (cfg.map_refind, map_refind_rescue: the default's): the sequence with a flat bar
 * over the left 11/16 of frames REFIND_FIRST and REFIND_FIRST + 1, which ends most landmark tracks and
 * leaves the map short of points, so that their stored templates are searched for and found again. The
 * digest covers the world poses and what the map did, the landmarks found again included. */
#define REFIND_FIRST 16
static void test_vo_refind(void **state)
{
    seq *s = *state;
    tvo_vo *vo = NULL;
    void *mem = open_default_vo(&vo);
    uint8_t *img = malloc((size_t)W * H);
    digest d;
    long refound = 0;
    assert_non_null(img);
    dg_init(&d);
    for (int k = 0; k < FRAMES; ++k) {
        tvo_vo_result res;
        tvo_image im = tvo_image_make(W, H, W, img);
        memcpy(img, s->img[k], (size_t)W * H);
        if (k >= REFIND_FIRST && k < REFIND_FIRST + 2)
            for (int y = 0; y < H; ++y)
                memset(img + (size_t)y * W, 128, (size_t)(11 * W / 16));
        assert_int_equal(tvo_vo_process(vo, &im, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        dg_pose(&d, &res.T_w_c);
        dg_i32(&d, (int32_t)res.map_state);
        dg_i32(&d, res.map_points);
        dg_i32(&d, res.map_refound);
        dg_i32(&d, res.map_losses);
        dg_i32(&d, res.tracks);
        refound += res.map_refound;
        trace("refind", k, &d);
    }
    fprintf(stderr, "determinism, refind: %ld landmarks found again\n", refound);
#if TVO_WITH_AFFINE
    assert_true(refound > 0); /* the path is taken (30 landmarks, 3 frames after the bar came) */
#else
    assert_true(refound == 0); /* the store needs the affine refinement: inert */
#endif
    free(mem);
    free(img);
    assert_true(check_digest("refind", "EXPECT_REFIND", d.h, EXPECT_REFIND));
}

#if TVO_WITH_AFFINE
/* The map digest of the room sequence, there and back, with a short window whose keyframes leave often (3
 * keyframes, 2 fixed, a keyframe at least every 2 frames), the landmarks' priors at weight w with their
 * gate g. */
static uint64_t run_vo_prior(seq *s, double w, double g, int *kf)
{
    const tvo_camera cam = pinhole();
    tvo_vo_config cfg;
    tvo_vo *vo = NULL;
    void *mem;
    digest d;
    tvo_vo_config_default(&cfg, &cam);
    cfg.map_window = 3;
    cfg.map_ba_fixed = 2;
    cfg.map_kf_max_frames = 2;
    cfg.map_lm_prior = w;
    cfg.map_lm_prior_gate = g;
    mem = open_vo(&cfg, &vo);
    dg_init(&d);
    *kf = 0;
    for (int k = 0; k < 2 * FRAMES - 1; ++k) { /* the room there and back: keyframes enough to leave */
        tvo_vo_result res;
        tvo_image img = tvo_image_make(W, H, W, s->img[k < FRAMES ? k : 2 * FRAMES - 2 - k]);
        assert_int_equal(tvo_vo_process(vo, &img, 1000000000LL + k * 50000000LL, &res), TVO_OK);
        assert_true(tvo_pose_is_finite(&res.T_w_c));
        dg_pose(&d, &res.T_w_c);
        dg_i32(&d, (int32_t)res.map_state);
        dg_i32(&d, res.keyframe);
        dg_i32(&d, res.map_points);
        dg_i32(&d, res.map_landmarks);
        dg_i32(&d, res.ba_iterations);
        dg_i32(&d, res.ba_flags);
        *kf += res.keyframe;
        if (g > 0.0 && w > 0.0)
            trace("vo_prior", k, &d);
    }
    free(mem);
    return d.h;
}
#endif

/* The map with the landmarks' priors and their gate (cfg.map_lm_prior, map_lm_prior_gate; builds with
 * the affine refinement): world poses and what the map did. The priors and the gate both change the run
 * (the digests without the priors, and with them but without the gate, differ), so the path is taken. */
static void test_vo_prior(void **state)
{
#if TVO_WITH_AFFINE
    seq *s = *state;
    int kf = 0, kf0 = 0, kf_nogate = 0;
    const uint64_t h = run_vo_prior(s, 1.0, 2.0, &kf);
    const uint64_t h0 = run_vo_prior(s, 0.0, 2.0, &kf0), h_nogate = run_vo_prior(s, 1.0, 0.0, &kf_nogate);
    fprintf(stderr, "determinism, vo_prior: %d keyframes (without the priors %d, without the gate %d)\n", kf,
            kf0, kf_nogate);
    assert_true(kf >= 6);
    assert_true(h != h0);
    assert_true(h != h_nogate);
    assert_true(check_digest("vo_prior", "EXPECT_VO_PRIOR", h, EXPECT_VO_PRIOR));
#else
    (void)state;
    skip();
#endif
}

/* The lens refinement (cfg.lens_refine): a window's block (information, estimate, variance) and the
 * adoption test's verdict and changed camera on two copies of it. */
static void test_lens(void **state)
{
#if TVO_WITH_LENS
    static tvo_lens_scene sc;
    const tvo_camera truth = tvo_ls_camera(0.02, -0.01), cfg = tvo_ls_camera(0.0, 0.0);
    const size_t sz = tvo_lens_scratch_size(TVO_LS_POSES, TVO_LS_POINTS, TVO_LS_POSES * TVO_LS_POINTS);
    void *mem = malloc(sz);
    tvo_lens_block b;
    tvo_lens s;
    tvo_camera changed;
    double dk[2], shift;
    digest d;
    (void)state;
    assert_non_null(mem);
    assert_int_equal(tvo_ls_make(&sc, &truth, &cfg, 0.3), 1);
    assert_int_equal(tvo_lens_window(&cfg, &sc.p, 2.5, mem, sz, &b), 1);
    free(mem);
    dg_init(&d);
    for (int i = 0; i < 4; ++i)
        dg_f64(&d, b.I[i]);
    dg_f64(&d, b.h[0]);
    dg_f64(&d, b.h[1]);
    dg_f64(&d, b.s2);
    dg_i32(&d, b.n_obs);
    memset(&s, 0, sizeof(s));
    tvo_lens_add(&s, &b);
    tvo_lens_add(&s, &b);
    memset(&changed, 0, sizeof(changed));
    dg_i32(&d, (int32_t)tvo_lens_decide(&s, &cfg, dk, &shift, &changed));
    dg_f64(&d, dk[0]);
    dg_f64(&d, dk[1]);
    dg_f64(&d, shift);
    dg_f64(&d, changed.k[0]);
    dg_f64(&d, changed.k[1]);
    assert_true(check_digest("lens", "EXPECT_LENS", d.h, EXPECT_LENS));
#else
    (void)state;
    skip();
#endif
}

/* The bundle adjustment with point priors (cfg.map_lm_prior's path; builds with the affine refinement):
 * the lens stage's noisy window with the lens as calibrated, camera 0's observations turned into priors on
 * their points (tvo_ba_point_prior_add, at the points' true positions) and left out, the free poses and
 * every point moved, then adjusted. The digest covers the status, the report and the adjusted state. */
static void test_ba_prior(void **state)
{
#if TVO_WITH_AFFINE
    static tvo_lens_scene sc;
    static double prior[TVO_LS_POINTS][TVO_BA_PRIOR_SIZE];
    const tvo_camera cam = tvo_ls_camera(0.0, 0.0);
    tvo_ba_config bc;
    tvo_ba_report rep;
    tvo_status st;
    int32_t kept = 0, added = 0;
    size_t sz;
    void *mem;
    digest d;
    (void)state;
    assert_int_equal(tvo_ls_make(&sc, &cam, &cam, 0.3), 1);
    tvo_ba_config_default(&bc);
    bc.max_poses = TVO_LS_POSES;
    bc.max_points = TVO_LS_POINTS;
    bc.max_obs = TVO_LS_POSES * TVO_LS_POINTS;
    memset(prior, 0, sizeof(prior));
    for (int32_t k = 0; k < sc.p.n_obs; ++k) {
        const tvo_ba_obs o = sc.obs[k];
        if (o.pose == 0)
            added += tvo_ba_point_prior_add(prior[o.point], &sc.T[0], sc.X[o.point], o.x, o.y, bc.huber, 1.0);
        else
            sc.obs[kept++] = o;
    }
    sc.p.n_obs = kept;
    sc.p.prior = (const double(*)[TVO_BA_PRIOR_SIZE])prior;
    for (int i = 2; i < TVO_LS_POSES; ++i)
        sc.T[i].t[0] += 0.01 * i;
    for (int j = 0; j < TVO_LS_POINTS; ++j)
        sc.X[j][2] *= 1.0 + 0.02 * (double)(j % 5 - 2);
    sz = tvo_ba_scratch_size(&bc);
    mem = malloc(sz);
    assert_non_null(mem);
    st = tvo_ba_solve(&bc, &sc.p, mem, sz, &rep);
    free(mem);
    dg_init(&d);
    dg_i32(&d, added);
    dg_i32(&d, (int32_t)st);
    dg_i32(&d, rep.iterations);
    dg_i32(&d, rep.flags);
    dg_f64(&d, rep.cost_final);
    for (int i = 0; i < TVO_LS_POSES; ++i)
        dg_pose(&d, &sc.T[i]);
    for (int j = 0; j < TVO_LS_POINTS; ++j)
        for (int a = 0; a < 3; ++a)
            dg_f64(&d, sc.X[j][a]);
    fprintf(stderr, "determinism, ba_prior: %d priors, status %d, %d iterations, cost %.6g\n", (int)added,
            (int)st, (int)rep.iterations, rep.cost_final);
    assert_true(added > 100 && st == TVO_OK);
    assert_true(check_digest("ba_prior", "EXPECT_BA_PRIOR", d.h, EXPECT_BA_PRIOR));
#else
    (void)state;
    skip();
#endif
}

int main(void)
{
    const struct CMUnitTest tests[] = {
            cmocka_unit_test(test_input),     cmocka_unit_test(test_corners),   cmocka_unit_test(test_tracks),
            cmocka_unit_test(test_undistort), cmocka_unit_test(test_relpose),   cmocka_unit_test(test_nn),
            cmocka_unit_test(test_vo),        cmocka_unit_test(test_vo_refind), cmocka_unit_test(test_lens),
            cmocka_unit_test(test_ba_prior),  cmocka_unit_test(test_vo_prior),
    };
    return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
