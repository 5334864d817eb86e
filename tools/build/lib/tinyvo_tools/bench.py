# SPDX-License-Identifier: Apache-2.0
"""Side-by-side benchmark: tinyvo's replay against OpenCV pipelines doing the same job.

    python -m tinyvo_tools.bench --euroc DIR [--frames N] [--replay build/release/examples/replay/tvo_replay]
                                 [--out OUTDIR] [--repeat N] [--pipeline plain|fb|both] [--preset NAME]

All run on the same frames, single thread, in one session, with ground-truth step lengths:
  tinyvo : tvo_replay --scale gt (its per-stage timings come from --stats: median and p90 per frame), with
           --preset NAME when given (default, balanced, accurate, basic, small)
  OpenCV, two pipelines (undistortPoints, findEssentialMat (RANSAC, p = 0.999, 1 px) and recoverPose in both):
    fb    : goodFeaturesToTrack (300 corners, re-detect below 200, min distance 10 px), calcOpticalFlowPyrLK
            (21x21, maxLevel 3, 30 iterations / 0.01) forward and backward, a track kept when it comes back
            within 1 px (the check tinyvo does);
    plain : goodFeaturesToTrack (500 corners, re-detect below 200, min distance 10 px), one calcOpticalFlowPyrLK
            pass (21x21, maxLevel 3, 30 iterations / 0.01), no forward-backward check.
  --pipeline both (default) runs the two.
Per-frame times exclude PNG decoding for all. Accuracy of the trajectories comes from tinyvo_tools.eval (evo).
With --repeat N tinyvo and the pipelines alternate N times: the table shows the last run, the ratio lines
the median of the N per-run ratios (the figure to quote on a shared machine). OpenCV is a test/benchmark
dependency only; the library never uses it.
"""
import json
import os
import subprocess
import sys
import time

import numpy as np

from . import cli, trajio


def _rot_to_quat_xyzw(R):
    from scipy.spatial.transform import Rotation
    return Rotation.from_matrix(R).as_quat()


PIPELINES = {"fb": dict(max_corners=300, fb_check=True), "plain": dict(max_corners=500, fb_check=False)}


def opencv_pipeline(seq_dir, cam="cam0", max_frames=None, max_corners=300, min_tracks=200, fb_check=True):
    """Run an OpenCV pipeline over a EuRoC folder (see the module doc: fb_check True is "fb", False with 500
    corners "plain"). Returns (t_ns, poses T_W_C (N,4,4), per-frame ms)."""
    import cv2
    cv2.setNumThreads(1)
    camdir = os.path.join(seq_dir, "mav0", cam)
    info = trajio.read_sensor_yaml(os.path.join(camdir, "sensor.yaml"))
    fx, fy, cx, cy = info.intrinsics
    K = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]], dtype=np.float64)
    D = np.array(list(info.distortion) + [0.0] * (5 - len(info.distortion)), dtype=np.float64)
    t_ns, names = trajio.read_cam_frames(camdir)
    if max_frames:
        t_ns, names = t_ns[:max_frames], names[:max_frames]
    gt = trajio.read_euroc_groundtruth(os.path.join(seq_dir, "mav0", "state_groundtruth_estimate0",
                                                    "data.csv")).to_camera(info.T_BS)
    gt_at = trajio.interpolate_poses(gt.t_ns, gt.poses, t_ns)
    lk = dict(winSize=(21, 21), maxLevel=3,
              criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 30, 0.01))
    f = 0.5 * (fx + fy)
    poses, times = [], []
    T = gt_at[0].copy()
    prev, pts = None, None
    for i, name in enumerate(names):
        img = cv2.imread(os.path.join(camdir, "data", name), cv2.IMREAD_GRAYSCALE)
        t0 = time.perf_counter()
        if prev is not None and pts is not None and len(pts) >= 8:
            nxt, st, _ = cv2.calcOpticalFlowPyrLK(prev, img, pts, None, **lk)
            if fb_check:
                back, st2, _ = cv2.calcOpticalFlowPyrLK(img, prev, nxt, None, **lk)
                good = (st[:, 0] == 1) & (st2[:, 0] == 1) & (np.linalg.norm(back - pts, axis=2)[:, 0] < 1.0)
            else:
                good = st[:, 0] == 1
            p0, p1 = pts[good], nxt[good]
            pts = p1
            if len(p0) >= 8:
                u0 = cv2.undistortPoints(p0, K, D)
                u1 = cv2.undistortPoints(p1, K, D)
                E, mask = cv2.findEssentialMat(u0, u1, np.eye(3), method=cv2.RANSAC, prob=0.999,
                                               threshold=1.0 / f)
                if E is not None and E.shape == (3, 3):
                    _, R, t, mask = cv2.recoverPose(E, u0, u1, np.eye(3), mask=mask)
                    # X1 = R X0 + t  ->  T_prev_cur = inv([R|t])
                    Tc = np.eye(4)
                    Tc[:3, :3] = R.T
                    Tc[:3, 3] = (-R.T @ t).ravel()
                    rel = trajio.inv_pose(gt_at[i - 1]) @ gt_at[i]
                    Tc[:3, 3] *= np.linalg.norm(rel[:3, 3])
                    T = T @ Tc
                    pts = p1[mask.ravel() > 0] if mask is not None else p1
        if pts is None or len(pts) < min_tracks:
            m = np.full(img.shape, 255, np.uint8)
            if pts is not None:
                for p in pts.reshape(-1, 2):
                    cv2.circle(m, (int(p[0]), int(p[1])), 10, 0, -1)
            want = max_corners - (0 if pts is None else len(pts))
            new = cv2.goodFeaturesToTrack(img, want, 0.01, 10, mask=m) if want > 0 else None
            if new is not None:
                new = new.astype(np.float32)
                pts = new if pts is None or len(pts) == 0 else np.vstack([pts.reshape(-1, 1, 2), new])
        times.append((time.perf_counter() - t0) * 1e3)
        poses.append(T.copy())
        prev = img
    return t_ns, np.array(poses), np.array(times)


