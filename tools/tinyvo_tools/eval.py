# SPDX-License-Identifier: Apache-2.0
"""Trajectory evaluation against ground truth: the standard metrics (via evo) and the paper's protocol.

    tinyvo-eval --est TRAJ.txt --gt <EuRoC / TUM / KITTI folder | pose file> [--gt-format F]
                [--gt-times times.txt] [--tbs sensor.yaml] [--cam camN] [--frame camera|body]
                [--metric-scale] [--out RESULT.json] [--plots DIR]

- ``--est``: TUM file ``t tx ty tz qx qy qz qw`` (seconds), camera pose in the world (``--frame body``
  if it is a body pose). tvo_replay's first line (``# tvo_replay frame=... source=... camera=...
  scale=...``) says whose pose it is: ``--frame`` and ``--cam`` default to it, an option that
  contradicts it is refused, and so is ``--metric-scale`` on a ``scale=none`` trajectory (the map's
  own unit).
- ``--gt``: a EuRoC csv (``timestamp_ns, p, q w x y z``: body poses), a TUM file (``t p qx qy qz qw``,
  seconds: camera poses) or KITTI poses (12 numbers per line: camera poses; times from ``--gt-times``,
  or the ``times.txt`` next to it or in ``../sequences/<seq>/``), or a folder of one of these datasets.
  The format is read from the file's header, separator, column count, timestamp magnitude and
  quaternion norm; a file that fits more than one (8 space-separated columns with ns timestamps, say)
  is refused with the reason, and ``--gt-format euroc|tum|kitti`` names it.
- EuRoC ground truth (body poses) is moved to the camera frame with ``T_BS``: from ``--tbs``, else the
  estimate's camera's ``sensor.yaml`` (``mav0/camN``) of the EuRoC folder, else, for cam0 only, EuRoC
  cam0's ``T_BS`` (said so in the output; another camera without its sensor.yaml is refused). TUM and
  KITTI ground truth is the camera's pose already (``T_BS`` identity unless ``--tbs``).
- Association by nearest timestamp (``--max-diff``, default 10 ms), with evo's ``sync``.

Metrics (see docs/evaluation.md):
- standard: ATE RMSE after Sim(3) alignment (default, scale-free monocular output) or SE(3)
  (``--metric-scale``), by evo's Umeyama alignment and APE; RPE per frame and over 1 m of travelled path
  (evo RPE, translation in m and rotation in deg) on the aligned estimate; per-DoF RPE per frame
  (tx ty tz in m, rx ry rz in deg: components of the relative-pose error, as in the paper's tables).
- scale drift (Sim(3) only): the run split into ``parts`` (default 4) runs of consecutive frames, each
  aligned on its own; each part's scale over the whole run's (1 everywhere for an estimate with one
  consistent scale; a part whose positions do not span enough to align gives null).
- ``paper_protocol``: the protocol of Boloorchi Tabrizi & Crick, labelled as such: no alignment, the
  estimate's relative motions chained from the first ground-truth pose, mean position error.
"""
from __future__ import annotations

import copy
import json
import os
import re
import sys
from dataclasses import dataclass, field

import numpy as np
from evo.core.geometry import GeometryException
from scipy.spatial.transform import Rotation

from . import cli, trajio
from .trajio import Trajectory, EUROC_CAM0_T_BS

PAPER_LABEL = ("paper protocol (Boloorchi Tabrizi & Crick): NO alignment, the estimate's relative motions "
               "chained from the first ground-truth pose (P_k = G_0 inv(E_0) E_k), no scale correction, "
               "mean position error over all frames. Not comparable with the standard aligned ATE.")

DOFS = ("tx", "ty", "tz", "rx", "ry", "rz")


def _to_evo(traj: Trajectory):
    from evo.core.trajectory import PoseTrajectory3D

    return PoseTrajectory3D(poses_se3=list(traj.poses), timestamps=traj.t_ns.astype(np.float64) * 1e-9)


def _stats(x) -> dict:
    x = np.asarray(x, dtype=np.float64)
    if x.size == 0:
        return {"n": 0}
    return {"rmse": float(np.sqrt(np.mean(x * x))), "mean": float(np.mean(x)), "median": float(np.median(x)),
            "std": float(np.std(x)), "min": float(np.min(x)), "max": float(np.max(x)), "n": int(x.size)}


