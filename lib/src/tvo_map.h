/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the VO's local map (internal to the VO object; see vo.h for what users see of it).
 *
 * Keyframes in a sliding window, landmarks triangulated between them, frame poses from PnP on the
 * landmarks the LK tracks carry, and a windowed bundle adjustment at each new keyframe.
 *
 * Landmarks are 3D points in the map's world frame (not inverse depth anchored in a keyframe): every
 * observation then ties one pose to one point, so the bundle adjustment's Schur complement has 3x3
 * point blocks and no anchor coupling, and PnP reads the points directly. The usual weakness of 3D
 * points, far points with little parallax, is handled where they are made: a track is triangulated only
 * when its two rays (first keyframe that saw it, current keyframe) are at least
 * cfg.map_tri_parallax_deg apart; until then it waits, carrying its first observation. A landmark whose
 * 3x3 block is still ill-conditioned is held fixed by the solver.
 *
 * The map's world is the VO's world: the camera of the first frame after tvo_vo_init() is the origin.
 * Its unit of length is the first map's initial baseline (1 unit), and every later map (after a loss)
 * continues in the same unit: its initial baseline is the speed of the previous map (units per second,
 * over its last window) times the time between its two first keyframes.
 *
 * Memory: everything lives in the VO's block (tvo_map_layout_size()); nothing allocated afterwards. */
#ifndef TVO_MAP_H
#define TVO_MAP_H

#include "tinyvo/arena.h"
#include "tinyvo/options.h"
#include "tinyvo/ba.h"
#include "tinyvo/pnp.h"
#include "tinyvo/relpose.h"
#include "tinyvo/se3.h"
#include "tinyvo/vo.h"
#include "tvo_lens.h"

/* A landmark's prior in the map: the adjustment's TVO_BA_PRIOR_SIZE values, then the number of
 * observations it holds (cfg.map_lm_prior_gate's mean). */
#define TVO_MAP_PRIOR_SIZE (TVO_BA_PRIOR_SIZE + 1)

/* A keyframe of the window: its pose and the landmark observations made in it. */
typedef struct tvo_map_kf {
    int32_t id;       /* increasing keyframe id (never reused) */
    int32_t adjusted; /* 1 once an adjustment that was taken had it free (cfg.map_lm_prior only) */
    int64_t t_ns;
    tvo_pose T_c_w;     /* world -> camera */
    int32_t has_R_prev; /* 1: R_prev holds the two-view rotations chained since the previous keyframe */
    double R_prev[9];   /* X_this = R_prev X_previous keyframe */
    int32_t n_obs;
    int32_t *obs_lm;    /* [max_tracks] landmark index of each observation */
    tvo_point2d *obs_x; /* [max_tracks] normalised position */
} tvo_map_kf;

/* A landmark: a world point, the number of window keyframes that observe it, and whether a live
 * track carries it. Free when !alive. gen counts the landmarks its slot has held, so that a landmark is
 * told apart from a later one in the same slot (tvo_map_refind_point). */
typedef struct tvo_map_lm {
    double X[3];
    int16_t n_obs;
    uint8_t alive, tracked;
    uint32_t gen;
} tvo_map_lm;

/* The VO's tracks as the map sees them: parallel arrays of length n, owned by the VO. The map reads x
 * (normalised current position, valid where x_ok) and reads/writes lm, tri_fr, tri_x and inlier. */
typedef struct tvo_map_tracks {
    int32_t n;
    const tvo_point2d *x;
    const uint8_t *x_ok;
    int32_t *lm;        /* landmark index, or -1 */
    int32_t *tri_fr;    /* serial of the frame of the track's first observation (to triangulate), or -1 */
    tvo_point2d *tri_x; /* normalised position in that frame */
    uint8_t *inlier;    /* out: 1 when the track's landmark is an inlier of this frame's map pose */
    /* called, when not NULL, on a frame that becomes a keyframe, before its observations are taken:
       it may move the tracks' positions x (by less than the PnP threshold) */
    void (*refine)(void *ctx);
    void *refine_ctx;
} tvo_map_tracks;

