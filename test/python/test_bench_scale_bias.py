# SPDX-License-Identifier: Apache-2.0
"""test/bench/bench_scale_bias.py's geometry on exact synthetic data: the depth of a correspondence in the
first camera, the ground truth's step ratios, and the OpenCV pipeline's three-frame ratio on rendered
frames of two textured planes (a camera whose step grows)."""
import pathlib
import sys

import cv2
import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "test" / "bench"))
sys.path.insert(0, str(ROOT / "tools"))
import bench_scale_bias  # noqa: E402
from tinyvo_tools import trajio  # noqa: E402


def test_depth_first_exact():
    rng = np.random.default_rng(3)
    X1 = np.c_[rng.uniform(-2, 2, 50), rng.uniform(-1, 1, 50), rng.uniform(4, 20, 50)]
    a = np.deg2rad(5.0)
    R = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    t = np.array([0.3, -0.05, -0.8])
    X2 = X1 @ R.T + t
    x1, x2 = X1[:, :2] / X1[:, 2:], X2[:, :2] / X2[:, 2:]
    d = bench_scale_bias.depth_first(x1, x2, R, t)
    assert np.allclose(d, X1[:, 2], rtol=1e-9)


def test_step_ratios_gt():
    T = np.repeat(np.eye(4)[None], 5, axis=0)
    T[:, 2, 3] = [0.0, 1.0, 3.0, 6.0, 10.0]  # steps 1, 2, 3, 4
    assert bench_scale_bias.step_ratios_gt(T, 2, 1) == pytest.approx(2.0)
    assert bench_scale_bias.step_ratios_gt(T, 4, 2) == pytest.approx(7.0 / 3.0)


def _render_plane(f, K, c, z, seed, size=(480, 360)):
    """A fronto-parallel textured plane at depth z seen from camera centre c (no rotation)."""
    tex = cv2.GaussianBlur((np.random.default_rng(seed).random((2400, 2400)) * 255).astype(np.uint8), (0, 0),
                           2.0)
    # plane coordinates: 1 texel = 0.01 m, centred on the axis
    Kp = np.array([[100.0, 0, 1200], [0, 100.0, 1200], [0, 0, 1]])  # plane metres -> texels
    depth = z - c[2]
    # image pixel -> plane point: X = (u - cx) / f * depth + c_x
    A = np.array([[depth / f, 0, -K[0, 2] * depth / f + c[0]], [0, depth / f, -K[1, 2] * depth / f + c[1]],
                  [0, 0, 1]])
    H = Kp @ A
    return cv2.warpPerspective(tex, H, size, flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP)


def _two_planes(f, K, steps):
    """Frames from camera centres moving sideways and forward by the given amounts, facing two planes (the
    left half of the view at 6 m, the right at 14 m: one plane alone is degenerate for the essential
    matrix)."""
    ims = []
    for s in steps:
        c = np.array([s, 0.0, 0.5 * s])
        near, far = _render_plane(f, K, c, 6.0, 5), _render_plane(f, K, c, 14.0, 6)
        near[:, 240:] = far[:, 240:]
        ims.append(near)
    return ims


def test_opencv_ratio_on_two_planes():
    f = 400.0
    cam = trajio.CameraInfo(width=480, height=360, intrinsics=(f, f, 239.5, 179.5), distortion=(0, 0, 0, 0))
    K = np.array([[f, 0, 239.5], [0, f, 179.5], [0, 0, 1]])
    # the second step 1.25 and 1.5 times the first (measured: 1.247 and 1.438)
    r125 = bench_scale_bias.ratio_opencv(_two_planes(f, K, [0.0, 0.2, 0.45]), cam, 2, 1)
    r150 = bench_scale_bias.ratio_opencv(_two_planes(f, K, [0.0, 0.2, 0.5]), cam, 2, 1)
    assert r125 == pytest.approx(1.25, rel=0.1)
    assert r150 == pytest.approx(1.5, rel=0.1)
    assert r150 > r125 + 0.1
