# SPDX-License-Identifier: Apache-2.0
"""Clipped relu layers (PACT: FloatBranch.act_clip, train.pact_finetune) and the exporter's handling of them
(rule 2 requantises a clipped layer over exactly [0, bound]), and rule 3's sequential weight rounding."""
import numpy as np
import pytest

from tinyvo_tools import nnfmt, quant, train


def _branch(seed=0, sizes=(24, 8, 8)):
    rng = np.random.default_rng(seed)
    return quant.random_float_branch(rng, nnfmt.DOF_LOG_STEP, "relu", sizes=sizes), \
        quant.synthetic_features(rng, 800)


def _hidden_max(fb, feats):
    return [float(post.max()) for _, post in fb.forward_all(feats)[1:-1]]


def test_float_clip_and_checkpoint(tmp_path):
    fb, x = _branch()
    top = _hidden_max(fb, x)
    clipped = quant.FloatBranch(**{**vars(fb), "act_clip": [0.3 * m for m in top]})
    got = _hidden_max(clipped, x)
    for g, m in zip(got, top):
        assert g == pytest.approx(0.3 * m)  # saturated rows exist: the bound is reached
    assert not np.allclose(clipped.forward(x), fb.forward(x))
    ck = tmp_path / "c.ckpt.npz"
    quant.save_checkpoint(ck, [clipped], {})
    (back,), _ = quant.load_checkpoint(ck)
    assert back.act_clip == pytest.approx(clipped.act_clip)
    np.testing.assert_allclose(back.forward(x), clipped.forward(x), rtol=1e-6, atol=1e-6)
    (plain,), _ = quant.load_checkpoint(_save(tmp_path / "p.ckpt.npz", fb))
    assert plain.act_clip is None


def _save(path, fb):
    quant.save_checkpoint(path, [fb], {})
    return path


def test_clipped_layers_requantised_over_the_bound():
    """A clipped relu layer: zero point -128, the level 127 at the bound, identity table (the unclipped model:
    rule 2's (1 + headroom) x its calibration max); the int8 output follows the clipped float model more
    closely than the unclipped pair, above all on rows beyond the calibration rows."""
    fb, x = _branch(1)
    bounds = [0.4 * m for m in _hidden_max(fb, x)]
    clipped = quant.FloatBranch(**{**vars(fb), "act_clip": bounds})
    qb = quant.quantize_branch(clipped, x)
    ident = np.arange(-128, 128).astype(np.int8)
    for L, bnd in zip(qb.layers[:-1], bounds):
        assert L.out_zp == -128 and L.act_zp == -128
        assert L.out_scale == pytest.approx(bnd / 255.0, rel=1e-6)
        np.testing.assert_array_equal(L.lut, ident)
    plain = quant.quantize_branch(fb, x)
    for L, m in zip(plain.layers[:-1], _hidden_max(fb, x)):
        assert L.out_scale * 255.0 > m  # unclipped: headroom above the calibration max
    # faster motion than calibrated (larger parallax): the unclipped model's int8 saturates where its float
    # relu does not; the clipped model's float saturates at the same bound as its int8
    xs = x.copy()
    xs[:, 7] *= 3.0

    def gap(b, q, rows):
        f = b.forward(rows)
        return np.sqrt(np.mean((nnfmt.run_branch(q, rows) - f) ** 2)) / f.std()

    assert gap(clipped, qb, x) < gap(fb, plain, x)
    assert gap(clipped, qb, xs) < 0.3 * gap(fb, plain, xs)
    with pytest.raises(ValueError):
        quant.quantize_branch(clipped, x, calibration=1)
    with pytest.raises(ValueError):
        quant.quantize_branch(quant.FloatBranch(**{**vars(fb), "act_clip": [1.0, 0.0, 1.0]}), x)


