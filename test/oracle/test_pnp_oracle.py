# SPDX-License-Identifier: Apache-2.0
"""PnP (tvo_p3p, tvo_pnp_refine, tvo_pnp_ransac) against OpenCV's solveP3P, solvePnP and solvePnPRansac.

The same random problems go through both, in normalised coordinates (K = I, no distortion, so OpenCV's
pixel errors are tinyvo's normalised ones): f = 450 px, 752x480 image, points 2..12 m in front of a
camera at a random pose (centre within +-5 m, any rotation). Tolerances, stated per test:
1. P3P, noise-free triples: tinyvo's and OpenCV's (SOLVEPNP_P3P and SOLVEPNP_AP3P) solution sets agree:
   every exact solution of either (reprojects the three points within 1e-7, positive depths) is among
   the other's within 1e-6 (rotation angle in rad + translation in m), in >= 97 % of the triples; the
   true pose is among tinyvo's in every triple.
2. Refinement, 0.5 px noise, no outliers, a start 2 deg / 10 cm off: with a Huber width above every
   residual tinyvo minimises the same least-squares cost as solvePnP(SOLVEPNP_ITERATIVE,
   useExtrinsicGuess): the poses agree within 1e-8 rad and 1e-8 m, the rms within 1e-10.
3. RANSAC, 0.5 px noise and 30 % outliers, the default configuration (1.5 px threshold) against
   solvePnPRansac (SOLVEPNP_ITERATIVE, the same threshold, 0.999, 200 iterations): both within
   0.1 deg / 3 cm of the truth and of each other, inlier flags 97 % the same (OpenCV's at the pose it
   returns), and tinyvo's median errors at most 1.2 x OpenCV's + 0.002 deg / 0.2 mm.
The figures are printed with pytest -s.
"""
import ctypes

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

F = 450.0
HW, HH = 376.0 / F, 240.0 / F


class PnpConfig(ctypes.Structure):
    _fields_ = [("threshold", ctypes.c_double), ("confidence", ctypes.c_double),
                ("max_iterations", ctypes.c_int32), ("refine_iterations", ctypes.c_int32),
                ("huber", ctypes.c_double), ("min_inliers", ctypes.c_int32), ("seed", ctypes.c_uint64),
                ("use_guess", ctypes.c_int32), ("rot_prior", ctypes.c_double * 9),
                ("rot_prior_weight", ctypes.c_double)]


class Pose(ctypes.Structure):
    _fields_ = [("R", ctypes.c_double * 9), ("t", ctypes.c_double * 3)]


def pose_arrays(p):
    return np.array(p.R).reshape(3, 3), np.array(p.t)


class TvoPnp:
    """ctypes binding of the PnP module with a preallocated scratch buffer."""

    def __init__(self, lib, max_points=2048):
        self.lib = lib
        lib.tvo_pnp_scratch_size.restype = ctypes.c_size_t
        lib.tvo_pnp_scratch_size.argtypes = [ctypes.c_int32]
        lib.tvo_pnp_config_default.argtypes = [ctypes.POINTER(PnpConfig)]
        lib.tvo_p3p.restype = ctypes.c_int
        lib.tvo_p3p.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.POINTER(Pose * 4)]
        lib.tvo_pnp_ransac.restype = ctypes.c_int
        lib.tvo_pnp_ransac.argtypes = [ctypes.POINTER(PnpConfig), ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int32,
                                       ctypes.POINTER(Pose), ctypes.c_void_p, ctypes.POINTER(ctypes.c_int32),
                                       ctypes.c_void_p, ctypes.c_size_t]
        lib.tvo_pnp_refine.restype = ctypes.c_int
        lib.tvo_pnp_refine.argtypes = [ctypes.POINTER(PnpConfig), ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
                                       ctypes.c_int32, ctypes.POINTER(Pose), ctypes.c_void_p,
                                       ctypes.POINTER(ctypes.c_int32), ctypes.POINTER(ctypes.c_double)]
        self.size = lib.tvo_pnp_scratch_size(max_points)
        self.scratch = ctypes.create_string_buffer(self.size)
        self.max_points = max_points

    def config(self, **kw):
        cfg = PnpConfig()
        self.lib.tvo_pnp_config_default(ctypes.byref(cfg))
        for k, v in kw.items():
            setattr(cfg, k, v)
        return cfg

    def p3p(self, X, x):
        X = np.ascontiguousarray(X, np.float64)
        x = np.ascontiguousarray(x, np.float64)
        out = (Pose * 4)()
        n = self.lib.tvo_p3p(X.ctypes.data, x.ctypes.data, ctypes.byref(out))
        return [pose_arrays(out[i]) for i in range(n)]

    def ransac(self, X, x, cfg=None):
        X = np.ascontiguousarray(X, np.float64)
        x = np.ascontiguousarray(x, np.float64)
        n = len(X)
        assert n <= self.max_points
        pose, ni = Pose(), ctypes.c_int32(0)
        pose.R[0] = pose.R[4] = pose.R[8] = 1.0
        mask = np.zeros(n, np.uint8)
        st = self.lib.tvo_pnp_ransac(ctypes.byref(cfg) if cfg is not None else None, X.ctypes.data, x.ctypes.data,
                                     n, ctypes.byref(pose), mask.ctypes.data, ctypes.byref(ni), self.scratch,
                                     self.size)
        R, t = pose_arrays(pose)
        return st, R, t, mask.astype(bool), ni.value

    def refine(self, X, x, R0, t0, cfg=None, use=None):
        X = np.ascontiguousarray(X, np.float64)
        x = np.ascontiguousarray(x, np.float64)
        n = len(X)
        pose = Pose()
        for i in range(9):
            pose.R[i] = float(R0.flat[i])
        for i in range(3):
            pose.t[i] = float(t0[i])
        mask = np.zeros(n, np.uint8)
        ni, rms = ctypes.c_int32(0), ctypes.c_double(0.0)
        use_p = None if use is None else np.ascontiguousarray(use, np.uint8)
        st = self.lib.tvo_pnp_refine(ctypes.byref(cfg) if cfg is not None else None, X.ctypes.data, x.ctypes.data,
                                     None if use_p is None else use_p.ctypes.data, n, ctypes.byref(pose),
                                     mask.ctypes.data, ctypes.byref(ni), ctypes.byref(rms))
        R, t = pose_arrays(pose)
        return st, R, t, mask.astype(bool), ni.value, rms.value


