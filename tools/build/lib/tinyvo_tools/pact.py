# SPDX-License-Identifier: Apache-2.0
"""Clip the relu layers of a trained checkpoint (PACT-style bounds, train.pact_finetune) and write a new one.

    tinyvo-pact MODEL.ckpt.npz DATASET.npz -o CLIPPED.ckpt.npz [--dofs log_step]
           [--epochs 0] [--lr 1e-4] [--alpha-lr 5e-2] [--decay 0] [--init 1.0] [--per-channel] [--quiet]

Rows: the checkpoint's training rows (DATASET rows outside its val_sequences). Each hidden relu of the
branches kept (--dofs; default all) becomes min(relu(a), bound), bound = init x the layer's largest
pre-activation on those rows; --epochs > 0 then fine-tunes weights and bounds (PACT, train.pact_finetune).
With --epochs 0 (the shipped step model, models/MODEL_CARD.md "Quantisation") the float function is
unchanged wherever no hidden activation exceeds the training rows' largest, and the exporter (rule 2)
requantises each clipped layer over exactly [0, bound]: the int8 saturation is the float model's own clip.
--per-channel then clips each hidden CHANNEL at its own largest activation on those rows (x init with
--epochs 0; the trained bound stays in force) and rescales it to the layer's bound (quant.clip_relu_channels:
every channel gets the layer's 256 int8 levels).
Then export as usual: tinyvo-export CLIPPED.ckpt.npz DATASET.npz -o MODEL.tvonn
"""
from __future__ import annotations

import sys

from . import __version__, cli, nnfmt, quant, train


def main(argv=None):
    ap = cli.parser("tinyvo-pact", __doc__)
    ap.add_argument("checkpoint", help="float checkpoint .npz (tinyvo-train)")
    ap.add_argument("dataset", help="the dataset .npz it was trained on (its training rows give the bounds)")
    ap.add_argument("-o", "--out", required=True, help="clipped checkpoint to write (.npz)")
    ap.add_argument("--dofs", default="", help="DoF names of the branches to keep (default: all)")
    ap.add_argument("--epochs", type=int, default=0, help="PACT fine-tuning epochs (default 0: clip only)")
    ap.add_argument("--lr", type=float, default=1e-4, help="weights' learning rate when fine-tuning (default 1e-4)")
    ap.add_argument("--alpha-lr", type=float, default=5e-2, help="bounds' learning rate when fine-tuning (default 5e-2)")
    ap.add_argument("--decay", type=float, default=0.0, help="L2 weight on the bounds (default 0)")
    ap.add_argument("--init", type=float, default=1.0, help="initial bound: this x the layer's training maximum (default 1)")
    ap.add_argument("--seed", type=int, default=0, help="fine-tuning seed (default 0)")
    ap.add_argument("--per-channel", action="store_true",
                    help="clip each hidden channel at its own training maximum, equalised (quant.clip_relu_channels)")
    a = ap.parse_args(argv)
    keep = None
    if a.dofs:
        try:
            keep = [nnfmt.DOFS.index(d.strip()) for d in a.dofs.split(",") if d.strip()]
        except ValueError:
            ap.error(f"--dofs {a.dofs!r}: DoF names among {', '.join(nnfmt.DOFS)}")
    if a.epochs < 0:
        ap.error("--epochs must be >= 0")
    return cli.run(ap.prog, lambda: _main(a, keep))


def _main(a, keep) -> int:
    branches, meta = quant.load_checkpoint(a.checkpoint)
    if keep is not None:
        branches = [b for b in branches if b.dof in keep]
        if not branches:
            raise cli.Failure(f"no branch of {a.checkpoint} among {a.dofs}")
    f, t, seq = train.load_dataset(a.dataset)
    tr, _ = train.split_rows(seq, meta.get("val_sequences") or [])
    out = train.pact_finetune(branches, f[tr], t[tr], epochs=a.epochs, lr=a.lr, alpha_lr=a.alpha_lr,
                              decay=a.decay, init=a.init, seed=a.seed, progress=a.epochs > 0 and not a.quiet)
    if a.per_channel:
        out = [quant.clip_relu_channels(b, f[tr], a.init if a.epochs == 0 else 1.0) if b.activation == "relu" else b
               for b in out]
    meta = dict(meta)
    meta["pact"] = {"tinyvo_tools": __version__, "from": str(a.checkpoint), "epochs": a.epochs, "lr": a.lr,
                    "alpha_lr": a.alpha_lr, "decay": a.decay, "init": a.init, "seed": a.seed,
                    "per_channel": a.per_channel, "rows": int(tr.sum())}
    meta.pop("branches", None)
    quant.save_checkpoint(a.out, out, meta)
    for b in out:
        cli.log(a.quiet, f"{nnfmt.DOFS[b.dof]}: relu bounds {b.act_clip}")
    cli.log(a.quiet, f"wrote {a.out} ({int(tr.sum())} rows)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
