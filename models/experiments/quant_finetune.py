"""Int8-aware fine-tuning of the step-length model (train.py stage 3, modes fq / noise / consist), judged on
the TRAINING sequences only (models/MODEL_CARD.md, "Quantisation"): leave one sequence out.

    cd tools && ../.venv/bin/python ../models/experiments/quant_finetune.py \
        --dataset ../out/model/scale2/dataset.npz --features ../out/model/scale2/features \
        --seq-root ../out/model/seq          # ~15 min on the shared 2-core machine

For each configuration and each training sequence h: a relu log-step branch is trained on the other four
(40 + 10 epochs, lr 1e-3, seed 0, input domain 0.5 %: tables.py's settings, the branch alone) with the
configuration's stage 3, exported with the exporter's default calibration (rule 2) on those four, and
evaluated on h: int8-vs-float gap (% of the std of |t| over the training rows, pooled over the five h),
held-out step RMSE of the float branch, and h's ATE SE(3) with the scale filter a = 0.01 (the shipped use;
tables.integrate, relscale_experiments.filter_steps) with the float and with the int8 step. Validation
sequences are not read.
"""
import argparse
import json
import os
import sys

import numpy as np

from tinyvo_tools import nnfmt, quant, tables, train

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from relscale_experiments import filter_steps, seq_data  # noqa: E402

TRAIN = ["MH_01", "MH_02", "MH_03", "V1_01", "V2_01"]
CONFIGS = [("none", dict()),
           ("fq 10 ep lr 1e-4", dict(qat_epochs=10, qat_lr=1e-4, qat_mode="fq")),
           ("noise 10 ep lr 1e-4", dict(qat_epochs=10, qat_lr=1e-4, qat_mode="noise")),
           ("consist w 100, 40 ep lr 3e-4", dict(qat_epochs=40, qat_lr=3e-4, qat_mode="consist", qat_weight=100.0)),
           ("consist w 300, 40 ep lr 3e-4", dict(qat_epochs=40, qat_lr=3e-4, qat_mode="consist", qat_weight=300.0))]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    for k in ("dataset", "features", "seq-root"):
        ap.add_argument(f"--{k}", required=True)
    ap.add_argument("--out", default=None, help="folder for the trajectories and results.json (default: a temp dir)")
    a = ap.parse_args()
    import tempfile
    out = a.out or tempfile.mkdtemp(prefix="quant_finetune_")
    os.makedirs(out, exist_ok=True)
    f, t, seq = train.load_dataset(a.dataset)
    step = train.targets_with_step(t)[:, nnfmt.OUT_STEP].astype(np.float64)
    tr = np.isin(seq, TRAIN)
    std = step[tr].std()
    data = {n: seq_data(a.features, a.seq_root, n) for n in TRAIN}
    res = {}
    print("| stage 3 | gap pooled % | held-out step RMSE m | ATE float " + " / ".join(TRAIN) + " | mean | ATE int8 mean |")
    for label, kw in CONFIGS:
        sq, w, rm, ate_f, ate_q = [], [], [], [], []
        for h in TRAIN:
            rest, ho = np.isin(seq, [n for n in TRAIN if n != h]), seq == h
            br = train.train(f[rest], t[rest], {nnfmt.DOF_LOG_STEP: "relu"}, epochs=40, joint_epochs=10, lr=1e-3,
                             seed=0, dofs=[nnfmt.DOF_LOG_STEP], progress=False, input_clip=0.5, **kw)
            model = quant.quantize_model(br, f[rest])
            fl = quant.float_run(br, f[ho])[:, nnfmt.OUT_STEP]
            q = nnfmt.reference_run(model, f[ho])[:, nnfmt.OUT_STEP].astype(np.float64)
            sq.append(np.mean((q - fl) ** 2))
            w.append(ho.sum())
            rm.append(np.mean((fl - step[ho]) ** 2))
            sd, fr, T_wc, _ = data[h]
            x = fr["features"].astype(np.float32)
            raw = np.hstack([fr["features"][:, 3:6], fr["features"][:, 0:3]])
            for n, lst, tag in ((quant.float_run(br, x)[:, nnfmt.OUT_STEP], ate_f, "float"),
                                (nnfmt.reference_run(model, x)[:, nnfmt.OUT_STEP].astype(np.float64), ate_q, "int8")):
                tp = os.path.join(out, f"{h}.{len(res)}.{tag}.txt")
                tables.integrate(fr["t_ns"], fr["state"], raw, filter_steps(fr["state"], fr["rel_scale"], n, 0.01),
                                 T_wc[0], tp)
                lst.append(tables.evaluate(tp, sd)["ate_se3_m"])
        r = {"gap_pooled_pct": 100 * float(np.sqrt(np.average(sq, weights=w))) / std,
             "heldout_step_rmse_m": float(np.sqrt(np.average(rm, weights=w))),
             "ate_float": ate_f, "ate_int8": ate_q}
        res[label] = r
        print(f"| {label} | {r['gap_pooled_pct']:.2f} | {r['heldout_step_rmse_m']:.5f} | " +
              " / ".join(f"{x:.3f}" for x in ate_f) + f" | {np.mean(ate_f):.3f} | {np.mean(ate_q):.3f} |", flush=True)
    with open(os.path.join(out, "results.json"), "w", encoding="utf-8") as fh:
        json.dump(res, fh, indent=1)


if __name__ == "__main__":
    main()