def _evo_stats(metric) -> dict:
    from evo.core.metrics import StatisticsType

    s = {k.value: float(metric.get_statistic(k)) for k in
         (StatisticsType.rmse, StatisticsType.mean, StatisticsType.median, StatisticsType.std,
          StatisticsType.min, StatisticsType.max)}
    s["n"] = int(len(metric.error))
    return s


def relative_motions(poses: np.ndarray) -> np.ndarray:
    """T_k,k+1 = inv(T_w,k) @ T_w,k+1 for consecutive poses, (N-1,4,4)."""
    return trajio.inv_pose(poses[:-1]) @ poses[1:]


def per_dof_errors(gt_poses: np.ndarray, est_poses: np.ndarray) -> np.ndarray:
    """Per-frame relative-pose error per DoF, (N-1, 6): the components of the RPE error transform
    E_k = inv(G_k^-1 G_k+1) @ (P_k^-1 P_k+1) (the same transform evo's RPE takes the norm of):
    translation tx ty tz in m and the rotation vector rx ry rz in deg."""
    g = relative_motions(gt_poses)
    e = relative_motions(est_poses)
    E = trajio.inv_pose(g) @ e
    dr = np.degrees(Rotation.from_matrix(E[:, :3, :3]).as_rotvec())
    return np.concatenate([E[:, :3, 3], dr], axis=1)


def paper_protocol_poses(gt_poses: np.ndarray, est_poses: np.ndarray) -> np.ndarray:
    """The estimate re-anchored at the first ground-truth pose: P_k = G_0 @ inv(E_0) @ E_k (the same as
    chaining the estimate's relative motions from G_0)."""
    return gt_poses[0] @ trajio.inv_pose(est_poses[0]) @ est_poses


def paper_protocol(gt_poses: np.ndarray, est_poses: np.ndarray) -> dict:
    P = paper_protocol_poses(gt_poses, est_poses)
    et = np.linalg.norm(P[:, :3, 3] - gt_poses[:, :3, 3], axis=1)
    dR = np.swapaxes(gt_poses[:, :3, :3], 1, 2) @ P[:, :3, :3]
    er = np.degrees(np.linalg.norm(Rotation.from_matrix(dR).as_rotvec(), axis=1))
    return {"label": PAPER_LABEL, "aligned": False,
            "mean_translation_error_m": float(et.mean()), "mean_rotation_error_deg": float(er.mean()),
            "translation_error_m": _stats(et), "rotation_error_deg": _stats(er),
            "final_translation_error_m": float(et[-1])}


@dataclass
class Evaluation:
    """The JSON-able ``result`` plus the arrays the plots need."""

    result: dict
    t_s: np.ndarray = field(repr=False, default=None)
    gt: np.ndarray = field(repr=False, default=None)  # (N,4,4) camera poses
    est_aligned: np.ndarray = field(repr=False, default=None)
    est_paper: np.ndarray = field(repr=False, default=None)
    dof_err: np.ndarray = field(repr=False, default=None)  # (N-1,6)

    def plot(self, out_dir: str) -> list:
        return make_plots(self, out_dir)


def part_scales(gt_xyz: np.ndarray, est_xyz: np.ndarray, whole_scale: float, parts: int) -> list:
    """The Sim(3) scale of each of ``parts`` runs of consecutive poses (as equal as the count allows),
    aligned on its own, over ``whole_scale`` (the whole run's); None for a part whose positions do not
    span enough to align (fewer than 3 poses, or standing still or on a line)."""
    from evo.core.geometry import umeyama_alignment
    out = []
    for idx in np.array_split(np.arange(len(gt_xyz)), parts):
        x, y = est_xyz[idx].T, gt_xyz[idx].T
        if len(idx) < 3 or np.linalg.matrix_rank(x - x.mean(1, keepdims=True), tol=1e-9) < 2:
            out.append(None)
            continue
        try:
            _, _, c = umeyama_alignment(x, y, with_scale=True)
        except GeometryException:
            out.append(None)
            continue
        out.append(float(c / whole_scale) if np.isfinite(c) and c > 0 else None)
    return out


