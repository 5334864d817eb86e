"""Step-length branch: choice of form (linear |t| or log |t|), activation and the scale filter's weight a,
on the five TRAINING sequences only (leave one sequence out), for models/MODEL_CARD.md ("Step-length model").

    cd tools && ../.venv/bin/python ../models/experiments/step_loso.py --dataset ../out/model/scale2/dataset.npz \
        --features ../out/model/scale2/features --seq-root ../out/model/seq --out ../out/model/scale2/loso

For each training sequence h: a float step-length branch (train.train, the settings of tables.py: 40 + 0
epochs, lr 1e-3, seed 0, input domain 0.5 %) is trained on the other four, and h's trajectory is integrated
(tables.integrate, the raw VO direction and rotation) with the step from the filter
log s_k = (1-a)(log s_(k-1) + log r_k) + a log n_k (relscale_experiments.filter_steps, the recursion of
tvo_scale_filter_update), n_k the branch's step; a = 1 is the branch alone. The constant step (the four
sequences' mean) with the same filter is the baseline. Score: mean ATE SE(3) over the five held-out
sequences. Validation sequences are not read. Writes OUT/results.json and prints the table.
"""
import argparse
import itertools
import json
import os
import sys

import numpy as np

from tinyvo_tools import dataset as dsmod, nnfmt, tables, train

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from relscale_experiments import filter_steps, seq_data  # noqa: E402

TRAIN = ["MH_01", "MH_02", "MH_03", "V1_01", "V2_01"]
ALPHAS = [0.0, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0]
ACTS = ["sigmoid", "relu", "elu", "tanh"]
FORMS = {"lin": nnfmt.DOF_STEP, "log": nnfmt.DOF_LOG_STEP}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    for k in ("dataset", "features", "seq-root", "out"):
        ap.add_argument(f"--{k}", required=True)
    ap.add_argument("--acts", default=",".join(ACTS))
    a = ap.parse_args()
    os.makedirs(os.path.join(a.out, "traj"), exist_ok=True)
    f, t, seq = train.load_dataset(a.dataset)
    data = {n: seq_data(a.features, a.seq_root, n) for n in TRAIN}
    res = {"ate": {}, "alphas": ALPHAS}

    def run(label, name, scale):
        sd, fr, T_wc, gs = data[name]
        raw = np.hstack([fr["features"][:, 3:6], fr["features"][:, 0:3]])
        tp = os.path.join(a.out, "traj", f"{name}.{label}.txt")
        tables.integrate(fr["t_ns"], fr["state"], raw, scale, T_wc[0], tp)
        res["ate"].setdefault(label, {})[name] = tables.evaluate(tp, sd)["ate_se3_m"]

    for h in TRAIN:
        rest = np.isin(seq, [n for n in TRAIN if n != h])
        sd, fr, T_wc, gs = data[h]
        st, r = fr["state"], fr["rel_scale"]
        const = float(np.linalg.norm(t[rest, :3], axis=1).mean())
        run("gt", h, gs)
        for al in ALPHAS:
            run(f"const_a{al:g}", h, filter_steps(st, r, np.full(len(st), const), al))
        for act, (form, dof) in itertools.product([x for x in a.acts.split(",") if x], FORMS.items()):
            br = train.train(f[rest], t[rest], {dof: act}, epochs=40, joint_epochs=0, lr=1e-3, seed=0,
                             dofs=[dof], progress=False, input_clip=0.5)
            n = train_out = br[0].forward(fr["features"].astype(np.float32))
            n = np.exp(np.clip(train_out, nnfmt.LOG_STEP_MIN, nnfmt.LOG_STEP_MAX)) if form == "log" \
                else np.maximum(train_out, 0.0)
            for al in ALPHAS:
                run(f"{form}_{act}_a{al:g}", h, filter_steps(st, r, n, al))
        print(f"{h}: done", flush=True)

    mean = {lab: float(np.mean([v[n] for n in TRAIN])) for lab, v in res["ate"].items()}
    res["mean"] = mean
    best = min((k for k in mean if k != "gt"), key=mean.get)
    res["best"] = best
    print("| method | " + " | ".join(TRAIN) + " | mean |")
    print("|---" * (len(TRAIN) + 2) + "|")
    for lab in sorted(mean, key=mean.get):
        print(f"| {lab}{' (best)' if lab == best else ''} | " +
              " | ".join(f"{res['ate'][lab][n]:.3f}" for n in TRAIN) + f" | {mean[lab]:.3f} |")
    with open(os.path.join(a.out, "results.json"), "w", encoding="utf-8") as fh:
        json.dump(res, fh, indent=1)


if __name__ == "__main__":
    main()
