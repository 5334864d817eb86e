# SPDX-License-Identifier: Apache-2.0
"""Trajectory and EuRoC/ASL file I/O shared by tinyvo's Python tools.

Conventions (see ../shared/DESIGN.md):
- A pose ``T_a_b`` is a 4x4 float64 matrix mapping points from frame b to frame a.
- Timestamps are int64 nanoseconds inside the tools; TUM files store float seconds.
- Quaternions are handled in EuRoC order (w, x, y, z) unless a name says ``xyzw``.
- EuRoC ground truth is the pose of the body (IMU) frame in the world, ``T_W_B``; a camera pose is
  ``T_W_C = T_W_B @ T_BS`` with ``T_BS`` (= ``T_B_C``) read from the camera's ``sensor.yaml``.

File formats:
- EuRoC ground-truth csv: ``#timestamp, p_RS_R_x [m], ..., q_RS_w [], q_RS_x [], ...`` comma separated,
  the first 8 columns required, further columns ignored.
- Ground-truth txt: the same 8 columns, space separated.
- TUM: ``t tx ty tz qx qy qz qw`` with t in seconds (TUM RGB-D's groundtruth.txt: the camera's pose).
- KITTI odometry poses: 12 numbers per line, the row-major 3x4 camera pose ``T_W_C`` of frame i; no
  timestamps (they are in the sequence's ``times.txt``, one per line in seconds).

``detect_pose_format`` tells these apart by their header, separator, column count, timestamp magnitude
and quaternion norm, and refuses (ValueError, saying why) a file it cannot place; ``read_trajectory``
reads any of them, detected or named.
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

# --------------------------------------------------------------------------------------------------
# pose helpers


def pose_from_pq(p, q_wxyz) -> np.ndarray:
    """(N,3) positions + (N,4) quaternions w,x,y,z -> (N,4,4) poses (quaternions are normalised)."""
    p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
    q = np.asarray(q_wxyz, dtype=np.float64).reshape(-1, 4)
    T = np.tile(np.eye(4), (len(p), 1, 1))
    T[:, :3, :3] = Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix()
    T[:, :3, 3] = p
    return T


def pq_from_pose(T):
    """(N,4,4) or (4,4) poses -> ((N,3) positions, (N,4) quaternions w,x,y,z with w >= 0)."""
    T = np.asarray(T, dtype=np.float64).reshape(-1, 4, 4)
    q = Rotation.from_matrix(T[:, :3, :3]).as_quat()[:, [3, 0, 1, 2]]
    q[q[:, 0] < 0] *= -1.0
    return T[:, :3, 3].copy(), q


def inv_pose(T) -> np.ndarray:
    """Inverse of (..., 4, 4) rigid transforms."""
    T = np.asarray(T, dtype=np.float64)
    R = T[..., :3, :3]
    Ri = np.swapaxes(R, -1, -2)
    out = np.zeros_like(T)
    out[..., :3, :3] = Ri
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Ri, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


def interpolate_poses(t_ns_src, T_src, t_ns_query) -> np.ndarray:
    """Poses at ``t_ns_query`` (clamped to the source range): linear in position, slerp in rotation."""
    t_src = np.asarray(t_ns_src, dtype=np.int64)
    tq = np.clip(np.asarray(t_ns_query, dtype=np.int64), t_src[0], t_src[-1])
    # float seconds relative to the start keep ns precision over hours
    x = (t_src - t_src[0]).astype(np.float64) * 1e-9
    xq = (tq - t_src[0]).astype(np.float64) * 1e-9
    from scipy.spatial.transform import Slerp

    rots = Rotation.from_matrix(T_src[:, :3, :3])
    out = np.tile(np.eye(4), (len(xq), 1, 1))
    out[:, :3, :3] = Slerp(x, rots)(xq).as_matrix()
    for k in range(3):
        out[:, k, 3] = np.interp(xq, x, T_src[:, k, 3])
    return out


# --------------------------------------------------------------------------------------------------
# trajectories


@dataclass
class Trajectory:
    """Timestamps (int64 ns) and poses (N,4,4) ``T_W_X`` of some frame X (body or camera)."""

    t_ns: np.ndarray
    poses: np.ndarray
    frame: str = "body"  # "body" or "camera"; informative only
    source: str = ""

    def __post_init__(self):
        self.t_ns = np.asarray(self.t_ns, dtype=np.int64)
        self.poses = np.asarray(self.poses, dtype=np.float64).reshape(-1, 4, 4)
        if len(self.t_ns) != len(self.poses):
            raise ValueError("timestamps and poses differ in length")

    def __len__(self):
        return len(self.t_ns)

    @property
    def positions(self):
        return self.poses[:, :3, 3]

    def to_camera(self, T_BS) -> "Trajectory":
        """Body poses T_W_B -> camera poses T_W_C = T_W_B @ T_BS."""
        return Trajectory(self.t_ns.copy(), self.poses @ np.asarray(T_BS, dtype=np.float64), "camera",
                          self.source)

    def to_body(self, T_BS) -> "Trajectory":
        """Camera poses T_W_C -> body poses T_W_B = T_W_C @ inv(T_BS)."""
        return Trajectory(self.t_ns.copy(), self.poses @ inv_pose(np.asarray(T_BS, dtype=np.float64)),
                          "body", self.source)


def _check_rows(a: np.ndarray, path: str, ncols: int) -> np.ndarray:
    if a.ndim != 2 or a.shape[1] < ncols or len(a) == 0:
        raise ValueError(f"{path}: expected rows of at least {ncols} numbers")
    if not np.all(np.isfinite(a[:, :ncols])):
        raise ValueError(f"{path}: non-finite values")
    return a


def _read_numeric_rows(path: str, ncols: int):
    """Rows of numbers (comma or space separated, '#' comments). Timestamps kept exact as int64 ns
    when they are integers (possibly with a '.000' tail), since float64 loses ns at 1.4e18."""
    ts, vals = [], []
    with open(path, "r", encoding="utf-8") as f:
        for lineno, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#") or line[0].isalpha():
                continue
            parts = [p for p in re.split(r"[,\s]+", line) if p]
            if len(parts) < ncols:
                raise ValueError(f"{path}:{lineno}: expected {ncols} columns, got {len(parts)}")
            ts.append(parts[0])
            try:
                vals.append([float(p) for p in parts[1:ncols]])
            except ValueError as e:
                raise ValueError(f"{path}:{lineno}: {e}") from None
    if not ts:
        raise ValueError(f"{path}: no data rows")
    return ts, _check_rows(np.array(vals, dtype=np.float64), path, ncols - 1)


def _ns_from_token(s: str) -> int:
    """One timestamp token -> int64 ns. Integers with 12+ digits are ns (a fraction is rounded away);
    shorter values are seconds, parsed digit by digit so that no precision is lost."""
    neg = s.startswith("-")
    s2 = s.lstrip("+-")
    head, _, tail = s2.partition(".")
    if head.isdigit() and (tail == "" or tail.isdigit()):
        if len(head) >= 12:
            v = int(head) + (1 if tail and tail[0] >= "5" else 0)
        else:
            v = int(head) * 1_000_000_000 + int((tail + "000000000")[:9])
            v += 1 if len(tail) > 9 and tail[9] >= "5" else 0
    else:
        f = float(s2)
        v = int(round(f if f >= 1e11 else f * 1e9))
    return -v if neg else v


def _ns_from_strings(ts):
    return np.array([_ns_from_token(s) for s in ts], dtype=np.int64)


def read_euroc_groundtruth(path: str) -> Trajectory:
    """EuRoC ground truth (body poses): a ``mav0`` dataset folder, its
    ``state_groundtruth_estimate0/data.csv``, or a space separated ``*.txt`` with the same 8 columns.
    Timestamps in ns (values below 1e11 are taken as seconds)."""
    path = str(path)
    if os.path.isdir(path):
        for cand in ("mav0/state_groundtruth_estimate0/data.csv", "state_groundtruth_estimate0/data.csv",
                     "data.csv"):
            if os.path.isfile(os.path.join(path, cand)):
                path = os.path.join(path, cand)
                break
        else:
            raise FileNotFoundError(f"{path}: no state_groundtruth_estimate0/data.csv")
    ts, v = _read_numeric_rows(path, 8)
    t_ns = _ns_from_strings(ts)
    T = pose_from_pq(v[:, 0:3], v[:, 3:7])
    order = np.argsort(t_ns, kind="stable")
    return Trajectory(t_ns[order], T[order], "body", path)


def read_cam_frames(cam_dir: str):
    """(timestamps in ns (int64 array), image file names) of an ASL camera folder (``mav0/cam0``), from
    its ``data.csv`` (``timestamp_ns,filename``), in the file's order. Blank lines and ``#`` comments are
    skipped; a row without two fields or with a timestamp that is not an integer raises ValueError with
    its line number."""
    path = os.path.join(cam_dir, "data.csv")
    t_ns, names = [], []
    with open(path, "r", encoding="utf-8") as f:
        for lineno, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            parts = [p.strip() for p in line.split(",")]
            if len(parts) < 2 or not parts[1] or not parts[0].isdigit():
                raise ValueError(f"{path}:{lineno}: expected 'timestamp_ns,filename', got {line!r}")
            t_ns.append(int(parts[0]))
            names.append(parts[1])
    return np.array(t_ns, dtype=np.int64), names


def write_euroc_groundtruth(path: str, traj: Trajectory) -> None:
    """Write body poses as an EuRoC ``state_groundtruth_estimate0/data.csv`` (8 columns)."""
    p, q = pq_from_pose(traj.poses)
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write("#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], "
                "q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z []\n")
        for t, pi, qi in zip(traj.t_ns, p, q):
            f.write(f"{int(t)},{pi[0]:.9f},{pi[1]:.9f},{pi[2]:.9f},"
                    f"{qi[0]:.12f},{qi[1]:.12f},{qi[2]:.12f},{qi[3]:.12f}\n")


def read_tum(path: str, frame: str = "camera") -> Trajectory:
    """TUM trajectory ``t tx ty tz qx qy qz qw`` (t in seconds; ns if above 1e11)."""
    ts, v = _read_numeric_rows(str(path), 8)
    t_ns = _ns_from_strings(ts)
    q_wxyz = v[:, [6, 3, 4, 5]]
    if np.any(np.linalg.norm(q_wxyz, axis=1) < 1e-9):
        raise ValueError(f"{path}: zero quaternion")
    return Trajectory(t_ns, pose_from_pq(v[:, 0:3], q_wxyz), frame, str(path))


def read_replay_header(path: str) -> dict:
    """The ``key=value`` fields of the comment line tvo_replay writes first in a trajectory
    (``# tvo_replay frame=camera source=euroc camera=cam1 scale=none: t tx ty tz qx qy qz qw``): whose
    pose each row is (``frame``, and ``camera`` of the dataset ``source``) and in which unit (``scale``).
    {} for a file without one (another program's trajectory)."""
    with open(path, "r", encoding="utf-8") as f:
        for line in f:
            s = line.strip()
            if not s:
                continue
            if not s.startswith("#"):
                break
            if s.startswith("# tvo_replay "):
                fields = s[len("# tvo_replay "):].split(":", 1)[0].split()
                return dict(tok.split("=", 1) for tok in fields if "=" in tok)
    return {}


def write_tum(path: str, traj: Trajectory) -> None:
    """Write a TUM trajectory (seconds with 9 decimals, exact for int64 ns)."""
    p, q = pq_from_pose(traj.poses)
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        for t, pi, qi in zip(traj.t_ns, p, q):
            t = int(t)
            sign = "-" if t < 0 else ""
            f.write(f"{sign}{abs(t) // 1_000_000_000}.{abs(t) % 1_000_000_000:09d} "
                    f"{pi[0]:.9f} {pi[1]:.9f} {pi[2]:.9f} {qi[1]:.12f} {qi[2]:.12f} {qi[3]:.12f} {qi[0]:.12f}\n")


def associate(t_a, t_b, max_diff_ns: int = 10_000_000):
    """Nearest-timestamp association, one to one. Returns index arrays (ia, ib) such that
    |t_a[ia] - t_b[ib]| <= max_diff_ns, with each index used once, in increasing t_a order."""
    t_a = np.asarray(t_a, dtype=np.int64)
    t_b = np.asarray(t_b, dtype=np.int64)
    order_b = np.argsort(t_b, kind="stable")
    sb = t_b[order_b]
    pos = np.searchsorted(sb, t_a)
    best = np.full(len(t_a), -1, dtype=np.int64)
    bestd = np.full(len(t_a), np.iinfo(np.int64).max, dtype=np.int64)
    for cand in (pos - 1, pos):
        ok = (cand >= 0) & (cand < len(sb))
        c = np.where(ok, cand, 0)
        d = np.where(ok, np.abs(sb[c] - t_a), np.iinfo(np.int64).max)
        better = d < bestd
        best = np.where(better, c, best)
        bestd = np.where(better, d, bestd)
    ia, ib, used = [], [], set()
    for i in np.argsort(bestd, kind="stable"):
        if best[i] < 0 or bestd[i] > max_diff_ns or best[i] in used:
            continue
        used.add(int(best[i]))
        ia.append(i)
        ib.append(order_b[best[i]])
    ia = np.array(ia, dtype=np.int64)
    ib = np.array(ib, dtype=np.int64)
    o = np.argsort(ia)
    return ia[o], ib[o]


# --------------------------------------------------------------------------------------------------
# sensor.yaml


@dataclass
class CameraInfo:
    """A camera as described by an ASL ``sensor.yaml``."""

    width: int = 752
    height: int = 480
    intrinsics: tuple = (458.654, 457.296, 367.215, 248.375)  # fu fv cu cv [px]
    distortion_model: str = "radial-tangential"
    distortion: tuple = (-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05)  # k1 k2 p1 p2
    rate_hz: float = 20.0
    T_BS: np.ndarray = field(default_factory=lambda: EUROC_CAM0_T_BS.copy())
    comment: str = "VI-Sensor cam0 (MT9M034)"


EUROC_CAM0_T_BS = np.array([
    [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975],
    [0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768],
    [-0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949],
    [0.0, 0.0, 0.0, 1.0]])


def _yaml_list(text: str, key: str):
    m = re.search(rf"^\s*{key}\s*:\s*\[([^\]]*)\]", text, re.M | re.S)
    if not m:
        return None
    return [float(x) for x in re.split(r"[,\s]+", m.group(1).strip()) if x]


def _yaml_scalar(text: str, key: str):
    m = re.search(rf"^\s*{key}\s*:\s*([^#\n]+)", text, re.M)
    return m.group(1).strip() if m else None


def read_sensor_yaml(path: str) -> CameraInfo:
    """Parse an ASL camera ``sensor.yaml`` (the subset EuRoC uses). Raises ValueError when malformed."""
    with open(path, "r", encoding="utf-8") as f:
        text = f.read()
    m = re.search(r"T_BS\s*:(.*?)data\s*:\s*\[([^\]]*)\]", text, re.S)
    if not m:
        raise ValueError(f"{path}: no T_BS data")
    tbs = np.array([float(x) for x in re.split(r"[,\s]+", m.group(2).strip()) if x], dtype=np.float64)
    if tbs.size != 16 or not np.all(np.isfinite(tbs)):
        raise ValueError(f"{path}: T_BS must have 16 finite numbers")
    cam = CameraInfo(T_BS=tbs.reshape(4, 4))
    res = _yaml_list(text, "resolution")
    intr = _yaml_list(text, "intrinsics")
    dist = _yaml_list(text, "distortion_coefficients")
    if res is None or len(res) != 2 or intr is None or len(intr) != 4:
        raise ValueError(f"{path}: resolution/intrinsics missing or malformed")
    cam.width, cam.height = int(res[0]), int(res[1])
    cam.intrinsics = tuple(intr)
    cam.distortion = tuple(dist or ())
    cam.distortion_model = _yaml_scalar(text, "distortion_model") or "none"
    rate = _yaml_scalar(text, "rate_hz")
    cam.rate_hz = float(rate) if rate else 20.0
    cam.comment = _yaml_scalar(text, "comment") or ""
    return cam


def write_sensor_yaml(path: str, cam: CameraInfo) -> None:
    """Write an ASL camera ``sensor.yaml`` in EuRoC's layout."""
    T = np.asarray(cam.T_BS, dtype=np.float64)
    rows = [", ".join(repr(float(v)) for v in T[r]) for r in range(4)]
    fmt = lambda xs: ", ".join(repr(float(v)) for v in xs)  # noqa: E731
    rate = int(cam.rate_hz) if float(cam.rate_hz).is_integer() else cam.rate_hz
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.write("%YAML:1.0\n# General sensor definitions.\nsensor_type: camera\n")
        f.write(f"comment: {cam.comment}\n\n# Sensor extrinsics wrt. the body-frame.\nT_BS:\n"
                f"  cols: 4\n  rows: 4\n  data: [{rows[0]},\n         {rows[1]},\n"
                f"         {rows[2]},\n         {rows[3]}]\n\n")
        f.write(f"# Camera specific definitions.\nrate_hz: {rate}\nresolution: [{cam.width}, {cam.height}]\n"
                f"camera_model: pinhole\nintrinsics: [{fmt(cam.intrinsics)}] #fu, fv, cu, cv\n"
                f"distortion_model: {cam.distortion_model}\n"
                f"distortion_coefficients: [{fmt(cam.distortion)}]\n\n")


def find_cam_yaml(path: str, cam: str = "cam0"):
    """The ``sensor.yaml`` of ``cam`` belonging to a EuRoC folder or to a ground-truth csv inside one,
    or None."""
    p = os.path.abspath(str(path))
    cands = []
    if os.path.isdir(p):
        cands += [os.path.join(p, "mav0", cam, "sensor.yaml"), os.path.join(p, cam, "sensor.yaml")]
    else:
        d = os.path.dirname(p)  # .../mav0/state_groundtruth_estimate0
        cands.append(os.path.join(os.path.dirname(d), cam, "sensor.yaml"))
    for c in cands:
        if os.path.isfile(c):
            return c
    return None


# --------------------------------------------------------------------------------------------------
# pose-file formats: EuRoC csv, TUM, KITTI

POSE_FORMATS = ("euroc", "tum", "kitti")
_QTOKEN = re.compile(r"^q(?:_[a-z0-9]+)*_?([wxyz])$")


def _header_and_rows(path: str, max_rows: int = 50):
    """(comment/header lines, first data rows as token lists, separator ',' or ' ')."""
    header, rows, comma = [], [], False
    with open(path, "r", encoding="utf-8") as f:
        for line in f:
            s = line.strip()
            if not s:
                continue
            if s.startswith("#") or s[0].isalpha():
                if not rows:
                    header.append(s)
                continue
            comma = comma or ("," in s)
            rows.append([p for p in re.split(r"[,\s]+", s) if p])
            if len(rows) >= max_rows:
                break
    return header, rows, "," if comma else " "


def _header_quat_order(header) -> str | None:
    """'wxyz' or 'xyzw' when the header names the quaternion components (EuRoC's q_RS_w, TUM's qx)."""
    order = []
    for h in header:
        for tok in re.split(r"[^A-Za-z0-9_]+", h.lower()):
            m = _QTOKEN.match(tok)
            if m and m.group(1) not in order:
                order.append(m.group(1))
    if "w" in order and "x" in order:
        return "wxyz" if order.index("w") < order.index("x") else "xyzw"
    return None


def detect_pose_format(path: str) -> tuple:
    """(format, why) of a pose file: 'euroc' (EuRoC ground-truth csv: ns, position, quaternion w first),
    'tum' (seconds, position, quaternion x y z w) or 'kitti' (12 numbers of a 3x4 pose, no time).
    Raises ValueError naming what was seen when the file could be more than one of them (e.g. 8
    space-separated columns with nanosecond timestamps) or none."""
    path = str(path)
    header, rows, sep = _header_and_rows(path)
    if not rows:
        raise ValueError(f"{path}: no data rows")
    ncols = {len(r) for r in rows}
    if len(ncols) != 1:
        raise ValueError(f"{path}: rows of {sorted(ncols)} columns: not one pose format")
    n = ncols.pop()
    try:
        vals = np.array([[float(x) for x in r] for r in rows])
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None
    seen = f"{n} {'comma' if sep == ',' else 'space'}-separated columns"
    order = _header_quat_order(header)
    if n == 12 and order is None:
        R = vals[0, [0, 1, 2, 4, 5, 6, 8, 9, 10]].reshape(3, 3)
        if np.allclose(R @ R.T, np.eye(3), atol=1e-2) and np.linalg.det(R) > 0:
            return "kitti", f"{seen}, a rotation in columns 1-3, 5-7, 9-11: KITTI poses"
        raise ValueError(f"{path}: {seen} but no rotation matrix in them: not KITTI poses; "
                         "pass --gt-format to say what it is")
    if n < 8:
        raise ValueError(f"{path}: {seen}: neither EuRoC (t p q, 8+), TUM (8) nor KITTI (12)")
    qn = np.linalg.norm(vals[:, 4:8], axis=1)
    if not np.all(np.abs(qn - 1.0) < 0.01):
        raise ValueError(f"{path}: {seen}, but columns 5-8 are not a unit quaternion (norm {qn[0]:.4g}): "
                         "not a EuRoC or TUM pose file")
    t0 = abs(vals[0, 0])
    unit = "ns" if t0 >= 1e11 else "s"
    if order == "wxyz":
        return "euroc", f"the header names the quaternion w first ({seen}): EuRoC"
    if order == "xyzw":
        if n != 8:
            raise ValueError(f"{path}: a TUM header (qx .. qw) but {n} columns (TUM has 8)")
        return "tum", f"the header names the quaternion x y z w ({seen}): TUM"
    if sep == "," and unit == "ns":
        return "euroc", f"{seen} with timestamps in ns: EuRoC csv"
    if sep == " " and n == 8 and unit == "s":
        return "tum", f"{seen} with timestamps in seconds: TUM"
    raise ValueError(f"{path}: cannot tell the quaternion order: {seen}, no header naming the columns, "
                     f"timestamps in {unit} ({t0:.3g}); EuRoC files are comma-separated with ns and w "
                     "first, TUM files space-separated with seconds and w last; pass --gt-format euroc|tum")


def read_kitti_times(path: str) -> np.ndarray:
    """KITTI times.txt: one time in seconds per line -> int64 ns (rounded)."""
    out = []
    with open(str(path), "r", encoding="utf-8") as f:
        for lineno, line in enumerate(f, 1):
            s = line.strip()
            if not s:
                continue
            try:
                t = float(s)
            except ValueError:
                raise ValueError(f"{path}:{lineno}: bad time {s!r}") from None
            if not np.isfinite(t) or t < 0:
                raise ValueError(f"{path}:{lineno}: bad time {s!r}")
            out.append(int(round(t * 1e9)))
    if not out:
        raise ValueError(f"{path}: no times")
    return np.array(out, dtype=np.int64)


def find_kitti_times(poses_path: str):
    """times.txt for a KITTI poses file: next to it, or KITTI's sequences/<seq>/times.txt beside
    poses/<seq>.txt; None when there is none."""
    p = os.path.abspath(str(poses_path))
    d, stem = os.path.dirname(p), os.path.splitext(os.path.basename(p))[0]
    for c in (os.path.join(d, "times.txt"), os.path.join(os.path.dirname(d), "sequences", stem, "times.txt")):
        if os.path.isfile(c):
            return c
    return None


def read_kitti_poses(path: str, times=None) -> Trajectory:
    """KITTI poses (camera poses T_W_C, 12 numbers per line). times: int64 ns per pose, or the path of
    times.txt, or None to look for it (find_kitti_times); the counts must agree."""
    path = str(path)
    rows = []
    with open(path, "r", encoding="utf-8") as f:
        for lineno, line in enumerate(f, 1):
            s = line.strip()
            if not s:
                continue
            parts = s.split()
            if len(parts) != 12:
                raise ValueError(f"{path}:{lineno}: expected 12 numbers (a 3x4 pose), got {len(parts)}")
            try:
                rows.append([float(x) for x in parts])
            except ValueError as e:
                raise ValueError(f"{path}:{lineno}: {e}") from None
    if not rows:
        raise ValueError(f"{path}: no poses")
    if times is None:
        times = find_kitti_times(path)
        if times is None:
            raise ValueError(f"{path}: KITTI poses carry no timestamps and no times.txt was found next to them "
                             "or in ../sequences/<seq>/: pass --gt-times FILE")
    if isinstance(times, (str, os.PathLike)):
        times = read_kitti_times(times)
    times = np.asarray(times, dtype=np.int64)
    if len(times) != len(rows):
        raise ValueError(f"{path}: {len(rows)} poses but {len(times)} times")
    a = np.array(rows, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{path}: non-finite values")
    T = np.tile(np.eye(4), (len(a), 1, 1))
    T[:, :3, :4] = a.reshape(-1, 3, 4)
    R = T[:, :3, :3]
    if not np.allclose(R @ np.swapaxes(R, 1, 2), np.eye(3), atol=1e-3):
        raise ValueError(f"{path}: a rotation block is not a rotation")
    return Trajectory(times, T, "camera", path)


def write_kitti_poses(path: str, traj: Trajectory) -> None:
    """Write KITTI poses (12 numbers per line; the times are not written)."""
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        for T in traj.poses:
            f.write(" ".join(f"{v:.9e}" for v in T[:3, :4].reshape(-1)) + "\n")


def read_trajectory(path: str, fmt: str = "auto", times=None):
    """(Trajectory, format, why) from a pose file or a dataset folder (EuRoC: mav0's ground truth, body
    poses; TUM RGB-D: groundtruth.txt; KITTI sequence: its poses file), the format detected
    (detect_pose_format) or named ('euroc', 'tum', 'kitti'). TUM and KITTI poses are camera poses."""
    path = str(path)
    if fmt not in ("auto",) + POSE_FORMATS:
        raise ValueError(f"unknown pose format {fmt!r} (auto, euroc, tum, kitti)")
    if os.path.isdir(path):
        if os.path.isfile(os.path.join(path, "groundtruth.txt")) and fmt in ("auto", "tum"):
            path, fmt, why = os.path.join(path, "groundtruth.txt"), "tum", "a TUM RGB-D folder's groundtruth.txt"
            return read_tum(path, "camera"), fmt, why
        if os.path.isfile(os.path.join(path, "times.txt")) and fmt in ("auto", "kitti"):
            name = os.path.basename(os.path.normpath(path))
            for c in (os.path.join(path, "poses.txt"),
                      os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(path))), "poses", name + ".txt")):
                if os.path.isfile(c):
                    tr = read_kitti_poses(c, os.path.join(path, "times.txt") if times is None else times)
                    return tr, "kitti", "a KITTI sequence folder's poses and times.txt"
            raise ValueError(f"{path}: a KITTI sequence folder without poses (poses.txt, ../../poses/{name}.txt)")
        return read_euroc_groundtruth(path), "euroc", "a EuRoC folder's state_groundtruth_estimate0/data.csv"
    why = f"named ({fmt})"
    if fmt == "auto":
        fmt, why = detect_pose_format(path)
    if fmt == "euroc":
        return read_euroc_groundtruth(path), fmt, why
    if fmt == "tum":
        return read_tum(path, "camera"), fmt, why
    return read_kitti_poses(path, times), fmt, why
