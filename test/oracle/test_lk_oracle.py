# SPDX-License-Identifier: Apache-2.0
"""Pyramids and pyramidal Lucas-Kanade vs OpenCV (cv2.pyrDown / buildOpticalFlowPyramid /
calcOpticalFlowPyrLK), on the real EuRoC cam0 -> cam1 pairs and on synthetic sub-pixel shifts.

The ctypes binding (class TvoLK) is also used by test/bench/bench_lk.py."""
import ctypes
import pathlib

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

MAX_LEVELS = 8  # TVO_MAX_PYR_LEVELS default (options.h)
WIN, MAX_LEVEL, ITERS, EPS = 21, 3, 30, 0.01
CRIT = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, ITERS, EPS)
HEAD = pathlib.Path("euroc") / "V1_01_easy_head" / "mav0"


class Pyramid(ctypes.Structure):
    _fields_ = [("levels", ctypes.c_int32),
                ("width", ctypes.c_int32 * MAX_LEVELS),
                ("height", ctypes.c_int32 * MAX_LEVELS),
                ("stride", ctypes.c_int32 * MAX_LEVELS),
                ("data", ctypes.POINTER(ctypes.c_uint8) * MAX_LEVELS),
                ("row_tmp", ctypes.POINTER(ctypes.c_uint16)),
                ("own0", ctypes.c_int32)]


class Image(ctypes.Structure):
    _fields_ = [("width", ctypes.c_int32), ("height", ctypes.c_int32), ("stride", ctypes.c_int32),
                ("data", ctypes.POINTER(ctypes.c_uint8))]


class LKConfig(ctypes.Structure):
    _fields_ = [("win_size", ctypes.c_int32), ("max_level", ctypes.c_int32),
                ("max_iters", ctypes.c_int32), ("epsilon", ctypes.c_float),
                ("min_eig_threshold", ctypes.c_float), ("use_initial_flow", ctypes.c_int32),
                ("fb_check", ctypes.c_int32), ("fb_max_error", ctypes.c_float),
                ("force_portable", ctypes.c_int32), ("fb_levels", ctypes.c_int32),
                ("pred_levels", ctypes.c_int32), ("pred_win_size", ctypes.c_int32),
                ("pred_fb_levels", ctypes.c_int32), ("pred_retry", ctypes.c_int32)]


def _image(arr):
    arr = np.ascontiguousarray(arr, dtype=np.uint8)
    return Image(arr.shape[1], arr.shape[0], arr.strides[0],
                 arr.ctypes.data_as(ctypes.POINTER(ctypes.c_uint8))), arr


