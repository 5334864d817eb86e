/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the VO object. See vo.h for the per-frame data flow. */
#include "tinyvo/vo.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "tinyvo/arena.h"
#include "tinyvo/dmath.h"
#include "tinyvo/linalg.h"
#include "tinyvo/pyramid.h"
#include "tvo_map.h"
#include "tinyvo/options.h"
#include "tvo_affine.h"

#if TVO_WITH_LENS
/* cfg.lens_refine's state: the camera configured at init, and the blocks and changes of tvo_lens.h */
typedef struct vo_lens {
    tvo_camera cam0;
    tvo_lens s;
} vo_lens;
#endif

/* The coverage grid (cfg.redetect_coverage, cfg.redetect_cell_kept): 8 x 6 cells over the frame. */
#define TVO_VO_COVER_COLS 8
#define TVO_VO_COVER_ROWS 6
#define TVO_VO_COVER_CELLS (TVO_VO_COVER_COLS * TVO_VO_COVER_ROWS)

struct tvo_vo {
    tvo_vo_config cfg;
    tvo_pyramid pyr[2]; /* level 0 borrowed: the current frame's is the caller's image, the previous
                                 frame's is the copy in level0 (made at the end of each frame) */
    uint8_t *level0;    /* [width x height] */
    int32_t cur;        /* index of the pyramid that receives the next frame */
    int32_t has_prev;   /* a previous frame with tracks exists */
    int64_t t_prev;
    double t_dir[3];           /* unit translation (X_cur = R X_prev + t) of the last frame that had one */
    int32_t t_dir_age;         /* frames since then; > TVO_VO_PRIOR_FRAMES: no motion prior */
    int32_t n;                 /* tracks in pts (positions in the previous frame) */
    tvo_point2f *pts;          /* [max_tracks] */
    tvo_point2f *next;         /* [max_tracks] */
    uint8_t *st;               /* [max_tracks] */
    tvo_point2d *x1, *x2;      /* [max_tracks] normalised prev / cur */
    uint8_t *ok1, *ok2, *mask; /* [max_tracks] */
    tvo_corner *corners;       /* [max_tracks] */
    /* relative scale: each track's normalised position two frames back (frame k-2 while frame k is
       processed; valid where has0[i]) and the previous frame's pose (X_(k-1) = R0 X_(k-2) + t0, |t0| = 1;
       valid while has_pose0) */
    tvo_point2d *x0; /* [max_tracks] */
    uint8_t *has0;   /* [max_tracks] */
    double R0[9], t0[3];
    int32_t has_pose0;
    /* keyframe rotation (cfg.keyframe): each track's normalised position in the keyframe K (valid where
       hask[i]), the K -> cur correspondences of one frame (kx1, kx2, kmask), and the rotation of the
       previous frame relative to K (X_prev = R_pK X_K; valid while has_kf) */
    tvo_point2d *xk;        /* [max_tracks] */
    uint8_t *hask;          /* [max_tracks] */
    tvo_point2d *kx1, *kx2; /* [max_tracks] */
    uint8_t *kmask;         /* [max_tracks] */
    double R_pK[9];
    int32_t has_kf;
    int32_t kf_age; /* frames from K to the previous frame */
    /* track prediction (cfg.track_prediction): the last frame's rotation (X_prev = R_pred X_prevprev),
       its frame interval, valid while has_pred; r2_max: the squared normalised radius (x 1.21) of the
       farthest image corner, beyond which a predicted point is not distorted back */
    double R_pred[9];
    int64_t dt_pred;
    int32_t has_pred;
    double r2_max;
    /* track identity (tvo_vo_tracks) and the local map's per-track state (tvo_map.h): landmark, the
       keyframe and position a track waits in for its triangulation, its map inlier flag */
    uint32_t *id;         /* [max_tracks] */
    int32_t *age;         /* [max_tracks] */
    int32_t *lm, *tri_fr; /* [max_tracks] */
    tvo_point2d *tri_x;   /* [max_tracks] */
    uint8_t *minl;        /* [max_tracks] */
    uint32_t next_id;
    tvo_map map;
    tvo_pose T_c_w;    /* the last frame's pose in the VO's world (world -> camera) */
    double chain_gain; /* the two-view chain's step length over its base (chain_scale_sigmas) */
    double rs_se;      /* the standard error of log(rel_scale) of this frame (with chain_scale_sigmas) */
    int32_t aff_tried, aff_refined, aff_ended; /* this frame's affine refinements (tvo_vo_result.affine_*) */
    int32_t cover_ref; /* cells of the coverage grid the tracks covered after the last detection */
    uint32_t cell[2][TVO_VO_COVER_CELLS]; /* cfg.redetect_cell_kept: corners born [0] and kept [1] */
    int32_t rescue_age; /* frames since the last prediction rescue (0: this frame's; saturates) */
    /* the last posed frame's motion in the world (T_c_w = v_step T_c_w_before) over v_dt ns (0: none);
       lost_ns: the LOST frames' time it has carried the pose on since (coast_step) */
    tvo_pose v_step;
    int64_t v_dt, lost_ns;
    int64_t dt_unit; /* the chain's first frame interval: before the first map the chain counts frames by it */
    /* affine refinement (cfg.affine_win_size > 0, else all NULL): each track's template, its model
       and warp, valid where hast[i] */
    uint8_t *tpl;      /* [max_tracks x tvo_aff_template_bytes(affine_win_size)] */
    tvo_aff_warp *aw;  /* [max_tracks] */
    tvo_aff_model *am; /* [max_tracks] */
    uint8_t *hast;     /* [max_tracks] */
#if TVO_WITH_AFFINE
    /* landmarks found again (cfg.map_refind, else NULL): a ring of the templates of ended landmark tracks,
       each with its landmark's slot (-1: empty) and generation, its model, its last warp and the
       searches in view that failed */
    int32_t *rf_lm;       /* [map_refind] */
    uint32_t *rf_gen;     /* [map_refind] */
    uint8_t *rf_miss;     /* [map_refind] */
    uint8_t *rf_wait;     /* [map_refind] frames left before the first search */
    uint8_t *rf_tpl;      /* [map_refind x tvo_aff_template_bytes(affine_win_size)] */
    tvo_aff_model *rf_am; /* [map_refind] */
    tvo_aff_warp *rf_aw;  /* [map_refind] */
    int32_t rf_next;      /* the entry the next ended track overwrites */
#endif
#if TVO_WITH_LENS
    /* the lens refined on the run (cfg.lens_refine, else NULL; cfg.camera then holds the refined lens) */
    struct vo_lens *lens;
#endif
    void *scratch;
    size_t scratch_size;
};

/* A translation direction older than this many frames is not used to resolve an ambiguous pose. */
#define TVO_VO_PRIOR_FRAMES 3
/* The largest cfg.map_rot_prior_obs_frames, and where the frames since the last prediction rescue stop
 * counting. */
#define TVO_VO_MAX_RESCUE_FRAMES 100000
/* The affine refinement (cfg.affine_win_size): at most this many Gauss-Newton steps, stopping when a
 * step moves no window corner by more than TVO_VO_AFF_EPS px; the result is taken when the patch
 * correlates with the template by at least TVO_VO_AFF_MIN_NCC and lies within TVO_VO_AFF_MAX_MOVE px
 * of LK's position. */
#define TVO_VO_AFF_ITERS 10
#define TVO_VO_AFF_EPS 0.02f
#define TVO_VO_AFF_MIN_NCC 0.8f
#define TVO_VO_AFF_MAX_MOVE 2.0f
/* The default pyramid's coarsest level keeps at most this many pixels on the frame's larger side, with 3
 * levels above the frame at least (lk_levels_for). */
#define TVO_VO_COARSE_PX 160

#if TVO_WITH_AFFINE
/* cfg.map_refind: a landmark is first looked for this many frames after its track ended (not in the frame
 * whose forward-backward check ended it: a real occlusion lasts), not where a track lies within
 * TVO_VO_REFIND_CLEAR_PX pixels of its projection (that track may be the point found again by the
 * detector), and its entry is dropped after TVO_VO_REFIND_MISSES failed searches in view. */
#define TVO_VO_REFIND_WAIT 3
#define TVO_VO_REFIND_CLEAR_PX 3.0f
#define TVO_VO_REFIND_MISSES 3

/* cfg.map_refind acts (and has its store) only with the map and the affine refinement's templates. */
static int refind_on(const tvo_vo_config *cfg)
{
    return cfg->map_refind > 0 && cfg->map && cfg->affine_win_size > 0;
}

/* The store of cfg.map_refind emptied (at init and reset). */
static void refind_clear(tvo_vo *vo)
{
    if (vo->rf_lm == NULL)
        return;
    for (int32_t e = 0; e < vo->cfg.map_refind; ++e)
        vo->rf_lm[e] = -1;
    vo->rf_next = 0;
}
#endif
/* ...and an ambiguous pose is resolved only when the chosen candidate is within this angle of it. */
#define TVO_VO_PRIOR_COS 0.7071067811865476 /* cos 45 deg */
/* A pose with a translation whose rotation is further than this many times the rotation-compensated
 * parallax, and more than TVO_VO_ROT_CHECK_MIN_DEG, from the rotation-only model of the same points is not
 * trusted (the frame becomes rotation-only with that model's rotation): at low parallax the rotation-only
 * model is near the true rotation, so such a pose is a wrong epipolar minimum or twin (synthetic MH_03:
 * frames at 40-1400x the parallax had 3-46 deg of rotation error). The floor keeps sideways motion in
 * front of a plane, where the rotation-only model absorbs ~1 deg of translation flow, untouched. */
#define TVO_VO_ROT_CHECK_RATIO 10.0
#define TVO_VO_ROT_CHECK_MIN_DEG 2.0

#define TVO_VO_DEG_PER_RAD (180.0 / 3.14159265358979323846)

/* The check above on a pose p with a translation: 1 when its rotation is too far from its own
 * rotation-only model. */
static int rotation_check_fails(const tvo_relpose *p)
{
    const double d = tvo_la_rot_dist(p->R, p->R_rot) * TVO_VO_DEG_PER_RAD;
    const double lim = TVO_VO_ROT_CHECK_RATIO * p->parallax_deg;
    return d > (lim > TVO_VO_ROT_CHECK_MIN_DEG ? lim : TVO_VO_ROT_CHECK_MIN_DEG);
}

/* TVO_VO_PRESET_BASIC's fields: translation-only LK on every track, a window of 6 keyframes with 2 fixed,
 * chain steps of one length (TVO_VO_PRESET_SMALL starts from them). */
static void preset_basic(tvo_vo_config *cfg)
{
    cfg->affine_win_size = 0;
    cfg->chain_scale_sigmas = 0.0;
    cfg->map_window = 6;
    cfg->map_ba_fixed = 2;
    cfg->map_prediction = 0;
    cfg->lk.pred_levels = 0;
    cfg->lk.pred_win_size = 0;
    cfg->map_refind = 0;
    cfg->map_refind_rescue = 0;
}

/* TVO_VO_PRESET_ACCURATE's fields: every track re-aligned to its first patch (the affine refinement),
 * 8 keyframes with 4 fixed, the full tracker on every track, the chain's steps following the relative
 * scale (docs/rules.md, "A twenty-third rule": measured on the balanced preset; on the basic tracker it
 * costs the KITTI 01 highway a quarter of its ATE, so the basic and small presets keep 0), and the
 * landmarks of 64 ended tracks found again while the map runs short of points ("A thirty-second rule"). */
static void preset_accurate(tvo_vo_config *cfg)
{
    preset_basic(cfg);
    cfg->affine_win_size = 21;
    cfg->chain_scale_sigmas = 3.0;
    cfg->map_window = 8;
    cfg->map_ba_fixed = 4;
    cfg->map_refind = 64;
    cfg->map_refind_rescue = 1;
}

/* TVO_VO_PRESET_BALANCED's fields (the defaults in a build with the affine refinement): the accurate
 * preset's, with the tracks the map predicts tracked on 2 levels with 11x11 windows. */
static void preset_balanced(tvo_vo_config *cfg)
{
    preset_accurate(cfg);
    cfg->map_prediction = 2;
    cfg->lk.pred_levels = 2;
    cfg->lk.pred_win_size = 11;
}

/* LK's pyramid for frames of w x h px (0 x 0 without a camera): 3 levels above the frame (lk.max_level 3)
 * up to TVO_VO_COARSE_PX x 8 px on the larger side, one more for each doubling beyond, so that the
 * coarsest level keeps at most TVO_VO_COARSE_PX px and LK's reach follows the motion in pixels of a camera
 * with more of them (docs/rules.md, "A sixty-first rule"); a level is only added while its smaller side
 * stays above the window `win` (LK does not use a level that small). */
static int32_t lk_levels_for(int32_t w, int32_t h, int32_t win)
{
    const int32_t big = w > h ? w : h, small = w > h ? h : w;
    int32_t l = 3;
    while (l < TVO_MAX_PYR_LEVELS - 1 && big > (TVO_VO_COARSE_PX << l) && (small >> (l + 1)) > win)
        ++l;
    return l;
}

void tvo_vo_config_default(tvo_vo_config *cfg, const tvo_camera *camera)
{
    if (cfg == NULL)
        return;
    memset(cfg, 0, sizeof(*cfg));
    if (camera != NULL)
        cfg->camera = *camera;
    tvo_detect_config_default(&cfg->detect);
    tvo_lk_config_default(&cfg->lk);
    cfg->lk.max_level = lk_levels_for(cfg->camera.width, cfg->camera.height, cfg->lk.win_size);
    cfg->lk.fb_check = 1;
    tvo_relpose_config_default(&cfg->relpose);
    cfg->max_tracks = 300;
    cfg->min_tracks = 200;
    cfg->redetect_coverage = 0.75; /* redetect_cell_kept 0 (memset above) */
    cfg->min_pose_tracks = 30;
    cfg->gain_retry = 1;
    cfg->pred_rescue = 1;
    cfg->fast_min_threshold = 7; /* as ORB-SLAM's second FAST pass (20 then 7) */
    cfg->fast_range_ref = 0;
    cfg->pose_threshold_px = 1.0;
    cfg->min_scale_points = 20;
    cfg->scale_min_parallax_deg = 0.1;
    /* rotation-only below 0.15 deg of rotation-compensated parallax: about 4x the noise floor of
       0.3 px tracking noise at f = 460 px; pure rotation measures ~0.005 deg in test_vo */
    cfg->relpose.min_parallax_deg = 0.02;
    cfg->keyframe = 1;
    cfg->keyframe_min_tracks = 100;
    cfg->keyframe_max_parallax_deg = 5.0;
    cfg->keyframe_max_rot_deg = 10.0;
    cfg->keyframe_translation = 1;
    cfg->track_prediction = 0; /* on: larger motion per frame tracked, but the EuRoC renders got worse */
    cfg->affine_step = 1;
    cfg->affine_at_keyframes = 0;
    cfg->affine_end_share = 0.0;
    cfg->map_refind = 0;
    cfg->map_refind_rescue = 0;
    cfg->map = 1;
    cfg->map_max_landmarks = 0; /* 2 x max_tracks */
    cfg->map_min_points = 20;
    cfg->map_init_parallax_deg = 1.0;
    cfg->map_init_wait_s = 0.0;
    cfg->map_tri_parallax_deg = 0.5;
    cfg->map_kf_baseline = 0.1;
    cfg->map_kf_points_ratio = 0.8;
    cfg->map_kf_max_frames = 30;
    cfg->map_ba_iterations = 5;
    cfg->map_ba_max_turn_deg = 0.5;
    cfg->map_ba_huber_px = 2.5;
    cfg->map_ba_rot_prior = 0.0;
    cfg->map_rot_prior = 100.0;
    /* a weak prior judged by the landmarks in 3+ keyframes within 30 frames of a prediction rescue (a
       jerk), by all of them elsewhere (docs/rules.md, "A forty-sixth rule") */
    cfg->map_rot_prior_obs = 3;
    cfg->map_rot_prior_obs_frames = 30;
    /* the landmarks' priors (map_lm_prior, off by default) forget what a slid track's old keyframes saw */
    cfg->map_lm_prior_gate = 2.0;
    /* the lens refined on the run where the build has it (docs/rules.md, "A forty-eighth rule") */
    cfg->lens_refine = TVO_WITH_LENS;
    cfg->clock = NULL;
    cfg->clock_user = NULL;
    /* the tracker, window and chain step: the balanced preset's (docs/rules.md, "A ninth rule"), or
       the basic preset's in a build without the affine refinement */
    if (TVO_WITH_AFFINE)
        preset_balanced(cfg);
    else
        preset_basic(cfg);
}

