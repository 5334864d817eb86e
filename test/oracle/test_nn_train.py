# SPDX-License-Identifier: Apache-2.0
"""The trainer's code on tiny data: a few steps of stage 1 and stage 2, checkpoint round trip, export,
load in C via ctypes, bit-exact against the NumPy reference, and the quantised-vs-float gap."""
import numpy as np
import pytest

from tinyvo_tools import export, nnfmt, quant, train

from test_nn_bitexact import CModel, assert_bits_equal

torch = pytest.importorskip("torch")


def test_train_export_run(tvo, tmp_path):
    rng = np.random.default_rng(0)
    f, t, seq = train.synthetic_dataset(rng, 600, sequences=("A", "B", "V"))
    acts = train.parse_activations("tx=relu,ty=leaky_relu,tz=elu,rx=selu,ry=tanh,rz=sigmoid")
    tr, va = train.split_rows(seq, ["V"])
    assert tr.sum() == 400 and va.sum() == 200
    kw = dict(sizes=(16, 8), epochs=2, joint_epochs=1, batch=64, lr=1e-3, seed=3, progress=False)
    branches = train.train(f[tr], t[tr], acts, **kw)
    again = train.train(f[tr], t[tr], acts, **kw)  # seeded: reproducible
    for a, b in zip(branches, again):
        for wa, wb in zip(a.weights, b.weights):
            np.testing.assert_array_equal(wa, wb)
    assert [b.activation for b in branches] == ["relu", "leaky_relu", "elu", "selu", "tanh", "sigmoid"]
    ck = tmp_path / "m.ckpt.npz"
    quant.save_checkpoint(ck, branches, {"val_sequences": ["V"], "seed": 3})
    loaded, meta = quant.load_checkpoint(ck)
    np.testing.assert_allclose(quant.float_run(loaded, f), quant.float_run(branches, f), rtol=1e-6, atol=1e-7)
    out = tmp_path / "m.tvonn"
    rep = export.export(loaded, meta, f, t, seq, out, tmp_path / "m.golden")
    assert rep["eval_split"] == "validation" and rep["calibration_rows"] == 400
    data = out.read_bytes()
    c = CModel(tvo, data)
    assert c.mask == 0x3F
    y, st = c.run(f)
    assert (st == 0).all()
    assert_bits_equal(y, nnfmt.reference_run(nnfmt.read(data), f)[:, :6])
    x, g, gen = nnfmt.read_golden(tmp_path / "m.golden")
    assert gen.startswith("tinyvo_tools.export")
    assert_bits_equal(c.run(x)[0], g)
    # quantisation error well inside the float model's own error even after 2 epochs
    for dof, r in rep["per_dof"].items():
        assert r["rms_diff_over_std"] < 0.1, (dof, r)


def test_parse_activations():
    assert train.parse_activations("tanh") == {d: "tanh" for d in range(len(nnfmt.DOFS))}
    assert train.parse_activations("rz=elu")[5] == "elu"
    with pytest.raises(ValueError):
        train.parse_activations("swish")