class TvoLK:
    """Thin ctypes wrapper over tvo_pyramid_* and tvo_lk_*; keeps the memory blocks alive."""

    def __init__(self, lib):
        self.lib = lib
        lib.tvo_pyramid_required_size.restype = ctypes.c_size_t
        lib.tvo_pyramid_required_size.argtypes = [ctypes.c_int32] * 3
        lib.tvo_pyramid_init.argtypes = [ctypes.POINTER(Pyramid), ctypes.c_int32, ctypes.c_int32,
                                         ctypes.c_int32, ctypes.c_void_p, ctypes.c_size_t]
        lib.tvo_pyramid_build.argtypes = [ctypes.POINTER(Pyramid), ctypes.POINTER(Image)]
        lib.tvo_lk_config_default.argtypes = [ctypes.POINTER(LKConfig)]
        lib.tvo_lk_scratch_size.restype = ctypes.c_size_t
        lib.tvo_lk_scratch_size.argtypes = [ctypes.POINTER(LKConfig)]
        lib.tvo_lk_track.argtypes = [ctypes.POINTER(LKConfig), ctypes.POINTER(Pyramid),
                                     ctypes.POINTER(Pyramid), ctypes.c_void_p, ctypes.c_void_p,
                                     ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int32,
                                     ctypes.c_void_p, ctypes.c_size_t]

    def pyramid(self, width, height, levels):
        size = self.lib.tvo_pyramid_required_size(width, height, levels)
        assert size > 0
        mem = ctypes.create_string_buffer(size)
        p = Pyramid()
        assert self.lib.tvo_pyramid_init(ctypes.byref(p), width, height, levels, mem, size) == 0
        p._mem = mem  # keep alive
        return p

    def build(self, p, img):
        im, keep = _image(img)
        st = self.lib.tvo_pyramid_build(ctypes.byref(p), ctypes.byref(im))
        assert st == 0, st
        return p

    @staticmethod
    def level(p, lvl):
        w, h, s = p.width[lvl], p.height[lvl], p.stride[lvl]
        buf = np.ctypeslib.as_array(p.data[lvl], shape=(h * s,))
        return buf.reshape(h, s)[:, :w].copy()

    def config(self, win=WIN, max_level=MAX_LEVEL, iters=ITERS, eps=EPS, fb=False, fb_max=1.0,
               init_flow=False, portable=False):
        c = LKConfig()
        self.lib.tvo_lk_config_default(ctypes.byref(c))
        c.win_size, c.max_level, c.max_iters, c.epsilon = win, max_level, iters, eps
        c.fb_check, c.fb_max_error, c.use_initial_flow = int(fb), fb_max, int(init_flow)
        c.force_portable = int(portable)
        return c

    def scratch(self, cfg):
        size = self.lib.tvo_lk_scratch_size(ctypes.byref(cfg))
        assert size > 0
        return ctypes.create_string_buffer(size), size

    def track(self, cfg, p0, p1, pts, guess=None, scratch=None):
        pts = np.ascontiguousarray(pts, dtype=np.float32).reshape(-1, 2)
        n = len(pts)
        nxt = (np.ascontiguousarray(guess, dtype=np.float32).reshape(-1, 2).copy()
               if guess is not None else np.zeros_like(pts))
        status = np.zeros(n, np.uint8)
        err = np.zeros(n, np.float32)
        sbuf, ssize = scratch if scratch is not None else self.scratch(cfg)
        st = self.lib.tvo_lk_track(ctypes.byref(cfg), ctypes.byref(p0), ctypes.byref(p1),
                                   pts.ctypes.data, nxt.ctypes.data, status.ctypes.data,
                                   err.ctypes.data, n, sbuf, ssize)
        assert st == 0, st
        return nxt, status, err


def cv_track(a, b, pts, win=WIN, max_level=MAX_LEVEL, crit=CRIT):
    p = np.ascontiguousarray(pts, dtype=np.float32).reshape(-1, 1, 2)
    nxt, st, err = cv2.calcOpticalFlowPyrLK(a, b, p, None, winSize=(win, win), maxLevel=max_level,
                                            criteria=crit)
    return nxt.reshape(-1, 2), st.ravel(), err.ravel()


@pytest.fixture(scope="module")
def lk(tvo):
    cv2.setNumThreads(1)
    return TvoLK(tvo)


