#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Benchmark: where a real sequence's monocular scale drifts, seen three ways against the ground truth.

A monocular trajectory's unit drifts where the images make each step look longer (or shorter) than the
one before it by more than it was. This program measures, per segment of a pinhole ASL sequence with
ground truth (the shared KITTI copies), the speed change between consecutive steps summed in log
(log of the last step's length over the first's, one term per triplet of frames):

  - tinyvo: the VO's three-frame relative scale (`rel_scale` of `tvo_replay --map 0 --features`, the
    median depth ratio of the tracks seen in three consecutive frames);
  - OpenCV: an independent pipeline on frames k - 2g, k - g, k (g = --gap): goodFeaturesToTrack (800
    corners), pyramidal LK (21x21, 3 levels, 100 iterations or 0.001 px), findEssentialMat (RANSAC,
    1 px) and recoverPose for both pairs, the median ratio of each inlier's depth in frame k - g from
    the second pair over the first;
  - ground truth: the same ratio of the true steps.

Where the first two agree with each other and not with the ground truth, the images (or their
calibration) carry the bias, not tinyvo's tracker or geometry. The ground truth is checked in turn by
the road: the map's trajectory (`tvo_replay --tracks`) triangulates the tracks in the bottom quarter of
the image (the road ahead of a car) from frame pairs 3-5 apart, and the median height of those points
under the camera in map units, divided by the map's units per metre from the ground truth, should stay
at the camera's height above the road (1.65 m on KITTI) where the ground truth is right.

Usage: .venv/bin/python test/bench/bench_scale_bias.py --seq $TVO_DATA_DIR/kitti/kitti07_160 \\
           --replay build/release/examples/replay/tvo_replay [--segments 0,24,47,60,120,160] [--gap 2] \\
           [-- REPLAY ARGS]
