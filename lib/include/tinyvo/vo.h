/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the monocular visual odometry object.
 *
 * Per frame: pyramid -> LK tracking of the current tracks (forward-backward checked) -> undistortion
 * to normalised coordinates -> two-view relative pose to the previous frame (5-point essential matrix in
 * RANSAC, or rotation-only / homography when the geometry calls for it) -> outlier removal -> the local
 * map (below) -> re-detection spread over the image when tracks run low.
 *
 * Two results per frame:
 *   - T_prev_cur, the RAW two-view relative pose with a unit (scale-free) translation: the front end's
 *     own estimate, and the input of the per-DoF networks (features);
 *   - T_w_c, the camera pose in the VO's world, from the local map: the trajectory to use.
 *
 * The local map (cfg.map, on by default). Keyframes in a sliding window of cfg.map_window (default 8);
 * landmarks are 3D points in the world, triangulated from a track's first keyframe and a later keyframe
 * once their rays are cfg.map_tri_parallax_deg apart, in front of both cameras and reprojecting within
 * 2 px. Every frame is posed by PnP on the landmarks its tracks carry (Huber-robust Gauss-Newton from the
 * motion-model prediction with this frame's two-view rotation, P3P RANSAC when that fails; pnp.h). A new
 * keyframe is made when the camera moved more than cfg.map_kf_baseline x the median landmark depth since
 * the last one, when fewer than cfg.map_kf_points_ratio of its landmarks remain, or after
 * cfg.map_kf_max_frames frames, and not when it barely moved (a turn on the spot adds little structure)
 * unless fewer than 2 x cfg.map_min_points landmarks are left (the map is about to be lost).
 * At each keyframe: new landmarks (at a keyframe of a map running out of points, also from the tracks
 * born since the last keyframe, triangulated from the frame they were born in), then a bundle adjustment
 * of the window (ba.h: Huber reprojection error in normalised coordinates, Levenberg-Marquardt with the
 * Schur complement on the poses, at most
 * cfg.map_ba_iterations iterations, the cfg.map_ba_fixed (default 4) oldest keyframes fixed to hold the
 * gauge and the scale: they are fixed, not marginalised), after which observations above 2.5 px are
 * dropped.
 * The map starts from two frames with cfg.map_init_parallax_deg of median parallax (5-point pose,
 * triangulated inliers: at least max(40, cfg.max_tracks / 3) landmarks). Until then, and after a loss, T_w_c continues the two-view chain: its rotation,
 * and its translation direction times the last map's speed (before the first map one unit per the
 * chain's first frame interval, an interval within a factor of 1.5 of it counting as one, so that a frame
 * after dropped ones steps further and jittered timestamps do not: at most 10 units).
 * A frame without a two-view pose (LOST) moves on by the last posed frame's motion scaled to its
 * interval, for at most 1 s of LOST frames in a row, then stands still.
 * A frame whose PnP fails, or whose map rotation is more than 5 deg from its own two-view rotation, loses
 * the map (map_state TVO_MAP_LOST, counted in map_losses); a new map starts from that frame, its initial
 * baseline the distance the chain travelled, so the whole run keeps one unit of length: the first map's
 * initial baseline. A monocular VO cannot know that unit in metres; tvo_replay's --scale sets it
 * from an outside source.
 *
 * Cost: the map's work per frame is one PnP refinement on up to max_tracks points (~0.4 M instructions
 * for 200 points, pnp.h); a keyframe adds the triangulation and one bundle adjustment (~14 M
 * instructions for 6 keyframes and 300 landmarks, ba.h).
 *
 * Memory: tvo_vo_required_size(&cfg) bytes, handed to tvo_vo_init(); nothing is allocated afterwards.
 * It covers the pyramids, the tracks, the map (map_window x max_tracks observations, map_max_landmarks
 * landmarks) and the scratch of the bundle adjustment; `tvo_replay --print-memory` prints it for a
 * sequence (docs/limits.md gives it for common sizes). Not thread-safe: one tvo_vo per thread.
 */
#ifndef TINYVO_VO_H
#define TINYVO_VO_H

#include "tinyvo/camera.h"
#include "tinyvo/corners.h"
#include "tinyvo/image.h"
#include "tinyvo/lk.h"
#include "tinyvo/nn.h"
#include "tinyvo/relpose.h"
#include "tinyvo/se3.h"
#include "tinyvo/export.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What the VO made of a frame. */
typedef enum tvo_vo_state {
    TVO_VO_OK = 0,            /* relative pose with a translation direction (relpose_flags AMBIGUOUS:
                                  one of a plane's twin poses, chosen as the one that continues the
                                  translation of the last 3 frames within 45 degrees, else the epipolar
                                  model's choice without the homography: may be the wrong twin when the
                                  scene is one plane only) */
    TVO_VO_INITIALISING = 1,  /* first frame (or first after a reset): corners detected, identity pose */
    TVO_VO_ROTATION_ONLY = 2, /* low parallax, or no translation we could trust (too few cheirality-
                                  consistent inliers, or a pose whose rotation is > 2 deg and > 10x the
                                  parallax away from the rotation-only model): rotation estimated,
                                  translation reported as zero */
    TVO_VO_LOST = 3, /* too few tracks or no trustworthy model: identity pose, tracker re-initialised */
    TVO_VO_STATE_COUNT = 4
} tvo_vo_state;

