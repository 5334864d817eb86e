#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Benchmark: the VO on degraded copies of a real sequence (blur, noise, a smaller camera, a lower rate).

A user's camera is rarely as sharp, quiet, large and fast as the shared KITTI frames. This program writes
copies of an EuRoC/ASL sequence (the resized copies only of a camera without distortion, as the shared
KITTI sequences; the others of any camera, the renders too):

  - none:        the frames as they are;
  - blur1:       Gaussian blur, sigma 1 px;
  - blur15n3:    Gaussian blur, sigma 1.5 px, then Gaussian noise, sigma 3 grey levels (a cheap lens in
                 dim light);
  - noise6:      Gaussian noise, sigma 6 grey levels;
  - half:        every frame at half the width and height (OpenCV INTER_AREA), the intrinsics halved
                 about the pixel centres;
  - up15, up2:   every frame at 1.5 or 2 times the width and height (OpenCV INTER_CUBIC), the intrinsics
                 scaled about the pixel centres: a camera with more pixels over the same view (the motion
                 in pixels 1.5 or 2 times as large), though without the finer detail a real one would see;
  - skip2:       every second frame (half the rate: twice the motion between frames);
  - jerk:        one or two frames on from each kept frame, at random (seeded), the kept frames then given
                 evenly spaced times at the original rate and their ground truth moved with them: the
                 camera's speed doubles or halves from one frame to the next, the motion a constant-velocity
                 prediction handles worst (a shaken hand-held camera, a drone's vibration).
  - reverse:     every frame, the last first, at the original rate with the ground truth moved with the
                 frames: the same path driven backwards (a car reversing; what enters the view now comes
                 in at the borders and leaves at the centre).
  - stop:        the camera stands still for 50 frames in the middle of the run (a car at a red light):
                 the middle frame held, each held copy with fresh sensor noise (sigma 2 grey levels), the
                 frames re-timed at the original rate and the ground truth held still with them; the
                 map must neither drift nor lose its scale while nothing moves, and go on afterwards.
  - start:       the same hold of 30 frames on the first frame (a camera switched on at rest, then moving).
  - drops:       frames dropped as a camera or a recording drops them: from the sixth on each frame with
                 probability 1/25 (Python's random.Random(52)), and a burst of 3 in the middle third; the
                 others keep their times and the rate stays: the replay sees gaps of 2-4 frame intervals.
  - jitter10:    every frame, with its timestamp (not the frame, nor the ground truth) moved at random by
                 up to 10 % of the frame interval (uniform, Python's random.Random(55); the first and last
                 frames keep theirs): stamps taken on arrival by a driver, around a steady capture rate.

Noise is seeded (the same copy on every run). It replays each copy with `tvo_replay --scale none` and the
given replay arguments, and prints the Sim(3)-aligned ATE (m) of the whole run, the number of frames
before the map's first pose (the map state `initialising`), the ATE of the frames from the map's first
pose on, the per-frame rotation RPE (deg), the frames without a pose and the map's losses.

Usage: .venv/bin/python test/bench/bench_degrade.py --seq SEQ --replay BUILD/examples/replay/tvo_replay
           [--work DIR] [--only NAME,NAME] [-- REPLAY ARGS]
The copies go to --work (default: a temporary folder, removed at the end).
"""
import argparse
import os
import random
import shutil
import sys

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "tools"))
import replay_copies  # noqa: E402  (beside this file)
from tinyvo_tools import trajio  # noqa: E402

# name: (scale, keep every n-th frame (0: one or two frames on at random, re-timed; -1: every frame, last
#        first, re-timed; -2 / -3: every frame with a hold in the middle / at the start, re-timed), blur
#        sigma px, noise sigma grey levels)
VARIANTS = {
    "none": (1.0, 1, 0.0, 0.0),
    "blur1": (1.0, 1, 1.0, 0.0),
    "blur15n3": (1.0, 1, 1.5, 3.0),
    "noise6": (1.0, 1, 0.0, 6.0),
    "half": (0.5, 1, 0.0, 0.0),
    "up15": (1.5, 1, 0.0, 0.0),
    "up2": (2.0, 1, 0.0, 0.0),
    "skip2": (1.0, 2, 0.0, 0.0),
    "jerk": (1.0, 0, 0.0, 0.0),
    "reverse": (1.0, -1, 0.0, 0.0),
    "stop": (1.0, -2, 0.0, 0.0),
    "start": (1.0, -3, 0.0, 0.0),
    "drops": (1.0, -4, 0.0, 0.0),
    "jitter10": (1.0, -5, 0.0, 0.0),
}
DROPS = -4
JITTER = -5
JITTER_SHARE = 0.10  # of the frame interval
# the holds of the stop and start copies: frames held, and the sensor noise of each held copy
HOLD_FRAMES = {-2: 50, -3: 30}
HOLD_NOISE = 2.0


def kept_frames(n: int, every: int) -> list:
    """The indices of the frames a copy keeps: every n-th, (every == 0) steps of 1 or 2 drawn with a
    fixed seed, (every == -1) every frame from the last to the first, (every == -2, -3) every frame with
    the middle or the first one repeated HOLD_FRAMES times, or (every == DROPS) all but the dropped ones."""
    if every > 0:
        return list(range(0, n, every))
    if every == JITTER:
        return list(range(n))
    if every == DROPS:
        rng_d = random.Random(52)
        drop = {i for i in range(5, n - 1) if rng_d.random() < 1 / 25}
        b = rng_d.randrange(n // 3, 2 * n // 3)
        drop |= {b, b + 1, b + 2}
        return [i for i in range(n) if i not in drop]
    if every in HOLD_FRAMES:
        k = n // 2 if every == -2 else 0
        return list(range(k)) + [k] * HOLD_FRAMES[every] + list(range(k, n))
    if every < 0:
        return list(range(n - 1, -1, -1))
    rng = np.random.default_rng(7)
    keep, k = [], 0
    while k < n:
        keep.append(k)
        k += int(rng.integers(1, 3))
    return keep


def jittered_times(t_ns: list) -> list:
    """The jitter copy's stamps: each frame but the first and the last moved by up to JITTER_SHARE of the
    frame interval around it (half the distance between its neighbours), uniform, seeded."""
    rng_j = random.Random(55)
    out = []
    for i, t in enumerate(t_ns):
        if 0 < i < len(t_ns) - 1:
            t = int(t + rng_j.uniform(-JITTER_SHARE, JITTER_SHARE) * (t_ns[i + 1] - t_ns[i - 1]) / 2)
        out.append(t)
    return out


def write_copy(seq: str, dst: str, scale: float, every: int, blur: float, noise: float) -> None:
    """seq's mav0/cam0 frames degraded, with the calibration scaled and the ground truth beside them."""
    cam = os.path.join(seq, "mav0", "cam0")
    out = os.path.join(dst, "mav0", "cam0")
    os.makedirs(os.path.join(out, "data"))
    info = trajio.read_sensor_yaml(os.path.join(cam, "sensor.yaml"))
    if scale != 1.0 and any(d != 0.0 for d in info.distortion):
        raise SystemExit("bench_degrade: the sequence's camera has distortion; a resized copy needs a pinhole "
                         "sequence")
    t_ns, names = trajio.read_cam_frames(cam)
    keep = kept_frames(len(names), every)
    # a jerk or reversed copy keeps the original frame interval: frame j of the copy at t0 + j * dt
    dt = int(np.median(np.diff(t_ns))) if len(t_ns) > 1 else 0
    same_times = every > 0 or every == DROPS
    if every == JITTER:  # the frames at their own times, only their stamps moved
        t_new = jittered_times([int(t) for t in t_ns])
    else:
        t_new = [int(t_ns[k]) if same_times else int(t_ns[0]) + j * dt for j, k in enumerate(keep)]
    rng = np.random.default_rng(1)
    rows = []
    for j, (k, t) in enumerate(zip(keep, t_new)):
        # a held frame's copies are new images: named by their new times
        held = j > 0 and keep[j - 1] == k
        name = f"{t}.png" if every in HOLD_FRAMES else names[k]
        img = cv2.imread(os.path.join(cam, "data", names[k]), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise SystemExit(f"bench_degrade: cannot read {names[k]}")
        if scale != 1.0:
            img = cv2.resize(img, (int(round(img.shape[1] * scale)), int(round(img.shape[0] * scale))),
                             interpolation=cv2.INTER_AREA if scale < 1.0 else cv2.INTER_CUBIC)
        if blur > 0.0:
            img = cv2.GaussianBlur(img, (0, 0), blur)
        for sigma in (noise, HOLD_NOISE if held else 0.0):
            if sigma > 0.0:
                img = np.clip(img.astype(np.float32) + rng.normal(0.0, sigma, img.shape) + 0.5, 0, 255)
                img = img.astype(np.uint8)
        cv2.imwrite(os.path.join(out, "data", name), img)
        rows.append((int(t), name))
    with open(os.path.join(out, "data.csv"), "w", encoding="utf-8", newline="\n") as f:
        f.write("#timestamp [ns],filename\n")
        for t, name in rows:
            f.write(f"{t},{name}\n")
    fx, fy, cx, cy = info.intrinsics
    info.intrinsics = (fx * scale, fy * scale, (cx + 0.5) * scale - 0.5, (cy + 0.5) * scale - 0.5)
    info.width, info.height = int(round(info.width * scale)), int(round(info.height * scale))
    if every > 0:
        info.rate_hz = info.rate_hz / every
    trajio.write_sensor_yaml(os.path.join(out, "sensor.yaml"), info)
    gt = os.path.join(seq, "mav0", "state_groundtruth_estimate0")
    if same_times or every == JITTER:
        shutil.copytree(gt, os.path.join(dst, "mav0", "state_groundtruth_estimate0"))
        return
    # the ground truth of each kept frame, at the frame's new time
    src = trajio.read_euroc_groundtruth(gt)
    poses = trajio.interpolate_poses(src.t_ns, src.poses, t_ns[keep])
    os.makedirs(os.path.join(dst, "mav0", "state_groundtruth_estimate0"))
    trajio.write_euroc_groundtruth(os.path.join(dst, "mav0", "state_groundtruth_estimate0", "data.csv"),
                                   trajio.Trajectory(np.array(t_new, dtype=np.int64), poses, "body", ""))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seq", required=True)
    ap.add_argument("--replay", required=True)
    ap.add_argument("--work")
    ap.add_argument("--only", default="", help="comma-separated variants (default: all)")
    ap.add_argument("rest", nargs=argparse.REMAINDER)
    a = ap.parse_args()
    args = a.rest[1:] if a.rest[:1] == ["--"] else a.rest
    names = replay_copies.pick(a.only, VARIANTS, "bench_degrade")
    with replay_copies.work_folder(a.work, "tvo_degrade_") as work:
        print(f"{'variant':<9} {'ATE m':>8} {'map from':>9} {'ATE after':>10} {'rot RPE deg':>12} {'lost':>5} "
              f"{'map losses':>11}")
        for name in names:
            dst = replay_copies.fresh(work, name)
            write_copy(a.seq, dst, *VARIANTS[name])
            r = replay_copies.replay(a.replay, dst, args, work, after_map=True)
            print(f"{name:<9} {r['ate']:>8.4f} {r['init']:>9d} {r['ate_after']:>10.4f} {r['rot']:>12.4f} "
                  f"{r['lost']:>5d} {r['losses']:>11d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
