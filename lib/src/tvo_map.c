/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the VO's local map. See tvo_map.h for the design and vo.h for the configuration. */
#include "tvo_map.h"

#include <math.h>
#include <string.h>

#include "tinyvo/ba_prior.h"
#include "tinyvo/dmath.h"
#include "tinyvo/linalg.h"

#define TVO_MAP_PI 3.14159265358979323846

/* ---- tuning constants (the user-facing ones are in tvo_vo_config; these are fixed) -------------- */

/* A triangulated point must reproject within this many pixels in both of its keyframes. */
#define TVO_MAP_TRI_MAX_ERR_PX 2.0
/* ...and lie at least this far in front of both cameras, in units of the baseline between them. */
#define TVO_MAP_TRI_MIN_DEPTH 1e-3
/* ...and at most this far (a point beyond it is as good as at infinity: its parallax is noise). */
#define TVO_MAP_TRI_MAX_DEPTH 1e4
/* The first map's points need cfg.map_tri_parallax_deg, like every landmark; when fewer than the
 * first map needs reach it and it is above this (deg), the pair is triangulated again at this one, so
 * that a higher landmark threshold does not hold back a first map that the default would have made (a
 * highway, whose tracks leave the view before many reach 1 deg). */
#define TVO_MAP_INIT_TRI_FALLBACK_DEG 0.5
/* After a bundle adjustment, observations with a larger reprojection error are removed. */
#define TVO_MAP_BA_MAX_ERR_PX 2.5
/* No keyframe below this share of cfg.map_kf_baseline (the camera only turned)... */
#define TVO_MAP_KF_MIN_BASELINE 0.25
/* ...unless fewer than this many times cfg.map_min_points landmarks are left (the map runs out of points:
 * below map_min_points it is lost). */
#define TVO_MAP_KF_RESCUE_POINTS 2
/* PnP inlier threshold, in pixels. */
#define TVO_MAP_PNP_THRESHOLD_PX 2.0
/* With cfg.map_inlier_sigmas, the gate on the inliers' reprojection errors never goes below this (px). */
#define TVO_MAP_GATE_MIN_PX 0.5
/* With cfg.map_lm_prior_gate, the gate on a landmark's prior never goes below this (px), and it needs the
 * priors of at least TVO_MAP_PRIOR_GATE_MIN_N of the leaving keyframe's landmarks for its median. */
#define TVO_MAP_PRIOR_GATE_MIN_PX 0.1
#define TVO_MAP_PRIOR_GATE_MIN_N 8
/* The median of the norm of a 2D Gaussian error of sigma 1 per axis (Rayleigh: sqrt(2 ln 2)). */
#define TVO_MAP_RAYLEIGH_MEDIAN 1.1774
/* The initial pair needs max(TVO_MAP_INIT_MIN_POINTS, cfg.max_tracks / TVO_MAP_INIT_TRACKS_DIV)
 * triangulated landmarks (100 with the default 300 tracks, as ORB-SLAM's monocular initialisation asks
 * for 100 map points; twice the divisor, 50, after cfg.map_init_wait_s seconds without a map), and half
 * of the reference's tracks still tracked; a reference older than
 * TVO_MAP_REF_MAX_FRAMES frames without success, or with fewer of its tracks left, is renewed. */
#define TVO_MAP_INIT_MIN_POINTS 40
#define TVO_MAP_INIT_TRACKS_DIV 3
#define TVO_MAP_REF_MAX_FRAMES 60
/* The initial pair is refused when its rotation is further than max(10 x its parallax, this) from its
 * own rotation-only model (a wrong epipolar minimum). */
#define TVO_MAP_INIT_ROT_CHECK_DEG 3.0
/* A frame pose from the map further than this from the two-view rotation of the frame (when there is
 * one) is not trusted: the map is dropped (a wrong PnP minimum on few points). */
#define TVO_MAP_ROT_CHECK_DEG 5.0

/* The two-view rotation prior of a frame's PnP keeps its weight while the rotation the landmarks alone
 * give is within this chi-square value (3 degrees of freedom, 99 %) of it under the two estimates'
 * covariances (consistent_prior); beyond it the weight is lowered until they agree... */
#define TVO_MAP_ROT_PRIOR_GATE 11.345
/* ...by halving it, up to this many times (2^-40: nothing left). */
#define TVO_MAP_ROT_PRIOR_HALVINGS 40

/* ---- small vector helpers ----------------------------------------------------------------------- */

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static double deg2rad(double d)
{
    return d * (TVO_MAP_PI / 180.0);
}

/* a - b for timestamps a >= b, saturated at INT64_MAX (two int64 timestamps can be further apart than
 * that); 0 when a < b */
static int64_t dt_ns(int64_t a, int64_t b)
{
    uint64_t d;
    if (a < b)
        return 0;
    d = (uint64_t)a - (uint64_t)b;
    return d > (uint64_t)INT64_MAX ? INT64_MAX : (int64_t)d;
}

/* camera centre of T_c_w: C = -R^T t */
static void centre(const tvo_pose *T, double C[3])
{
    tvo_la_mat3_tvec(T->R, T->t, C);
    C[0] = -C[0];
    C[1] = -C[1];
    C[2] = -C[2];
}

/* The distance between the centres of the cameras of A and B. */
static double centre_distance(const tvo_pose *A, const tvo_pose *B)
{
    double ca[3], cb[3], d[3];
    centre(A, ca);
    centre(B, cb);
    d[0] = cb[0] - ca[0];
    d[1] = cb[1] - ca[1];
    d[2] = cb[2] - ca[2];
    return sqrt(dot3(d, d));
}

static double focal(const tvo_vo_config *cfg)
{
    return 0.5 * (cfg->camera.fx + cfg->camera.fy);
}

/* ---- layout ------------------------------------------------------------------------------------- */

/* The landmarks' priors (cfg.map_lm_prior): in the map, and as the adjustment's copy in its scratch. */
static size_t prior_size(const tvo_vo_config *cfg)
{
#if TVO_WITH_AFFINE
    if (cfg->map_lm_prior > 0.0)
        return tvo_arena_round(
                tvo_size_mul((size_t)cfg->map_max_landmarks, TVO_MAP_PRIOR_SIZE * sizeof(double)));
#else
    (void)cfg;
#endif
    return 0;
}

size_t tvo_map_layout_size(const tvo_vo_config *cfg)
{
    const size_t w = (size_t)cfg->map_window, n = (size_t)cfg->max_tracks, l = (size_t)cfg->map_max_landmarks;
    size_t s = tvo_arena_round(tvo_size_mul(w, sizeof(tvo_map_kf)));
    s = tvo_size_add(s, tvo_size_mul(w, tvo_arena_round(tvo_size_mul(n, sizeof(int32_t)))));
    s = tvo_size_add(s, tvo_size_mul(w, tvo_arena_round(tvo_size_mul(n, sizeof(tvo_point2d)))));
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(l, sizeof(tvo_map_lm))));
    return tvo_size_add(s, prior_size(cfg));
}

/* The per-call scratch of each phase (they never overlap in time). */
static size_t init_scratch(const tvo_vo_config *cfg)
{
    const size_t n = (size_t)cfg->max_tracks;
    size_t s = tvo_arena_round(tvo_size_mul(n, sizeof(tvo_point2d))) * 2;
    s = tvo_size_add(s, tvo_arena_round(n));
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(int32_t))));
    return tvo_size_add(s, tvo_arena_round(tvo_relpose_scratch_size(cfg->max_tracks)));
}

static size_t track_scratch(const tvo_vo_config *cfg)
{
    const size_t n = (size_t)cfg->max_tracks;
    size_t s = tvo_arena_round(tvo_size_mul(n, 3 * sizeof(double)));
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(tvo_point2d))));
    s = tvo_size_add(s, tvo_arena_round(n) * 3);
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(int32_t))));
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(n, sizeof(double))));
    return tvo_size_add(s, tvo_arena_round(tvo_pnp_scratch_size(cfg->max_tracks)));
}

static void ba_config(const tvo_vo_config *cfg, tvo_ba_config *bc)
{
    tvo_ba_config_default(bc);
    bc->max_iterations = cfg->map_ba_iterations;
    bc->huber = cfg->map_ba_huber_px / focal(cfg);
    bc->max_poses = cfg->map_window;
    bc->max_points = cfg->map_max_landmarks;
    bc->max_obs = cfg->map_window * cfg->max_tracks;
}

static size_t kf_scratch(const tvo_vo_config *cfg)
{
    const size_t w = (size_t)cfg->map_window, l = (size_t)cfg->map_max_landmarks;
    const size_t o = tvo_size_mul(w, (size_t)cfg->max_tracks);
    tvo_ba_config bc;
    size_t s;
    ba_config(cfg, &bc);
    s = tvo_arena_round(tvo_size_mul(w, sizeof(tvo_pose)));
    s = tvo_size_add(s, tvo_arena_round(w));
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(l, 3 * sizeof(double))));
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(l, sizeof(int32_t))) * 2);
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(o, sizeof(tvo_ba_obs))));
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(o, sizeof(double))));
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(w, sizeof(tvo_ba_rot_prior))));
    s = tvo_size_add(s, prior_size(cfg));
#if TVO_WITH_LENS
    if (cfg->lens_refine)
        s = tvo_size_add(s,
                         tvo_arena_round(tvo_lens_scratch_size(cfg->map_window, cfg->map_max_landmarks,
                                                               cfg->map_window * cfg->max_tracks)));
#endif
    return tvo_size_add(s, tvo_arena_round(tvo_ba_scratch_size(&bc)));
}

size_t tvo_map_scratch_size(const tvo_vo_config *cfg)
{
    size_t a = init_scratch(cfg), b = track_scratch(cfg), c = kf_scratch(cfg);
    size_t m = a > b ? a : b;
    return tvo_size_add(m > c ? m : c, TVO_ARENA_ALIGN);
}