/* Per-stage timing slots in tvo_vo_result.stage_ns (filled only when the config has a clock). */
typedef enum tvo_vo_stage {
    TVO_STAGE_PYRAMID = 0,
    TVO_STAGE_TRACK = 1,
    TVO_STAGE_UNDISTORT = 2,
    TVO_STAGE_POSE = 3,
    TVO_STAGE_DETECT = 4,
    TVO_STAGE_MAP = 5, /* the local map: PnP, keyframes, triangulation, bundle adjustment */
    TVO_STAGE_TOTAL = 6,
    TVO_STAGE_COUNT = 7
} tvo_vo_stage;

/* What the local map (cfg.map) made of a frame. */
typedef enum tvo_vo_map_state {
    TVO_MAP_OFF = 0,          /* cfg.map = 0: T_w_c is the two-view chain with unit steps */
    TVO_MAP_INITIALISING = 1, /* no map yet (first frames, or after a loss): the map waits for a pair of
                                  frames with enough parallax; T_w_c continues the two-view chain (its
                                  rotation, and its translation direction times the last map's speed) */
    TVO_MAP_INITIALISED = 2,  /* this frame and the waiting reference became the map's two first
                                  keyframes; T_w_c is the new map's */
    TVO_MAP_TRACKING = 3,     /* T_w_c from PnP on the map's landmarks (and the bundle adjustment when
                                  the frame is a keyframe) */
    TVO_MAP_LOST = 4,         /* tracking against the map failed in this frame (too few landmarks still
                                  tracked, PnP refused, or a map rotation that disagrees with the frame's
                                  two-view rotation): the map is dropped, T_w_c continues the two-view
                                  chain, and a new map starts from this frame */
    TVO_MAP_STATE_COUNT = 5
} tvo_vo_map_state;

/* A monotonic clock in nanoseconds, supplied by the port layer (lib has no OS access). */
typedef int64_t (*tvo_clock_fn)(void *user);

