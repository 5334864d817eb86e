#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Benchmark: DSO (Direct Sparse Odometry) on an EuRoC/ASL sequence, for a comparison with tinyvo.

DSO (github.com/JakobEngel/dso) is GPL-licensed and is not part of tinyvo: nothing of it is in this
repository, and this program does not build it. Build its `dso_dataset` yourself (docs/evaluation.md,
"Beside DSO", lists the changes a current Debian needs) and pass it with --dso-bin.

The program
  1. converts the ASL folder into DSO's input in --out: `images/` (symlinks to the PNGs, named in frame
     order), `times.txt` (`index seconds`, seconds since the first frame; no exposure column) and
     `camera.txt`: `RadTan fx fy cx cy k1 k2 p1 p2` and DSO's `crop` rectification when the
     sensor.yaml has a distortion, else `Pinhole fx fy cx cy 0` and a centred crop without resampling;
     the output size is the input's rounded down to a multiple of 16 (DSO needs that), unless --size;
  2. runs `dso_dataset preset=N mode=1 nogui=1 nomt=1 quiet=1 sampleoutput=0 nolog=1` in --out (one
     thread, no photometric calibration), its output in `dso.log`;
  3. converts DSO's `result.txt` (seconds since the first frame, the camera pose in DSO's first camera)
     into `traj.txt`, a TUM file with the sequence's own timestamps, for tinyvo-eval;
  4. prints the frames DSO gave a pose for, the first frame it posed after its initialisation, whether it
     reported itself lost, DSO's own single-core time per frame and the wall time per frame, and writes
     them to `summary.json`.

DSO writes only keyframes to result.txt unless `setting_onlyLogKFPoses` is false (src/util/settings.cpp):
build it that way for a pose per frame. Its timing (`ms per frame (single core)`) is process CPU time
from its initialisation to the end, image reading and undistortion included, over all frames.

Usage: .venv/bin/python test/bench/bench_dso.py --dso-bin DSO/build/bin/dso_dataset --seq SEQ --preset 0
           --out DIR
Then: .venv/bin/python -m tinyvo_tools.eval --est DIR/traj.txt --gt SEQ
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from tinyvo_tools import trajio  # noqa: E402


def read_frames(seq: str):
    """(timestamps in ns, absolute image paths) of mav0/cam0, in data.csv's order."""
    cam = os.path.join(seq, "mav0", "cam0")
    t_ns, names = trajio.read_cam_frames(cam)
    return t_ns, [os.path.abspath(os.path.join(cam, "data", name)) for name in names]


