/* SPDX-License-Identifier: Apache-2.0 */
/* tinyvo: the lens's radial coefficients refined on the run. See tvo_lens.h. */
#include "tvo_lens.h"

#include <math.h>
#include <string.h>

#include "tinyvo/arena.h"
#include "tinyvo/options.h"

#if TVO_WITH_LENS

#include "tinyvo/camera_impl.h"
#include "tinyvo/linalg.h"
#include "tinyvo/se3.h"

/* A point takes part when it has at least this many usable observations, and the window when at least
 * TVO_LENS_MIN_POINTS points do. */
#define TVO_LENS_MIN_OBS 2
#define TVO_LENS_MIN_POINTS 50
/* A point whose 3x3 block has a Cholesky pivot below this share of its diagonal entry is left out. */
#define TVO_LENS_POINT_PIVOT 1e-9
/* The residuals' variance is taken as at least this (px^2): no track is better than 0.01 px. */
#define TVO_LENS_MIN_S2 1e-4
/* The pose block's regularisation (relative to its largest diagonal entry): the monocular scale. */
#define TVO_LENS_POSE_REG 1e-9

int tvo_lens_supported(const tvo_camera *cam)
{
    return cam != NULL && (cam->model == TVO_DIST_RADTAN || cam->model == TVO_DIST_NONE);
}

/* the camera's coefficients as RADTAN's five (zeros for NONE) */
static void radtan_k(const tvo_camera *cam, double k[5])
{
    if (cam->model == TVO_DIST_RADTAN)
        memcpy(k, cam->k, 5 * sizeof(double));
    else
        memset(k, 0, 5 * sizeof(double));
}

size_t tvo_lens_scratch_size(int32_t max_poses, int32_t max_points, int32_t max_obs)
{
    size_t nc, s;
    if (max_poses < 2 || max_points < 0 || max_obs < 0)
        return 0;
    nc = 6 * (size_t)(max_poses - 1) + 2;
    s = tvo_arena_round(tvo_size_mul(tvo_size_mul(nc, nc), sizeof(double)));    /* S */
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul(nc, 3 * sizeof(double)))); /* g, Y (2 columns) */
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul((size_t)max_poses, 18 * sizeof(double))));  /* B */
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul((size_t)max_poses, sizeof(int32_t))));      /* seen */
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul((size_t)max_points + 1, sizeof(int32_t)))); /* start */
    s = tvo_size_add(s, tvo_arena_round(tvo_size_mul((size_t)max_obs, sizeof(int32_t))));        /* order */
    return s;
}

/* One observation linearised: its pixel residual r, Huber weight w, the Jacobians of the pixel by the
 * point (Jx, 2x3), by the pose's left step (Jc, 2x6) and by dk (Jk, 2x2). 0 when not usable. */
typedef struct lens_lin {
    double r[2], w, e2;
    double Jx[6], Jc[12], Jk[4];
} lens_lin;