typedef struct tvo_vo_config {
    tvo_camera camera;          /* intrinsics + distortion; camera.width/height is the frame size */
    tvo_detect_config detect;   /* corner detection + bucketing (detect.max_corners is ignored: see below) */
    tvo_lk_config lk;           /* tracker; forward-backward check recommended */
    tvo_relpose_config relpose; /* RANSAC; relpose.threshold is derived from pose_threshold_px */
    int32_t max_tracks;         /* capacity of the track list, >= 16; default 300 */
    int32_t min_tracks;         /* re-detect when fewer tracks survive; default 200 */
    double redetect_coverage;   /* ...or when the tracks cover fewer cells of an 8 x 6 grid over the frame
                                   than this share of the cells they covered after the last detection (a
                                   turn leaves the tracks on one side of the frame, and the rotation of a
                                   one-sided set is poorly conditioned); [0, 1], 0 disables; default 0.75 */
    double redetect_cell_kept;  /* new corners are not taken in a cell of that grid while fewer than this
                                   share of the corners detected in it lately were tracked into the next
                                   frame (LK with its forward-backward check; each cell's counts lose 1/8
                                   a frame, and a cell is judged once it counts 4 corners): where the last
                                   corners died at once (the road close to a car, motion blur, a moving
                                   object) the next ones mostly die too, and a closed cell opens again as
                                   its counts fade. [0, 1], 0 disables; default 0: 0.15 helps the shared
                                   KITTI frames and hurts degraded copies of them (docs/rules.md, "A
                                   fiftieth rule") */
    int32_t min_pose_tracks;    /* fewer tracked points than this -> LOST; default 30 */
    int32_t gain_retry;         /* 1: when LK keeps fewer than half of at least min_pose_tracks tracks and
                                   the median grey level of the coarsest pyramid level changed by 10 % or
                                   more since the previous frame (an exposure step), the previous frame's
                                   pyramid is scaled by that ratio and the tracks are tracked again from
                                   their previous positions; the second pass is kept when it tracks more
                                   points (result.gain_retry). 0: off; default 1 */
    int32_t fast_min_threshold; /* low-contrast fallback: when a detection finds fewer than a quarter of the
                                   corners wanted, it is repeated with this FAST threshold (if it is lower
                                   than detect.fast_threshold); [0, 255], 0 disables; default 7 */
    int32_t fast_range_ref;     /* exposure: on a frame whose grey levels span less than this (the 1st to the
                                   99th percentile of the coarsest pyramid level), both FAST thresholds above
                                   are scaled by span / fast_range_ref (rounded, at least 1): with 255 a
                                   frame's corners do not depend on its exposure gain. [0, 255], 0: the
                                   thresholds as configured; default 0 */
    double pose_threshold_px; /* RANSAC inlier threshold in pixels, converted with the focal length; default 1.0 */
    int32_t min_scale_points; /* relative scale (tvo_vo_result.rel_scale): fewer usable three-frame tracks
                                   than this -> not available; >= 3 (above max_tracks: never); default 20 */
    double scale_min_parallax_deg; /* ...a track is usable when both of its pairs (k-2,k-1) and (k-1,k) see it
                                   with at least this ray angle, in degrees, (0, 10]; default 0.1 */
    /* keyframe rotation: the tracks keep their normalised position in a keyframe K; each frame also
       estimates K -> cur from the tracks seen since K (same relpose config), and when that estimate is
       trustworthy (not low-confidence or ambiguous, >= min_pose_tracks inliers and half of the tracks,
       within 1 deg of the chained frame-to-frame rotation) and has more parallax than the frame-to-frame
       one (any, on a rotation-only frame), the frame's rotation is R_cK R_pK^T (R_pK: K -> previous
       frame), so the chained rotation does not drift between keyframes */
    int32_t keyframe;                 /* 1: on, 0: frame-to-frame only; default 1 */
    int32_t keyframe_min_tracks;      /* a new keyframe when fewer tracks seen in K survive; >= 0 (above
                                   max_tracks: every frame, which turns the keyframe rotation off);
                                   default 100 */
    double keyframe_max_parallax_deg; /* ...or when the K -> cur parallax exceeds this, (0, 90]; default 5 */
    double keyframe_max_rot_deg;      /* ...or the K -> cur rotation, (0, 180]; default 10 */
    int32_t keyframe_translation; /* 1: on a frame with the keyframe rotation, the translation direction is
                                   re-fitted to it (R fixed, t linear: smallest eigenvector of the 3x3
                                   normal matrix of the rows (R x1) x x2 over the inliers, sign by
                                   cheirality); 0: the 5-point direction is kept; default 1 */
    int32_t track_prediction;     /* 1: LK starts each track where the previous frame's rotation (scaled to
                                   this frame's interval; constant angular velocity, points at infinity)
                                   moves it, when the previous frame had a pose and the intervals are
                                   within 2x; 0: at its previous position. For cameras whose frames move
                                   further than LK reaches (low frame rates, vehicles, fast pans);
                                   default 0 (docs/geometry.md, "Track prediction") */
    int32_t map_prediction;       /* 1 (with map): each track carrying a map landmark that was an inlier of
                                   the previous frame's map pose starts where the landmark projects with
                                   the map's constant-velocity pose of this frame (when the map posed the
                                   previous frame), and is tracked with the lk.pred_* settings
                                   (tvo_lk_track_pred); 2: also each other track, as a point at the
                                   median depth of the 4 landmark tracks nearest to it in the previous
                                   image; the tracks left over as track_prediction says; 0: off;
                                   default 2 (0 in a build without the affine refinement) */
    int32_t pred_rescue;          /* 1 (with map_prediction): when LK loses more than half of the tracks
                                   the map predicted in a frame (a jerk, a velocity the motion model did
                                   not foresee), those lost are tracked again the full way (lk's full
                                   levels and window) from where the shorter way left them, LK's last
                                   estimate for a lost track (result.pred_rescue); frames that lose
                                   fewer are left as they are. Starting from the guesses instead was
                                   measured and is not kept (docs/rules.md, "A thirty-ninth rule").
                                   0: off; default 1 */
    int32_t affine_win_size;      /* affine track refinement: each track keeps the affine_win_size^2 pixels
                                   around where it was detected (its template), and every frame the
                                   position LK found is refined by aligning the template under an affine
                                   warp (zoom, rotation, shear and shift, the patch's mean and contrast
                                   matched to the template's). Translation-only LK drifts with the patch's
                                   deformation since detection (docs/evaluation.md, "Track accuracy on
                                   the renders"). A track whose alignment fails (no convergence, a
                                   correlation below 0.8, more than 2 px from LK's position, the window
                                   out of the image) keeps LK's position and takes a new template there.
                                   Odd, [3, 31], or 0: off; default 21 (0 in a build without the
                                   refinement; its accuracy: docs/rules.md, its cost: docs/budget.md).
                                   Memory: (w + 2)^2 + 313 bytes a track (w = affine_win_size). A build with TVO_WITH_AFFINE 0
                                   (options.h) leaves the refinement out: tvo_vo_required_size() is 0
                                   and tvo_vo_init() returns TVO_ERR_UNSUPPORTED for any value but 0 */
    int32_t affine_step;          /* the affine refinement aligns every affine_step-th pixel of the window
                                   in each direction (2: an 11 x 11 grid of a 21 x 21 window, a quarter
                                   of the work of 1); it must divide affine_win_size / 2. [1, 15];
                                   default 1 */
    int32_t affine_at_keyframes;  /* 1: the affine refinement runs only on the frames that become the
                                   map's keyframes (after the frame's map pose, before the keyframe's
                                   observations, new landmarks and bundle adjustment), on every track
                                   with a template; the frames between keep LK's positions, which
                                   start from the refined ones. 0: on every frame; default 0 */
    int32_t map_refind;           /* landmarks found again: a track that ends while it carries a landmark
                                   leaves its affine template in a store of this many entries (the
                                   oldest overwritten); on every frame the map posed from the third
                                   after the track ended, each stored landmark that no track carries is
                                   looked for where the pose projects it (its template aligned there:
                                   converged, a correlation of at least 0.8, within 2 px), and found it
                                   becomes a new track that carries it (about 850 bytes an entry).
                                   Without the map or affine_win_size > 0 it does nothing and takes
                                   no memory. [0, 4096], 0: off; default 64 (the balanced and accurate
                                   presets; 0 in the basic and small ones) */
    double affine_end_share;      /* in a frame where at most this share of the affine alignments fails (no
                                   convergence, a correlation below 0.8, a degenerate warp, more than 2
                                   px from LK's position; a window that reaches the image's border is
                                   neither counted nor ended), each track whose alignment failed is ended
                                   as if LK had lost it, instead of keeping LK's position with a new
                                   template: where the images are sharp a failure is the track's (a corner
                                   on a depth edge slides along it). Not with affine_at_keyframes 1.
                                   [0, 1], 0: off; default 0 in every preset. 0.1 on the renders: 0.855
                                   times the per-frame rotation error, MH_01's ATE twice; for a sharp
                                   global-shutter camera, not a car's (docs/rules.md, "A twenty-seventh
                                   rule") */
    /* local map (vo.h header comment, "The local map"): keyframes in a sliding window, landmarks
       triangulated between them, every frame posed by PnP on the landmarks its tracks carry, and a
       windowed bundle adjustment at each new keyframe */
    int32_t map;                  /* 1: on; 0: two-view only (the VO of earlier versions); default 1 */
    int32_t map_window;           /* keyframes in the window, [3, TVO_VO_MAX_WINDOW]; default 8 (6 in a
                                   build without the affine refinement) */
    int32_t map_max_landmarks;    /* landmark capacity, [16, 100000], or 0: 2 x max_tracks; default 0 */
    int32_t map_min_points;       /* a frame with fewer PnP inliers loses the map, [6, 100000] (above
                                   max_tracks: the map never tracks); below twice as many, a keyframe
                                   needs no minimum baseline; default 20 */
    double map_init_parallax_deg; /* the initial pair needs this median parallax, (0, 30]; default 1 */
    double map_init_wait_s;       /* a new map (the first, or after a loss) needs max(40, max_tracks / 3)
                                   landmarks from its first pair; after this many seconds of frames
                                   without a map, half as many (max(40, max_tracks / 6)): a camera that
                                   keeps few tracks from frame to frame (blur, noise, a low frame rate)
                                   gets a map at all. [0, 86400], 0: never fewer; default 0
                                   (docs/design.md, "Initialisation") */
    double chain_scale_sigmas;    /* the steps of the two-view chain (the frames without a map pose: before
                                   the first map and while the map is lost) follow the relative scale's
                                   changes (rel_scale) beyond this many of its standard errors: a step
                                   length changes from one frame to the next only by what the tracks
                                   show beyond their noise (shrunk by that much), and keeps its length
                                   otherwise. 0: every chain step has the same length (one unit a frame
                                   before the first map, the map's last speed after a loss). [0, 100];
                                   default 3 in the balanced and accurate presets (against 0: 0.88 times
                                   the ATE over the accuracy sequences, 0.81 times on degraded, jerky
                                   and reversed copies), 0 in the basic and small ones, whose tracker
                                   it costs the KITTI 01 highway a quarter of its ATE (docs/design.md,
                                   "The chain's step length"; docs/rules.md, "A twenty-third rule") */
    double map_tri_parallax_deg;  /* a track is triangulated when its rays are this far apart, (0, 30];
                                   default 0.5 (1 suits a car's camera: docs/camera.md); the first map
                                   falls back to 0.5 when too few of its points reach a higher value */
    double map_kf_baseline;       /* a new keyframe when the camera moved more than this x the median depth
                                   of its landmarks since the last keyframe, (0, 10]; default 0.1 */
    double map_kf_points_ratio;   /* ...or when fewer than this share of the last keyframe's landmarks
                                   remain inliers, [0, 1]; default 0.8 */
    int32_t map_kf_max_frames;    /* ...or after this many frames, [1, 100000]; default 30 (and after
                                   keyframe_max_rot_deg of rotation) */
    int32_t map_ba_iterations;    /* Levenberg-Marquardt iterations of the bundle adjustment, [1, 100];
                                   default 5 */
    int32_t map_ba_fixed;         /* the bundle adjustment holds this many of the window's oldest keyframes
                                   fixed (the gauge and the scale; a longer fixed tail ties the scale to
                                   older keyframes, as ORB-SLAM's local bundle adjustment holds the
                                   keyframes outside its local set), [2, map_window - 1]; default 4 (2
                                   in a build without the affine refinement) */
    int32_t map_refind_rescue;    /* with map_refind: 1 looks for the stored landmarks only on the frames
                                   whose PnP inliers are fewer than 2 x map_min_points (the map running
                                   short of points: after a jump or a fast turn), a rescue; 0 on every
                                   frame the map posed (worse on clean frames: docs/rules.md, "A
                                   thirty-first rule"). 0 or 1; default 1 (0 in the basic and small
                                   presets) */
    double map_ba_max_turn_deg;   /* the bundle adjustment's result is not taken (the window keeps its poses
                                   and points from before it; ba_flags gets TVO_VO_BA_TURN_REFUSED) when
                                   it turns the newest keyframe by more than this from the pose its
                                   tracking gave it (there the frame's two-view rotation held the
                                   rotation): a window that trades the newest keyframe's rotation for a
                                   lower reprojection cost has followed landmarks that are wrong
                                   together (docs/design.md, "Windowed bundle adjustment"). (0, 180];
                                   default 0.5 */
    double map_ba_huber_px;       /* the bundle adjustment's robust (Huber) width in pixels (divided by the
                                   focal length): an observation whose reprojection error is larger
                                   weighs as its error's square root, not its square. Observations left
                                   above 2.5 px after the adjustment are removed whatever the width.
                                   (0, 100]; default 2.5 (docs/rules.md, "A tenth rule") */
    double map_ba_rot_prior;      /* the frames' two-view rotations, chained from each keyframe to the next,
                                   as priors on the relative rotation of consecutive keyframes in the
                                   bundle adjustment (ba.h, tvo_ba_rot_prior: a visual gyroscope; the
                                   per-frame two-view rotation is more accurate than the map's): their
                                   weight, as map_rot_prior's (100: as much as 100 reprojection errors
                                   of the same angle), [0, 1e12]; 0: none (no chain breaks it but a frame
                                   without a two-view rotation); default 0 (docs/rules.md, "An eleventh
                                   rule") */
    double map_rot_prior;         /* weight of this frame's two-view rotation (turning the last pose) as a
                                   prior on its map pose (pnp.h, rot_prior_weight), [0, 1e12]; 0: none;
                                   default 100 (as much as 100 points' reprojection errors: the
                                   per-frame rotation mostly follows the two-view estimate, the map
                                   corrects its drift). Lowered for a rotation-only frame by the
                                   translation flow the motion model predicts (which such a rotation
                                   absorbs), and for a frame with a weak two-view rotation
                                   (rotation-only, a plane's twin, below 0.2 deg of parallax) whose
                                   landmarks alone give a rotation that disagrees with the prior beyond
                                   the two estimates' noise (a chi-square test at 99 %); docs/design.md */
    int32_t map_rot_prior_obs;    /* the landmarks whose own rotation that test compares with the prior: 0
                                   all of them; N in [2, TVO_VO_MAX_WINDOW] those observed in at least N
                                   keyframes of the window, when map_min_points of them are tracked (else
                                   all), on the frames map_rot_prior_obs_frames selects; default 3: keeps
                                   a jerking camera's frames off landmarks of two keyframes whose depths
                                   the jerk got wrong (docs/camera.md; docs/rules.md, "A forty-fourth
                                   rule", "A forty-sixth rule") */
    int32_t map_rot_prior_obs_frames; /* the frames on which map_rot_prior_obs judges: 0 every weak frame;
                                   N in [1, 100000] those within N frames of a prediction rescue
                                   (pred_rescue fired in this frame or one of the N - 1 before: the
                                   camera's speed jumped), all the landmarks judging the others; default
                                   30. Without pred_rescue (or map_prediction: the basic, accurate and
                                   small presets) no frame has a rescue, so the test uses all the
                                   landmarks (docs/rules.md, "A forty-sixth rule") */
    int32_t lens_refine;              /* (added) 1: the lens's radial coefficients k1, k2 refined on the run
                                   from the map's windows and changed when enough windows agree on a
                                   change (docs/camera.md, "The lens refined on the run"); RADTAN and
                                   NONE cameras (NONE becomes RADTAN), never EQUIDISTANT; acts with the
                                   map only; needs a build with TVO_WITH_LENS (options.h). Default 1 in
                                   such builds (docs/rules.md, "A forty-eighth rule"), 0 in the small
                                   preset and in builds without it. 0: the lens stays as configured */
    tvo_clock_fn clock;               /* optional (NULL: no timings) */
    void *clock_user;
    double map_inlier_sigmas; /* (added) a landmark whose reprojection error in this frame's map pose is
                                   above this many times the frame's robust reprojection sigma (the
                                   median of its inliers' errors / 1.1774), at least 0.5 px and at most
                                   the fixed 2 px gate, is given up by its track as an outlier's is: a
                                   track that has slid off its point stops holding the landmark.
                                   [0, 100]; 0: the fixed 2 px gate only; default 0 (docs/design.md,
                                   "Tracking"; docs/rules.md, "A fifty-ninth rule"). Needs a build with
                                   the affine refinement (TVO_WITH_AFFINE, options.h): without it only 0
                                   (tvo_vo_init: TVO_ERR_UNSUPPORTED) */
    double map_lm_prior;      /* (added) a keyframe that leaves the window leaves its observations of the
                                   landmarks that live on as priors on them, at this weight (a keyframe
                                   that an adjustment had free: not the map's first two, which hold its
                                   gauge): each observation's reprojection error linearised at the
                                   landmark (Huber weighted, the keyframe held where the window last had
                                   it), added to the landmark's cost in every later bundle adjustment. A
                                   landmark seen for long keeps what its old keyframes said, which holds
                                   the scale over long runs; best with map_ba_fixed 2 (docs/camera.md).
                                   [0, 1]; 0: off (a landmark only knows the window's keyframes);
                                   default 0 (docs/design.md, "Windowed bundle adjustment"). Memory: 88
                                   bytes a landmark (map_max_landmarks) and 80 of scratch. Needs a
                                   build with the affine refinement (TVO_WITH_AFFINE, options.h): without
                                   it only 0 (tvo_vo_init: TVO_ERR_UNSUPPORTED) */
    double map_lm_prior_gate; /* (added) with map_lm_prior: when a keyframe leaves, a landmark whose prior
                                   disagrees with where the window has put it (the root mean square of
                                   the prior's reprojection errors at the landmark) by more than this
                                   many times the median over the leaving keyframe's landmarks (at
                                   least 0.1 px) forgets its prior before taking the keyframe's
                                   observation: what its old keyframes saw no longer agrees with what
                                   the window sees (a track that slid, old poses that drifted), and a
                                   prior kept through that holds the disagreement in the map (on the
                                   renders its scale drifted). [0, 100]; 0: no gate; default 2
                                   (docs/design.md, "Windowed bundle adjustment") */
    int32_t map_twin_dir;     /* (added) 1: a plane's twin poses (two-view poses that explain a dominant
                                   plane's tracks equally well) that the tracks off the plane cannot
                                   tell apart are told apart by the direction of the map's last step
                                   while the map poses frames, when it is within 45 deg of one twin's,
                                   before the last two-view directions are asked (which follow the twin
                                   they chose: in a turn with a sideways step in front of one wall they
                                   slide to the wrong twin, whose rotation is off by up to 0.6 deg a
                                   frame, and the map's rotation prior follows it). 0 or 1; default 0
                                   (docs/evaluation.md, "Fast turns in the test room") */
} tvo_vo_config;