REPLAY ARGS go to both tvo_replay runs (a tracker setting, another calibration with --calib); the OpenCV
column always uses the sequence's own calibration.
"""
import argparse
import os
import subprocess
import sys
import tempfile

import cv2
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from tinyvo_tools import trajio  # noqa: E402


def load(seq):
    cam_dir = os.path.join(seq, "mav0", "cam0")
    t_ns, names = trajio.read_cam_frames(cam_dir)
    cam = trajio.read_sensor_yaml(os.path.join(cam_dir, "sensor.yaml"))
    if any(abs(d) > 0 for d in cam.distortion):
        sys.exit(f"{seq}: a pinhole camera without distortion is needed")
    gt = trajio.read_euroc_groundtruth(seq)
    T_w_c = trajio.interpolate_poses(gt.t_ns, gt.poses @ cam.T_BS, t_ns)
    return t_ns, [os.path.join(cam_dir, "data", n) for n in names], cam, T_w_c


def step_ratios_gt(T_w_c, k, g):
    a = np.linalg.norm(T_w_c[k - g, :3, 3] - T_w_c[k - 2 * g, :3, 3])
    b = np.linalg.norm(T_w_c[k, :3, 3] - T_w_c[k - g, :3, 3])
    return b / a


def depth_first(x1, x2, R, t):
    """Depth in camera 1 of each correspondence (normalised x1, x2; X2 = R X1 + t)."""
    out = np.empty(len(x1))
    for i, (u, v) in enumerate(zip(x1, x2)):
        a = np.array([u[0], u[1], 1.0])
        b = np.array([v[0], v[1], 1.0])
        out[i] = np.linalg.lstsq(np.c_[R @ a, -b], -t, rcond=None)[0][0]
    return out


def ratio_opencv(ims, cam, k, g):
    fx, fy, cx, cy = cam.intrinsics
    p0 = cv2.goodFeaturesToTrack(ims[k - 2 * g], 800, 0.01, 8)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 0.001)
    p1, s1, _ = cv2.calcOpticalFlowPyrLK(ims[k - 2 * g], ims[k - g], p0, None, winSize=(21, 21), maxLevel=3,
                                         criteria=crit)
    p2, s2, _ = cv2.calcOpticalFlowPyrLK(ims[k - g], ims[k], p1, None, winSize=(21, 21), maxLevel=3,
                                         criteria=crit)
    ok = (s1[:, 0] == 1) & (s2[:, 0] == 1)
    a, b, c = [(p[ok, 0] - [cx, cy]) / [fx, fy] for p in (p0, p1, p2)]
    if len(a) < 20:
        return np.nan
    E1, m1 = cv2.findEssentialMat(a, b, np.eye(3), cv2.RANSAC, 0.999, 1.0 / fx)
    _, R1, t1, m1 = cv2.recoverPose(E1, a, b, np.eye(3), mask=m1)
    E2, m2 = cv2.findEssentialMat(b, c, np.eye(3), cv2.RANSAC, 0.999, 1.0 / fx)
    _, R2, t2, m2 = cv2.recoverPose(E2, b, c, np.eye(3), mask=m2)
    m = (m1[:, 0] > 0) & (m2[:, 0] > 0)
    # depth in k - g: as the second camera of pair 1 (depth_first on the reversed pair), the first of pair 2
    R1i = R1.T
    t1i = -R1.T @ t1[:, 0]
    d1 = depth_first(b[m], a[m], R1i, t1i)
    d2 = depth_first(b[m], c[m], R2, t2[:, 0])
    good = (d1 > 0) & (d2 > 0) & np.isfinite(d1) & np.isfinite(d2)
    return float(np.median(d1[good] / d2[good])) if good.sum() >= 10 else np.nan


def run(cmd):
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def road_heights(tracks_csv, traj, cam, n_frames):
    """(frame, height in map units) of the tracks in the image's bottom quarter, triangulated from frame
    pairs 3-5 apart with the map's poses."""
    fx, fy, cx, cy = cam.intrinsics
    est = trajio.read_tum(traj)
    rows = np.loadtxt(tracks_csv, delimiter=",", skiprows=1, ndmin=2)
    times = {t: i for i, t in enumerate(np.unique(rows[:, 0].astype(np.int64)))}
    obs = [dict() for _ in range(n_frames)]
    for r in rows:
        obs[times[int(r[0])]][int(r[1])] = ((r[2] - cx) / fx, (r[3] - cy) / fy, r[3])
    T = est.poses
    y_min = 0.75 * cam.height  # the image's bottom quarter
    out = []
    for k in range(n_frames):
        for gap in (3, 4, 5):
            if k + gap >= min(n_frames, len(T)):
                continue
            for tid, (u, v, y_px) in obs[k].items():
                if y_px < y_min or tid not in obs[k + gap]:
                    continue
                u2, v2, _ = obs[k + gap][tid]
                A, b = np.zeros((3, 3)), np.zeros(3)
                for (uu, vv), Tk in (((u, v), T[k]), ((u2, v2), T[k + gap])):
                    d = Tk[:3, :3] @ np.array([uu, vv, 1.0])
                    d /= np.linalg.norm(d)
                    M = np.eye(3) - np.outer(d, d)
                    A += M
                    b += M @ Tk[:3, 3]
                X = np.linalg.solve(A, b)
                Xc = T[k][:3, :3].T @ (X - T[k][:3, 3])
                if Xc[2] > 0:
                    out.append((k, Xc[1]))
    return np.array(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seq", required=True)
    ap.add_argument("--replay", required=True)
    ap.add_argument("--segments", default="0,24,47,60,120,160")
    ap.add_argument("--gap", type=int, default=2)
    ap.add_argument("replay_args", nargs="*", help="after --: arguments for tvo_replay")
    args = ap.parse_args()
    extra = list(args.replay_args)
    t_ns, files, cam, T_w_c = load(args.seq)
    n = len(files)
    cuts = [min(int(x), n) for x in args.segments.split(",")]
    with tempfile.TemporaryDirectory() as tmp:
        feats, traj, tracks = (os.path.join(tmp, x) for x in ("f.csv", "t.txt", "tr.csv"))
        run([args.replay, "--euroc", args.seq, "--map", "0", "--out", os.path.join(tmp, "chain.txt"),
             "--features", feats, "--quiet"] + extra)
        run([args.replay, "--euroc", args.seq, "--out", traj, "--tracks", tracks, "--quiet"] + extra)
        f = np.genfromtxt(feats, delimiter=",", names=True)
        rel = f["rel_scale"]
        est = trajio.read_tum(traj).poses
        heights = road_heights(tracks, traj, cam, n)
    ims = [cv2.imread(p, cv2.IMREAD_GRAYSCALE) for p in files[:cuts[-1]]]
    g = args.gap
    print(f"{args.seq}: {n} frames; sums of log(step / previous step) per segment (tinyvo: consecutive "
          f"frames; OpenCV: frames {g} apart)")
    print(f"| frames | tinyvo, three frames / truth | OpenCV, {g} frames apart / truth | map units per m "
          "over the segment (by the ground truth) | road below the camera, m (points) |")
    print("|---|---|---|---|---|")
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        ks = [k for k in range(max(lo, 2), hi) if rel[k] > 0 and np.isfinite(rel[k])]
        s_tvo = sum(np.log(rel[k]) for k in ks)
        s_gt1 = sum(np.log(step_ratios_gt(T_w_c, k, 1)) for k in ks)
        kc = [k for k in range(max(lo, 2 * g), hi, g)]
        rc = [(ratio_opencv(ims, cam, k, g), step_ratios_gt(T_w_c, k, g)) for k in kc]
        rc = [(a, b) for a, b in rc if np.isfinite(a) and a > 0]
        s_cv = sum(np.log(a) for a, _ in rc)
        s_gtg = sum(np.log(b) for _, b in rc)
        e = hi - 1
        unit = np.linalg.norm(est[e, :3, 3] - est[lo, :3, 3]) / np.linalg.norm(T_w_c[e, :3, 3] - T_w_c[lo, :3, 3])
        m = (heights[:, 0] >= lo) & (heights[:, 0] < hi) if len(heights) else np.zeros(0, bool)
        road = f"{np.median(heights[m, 1]) / unit:.2f} m ({m.sum()})" if m.sum() >= 5 else "-"
        print(f"| {lo}-{hi} | {s_tvo:+.3f} / {s_gt1:+.3f} | {s_cv:+.3f} / {s_gtg:+.3f} | {unit:.2f} | {road} |")


if __name__ == "__main__":
    main()