tvo_status tvo_map_init(tvo_map *m, const tvo_vo_config *cfg, tvo_arena *a)
{
    memset(m, 0, sizeof(*m));
    m->window = cfg->map_window;
    m->max_tracks = cfg->max_tracks;
    m->max_lm = cfg->map_max_landmarks;
    m->kf = (tvo_map_kf *)tvo_arena_alloc(a, (size_t)m->window * sizeof(tvo_map_kf));
    if (m->kf == NULL)
        return TVO_ERR_NO_MEMORY;
    for (int32_t i = 0; i < m->window; ++i) {
        m->kf[i].obs_lm = (int32_t *)tvo_arena_alloc(a, (size_t)m->max_tracks * sizeof(int32_t));
        if (m->kf[i].obs_lm == NULL)
            return TVO_ERR_NO_MEMORY;
    }
    for (int32_t i = 0; i < m->window; ++i) {
        m->kf[i].obs_x = (tvo_point2d *)tvo_arena_alloc(a, (size_t)m->max_tracks * sizeof(tvo_point2d));
        if (m->kf[i].obs_x == NULL)
            return TVO_ERR_NO_MEMORY;
    }
    m->lm = (tvo_map_lm *)tvo_arena_alloc(a, (size_t)m->max_lm * sizeof(tvo_map_lm));
    if (m->lm == NULL)
        return TVO_ERR_NO_MEMORY;
#if TVO_WITH_AFFINE
    if (cfg->map_lm_prior > 0.0) {
        m->prior = (double(*)[TVO_MAP_PRIOR_SIZE])tvo_arena_alloc(a,
                                                                  (size_t)m->max_lm * TVO_MAP_PRIOR_SIZE *
                                                                          sizeof(double));
        if (m->prior == NULL)
            return TVO_ERR_NO_MEMORY;
        m->prior_w = cfg->map_lm_prior;
        m->prior_huber = cfg->map_ba_huber_px / focal(cfg);
    }
    for (int32_t i = 0; i < m->max_lm; ++i)
        m->lm[i].gen = 0;
#endif
    tvo_map_reset(m);
    return TVO_OK;
}

