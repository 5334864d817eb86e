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
    assert_bits_equal(y, nnfmt.reference_run(nnfmt.read(data), f))
    x, g, gen = nnfmt.read_golden(tmp_path / "m.golden")
    assert gen.startswith("tinyvo_tools.export")
    assert_bits_equal(c.run(x)[0], g)
    # quantisation error well inside the float model's own error even after 2 epochs
    for dof, r in rep["per_dof"].items():
        assert r["rms_diff_over_std"] < 0.1, (dof, r)


def test_parse_activations():
    assert train.parse_activations("tanh") == {d: "tanh" for d in range(6)}
    assert train.parse_activations("rz=elu")[5] == "elu"
    with pytest.raises(ValueError):
        train.parse_activations("swish")