/* The poses of the last TVO_MAP_RING frames, for triangulating a track from the frame it was first seen
 * in (any frame, not only a keyframe). A track first seen further back waits again from the current frame. */
#define TVO_MAP_RING 32
typedef struct tvo_map_frame_pose {
    int32_t serial; /* frame serial (-1: empty) */
    int32_t kf_id;  /* id of the keyframe the frame became, or -1 */
    tvo_pose T_c_w;
} tvo_map_frame_pose;

typedef struct tvo_map {
    int32_t window, max_tracks, max_lm;
    int32_t n_kf;    /* keyframes in the window, oldest first in kf[] order by age */
    int32_t kf_head; /* slot of the oldest keyframe (ring) */
    tvo_map_kf *kf;  /* [window] */
    tvo_map_lm *lm;  /* [max_lm] */
    int32_t n_lm;    /* alive landmarks */
    int32_t next_kf_id;
    int32_t active; /* 1 while the map poses frames */
    /* cfg.map_lm_prior > 0: each landmark's prior from the observations of the keyframes that left the
       window (tvo_ba_problem.prior's layout, then how many observations it holds), zero for a new
       landmark; else NULL */
    double (*prior)[TVO_MAP_PRIOR_SIZE]; /* [max_lm] */
    double prior_w, prior_huber;         /* cfg.map_lm_prior, the adjustment's Huber width (normalised) */
    tvo_map_frame_pose ring[TVO_MAP_RING];
    int32_t serial; /* serial of the frame being processed (increases by one per frame) */
    /* initialisation: the reference frame (its serial, pose and time); the tracks first seen in it */
    int32_t has_ref;
    int32_t ref_serial;
    tvo_pose ref_T_c_w;
    int64_t ref_t_ns;
    int32_t ref_frames; /* frames since the reference */
    int32_t waiting;    /* 1 from the first frame without a map (at the start or after a loss)... */
    int64_t wait_t_ns;  /* ...whose time this is, until a map is made (cfg.map_init_wait_s) */
    /* motion: the last frame's pose and its velocity (T_cur_prev of the last two posed frames) */
    tvo_pose last_T_c_w;
    tvo_pose vel; /* T_cur_prev of the last step, in map units */
    int64_t last_t_ns, vel_dt_ns;
    int32_t has_vel;
    double speed;      /* map units per second of the last map (> 0 when known) */
    int32_t kf_points; /* landmarks the last keyframe saw (for the keyframe decision) */
    int32_t frames_since_kf;
    double depth_med; /* median depth of the last tracked frame's inliers (map units; 0: unknown) */
    double rms;       /* the last landmarks-only PnP reprojection RMS (normalised; 0: unknown) */
    int32_t losses;
    int32_t store_full; /* keyframes and new maps that found the landmark store full (since init) */
    int32_t cur_kf_id;  /* id of the keyframe made in the last processed frame, or -1 */
    /* the frames' two-view rotations chained since the newest keyframe (X_cur = chain_R X_kf), kept when
       cfg.map_ba_rot_prior > 0; chain_ok 0 when a frame since then had none */
    double chain_R[9];
    int32_t chain_ok;
    int32_t lm_cursor; /* where the search for a free landmark slot starts */
    int32_t lens_kf; /* id of the newest keyframe of the last window that gave a lens block (cfg.lens_refine) */
} tvo_map;

/* What the map did with a frame (filled into the VO result by tvo_vo.c). */
typedef struct tvo_map_frame {
    tvo_vo_map_state state;
    int32_t keyframe;   /* 1 when the frame became a keyframe */
    int32_t points;     /* landmarks used for the pose (inliers) */
    int32_t new_points; /* landmarks triangulated in this frame */
    int32_t ba_iterations, ba_flags;
    tvo_pose T_c_w;  /* valid when state is TRACKING or INITIALISED */
    int32_t lens_ok; /* 1: the keyframe's adjusted window gave a lens block (cfg.lens_refine; tvo_lens.h) */
    tvo_lens_block lens; /* valid when lens_ok */
} tvo_map_frame;