static int linearise(const tvo_camera *cam, const double k[5], const tvo_pose *T, const double X[3],
                     const tvo_ba_obs *ob, double huber_px, lens_lin *L)
{
    double P[3], x, y, z, xd, yd, Jd[4], uo, vo, JP[6], e;
    tvo_pose_transform_point(T, X, P);
    z = P[2];
    if (!(z > 1e-9) || !isfinite(P[0]) || !isfinite(P[1]) || !isfinite(ob->x) || !isfinite(ob->y))
        return 0;
    x = P[0] / z;
    y = P[1] / z;
    tvo_camera_radtan(k, ob->x, ob->y, &uo, &vo, NULL);
    tvo_camera_radtan(k, x, y, &xd, &yd, Jd);
    L->r[0] = cam->fx * (xd - uo);
    L->r[1] = cam->fy * (yd - vo);
    L->e2 = L->r[0] * L->r[0] + L->r[1] * L->r[1];
    if (!isfinite(L->e2))
        return 0;
    e = sqrt(L->e2);
    L->w = e <= huber_px ? 1.0 : huber_px / e;
    /* d pixel / d P = diag(fx, fy) Jd [1/z 0 -x/z; 0 1/z -y/z] */
    for (int a = 0; a < 2; ++a) {
        const double f = a == 0 ? cam->fx : cam->fy;
        const double j0 = f * Jd[2 * a], j1 = f * Jd[2 * a + 1];
        JP[3 * a] = j0 / z;
        JP[3 * a + 1] = j1 / z;
        JP[3 * a + 2] = -(j0 * x + j1 * y) / z;
    }
    for (int a = 0; a < 2; ++a) {
        const double *jp = JP + 3 * a;
        /* the point: JP R */
        for (int c = 0; c < 3; ++c)
            L->Jx[3 * a + c] = jp[0] * T->R[c] + jp[1] * T->R[3 + c] + jp[2] * T->R[6 + c];
        /* the pose's left step [omega, v]: dP = -[P]x omega + v */
        L->Jc[6 * a + 0] = jp[1] * -P[2] + jp[2] * P[1];
        L->Jc[6 * a + 1] = jp[0] * P[2] + jp[2] * -P[0];
        L->Jc[6 * a + 2] = jp[0] * -P[1] + jp[1] * P[0];
        L->Jc[6 * a + 3] = jp[0];
        L->Jc[6 * a + 4] = jp[1];
        L->Jc[6 * a + 5] = jp[2];
    }
    {
        const double r2 = x * x + y * y;
        L->Jk[0] = cam->fx * x * r2;
        L->Jk[1] = cam->fx * x * r2 * r2;
        L->Jk[2] = cam->fy * y * r2;
        L->Jk[3] = cam->fy * y * r2 * r2;
    }
    return 1;
}

/* 3x3 symmetric inverse (the lower triangle of V is read): tvo_la_chol with the pivot bound
 * TVO_LENS_POINT_PIVOT, then its solve for each unit vector, column by column. 0 when a pivot is not above
 * that share of its entry. (tvo_la_chol3_inv, the closed form, agrees only up to rounding: the lens
 * blocks, and the runs whose lens they change, were measured with this order of operations.) */
static int sym3_inv(const double V[9], double Vi[9])
{
    double L[9];
    memcpy(L, V, sizeof(L));
    if (!tvo_la_chol(L, 3, 3, TVO_LENS_POINT_PIVOT))
        return 0;
    for (int c = 0; c < 3; ++c) {
        const double e[3] = {c == 0 ? 1.0 : 0.0, c == 1 ? 1.0 : 0.0, c == 2 ? 1.0 : 0.0};
        double x[3];
        tvo_la_chol_solve(L, 3, 3, e, x);
        for (int i = 0; i < 3; ++i)
            Vi[3 * i + c] = x[i];
    }
    return 1;
}

/* the block row offset of pose i (>= 1) in S */
#define POSE_ROW(i) (6 * ((i)-1))

/* tvo_lens_window's work: the system S (nc x nc: the free poses' 6 (P - 1) rows, then dk's 2) and g,
 * one column of A^-1 (Y), each seen pose's 6x3 block W of the point being eliminated (B) and the list of
 * those poses (seen), the observations grouped by point (order; run j ends at end[j]), the sums. */
typedef struct lens_ws {
    const tvo_camera *cam;
    const tvo_ba_problem *p;
    double huber_px, k[5];
    int32_t na, nc;
    double *S, *g, *Y, *B;
    int32_t *seen, *end, *order;
    double sum_we2, drop; /* the weighted squared residuals, and what the whole step removes of them */
    int32_t n_pts, n_used;
} lens_ws;