def evaluate(est: Trajectory, gt_body: Trajectory, T_BS=None, metric_scale: bool = False,
             max_diff_s: float = 0.01, frame: str = "camera", parts: int = 4,
             rpe_deltas: tuple = ()) -> Evaluation:
    """Evaluate an estimated trajectory (``frame`` poses in the world) against body ground truth.
    ``T_BS``: 4x4 body-from-camera transform (None: EuRoC cam0); ignored with ``frame='body'``."""
    from evo import EvoException
    from evo.core import metrics, sync
    from evo.core.units import Unit

    if frame not in ("camera", "body"):
        raise ValueError("frame must be 'camera' or 'body'")
    if not 1 <= parts <= 1000:
        raise ValueError("parts must be in 1..1000")
    if any(int(k) != k or k < 1 for k in rpe_deltas):
        raise ValueError("RPE deltas must be whole numbers of frames, at least 1")
    if len(est) < 2 or len(gt_body) < 2:
        raise ValueError("need at least 2 poses in both trajectories")
    if not (np.all(np.isfinite(est.poses)) and np.all(np.isfinite(gt_body.poses))):
        raise ValueError("non-finite poses")
    T_BS = EUROC_CAM0_T_BS if T_BS is None else np.asarray(T_BS, dtype=np.float64)
    gt = gt_body.to_camera(T_BS) if frame == "camera" else gt_body
    try:
        ref, est_e = sync.associate_trajectories(_to_evo(gt), _to_evo(est), max_diff=max_diff_s)
    except EvoException as e:
        raise ValueError(f"association failed: {e}") from None
    n = ref.num_poses
    if n < 3:
        raise ValueError(f"only {n} poses associated within {max_diff_s} s")
    gt_poses = np.array(ref.poses_se3)
    est_raw = np.array(est_e.poses_se3)

    aligned = copy.deepcopy(est_e)
    try:
        r_a, t_a, s = aligned.align(ref, correct_scale=not metric_scale)
    except GeometryException as e:
        # evo's Umeyama needs positions that span more than a line: a camera that only turns (or a
        # trajectory standing still) has no alignment, and so no ATE
        raise ValueError(f"{'SE(3)' if metric_scale else 'Sim(3)'} alignment is not possible: the positions "
                         f"do not span enough ({e}); a rotation-only or static sequence has no ATE") from e
    est_al = np.array(aligned.poses_se3)

    ape_t = metrics.APE(metrics.PoseRelation.translation_part)
    ape_t.process_data((ref, aligned))
    ape_r = metrics.APE(metrics.PoseRelation.rotation_angle_deg)
    ape_r.process_data((ref, aligned))

    def rpe(delta, unit, all_pairs=False):
        out = {}
        for name, rel in (("translation_m", metrics.PoseRelation.translation_part),
                          ("rotation_deg", metrics.PoseRelation.rotation_angle_deg)):
            m = metrics.RPE(rel, delta=delta, delta_unit=unit, all_pairs=all_pairs)
            try:
                m.process_data((ref, aligned))
                out[name] = _evo_stats(m)
            except EvoException as e:  # e.g. a path shorter than 1 m
                out[name] = None
                out["note"] = str(e)
        return out

    dof = per_dof_errors(gt_poses, est_al)
    t_s = np.array(ref.timestamps)
    path_len = float(np.sum(np.linalg.norm(np.diff(gt_poses[:, :3, 3], axis=0), axis=1)))
    result = {
        "tool": "tinyvo_tools.eval",
        "frame": frame,
        "poses": {"estimate": len(est), "ground_truth": len(gt_body), "associated": int(n),
                  "max_diff_s": max_diff_s},
        "duration_s": float(t_s[-1] - t_s[0]),
        "gt_path_length_m": path_len,
        "standard": {
            "alignment": {"type": "se3" if metric_scale else "sim3", "scale": float(s),
                          "rotation": np.asarray(r_a).tolist(), "translation": np.asarray(t_a).tolist()},
            "ate_m": _evo_stats(ape_t),
            "ate_rotation_deg": _evo_stats(ape_r),
            "rpe_frame": rpe(1, Unit.frames),
            "rpe_1m": rpe(1.0, Unit.meters),
            "rpe_per_dof": {
                "units": "tx ty tz in m, rx ry rz in deg; per frame, components of inv(gt_rel) @ est_rel",
                **{d: _stats(dof[:, i]) for i, d in enumerate(DOFS)}},
        },
        "paper_protocol": paper_protocol(gt_poses, est_raw),
    }
    if rpe_deltas:
        # every pair k frames apart (overlapping): how the error between two poses grows with their distance
        result["standard"]["rpe_frames"] = {str(int(k)): rpe(int(k), Unit.frames, all_pairs=True)
                                            for k in rpe_deltas}
    if not metric_scale:
        result["standard"]["scale_parts"] = part_scales(gt_poses[:, :3, 3], est_raw[:, :3, 3], float(s), parts)
    return Evaluation(result, t_s, gt_poses, est_al, paper_protocol_poses(gt_poses, est_raw), dof)


