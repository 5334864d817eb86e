"""What issue 5's accuracy target asks of a scale source (models/MODEL_CARD.md, "What the ATE target needs"):
the validation trajectories integrated with the raw VO rotation and direction and step lengths from oracles
that know something no monocular per-frame feature carries: the sequence's own mean ground-truth step (its
level), that level as the prior of the relative-scale filter, and the ground-truth step with independent
per-frame log-normal noise of RMS sigma. Evaluation only (nothing here is trained or chosen for shipping);
the same integration and ATE SE(3) as tables.py / tvo_replay.

    cd tools && ../.venv/bin/python ../models/experiments/scale_oracle.py --features ../out/model/scale2/features \
        --seq-root ../out/model/seq --out ../out/model/oracle \
        --model ../models/tinyvo_synth_euroc_logstep_relu.tvonn
"""
import argparse
import os
import sys

import numpy as np

from tinyvo_tools import dataset as dsmod, nnfmt, tables

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from relscale_experiments import ALPHAS, TRAIN, VAL, filter_steps, seq_data  # noqa: E402

SIGMAS = [0.05, 0.1, 0.2, 0.3, 0.5]
NOISE_SEEDS = 5


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    for k in ("features", "seq-root", "out", "model"):
        ap.add_argument(f"--{k}", required=True)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    with open(a.model, "rb") as fh:
        model = nnfmt.read(fh.read())
    data = {n: seq_data(a.features, a.seq_root, n) for n in TRAIN + VAL}

    def used(n):  # the frames the integration composes with a translation
        return (data[n][1]["state"] == dsmod.STATE_OK) & (np.arange(len(data[n][3])) > 0)

    const = float(np.mean(np.concatenate([data[n][3][used(n)] for n in TRAIN])))
    rows = {}

    def ate(n, scale, tag):
        sd, fr, T_wc, _ = data[n]
        raw = np.hstack([fr["features"][:, 3:6], fr["features"][:, 0:3]])
        tp = os.path.join(a.out, f"{n}.{tag}.txt")
        tables.integrate(fr["t_ns"], fr["state"], raw, scale, T_wc[0], tp)
        return tables.evaluate(tp, sd)["ate_se3_m"]

    for n in VAL:
        sd, fr, T_wc, gs = data[n]
        u = used(n)
        level = float(np.mean(gs[u]))
        net = nnfmt.reference_run(model, fr["features"].astype(np.float32))[:, nnfmt.OUT_STEP].astype(np.float64)
        filt = filter_steps(fr["state"], fr["rel_scale"], net, 0.01)
        k = u & (gs > 1e-4)
        rel = fr["rel_scale"][k][1:]  # r_k against the ground-truth ratio, consecutive used frames, r_k available
        rel_gt = (gs[k][1:] / gs[k][:-1])[rel > 0]
        print(f"{n}: mean gt step {level:.4f} m (training mean {const:.4f}); per-frame RMS log error of the step: "
              f"network {np.sqrt(np.mean(np.log(net[k] / gs[k]) ** 2)):.3f}, network + filter a = 0.01 "
              f"{np.sqrt(np.mean(np.log(filt[k] / gs[k]) ** 2)):.3f}, relative scale r_k (where available) "
              f"{np.sqrt(np.mean(np.log(rel[rel > 0] / rel_gt) ** 2)):.3f} (consecutive used frames)")
        r = rows.setdefault
        r("ground-truth step", []).append(ate(n, gs, "gt"))
        r("training mean step (the constant prior)", []).append(ate(n, np.full(len(gs), const), "const"))
        r("oracle level: the sequence's own mean step, constant", []).append(ate(n, np.full(len(gs), level), "level"))
        by_a = {al: ate(n, filter_steps(fr["state"], fr["rel_scale"], np.full(len(gs), level), al), f"lvlf{al}")
                for al in ALPHAS}
        r("oracle level as the filter's prior, best a per sequence (a)", []).append(
            min((v, al) for al, v in by_a.items()))
        r("oracle level as the filter's prior, a = 0.01", []).append(by_a[0.01])
        rng = np.random.default_rng(0)
        for sg in SIGMAS:
            v = [ate(n, gs * np.exp(sg * rng.standard_normal(len(gs))), f"noise{sg}") for _ in range(NOISE_SEEDS)]
            r(f"ground-truth step x exp(N(0, {sg}^2)) per frame, mean of {NOISE_SEEDS} draws", []).append(float(np.mean(v)))
    print("| step source | " + " | ".join(VAL) + " | mean |")
    for lab, v in rows.items():
        if isinstance(v[0], tuple):
            print(f"| {lab} | " + " | ".join(f"{x:.3f} ({al:g})" for x, al in v) + f" | {np.mean([x for x, _ in v]):.3f} |")
        else:
            print(f"| {lab} | " + " | ".join(f"{x:.3f}" for x in v) + f" | {np.mean(v):.3f} |")


if __name__ == "__main__":
    main()