/* The two-view rotations chained since the newest keyframe start again (at a keyframe, a new map). */
static void chain_reset(tvo_map *m)
{
    static const double I[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    memcpy(m->chain_R, I, sizeof(I));
    m->chain_ok = 1;
}

void tvo_map_reset(tvo_map *m)
{
    tvo_map_clear(m);
    m->waiting = 0;
    m->wait_t_ns = 0;
    for (int32_t i = 0; i < TVO_MAP_RING; ++i)
        m->ring[i].serial = -1;
    m->next_kf_id = 0;
    m->lens_kf = -1;
    m->serial = -1;
    m->speed = 0.0;
    m->losses = 0;
    m->store_full = 0;
}

void tvo_map_clear(tvo_map *m)
{
    m->n_kf = 0;
    m->kf_head = 0;
    m->n_lm = 0;
    m->active = 0;
    m->has_ref = 0;
    m->has_vel = 0;
    m->kf_points = 0;
    m->frames_since_kf = 0;
    m->cur_kf_id = -1;
    m->lm_cursor = 0;
    m->depth_med = 0.0;
    m->rms = 0.0;
    chain_reset(m);
    for (int32_t i = 0; i < m->max_lm; ++i) {
        m->lm[i].alive = 0;
        m->lm[i].tracked = 0;
        m->lm[i].n_obs = 0;
    }
}

/* The landmarks a new map needs at time t_ns (see TVO_MAP_INIT_MIN_POINTS): half as many once the map
 * has been waited for cfg.map_init_wait_s seconds. */
static int32_t init_min_points(const tvo_map *m, const tvo_vo_config *cfg, int64_t t_ns)
{
    int32_t div = TVO_MAP_INIT_TRACKS_DIV, k;
    if (cfg->map_init_wait_s > 0.0 && m->waiting &&
        (double)dt_ns(t_ns, m->wait_t_ns) >= cfg->map_init_wait_s * 1e9)
        div *= 2;
    k = cfg->max_tracks / div;
    return k > TVO_MAP_INIT_MIN_POINTS ? k : TVO_MAP_INIT_MIN_POINTS;
}

/* ---- keyframes and landmarks -------------------------------------------------------------------- */

/* the i-th keyframe of the window, oldest first */
static tvo_map_kf *kf_at(tvo_map *m, int32_t i)
{
    return &m->kf[(m->kf_head + i) % m->window];
}

static tvo_map_kf *kf_by_id(tvo_map *m, int32_t id)
{
    for (int32_t i = 0; i < m->n_kf; ++i) {
        tvo_map_kf *k = kf_at(m, i);
        if (k->id == id)
            return k;
    }
    return NULL;
}

/* The pose of frame `serial` (the keyframe's, refined, when it became one in the window); NULL when the
 * frame is no longer in the ring. *kf gets its keyframe or NULL. */
static const tvo_pose *frame_pose(tvo_map *m, int32_t serial, tvo_map_kf **kf)
{
    const tvo_map_frame_pose *f;
    *kf = NULL;
    if (serial < 0)
        return NULL;
    f = &m->ring[serial % TVO_MAP_RING];
    if (f->serial != serial)
        return NULL;
    if (f->kf_id >= 0)
        *kf = kf_by_id(m, f->kf_id);
    return *kf != NULL ? &(*kf)->T_c_w : &f->T_c_w;
}

static void ring_put(tvo_map *m, const tvo_pose *T, int32_t kf_id)
{
    tvo_map_frame_pose *f = &m->ring[m->serial % TVO_MAP_RING];
    f->serial = m->serial;
    f->kf_id = kf_id;
    f->T_c_w = *T;
}

static void lm_free(tvo_map *m, int32_t j)
{
    if (m->lm[j].alive) {
        m->lm[j].alive = 0;
        m->n_lm--;
    }
}

/* A free landmark slot, or -1 when the map is full (counted in store_full: each caller stops making
 * landmarks at the first -1). */
static int32_t lm_alloc(tvo_map *m)
{
    for (int32_t k = 0; k < m->max_lm; ++k) {
        const int32_t j = (m->lm_cursor + k) % m->max_lm;
        if (!m->lm[j].alive) {
            m->lm_cursor = (j + 1) % m->max_lm;
            m->lm[j].alive = 1;
            m->lm[j].n_obs = 0;
            m->lm[j].tracked = 0;
#if TVO_WITH_AFFINE
            if (m->prior != NULL)
                memset(m->prior[j], 0, sizeof(m->prior[j]));
            m->lm[j].gen++;
#endif
            m->n_lm++;
            return j;
        }
    }
    m->store_full++;
    return -1;
}

static int kf_add_obs(tvo_map *m, tvo_map_kf *k, int32_t j, tvo_point2d x)
{
    if (k->n_obs >= m->max_tracks)
        return 0;
    k->obs_lm[k->n_obs] = j;
    k->obs_x[k->n_obs] = x;
    k->n_obs++;
    m->lm[j].n_obs++;
    return 1;
}

/* A landmark at X for track i (when i >= 0: the track carries it), observed at x0 in k0 (when not NULL) and
 * at x1 in k1; -1 when the store is full. */
static int32_t lm_make(tvo_map *m, tvo_map_tracks *tr, int32_t i, const double X[3], tvo_map_kf *k0,
                       tvo_point2d x0, tvo_map_kf *k1, tvo_point2d x1)
{
    const int32_t j = lm_alloc(m);
    if (j < 0)
        return -1;
    memcpy(m->lm[j].X, X, sizeof(m->lm[j].X));
    if (k0 != NULL)
        (void)kf_add_obs(m, k0, j, x0);
    (void)kf_add_obs(m, k1, j, x1);
    if (i >= 0) {
        m->lm[j].tracked = 1;
        tr->lm[i] = j;
        tr->inlier[i] = 1;
    }
    return j;
}

#if TVO_WITH_AFFINE
/* The mean square of the reprojection errors a landmark's prior holds (normalised units), at X: the
 * prior's cost 1/2 X^T L X + g^T X + c over half its weight; 0 for an empty prior. */
static double prior_ms(const tvo_map *m, const double *q, const double X[3])
{
    const double cost = tvo_ba_prior_cost(q, X);
    const double n = q[TVO_BA_PRIOR_SIZE];
    return n > 0.0 && cost > 0.0 ? 2.0 * cost / (m->prior_w * n) : 0.0;
}

/* cfg.map_lm_prior_gate: the squared gate on the priors of keyframe k's landmarks, from the median of
 * their mean squares (err: scratch for cap values), or -1 (no gate: off, no cfg or scratch, too few
 * priors). */
static double prior_gate2(const tvo_map *m, const tvo_vo_config *cfg, const tvo_map_kf *k, double *err,
                          int32_t cap)
{
    int32_t ne = 0;
    double g2, lo;
    if (cfg == NULL || !(cfg->map_lm_prior_gate > 0.0) || err == NULL)
        return -1.0;
    for (int32_t o = 0; o < k->n_obs && ne < cap; ++o) {
        const int32_t j = k->obs_lm[o];
        if (m->prior[j][TVO_BA_PRIOR_SIZE] > 0.0)
            err[ne++] = prior_ms(m, m->prior[j], m->lm[j].X);
    }
    if (ne < TVO_MAP_PRIOR_GATE_MIN_N)
        return -1.0;
    g2 = cfg->map_lm_prior_gate * cfg->map_lm_prior_gate * tvo_la_select_kth(err, ne, ne / 2);
    lo = TVO_MAP_PRIOR_GATE_MIN_PX / focal(cfg);
    return g2 > lo * lo ? g2 : lo * lo;
}
#endif

/* Drop the oldest keyframe of the window: its observations go (with cfg.map_lm_prior, into their
 * landmarks' priors, linearised where the window left the keyframe and the landmark; a prior the gate of
 * cfg.map_lm_prior_gate refuses is emptied first), and landmarks nobody observes or tracks any more are
 * freed. cfg, err: the configuration and scratch for cap values for the gate (NULL: no gate). */
static void kf_drop_oldest(tvo_map *m, const tvo_vo_config *cfg, double *err, int32_t cap)
{
    tvo_map_kf *k = kf_at(m, 0);
#if TVO_WITH_AFFINE
    const double g2 = m->prior != NULL && k->adjusted ? prior_gate2(m, cfg, k, err, cap) : -1.0;
#else
    (void)cfg;
    (void)err;
    (void)cap;
#endif
    for (int32_t o = 0; o < k->n_obs; ++o) {
        const int32_t j = k->obs_lm[o];
#if TVO_WITH_AFFINE
        if (m->prior != NULL && k->adjusted) {
            double *q = m->prior[j];
            if (g2 >= 0.0 && q[TVO_BA_PRIOR_SIZE] > 0.0 && !(prior_ms(m, q, m->lm[j].X) <= g2))
                memset(q, 0, sizeof(m->prior[j]));
            if (tvo_ba_point_prior_add(q, &k->T_c_w, m->lm[j].X, k->obs_x[o].x, k->obs_x[o].y, m->prior_huber,
                                       m->prior_w))
                q[TVO_BA_PRIOR_SIZE] += 1.0;
        }
#endif
        m->lm[j].n_obs--;
        if (m->lm[j].n_obs <= 0 && !m->lm[j].tracked)
            lm_free(m, j);
    }
    k->n_obs = 0;
    m->kf_head = (m->kf_head + 1) % m->window;
    m->n_kf--;
}

/* A new keyframe at the window's end (the oldest dropped when the window is full; cfg, err, cap: as
 * kf_drop_oldest takes them). */
static tvo_map_kf *kf_push(tvo_map *m, const tvo_pose *T_c_w, int64_t t_ns, const tvo_vo_config *cfg,
                           double *err, int32_t cap)
{
    tvo_map_kf *k;
    if (m->n_kf == m->window)
        kf_drop_oldest(m, cfg, err, cap);
    k = &m->kf[(m->kf_head + m->n_kf) % m->window];
    m->n_kf++;
    k->id = m->next_kf_id++;
    if (m->next_kf_id < 0) { /* wrapped after 2^31 keyframes: ids only need to differ within the window */
        m->next_kf_id = 0;
        m->lens_kf = -1;
    }
    k->t_ns = t_ns;
    k->T_c_w = *T_c_w;
    k->n_obs = 0;
    k->has_R_prev = 0;
    k->adjusted = 0;
    return k;
}

/* Mark the landmarks the tracks carry. */
static void mark_tracked(tvo_map *m, const tvo_map_tracks *tr)
{
    for (int32_t j = 0; j < m->max_lm; ++j)
        m->lm[j].tracked = 0;
    for (int32_t i = 0; i < tr->n; ++i)
        if (tr->lm[i] >= 0)
            m->lm[tr->lm[i]].tracked = 1;
}

/* The map's speed over its window (units per second), when the window spans time and distance. */
static void update_speed(tvo_map *m)
{
    const tvo_map_kf *a, *b;
    double dist, dt;
    if (m->n_kf < 2)
        return;
    a = kf_at(m, 0);
    b = kf_at(m, m->n_kf - 1);
    dist = centre_distance(&a->T_c_w, &b->T_c_w);
    dt = (double)dt_ns(b->t_ns, a->t_ns) * 1e-9;
    if (dt > 0.0 && dist > 0.0 && isfinite(dist / dt))
        m->speed = dist / dt;
}

/* ---- triangulation ------------------------------------------------------------------------------ */

#if defined(__GNUC__) || defined(__clang__)
#define MAP_NOINLINE __attribute__((noinline))
#else
#define MAP_NOINLINE
#endif

/* Squared reprojection error of X (world) seen at x by the camera T (normalised units); 1e60 behind the
 * camera. Not inlined: triangulate and gate_inliers call it in loops, and -Os code keeps one copy. */
static MAP_NOINLINE double reproj2(const tvo_pose *T, const double X[3], tvo_point2d x)
{
    double p[3], dx, dy;
    tvo_pose_transform_point(T, X, p);
    if (!(p[2] > 0.0))
        return 1e60;
    dx = p[0] / p[2] - x.x;
    dy = p[1] / p[2] - x.y;
    return dx * dx + dy * dy;
}

/* Midpoint triangulation of normalised x1 (camera 1) and x2 (camera 2) into world X; 1 when the rays are
 * at least min_cos apart (cos of the angle below min_cos), the point is in front of both cameras, and it
 * reprojects within max_err (normalised units) in both. */
static int triangulate(const tvo_pose *T1, const tvo_pose *T2, tvo_point2d x1, tvo_point2d x2, double min_cos,
                       double max_err, double X[3])
{
    double h1[3] = {x1.x, x1.y, 1.0}, h2[3] = {x2.x, x2.y, 1.0}, r1[3], r2[3], c1[3], c2[3], b[3];
    double a11, a12, a22, b1, b2, det, s1, s2, n1, n2, cosang, base;
    tvo_la_mat3_tvec(T1->R, h1, r1); /* ray directions in the world */
    tvo_la_mat3_tvec(T2->R, h2, r2);
    n1 = sqrt(dot3(r1, r1));
    n2 = sqrt(dot3(r2, r2));
    cosang = dot3(r1, r2) / (n1 * n2);
    if (!(cosang < min_cos))
        return 0;
    centre(T1, c1);
    centre(T2, c2);
    b[0] = c2[0] - c1[0];
    b[1] = c2[1] - c1[1];
    b[2] = c2[2] - c1[2];
    base = sqrt(dot3(b, b));
    /* c1 + s1 r1 ~ c2 + s2 r2: least squares in (s1, s2) */
    a11 = dot3(r1, r1);
    a12 = -dot3(r1, r2);
    a22 = dot3(r2, r2);
    b1 = dot3(r1, b);
    b2 = -dot3(r2, b);
    det = a11 * a22 - a12 * a12;
    if (!(det > 1e-14 * a11 * a22) || !(base > 0.0))
        return 0;
    s1 = (b1 * a22 - a12 * b2) / det;
    s2 = (a11 * b2 - a12 * b1) / det;
    /* s are depths (the rays have z = 1 in their cameras) */
    if (!(s1 > TVO_MAP_TRI_MIN_DEPTH * base && s2 > TVO_MAP_TRI_MIN_DEPTH * base) ||
        !(s1 < TVO_MAP_TRI_MAX_DEPTH * base && s2 < TVO_MAP_TRI_MAX_DEPTH * base))
        return 0;
    for (int c = 0; c < 3; ++c)
        X[c] = 0.5 * ((c1[c] + s1 * r1[c]) + (c2[c] + s2 * r2[c]));
    {
        const tvo_pose *T[2] = {T1, T2};
        const tvo_point2d *x[2] = {&x1, &x2};
        for (int v = 0; v < 2; ++v)
            if (!(reproj2(T[v], X, *x[v]) < max_err * max_err)) /* also behind the camera */
                return 0;
    }
    return isfinite(X[0]) && isfinite(X[1]) && isfinite(X[2]);
}

/* ---- scratch carving ---------------------------------------------------------------------------- */

typedef struct carve {
    tvo_arena a;
} carve;

static void *take(carve *c, size_t bytes)
{
    return tvo_arena_alloc(&c->a, bytes);
}

/* ---- initialisation ----------------------------------------------------------------------------- */

/* Make this frame the reference of a new map: every track waits in it. */
static void start_ref(tvo_map *m, tvo_map_tracks *tr, int64_t t_ns, const tvo_pose *T_c_w)
{
    tvo_map_clear(m);
    m->has_ref = 1;
    m->ref_serial = m->serial;
    m->ref_T_c_w = *T_c_w;
    m->ref_t_ns = t_ns;
    m->ref_frames = 0;
    for (int32_t i = 0; i < tr->n; ++i) {
        tr->lm[i] = -1;
        tr->tri_fr[i] = tr->x_ok[i] ? m->serial : -1;
        tr->tri_x[i] = tr->x[i];
    }
}

static void relpose_config(const tvo_vo_config *cfg, tvo_relpose_config *rc)
{
    *rc = cfg->relpose;
    rc->threshold = cfg->pose_threshold_px / focal(cfg);
}

/* The correspondences reference -> this frame (the tracks first seen in the reference) and their 5-point
 * pose, in scratch. */
typedef struct init_pair {
    tvo_point2d *xa, *xb; /* [k] normalised positions in the reference and in this frame */
    uint8_t *mask;        /* [k] inliers of rp */
    int32_t *idx;         /* [k] the tracks they belong to */
    int32_t k;
    tvo_relpose rp;
} init_pair;

/* 1 when the pair's pose is good enough to start a map on: trustworthy (not low-confidence, ambiguous or
 * rotation-only, at least need inliers and half of the pairs, its rotation near its own rotation-only
 * model) and with map_init_parallax_deg of median parallax. */
static int init_pair_pose(tvo_map *m, const tvo_vo_config *cfg, const tvo_map_tracks *tr, int32_t need,
                          void *scratch, size_t scratch_size, init_pair *ip)
{
    const int32_t n = tr->n;
    const size_t rs_size = tvo_relpose_scratch_size(cfg->max_tracks);
    tvo_relpose_config rc;
    tvo_relpose *rp = &ip->rp;
    void *rs;
    carve c;
    tvo_arena_init(&c.a, scratch, scratch_size);
    ip->xa = (tvo_point2d *)take(&c, (size_t)n * sizeof(tvo_point2d));
    ip->xb = (tvo_point2d *)take(&c, (size_t)n * sizeof(tvo_point2d));
    ip->mask = (uint8_t *)take(&c, (size_t)n);
    ip->idx = (int32_t *)take(&c, (size_t)n * sizeof(int32_t));
    rs = take(&c, rs_size);
    ip->k = 0;
    if (ip->xa == NULL || ip->xb == NULL || ip->mask == NULL || ip->idx == NULL || rs == NULL)
        return 0;
    for (int32_t i = 0; i < n; ++i) {
        if (tr->tri_fr[i] == m->ref_serial && tr->x_ok[i]) {
            ip->xa[ip->k] = tr->tri_x[i];
            ip->xb[ip->k] = tr->x[i];
            ip->idx[ip->k] = i;
            ++ip->k;
        }
    }
    if (ip->k < need)
        return 0;
    relpose_config(cfg, &rc);
    if (tvo_relpose_estimate(&rc, ip->xa, ip->xb, ip->k, rp, ip->mask, rs, rs_size) != TVO_OK)
        return 0;
    if (rp->flags &
        (TVO_RELPOSE_FLAG_LOW_CONFIDENCE | TVO_RELPOSE_FLAG_AMBIGUOUS | TVO_RELPOSE_FLAG_ROTATION_ONLY))
        return 0;
    if (rp->parallax_deg < cfg->map_init_parallax_deg || rp->inliers < need || 2 * rp->inliers < ip->k)
        return 0;
    {
        /* the pose's rotation must be near its own rotation-only model, as the VO checks every frame */
        const double lim = 10.0 * rp->parallax_deg > TVO_MAP_INIT_ROT_CHECK_DEG ? 10.0 * rp->parallax_deg
                                                                                : TVO_MAP_INIT_ROT_CHECK_DEG;
        if (tvo_la_rot_dist(rp->R, rp->R_rot) > deg2rad(lim))
            return 0;
    }
    return sqrt(dot3(rp->t, rp->t)) > 0.0;
}

/* The initial baseline: the distance the two-view chain travelled since the reference (its unit: one
 * step per frame before the first map, the last map's speed after a loss), so the new map continues the
 * run's unit. */
static double init_baseline(const tvo_map *m, const tvo_pose *T_c_w_chain, int64_t t_ns)
{
    double baseline = centre_distance(&m->ref_T_c_w, T_c_w_chain);
    if (!(baseline > 0.0) || !isfinite(baseline))
        baseline = m->speed > 0.0 ? m->speed * (double)dt_ns(t_ns, m->ref_t_ns) * 1e-9 : 1.0;
    if (!(baseline > 0.0) || !isfinite(baseline))
        baseline = 1.0;
    return baseline;
}

/* The map's first two keyframes (the reference at T0, this frame at T1) and the pair's inliers
 * triangulated between them, in a cleared map (every track unlinked first); returns the landmarks made
 * (the tracks carry them). */
static int32_t init_landmarks(tvo_map *m, const tvo_vo_config *cfg, tvo_map_tracks *tr, const init_pair *ip,
                              const tvo_pose *T0, int64_t t0, const tvo_pose *T1, int64_t t_ns,
                              double min_deg)
{
    const double min_cos = tvo_dm_cos(deg2rad(min_deg));
    const double max_err = TVO_MAP_TRI_MAX_ERR_PX / focal(cfg);
    tvo_map_kf *k0, *k1;
    int32_t made = 0;
    for (int32_t i = 0; i < tr->n; ++i)
        tr->lm[i] = -1;
    tvo_map_clear(m);
    k0 = kf_push(m, T0, t0, NULL, NULL, 0);
    k1 = kf_push(m, T1, t_ns, NULL, NULL, 0);
    for (int32_t q = 0; q < ip->k; ++q) {
        double X[3];
        int32_t j;
        if (!ip->mask[q] || !triangulate(&k0->T_c_w, &k1->T_c_w, ip->xa[q], ip->xb[q], min_cos, max_err, X))
            continue;
        j = lm_make(m, tr, -1, X, k0, ip->xa[q], k1, ip->xb[q]);
        if (j < 0)
            break;
        tr->lm[ip->idx[q]] = j;
        ++made;
    }
    return made;
}

/* Try to make the map from the reference frame and this one, on at least need landmarks (init_min_points).
 * 1 when made (two keyframes, landmarks). */
static int try_init(tvo_map *m, const tvo_vo_config *cfg, tvo_map_tracks *tr, int64_t t_ns, int32_t need,
                    const tvo_pose *T_c_w_chain, void *scratch, size_t scratch_size, tvo_map_frame *out)
{
    init_pair ip;
    tvo_pose T_cur_ref, T1;
    const tvo_pose T0 = m->ref_T_c_w;
    const int64_t t0 = m->ref_t_ns;
    double baseline, tn;
    int32_t made;
    if (!init_pair_pose(m, cfg, tr, need, scratch, scratch_size, &ip))
        return 0;
    if (tr->refine != NULL) {
        /* the pair becomes two keyframes: their positions refined, the pair's pose again on them */
        tr->refine(tr->refine_ctx);
        if (!init_pair_pose(m, cfg, tr, need, scratch, scratch_size, &ip))
            return 0;
    }
    tn = sqrt(dot3(ip.rp.t, ip.rp.t));
    baseline = init_baseline(m, T_c_w_chain, t_ns);
    memcpy(T_cur_ref.R, ip.rp.R, sizeof(ip.rp.R));
    for (int c2 = 0; c2 < 3; ++c2)
        T_cur_ref.t[c2] = ip.rp.t[c2] / tn * baseline;
    T1 = tvo_pose_compose(&T_cur_ref, &T0);
    made = init_landmarks(m, cfg, tr, &ip, &T0, t0, &T1, t_ns, cfg->map_tri_parallax_deg);
    if (made < need && cfg->map_tri_parallax_deg > TVO_MAP_INIT_TRI_FALLBACK_DEG)
        made = init_landmarks(m, cfg, tr, &ip, &T0, t0, &T1, t_ns, TVO_MAP_INIT_TRI_FALLBACK_DEG);
    if (made < need) {
        /* not enough structure yet: back to waiting on the same reference */
        for (int32_t i = 0; i < tr->n; ++i)
            tr->lm[i] = -1;
        tvo_map_clear(m);
        m->has_ref = 1;
        m->ref_T_c_w = T0;
        m->ref_t_ns = t0;
        return 0;
    }
    /* the reference frame is keyframe 0 now; the tracks that were not triangulated keep waiting where
       they were first seen */
    {
        tvo_map_frame_pose *f = &m->ring[m->ref_serial % TVO_MAP_RING];
        f->serial = m->ref_serial;
        f->kf_id = kf_at(m, 0)->id;
        f->T_c_w = kf_at(m, 0)->T_c_w;
    }
    mark_tracked(m, tr);
    m->active = 1; /* the rotation chain starts here: init_landmarks cleared the map */
    m->kf_points = made;
    m->frames_since_kf = 0;
    m->cur_kf_id = kf_at(m, 1)->id;
    m->last_T_c_w = T1;
    m->last_t_ns = t_ns;
    m->vel = T_cur_ref; /* the average step over the pair would be better; the next frame replaces it */
    m->vel_dt_ns = dt_ns(t_ns, m->ref_t_ns);
    m->has_vel = 1;
    update_speed(m);
    out->state = TVO_MAP_INITIALISED;
    m->waiting = 0;
    out->keyframe = 1;
    out->points = made;
    out->new_points = made;
    out->T_c_w = T1;
    for (int32_t i = 0; i < tr->n; ++i)
        tr->inlier[i] = (uint8_t)(tr->lm[i] >= 0);
    return 1;
}

/* ---- tracking ----------------------------------------------------------------------------------- */

/* The motion model's step to this frame (T_cur_prev): the last velocity scaled to this frame's
 * interval (the identity without one). */
static tvo_pose predicted_step(const tvo_map *m, int64_t t_ns)
{
    tvo_pose step = m->vel;
    double ratio = 1.0;
    if (!m->has_vel)
        return tvo_pose_identity();
    if (m->vel_dt_ns > 0 && t_ns > m->last_t_ns)
        ratio = (double)dt_ns(t_ns, m->last_t_ns) / (double)m->vel_dt_ns;
    if (!(ratio > 0.0 && ratio < 4.0))
        ratio = 1.0;
    for (int c = 0; c < 3; ++c)
        step.t[c] *= ratio;
    return step;
}

int tvo_map_motion_dir(const tvo_map *m, double dir[3])
{
    const double n = sqrt(dot3(m->vel.t, m->vel.t));
    if (!m->active || !m->has_vel || !(n > 0.0) || !isfinite(n))
        return 0;
    for (int c = 0; c < 3; ++c)
        dir[c] = m->vel.t[c] / n;
    return 1;
}

/* The predicted pose of this frame: the last pose moved by the last velocity (scaled to this frame's
 * interval) with the two-view rotation of this frame when there is one. */
static tvo_pose predict(const tvo_map *m, int64_t t_ns, const double *R_cur_prev)
{
    tvo_pose step = predicted_step(m, t_ns), T;
    if (R_cur_prev != NULL)
        memcpy(step.R, R_cur_prev, sizeof(step.R));
    T = tvo_pose_compose(&step, &m->last_T_c_w);
    return T;
}

int tvo_map_predict_pose(const tvo_map *m, int64_t t_ns, int64_t prev_t_ns, tvo_pose *T)
{
    tvo_pose step = m->vel;
    double ratio;
    if (!m->active || !m->has_vel || m->last_t_ns != prev_t_ns || t_ns <= prev_t_ns || m->vel_dt_ns <= 0)
        return 0;
    /* the last step scaled to this interval, its rotation too (after a new map the step spans the
       initial pair, many frames) */
    ratio = (double)dt_ns(t_ns, m->last_t_ns) / (double)m->vel_dt_ns;
    if (!(ratio > 0.0 && ratio < 4.0))
        return 0;
    tvo_rot_pow(m->vel.R, ratio, step.R);
    for (int c = 0; c < 3; ++c)
        step.t[c] *= ratio;
    *T = tvo_pose_compose(&step, &m->last_T_c_w);
    return tvo_pose_is_finite(T);
}

/* The prior's weight for a rotation-only two-view rotation. Such an estimate cannot see a translation
 * whose flow is below its parallax bound, and absorbs up to b = |t| / Z of it (rad; t: the motion
 * model's translation for this frame, Z: the landmarks' median depth, both in map units): as a
 * measurement its variance per axis is sigma^2 / w + b^2 rather than sigma^2 / w (pnp.h's unit: w counts
 * as one point's error per rad^2; sigma: a point's reprojection error, the last landmarks-only RMS, or
 * pose_threshold_px before there is one), i.e. the weight w / (1 + w b^2 / sigma^2). A camera that only
 * turns keeps the full weight; one that drifts sideways in front of far points loses most of it. */
static double rotation_only_weight(const tvo_map *m, const tvo_vo_config *cfg, int64_t t_ns)
{
    const tvo_pose step = predicted_step(m, t_ns);
    const double w = cfg->map_rot_prior;
    const double sigma = m->rms > 0.0 ? m->rms : cfg->pose_threshold_px / focal(cfg);
    double b2, r;
    if (!(m->depth_med > 0.0))
        return w;
    b2 = dot3(step.t, step.t) / (m->depth_med * m->depth_med);
    r = w / (1.0 + w * b2 / (sigma * sigma));
    return isfinite(r) && r >= 0.0 ? r : w;
}

/* Inv = M^-1 (3x3, row-major), column by column by tvo_la_solve; 0 when M is singular. */
static int mat3_inverse(const double M[9], double Inv[9])
{
    for (int c = 0; c < 3; ++c) {
        double W[9], rhs[3] = {0.0, 0.0, 0.0}, col[3];
        rhs[c] = 1.0;
        memcpy(W, M, sizeof(W));
        if (tvo_la_solve(W, rhs, 3, col) != TVO_OK)
            return 0;
        Inv[c] = col[0];
        Inv[3 + c] = col[1];
        Inv[6 + c] = col[2];
    }
    return 1;
}

/* The covariance of the rotation of T (posed on the k landmarks X without a prior; inliers where inl[q])
 * in Sig: rms^2 Lambda^-1, Lambda the rotation block of the Gauss-Newton normal matrix of the
 * reprojection errors (normalised units) with the translation marginalised out (its Schur complement).
 * 0 when it cannot be computed (too few points, a singular block). */
static int landmark_rot_cov(const double (*X)[3], const uint8_t *inl, int32_t k, const tvo_pose *T,
                            double rms, double Sig[9])
{
    double H[36] = {0}, A[9], B[9], C[9], Ci[9], L[9], Li[9], BCi[9], BCiBt[9];
    const double s2 = rms * rms;
    for (int32_t q = 0; q < k; ++q) {
        double p[3], J[12];
        if (!inl[q])
            continue;
        tvo_pose_transform_point(T, X[q], p);
        if (!(p[2] > 0.0))
            continue;
        {
            /* the rows of d(u, v) / d(r, dt) for p' = exp(r) p + dt: a, b = d(u, v) / dp, whose
               rotation parts are a x p, b x p (up to a common sign, which Lambda does not see) */
            const double iz = 1.0 / p[2], u = p[0] * iz, v = p[1] * iz;
            const double a[3] = {iz, 0.0, -u * iz}, b[3] = {0.0, iz, -v * iz};
            tvo_la_cross(a, p, J);
            memcpy(J + 3, a, sizeof(a));
            tvo_la_cross(b, p, J + 6);
            memcpy(J + 9, b, sizeof(b));
            for (int r = 0; r < 6; ++r)
                for (int c = 0; c < 6; ++c)
                    H[6 * r + c] += J[r] * J[c] + J[6 + r] * J[6 + c];
        }
    }
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            A[3 * r + c] = H[6 * r + c];
            B[3 * r + c] = H[6 * r + 3 + c];
            C[3 * r + c] = H[6 * (r + 3) + 3 + c];
        }
    if (!mat3_inverse(C, Ci))
        return 0;
    tvo_la_mat3_mul(B, Ci, BCi);
    tvo_la_mat3_mul_bt(BCi, B, BCiBt);
    for (int i = 0; i < 9; ++i)
        L[i] = A[i] - BCiBt[i];
    if (!mat3_inverse(L, Li))
        return 0;
    for (int i = 0; i < 9; ++i) {
        Sig[i] = s2 * Li[i];
        if (!isfinite(Sig[i]))
            return 0;
    }
    return 1;
}