def test_input_domain_clamp(tvo, tmp_path):
    """train(input_clip=p): the model clamps each normalised input to its training percentile range
    (+margin); the int8 input stage maps exactly that range, so a heavy-tailed input (a few huge outliers)
    no longer coarsens every row's int8 step, and float and int8 agree on out-of-domain inputs too."""
    rng = np.random.default_rng(1)
    f, t, seq = train.synthetic_dataset(rng, 600, sequences=("A", "B", "V"))
    f[::97, 0] *= 60.0  # rare outliers on rx (twisted-pair-like rotations)
    tr, _ = train.split_rows(seq, ["V"])
    acts = train.parse_activations("sigmoid")
    kw = dict(sizes=(16, 8), epochs=3, joint_epochs=1, batch=64, lr=1e-3, seed=2, progress=False)
    plain = train.train(f[tr], t[tr], acts, **kw)
    dom = train.train(f[tr], t[tr], acts, input_clip=1.0, input_clip_margin=0.25, **kw)
    b = dom[3]
    assert b.clip_lo is not None and (b.clip_lo < b.clip_hi).all()
    z = plain[3].normalise(f[tr])  # unclamped normalised training inputs (same normalisation)
    lo, hi = np.percentile(z, [1, 99], axis=0)
    np.testing.assert_allclose(b.clip_lo, lo - 0.25 * (hi - lo), rtol=1e-5, atol=1e-6)
    assert z[:, 0].max() > b.clip_hi[0]  # the outliers lie outside the domain ...
    far = f[:8].copy()
    far[:, 0] = 1e3
    edge = f[:8].copy()
    edge[:, 0] = (b.clip_hi[0] - b.norm_offset[0]) / b.norm_scale[0] + 1.0
    np.testing.assert_allclose(b.forward(far), b.forward(edge), rtol=0, atol=1e-12)  # ... and are clamped
    ck = tmp_path / "d.ckpt.npz"
    quant.save_checkpoint(ck, dom, {"seed": 2})
    loaded, _ = quant.load_checkpoint(ck)
    np.testing.assert_array_equal(loaded[3].clip_lo, b.clip_lo)
    np.testing.assert_allclose(quant.float_run(loaded, far), quant.float_run(dom, far), rtol=1e-6, atol=1e-7)
    gap, step = {}, {}
    for name, br in (("plain", plain), ("domain", dom)):
        model = quant.quantize_model(br, f[tr])
        q = nnfmt.reference_run(model, f)[:, :6].astype(np.float64)
        fl = quant.float_run(br, f)[:, :6]
        gap[name] = np.sqrt(np.mean((q - fl) ** 2, axis=0)) / t.std(axis=0)
        step[name] = model.branches[3].in_scale / model.branches[3].norm_scale[0]  # int8 step of rx, rad
        if name == "domain":
            s_in, zp = model.branches[3].in_scale, model.branches[3].in_zp
            assert abs(s_in - 2 / 255) < 1e-7  # the domain, equalised to [-1, 1], is the int8 input range
            assert (-128 - zp) * s_in <= -1 + s_in and (127 - zp) * s_in >= 1 - s_in
            data = nnfmt.write(model)
            y, st = CModel(tvo, data).run(np.vstack([f, far]))
            assert (st == 0).all()
            assert_bits_equal(y, nnfmt.reference_run(nnfmt.read(data), np.vstack([f, far]))[:, :6])
            qf = nnfmt.reference_run(model, far)[:, :6].astype(np.float64)
            assert (np.abs(qf - quant.float_run(dom, far)[:, :6]) / t.std(axis=0)).max() < 0.05
    # the outliers set the plain model's int8 step of rx; the domain's step is many times finer
    assert step["domain"] < step["plain"] / 10, step
    assert gap["domain"].max() < 0.02, gap


def test_calibration_rule2(tvo):
    """Exporter calibration rule 2 (quant.py): relu layers requantised over [0, (1 + RELU_HEADROOM) max]
    with the identity table, the input domain (within the features' own range) on the int8 levels -128..127
    exactly, layers re-fitted to the int8 inputs; bit-exact in C, and a smaller quantised-vs-float gap than
    rule 1 on held-out rows for a relu model."""
    rng = np.random.default_rng(4)
    f, t, seq = train.synthetic_dataset(rng, 900, sequences=("A", "B", "V"))
    tr, va = train.split_rows(seq, ["V"])
    kw = dict(sizes=(32, 16), epochs=4, joint_epochs=1, batch=64, lr=1e-3, seed=1, progress=False)
    br = train.train(f[tr], t[tr], train.parse_activations("relu"), dofs=[7, 3], input_clip=0.5, **kw)
    m1 = quant.quantize_model(br, f[tr], calibration=1)
    m2 = quant.quantize_model(br, f[tr])  # rule 2 is the default
    b2 = m2.branches[0]
    fe = quant.equalise_inputs(br[0], f[tr])
    trace = fe.forward_all(f[tr])
    for k, L in enumerate(b2.layers[:-1]):
        assert L.out_zp == -128 and L.act_zp == -128 and L.act_scale == L.out_scale
        np.testing.assert_array_equal(L.lut, np.arange(-128, 128))  # relu on [0, hi]: identity
        hi = trace[k + 1][0].max() * (1 + quant.RELU_HEADROOM)
        assert abs(L.out_scale * 255 - hi) <= 1e-6 * hi
    # the domain's ends are levels -128 and 127: rot_only 0 / 1 (domain [0, 1] after the feature range)
    # and inputs far outside the domain
    x = nnfmt.quantize_input(b2, f)
    col = b2.feature_ids.index(nnfmt.FEATURES.index("rot_only"))
    assert set(np.unique(x[:, col])) == {-128, 127}
    np.testing.assert_array_equal(x[f[:, 10] == 1.0, col], 127)
    far = np.vstack([f[:4] * 0 + 1e6, f[:4] * 0 - 1e6]).astype(np.float32)
    xf = nnfmt.quantize_input(b2, far)
    assert (xf[:4] == 127).all() and (xf[4:] == -128).all()
    # C == reference on the rule 2 model
    data = nnfmt.write(m2)
    y, st = CModel(tvo, data).run(f)
    assert (st == 0).all()
    ref = nnfmt.reference_run(nnfmt.read(data), f)
    assert_bits_equal(y, ref[:, :6])
    # gap on the held-out rows (% of the std of |t|): rule 2 below rule 1
    fl = quant.float_run(br, f[va])[:, 6]
    std = np.linalg.norm(t[va, :3], axis=1).std()
    gap = {r: np.sqrt(np.mean((nnfmt.reference_run(m, f[va])[:, 6] - fl) ** 2)) / std for r, m in ((1, m1), (2, m2))}
    print("gap rule 1 / 2", gap)
    assert gap[2] < gap[1], gap