/* Fill cfg with defaults for `camera` (copied): the balanced preset's tracker and window below (the
 * affine refinement, the map's predicted tracks, 8 keyframes with 4 fixed) in a build with the affine
 * refinement (TVO_WITH_AFFINE, the default build), the basic preset's in a build without it. LK's pyramid
 * follows the frame's size: lk.max_level 3 up to 1280 px on the larger side, one more level for each
 * doubling beyond (4 up to 2560, 5 up to 5120, at most TVO_MAX_PYR_LEVELS - 1), so that the coarsest
 * level keeps at most 160 px, while the new level's smaller side stays above lk.win_size (LK does not
 * use a level that small); 3 for a NULL camera. */
TVO_API void tvo_vo_config_default(tvo_vo_config *cfg, const tvo_camera *camera);

/* Named configurations (docs/camera.md, "Presets"):
 * TVO_VO_PRESET_DEFAULT    the defaults (tvo_vo_config_default): TVO_VO_PRESET_BALANCED in a build with the
 *                          affine refinement, TVO_VO_PRESET_BASIC without it.
 * TVO_VO_PRESET_BALANCED   every track re-aligned every frame to the patch it was detected on under an
 *                          affine warp (affine_win_size 21), the tracks the local map predicts tracked on
 *                          2 pyramid levels with 11x11 windows before that (map_prediction 2,
 *                          lk.pred_levels 2, lk.pred_win_size 11; a frame that loses more than half of
 *                          them tracks those again the full way, pred_rescue, and for 30 frames the map
 *                          judges a weak rotation prior by its landmarks in 3 or more keyframes:
 *                          map_rot_prior_obs 3, map_rot_prior_obs_frames 30, every preset's values, which
 *                          act only with pred_rescue), a window of 8 keyframes
 *                          with 4 fixed (map_window 8, map_ba_fixed 4), the chain's steps following the
 *                          relative scale before the map (chain_scale_sigmas 3), and the landmarks of
 *                          64 ended tracks found again while the map runs short of points (map_refind
 *                          64, map_refind_rescue 1). On the sequences of docs/rules.md 0.45 times the
 *                          basic preset's ATE and 0.48 times its rotation error, for 0.55-1.05 times
 *                          its instructions; about 1,000 more bytes a track and 54 KB for the store.
 *                          Needs a build with the affine refinement (TVO_WITH_AFFINE, options.h).
 * TVO_VO_PRESET_ACCURATE   the balanced preset with the full tracker on every track (no map prediction):
 *                          more accurate than balanced on the real KITTI 06 and 01 (KITTI 07 the same once
 *                          its lens is refined on the run), for 1.2-1.3 times the
 *                          basic preset's instructions and 1.45-1.6 times the two-view time per frame.
 *                          Needs the affine refinement.
 * TVO_VO_PRESET_BASIC      translation-only LK on every track, a window of 6 keyframes with 2 fixed, chain
 *                          steps of one length (affine_win_size 0, map_prediction 0, map_window 6,
 *                          map_ba_fixed 2, chain_scale_sigmas 0): the
 *                          default before the balanced preset, and of a build without the affine refinement;
 *                          the least memory of the full-size presets.
 * TVO_VO_PRESET_SMALL      sized for a QVGA (320x240) camera on a microcontroller: the basic preset with
 *                          120 tracks (min_tracks 80, keyframe_min_tracks 40, detect.max_corners 120), 3
 *                          pyramid levels (lk.max_level 2), a map of 5 keyframes and 160 landmarks, the
 *                          lens as configured (lens_refine 0: a microcontroller build leaves it out). At
 *                          320x240 the VO needs 230,192 bytes on a Cortex-M7 (tools/run-mcu.sh runs it
 *                          there). */