tvo_status tvo_vo_config_preset(tvo_vo_config *cfg, const tvo_camera *camera, tvo_vo_preset preset)
{
    if (cfg == NULL)
        return TVO_ERR_NULL;
    tvo_vo_config_default(cfg, camera);
    switch (preset) {
    case TVO_VO_PRESET_DEFAULT:
        return TVO_OK;
    case TVO_VO_PRESET_ACCURATE:
        if (!TVO_WITH_AFFINE)
            return TVO_ERR_UNSUPPORTED;
        preset_accurate(cfg);
        return TVO_OK;
    case TVO_VO_PRESET_BALANCED:
        if (!TVO_WITH_AFFINE)
            return TVO_ERR_UNSUPPORTED;
        preset_balanced(cfg);
        return TVO_OK;
    case TVO_VO_PRESET_BASIC:
        preset_basic(cfg);
        return TVO_OK;
    case TVO_VO_PRESET_SMALL:
        preset_basic(cfg);
        cfg->max_tracks = 120;
        cfg->min_tracks = 80;
        cfg->keyframe_min_tracks = 40;
        cfg->detect.max_corners = cfg->max_tracks; /* the scratch is sized for this many */
        cfg->lk.max_level = 2;
        cfg->map_window = 5;
        cfg->map_max_landmarks = 160;
        cfg->lens_refine = 0;
        return TVO_OK;
    default:
        return TVO_ERR_ARG;
    }
}

/* The double fields of tvo_vo_config and their ranges, checked by config_valid from one table (less code
 * than a comparison per field: the Cortex-M7 core's budget): 0 <= v <= hi, or 0 < v <= hi with above set
 * (NaN fails both); hi is range_hi[hi]. */
typedef struct range_check {
    uint16_t off; /* offsetof: the struct is far below 64 KiB */
    uint8_t hi, above;
} range_check;

/* range_hi's entries, by name */
enum { HI_1, HI_10, HI_30, HI_90, HI_100, HI_180, HI_DAY_S, HI_1E12, HI_FINITE, HI_GATE, HI_PRIOR };
static const double range_hi[] = {1.0, 10.0, 30.0, 90.0, 100.0, 180.0, 86400.0, 1e12, DBL_MAX,
                                  /* the inlier gate and the landmark priors are left out with the affine
                                     refinement: only 0 there */
                                  TVO_WITH_AFFINE ? 100.0 : 0.0, TVO_WITH_AFFINE ? 1.0 : 0.0};

static const range_check ranges[] = {
        {(uint16_t)offsetof(tvo_vo_config, redetect_coverage), HI_1, 0},
        {(uint16_t)offsetof(tvo_vo_config, redetect_cell_kept), HI_1, 0},
        {(uint16_t)offsetof(tvo_vo_config, pose_threshold_px), HI_FINITE, 1},
        {(uint16_t)offsetof(tvo_vo_config, scale_min_parallax_deg), HI_10, 1},
        {(uint16_t)offsetof(tvo_vo_config, keyframe_max_parallax_deg), HI_90, 1},
        {(uint16_t)offsetof(tvo_vo_config, keyframe_max_rot_deg), HI_180, 1},
        {(uint16_t)offsetof(tvo_vo_config, affine_end_share), HI_1, 0},
        {(uint16_t)offsetof(tvo_vo_config, map_init_parallax_deg), HI_30, 1},
        {(uint16_t)offsetof(tvo_vo_config, map_tri_parallax_deg), HI_30, 1},
        {(uint16_t)offsetof(tvo_vo_config, map_init_wait_s), HI_DAY_S, 0},
        {(uint16_t)offsetof(tvo_vo_config, chain_scale_sigmas), HI_100, 0},
        {(uint16_t)offsetof(tvo_vo_config, map_inlier_sigmas), HI_GATE, 0},
        {(uint16_t)offsetof(tvo_vo_config, map_lm_prior), HI_PRIOR, 0},
        {(uint16_t)offsetof(tvo_vo_config, map_lm_prior_gate), HI_100, 0},
        {(uint16_t)offsetof(tvo_vo_config, map_kf_baseline), HI_10, 1},
        {(uint16_t)offsetof(tvo_vo_config, map_kf_points_ratio), HI_1, 0},
        {(uint16_t)offsetof(tvo_vo_config, map_ba_max_turn_deg), HI_180, 1},
        {(uint16_t)offsetof(tvo_vo_config, map_ba_huber_px), HI_100, 1},
        {(uint16_t)offsetof(tvo_vo_config, map_ba_rot_prior), HI_1E12, 0},
        {(uint16_t)offsetof(tvo_vo_config, map_rot_prior), HI_1E12, 0},
};

static int ranges_valid(const tvo_vo_config *cfg)
{
    for (size_t i = 0; i < sizeof(ranges) / sizeof(ranges[0]); ++i) {
        double v;
        memcpy(&v, (const char *)cfg + ranges[i].off, sizeof(v));
        if (!(ranges[i].above ? v > 0.0 : v >= 0.0) || !(v <= range_hi[ranges[i].hi]))
            return 0;
    }
    return 1;
}

static int config_valid(const tvo_vo_config *cfg)
{
    if (cfg == NULL || tvo_camera_check(&cfg->camera) != TVO_OK || !ranges_valid(cfg))
        return 0;
    if (cfg->max_tracks < 16 || cfg->max_tracks > 100000)
        return 0;
    if (cfg->min_tracks < 0 || cfg->min_tracks > cfg->max_tracks)
        return 0;
    if ((uint32_t)cfg->gain_retry > 1u || (uint32_t)cfg->pred_rescue > 1u)
        return 0;
    if (cfg->min_pose_tracks < 8 || cfg->min_pose_tracks > cfg->max_tracks)
        return 0;
    if (cfg->fast_min_threshold < 0 || cfg->fast_min_threshold > 255 || cfg->fast_range_ref < 0 ||
        cfg->fast_range_ref > 255)
        return 0;
    if (cfg->min_scale_points < 3) /* above max_tracks: never available */
        return 0;
    if (cfg->keyframe != 0 && cfg->keyframe != 1)
        return 0;
    if (cfg->keyframe_min_tracks < 0) /* above max_tracks: a new keyframe every frame */
        return 0;
    if (cfg->keyframe_translation != 0 && cfg->keyframe_translation != 1)
        return 0;
    if (cfg->track_prediction != 0 && cfg->track_prediction != 1)
        return 0;
    if (cfg->affine_win_size != 0 &&
        (!TVO_WITH_AFFINE || cfg->affine_win_size < 3 || cfg->affine_win_size > TVO_AFF_MAX_SIDE ||
         (cfg->affine_win_size & 1) == 0))
        return 0;
    if (cfg->affine_at_keyframes != 0 && cfg->affine_at_keyframes != 1)
        return 0;
    if (cfg->map_refind < 0 || cfg->map_refind > 4096) /* inert without the map or the templates */
        return 0;
    if (cfg->map_twin_dir != 0 && cfg->map_twin_dir != 1)
        return 0;
    if (cfg->map_refind_rescue != 0 && cfg->map_refind_rescue != 1)
        return 0;
    if (cfg->affine_step < 1 || cfg->affine_step > 15 ||
        (cfg->affine_win_size != 0 && !tvo_aff_step_ok(cfg->affine_win_size, cfg->affine_step)))
        return 0;
    if (cfg->map_prediction < 0 || cfg->map_prediction > 2)
        return 0;
    if (cfg->lk.max_level < 0 || cfg->lk.max_level + 1 > TVO_MAX_PYR_LEVELS)
        return 0;
    if (cfg->map != 0 && cfg->map != 1)
        return 0;
    if (cfg->map_window < 3 || cfg->map_window > TVO_VO_MAX_WINDOW)
        return 0;
    if (cfg->map_max_landmarks != 0 && (cfg->map_max_landmarks < 16 || cfg->map_max_landmarks > 100000))
        return 0;
    if (cfg->map_min_points < 6 || cfg->map_min_points > 100000) /* above max_tracks: never a map */
        return 0;
    if (cfg->map_kf_max_frames < 1 || cfg->map_kf_max_frames > 100000 || cfg->map_ba_iterations < 1 ||
        cfg->map_ba_iterations > 100)
        return 0;
    if (cfg->lens_refine != 0 && (cfg->lens_refine != 1 || !TVO_WITH_LENS))
        return 0;
    if (cfg->map_ba_fixed < 2 || cfg->map_ba_fixed > cfg->map_window - 1)
        return 0;
    if (cfg->map_rot_prior_obs != 0 &&
        (cfg->map_rot_prior_obs < 2 || cfg->map_rot_prior_obs > TVO_VO_MAX_WINDOW))
        return 0;
    if (cfg->map_rot_prior_obs_frames < 0 || cfg->map_rot_prior_obs_frames > TVO_VO_MAX_RESCUE_FRAMES)
        return 0;
    return 1;
}

static size_t scratch_need(const tvo_vo_config *cfg)
{
    /* detections ask for up to max_tracks corners (detect_append), whatever detect.max_corners says */
    tvo_detect_config dc = cfg->detect;
    size_t a;
    dc.max_corners = cfg->max_tracks;
    a = tvo_detect_scratch_size(&dc, cfg->camera.width, cfg->camera.height);
    size_t b = tvo_lk_scratch_size(&cfg->lk);
    size_t c = tvo_relpose_scratch_size(cfg->max_tracks);
    size_t d = tvo_size_mul((size_t)cfg->max_tracks, sizeof(double)); /* depth ratios (rel_scale) */
    size_t e = cfg->map ? tvo_map_scratch_size(cfg) : 0;
    size_t m = a > b ? a : b;
#if TVO_WITH_AFFINE
    if (cfg->affine_win_size > 0) {
        const size_t f = tvo_aff_scratch_size(cfg->affine_win_size);
        m = m > f ? m : f;
    }
#endif
    m = m > c ? m : c;
    m = m > d ? m : d;
    return m > e ? m : e;
}

/* Bytes tvo_vo_init() carves out of the caller's block, in the order it carves them. */
static size_t layout_size(const tvo_vo_config *cfg)
{
    const size_t n = (size_t)cfg->max_tracks;
    const int32_t levels = cfg->lk.max_level + 1;
    size_t pyr = tvo_pyramid_required_size_borrowed(cfg->camera.width, cfg->camera.height, levels);
    size_t s = tvo_arena_round(sizeof(tvo_vo));
    if (pyr == 0)
        return 0;
    s = tvo_size_add(s, tvo_size_mul(2, tvo_arena_round(pyr)));
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul((size_t)cfg->camera.width, (size_t)cfg->camera.height)));
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(tvo_point2f))) * 2);
    s = tvo_size_add(s, tvo_arena_round(n) * 4); /* st ok1 ok2 mask */
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(tvo_point2d))) * 2);
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(tvo_corner))));
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(tvo_point2d))));     /* x0 */
    s = tvo_size_add(s, tvo_arena_round(n));                                        /* has0 */
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(tvo_point2d))) * 3); /* xk kx1 kx2 */
    s = tvo_size_add(s, tvo_arena_round(n) * 2);                                    /* hask kmask */
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(int32_t))) * 4);     /* id age lm tri_fr */
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(tvo_point2d))));     /* tri_x */
    s = tvo_size_add(s, tvo_arena_round(n));                                        /* minl */
    if (cfg->map)
        s = tvo_size_add(s, tvo_map_layout_size(cfg));
#if TVO_WITH_AFFINE
    if (cfg->affine_win_size > 0) {
        s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, tvo_aff_template_bytes(cfg->affine_win_size))));
        s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(tvo_aff_warp))));
        s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(tvo_aff_model))));
        s = tvo_size_add(s, tvo_arena_round(n));
    }
    if (refind_on(cfg)) {
        const size_t r = (size_t)cfg->map_refind;
        s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(r, sizeof(int32_t))) * 2); /* rf_lm rf_gen */
        s = tvo_size_add(s, tvo_arena_round(r) * 2);                                /* rf_miss rf_wait */
        s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(r, tvo_aff_template_bytes(cfg->affine_win_size))));
        s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(r, sizeof(tvo_aff_model))));
        s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(r, sizeof(tvo_aff_warp))));
    }
#endif
#if TVO_WITH_LENS
    if (cfg->lens_refine)
        s = tvo_size_add(s, tvo_arena_round(sizeof(vo_lens)));
#endif
    s = tvo_size_add(s, tvo_arena_round(scratch_need(cfg)));
    return tvo_size_add(s, TVO_ARENA_ALIGN); /* slack for an unaligned block */
}

/* cfg with its automatic values filled in (map_max_landmarks 0: 2 x max_tracks). */
static tvo_vo_config resolved(const tvo_vo_config *cfg)
{
    tvo_vo_config c = *cfg;
    if (c.map_max_landmarks == 0)
        c.map_max_landmarks = 2 * c.max_tracks;
    return c;
}

size_t tvo_vo_required_size(const tvo_vo_config *cfg)
{
    tvo_vo_config c;
    if (!config_valid(cfg))
        return 0;
    c = resolved(cfg);
    return layout_size(&c);
}

#if TVO_WITH_AFFINE
/* The affine refinement's arrays (cfg.affine_win_size > 0) and the store of cfg.map_refind, from the
 * VO's block (in the order of layout_size). */
static tvo_status affine_alloc(tvo_vo *vo, const tvo_vo_config *cfg, tvo_arena *a)
{
    const size_t n = (size_t)cfg->max_tracks;
    if (cfg->affine_win_size > 0) {
        vo->tpl = (uint8_t *)tvo_arena_alloc(a, n * tvo_aff_template_bytes(cfg->affine_win_size));
        vo->aw = (tvo_aff_warp *)tvo_arena_alloc(a, n * sizeof(tvo_aff_warp));
        vo->am = (tvo_aff_model *)tvo_arena_alloc(a, n * sizeof(tvo_aff_model));
        vo->hast = (uint8_t *)tvo_arena_alloc(a, n);
        if (vo->tpl == NULL || vo->aw == NULL || vo->am == NULL || vo->hast == NULL)
            return TVO_ERR_NO_MEMORY;
        memset(vo->hast, 0, n);
    }
    if (refind_on(cfg)) {
        const size_t r = (size_t)cfg->map_refind;
        vo->rf_lm = (int32_t *)tvo_arena_alloc(a, r * sizeof(int32_t));
        vo->rf_gen = (uint32_t *)tvo_arena_alloc(a, r * sizeof(uint32_t));
        vo->rf_miss = (uint8_t *)tvo_arena_alloc(a, r);
        vo->rf_wait = (uint8_t *)tvo_arena_alloc(a, r);
        vo->rf_tpl = (uint8_t *)tvo_arena_alloc(a, r * tvo_aff_template_bytes(cfg->affine_win_size));
        vo->rf_am = (tvo_aff_model *)tvo_arena_alloc(a, r * sizeof(tvo_aff_model));
        vo->rf_aw = (tvo_aff_warp *)tvo_arena_alloc(a, r * sizeof(tvo_aff_warp));
        if (vo->rf_lm == NULL || vo->rf_gen == NULL || vo->rf_miss == NULL || vo->rf_wait == NULL ||
            vo->rf_tpl == NULL || vo->rf_am == NULL || vo->rf_aw == NULL)
            return TVO_ERR_NO_MEMORY;
        refind_clear(vo);
    }
    return TVO_OK;
}
#endif

