# SPDX-License-Identifier: Apache-2.0
"""Regenerates test/data/nn/: small weights files and golden input/output vectors for the C tests.

    python -m tinyvo_tools.nngolden [--out test/data/nn] [--quiet]      (a developer tool: no console script)

Writes (deterministic, seed 5):
  tiny.tvonn       6 branches 11 -> 16 -> 8 -> 1, one activation per branch (relu, leaky_relu, elu,
                   selu, tanh, sigmoid for tx..rz)
  tiny.golden      256 inputs (calibration-like, outliers, edge values) and the NumPy reference outputs
  paper.tvonn      paper-sized model (6 branches 11 -> 256 -> 32 -> 32 -> 1, same activations): bench
  paper.golden     64 golden vectors for it
  step.tvonn       format 1.1: a log-step branch (code 7, elu, wide output so that the clamp to
                   [LOG_STEP_MIN, LOG_STEP_MAX] is reached) and rx ry rz (relu, tanh, sigmoid), 11 -> 16 -> 8 -> 1
  step.golden      256 golden vectors (version 2: 7 outputs, the last one the step length)
  steplin.tvonn    format 1.1: one linear step-length branch (code 6, selu) alone
  steplin.golden   256 golden vectors (version 2)
All use the exporter's calibration rule 1 (quant.py), so that the files stay reproducible.
Files without a step-length branch are written as 1.0 with version-1 golden files (6 outputs): the tiny
and paper models and their vectors and outputs are those of generator version 2 (the golden files in the
tree still record version 2). The golden files record this script's name and GENERATOR_VERSION; version 4
(step.golden, steplin.golden): the log step's exp is tvo_dm_exp's operation sequence (nnfmt.det_exp), which
gave the same float32 outputs as version 3's.
"""
from __future__ import annotations

import pathlib
import sys

import numpy as np

from . import cli, nnfmt, quant

GENERATOR_VERSION = 4
GENERATOR = f"tinyvo_tools.nngolden {GENERATOR_VERSION}"
BRANCH_ACTS = ["relu", "leaky_relu", "elu", "selu", "tanh", "sigmoid"]


def make_model(rng, sizes, acts=BRANCH_ACTS, calib_n=2000):
    calib = quant.synthetic_features(rng, calib_n)
    fbs = [quant.random_float_branch(rng, d, a, sizes=sizes) for d, a in enumerate(acts)]
    return quant.quantize_model(fbs, calib, calibration=1), fbs, calib


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
    ap = cli.parser("python -m tinyvo_tools.nngolden", __doc__)
    root = pathlib.Path(__file__).resolve().parents[2]
    ap.add_argument("--out", type=pathlib.Path, default=root / "test" / "data" / "nn",
                    help="output folder (default: test/data/nn of the source tree)")
    args = ap.parse_args(argv)
    return cli.run(ap.prog, lambda: _main(args))


def _main(args) -> int:
    args.out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(5)
    for name, sizes, n in (("tiny", (16, 8), 256), ("paper", (256, 32, 32), 64)):
        model, _, _ = make_model(rng, sizes)
        write_pair(args.out, name, model, test_inputs(rng, n), GENERATOR, args.quiet)
    # step-length models (1.1); generated after tiny and paper so that those stay unchanged
    calib = quant.synthetic_features(rng, 2000)
    ls = quant.random_float_branch(rng, nnfmt.DOF_LOG_STEP, "elu", sizes=(16, 8))
    ls.out_scale, ls.out_offset = 12.0, -4.0  # outputs beyond [-16, 8] on the widened inputs
    fbs = [ls] + [quant.random_float_branch(rng, d, a, sizes=(16, 8))
                  for d, a in ((3, "relu"), (4, "tanh"), (5, "sigmoid"))]
    write_pair(args.out, "step", quant.quantize_model(fbs, calib, calibration=1), test_inputs(rng, 256), GENERATOR,
               args.quiet)
    fbs = [quant.random_float_branch(rng, nnfmt.DOF_STEP, "selu", sizes=(16, 8))]
    write_pair(args.out, "steplin", quant.quantize_model(fbs, calib, calibration=1), test_inputs(rng, 256), GENERATOR,
               args.quiet)


def write_pair(out, name, model, x, generator, quiet=False):
    """NAME.tvonn and NAME.golden (6 outputs for a model without a step-length branch, else 7)."""
    data = nnfmt.write(model)
    (out / f"{name}.tvonn").write_bytes(data)
    y = nnfmt.reference_run(nnfmt.read(data), x)
    if not model.output_mask & (1 << nnfmt.OUT_STEP):
        y = y[:, :6]
    nnfmt.write_golden(out / f"{name}.golden", x, y, generator)
    cli.log(quiet, f"{name}: {len(data)} bytes, format 1.{model.minor}, {model.macs} MACs, {len(x)} golden vectors")


if __name__ == "__main__":
    sys.exit(main())