def test_sequential_round_beats_nearest():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(500, 12)) @ rng.normal(size=(12, 12))  # correlated inputs
    w = rng.normal(size=(6, 12))
    b = rng.normal(size=6)
    s = np.abs(w).max(axis=1) / 127.0
    wq, bq = quant._sequential_round(w, b, s, x)
    k = wq / s[:, None]
    np.testing.assert_allclose(k, np.rint(k), atol=1e-9)
    assert np.abs(k).max() <= 127
    ref = x @ w.T + b
    near = np.clip(np.rint(w / s[:, None]), -127, 127) * s[:, None]
    err_seq = np.mean((x @ wq.T + bq - ref) ** 2)
    err_near = np.mean((x @ near.T + b - ref) ** 2)
    assert err_seq < 0.8 * err_near
    model = quant.quantize_model([quant.random_float_branch(rng, nnfmt.DOF_LOG_STEP, "relu", sizes=(16, 8))],
                                 quant.synthetic_features(rng, 300), calibration=3)
    assert np.isfinite(nnfmt.reference_run(model, quant.synthetic_features(rng, 50))[:, nnfmt.OUT_STEP]).all()


def test_pact_finetune():
    pytest.importorskip("torch")
    rng = np.random.default_rng(3)
    f, t, _ = train.synthetic_dataset(rng, 600)
    kw = dict(sizes=(16, 8), epochs=2, joint_epochs=0, batch=64, lr=1e-3, seed=1, progress=False,
              dofs=[nnfmt.DOF_LOG_STEP])
    base = train.train(f, t, {nnfmt.DOF_LOG_STEP: "relu"}, **kw)
    assert base[0].act_clip is None
    runs = {d: train.pact_finetune(base, f, t, epochs=3, lr=1e-4, alpha_lr=5e-2, decay=d, seed=1, progress=False)
            for d in (0.0, 0.1)}
    again = train.pact_finetune(base, f, t, epochs=3, lr=1e-4, alpha_lr=5e-2, decay=0.1, seed=1, progress=False)
    assert again[0].act_clip == runs[0.1][0].act_clip  # seeded
    top = _hidden_max(base[0], f)
    assert all(c > 0 for c in runs[0.1][0].act_clip)
    assert all(a < b for a, b in zip(runs[0.1][0].act_clip, runs[0.0][0].act_clip))  # decay shrinks the bounds
    assert all(c < m for c, m in zip(runs[0.1][0].act_clip, top))
    # frozen weights: only the clip changes the function
    frozen = train.pact_finetune(base, f, t, epochs=2, lr=0.0, alpha_lr=5e-2, decay=0.1, seed=1, progress=False)
    for a, b in zip(frozen[0].weights, base[0].weights):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-7)
    # via train(): same stage, and its model exports with the bounds as ranges
    br = train.train(f, t, {nnfmt.DOF_LOG_STEP: "relu"}, pact_epochs=3, pact_lr=1e-4, pact_decay=0.1, **kw)
    qb = quant.quantize_branch(br[0], f)
    for L, c in zip(qb.layers[:-1], br[0].act_clip):
        assert L.out_scale == pytest.approx(c / 255.0, rel=1e-6)
    with pytest.raises(ValueError):
        train.train(f, t, {nnfmt.DOF_LOG_STEP: "relu"}, pact_epochs=1, qat_epochs=1, **kw)


def _per_channel_forward(fb, feats, m):
    """min(relu(a_c), m[k][c]) per channel with the branch's own weights: the function clip_relu_channels
    must give."""
    x = fb.normalise(feats)
    for k, (w, b) in enumerate(zip(fb.weights, fb.biases)):
        a = x @ np.asarray(w, np.float64).T + np.asarray(b, np.float64)
        if k == len(fb.weights) - 1:
            return a[:, 0] * fb.out_scale + fb.out_offset
        x = np.minimum(np.maximum(a, 0.0), m[k][None, :])