static int ws_carve(lens_ws *w, void *scratch, size_t scratch_size)
{
    const tvo_ba_problem *p = w->p;
    tvo_arena ar;
    tvo_arena_init(&ar, scratch, scratch_size);
    w->S = (double *)tvo_arena_alloc(&ar, (size_t)w->nc * (size_t)w->nc * sizeof(double));
    w->g = (double *)tvo_arena_alloc(&ar, (size_t)w->nc * 3 * sizeof(double));
    w->B = (double *)tvo_arena_alloc(&ar, (size_t)p->n_poses * 18 * sizeof(double));
    w->seen = (int32_t *)tvo_arena_alloc(&ar, (size_t)p->n_poses * sizeof(int32_t));
    w->end = (int32_t *)tvo_arena_alloc(&ar, ((size_t)p->n_points + 1) * sizeof(int32_t));
    w->order = (int32_t *)tvo_arena_alloc(&ar, (size_t)p->n_obs * sizeof(int32_t));
    if (w->S == NULL || w->g == NULL || w->B == NULL || w->seen == NULL || w->end == NULL || w->order == NULL)
        return 0;
    w->Y = w->g + w->nc;
    memset(w->S, 0, (size_t)w->nc * (size_t)w->nc * sizeof(double));
    memset(w->g, 0, (size_t)w->nc * sizeof(double));
    return 1;
}

/* The observations grouped by point (a stable counting sort); observations that name no pose or point
 * of the problem are left out. */
static void group_by_point(lens_ws *w)
{
    const tvo_ba_problem *p = w->p;
    int32_t *end = w->end;
    memset(end, 0, ((size_t)p->n_points + 1) * sizeof(int32_t));
    for (int32_t o = 0; o < p->n_obs; ++o) {
        const tvo_ba_obs *ob = &p->obs[o];
        if (ob->point >= 0 && ob->point < p->n_points && ob->pose >= 0 && ob->pose < p->n_poses)
            end[ob->point + 1]++;
    }
    for (int32_t j = 0; j < p->n_points; ++j)
        end[j + 1] += end[j];
    for (int32_t o = 0; o < p->n_obs; ++o) {
        const tvo_ba_obs *ob = &p->obs[o];
        if (ob->point >= 0 && ob->point < p->n_points && ob->pose >= 0 && ob->pose < p->n_poses)
            w->order[end[ob->point]++] = o; /* end[j] ends at the end of point j's run */
    }
}

/* One observation of point j into S, g and the point's blocks (gp, Bk; B and seen for its pose). */
static void add_obs(lens_ws *w, const lens_lin *L, int32_t i, double gp[3], double Bk[6], int32_t *ns)
{
    const int32_t na = w->na, nc = w->nc;
    for (int a = 0; a < 3; ++a)
        gp[a] += L->w * (L->Jx[a] * L->r[0] + L->Jx[3 + a] * L->r[1]);
    for (int a = 0; a < 2; ++a) {
        double *Sk = w->S + (size_t)(na + a) * (size_t)nc;
        for (int b = 0; b < 2; ++b)
            Sk[na + b] += L->w * (L->Jk[a] * L->Jk[b] + L->Jk[2 + a] * L->Jk[2 + b]);
        w->g[na + a] += L->w * (L->Jk[a] * L->r[0] + L->Jk[2 + a] * L->r[1]);
        for (int b = 0; b < 3; ++b)
            Bk[3 * a + b] += L->w * (L->Jk[a] * L->Jx[b] + L->Jk[2 + a] * L->Jx[3 + b]);
    }
    if (i == 0)
        return; /* the held pose */
    {
        const int32_t r0 = POSE_ROW(i);
        double *Bi = w->B + 18 * (size_t)i;
        int found = 0;
        for (int32_t s = 0; s < *ns; ++s)
            found |= w->seen[s] == i;
        if (!found) {
            w->seen[(*ns)++] = i;
            memset(Bi, 0, 18 * sizeof(double));
        }
        for (int a = 0; a < 6; ++a) {
            double *Sa = w->S + (size_t)(r0 + a) * (size_t)nc;
            for (int b = 0; b < 6; ++b)
                Sa[r0 + b] += L->w * (L->Jc[a] * L->Jc[b] + L->Jc[6 + a] * L->Jc[6 + b]);
            for (int b = 0; b < 2; ++b)
                Sa[na + b] += L->w * (L->Jc[a] * L->Jk[b] + L->Jc[6 + a] * L->Jk[2 + b]);
            w->g[r0 + a] += L->w * (L->Jc[a] * L->r[0] + L->Jc[6 + a] * L->r[1]);
            for (int b = 0; b < 3; ++b)
                Bi[3 * a + b] += L->w * (L->Jc[a] * L->Jx[b] + L->Jc[6 + a] * L->Jx[3 + b]);
        }
    }
}