def load_groundtruth(path: str, fmt: str = "auto", times=None, cam: str = "cam0"):
    """(Trajectory, path of camera ``cam``'s sensor.yaml next to it or None, format, why). EuRoC ground
    truth is the body's pose, TUM and KITTI ground truth the camera's."""
    gt, fmt, why = trajio.read_trajectory(path, fmt, times)
    return gt, (trajio.find_cam_yaml(path, cam) if fmt == "euroc" else None), fmt, why


def estimate_frame_and_camera(est_path: str, frame: str | None, cam: str | None, metric_scale: bool):
    """(frame, camera) of an estimate: as given, else as its tvo_replay header says (camera only for a
    EuRoC replay), else camera and cam0. Refuses what contradicts the header, and an SE(3) evaluation
    of a trajectory in the map's own unit (``scale=none``): its ATE in metres would mean nothing."""
    hdr = trajio.read_replay_header(est_path)
    if (hdr.get("frame", "camera") not in ("camera", "body")
            or not re.fullmatch(r"\w{1,63}", hdr.get("camera", "x"))):
        raise ValueError(f"{est_path}: a tvo_replay header with frame={hdr.get('frame')} "
                         f"camera={hdr.get('camera')} (expected frame camera or body, a camera folder name)")
    if frame is None:
        frame = hdr.get("frame", "camera")
    elif hdr.get("frame", frame) != frame:
        raise ValueError(f"--frame {frame}, but {est_path} holds {hdr['frame']} poses (its tvo_replay header)")
    hcam = hdr.get("camera") if hdr.get("source") == "euroc" else None
    if cam is not None and hcam is not None and cam != hcam:
        raise ValueError(f"--cam {cam}, but {est_path} is a replay of {hcam} (its tvo_replay header)")
    if metric_scale and hdr.get("scale") == "none":
        raise ValueError(f"--metric-scale, but {est_path} was written with --scale none (the map's own "
                         "unit): evaluate it with Sim(3), without --metric-scale")
    return frame, cam or hcam or "cam0"


def restrict_to_frames_of(est: Trajectory, other: Trajectory, max_diff_s: float):
    """The poses of ``est`` whose timestamp is within ``max_diff_s`` of one of ``other``'s: two methods
    compared on the frames both report (a peer that starts late or drops frames is otherwise compared
    on fewer, often easier, frames). Returns the restricted trajectory and (kept, of)."""
    if len(other) == 0:
        raise ValueError("--same-frames-as: the trajectory has no poses")
    ref = np.sort(other.t_ns)
    pos = np.clip(np.searchsorted(ref, est.t_ns), 1, len(ref) - 1) if len(ref) > 1 else np.zeros(len(est), int)
    near = np.minimum(np.abs(est.t_ns - ref[pos]), np.abs(est.t_ns - ref[np.maximum(pos - 1, 0)]))
    keep = near <= int(round(max_diff_s * 1e9))
    if keep.sum() < 3:
        raise ValueError(f"--same-frames-as: only {int(keep.sum())} frames in common (tolerance {max_diff_s} s)")
    return Trajectory(est.t_ns[keep], est.poses[keep], est.frame, est.source), (int(keep.sum()), len(est))