typedef enum tvo_vo_preset {
    TVO_VO_PRESET_DEFAULT = 0,
    TVO_VO_PRESET_ACCURATE = 1,
    TVO_VO_PRESET_SMALL = 2,
    TVO_VO_PRESET_BALANCED = 3,
    TVO_VO_PRESET_BASIC = 4
} tvo_vo_preset;

/* Fill cfg with the preset's configuration for `camera` (copied). TVO_OK; TVO_ERR_NULL when cfg is NULL;
 * TVO_ERR_ARG for an unknown preset and TVO_ERR_UNSUPPORTED for TVO_VO_PRESET_ACCURATE or _BALANCED in a build
 * without the affine refinement, both leaving cfg filled with the defaults. */
TVO_API tvo_status tvo_vo_config_preset(tvo_vo_config *cfg, const tvo_camera *camera, tvo_vo_preset preset);

/* tvo_vo_result.rel_scale when the relative scale is not available. */
#define TVO_VO_REL_SCALE_NONE 0.0

typedef struct tvo_vo_result {
    tvo_vo_state state;
    int32_t relpose_flags;          /* TVO_RELPOSE_FLAG_* of this frame's estimate (0 when none ran) */
    tvo_status pose_status;         /* status of this frame's relative-pose estimate (TVO_OK when none ran) */
    tvo_pose T_prev_cur;            /* raw relative pose: p_prev = R p_cur + t, |t| = 1 or t = 0 */
    int32_t tracked;                /* tracks that survived LK + forward-backward into this frame */
    int32_t gain_retry;             /* 1: they were tracked again after an exposure step (cfg.gain_retry) */
    int32_t pred_rescue;            /* 1: the map predicted their positions, LK lost more than half of the
                                       predicted ones, and those were tracked again the default way
                                       (cfg.pred_rescue) */
    int32_t affine_tried;           /* tracks the affine refinement tried to align to their templates in this
                                       frame (cfg.affine_win_size; only on keyframes with
                                       cfg.affine_at_keyframes); 0 without the refinement */
    int32_t affine_refined;         /* of them, those it moved: the others keep LK's position and take a new
                                       template (no convergence, a correlation below 0.8, more than 2 px from
                                       LK's position, the window out of the image), or are ended */
    int32_t affine_ended;           /* of the others, the tracks ended (cfg.affine_end_share); 0 when off */
    int32_t map_refound;            /* landmarks found again and carried by new tracks (cfg.map_refind) */
    int32_t inliers;                /* pose inliers among them */
    int32_t new_corners;            /* corners added by re-detection in this frame */
    int32_t tracks;                 /* tracks carried to the next frame */
    double parallax_deg;            /* median rotation-compensated parallax of the inliers */
    int64_t dt_ns;                  /* time since the previous frame (0 on the first; at most INT64_MAX) */
    float features[TVO_FEAT_COUNT]; /* front-end features for the per-DoF networks (nn.h layout) */
    double rel_scale;         /* relative scale r = |t_k| / |t_(k-1)|: the metric length of this frame's step
                                  over the previous frame's, from the tracks seen in frames k-2, k-1 and k,
                                  triangulated in frame k-1 once with the previous step's unit translation
                                  and once with this one's (median depth ratio). TVO_VO_REL_SCALE_NONE (0)
                                  when not available: this frame or the previous one is not OK (no
                                  translation: initialising, rotation-only, lost, after a reset), or fewer
                                  than cfg.min_scale_points tracks have enough parallax and positive depth in
                                  both pairs (e.g. most tracks re-detected). Otherwise finite and > 0. */
    int32_t rel_scale_points; /* tracks the median used (may be > 0 with rel_scale 0: too few of them) */
    int32_t keyframe_age;     /* > 0: the rotation is the keyframe rotation, K being this many frames back;
                                  0: frame-to-frame */
    /* the pose in the VO's world: the camera of the first frame after init is the origin; the unit of
       length is the first map's initial baseline, and it holds for the whole run (see map_state for
       where the pose comes from). Always finite. */
    tvo_pose T_w_c;
    tvo_vo_map_state map_state;
    int32_t keyframe;       /* 1 when this frame became a map keyframe */
    int32_t map_points;     /* landmarks (PnP inliers) this frame's pose used */
    int32_t map_new_points; /* landmarks triangulated in this frame */
    int32_t map_landmarks;  /* landmarks in the map after this frame */
    int32_t map_losses;     /* map losses since init (TVO_MAP_LOST frames) */
    int32_t map_store_full; /* (added) keyframes and new maps since init that found the landmark store
                               (map_max_landmarks) full and made fewer landmarks than they could: a
                               store too small for the window and the scene */
    int32_t ba_iterations;  /* bundle adjustment iterations in this frame (0: none ran) */
    int32_t ba_flags;       /* its TVO_BA_FLAG_* (ba.h), and TVO_VO_BA_TURN_REFUSED */
    int64_t stage_ns[TVO_STAGE_COUNT];
    int32_t lens_update;  /* (added) 1: the lens was changed after this frame (cfg.lens_refine) */
    int32_t lens_updates; /* (added) lens changes since init (0 without cfg.lens_refine) */
    double lens_dk[2];    /* (added) their sum: the k1, k2 in use minus the configured ones */
} tvo_vo_result;

