# SPDX-License-Identifier: Apache-2.0
"""Synthetic EuRoC/ASL sequences: a seeded, textured 3D room rendered along a trajectory.

    tinyvo-synth --out DIR [--trajectory FILE | --builtin NAME] [--frames N]
                 [--camera euroc|kitti|tum] [--rate HZ] [--seed S] [--noise SIGMA] [--blur SIGMA]
                 [--start-time SEC] [--quiet]

writes DIR/mav0/cam0/data/<t_ns>.png (8-bit grey, 752x480 for the default camera), mav0/cam0/data.csv,
mav0/cam0/sensor.yaml (EuRoC cam0 intrinsics, radial-tangential distortion, T_BS, 20 Hz; or another
preset, CAMERAS) and
mav0/state_groundtruth_estimate0/data.csv (body poses T_W_B at the image timestamps).

How it renders (see docs/synth.md):
- The scene is an axis-aligned room (sized from the trajectory's bounding box) with axis-aligned boxes
  inside (floor boxes, pillars, wall panels, hanging boxes), placed with a clearance from the trajectory.
- Every pixel of the *distorted* image has a precomputed unit ray (the radial-tangential model inverted
  by Newton iterations), so distortion is exact, not a remap. Per frame the rays are rotated into the
  world and cast with numpy: slab tests against the room and the boxes. Pixels are stored in 16x16 tiles
  and each box is only tested on the tiles its (near-plane clipped) projection overlaps.
- Each face samples one of several seeded, tileable procedural textures (1/f noise + rectangles, discs,
  bricks, tiles, lines: texture at many scales) through a mip pyramid with trilinear filtering; the mip
  level comes from the pixel footprint (distance, pixel angle, incidence), so there is no aliasing.
- Shading: per-face albedo and a directional light; mild vignetting; optional Gaussian blur and noise;
  8-bit rounding. The noise of frame k is seeded by (seed, k): every run writes the same bytes.
"""
from __future__ import annotations

import math
import os
import struct
import sys
import time
import zlib
from dataclasses import dataclass, replace

import numpy as np

from . import cli, trajio
from .trajio import CameraInfo, Trajectory, EUROC_CAM0_T_BS

TILE = 16

# --------------------------------------------------------------------------------------------------
# camera model


def distort_radtan(x, y, d):
    """Normalised undistorted (x, y) -> distorted, radial-tangential (k1 k2 p1 p2 [k3])."""
    k1, k2, p1, p2 = d[:4]
    k3 = d[4] if len(d) > 4 else 0.0
    r2 = x * x + y * y
    rad = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * rad + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * rad + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    return xd, yd


def undistort_radtan(xd, yd, d, iters: int = 12):
    """Inverse of :func:`distort_radtan` by Newton's method (float64, residual < 1e-12 on EuRoC cam0)."""
    k1, k2, p1, p2 = d[:4]
    k3 = d[4] if len(d) > 4 else 0.0
    x = np.array(xd, dtype=np.float64, copy=True)
    y = np.array(yd, dtype=np.float64, copy=True)
    for _ in range(iters):
        r2 = x * x + y * y
        rad = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        drad = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)  # d rad / d r2
        fx = x * rad + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) - xd
        fy = y * rad + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y - yd
        j11 = rad + 2.0 * x * x * drad + 2.0 * p1 * y + 6.0 * p2 * x
        j12 = 2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y
        j21 = 2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y
        j22 = rad + 2.0 * y * y * drad + 6.0 * p1 * y + 2.0 * p2 * x
        det = j11 * j22 - j12 * j21
        x = x - (j22 * fx - j12 * fy) / det
        y = y - (-j21 * fx + j11 * fy) / det
    return x, y


def distort_equidistant(x, y, k):
    """Normalised undistorted (x, y) -> distorted, equidistant (Kannala-Brandt k1..k4, OpenCV's fisheye and
    Kalibr's "equidistant"): theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)."""
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    r = np.hypot(x, y)
    th = np.arctan(r)
    t2 = th * th
    thd = th * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))))
    s = np.where(r > 1e-12, thd / np.maximum(r, 1e-300), 1.0)
    return x * s, y * s


def undistort_equidistant(xd, yd, k, iters: int = 20):
    """Inverse of :func:`distort_equidistant` by Newton's method on theta (the angle must stay below 90
    degrees: a ray at or beyond it has no normalised (x, y))."""
    xd = np.asarray(xd, dtype=np.float64)
    yd = np.asarray(yd, dtype=np.float64)
    thd = np.hypot(xd, yd)
    th = np.array(thd, copy=True)
    for _ in range(iters):
        t2 = th * th
        g = th * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])))) - thd
        dg = 1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])))
        th = th - g / dg
    if np.any(th >= np.pi / 2):
        raise ValueError("equidistant camera: a pixel's ray is at or beyond 90 degrees from the axis")
    s = np.where(thd > 1e-12, np.tan(th) / np.maximum(thd, 1e-300), 1.0)
    return xd * s, yd * s


def distort(model: str, x, y, d):
    """Normalised undistorted (x, y) -> distorted with the sensor.yaml distortion model `model` and its
    coefficients d (radial-tangential with at least 4 coefficients, or equidistant; any other: none)."""
    if model.startswith("radial") and len(d) >= 4:
        return distort_radtan(x, y, d)
    if model == "equidistant":
        return distort_equidistant(x, y, d)
    return x, y


def undistort(model: str, xd, yd, d):
    """The inverse of :func:`distort`; ValueError for a model it does not know with coefficients that are
    not all zero."""
    if model.startswith("radial") and len(d) >= 4:
        return undistort_radtan(xd, yd, d)
    if model == "equidistant":
        return undistort_equidistant(xd, yd, d)
    if model in ("none", "") or not any(d):
        return xd, yd
    raise ValueError(f"unsupported distortion model {model}")


