#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Benchmark: how far the VO's tracks are from where the scene really is, on a tinyvo-synth render.

A render knows its geometry: the range of every pixel in every frame (tinyvo_tools.synth's ray caster)
and the camera's pose. A corner detected at pixel p of frame k is the surface point at range r along
p's ray; in frame k + a it must be where that point projects. This program replays the render with
`tvo_replay --tracks`, and for every track born on a single surface (its whole LK window on one face
of the scene, so that no depth edge is inside it) prints, per track age a (frames since detection):

  - the median and p90 distance between the track and the true projection, in pixels;
  - the median of the error along the true displacement since detection (a lag behind the motion
    would show here).

It then isolates the tracker's model from the VO: from one frame f0, the same corners are aligned
directly to the noise-free frame f0 + gap, starting at the true position, with OpenCV's pyramidal LK
(translation only, 21x21, level 0) and with OpenCV's ECC alignment of the same 21x21 template under an
affine warp. What translation-only LK loses to the patch's deformation (scale and perspective change
with the camera's motion), the affine alignment keeps.

Usage: .venv/bin/python test/bench/bench_track_drift.py --seq RENDER --replay build/release/examples/replay/tvo_replay
           [--frames N] [--seed S] [--f0 K] [--gaps 1,5,20] [-- REPLAY ARGS]
RENDER is a folder written by tinyvo-synth with scene seed S (default 0, the tool's default).
"""
import argparse
import os
import subprocess
import sys
import tempfile
from collections import defaultdict

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from tinyvo_tools import synth, trajio  # noqa: E402

HALF = 10  # LK's 21x21 window
AGES = (1, 2, 3, 5, 8, 12, 20, 30, 50, 80)


def normalised(cam, px):
    """Undistorted normalised coordinates (N,2) of pixel positions px (N,2) of an ASL camera."""
    fu, fv, cu, cv = cam.intrinsics
    x, y = (px[:, 0] - cu) / fu, (px[:, 1] - cv) / fv
    if cam.distortion_model.startswith("radial") and any(cam.distortion):
        x, y = synth.undistort_radtan(x, y, cam.distortion)
    return np.stack([x, y], axis=1)


def read_tracks(path):
    """A `tvo_replay --tracks` CSV (t_ns,id,x,y,age,flags) as arrays: t_ns (int64: a float loses its
    nanoseconds), id, pixel positions (N,2), age."""
    with open(path, encoding="utf-8") as f:
        cells = [line.split(",") for line in f.read().splitlines()[1:] if line]
    t = np.array([int(c[0]) for c in cells], dtype=np.int64)
    ids = np.array([int(c[1]) for c in cells])
    xy = np.array([[float(c[2]), float(c[3])] for c in cells]).reshape(-1, 2)
    age = np.array([int(c[4]) for c in cells])
    return t, ids, xy, age


class Render:
    """The render's camera, camera poses (by frame and timestamp) and scene."""

    def __init__(self, seq, seed):
        self.cam = trajio.read_sensor_yaml(os.path.join(seq, "mav0", "cam0", "sensor.yaml"))
        body = trajio.read_euroc_groundtruth(os.path.join(seq, "mav0", "state_groundtruth_estimate0", "data.csv"))
        self.traj = body.to_camera(self.cam.T_BS)
        self.frame_of = {int(t): i for i, t in enumerate(self.traj.t_ns)}
        self.ren = synth.Renderer(synth.make_scene(self.traj.positions, seed=seed), self.cam)
        self._cast = {}

    def cast(self, f):
        """(range image, face-id image) of frame f."""
        if f not in self._cast:
            t, face, _ = self.ren.cast(self.traj.poses[f])
            self._cast[f] = (self.ren.px.to_image(t), self.ren.px.to_image(face))
        return self._cast[f]

    def image(self, f):
        """Frame f without noise or blur, 8-bit."""
        a, _ = self.ren.render(self.traj.poses[f])
        return np.clip(np.rint(a), 0, 255).astype(np.uint8)

    def ray(self, px):
        """Unit camera rays (N,3) of distorted pixel positions (N,2)."""
        xy = normalised(self.cam, px)
        r = np.stack([xy[:, 0], xy[:, 1], np.ones(len(xy))], axis=1)
        return r / np.linalg.norm(r, axis=1, keepdims=True)

    def surface_points(self, f, px):
        """World points of integer pixels px (N,2) of frame f, and whether each pixel's 21x21 window
        lies on one face of the scene (NaN rows where it does not)."""
        rng, face = self.cast(f)
        h, w = rng.shape
        out = np.full((len(px), 3), np.nan)
        T = self.traj.poses[f]
        rays = self.ray(px.astype(np.float64))
        for i, (x, y) in enumerate(np.rint(px).astype(int)):
            if not (HALF <= x < w - HALF and HALF <= y < h - HALF):
                continue
            win = face[y - HALF:y + HALF + 1, x - HALF:x + HALF + 1]
            if win.min() != win.max():
                continue
            out[i] = T[:3, 3] + rng[y, x] * (T[:3, :3] @ rays[i])
        return out

    def project(self, f, X):
        T = self.traj.poses[f]
        Xc = (X - T[:3, 3]) @ T[:3, :3]
        return synth.project_points(self.cam, Xc)


def track_errors(render, tracks_csv, max_frames):
    t, ids, xy, ages = read_tracks(tracks_csv)
    frames = np.array([render.frame_of[int(v)] for v in t])
    births = defaultdict(list)
    for tid, p, age, f in zip(ids, xy, ages, frames):
        if age == 0 and f < max_frames:
            births[f].append((int(tid), p[0], p[1]))
    origin = {}
    for f, lst in births.items():
        px = np.array([[x, y] for _, x, y in lst])
        X = render.surface_points(f, px)
        for (tid, x, y), Xi in zip(lst, X):
            if np.all(np.isfinite(Xi)):
                origin[tid] = (Xi, np.array([x, y]))
    err, along = defaultdict(list), defaultdict(list)
    for tid, p, age, f in zip(ids, xy, ages, frames):
        tid, age = int(tid), int(age)
        if age == 0 or tid not in origin or f >= max_frames:
            continue
        X, p0 = origin[tid]
        u = render.project(f, X[None])[0]
        e = p - u
        err[age].append(float(np.hypot(*e)))
        d = u - p0
        if np.hypot(*d) > 2.0:
            along[age].append(float(e @ d / np.hypot(*d)))
    return err, along


def model_errors(render, f0, gaps):
    """Per gap: (n, median, p90) of translation-only LK and of affine ECC against the true positions."""
    import cv2

    cv2.setNumThreads(1)
    I0 = render.image(f0)
    pts = cv2.goodFeaturesToTrack(I0, 400, 0.01, 10)
    pts = np.rint(pts.reshape(-1, 2))
    X = render.surface_points(f0, pts)
    ok = np.all(np.isfinite(X), axis=1)
    pts, X = pts[ok].astype(np.float32), X[ok]
    h, w = I0.shape
    out = []
    for g in gaps:
        u = render.project(f0 + g, X).astype(np.float32)
        inside = (u[:, 0] >= HALF + 2) & (u[:, 0] < w - HALF - 2) & (u[:, 1] >= HALF + 2) & (u[:, 1] < h - HALF - 2)
        p, uu = pts[inside], u[inside]
        I1 = render.image(f0 + g)
        nxt, st, _ = cv2.calcOpticalFlowPyrLK(I0, I1, p.reshape(-1, 1, 2), uu.reshape(-1, 1, 2).copy(),
                                              winSize=(2 * HALF + 1, 2 * HALF + 1), maxLevel=0,
                                              flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
                                              criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-3))
        good = st.ravel() == 1
        lk = np.hypot(*(nxt.reshape(-1, 2)[good] - uu[good]).T)
        I1f = I1.astype(np.float32)
        ecc = []
        for (x, y), (ux, uy) in zip(p.astype(int), uu):
            tpl = I0[y - HALF:y + HALF + 1, x - HALF:x + HALF + 1].astype(np.float32)
            W = np.array([[1, 0, ux - HALF], [0, 1, uy - HALF]], np.float32)
            try:
                _, W = cv2.findTransformECC(tpl, I1f, W, cv2.MOTION_AFFINE,
                                            (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-6), None, 1)
            except cv2.error:
                continue  # ECC did not converge on this patch
            c = W @ np.array([HALF, HALF, 1.0])
            ecc.append(float(np.hypot(c[0] - ux, c[1] - uy)))
        base = np.linalg.norm(render.traj.poses[f0 + g][:3, 3] - render.traj.poses[f0][:3, 3])
        out.append((g, base, lk, np.array(ecc)))
    return out


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seq", required=True, help="a tinyvo-synth render (EuRoC/ASL folder)")
    ap.add_argument("--replay", required=True, help="the tvo_replay binary")
    ap.add_argument("--frames", type=int, default=200, help="frames of the replay measured (default 200)")
    ap.add_argument("--seed", type=int, default=0, help="the render's scene seed (tinyvo-synth --seed)")
    ap.add_argument("--f0", type=int, default=100, help="first frame of the tracker-model comparison")
    ap.add_argument("--gaps", default="1,5,20", help="frame gaps of the tracker-model comparison")
    a = ap.parse_args(argv)
    render = Render(a.seq, a.seed)
    gaps = [int(g) for g in a.gaps.split(",")]
    if a.f0 + max(gaps) >= len(render.traj.t_ns):
        ap.error("--f0 + the largest gap is past the render's last frame")
    with tempfile.TemporaryDirectory() as tmp:
        tracks = os.path.join(tmp, "tracks.csv")
        subprocess.run([a.replay, "--euroc", a.seq, "--scale", "none", "--out", os.path.join(tmp, "traj.txt"),
                        "--tracks", tracks, "--max-frames", str(a.frames), "--quiet", *extra], check=True)
        err, along = track_errors(render, tracks, a.frames)
    print(f"tracks of tvo_replay on {os.path.basename(os.path.normpath(a.seq))}, frames 0-{a.frames - 1}, "
          f"born with their {2 * HALF + 1}x{2 * HALF + 1} window on one surface:")
    print("| age (frames) | tracks | median error, px | p90, px | median error along the motion, px |")
    print("|---|---|---|---|---|")
    for age in AGES:
        e = np.array(err.get(age, []))
        if len(e) < 20:
            continue
        al = np.array(along.get(age, [0.0]))
        print(f"| {age} | {len(e)} | {np.median(e):.3f} | {np.percentile(e, 90):.3f} | {np.median(al):+.3f} |")
    print(f"\none alignment from frame {a.f0} (noise-free frames, started at the true position):")
    print("| gap (frames) | baseline, m | LK 21x21 translation: n, median / p90 px | affine ECC 21x21: n, median / p90 px |")
    print("|---|---|---|---|")
    for g, base, lk, ecc in model_errors(render, a.f0, gaps):
        def cell(v):
            return f"{len(v)}, {np.median(v):.3f} / {np.percentile(v, 90):.3f}" if len(v) else "0"
        print(f"| {g} | {base:.3f} | {cell(lk)} | {cell(ecc)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