/* vo->r2_max from the camera's corners */
static void set_r2_max(tvo_vo *vo)
{
    const tvo_camera *cam = &vo->cfg.camera;
    vo->r2_max = 0.0;
    for (int i = 0; i < 4; ++i) {
        tvo_point2d c;
        if (tvo_camera_undistort_point(cam, (i & 1) ? cam->width - 1 : 0, (i & 2) ? cam->height - 1 : 0,
                                       &c) == TVO_OK) {
            const double r2 = 1.21 * (c.x * c.x + c.y * c.y); /* (1.1 x the corner's radius)^2 */
            vo->r2_max = r2 > vo->r2_max ? r2 : vo->r2_max;
        }
    }
}

#if TVO_WITH_LENS
/* cfg.lens_refine's state, carved from the arena (NULL when it is exhausted) */
static vo_lens *lens_alloc(const tvo_vo_config *cfg, tvo_arena *a)
{
    vo_lens *l = (vo_lens *)tvo_arena_alloc(a, sizeof(vo_lens));
    if (l != NULL) {
        memset(l, 0, sizeof(*l));
        l->cam0 = cfg->camera;
    }
    return l;
}
#endif

tvo_status tvo_vo_init(tvo_vo **out, const tvo_vo_config *cfg_in, void *mem, size_t mem_size)
{
    tvo_vo_config cfg_r;
    const tvo_vo_config *cfg = &cfg_r;
    tvo_arena a;
    tvo_vo *vo;
    size_t n, pyr;
    int32_t levels;
    if (out == NULL || cfg_in == NULL || mem == NULL)
        return TVO_ERR_NULL;
    *out = NULL;
    if (!config_valid(cfg_in))
        return (!TVO_WITH_AFFINE &&
                (cfg_in->affine_win_size != 0 || cfg_in->map_inlier_sigmas > 0.0 ||
                 cfg_in->map_lm_prior > 0.0)) ||
                        (!TVO_WITH_LENS && cfg_in->lens_refine == 1)
                ? TVO_ERR_UNSUPPORTED
                : TVO_ERR_ARG;
    cfg_r = resolved(cfg_in);
    if (mem_size < layout_size(cfg))
        return TVO_ERR_NO_MEMORY;
    n = (size_t)cfg->max_tracks;
    levels = cfg->lk.max_level + 1;
    pyr = tvo_pyramid_required_size_borrowed(cfg->camera.width, cfg->camera.height, levels);
    tvo_arena_init(&a, mem, mem_size);
    vo = (tvo_vo *)tvo_arena_alloc(&a, sizeof(tvo_vo));
    if (vo == NULL)
        return TVO_ERR_NO_MEMORY;
    memset(vo, 0, sizeof(*vo));
    vo->cfg = *cfg;
    for (int i = 0; i < 2; ++i) {
        void *pm = tvo_arena_alloc(&a, pyr);
        tvo_status st;
        if (pm == NULL)
            return TVO_ERR_NO_MEMORY;
        st = tvo_pyramid_init_borrowed(&vo->pyr[i], cfg->camera.width, cfg->camera.height, levels, pm, pyr);
        if (st != TVO_OK)
            return st;
    }
    vo->level0 = (uint8_t *)tvo_arena_alloc(&a, (size_t)cfg->camera.width * (size_t)cfg->camera.height);
    if (vo->level0 == NULL)
        return TVO_ERR_NO_MEMORY;
    vo->pts = (tvo_point2f *)tvo_arena_alloc(&a, n * sizeof(tvo_point2f));
    vo->next = (tvo_point2f *)tvo_arena_alloc(&a, n * sizeof(tvo_point2f));
    vo->st = (uint8_t *)tvo_arena_alloc(&a, n);
    vo->ok1 = (uint8_t *)tvo_arena_alloc(&a, n);
    vo->ok2 = (uint8_t *)tvo_arena_alloc(&a, n);
    vo->mask = (uint8_t *)tvo_arena_alloc(&a, n);
    vo->x1 = (tvo_point2d *)tvo_arena_alloc(&a, n * sizeof(tvo_point2d));
    vo->x2 = (tvo_point2d *)tvo_arena_alloc(&a, n * sizeof(tvo_point2d));
    vo->corners = (tvo_corner *)tvo_arena_alloc(&a, n * sizeof(tvo_corner));
    vo->x0 = (tvo_point2d *)tvo_arena_alloc(&a, n * sizeof(tvo_point2d));
    vo->has0 = (uint8_t *)tvo_arena_alloc(&a, n);
    vo->xk = (tvo_point2d *)tvo_arena_alloc(&a, n * sizeof(tvo_point2d));
    vo->kx1 = (tvo_point2d *)tvo_arena_alloc(&a, n * sizeof(tvo_point2d));
    vo->kx2 = (tvo_point2d *)tvo_arena_alloc(&a, n * sizeof(tvo_point2d));
    vo->hask = (uint8_t *)tvo_arena_alloc(&a, n);
    vo->kmask = (uint8_t *)tvo_arena_alloc(&a, n);
    vo->id = (uint32_t *)tvo_arena_alloc(&a, n * sizeof(uint32_t));
    vo->age = (int32_t *)tvo_arena_alloc(&a, n * sizeof(int32_t));
    vo->lm = (int32_t *)tvo_arena_alloc(&a, n * sizeof(int32_t));
    vo->tri_fr = (int32_t *)tvo_arena_alloc(&a, n * sizeof(int32_t));
    vo->tri_x = (tvo_point2d *)tvo_arena_alloc(&a, n * sizeof(tvo_point2d));
    vo->minl = (uint8_t *)tvo_arena_alloc(&a, n);
    if (vo->id == NULL || vo->age == NULL || vo->lm == NULL || vo->tri_fr == NULL || vo->tri_x == NULL ||
        vo->minl == NULL)
        return TVO_ERR_NO_MEMORY;
    if (cfg->map) {
        tvo_status ms = tvo_map_init(&vo->map, cfg, &a);
        if (ms != TVO_OK)
            return ms;
    }
#if TVO_WITH_AFFINE
    {
        const tvo_status as = affine_alloc(vo, cfg, &a);
        if (as != TVO_OK)
            return as;
    }
#endif
    vo->T_c_w = tvo_pose_identity();
    vo->chain_gain = 1.0;
    vo->v_dt = 0;
    vo->dt_unit = 0;
    vo->t_dir_age = TVO_VO_PRIOR_FRAMES + 1;
    vo->rescue_age = TVO_VO_MAX_RESCUE_FRAMES;
    set_r2_max(vo);
#if TVO_WITH_LENS
    if (cfg->lens_refine && (vo->lens = lens_alloc(cfg, &a)) == NULL)
        return TVO_ERR_NO_MEMORY;
#endif
    vo->scratch_size = scratch_need(cfg);
    vo->scratch = tvo_arena_alloc(&a, vo->scratch_size);
    if (vo->pts == NULL || vo->next == NULL || vo->st == NULL || vo->ok1 == NULL || vo->ok2 == NULL ||
        vo->mask == NULL || vo->x1 == NULL || vo->x2 == NULL || vo->corners == NULL || vo->x0 == NULL ||
        vo->has0 == NULL || vo->xk == NULL || vo->kx1 == NULL || vo->kx2 == NULL || vo->hask == NULL ||
        vo->kmask == NULL || vo->scratch == NULL)
        return TVO_ERR_NO_MEMORY;
    *out = vo;
    return TVO_OK;
}

void tvo_vo_reset(tvo_vo *vo)
{
    if (vo == NULL)
        return;
    vo->has_prev = 0;
    vo->n = 0;
    memset(vo->cell, 0, sizeof(vo->cell));
    vo->t_dir_age = TVO_VO_PRIOR_FRAMES + 1;
    vo->has_pose0 = 0;
    vo->has_kf = 0;
    if (vo->cfg.map)
        tvo_map_reset(&vo->map);
#if TVO_WITH_AFFINE
    refind_clear(vo);
#endif
    vo->T_c_w = tvo_pose_identity();
    vo->chain_gain = 1.0;
    vo->v_dt = 0;
    vo->dt_unit = 0;
    vo->next_id = 0;
    vo->has_pred = 0;
    vo->rescue_age = TVO_VO_MAX_RESCUE_FRAMES;
#if TVO_WITH_LENS
    if (vo->lens != NULL) {
        vo->cfg.camera = vo->lens->cam0;
        memset(&vo->lens->s, 0, sizeof(vo->lens->s));
        set_r2_max(vo);
    }
#endif
}

static int64_t now_ns(const tvo_vo *vo)
{
    return vo->cfg.clock != NULL ? vo->cfg.clock(vo->cfg.clock_user) : 0;
}

static void result_clear(tvo_vo_result *res, tvo_vo_state state)
{
    memset(res, 0, sizeof(*res));
    res->state = state;
    res->T_prev_cur = tvo_pose_identity();
    res->T_w_c = tvo_pose_identity();
}

/* The cell of the coverage grid a position falls in. */
static int32_t cover_cell(const tvo_vo *vo, tvo_point2f p)
{
    int32_t cx = (int32_t)(p.x * ((float)TVO_VO_COVER_COLS / (float)vo->cfg.camera.width)),
            cy = (int32_t)(p.y * ((float)TVO_VO_COVER_ROWS / (float)vo->cfg.camera.height));
    cx = cx < 0 ? 0 : (cx >= TVO_VO_COVER_COLS ? TVO_VO_COVER_COLS - 1 : cx);
    cy = cy < 0 ? 0 : (cy >= TVO_VO_COVER_ROWS ? TVO_VO_COVER_ROWS - 1 : cy);
    return cy * TVO_VO_COVER_COLS + cx;
}

/* The cells of the coverage grid holding a track (cfg.redetect_coverage). */
static int32_t track_coverage(const tvo_vo *vo)
{
    uint64_t cells = 0;
    int32_t n = 0;
    for (int32_t i = 0; i < vo->n; ++i)
        cells |= (uint64_t)1 << cover_cell(vo, vo->pts[i]);
    for (; cells != 0; cells &= cells - 1)
        ++n;
    return n;
}

/* cfg.redetect_cell_kept: a cell takes no new corners while fewer than that share of the corners detected
 * in it lately were kept. Each cell counts its corners born and kept in 1/256 (a corner adds 256), both
 * counts lose 1/8 a frame (rounded down), and a cell is judged once it counts TVO_VO_CELL_MIN_BORN. */
#define TVO_VO_CELL_MIN_BORN (4u * 256u)

/* The corners detected in the previous frame (age 0) counted in their cells: born, and kept when LK
 * tracked them (st). */
static void count_cells(tvo_vo *vo)
{
    uint32_t *v = &vo->cell[0][0];
    for (int32_t c = 0; c < 2 * TVO_VO_COVER_CELLS; ++c)
        v[c] -= v[c] >> 3;
    for (int32_t i = 0; i < vo->n; ++i) {
        if (vo->age[i] == 0) {
            const int32_t c = cover_cell(vo, vo->pts[i]);
            vo->cell[0][c] += 256u;
            vo->cell[1][c] += vo->st[i] ? 256u : 0u;
        }
    }
}

/* Detect corners on pyramid level 0 of `pyr` with FAST threshold `threshold`, avoiding the n current
 * tracks, and append them. */
static int32_t detect_append(tvo_vo *vo, const tvo_pyramid *pyr, int32_t threshold)
{
    tvo_image img = tvo_pyramid_level(pyr, 0);
    tvo_detect_config dc = vo->cfg.detect;
    int32_t room = vo->cfg.max_tracks - vo->n, got = 0;
    tvo_status st;
    if (room <= 0)
        return 0;
    dc.max_corners = room;
    dc.fast_threshold = threshold;
    st = tvo_detect(&dc, &img, vo->pts, vo->n, vo->corners, room, &got, vo->scratch, vo->scratch_size);
    if (st != TVO_OK && st != TVO_ERR_NO_MEMORY)
        return 0; /* a frame without corners is not an error: tracking just stays low */
    if (got > room)
        got = room;
    if (vo->cfg.redetect_cell_kept > 0.0) {
        /* the corners in closed cells are dropped */
        const double share = vo->cfg.redetect_cell_kept;
        int32_t k = 0;
        for (int32_t i = 0; i < got; ++i) {
            const tvo_point2f p = {vo->corners[i].x, vo->corners[i].y};
            const int32_t c = cover_cell(vo, p);
            if (vo->cell[0][c] < TVO_VO_CELL_MIN_BORN || (double)vo->cell[1][c] >= share * vo->cell[0][c])
                vo->corners[k++] = vo->corners[i];
        }
        got = k;
    }
    for (int32_t i = 0; i < got; ++i) {
        vo->pts[vo->n + i].x = vo->corners[i].x;
        vo->pts[vo->n + i].y = vo->corners[i].y;
        vo->has0[vo->n + i] = 0; /* a new track has no earlier position */
        vo->hask[vo->n + i] = 0; /* ...and none in the keyframe */
        vo->id[vo->n + i] = vo->next_id++;
        vo->age[vo->n + i] = 0;
        vo->lm[vo->n + i] = -1;
        vo->tri_fr[vo->n + i] = -1;
        vo->minl[vo->n + i] = 0;
        if (vo->hast != NULL)
            vo->hast[vo->n + i] = 0; /* its template is taken at the end of the frame */
    }
    vo->n += got;
    return got;
}

/* The grey levels of an image in a 256-bin histogram (zeroed here). */
static void grey_hist(const tvo_image *im, uint32_t hist[256])
{
    memset(hist, 0, 256 * sizeof(hist[0]));
    for (int32_t y = 0; y < im->height; ++y) {
        const uint8_t *row = im->data + (size_t)y * (size_t)im->stride;
        for (int32_t x = 0; x < im->width; ++x)
            hist[row[x]]++;
    }
}

/* The first grey level at which k (1 <= k <= the histogram's count) pixels are counted. */
static int32_t hist_rank(const uint32_t hist[256], uint32_t k)
{
    uint32_t acc = hist[0];
    int32_t v = 0;
    while (acc < k && v < 255)
        acc += hist[++v];
    return v;
}

/* The median grey level of an image (it has at least one pixel). */
static int32_t median_grey(const tvo_image *im)
{
    uint32_t hist[256];
    grey_hist(im, hist);
    return hist_rank(hist, ((uint32_t)im->width * (uint32_t)im->height + 1u) / 2u);
}

/* The grey-level range of the coarsest level of pyr: its 1st to 99th percentile. */
static int32_t grey_range(const tvo_pyramid *pyr)
{
    const tvo_image im = tvo_pyramid_level(pyr, pyr->levels - 1);
    const uint32_t n = (uint32_t)im.width * (uint32_t)im.height;
    uint32_t hist[256];
    grey_hist(&im, hist);
    return hist_rank(hist, n - n / 100u) - hist_rank(hist, n / 100u + 1u);
}

/* Re-detection: the configured threshold first; on a low-contrast frame (fewer than a quarter of the
 * corners wanted) a second pass with fast_min_threshold fills the rest. On a frame whose grey-level range
 * is below cfg.fast_range_ref both thresholds are scaled by range / fast_range_ref (rounded, at least 1; 0
 * stays 0). */
static int32_t redetect(tvo_vo *vo, const tvo_pyramid *pyr)
{
    const int32_t wanted = vo->cfg.max_tracks - vo->n, ref = vo->cfg.fast_range_ref;
    const int32_t range = ref > 0 ? grey_range(pyr) : 0;
    int32_t t[2], got;
    t[0] = vo->cfg.detect.fast_threshold;
    t[1] = vo->cfg.fast_min_threshold;
    for (int k = 0; k < 2 && range < ref; ++k) {
        const int32_t v = (t[k] * range + ref / 2) / ref;
        t[k] = t[k] > 0 && v < 1 ? 1 : v;
    }
    got = detect_append(vo, pyr, t[0]);
    if (got < wanted / 4 && t[1] > 0 && t[1] < t[0])
        got += detect_append(vo, pyr, t[1]);
    vo->cover_ref = track_coverage(vo);
    return got;
}

