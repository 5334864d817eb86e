"""Quantisation of the step-length model: where the int8-vs-float gap comes from, and the choice of the
exporter's calibration rule 2 on the TRAINING sequences only (models/MODEL_CARD.md, "Quantisation").

    cd tools && ../.venv/bin/python ../models/experiments/quant_calib.py \
        --dataset ../out/model/scale2/dataset.npz \
        --checkpoint ../out/model/quant/tables_logstep/models/relu.ckpt.npz

Gap = RMS(int8 step - float step) / std(|t|) in %, the figure of issue 5 (tinyvo_tools.export.compare).
1. Per stage, rule 1 (the exporter before rule 2): each stage alone fake-quantised as the interpreter does
   (inputs, one layer's weights, one hidden layer's requantised output or its table's output), the rest
   float; on the training rows and, as a diagnosis only, the validation rows.
2. Choice: every candidate rule is calibrated on four training sequences and its gap measured on the fifth
   (leave one sequence out: a held-out sequence is faster or slower than the calibration rows, as the
   validation sequences are); score = the gap pooled over the five held-out sequences. Candidates: rule 1,
   and rule 2 with RELU_HEADROOM in {0, 0.25, 0.5, 0.75, 1, 1.5} x REFIT_RIDGE in {0.01, 0.1, 1e6 (no
   refit in effect)}. Validation rows are not read for the choice; the chosen rule's validation gap is
   printed once at the end.
"""
import argparse
import itertools

import numpy as np

from tinyvo_tools import nnfmt, quant, train

VAL = ["MH_04", "V1_02", "V2_03"]


def gap(q, fl, std):
    return 100.0 * float(np.sqrt(np.mean((np.asarray(q, np.float64) - fl) ** 2))) / std


def stage_sim(fb, qb, feats, stage):
    """The equalised float branch fb with one stage fake-quantised with qb's (rule 1) parameters:
    ('in',), ('w', k), ('pre', k), ('post', k); None: all stages."""
    n = len(fb.weights)

    def on(*s):
        return stage is None or stage == s

    x = fb.normalise(feats)
    if on("in"):
        x = (np.clip(np.rint(x / qb.in_scale) + qb.in_zp, -128, 127) - qb.in_zp) * qb.in_scale
    for k in range(n):
        w = np.asarray(fb.weights[k], np.float64)
        if on("w", k):
            s = np.abs(w).max(axis=1) / 127.0
            w = np.clip(np.rint(w / s[:, None]), -127, 127) * s[:, None]
        a = x @ w.T + np.asarray(fb.biases[k], np.float64)
        if k == n - 1:
            break
        L = qb.layers[k]
        if on("pre", k):
            a = (np.clip(np.rint(a / L.out_scale) + L.out_zp, -128, 127) - L.out_zp) * L.out_scale
        x = quant.activate(fb.activation, a)
        if on("post", k):
            x = (np.clip(np.rint(x / L.act_scale) + L.act_zp, -128, 127) - L.act_zp) * L.act_scale
    return np.exp(np.clip(a[:, 0] * fb.out_scale + fb.out_offset, nnfmt.LOG_STEP_MIN, nnfmt.LOG_STEP_MAX))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--checkpoint", required=True, help="tables.py --translation log_step --acts relu checkpoint")
    a = ap.parse_args()
    f, t, seq = train.load_dataset(a.dataset)
    br, meta = quant.load_checkpoint(a.checkpoint)
    b = [x for x in br if x.dof == nnfmt.DOF_LOG_STEP][0]
    names = meta["train_sequences"]
    tr, va = np.isin(seq, names), np.isin(seq, VAL)
    step = train.targets_with_step(t)[:, nnfmt.OUT_STEP].astype(np.float64)
    fl = quant.float_run([b], f)[:, nnfmt.OUT_STEP]

    print("## 1. per stage, rule 1 (gap % of std |t|: training rows / validation rows, diagnosis)")
    fe = quant.equalise_inputs(b, f[tr], calibration=1)
    qb = quant.quantize_branch(b, f[tr], calibration=1)
    stages = [None, ("in",)] + [("w", k) for k in range(len(fe.weights))]
    stages += [s for k in range(len(fe.weights) - 1) for s in (("pre", k), ("post", k))]
    q1 = nnfmt.run_branch(qb, f)
    q1 = nnfmt.log_step_to_step(q1)
    print(f"| int8 (rule 1, the interpreter) | {gap(q1[tr], fl[tr], step[tr].std()):.2f} | "
          f"{gap(q1[va], fl[va], step[va].std()):.2f} |")
    for s in stages:
        y = stage_sim(fe, qb, f, s)
        label = "all stages (simulated)" if s is None else " ".join(map(str, s)) + " alone"
        print(f"| {label} | {gap(y[tr], fl[tr], step[tr].std()):.2f} | {gap(y[va], fl[va], step[va].std()):.2f} |")

    print("\n## 2. leave one training sequence out (calibrate on four, gap on the fifth)")
    print("| rule | " + " | ".join(names) + " | pooled | in-sample |")
    cands = [(1, None, None)] + [(2, h, r) for h, r in itertools.product([0.0, 0.25, 0.5, 0.75, 1.0, 1.5],
                                                                          [0.01, 0.1, 1e6])]
    std_tr = step[tr].std()
    best = None
    h0, r0 = quant.RELU_HEADROOM, quant.REFIT_RIDGE
    for rule, h, r in cands:
        if rule == 2:
            quant.RELU_HEADROOM, quant.REFIT_RIDGE = h, r
        sq, w = [], []
        for n in names:
            cal, ho = tr & (seq != n), seq == n
            q = nnfmt.reference_run(quant.quantize_model([b], f[cal], calibration=rule), f[ho])[:, nnfmt.OUT_STEP]
            sq.append(np.mean((q.astype(np.float64) - fl[ho]) ** 2))
            w.append(ho.sum())
        pooled = 100.0 * np.sqrt(np.average(sq, weights=w)) / std_tr
        q = nnfmt.reference_run(quant.quantize_model([b], f[tr], calibration=rule), f[tr])[:, nnfmt.OUT_STEP]
        label = "1" if rule == 1 else f"2, headroom {h:g}, ridge {r:g}"
        print(f"| {label} | " + " | ".join(f"{100 * np.sqrt(x) / std_tr:.2f}" for x in sq) +
              f" | {pooled:.2f} | {gap(q, fl[tr], std_tr):.2f} |", flush=True)
        if best is None or pooled < best[0]:
            best = (pooled, rule, h, r)
    quant.RELU_HEADROOM, quant.REFIT_RIDGE = h0, r0
    print(f"\nbest (lowest pooled held-out gap): rule {best[1]}, headroom {best[2]}, ridge {best[3]}; "
          f"quant.py's defaults: headroom {h0}, ridge {r0}")
    if best[1] == 2:
        quant.RELU_HEADROOM, quant.REFIT_RIDGE = best[2], best[3]
    q = nnfmt.reference_run(quant.quantize_model([b], f[tr], calibration=best[1]), f)[:, nnfmt.OUT_STEP]
    print(f"chosen rule, calibrated on all training rows: gap training {gap(q[tr], fl[tr], std_tr):.2f} %, "
          f"validation {gap(q[va], fl[va], step[va].std()):.2f} % (evaluated once)")


if __name__ == "__main__":
    main()