/* The point eliminated: S -= E V^-1 E^T and g -= E V^-1 gp over its blocks (the ns poses seen, then dk),
 * written in the upper triangle of blocks (rows of the block that comes first). */
static void eliminate_point(lens_ws *w, const double Vi[9], const double gp[3], const double Bk[6],
                            int32_t ns)
{
    const int32_t na = w->na, nc = w->nc;
    for (int32_t s = 0; s <= ns; ++s) {
        const int32_t ra = s < ns ? POSE_ROW(w->seen[s]) : na, nra = s < ns ? 6 : 2;
        const double *Ba = s < ns ? w->B + 18 * (size_t)w->seen[s] : Bk;
        double M[18];
        for (int a = 0; a < nra; ++a)
            for (int c = 0; c < 3; ++c)
                M[3 * a + c] = Ba[3 * a] * Vi[c] + Ba[3 * a + 1] * Vi[3 + c] + Ba[3 * a + 2] * Vi[6 + c];
        for (int a = 0; a < nra; ++a)
            w->g[ra + a] -= M[3 * a] * gp[0] + M[3 * a + 1] * gp[1] + M[3 * a + 2] * gp[2];
        for (int32_t t = 0; t <= ns; ++t) {
            const int32_t rb = t < ns ? POSE_ROW(w->seen[t]) : na, nrb = t < ns ? 6 : 2;
            const double *Bb = t < ns ? w->B + 18 * (size_t)w->seen[t] : Bk;
            if (rb < ra)
                continue;
            for (int a = 0; a < nra; ++a) {
                double *Sa = w->S + (size_t)(ra + a) * (size_t)nc;
                for (int b = 0; b < nrb; ++b)
                    Sa[rb + b] -= M[3 * a] * Bb[3 * b] + M[3 * a + 1] * Bb[3 * b + 1] +
                            M[3 * a + 2] * Bb[3 * b + 2];
            }
        }
    }
}

/* Point j: its usable observations (at least TVO_LENS_MIN_OBS, and a well-conditioned 3x3 block) into
 * the system, the point eliminated. 1 when it took part. */
static int add_point(lens_ws *w, int32_t j)
{
    const tvo_ba_problem *p = w->p;
    const int32_t o0 = j == 0 ? 0 : w->end[j - 1], o1 = w->end[j];
    double V[9] = {0}, Vi[9], gp[3] = {0}, Bk[6] = {0}, we2 = 0.0;
    int32_t used = 0, ns = 0;
    lens_lin L;
    if (o1 - o0 < TVO_LENS_MIN_OBS)
        return 0;
    for (int32_t q = o0; q < o1; ++q) {
        const tvo_ba_obs *ob = &p->obs[w->order[q]];
        if (!linearise(w->cam, w->k, &p->T_c_w[ob->pose], p->X[j], ob, w->huber_px, &L))
            continue;
        ++used;
        for (int a = 0; a < 3; ++a)
            for (int b = 0; b < 3; ++b)
                V[3 * a + b] += L.w * (L.Jx[a] * L.Jx[b] + L.Jx[3 + a] * L.Jx[3 + b]);
    }
    if (used < TVO_LENS_MIN_OBS || !sym3_inv(V, Vi))
        return 0;
    for (int32_t q = o0; q < o1; ++q) {
        const tvo_ba_obs *ob = &p->obs[w->order[q]];
        if (!linearise(w->cam, w->k, &p->T_c_w[ob->pose], p->X[j], ob, w->huber_px, &L))
            continue;
        we2 += L.w * L.e2;
        add_obs(w, &L, ob->pose, gp, Bk, &ns);
    }
    eliminate_point(w, Vi, gp, Bk, ns);
    /* the least-squares cost the point's own step removes: gp^T V^-1 gp */
    for (int a = 0; a < 3; ++a)
        w->drop += gp[a] * (Vi[3 * a] * gp[0] + Vi[3 * a + 1] * gp[1] + Vi[3 * a + 2] * gp[2]);
    w->sum_we2 += we2;
    w->n_used += used;
    w->n_pts++;
    return 1;
}