def test_calibration_rule1_reproduces_golden_models():
    """Rule 1 is kept for files exported before rule 2: nngolden (rule 1) rebuilds tiny.tvonn exactly."""
    from tinyvo_tools import nngolden
    model, _, _ = nngolden.make_model(np.random.default_rng(5), (16, 8))
    ref = (nngolden.pathlib.Path(__file__).resolve().parents[1] / "data" / "nn" / "tiny.tvonn").read_bytes()
    assert nnfmt.write(model) == ref
    with pytest.raises(ValueError):
        quant.quantize_model([quant.random_float_branch(np.random.default_rng(0), 0, "relu", sizes=(4,))],
                             quant.synthetic_features(np.random.default_rng(0), 50), calibration=4)


def test_int8_aware_stage3():
    """train(qat_epochs > 0): each mode of stage 3 runs, is seeded (same weights twice), changes the weights
    of stages 1-2, and the consistency mode pulls the int8 output towards the float one (its own target)."""
    rng = np.random.default_rng(6)
    f, t, seq = train.synthetic_dataset(rng, 500, sequences=("A", "V"))
    tr, va = train.split_rows(seq, ["V"])
    kw = dict(sizes=(16, 8), epochs=2, joint_epochs=0, batch=64, lr=1e-3, seed=5, progress=False, dofs=[7],
              input_clip=0.5)
    acts = train.parse_activations("relu")
    base = train.train(f[tr], t[tr], acts, **kw)
    for mode in train.QAT_MODES:
        a = train.train(f[tr], t[tr], acts, qat_epochs=2, qat_mode=mode, qat_lr=1e-3, qat_weight=1000.0, **kw)
        b = train.train(f[tr], t[tr], acts, qat_epochs=2, qat_mode=mode, qat_lr=1e-3, qat_weight=1000.0, **kw)
        for wa, wb, w0 in zip(a[0].weights, b[0].weights, base[0].weights):
            np.testing.assert_array_equal(wa, wb)
        assert any(not np.array_equal(wa, w0) for wa, w0 in zip(a[0].weights, base[0].weights)), mode
    def gap(br):
        q = nnfmt.reference_run(quant.quantize_model(br, f[tr]), f[tr])[:, 6]
        return np.sqrt(np.mean((q - quant.float_run(br, f[tr])[:, 6]) ** 2))
    # the same fine-tuning epochs without (weight 0) and with the consistency term
    g = {w: gap(train.train(f[tr], t[tr], acts, qat_epochs=8, qat_mode="consist", qat_lr=1e-3, qat_weight=w, **kw))
         for w in (0.0, 1e4)}
    print("int8-vs-float rms gap, consistency weight 0 / 1e4:", g)
    assert g[1e4] < 0.8 * g[0.0], g
    with pytest.raises(ValueError):
        train.train(f[tr], t[tr], acts, qat_epochs=1, qat_mode="swish", **kw)