/* d^T (Sig + v I)^-1 d: the chi-square value of the rotation difference d (rotation vector) between
 * the landmarks' rotation (covariance Sig) and a prior of variance v per axis; -1 when singular. */
static double rot_chi2(const double Sig[9], double v, const double d[3])
{
    double M[9], rhs[3], x[3], chi2;
    memcpy(M, Sig, sizeof(M));
    M[0] += v;
    M[4] += v;
    M[8] += v;
    memcpy(rhs, d, sizeof(rhs));
    if (tvo_la_solve(M, rhs, 3, x) != TVO_OK)
        return -1.0;
    chi2 = dot3(d, x);
    return isfinite(chi2) && chi2 >= 0.0 ? chi2 : -1.0;
}

/* The rotation prior of pc against the landmarks (*T: the pose refined with the prior): the pose refined
 * without it on the landmarks use selects (NULL: all) gives the landmarks' own rotation and its
 * covariance (landmark_rot_cov); when the prior's rotation is further from it than
 * TVO_MAP_ROT_PRIOR_GATE allows under the two covariances (the prior's being rms^2 / w per axis: pnp.h,
 * a weight w counts as one point's error per rad^2), the weight is halved until they agree and the pose
 * refined again with it (on all the landmarks). 1 when *T, *ni and inl were
 * replaced (inl: the inliers of the new pose, k entries). *rms_out gets the landmarks-only pose's
 * reprojection RMS when it was computed. */
