# SPDX-License-Identifier: Apache-2.0
"""Hidden-channel copies in the exporter (quant.copy_offsets, quantize_branch(hidden_copies=...)): k copies
of a clipped relu channel, biases offset by copy_offsets levels, are one channel with k times finer levels
(Hermite's identity), with the float model untouched."""
import json

import numpy as np
import pytest

from tinyvo_tools import export, nnfmt, quant


def _clipped(seed=0, sizes=(24, 8)):
    rng = np.random.default_rng(seed)
    fb = quant.random_float_branch(rng, nnfmt.DOF_LOG_STEP, "relu", sizes=sizes)
    x = quant.synthetic_features(rng, 800)
    top = [float(post.max()) for _, post in fb.forward_all(x)[1:-1]]
    return quant.FloatBranch(**{**vars(fb), "act_clip": top}), x


def test_copy_offsets_hermite():
    for k in (1, 2, 3, 4, 7):
        o = quant.copy_offsets(k)
        assert len(o) == k and abs(o.sum()) < 1e-12 and o.max() - o.min() < 1.0
        u = np.random.default_rng(k).uniform(-3.0, 260.0, 20000)
        u = u[np.abs(k * u - np.floor(k * u) - 0.5) > 1e-6]  # away from exact ties of rint
        levels = np.clip(np.rint(u[:, None] + o[None, :]), 0, 255).sum(axis=1)
        np.testing.assert_array_equal(levels, np.clip(np.rint(k * u), 0, 255 * k))


def test_copies_are_a_finer_layer():
    """Layer 0 in 3 copies: the sum of the copies' levels is within one fine level of rint(3 u) of the
    layer's real requantised value u, on every row (off by one only where the offsets' integer rounding
    moves a tie); the next layer reads the copies with a third of the weight; every block of copies holds
    identical weights."""
    fb, x = _clipped(1)
    plain = quant.quantize_branch(fb, x)
    qb = quant.quantize_branch(fb, x, hidden_copies=[3, 1])
    L0, P0 = qb.layers[0], plain.layers[0]
    n = P0.n_out
    assert L0.n_out == 3 * n and qb.layers[1].n_in == 3 * n and qb.layers[1].n_out == plain.layers[1].n_out
    for j in range(3):
        np.testing.assert_array_equal(L0.w[j * n:(j + 1) * n], L0.w[:n])
    xq = nnfmt.quantize_input(qb, x)
    acc = nnfmt.fc_acc(L0, xq).astype(np.float64)
    base = acc[:, n:2 * n]  # the middle copy's offset is 0 for k = 3
    r = L0.mult.astype(np.float64)[:n] * 2.0 ** -L0.shift.astype(np.float64)[:n]
    u = base * r
    y = np.clip(nnfmt.requantize(acc.astype(np.int32), L0.mult, L0.shift) + L0.out_zp, -128, 127) - L0.out_zp
    s = y.reshape(len(x), 3, n).sum(axis=1)
    ideal = np.clip(np.rint(3 * u), 0, 3 * 255)
    assert np.abs(s - ideal).max() <= 1
    assert np.mean(s == ideal) > 0.99


def test_copies_shrink_the_gap_and_keep_the_format():
    fb, x = _clipped(2)
    f = fb.forward(x)

    def gap(copies):
        m = quant.quantize_model([fb], x, hidden_copies=copies)
        back = nnfmt.read(nnfmt.write(m))  # a 1.1 file like any other: the format is unchanged
        assert back.minor == 1 and back.macs == m.macs
        return np.sqrt(np.mean((nnfmt.run_branch(back.branches[0], x) - f) ** 2)) / f.std(), m.macs

    g1, m1 = gap(None)
    g4, m4 = gap([4, 4])
    assert g4 < 0.75 * g1  # input rounding stays: copies refine the hidden layers only
    assert m4 > 3 * m1
    assert gap([1, 1])[0] == g1


def test_copies_refused():
    fb, x = _clipped(3)
    for bad in ([2], [2, 2, 2], [0, 1], [1, -1]):
        with pytest.raises(ValueError):
            quant.quantize_branch(fb, x, hidden_copies=bad)
    with pytest.raises(ValueError):
        quant.quantize_branch(fb, x, calibration=1, hidden_copies=[2, 1])
    tanh = quant.random_float_branch(np.random.default_rng(4), nnfmt.DOF_LOG_STEP, "tanh", sizes=(8, 4))
    with pytest.raises(ValueError):
        quant.quantize_branch(tanh, x, hidden_copies=[2, 1])


def test_export_cli_hidden_copies(tmp_path, capsys):
    fb, x = _clipped(5)
    ck = tmp_path / "c.ckpt.npz"
    quant.save_checkpoint(ck, [fb], {})
    rng = np.random.default_rng(5)
    ds = tmp_path / "d.npz"
    t = np.zeros((len(x), 6), np.float32)
    t[:, 0] = np.exp(fb.forward(x)) * (1 + 0.1 * rng.normal(size=len(x)))  # |t| = |tx|
    np.savez(ds, features=x, targets=t, sequence=np.array(["A"] * len(x)))
    export.main([str(ck), str(ds), "-o", str(tmp_path / "m.tvonn"), "--hidden-copies", "2,1"])
    rep = json.loads(capsys.readouterr().out)
    assert rep["hidden_copies"] == [2, 1]
    m = nnfmt.read((tmp_path / "m.tvonn").read_bytes())
    assert m.branches[0].layers[0].n_out == 2 * 24
    for bad in ("2,x", "2", "0,1"):
        with pytest.raises(SystemExit):
            export.main([str(ck), str(ds), "-o", str(tmp_path / "b.tvonn"), "--hidden-copies", bad])
