/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: windowed bundle adjustment (contract and cost in tinyvo/ba.h). */
#include "tinyvo/ba.h"
#include "tinyvo/ba_prior.h"
#include "tinyvo/linalg.h"
#include "tinyvo/options.h"

#include <math.h>
#include <string.h>

/* point states during one linearisation */
#define PT_FREE 0  /* optimised */
#define PT_FIXED 1 /* fixed by the caller */
#define PT_HELD 2  /* free, but held fixed for this step (too few observations, ill-conditioned) */

#define ACCEPT_REL 1e-12   /* a step must lower the cost by more than this fraction of it */
#define CONVERGED_REL 1e-6 /* an accepted step lowering the cost by less than this fraction: converged */
#define COST_FLOOR 1e-24   /* cost per used observation at or below which the solve is converged */
#define LAMBDA_MIN 1e-12
#define LAMBDA_MAX 1e12
#define PIVOT_POINT 1e-12    /* 3x3 point block: pivot / diagonal entry */
#define PIVOT_SINGULAR 1e-10 /* undamped reduced system: pivot / diagonal entry */
#define PIVOT_DAMPED 1e-14   /* damped reduced system: pivot / diagonal entry */

/* Memory (see "Memory" in ba.h): per observation only its index in the by-point order and its usable
 * flag; the Jacobians, IRLS weights and W blocks are recomputed from the state (the linearisation
 * point) by point_blocks() for every system build and back-substitution. */
typedef struct ba_ws {
    /* poses [max_poses] */
    int32_t *slot;      /* index in the reduced system, -1 when not optimised */
    int32_t *pose_nuse; /* usable observations */
    tvo_pose *pose_bak;
    double (*Hc)[36]; /* J^T W J of the pose (6x6, row-major) */
    double (*gc)[6];  /* J^T W r of the pose */
    int32_t *tpos;    /* [slot]: position in the current point's touched list, -1 when not in it */
    int32_t *tlist;   /* slots the current point's observations touch, in order of first appearance */
    double (*Wp)[18]; /* [touched]: sum of the point's W = Jc^T W Jx (6x3) in that free pose */
    double (*Yp)[18]; /* [touched]: Wp V^-1 (6x3) */
    /* points [max_points] */
    uint8_t *pstate;
    int32_t *pt_nuse;
    int32_t *
            pt_start; /* [max_points + 1]: observations of point j are pt_obs[pt_start[j] .. pt_start[j+1]) */
    double (*X_bak)[3];
    double (*V)[6]; /* J^T W J of the point: upper triangle 00 01 02 11 12 22 */
    double (*gx)[3];
    double (*dx)[3];
    /* observations [max_obs] */
    int32_t *pt_obs;
    uint8_t *ouse; /* usable (decided at the first linearisation) */
    /* reduced system, n = 6 * max_poses */
    double *S; /* n x n, row stride n_cur */
    double *b;
    double *dc;
} ba_ws;

/* index of (a, b) in a packed symmetric 3x3 (ba_ws.V) */
static const int8_t sym3[3][3] = {{0, 1, 2}, {1, 3, 4}, {2, 4, 5}};

static int cfg_valid(const tvo_ba_config *c)
{
    if (c == NULL)
        return 0;
    if (c->max_iterations < 1 || c->max_iterations > TVO_BA_MAX_ITERATIONS)
        return 0;
    if (!(isfinite(c->huber) && c->huber > 0.0))
        return 0;
    if (!(isfinite(c->lambda_init) && c->lambda_init > 0.0 && c->lambda_init <= LAMBDA_MAX))
        return 0;
    if (!(isfinite(c->min_depth) && c->min_depth > 0.0))
        return 0;
    if (!(isfinite(c->max_point_cond) && c->max_point_cond >= 1.0))
        return 0;
    if (c->max_poses < 1 || c->max_poses > TVO_BA_MAX_POSES)
        return 0;
    if (c->max_points < 1 || c->max_points > TVO_BA_MAX_POINTS)
        return 0;
    if (c->max_obs < 1 || c->max_obs > TVO_BA_MAX_OBS)
        return 0;
    return 1;
}

void tvo_ba_config_default(tvo_ba_config *cfg)
{
    if (cfg == NULL)
        return;
    memset(cfg, 0, sizeof *cfg);
    cfg->max_iterations = 10;
    cfg->huber = 2.0 / 458.0;
    cfg->lambda_init = 1e-3;
    cfg->min_depth = 1e-3;
    cfg->max_poses = 10;
    cfg->max_points = 1024;
    cfg->max_obs = 4096;
    cfg->max_point_cond = 1e6;
}

/* Carves the workspace from base (NULL: only sizes). Returns the bytes used from an aligned base. */
static size_t carve(const tvo_ba_config *c, uint8_t *base, ba_ws *ws)
{
    const size_t np = (size_t)c->max_poses, nx = (size_t)c->max_points, no = (size_t)c->max_obs;
    const size_t n = 6u * np;
    size_t off = 0;
#define TVO_BA_TAKE(field, count)                                   \
    do {                                                            \
        if (base != NULL)                                           \
            ws->field = (void *)(base + off);                       \
        off += ((count) * sizeof(*ws->field) + 15u) & ~(size_t)15u; \
    } while (0)
    TVO_BA_TAKE(slot, np);
    TVO_BA_TAKE(pose_nuse, np);
    TVO_BA_TAKE(pose_bak, np);
    TVO_BA_TAKE(Hc, np);
    TVO_BA_TAKE(gc, np);
    TVO_BA_TAKE(tpos, np);
    TVO_BA_TAKE(tlist, np);
    TVO_BA_TAKE(Wp, np);
    TVO_BA_TAKE(Yp, np);
    TVO_BA_TAKE(pstate, nx);
    TVO_BA_TAKE(pt_nuse, nx);
    TVO_BA_TAKE(pt_start, nx + 1u);
    TVO_BA_TAKE(X_bak, nx);
    TVO_BA_TAKE(V, nx);
    TVO_BA_TAKE(gx, nx);
    TVO_BA_TAKE(dx, nx);
    TVO_BA_TAKE(pt_obs, no);
    TVO_BA_TAKE(ouse, no);
    TVO_BA_TAKE(S, n * n);
    TVO_BA_TAKE(b, n);
    TVO_BA_TAKE(dc, n);
#undef TVO_BA_TAKE
    return off;
}

