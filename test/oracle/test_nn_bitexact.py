# SPDX-License-Identifier: Apache-2.0
"""The C int8 interpreter (lib/src/tvo_nn_*.c) against the NumPy integer reference (tinyvo_tools.nnfmt),
bit for bit: golden vectors of test/data/nn, >= 10,000 random inputs per activation, and the loader's
refusals of corrupted files."""
import ctypes
import math
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
        tvo.tvo_nn_run_all.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
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

    def run(self, features: np.ndarray, n_out: int = 6):
        """tvo_nn_run (6 outputs) or tvo_nn_run_all (n_out = 7, the step length last)."""
        features = np.ascontiguousarray(features, np.float32)
        out = np.empty((features.shape[0], n_out), np.float32)
        fp = features.ctypes.data
        op = out.ctypes.data
        run = self.tvo.tvo_nn_run if n_out == 6 else self.tvo.tvo_nn_run_all
        h = self.handle
        status = np.empty(features.shape[0], np.int32)
        for i in range(features.shape[0]):
            status[i] = run(h, fp + 4 * FEAT * i, op + 4 * n_out * i)
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
    # the reference still reproduces the stored vectors (format/reference drift); 1.0 model: no step
    ref = nnfmt.reference_run(nnfmt.read(data), x)
    assert np.isnan(ref[:, 6]).all()
    assert_bits_equal(ref[:, :6], y)


@pytest.mark.parametrize("name,mask", [("step", 0x78), ("steplin", 0x40)])
def test_golden_vectors_step(tvo, name, mask):
    """Format 1.1 step-length models (log step with rx ry rz; linear step alone): 7 outputs."""
    data = (DATA / f"{name}.tvonn").read_bytes()
    assert struct.unpack_from("<HH", data, 4) == (1, 1)
    x, y, gen = nnfmt.read_golden(DATA / f"{name}.golden")
    assert y.shape[1] == 7 and gen.startswith("tinyvo_tools.nngolden")
    c = CModel(tvo, data)
    assert c.mask == mask
    out, st = c.run(x, 7)
    assert (st == 0).all()
    assert_bits_equal(out, y)
    out6, st = c.run(x, 6)
    assert (st == 0).all()
    assert_bits_equal(out6, y[:, :6])
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
    assert_bits_equal(out, ref[:, :6])


def test_random_inputs_hidden_copies(tvo):
    """A clipped relu log-step branch exported with hidden-channel copies (quant.copy_offsets: 3 / 2 copies of
    the two hidden layers' channels, biases offset by fractions of a level), 10,000 random inputs."""
    rng = np.random.default_rng(4000)
    calib = quant.synthetic_features(rng, 1000)
    fb = quant.random_float_branch(rng, nnfmt.DOF_LOG_STEP, "relu", sizes=(48, 16))
    fb.act_clip = [float(post.max()) for _, post in fb.forward_all(calib)[1:-1]]
    model = quant.quantize_model([fb], calib, hidden_copies=[3, 2])
    assert [L.n_out for L in model.branches[0].layers] == [144, 32, 1]
    data = nnfmt.write(model)
    c = CModel(tvo, data)
    x = random_inputs(rng, 10000)
    out, st = c.run(x, n_out=nnfmt.OUT_COUNT)
    assert (st == 0).all()
    assert_bits_equal(out, nnfmt.reference_run(model, x))


@pytest.mark.parametrize("act", quant.nnfmt.ACTS[1:])
@pytest.mark.parametrize("code", [nnfmt.DOF_STEP, nnfmt.DOF_LOG_STEP])
def test_random_inputs_step(tvo, act, code):
    """A step-length branch (linear or log, wide outputs so that the log clamp is reached) with rx ry rz,
    10,000 random inputs per activation, through tvo_nn_run_all."""
    rng = np.random.default_rng(2000 + 10 * code + quant.nnfmt.ACT_CODE[act])
    calib = quant.synthetic_features(rng, 1000)
    st_br = quant.random_float_branch(rng, code, act, sizes=(32, 16))
    if code == nnfmt.DOF_LOG_STEP:
        st_br.out_scale, st_br.out_offset = 10.0, -4.0
    fbs = [st_br] + [quant.random_float_branch(rng, d, act, sizes=(32, 16)) for d in (3, 4, 5)]
    model = quant.quantize_model(fbs, calib)
    data = nnfmt.write(model)
    assert model.minor == 1
    c = CModel(tvo, data)
    assert c.mask == 0x78
    x = random_inputs(rng, 10000)
    out, st = c.run(x, 7)
    assert (st == 0).all()
    ref = nnfmt.reference_run(model, x)
    assert_bits_equal(out, ref)
    assert np.isnan(out[:, :3]).all() and np.isfinite(out[:, 3:]).all()


