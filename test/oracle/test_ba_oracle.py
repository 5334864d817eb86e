# SPDX-License-Identifier: Apache-2.0
"""Windowed bundle adjustment (tvo_ba_solve) against scipy.optimize.least_squares on the same problem.

Same model on both sides: residuals are the two components of (projection - observation) in normalised
coordinates, loss='huber' with f_scale = the C config's huber (scipy applies it per residual component, as
tvo_ba does), poses parametrised by the left increment T <- (R(omega) R0, R(omega) t0 + v) of the start pose,
points by X0 + dx, the first two poses fixed. scipy minimises with 'trf' and a finite-difference Jacobian to
tight tolerances. Checked: the initial costs agree to 1e-12 (same cost definition, 1/2 sum rho), the final
costs within 1 % (they agree to about 1e-6: tinyvo stops when a step gains less than 1e-6 of the cost),
the poses within 1e-4 rad / 1e-3 m of scipy's optimum, the points within 1e-3 m (median) and 5e-2 m (all:
with outliers the Huber cost has flat valleys along the depth of a few points, where the two solvers stop at
slightly different places of nearly equal cost).
"""
import ctypes

import numpy as np
import pytest

scipy_opt = pytest.importorskip("scipy.optimize")


def _blas_single_thread():
    """One BLAS thread for numpy's and scipy's OpenBLAS: trf's small dense SVDs are 20x slower with
    threads spinning against a busy CPU. Linux only (the loaded libraries are read from /proc); a no-op
    elsewhere."""
    try:
        with open("/proc/self/maps") as f:
            paths = {line.split()[-1] for line in f if "openblas" in line.lower()}
    except OSError:
        return
    for path in sorted(paths):
        lib = ctypes.CDLL(path)
        for name in ("openblas_set_num_threads64_", "scipy_openblas_set_num_threads64_", "scipy_openblas_set_num_threads",
                     "openblas_set_num_threads"):
            fn = getattr(lib, name, None)
            if fn is not None:
                fn(ctypes.c_int(1))


class Pose(ctypes.Structure):
    _fields_ = [("R", ctypes.c_double * 9), ("t", ctypes.c_double * 3)]


class Obs(ctypes.Structure):
    _fields_ = [("pose", ctypes.c_int32), ("point", ctypes.c_int32), ("x", ctypes.c_double),
                ("y", ctypes.c_double)]


class Config(ctypes.Structure):
    _fields_ = [("max_iterations", ctypes.c_int32), ("huber", ctypes.c_double), ("lambda_init", ctypes.c_double),
                ("min_depth", ctypes.c_double), ("max_poses", ctypes.c_int32), ("max_points", ctypes.c_int32),
                ("max_obs", ctypes.c_int32), ("max_point_cond", ctypes.c_double)]


class Problem(ctypes.Structure):
    _fields_ = [("n_poses", ctypes.c_int32), ("T_c_w", ctypes.POINTER(Pose)),
                ("pose_fixed", ctypes.POINTER(ctypes.c_uint8)), ("n_points", ctypes.c_int32),
                ("X", ctypes.c_void_p), ("point_fixed", ctypes.POINTER(ctypes.c_uint8)),
                ("n_obs", ctypes.c_int32), ("obs", ctypes.POINTER(Obs)),
                ("n_rot", ctypes.c_int32), ("rot", ctypes.c_void_p),  # no rotation priors (left 0 / NULL)
                ("prior", ctypes.c_void_p)]  # no point priors (NULL)


class Report(ctypes.Structure):
    _fields_ = [("iterations", ctypes.c_int32), ("accepted", ctypes.c_int32), ("flags", ctypes.c_int32),
                ("points_skipped", ctypes.c_int32), ("cost_initial", ctypes.c_double),
                ("cost_final", ctypes.c_double), ("obs_skipped", ctypes.c_int32), ("poses_free", ctypes.c_int32)]


FOCAL = 458.0


def rotvec_to_rot(w):
    th = np.linalg.norm(w)
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if th < 1e-8:
        return np.eye(3) + K + 0.5 * K @ K
    return np.eye(3) + np.sin(th) / th * K + (1.0 - np.cos(th)) / th ** 2 * K @ K


def make_problem(seed, n_poses=4, n_points=30, noise_px=0.5, outlier_frac=0.1):
    rng = np.random.default_rng(seed)
    Rs, ts = [], []
    for i in range(n_poses):
        R = rotvec_to_rot(np.array([0.01 * np.sin(0.7 * i), 0.04 * i - 0.05, 0.005 * i]))
        c = np.array([0.3 * i, 0.03 * np.sin(1.3 * i), 0.02 * i])
        Rs.append(R)
        ts.append(-R @ c)
    z = rng.uniform(4.0, 9.0, n_points)
    X = np.stack([0.5 + 0.5 * z * rng.uniform(-1, 1, n_points), 0.4 * z * rng.uniform(-1, 1, n_points), z], 1)
    obs = []
    for j in range(n_points):
        for i in range(n_poses):
            P = Rs[i] @ X[j] + ts[i]
            u = P[:2] / P[2] + noise_px / FOCAL * rng.standard_normal(2)
            if rng.uniform() < outlier_frac:
                a = rng.uniform(-np.pi, np.pi)
                u = u + rng.uniform(15.0, 40.0) / FOCAL * np.array([np.cos(a), np.sin(a)])
            obs.append((i, j, u[0], u[1]))
    # perturbed start: free poses and all points
    R0, t0 = [R.copy() for R in Rs], [t.copy() for t in ts]
    for i in range(2, n_poses):
        R0[i] = rotvec_to_rot(rng.uniform(-0.01, 0.01, 3)) @ Rs[i]
        t0[i] = ts[i] + rng.uniform(-0.03, 0.03, 3)
    X0 = X + rng.uniform(-0.1, 0.1, X.shape)
    return R0, t0, X0, obs


