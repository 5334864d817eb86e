# SPDX-License-Identifier: Apache-2.0
"""Dataset builder for the per-DoF networks: VO features paired with ground-truth relative poses.

    tinyvo-dataset SEQDIR [SEQDIR ...] -o DATASET.npz [--replay build/x/examples/replay/tvo_replay]
                   [--work DIR] [--states 0,2] [--name SEQDIR=NAME ...] [--quiet]

For every EuRoC/ASL sequence folder (holding mav0/, real or rendered by tinyvo_tools.synth) it runs
``tvo_replay --features`` (or reads an existing features csv given as ``SEQDIR:FEATURES.csv``) and pairs
each frame's front-end features (the 11 columns of enum tvo_feature, nn.h) with the ground-truth relative
pose of the same step, prev -> cur, where prev is the previous frame the VO processed (the previous row of
the csv: that is the step tvo_replay integrates):

    T_W_C = T_W_B(t) @ T_BS                   (body -> camera, T_BS from mav0/cam0/sensor.yaml)
    T_prev_cur = inv(T_W_C(t_prev)) @ T_W_C(t_cur)   (absolute -> relative, in the camera frame of prev)
    target = [t (m), rotation vector of R (rad)]      (order tx ty tz rx ry rz, enum tvo_nn_dof)

Ground truth is interpolated at the image timestamps (linear/slerp, trajio.interpolate_poses); rows whose
timestamps fall outside the ground truth, or whose VO state is not in --states (default: 0 ok and
2 rotation-only, the states tvo_replay integrates) are dropped. Output .npz (read by train.py):
``features`` (N,11) float32, ``targets`` (N,6) float32, ``sequence`` (N,) str, plus ``t_ns``, ``state``,
``dt_gt`` for analysis and ``rel_scale`` (N,) (the VO's |t_k|/|t_(k-1)| of the row, 0 = not available). Normalisation statistics are NOT computed here: the trainer fits them on the
training sequences only and stores them in the model.
"""
from __future__ import annotations

import os
import subprocess
import sys
from typing import Dict, Optional, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from . import cli, nnfmt, trajio

CSV_COLUMNS = ["t_ns", "state", "relpose_flags", "pose_status", "inliers"] + nnfmt.FEATURES
# tvo_replay since the relative scale (vo.h, tvo_vo_result.rel_scale) appends these two; older files lack them
CSV_EXTRA = ["rel_scale", "rel_scale_points"]
STATE_OK, STATE_INIT, STATE_ROT_ONLY, STATE_LOST = 0, 1, 2, 3


def default_replay() -> Optional[str]:
    """The tvo_replay binary: $TVO_REPLAY, else the first build/*/examples/replay/tvo_replay found."""
    env = os.environ.get("TVO_REPLAY")
    if env:
        return env
    root = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
    bdir = os.path.join(root, "build")
    if os.path.isdir(bdir):
        for name in sorted(os.listdir(bdir)):
            p = os.path.join(bdir, name, "examples", "replay", "tvo_replay")
            if os.path.isfile(p) and os.access(p, os.X_OK):
                return p
    return None