static int consistent_prior(const tvo_pnp_config *pc, const double (*X)[3], const tvo_point2d *x, int32_t k,
                            int32_t min_points, const uint8_t *use, uint8_t *inl, tvo_pose *T, int32_t *ni,
                            double *rms_out)
{
    tvo_pnp_config pf = *pc;
    tvo_pose Tf = *T, Tw;
    int32_t nf = 0, nw = 0;
    double rms = 0.0, Sig[9], d[3], Rd[9], v, w = pc->rot_prior_weight;
    pf.rot_prior_weight = 0.0;
    if (tvo_pnp_refine(&pf, X, x, use, k, &Tf, inl, &nf, &rms) != TVO_OK || nf < min_points || !(rms > 0.0))
        return 0;
    *rms_out = rms;
    if (!landmark_rot_cov(X, inl, k, &Tf, rms, Sig))
        return 0;
    tvo_la_mat3_mul_bt(Tf.R, pc->rot_prior, Rd); /* R_free R_prior^T */
    tvo_rot_to_rotvec(Rd, d);
    v = rms * rms;
    if (!(rot_chi2(Sig, v / w, d) > TVO_MAP_ROT_PRIOR_GATE))
        return 0; /* they agree: the pose with the full prior stands */
    for (int it = 0; it < TVO_MAP_ROT_PRIOR_HALVINGS; ++it) {
        w *= 0.5;
        if (rot_chi2(Sig, v / w, d) <= TVO_MAP_ROT_PRIOR_GATE)
            break;
    }
    pf.rot_prior_weight = w;
    Tw = *T;
    if (tvo_pnp_refine(&pf, X, x, NULL, k, &Tw, inl, &nw, NULL) == TVO_OK && nw >= min_points) {
        *T = Tw;
        *ni = nw;
        return 1;
    }
    /* the refinement with the lowered weight failed: the landmarks' own pose (again, for its inliers) */
    pf.rot_prior_weight = 0.0;
    if (tvo_pnp_refine(&pf, X, x, NULL, k, &Tf, inl, &nf, NULL) != TVO_OK || nf < min_points)
        return 0;
    *T = Tf;
    *ni = nf;
    return 1;
}

/* The landmarks that judge a weak rotation prior (cfg.map_rot_prior_obs): NULL for all of them, or judge
 * (k flags, for the k landmarks idx names) marking those observed in at least map_rot_prior_obs keyframes
 * when map_min_points of them are tracked (with map_rot_prior_obs_frames, only on a frame after a jerk:
 * prior_flags). A landmark in two keyframes fits both by construction, whatever its depth along their
 * baseline; a third view has checked the others'. */
static const uint8_t *prior_judges(const tvo_map *m, const tvo_vo_config *cfg, const tvo_map_tracks *tr,
                                   int prior_flags, const int32_t *idx, int32_t k, uint8_t *judge)
{
    int32_t nj = 0;
    if (cfg->map_rot_prior_obs <= 0 ||
        (cfg->map_rot_prior_obs_frames > 0 && !(prior_flags & TVO_MAP_PRIOR_JERK)))
        return NULL;
    for (int32_t q = 0; q < k; ++q) {
        judge[q] = (uint8_t)(m->lm[tr->lm[idx[q]]].n_obs >= cfg->map_rot_prior_obs);
        nj += judge[q];
    }
    return nj >= cfg->map_min_points ? judge : NULL;
}

#if TVO_WITH_AFFINE
/* cfg.map_inlier_sigmas: the inliers of the pose T whose reprojection error is above that many times
 * the frame's robust sigma (the median of the inliers' errors over the Rayleigh median), kept between
 * TVO_MAP_GATE_MIN_PX and TVO_MAP_PNP_THRESHOLD_PX, become outliers. err: scratch for k values. Returns
 * the inliers left (ni when the gate does not apply: off, or fewer than map_min_points inliers). */
static int32_t gate_inliers(const tvo_vo_config *cfg, const tvo_pose *T, const double (*X)[3],
                            const tvo_point2d *x, int32_t k, uint8_t *inl, int32_t ni, double *err)
{
    const double f = focal(cfg), lo = TVO_MAP_GATE_MIN_PX / f, hi = TVO_MAP_PNP_THRESHOLD_PX / f;
    double thr;
    int32_t ne = 0;
    if (!(cfg->map_inlier_sigmas > 0.0))
        return ni;
    for (int32_t q = 0; q < k; ++q)
        if (inl[q])
            err[ne++] = sqrt(reproj2(T, X[q], x[q]));
    if (ne < cfg->map_min_points)
        return ni;
    thr = cfg->map_inlier_sigmas * (tvo_la_select_kth(err, ne, ne / 2) / TVO_MAP_RAYLEIGH_MEDIAN);
    thr = thr < lo ? lo : (thr > hi ? hi : thr);
    ne = 0;
    for (int32_t q = 0; q < k; ++q) {
        if (inl[q] && reproj2(T, X[q], x[q]) > thr * thr)
            inl[q] = 0;
        ne += inl[q];
    }
    return ne;
}
#else
/* left out with the affine refinement (options.h): config_valid refuses map_inlier_sigmas there */
#define gate_inliers(cfg, T, X, x, k, inl, ni, err) (ni)
#endif

