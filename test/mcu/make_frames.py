# SPDX-License-Identifier: Apache-2.0
"""Frames for the microcontroller replay (test/mcu/mcu_replay.c): a real sequence cut to QVGA.

    python test/mcu/make_frames.py --euroc DIR --out frames.bin [--frames N] [--width 320 --height 240]

DIR is an EuRoC/ASL folder with a pinhole camera without distortion (the shared KITTI sequences): each
frame's centre crop of the target aspect ratio is resized to width x height (OpenCV INTER_AREA) and the
intrinsics follow (fx, fy, cx, cy scaled, the crop offset removed). Layout: see mcu_replay.c. The host
and the target replay the same file, so the resizing need not be reproducible across OpenCV versions.
"""
import argparse
import os
import struct
import sys

import cv2
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools"))
from tinyvo_tools import trajio  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--euroc", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    a = ap.parse_args(argv)
    camdir = os.path.join(a.euroc, "mav0", "cam0")
    info = trajio.read_sensor_yaml(os.path.join(camdir, "sensor.yaml"))
    if any(abs(float(k)) > 0 for k in info.distortion):
        ap.error("the camera has distortion: use an undistorted (rectified) sequence")
    fx, fy, cx, cy = info.intrinsics
    rows = [ln.split(",") for ln in open(os.path.join(camdir, "data.csv")) if ln[:1].isdigit()][: a.frames]
    if not rows:
        ap.error("no frames")
    out = []
    geom = None
    for r in rows:
        img = cv2.imread(os.path.join(camdir, "data", r[1].strip()), cv2.IMREAD_GRAYSCALE)
        h, w = img.shape
        if geom is None:
            cw, ch = w, int(round(w * a.height / a.width))
            if ch > h:
                cw, ch = int(round(h * a.width / a.height)), h
            x0, y0 = (w - cw) // 2, (h - ch) // 2
            sx, sy = a.width / cw, a.height / ch
            geom = (x0, y0, cw, ch, sx, sy)
        x0, y0, cw, ch, sx, sy = geom
        small = cv2.resize(img[y0:y0 + ch, x0:x0 + cw], (a.width, a.height), interpolation=cv2.INTER_AREA)
        out.append((int(r[0]), np.ascontiguousarray(small, dtype=np.uint8)))
    x0, y0, cw, ch, sx, sy = geom
    # pixel centres: u' = (u - x0 + 0.5) * s - 0.5
    K = (fx * sx, fy * sy, (cx - x0 + 0.5) * sx - 0.5, (cy - y0 + 0.5) * sy - 0.5)
    with open(a.out, "wb") as fh:
        fh.write(b"TVOFRM1\0")
        fh.write(struct.pack("<4i4d", a.width, a.height, len(out), 0, *K))
        for t, im in out:
            fh.write(struct.pack("<q", t))
            fh.write(im.tobytes())
    print(f"{a.out}: {len(out)} frames {a.width}x{a.height}, fx fy cx cy {K[0]:.3f} {K[1]:.3f} {K[2]:.3f} {K[3]:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