def read_features_csv(path: str) -> Dict[str, np.ndarray]:
    """Parse tvo_replay's --features csv. Returns t_ns (int64), state, relpose_flags, pose_status,
    inliers (int), features (N,11 float64), rel_scale (N float64; 0 = not available, also for files
    written before the column existed) and rel_scale_points (N int). Raises ValueError on a malformed
    file."""
    rows = []
    with open(path, "r", encoding="utf-8") as f:
        for ln, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#") or line[0].isalpha():
                continue  # header / comments
            parts = line.split(",")
            nf = len(CSV_COLUMNS)
            if len(parts) not in (nf, nf + len(CSV_EXTRA)):
                raise ValueError(f"{path}:{ln}: {len(parts)} columns, expected {nf} or {nf + len(CSV_EXTRA)}")
            try:
                extra = (float(parts[nf]), int(parts[nf + 1])) if len(parts) > nf else (0.0, 0)
                rows.append((int(parts[0]), [int(p) for p in parts[1:5]], [float(p) for p in parts[5:nf]], extra))
            except ValueError as e:
                raise ValueError(f"{path}:{ln}: {e}") from None
    n = len(rows)
    out = {"t_ns": np.array([r[0] for r in rows], np.int64)}
    ints = np.array([r[1] for r in rows], np.int64).reshape(n, 4)
    for k, name in enumerate(CSV_COLUMNS[1:5]):
        out[name] = ints[:, k]
    out["features"] = np.array([r[2] for r in rows], np.float64).reshape(n, nnfmt.FEAT_COUNT)
    out["rel_scale"] = np.array([r[3][0] for r in rows], np.float64).reshape(n)
    out["rel_scale_points"] = np.array([r[3][1] for r in rows], np.int64).reshape(n)
    if not np.all(np.isfinite(out["rel_scale"])) or np.any(out["rel_scale"] < 0):
        raise ValueError(f"{path}: rel_scale must be finite and >= 0")
    return out


def relative_camera_poses(gt_body: trajio.Trajectory, T_BS: np.ndarray, t_prev_ns, t_cur_ns) -> np.ndarray:
    """Ground-truth T_prev_cur (N,4,4) in the camera frame of prev, from body poses T_W_B."""
    Tp = trajio.interpolate_poses(gt_body.t_ns, gt_body.poses, t_prev_ns) @ T_BS
    Tc = trajio.interpolate_poses(gt_body.t_ns, gt_body.poses, t_cur_ns) @ T_BS
    return trajio.inv_pose(Tp) @ Tc


def pose_targets(T_rel: np.ndarray) -> np.ndarray:
    """(N,4,4) -> (N,6) tx ty tz rx ry rz (metres, rotation vector rad)."""
    T_rel = np.asarray(T_rel, np.float64).reshape(-1, 4, 4)
    rv = Rotation.from_matrix(T_rel[:, :3, :3]).as_rotvec() if len(T_rel) else np.zeros((0, 3))
    return np.concatenate([T_rel[:, :3, 3], rv], axis=1)


def pair_sequence(feat: Dict[str, np.ndarray], gt_body: trajio.Trajectory, T_BS: np.ndarray,
                  states: Sequence[int] = (STATE_OK, STATE_ROT_ONLY)):
    """Pair feature rows with ground truth. Returns (features (M,11), targets (M,6), index of the kept
    csv rows). Row k's step is csv row k-1 -> k; the first row and rows outside the ground truth are
    dropped, as are rows whose state is not in ``states``."""
    t = feat["t_ns"]
    if len(t) < 2:
        return np.zeros((0, nnfmt.FEAT_COUNT)), np.zeros((0, 6)), np.zeros(0, np.int64)
    if np.any(np.diff(t) <= 0):
        raise ValueError("feature rows are not in increasing time order")
    k = np.arange(1, len(t))
    keep = np.isin(feat["state"][k], list(states))
    keep &= (t[k - 1] >= gt_body.t_ns[0]) & (t[k] <= gt_body.t_ns[-1])
    k = k[keep]
    T_rel = relative_camera_poses(gt_body, T_BS, t[k - 1], t[k])
    return feat["features"][k], pose_targets(T_rel), k


def run_replay(replay: str, seq_dir: str, features_csv: str, traj_out: str, extra=()) -> None:
    cmd = [replay, "--euroc", seq_dir, "--out", traj_out, "--features", features_csv, "--quiet", *extra]
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({r.returncode}): {r.stderr.strip()[-500:]}")


def sequence_paths(seq_dir: str):
    """(ground-truth csv, cam0 sensor.yaml) of a EuRoC folder."""
    gt = os.path.join(seq_dir, "mav0", "state_groundtruth_estimate0", "data.csv")
    yml = trajio.find_cam_yaml(seq_dir)
    if not os.path.isfile(gt):
        raise ValueError(f"{seq_dir}: no mav0/state_groundtruth_estimate0/data.csv")
    return gt, yml