@pytest.fixture(scope="module")
def pnp(tvo):
    return TvoPnp(tvo)


def rodrigues(w):
    R, _ = cv2.Rodrigues(np.asarray(w, np.float64).reshape(3, 1))
    return R


def rot_err(Ra, Rb):
    """Angle of Ra^T Rb from the chord |Ra - Rb|_F = 2 sqrt(2) sin(angle / 2): accurate near 0, unlike arccos."""
    return float(2.0 * np.arcsin(min(1.0, np.linalg.norm(Ra - Rb) / (2.0 * np.sqrt(2.0)))))


def centre(R, t):
    return -R.T @ t


def scene(rng, n, noise_px=0.0, outliers=0.0):
    """Random T_c_w (R, t) and n world points in front of it; x normalised, with noise and outliers."""
    axis = rng.normal(size=3)
    R = rodrigues(axis / np.linalg.norm(axis) * np.pi * rng.uniform())
    C = rng.uniform(-5, 5, size=3)
    t = -R @ C
    u = rng.uniform(-HW, HW, size=n)
    v = rng.uniform(-HH, HH, size=n)
    z = rng.uniform(2, 12, size=n)
    Xc = np.column_stack([u * z, v * z, z])
    Xw = (Xc - t) @ R  # R^T (Xc - t)
    x = np.column_stack([u, v]) + rng.normal(scale=noise_px / F, size=(n, 2))
    out = rng.uniform(size=n) < outliers
    x[out] = np.column_stack([rng.uniform(-HW, HW, out.sum()), rng.uniform(-HH, HH, out.sum())])
    return R, t, Xw, x, out


def exact_solution(R, t, X, x, tol=1e-7):
    Xc = X @ R.T + t
    if np.any(Xc[:, 2] <= 0):
        return False
    return bool(np.max(np.abs(Xc[:, :2] / Xc[:, 2:] - x)) < tol)


def cv_p3p(X, x, flags):
    K = np.eye(3)
    try:
        n, rvecs, tvecs = cv2.solveP3P(X.reshape(3, 1, 3), x.reshape(3, 1, 2), K, None, flags=flags)
    except cv2.error:
        return []
    return [(rodrigues(rvecs[i]), np.asarray(tvecs[i]).ravel()) for i in range(n)]


def matched(a, sols, tol=1e-6):
    return any(rot_err(a[0], b[0]) + np.linalg.norm(a[1] - b[1]) < tol for b in sols)


def test_p3p_against_opencv(pnp):
    rng = np.random.default_rng(11)
    trials, agree, true_found, counts = 300, {"P3P": 0, "AP3P": 0}, 0, []
    for _ in range(trials):
        R, t, X, x, _ = scene(rng, 3)
        ours = pnp.p3p(X, x)
        counts.append(len(ours))
        assert all(exact_solution(Ra, ta, X, x) for Ra, ta in ours)
        true_found += matched((R, t), ours, 1e-9)
        for name, flag in (("P3P", cv2.SOLVEPNP_P3P), ("AP3P", cv2.SOLVEPNP_AP3P)):
            theirs = [s for s in cv_p3p(X, x, flag) if exact_solution(s[0], s[1], X, x)]
            ok = all(matched(s, ours) for s in theirs) and all(matched(s, theirs) for s in ours)
            agree[name] += ok
    print(f"\np3p: {trials} triples, tinyvo solution counts {np.bincount(counts, minlength=5).tolist()}, "
          f"true pose found {true_found}, solution sets equal to OpenCV P3P in {agree['P3P']}, AP3P in {agree['AP3P']}")
    assert true_found == trials
    assert max(agree.values()) >= 0.97 * trials


