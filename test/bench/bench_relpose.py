# SPDX-License-Identifier: Apache-2.0
"""Benchmark: tinyvo_relpose_estimate vs cv2.findEssentialMat (+ recoverPose) on the same synthetic
input, one process, single thread. 300 correspondences, 30 % outliers, 0.5 px noise, f = 460.

    TVO_BUILD_DIR=build/<dir> .venv/bin/python test/bench/bench_relpose.py [scenes]

Prints median times per call and the tinyvo / OpenCV ratio (< 1: tinyvo faster), plus accuracy.
tinyvo's variants are timed warm (each scene's first call, which follows OpenCV's and finds the caches
full of OpenCV's code and data, is timed separately and printed as the cold figure); the ratios use
the warm full call."""
import ctypes
import os
import pathlib
import sys
import time

import numpy as np
import cv2

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "test" / "oracle"))
import test_relpose_oracle as T  # noqa: E402


def main():
    scenes = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    cv2.setNumThreads(1)
    build = pathlib.Path(os.environ.get("TVO_BUILD_DIR", ROOT / "build" / "release"))
    rp = T.TvoRelpose(ctypes.CDLL(str(build / "test" / "libtinyvo_py.so")))
    rng = np.random.default_rng(7)
    cfg_full = rp.config()
    cfg_noh = rp.config(use_homography=0)
    cfg_ransac = rp.config(use_homography=0, refine_iters=0)
    t_cold, t_full, t_noh, t_ransac, t_cv, t_cvrp = [], [], [], [], [], []
    err = {"tinyvo": [], "opencv": []}
    thr = 1.0 / 460
    for k in range(scenes):
        x1, x2, R, t = T.synthetic_scene(rng)
        x1 = np.ascontiguousarray(x1)
        x2 = np.ascontiguousarray(x2)
        cfg_full.seed = cfg_noh.seed = cfg_ransac.seed = k
        # The first call after OpenCV's runs with caches full of OpenCV's code and data: timed on
        # its own (cold), then the variants are timed warm, as back-to-back calls are.
        for cfg, acc in ((cfg_full, t_cold), (cfg_full, t_full), (cfg_noh, t_noh), (cfg_ransac, t_ransac)):
            t0 = time.perf_counter()
            st, Re, te, out, _ = rp.estimate(x1, x2, cfg)
            acc.append(time.perf_counter() - t0)
            if acc is t_full:
                err["tinyvo"].append((T.rot_err_deg(Re, R), T.t_err_deg(te, t)))
        t0 = time.perf_counter()
        E, mask = cv2.findEssentialMat(x1, x2, focal=1.0, pp=(0.0, 0.0), method=cv2.RANSAC, prob=0.999,
                                       threshold=thr)
        t_cv.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        _, Ro, to, _ = cv2.recoverPose(E[:3], x1, x2, focal=1.0, pp=(0.0, 0.0), mask=mask)
        t_cvrp.append(time.perf_counter() - t0 + t_cv[-1])
        err["opencv"].append((T.rot_err_deg(Ro, R), T.t_err_deg(to.ravel(), t)))
    m = lambda a: float(np.median(a)) * 1e3  # noqa: E731
    print(f"{scenes} scenes, 300 pts, 30% outliers, 0.5 px noise (median ms per call)")
    print(f"  tinyvo relpose (5pt + H + rotation model + LM): {m(t_full):.3f} ms "
          f"(first call after OpenCV's, cold caches: {m(t_cold):.3f} ms)")
    print(f"  tinyvo relpose without homography model:       {m(t_noh):.3f} ms")
    print(f"  tinyvo RANSAC + pose only (no H, no LM polish): {m(t_ransac):.3f} ms")
    print(f"  cv2.findEssentialMat:                          {m(t_cv):.3f} ms")
    print(f"  cv2.findEssentialMat + recoverPose:            {m(t_cvrp):.3f} ms")
    print(f"  ratio tinyvo(full) / findEssentialMat = {m(t_full) / m(t_cv):.2f}, "
          f"/ findEssentialMat+recoverPose = {m(t_full) / m(t_cvrp):.2f}")
    for name, e in err.items():
        e = np.array(e)
        ok = np.mean((e[:, 0] < 1) & (e[:, 1] < 5)) * 100
        print(f"  {name}: median rot {np.median(e[:, 0]):.4f} deg, t {np.median(e[:, 1]):.3f} deg, "
              f"success {ok:.1f}%")


if __name__ == "__main__":
    main()
