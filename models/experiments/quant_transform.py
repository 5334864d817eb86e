"""Session 13, exploratory (one training seed; nothing shipped from it): the step-length model with its parallax
input compressed before normalisation (sqrt p, or ln(p + 0.01 deg)), judged like quant_pact.py (leave one
TRAINING sequence out, rule-2 export calibrated on the other four, filter a = 0.01). A transformed input
is not in weights format 1.1 (the interpreter's input stage is affine + clamp), so the int8 path here is
the NumPy reference run on pre-transformed features; shipping it would need a per-input transform in the
format and the C input stage (docs/weights-format.md). models/MODEL_CARD.md, "Input domain and per-channel
clips".

    cd tools && ../.venv/bin/python ../models/experiments/quant_transform.py lin|sqrt|log \
        --dataset ../out/model/scale2/dataset.npz --features ../out/model/scale2/features \
        --seq-root ../out/model/seq --out ../out/model/pact/transform [--input-clip 0.5]
"""
import argparse
import os
import sys

import numpy as np

from tinyvo_tools import nnfmt, quant, train

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from quant_pact import judge_heldout  # noqa: E402
from relscale_experiments import seq_data  # noqa: E402

TRAIN = ["MH_01", "MH_02", "MH_03", "V1_01", "V2_01"]
C_DEG = 0.01
PARALLAX = 7  # enum tvo_feature: TVO_FEAT_PARALLAX_DEG
TRANSFORMS = {"lin": (lambda p: p, (0.0, np.inf)),
              "sqrt": (lambda p: np.sqrt(np.maximum(p, 0.0)), (0.0, np.inf)),
              "log": (lambda p: np.log(np.maximum(p, 0.0) + C_DEG), (np.log(C_DEG), np.inf))}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("transform", choices=sorted(TRANSFORMS))
    for k in ("dataset", "features", "seq-root", "out"):
        ap.add_argument(f"--{k}", required=True)
    ap.add_argument("--input-clip", type=float, default=0.5)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    fx, rng7 = TRANSFORMS[a.transform]
    nnfmt.FEAT_RANGE[PARALLAX] = rng7  # the parallax input's range, as the exporter's rule 2 uses it

    def tf(x):
        x = np.array(x, np.float32, copy=True)
        x[:, PARALLAX] = fx(x[:, PARALLAX].astype(np.float64)).astype(np.float32)
        return x

    f, t, seq = train.load_dataset(a.dataset)
    f = tf(f)
    step = train.targets_with_step(t)[:, nnfmt.OUT_STEP].astype(np.float64)
    std = step[np.isin(seq, TRAIN)].std()
    acc = {lab: dict(sq=[], w=[], se=[], ate_f=[], ate_q=[]) for lab in ("layer", "channel")}
    for h in TRAIN:
        rest, ho = np.isin(seq, [n for n in TRAIN if n != h]), seq == h
        base = train.train(f[rest], t[rest], {nnfmt.DOF_LOG_STEP: "relu"}, epochs=40, joint_epochs=10, lr=1e-3,
                           seed=0, dofs=[nnfmt.DOF_LOG_STEP], progress=False, input_clip=a.input_clip)
        seqd = seq_data(a.features, a.seq_root, h)
        x = tf(seqd[1]["features"])
        for lab, r in acc.items():
            br = (train.pact_finetune(base, f[rest], t[rest], seed=0, progress=False, epochs=0) if lab == "layer"
                  else [quant.clip_relu_channels(b, f[rest]) for b in base])
            j = judge_heldout(br, f[rest], f[ho], step[ho], seqd, os.path.join(a.out, f"{a.transform}.{h}.{lab}"), x=x)
            for k in r:
                r[k].append(j[k])
    for lab, r in acc.items():
        print(f"| {a.transform}, domain {a.input_clip:g} %, {lab} clip | "
              f"{100 * np.sqrt(np.average(r['sq'], weights=r['w'])) / std:.2f} | "
              f"{np.sqrt(np.average(r['se'], weights=r['w'])):.5f} | " + " / ".join(f"{v:.3f}" for v in r["ate_f"])
              + f" | {np.mean(r['ate_f']):.3f} / {np.mean(r['ate_q']):.3f} |")


if __name__ == "__main__":
    main()