/* tvo_vo_result.ba_flags: the bundle adjustment's result was not taken, since it turned the newest
 * keyframe by more than cfg.map_ba_max_turn_deg (a bit beside the TVO_BA_FLAG_* of ba.h). */
#define TVO_VO_BA_TURN_REFUSED 256

/* Largest map window (keyframes). */
#define TVO_VO_MAX_WINDOW 16

/* A track as the VO holds it after a frame (tvo_vo_tracks). */
typedef struct tvo_vo_track {
    float x, y;       /* position in the last frame, pixels of the raw (distorted) image */
    uint32_t id;      /* unique per track while the VO lives (wraps after 2^32 tracks) */
    int32_t age;      /* frames it has been tracked through (0: detected in the last frame) */
    uint8_t inlier;   /* 1: it supported the last frame's pose (map inlier when the map tracked
                                  the frame, else an inlier of the two-view pose) */
    uint8_t landmark; /* 1: it carries a map landmark */
} tvo_vo_track;

typedef struct tvo_vo tvo_vo;

/* Bytes of memory tvo_vo_init() needs for `cfg`, or 0 if cfg is invalid. */
TVO_API size_t tvo_vo_required_size(const tvo_vo_config *cfg);

/* Lay the VO out in mem (which must stay valid while *vo is used). Copies cfg. */
TVO_API tvo_status tvo_vo_init(tvo_vo **vo, const tvo_vo_config *cfg, void *mem, size_t mem_size);