def test_clip_relu_channels():
    fb, x = _branch(4)
    # a dead channel (never active on x), one with a tiny range and a third of layer 0's with a small one
    fb.biases[0][3] = -1e6
    fb.weights[0][5] *= 1e-3
    fb.biases[0][5] *= 1e-3
    fb.weights[0][8:16] *= 0.05
    fb.biases[0][8:16] *= 0.05
    for init in (1.0, 1.25):
        m = [init * post.max(axis=0) for _, post in fb.forward_all(x)[1:-1]]
        eq = quant.clip_relu_channels(fb, x, init)
        assert len(eq.act_clip) == len(fb.weights) - 1
        assert eq.act_clip == pytest.approx([float(v.max()) for v in m])
        np.testing.assert_allclose(eq.forward(x), fb.forward(x), rtol=1e-12, atol=1e-12)  # unchanged on the rows
        xs = x.copy()
        xs[:, 7] *= 4.0  # beyond the rows: each channel saturates at its own bound
        np.testing.assert_allclose(eq.forward(xs), _per_channel_forward(fb, xs, m), rtol=1e-10, atol=1e-10)
        assert not np.allclose(eq.forward(xs), fb.forward(xs))
        assert np.all(eq.weights[0][3] == 0) and eq.biases[0][3] == 0
    # equalised: every live channel reaches the layer's bound on the rows (all its int8 levels are used), so
    # the export follows its float model more closely than the per-layer clip's
    eq = quant.clip_relu_channels(fb, x)
    for (_, post), bound in zip(eq.forward_all(x)[1:-1], eq.act_clip):
        top = post.max(axis=0)
        np.testing.assert_allclose(top[top > 0], bound, rtol=1e-12)
    assert (eq.forward_all(x)[1][1].max(axis=0) == 0).sum() == 1  # the dead channel
    per_layer = quant.FloatBranch(**{**vars(fb), "act_clip": _hidden_max(fb, x)})

    def gap(b):
        f = b.forward(x)
        return np.sqrt(np.mean((nnfmt.run_branch(quant.quantize_branch(b, x), x) - f) ** 2)) / f.std()

    assert gap(eq) < 0.9 * gap(per_layer)
    # bounds of an already clipped branch stay in force
    tight = quant.FloatBranch(**{**vars(fb), "act_clip": [0.5 * v for v in _hidden_max(fb, x)]})
    assert all(c <= t + 1e-12 for c, t in zip(quant.clip_relu_channels(tight, x, 2.0).act_clip, tight.act_clip))
    with pytest.raises(ValueError):
        quant.clip_relu_channels(fb, x, 0.0)
    with pytest.raises(ValueError):
        quant.clip_relu_channels(quant.FloatBranch(**{**vars(fb), "activation": "tanh"}), x)


def test_pact_cli_per_channel(tmp_path, capsys):
    """python -m tinyvo_tools.pact --per-channel: clipped per channel on the checkpoint's training rows (not
    its validation sequences), the same function there, one bound per hidden layer."""
    from tinyvo_tools import pact
    rng = np.random.default_rng(5)
    f, t, seq = train.synthetic_dataset(rng, 400, sequences=("A", "V"))
    ds = tmp_path / "d.npz"
    np.savez(ds, features=f, targets=t, sequence=seq)
    fb, _ = _branch(6)
    ck = tmp_path / "m.ckpt.npz"
    quant.save_checkpoint(ck, [fb], {"val_sequences": ["V"]})
    out = tmp_path / "new" / "c.ckpt.npz"  # output folders are created (the model card's commands rely on it)
    pact.main([str(ck), str(ds), "-o", str(out), "--per-channel"])
    assert "relu bounds" in capsys.readouterr().out
    (got,), meta = quant.load_checkpoint(out)
    (ref,), _ = quant.load_checkpoint(ck)  # the float32 weights as stored
    tr = seq == "A"
    want = quant.clip_relu_channels(ref, f[tr])
    assert meta["pact"]["per_channel"] is True and meta["pact"]["rows"] == int(tr.sum())
    assert got.act_clip == pytest.approx(want.act_clip, rel=1e-6)
    np.testing.assert_allclose(got.forward(f[tr]), ref.forward(f[tr]), rtol=1e-5, atol=1e-5)
    assert not np.allclose(got.act_clip, quant.clip_relu_channels(ref, f).act_clip)  # the V rows not used
    from tinyvo_tools import export
    export.main([str(out), str(ds), "-o", str(tmp_path / "m" / "c.tvonn")])
    assert nnfmt.read((tmp_path / "m" / "c.tvonn").read_bytes()).branches
