# SPDX-License-Identifier: Apache-2.0
"""Check a camera's lens calibration on a recorded sequence: the VO's tracks at keyframes, adjusted once
with the calibration as it is and once with its focal length and/or first radial coefficients free.

    tinyvo-lenscheck --seq DIR --replay BIN [--keyframes N] [--free f,k1,k2] [--out JSON]
                     [--write-yaml FILE] [-- REPLAY_ARGS]

A monocular VO turns small lens errors into large trajectory errors (docs/camera.md, "How much a lens
error costs": 0.7 px at the image's side edges made a render's ATE 4-7 times larger). This tool replays the
sequence (EuRoC/ASL folder with mav0/cam0/sensor.yaml) with tvo_replay, takes N frames spread over the
run (default 40) and the tracks seen in at least 3 of them, and runs a bundle adjustment over those
frames' poses and the tracks' points (Levenberg-Marquardt, the points eliminated by their Schur complement,
Huber weights of 1 px, the first frame fixed): first with the calibration of sensor.yaml, then with the
parameters of --free free as well: f (the focal length: fu and fv times one factor), k1, k2 (default
k1). It prints, for both, the reprojection error of the tracks (median and 90th percentile, in the
image's centre and its outer ring), each estimated change with its standard error, and how far the
changes move the image's side edges and corners. A change that is several standard errors from zero and
lowers the outer ring's error says the calibration is off there. The standard errors assume the model: the
same adjustment on the first and on the second half of the run (half the frames each) checks it. When the
halves' estimates differ by more than 3 standard errors of their difference and their two models put the
image's edges further apart than half of what the whole run's change moves them, the estimate is reported
as not to be applied. f is freed only with k1 (alone, it takes up a radial error).

What it needs: a sequence with translation and turns (the focal length is seen only through rotation,
and a camera that only rotates gives no points), frames the VO poses, and the principal point near right.
It is a check, not a calibration: calibrate with a target, then use this to see whether a recorded run
agrees with the result; confirm an estimate by replaying with it.

--out writes the figures as JSON, --write-yaml the sensor.yaml with the estimated changes applied (replay
with it, `tvo_replay --calib FILE`, to confirm it); when the halves disagree or cannot be adjusted it
writes nothing and exits with status 1. The replay keeps the lens as configured (`--set lens_refine=0`:
the VO's own refinement of k1 and k2 on the run is off, so that the check sees the calibration as given).
Arguments after "--" go to tvo_replay after that (e.g. --preset basic)."""
from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

from . import cli, trajio
from .synth import project_points, undistort

PROG = "tinyvo-lenscheck"


def read_tracks(path: str):
    """The --tracks CSV of tvo_replay (t_ns,id,x,y,age,flags) as arrays t (int64), id (int64), xy (N,2)."""
    try:
        raw = np.loadtxt(path, delimiter=",", skiprows=1, dtype=np.float64, ndmin=2)
    except (OSError, ValueError) as e:
        raise cli.Failure(f"cannot read tracks {path}: {e}") from e
    if raw.size == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2))
    if raw.shape[1] != 6:
        raise cli.Failure(f"{path}: expected 6 columns (t_ns,id,x,y,age,flags), found {raw.shape[1]}")
    t = np.loadtxt(path, delimiter=",", skiprows=1, usecols=0, dtype=np.int64, ndmin=1)
    return t, raw[:, 1].astype(np.int64), raw[:, 2:4].copy()