def speedup_sequence(src: str, dst: str, factor: int) -> str:
    """Speed augmentation for TRAINING sequences: a EuRoC folder ``dst`` holding every ``factor``-th
    frame of ``src`` with image and ground-truth timestamps compressed in time by ``factor`` about the
    first frame: the same path flown ``factor`` times faster at the same frame rate (the images are
    not re-rendered: ``dst/mav0/cam0/data`` links to the source frames). Returns dst."""
    if factor < 2:
        raise ValueError("speed-up factor must be >= 2")
    gt_path, yml = sequence_paths(src)
    cam_src = os.path.dirname(yml) if yml else os.path.join(src, "mav0", "cam0")
    t_src, names = trajio.read_cam_frames(cam_src)
    rows = list(zip((int(t) for t in t_src), names))[::factor]
    if len(rows) < 2:
        raise ValueError(f"{src}: too few frames for a x{factor} speed-up")
    t0 = rows[0][0]
    cam_dst = os.path.join(dst, "mav0", "cam0")
    gt_dst = os.path.join(dst, "mav0", "state_groundtruth_estimate0")
    os.makedirs(cam_dst, exist_ok=True)
    os.makedirs(gt_dst, exist_ok=True)
    link = os.path.join(cam_dst, "data")
    if os.path.islink(link):
        os.remove(link)
    os.symlink(os.path.abspath(os.path.join(cam_src, "data")), link)
    with open(os.path.join(cam_dst, "data.csv"), "w", encoding="utf-8", newline="\n") as f:
        f.write("#timestamp [ns],filename\n")
        for t, name in rows:
            f.write(f"{t0 + (t - t0) // factor},{name}\n")
    if yml:
        with open(yml, "r", encoding="utf-8") as fi, open(os.path.join(cam_dst, "sensor.yaml"), "w") as fo:
            fo.write(fi.read())
    gt = trajio.read_euroc_groundtruth(gt_path)
    trajio.write_euroc_groundtruth(os.path.join(gt_dst, "data.csv"), trajio.Trajectory(
        t0 + (gt.t_ns - t0) // factor, gt.poses, "body"))
    return dst


def build(seqs: Sequence[str], work_dir: str, replay: Optional[str] = None, names: Optional[Dict[str, str]] = None,
          states=(STATE_OK, STATE_ROT_ONLY), log=print) -> Dict[str, np.ndarray]:
    """seqs: folders, or 'FOLDER:FEATURES.csv' to reuse a features csv. Returns the dataset dict."""
    names = names or {}
    parts = {k: [] for k in ("features", "targets", "sequence", "t_ns", "state", "dt_gt", "rel_scale")}
    os.makedirs(work_dir, exist_ok=True)
    for spec in seqs:
        seq_dir, _, csv = spec.partition(":") if ":" in spec and not os.path.isdir(spec) else (spec, "", "")
        seq_dir = seq_dir.rstrip("/")
        name = names.get(seq_dir, os.path.basename(seq_dir))
        if not csv:
            if replay is None:
                raise RuntimeError("no tvo_replay found: build it or pass --replay / set TVO_REPLAY")
            csv = os.path.join(work_dir, f"{name}.features.csv")
            run_replay(replay, seq_dir, csv, os.path.join(work_dir, f"{name}.unit.txt"))
        gt_path, yml = sequence_paths(seq_dir)
        T_BS = trajio.read_sensor_yaml(yml).T_BS if yml else trajio.EUROC_CAM0_T_BS
        gt = trajio.read_euroc_groundtruth(gt_path)
        feat = read_features_csv(csv)
        f, tgt, k = pair_sequence(feat, gt, T_BS, states)
        parts["features"].append(f)
        parts["targets"].append(tgt)
        parts["sequence"].append(np.array([name] * len(k)))
        parts["t_ns"].append(feat["t_ns"][k])
        parts["state"].append(feat["state"][k])
        parts["rel_scale"].append(feat["rel_scale"][k])
        parts["dt_gt"].append((feat["t_ns"][k] - feat["t_ns"][k - 1]) * 1e-9 if len(k) else np.zeros(0))
        log(f"{name}: {len(feat['t_ns'])} frames, {len(k)} pairs "
            f"(mean step {np.linalg.norm(tgt[:, :3], axis=1).mean() if len(k) else 0:.4f} m)")
    return {"features": np.concatenate(parts["features"]).astype(np.float32),
            "targets": np.concatenate(parts["targets"]).astype(np.float32),
            "sequence": np.concatenate(parts["sequence"]).astype(str),
            "t_ns": np.concatenate(parts["t_ns"]).astype(np.int64),
            "state": np.concatenate(parts["state"]).astype(np.int8),
            "dt_gt": np.concatenate(parts["dt_gt"]).astype(np.float64),
            "rel_scale": np.concatenate(parts["rel_scale"]).astype(np.float64)}


def save(path: str, data: Dict[str, np.ndarray]) -> None:
    d = os.path.dirname(os.path.abspath(path))
    os.makedirs(d, exist_ok=True)
    np.savez_compressed(path, **data)


def main(argv=None) -> int:
    ap = cli.parser("tinyvo-dataset", __doc__)
    ap.add_argument("sequences", nargs="+", help="EuRoC folders (or FOLDER:FEATURES.csv to reuse a features csv)")
    ap.add_argument("-o", "--out", required=True, help="dataset .npz to write")
    ap.add_argument("--replay", default=None, help="tvo_replay binary (default: $TVO_REPLAY or build/*/...)")
    ap.add_argument("--work", default=None, help="folder for the features csv files (default: next to --out)")
    ap.add_argument("--name", action="append", default=[], metavar="SEQDIR=NAME",
                    help="name the rows of sequence SEQDIR NAME instead of the folder's name (repeatable)")
    ap.add_argument("--speedup", default="", help="speed augmentation factors, e.g. 2,3: each sequence "
                    "named in --speedup-seqs is also added as NAME_x<k> (every k-th frame, k times faster)")
    ap.add_argument("--speedup-seqs", default="", help="comma-separated sequence names to augment (training only!)")
    ap.add_argument("--states", default="0,2", help="VO states kept (0 ok, 1 init, 2 rotation-only, 3 lost)")
    a = ap.parse_args(argv)
    names = {}
    for spec in a.name:
        d, eq, n = spec.partition("=")
        if not eq or not d or not n:
            ap.error(f"--name {spec!r}: expected SEQDIR=NAME")
        names[d.rstrip("/")] = n
    try:
        states = tuple(int(x) for x in a.states.split(",") if x)
        factors = [int(x) for x in a.speedup.split(",") if x]
    except ValueError:
        ap.error(f"--states {a.states!r} / --speedup {a.speedup!r}: comma-separated integers")
    if not states or any(x not in (STATE_OK, STATE_INIT, STATE_ROT_ONLY, STATE_LOST) for x in states):
        ap.error(f"--states {a.states!r}: VO states 0..3")
    if any(k < 2 for k in factors):
        ap.error(f"--speedup {a.speedup!r}: factors >= 2")
    return cli.run(ap.prog, lambda: _main(a, names, states, factors))


def _main(a, names, states, factors) -> int:
    work = a.work or os.path.join(os.path.dirname(os.path.abspath(a.out)), "features")
    seqs = list(a.sequences)
    aug = set(x for x in a.speedup_seqs.split(",") if x)
    for k in factors:
        for spec in a.sequences:
            d = spec.split(":")[0].rstrip("/")
            if os.path.basename(d) in aug:
                seqs.append(speedup_sequence(d, os.path.join(work, "speedup", f"{os.path.basename(d)}_x{k}"), k))
    data = build(seqs, work, a.replay or default_replay(), names=names, states=states,
                 log=lambda *x: cli.log(a.quiet, *x))
    save(a.out, data)
    cli.log(a.quiet, f"wrote {a.out}: {len(data['features'])} rows from {len(set(data['sequence'].tolist()))} sequences")
    return 0


if __name__ == "__main__":
    sys.exit(main())