/* The poses eliminated (H = S_kk - S_ak^T A^-1 S_ak, gk = g_k - S_ak^T A^-1 g_a, A regularised for the
 * scale) and the block made. 0 when A or H is not positive definite or a value is not finite. */
static int finish_block(lens_ws *w, tvo_lens_block *out)
{
    const int32_t na = w->na, nc = w->nc;
    double *S = w->S, *g = w->g, *col = w->Y, H[4], gk[2], det, dof, s2, dk[2], diag_max = 0.0;
    /* mirror the upper block triangle into the lower one */
    for (int32_t a = 0; a < nc; ++a)
        for (int32_t b = 0; b < a; ++b)
            S[(size_t)a * (size_t)nc + (size_t)b] = S[(size_t)b * (size_t)nc + (size_t)a];
    for (int32_t a = 0; a < na; ++a)
        if (S[(size_t)a * (size_t)nc + (size_t)a] > diag_max)
            diag_max = S[(size_t)a * (size_t)nc + (size_t)a];
    if (!(diag_max > 0.0) || !isfinite(diag_max))
        return 0;
    for (int32_t a = 0; a < na; ++a)
        S[(size_t)a * (size_t)nc + (size_t)a] += TVO_LENS_POSE_REG * diag_max;
    if (!tvo_la_chol(S, na, nc, 0.0))
        return 0;
    for (int a = 0; a < 2; ++a) {
        gk[a] = g[na + a];
        for (int b = 0; b < 2; ++b)
            H[2 * a + b] = S[(size_t)(na + a) * (size_t)nc + (size_t)(na + b)];
    }
    for (int c = 0; c < 3; ++c) {
        for (int32_t r = 0; r < na; ++r)
            col[r] = c < 2 ? S[(size_t)r * (size_t)nc + (size_t)(na + c)] : g[r];
        tvo_la_chol_solve(S, na, nc, col, col);
        if (c == 2) /* ...and the poses' step: g_a^T A^-1 g_a */
            for (int32_t r = 0; r < na; ++r)
                w->drop += g[r] * col[r];
        for (int a = 0; a < 2; ++a) {
            double sum = 0.0;
            for (int32_t r = 0; r < na; ++r)
                sum += S[(size_t)r * (size_t)nc + (size_t)(na + a)] * col[r];
            if (c < 2)
                H[2 * a + c] -= sum;
            else
                gk[a] -= sum;
        }
    }
    H[1] = H[2] = 0.5 * (H[1] + H[2]);
    det = H[0] * H[3] - H[1] * H[2];
    if (!(H[0] > 0.0) || !(det > 1e-12 * H[0] * H[3]) || !isfinite(det) || !isfinite(gk[0]) ||
        !isfinite(gk[1]))
        return 0;
    dk[0] = -(H[3] * gk[0] - H[1] * gk[1]) / det;
    dk[1] = -(-H[2] * gk[0] + H[0] * gk[1]) / det;
    /* the weighted residuals' variance after the whole step (points, poses and dk): the lens error itself
       is not counted as noise */
    w->drop += -(gk[0] * dk[0] + gk[1] * dk[1]);
    dof = 2.0 * w->n_used - 3.0 * w->n_pts - na - 1.0;
    s2 = (w->sum_we2 - w->drop) / (dof > 1.0 ? dof : 1.0);
    if (s2 < TVO_LENS_MIN_S2)
        s2 = TVO_LENS_MIN_S2;
    if (!isfinite(s2) || !isfinite(dk[0]) || !isfinite(dk[1]))
        return 0;
    for (int a = 0; a < 4; ++a)
        out->I[a] = H[a] / s2;
    out->h[0] = out->I[0] * dk[0] + out->I[1] * dk[1];
    out->h[1] = out->I[2] * dk[0] + out->I[3] * dk[1];
    out->s2 = s2;
    out->n_obs = w->n_used;
    return 1;
}