/* Pose this frame on the landmarks the tracks carry. 1 when posed (T written, tr->inlier set, the
 * outliers' landmarks unlinked from their tracks); *depth_med gets the inliers' median depth. */
static int track_frame(tvo_map *m, const tvo_vo_config *cfg, tvo_map_tracks *tr, int64_t t_ns,
                       const double *R_cur_prev, int prior_flags, void *scratch, size_t scratch_size,
                       tvo_pose *T, int32_t *n_in, double *depth_med)
{
    const int32_t n = tr->n;
    carve c;
    double(*X)[3], *depth;
    tvo_point2d *x;
    uint8_t *inl, *inl_free, *judge;
    int32_t *idx, k = 0, ni = 0, nd = 0;
    void *ps;
    const size_t ps_size = tvo_pnp_scratch_size(cfg->max_tracks);
    tvo_pnp_config pc;
    tvo_status st;
    *n_in = 0;
    *depth_med = 0.0;
    tvo_arena_init(&c.a, scratch, scratch_size);
    X = (double(*)[3])take(&c, (size_t)n * 3 * sizeof(double));
    x = (tvo_point2d *)take(&c, (size_t)n * sizeof(tvo_point2d));
    inl = (uint8_t *)take(&c, (size_t)n);
    inl_free = (uint8_t *)take(&c, (size_t)n);
    judge = (uint8_t *)take(&c, (size_t)n);
    idx = (int32_t *)take(&c, (size_t)n * sizeof(int32_t));
    depth = (double *)take(&c, (size_t)n * sizeof(double));
    ps = take(&c, ps_size);
    if (X == NULL || x == NULL || inl == NULL || inl_free == NULL || judge == NULL || idx == NULL ||
        depth == NULL || ps == NULL)
        return 0;
    for (int32_t i = 0; i < n; ++i) {
        tr->inlier[i] = 0;
        if (tr->lm[i] >= 0 && tr->x_ok[i]) {
            memcpy(X[k], m->lm[tr->lm[i]].X, sizeof(X[k]));
            x[k] = tr->x[i];
            idx[k] = i;
            ++k;
        }
    }
    if (k < cfg->map_min_points)
        return 0;
    tvo_pnp_config_default(&pc);
    pc.threshold = TVO_MAP_PNP_THRESHOLD_PX / focal(cfg);
    pc.huber = pc.threshold;
    pc.min_inliers = cfg->map_min_points;
    if (R_cur_prev != NULL && cfg->map_rot_prior > 0.0) {
        /* this frame's two-view rotation turns the last pose: a prior on the rotation */
        tvo_la_mat3_mul(R_cur_prev, m->last_T_c_w.R, pc.rot_prior);
        pc.rot_prior_weight = (prior_flags & TVO_MAP_PRIOR_ROT_ONLY) ? rotation_only_weight(m, cfg, t_ns)
                                                                     : cfg->map_rot_prior;
    }
    *T = predict(m, t_ns, R_cur_prev);
    st = tvo_pnp_refine(&pc, (const double(*)[3])X, x, NULL, k, T, inl, &ni, NULL);
    if (st != TVO_OK || 2 * ni < k) {
        /* the prediction was too far (a jerk, a wrong velocity): hypothesise from scratch */
        tvo_pose Tr = *T;
        st = tvo_pnp_ransac(&pc, (const double(*)[3])X, x, k, &Tr, inl, &ni, ps, ps_size);
        if (st != TVO_OK)
            return 0;
        *T = Tr;
    }
    if (ni < cfg->map_min_points)
        return 0;
    if (pc.rot_prior_weight > 0.0 && (prior_flags & TVO_MAP_PRIOR_WEAK)) {
        /* a weak prior is a measurement of the rotation that keeps its weight only while the landmarks
           alone agree with it (the two-view rotation of a low-parallax frame can have absorbed the flow
           of a translation that the landmarks' depths tell apart, a plane's twin is off by about the
           parallax); a well-conditioned two-view rotation is better than the landmarks' own */
        tvo_pose Tc = *T;
        int32_t nc = ni;
        if (consistent_prior(&pc, (const double(*)[3])X, x, k, cfg->map_min_points,
                             prior_judges(m, cfg, tr, prior_flags, idx, k, judge), inl_free, &Tc, &nc,
                             &m->rms)) {
            *T = Tc;
            ni = nc;
            memcpy(inl, inl_free, (size_t)k);
        }
    }
    if (R_cur_prev != NULL) {
        /* the map's rotation must agree with the frame's own two-view rotation */
        double Rrel[9];
        tvo_la_mat3_mul_bt(T->R, m->last_T_c_w.R, Rrel); /* R_cur_prev of the map */
        if (tvo_la_rot_dist(Rrel, R_cur_prev) > deg2rad(TVO_MAP_ROT_CHECK_DEG))
            return 0;
    }
    ni = gate_inliers(cfg, T, (const double(*)[3])X, x, k, inl, ni, depth);
    for (int32_t q = 0; q < k; ++q) {
        const int32_t i = idx[q];
        if (inl[q]) {
            double p[3];
            tr->inlier[i] = 1;
            tvo_pose_transform_point(T, X[q], p);
            depth[nd++] = p[2];
        } else {
            tr->lm[i] = -1; /* an outlier: the track no longer carries the landmark, and waits again */
            tr->tri_fr[i] = m->serial;
            tr->tri_x[i] = tr->x[i];
        }
    }
    *n_in = ni;
    if (nd > 0)
        *depth_med = tvo_la_select_kth(depth, nd, nd / 2);
    return tvo_pose_is_finite(T);
}

/* ---- keyframes ---------------------------------------------------------------------------------- */

/* The map is running out of points: fewer PnP inliers than TVO_MAP_KF_RESCUE_POINTS x map_min_points. */
static int running_out(const tvo_vo_config *cfg, int32_t n_in)
{
    return n_in < TVO_MAP_KF_RESCUE_POINTS * cfg->map_min_points;
}

static int need_keyframe(const tvo_map *m, const tvo_vo_config *cfg, const tvo_pose *T, int32_t n_in,
                         double depth_med)
{
    const tvo_map_kf *k = &m->kf[(m->kf_head + m->n_kf - 1) % m->window];
    const double base = centre_distance(&k->T_c_w, T);
    /* a keyframe that barely moved adds little structure and, as one of the oldest of a later window,
       would hold the scale on a tiny baseline: none while the camera only turns... unless the map is
       running out of points (a turn, or a camera backing away from what it sees, takes them out of view
       faster than the baseline grows): then a keyframe is the only way to new landmarks, and the tracks
       that wait since an older keyframe count their parallax from there, not from the last keyframe */
    if (!(depth_med > 0.0) ||
        (!running_out(cfg, n_in) && base < TVO_MAP_KF_MIN_BASELINE * cfg->map_kf_baseline * depth_med))
        return 0;
    if (m->frames_since_kf + 1 >= cfg->map_kf_max_frames)
        return 1;
    if ((double)n_in < cfg->map_kf_points_ratio * (double)m->kf_points)
        return 1;
    return base > cfg->map_kf_baseline * depth_med;
}

/* Triangulate the waiting tracks against the new keyframe kn; tracks whose first keyframe left the window
 * (or that had none) start waiting in kn. At a keyframe made while the map runs out of points (rescue), a
 * track first seen since the last keyframe, in a frame whose pose the ring still holds, is triangulated
 * from that frame with the tests of any landmark, and its landmark gets one observation, in kn (the next
 * keyframe adds the second, and the bundle adjustment takes it from then on; PnP uses it at once): in a
 * turn that takes the landmarks out of view faster than the baseline grows, these tracks are the only new
 * points the map can get before it is lost (docs/rules.md, "A thirty-seventh rule"). kn never holds
 * max_tracks observations here (each track adds at most one), so only the first keyframe's count is
 * checked; a full store ends the keyframe's landmarks. Returns the landmarks made. */
static int32_t triangulate_new(tvo_map *m, const tvo_vo_config *cfg, tvo_map_tracks *tr, tvo_map_kf *kn,
                               int rescue)
{
    const double min_cos = tvo_dm_cos(deg2rad(cfg->map_tri_parallax_deg));
    const double max_err = TVO_MAP_TRI_MAX_ERR_PX / focal(cfg);
    int32_t made = 0;
    for (int32_t i = 0; i < tr->n; ++i) {
        tvo_map_kf *k0;
        double X[3];
        if (tr->lm[i] >= 0 || !tr->x_ok[i])
            continue;
        const tvo_pose *T0 = frame_pose(m, tr->tri_fr[i], &k0);
        const int now = tr->tri_fr[i] == m->serial;
        if (!now && (k0 != NULL || (rescue && T0 != NULL)) &&
            triangulate(T0, &kn->T_c_w, tr->tri_x[i], tr->x[i], min_cos, max_err, X)) {
            if (k0 != NULL && k0->n_obs >= m->max_tracks)
                continue;
            /* first seen in a keyframe of the window (k0): observed there too */
            if (lm_make(m, tr, i, X, k0, tr->tri_x[i], kn, tr->x[i]) < 0)
                break; /* the store is full: the keyframe's other tracks wait for the next one */
            ++made;
        } else if (k0 == NULL || now) {
            /* first seen in a frame that is not a keyframe of the window (or now): wait from this
               keyframe, so that every landmark starts with two observations the adjustment refines */
            tr->tri_fr[i] = m->serial;
            tr->tri_x[i] = tr->x[i];
        } /* else not enough parallax yet (or a bad track): wait for the next keyframe */
    }
    return made;
}

/* Remove observation o of keyframe k (swap with the last). */
static void kf_remove_obs(tvo_map *m, tvo_map_kf *k, int32_t o)
{
    const int32_t j = k->obs_lm[o];
    m->lm[j].n_obs--;
    k->n_obs--;
    k->obs_lm[o] = k->obs_lm[k->n_obs];
    k->obs_x[o] = k->obs_x[k->n_obs];
}

/* Windowed bundle adjustment over the window's keyframes and the landmarks with >= 2 observations; the
 * cfg.map_ba_fixed oldest keyframes are fixed (they hold the gauge and the scale; while the window fills,
 * all but the newest, and at least two). Observations that end with a large error are removed, and with
 * them the landmarks that are left with fewer than two observations and no track. */
