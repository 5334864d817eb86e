# SPDX-License-Identifier: Apache-2.0
"""Oracle tests of tinyvo's corner module against OpenCV (opencv-python-headless, pinned in the venv).

- FAST-9 without non-max suppression: exactly OpenCV's corner set (TYPE_9_16), several EuRoC frames and
  thresholds; with non-max suppression: exactly OpenCV's set AND scores (KeyPoint.response).
- Harris / Shi-Tomasi responses vs cv2.cornerHarris / cv2.cornerMinEigenVal (ksize 3,
  BORDER_REFLECT_101): per pixel |tvo - cv| <= RTOL * |cv| + ATOL_REL * S (S below; as stated in
  tinyvo/corners.h), plus tvo_corner_score_at equals the dense map exactly.
"""
import ctypes
import pathlib

import numpy as np
import pytest

cv2 = pytest.importorskip("cv2")

RTOL = 1e-4       # relative, per pixel
ATOL_REL = 1e-6   # absolute, as a fraction of S = max over the image of |response| and of trace(M)
                  # (Shi-Tomasi) or trace(M)^2 (Harris): OpenCV's float cancellation error scales so

FRAMES = [0, 30, 60, 94]
THRESHOLDS = [5, 10, 20, 40]


class TvoImage(ctypes.Structure):
    _fields_ = [("width", ctypes.c_int32), ("height", ctypes.c_int32), ("stride", ctypes.c_int32),
                ("data", ctypes.POINTER(ctypes.c_uint8))]


class TvoCorner(ctypes.Structure):
    _fields_ = [("x", ctypes.c_float), ("y", ctypes.c_float), ("score", ctypes.c_float)]


class TvoPoint2f(ctypes.Structure):
    _fields_ = [("x", ctypes.c_float), ("y", ctypes.c_float)]


class TvoDetectConfig(ctypes.Structure):
    _fields_ = [("fast_threshold", ctypes.c_int32), ("score", ctypes.c_int), ("block_size", ctypes.c_int32),
                ("harris_k", ctypes.c_float), ("grid_cols", ctypes.c_int32), ("grid_rows", ctypes.c_int32),
                ("max_corners", ctypes.c_int32), ("max_per_cell", ctypes.c_int32),
                ("min_distance", ctypes.c_float), ("border", ctypes.c_int32),
                ("candidates_per_cell", ctypes.c_int32)]


def setup_lib(lib):
    lib.tvo_fast_scratch_size.restype = ctypes.c_size_t
    lib.tvo_fast_scratch_size.argtypes = [ctypes.c_int32]
    lib.tvo_fast9_detect.restype = ctypes.c_int
    lib.tvo_fast9_detect.argtypes = [ctypes.POINTER(TvoImage), ctypes.c_int32, ctypes.c_int,
                                     ctypes.POINTER(TvoCorner), ctypes.c_int32, ctypes.POINTER(ctypes.c_int32),
                                     ctypes.c_void_p, ctypes.c_size_t]
    lib.tvo_corner_response_scratch_size.restype = ctypes.c_size_t
    lib.tvo_corner_response_scratch_size.argtypes = [ctypes.c_int32, ctypes.c_int32]
    lib.tvo_corner_response.restype = ctypes.c_int
    lib.tvo_corner_response.argtypes = [ctypes.POINTER(TvoImage), ctypes.c_int, ctypes.c_int32, ctypes.c_float,
                                        ctypes.POINTER(ctypes.c_float), ctypes.c_int32, ctypes.c_void_p,
                                        ctypes.c_size_t]
    lib.tvo_corner_score_at.restype = ctypes.c_float
    lib.tvo_corner_score_at.argtypes = [ctypes.POINTER(TvoImage), ctypes.c_int32, ctypes.c_int32, ctypes.c_int,
                                        ctypes.c_int32, ctypes.c_float]
    lib.tvo_detect_config_default.restype = None
    lib.tvo_detect_config_default.argtypes = [ctypes.POINTER(TvoDetectConfig)]
    lib.tvo_detect_scratch_size.restype = ctypes.c_size_t
    lib.tvo_detect_scratch_size.argtypes = [ctypes.POINTER(TvoDetectConfig), ctypes.c_int32, ctypes.c_int32]
    lib.tvo_detect.restype = ctypes.c_int
    lib.tvo_detect.argtypes = [ctypes.POINTER(TvoDetectConfig), ctypes.POINTER(TvoImage),
                               ctypes.POINTER(TvoPoint2f), ctypes.c_int32, ctypes.POINTER(TvoCorner),
                               ctypes.c_int32, ctypes.POINTER(ctypes.c_int32), ctypes.c_void_p, ctypes.c_size_t]
    return lib