def _rotations(rv):
    """Rotation matrices (K,3,3) of rotation vectors (K,3) (Rodrigues)."""
    th = np.linalg.norm(rv, axis=1)
    k = np.where(th[:, None] > 1e-12, rv / np.maximum(th, 1e-300)[:, None], 0.0)
    K = np.zeros((len(rv), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    K[:, 1, 0], K[:, 2, 0], K[:, 2, 1] = k[:, 2], -k[:, 1], k[:, 0]
    s, c = np.sin(th)[:, None, None], np.cos(th)[:, None, None]
    return np.eye(3)[None] + s * K + (1.0 - c) * (K @ K)


# The parameters the check can free, in this order: f, a relative change of the focal length (fu and fv
# times 1 + f), then changes of the first two distortion coefficients.
PARAMS = ("f", "k1", "k2")


def parse_free(text: str):
    """The parameters named by --free (a comma-separated list of f, k1, k2; "k1k2" is k1,k2), in PARAMS'
    order; ValueError for an unknown or empty name."""
    names = [n.strip() for n in text.replace("k1k2", "k1,k2").split(",")]
    bad = [n for n in names if n not in PARAMS]
    if bad or not names:
        raise ValueError(f"unknown parameter {bad[0]!r}" if bad else "no parameter")
    return tuple(n for n in PARAMS if n in names)


def _changed(cam, d, f_change=0.0):
    """cam with the distortion coefficients d and its focal length times 1 + f_change (for
    synth.project_points)."""
    fu, fv, cu, cv = cam.intrinsics
    s = 1.0 + f_change
    return dataclasses.replace(cam, intrinsics=(s * fu, s * fv, cu, cv), distortion=d)


class Problem:
    """Keyframe poses T_c_w (the first fixed), points in the world and changes of the camera parameters
    (PARAMS), adjusted by Levenberg-Marquardt on the reprojection errors in pixels (Huber weights of
    width 1 px), the points eliminated by their Schur complement."""

    def __init__(self, cam, T_c_w, pts, obs_k, obs_p, obs_xy):
        self.cam = cam
        self.R = np.array([T[:3, :3] for T in T_c_w])
        self.t = np.array([T[:3, 3] for T in T_c_w])
        self.X = np.array(pts, dtype=np.float64)
        self.obs_k, self.obs_p, self.obs_xy = obs_k, obs_p, obs_xy
        self.dc = np.zeros(len(PARAMS))  # the changes, in PARAMS' order

    def distortion(self, dc=None):
        d = np.array(self.cam.distortion, dtype=np.float64)
        dc = self.dc if dc is None else dc
        d[:2] += dc[1:3]
        return d

    def _pixels(self, Xc, d, f_change=0.0):
        return project_points(_changed(self.cam, d, f_change), Xc)

    def camera_points(self, R=None, t=None, X=None):
        R = self.R if R is None else R
        t = self.t if t is None else t
        X = self.X if X is None else X
        k, p = self.obs_k, self.obs_p
        return np.einsum("nij,nj->ni", R[k], X[p]) + t[k]

    def residuals(self, R=None, t=None, X=None, dc=None):
        dc = self.dc if dc is None else dc
        return self._pixels(self.camera_points(R, t, X), self.distortion(dc), dc[0]) - self.obs_xy

    def normal_equations(self, free):
        """The weighted Gauss-Newton blocks: camera (poses 1..K-1, then the parameters `free`, names of
        PARAMS) H_cc and g_c, points H_pp and g_p, and their coupling H_cp, per point."""
        K, P = len(self.R), len(self.X)
        k, p = self.obs_k, self.obs_p
        Xc = self.camera_points()
        d, fc = self.distortion(), self.dc[0]
        r = self._pixels(Xc, d, fc) - self.obs_xy
        w = _huber_weights(r)
        # d pixel / d camera point (central differences) and / d parameter change
        Jx = np.zeros((len(k), 2, 3))
        for j in range(3):
            h = 1e-6 * np.maximum(np.abs(Xc[:, 2]), 1e-3)
            Xp, Xm = Xc.copy(), Xc.copy()
            Xp[:, j] += h
            Xm[:, j] -= h
            Jx[:, :, j] = (self._pixels(Xp, d, fc) - self._pixels(Xm, d, fc)) / (2.0 * h[:, None])
        nc = 6 * (K - 1) + len(free)
        Jc = np.zeros((len(k), 2, nc))
        for j, name in enumerate(free):
            i = PARAMS.index(name)
            dp, dm = self.dc.copy(), self.dc.copy()
            dp[i] += 1e-6
            dm[i] -= 1e-6
            Jc[:, :, 6 * (K - 1) + j] = (self._pixels(Xc, self.distortion(dp), dp[0]) -
                                         self._pixels(Xc, self.distortion(dm), dm[0])) / 2e-6
        # a pose change exp(w) (R X + t) + v moves the camera point by w x Xc + v
        skew = np.zeros((len(k), 3, 3))
        skew[:, 0, 1], skew[:, 0, 2], skew[:, 1, 2] = Xc[:, 2], -Xc[:, 1], Xc[:, 0]
        skew[:, 1, 0], skew[:, 2, 0], skew[:, 2, 1] = -Xc[:, 2], Xc[:, 1], -Xc[:, 0]
        Jrot = np.einsum("nij,njk->nik", Jx, skew)
        rows = np.nonzero(k > 0)[0]
        cols = 6 * (k[rows] - 1)
        for j in range(3):
            Jc[rows, :, cols + j] = Jrot[rows, :, j]
            Jc[rows, :, cols + 3 + j] = Jx[rows, :, j]
        Jp = np.einsum("nij,njk->nik", Jx, self.R[k])
        Jcw = Jc * w[:, None, None]
        Jpw = Jp * w[:, None, None]
        H_cc = np.einsum("nai,naj->ij", Jcw, Jc)
        g_c = np.einsum("nai,na->i", Jcw, r)
        H_pp = np.zeros((P, 3, 3))
        np.add.at(H_pp, p, np.einsum("nai,naj->nij", Jpw, Jp))
        g_p = np.zeros((P, 3))
        np.add.at(g_p, p, np.einsum("nai,na->ni", Jpw, r))
        H_cp = np.zeros((P, nc, 3))
        np.add.at(H_cp, p, np.einsum("nai,naj->nij", Jcw, Jp))
        return H_cc, g_c, H_pp, g_p, H_cp, r, w

    def solve(self, free=(), iters: int = 40):
        """Levenberg-Marquardt over poses 1..K-1, the points and the parameters `free` (names of PARAMS)."""
        K = len(self.R)
        idx = [PARAMS.index(n) for n in free]
        lam = 1e-3
        cost = _cost(self.residuals())
        for _ in range(iters):
            H_cc, g_c, H_pp, g_p, H_cp, _, _ = self.normal_equations(free)
            improvement = 0.0
            while True:
                A = H_cc + lam * np.diag(np.diag(H_cc) + 1e-9)
                Hpp = H_pp + lam * (np.einsum("pii->pi", H_pp)[:, :, None] + 1e-9) * np.eye(3)[None]
                Hpp_inv = np.linalg.inv(Hpp)
                HcpHinv = np.einsum("pij,pjk->pik", H_cp, Hpp_inv)
                S = A - np.einsum("pij,pkj->ik", HcpHinv, H_cp)
                rhs = g_c - np.einsum("pij,pj->i", HcpHinv, g_p)
                dc = -np.linalg.lstsq(S, rhs, rcond=None)[0]
                dp = -np.einsum("pij,pj->pi", Hpp_inv, g_p + np.einsum("pji,j->pi", H_cp, dc))
                R_new, t_new = self.R.copy(), self.t.copy()
                for kk in range(1, K):
                    E = _rotations(dc[None, 6 * (kk - 1):6 * (kk - 1) + 3])[0]
                    R_new[kk] = E @ self.R[kk]
                    t_new[kk] = E @ self.t[kk] + dc[6 * (kk - 1) + 3:6 * kk]
                X_new = self.X + dp
                dc_new = self.dc.copy()
                dc_new[idx] += dc[6 * (K - 1):]
                new_cost = _cost(self.residuals(R_new, t_new, X_new, dc_new))
                if np.isfinite(new_cost) and new_cost < cost:
                    self.R, self.t, self.X, self.dc = R_new, t_new, X_new, dc_new
                    improvement = (cost - new_cost) / max(cost, 1e-300)
                    cost = new_cost
                    lam = max(lam / 3.0, 1e-9)
                    break
                lam *= 4.0
                if lam > 1e8:
                    return
            if improvement < 1e-10:
                return

    def stderr(self, free):
        """Standard errors of the changes of the parameters `free`: the camera block of the inverse
        Gauss-Newton matrix (the points eliminated by their Schur complement) times the weighted residuals'
        variance."""
        H_cc, _, H_pp, _, H_cp, r, w = self.normal_equations(free)
        Hpp_inv = np.linalg.inv(H_pp + 1e-9 * np.eye(3)[None])
        S = H_cc - np.einsum("pij,pjk,plk->il", H_cp, Hpp_inv, H_cp)
        dof = max(r.size - S.shape[0] - 3 * len(self.X), 1)
        sigma2 = float(np.sum(w[:, None] * r * r) / dof)
        cov = np.linalg.pinv(S) * sigma2
        return np.sqrt(np.maximum(np.diag(cov)[len(cov) - len(free):], 0.0))


def _cost(r):
    e = np.linalg.norm(r, axis=1)
    return float(np.sum(np.where(e <= 1.0, 0.5 * e * e, e - 0.5)))


def _huber_weights(r, width: float = 1.0):
    e = np.linalg.norm(r, axis=1)
    return np.where(e <= width, 1.0, width / np.maximum(e, 1e-12))


def _ring_stats(prob: Problem, cam):
    e = np.linalg.norm(prob.residuals(), axis=1)
    fu, fv, cu, cv = cam.intrinsics
    u, v = prob.obs_xy[:, 0], prob.obs_xy[:, 1]
    # the outer ring: beyond 70 % of the way from the principal point to the image's border
    rel = np.maximum(np.abs(u - cu) / max(cu, cam.width - 1 - cu), np.abs(v - cv) / max(cv, cam.height - 1 - cv))
    out = {}
    for name, m in (("all", np.ones_like(rel, bool)), ("centre", rel <= 0.7), ("outer", rel > 0.7)):
        out[name] = {"n": int(m.sum()),
                     "median_px": float(np.median(e[m])) if m.any() else None,
                     "p90_px": float(np.percentile(e[m], 90)) if m.any() else None}
    return out


def _edge_pixels(cam, d, f_change=0.0):
    """Where a model (distortion d, focal length times 1 + f_change) puts the rays that the calibrated model
    puts at the middle of the two side edges and at the four corners: (calibrated pixels, model's pixels),
    each (6, 2)."""
    fu, fv, cu, cv = cam.intrinsics
    W, H = cam.width, cam.height
    px = np.array([[0.0, cv], [W - 1.0, cv], [0.0, 0.0], [W - 1.0, 0.0], [0.0, H - 1.0], [W - 1.0, H - 1.0]])
    x, y = undistort(cam.distortion_model, (px[:, 0] - cu) / fu, (px[:, 1] - cv) / fv, cam.distortion)
    return px, project_points(_changed(cam, d, f_change), np.stack([x, y, np.ones_like(x)], axis=1))


def _edge_shift(cam, d_new, f_change=0.0):
    """How far the changed distortion and focal length move the rays that the calibrated model puts at the
    middle of the side edges and at the corners, in pixels."""
    px, moved_px = _edge_pixels(cam, d_new, f_change)
    moved = np.linalg.norm(moved_px - px, axis=1)
    return float(moved[:2].max()), float(moved[2:].max())


def _nearest(pose_t, frames, tol_ns: int = 1_000_000):
    """For each frame time, the index of the nearest pose time and whether it is within tol_ns (the
    replay writes its trajectory's times in seconds, rounded)."""
    if len(pose_t) == 0:
        return np.zeros(len(frames), int), np.zeros(len(frames), bool)
    i = np.clip(np.searchsorted(pose_t, frames), 1, len(pose_t) - 1) if len(pose_t) > 1 else np.zeros(len(frames), int)
    if len(pose_t) > 1:
        left = np.abs(pose_t[i - 1] - frames) <= np.abs(pose_t[i] - frames)
        i = np.where(left, i - 1, i)
    return i, np.abs(pose_t[i] - frames) <= tol_ns


def select(t, ids, xy, pose_t, n_key: int, min_obs: int, max_points: int):
    """Keyframe times (n_key frames with a pose, spread evenly) and the observations of the tracks seen in
    at least min_obs of them: (key times, obs keyframe index, obs track index, obs xy, track ids)."""
    frames = np.unique(t)
    posed = frames[_nearest(pose_t, frames)[1]]
    if len(posed) < 3:
        raise cli.Failure(f"only {len(posed)} frames with both a pose and tracks: nothing to adjust")
    keys = posed[np.unique(np.linspace(0, len(posed) - 1, min(n_key, len(posed))).round().astype(int))]
    sel = np.isin(t, keys)
    kt, kid, kxy = t[sel], ids[sel], xy[sel]
    uid, counts = np.unique(kid, return_counts=True)
    good = uid[counts >= min_obs]
    if len(good) > max_points:  # the longest-seen tracks first
        order = np.argsort(-counts[counts >= min_obs], kind="stable")
        good = np.sort(good[order[:max_points]])
    keep = np.isin(kid, good)
    kt, kid, kxy = kt[keep], kid[keep], kxy[keep]
    return keys, np.searchsorted(keys, kt), np.searchsorted(good, kid), kxy, good


def triangulate(cam, T_c_w, obs_k, obs_p, obs_xy, n_points: int):
    """Each track's point from the rays of its first and last observation (midpoint of the closest
    approach); a mask of the tracks whose two rays are at least 0.5 degrees apart and in front of both."""
    fu, fv, cu, cv = cam.intrinsics
    x, y = undistort(cam.distortion_model, (obs_xy[:, 0] - cu) / fu, (obs_xy[:, 1] - cv) / fv, cam.distortion)
    rays_c = np.stack([x, y, np.ones_like(x)], axis=1)
    R = np.array([T[:3, :3] for T in T_c_w])
    t = np.array([T[:3, 3] for T in T_c_w])
    centres = -np.einsum("kji,kj->ki", R, t)
    rays_w = np.einsum("nji,nj->ni", R[obs_k], rays_c)
    rays_w /= np.linalg.norm(rays_w, axis=1)[:, None]
    pts = np.zeros((n_points, 3))
    ok = np.zeros(n_points, bool)
    # each track's first and last observation (-1: none)
    idx = np.arange(len(obs_p))
    first = np.full(n_points, len(obs_p))
    last = np.full(n_points, -1)
    np.minimum.at(first, obs_p, idx)
    np.maximum.at(last, obs_p, idx)
    for p in range(n_points):
        a, b = first[p], last[p]
        if b < 0 or a == b:
            continue
        c1, c2, d1, d2 = centres[obs_k[a]], centres[obs_k[b]], rays_w[a], rays_w[b]
        cosang = float(d1 @ d2)
        if cosang > np.cos(np.radians(0.5)):
            continue
        w = c2 - c1
        A = np.array([[d1 @ d1, -d1 @ d2], [d1 @ d2, -d2 @ d2]])
        s, u = np.linalg.solve(A, np.array([d1 @ w, d2 @ w]))
        if s <= 0 or u <= 0:
            continue
        pts[p] = 0.5 * (c1 + s * d1 + c2 + u * d2)
        ok[p] = True
    return pts, ok


def _normalised(cam):
    """cam, with no distortion written as radial-tangential with zero coefficients (which the check
    may change)."""
    if cam.distortion_model == "equidistant":
        return cam
    d = tuple(float(v) for v in list(cam.distortion)[:5])
    return trajio.CameraInfo(cam.width, cam.height, tuple(cam.intrinsics), "radial-tangential",
                             d + (0.0,) * max(0, 4 - len(d)), cam.rate_hz, cam.T_BS, cam.comment)


# The run's halves disagree when some parameter's two values differ by more than AGREE_SIGMAS standard
# errors of their difference (the difference is significant) and the two halves' models put the image's
# side edges or corners further apart than AGREE_SHARE of the whole run's change moves them (it matters
# next to the change itself).
AGREE_SIGMAS = 3.0
AGREE_SHARE = 0.5


def _problem(cam, traj, t, ids, xy, n_key, min_obs, max_points):
    """The adjustment's problem over n_key posed frames of the tracks (t, ids, xy): (problem, keyframes)."""
    pose_t = traj.t_ns
    keys, obs_k, obs_p, obs_xy, _ = select(t, ids, xy, pose_t, n_key, min_obs, max_points)
    T_w_c = traj.poses[_nearest(pose_t, keys)[0]]
    T_c_w = np.array([trajio.inv_pose(T) for T in T_w_c])
    pts, ok = triangulate(cam, T_c_w, obs_k, obs_p, obs_xy, int(obs_p.max()) + 1 if len(obs_p) else 0)
    if ok.sum() < 20:
        raise cli.Failure(f"only {int(ok.sum())} tracks with 0.5 degrees of parallax between keyframes: the "
                          "sequence needs more translation")
    keep = ok[obs_p]
    remap = np.cumsum(ok) - 1
    obs_k, obs_p, obs_xy, pts = obs_k[keep], remap[obs_p[keep]], obs_xy[keep], pts[ok]
    return Problem(cam, T_c_w, pts, obs_k, obs_p, obs_xy), len(keys)


def _change(prob, free):
    dc = prob.dc[[PARAMS.index(n) for n in free]]
    se = prob.stderr(free)
    return {n: {"value": float(v), "stderr": float(s)} for n, v, s in zip(free, dc, se)}


def _halves(cam, traj, t, ids, xy, n_key, min_obs, max_points, free):
    """The estimate from the first and from the second half of the run's frames (n_key / 2 keyframes
    each) and how far they disagree: (changes of each half, the largest |difference| / its standard error,
    or None and the reason when a half could not be adjusted)."""
    frames = np.unique(t)
    mid = frames[len(frames) // 2]
    out, models = [], []
    for m in (t < mid, t >= mid):
        try:
            prob, _ = _problem(cam, traj, t[m], ids[m], xy[m], max(3, n_key // 2), min_obs, max_points)
        except cli.Failure as e:
            return out, None, str(e), None
        prob.solve(free)
        out.append(_change(prob, free))
        models.append(_edge_pixels(cam, prob.distortion(), prob.dc[0])[1])
    z = max(abs(out[0][n]["value"] - out[1][n]["value"]) /
            max(np.hypot(out[0][n]["stderr"], out[1][n]["stderr"]), 1e-12) for n in free)
    return out, float(z), None, float(np.linalg.norm(models[0] - models[1], axis=1).max())


def check(cam, traj, t, ids, xy, n_key=40, min_obs=3, max_points=1500, free=("k1",), halves=True):
    """The adjustments and their figures, as a dict: with the calibration as it is and with the parameters
    `free` (names of PARAMS, or a count of distortion coefficients, 1 or 2) free, over the whole run and,
    when halves, over each half of it ("consistent": whether the halves agree)."""
    if isinstance(free, int):
        free = PARAMS[1:1 + free]
    free = tuple(n for n in PARAMS if n in free)
    if not free:
        raise ValueError("no parameter to free")
    cam = _normalised(cam)
    prob, n_keys = _problem(cam, traj, t, ids, xy, n_key, min_obs, max_points)
    prob.solve()
    before = _ring_stats(prob, cam)
    prob.solve(free)
    after = _ring_stats(prob, cam)
    side, corner = _edge_shift(cam, prob.distortion(), prob.dc[0])
    r = {
        "keyframes": int(n_keys), "tracks": int(len(prob.X)), "observations": int(len(prob.obs_k)),
        "model": cam.distortion_model, "distortion": [float(v) for v in cam.distortion],
        "intrinsics": [float(v) for v in cam.intrinsics],
        "calibrated": before,
        "freed": after,
        "change": _change(prob, free),
        "shift_px": {"side_edges": side, "corners": corner},
    }
    if halves:
        h, z, why, apart = _halves(cam, traj, t, ids, xy, n_key, min_obs, max_points, free)
        limit_px = AGREE_SHARE * max(side, corner)
        r["halves"] = {"changes": h, "disagreement_sigmas": z, "limit_sigmas": AGREE_SIGMAS, "reason": why,
                       "apart_px": apart, "limit_px": limit_px}
        r["consistent"] = z is not None and (z <= AGREE_SIGMAS or apart <= limit_px)
    return r


def format_report(r) -> str:
    def line(name, s):
        return (f"  {name:<22} median {s['all']['median_px']:.3f} px, p90 {s['all']['p90_px']:.3f}; "
                f"centre {s['centre']['median_px'] or 0:.3f} / outer ring {s['outer']['median_px'] or 0:.3f} px "
                f"(median; {s['outer']['n']} observations outside 70 %)")
    out = [f"{r['keyframes']} keyframes, {r['tracks']} tracks, {r['observations']} observations; "
           f"{r['model']} distortion {r['distortion']}",
           "reprojection error after the adjustment:",
           line("calibration as it is", r["calibrated"]),
           line("with " + "+".join(r["change"]) + " free", r["freed"])]
    for n, c in r["change"].items():
        z = abs(c["value"]) / c["stderr"] if c["stderr"] > 0 else float("inf")
        if n == "f":
            fu, fv = r["intrinsics"][:2]
            out.append(f"estimated change of the focal length: {100 * c['value']:+.3f} % ({c['value'] * fu:+.2f} px "
                       f"in fu; standard error {100 * c['stderr']:.3f} %, {z:.1f} of them)")
        else:
            out.append(f"estimated change of {n}: {c['value']:+.5f} (standard error {c['stderr']:.5f}, "
                       f"{z:.1f} of them)")
    out.append(f"the change moves the side edges by {r['shift_px']['side_edges']:.2f} px and the corners by "
               f"{r['shift_px']['corners']:.2f} px")
    if "halves" in r:
        h = r["halves"]
        if h["disagreement_sigmas"] is None:
            out.append(f"the run's halves: not checked ({h['reason']})")
        else:
            def vals(c):
                return ", ".join(f"{n} {v['value']:+.5f}" for n, v in c.items())
            verdict = "they agree" if r["consistent"] else "they DISAGREE: do not apply this estimate"
            out.append(f"the run's halves: {vals(h['changes'][0])} / {vals(h['changes'][1])}: "
                       f"{h['disagreement_sigmas']:.1f} standard errors apart at most (limit {h['limit_sigmas']:g}), "
                       f"their models {h['apart_px']:.2f} px apart at the edges (limit {h['limit_px']:.2f}): {verdict}")
    return "\n".join(out)


def main(argv=None) -> int:
    argv, extra = cli.split_passthrough(argv)
    ap = cli.parser(PROG, __doc__)
    ap.add_argument("--seq", required=True, help="EuRoC/ASL sequence folder (mav0/cam0/...)")
    ap.add_argument("--replay", required=True, help="the tvo_replay binary")
    ap.add_argument("--keyframes", type=int, default=40, help="frames adjusted, spread over the run (default 40)")
    ap.add_argument("--min-obs", type=int, default=3, help="a track is used when seen in this many of them (default 3)")
    ap.add_argument("--max-points", type=int, default=1500, help="at most this many tracks (default 1500)")
    ap.add_argument("--free", default="k1",
                    help="the parameters freed, comma-separated: f (the focal length, fu and fv by one "
                         "factor), k1, k2 (k1k2 is k1,k2; default k1)")
    ap.add_argument("--out", help="write the figures as JSON here")
    ap.add_argument("--write-yaml", metavar="FILE",
                    help="write the sequence's sensor.yaml with the estimated change applied here (for "
                         "tvo_replay --calib FILE; confirm it by replaying)")
    a = ap.parse_args(argv)
    try:
        a.free = parse_free(a.free)
    except ValueError as e:
        ap.error(f"--free: {e} (give f, k1 and/or k2, comma-separated)")
    if "f" in a.free and "k1" not in a.free:
        ap.error("--free: f needs k1 beside it (a focal length freed alone takes up a radial error)")
    if a.keyframes < 3:
        ap.error("--keyframes must be at least 3")
    if a.min_obs < 2:
        ap.error("--min-obs must be at least 2")
    if a.max_points < 20:
        ap.error("--max-points must be at least 20")
    return cli.run(ap.prog, lambda: _main(a, extra))


def _main(a, extra) -> int:
    yaml = trajio.find_cam_yaml(a.seq)
    if yaml is None:
        raise cli.Failure(f"{a.seq}: no mav0/cam0/sensor.yaml")
    try:
        cam = trajio.read_sensor_yaml(yaml)
    except (OSError, ValueError) as e:
        raise cli.Failure(f"{yaml}: {e}") from e
    if cam.distortion_model != "equidistant":
        if not cam.distortion_model.startswith("radial") and cam.distortion_model not in ("none", "pinhole"):
            raise cli.Failure(f"{yaml}: distortion model {cam.distortion_model!r} is not radial-tangential, "
                              "equidistant or none")
    if not os.access(a.replay, os.X_OK):
        raise cli.Failure(f"{a.replay}: not an executable")
    with tempfile.TemporaryDirectory() as tmp:
        traj_p, tracks_p = os.path.join(tmp, "traj.txt"), os.path.join(tmp, "tracks.csv")
        # the VO keeps the lens as configured (its own refinement off): the check judges the calibration
        # as given; a later --set lens_refine=1 among the passed arguments turns the refinement back on
        cmd = [a.replay, "--euroc", a.seq, "--scale", "none", "--out", traj_p, "--tracks", tracks_p, "--quiet",
               "--set", "lens_refine=0"] + extra
        p = subprocess.run(cmd, capture_output=True, text=True)
        if p.returncode != 0:
            msg = (p.stderr.strip().splitlines() or ["(no message)"])[-1]
            raise cli.Failure(f"tvo_replay failed (exit {p.returncode}): {msg}")
        traj = trajio.read_tum(traj_p)
        t, ids, xy = read_tracks(tracks_p)
    r = check(cam, traj, t, ids, xy, a.keyframes, a.min_obs, a.max_points, a.free)
    if not a.quiet:
        print(format_report(r))
    if a.out:
        with open(a.out, "w") as f:
            json.dump(r, f, indent=1)
    if a.write_yaml and not r.get("consistent", False):
        h = r["halves"]
        raise cli.Failure(f"{a.write_yaml} not written: the run's halves "
                          + (f"disagree ({h['disagreement_sigmas']:.1f} standard errors apart)"
                             if h["disagreement_sigmas"] is not None else f"could not be checked ({h['reason']})"))
    if a.write_yaml:
        d = list(r["distortion"])
        for i, n in enumerate(("k1", "k2")):
            if n in r["change"]:
                d[i] += r["change"][n]["value"]
        s = 1.0 + (r["change"]["f"]["value"] if "f" in r["change"] else 0.0)
        fu, fv, cu, cv = r["intrinsics"]
        cam.intrinsics = (s * fu, s * fv, cu, cv)
        cam.distortion_model, cam.distortion = r["model"], tuple(d)
        try:
            trajio.write_sensor_yaml(a.write_yaml, cam)
        except OSError as e:
            raise cli.Failure(f"cannot write {a.write_yaml}: {e}") from e
    return 0


if __name__ == "__main__":
    sys.exit(main())
