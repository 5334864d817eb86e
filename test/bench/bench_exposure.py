#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Benchmark: the VO on a real sequence whose exposure changes.

Real cameras with automatic exposure change the gain of whole frames: slowly while the exposure control
hunts, in steps when the scene's light changes, and on every other frame when a light flickers. Neither
the shared KITTI frames (fixed exposure) nor the renders have that. This program writes copies of an
EuRoC/ASL sequence with each frame's grey levels multiplied by a gain (rounded, clipped to 0..255):

  - none:    the frames as they are;
  - sine25:  1 + 0.25 sin(2 pi k / 30) for frame k (exposure hunting, +-25 % over 30 frames);
  - steps:   0.6 on frames 50-99, 1.4 from frame 130 on (two changes of light, each within one frame);
  - flicker: 0.9 and 1.1 on alternate frames (+-10 %);
  - dark35, dark20, dark12: 0.35, 0.20 and 0.12 on every frame (a camera whose exposure control has run out
    of range in a dim scene: the frame's grey levels span a third, a fifth or an eighth of what they did).

It replays each copy with `tvo_replay --scale none` and the given replay arguments, and prints the
Sim(3)-aligned ATE (m), the per-frame rotation RPE (deg), the frames without a pose and the map's losses.

Usage: .venv/bin/python test/bench/bench_exposure.py --seq SEQ --replay BUILD/examples/replay/tvo_replay
           [--work DIR] [--only NAME,NAME] [-- REPLAY ARGS]
The copies go to --work (default: a temporary folder, removed at the end).
"""
import argparse
import math
import os
import shutil
import sys

import cv2
import numpy as np

import replay_copies  # beside this file

GAINS = {
    "none": lambda k: 1.0,
    "sine25": lambda k: 1.0 + 0.25 * math.sin(2.0 * math.pi * k / 30.0),
    "steps": lambda k: 0.6 if 50 <= k < 100 else (1.4 if k >= 130 else 1.0),
    "flicker": lambda k: 1.1 if k % 2 else 0.9,
    "dark35": lambda k: 0.35,
    "dark20": lambda k: 0.20,
    "dark12": lambda k: 0.12,
}


def write_copy(seq: str, dst: str, gain) -> None:
    """seq's mav0/cam0 frames times gain(k), with its ground truth and calibration beside them."""
    cam = os.path.join(seq, "mav0", "cam0")
    out = os.path.join(dst, "mav0", "cam0")
    os.makedirs(os.path.join(out, "data"))
    for f in ("data.csv", "sensor.yaml"):
        shutil.copy(os.path.join(cam, f), os.path.join(out, f))
    gt = os.path.join(seq, "mav0", "state_groundtruth_estimate0")
    if os.path.isdir(gt):
        shutil.copytree(gt, os.path.join(dst, "mav0", "state_groundtruth_estimate0"))
    for k, name in enumerate(sorted(os.listdir(os.path.join(cam, "data")))):
        img = cv2.imread(os.path.join(cam, "data", name), cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise SystemExit(f"bench_exposure: cannot read {name}")
        g = np.clip(img.astype(np.float32) * gain(k) + 0.5, 0, 255).astype(np.uint8)
        cv2.imwrite(os.path.join(out, "data", name), g)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seq", required=True)
    ap.add_argument("--replay", required=True)
    ap.add_argument("--work")
    ap.add_argument("--only", default="", help="comma-separated copies (default: all)")
    ap.add_argument("rest", nargs=argparse.REMAINDER)
    a = ap.parse_args()
    args = a.rest[1:] if a.rest[:1] == ["--"] else a.rest
    names = replay_copies.pick(a.only, GAINS, "bench_exposure")
    with replay_copies.work_folder(a.work, "tvo_exposure_") as work:
        print(f"{'gain':<8} {'ATE m':>8} {'rot RPE deg':>12} {'lost':>5} {'map losses':>11}")
        for name in names:
            dst = replay_copies.fresh(work, name)
            write_copy(a.seq, dst, GAINS[name])
            r = replay_copies.replay(a.replay, dst, args, work)
            print(f"{name:<8} {r['ate']:>8.4f} {r['rot']:>12.4f} {r['lost']:>5d} {r['losses']:>11d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