def camera_txt(cam: trajio.CameraInfo, size) -> tuple:
    """DSO's camera.txt for the ASL camera, and the output size."""
    w, h = cam.width, cam.height
    ow, oh = size if size else (w // 16 * 16, h // 16 * 16)
    fx, fy, cx, cy = cam.intrinsics
    dist = list(cam.distortion) + [0.0] * (4 - len(cam.distortion))
    if any(abs(d) > 0 for d in dist):
        if cam.distortion_model not in ("radial-tangential", "radtan"):
            raise SystemExit(f"bench_dso: distortion model {cam.distortion_model} not converted")
        first = "RadTan %.9g %.9g %.9g %.9g %.9g %.9g %.9g %.9g" % (fx, fy, cx, cy, *dist[:4])
        out = "crop"
    else:
        # centred crop, same focal length: DSO's output line is relative, K = (f*w, f*h, c*w-0.5, c*h-0.5)
        dx, dy = (w - ow) // 2, (h - oh) // 2
        first = "Pinhole %.9g %.9g %.9g %.9g 0" % (fx, fy, cx, cy)
        out = "%.9g %.9g %.9g %.9g 0" % (fx / ow, fy / oh, (cx - dx + 0.5) / ow, (cy - dy + 0.5) / oh)
    return f"{first}\n{w} {h}\n{out}\n{ow} {oh}\n", (ow, oh)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dso-bin", required=True, help="DSO's dso_dataset, built by you")
    ap.add_argument("--seq", required=True, help="EuRoC/ASL sequence (folder holding mav0/)")
    ap.add_argument("--preset", type=int, default=0, help="DSO preset: 0 (default settings) or 2 (fast)")
    ap.add_argument("--out", required=True, help="work and output folder (created)")
    ap.add_argument("--size", help="DSO's output size WxH (default: the input's, down to multiples of 16)")
    args = ap.parse_args()

    seq, out = os.path.abspath(args.seq), os.path.abspath(args.out)
    t_ns, paths = read_frames(seq)
    cam = trajio.read_sensor_yaml(os.path.join(seq, "mav0", "cam0", "sensor.yaml"))
    size = tuple(int(v) for v in args.size.lower().split("x")) if args.size else None

    img_dir = os.path.join(out, "images")
    os.makedirs(img_dir, exist_ok=True)
    for name in os.listdir(img_dir):
        os.unlink(os.path.join(img_dir, name))
    digits = len(str(len(paths)))
    t_rel = (t_ns - t_ns[0]) * 1e-9
    with open(os.path.join(out, "times.txt"), "w", encoding="utf-8") as f:
        for k, (p, t) in enumerate(zip(paths, t_rel)):
            os.symlink(p, os.path.join(img_dir, f"{k:0{digits}d}.png"))
            f.write(f"{k} {t:.9f}\n")
    text, osize = camera_txt(cam, size)
    with open(os.path.join(out, "camera.txt"), "w", encoding="utf-8") as f:
        f.write(text)

    result = os.path.join(out, "result.txt")
    if os.path.exists(result):
        os.unlink(result)
    cmd = [os.path.abspath(args.dso_bin), f"files={img_dir}", f"calib={os.path.join(out, 'camera.txt')}",
           f"preset={args.preset}", "mode=1", "nogui=1", "nomt=1", "quiet=1", "sampleoutput=0", "nolog=1"]
    t0 = time.perf_counter()
    with open(os.path.join(out, "dso.log"), "w", encoding="utf-8") as log:
        rc = subprocess.run(cmd, cwd=out, stdout=log, stderr=subprocess.STDOUT).returncode
    wall = time.perf_counter() - t0
    with open(os.path.join(out, "dso.log"), encoding="utf-8", errors="replace") as f:
        text = f.read()
    if rc != 0 or not os.path.exists(result):
        print(f"bench_dso: dso_dataset failed (exit {rc}), see {out}/dso.log", file=sys.stderr)
        return 1

    # result.txt: t tx ty tz qx qy qz qw, t as written in times.txt; back to the frame's ns timestamp
    rows = np.loadtxt(result, ndmin=2)
    if rows.size == 0:
        rows = np.zeros((0, 8))
    idx = np.searchsorted(t_rel, rows[:, 0] - 5e-4).clip(0, len(t_rel) - 1)
    if len(rows) and np.max(np.abs(t_rel[idx] - rows[:, 0])) > 1e-3:
        raise SystemExit("bench_dso: a timestamp of result.txt matches no frame")
    if len(rows):
        poses = trajio.pose_from_pq(rows[:, 1:4], rows[:, [7, 4, 5, 6]])
        trajio.write_tum(os.path.join(out, "traj.txt"), trajio.Trajectory(t_ns[idx], poses, "camera"))
    else:  # DSO posed nothing (never initialised): an empty trajectory
        open(os.path.join(out, "traj.txt"), "w", encoding="utf-8").close()

    m = re.search(r"([0-9.]+)ms per frame \(single core\)", text)
    posed = np.unique(idx)
    started = len(posed) >= 2  # never initialised: only the pose of the initialiser's first frame
    summary = {
        "seq": seq, "preset": args.preset, "frames": len(paths), "output_size": list(osize),
        "initialised": started, "frames_posed": int(len(posed)) if started else 0,
        "first_posed": int(posed[0]) if started else None, "tracking_from": int(posed[1]) if started else None,
        "last_posed": int(posed[-1]) if started else None,
        "lost": "LOST" in text, "resets": text.count("RESETTING"),
        "dso_ms_per_frame": float(m.group(1)) if m and started else None,
        "wall_ms_per_frame": 1000.0 * wall / len(paths),
    }
    with open(os.path.join(out, "summary.json"), "w", encoding="utf-8") as f:
        json.dump(summary, f, indent=1)
    s = summary
    state = (f"frames {s['first_posed']}, {s['tracking_from']}-{s['last_posed']}" if started else "never initialised")
    print(f"{os.path.basename(seq)} preset {args.preset}: {s['frames_posed']} of {len(paths)} frames posed ({state}; "
          f"{'lost, ' if s['lost'] else ''}{s['resets']} resets); DSO {s['dso_ms_per_frame']} ms/frame, "
          f"wall {s['wall_ms_per_frame']:.2f} ms/frame")
    return 0


if __name__ == "__main__":
    sys.exit(main())