/* The bundle adjustment's problem over the window, in scratch: the window's poses (the oldest fixed),
 * the landmarks with >= 2 observations (lm2pt / pt2lm map between landmark slots and problem points) and
 * their observations, in keyframe order. */
typedef struct ba_work {
    tvo_ba_config bc;
    tvo_ba_problem p;
    tvo_pose *poses;
    uint8_t *fixed;
    double (*X)[3], *err2;
    int32_t *lm2pt, *pt2lm;
    tvo_ba_obs *obs;
    tvo_ba_rot_prior *rot;
    void *bs;
    size_t bs_size;
#if TVO_WITH_LENS
    void *ls; /* the lens block's scratch (cfg.lens_refine), else NULL */
    size_t ls_size;
#endif
} ba_work;

/* 1 when the problem was built (enough scratch, >= 3 keyframes, something to adjust). */
static int ba_build(tvo_map *m, const tvo_vo_config *cfg, void *scratch, size_t scratch_size, ba_work *b)
{
    const int32_t w = m->n_kf, cap_obs = m->window * m->max_tracks;
    /* the cfg.map_ba_fixed oldest keyframes are fixed, fewer while the window fills (the newest free) */
    const int32_t nfix = cfg->map_ba_fixed < w - 1 ? cfg->map_ba_fixed : (w - 1 > 2 ? w - 1 : 2);
    int32_t np = 0, no = 0;
    carve c;
    ba_config(cfg, &b->bc);
    b->bs_size = tvo_ba_scratch_size(&b->bc);
    tvo_arena_init(&c.a, scratch, scratch_size);
    b->poses = (tvo_pose *)take(&c, (size_t)m->window * sizeof(tvo_pose));
    b->fixed = (uint8_t *)take(&c, (size_t)m->window);
    b->X = (double(*)[3])take(&c, (size_t)m->max_lm * 3 * sizeof(double));
    b->lm2pt = (int32_t *)take(&c, (size_t)m->max_lm * sizeof(int32_t));
    b->pt2lm = (int32_t *)take(&c, (size_t)m->max_lm * sizeof(int32_t));
    b->obs = (tvo_ba_obs *)take(&c, (size_t)cap_obs * sizeof(tvo_ba_obs));
    b->err2 = (double *)take(&c, (size_t)cap_obs * sizeof(double));
    b->rot = (tvo_ba_rot_prior *)take(&c, (size_t)m->window * sizeof(tvo_ba_rot_prior));
    b->bs = take(&c, b->bs_size);
#if TVO_WITH_LENS
    b->ls = NULL;
    b->ls_size = 0;
    if (cfg->lens_refine) {
        b->ls_size = tvo_lens_scratch_size(m->window, m->max_lm, cap_obs);
        b->ls = take(&c, b->ls_size);
    }
#endif
    if (b->poses == NULL || b->fixed == NULL || b->X == NULL || b->lm2pt == NULL || b->pt2lm == NULL ||
        b->obs == NULL || b->err2 == NULL || b->rot == NULL || b->bs == NULL || w < 3)
        return 0;
    for (int32_t j = 0; j < m->max_lm; ++j) {
        b->lm2pt[j] = -1;
        if (m->lm[j].alive && m->lm[j].n_obs >= 2) {
            b->lm2pt[j] = np;
            b->pt2lm[np] = j;
            memcpy(b->X[np], m->lm[j].X, sizeof(b->X[np]));
            ++np;
        }
    }
    for (int32_t i = 0; i < w; ++i) {
        const tvo_map_kf *k = kf_at(m, i);
        b->poses[i] = k->T_c_w;
        b->fixed[i] = (uint8_t)(i < nfix);
        for (int32_t o = 0; o < k->n_obs; ++o) {
            const int32_t pt = b->lm2pt[k->obs_lm[o]];
            if (pt < 0 || no >= cap_obs)
                continue;
            b->obs[no].pose = i;
            b->obs[no].point = pt;
            b->obs[no].x = k->obs_x[o].x;
            b->obs[no].y = k->obs_x[o].y;
            ++no;
        }
    }
    memset(&b->p, 0, sizeof(b->p));
    b->p.n_poses = w;
    b->p.T_c_w = b->poses;
    b->p.pose_fixed = b->fixed;
    b->p.n_points = np;
    b->p.X = b->X;
    b->p.point_fixed = NULL;
    b->p.n_obs = no;
    b->p.obs = b->obs;
#if TVO_WITH_AFFINE
    if (m->prior != NULL) {
        /* cfg.map_lm_prior: the points' priors in the problem's order */
        const size_t bytes = (size_t)m->max_lm * sizeof(m->prior[0]);
        double(*pr)[TVO_BA_PRIOR_SIZE] = (double(*)[TVO_BA_PRIOR_SIZE])take(&c, bytes);
        if (pr == NULL)
            return 0;
        for (int32_t q = 0; q < np; ++q)
            memcpy(pr[q], m->prior[b->pt2lm[q]], sizeof(pr[q]));
        b->p.prior = (const double(*)[TVO_BA_PRIOR_SIZE])pr;
    }
#endif
    b->p.rot = b->rot;
    b->p.n_rot = 0;
    if (cfg->map_ba_rot_prior > 0.0)
        for (int32_t i = 1; i < w; ++i) {
            const tvo_map_kf *k = kf_at(m, i);
            tvo_ba_rot_prior *q = &b->rot[b->p.n_rot];
            if (!k->has_R_prev)
                continue;
            q->pose_a = i - 1;
            q->pose_b = i;
            memcpy(q->R_ba, k->R_prev, sizeof(q->R_ba));
            q->weight = cfg->map_ba_rot_prior;
            b->p.n_rot++;
        }
    return np > 0 && no > 0;
}

/* Remove the observations whose error after the adjustment is above TVO_MAP_BA_MAX_ERR_PX, walking them
 * in the order ba_build made them and each keyframe's list from the back (so the indices left stay
 * valid). */
static void ba_drop_outliers(tvo_map *m, const tvo_vo_config *cfg, const ba_work *b)
{
    double max_err2 = TVO_MAP_BA_MAX_ERR_PX / focal(cfg);
    int32_t q = 0;
    max_err2 *= max_err2;
    for (int32_t i = 0; i < m->n_kf; ++i) {
        tvo_map_kf *k = kf_at(m, i);
        int32_t first = q, cnt = 0;
        for (int32_t o = 0; o < k->n_obs; ++o)
            if (b->lm2pt[k->obs_lm[o]] >= 0)
                ++cnt;
        q += cnt;
        for (int32_t o = k->n_obs - 1, e = q - 1; o >= 0; --o) {
            if (b->lm2pt[k->obs_lm[o]] < 0)
                continue;
            if (e >= first && b->err2[e] > max_err2)
                kf_remove_obs(m, k, o);
            --e;
        }
    }
}

/* Remove the window's observations of freed landmarks: a freed slot is reused by the next landmark made,
 * and an observation left behind would then observe that one (and its count would be off). */
static void purge_dead_obs(tvo_map *m)
{
    for (int32_t i = 0; i < m->n_kf; ++i) {
        tvo_map_kf *k = kf_at(m, i);
        for (int32_t o = k->n_obs - 1; o >= 0; --o)
            if (!m->lm[k->obs_lm[o]].alive)
                kf_remove_obs(m, k, o);
    }
}

/* Tracks whose landmark lost its observation in the newest keyframe let go of it (and wait again from
 * this frame); landmarks left with fewer than two observations and no track are freed. */
static void release_unobserved(tvo_map *m, tvo_map_tracks *tr)
{
    const tvo_map_kf *kn = kf_at(m, m->n_kf - 1);
    for (int32_t i = 0; i < tr->n; ++i) {
        int32_t j = tr->lm[i], seen = 0;
        if (j < 0)
            continue;
        for (int32_t o = 0; o < kn->n_obs && !seen; ++o)
            seen = kn->obs_lm[o] == j;
        if (!seen) {
            tr->lm[i] = -1;
            tr->inlier[i] = 0;
            tr->tri_fr[i] = m->serial;
            tr->tri_x[i] = tr->x[i];
        }
    }
    mark_tracked(m, tr);
    {
        int32_t freed_seen = 0;
        for (int32_t j = 0; j < m->max_lm; ++j)
            if (m->lm[j].alive && !m->lm[j].tracked && m->lm[j].n_obs < 2) {
                freed_seen += m->lm[j].n_obs > 0;
                lm_free(m, j);
            }
        if (freed_seen > 0)
            purge_dead_obs(m);
    }
}

static void bundle_adjust(tvo_map *m, const tvo_vo_config *cfg, tvo_map_tracks *tr, void *scratch,
                          size_t scratch_size, tvo_map_frame *out)
{
    ba_work b;
    tvo_ba_report rep;
    if (!ba_build(m, cfg, scratch, scratch_size, &b))
        return;
    memset(&rep, 0, sizeof(rep));
    if (tvo_ba_solve(&b.bc, &b.p, b.bs, b.bs_size, &rep) != TVO_OK)
        return;
    out->ba_iterations = rep.iterations;
    out->ba_flags = rep.flags;
    for (int32_t i = 0; i < b.p.n_poses; ++i)
        if (!tvo_pose_is_finite(&b.poses[i]))
            return; /* by contract the solver never writes one; never take it */
    for (int32_t q = 0; q < b.p.n_points; ++q)
        if (!(isfinite(b.X[q][0]) && isfinite(b.X[q][1]) && isfinite(b.X[q][2])))
            return;
    {
        /* the newest keyframe's rotation as its tracking gave it (its two-view rotation held it there)
           against the adjusted one (cfg.map_ba_max_turn_deg) */
        const double turn = tvo_la_rot_dist(b.poses[b.p.n_poses - 1].R, kf_at(m, b.p.n_poses - 1)->T_c_w.R);
        if (!(turn <= deg2rad(cfg->map_ba_max_turn_deg))) {
            out->ba_flags |= TVO_VO_BA_TURN_REFUSED;
            return;
        }
    }
    for (int32_t i = 0; i < b.p.n_poses; ++i) {
        kf_at(m, i)->T_c_w = b.poses[i];
#if TVO_WITH_AFFINE
        kf_at(m, i)->adjusted |= !b.fixed[i];
#endif
    }
    for (int32_t q = 0; q < b.p.n_points; ++q)
        memcpy(m->lm[b.pt2lm[q]].X, b.X[q], sizeof(b.X[q]));
#if TVO_WITH_LENS
    /* a lens block from a window that shares no keyframe with the last block's (tvo_lens.h) */
    if (cfg->lens_refine && b.ls != NULL && b.p.n_poses == m->window && kf_at(m, 0)->id > m->lens_kf) {
        if (tvo_lens_window(&cfg->camera, &b.p, cfg->map_ba_huber_px, b.ls, b.ls_size, &out->lens)) {
            out->lens_ok = 1;
            m->lens_kf = kf_at(m, m->n_kf - 1)->id;
        }
    }
#endif
    /* outliers: the observations that still do not fit */
    if (tvo_ba_obs_errors(&b.p, b.err2) != TVO_OK)
        return;
    ba_drop_outliers(m, cfg, &b);
    release_unobserved(m, tr);
}