size_t tvo_ba_scratch_size(const tvo_ba_config *cfg)
{
    if (!cfg_valid(cfg))
        return 0;
    /* bounded capacities keep every product far below SIZE_MAX on 32-bit targets too */
    return carve(cfg, NULL, NULL) + 16u;
}

/* ---- robust cost ------------------------------------------------------------------------------ */

/* 1/2 rho(r^2) and the IRLS weight of one residual component */
static double huber_half(double r, double k, double *w)
{
    const double a = fabs(r);
    if (a <= k) {
        *w = 1.0;
        return 0.5 * r * r;
    }
    *w = k / a;
    return k * a - 0.5 * k * k;
}

static void to_camera(const tvo_pose *T, const double X[3], double P[3])
{
    P[0] = T->R[0] * X[0] + T->R[1] * X[1] + T->R[2] * X[2] + T->t[0];
    P[1] = T->R[3] * X[0] + T->R[4] * X[1] + T->R[5] * X[2] + T->t[1];
    P[2] = T->R[6] * X[0] + T->R[7] * X[1] + T->R[8] * X[2] + T->t[2];
}

/* A = R_b R_a^T of prior q's poses: the Jacobians of its residual under the left steps of a and b are -A
 * and I to first order. */
static void rot_prior_rel(const tvo_ba_problem *p, const tvo_ba_rot_prior *q, double A[9])
{
    const double *Ra = p->T_c_w[q->pose_a].R, *Rb = p->T_c_w[q->pose_b].R;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            A[3 * r + c] = Rb[3 * r] * Ra[3 * c] + Rb[3 * r + 1] * Ra[3 * c + 1] +
                    Rb[3 * r + 2] * Ra[3 * c + 2];
}

/* Relative-rotation prior q: its residual e = log(R_b R_a^T R_ba^T) and A (rot_prior_rel); returns
 * 1/2 weight |e|^2. */