def make_image(a):
    a = np.ascontiguousarray(a, dtype=np.uint8)
    img = TvoImage(a.shape[1], a.shape[0], a.strides[0], a.ctypes.data_as(ctypes.POINTER(ctypes.c_uint8)))
    return img, a  # keep the array alive


def tvo_fast(lib, a, threshold, nonmax):
    img, keep = make_image(a)
    scratch = ctypes.create_string_buffer(lib.tvo_fast_scratch_size(a.shape[1]))
    cap = a.shape[0] * a.shape[1]
    out = (TvoCorner * cap)()
    n = ctypes.c_int32(0)
    st = lib.tvo_fast9_detect(ctypes.byref(img), threshold, int(nonmax), out, cap, ctypes.byref(n),
                              scratch, len(scratch))
    assert st == 0
    arr = np.ctypeslib.as_array(out)[: n.value]
    return [(int(c[0]), int(c[1]), int(c[2])) for c in arr]


def cv_fast(a, threshold, nonmax):
    det = cv2.FastFeatureDetector_create(threshold, nonmaxSuppression=nonmax,
                                         type=cv2.FAST_FEATURE_DETECTOR_TYPE_9_16)
    return [(int(k.pt[0]), int(k.pt[1]), int(k.response)) for k in det.detect(a)]


def tvo_response(lib, a, kind, block, k=0.04):
    img, keep = make_image(a)
    h, w = a.shape
    scratch = ctypes.create_string_buffer(lib.tvo_corner_response_scratch_size(w, block))
    out = np.zeros((h, w + 3), np.float32)  # padded stride
    st = lib.tvo_corner_response(ctypes.byref(img), kind, block, k,
                                 out.ctypes.data_as(ctypes.POINTER(ctypes.c_float)), w + 3, scratch, len(scratch))
    assert st == 0
    return out[:, :w]


@pytest.fixture(scope="module")
def lib(tvo):
    return setup_lib(tvo)


@pytest.fixture(scope="module")
def frames(data_dir):
    d = pathlib.Path(data_dir) / "euroc" / "V1_01_easy_head" / "mav0" / "cam0" / "data"
    files = sorted(d.glob("*.png"))
    if len(files) < 95:
        pytest.skip(f"expected 95 frames in {d}")
    return [cv2.imread(str(files[i]), cv2.IMREAD_GRAYSCALE) for i in FRAMES]


@pytest.mark.parametrize("threshold", THRESHOLDS)
def test_fast_no_nonmax_equals_opencv(lib, frames, threshold):
    cv2.setNumThreads(1)
    for a in frames:
        ours = tvo_fast(lib, a, threshold, False)
        ref = cv_fast(a, threshold, False)
        assert len(ref) > 100
        assert sorted((x, y) for x, y, _ in ours) == sorted((x, y) for x, y, _ in ref)
        assert all(s >= threshold for _, _, s in ours)  # tinyvo fills the score (OpenCV: 0)


@pytest.mark.parametrize("threshold", THRESHOLDS)
def test_fast_nonmax_equals_opencv(lib, frames, threshold):
    for a in frames:
        ours = tvo_fast(lib, a, threshold, True)
        ref = cv_fast(a, threshold, True)
        assert len(ref) > 50
        assert sorted(ours) == sorted(ref)   # positions and scores
        assert ours == sorted(ours, key=lambda c: (c[1], c[0]))  # row-major


def test_fast_odd_sizes_and_crops(lib, frames):
    a = frames[1]
    for (h, w) in [(7, 7), (8, 9), (31, 17), (101, 333), (480, 751), (37, 640)]:
        crop = np.ascontiguousarray(a[11:11 + h, 5:5 + w])
        for nonmax in (False, True):
            ours = tvo_fast(lib, crop, 10, nonmax)
            ref = cv_fast(crop, 10, nonmax)
            assert sorted((x, y) for x, y, _ in ours) == sorted((x, y) for x, y, _ in ref), (h, w, nonmax)
    tiny = np.ascontiguousarray(a[:6, :50])
    assert tvo_fast(lib, tiny, 10, True) == []


def test_fast_synthetic_noise(lib):
    rng = np.random.default_rng(7)
    a = rng.integers(0, 256, (120, 200), dtype=np.uint8)  # saturating extremes near 0 and 255
    for t in (0, 1, 50, 254, 255):
        for nonmax in (False, True):
            ours = tvo_fast(lib, a, t, nonmax)
            ref = cv_fast(a, t, nonmax)
            if nonmax:
                assert sorted(ours) == sorted(ref), t
            else:
                assert sorted((x, y) for x, y, _ in ours) == sorted((x, y) for x, y, _ in ref), t