def evaluate_files(est_path: str, gt_path: str, tbs_yaml: str | None = None, metric_scale: bool = False,
                   max_diff_s: float = 0.01, frame: str | None = None, plots_dir: str | None = None,
                   out_json: str | None = None, gt_format: str = "auto", gt_times: str | None = None,
                   same_frames_as: str | None = None, parts: int = 4, rpe_deltas: tuple = (),
                   cam: str | None = None) -> Evaluation:
    """The command line's work as a function (used by the bench and the README demo). ``frame`` and
    ``cam`` None: from the estimate's tvo_replay header, else camera and cam0."""
    frame, cam = estimate_frame_and_camera(est_path, frame, cam, metric_scale)
    est = trajio.read_tum(est_path, frame)
    kept = None
    if same_frames_as:
        est, kept = restrict_to_frames_of(est, trajio.read_tum(same_frames_as, frame), max_diff_s)
    gt, auto_yaml, fmt, why = load_groundtruth(gt_path, gt_format, gt_times, cam)
    if frame == "body":
        T_BS, tbs_src = np.eye(4), "not used (--frame body)"
    elif tbs_yaml:
        T_BS, tbs_src = trajio.read_sensor_yaml(tbs_yaml).T_BS, os.path.abspath(tbs_yaml)
    elif fmt != "euroc":
        T_BS, tbs_src = np.eye(4), f"identity ({fmt} ground truth is the camera's pose)"
    elif auto_yaml:
        T_BS, tbs_src = trajio.read_sensor_yaml(auto_yaml).T_BS, auto_yaml
    elif cam == "cam0":
        T_BS, tbs_src = EUROC_CAM0_T_BS, "EuRoC cam0 T_BS (built in; pass --tbs to change)"
    else:
        raise ValueError(f"the estimate is of {cam}, and no {cam}/sensor.yaml is beside the ground truth "
                         f"{gt_path}: give its T_BS with --tbs")
    ev = evaluate(est, gt, T_BS, metric_scale, max_diff_s, frame, parts, rpe_deltas)
    ev.result["inputs"] = {"estimate": os.path.abspath(est_path), "estimate_frame": frame, "camera": cam,
                           "ground_truth": gt.source, "ground_truth_format": fmt,
                           "ground_truth_format_why": why, "T_BS": tbs_src}
    if kept is not None:
        ev.result["inputs"]["same_frames_as"] = {"trajectory": os.path.abspath(same_frames_as),
                                                 "frames_kept": kept[0], "frames_of_estimate": kept[1]}
    if plots_dir:
        ev.result["plots"] = make_plots(ev, plots_dir)
    if out_json:
        d = os.path.dirname(os.path.abspath(out_json))
        os.makedirs(d, exist_ok=True)
        with open(out_json, "w", encoding="utf-8") as f:
            json.dump(ev.result, f, indent=2)
    return ev