def test_old_reader_files_and_step_refusals(tvo):
    """1.0 files still load (tiny, paper: their golden tests above); the writer keeps 1.0 for models
    without a step branch; inconsistent step models are refused by the C loader (-9 = TVO_ERR_FORMAT)."""
    rng = np.random.default_rng(11)
    calib = quant.synthetic_features(rng, 300)
    plain = quant.quantize_model([quant.random_float_branch(rng, 0, "relu", sizes=(8,))], calib)
    assert struct.unpack_from("<HH", nnfmt.write(plain), 4) == (1, 0)
    assert load_status(tvo, nnfmt.write(plain)) == 0
    for dofs in ([nnfmt.DOF_STEP, 0], [nnfmt.DOF_LOG_STEP, nnfmt.DOF_STEP], [2, nnfmt.DOF_LOG_STEP]):
        with pytest.raises(ValueError):
            nnfmt.check_dofs(dofs)
        m = quant.quantize_model([quant.random_float_branch(rng, d, "relu", sizes=(8,)) for d in dofs], calib)
        assert load_status(tvo, nnfmt.write(m)) == -9, dofs
    m = quant.quantize_model([quant.random_float_branch(rng, nnfmt.DOF_STEP, "relu", sizes=(8,))], calib)
    m.version_minor = 0
    assert load_status(tvo, nnfmt.write(m)) == -9


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
    assert_bits_equal(out, nnfmt.reference_run(model, x)[:, :6])
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


@pytest.mark.parametrize("name", sorted(p.name for p in (ROOT / "models").glob("*.tvonn")))
def test_shipped_models(tvo, name):
    """Every shipped weights file loads in C and matches the NumPy reference bit for bit (all seven outputs
    of tvo_nn_run_all) on 10,000 random inputs (calibration-like, widened, arbitrary)."""
    data = (ROOT / "models" / name).read_bytes()
    model = nnfmt.read(data)
    c = CModel(tvo, data)
    assert c.mask == model.output_mask
    x = random_inputs(np.random.default_rng(3000), 10000)
    out, st = c.run(x, n_out=nnfmt.OUT_COUNT)
    assert (st == 0).all()
    assert_bits_equal(out, nnfmt.reference_run(model, x))


def test_log_step_exp_is_tvo_dm_exp(tvo):
    """nnfmt.det_exp repeats tvo_dm_exp's operations (the interpreter's exp of a log step): same binary64
    bits on 100,000 values over the clamp range [LOG_STEP_MIN, LOG_STEP_MAX] and at its ends / ties."""
    tvo.tvo_dm_exp.argtypes = [ctypes.c_double]
    tvo.tvo_dm_exp.restype = ctypes.c_double
    rng = np.random.default_rng(7)
    x = np.concatenate([rng.uniform(nnfmt.LOG_STEP_MIN, nnfmt.LOG_STEP_MAX, 100000),
                        [nnfmt.LOG_STEP_MIN, nnfmt.LOG_STEP_MAX, 0.0, -0.0, 0.5 * np.log(2.0), -0.5 * np.log(2.0)],
                        rng.uniform(-16, 8, 1000).astype(np.float32)])
    c = np.array([tvo.tvo_dm_exp(float(v)) for v in x])
    ref = nnfmt.det_exp(x)
    bad = c.view(np.uint64) != ref.view(np.uint64)
    assert not bad.any(), (x[bad][:3], c[bad][:3], ref[bad][:3])
    # accuracy against libm's exp (math.exp): numpy's own np.exp is not an oracle here, its AVX512F path
    # differs from libm by up to 2 ulp on machines that have AVX512 (numpy 1.26)
    libm = np.array([math.exp(float(v)) for v in x])
    assert np.max(np.abs(ref - libm) / np.spacing(libm)) <= 1.0