def test_refine_matches_solvepnp_iterative(pnp):
    rng = np.random.default_rng(12)
    cfg = pnp.config(huber=1.0, refine_iterations=50, min_inliers=3)  # Huber above every residual: least squares
    worst_r = worst_t = worst_rms = 0.0
    for _ in range(20):
        R, t, X, x, _ = scene(rng, 200, noise_px=0.5)
        axis = rng.normal(size=3)
        R0 = rodrigues(axis / np.linalg.norm(axis) * np.radians(2.0)) @ R
        t0 = t + rng.normal(size=3) * 0.1 / np.sqrt(3)
        st, Rt, tt, _, ni, rms = pnp.refine(X, x, R0, t0, cfg)
        assert st == 0 and ni >= 190
        rv0, _ = cv2.Rodrigues(R0)
        ok, rv, tv = cv2.solvePnP(X, x, np.eye(3), None, rvec=rv0.copy(), tvec=t0.reshape(3, 1).copy(),
                                  useExtrinsicGuess=True, flags=cv2.SOLVEPNP_ITERATIVE)
        assert ok
        Rc, tc = rodrigues(rv), tv.ravel()
        Xc = X @ Rc.T + tc
        e = np.linalg.norm(Xc[:, :2] / Xc[:, 2:] - x, axis=1)
        rms_cv = float(np.sqrt(np.mean(e[e < cfg.threshold] ** 2)))
        worst_r = max(worst_r, rot_err(Rt, Rc))
        worst_t = max(worst_t, float(np.linalg.norm(tt - tc)))
        worst_rms = max(worst_rms, abs(rms - rms_cv))
    print(f"\nrefine vs solvePnP ITERATIVE: worst rotation difference {worst_r:.2e} rad, translation {worst_t:.2e} m, "
          f"rms {worst_rms:.2e}")
    assert worst_r < 1e-8 and worst_t < 1e-8 and worst_rms < 1e-10


def test_ransac_against_solvepnpransac(pnp):
    rng = np.random.default_rng(13)
    cfg = pnp.config()
    er_t, ec_t, er_c, ec_c, cv_own, agree = [], [], [], [], [], []
    ni_sum = 0
    for _ in range(30):
        R, t, X, x, out = scene(rng, 200, noise_px=0.5, outliers=0.3)
        st, Rt, tt, mask, ni = pnp.ransac(X, x, cfg)
        assert st == 0
        ni_sum += ni
        ok, rv, tv, inl = cv2.solvePnPRansac(X, x, np.eye(3), None, iterationsCount=200,
                                             reprojectionError=cfg.threshold, confidence=0.999,
                                             flags=cv2.SOLVEPNP_ITERATIVE)
        assert ok
        Rc, tc = rodrigues(rv), tv.ravel()
        # OpenCV returns the inliers of its best minimal-sample model, before its final refinement: compare
        # with the inliers of the pose it returns instead (same threshold)
        Xc = X @ Rc.T + tc
        cmask = (Xc[:, 2] > 1e-6) & (np.linalg.norm(Xc[:, :2] / Xc[:, 2:] - x, axis=1) < cfg.threshold)
        cv_own.append(len(inl))
        C, Ct, Cc = centre(R, t), centre(Rt, tt), centre(Rc, tc)
        er_t.append(np.degrees(rot_err(Rt, R)))
        ec_t.append(np.linalg.norm(Ct - C))
        er_c.append(np.degrees(rot_err(Rc, R)))
        ec_c.append(np.linalg.norm(Cc - C))
        assert er_t[-1] < 0.1 and ec_t[-1] < 0.03
        assert er_c[-1] < 0.1 and ec_c[-1] < 0.03
        assert np.degrees(rot_err(Rt, Rc)) < 0.1 and np.linalg.norm(Ct - Cc) < 0.03
        agree.append(np.mean(mask == cmask))
        assert agree[-1] >= 0.97
        assert ni == mask.sum() and np.sum(mask & out) <= 3  # outliers that fall within 1.5 px by chance
    mt, mc = np.median(er_t), np.median(er_c)
    mtc, mcc = np.median(ec_t), np.median(ec_c)
    print(f"\nransac (30 scenes, 30 % outliers): median rotation error tinyvo {mt:.4f} deg, OpenCV {mc:.4f} deg; "
          f"median centre error tinyvo {mtc * 1000:.2f} mm, OpenCV {mcc * 1000:.2f} mm; inlier flags equal "
          f"{100 * np.min(agree):.1f} % at worst; mean inliers tinyvo {ni_sum / 30:.1f}, OpenCV (returned) "
          f"{np.mean(cv_own):.1f}")
    assert mt <= 1.2 * mc + 0.002
    assert mtc <= 1.2 * mcc + 0.0002
