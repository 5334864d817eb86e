#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Benchmark: tinyvo pyramids + pyramidal LK vs OpenCV, in ONE process, single thread.

On EuRoC V1_01_easy_head cam0 -> cam1 pairs (real stereo, disparities up to tens of px) and on
consecutive cam0 frames, 300 goodFeaturesToTrack points, 21x21 window, max level 3, 30 iterations,
epsilon 0.01. Prints medians (ms) and the ratio tinyvo / OpenCV:
  - pyramid: tvo_pyramid_build (4 levels) vs cv2.buildOpticalFlowPyramid (same levels, no derivatives)
  - tracking: tvo_lk_track on built pyramids vs (cv2.calcOpticalFlowPyrLK on images) minus the two
    pyramid builds OpenCV does inside (Python cannot hand OpenCV ready pyramids); OpenCV's tracking
    time still includes its per-level Scharr derivative images, which tinyvo computes per window
  - total: both pyramids + tracking vs one cv2.calcOpticalFlowPyrLK call on the two images.

Usage: TVO_BUILD_DIR=build/<dir> .venv/bin/python test/bench/bench_lk.py [--reps N] [--pairs N]
"""
import argparse
import ctypes
import os
import pathlib
import sys
import time

import cv2
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "test" / "oracle"))
from test_lk_oracle import TvoLK, corners, CRIT  # noqa: E402

WIN, LEVEL = 21, 3


def median_ms(fns, reps):
    """Median ms of each function; the functions are called alternately, rep by rep, so that load
    changes on a shared machine hit all of them alike."""
    ts = [[] for _ in fns]
    for _ in range(reps):
        for k, fn in enumerate(fns):
            t0 = time.perf_counter()
            fn()
            ts[k].append(time.perf_counter() - t0)
    return [1e3 * float(np.median(t)) for t in ts]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--reps", type=int, default=15)
    ap.add_argument("--pairs", type=int, default=6)
    ap.add_argument("--points", type=int, default=300)
    args = ap.parse_args()
    cv2.setNumThreads(1)
    build = pathlib.Path(os.environ.get("TVO_BUILD_DIR", ROOT / "build" / "release"))
    lib = ctypes.CDLL(str(build / "test" / "libtinyvo_py.so"))
    lk = TvoLK(lib)
    data = pathlib.Path(os.environ.get("TVO_DATA_DIR", ROOT.parent / "shared" / "data"))
    root = data / "euroc" / "V1_01_easy_head" / "mav0"
    names = sorted((root / "cam0" / "data").glob("*.png"))
    if not names:
        sys.exit(f"no EuRoC frames under {root}")
    step = max(1, len(names) // args.pairs)
    jobs = []
    for f0 in names[::step][:args.pairs]:
        a = cv2.imread(str(f0), cv2.IMREAD_GRAYSCALE)
        jobs.append(("stereo", a, cv2.imread(str(root / "cam1" / "data" / f0.name), cv2.IMREAD_GRAYSCALE)))
        i = names.index(f0)
        if i + 1 < len(names):
            jobs.append(("temporal", a, cv2.imread(str(names[i + 1]), cv2.IMREAD_GRAYSCALE)))

    h, w = jobs[0][1].shape
    cfg = lk.config(win=WIN, max_level=LEVEL)
    scratch = lk.scratch(cfg)
    pa, pb = lk.pyramid(w, h, LEVEL + 1), lk.pyramid(w, h, LEVEL + 1)
    rows = []
    for kind, a, b in jobs:
        pts = corners(a, args.points)
        p = pts.reshape(-1, 1, 2)
        lk.build(pa, a)
        lk.build(pb, b)
        t_pyr_tvo, t_pyr_cv = median_ms(
            [lambda: lk.build(pa, a),
             lambda: cv2.buildOpticalFlowPyramid(a, (WIN, WIN), LEVEL, withDerivatives=False)], args.reps)
        t_trk_tvo, t_all_cv = median_ms(
            [lambda: lk.track(cfg, pa, pb, pts, scratch=scratch),
             lambda: cv2.calcOpticalFlowPyrLK(a, b, p, None, winSize=(WIN, WIN), maxLevel=LEVEL,
                                              criteria=CRIT)], args.reps)
        _, st, _ = lk.track(cfg, pa, pb, pts, scratch=scratch)
        _, rst, _ = cv2.calcOpticalFlowPyrLK(a, b, p, None, winSize=(WIN, WIN), maxLevel=LEVEL, criteria=CRIT)
        t_trk_cv = t_all_cv - 2 * t_pyr_cv
        rows.append((kind, len(pts), int(st.sum()), int(rst.sum()), t_pyr_tvo, t_pyr_cv, t_trk_tvo, t_trk_cv,
                     2 * t_pyr_tvo + t_trk_tvo, t_all_cv))

    print(f"tinyvo vs OpenCV {cv2.__version__}, single thread, {w}x{h}, win {WIN}, max level {LEVEL}, "
          f"{args.reps} reps per figure (median)")
    print(f"{'pair':9} {'pts':>4} {'trk tvo/cv':>11} | {'pyr tvo':>8} {'pyr cv':>8} {'ratio':>6} | "
          f"{'trk tvo':>8} {'trk cv':>8} {'ratio':>6} | {'all tvo':>8} {'all cv':>8} {'ratio':>6}")
    for r in rows:
        print(f"{r[0]:9} {r[1]:4d} {r[2]:5d}/{r[3]:<5d} | {r[4]:8.3f} {r[5]:8.3f} {r[4] / r[5]:6.2f} | "
              f"{r[6]:8.3f} {r[7]:8.3f} {r[6] / r[7]:6.2f} | {r[8]:8.3f} {r[9]:8.3f} {r[8] / r[9]:6.2f}")
    arr = np.array([r[4:] for r in rows])
    med = np.median(arr, axis=0)
    print(f"median over pairs (ms): pyramid tinyvo {med[0]:.3f} OpenCV {med[1]:.3f} ratio {med[0] / med[1]:.2f}; "
          f"tracking tinyvo {med[2]:.3f} OpenCV {med[3]:.3f} ratio {med[2] / med[3]:.2f}; "
          f"total tinyvo {med[4]:.3f} OpenCV {med[5]:.3f} ratio {med[4] / med[5]:.2f}")


if __name__ == "__main__":
    main()