def _check_close(ours, ref, a, block, harris):
    # OpenCV rounds in float: its error scales with trace(M) (Shi-Tomasi) or trace(M)^2 (Harris)
    ev = cv2.cornerEigenValsAndVecs(a, block, 3, borderType=cv2.BORDER_REFLECT_101)
    trace = float(np.max(np.abs(ev[..., 0] + ev[..., 1])))
    atol = ATOL_REL * max(float(np.max(np.abs(ref))), trace * trace if harris else trace)
    err = np.abs(ours.astype(np.float64) - ref.astype(np.float64))
    lim = RTOL * np.abs(ref.astype(np.float64)) + atol
    assert np.all(err <= lim), f"max excess {np.max(err - lim)}, max err {np.max(err)}"


@pytest.mark.parametrize("block", [2, 3, 5, 7])
def test_shi_tomasi_equals_opencv(lib, frames, block):
    for a in frames[:2]:
        ref = cv2.cornerMinEigenVal(a, block, 3, borderType=cv2.BORDER_REFLECT_101)
        _check_close(tvo_response(lib, a, 2, block), ref, a, block, False)


@pytest.mark.parametrize("block", [2, 3, 5, 7])
def test_harris_equals_opencv(lib, frames, block):
    for a in frames[:2]:
        ref = cv2.cornerHarris(a, block, 3, 0.04, borderType=cv2.BORDER_REFLECT_101)
        _check_close(tvo_response(lib, a, 1, block, 0.04), ref, a, block, True)


def test_response_small_images(lib, frames):
    a = frames[0]
    for (h, w) in [(1, 1), (1, 9), (2, 2), (3, 5), (9, 4), (40, 33)]:
        crop = np.ascontiguousarray(a[100:100 + h, 200:200 + w])
        for block in (1, 3, 7):
            _check_close(tvo_response(lib, crop, 2, block),
                         cv2.cornerMinEigenVal(crop, block, 3, borderType=cv2.BORDER_REFLECT_101),
                         crop, block, False)
            _check_close(tvo_response(lib, crop, 1, block, 0.05),
                         cv2.cornerHarris(crop, block, 3, 0.05, borderType=cv2.BORDER_REFLECT_101),
                         crop, block, True)


def test_score_at_equals_dense(lib, frames):
    a = frames[2]
    img, keep = make_image(a)
    for kind in (1, 2):
        for block in (3, 5, 7):
            dense = tvo_response(lib, a, kind, block)
            rng = np.random.default_rng(block)
            m = block // 2 + 2
            for _ in range(200):
                x = int(rng.integers(m, a.shape[1] - m))
                y = int(rng.integers(m, a.shape[0] - m))
                assert lib.tvo_corner_score_at(ctypes.byref(img), x, y, kind, block, 0.04) == dense[y, x]


def test_detect_spreads_and_ranks(lib, frames):
    a = frames[0]
    img, keep = make_image(a)
    cfg = TvoDetectConfig()
    lib.tvo_detect_config_default(ctypes.byref(cfg))
    scratch = ctypes.create_string_buffer(lib.tvo_detect_scratch_size(ctypes.byref(cfg), a.shape[1], a.shape[0]))
    out = (TvoCorner * 400)()
    n = ctypes.c_int32(0)
    assert lib.tvo_detect(ctypes.byref(cfg), ctypes.byref(img), None, 0, out, 400, ctypes.byref(n),
                          scratch, len(scratch)) == 0
    pts = [(c.x, c.y, c.score) for c in out[: n.value]]
    fast = set((x, y) for x, y, _ in cv_fast(a, cfg.fast_threshold, True))
    # what an 8x6 grid with 7 per cell can offer on this (low-texture) frame, from OpenCV's FAST corners
    h, w = a.shape
    b, iw, ih = cfg.border, w - 2 * cfg.border, h - 2 * cfg.border
    cells = {}
    for x, y in fast:
        if b <= x < w - b and b <= y < h - b:
            cells.setdefault(((y - b) * 6 // ih, (x - b) * 8 // iw), []).append((x, y))
    offer = sum(min(len(v), 7) for v in cells.values())
    assert 0.9 * offer <= len(pts) <= 300
    got = set(((int(y) - b) * 6 // ih, (int(x) - b) * 8 // iw) for x, y, _ in pts)
    # every cell with a few FAST corners gets corners (a lone corner may sit within min_distance of a
    # corner taken in the neighbouring cell)
    assert got >= set(k for k, v in cells.items() if len(v) >= 3)
    ref = cv2.cornerMinEigenVal(a, cfg.block_size, 3, borderType=cv2.BORDER_REFLECT_101)
    for x, y, s in pts:
        assert (int(x), int(y)) in fast                       # every corner is an OpenCV FAST corner
        assert abs(s - ref[int(y), int(x)]) <= RTOL * abs(ref[int(y), int(x)]) + ATOL_REL * np.max(ref)