/* Process one grey frame of exactly camera.width x camera.height. t_ns must increase; a frame
 * whose timestamp does not increase is refused with TVO_ERR_ARG and leaves the VO unchanged.
 * On any error the VO is unchanged and *res holds state LOST with an identity pose.
 * res->T_prev_cur is always finite. */
TVO_API tvo_status tvo_vo_process(tvo_vo *vo, const tvo_image *frame, int64_t t_ns, tvo_vo_result *res);

/* Forget the tracks and the map: the object behaves as after tvo_vo_init() (the next frame initialises
 * again, T_w_c starts from the identity in a new unit of length). For a change of camera or scene (a
 * camera restart, another recording); dropped frames need no reset: pass the next frame with its time,
 * and the VO tracks across the gap or, where it cannot, starts a new map that keeps the unit. A caller
 * that chains trajectories across a reset (tvo_replay --gap-reset) composes the new T_w_c onto its last
 * pose. */
TVO_API void tvo_vo_reset(tvo_vo *vo);

/* Read-only view of the current tracks (for drawing or logging): copies min(count, capacity) of them into
 * out and writes the number the VO holds into *count. TVO_ERR_NULL; out may be NULL with capacity 0. */
TVO_API tvo_status tvo_vo_tracks(const tvo_vo *vo, tvo_vo_track *out, int32_t capacity, int32_t *count);

