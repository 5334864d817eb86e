"""The C int8 interpreter (lib/src/tvo_nn_*.c) against the NumPy integer reference (tinyvo_tools.nnfmt),
bit for bit: golden vectors of test/data/nn, >= 10,000 random inputs per activation, and the loader's
refusals of corrupted files."""
import ctypes
import pathlib
import struct

import numpy as np
import pytest

from tinyvo_tools import nnfmt, quant

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "test" / "data" / "nn"
FEAT = nnfmt.FEAT_COUNT


class CModel:
    """A model loaded by the C library through ctypes."""

    def __init__(self, tvo, data: bytes):
        self.tvo = tvo
        tvo.tvo_nn_required_size.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.POINTER(ctypes.c_size_t)]
        tvo.tvo_nn_load.argtypes = [ctypes.POINTER(ctypes.c_void_p), ctypes.c_char_p, ctypes.c_size_t,
                                    ctypes.c_void_p, ctypes.c_size_t]
        tvo.tvo_nn_run.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
        tvo.tvo_nn_output_mask.argtypes = [ctypes.c_void_p]
        tvo.tvo_nn_macs.argtypes = [ctypes.c_void_p]
        tvo.tvo_nn_macs.restype = ctypes.c_uint32
        need = ctypes.c_size_t()
        st = tvo.tvo_nn_required_size(data, len(data), ctypes.byref(need))
        if st != 0:
            raise ValueError(f"required_size status {st}")
        self.mem = ctypes.create_string_buffer(need.value)
        self.handle = ctypes.c_void_p()
        st = tvo.tvo_nn_load(ctypes.byref(self.handle), data, len(data), self.mem, need.value)
        if st != 0:
            raise ValueError(f"load status {st}")

    def run(self, features: np.ndarray):
        features = np.ascontiguousarray(features, np.float32)
        out = np.empty((features.shape[0], 6), np.float32)
        fp = features.ctypes.data
        op = out.ctypes.data
        run = self.tvo.tvo_nn_run
        h = self.handle
        status = np.empty(features.shape[0], np.int32)
        for i in range(features.shape[0]):
            status[i] = run(h, fp + 4 * FEAT * i, op + 24 * i)
        return out, status

    @property
    def mask(self):
        return self.tvo.tvo_nn_output_mask(self.handle)


def load_status(tvo, data: bytes) -> int:
    need = ctypes.c_size_t()
    tvo.tvo_nn_required_size.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.POINTER(ctypes.c_size_t)]
    return tvo.tvo_nn_required_size(data, len(data), ctypes.byref(need))


def assert_bits_equal(a: np.ndarray, b: np.ndarray):
    a = np.ascontiguousarray(a, np.float32)
    b = np.ascontiguousarray(b, np.float32)
    bad = a.view(np.uint32) != b.view(np.uint32)
    assert not bad.any(), f"{bad.sum()} mismatches, first at {np.argwhere(bad)[0]}: C {a[bad][0]!r} ref {b[bad][0]!r}"


@pytest.mark.parametrize("name", ["tiny", "paper"])
def test_golden_vectors(tvo, name):
    data = (DATA / f"{name}.tvonn").read_bytes()
    x, y, gen = nnfmt.read_golden(DATA / f"{name}.golden")
    assert gen.startswith("tinyvo_tools.nngolden")
    c = CModel(tvo, data)
    assert c.mask == 0x3F
    out, st = c.run(x)
    assert (st == 0).all()
    assert_bits_equal(out, y)
    # the reference still reproduces the stored vectors (format/reference drift)
    assert_bits_equal(nnfmt.reference_run(nnfmt.read(data), x), y)


def random_inputs(rng, n):
    f = quant.synthetic_features(rng, n)
    # a third at calibration-like values, a third widened (saturation), a third arbitrary
    k = n // 3
    f[k:2 * k] *= rng.uniform(-8, 8, (k, 1)).astype(np.float32)
    f[2 * k:] = rng.normal(0, 3, (n - 2 * k, FEAT)).astype(np.float32)
    return f


@pytest.mark.parametrize("act", quant.nnfmt.ACTS[1:])
def test_random_inputs_per_activation(tvo, act):
    rng = np.random.default_rng(1000 + quant.nnfmt.ACT_CODE[act])
    calib = quant.synthetic_features(rng, 1000)
    fbs = [quant.random_float_branch(rng, d, act, sizes=(64, 32, 32)) for d in range(6)]
    model = quant.quantize_model(fbs, calib)
    data = nnfmt.write(model)
    c = CModel(tvo, data)
    x = random_inputs(rng, 10000)
    out, st = c.run(x)
    assert (st == 0).all()
    ref = nnfmt.reference_run(model, x)
    assert_bits_equal(out, ref)


def test_partial_model_and_feature_subset(tvo):
    rng = np.random.default_rng(7)
    calib = quant.synthetic_features(rng, 500)
    fbs = [quant.random_float_branch(rng, 4, "tanh", sizes=(8,), feature_ids=[0, 1, 2, 7]),
           quant.random_float_branch(rng, 1, "relu", sizes=(8, 4), feature_ids=[9, 3])]
    model = quant.quantize_model(fbs, calib)
    c = CModel(tvo, nnfmt.write(model))
    assert c.mask == (1 << 4) | (1 << 1)
    x = random_inputs(rng, 500)
    x[:, 10] = np.nan  # not read by any branch: ignored
    out, st = c.run(x)
    assert (st == 0).all()
    assert np.isnan(out[:, [0, 2, 3, 5]]).all()
    assert_bits_equal(out, nnfmt.reference_run(model, x))
    x[0, 7] = np.inf  # read: refused
    out, st = c.run(x[:1])
    assert st[0] == -6 and np.isnan(out).all()


def test_corrupt_files_refused(tvo):
    """A few structural corruptions (CRC fixed so that the structural check is reached)."""
    good = bytearray((DATA / "tiny.tvonn").read_bytes())
    assert load_status(tvo, bytes(good)) == 0
    rng = np.random.default_rng(3)
    # flipping any single byte without fixing the CRC is refused
    for _ in range(300):
        b = bytearray(good)
        i = int(rng.integers(0, len(b)))
        b[i] ^= 1 << int(rng.integers(0, 8))
        assert load_status(tvo, bytes(b)) != 0, i
    # random bytes after a CRC fix never crash, and either load or give an error
    for _ in range(300):
        b = bytearray(good)
        for _ in range(4):
            b[int(rng.integers(16, len(b)))] = int(rng.integers(0, 256))
        nnfmt.fix_crc(b)
        st = load_status(tvo, bytes(b))
        assert st <= 0
    b = bytearray(good)
    struct.pack_into("<I", b, 20, 2)  # layout id
    nnfmt.fix_crc(b)
    assert load_status(tvo, bytes(b)) == -21
