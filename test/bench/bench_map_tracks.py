#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Benchmark: what the tracks' errors cost the local map, on a tinyvo-synth render.

The render knows where every tracked point really is (tinyvo_tools.synth's ray caster gives the range
of every pixel). This program replays the render with `tvo_replay --tracks`, takes the surface point
under each track's birth pixel, and feeds the VO's map module alone (the `bench_map_tracks` binary:
keyframes, triangulation, PnP, windowed bundle adjustment; ground-truth two-view rotations) with:

  - true:   every track at the true projection of its point, for as long as the VO kept it;
  - real:   every track where the VO's tracker put it;
  - real, ended above E px: the tracker's positions, each track ended at the first frame where it is
    more than E px from the truth (an oracle: what a perfect check of that size would leave).

With --no-truth (any EuRoC/ASL sequence with ground-truth poses, e.g. the real KITTI ones) only the
tracker's positions are fed, which tells whether the two-view rotations matter: compare with the VO's own
figures, printed beside them.

For each it prints the frames the map posed (the others are left out of the figures: a run that keeps too
few tracks loses its map), the Sim(3)-aligned ATE (m), the per-frame rotation RPE (deg) and the scale of
the last quarter of the run relative to the first (each quarter Sim(3)-aligned on its own; 1 is no drift).

Usage: .venv/bin/python test/bench/bench_map_tracks.py --seq RENDER --replay BUILD/examples/replay/tvo_replay
           --map-bench BUILD/test/bench_map_tracks [--seed S] [--ends 0.5,1,2] [--no-truth] [-- REPLAY ARGS]
RENDER is a folder written by tinyvo-synth with scene seed S (default 0).
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(ROOT, "tools"))
from bench_track_drift import Render, normalised, read_tracks  # noqa: E402
from tinyvo_tools import eval as tvo_eval  # noqa: E402
from tinyvo_tools import trajio  # noqa: E402


def true_positions(render, t, ids, xy, age):
    """Normalised true projection of every row's point (NaN where unknown) and the tracker's own."""
    frame = np.array([render.frame_of[int(v)] for v in t])
    origin = {}
    for f in np.unique(frame[age == 0]):
        sel = np.where((frame == f) & (age == 0))[0]
        rng, _ = render.cast(f)
        T = render.traj.poses[f]
        rays = render.ray(xy[sel])
        for k, i in enumerate(sel):
            x, y = np.rint(xy[i]).astype(int)
            origin[ids[i]] = T[:3, 3] + rng[y, x] * (T[:3, :3] @ rays[k])
    real = normalised(render.cam, xy)
    true = np.full_like(real, np.nan)
    for i in range(len(t)):
        X = origin.get(ids[i])
        if X is None:
            continue
        T = render.traj.poses[frame[i]]
        Xc = (X - T[:3, 3]) @ T[:3, :3]
        if Xc[2] > 0:
            true[i] = Xc[:2] / Xc[2]
    return frame, real, true


def write_tracks(path, t, ids, age, pos, keep):
    """The bench's track file: one marker row per frame, then the kept rows."""
    with open(path, "w", encoding="utf-8") as f:
        last = None
        for i in range(len(t)):
            if t[i] != last:
                f.write(f"{t[i]} -1 1 0 0\n")
                last = t[i]
            if keep[i]:
                f.write(f"{t[i]} {ids[i]} {age[i]} {pos[i, 0]:.10f} {pos[i, 1]:.10f}\n")


def ended_above(t, ids, err_px, limit):
    """Rows kept when every track ends at its first row more than limit px from the truth."""
    keep = np.ones(len(t), dtype=bool)
    dead = set()
    for i in np.lexsort((ids, t)):
        if ids[i] in dead or not np.isfinite(err_px[i]) or err_px[i] > limit:
            dead.add(ids[i])
            keep[i] = False
    return keep


