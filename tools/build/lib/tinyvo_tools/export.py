# SPDX-License-Identifier: Apache-2.0
"""Exporter: float checkpoint -> int8 weights file (docs/weights-format.md) + golden vectors + report.

    tinyvo-export model.ckpt.npz DATASET.npz -o model.tvonn [--golden model.golden]
        [--hidden-copies 1,2,2] [--quiet]

Activation ranges are calibrated on the training rows of DATASET (the sequences the checkpoint was
trained on; its validation sequences are never used for calibration). The report compares the
quantised model (NumPy integer reference == the C interpreter) with the float model per DoF on the
validation rows (all rows if there are none): RMS difference divided by that DoF's ground-truth std,
printed as JSON on stdout (not with --quiet).
"""
from __future__ import annotations

import json
import os
import sys

import numpy as np

from . import cli, nnfmt, quant, train

GOLDEN_GENERATOR = "tinyvo_tools.export 1"


def compare(model: nnfmt.Model, branches, features: np.ndarray, targets: np.ndarray) -> dict:
    """Per-DoF quantised-vs-float difference relative to the DoF's std (of the targets). A step-length
    branch (linear or log) is compared on the step it gives, in metres, against the std of |t|."""
    q = nnfmt.reference_run(model, features).astype(np.float64)
    f = quant.float_run(branches, features)
    targets = train.targets_with_step(targets)
    rep = {}
    for b in branches:
        d = min(b.dof, nnfmt.OUT_STEP)  # output column; targets column 6 = |t| (m)
        std = float(targets[:, d].std()) or 1.0
        diff = q[:, d] - f[:, d]
        rep[nnfmt.DOFS[b.dof]] = {"std": std, "rms_diff_over_std": float(np.sqrt(np.mean(diff ** 2)) / std),
                              "max_abs_diff_over_std": float(np.abs(diff).max() / std),
                              "float_rmse": float(np.sqrt(np.mean((f[:, d] - targets[:, d]) ** 2))),
                              "quant_rmse": float(np.sqrt(np.mean((q[:, d] - targets[:, d]) ** 2)))}
    return rep


def export(branches, meta, features, targets, seq, out_path, golden_path=None, n_golden=256, seed=0,
           calibration=quant.CALIBRATION_DEFAULT, hidden_copies=None):
    """Quantise (calibration rule: quant.CALIBRATION_DEFAULT; hidden_copies: quant.quantize_branch's), write
    the weights file (and golden vectors); return the report dict."""
    val = meta.get("val_sequences") or []
    tr, va = train.split_rows(seq, val)
    if not tr.any():
        raise ValueError("no training rows to calibrate on")
    model = quant.quantize_model(branches, features[tr], calibration=calibration, hidden_copies=hidden_copies)
    data = nnfmt.write(model)
    if os.path.dirname(str(out_path)):
        os.makedirs(os.path.dirname(str(out_path)), exist_ok=True)
    with open(out_path, "wb") as fh:
        fh.write(data)
    evalrows = va if va.any() else tr
    rep = {"file": str(out_path), "bytes": len(data), "calibration": calibration, "hidden_copies": hidden_copies,
           "macs": model.macs, "output_mask": model.output_mask,
           "calibration_rows": int(tr.sum()), "eval_rows": int(evalrows.sum()),
           "eval_split": "validation" if va.any() else "training",
           "per_dof": compare(model, branches, features[evalrows], targets[evalrows])}
    rep["worst_rms_diff_over_std"] = max(v["rms_diff_over_std"] for v in rep["per_dof"].values())
    if golden_path is not None:
        rng = np.random.default_rng(seed)
        pick = rng.choice(len(features), size=min(n_golden, len(features)), replace=False)
        x = features[np.sort(pick)]
        y = nnfmt.reference_run(nnfmt.read(data), x)
        if not model.output_mask & (1 << nnfmt.OUT_STEP):
            y = y[:, :6]  # golden version 1 (6 outputs) for models without a step-length branch
        nnfmt.write_golden(golden_path, x, y, GOLDEN_GENERATOR)
    return rep


def main(argv=None):
    ap = cli.parser("tinyvo-export", __doc__)
    ap.add_argument("checkpoint", help="float checkpoint .npz written by tinyvo-train (or tinyvo-pact)")
    ap.add_argument("dataset", help="the training dataset .npz ('synthetic' for tinyvo-train's demo data)")
    ap.add_argument("-o", "--out", required=True, help="int8 weights file to write (.tvonn)")
    ap.add_argument("--golden", default=None, help="also write golden vectors here")
    ap.add_argument("--seed", type=int, default=0, help="seed of the golden-vector inputs (default 0)")
    ap.add_argument("--calibration", type=int, default=quant.CALIBRATION_DEFAULT, choices=[1, 2, 3],
                    help="quantisation calibration rule (quant.py; 1: files exported before rule 2; 3: tried)")
    ap.add_argument("--hidden-copies", default=None, metavar="K1,K2,...",
                    help="copies of each hidden layer's channels (relu branches, rule 2 or 3; quant.copy_offsets): "
                         "k times finer int8 levels for that layer at k times its MACs and the next layer's")
    args = ap.parse_args(argv)
    copies = None
    if args.hidden_copies:
        try:
            copies = [int(v) for v in args.hidden_copies.split(",")]
        except ValueError:
            ap.error(f"--hidden-copies {args.hidden_copies!r}: comma-separated integers")
    return cli.run(ap.prog, lambda: _main(args, ap, copies))


def _main(args, ap, copies) -> int:
    branches, meta = quant.load_checkpoint(args.checkpoint)
    if args.dataset == "synthetic":
        f, t, seq = train.synthetic_dataset(np.random.default_rng(meta.get("seed", 0)), 20000)
    else:
        f, t, seq = train.load_dataset(args.dataset)
    try:
        rep = export(branches, meta, f, t, seq, args.out, args.golden, seed=args.seed, calibration=args.calibration,
                     hidden_copies=copies)
    except ValueError as e:
        ap.error(str(e))
    cli.log(args.quiet, json.dumps(rep, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