def residuals(params, R0, t0, X0, obs, n_fixed):
    n_free = len(R0) - n_fixed
    Rs, ts = list(R0), list(t0)
    for k in range(n_free):
        d = params[6 * k:6 * k + 6]
        Rd = rotvec_to_rot(d[:3])
        Rs[n_fixed + k] = Rd @ R0[n_fixed + k]
        ts[n_fixed + k] = Rd @ t0[n_fixed + k] + d[3:]
    X = X0 + params[6 * n_free:].reshape(-1, 3)
    R_all, t_all = np.stack(Rs), np.stack(ts)
    P = np.einsum("kab,kb->ka", R_all[obs[:, 0].astype(int)], X[obs[:, 1].astype(int)]) + t_all[obs[:, 0].astype(int)]
    out = (P[:, :2] / P[:, 2:3] - obs[:, 2:4]).ravel()
    return out, Rs, ts, X


def tvo_solve(lib, R0, t0, X0, obs, n_fixed, cfg_kw):
    lib.tvo_ba_config_default.argtypes = [ctypes.POINTER(Config)]
    lib.tvo_ba_scratch_size.argtypes = [ctypes.POINTER(Config)]
    lib.tvo_ba_scratch_size.restype = ctypes.c_size_t
    lib.tvo_ba_solve.argtypes = [ctypes.POINTER(Config), ctypes.POINTER(Problem), ctypes.c_void_p, ctypes.c_size_t,
                                 ctypes.POINTER(Report)]
    lib.tvo_ba_solve.restype = ctypes.c_int
    cfg = Config()
    lib.tvo_ba_config_default(ctypes.byref(cfg))
    for k, v in cfg_kw.items():
        setattr(cfg, k, v)
    n_poses, n_points = len(R0), len(X0)
    cfg.max_poses, cfg.max_points, cfg.max_obs = n_poses, n_points, len(obs)
    size = lib.tvo_ba_scratch_size(ctypes.byref(cfg))
    assert size > 0
    scratch = ctypes.create_string_buffer(size)
    poses = (Pose * n_poses)()
    for i in range(n_poses):
        poses[i].R[:] = list(R0[i].ravel())
        poses[i].t[:] = list(t0[i])
    fixed = (ctypes.c_uint8 * n_poses)(*([1] * n_fixed + [0] * (n_poses - n_fixed)))
    X = np.ascontiguousarray(X0, dtype=np.float64).copy()
    obs_c = (Obs * len(obs))(*[Obs(int(i), int(j), x, y) for (i, j, x, y) in obs])
    prob = Problem(n_poses, poses, fixed, n_points, X.ctypes.data, None, len(obs), obs_c)
    rep = Report()
    st = lib.tvo_ba_solve(ctypes.byref(cfg), ctypes.byref(prob), scratch, size, ctypes.byref(rep))
    assert st == 0
    Rs = [np.array(poses[i].R[:]).reshape(3, 3) for i in range(n_poses)]
    ts = [np.array(poses[i].t[:]) for i in range(n_poses)]
    return rep, Rs, ts, X


def rot_angle(Ra, Rb):
    c = (np.trace(Ra.T @ Rb) - 1.0) / 2.0
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


@pytest.mark.parametrize("seed,outliers", [(1, 0.0), (2, 0.1), (3, 0.1)])
def test_ba_matches_scipy_huber(tvo, seed, outliers):
    _blas_single_thread()
    n_fixed = 2
    R0, t0, X0, obs = make_problem(seed, outlier_frac=outliers)
    obs = np.array(obs, dtype=np.float64)
    huber = 2.0 / FOCAL
    rep, Rc, tc, Xc = tvo_solve(tvo, R0, t0, X0, obs, n_fixed, {"max_iterations": 200, "huber": huber})

    n_params = 6 * (len(R0) - n_fixed) + 3 * len(X0)
    fun = lambda p: residuals(p, R0, t0, X0, obs, n_fixed)[0]  # noqa: E731
    res = scipy_opt.least_squares(fun, np.zeros(n_params), loss="huber", f_scale=huber, method="trf",
                                  x_scale="jac", ftol=1e-15, xtol=1e-15, gtol=1e-15, max_nfev=2000)
    _, Rs, ts, Xs = residuals(res.x, R0, t0, X0, obs, n_fixed)
    r0 = fun(np.zeros(n_params))
    a = np.abs(r0)
    cost0 = 0.5 * np.sum(np.where(a <= huber, r0 * r0, 2.0 * huber * a - huber * huber))

    rot = max(rot_angle(Rc[i], Rs[i]) for i in range(len(R0)))
    trans = max(float(np.linalg.norm(tc[i] - ts[i])) for i in range(len(R0)))
    pts = float(np.max(np.abs(Xc - Xs)))
    pts_med = float(np.median(np.linalg.norm(Xc - Xs, axis=1)))
    print(f"seed {seed} outliers {outliers}: tinyvo cost {rep.cost_initial:.6g} -> {rep.cost_final:.8g} "
          f"({rep.iterations} iterations, {rep.accepted} accepted, flags {rep.flags}); scipy {res.cost:.8g} "
          f"({res.nfev} evaluations, status {res.status}); pose diff {rot:.2e} rad {trans:.2e} m, points max {pts:.2e} m median {pts_med:.2e} m")
    assert res.success
    assert rep.cost_initial == pytest.approx(cost0, rel=1e-12)
    assert rep.cost_final == pytest.approx(res.cost, rel=0.01)
    assert rep.cost_final < rep.cost_initial
    assert rot < 1e-4
    assert trans < 1e-3
    assert pts_med < 1e-3
    assert pts < 5e-2
