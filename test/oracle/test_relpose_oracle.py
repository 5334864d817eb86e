# SPDX-License-Identifier: Apache-2.0
"""Relative pose (tinyvo_relpose_estimate) against OpenCV findEssentialMat + recoverPose.

1. Synthetic scenes (f = 460, 752x480, 0.5 px noise, 30 % outliers): tinyvo is at least as accurate
   as OpenCV on the same input.
2. EuRoC V1_01_easy_head cam0 -> cam1 pairs (exactly known T_cam1_cam0 from the sensor.yaml files),
   the issue's reference correspondences (OpenCV goodFeaturesToTrack 500, LK 21x21 3 levels,
   undistortPoints) and a forward-backward-checked variant: median rotation / translation-direction
   errors of both pipelines, rotation-only results, share of tracks consistent with the true pose.
3. V1_01_easy_keyframes consecutive pairs (ground truth + T_BS of cam0): failures (> 10 deg).
The figures are printed (pytest -s) and the module's helpers are reused by test/bench/bench_relpose.py.
"""
import ctypes
import pathlib

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")


class RelposeConfig(ctypes.Structure):
    _fields_ = [("method", ctypes.c_int), ("threshold", ctypes.c_double), ("confidence", ctypes.c_double),
                ("max_iters", ctypes.c_int32), ("seed", ctypes.c_uint64), ("min_parallax_deg", ctypes.c_double),
                ("min_inliers", ctypes.c_int32), ("use_homography", ctypes.c_int32),
                ("refine_iters", ctypes.c_int32)]


class Relpose(ctypes.Structure):
    _fields_ = [("R", ctypes.c_double * 9), ("t", ctypes.c_double * 3), ("inliers", ctypes.c_int32),
                ("flags", ctypes.c_int32), ("parallax_deg", ctypes.c_double), ("iterations", ctypes.c_int32),
                ("R_alt", ctypes.c_double * 9), ("t_alt", ctypes.c_double * 3), ("R_rot", ctypes.c_double * 9)]


FLAG_LOW_PARALLAX, FLAG_ROTATION_ONLY, FLAG_HOMOGRAPHY, FLAG_LOW_CONFIDENCE, FLAG_AMBIGUOUS = 1, 2, 4, 8, 16


class TvoRelpose:
    """ctypes binding of tvo_relpose_estimate with a preallocated scratch buffer."""

    def __init__(self, lib, max_points=4096):
        self.lib = lib
        lib.tvo_relpose_scratch_size.restype = ctypes.c_size_t
        lib.tvo_relpose_scratch_size.argtypes = [ctypes.c_int32]
        lib.tvo_relpose_config_default.argtypes = [ctypes.POINTER(RelposeConfig)]
        lib.tvo_relpose_estimate.restype = ctypes.c_int
        lib.tvo_relpose_estimate.argtypes = [ctypes.POINTER(RelposeConfig), ctypes.c_void_p, ctypes.c_void_p,
                                             ctypes.c_int32, ctypes.POINTER(Relpose), ctypes.c_void_p,
                                             ctypes.c_void_p, ctypes.c_size_t]
        self.size = lib.tvo_relpose_scratch_size(max_points)
        self.scratch = ctypes.create_string_buffer(self.size)
        self.max_points = max_points

    def config(self, **kw):
        cfg = RelposeConfig()
        self.lib.tvo_relpose_config_default(ctypes.byref(cfg))
        for k, v in kw.items():
            setattr(cfg, k, v)
        return cfg

    def estimate(self, x1, x2, cfg=None, mask=None):
        x1 = np.ascontiguousarray(x1, dtype=np.float64)
        x2 = np.ascontiguousarray(x2, dtype=np.float64)
        n = len(x1)
        assert n <= self.max_points
        out = Relpose()
        if mask is None:
            mask = np.zeros(n, np.uint8)
        st = self.lib.tvo_relpose_estimate(ctypes.byref(cfg) if cfg is not None else None,
                                           x1.ctypes.data, x2.ctypes.data, n, ctypes.byref(out),
                                           mask.ctypes.data, self.scratch, self.size)
        R = np.array(out.R).reshape(3, 3)
        t = np.array(out.t)
        return st, R, t, out, mask