def stereo_pairs(data_dir, count=5):
    root = data_dir / HEAD
    names = sorted((root / "cam0" / "data").glob("*.png"))
    step = max(1, len(names) // count)
    out = []
    for f0 in names[::step][:count]:
        f1 = root / "cam1" / "data" / f0.name
        if f1.exists():
            out.append((cv2.imread(str(f0), cv2.IMREAD_GRAYSCALE), cv2.imread(str(f1), cv2.IMREAD_GRAYSCALE)))
    return out


def corners(img, n=300):
    p = cv2.goodFeaturesToTrack(img, n, 0.01, 10)
    return p.reshape(-1, 2).astype(np.float32)


# ---------------------------------------------------------------- pyramids

@pytest.mark.parametrize("shape", [(480, 752), (37, 41), (16, 17), (64, 1), (1, 9), (101, 203)])
def test_pyr_down_matches_opencv(lk, shape):
    rng = np.random.default_rng(shape[0] * 1000 + shape[1])
    img = rng.integers(0, 256, size=shape, dtype=np.uint8)
    levels = 1
    h, w = shape
    while levels < 4:
        w2, h2 = (w + 1) // 2, (h + 1) // 2
        if min(w2, h2) < 8:
            break
        w, h, levels = w2, h2, levels + 1
    p = lk.build(lk.pyramid(shape[1], shape[0], levels), img)
    ref = img
    assert np.array_equal(lk.level(p, 0), img)
    for lvl in range(1, levels):
        ref = cv2.pyrDown(ref)
        got = lk.level(p, lvl)
        assert got.shape == ref.shape
        assert int(np.abs(got.astype(int) - ref.astype(int)).max()) == 0


def test_tvo_pyr_down_tiny_images(lk):
    """The one-step function on sizes a pyramid refuses (1..7 px), still exact vs cv2.pyrDown."""
    lib = lk.lib
    lib.tvo_pyr_down.argtypes = [ctypes.POINTER(Image), ctypes.POINTER(Image), ctypes.c_void_p]
    rng = np.random.default_rng(7)
    for h in range(1, 8):
        for w in range(1, 8):
            img = rng.integers(0, 256, size=(h, w), dtype=np.uint8)
            dst = np.zeros(((h + 1) // 2, (w + 1) // 2), np.uint8)
            si, k1 = _image(img)
            di, k2 = _image(dst)
            tmp = (ctypes.c_uint16 * w)()
            assert lib.tvo_pyr_down(ctypes.byref(si), ctypes.byref(di), tmp) == 0
            ref = cv2.pyrDown(img, dstsize=(dst.shape[1], dst.shape[0]))
            assert np.array_equal(k2, ref), (h, w)


def test_pyramid_matches_build_optical_flow_pyramid(lk, data_dir):
    a, _ = stereo_pairs(data_dir, 1)[0]
    p = lk.build(lk.pyramid(a.shape[1], a.shape[0], MAX_LEVEL + 1), a)
    n, ref = cv2.buildOpticalFlowPyramid(a, (WIN, WIN), MAX_LEVEL, withDerivatives=False)
    assert n == MAX_LEVEL
    maxdiff = max(int(np.abs(lk.level(p, i).astype(int) - ref[i].astype(int)).max()) for i in range(n + 1))
    print(f"pyramid max abs difference vs buildOpticalFlowPyramid: {maxdiff}")
    assert maxdiff == 0


# ---------------------------------------------------------------- tracking vs OpenCV

def _compare(lk, a, b, pts, **kw):
    cfg = lk.config(**kw)
    levels = kw.get("max_level", MAX_LEVEL) + 1
    pa = lk.build(lk.pyramid(a.shape[1], a.shape[0], levels), a)
    pb = lk.build(lk.pyramid(b.shape[1], b.shape[0], levels), b)
    got, st, err = lk.track(cfg, pa, pb, pts)
    ref, rst, rerr = cv_track(a, b, pts, win=kw.get("win", WIN), max_level=kw.get("max_level", MAX_LEVEL))
    both = (st == 1) & (rst == 1)
    d = np.linalg.norm(got[both] - ref[both], axis=1)
    return got, st, err, ref, rst, rerr, both, d


def test_lk_euroc_stereo_matches_opencv(lk, data_dir):
    meds, agree, total_both, total_cv = [], [], 0, 0
    for a, b in stereo_pairs(data_dir, 5):
        pts = corners(a)
        got, st, err, ref, rst, rerr, both, d = _compare(lk, a, b, pts)
        # disparities are real: tens of px along x
        assert np.percentile(np.abs(ref[rst == 1, 0] - pts[rst == 1, 0]), 90) > 10
        meds.append(np.median(d))
        agree.append(np.mean(d < 0.01))
        total_both += both.sum()
        total_cv += (rst == 1).sum()
        # err agrees where both track and positions agree
        close = d < 1e-3
        e1, e2 = err[both][close], rerr[both][close]
        assert np.median(np.abs(e1 - e2)) < 0.05
    print(f"stereo: median endpoint diff per pair {np.round(meds, 5)}, "
          f"share < 0.01 px {np.round(agree, 3)}, both tracked {total_both} / cv tracked {total_cv}")
    assert max(meds) <= 0.05
    # tracked sets nearly agree (tinyvo additionally drops points that end outside the image)
    assert total_both >= 0.95 * total_cv


def _shift_image(img, dx, dy):
    """img translated by (dx, dy) px (content at x moves to x + dx), exactly for a band-limited
    periodic image: a Fourier phase shift. (cv2.warpAffine is not used: its fixed-point 1/32 px
    interpolation tables bias the shift by up to ~0.05 px.)"""
    f = np.fft.fft2(img.astype(np.float64))
    fy = np.fft.fftfreq(img.shape[0])[:, None]
    fx = np.fft.fftfreq(img.shape[1])[None, :]
    return np.real(np.fft.ifft2(f * np.exp(-2j * np.pi * (fx * dx + fy * dy))))


@pytest.mark.parametrize("shift", [(0.25, 0.0), (0.5, -0.75), (-1.3, 2.6), (7.4, -3.2), (18.6, 4.45)])
def test_lk_synthetic_subpixel_shift(lk, data_dir, shift):
    a, _ = stereo_pairs(data_dir, 1)[0]
    # smooth a little: the shifted 8-bit image then stays close to a true translation
    base = cv2.GaussianBlur(a, (0, 0), 1.0).astype(np.float64)
    a8 = np.clip(np.rint(base), 0, 255).astype(np.uint8)
    b8 = np.clip(np.rint(_shift_image(base, *shift)), 0, 255).astype(np.uint8)
    pts = corners(a8)
    m = 40  # away from the wrap-around of the periodic shift
    keep = ((pts[:, 0] > m) & (pts[:, 0] < a.shape[1] - m) & (pts[:, 1] > m) & (pts[:, 1] < a.shape[0] - m))
    pts = pts[keep]
    got, st, err, ref, rst, rerr, both, d = _compare(lk, a8, b8, pts)
    truth = pts + np.float32(shift)
    e_tvo = np.linalg.norm(got[st == 1] - truth[st == 1], axis=1)
    e_cv = np.linalg.norm(ref[rst == 1] - truth[rst == 1], axis=1)
    print(f"shift {shift}: tinyvo median error vs truth {np.median(e_tvo):.4f} px "
          f"(OpenCV {np.median(e_cv):.4f}), median diff vs OpenCV {np.median(d):.5f}, "
          f"tracked {st.sum()}/{len(pts)}")
    assert st.mean() > 0.9
    assert np.median(e_tvo) <= 0.05
    assert np.median(d) <= 0.05


def test_lk_other_window_and_levels(lk, data_dir):
    a, b = stereo_pairs(data_dir, 1)[0]
    pts = corners(a, 150)
    for win, lvl in [(7, 1), (15, 2), (31, 4)]:
        *_, both, d = _compare(lk, a, b, pts, win=win, max_level=lvl)
        assert both.sum() > 0.5 * len(pts)
        assert np.median(d) <= 0.05, (win, lvl, np.median(d))


def test_lk_points_near_borders_match_opencv(lk, data_dir):
    """Windows that hang over the image edge: reflected pixels, zero derivatives, as OpenCV."""
    a, b = stereo_pairs(data_dir, 1)[0]
    rng = np.random.default_rng(3)
    h, w = a.shape
    xs = np.concatenate([rng.uniform(0, 12, 60), rng.uniform(w - 12, w - 1, 60), rng.uniform(0, w - 1, 120)])
    ys = np.concatenate([rng.uniform(0, h - 1, 120), rng.uniform(0, 12, 60), rng.uniform(h - 12, h - 1, 60)])
    pts = np.stack([xs, ys], 1).astype(np.float32)
    got, st, err, ref, rst, rerr, both, d = _compare(lk, a, a, pts)
    # identical images: both stay put where the window has texture
    assert both.sum() > 0.5 * len(pts)
    assert np.median(d) <= 0.01