def project_points(cam: CameraInfo, X_c):
    """Camera-frame points (N,3) -> distorted pixel coordinates (N,2) (pixel centres at integers)."""
    X_c = np.asarray(X_c, dtype=np.float64).reshape(-1, 3)
    x, y = distort(cam.distortion_model, X_c[:, 0] / X_c[:, 2], X_c[:, 1] / X_c[:, 2], cam.distortion)
    fu, fv, cu, cv = cam.intrinsics
    return np.stack([fu * x + cu, fv * y + cv], axis=1)


class PixelRays:
    """Per-pixel unit rays of the distorted image, tile-major (ntiles, TILE*TILE), float32."""

    def __init__(self, cam: CameraInfo):
        self.cam = cam
        W, H = cam.width, cam.height
        self.ntx, self.nty = -(-W // TILE), -(-H // TILE)
        Wp, Hp = self.ntx * TILE, self.nty * TILE
        fu, fv, cu, cv = cam.intrinsics
        v, u = np.mgrid[0:Hp, 0:Wp].astype(np.float64)
        xd, yd = (u - cu) / fu, (v - cv) / fv
        x, y = undistort(cam.distortion_model, xd, yd, cam.distortion)
        rays = np.stack([x, y, np.ones_like(x)], axis=-1)
        rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
        # pixel angle (rad): sqrt of the solid angle of one pixel from neighbouring rays
        du = np.linalg.norm(np.diff(rays, axis=1, append=rays[:, -2:-1] * 2 - rays[:, -3:-2]), axis=-1)
        dv = np.linalg.norm(np.diff(rays, axis=0, append=rays[-2:-1] * 2 - rays[-3:-2]), axis=-1)
        pixang = np.sqrt(np.abs(du * dv))

        def tiles(a):
            a = a.reshape(self.nty, TILE, self.ntx, TILE, *a.shape[2:]).swapaxes(1, 2)
            return a.reshape(self.nty * self.ntx, TILE * TILE, *a.shape[4:])

        rt = tiles(rays)
        self.rays = np.ascontiguousarray(np.moveaxis(rt, -1, 0).astype(np.float32))  # (3, ntiles, 256)
        self.pixang = tiles(pixang).astype(np.float32)
        xt, yt = tiles(x), tiles(y)
        self.tile_xmin, self.tile_xmax = xt.min(1), xt.max(1)
        self.tile_ymin, self.tile_ymax = yt.min(1), yt.max(1)
        r2 = (((u - cu) / (W / 2.0)) ** 2 + ((v - cv) / (H / 2.0)) ** 2) / 2.0
        self.vignette_r2 = tiles(r2).astype(np.float32)
        self.ntiles = self.ntx * self.nty

    def to_image(self, a):
        """Tile-major (ntiles, 256) -> (H, W) raster."""
        a = a.reshape(self.nty, self.ntx, TILE, TILE).swapaxes(1, 2).reshape(self.nty * TILE, self.ntx * TILE)
        return a[: self.cam.height, : self.cam.width]


# --------------------------------------------------------------------------------------------------
# textures


class MipTextures:
    """A stack of square, tileable, power-of-two textures (values 0..1) with their mip pyramids (down to
    8x8) in one flat uint8 array; samples are returned in 0..255. Every level is stored with a one-texel wrapped border, so bilinear lookups need
    no modulo per corner, and all addresses stay below 2^24 so they are computed exactly in float32
    (far cheaper in numpy than int64 arithmetic)."""

    def __init__(self, textures: np.ndarray):
        n, S, S2 = textures.shape
        if S != S2 or S & (S - 1) or S < 8:
            raise ValueError("textures must be square, a power of two, at least 8")
        levels = [textures.astype(np.float32)]
        while levels[-1].shape[1] > 8:
            c = levels[-1]
            levels.append(0.25 * (c[:, 0::2, 0::2] + c[:, 1::2, 0::2] + c[:, 0::2, 1::2] + c[:, 1::2, 1::2]))
        self.levels = levels
        self.nlev = len(levels)
        self.size0 = S
        self.ntex = n
        base = np.zeros((n, self.nlev), dtype=np.int64)
        flat, off = [], 0
        for l, lev in enumerate(levels):
            s = lev.shape[1]
            padded = np.pad(lev, ((0, 0), (1, 1), (1, 1)), mode="wrap")
            for t in range(n):
                base[t, l] = off + (s + 2) + 1  # address of texel (0, 0)
                flat.append(padded[t].ravel())
                off += (s + 2) * (s + 2)
        if off >= 1 << 24:
            raise ValueError("textures too large for float32 addressing")
        # 8-bit texels: a quarter of the memory traffic of float32 (the gathers dominate the render time)
        self.data = np.clip(np.rint(np.concatenate(flat) * 255.0), 0, 255).astype(np.uint8)
        self.basef = base.ravel().astype(np.float32)  # [t * nlev + l]
        self.rowf = np.array([lev.shape[1] + 2 for lev in levels], dtype=np.float32)
        self.scales = (1.0 / (2.0 ** np.arange(self.nlev + 1))).astype(np.float32)

    def _bilinear(self, base, row, sc, u, v):
        """Bilinear sample at one level per pixel; u, v wrapped level-0 texel coordinates in [0, S0)."""
        x = u * sc
        x -= np.float32(0.5)
        y = v * sc
        y -= np.float32(0.5)
        x0 = np.floor(x)
        y0 = np.floor(y)
        x -= x0
        y -= y0
        y0 *= row
        y0 += x0
        y0 += base
        i00 = y0.astype(np.int64)
        i10 = i00 + row.astype(np.int64)
        d = self.data
        f32 = np.float32
        a = d.take(i00).astype(f32)
        top = d.take(i00 + 1).astype(f32)
        top -= a
        top *= x
        top += a
        a = d.take(i10).astype(f32)
        bot = d.take(i10 + 1).astype(f32)
        bot -= a
        bot *= x
        bot += a
        bot -= top
        bot *= y
        bot += top
        return bot

    def sample(self, tex, u, v, lod):
        """Trilinear sample; tex int array, u, v in level-0 texels (any value, wrapping), lod >= 0."""
        S0 = np.float32(self.size0)
        inv = np.float32(1.0 / self.size0)
        u = u - np.floor(u * inv) * S0
        v = v - np.floor(v * inv) * S0
        np.clip(u, 0, S0 - np.float32(1e-3), out=u)  # guard the float rounding of u - floor(u/S)*S
        np.clip(v, 0, S0 - np.float32(1e-3), out=v)
        lod = np.clip(lod, np.float32(0.0), np.float32(self.nlev - 1.001))
        l0 = lod.astype(np.int64)
        f = lod - l0.astype(np.float32)
        ti = tex.astype(np.int64) * self.nlev + l0
        sc = self.scales.take(l0)
        a = self._bilinear(self.basef.take(ti), self.rowf.take(l0), sc, u, v)
        b = self._bilinear(self.basef.take(ti + 1), self.rowf.take(l0 + 1), sc * np.float32(0.5), u, v)
        b -= a
        b *= f
        b += a
        return b


def _periodic_noise(rng, S, beta, lo_cut=1.0):
    """Tileable 1/f^beta noise (S x S), zero mean, unit std."""
    w = rng.standard_normal((S, S))
    fy = np.fft.fftfreq(S)[:, None] * S
    fx = np.fft.rfftfreq(S)[None, :] * S
    f = np.sqrt(fx * fx + fy * fy)
    amp = np.where(f >= lo_cut, 1.0 / np.maximum(f, 1e-9) ** beta, 0.0)
    img = np.fft.irfft2(np.fft.rfft2(w) * amp, s=(S, S))
    return (img - img.mean()) / (img.std() + 1e-12)


def _paint_rect(img, y0, x0, h, w, val):
    S = img.shape[0]
    img[np.ix_(np.arange(y0, y0 + h) % S, np.arange(x0, x0 + w) % S)] = val


def _paint_disc(img, cy, cx, r, val):
    S = img.shape[0]
    n = int(np.ceil(r)) + 1
    oy, ox = int(np.floor(cy)) - n, int(np.floor(cx)) - n
    yy, xx = np.mgrid[oy:oy + 2 * n + 1, ox:ox + 2 * n + 1]
    m = (yy - cy) ** 2 + (xx - cx) ** 2 <= r * r
    img[yy[m] % S, xx[m] % S] = val


def make_texture(rng, S: int, kind: str) -> np.ndarray:
    """One tileable texture in [0, 1] with structure from ~2 texels to S/4 texels."""
    img = 0.5 + 0.16 * _periodic_noise(rng, S, 1.1) + 0.05 * _periodic_noise(rng, S, 0.3, lo_cut=S / 16)
    if kind == "bricks":
        bh = int(rng.integers(S // 32, S // 12))
        bw = 2 * bh + int(rng.integers(0, bh))
        for r in range(S // bh):
            shift = (bw // 2) * (r % 2)
            for c in range(-1, S // bw + 1):
                val = 0.5 + 0.25 * rng.standard_normal()
                x0 = c * bw + shift
                _paint_rect(img, r * bh + 2, x0 + 2, bh - 4, bw - 4, val)
        img += 0.06 * _periodic_noise(rng, S, 0.8)
    elif kind == "tiles":
        n = int(rng.choice([8, 16]))
        t = S // n
        for r in range(n):
            for c in range(n):
                if rng.random() < 0.8:
                    _paint_rect(img, r * t + 3, c * t + 3, t - 6, t - 6, 0.5 + 0.22 * rng.standard_normal())
        img += 0.08 * _periodic_noise(rng, S, 1.0)
    n_rect = {"rects": 260, "bricks": 30, "tiles": 40, "blobs": 60, "posters": 120}[kind]
    n_disc = {"rects": 40, "bricks": 10, "tiles": 20, "blobs": 200, "posters": 60}[kind]
    for _ in range(n_rect):
        h, w = (np.exp(rng.uniform(np.log(3), np.log(S / 5), 2))).astype(int) + 1
        _paint_rect(img, int(rng.integers(S)), int(rng.integers(S)), h, w,
                    float(np.clip(0.5 + 0.3 * rng.standard_normal(), 0.03, 0.97)))
    for _ in range(n_disc):
        _paint_disc(img, rng.uniform(0, S), rng.uniform(0, S), float(np.exp(rng.uniform(np.log(2), np.log(S / 12)))),
                    float(np.clip(0.5 + 0.3 * rng.standard_normal(), 0.03, 0.97)))
    if kind == "posters":  # a few noisy patches with fine detail
        for _ in range(6):
            h, w = rng.integers(S // 10, S // 4, 2)
            y0, x0 = rng.integers(S, size=2)
            patch = 0.5 + 0.25 * _periodic_noise(rng, 256, 0.6)[:h % 256, :w % 256]
            rows = np.arange(y0, y0 + patch.shape[0]) % S
            cols = np.arange(x0, x0 + patch.shape[1]) % S
            img[np.ix_(rows, cols)] = patch
    # lines
    for _ in range(25):
        if rng.random() < 0.5:
            _paint_rect(img, int(rng.integers(S)), 0, int(rng.integers(1, 4)), S, float(rng.uniform(0.05, 0.95)))
        else:
            _paint_rect(img, 0, int(rng.integers(S)), S, int(rng.integers(1, 4)), float(rng.uniform(0.05, 0.95)))
    img += 0.03 * _periodic_noise(rng, S, 0.0)  # fine grain
    return np.clip(img, 0.02, 0.98).astype(np.float32)


TEXTURE_KINDS = ("rects", "bricks", "tiles", "blobs", "posters", "rects", "blobs", "posters")

# --------------------------------------------------------------------------------------------------
# scene


@dataclass
class Scene:
    """Axis-aligned room and boxes; face f = 6*obj + 2*axis + side (side 0: low plane, 1: high plane);
    object 0 is the room (seen from inside), objects 1.. are the boxes (seen from outside)."""

    room_lo: np.ndarray
    room_hi: np.ndarray
    box_lo: np.ndarray  # (B, 3)
    box_hi: np.ndarray
    face_tex: np.ndarray  # (F,) int32
    face_off: np.ndarray  # (F, 2) float32, texels
    face_inv_texel: np.ndarray  # (F,) float32, texels per metre
    face_gain: np.ndarray  # (F,) float32
    face_bias: np.ndarray  # (F,) float32
    textures: MipTextures

    @property
    def nboxes(self):
        return len(self.box_lo)


def _box_distance(points, lo, hi):
    """Euclidean distance of points (N,3) to an axis-aligned box (0 inside)."""
    d = np.maximum(np.maximum(lo - points, points - hi), 0.0)
    return np.linalg.norm(d, axis=1)


def make_scene(positions, seed: int = 0, texture_size: int = 1024, texel_m: float = 0.004,
               n_boxes: int | None = None, clearance: float = 0.45, boxes: bool = True) -> Scene:
    """A seeded room enclosing ``positions`` (camera centres, (N,3), world z up) with boxes that keep
    ``clearance`` metres away from every position."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x5EED]))
    P = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    pmin, pmax = P.min(0), P.max(0)
    ext = pmax - pmin
    margin = np.maximum(2.0, 0.25 * ext[:2])
    lo = np.array([pmin[0] - margin[0], pmin[1] - margin[1], min(pmin[2] - 0.7, 0.0)])  # z = 0 floor if it fits
    hi = np.array([pmax[0] + margin[0], pmax[1] + margin[1], pmax[2] + max(1.4, 0.3 * ext[2])])
    lo = lo + rng.uniform(-0.5, 0.0, 3) * [1, 1, 0]
    hi = hi + rng.uniform(0.0, 0.5, 3) * [1, 1, 0]
    size = hi - lo
    Psub = P[:: max(1, len(P) // 3000)]
    if n_boxes is None:
        n_boxes = int(np.clip(size[0] * size[1] / 2.5, 16, 70))
    blo, bhi = [], []
    tries = 0
    while boxes and len(blo) < n_boxes and tries < 60 * n_boxes:
        tries += 1
        kind = rng.choice(["floor", "floor", "floor", "pillar", "panel", "hanging", "shelf"])
        if kind == "floor":
            s = np.array([*rng.uniform(0.25, 1.6, 2), rng.uniform(0.2, 2.2)])
            c = rng.uniform(lo[:2] + s[:2] / 2, hi[:2] - s[:2] / 2)
            b0 = np.array([c[0] - s[0] / 2, c[1] - s[1] / 2, lo[2]])
        elif kind == "pillar":
            w = rng.uniform(0.25, 0.6)
            s = np.array([w, w * rng.uniform(0.8, 1.25), size[2]])
            c = rng.uniform(lo[:2] + s[:2] / 2, hi[:2] - s[:2] / 2)
            b0 = np.array([c[0] - s[0] / 2, c[1] - s[1] / 2, lo[2]])
        elif kind in ("panel", "shelf"):  # against a wall
            ax = int(rng.integers(2))
            side = int(rng.integers(2))
            depth = rng.uniform(0.04, 0.2) if kind == "panel" else rng.uniform(0.3, 0.6)
            s = np.zeros(3)
            s[ax] = depth
            s[1 - ax] = rng.uniform(0.5, 2.5)
            s[2] = rng.uniform(0.4, 1.8) if kind == "panel" else rng.uniform(1.0, size[2] * 0.8)
            b0 = np.zeros(3)
            b0[ax] = lo[ax] if side == 0 else hi[ax] - depth
            b0[1 - ax] = rng.uniform(lo[1 - ax], hi[1 - ax] - s[1 - ax])
            if kind == "panel" and s[2] > size[2] - 0.4:
                continue  # a low room (a short trajectory near the floor): no room for this panel
            b0[2] = lo[2] if kind == "shelf" else rng.uniform(lo[2] + 0.3, hi[2] - s[2] - 0.1)
        else:  # hanging from the ceiling
            s = rng.uniform([0.3, 0.3, 0.2], [1.0, 1.0, 0.8])
            c = rng.uniform(lo[:2] + s[:2] / 2, hi[:2] - s[:2] / 2)
            b0 = np.array([c[0] - s[0] / 2, c[1] - s[1] / 2, hi[2] - s[2]])
        b1 = b0 + s
        b0, b1 = np.maximum(b0, lo), np.minimum(b1, hi)
        if np.any(b1 - b0 < 0.03):
            continue
        if _box_distance(Psub, b0, b1).min() < clearance:
            continue
        blo.append(b0)
        bhi.append(b1)
    B = len(blo)
    F = 6 * (B + 1)
    ntex = len(TEXTURE_KINDS)
    textures = np.stack([make_texture(np.random.default_rng(np.random.SeedSequence([int(seed), 7, t])),
                                      texture_size, TEXTURE_KINDS[t]) for t in range(ntex)])
    face_tex = rng.integers(0, ntex, F).astype(np.int32)
    face_tex[4] = 2  # floor: tiles
    face_tex[[0, 1, 2, 3]] = rng.choice([0, 1, 3, 4], 4)  # walls
    face_off = rng.uniform(0, texture_size, (F, 2)).astype(np.float32)
    face_inv_texel = (1.0 / (texel_m * rng.uniform(0.75, 1.35, F))).astype(np.float32)
    # directional light + per-object albedo
    L = np.array([0.35, 0.55, 0.76])
    L /= np.linalg.norm(L)
    gain = np.empty(F, dtype=np.float32)
    bias = np.empty(F, dtype=np.float32)
    for obj in range(B + 1):
        albedo = rng.uniform(0.6, 1.05) if obj else 0.9
        for ax in range(3):
            for side in range(2):
                n = np.zeros(3)
                n[ax] = (1.0 if side else -1.0) * (-1.0 if obj == 0 else 1.0)  # room normals point inwards
                shade = 0.62 + 0.38 * max(0.0, float(n @ L)) + 0.08 * max(0.0, -float(n @ L))
                f = 6 * obj + 2 * ax + side
                gain[f] = (220.0 / 255.0) * albedo * shade
                bias[f] = rng.uniform(0.0, 15.0)
    return Scene(lo, hi, np.array(blo).reshape(-1, 3), np.array(bhi).reshape(-1, 3), face_tex, face_off,
                 face_inv_texel, gain, bias, MipTextures(textures))


# --------------------------------------------------------------------------------------------------
# renderer

_CUBE = np.array([[(i >> 0) & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], dtype=np.float64)
_EDGES = [(a, a | (1 << k)) for a in range(8) for k in range(3) if not a & (1 << k)]


def _tune_malloc():
    """numpy's frame-sized temporaries (1.4 MB) are above glibc's mmap threshold, so every one of them
    is a fresh mmap with page faults (3-9x slower arithmetic). Keep them on the heap instead. Linux/glibc
    only; harmless (and skipped) elsewhere. Affects the whole process (memory is kept, not returned)."""
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-3, 256 << 20)  # M_MMAP_THRESHOLD
        libc.mallopt(-1, 512 << 20)  # M_TRIM_THRESHOLD
        libc.mallopt(-2, 64 << 20)  # M_TOP_PAD
    except (OSError, AttributeError):
        pass


class Renderer:
    """Renders ``scene`` seen by ``cam``. ``render(T_WC)`` -> (float32 intensity image, range image)."""

    def __init__(self, scene: Scene, cam: CameraInfo):
        self.scene = scene
        self.cam = cam
        self.px = PixelRays(cam)
        self.last_box_tiles = 0
        _tune_malloc()

    def _box_tiles(self, R_cw, o, b0, b1):
        """Indices of tiles the box may cover (None: box behind the camera)."""
        corners = b0 + _CUBE * (b1 - b0)
        Xc = (corners - o) @ R_cw.T
        z = Xc[:, 2]
        near = 1e-3
        if np.all(z <= near):
            return None
        pts = [Xc[z > near]]
        if np.any(z <= near):  # clip the box's edges against the near plane
            for a, b in _EDGES:
                za, zb = z[a], z[b]
                if (za > near) != (zb > near):
                    s = (near - za) / (zb - za)
                    pts.append((Xc[a] + s * (Xc[b] - Xc[a]))[None])
        pts = np.concatenate(pts)
        x = pts[:, 0] / pts[:, 2]
        y = pts[:, 1] / pts[:, 2]
        p = self.px
        sel = ((p.tile_xmax >= x.min()) & (p.tile_xmin <= x.max()) &
               (p.tile_ymax >= y.min()) & (p.tile_ymin <= y.max()))
        idx = np.flatnonzero(sel)
        return idx if len(idx) else None

    def cast(self, T_WC):
        """Ray casting only: (range (ntiles,256) float32, face id int32, world ray components Dx, Dy, Dz)."""
        sc = self.scene
        T_WC = np.asarray(T_WC, dtype=np.float64)
        R = T_WC[:3, :3]
        o = T_WC[:3, 3]
        if np.any(o <= sc.room_lo) or np.any(o >= sc.room_hi):
            raise ValueError("camera outside the room")
        r = self.px.rays
        Rf = R.astype(np.float32)
        D = [Rf[k, 0] * r[0] + Rf[k, 1] * r[1] + Rf[k, 2] * r[2] for k in range(3)]
        inv = []
        for k in range(3):
            dk = D[k]
            dk[dk == 0] = 1e-20
            inv.append(np.float32(1.0) / dk)
        # room, from inside: exit distance
        t = None
        face = None
        for k in range(3):
            pos = D[k] > 0
            tk = np.where(pos, np.float32(sc.room_hi[k] - o[k]), np.float32(sc.room_lo[k] - o[k])) * inv[k]
            fk = (2 * k + pos).astype(np.int32)
            if t is None:
                t, face = tk, fk
            else:
                better = tk < t
                t = np.where(better, tk, t)
                face = np.where(better, fk, face)
        # boxes, from outside: slab test on the tiles each box may cover
        ntested = 0
        for b in range(sc.nboxes):
            b0, b1 = sc.box_lo[b], sc.box_hi[b]
            idx = self._box_tiles(R.T, o, b0, b1)
            if idx is None:
                continue
            ntested += len(idx)
            full = len(idx) == self.px.ntiles
            tnear = tfar = ax = None
            for k in range(3):
                ik = inv[k] if full else inv[k][idx]
                t1 = np.float32(b0[k] - o[k]) * ik
                t2 = np.float32(b1[k] - o[k]) * ik
                tmin = np.minimum(t1, t2)
                tmax = np.maximum(t1, t2)
                if tnear is None:
                    tnear, tfar, ax = tmin, tmax, np.zeros(tmin.shape, np.int32)
                else:
                    gt = tmin > tnear
                    tnear = np.where(gt, tmin, tnear)
                    ax = np.where(gt, np.int32(k), ax)
                    tfar = np.minimum(tfar, tmax)
            tcur = t if full else t[idx]
            hit = (tnear <= tfar) & (tnear > 0) & (tnear < tcur)
            if not hit.any():
                continue
            # side: entering through the low plane when the ray goes in +axis
            dax = np.where(ax == 0, D[0] if full else D[0][idx],
                           np.where(ax == 1, D[1] if full else D[1][idx], D[2] if full else D[2][idx]))
            fb = (6 * (b + 1) + 2 * ax + (dax < 0)).astype(np.int32)
            if full:
                t = np.where(hit, tnear, t)
                face = np.where(hit, fb, face)
            else:
                t[idx] = np.where(hit, tnear, tcur)
                face[idx] = np.where(hit, fb, face[idx])
        self.last_box_tiles = ntested
        return t, face, D

    def render(self, T_WC, vignette: float = 0.15):
        """(H,W) float32 intensity (0..255 scale, before noise/blur) and (H,W) float32 range [m]."""
        sc = self.scene
        o = np.asarray(T_WC, dtype=np.float64)[:3, 3]
        t, face, D = self.cast(T_WC)
        P = [np.float32(o[k]) + t * D[k] for k in range(3)]
        axis = face // 2 % 3  # object index is face // 6
        a0 = axis == 0
        a2 = axis == 2
        u = np.where(a0, P[1], P[0])
        v = np.where(a2, P[1], P[2])
        cos = np.abs(np.where(a0, D[0], np.where(a2, D[2], D[1])))
        face = face.astype(np.int64)
        itx = sc.face_inv_texel.take(face)
        u = u * itx + sc.face_off[:, 0].take(face)
        v = v * itx + sc.face_off[:, 1].take(face)
        foot = t * self.px.pixang * itx / np.sqrt(np.maximum(cos, np.float32(0.04)))
        lod = np.log2(np.maximum(foot, np.float32(1.0)))
        val = sc.textures.sample(sc.face_tex.take(face), u, v, lod)
        img = val * sc.face_gain.take(face) + sc.face_bias.take(face)
        if vignette:
            img *= np.float32(1.0) - np.float32(vignette) * self.px.vignette_r2
        return self.px.to_image(img), self.px.to_image(t)


# --------------------------------------------------------------------------------------------------
# trajectories


BUILTINS = ("handheld", "rotation", "line", "drive")

# Camera presets (--camera). euroc: the EuRoC cam0 of the real data (radial-tangential, 20 Hz); kitti: a
# pinhole with KITTI's cam0 intrinsics (sequences 00-02) and frame size, 10 Hz; tum: a 640x480 pinhole at
# 30 Hz with the nominal intrinsics of the TUM RGB-D benchmark; fisheye: a 640x480 wide-angle lens with the
# equidistant model (128 degrees across, 159 on the diagonal), 20 Hz. All keep EuRoC's T_BS, so that a
# EuRoC body trajectory moves each of them as it moved cam0.
CAMERAS = {
    "euroc": CameraInfo(),
    "kitti": CameraInfo(width=1241, height=376, intrinsics=(718.856, 718.856, 607.1928, 185.2157),
                        distortion_model="none", distortion=(0.0, 0.0, 0.0, 0.0), rate_hz=10.0,
                        comment="KITTI-like pinhole (cam0 intrinsics of KITTI odometry 00-02)"),
    "tum": CameraInfo(width=640, height=480, intrinsics=(525.0, 525.0, 319.5, 239.5),
                      distortion_model="none", distortion=(0.0, 0.0, 0.0, 0.0), rate_hz=30.0,
                      comment="TUM RGB-D-like pinhole (nominal intrinsics)"),
    "fisheye": CameraInfo(width=640, height=480, intrinsics=(280.0, 280.0, 319.5, 239.5),
                          distortion_model="equidistant", distortion=(0.02, -0.005, 0.001, 0.0), rate_hz=20.0,
                          comment="wide-angle lens, equidistant (Kannala-Brandt) model"),
}


def _look_rotation(yaw, pitch, roll):
    """R_W_C for a camera (x right, y down, z forward) looking along yaw (about world z up), then
    pitched up by ``pitch`` and rolled by ``roll`` (radians). Arrays of shape (N,)."""
    n = len(yaw)
    cy, sy = np.cos(yaw), np.sin(yaw)
    fwd = np.stack([cy, sy, np.zeros(n)], 1)
    right = np.stack([sy, -cy, np.zeros(n)], 1)
    down = np.tile([0.0, 0.0, -1.0], (n, 1))
    R0 = np.stack([right, down, fwd], axis=2)  # columns
    from scipy.spatial.transform import Rotation

    Rp = Rotation.from_rotvec(np.stack([-pitch, np.zeros(n), np.zeros(n)], 1)).as_matrix()
    Rr = Rotation.from_rotvec(np.stack([np.zeros(n), np.zeros(n), roll], 1)).as_matrix()
    return R0 @ Rp @ Rr


def builtin_trajectory(name: str, n_frames: int, rate_hz: float = 20.0, seed: int = 0,
                       t0_ns: int = 1_000_000_000_000_000_000, T_BS=EUROC_CAM0_T_BS) -> Trajectory:
    """A generated body trajectory (T_W_B, so that T_W_B @ T_BS is the intended camera motion).
    handheld: walking round a loop at ~0.6 m/s with sway, bob and look-around, every ~8 s a fast pan with
    little translation (rotation-heavy part); rotation: standing still, panning and tilting;
    line: walking straight, looking ahead; drive: a car's camera 1.65 m above the floor going round a
    40 x 25 m ellipse at 7.7-12.3 m/s (turn radius 15.6-64 m, yaw rate 11-29 deg/s), with slight pitch and roll
    (a parking-garage drive, KITTI's speed)."""
    if name not in BUILTINS:
        raise ValueError(f"unknown builtin trajectory {name!r} (choose from {', '.join(BUILTINS)})")
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7EA7]))
    dt = 1.0 / rate_hz
    # generate on a fine grid, then sample (keeps the path independent of the frame count)
    tt = np.arange(n_frames) * dt

    def wobble(amp, fmin, fmax, k=3):
        out = np.zeros_like(tt)
        for _ in range(k):
            f = rng.uniform(fmin, fmax)
            out += amp / k * np.sin(2 * np.pi * f * tt + rng.uniform(0, 2 * np.pi))
        return out

    sway = wobble(0.08, 0.3, 1.2)
    bob = wobble(0.05, 0.8, 2.0)
    look = wobble(np.radians(18), 0.05, 0.25)
    pitch = wobble(np.radians(8), 0.1, 0.6) + np.radians(-4)
    roll = wobble(np.radians(4), 0.1, 0.7)
    if name == "handheld":
        period = 8.0
        phase = rng.uniform(0, period)
        ph = ((tt + phase) % period) / period
        pan_w = np.clip(np.sin(np.pi * np.clip((ph - 0.7) / 0.3, 0, 1)), 0, 1) ** 2  # 0..1 bump, 30% of the time
        speed = 0.6 * (1.0 - 0.85 * pan_w)
        s = np.concatenate([[0.0], np.cumsum(speed[:-1] * dt)])
        a, b = rng.uniform(2.5, 3.5), rng.uniform(1.5, 2.2)
        th = s / (0.5 * (a + b))  # approximately arc length on the ellipse
        x, y = a * np.cos(th), b * np.sin(th)
        heading = np.arctan2(b * np.cos(th), -a * np.sin(th))
        pan = np.radians(rng.uniform(50, 75)) * np.sin(2 * np.pi * np.clip((ph - 0.7) / 0.3, 0, 1))
        yaw = heading + look + pan
        nx, ny = np.cos(heading + np.pi / 2), np.sin(heading + np.pi / 2)
        pos = np.stack([x + sway * nx, y + sway * ny, 1.5 + bob], 1)
    elif name == "rotation":
        yaw = np.radians(70) * np.sin(2 * np.pi * tt / 6.0) + look
        pitch = pitch + np.radians(12) * np.sin(2 * np.pi * tt / 4.3)
        pos = np.stack([0.01 * sway, 0.01 * bob, 1.5 + 0.0 * tt], 1)
    elif name == "line":
        yaw = 0.3 * look
        pos = np.stack([-3.0 + 0.5 * tt, sway, 1.5 + bob], 1)
    else:  # drive
        a, b = 40.0, 25.0
        th = 10.0 * tt / (0.5 * (a + b))
        heading = np.arctan2(b * np.cos(th), -a * np.sin(th))
        yaw = heading + 0.05 * look
        pitch = 0.1 * pitch + np.radians(0.4)
        roll = 0.1 * roll
        pos = np.stack([a * np.cos(th), b * np.sin(th), 1.65 + 0.2 * bob], 1)
    Twc = np.tile(np.eye(4), (n_frames, 1, 1))
    Twc[:, :3, :3] = _look_rotation(yaw, pitch, roll)
    Twc[:, :3, 3] = pos
    t_ns = t0_ns + np.round(tt * 1e9).astype(np.int64)
    return Trajectory(t_ns, Twc, "camera", f"builtin:{name}").to_body(T_BS)


def load_trajectory(path: str, T_BS=EUROC_CAM0_T_BS) -> Trajectory:
    """Body trajectory from an EuRoC csv / groundtruth txt (ns timestamps, body poses, w first) or a TUM
    file (seconds, camera poses, w last), told apart by the timestamp magnitude."""
    with open(path, "r", encoding="utf-8") as f:
        for line in f:
            s = line.strip()
            if s and not s.startswith("#") and not s[0].isalpha():
                first = s.replace(",", " ").split()[0]
                break
        else:
            raise ValueError(f"{path}: no data rows")
    if abs(float(first)) >= 1e11:
        return trajio.read_euroc_groundtruth(path)
    return trajio.read_tum(path).to_body(T_BS)


# --------------------------------------------------------------------------------------------------
# output


def encode_png_gray8(img: np.ndarray, level: int = 3) -> bytes:
    """Minimal deterministic PNG encoder: 8-bit greyscale, 'Up' filter, zlib ``level``."""
    img = np.ascontiguousarray(img, dtype=np.uint8)
    h, w = img.shape
    up = img.copy()
    up[1:] = img[1:] - img[:-1]  # uint8 wraps: filter type 2 (Up)
    raw = np.empty((h, w + 1), dtype=np.uint8)
    raw[:, 0] = 2
    raw[0, 0] = 0
    raw[0, 1:] = img[0]
    raw[1:, 1:] = up[1:]

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw.tobytes(), level)) + chunk(b"IEND", b""))


def finish_image(img: np.ndarray, frame_index: int, seed: int, noise: float, blur: float) -> np.ndarray:
    """Blur (Gaussian, sigma in px), add Gaussian noise (sigma in grey levels, seeded by seed and frame
    index), round to uint8."""
    if blur > 0:
        from scipy.ndimage import gaussian_filter

        img = gaussian_filter(img, blur, mode="nearest", truncate=3.0)
    if noise > 0:
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x401, int(frame_index)]))
        img = img + rng.standard_normal(img.shape, dtype=np.float32) * np.float32(noise)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def frame_times(traj: Trajectory, rate_hz: float, n_frames: int | None, start_time_s: float = 0.0):
    """Regular frame timestamps (ns) from trajectory start + start_time_s, within the trajectory."""
    step = int(round(1e9 / rate_hz))
    t0 = int(traj.t_ns[0]) + int(round(start_time_s * 1e9))
    if t0 > traj.t_ns[-1]:
        raise ValueError("--start-time beyond the end of the trajectory")
    n_max = int((traj.t_ns[-1] - t0) // step) + 1
    n = n_max if n_frames is None else min(int(n_frames), n_max)
    return t0 + step * np.arange(n, dtype=np.int64)


def render_sequence(out_dir: str, traj_body: Trajectory, n_frames: int | None = None, seed: int = 0,
                    noise: float = 1.5, blur: float = 0.6, start_time_s: float = 0.0,
                    cam: CameraInfo | None = None, progress: bool = True, scene_kwargs=None) -> dict:
    """Render a EuRoC/ASL sequence into ``out_dir`` (``mav0/...``); returns a summary dict."""
    cam = cam or CameraInfo()
    t_ns = frame_times(traj_body, cam.rate_hz, n_frames, start_time_s)
    body = Trajectory(t_ns, trajio.interpolate_poses(traj_body.t_ns, traj_body.poses, t_ns), "body")
    camtraj = body.to_camera(cam.T_BS)
    t_start = time.perf_counter()
    scene = make_scene(camtraj.positions, seed=seed, **(scene_kwargs or {}))
    renderer = Renderer(scene, cam)
    t_scene = time.perf_counter() - t_start
    mav = os.path.join(out_dir, "mav0")
    cam_dir = os.path.join(mav, "cam0")
    os.makedirs(os.path.join(cam_dir, "data"), exist_ok=True)
    os.makedirs(os.path.join(mav, "state_groundtruth_estimate0"), exist_ok=True)
    trajio.write_sensor_yaml(os.path.join(cam_dir, "sensor.yaml"), cam)
    trajio.write_euroc_groundtruth(os.path.join(mav, "state_groundtruth_estimate0", "data.csv"), body)
    bar = None
    if progress and sys.stderr.isatty():
        try:
            from tqdm import tqdm

            bar = tqdm(total=len(t_ns), unit="frame", file=sys.stderr)
        except ImportError:
            bar = None
    t_render = t_write = 0.0
    cpu0 = time.process_time()
    with open(os.path.join(cam_dir, "data.csv"), "w", encoding="utf-8", newline="\n") as csv:
        csv.write("#timestamp [ns],filename\n")
        for k, (t, T) in enumerate(zip(t_ns, camtraj.poses)):
            a = time.perf_counter()
            img, _ = renderer.render(T)
            img8 = finish_image(img, k, seed, noise, blur)
            b = time.perf_counter()
            name = f"{int(t)}.png"
            with open(os.path.join(cam_dir, "data", name), "wb") as f:
                f.write(encode_png_gray8(img8))
            csv.write(f"{int(t)},{name}\n")
            t_write += time.perf_counter() - b
            t_render += b - a
            if bar:
                bar.update(1)
    if bar:
        bar.close()
    cpu = time.process_time() - cpu0
    n = len(t_ns)
    return {"frames": n, "scene_s": t_scene, "render_fps": n / max(t_render, 1e-9),
            "total_fps": n / max(t_render + t_write, 1e-9), "total_cpu_fps": n / max(cpu, 1e-9), "boxes": scene.nboxes,
            "room_lo": scene.room_lo.tolist(), "room_hi": scene.room_hi.tolist()}


def main(argv=None) -> int:
    ap = cli.parser("tinyvo-synth", "\n\n".join(__doc__.split("\n\n")[:3]) + "\n\nMore: docs/synth.md.")
    ap.add_argument("--out", required=True, help="output folder (gets mav0/...)")
    src = ap.add_mutually_exclusive_group()
    src.add_argument("--trajectory", help="EuRoC ground truth csv/txt (body poses, ns) or TUM (camera poses, s)")
    src.add_argument("--builtin", choices=BUILTINS, help="generated trajectory (default: handheld)")
    ap.add_argument("--camera", choices=sorted(CAMERAS), default="euroc",
                    help="camera preset: frame size, intrinsics, distortion, frame rate (default euroc)")
    ap.add_argument("--rate", type=float, default=None, help="frame rate in Hz instead of the preset's")
    ap.add_argument("--frames", type=int, default=None, help="number of frames (default: all / 600 for builtin)")
    ap.add_argument("--seed", type=int, default=0, help="scene, texture, noise and builtin-trajectory seed")
    ap.add_argument("--noise", type=float, default=1.5, help="Gaussian noise sigma, grey levels (default 1.5)")
    ap.add_argument("--blur", type=float, default=0.6, help="Gaussian blur sigma, pixels (default 0.6)")
    ap.add_argument("--start-time", type=float, default=0.0, help="seconds skipped at the trajectory start")
    a = ap.parse_args(argv)
    return cli.run(ap.prog, lambda: _main(a, ap))


def _main(a, ap) -> int:
    if a.frames is not None and a.frames <= 0:
        ap.error("--frames must be positive")
    if a.noise < 0 or a.blur < 0:
        ap.error("--noise and --blur must be >= 0")
    if a.rate is not None and not (math.isfinite(a.rate) and 0.1 <= a.rate <= 1000.0):
        ap.error("--rate must be in [0.1, 1000] Hz")
    cam = replace(CAMERAS[a.camera], rate_hz=a.rate or CAMERAS[a.camera].rate_hz)
    if a.trajectory:
        traj = load_trajectory(a.trajectory)
    else:
        n = (a.frames or 600) + int(np.ceil(max(a.start_time, 0) * cam.rate_hz)) + 1
        traj = builtin_trajectory(a.builtin or "handheld", n, rate_hz=cam.rate_hz, seed=a.seed)
    info = render_sequence(a.out, traj, a.frames, a.seed, a.noise, a.blur, a.start_time, cam=cam,
                           progress=not a.quiet)
    if not a.quiet:
        print(f"synth: {info['frames']} frames -> {a.out}/mav0 ({info['boxes']} boxes, "
              f"render {info['render_fps']:.1f} frames/s, with PNG writing {info['total_fps']:.1f} frames/s wall, "
              f"{info['total_cpu_fps']:.1f} frames/s per CPU second)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