int tvo_lens_window(const tvo_camera *cam, const tvo_ba_problem *p, double huber_px, void *scratch,
                    size_t scratch_size, tvo_lens_block *out)
{
    lens_ws w;
    if (!tvo_lens_supported(cam) || p == NULL || out == NULL || p->n_poses < 2 || p->n_points <= 0 ||
        p->n_obs <= 0 || !(huber_px > 0.0))
        return 0;
    if (scratch == NULL || scratch_size < tvo_lens_scratch_size(p->n_poses, p->n_points, p->n_obs))
        return 0;
    memset(&w, 0, sizeof(w));
    w.cam = cam;
    w.p = p;
    w.huber_px = huber_px;
    w.na = 6 * (p->n_poses - 1);
    w.nc = w.na + 2;
    radtan_k(cam, w.k);
    if (!ws_carve(&w, scratch, scratch_size))
        return 0;
    group_by_point(&w);
    for (int32_t j = 0; j < p->n_points; ++j)
        (void)add_point(&w, j);
    if (w.n_pts < TVO_LENS_MIN_POINTS)
        return 0;
    return finish_block(&w, out);
}

void tvo_lens_clear_blocks(tvo_lens *s)
{
    s->n = 0;
}

void tvo_lens_add(tvo_lens *s, const tvo_lens_block *blk)
{
    if (s->n == TVO_LENS_MAX_BLOCKS) {
        memmove(s->b, s->b + 1, (TVO_LENS_MAX_BLOCKS - 1) * sizeof(s->b[0]));
        s->n--;
    }
    s->b[s->n++] = *blk;
}

tvo_status tvo_lens_changed(const tvo_camera *cam, const double dk[2], tvo_camera *out)
{
    *out = *cam;
    if (out->model == TVO_DIST_NONE) {
        memset(out->k, 0, sizeof(out->k));
        out->model = TVO_DIST_RADTAN;
    }
    out->k[0] += dk[0];
    out->k[1] += dk[1];
    return tvo_camera_check(out);
}

int tvo_lens_remap(const tvo_camera *from, const tvo_camera *to, tvo_point2d *x)
{
    double u, v;
    tvo_point2d y;
    if (tvo_camera_distort_point(from, x, &u, &v) != TVO_OK ||
        tvo_camera_undistort_point(to, u, v, &y) != TVO_OK)
        return 0;
    *x = y;
    return 1;
}

/* blocks [b0, b1) combined: d = I^-1 h and C = I^-1; 0 when I is not invertible */
static int combine(const tvo_lens *s, int32_t b0, int32_t b1, double d[2], double C[4], double I[4])
{
    double h[2] = {0.0, 0.0}, det;
    memset(I, 0, 4 * sizeof(double));
    for (int32_t b = b0; b < b1; ++b) {
        for (int a = 0; a < 4; ++a)
            I[a] += s->b[b].I[a];
        h[0] += s->b[b].h[0];
        h[1] += s->b[b].h[1];
    }
    det = I[0] * I[3] - I[1] * I[2];
    if (!(I[0] > 0.0) || !(det > 0.0) || !isfinite(det))
        return 0;
    C[0] = I[3] / det;
    C[1] = -I[1] / det;
    C[2] = -I[2] / det;
    C[3] = I[0] / det;
    d[0] = C[0] * h[0] + C[1] * h[1];
    d[1] = C[2] * h[0] + C[3] * h[1];
    return isfinite(d[0]) && isfinite(d[1]);
}

/* The image's border points: corners and side middles (pixels). */
static void border_point(const tvo_camera *cam, int i, double *u, double *v)
{
    const double w = (double)(cam->width - 1), h = (double)(cam->height - 1);
    static const double fu[8] = {0.0, 1.0, 0.0, 1.0, 0.5, 0.5, 0.0, 1.0};
    static const double fv[8] = {0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 0.5, 0.5};
    *u = fu[i] * w;
    *v = fv[i] * h;
}