def _eval(traj_path, seq_dir, out_json):
    subprocess.run([sys.executable, "-m", "tinyvo_tools.eval", "--est", traj_path, "--gt", seq_dir,
                    "--out", out_json], check=True, stdout=subprocess.DEVNULL)
    with open(out_json) as fh:
        return json.load(fh)


def main(argv=None):
    ap = cli.parser("tinyvo-bench", __doc__)
    ap.add_argument("--euroc", required=True, help="EuRoC/ASL folder (holding mav0/)")
    ap.add_argument("--frames", type=int, default=0, help="frames to use (0 = all)")
    ap.add_argument("--replay", default=os.path.join("build", "release", "examples", "replay", "tvo_replay"),
                    help="tvo_replay binary (default build/release/examples/replay/tvo_replay)")
    ap.add_argument("--out", default=os.path.join("out", "bench"),
                    help="output folder: trajectories, evaluations, bench.json (default out/bench)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="alternate the pipelines this many times and report the median of the per-run "
                         "ratios (a load change on a shared machine then biases one run, not the figure)")
    ap.add_argument("--pipeline", choices=("plain", "fb", "both"), default="both",
                    help="OpenCV pipeline(s) to compare with (module doc)")
    ap.add_argument("--preset", choices=("default", "balanced", "accurate", "basic", "small"), default=None,
                    help="tinyvo's configuration (tvo_replay --preset; default: the library's defaults)")
    a = ap.parse_args(argv)
    if a.repeat < 1:
        ap.error("--repeat must be >= 1")
    if a.frames < 0:
        ap.error("--frames must be >= 0")
    return cli.run(ap.prog, lambda: _main(a))