/* The per-DoF networks' refinement of a frame's raw step: *step = res->T_prev_cur with its translation
 * (metres) replaced by the model's tx ty tz when the model provides all three, or by the model's step
 * length s times the raw unit translation when it has a step-length branch (s <= 0 gives t = 0), and its
 * rotation by the model's rotation vector when it provides rx ry rz. Integrate the result with scale 1. On an error of
 * tvo_nn_run (e.g. a non-finite feature) *step is the raw step and the status is returned: integrate it
 * with scale 0. */
TVO_API tvo_status tvo_vo_refine(const tvo_nn *nn, const tvo_vo_result *res, tvo_pose *step);

/* Step-length filter: the metric length of each OK frame's unit translation from the VO's relative scale
 * (tvo_vo_result.rel_scale) and an absolute step-length prior n_k (e.g. the per-DoF networks' |t|, or a
 * constant), combined in log space as a complementary filter:
 *     log s_k = (1 - alpha) (log s_(k-1) + log r_k) + alpha log n_k
 * alpha = 0 propagates the scale (s_k = r_k s_(k-1), after tvo_scale_filter_seed()); alpha = 1 is the
 * prior alone. When r_k is not available the previous length is carried (r_k = 1); without a prior
 * (n_k <= 0 or not finite) the prediction alone is kept. The state is two numbers: no allocation.
 * log/exp are evaluated with + - * / and frexp/ldexp only, so results agree across targets. */
typedef struct tvo_scale_filter {
    double alpha; /* weight of the prior per step, [0, 1] */
    double log_s; /* log of the last step length (m), valid when has_s */
    int32_t has_s;
    int32_t steps; /* updates done since init */
} tvo_scale_filter;

/* TVO_ERR_NULL, or TVO_ERR_ARG for alpha outside [0, 1] (or NaN): f is then unusable (its updates return
 * TVO_ERR_ARG with a zero step). */
TVO_API tvo_status tvo_scale_filter_init(tvo_scale_filter *f, double alpha);
/* Set the current step length (m, finite, > 0; else TVO_ERR_ARG and f unchanged), e.g. from ground truth. */
TVO_API tvo_status tvo_scale_filter_seed(tvo_scale_filter *f, double step);
/* One frame with a translation: rel_scale r_k (TVO_VO_REL_SCALE_NONE when not available; other values
 * <= 0 or not finite are treated the same), prior n_k in metres (<= 0 or not finite: none). *step gets
 * s_k (finite, in [1e-9, 1e3] m). Without a state and without a prior there is nothing to start from:
 * *step = 0 and TVO_ERR_RANGE (integrate a zero step). */
TVO_API tvo_status tvo_scale_filter_update(tvo_scale_filter *f, double rel_scale, double prior, double *step);

/* Trajectory integration: T_w_c(k+1) = T_w_c(k) * [R | scale * t]. */
typedef struct tvo_traj {
    tvo_pose T_w_c; /* current camera pose in the world */
    int32_t steps;
} tvo_traj;
TVO_API void tvo_traj_init(tvo_traj *traj, const tvo_pose *T_w_c0);
/* scale in metres for the unit translation of T_prev_cur; refuses non-finite input (TVO_ERR_NOT_FINITE)
 * and leaves the trajectory unchanged. */
TVO_API tvo_status tvo_traj_step(tvo_traj *traj, const tvo_pose *T_prev_cur, double scale);

#ifdef __cplusplus
}
#endif

#endif /* TINYVO_VO_H */