def make_plots(ev: Evaluation, out_dir: str) -> list:
    """trajectory_top.png (x-y of ground truth, aligned estimate, paper-protocol estimate) and
    dof_error.png (per-DoF relative-pose error over time). Returns the file paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(out_dir, exist_ok=True)
    std = ev.result["standard"]
    al = std["alignment"]["type"].upper().replace("SIM3", "Sim(3)").replace("SE3", "SE(3)")
    fig, ax = plt.subplots(figsize=(7, 6))
    ax.plot(ev.gt[:, 0, 3], ev.gt[:, 1, 3], "k-", lw=1.5, label="ground truth (camera)")
    ax.plot(ev.est_aligned[:, 0, 3], ev.est_aligned[:, 1, 3], "-", color="tab:blue", lw=1.2,
            label=f"estimate, {al} aligned (ATE RMSE {std['ate_m']['rmse']:.3f} m)")
    pp = ev.result["paper_protocol"]
    ax.plot(ev.est_paper[:, 0, 3], ev.est_paper[:, 1, 3], "--", color="tab:orange", lw=1.0,
            label=f"estimate, paper protocol (mean err {pp['mean_translation_error_m']:.3f} m)")
    ax.plot(ev.gt[0, 0, 3], ev.gt[0, 1, 3], "ko")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("trajectory, top view")
    fig.tight_layout()
    p1 = os.path.join(out_dir, "trajectory_top.png")
    fig.savefig(p1, dpi=110)
    plt.close(fig)

    fig, axs = plt.subplots(6, 1, figsize=(8, 9), sharex=True)
    t = ev.t_s[1:] - ev.t_s[0]
    for i, (a, d) in enumerate(zip(axs, DOFS)):
        a.plot(t, ev.dof_err[:, i], lw=0.7, color="tab:red" if i >= 3 else "tab:blue")
        a.axhline(0, color="k", lw=0.5)
        a.set_ylabel(f"{d} [{'deg' if i >= 3 else 'm'}]")
        a.grid(True, alpha=0.3)
    axs[-1].set_xlabel("time [s]")
    axs[0].set_title(f"per-DoF relative pose error per frame ({al} aligned estimate)")
    fig.tight_layout()
    p2 = os.path.join(out_dir, "dof_error.png")
    fig.savefig(p2, dpi=110)
    plt.close(fig)
    return [p1, p2]


def format_summary(res: dict) -> str:
    s = res["standard"]
    al = s["alignment"]["type"]
    lines = [f"associated poses: {res['poses']['associated']}  (gt path {res['gt_path_length_m']:.2f} m, "
             f"{res['duration_s']:.1f} s)",
             f"ATE RMSE ({al}{', scale %.4f' % s['alignment']['scale'] if al == 'sim3' else ''}): "
             f"{s['ate_m']['rmse']:.4f} m   rotation {s['ate_rotation_deg']['rmse']:.3f} deg"]
    rf = s["rpe_frame"]
    lines.append(f"RPE per frame: {rf['translation_m']['rmse']:.4f} m, {rf['rotation_deg']['rmse']:.4f} deg (RMSE)")
    r1 = s["rpe_1m"]
    if r1.get("translation_m"):
        lines.append(f"RPE over 1 m: {r1['translation_m']['rmse']:.4f} m, {r1['rotation_deg']['rmse']:.4f} deg (RMSE)")
    else:
        lines.append(f"RPE over 1 m: n/a ({r1.get('note', '')})")
    d = s["rpe_per_dof"]
    lines.append("per-DoF RPE RMSE: " + "  ".join(f"{k} {d[k]['rmse']:.4g}" for k in DOFS) + "  (m / deg)")
    for k, r in s.get("rpe_frames", {}).items():
        if r.get("rotation_deg"):
            lines.append(f"RPE over {k} frames: {r['translation_m']['rmse']:.4f} m, "
                         f"{r['rotation_deg']['rmse']:.4f} deg (RMSE, every pair {k} frames apart)")
        else:
            lines.append(f"RPE over {k} frames: n/a ({r.get('note', '')})")
    if s.get("scale_parts") is not None:
        sp = " ".join("-" if v is None else f"{v:.3f}" for v in s["scale_parts"])
        lines.append(f"scale of {len(s['scale_parts'])} parts / the whole run's: {sp}")
    pp = res["paper_protocol"]
    lines.append(f"paper protocol (no alignment, chained from first gt pose): mean error "
                 f"{pp['mean_translation_error_m']:.4f} m, {pp['mean_rotation_error_deg']:.3f} deg")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = cli.parser("tinyvo-eval", __doc__)
    ap.add_argument("--est", required=True, help="estimated trajectory, TUM format (seconds)")
    ap.add_argument("--gt", required=True,
                    help="ground truth: a EuRoC, TUM RGB-D or KITTI folder, or a EuRoC csv, TUM or KITTI poses file")
    ap.add_argument("--gt-format", choices=("auto",) + trajio.POSE_FORMATS, default="auto",
                    help="format of --gt (default auto: detected, ambiguous files refused)")
    ap.add_argument("--gt-times", help="KITTI times.txt for a KITTI poses file (default: found next to it)")
    ap.add_argument("--tbs", help="sensor.yaml whose T_BS moves ground truth to the camera frame")
    ap.add_argument("--metric-scale", action="store_true", help="SE(3) alignment (metric output)")
    ap.add_argument("--frame", choices=("camera", "body"),
                    help="frame of --est poses (default: what its tvo_replay header says, else camera)")
    ap.add_argument("--cam", help="EuRoC camera of --est, whose sensor.yaml moves the ground truth to it "
                                  "(default: what its tvo_replay header says, else cam0)")
    ap.add_argument("--max-diff", type=float, default=0.01, help="association tolerance, s (default 0.01)")
    ap.add_argument("--out", help="write the result JSON here")
    ap.add_argument("--plots", help="write PNG plots into this folder")
    ap.add_argument("--same-frames-as", metavar="TRAJ",
                    help="evaluate only the frames of --est that this TUM trajectory (a peer's) also has")
    ap.add_argument("--parts", type=int, default=4,
                    help="scale drift: the Sim(3) scale of this many consecutive parts of the run, each "
                         "over the whole run's (default 4)")
    ap.add_argument("--rpe-delta", type=int, action="append", default=[], metavar="K",
                    help="also the RPE between every pair of frames K apart (repeatable): how the error of "
                         "two poses grows with their distance")
    a = ap.parse_args(argv)

    def body():
        ev = evaluate_files(a.est, a.gt, a.tbs, a.metric_scale, a.max_diff, a.frame, a.plots, a.out,
                            a.gt_format, a.gt_times, a.same_frames_as, a.parts, tuple(a.rpe_delta), a.cam)
        if not a.quiet:
            inp = ev.result["inputs"]
            print(f"ground truth: {inp['ground_truth_format']} ({inp['ground_truth_format_why']})")
            print(format_summary(ev.result))
            if a.plots:
                print("plots: " + ", ".join(ev.result["plots"]))
            if a.out:
                print(f"result: {a.out}")
        return 0

    return cli.run(ap.prog, body)


if __name__ == "__main__":
    sys.exit(main())
