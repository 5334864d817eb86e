"""Regenerates test/data/nn/: small weights files and golden input/output vectors for the C tests.

    python -m tinyvo_tools.nngolden [--out test/data/nn]

Writes (deterministic, seed 5):
  tiny.tvonn       6 branches 11 -> 16 -> 8 -> 1, one activation per branch (relu, leaky_relu, elu,
                   selu, tanh, sigmoid for tx..rz)
  tiny.golden      256 inputs (calibration-like, outliers, edge values) and the NumPy reference outputs
  paper.tvonn      paper-sized model (6 branches 11 -> 256 -> 32 -> 32 -> 1, same activations): bench
  paper.golden     64 golden vectors for it
The golden files record this script's name and GENERATOR_VERSION.
"""
from __future__ import annotations

import argparse
import pathlib

import numpy as np

from . import nnfmt, quant

GENERATOR_VERSION = 2
GENERATOR = f"tinyvo_tools.nngolden {GENERATOR_VERSION}"
BRANCH_ACTS = ["relu", "leaky_relu", "elu", "selu", "tanh", "sigmoid"]


def make_model(rng, sizes, acts=BRANCH_ACTS, calib_n=2000):
    calib = quant.synthetic_features(rng, calib_n)
    fbs = [quant.random_float_branch(rng, d, a, sizes=sizes) for d, a in enumerate(acts)]
    return quant.quantize_model(fbs, calib), fbs, calib


def test_inputs(rng, n):
    """Calibration-like inputs, scaled-up outliers, zeros and large values (clamping paths)."""
    f = quant.synthetic_features(rng, n)
    k = n // 4
    f[:k] *= rng.uniform(-20, 20, (k, 1)).astype(np.float32)
    f[k] = 0.0
    f[k + 1] = 1e30
    f[k + 2] = -1e30
    return f


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    root = pathlib.Path(__file__).resolve().parents[2]
    ap.add_argument("--out", type=pathlib.Path, default=root / "test" / "data" / "nn")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(5)
    for name, sizes, n in (("tiny", (16, 8), 256), ("paper", (256, 32, 32), 64)):
        model, _, _ = make_model(rng, sizes)
        data = nnfmt.write(model)
        (args.out / f"{name}.tvonn").write_bytes(data)
        x = test_inputs(rng, n)
        y = nnfmt.reference_run(nnfmt.read(data), x)
        nnfmt.write_golden(args.out / f"{name}.golden", x, y, GENERATOR)
        print(f"{name}: {len(data)} bytes, {model.macs} MACs, {n} golden vectors")


if __name__ == "__main__":
    main()