def rot_err_deg(Ra, Rb):
    c = (np.trace(Ra.T @ Rb) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def t_err_deg(ta, tb):
    na, nb = np.linalg.norm(ta), np.linalg.norm(tb)
    if na == 0 or nb == 0:
        return 180.0
    return float(np.degrees(np.arccos(np.clip(np.dot(ta, tb) / (na * nb), -1.0, 1.0))))


def rodrigues(w):
    R, _ = cv2.Rodrigues(np.asarray(w, np.float64).reshape(3, 1))
    return R


def synthetic_scene(rng, n=300, max_deg=20.0, noise_px=0.5, outliers=0.3, f=460.0, w=752, h=480):
    """Random pose and 3D points (1..8 m) seen by both cameras; returns x1, x2 (normalised), R, t."""
    axis = rng.normal(size=3)
    R = rodrigues(axis / np.linalg.norm(axis) * np.radians(max_deg) * rng.uniform())
    t = rng.normal(size=3)
    t /= np.linalg.norm(t)
    hw, hh = w / 2 / f, h / 2 / f
    x1 = np.empty((n, 2))
    x2 = np.empty((n, 2))
    i = 0
    while i < n:
        p = np.array([rng.uniform(-hw, hw), rng.uniform(-hh, hh), 1.0]) * rng.uniform(1, 8)
        q = R @ p + t
        if q[2] < 0.5 or abs(q[0] / q[2]) > hw or abs(q[1] / q[2]) > hh:
            continue
        x1[i] = p[:2] / p[2]
        x2[i] = q[:2] / q[2]
        i += 1
    x1 += rng.normal(scale=noise_px / f, size=x1.shape)
    x2 += rng.normal(scale=noise_px / f, size=x2.shape)
    out = rng.uniform(size=n) < outliers
    x2[out] = np.column_stack([rng.uniform(-hw, hw, out.sum()), rng.uniform(-hh, hh, out.sum())])
    return x1, x2, R, t


def opencv_pose(x1, x2, thr):
    """OpenCV's plain pipeline on normalised points: findEssentialMat (RANSAC) + recoverPose."""
    E, mask = cv2.findEssentialMat(x1, x2, focal=1.0, pp=(0.0, 0.0), method=cv2.RANSAC, prob=0.999,
                                   threshold=thr)
    if E is None or E.shape != (3, 3):
        E = None if E is None else E[:3]
    if E is None:
        return np.eye(3), np.zeros(3)
    _, R, t, _ = cv2.recoverPose(E, x1, x2, focal=1.0, pp=(0.0, 0.0), mask=mask)
    return R, t.ravel()


# ---- EuRoC helpers -------------------------------------------------------------------------------

def _yaml_list(txt, key):
    import re
    m = re.search(key + r"[^\[]*\[([^\]]*)\]", txt)
    return np.array([float(v) for v in m.group(1).replace("\n", " ").split(",")])


def read_sensor_yaml(path):
    """T_BS (4x4), K, distortion of an EuRoC sensor.yaml (plain parsing: cv2 rejects the %YAML:1.0 file)."""
    txt = pathlib.Path(path).read_text()
    T = _yaml_list(txt[txt.index("T_BS"):], "data:").reshape(4, 4)
    intr = _yaml_list(txt, "intrinsics:")
    dist = _yaml_list(txt, "distortion_coefficients:")
    K = np.array([[intr[0], 0, intr[2]], [0, intr[1], intr[3]], [0, 0, 1.0]])
    return T, K, dist


def read_frames(cam_dir):
    rows = []
    for line in (cam_dir / "data.csv").read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        ts, name = line.split(",")
        rows.append((int(ts), cam_dir / "data" / name.strip()))
    return rows


def track_opencv(img1, img2, K1, D1, K2, D2, fb_px=None, max_level=2):
    """goodFeaturesToTrack 500 + LK 21x21 (max_level + 1 levels) + undistortPoints -> normalised
    x1, x2; with fb_px, tracks whose backward track misses the start by more than fb_px are dropped
    (tinyvo's LK matches OpenCV's to 0.00000 px, so this stands for tinyvo's fb-checked front end)."""
    p1 = cv2.goodFeaturesToTrack(img1, 500, 0.01, 10)
    p2, st, _ = cv2.calcOpticalFlowPyrLK(img1, img2, p1, None, winSize=(21, 21), maxLevel=max_level)
    ok = st.ravel() == 1
    if fb_px is not None:
        pb, st2, _ = cv2.calcOpticalFlowPyrLK(img2, img1, p2, None, winSize=(21, 21), maxLevel=max_level)
        ok &= (st2.ravel() == 1) & (np.linalg.norm((pb - p1).reshape(-1, 2), axis=1) < fb_px)
    p1, p2 = p1[ok], p2[ok]
    n1 = cv2.undistortPoints(p1, K1, D1).reshape(-1, 2)
    n2 = cv2.undistortPoints(p2, K2, D2).reshape(-1, 2)
    return n1.astype(np.float64), n2.astype(np.float64)


def quat_to_R(w, x, y, z):
    q = np.array([w, x, y, z]) / np.linalg.norm([w, x, y, z])
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def read_groundtruth(path):
    data = np.loadtxt(path, delimiter=",", comments="#")
    return data[:, 0].astype(np.int64), data


def gt_pose(ts_arr, data, ts, tol_ns=2_000_000):
    i = int(np.argmin(np.abs(ts_arr - ts)))
    if abs(int(ts_arr[i]) - ts) > tol_ns:
        return None
    T = np.eye(4)
    T[:3, :3] = quat_to_R(*data[i, 4:8])
    T[:3, 3] = data[i, 1:4]
    return T


def skew(t):
    return np.array([[0.0, -t[2], t[1]], [t[2], 0.0, -t[0]], [-t[1], t[0], 0.0]])


def sampson_px(R, t, x1, x2, f):
    """|Sampson error| in pixels of normalised correspondences under the pose (R, t)."""
    E = skew(np.asarray(t, np.float64) / max(np.linalg.norm(t), 1e-300)) @ R
    a = np.column_stack([x1, np.ones(len(x1))])
    b = np.column_stack([x2, np.ones(len(x2))])
    Ex, Etb = a @ E.T, b @ E
    d = np.sqrt(Ex[:, 0] ** 2 + Ex[:, 1] ** 2 + Etb[:, 0] ** 2 + Etb[:, 1] ** 2)
    return np.abs(np.sum(b * Ex, 1)) / np.maximum(d, 1e-300) * f


def euroc_stereo_errors(tvo_rp, data_dir, fb_px=None, max_level=2, step=1):
    """Per-pair (rot, t) errors of tinyvo and OpenCV on the V1_01_easy_head cam0 -> cam1 pairs, the
    flags, and the share of correspondences within 1 px of their true epipolar lines."""
    root = data_dir / "euroc" / "V1_01_easy_head" / "mav0"
    T0, K0, D0 = read_sensor_yaml(root / "cam0" / "sensor.yaml")
    T1, K1, D1 = read_sensor_yaml(root / "cam1" / "sensor.yaml")
    T10 = np.linalg.inv(T1) @ T0  # cam0 -> cam1
    Rg, tg = T10[:3, :3], T10[:3, 3]
    f0 = read_frames(root / "cam0")
    f1 = dict(read_frames(root / "cam1"))
    thr = 1.0 / K0[0, 0]
    cfg = tvo_rp.config(threshold=thr, seed=1)
    res = []
    for ts, path0 in f0[::step]:
        if ts not in f1:
            continue
        a = cv2.imread(str(path0), cv2.IMREAD_GRAYSCALE)
        b = cv2.imread(str(f1[ts]), cv2.IMREAD_GRAYSCALE)
        x1, x2 = track_opencv(a, b, K0, D0, K1, D1, fb_px=fb_px, max_level=max_level)
        st, R, t, out, mask = tvo_rp.estimate(x1, x2, cfg)
        Ro, to = opencv_pose(x1, x2, thr)
        good = float(np.mean(sampson_px(Rg, tg, x1, x2, K0[0, 0]) < 1.0))
        m = mask.astype(bool)
        rms = lambda Rx, tx: float(np.sqrt(np.mean(sampson_px(Rx, tx, x1[m], x2[m], K0[0, 0]) ** 2)))  # noqa: E731
        fit = (rms(R, t), rms(Rg, tg)) if m.sum() >= 5 and np.linalg.norm(t) > 0 else (np.nan, np.nan)
        res.append((rot_err_deg(R, Rg), t_err_deg(t, tg), rot_err_deg(Ro, Rg), t_err_deg(to, tg), out.flags,
                    good) + fit)
    return np.array(res)


def euroc_keyframe_errors(tvo_rp, data_dir):
    """Per-pair errors on consecutive V1_01_easy_keyframes pairs (cam0, ground truth with T_BS)."""
    root = data_dir / "euroc" / "V1_01_easy_keyframes" / "mav0"
    Tbs, K, D = read_sensor_yaml(data_dir / "euroc" / "V1_01_easy_head" / "mav0" / "cam0" / "sensor.yaml")
    gts, gtd = read_groundtruth(root / "state_groundtruth_estimate0" / "data.csv")
    frames = read_frames(root / "cam0")
    thr = 1.0 / K[0, 0]
    cfg = tvo_rp.config(threshold=thr, seed=1)
    res = []
    for (ta, pa), (tb, pb) in zip(frames[:-1], frames[1:]):
        Ta, Tb = gt_pose(gts, gtd, ta), gt_pose(gts, gtd, tb)
        if Ta is None or Tb is None:
            continue
        Tca, Tcb = Ta @ Tbs, Tb @ Tbs
        Tba = np.linalg.inv(Tcb) @ Tca  # frame a -> frame b
        a = cv2.imread(str(pa), cv2.IMREAD_GRAYSCALE)
        b = cv2.imread(str(pb), cv2.IMREAD_GRAYSCALE)
        x1, x2 = track_opencv(a, b, K, D, K, D)
        if len(x1) < 8:
            res.append((180.0, 180.0, 180.0, 180.0, -1, 0.0))
            continue
        good = float(np.mean(sampson_px(Tba[:3, :3], Tba[:3, 3], x1, x2, K[0, 0]) < 1.0))
        st, R, t, out, _ = tvo_rp.estimate(x1, x2, cfg)
        if st != 0:
            R, t, flags = np.eye(3), np.zeros(3), -1
        else:
            flags = out.flags
        Ro, to = opencv_pose(x1, x2, thr)
        res.append((rot_err_deg(R, Tba[:3, :3]), t_err_deg(t, Tba[:3, 3]), rot_err_deg(Ro, Tba[:3, :3]),
                    t_err_deg(to, Tba[:3, 3]), flags, good))
    return np.array(res)


# ---- tests ---------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def rp(tvo):
    return TvoRelpose(tvo)


def test_synthetic_vs_opencv(rp):
    rng = np.random.default_rng(2024)
    ours, cvs, worse = [], [], 0
    trials = 40
    for k in range(trials):
        x1, x2, R, t = synthetic_scene(rng)
        st, Re, te, out, mask = rp.estimate(x1, x2, rp.config(seed=k))
        assert st == 0
        Ro, to = opencv_pose(x1, x2, 1.0 / 460)
        ours.append((rot_err_deg(Re, R), t_err_deg(te, t)))
        cvs.append((rot_err_deg(Ro, R), t_err_deg(to, t)))
        # OpenCV right (rot < 0.5, t < 3 deg) but tinyvo not
        if ours[-1][0] > 0.5 or ours[-1][1] > 3.0:
            worse += cvs[-1][0] < 0.5 and cvs[-1][1] < 3.0
    ours, cvs = np.median(ours, axis=0), np.median(cvs, axis=0)
    print(f"\nsynthetic median rot/t error: tinyvo {ours[0]:.4f}/{ours[1]:.3f} deg, "
          f"OpenCV {cvs[0]:.4f}/{cvs[1]:.3f} deg, tinyvo wrong where OpenCV right {worse}/{trials}")
    assert ours[0] <= cvs[0] * 1.1 + 0.005
    assert ours[1] <= cvs[1] * 1.1 + 0.05
    assert worse <= 1


def test_bad_input_ctypes(rp):
    x = np.zeros((4, 2))
    st, R, t, out, _ = rp.estimate(x, x, rp.config())
    assert st != 0 and np.all(np.isfinite(R)) and out.flags & FLAG_LOW_CONFIDENCE
    x1 = np.random.default_rng(1).uniform(-0.5, 0.5, (50, 2))
    x2 = x1.copy()
    x2[3, 0] = np.nan
    st, R, t, out, _ = rp.estimate(x1, x2, rp.config())
    assert st != 0 and np.all(np.isfinite(R))


def test_euroc_stereo(rp, data_dir):
    res = euroc_stereo_errors(rp, data_dir)
    assert len(res) > 50
    med = np.median(res[:, :4], axis=0)
    rot_only = int(np.sum((res[:, 4].astype(int) & FLAG_ROTATION_ONLY) != 0))
    print(f"\nEuRoC V1_01_easy_head cam0->cam1 ({len(res)} pairs): median rot/t error "
          f"tinyvo {med[0]:.3f}/{med[1]:.2f} deg, OpenCV {med[2]:.3f}/{med[3]:.2f} deg; rotation-only {rot_only}; "
          f"correspondences within 1 px of the true epipolar line: {np.median(res[:, 5]):.2f}")
    # the targets are 0.3 deg / 5 deg, met with these (reference) correspondences; docs/geometry.md
    # explains why the translation direction has no large margin on this single static scene
    assert med[0] <= med[2] and med[1] <= med[3]
    assert med[0] <= 0.3 and med[1] <= 5.0
    assert rot_only == 0  # an 11 cm baseline is a real translation
    # cleaner, forward-backward-checked tracks (as tinyvo's front end): the rotation model must not
    # absorb the baseline (it did on 18 of 19 pairs before the rotation-only rule required the
    # rotation to explain most of the epipolar inliers)
    for fb_px, max_level in ((1.0, 2), (0.5, 3)):
        fb = euroc_stereo_errors(rp, data_dir, fb_px=fb_px, max_level=max_level, step=5)
        fb_rot_only = int(np.sum((fb[:, 4].astype(int) & FLAG_ROTATION_ONLY) != 0))
        fmed = np.median(fb[:, :4], axis=0)
        print(f"{fb_px} px forward-backward check, {max_level + 1} levels ({len(fb)} pairs): tinyvo "
              f"{fmed[0]:.3f}/{fmed[1]:.2f} deg, OpenCV {fmed[2]:.3f}/{fmed[3]:.2f} deg; rotation-only "
              f"{fb_rot_only}; within 1 px of the true epipolar line: {np.median(fb[:, 5]):.2f}; RMS Sampson "
              f"error of tinyvo's inliers under its pose {np.nanmedian(fb[:, 6]):.3f} px, under the true pose "
              f"{np.nanmedian(fb[:, 7]):.3f} px")
        assert fb_rot_only == 0 and fmed[0] <= 1.0 and fmed[0] <= fmed[2]


def test_euroc_keyframes(rp, data_dir):
    res = euroc_keyframe_errors(rp, data_dir)
    fail_t = int(np.sum((res[:, 0] > 10) | (res[:, 1] > 10)))
    fail_o = int(np.sum((res[:, 2] > 10) | (res[:, 3] > 10)))
    rot_only = int(np.sum((res[:, 4] >= 0) & ((res[:, 4].astype(int) & FLAG_ROTATION_ONLY) != 0)))
    low_conf = int(np.sum((res[:, 4] < 0) | ((res[:, 4].astype(int) & FLAG_LOW_CONFIDENCE) != 0)))
    ok = (res[:, 4] >= 0) & ((res[:, 4].astype(int) & (FLAG_ROTATION_ONLY | FLAG_LOW_CONFIDENCE)) == 0)
    fail_unflagged = int(np.sum(ok & ((res[:, 0] > 10) | (res[:, 1] > 10))))
    print(f"\nEuRoC keyframes ({len(res)} pairs): > 10 deg failures tinyvo {fail_t} "
          f"(of which {fail_unflagged} without ROTATION_ONLY/LOW_CONFIDENCE flags; rotation-only {rot_only}, "
          f"low-confidence {low_conf}), OpenCV {fail_o}; median rot err tinyvo {np.median(res[:, 0]):.2f} "
          f"OpenCV {np.median(res[:, 2]):.2f} deg")
    rot_fail_t = int(np.sum(res[:, 0] > 10))
    rot_fail_o = int(np.sum(res[:, 2] > 10))
    print(f"rotation > 10 deg: tinyvo {rot_fail_t}, OpenCV {rot_fail_o}")
    failed = res[:, 0] > 10
    print(f"LK tracks within 1 px of the true epipolar line, median share: {np.median(res[failed, 5]):.2f} on "
          f"the failed pairs, {np.median(res[~failed, 5]):.2f} on the others; failed pairs among the "
          f"{int(np.sum(res[:, 5] < 0.2))} pairs with < 20 %: {int(np.sum(failed & (res[:, 5] < 0.2)))}")
    assert len(res) >= 80
    # LK 21x21 cannot follow most of these wide-baseline pairs, so both pipelines fail often; tinyvo
    # must not be worse on rotation (its rotation-only results have t = 0 and count as t failures)
    assert rot_fail_t <= rot_fail_o