#if TVO_WITH_LENS
void tvo_map_remap(tvo_map *m, const tvo_camera *from, const tvo_camera *to)
{
    for (int32_t i = 0; i < m->n_kf; ++i) {
        tvo_map_kf *k = kf_at(m, i);
        for (int32_t o = 0; o < k->n_obs; ++o)
            (void)tvo_lens_remap(from, to, &k->obs_x[o]);
    }
#if TVO_WITH_AFFINE
    /* the priors were linearised in the old lens's coordinates: they go */
    if (m->prior != NULL)
        memset(m->prior, 0, (size_t)m->max_lm * sizeof(m->prior[0]));
#endif
}
#endif

/* A keyframe at pose *T (adjusted on return); rescue: the map runs out of points (triangulate_new). */
static void add_keyframe(tvo_map *m, const tvo_vo_config *cfg, tvo_map_tracks *tr, int64_t t_ns, tvo_pose *T,
                         int rescue, void *scratch, size_t scratch_size, tvo_map_frame *out)
{
    tvo_map_kf *kn;
    int32_t seen = 0;
    if (tr->refine != NULL)
        tr->refine(tr->refine_ctx);
    mark_tracked(m, tr);
#if TVO_WITH_AFFINE
    {
        /* the scratch is free until the adjustment: the priors' gate takes max_tracks values of it */
        carve c;
        tvo_arena_init(&c.a, scratch, scratch_size);
        kn = kf_push(m, T, t_ns, cfg, (double *)take(&c, (size_t)m->max_tracks * sizeof(double)),
                     m->max_tracks);
    }
#else
    kn = kf_push(m, T, t_ns, NULL, NULL, 0);
#endif
    kn->has_R_prev = m->chain_ok;
    memcpy(kn->R_prev, m->chain_R, sizeof(kn->R_prev));
    chain_reset(m);
    for (int32_t i = 0; i < tr->n; ++i) {
        if (tr->lm[i] >= 0 && tr->inlier[i] && kf_add_obs(m, kn, tr->lm[i], tr->x[i]))
            ++seen;
    }
    out->new_points = triangulate_new(m, cfg, tr, kn, rescue);
    bundle_adjust(m, cfg, tr, scratch, scratch_size, out);
    kn = kf_at(m, m->n_kf - 1);
    *T = kn->T_c_w;
    m->kf_points = seen + out->new_points;
    m->frames_since_kf = 0;
    m->cur_kf_id = kn->id;
    out->keyframe = 1;
    update_speed(m);
}

/* ---- the per-frame entry ------------------------------------------------------------------------ */

static void lose(tvo_map *m, tvo_map_tracks *tr, int64_t t_ns, const tvo_pose *T_c_w_prior,
                 tvo_map_frame *out)
{
    update_speed(m);
    m->losses++;
    start_ref(m, tr, t_ns, T_c_w_prior);
    out->state = TVO_MAP_LOST;
}

static void tvo_map_step(tvo_map *m, const tvo_vo_config *cfg, tvo_map_tracks *tr, int64_t t_ns,
                         const double *R_cur_prev, int prior_flags, const tvo_pose *T_c_w_prior,
                         void *scratch, size_t scratch_size, tvo_map_frame *out);

tvo_status tvo_map_process(tvo_map *m, const tvo_vo_config *cfg, tvo_map_tracks *tr, int64_t t_ns,
                           const double *R_cur_prev, int prior_flags, const tvo_pose *T_c_w_prior,
                           void *scratch, size_t scratch_size, tvo_map_frame *out)
{
    memset(out, 0, sizeof(*out));
    out->T_c_w = *T_c_w_prior;
    m->cur_kf_id = -1;
    m->serial = m->serial < INT32_MAX - 1 ? m->serial + 1 : 0; /* wraps after 2^31 frames */
    tvo_map_step(m, cfg, tr, t_ns, R_cur_prev, prior_flags, T_c_w_prior, scratch, scratch_size, out);
    /* only the map's own poses serve triangulation (the two-view chain's are in another geometry); the
       reference frame's entry is written when it becomes keyframe 0 */
    if (out->state == TVO_MAP_TRACKING || out->state == TVO_MAP_INITIALISED)
        ring_put(m, &out->T_c_w, out->keyframe ? m->cur_kf_id : -1);
    else if (!(m->has_ref && m->ref_serial == m->serial))
        m->ring[m->serial % TVO_MAP_RING].serial = -1;
    else
        ring_put(m, &out->T_c_w, -1);
    return TVO_OK;
}

static void tvo_map_step(tvo_map *m, const tvo_vo_config *cfg, tvo_map_tracks *tr, int64_t t_ns,
                         const double *R_cur_prev, int prior_flags, const tvo_pose *T_c_w_prior,
                         void *scratch, size_t scratch_size, tvo_map_frame *out)
{
    tvo_pose T;
    int32_t n_in = 0;
    double depth_med = 0.0;
    for (int32_t i = 0; i < tr->n; ++i)
        tr->inlier[i] = 0;
    if (!m->active) {
        int32_t need;
        out->state = TVO_MAP_INITIALISING;
        if (!m->waiting) {
            m->waiting = 1;
            m->wait_t_ns = t_ns;
        }
        need = init_min_points(m, cfg, t_ns);
        if (!m->has_ref) {
            start_ref(m, tr, t_ns, T_c_w_prior);
            return;
        }
        m->ref_frames++;
        if (try_init(m, cfg, tr, t_ns, need, T_c_w_prior, scratch, scratch_size, out))
            return;
        {
            /* renew the reference when it is too old or most of its tracks are gone */
            int32_t k = 0;
            for (int32_t i = 0; i < tr->n; ++i)
                k += tr->tri_fr[i] == m->ref_serial && tr->x_ok[i];
            if (m->ref_frames > TVO_MAP_REF_MAX_FRAMES || k < need)
                start_ref(m, tr, t_ns, T_c_w_prior);
        }
        return;
    }
    if (!track_frame(m, cfg, tr, t_ns, R_cur_prev, prior_flags, scratch, scratch_size, &T, &n_in,
                     &depth_med)) {
        lose(m, tr, t_ns, T_c_w_prior, out);
        return;
    }
    mark_tracked(m, tr);
    out->state = TVO_MAP_TRACKING;
    m->depth_med = depth_med;
    if (cfg->map_ba_rot_prior > 0.0) { /* the chain is kept for the priors only */
        if (R_cur_prev != NULL) {
            double C[9];
            tvo_la_mat3_mul(R_cur_prev, m->chain_R, C);
            memcpy(m->chain_R, C, sizeof(C));
        } else {
            m->chain_ok = 0;
        }
    }
    out->points = n_in;
    if (need_keyframe(m, cfg, &T, n_in, depth_med)) {
        /* the frame keeps its tracking pose (what it was measured to be when it came); the map keeps the
           adjusted keyframe, on which the next frames are posed (reporting the adjusted pose instead
           puts each correction into one frame's step: a jump in the per-frame rotation) */
        tvo_pose Tk = T;
        add_keyframe(m, cfg, tr, t_ns, &Tk, running_out(cfg, n_in), scratch, scratch_size, out);
    } else {
        m->frames_since_kf++;
    }
    if (!tvo_pose_is_finite(&T)) {
        lose(m, tr, t_ns, T_c_w_prior, out);
        return;
    }
    {
        /* the velocity of this step, for the next prediction */
        const tvo_pose Tw = tvo_pose_inverse(&m->last_T_c_w);
        m->vel = tvo_pose_compose(&T, &Tw);
        m->vel_dt_ns = dt_ns(t_ns, m->last_t_ns);
        m->has_vel = 1;
    }
    m->last_T_c_w = T;
    m->last_t_ns = t_ns;
    out->T_c_w = T;
    return;
}

void tvo_map_new_tracks(const tvo_map *m, tvo_map_tracks *tr, int32_t first)
{
    for (int32_t i = first; i < tr->n; ++i) {
        tr->lm[i] = -1;
        tr->inlier[i] = 0;
        tr->tri_x[i] = tr->x[i];
        tr->tri_fr[i] = tr->x_ok[i] ? m->serial : -1;
    }
}

#if TVO_WITH_AFFINE
int tvo_map_refind_point(const tvo_map *m, int32_t j, uint32_t gen, const tvo_pose *T_c_w, tvo_point2d *xn)
{
    double p[3];
    if (j < 0 || j >= m->max_lm || !m->lm[j].alive || m->lm[j].tracked || m->lm[j].gen != gen || !m->active)
        return 0;
    tvo_pose_transform_point(T_c_w, m->lm[j].X, p);
    if (!(p[2] > 0.0))
        return 0;
    xn->x = p[0] / p[2];
    xn->y = p[1] / p[2];
    return isfinite(xn->x) && isfinite(xn->y);
}

void tvo_map_refound(tvo_map *m, int32_t j)
{
    if (j >= 0 && j < m->max_lm && m->lm[j].alive)
        m->lm[j].tracked = 1;
}
#endif