def write_tum(path, t_s, poses):
    """Camera poses (4x4, camera to world) at times t_s (s) in TUM format."""
    with open(path, "w", encoding="utf-8") as f:
        for ts, T in zip(t_s, poses):
            R = T[:3, :3]
            q = [np.copysign(np.sqrt(max(0.0, 1 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2]),
                 np.copysign(np.sqrt(max(0.0, 1 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0]),
                 np.copysign(np.sqrt(max(0.0, 1 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1]),
                 np.sqrt(max(0.0, 1 + np.trace(R))) / 2]
            f.write(f"{ts:.9f} " + " ".join(f"{v:.10f}" for v in list(T[:3, 3]) + q) + "\n")


def map_args(replay_args):
    """The replay's --preset and its map settings (--set map_*), for the map bench: the map runs with the
    configuration the tracks were recorded with."""
    out = []
    for k in range(len(replay_args) - 1):
        name, value = replay_args[k], replay_args[k + 1]
        if name == "--preset" or (name == "--set" and value.startswith("map_")):
            out += [name, value]
    return out


def run_map(a, cam, gt, tf, est):
    """The bench binary on one track file; (frames posed text, ATE, rot RPE, scale drift)."""
    fu, fv, cu, cv = cam.intrinsics
    out = subprocess.run([a.map_bench, gt, tf, est, "--camera", str(cam.width), str(cam.height), str(fu), str(fv),
                          str(cu), str(cv)] + map_args(a.replay_args), check=True, capture_output=True,
                         text=True).stdout
    words = out.split()
    posed = f"{words[words.index('posed') + 1]} of {words[words.index('frames') + 1]}"
    ev = tvo_eval.evaluate_files(est, gt, gt_format="tum")
    r = ev.result["standard"]
    return posed, r["ate_m"]["rmse"], r["rpe_frame"]["rotation_deg"]["rmse"], quarter_scale_drift(ev)


def no_truth(a, extra, tmp):
    """The map fed with the VO's tracks of a real sequence, beside the VO's own figures."""
    cam = trajio.read_sensor_yaml(os.path.join(a.seq, "mav0", "cam0", "sensor.yaml"))
    csv, vo = os.path.join(tmp, "tracks.csv"), os.path.join(tmp, "vo.txt")
    subprocess.run([a.replay, "--euroc", a.seq, "--scale", "none", "--out", vo, "--tracks", csv, "--quiet"] + extra,
                   check=True)
    t, ids, xy, age = read_tracks(csv)
    ev = tvo_eval.evaluate_files(vo, a.seq)
    gt = os.path.join(tmp, "gt.tum")
    write_tum(gt, ev.t_s, ev.gt)
    if len(ev.t_s) != len(np.unique(t)):
        raise SystemExit("bench_map_tracks: the ground truth does not cover every frame of the replay")
    tf, est = os.path.join(tmp, "t.txt"), os.path.join(tmp, "est.tum")
    write_tracks(tf, t, ids, age, normalised(cam, xy), np.ones(len(t), dtype=bool))
    posed, ate, rot, drift = run_map(a, cam, gt, tf, est)
    r = ev.result["standard"]
    print(f"{a.seq}: {len(np.unique(ids))} tracks")
    print("| run | frames posed | ATE, m | rot RPE, deg | scale drift, last / first quarter |")
    print("|---|---|---|---|---|")
    print(f"| the VO | {len(ev.t_s)} of {len(ev.t_s)} | {r['ate_m']['rmse']:.4f} | "
          f"{r['rpe_frame']['rotation_deg']['rmse']:.4f} | {quarter_scale_drift(ev):.4f} |")
    print(f"| its map fed with its tracks and the true two-view rotations | {posed} | {ate:.4f} | {rot:.4f} | "
          f"{drift:.4f} |")
    return 0


def quarter_scale_drift(ev):
    g, e = ev.gt[:, :3, 3], ev.est_aligned[:, :3, 3]
    n, s = len(g), []
    for q in (0, 3):
        G, X = g[q * n // 4:(q + 1) * n // 4], e[q * n // 4:(q + 1) * n // 4]
        Gc, Xc = G - G.mean(0), X - X.mean(0)
        U, S, Vt = np.linalg.svd(Gc.T @ Xc)
        D = np.eye(3)
        D[2, 2] = np.sign(np.linalg.det(U @ Vt))
        s.append(np.trace(np.diag(S) @ D) / (Xc ** 2).sum())
    return s[1] / s[0]


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    extra = []
    if "--" in argv:
        extra = argv[argv.index("--") + 1:]
        argv = argv[:argv.index("--")]
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seq", required=True, help="a tinyvo-synth render (EuRoC/ASL folder)")
    ap.add_argument("--replay", required=True, help="the tvo_replay binary")
    ap.add_argument("--map-bench", required=True, help="the bench_map_tracks binary")
    ap.add_argument("--seed", type=int, default=0, help="the render's scene seed (tinyvo-synth --seed)")
    ap.add_argument("--ends", default="0.5,1,2", help="error limits (px) of the oracle runs")
    ap.add_argument("--no-truth", action="store_true",
                    help="a sequence that is not a render: feed the tracker's positions only")
    a = ap.parse_args(argv)
    a.replay_args = extra
    if a.no_truth:
        with tempfile.TemporaryDirectory() as tmp:
            return no_truth(a, extra, tmp)
    render = Render(a.seq, a.seed)
    fu = render.cam.intrinsics[0]
    with tempfile.TemporaryDirectory() as tmp:
        csv = os.path.join(tmp, "tracks.csv")
        subprocess.run([a.replay, "--euroc", a.seq, "--scale", "none", "--out", os.path.join(tmp, "vo.txt"),
                        "--tracks", csv, "--quiet"] + extra, check=True)
        t, ids, xy, age = read_tracks(csv)
        frame, real, true = true_positions(render, t, ids, xy, age)
        err_px = np.hypot(*(real - true).T) * fu
        gt = os.path.join(tmp, "gt.tum")
        ts = np.unique(t)
        write_tum(gt, ts * 1e-9, [render.traj.poses[render.frame_of[int(v)]] for v in ts])
        runs = [("true", true, np.isfinite(true[:, 0])), ("real", real, np.ones(len(t), dtype=bool))]
        for e in [float(v) for v in a.ends.split(",") if v]:
            runs.append((f"real, ended above {e:g} px", real, ended_above(t, ids, err_px, e)))
        print(f"{a.seq}: {len(np.unique(ids))} tracks; tracker error median {np.nanmedian(err_px):.3f} px, "
              f"p90 {np.nanpercentile(err_px, 90):.3f} px over all rows")
        print("| tracks | frames posed | ATE, m | rot RPE, deg | scale drift, last / first quarter | rows kept |")
        print("|---|---|---|---|---|---|")
        for name, pos, keep in runs:
            tf, est = os.path.join(tmp, "t.txt"), os.path.join(tmp, "est.tum")
            write_tracks(tf, t, ids, age, pos, keep)
            posed, ate, rot, drift = run_map(a, render.cam, gt, tf, est)
            print(f"| {name} | {posed} | {ate:.4f} | {rot:.4f} | {drift:.4f} | {keep.mean():.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