def _main(a) -> int:
    if not os.path.isdir(os.path.join(a.euroc, "mav0")):
        raise cli.Failure(f"{a.euroc}: no mav0/ folder (not an EuRoC/ASL sequence)")
    if not (os.path.isfile(a.replay) and os.access(a.replay, os.X_OK)):
        raise cli.Failure(f"{a.replay}: no tvo_replay program there (build it or pass --replay)")
    os.makedirs(a.out, exist_ok=True)
    say = (lambda *x: None) if a.quiet else print
    names = ["plain", "fb"] if a.pipeline == "both" else [a.pipeline]

    tvo_traj = os.path.join(a.out, "tinyvo.txt")
    stats_path = os.path.join(a.out, "tinyvo_stats.json")
    cmd = [a.replay, "--euroc", a.euroc, "--out", tvo_traj, "--scale", "gt", "--stats", stats_path, "--quiet"]
    if a.frames:
        cmd += ["--max-frames", str(a.frames)]
    if a.preset:
        cmd += ["--preset", a.preset]
    runs = []  # per alternation: tinyvo median ms and each pipeline's median ms
    last = {}
    for _ in range(a.repeat):
        subprocess.run(cmd, check=True)
        with open(stats_path) as fh:
            stats = json.load(fh)
        run = {"tinyvo": stats["timing_us"]["total"]["median"] / 1e3}
        for name in names:
            t_ns, poses, ms = opencv_pipeline(a.euroc, max_frames=a.frames or None, **PIPELINES[name])
            run[name] = float(np.median(ms[1:]))
            last[name] = (t_ns, poses, ms)
        for name in names:  # "ratio": against the fb pipeline (the key of the single-pipeline output)
            run["ratio" if name == "fb" else f"ratio_{name}"] = run["tinyvo"] / run[name]
        runs.append(run)

    ev_t = _eval(tvo_traj, a.euroc, os.path.join(a.out, "tinyvo_eval.json"))
    tv_med = stats["timing_us"]["total"]["median"] / 1e3
    tv_p90 = stats["timing_us"]["total"]["p90"] / 1e3
    result = {"frames": int(len(last[names[0]][0])), "preset": a.preset or "default",
              "tinyvo": {"median_ms": tv_med, "p90_ms": tv_p90, "eval": ev_t, "stats": stats},
              "runs": runs}
    for name in names:
        t_ns, poses, ms = last[name]
        path = os.path.join(a.out, f"opencv_{name}.txt")
        trajio.write_tum(path, trajio.Trajectory(t_ns, poses, "camera"))
        ev = _eval(path, a.euroc, os.path.join(a.out, f"opencv_{name}_eval.json"))
        med, p90 = float(np.median(ms[1:])), float(np.percentile(ms[1:], 90))
        result[f"opencv_{name}"] = {"median_ms": med, "p90_ms": p90, "eval": ev,
                                    "ratio_median_tinyvo_over_opencv": tv_med / med if med > 0 else None,
                                    "ratios_of_runs": [r["tinyvo"] / r[name] for r in runs],
                                    "ratio_median_of_runs": float(np.median([r["tinyvo"] / r[name] for r in runs]))}
    if "fb" in names:  # the keys of the earlier single-pipeline output
        result["opencv"] = result["opencv_fb"]
        result["ratio_median_tinyvo_over_opencv"] = result["opencv_fb"]["ratio_median_tinyvo_over_opencv"]
        result["ratio_median_of_runs"] = result["opencv_fb"]["ratio_median_of_runs"]
    with open(os.path.join(a.out, "bench.json"), "w") as fh:
        json.dump(result, fh, indent=2)

    def row(name, med, p90, ev):
        std = ev["standard"]
        ate = std["ate_m"]["rmse"]
        rpe_t = std["rpe_frame"]["translation_m"]["rmse"]
        rpe_r = std["rpe_frame"]["rotation_deg"]["rmse"]
        return (f"{name:13s} {med:9.3f} {p90:9.3f}   ATE({std['alignment']['type']}) {ate:.4f} m   "
                f"RPE/frame {rpe_t:.5f} m {rpe_r:.3f} deg")
    say(f"frames: {result['frames']} ({a.euroc})")
    say(f"{'':13s} {'median ms':>9s} {'p90 ms':>9s}")
    say(row("tinyvo", tv_med, tv_p90, ev_t))
    for name in names:
        r = result[f"opencv_{name}"]
        say(row(f"opencv {name}", r["median_ms"], r["p90_ms"], r["eval"]))
    for name in names:
        r = result[f"opencv_{name}"]
        line = f"ratio tinyvo/opencv {name} (median per frame): {r['ratio_median_tinyvo_over_opencv']:.3f}"
        if len(runs) > 1:
            rs = " ".join(f"{x:.3f}" for x in r["ratios_of_runs"])
            line += f"; {len(runs)} alternating runs: {rs}; median of runs {r['ratio_median_of_runs']:.3f}"
        say(line)
    say(f"written: {os.path.join(a.out, 'bench.json')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