/* The relative pose of the m current correspondences (vo->x1 -> vo->x2); inliers into vo->mask. */
static tvo_status relpose_tracks(tvo_vo *vo, const tvo_relpose_config *rc, int32_t m, tvo_relpose *out)
{
    return tvo_relpose_estimate(rc, vo->x1, vo->x2, m, out, vo->mask, vo->scratch, vo->scratch_size);
}

/* The ambiguous estimate rp takes its twin's pose (R_alt, t_alt). */
static void take_twin(tvo_relpose *rp)
{
    memcpy(rp->R, rp->R_alt, sizeof(rp->R));
    memcpy(rp->t, rp->t_alt, sizeof(rp->t));
}

/* A plane seen with a small baseline has two poses that explain the plane's tracks equally well
 * (relpose flags AMBIGUOUS). The tracks off the plane fit only the true twin's epipolar geometry: the
 * twin they clearly favour (tvo_relpose_twin_choice at the pose threshold) is taken. Otherwise the
 * twin whose translation continues the recent motion (frames at camera rate move smoothly): with
 * cfg.map_twin_dir the map's last step while the map poses frames, when it is within 45 degrees of a
 * twin's direction; else the last two-view directions. Without a
 * recent direction, or when neither twin is within 45 degrees of it, the epipolar model alone (rc
 * without the homography) picks one. The frame keeps the AMBIGUOUS flag. If that fails too, only the
 * rotation is kept (the twins' rotations differ by about the parallax, which is small here).
 * Returns the resulting state and writes the pose to use into *rp. */
static tvo_vo_state resolve_ambiguous(tvo_vo *vo, tvo_relpose_config rc, int32_t m, tvo_relpose *rp)
{
    tvo_relpose re;
    const int twin = tvo_relpose_twin_choice(rp, vo->x1, vo->x2, m, rc.threshold);
    if (twin == 1)
        take_twin(rp);
    if (twin >= 0)
        return TVO_VO_OK;
    double md[3];
    if (vo->cfg.map_twin_dir && vo->cfg.map && tvo_map_motion_dir(&vo->map, md)) {
        /* the map's last step, when it is within 45 deg of a twin's direction (else the map's motion
           says nothing about this frame's: a young map's first steps) */
        const double c0 = rp->t[0] * md[0] + rp->t[1] * md[1] + rp->t[2] * md[2];
        const double c1 = rp->t_alt[0] * md[0] + rp->t_alt[1] * md[1] + rp->t_alt[2] * md[2];
        if (c1 > c0 && c1 >= TVO_VO_PRIOR_COS)
            take_twin(rp);
        if ((c1 > c0 ? c1 : c0) >= TVO_VO_PRIOR_COS)
            return TVO_VO_OK;
    }
    if (vo->t_dir_age <= TVO_VO_PRIOR_FRAMES) {
        const double *d = vo->t_dir;
        double c0 = rp->t[0] * d[0] + rp->t[1] * d[1] + rp->t[2] * d[2];
        double c1 = rp->t_alt[0] * d[0] + rp->t_alt[1] * d[1] + rp->t_alt[2] * d[2];
        if (c1 > c0) {
            take_twin(rp);
            c0 = c1;
        }
        if (c0 >= TVO_VO_PRIOR_COS)
            return TVO_VO_OK;
    }
    rp->t[0] = rp->t[1] = rp->t[2] = 0.0;
    rc.use_homography = 0;
    if (relpose_tracks(vo, &rc, m, &re) == TVO_OK &&
        !(re.flags & (TVO_RELPOSE_FLAG_LOW_CONFIDENCE | TVO_RELPOSE_FLAG_ROTATION_ONLY))) {
        re.flags |= rp->flags & (TVO_RELPOSE_FLAG_AMBIGUOUS | TVO_RELPOSE_FLAG_LOW_CONFIDENCE);
        *rp = re;
        return TVO_VO_OK;
    }
    return TVO_VO_ROTATION_ONLY;
}