size_t tvo_map_layout_size(const tvo_vo_config *cfg);
#if TVO_WITH_LENS
/* The window's observations moved from the lens `from` to the lens `to` (tvo_lens_remap). */
void tvo_map_remap(tvo_map *m, const tvo_camera *from, const tvo_camera *to);
#endif
size_t tvo_map_scratch_size(const tvo_vo_config *cfg);
/* Carve the map's arrays from arena a (in the order of tvo_map_layout_size). TVO_ERR_NO_MEMORY. */
tvo_status tvo_map_init(tvo_map *m, const tvo_vo_config *cfg, tvo_arena *a);
/* Forget keyframes and landmarks (the speed, the loss count and the frame ring are kept). */
void tvo_map_clear(tvo_map *m);
/* Back to the state after tvo_map_init (everything forgotten). */
void tvo_map_reset(tvo_map *m);

/* What the VO knows of its two-view rotation (the prior_flags of tvo_map_process). */
enum {
    TVO_MAP_PRIOR_ROT_ONLY = 1, /* a rotation-only estimate (no translation seen) */
    TVO_MAP_PRIOR_WEAK = 2, /* a poorly conditioned one (rotation-only, a plane's twin, little parallax) */
    TVO_MAP_PRIOR_JERK = 4  /* a prediction rescue within cfg->map_rot_prior_obs_frames frames */
};

/* One frame after the VO's two-view step. R_cur_prev: the two-view rotation of this frame (NULL when
 * none): it turns the motion model's prediction, it is a prior on the PnP rotation (weight
 * cfg->map_rot_prior, lowered for a rotation-only estimate by the translation the motion model predicts,
 * and for a weak one whose landmarks alone disagree with it beyond their noise: tvo_map.c,
 * rotation_only_weight and consistent_prior), and the map's rotation must stay within
 * TVO_MAP_ROT_CHECK_DEG of it. prior_flags: TVO_MAP_PRIOR_* bits. T_c_w_prior: the pose the VO would report without the map (the two-view chain),
 * used as the reference pose when a new map starts. Tracks' lm / tri_* are updated, *out filled. Uses
 * scratch. */
tvo_status tvo_map_process(tvo_map *m, const tvo_vo_config *cfg, tvo_map_tracks *tr, int64_t t_ns,
                           const double *R_cur_prev, int prior_flags, const tvo_pose *T_c_w_prior,
                           void *scratch, size_t scratch_size, tvo_map_frame *out);

/* The motion model's pose (world -> camera) of a frame at t_ns: the last posed frame's pose moved by the
 * last velocity, its rotation and translation scaled to the interval. 1 when the map is tracking, posed
 * the frame at prev_t_ns (the VO's previous frame) and has a velocity; else 0 and *T untouched. */
int tvo_map_predict_pose(const tvo_map *m, int64_t t_ns, int64_t prev_t_ns, tvo_pose *T);

/* The direction of the map's last step (X_cur = R X_prev + t: t / |t|, in the camera's frame) in dir: 1
 * while the map poses frames and has moved, else 0. */
int tvo_map_motion_dir(const tvo_map *m, double dir[3]);

/* Tracks added after tvo_map_process (re-detection) start their wait for triangulation in this frame. */
void tvo_map_new_tracks(const tvo_map *m, tvo_map_tracks *tr, int32_t first);

#if TVO_WITH_AFFINE
/* For finding a landmark again (cfg.map_refind; a build with the affine refinement): 1 when slot j holds
 * landmark generation gen, alive, carried by no track and in front of the camera T_c_w, with *xn its
 * normalised projection; else 0. */
int tvo_map_refind_point(const tvo_map *m, int32_t j, uint32_t gen, const tvo_pose *T_c_w, tvo_point2d *xn);

/* Landmark j is carried by a track again (the VO set the track's lm to j). */
void tvo_map_refound(tvo_map *m, int32_t j);
#endif

#endif /* TVO_MAP_H */