/* The largest distance over the border points between cameras a and b (both cam changed by da, db),
 * the points taken where cam sees them; -1 when a point cannot be mapped. */
static double border_dist(const tvo_camera *cam, const double da[2], const double db[2])
{
    tvo_camera ca, cb;
    double worst = 0.0;
    if (tvo_lens_changed(cam, da, &ca) != TVO_OK || tvo_lens_changed(cam, db, &cb) != TVO_OK)
        return -1.0;
    for (int i = 0; i < 8; ++i) {
        double u, v, ua, va, ub, vb, dd;
        tvo_point2d x;
        border_point(cam, i, &u, &v);
        if (tvo_camera_undistort_point(cam, u, v, &x) != TVO_OK ||
            tvo_camera_distort_point(&ca, &x, &ua, &va) != TVO_OK ||
            tvo_camera_distort_point(&cb, &x, &ub, &vb) != TVO_OK)
            return -1.0;
        dd = sqrt((ua - ub) * (ua - ub) + (va - vb) * (va - vb));
        if (dd > worst)
            worst = dd;
    }
    return worst;
}

tvo_lens_verdict tvo_lens_decide(const tvo_lens *s, const tvo_camera *cam, double dk[2], double *shift_px,
                                 tvo_camera *changed)
{
    static const double zero[2] = {0.0, 0.0};
    double d[2], C[4], I[4], dA[2], CA[4], IA[4], dB[2], CB[4], IB[4], shift, m2;
    const int32_t half = s->n / 2;
    if (dk != NULL)
        dk[0] = dk[1] = 0.0;
    if (shift_px != NULL)
        *shift_px = 0.0;
    if (s->n < TVO_LENS_MIN_BLOCKS)
        return TVO_LENS_WAIT;
    if (!combine(s, 0, s->n, d, C, I) || !combine(s, 0, half, dA, CA, IA) ||
        !combine(s, half, s->n, dB, CB, IB))
        return TVO_LENS_SMALL;
    if (dk != NULL) {
        dk[0] = d[0];
        dk[1] = d[1];
    }
    shift = border_dist(cam, d, zero);
    if (shift_px != NULL)
        *shift_px = shift;
    if (shift < 0.0)
        return TVO_LENS_LARGE;
    {
        /* condition 2: the halves */
        const double z0 = fabs(dA[0] - dB[0]) / sqrt(CA[0] + CB[0]);
        const double z1 = fabs(dA[1] - dB[1]) / sqrt(CA[3] + CB[3]);
        const double apart = border_dist(cam, dA, dB);
        if ((!(z0 <= TVO_LENS_AGREE_SIGMAS) || !(z1 <= TVO_LENS_AGREE_SIGMAS)) &&
            !(apart >= 0.0 && apart <= TVO_LENS_AGREE_SHARE * shift))
            return TVO_LENS_DISAGREE;
    }
    /* condition 3 */
    m2 = d[0] * (I[0] * d[0] + I[1] * d[1]) + d[1] * (I[2] * d[0] + I[3] * d[1]);
    if (!(m2 >= TVO_LENS_MIN_SIGMAS * TVO_LENS_MIN_SIGMAS) || !(shift >= TVO_LENS_MIN_SHIFT_PX))
        return TVO_LENS_SMALL;
    if (!(shift <= TVO_LENS_MAX_SHIFT_PX))
        return TVO_LENS_LARGE;
    /* condition 4 */
    {
        tvo_camera c;
        if (tvo_lens_changed(cam, d, &c) != TVO_OK)
            return TVO_LENS_LARGE;
        for (int i = 0; i < 8; ++i) {
            double u, v;
            tvo_point2d x;
            border_point(cam, i, &u, &v);
            if (tvo_camera_undistort_point(&c, u, v, &x) != TVO_OK)
                return TVO_LENS_LARGE;
        }
        if (changed != NULL)
            *changed = c;
    }
    return TVO_LENS_ADOPT;
}

#else

typedef int tvo_lens_unused; /* ISO C: a translation unit is not empty */

#endif /* TVO_WITH_LENS */