static void fill_features(const tvo_vo_result *res, float f[TVO_FEAT_COUNT])
{
    double v[3];
    tvo_rot_to_rotvec(res->T_prev_cur.R, v);
    f[TVO_FEAT_RX] = (float)v[0];
    f[TVO_FEAT_RY] = (float)v[1];
    f[TVO_FEAT_RZ] = (float)v[2];
    f[TVO_FEAT_TX] = (float)res->T_prev_cur.t[0];
    f[TVO_FEAT_TY] = (float)res->T_prev_cur.t[1];
    f[TVO_FEAT_TZ] = (float)res->T_prev_cur.t[2];
    f[TVO_FEAT_INLIER_RATIO] = res->tracked > 0 ? (float)res->inliers / (float)res->tracked : 0.0f;
    f[TVO_FEAT_PARALLAX_DEG] = (float)res->parallax_deg;
    f[TVO_FEAT_TRACKS] = (float)res->tracked / 1000.0f;
    f[TVO_FEAT_DT] = (float)((double)res->dt_ns * 1e-9);
    f[TVO_FEAT_ROT_ONLY] = res->state == TVO_VO_ROTATION_ONLY ? 1.0f : 0.0f;
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* The homogeneous ray (x, y, 1) of a normalised point. */
static void homog(tvo_point2d p, double h[3])
{
    h[0] = p.x;
    h[1] = p.y;
    h[2] = 1.0;
}

/* Depth along the ray xb (homogeneous, z = 1) in frame b of the point seen along xa in frame a, with
 * X_b = R X_a + t: lambda xb - nu (R xa) = t, solved by crossing with R xa. 0 when the two rays are
 * closer than the angle whose squared sine is sin2_min (no usable parallax) or the point is behind
 * either camera. */
static double depth_in_b(const double R[9], const double t[3], const double xa[3], const double xb[3],
                         double sin2_min)
{
    double a[3], c[3], d[3], c2, lam, nu;
    tvo_la_mat3_vec(R, xa, a);
    tvo_la_cross(xb, a, c);
    c2 = dot3(c, c);
    if (!(c2 > sin2_min * dot3(xb, xb) * dot3(a, a)))
        return 0.0;
    tvo_la_cross(t, a, d);
    lam = dot3(c, d) / c2;
    /* nu from the same equation crossed with xb from the left: -nu (xb x R xa) = xb x t */
    tvo_la_cross(t, xb, d);
    nu = dot3(c, d) / c2;
    return (lam > 0.0 && nu > 0.0 && isfinite(lam)) ? lam : 0.0;
}

/* The relative scale of this frame's step over the previous one from the m carried tracks (x0 in frame
 * k-2 where has0, x1 in k-1, x2 in k) and the two unit-translation poses: each track's depth in frame
 * k-1 from the pair (k-2, k-1) over its depth from (k-1, k), the median over the tracks with enough
 * parallax in both. Writes the number of tracks used into *used; returns TVO_VO_REL_SCALE_NONE when
 * fewer than cfg.min_scale_points. Uses vo->scratch. */
static double relative_scale(tvo_vo *vo, const double R[9], const double t[3], int32_t m, int32_t *used)
{
    double *ratio = (double *)vo->scratch;
    const double sp = tvo_dm_sin(vo->cfg.scale_min_parallax_deg * (3.14159265358979323846 / 180.0));
    const double sin2_min = sp * sp;
    double Rt[9], tt[3];
    int32_t k = 0;
    /* the pair (k-1, k) seen from frame k-1: X_(k-1) = R^T X_k - R^T t */
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            Rt[3 * r + c] = R[3 * c + r];
    tvo_la_mat3_tvec(R, t, tt);
    tt[0] = -tt[0];
    tt[1] = -tt[1];
    tt[2] = -tt[2];
    for (int32_t i = 0; i < m; ++i) {
        double xa[3], xb[3], xc[3], da, db;
        if (!vo->has0[i])
            continue;
        homog(vo->x0[i], xa);
        homog(vo->x1[i], xb);
        homog(vo->x2[i], xc);
        da = depth_in_b(vo->R0, vo->t0, xa, xb, sin2_min); /* frame k-1 from (k-2, k-1) */
        if (da <= 0.0)
            continue;
        db = depth_in_b(Rt, tt, xc, xb, sin2_min); /* frame k-1 from (k-1, k) */
        if (db <= 0.0)
            continue;
        {
            const double r = da / db;
            if (isfinite(r) && r > 0.0)
                ratio[k++] = r;
        }
    }
    *used = k;
    if (k < vo->cfg.min_scale_points)
        return TVO_VO_REL_SCALE_NONE;
    {
        const double med = tvo_la_select_kth(ratio, k, k / 2);
        if (vo->cfg.map && vo->cfg.chain_scale_sigmas > 0.0) {
            /* for chain_follow_scale only: the median's standard error in log, 1.2533 sigma / sqrt(k) for
               the median of k normal values, sigma from the ratios' median absolute deviation in log
               (1.4826 MAD) */
            const double lmed = tvo_dm_log(med);
            for (int32_t i = 0; i < k; ++i)
                ratio[i] = fabs(tvo_dm_log(ratio[i]) - lmed);
            vo->rs_se = 1.4826 * 1.2533 * tvo_la_select_kth(ratio, k, k / 2) / sqrt((double)k);
        }
        return med;
    }
}

/* ---- keyframe rotation ------------------------------------------------------------------------- */

/* A keyframe rotation further than this from the frame-to-frame prediction (this frame's rotation
 * composed with the previous frame's R_pK) is not trusted, and a new keyframe is taken. At a few
 * hundredths of a degree of K -> cur parallax (a hovering camera) the five-point rotation can be 1-1.4
 * deg off while every other check passes; the frame-to-frame prediction is good to a few tenths there. */
#define TVO_VO_KF_CHECK_DEG 1.0

enum { KF_NONE = 0, KF_USED = 1, KF_FAILED = 2 };

/* Make the current frame the keyframe: every carried track's position (vo->pts, pixels) undistorted
 * into xk (hask 0 where that fails); the next frame's R_pK is the identity. */
static void keyframe_set(tvo_vo *vo)
{
    vo->has_kf = 0;
    if (vo->n <= 0 || tvo_camera_undistort(&vo->cfg.camera, vo->pts, vo->xk, vo->hask, vo->n) != TVO_OK)
        return;
    memset(vo->R_pK, 0, sizeof(vo->R_pK));
    vo->R_pK[0] = vo->R_pK[4] = vo->R_pK[8] = 1.0;
    vo->has_kf = 1;
    vo->kf_age = 0;
}

/* The rotation K -> cur (X_cur = R_cK X_K) from the tracks seen since the keyframe: those of the m
 * current tracks with hask[i] that are inliers of this frame's pose rp (vo->mask), estimated with the
 * frame's relpose config rc. KF_USED (R_cK written, the estimate's outliers lose their keyframe
 * position) when it is trustworthy and better placed than the frame-to-frame estimate: neither low
 * confidence nor ambiguous, at least cfg.min_pose_tracks inliers and half of the correspondences,
 * within TVO_VO_KF_CHECK_DEG of the frame-to-frame prediction rp.R R_pK and, with a translation,
 * within the frame-to-frame rotation check of its own rotation-only model; for a frame with a
 * translation also more parallax than rp (a frame-to-frame rotation-only frame takes any).
 * KF_FAILED when it is not trustworthy (take a new keyframe), KF_NONE when it is fine but not better.
 * *kpar gets its parallax (0 when none ran). Uses vo->scratch. */
static int keyframe_rotation(tvo_vo *vo, const tvo_relpose_config *rc, int32_t m, const tvo_relpose *rp,
                             tvo_vo_state state, double R_cK[9], double *kpar)
{
    tvo_relpose kp;
    double Rpred[9], d;
    int32_t k = 0;
    *kpar = 0.0;
    for (int32_t i = 0; i < m; ++i) {
        if (vo->mask[i] && vo->hask[i]) {
            vo->kx1[k] = vo->xk[i];
            vo->kx2[k] = vo->x2[i];
            ++k;
        }
    }
    if (k < vo->cfg.min_pose_tracks)
        return KF_FAILED;
    if (tvo_relpose_estimate(rc, vo->kx1, vo->kx2, k, &kp, vo->kmask, vo->scratch, vo->scratch_size) !=
        TVO_OK)
        return KF_FAILED;
    *kpar = kp.parallax_deg;
    if ((kp.flags & (TVO_RELPOSE_FLAG_LOW_CONFIDENCE | TVO_RELPOSE_FLAG_AMBIGUOUS)) ||
        kp.inliers < vo->cfg.min_pose_tracks || 2 * kp.inliers < k)
        return KF_FAILED;
    tvo_la_mat3_mul(rp->R, vo->R_pK, Rpred);
    d = tvo_la_rot_dist(kp.R, Rpred) * TVO_VO_DEG_PER_RAD;
    if (d > TVO_VO_KF_CHECK_DEG)
        return KF_FAILED;
    if (!(kp.flags & TVO_RELPOSE_FLAG_ROTATION_ONLY) && rotation_check_fails(&kp))
        return KF_FAILED;
    if (state == TVO_VO_OK && !(kp.parallax_deg > rp->parallax_deg))
        return KF_NONE;
    for (int32_t i = 0, j = 0; i < m; ++i) {
        if (vo->mask[i] && vo->hask[i]) {
            if (!vo->kmask[j])
                vo->hask[i] = 0;
            ++j;
        }
    }
    memcpy(R_cK, kp.R, sizeof(kp.R));
    return KF_USED;
}

/* The unit translation t of X_cur = R X_prev + t with R fixed, from the inliers (vo->mask) of the m
 * correspondences x1 -> x2: x2^T [t]x R x1 = 0 is linear in t, each point gives a row a = (R x1) x x2
 * with a . t = 0, and t is the eigenvector of the smallest eigenvalue of sum a a^T (3x3); its sign is
 * the one that puts more points in front of both cameras. (Weighting the rows by the inverse Sampson
 * denominators, iterated 3 times, did not do better on the EuRoC renders.) 1 when t was written. */
static int translation_given_rotation(const tvo_vo *vo, const double R[9], int32_t m, double t[3])
{
    double A[9] = {0}, w[3], V[9], u[3], un[3], nrm;
    int32_t k = 0, front = 0, back = 0;
    for (int32_t i = 0; i < m; ++i) {
        double x1[3], x2[3], Rx[3], a[3];
        if (!vo->mask[i])
            continue;
        homog(vo->x1[i], x1);
        homog(vo->x2[i], x2);
        tvo_la_mat3_vec(R, x1, Rx);
        tvo_la_cross(Rx, x2, a);
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
                A[3 * r + c] += a[r] * a[c];
        ++k;
    }
    /* w[1] > 0: the null direction is unique */
    if (k < 5 || tvo_la_sym_eig(A, 3, w, V) != TVO_OK || !(w[1] > 0.0) || !isfinite(w[2]))
        return 0;
    u[0] = V[0];
    u[1] = V[3];
    u[2] = V[6];
    nrm = sqrt(dot3(u, u));
    if (!(nrm > 0.0) || !isfinite(nrm))
        return 0;
    for (int c = 0; c < 3; ++c) {
        u[c] /= nrm;
        un[c] = -u[c];
    }
    for (int32_t i = 0; i < m; ++i) {
        double x1[3], x2[3];
        if (!vo->mask[i])
            continue;
        homog(vo->x1[i], x1);
        homog(vo->x2[i], x2);
        front += depth_in_b(R, u, x1, x2, 0.0) > 0.0;
        back += depth_in_b(R, un, x1, x2, 0.0) > 0.0;
    }
    memcpy(t, back > front ? un : u, sizeof(u));
    return 1;
}

#if TVO_WITH_AFFINE
/* cfg.map_refind: track i ends; when it carries a landmark and holds a template, both go into the store
 * (the oldest entry overwritten). */
static void refind_keep(tvo_vo *vo, int32_t i)
{
    const int32_t e = vo->rf_next, j = vo->lm[i];
    if (vo->rf_lm == NULL || vo->hast == NULL || j < 0 || !vo->hast[i] || !vo->map.lm[j].alive)
        return;
    const size_t tb = tvo_aff_template_bytes(vo->cfg.affine_win_size);
    vo->rf_lm[e] = j;
    vo->rf_gen[e] = vo->map.lm[j].gen;
    vo->rf_miss[e] = 0;
    vo->rf_wait[e] = TVO_VO_REFIND_WAIT;
    memcpy(vo->rf_tpl + (size_t)e * tb, vo->tpl + (size_t)i * tb, tb);
    vo->rf_am[e] = vo->am[i];
    vo->rf_aw[e] = vo->aw[i];
    vo->rf_next = (e + 1) % vo->cfg.map_refind;
}
#endif

/* Keep the entries i with keep[i] != 0 of the parallel track arrays, in order (an entry dropped leaves
 * its landmark's template to cfg.map_refind). */
static int32_t compact(tvo_vo *vo, int32_t n, const uint8_t *keep)
{
    int32_t m = 0;
    for (int32_t i = 0; i < n; ++i) {
        if (!keep[i]) {
#if TVO_WITH_AFFINE
            refind_keep(vo, i);
#endif
            continue;
        }
        vo->pts[m] = vo->pts[i];
        vo->next[m] = vo->next[i];
        vo->x1[m] = vo->x1[i];
        vo->ok1[m] = vo->ok1[i]; /* with keep == ok1 too: ok1[i] is read before any ok1[m <= i] is written */
        vo->x2[m] = vo->x2[i];
        vo->x0[m] = vo->x0[i];
        vo->has0[m] = vo->has0[i];
        vo->xk[m] = vo->xk[i];
        vo->hask[m] = vo->hask[i];
        vo->id[m] = vo->id[i];
        vo->age[m] = vo->age[i];
        vo->lm[m] = vo->lm[i];
        vo->tri_fr[m] = vo->tri_fr[i];
        vo->tri_x[m] = vo->tri_x[i];
        vo->minl[m] = vo->minl[i];
#if TVO_WITH_AFFINE
        if (vo->hast != NULL) {
            if (m != i) {
                const size_t tb = tvo_aff_template_bytes(vo->cfg.affine_win_size);
                memcpy(vo->tpl + (size_t)m * tb, vo->tpl + (size_t)i * tb, tb);
                vo->aw[m] = vo->aw[i];
                vo->am[m] = vo->am[i];
            }
            vo->hast[m] = vo->hast[i];
        }
#endif
        ++m;
    }
    return m;
}

/* Track i's guess from its predicted camera point (d0, d1, d2), distorted back to pixels, when it lies
 * in front of the camera and inside the camera's domain; pred[i] = from then. */
static void predict_store(tvo_vo *vo, int32_t i, double d0, double d1, double d2, int from, uint8_t *pred)
{
    tvo_point2d q;
    double u, w;
    if (!(d2 > 1e-3 * (from ? fabs(d0) + fabs(d1) + fabs(d2) : 1.0)))
        return;
    q.x = d0 / d2;
    q.y = d1 / d2;
    if (q.x * q.x + q.y * q.y <= vo->r2_max &&
        tvo_camera_distort_point(&vo->cfg.camera, &q, &u, &w) == TVO_OK) {
        vo->next[i].x = (float)u;
        vo->next[i].y = (float)w;
        pred[i] = (uint8_t)from;
    }
}

/* Neighbours whose landmark depths give a track without a landmark its depth (map_prediction 2). */
#define TVO_VO_PRED_NEIGHBOURS 4

/* map_prediction 2: a track without a predicted landmark gets the median depth (in the previous frame)
 * of the TVO_VO_PRED_NEIGHBOURS landmark tracks nearest to it in the previous image (vo->x2[j].x > 0),
 * and its guess where that point moves with the map's predicted pose T (pred 2). */
static void predict_by_neighbours(tvo_vo *vo, const tvo_pose *T, uint8_t *pred)
{
    const double *Rl = vo->map.last_T_c_w.R, *tl = vo->map.last_T_c_w.t;
    for (int32_t i = 0; i < vo->n; ++i) {
        float bd[TVO_VO_PRED_NEIGHBOURS];
        double bz[TVO_VO_PRED_NEIGHBOURS], z, c[3], X[3], d[3];
        int k = 0;
        if (pred[i] || vo->x2[i].x > 0.0 || !vo->ok1[i])
            continue;
        for (int32_t j = 0; j < vo->n; ++j) {
            float dx, dy, dd;
            int p;
            if (!(vo->x2[j].x > 0.0))
                continue;
            dx = vo->pts[j].x - vo->pts[i].x;
            dy = vo->pts[j].y - vo->pts[i].y;
            dd = dx * dx + dy * dy;
            if (k == TVO_VO_PRED_NEIGHBOURS && !(dd < bd[k - 1]))
                continue;
            p = k < TVO_VO_PRED_NEIGHBOURS ? k++ : k - 1;
            while (p > 0 && bd[p - 1] > dd) {
                bd[p] = bd[p - 1];
                bz[p] = bz[p - 1];
                --p;
            }
            bd[p] = dd;
            bz[p] = vo->x2[j].x;
        }
        if (k < TVO_VO_PRED_NEIGHBOURS)
            continue;
        /* the median of the depths (the mean of the middle two) */
        for (int a = 1; a < k; ++a)
            for (int b = a; b > 0 && bz[b - 1] > bz[b]; --b) {
                const double t = bz[b];
                bz[b] = bz[b - 1];
                bz[b - 1] = t;
            }
        z = 0.5 * (bz[k / 2 - 1] + bz[k / 2]);
        /* the point in the previous camera, in the world, then in this frame's predicted camera */
        c[0] = vo->x1[i].x * z - tl[0];
        c[1] = vo->x1[i].y * z - tl[1];
        c[2] = z - tl[2];
        for (int r = 0; r < 3; ++r)
            X[r] = Rl[r] * c[0] + Rl[3 + r] * c[1] + Rl[6 + r] * c[2];
        tvo_pose_transform_point(T, X, d);
        predict_store(vo, i, d[0], d[1], d[2], 2, pred);
    }
}

/* LK's initial guesses, in vo->next, and which of them LK may trust (pred[i], for tvo_lk_track_pred):
 *  - cfg.map_prediction: a track carrying a landmark that was an inlier of the previous frame's map pose
 *    starts where the landmark projects with the map's constant-velocity pose of this frame (pred 1);
 *  - cfg.track_prediction: the other tracks move by the last frame's rotation, scaled to this frame's
 *    interval (constant angular velocity; points at infinity, so no depth is needed), when the intervals
 *    are within [1/2, 2] of each other (pred 0);
 *  - any other track, or one whose prediction leaves the camera's domain, keeps its position as guess.
 * The tracks' undistorted positions stay in x1 / ok1 (step 2 of tvo_vo_process uses them). 0 when no
 * prediction applies. */
static int predict_tracks(tvo_vo *vo, int64_t dt, uint8_t *pred)
{
    double R[9], ratio = 1.0;
    tvo_pose T;
    int rot = vo->cfg.track_prediction && vo->has_pred && vo->dt_pred > 0 && dt > 0;
    const int mp = vo->cfg.map_prediction && vo->cfg.map && dt > 0 &&
            tvo_map_predict_pose(&vo->map, vo->t_prev + dt, vo->t_prev, &T);
    if (rot) {
        ratio = (double)dt / (double)vo->dt_pred;
        rot = ratio >= 0.5 && ratio <= 2.0;
    }
    memset(pred, 0, (size_t)vo->n);
    if (!rot && !mp)
        return 0;
    if (tvo_camera_undistort(&vo->cfg.camera, vo->pts, vo->x1, vo->ok1, vo->n) != TVO_OK)
        return 0;
    if (rot)
        tvo_rot_pow(vo->R_pred, ratio, R);
    for (int32_t i = 0; i < vo->n; ++i) {
        const double x = vo->x1[i].x, y = vo->x1[i].y;
        double d0, d1, d2;
        int from = 0; /* 1: its landmark, 2: its neighbours' depth */
        vo->next[i] = vo->pts[i];
        vo->x2[i].x = 0.0; /* the landmark's depth in the previous frame (0: none); x2 is free here */
        if (mp && vo->lm[i] >= 0 && vo->minl[i] && vo->map.lm[vo->lm[i]].alive) {
            const double *X = vo->map.lm[vo->lm[i]].X;
            double p[3], q[3];
            tvo_pose_transform_point(&vo->map.last_T_c_w, X, p);
            tvo_pose_transform_point(&T, X, q);
            d0 = q[0];
            d1 = q[1];
            d2 = q[2];
            if (p[2] > 0.0)
                vo->x2[i].x = p[2];
            from = 1;
        } else if (rot && vo->ok1[i]) {
            d0 = R[0] * x + R[1] * y + R[2];
            d1 = R[3] * x + R[4] * y + R[5];
            d2 = R[6] * x + R[7] * y + R[8];
        } else
            continue;
        predict_store(vo, i, d0, d1, d2, from, pred);
    }
    if (mp && vo->cfg.map_prediction == 2)
        predict_by_neighbours(vo, &T, pred);
    return 1;
}

/* ---- local map ---------------------------------------------------------------------------------- */

/* A LOST frame carries the pose on at the last posed frame's motion for at most this long in all. */
#define TVO_VO_COAST_NS 1000000000
/* and with its interval at most this many times that frame's; a step of the chain before the first map
   is at most this many units (chain_units: a first interval far shorter than the rest, a duplicated
   frame's, would otherwise give steps of thousands of units) */
#define TVO_VO_COAST_MAX_RATIO 10.0

/* A LOST frame's step: the last posed frame's motion scaled to dt (its rotation vector and translation
 * times the ratio of the intervals), or the identity past the limits above. */
static void coast_step(const tvo_vo *vo, int64_t dt, tvo_pose *step)
{
    double r;
    if (vo->v_dt <= 0 || dt <= 0 || dt > TVO_VO_COAST_NS - vo->lost_ns)
        return;
    r = (double)dt / (double)vo->v_dt;
    if (!(r <= TVO_VO_COAST_MAX_RATIO))
        return;
    tvo_rot_pow(vo->v_step.R, r, step->R);
    for (int c = 0; c < 3; ++c)
        step->t[c] = vo->v_step.t[c] * r;
}

/* A frame interval within this factor of the chain's first (either way) counts as one frame: timestamps
   that jitter around a steady rate (a driver's or a USB camera's) give steps of one length, and only a
   frame after dropped ones (an interval of 2, 3, ... frames) or a change of the frame rate steps further. */
#define TVO_VO_CHAIN_DT_BAND 1.5

/* The chain's length of a frame interval dt before the first map, in units of its first interval
 * (dt_unit): 1 within TVO_VO_CHAIN_DT_BAND of it, else dt / dt_unit, at most TVO_VO_COAST_MAX_RATIO. */
static double chain_units(const tvo_vo *vo, int64_t dt)
{
    double r;
    if (vo->dt_unit <= 0 || dt <= 0)
        return 1.0;
    r = (double)dt / (double)vo->dt_unit;
    if (r > TVO_VO_COAST_MAX_RATIO)
        return TVO_VO_COAST_MAX_RATIO;
    return r * TVO_VO_CHAIN_DT_BAND > 1.0 && r < TVO_VO_CHAIN_DT_BAND ? 1.0 : r;
}

/* The pose the two-view chain gives this frame (world -> camera): the last pose moved by this frame's
 * two-view step, its unit translation scaled to the map's last speed (unit steps without a map). A LOST
 * frame moves on by the last posed frame's motion scaled to its own interval (constant velocity), for
 * at most TVO_VO_COAST_NS of LOST frames in a row; then it stands still. */
static tvo_pose chain_pose(const tvo_vo *vo, const tvo_vo_result *res)
{
    tvo_pose step = tvo_pose_identity();
    if (res->state == TVO_VO_LOST) {
        coast_step(vo, res->dt_ns, &step);
    } else if (res->state == TVO_VO_OK || res->state == TVO_VO_ROTATION_ONLY) {
        double len = 0.0;
        step = tvo_pose_inverse(&res->T_prev_cur); /* T_cur_prev */
        /* before the first map one unit per frame, counted by chain_units (a frame after dropped ones
           steps further), and the first map's baseline continues it (tvo_map.h); times the speed changes
           chain_follow_scale took (1 without cfg.chain_scale_sigmas) */
        if (res->state == TVO_VO_OK) {
            if (vo->cfg.map && vo->map.speed > 0.0)
                len = vo->map.speed * (double)res->dt_ns * 1e-9;
            else
                len = chain_units(vo, res->dt_ns);
            len *= vo->chain_gain;
        }
        if (!(len >= 0.0) || !isfinite(len))
            len = 0.0;
        for (int c = 0; c < 3; ++c)
            step.t[c] *= len;
    }
    return tvo_pose_compose(&step, &vo->T_c_w);
}

/* With cfg.chain_scale_sigmas > 0 (and the map on), the chain's step length follows this frame's
 * relative scale where it differs from a constant speed by more than that many standard errors: the
 * log of rel_scale soft-thresholded by that bound (the change the tracks show beyond their noise, shrunk
 * by it), so that a constant speed keeps its steps and a camera that speeds up or slows down before its
 * first map (a car starting, a jerk) gets steps of the right length. The gain stays within [1e-3, 1e3]. */
static void chain_follow_scale(tvo_vo *vo, const tvo_vo_result *res)
{
    double z, tau, w;
    if (!vo->cfg.map || !(vo->cfg.chain_scale_sigmas > 0.0) || res->state != TVO_VO_OK ||
        !(res->rel_scale > 0.0) || !isfinite(res->rel_scale))
        return;
    /* the speed's change: rel_scale over the ratio of the two frame intervals in the chain's units (1 at
       a steady rate, timestamp jitter included) */
    z = tvo_dm_log(res->rel_scale);
    if (vo->dt_pred > 0 && res->dt_ns > 0) {
        const double q = chain_units(vo, vo->dt_pred) / chain_units(vo, res->dt_ns);
        if (q != 1.0)
            z += tvo_dm_log(q);
    }
    tau = vo->cfg.chain_scale_sigmas * vo->rs_se;
    w = z > tau ? z - tau : (z < -tau ? z + tau : 0.0);
    vo->chain_gain *= tvo_dm_exp(w);
    if (!(vo->chain_gain >= 1e-3))
        vo->chain_gain = 1e-3;
    else if (vo->chain_gain > 1e3)
        vo->chain_gain = 1e3;
}

static void affine_refine_keyframe(void *ctx);

static tvo_map_tracks map_tracks(tvo_vo *vo)
{
    tvo_map_tracks tr;
    tr.n = vo->n;
    tr.x = vo->x2;
    tr.x_ok = vo->ok2;
    tr.lm = vo->lm;
    tr.tri_fr = vo->tri_fr;
    tr.tri_x = vo->tri_x;
    tr.inlier = vo->minl;
    tr.refine = NULL;
    tr.refine_ctx = NULL;
    return tr;
}

/* Below this parallax (deg) a frame's two-view rotation is a weak prior for the map (tvo_map.h): on the
 * long MH_01 render the landmarks' own rotation was the better one below about 0.2 deg, the two-view
 * rotation above it; testing the prior on frames up to 0.5 deg made the KITTI 01 highway frames worse
 * (per-frame rotation RPE 0.05-0.07 -> 0.08-0.11 deg over five RANSAC seeds). */
#define TVO_VO_WEAK_PRIOR_PARALLAX_DEG 0.2

/* The map's view of this frame's two-view rotation: rotation-only, weak (rotation-only, a plane's
 * twin, or little parallax), and after a jerk (a prediction rescue within cfg.map_rot_prior_obs_frames
 * frames). */
static int map_prior_flags(const tvo_vo *vo, const tvo_vo_result *res)
{
    const int rot_only = res->state == TVO_VO_ROTATION_ONLY;
    int f = rot_only ? TVO_MAP_PRIOR_ROT_ONLY : 0;
    if (rot_only || (res->relpose_flags & TVO_RELPOSE_FLAG_AMBIGUOUS) ||
        res->parallax_deg < TVO_VO_WEAK_PRIOR_PARALLAX_DEG)
        f |= TVO_MAP_PRIOR_WEAK;
    if (vo->rescue_age < vo->cfg.map_rot_prior_obs_frames)
        f |= TVO_MAP_PRIOR_JERK;
    return f;
}

#if TVO_WITH_LENS
/* The lens changed from cfg.camera to *to: every normalised position the VO and its map keep (the
 * tracks' previous, current, keyframe, two-frames-back and waiting positions, the window's observations)
 * moved to where the new lens sees the same pixel. */
static void lens_apply(tvo_vo *vo, const tvo_camera *to)
{
    const tvo_camera from = vo->cfg.camera;
    for (int32_t i = 0; i < vo->n; ++i) {
        (void)tvo_lens_remap(&from, to, &vo->x0[i]);
        (void)tvo_lens_remap(&from, to, &vo->x1[i]);
        (void)tvo_lens_remap(&from, to, &vo->x2[i]);
        (void)tvo_lens_remap(&from, to, &vo->xk[i]);
        (void)tvo_lens_remap(&from, to, &vo->tri_x[i]);
    }
    tvo_map_remap(&vo->map, &from, to);
    vo->cfg.camera = *to;
    set_r2_max(vo);
}

/* cfg.lens_refine: the keyframe's lens block (if any) added, and the change adopted when tvo_lens_decide
 * says so. */
static void lens_step(tvo_vo *vo, const tvo_map_frame *mf, tvo_vo_result *res)
{
    tvo_lens *s;
    if (vo->lens == NULL)
        return;
    s = &vo->lens->s;
    if (mf->lens_ok) {
        double dk[2];
        tvo_camera c;
        tvo_lens_add(s, &mf->lens);
        if (tvo_lens_decide(s, &vo->cfg.camera, dk, NULL, &c) == TVO_LENS_ADOPT) {
            lens_apply(vo, &c);
            s->updates++;
            s->dk[0] += dk[0];
            s->dk[1] += dk[1];
            tvo_lens_clear_blocks(s);
            res->lens_update = 1;
        }
    }
    res->lens_updates = s->updates;
    res->lens_dk[0] = s->dk[0];
    res->lens_dk[1] = s->dk[1];
}
#endif

/* Before the frame's pose T_c_w replaces the previous one in vo->T_c_w: a posed frame's motion becomes
 * the one a LOST frame carries on (coast_step); a LOST frame adds its interval to the time carried. */
static void keep_velocity(tvo_vo *vo, const tvo_vo_result *res, const tvo_pose *T_c_w)
{
    if (res->state != TVO_VO_LOST) { /* OK or rotation-only; the first frame (dt 0) leaves none */
        const tvo_pose inv_before = tvo_pose_inverse(&vo->T_c_w);
        vo->v_step = tvo_pose_compose(T_c_w, &inv_before);
        vo->v_dt = res->dt_ns;
        vo->lost_ns = 0;
    } else {
        vo->lost_ns = res->dt_ns > TVO_VO_COAST_NS - vo->lost_ns ? TVO_VO_COAST_NS : vo->lost_ns + res->dt_ns;
    }
}

/* The map's part of a frame, after the two-view step: vo->x2 holds the normalised positions of the
 * vo->n carried tracks. R_cur_prev: this frame's two-view rotation, or NULL. Sets vo->T_c_w. */
static void map_step(tvo_vo *vo, tvo_vo_result *res, int64_t t_ns, const double *R_cur_prev)
{
    tvo_pose prior;
    tvo_map_tracks tr;
    tvo_map_frame mf;
    if (vo->cfg.map && vo->dt_unit == 0 && res->dt_ns > 0)
        vo->dt_unit = res->dt_ns;
    chain_follow_scale(vo, res);
    prior = chain_pose(vo, res);
    if (!vo->cfg.map) {
        keep_velocity(vo, res, &prior);
        vo->T_c_w = prior;
        res->map_state = TVO_MAP_OFF;
        return;
    }
    memset(vo->ok2, 1, (size_t)vo->n);
    tr = map_tracks(vo);
    if (vo->cfg.affine_win_size > 0 && vo->cfg.affine_at_keyframes) {
        tr.refine = affine_refine_keyframe;
        tr.refine_ctx = vo;
    }
    if (tvo_map_process(&vo->map, &vo->cfg, &tr, t_ns, R_cur_prev, map_prior_flags(vo, res), &prior,
                        vo->scratch, vo->scratch_size, &mf) != TVO_OK ||
        !tvo_pose_is_finite(&mf.T_c_w)) {
        mf.T_c_w = prior;
        mf.state = TVO_MAP_LOST;
    }
    keep_velocity(vo, res, &mf.T_c_w);
    vo->T_c_w = mf.T_c_w;
    if (mf.state == TVO_MAP_TRACKING || mf.state == TVO_MAP_INITIALISED)
        vo->chain_gain = 1.0; /* a chain that starts again (a loss) starts from the map's speed */
    res->map_state = mf.state;
    res->keyframe = mf.keyframe;
    res->map_points = mf.points;
    res->map_new_points = mf.new_points;
    res->ba_iterations = mf.ba_iterations;
    res->ba_flags = mf.ba_flags;
#if TVO_WITH_LENS
    lens_step(vo, &mf, res);
#endif
}

/* Tracks from index `first` on were just detected: undistort them into x2 and let the map know. */
static void map_new_tracks(tvo_vo *vo, int32_t first)
{
    tvo_map_tracks tr;
    if (!vo->cfg.map || first >= vo->n)
        return;
    if (tvo_camera_undistort(&vo->cfg.camera, vo->pts + first, vo->x2 + first, vo->ok2 + first,
                             vo->n - first) != TVO_OK)
        memset(vo->ok2 + first, 0, (size_t)(vo->n - first));
    tr = map_tracks(vo);
    tvo_map_new_tracks(&vo->map, &tr, first);
}

/* What one frame's stages hand to each other (tvo_vo_process). */
typedef struct frame_ctx {
    tvo_pyramid *pc, *pp; /* this frame's pyramid, the previous frame's */
    int32_t m;            /* correspondences (tracks with both ends) */
    int32_t pose0_next;   /* this frame's pose is a unit translation for the next rel_scale */
    int32_t pred_next;    /* this frame's rotation predicts the next frame's tracks */
    int predicted;        /* LK started from predicted positions (x1 / ok1 then hold pts') */
    int kf;               /* what the keyframe rotation did this frame */
    double kpar;          /* its parallax */
    double R2v[9];        /* this frame's two-view rotation (X_cur = R X_prev), valid when has_R2v */
    int has_R2v;
} frame_ctx;

/* 1b. The affine refinement (cfg.affine_win_size > 0): each tracked point that has a template moves to
 * where its template aligns under an affine warp, starting from LK's position with the last frame's
 * warp; a point whose refinement fails keeps LK's position and takes a new template in finish_frame. */
#if TVO_WITH_AFFINE
/* A template (tpl, am) aligned in l0 from `at` with the warp *aw moved there: 1 when the alignment is
 * taken (converged, correlated, within TVO_VO_AFF_MAX_MOVE px of `at`), with the new warp in *aw and the
 * point in *out; TVO_AFF_AT_BORDER when the window reached the image's border, 0 when it failed. */
static int align_template(tvo_vo *vo, const uint8_t *tpl, const tvo_aff_model *am, const tvo_image *l0,
                          tvo_point2f at, tvo_aff_warp *aw, tvo_point2f *out)
{
    float ox, oy, px, py, ncc = 0.0f;
    tvo_aff_point(aw, &ox, &oy);
    aw->t[0] += at.x - ox;
    aw->t[1] += at.y - oy;
    const int r = tvo_aff_refine(tpl, am, vo->cfg.affine_win_size, vo->cfg.affine_step, l0, aw,
                                 TVO_VO_AFF_ITERS, TVO_VO_AFF_EPS, vo->scratch, vo->scratch_size, &ncc);
    if (r != 1)
        return r; /* 0, or TVO_AFF_AT_BORDER */
    if (!(ncc >= TVO_VO_AFF_MIN_NCC))
        return 0;
    tvo_aff_point(aw, &px, &py);
    if (!((px - at.x) * (px - at.x) + (py - at.y) * (py - at.y) < TVO_VO_AFF_MAX_MOVE * TVO_VO_AFF_MAX_MOVE))
        return 0;
    out->x = px;
    out->y = py;
    return 1;
}

/* Track i's alignment to its template in l0, from `at` (where LK left it) with the warp of its last
 * refinement (align_template); the caller commits a taken one. Either way the track is counted and left
 * without a template until then (hast[i] 0: a new one is taken in finish_frame). */
static int affine_align(tvo_vo *vo, int32_t i, const tvo_image *l0, tvo_point2f at, tvo_aff_warp *aw,
                        tvo_point2f *out)
{
    *aw = vo->aw[i];
    vo->aff_tried++;
    vo->hast[i] = 0;
    return align_template(vo, vo->tpl + (size_t)i * tvo_aff_template_bytes(vo->cfg.affine_win_size),
                          &vo->am[i], l0, at, aw, out);
}

/* A taken alignment: the warp kept, the template valid again. */
static void affine_commit(tvo_vo *vo, int32_t i, const tvo_aff_warp *aw)
{
    vo->aw[i] = *aw;
    vo->hast[i] = 1;
    vo->aff_refined++;
}

static void affine_refine(tvo_vo *vo, const frame_ctx *fc)
{
    int32_t tried = 0, failed = 0;
    if (vo->hast == NULL)
        return;
    const tvo_image l0 = tvo_pyramid_level(fc->pc, 0);
    /* kmask (free from the end of LK to the pose stage) flags the tracks whose alignment failed */
    memset(vo->kmask, 0, (size_t)vo->n);
    for (int32_t i = 0; i < vo->n; ++i) {
        tvo_aff_warp aw;
        tvo_point2f p;
        int r;
        if (!vo->st[i] || !vo->hast[i])
            continue;
        r = affine_align(vo, i, &l0, vo->next[i], &aw, &p);
        if (r == TVO_AFF_AT_BORDER)
            continue;
        ++tried;
        if (r != 1) {
            vo->kmask[i] = 1;
            ++failed;
            continue;
        }
        vo->next[i] = p;
        affine_commit(vo, i, &aw);
    }
    /* cfg.affine_end_share: in a frame where few alignments fail, a failure is the track's (a corner on a
       depth edge slides along it), where many fail it is the images' (blur, low contrast); a window at
       the image's border is neither, and was not counted */
    if (failed > 0 && (double)failed <= vo->cfg.affine_end_share * (double)tried)
        for (int32_t i = 0; i < vo->n; ++i)
            if (vo->kmask[i]) {
                vo->st[i] = 0;
                vo->aff_ended++;
            }
}

/* With affine_at_keyframes: the refinement of a frame that becomes a keyframe (the map's refine hook,
 * after the frame's map pose): every track with a template moves to where its template aligns, from
 * where LK left it; its normalised position (x2, the map's view) follows. A track whose refinement fails
 * keeps its position and takes a new template in finish_frame. */
static void affine_refine_keyframe(void *ctx)
{
    tvo_vo *vo = (tvo_vo *)ctx;
    if (vo->hast == NULL)
        return;
    const tvo_image l0 = tvo_pyramid_level(&vo->pyr[vo->cur], 0);
    for (int32_t i = 0; i < vo->n; ++i) {
        tvo_aff_warp aw;
        tvo_point2f p;
        tvo_point2d xn;
        if (!vo->hast[i] || affine_align(vo, i, &l0, vo->pts[i], &aw, &p) != 1 ||
            tvo_camera_undistort_point(&vo->cfg.camera, p.x, p.y, &xn) != TVO_OK)
            continue;
        vo->pts[i] = p;
        vo->next[i] = p;
        vo->x2[i] = xn;
        affine_commit(vo, i, &aw);
    }
}

/* The end of a frame with the affine refinement: every track without a template (new, or whose
 * refinement failed) takes one from this frame, where it lies now. */
static void affine_take(tvo_vo *vo, const frame_ctx *fc)
{
    const int32_t side = vo->cfg.affine_win_size;
    if (vo->hast == NULL)
        return;
    const tvo_image l0 = tvo_pyramid_level(fc->pc, 0);
    const size_t tb = tvo_aff_template_bytes(side);
    for (int32_t i = 0; i < vo->n; ++i)
        if (!vo->hast[i])
            vo->hast[i] = (uint8_t)tvo_aff_take(&l0, vo->pts[i].x, vo->pts[i].y, side, vo->cfg.affine_step,
                                                vo->tpl + (size_t)i * tb, &vo->am[i], &vo->aw[i]);
}
#else
/* left out of this build (TVO_WITH_AFFINE 0): config_valid() refuses affine_win_size > 0 */
static void affine_refine_keyframe(void *ctx)
{
    (void)ctx;
}

static void affine_refine(tvo_vo *vo, const frame_ctx *fc)
{
    (void)vo;
    (void)fc;
}

static void affine_take(tvo_vo *vo, const frame_ctx *fc)
{
    (void)vo;
    (void)fc;
}
#endif

/* 1 when q lies in the image (a NaN does not). */
static int in_image(const tvo_vo *vo, tvo_point2f q)
{
    return q.x >= 0.0f && q.y >= 0.0f && q.x <= (float)(vo->cfg.camera.width - 1) &&
            q.y <= (float)(vo->cfg.camera.height - 1);
}

/* LK from the previous pyramid into this one (vo->st, vo->next); the tracks that leave the image are
 * marked lost. Returns the tracks kept. */
static int32_t lk_pass(tvo_vo *vo, const frame_ctx *fc, const tvo_lk_config *lkc, const uint8_t *pred)
{
    int32_t kept = 0;
    if (tvo_lk_track_pred(lkc, fc->pp, fc->pc, vo->pts, vo->next, pred, vo->st, NULL, vo->n, vo->scratch,
                          vo->scratch_size) != TVO_OK)
        memset(vo->st, 0, (size_t)vo->n);
    for (int32_t i = 0; i < vo->n; ++i) {
        const tvo_point2f q = vo->next[i];
        if (vo->st[i] && !in_image(vo, q))
            vo->st[i] = 0;
        kept += vo->st[i];
    }
    return kept;
}

/* Scale every level of the previous pyramid by gain g (16.16), rounding, saturating at 255. It is not
 * used after this frame's tracking. */
static void scale_previous(const frame_ctx *fc, int32_t g)
{
    for (int32_t l = 0; l < fc->pp->levels; ++l) {
        const tvo_image im = tvo_pyramid_level(fc->pp, l);
        for (int32_t y = 0; y < im.height; ++y) {
            uint8_t *row = (uint8_t *)im.data + (size_t)y * (size_t)im.stride;
            for (int32_t x = 0; x < im.width; ++x) {
                const int32_t v = (row[x] * g + 32768) >> 16;
                row[x] = (uint8_t)(v > 255 ? 255 : v);
            }
        }
    }
}

/* Exposure steps (cfg.gain_retry): the gain g this frame's coarsest level shows over the previous frame's
 * (16.16 fixed point, the ratio of their median grey levels) is acted on when it is 10 % or more from 1
 * (the two bounds below) and both medians are at least 8 (so g <= 255 / 8 and v * g fits in int32). */
#define TVO_VO_GAIN_LOW 58982  /* 0.9 * 65536 */
#define TVO_VO_GAIN_HIGH 72090 /* 1.1 * 65536 */

/* LK kept `tracked` of the tracks, fewer than half: after an exposure step, track them again from their
 * previous positions (no prediction) on the previous pyramid scaled by the gain, and keep whichever pass
 * tracked more. Returns 1 when the second pass is kept. */
static int32_t gain_retry(tvo_vo *vo, const frame_ctx *fc, int32_t tracked)
{
    const int32_t top = fc->pc->levels - 1;
    const tvo_image a = tvo_pyramid_level(fc->pp, top), b = tvo_pyramid_level(fc->pc, top);
    const int32_t mp = median_grey(&a), mc = median_grey(&b);
    tvo_lk_config lkc = vo->cfg.lk;
    int32_t g;
    if (mp < 8 || mc < 8) /* too dark to measure a ratio */
        return 0;
    g = ((mc << 16) + mp / 2) / mp;
    if (g > TVO_VO_GAIN_LOW && g < TVO_VO_GAIN_HIGH)
        return 0;
    /* the first pass waits in the keyframe rotation's buffers, free until the pose stage (bytes only:
       kx1 holds more than n points, kmask n flags) */
    memcpy(vo->kx1, vo->next, (size_t)vo->n * sizeof(tvo_point2f));
    memcpy(vo->kmask, vo->st, (size_t)vo->n);
    scale_previous(fc, g);
    lkc.use_initial_flow = 0;
    if (lk_pass(vo, fc, &lkc, NULL) > tracked)
        return 1;
    memcpy(vo->next, vo->kx1, (size_t)vo->n * sizeof(tvo_point2f));
    memcpy(vo->st, vo->kmask, (size_t)vo->n);
    return 0;
}

/* cfg.pred_rescue: LK lost more than half of the tracks the map predicted (pred[i] nonzero) - the motion
 * model was wrong, not the tracks - so those lost are tracked again the full way (every level, the
 * full window) from where the shorter way left them (LK's last estimate for a lost track, not its guess:
 * docs/rules.md, "A thirty-ninth rule"). They wait in the keyframe rotation's buffers, free until the
 * pose stage: kx1 holds 2 n points (starts, then where LK starts from), kmask n flags. Returns the tracks
 * kept; *rescued is 1 when the second pass ran. */
static int32_t pred_rescue(tvo_vo *vo, const frame_ctx *fc, const tvo_lk_config *lkc, const uint8_t *pred,
                           int32_t tracked, int32_t *rescued)
{
    const int32_t n = vo->n;
    tvo_point2f *from = (tvo_point2f *)(void *)vo->kx1, *to = from + n;
    tvo_lk_config full = *lkc;
    int32_t np = 0, k = 0;
    for (int32_t i = 0; i < n; ++i) {
        if (!pred[i])
            continue;
        ++np;
        if (!vo->st[i]) {
            from[k] = vo->pts[i];
            to[k] = vo->next[i];
            ++k;
        }
    }
    if (k == 0 || 2 * k <= np)
        return tracked;
    full.use_initial_flow = 1;
    full.pred_levels = full.pred_win_size = full.pred_fb_levels = full.pred_retry = 0;
    if (tvo_lk_track(&full, fc->pp, fc->pc, from, to, vo->kmask, NULL, k, vo->scratch, vo->scratch_size) !=
        TVO_OK)
        return tracked;
    *rescued = 1;
    k = 0;
    for (int32_t i = 0; i < n; ++i) {
        if (!pred[i] || vo->st[i])
            continue;
        const tvo_point2f q = to[k];
        if (vo->kmask[k] && in_image(vo, q)) {
            vo->next[i] = q;
            vo->st[i] = 1;
            ++tracked;
        }
        ++k;
    }
    return tracked;
}

/* 1. LK tracking of the tracks into this frame; the tracks that leave the image are dropped. */
static void stage_track(tvo_vo *vo, frame_ctx *fc, tvo_vo_result *res)
{
    tvo_lk_config lkc = vo->cfg.lk;
    int32_t tracked;
    /* ok2 holds nothing between frames: it carries the predicted flags to LK here */
    fc->predicted = predict_tracks(vo, res->dt_ns, vo->ok2);
    if (fc->predicted)
        lkc.use_initial_flow = 1;
    tracked = lk_pass(vo, fc, &lkc, vo->ok2);
    if (fc->predicted && vo->cfg.pred_rescue)
        tracked = pred_rescue(vo, fc, &lkc, vo->ok2, tracked, &res->pred_rescue);
    vo->rescue_age = res->pred_rescue ? 0 : vo->rescue_age + (vo->rescue_age < TVO_VO_MAX_RESCUE_FRAMES);
    if (vo->cfg.gain_retry && vo->n >= vo->cfg.min_pose_tracks && 2 * tracked < vo->n)
        res->gain_retry = gain_retry(vo, fc, tracked);
    if (!vo->cfg.affine_at_keyframes)
        affine_refine(vo, fc);
    if (vo->cfg.redetect_cell_kept > 0.0)
        count_cells(vo);
    fc->m = compact(vo, vo->n, vo->st);
    for (int32_t i = 0; i < fc->m; ++i)
        vo->age[i]++;
    res->tracked = fc->m;
}

/* 2. Both ends of every track to normalised coordinates; tracks that cannot be undistorted go. */
static void stage_undistort(tvo_vo *vo, frame_ctx *fc)
{
    const int32_t m = fc->m;
    if (m <= 0)
        return;
    if (!fc->predicted) /* else x1 / ok1 are the prediction's, compacted with the tracks */
        tvo_camera_undistort(&vo->cfg.camera, vo->pts, vo->x1, vo->ok1, m);
    tvo_camera_undistort(&vo->cfg.camera, vo->next, vo->x2, vo->ok2, m);
    for (int32_t i = 0; i < m; ++i)
        vo->ok1[i] = (uint8_t)(vo->ok1[i] && vo->ok2[i]);
    fc->m = compact(vo, m, vo->ok1);
}

/* A low-confidence estimate (neither ambiguous nor rotation-only: too few cheirality-consistent inliers)
 * is drawn again this many times with other seeds of RANSAC's generator before the fallbacks. */
#define TVO_VO_POSE_REDRAWS 2

/* 1 when rp (status st) is an epipolar estimate that cannot be trusted and has no twin (a homography's
 * result is never rotation-only). */
static int untrusted(tvo_status st, const tvo_relpose *rp)
{
    return st == TVO_OK && (rp->flags & TVO_RELPOSE_FLAG_LOW_CONFIDENCE) &&
            !(rp->flags & (TVO_RELPOSE_FLAG_AMBIGUOUS | TVO_RELPOSE_FLAG_ROTATION_ONLY));
}

/* 3a. The relative pose of the m correspondences, with the fallbacks: other RANSAC draws when the first
 * is untrusted (on a frame of low parallax with many far points, which points come out in front of both
 * cameras depends on the draw: on one real highway frame 42 % of seeds gave a low-confidence pose, whose
 * rotation was as good as the others'), the epipolar model alone when the homography won but none of its
 * decompositions held up, and the rotation-only model alone when no epipolar pose can be trusted. */
static tvo_status estimate_pose(tvo_vo *vo, const tvo_relpose_config *rc, int32_t m, tvo_relpose *rp)
{
    tvo_status st = relpose_tracks(vo, rc, m, rp);
    for (int k = 1; k <= TVO_VO_POSE_REDRAWS && untrusted(st, rp); ++k) {
        tvo_relpose rd;
        tvo_relpose_config rs = *rc;
        rs.seed = rc->seed ^ (0x9E3779B97F4A7C15ull * (uint64_t)k); /* another draw, the same every run */
        if (relpose_tracks(vo, &rs, m, &rd) == TVO_OK && !(rd.flags & TVO_RELPOSE_FLAG_LOW_CONFIDENCE)) {
            *rp = rd;
            break;
        }
    }
    if (untrusted(st, rp) && (rp->flags & TVO_RELPOSE_FLAG_HOMOGRAPHY) && rc->use_homography) {
        /* the homography won the model selection but none of its decompositions held up: the
           epipolar model still may, so ask for it alone before calling the frame lost (not when
           the plane's twins are both fine: the epipolar model alone would return one of them
           unflagged, and they are resolved below) */
        tvo_relpose_config re = *rc;
        re.use_homography = 0;
        st = relpose_tracks(vo, &re, m, rp);
    }
    if (untrusted(st, rp)) {
        /* no epipolar pose we can trust (too few cheirality-consistent inliers): the rotation
           usually still is, so ask for the rotation-only model alone rather than lose the frame */
        tvo_relpose rr;
        tvo_relpose_config ro = *rc;
        ro.min_parallax_deg = 180.0; /* every parallax is below it */
        if (relpose_tracks(vo, &ro, m, &rr) == TVO_OK && !(rr.flags & TVO_RELPOSE_FLAG_LOW_CONFIDENCE))
            *rp = rr;
    }
    return st;
}

/* 3b. The keyframe rotation (cfg.keyframe): replaces rp's rotation by R_cK R_pK^T when the keyframe
 * estimate is trustworthy and better placed (and re-fits the translation direction to it), else chains
 * R_pK; the result's keyframe_age says which. */
static void apply_keyframe_rotation(tvo_vo *vo, frame_ctx *fc, const tvo_relpose_config *rc, tvo_relpose *rp,
                                    tvo_vo_result *res)
{
    double R_cK[9];
    if (vo->kf_age >= 1)
        fc->kf = keyframe_rotation(vo, rc, fc->m, rp, res->state, R_cK, &fc->kpar);
    if (fc->kf == KF_USED) {
        tvo_la_mat3_mul_bt(R_cK, vo->R_pK, rp->R); /* R_cp = R_cK R_pK^T */
        if (res->state == TVO_VO_OK && vo->cfg.keyframe_translation) {
            /* the 5-point direction belongs to the 5-point rotation: re-fit it to the new one */
            double tn[3];
            if (translation_given_rotation(vo, rp->R, fc->m, tn))
                memcpy(rp->t, tn, sizeof(tn));
        }
        memcpy(vo->R_pK, R_cK, sizeof(R_cK));
        res->keyframe_age = vo->kf_age + 1;
    } else {
        tvo_la_mat3_mul(rp->R, vo->R_pK, R_cK); /* chain: R_cK = R_cp R_pK */
        memcpy(vo->R_pK, R_cK, sizeof(R_cK));
    }
    vo->kf_age++;
}

/* 3c. A trustworthy estimate rp becomes the frame's relative pose: the state (plane twins resolved, the
 * rotation check), the keyframe rotation, the result's pose and counts, the inliers carried on and the
 * relative scale. */
static void accept_pose(tvo_vo *vo, frame_ctx *fc, const tvo_relpose_config *rc, tvo_relpose *rp,
                        tvo_vo_result *res)
{
    /* rp: X_cur = R X_prev + t, i.e. T_cur_prev; report T_prev_cur */
    tvo_pose T_cur_prev;
    double Rf[9], tf[3]; /* the frame-to-frame pose (the relative scale's geometry) */
    if (rp->flags & TVO_RELPOSE_FLAG_AMBIGUOUS)
        res->state = resolve_ambiguous(vo, *rc, fc->m, rp);
    else
        res->state = (rp->flags & TVO_RELPOSE_FLAG_ROTATION_ONLY) ? TVO_VO_ROTATION_ONLY : TVO_VO_OK;
    if (res->state == TVO_VO_OK && rotation_check_fails(rp)) {
        memcpy(rp->R, rp->R_rot, sizeof(rp->R));
        rp->t[0] = rp->t[1] = rp->t[2] = 0.0;
        res->state = TVO_VO_ROTATION_ONLY;
    }
    memcpy(Rf, rp->R, sizeof(Rf));
    memcpy(tf, rp->t, sizeof(tf));
    if (vo->cfg.keyframe && vo->has_kf)
        apply_keyframe_rotation(vo, fc, rc, rp, res);
    memcpy(T_cur_prev.R, rp->R, sizeof(rp->R));
    memcpy(T_cur_prev.t, rp->t, sizeof(rp->t));
    memcpy(vo->R_pred, rp->R, sizeof(rp->R));
    memcpy(fc->R2v, rp->R, sizeof(rp->R));
    fc->has_R2v = 1;
    fc->pred_next = 1;
    res->T_prev_cur = tvo_pose_inverse(&T_cur_prev);
    res->relpose_flags = rp->flags;
    res->inliers = rp->inliers;
    res->parallax_deg = rp->parallax_deg;
    if (res->state == TVO_VO_ROTATION_ONLY)
        res->T_prev_cur.t[0] = res->T_prev_cur.t[1] = res->T_prev_cur.t[2] = 0.0;
    else
        memcpy(vo->t_dir, tf, sizeof(vo->t_dir)); /* the twins' prior: frame-to-frame directions */
    /* carry the inliers (the outliers are bad tracks) */
    fc->m = compact(vo, fc->m, vo->mask);
    if (res->state == TVO_VO_OK && vo->has_pose0)
        res->rel_scale = relative_scale(vo, Rf, tf, fc->m, &res->rel_scale_points);
    for (int32_t i = 0; i < fc->m; ++i) {
        vo->pts[i] = vo->next[i];
        vo->x0[i] = vo->x1[i]; /* frame k-1 becomes k-2 of the next frame */
        vo->has0[i] = 1;
    }
    vo->n = fc->m;
    if (res->state == TVO_VO_OK) {
        memcpy(vo->R0, Rf, sizeof(vo->R0));
        memcpy(vo->t0, tf, sizeof(vo->t0));
        fc->pose0_next = 1;
    }
    if (!tvo_pose_is_finite(&res->T_prev_cur)) { /* cannot happen by contract; never emit it */
        res->T_prev_cur = tvo_pose_identity();
        res->state = TVO_VO_LOST;
        res->rel_scale = TVO_VO_REL_SCALE_NONE;
        fc->pose0_next = 0;
        fc->pred_next = 0;
        fc->has_R2v = 0;
    }
}

/* 3. The frame's relative pose: LOST with too few correspondences (the tracks start again here) or
 * without a trustworthy estimate (the tracks are kept), else accept_pose. */
static void stage_pose(tvo_vo *vo, frame_ctx *fc, tvo_vo_result *res)
{
    tvo_relpose rp;
    tvo_relpose_config rc = vo->cfg.relpose;
    const double f = 0.5 * (vo->cfg.camera.fx + vo->cfg.camera.fy);
    tvo_status st;
    int ambiguous;
    if (fc->m < vo->cfg.min_pose_tracks) {
        res->state = TVO_VO_LOST;
        vo->n = 0; /* re-initialise on this frame */
        return;
    }
    rc.threshold = vo->cfg.pose_threshold_px / f;
    st = estimate_pose(vo, &rc, fc->m, &rp);
    res->pose_status = st;
    ambiguous = st == TVO_OK && (rp.flags & TVO_RELPOSE_FLAG_AMBIGUOUS);
    if (st != TVO_OK || ((rp.flags & TVO_RELPOSE_FLAG_LOW_CONFIDENCE) && !ambiguous)) {
        /* keep the tracks, but report no motion we could trust */
        res->state = TVO_VO_LOST;
        res->relpose_flags = st == TVO_OK ? rp.flags : 0;
        vo->n = fc->m;
        for (int32_t i = 0; i < fc->m; ++i)
            vo->pts[i] = vo->next[i];
        return;
    }
    accept_pose(vo, fc, &rc, &rp, res);
}

#if TVO_WITH_AFFINE
/* cfg.map_refind: store entry e found at p (normalised xk) with warp aw: a new track that carries its
 * landmark (an inlier of this frame's pose, so the map predicts it in the next), with the entry's
 * template; the entry is emptied. */
static void refound_track(tvo_vo *vo, int32_t e, tvo_point2f p, tvo_point2d xk, const tvo_aff_warp *aw)
{
    const int32_t k = vo->n, j = vo->rf_lm[e];
    const size_t tb = tvo_aff_template_bytes(vo->cfg.affine_win_size);
    vo->pts[k] = p;
    vo->x2[k] = xk;
    vo->ok2[k] = 1;
    vo->has0[k] = 0; /* a new track: no earlier position, none in the keyframe */
    vo->hask[k] = 0;
    vo->id[k] = vo->next_id++;
    vo->age[k] = 0;
    vo->lm[k] = j;
    vo->tri_fr[k] = -1;
    vo->tri_x[k] = xk;
    vo->minl[k] = 1;
    memcpy(vo->tpl + (size_t)k * tb, vo->rf_tpl + (size_t)e * tb, tb);
    vo->am[k] = vo->rf_am[e];
    vo->aw[k] = *aw;
    vo->hast[k] = 1;
    vo->n++;
    tvo_map_refound(&vo->map, j);
    vo->rf_lm[e] = -1;
}

/* 5a. Landmarks found again (cfg.map_refind), on a frame the map posed: each stored landmark that is
 * still in the map, carried by no track, TVO_VO_REFIND_WAIT frames or more past the end of its track, in
 * view and without a track within TVO_VO_REFIND_CLEAR_PX of its projection has its template aligned
 * there, from its last warp moved to the projection (align_template, the affine refinement's test).
 * Found, it becomes a new
 * track (refound_track). An entry is dropped when found, when its landmark left the map, is behind the
 * camera or is carried again, or after TVO_VO_REFIND_MISSES failed searches; one out of view waits.
 * With cfg.map_refind_rescue the search runs only on frames with fewer than 2 x map_min_points PnP
 * inliers (the waits and the drops on every frame). Returns the landmarks found. */
static int32_t refind(tvo_vo *vo, const frame_ctx *fc, const tvo_vo_result *res)
{
    const float clear2 = TVO_VO_REFIND_CLEAR_PX * TVO_VO_REFIND_CLEAR_PX;
    /* cfg.map_refind_rescue: only while the map runs short of points (the keyframe rule's test) */
    const int search = !vo->cfg.map_refind_rescue || res->map_points < 2 * vo->cfg.map_min_points;
    int32_t found = 0;
    if (vo->rf_lm == NULL || res->map_state != TVO_MAP_TRACKING)
        return 0;
    const tvo_image l0 = tvo_pyramid_level(fc->pc, 0);
    const size_t tb = tvo_aff_template_bytes(vo->cfg.affine_win_size);
    for (int32_t e = 0; e < vo->cfg.map_refind && vo->n < vo->cfg.max_tracks; ++e) {
        const int32_t j = vo->rf_lm[e];
        tvo_point2d xn, xk;
        tvo_point2f q, p;
        tvo_aff_warp aw;
        double u, v;
        int near = 0, r;
        if (j < 0)
            continue;
        if (!tvo_map_refind_point(&vo->map, j, vo->rf_gen[e], &vo->T_c_w, &xn)) {
            vo->rf_lm[e] = -1;
            continue;
        }
        if (vo->rf_wait[e] > 0) {
            vo->rf_wait[e]--;
            continue;
        }
        if (!search)
            continue;
        if (tvo_camera_distort_point(&vo->cfg.camera, &xn, &u, &v) != TVO_OK)
            continue;
        q.x = (float)u;
        q.y = (float)v;
        if (!in_image(vo, q))
            continue;
        for (int32_t i = 0; i < vo->n && !near; ++i) {
            const float dx = vo->pts[i].x - q.x, dy = vo->pts[i].y - q.y;
            near = dx * dx + dy * dy < clear2;
        }
        if (near)
            continue;
        aw = vo->rf_aw[e];
        r = align_template(vo, vo->rf_tpl + (size_t)e * tb, &vo->rf_am[e], &l0, q, &aw, &p);
        if (r == TVO_AFF_AT_BORDER)
            continue;
        if (r != 1 || !in_image(vo, p) ||
            tvo_camera_undistort_point(&vo->cfg.camera, p.x, p.y, &xk) != TVO_OK) {
            if (++vo->rf_miss[e] >= TVO_VO_REFIND_MISSES)
                vo->rf_lm[e] = -1;
            continue;
        }
        refound_track(vo, e, p, xk, &aw);
        ++found;
    }
    return found;
}
#endif

/* 5. Re-detection when tracks run low (the new tracks start waiting for the map's triangulation), after
 * the landmarks found again (cfg.map_refind). */
static void stage_redetect(tvo_vo *vo, frame_ctx *fc, tvo_vo_result *res)
{
    int32_t before;
    int64_t t1 = now_ns(vo);
#if TVO_WITH_AFFINE
    res->map_refound = refind(vo, fc, res);
    res->stage_ns[TVO_STAGE_MAP] += now_ns(vo) - t1;
    t1 = now_ns(vo);
#endif
    before = vo->n;
    if (vo->n < vo->cfg.min_tracks ||
        (vo->n < vo->cfg.max_tracks &&
         (double)track_coverage(vo) < vo->cfg.redetect_coverage * (double)vo->cover_ref))
        res->new_corners = redetect(vo, fc->pc);
    res->stage_ns[TVO_STAGE_DETECT] = now_ns(vo) - t1;
    t1 = now_ns(vo);
    map_new_tracks(vo, before);
    res->stage_ns[TVO_STAGE_MAP] += now_ns(vo) - t1;
}

/* The end of every processed frame: the keyframe rotation's renewal, the state carried to the next
 * frame, the world pose, and the frame's level 0 kept as the next frame's previous one. */
static void finish_frame(tvo_vo *vo, const frame_ctx *fc, int64_t t_ns, tvo_vo_result *res)
{
    if (vo->cfg.keyframe) {
        /* a new keyframe after a frame without a pose, when the keyframe estimate failed, when too few
           tracks seen in K survive, or when K is far (parallax or rotation) from this frame */
        int renew = !vo->has_kf || fc->kf == KF_FAILED ||
                (res->state != TVO_VO_OK && res->state != TVO_VO_ROTATION_ONLY);
        if (!renew) {
            int32_t nk = 0;
            for (int32_t i = 0; i < vo->n; ++i)
                nk += vo->hask[i];
            renew = nk < vo->cfg.keyframe_min_tracks || fc->kpar > vo->cfg.keyframe_max_parallax_deg ||
                    tvo_la_rot_angle(vo->R_pK) * TVO_VO_DEG_PER_RAD > vo->cfg.keyframe_max_rot_deg;
        }
        if (renew)
            keyframe_set(vo);
    }
    vo->has_pose0 = fc->pose0_next;
    vo->has_pred = fc->pred_next;
    vo->dt_pred = res->dt_ns;
    if (res->state == TVO_VO_OK)
        vo->t_dir_age = 0;
    else if (vo->t_dir_age <= TVO_VO_PRIOR_FRAMES)
        vo->t_dir_age++;
    res->tracks = vo->n;
    res->affine_tried = vo->aff_tried;
    res->affine_refined = vo->aff_refined;
    res->affine_ended = vo->aff_ended;
    res->T_w_c = tvo_pose_inverse(&vo->T_c_w);
    if (!tvo_pose_is_finite(&res->T_w_c)) { /* cannot happen: every pose taken is checked; never emit it */
        vo->T_c_w = tvo_pose_identity();
        res->T_w_c = vo->T_c_w;
    }
    if (vo->cfg.map) {
        res->map_landmarks = vo->map.n_lm;
        res->map_losses = vo->map.losses;
        res->map_store_full = vo->map.store_full;
    }
    affine_take(vo, fc);
    vo->has_prev = 1;
    vo->t_prev = t_ns;
    /* the frame becomes the previous one: its level 0 moves into our memory (the caller's image may
       change after the call); the old previous level 0 is not needed any more */
    (void)tvo_pyramid_keep_level0(fc->pc, vo->level0, vo->cfg.camera.width);
    vo->cur ^= 1;
    fill_features(res, res->features);
}

/* The first frame (or the first after a reset): corners only, and the map's reference. */
static void first_frame(tvo_vo *vo, frame_ctx *fc, int64_t t_ns, tvo_vo_result *res)
{
    int64_t t1 = now_ns(vo);
    vo->n = 0;
    res->state = TVO_VO_INITIALISING;
    map_step(vo, res, t_ns, NULL);
    res->stage_ns[TVO_STAGE_MAP] = now_ns(vo) - t1;
    t1 = now_ns(vo);
    res->new_corners = redetect(vo, fc->pc);
    res->stage_ns[TVO_STAGE_DETECT] = now_ns(vo) - t1;
    t1 = now_ns(vo);
    map_new_tracks(vo, 0);
    res->stage_ns[TVO_STAGE_MAP] += now_ns(vo) - t1;
}

tvo_status tvo_vo_process(tvo_vo *vo, const tvo_image *frame, int64_t t_ns, tvo_vo_result *res)
{
    frame_ctx fc;
    tvo_status st;
    int64_t t0, t1;
    if (res == NULL)
        return TVO_ERR_NULL;
    result_clear(res, TVO_VO_LOST);
    if (vo == NULL || frame == NULL)
        return TVO_ERR_NULL;
    st = tvo_image_check(frame);
    if (st != TVO_OK)
        return st;
    if (frame->width != vo->cfg.camera.width || frame->height != vo->cfg.camera.height)
        return TVO_ERR_SIZE;
    if (vo->has_prev && t_ns <= vo->t_prev)
        return TVO_ERR_ARG;
    memset(&fc, 0, sizeof(fc));
    fc.kf = KF_NONE;
    vo->aff_tried = vo->aff_refined = vo->aff_ended = 0;
    t0 = now_ns(vo);
    fc.pc = &vo->pyr[vo->cur];
    fc.pp = &vo->pyr[vo->cur ^ 1];
    st = tvo_pyramid_build_borrowed(fc.pc,
                                    frame); /* level 0 is the caller's frame until the end of the call */
    if (st != TVO_OK)
        return st;
    t1 = now_ns(vo);
    res->stage_ns[TVO_STAGE_PYRAMID] = t1 - t0;
    if (!vo->has_prev) {
        first_frame(vo, &fc, t_ns, res);
    } else {
        /* t_ns > t_prev here, but the difference of two int64 timestamps can exceed INT64_MAX: saturate */
        const uint64_t dt = (uint64_t)t_ns - (uint64_t)vo->t_prev;
        res->dt_ns = dt > (uint64_t)INT64_MAX ? INT64_MAX : (int64_t)dt;
        t1 = now_ns(vo);
        stage_track(vo, &fc, res);
        res->stage_ns[TVO_STAGE_TRACK] = now_ns(vo) - t1;
        t1 = now_ns(vo);
        stage_undistort(vo, &fc);
        res->stage_ns[TVO_STAGE_UNDISTORT] = now_ns(vo) - t1;
        t1 = now_ns(vo);
        stage_pose(vo, &fc, res);
        res->stage_ns[TVO_STAGE_POSE] = now_ns(vo) - t1;
        t1 = now_ns(vo); /* 4. the local map: the frame's pose in the world */
        map_step(vo, res, t_ns, fc.has_R2v ? fc.R2v : NULL);
        res->stage_ns[TVO_STAGE_MAP] = now_ns(vo) - t1;
        stage_redetect(vo, &fc, res);
    }
    finish_frame(vo, &fc, t_ns, res);
    res->stage_ns[TVO_STAGE_TOTAL] = now_ns(vo) - t0;
    return TVO_OK;
}

tvo_status tvo_vo_tracks(const tvo_vo *vo, tvo_vo_track *out, int32_t capacity, int32_t *count)
{
    if (vo == NULL || count == NULL || (out == NULL && capacity > 0))
        return TVO_ERR_NULL;
    if (capacity < 0)
        return TVO_ERR_ARG;
    *count = vo->n;
    for (int32_t i = 0; i < vo->n && i < capacity; ++i) {
        out[i].x = vo->pts[i].x;
        out[i].y = vo->pts[i].y;
        out[i].id = vo->id[i];
        out[i].age = vo->age[i];
        out[i].landmark = (uint8_t)(vo->cfg.map && vo->lm[i] >= 0);
        out[i].inlier = vo->cfg.map && vo->map.active ? vo->minl[i] : (uint8_t)(vo->age[i] > 0);
    }
    return TVO_OK;
}

tvo_status tvo_vo_refine(const tvo_nn *nn, const tvo_vo_result *res, tvo_pose *step)
{
    float y[TVO_NN_OUT_COUNT];
    int32_t mask;
    tvo_status st;
    if (nn == NULL || res == NULL || step == NULL)
        return TVO_ERR_NULL;
    *step = res->T_prev_cur;
    st = tvo_nn_run_all(nn, res->features, y);
    if (st != TVO_OK)
        return st;
    mask = tvo_nn_output_mask(nn);
    if ((mask & 0x38) == 0x38) {
        const double v[3] = {y[TVO_NN_RX], y[TVO_NN_RY], y[TVO_NN_RZ]};
        tvo_rotvec_to_rot(v, step->R);
    }
    if ((mask & 0x7) == 0x7) {
        step->t[0] = y[TVO_NN_TX];
        step->t[1] = y[TVO_NN_TY];
        step->t[2] = y[TVO_NN_TZ];
    } else if (mask & (1 << TVO_NN_STEP)) {
        /* step length along the raw unit translation (t = 0 stays 0); a negative length gives t = 0 */
        const double s = y[TVO_NN_STEP] > 0.0f ? (double)y[TVO_NN_STEP] : 0.0;
        step->t[0] = s * res->T_prev_cur.t[0];
        step->t[1] = s * res->T_prev_cur.t[1];
        step->t[2] = s * res->T_prev_cur.t[2];
    }
    return TVO_OK;
}

/* ---- step-length filter ------------------------------------------------------------------------ */

#define TVO_SCALE_LOG_MIN (-20.7232658369464) /* log 1e-9 */
#define TVO_SCALE_LOG_MAX 6.90775527898214    /* log 1e3 */

tvo_status tvo_scale_filter_init(tvo_scale_filter *f, double alpha)
{
    if (f == NULL)
        return TVO_ERR_NULL;
    memset(f, 0, sizeof(*f));
    if (!(alpha >= 0.0 && alpha <= 1.0)) {
        f->alpha = -1.0; /* tvo_scale_filter_update refuses it */
        return TVO_ERR_ARG;
    }
    f->alpha = alpha;
    return TVO_OK;
}

static double clamp_log(double v)
{
    return v < TVO_SCALE_LOG_MIN ? TVO_SCALE_LOG_MIN : (v > TVO_SCALE_LOG_MAX ? TVO_SCALE_LOG_MAX : v);
}

tvo_status tvo_scale_filter_seed(tvo_scale_filter *f, double step)
{
    if (f == NULL)
        return TVO_ERR_NULL;
    if (!(step > 0.0) || !isfinite(step))
        return TVO_ERR_ARG;
    f->log_s = clamp_log(tvo_dm_log(step));
    f->has_s = 1;
    return TVO_OK;
}

tvo_status tvo_scale_filter_update(tvo_scale_filter *f, double rel_scale, double prior, double *step)
{
    const int have_r = rel_scale > 0.0 && isfinite(rel_scale);
    const int have_n = prior > 0.0 && isfinite(prior);
    double v;
    if (step != NULL)
        *step = 0.0;
    if (f == NULL || step == NULL)
        return TVO_ERR_NULL;
    if (!(f->alpha >= 0.0 && f->alpha <= 1.0))
        return TVO_ERR_ARG;
    if (!f->has_s) {
        if (!have_n)
            return TVO_ERR_RANGE;
        v = tvo_dm_log(prior);
    } else {
        const double pred = f->log_s + (have_r ? tvo_dm_log(rel_scale) : 0.0);
        v = have_n ? (1.0 - f->alpha) * pred + f->alpha * tvo_dm_log(prior) : pred;
    }
    f->log_s = clamp_log(v);
    f->has_s = 1;
    f->steps++;
    *step = tvo_dm_exp(f->log_s);
    return TVO_OK;
}

void tvo_traj_init(tvo_traj *traj, const tvo_pose *T_w_c0)
{
    if (traj == NULL)
        return;
    traj->T_w_c = T_w_c0 != NULL ? *T_w_c0 : tvo_pose_identity();
    traj->steps = 0;
}

tvo_status tvo_traj_step(tvo_traj *traj, const tvo_pose *T_prev_cur, double scale)
{
    tvo_pose step, next;
    if (traj == NULL || T_prev_cur == NULL)
        return TVO_ERR_NULL;
    if (!isfinite(scale) || !tvo_pose_is_finite(T_prev_cur))
        return TVO_ERR_NOT_FINITE;
    step = *T_prev_cur;
    for (int i = 0; i < 3; ++i)
        step.t[i] *= scale;
    next = tvo_pose_compose(&traj->T_w_c, &step);
    if (!tvo_pose_is_finite(&next))
        return TVO_ERR_NOT_FINITE;
    tvo_rot_orthonormalize(next.R);
    traj->T_w_c = next;
    traj->steps++;
    return TVO_OK;
}