static double rot_prior_res(const tvo_ba_problem *p, const tvo_ba_rot_prior *q, double e[3], double A[9])
{
    double E[9];
    rot_prior_rel(p, q, A);
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            E[3 * r + c] = A[3 * r] * q->R_ba[3 * c] + A[3 * r + 1] * q->R_ba[3 * c + 1] +
                    A[3 * r + 2] * q->R_ba[3 * c + 2];
    tvo_rot_to_rotvec(E, e);
    return 0.5 * q->weight * (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
}

#if TVO_WITH_AFFINE
/* 1/2 X^T L X + g^T X + c of a point prior q (tvo_ba_problem.prior); LX gets L X + g, its gradient */
static double prior_cost(const double *q, const double X[3], double LX[3])
{
    LX[0] = q[0] * X[0] + q[1] * X[1] + q[2] * X[2];
    LX[1] = q[1] * X[0] + q[3] * X[1] + q[4] * X[2];
    LX[2] = q[2] * X[0] + q[4] * X[1] + q[5] * X[2];
    const double v = 0.5 * (X[0] * LX[0] + X[1] * LX[1] + X[2] * LX[2]) + q[6] * X[0] + q[7] * X[1] +
            q[8] * X[2] + q[9];
    for (int a = 0; a < 3; ++a)
        LX[a] += q[6 + a];
    return v;
}

double tvo_ba_prior_cost(const double q[TVO_BA_PRIOR_SIZE], const double X[3])
{
    double LX[3];
    return prior_cost(q, X, LX);
}
#endif

/* Cost of the current state over the observations marked usable; +inf when one of them fell below
 * min_depth or a value is not finite. O(obs). */
static double eval_cost(const tvo_ba_config *c, const tvo_ba_problem *p, const ba_ws *ws)
{
    double cost = 0.0, w;
    for (int32_t k = 0; k < p->n_obs; ++k) {
        const tvo_ba_obs *o = &p->obs[k];
        double P[3];
        if (!ws->ouse[k])
            continue;
        to_camera(&p->T_c_w[o->pose], p->X[o->point], P);
        if (!(P[2] >= c->min_depth))
            return INFINITY;
        cost += huber_half(P[0] / P[2] - o->x, c->huber, &w);
        cost += huber_half(P[1] / P[2] - o->y, c->huber, &w);
    }
    for (int32_t q = 0; q < p->n_rot; ++q) {
        double e[3], A[9];
        cost += rot_prior_res(p, &p->rot[q], e, A);
    }
#if TVO_WITH_AFFINE
    if (p->prior != NULL)
        for (int32_t j = 0; j < p->n_points; ++j) {
            double g[3];
            cost += prior_cost(p->prior[j], p->X[j], g);
        }
#endif
    return isfinite(cost) ? cost : INFINITY;
}

/* ---- small dense algebra ---------------------------------------------------------------------- */

/* ---- linearisation ---------------------------------------------------------------------------- */

/* One observation linearised at the current state. */
typedef struct obs_lin {
    double r0, r1;   /* residual */
    double w0, w1;   /* IRLS weights */
    double cost;     /* 1/2 rho of both components */
    double Jc[2][6]; /* d r / d (omega, v) of the pose */
    double Jx[2][3]; /* d r / d X */
} obs_lin;

/* Linearises observation o at the current state; 0 when it is not usable (non-finite x, y or residual,
 * Z_c < min_depth). The same state gives bit-identical values, which lets the system builds and the
 * back-substitution recompute them instead of storing them. Inlined (where the compiler is told to
 * optimise for speed): it runs about 16 times per observation and call. */
#if defined(__GNUC__) && !defined(__OPTIMIZE_SIZE__)
#define BA_INLINE static inline __attribute__((always_inline))
#else
#define BA_INLINE static inline
#endif
BA_INLINE int lin_obs(const tvo_ba_config *c, const tvo_ba_problem *p, const tvo_ba_obs *o, obs_lin *L)
{
    const tvo_pose *T = &p->T_c_w[o->pose];
    double P[3], iz, u, v;
    if (!(isfinite(o->x) && isfinite(o->y)))
        return 0;
    to_camera(T, p->X[o->point], P);
    if (!(P[2] >= c->min_depth))
        return 0;
    iz = 1.0 / P[2];
    u = P[0] * iz;
    v = P[1] * iz;
    L->r0 = u - o->x;
    L->r1 = v - o->y;
    if (!(isfinite(L->r0) && isfinite(L->r1)))
        return 0;
    L->cost = huber_half(L->r0, c->huber, &L->w0) + huber_half(L->r1, c->huber, &L->w1);
    /* d(u, v)/dP = iz [1 0 -u; 0 1 -v]; dP/d(omega, v) = [-[P]x  I]; dP/dX = R */
    L->Jc[0][0] = -u * v;
    L->Jc[0][1] = 1.0 + u * u;
    L->Jc[0][2] = -v;
    L->Jc[0][3] = iz;
    L->Jc[0][4] = 0.0;
    L->Jc[0][5] = -u * iz;
    L->Jc[1][0] = -1.0 - v * v;
    L->Jc[1][1] = u * v;
    L->Jc[1][2] = u;
    L->Jc[1][3] = 0.0;
    L->Jc[1][4] = iz;
    L->Jc[1][5] = -v * iz;
    for (int a = 0; a < 3; ++a) {
        L->Jx[0][a] = iz * (T->R[a] - u * T->R[6 + a]);
        L->Jx[1][a] = iz * (T->R[3 + a] - v * T->R[6 + a]);
    }
    return 1;
}

/* Holds (PT_HELD) the free points with fewer than 2 usable observations or an ill-conditioned 3x3
 * block (a pivot below PIVOT_POINT, or a condition estimate trace(V) |V^-1|_F above max_point_cond).
 * Returns how many. */
static int32_t hold_points(const tvo_ba_config *c, const tvo_ba_problem *p, ba_ws *ws)
{
    int32_t held = 0;
    for (int32_t j = 0; j < p->n_points; ++j) {
        double V9[9], Vi[9], tr, fro = 0.0;
        if (ws->pstate[j] != PT_FREE)
            continue;
        for (int a = 0; a < 9; ++a)
            V9[a] = ws->V[j][sym3[a / 3][a % 3]];
        if (ws->pt_nuse[j] < 2 || !tvo_la_chol3_inv(V9, PIVOT_POINT, Vi)) {
            ws->pstate[j] = PT_HELD;
            held++;
            continue;
        }
        tr = V9[0] + V9[4] + V9[8];
        for (int a = 0; a < 9; ++a)
            fro += Vi[a] * Vi[a];
        if (!(tr * sqrt(fro) <= c->max_point_cond)) {
            ws->pstate[j] = PT_HELD;
            held++;
        }
    }
    return held;
}

/* Builds the per-pose and per-point blocks at the current state, marks usable observations (first:
 * from all of them; later: from those usable before, which accepted steps keep usable), decides the held
 * points and the free-pose slots. Returns the cost (over the usable observations); counts to
 * *n_used, *n_skipped_obs, *n_held, *n_free_poses; *pose_starved when a free pose had no usable
 * observation. */
static double linearise(const tvo_ba_config *c, const tvo_ba_problem *p, ba_ws *ws, int first,
                        int32_t *n_used, int32_t *n_skipped_obs, int32_t *n_held, int32_t *n_free_poses,
                        int *pose_starved)
{
    double cost = 0.0;
    int32_t used = 0, nfree = 0;
    *pose_starved = 0;
    for (int32_t i = 0; i < p->n_poses; ++i) {
        ws->pose_nuse[i] = 0;
        memset(ws->Hc[i], 0, sizeof ws->Hc[i]);
        memset(ws->gc[i], 0, sizeof ws->gc[i]);
    }
    for (int32_t j = 0; j < p->n_points; ++j) {
        ws->pt_nuse[j] = 0;
        memset(ws->V[j], 0, sizeof ws->V[j]);
        memset(ws->gx[j], 0, sizeof ws->gx[j]);
        ws->pstate[j] = (p->point_fixed != NULL && p->point_fixed[j]) ? PT_FIXED : PT_FREE;
#if TVO_WITH_AFFINE
        if (p->prior != NULL) {
            /* the prior's quadratic: its matrix is the block's start, its gradient the gradient's */
            double g[3];
            cost += prior_cost(p->prior[j], p->X[j], g);
            if (ws->pstate[j] == PT_FREE) {
                memcpy(ws->V[j], p->prior[j], sizeof ws->V[j]);
                memcpy(ws->gx[j], g, sizeof ws->gx[j]);
            }
        }
#endif
    }
    for (int32_t k = 0; k < p->n_obs; ++k) {
        const tvo_ba_obs *o = &p->obs[k];
        obs_lin L;
        if (!first && !ws->ouse[k])
            continue; /* the usable set is the first linearisation's for the whole call */
        ws->ouse[k] = 0;
        if (!lin_obs(c, p, o, &L))
            continue;
        ws->ouse[k] = 1;
        used++;
        ws->pose_nuse[o->pose]++;
        ws->pt_nuse[o->point]++;
        cost += L.cost;
        if (!p->pose_fixed[o->pose]) {
            double *H = ws->Hc[o->pose], *g = ws->gc[o->pose];
            for (int a = 0; a < 6; ++a) {
                const double wa0 = L.w0 * L.Jc[0][a], wa1 = L.w1 * L.Jc[1][a];
                for (int b = a; b < 6; ++b) /* upper triangle; mirrored below */
                    H[6 * a + b] += wa0 * L.Jc[0][b] + wa1 * L.Jc[1][b];
                g[a] += wa0 * L.r0 + wa1 * L.r1;
            }
        }
        if (ws->pstate[o->point] == PT_FREE) {
            double *Vj = ws->V[o->point], *g = ws->gx[o->point];
            for (int a = 0; a < 3; ++a) {
                const double wa0 = L.w0 * L.Jx[0][a], wa1 = L.w1 * L.Jx[1][a];
                for (int b = a; b < 3; ++b)
                    Vj[sym3[a][b]] += wa0 * L.Jx[0][b] + wa1 * L.Jx[1][b];
                g[a] += wa0 * L.r0 + wa1 * L.r1;
            }
        }
    }
    for (int32_t q = 0; q < p->n_rot; ++q) {
        /* e ~ e0 + w_b - A w_a on the rotation parts: J_b = I, J_a = -A; J_a^T J_a = I */
        const tvo_ba_rot_prior *rp = &p->rot[q];
        double e[3], A[9];
        const double w = rp->weight;
        cost += rot_prior_res(p, rp, e, A);
        if (!p->pose_fixed[rp->pose_b])
            for (int a = 0; a < 3; ++a) {
                ws->Hc[rp->pose_b][7 * a] += w;
                ws->gc[rp->pose_b][a] += w * e[a];
            }
        if (!p->pose_fixed[rp->pose_a])
            for (int a = 0; a < 3; ++a) {
                ws->Hc[rp->pose_a][7 * a] += w;
                ws->gc[rp->pose_a][a] -= w * (A[a] * e[0] + A[3 + a] * e[1] + A[6 + a] * e[2]);
            }
    }
    const int32_t held = hold_points(c, p, ws);
    for (int32_t i = 0; i < p->n_poses; ++i) {
        ws->slot[i] = -1;
        ws->tpos[i] = -1;
        if (p->pose_fixed[i])
            continue;
        for (int a = 1; a < 6; ++a)
            for (int b = 0; b < a; ++b)
                ws->Hc[i][6 * a + b] = ws->Hc[i][6 * b + a];
        if (ws->pose_nuse[i] == 0) {
            *pose_starved = 1;
            continue;
        }
        ws->slot[i] = nfree++;
    }
    *n_used = used;
    *n_skipped_obs = p->n_obs - used;
    *n_held = held;
    *n_free_poses = nfree;
    return isfinite(cost) ? cost : INFINITY;
}

/* Inverse of free point j's damped block (factor dmp on the diagonal) to Vi; 0 when not positive
 * definite. */
static int point_inv(const ba_ws *ws, int32_t j, double dmp, double Vi[9])
{
    double Vd[9];
    for (int a = 0; a < 9; ++a)
        Vd[a] = ws->V[j][sym3[a / 3][a % 3]];
    Vd[0] *= dmp;
    Vd[4] *= dmp;
    Vd[8] *= dmp;
    return tvo_la_chol3_inv(Vd, 0.0, Vi);
}

/* Recomputes free point j's blocks W = Jc^T W Jx with its free poses at the current state (the
 * linearisation point), summed per pose into ws->Wp[m] for the touched slots ws->tlist[m], m < the
 * returned count (in order of first appearance; ws->tpos is -1 again on return). */
static int32_t point_blocks(const tvo_ba_config *c, const tvo_ba_problem *p, ba_ws *ws, int32_t j)
{
    const int32_t k0 = ws->pt_start[j], k1 = ws->pt_start[j + 1];
    int32_t nt = 0;
    for (int32_t q = k0; q < k1; ++q) {
        const int32_t k = ws->pt_obs[q];
        const int32_t s = ws->slot[p->obs[k].pose];
        obs_lin L;
        double *Wm;
        int32_t m;
        if (!ws->ouse[k] || s < 0 || !lin_obs(c, p, &p->obs[k], &L))
            continue;
        m = ws->tpos[s];
        if (m < 0) {
            m = nt++;
            ws->tpos[s] = m;
            ws->tlist[m] = s;
            Wm = ws->Wp[m];
            for (int a = 0; a < 6; ++a) {
                const double wa0 = L.w0 * L.Jc[0][a], wa1 = L.w1 * L.Jc[1][a];
                for (int b = 0; b < 3; ++b)
                    Wm[3 * a + b] = wa0 * L.Jx[0][b] + wa1 * L.Jx[1][b];
            }
        } else {
            Wm = ws->Wp[m];
            for (int a = 0; a < 6; ++a) {
                const double wa0 = L.w0 * L.Jc[0][a], wa1 = L.w1 * L.Jc[1][a];
                for (int b = 0; b < 3; ++b)
                    Wm[3 * a + b] += wa0 * L.Jx[0][b] + wa1 * L.Jx[1][b];
            }
        }
    }
    for (int32_t m = 0; m < nt; ++m)
        ws->tpos[ws->tlist[m]] = -1;
    return nt;
}

/* the back-substitution for the free points: dx_j = Vi (-gx_j - sum_k W_k^T dc_k), W_k and Vi
 * recomputed at damping dmp; 0 if a point block does not factor (not reached after build_solve) */
static int back_substitute(const tvo_ba_config *c, const tvo_ba_problem *p, ba_ws *ws, double dmp)
{
    for (int32_t j = 0; j < p->n_points; ++j) {
        double t[3], Vi[9];
        int32_t nt;
        if (ws->pstate[j] != PT_FREE)
            continue;
        if (!point_inv(ws, j, dmp, Vi))
            return 0; /* not reached: the same block factored in build_solve */
        nt = point_blocks(c, p, ws, j);
        t[0] = -ws->gx[j][0];
        t[1] = -ws->gx[j][1];
        t[2] = -ws->gx[j][2];
        for (int32_t m = 0; m < nt; ++m) {
            const double *Wk = ws->Wp[m], *d = ws->dc + 6 * ws->tlist[m];
            for (int b2 = 0; b2 < 3; ++b2)
                for (int a = 0; a < 6; ++a)
                    t[b2] -= Wk[3 * a + b2] * d[a];
        }
        for (int a = 0; a < 3; ++a)
            ws->dx[j][a] = Vi[3 * a] * t[0] + Vi[3 * a + 1] * t[1] + Vi[3 * a + 2] * t[2];
    }
    return 1;
}

/* Builds and solves the damped system (lambda; Cholesky pivot bound rel) into ws->dc (poses, by slot)
 * and ws->dx (free points). Returns 0 when a factorisation fails. With solve == 0 only the reduced
 * system's factorisation is attempted (the singularity test). */
static int build_solve(const tvo_ba_config *c, const tvo_ba_problem *p, ba_ws *ws, int32_t nfree,
                       double lambda, double rel, int solve)
{
    const int n = 6 * nfree;
    const double dmp = 1.0 + lambda;
    double *S = ws->S;
    memset(S, 0, (size_t)n * (size_t)n * sizeof *S);
    for (int32_t i = 0; i < p->n_poses; ++i) {
        const int32_t s = ws->slot[i];
        if (s < 0)
            continue;
        for (int a = 0; a < 6; ++a) {
            double *row = S + (size_t)(6 * s + a) * (size_t)n + (size_t)(6 * s);
            for (int b2 = 0; b2 < 6; ++b2)
                row[b2] = ws->Hc[i][6 * a + b2];
            row[a] *= dmp;
            ws->b[6 * s + a] = -ws->gc[i][a];
        }
    }
    for (int32_t j = 0; j < p->n_points; ++j) {
        double Vi[9];
        const double *g = ws->gx[j];
        int32_t nt;
        if (ws->pstate[j] != PT_FREE)
            continue;
        if (!point_inv(ws, j, dmp, Vi))
            return 0;
        nt = point_blocks(c, p, ws, j);
        for (int32_t m = 0; m < nt; ++m) {
            const int32_t sk = ws->tlist[m];
            const double *Wk = ws->Wp[m];
            double *Yk = ws->Yp[m];
            for (int a = 0; a < 6; ++a) {
                for (int b2 = 0; b2 < 3; ++b2)
                    Yk[3 * a + b2] = Wk[3 * a] * Vi[b2] + Wk[3 * a + 1] * Vi[3 + b2] +
                            Wk[3 * a + 2] * Vi[6 + b2];
                ws->b[6 * sk + a] += Yk[3 * a] * g[0] + Yk[3 * a + 1] * g[1] + Yk[3 * a + 2] * g[2];
            }
        }
        for (int32_t m = 0; m < nt; ++m) {
            const int32_t sk = ws->tlist[m];
            const double *Yk = ws->Yp[m];
            for (int32_t m2 = 0; m2 < nt; ++m2) {
                const int32_t sl = ws->tlist[m2];
                const double *Wl = ws->Wp[m2];
                if (sl > sk)
                    continue;
                for (int a = 0; a < 6; ++a) {
                    double *row = S + (size_t)(6 * sk + a) * (size_t)n + (size_t)(6 * sl);
                    for (int b2 = 0; b2 < 6; ++b2)
                        row[b2] -= Yk[3 * a] * Wl[3 * b2] + Yk[3 * a + 1] * Wl[3 * b2 + 1] +
                                Yk[3 * a + 2] * Wl[3 * b2 + 2];
                }
            }
        }
    }
    for (int32_t q = 0; q < p->n_rot; ++q) {
        /* the priors' cross blocks J_b^T w J_a = -w A (rows of b's rotation, columns of a's), in the lower
           triangle (row slot above column slot) */
        const tvo_ba_rot_prior *rp = &p->rot[q];
        const int32_t sa = ws->slot[rp->pose_a], sb = ws->slot[rp->pose_b];
        double A[9];
        if (sa < 0 || sb < 0)
            continue;
        rot_prior_rel(p, rp, A);
        for (int r = 0; r < 3; ++r)
            for (int col = 0; col < 3; ++col) {
                if (sb > sa)
                    S[(size_t)(6 * sb + r) * (size_t)n + (size_t)(6 * sa + col)] -= rp->weight *
                            A[3 * r + col];
                else
                    S[(size_t)(6 * sa + r) * (size_t)n + (size_t)(6 * sb + col)] -= rp->weight *
                            A[3 * col + r];
            }
    }
    if (n > 0 && !tvo_la_chol(S, n, n, rel))
        return 0;
    if (!solve)
        return 1;
    if (n > 0)
        tvo_la_chol_solve(S, n, n, ws->b, ws->dc);
    return back_substitute(c, p, ws, dmp);
}

/* Applies the step; 0 (nothing written) when a value of the step or of the result is not finite. */
static int apply_step(tvo_ba_problem *p, const ba_ws *ws, int32_t nfree)
{
    for (int i = 0; i < 6 * nfree; ++i)
        if (!isfinite(ws->dc[i]))
            return 0;
    for (int32_t j = 0; j < p->n_points; ++j)
        if (ws->pstate[j] == PT_FREE &&
            !(isfinite(ws->dx[j][0]) && isfinite(ws->dx[j][1]) && isfinite(ws->dx[j][2])))
            return 0;
    for (int32_t i = 0; i < p->n_poses; ++i) {
        const int32_t s = ws->slot[i];
        tvo_pose *T = &p->T_c_w[i];
        double Rd[9], R[9], t[3];
        const double *d;
        if (s < 0)
            continue;
        d = ws->dc + 6 * s;
        tvo_rotvec_to_rot(d, Rd);
        for (int r = 0; r < 3; ++r) {
            for (int col = 0; col < 3; ++col)
                R[3 * r + col] = Rd[3 * r] * T->R[col] + Rd[3 * r + 1] * T->R[3 + col] +
                        Rd[3 * r + 2] * T->R[6 + col];
            t[r] = Rd[3 * r] * T->t[0] + Rd[3 * r + 1] * T->t[1] + Rd[3 * r + 2] * T->t[2] + d[3 + r];
        }
        memcpy(T->R, R, sizeof R);
        memcpy(T->t, t, sizeof t);
    }
    for (int32_t j = 0; j < p->n_points; ++j) {
        if (ws->pstate[j] != PT_FREE)
            continue;
        p->X[j][0] += ws->dx[j][0];
        p->X[j][1] += ws->dx[j][1];
        p->X[j][2] += ws->dx[j][2];
    }
    for (int32_t i = 0; i < p->n_poses; ++i)
        if (!tvo_pose_is_finite(&p->T_c_w[i]))
            return 0;
    for (int32_t j = 0; j < p->n_points; ++j)
        if (!(isfinite(p->X[j][0]) && isfinite(p->X[j][1]) && isfinite(p->X[j][2])))
            return 0;
    return 1;
}

/* Decrease of the cost the damped model predicts for the solved step: 1/2 d^T (lambda D d - g). */
static double predicted_drop(const tvo_ba_problem *p, const ba_ws *ws, double lambda)
{
    double s = 0.0;
    for (int32_t i = 0; i < p->n_poses; ++i) {
        const int32_t sl = ws->slot[i];
        if (sl < 0)
            continue;
        for (int a = 0; a < 6; ++a) {
            const double d = ws->dc[6 * sl + a];
            s += d * (lambda * ws->Hc[i][7 * a] * d - ws->gc[i][a]);
        }
    }
    for (int32_t j = 0; j < p->n_points; ++j) {
        if (ws->pstate[j] != PT_FREE)
            continue;
        for (int a = 0; a < 3; ++a) {
            const double d = ws->dx[j][a];
            s += d * (lambda * ws->V[j][sym3[a][a]] * d - ws->gx[j][a]);
        }
    }
    return 0.5 * s;
}

static void backup(const tvo_ba_problem *p, ba_ws *ws)
{
    memcpy(ws->pose_bak, p->T_c_w, (size_t)p->n_poses * sizeof *p->T_c_w);
    if (p->n_points > 0)
        memcpy(ws->X_bak, p->X, (size_t)p->n_points * sizeof *p->X);
}

static void restore(tvo_ba_problem *p, const ba_ws *ws)
{
    memcpy(p->T_c_w, ws->pose_bak, (size_t)p->n_poses * sizeof *p->T_c_w);
    if (p->n_points > 0)
        memcpy(p->X, ws->X_bak, (size_t)p->n_points * sizeof *p->X);
}

static tvo_status check_problem(const tvo_ba_config *cfg, const tvo_ba_problem *p)
{
    int32_t free_vars = 0;
    if (p->T_c_w == NULL || p->pose_fixed == NULL || (p->n_points > 0 && p->X == NULL) ||
        (p->n_obs > 0 && p->obs == NULL))
        return TVO_ERR_NULL;
#if !TVO_WITH_AFFINE
    if (p->prior != NULL) /* left out with the affine refinement (options.h) */
        return TVO_ERR_UNSUPPORTED;
#endif
    if (p->n_poses < 1 || p->n_points < 0 || p->n_obs < 0)
        return TVO_ERR_ARG;
    if (p->n_poses > cfg->max_poses || p->n_points > cfg->max_points || p->n_obs > cfg->max_obs)
        return TVO_ERR_NO_MEMORY;
    for (int32_t k = 0; k < p->n_obs; ++k)
        if (p->obs[k].pose < 0 || p->obs[k].pose >= p->n_poses || p->obs[k].point < 0 ||
            p->obs[k].point >= p->n_points)
            return TVO_ERR_ARG;
    for (int32_t i = 0; i < p->n_poses; ++i) {
        if (!tvo_pose_is_finite(&p->T_c_w[i]))
            return TVO_ERR_NOT_FINITE;
        free_vars += !p->pose_fixed[i];
    }
    for (int32_t j = 0; j < p->n_points; ++j) {
        if (!(isfinite(p->X[j][0]) && isfinite(p->X[j][1]) && isfinite(p->X[j][2])))
            return TVO_ERR_NOT_FINITE;
#if TVO_WITH_AFFINE
        if (p->prior != NULL)
            for (int a = 0; a < TVO_BA_PRIOR_SIZE; ++a)
                if (!isfinite(p->prior[j][a]))
                    return TVO_ERR_NOT_FINITE;
#endif
        free_vars += p->point_fixed == NULL || !p->point_fixed[j];
    }
    if (free_vars == 0 || p->n_obs == 0)
        return TVO_ERR_TOO_FEW;
    if (p->n_rot > 0 && p->rot == NULL)
        return TVO_ERR_NULL;
    if (p->n_rot < 0 || p->n_rot > p->n_poses)
        return TVO_ERR_ARG;
    for (int32_t q = 0; q < p->n_rot; ++q) {
        const tvo_ba_rot_prior *rp = &p->rot[q];
        if (rp->pose_a < 0 || rp->pose_a >= p->n_poses || rp->pose_b < 0 || rp->pose_b >= p->n_poses ||
            rp->pose_a == rp->pose_b || !(rp->weight >= 0.0 && isfinite(rp->weight)))
            return TVO_ERR_ARG;
        for (int k = 0; k < 9; ++k)
            if (!isfinite(rp->R_ba[k]))
                return TVO_ERR_NOT_FINITE;
    }
    return TVO_OK;
}

/* observations grouped by point (counting sort, stable): pt_obs[pt_start[j] .. pt_start[j + 1]) */
static void group_by_point(const tvo_ba_problem *p, ba_ws *ws)
{
    for (int32_t j = 0; j <= p->n_points; ++j)
        ws->pt_start[j] = 0;
    for (int32_t k = 0; k < p->n_obs; ++k)
        ws->pt_start[p->obs[k].point + 1]++;
    for (int32_t j = 0; j < p->n_points; ++j)
        ws->pt_start[j + 1] += ws->pt_start[j];
    for (int32_t j = 0; j < p->n_points; ++j)
        ws->pt_nuse[j] = ws->pt_start[j]; /* fill cursor */
    for (int32_t k = 0; k < p->n_obs; ++k)
        ws->pt_obs[ws->pt_nuse[p->obs[k].point]++] = k;
}

/* the state of the current linearisation: its cost and counts (see linearise) */
typedef struct ba_lin {
    double cost;
    int32_t n_used, n_skip, n_held, nfree;
} ba_lin;

/* linearise at the current state into *L; a starved free pose flags the report singular */
static void relinearise(const tvo_ba_config *cfg, const tvo_ba_problem *p, ba_ws *ws, int first, ba_lin *L,
                        tvo_ba_report *r)
{
    int starved;
    L->cost = linearise(cfg, p, ws, first, &L->n_used, &L->n_skip, &L->n_held, &L->nfree, &starved);
    if (starved)
        r->flags |= TVO_BA_FLAG_SINGULAR;
}

/* One Levenberg-Marquardt trial at damping *lambda: solve the damped reduced system, apply the step
 * and keep it when the cost drops by more than ACCEPT_REL of it (*lambda / 10, relinearise next:
 * *linearised = 0), else restore the state (*lambda * 10); a singular system raises *lambda too.
 * Returns 1 when the solve has converged (the model promises no meaningful decrease, or an accepted
 * step gained less than CONVERGED_REL). */
static int lm_trial(const tvo_ba_config *cfg, tvo_ba_problem *p, ba_ws *ws, ba_lin *L, double *lambda,
                    int *linearised, tvo_ba_report *r)
{
    double cnew;
    if (!build_solve(cfg, p, ws, L->nfree, *lambda, PIVOT_DAMPED, 1)) {
        r->iterations++;
        r->flags |= TVO_BA_FLAG_SINGULAR;
        *lambda *= 10.0;
        return 0;
    }
    if (!(predicted_drop(p, ws, *lambda) > ACCEPT_REL * L->cost))
        return 1; /* the model promises no meaningful decrease: a stationary point */
    r->iterations++;
    if (!apply_step(p, ws, L->nfree) || !((cnew = eval_cost(cfg, p, ws)) < L->cost - ACCEPT_REL * L->cost)) {
        restore(p, ws);
        *lambda *= 10.0;
        return 0;
    }
    const double drop = L->cost - cnew;
    r->accepted++;
    L->cost = cnew;
    *lambda = *lambda / 10.0 < LAMBDA_MIN ? LAMBDA_MIN : *lambda / 10.0;
    *linearised = 0;
    return drop < CONVERGED_REL * (L->cost + drop);
}

/* The damped iterations from the first linearisation *L (at most max_iterations trials, relinearising
 * after each accepted step). Returns 1 when converged: nothing left to optimise, the cost at
 * COST_FLOOR per observation, no meaningful decrease, or the damping above LAMBDA_MAX; 0 at the
 * iteration cap. */
static int lm_iterate(const tvo_ba_config *cfg, tvo_ba_problem *p, ba_ws *ws, ba_lin *L, tvo_ba_report *r)
{
    double lambda = cfg->lambda_init;
    int linearised = 1;
    backup(p, ws);
    for (int32_t it = 0; it < cfg->max_iterations; ++it) {
        int has_free_point = 0;
        if (!linearised) {
            relinearise(cfg, p, ws, 0, L, r);
            backup(p, ws);
            linearised = 1;
        }
        for (int32_t j = 0; j < p->n_points && !has_free_point; ++j)
            has_free_point = ws->pstate[j] == PT_FREE;
        if (L->n_used == 0 || L->cost <= COST_FLOOR * (double)L->n_used ||
            (L->nfree == 0 && !has_free_point) || !isfinite(L->cost))
            return 1;
        if (lm_trial(cfg, p, ws, L, &lambda, &linearised, r))
            return 1;
        if (lambda > LAMBDA_MAX)
            return 1; /* no step lowers the cost any more */
    }
    return 0;
}

tvo_status tvo_ba_solve(const tvo_ba_config *cfg, tvo_ba_problem *p, void *scratch, size_t scratch_size,
                        tvo_ba_report *rep)
{
    ba_ws ws;
    ba_lin L;
    tvo_ba_report r;
    tvo_status st;
    uint8_t *base;
    if (cfg == NULL || p == NULL || scratch == NULL)
        return TVO_ERR_NULL;
    if (!cfg_valid(cfg))
        return TVO_ERR_ARG;
    st = check_problem(cfg, p);
    if (st != TVO_OK)
        return st;
    if (scratch_size < tvo_ba_scratch_size(cfg))
        return TVO_ERR_NO_MEMORY;
    base = (uint8_t *)scratch + ((16u - ((uintptr_t)scratch & 15u)) & 15u);
    (void)carve(cfg, base, &ws);
    group_by_point(p, &ws);

    memset(&r, 0, sizeof r);
    relinearise(cfg, p, &ws, 1, &L, &r);
    r.cost_initial = L.cost;
    /* the undamped reduced system: is every free pose determined? */
    if (L.nfree > 0 && !build_solve(cfg, p, &ws, L.nfree, 0.0, PIVOT_SINGULAR, 0))
        r.flags |= TVO_BA_FLAG_SINGULAR;
    if (!lm_iterate(cfg, p, &ws, &L, &r))
        r.flags |= TVO_BA_FLAG_ITER_CAP;
    if (r.accepted == 0 && r.iterations > 0)
        r.flags |= TVO_BA_FLAG_COST_ROSE;
    if (L.n_held > 0)
        r.flags |= TVO_BA_FLAG_POINTS_SKIPPED;
    r.points_skipped = L.n_held;
    r.obs_skipped = L.n_skip;
    r.poses_free = L.nfree;
    r.cost_final = L.cost;
    if (rep != NULL)
        *rep = r;
    return TVO_OK;
}

#if TVO_WITH_AFFINE
int tvo_ba_point_prior_add(double prior[TVO_BA_PRIOR_SIZE], const tvo_pose *T_c_w, const double X[3],
                           double x, double y, double huber, double weight)
{
    /* the observation linearised as lin_obs does, r ~ r0 + J (X' - X) = J X' + d with d = r0 - J X: its
       weighted square w |J X' + d|^2 / 2 is 1/2 X'^T (w J^T J) X' + (w J^T d)^T X' + w |d|^2 / 2 */
    tvo_ba_config c;
    tvo_ba_obs o;
    tvo_ba_problem p;
    obs_lin L;
    double q[TVO_BA_PRIOR_SIZE];
    if (prior == NULL || T_c_w == NULL || X == NULL || !(huber > 0.0) || !(weight >= 0.0) ||
        !isfinite(weight) || !isfinite(huber) || !tvo_pose_is_finite(T_c_w) ||
        !(isfinite(X[0]) && isfinite(X[1]) && isfinite(X[2])))
        return 0;
    tvo_ba_config_default(&c);
    c.huber = huber;
    memset(&p, 0, sizeof(p));
    p.T_c_w = (tvo_pose *)T_c_w;
    p.X = (double(*)[3])X;
    o.pose = 0;
    o.point = 0;
    o.x = x;
    o.y = y;
    if (!lin_obs(&c, &p, &o, &L))
        return 0;
    memcpy(q, prior, sizeof(q));
    for (int i = 0; i < 2; ++i) {
        const double *J = L.Jx[i], w = weight * (i == 0 ? L.w0 : L.w1);
        const double d = (i == 0 ? L.r0 : L.r1) - (J[0] * X[0] + J[1] * X[1] + J[2] * X[2]);
        for (int a = 0; a < 3; ++a) {
            for (int b = a; b < 3; ++b)
                q[sym3[a][b]] += w * J[a] * J[b];
            q[6 + a] += w * J[a] * d;
        }
        q[9] += 0.5 * w * d * d;
    }
    for (int a = 0; a < TVO_BA_PRIOR_SIZE; ++a)
        if (!isfinite(q[a]))
            return 0;
    memcpy(prior, q, sizeof(q));
    return 1;
}
#else
/* left out with the affine refinement (options.h): nothing is added */
int tvo_ba_point_prior_add(double prior[TVO_BA_PRIOR_SIZE], const tvo_pose *T_c_w, const double X[3],
                           double x, double y, double huber, double weight)
{
    (void)prior;
    (void)T_c_w;
    (void)X;
    (void)x;
    (void)y;
    (void)huber;
    (void)weight;
    return 0;
}
#endif

tvo_status tvo_ba_obs_errors(const tvo_ba_problem *p, double *err2)
{
    if (p == NULL || err2 == NULL || p->T_c_w == NULL || (p->n_points > 0 && p->X == NULL) ||
        (p->n_obs > 0 && p->obs == NULL))
        return TVO_ERR_NULL;
    if (p->n_poses < 0 || p->n_points < 0 || p->n_obs < 0)
        return TVO_ERR_ARG;
    for (int32_t k = 0; k < p->n_obs; ++k)
        if (p->obs[k].pose < 0 || p->obs[k].pose >= p->n_poses || p->obs[k].point < 0 ||
            p->obs[k].point >= p->n_points)
            return TVO_ERR_ARG;
    for (int32_t k = 0; k < p->n_obs; ++k) {
        const tvo_ba_obs *o = &p->obs[k];
        double P[3], e0, e1, e;
        to_camera(&p->T_c_w[o->pose], p->X[o->point], P);
        err2[k] = TVO_BA_ERR_INVALID;
        if (!(P[2] > 0.0))
            continue;
        e0 = P[0] / P[2] - o->x;
        e1 = P[1] / P[2] - o->y;
        e = e0 * e0 + e1 * e1;
        if (isfinite(e) && e < TVO_BA_ERR_INVALID)
            err2[k] = e;
    }
    return TVO_OK;
}
