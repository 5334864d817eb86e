"""Session 13: a narrower input domain and per-channel clipped relu layers for the step-length model, judged
on the TRAINING sequences only, leave one sequence out, averaged over three training seeds
(models/MODEL_CARD.md, "Quantisation", "Input domain and per-channel clips").

    cd tools && ../.venv/bin/python ../models/experiments/quant_domain.py \
        --dataset ../out/model/scale2/dataset.npz --features ../out/model/scale2/features \
        --seq-root ../out/model/seq --out ../out/model/pact/domain        # ~15 min on 2 cores (--jobs 2)

Session 14 ran it unchanged on the dataset rebuilt with the then current front end (40 s on its machine): domain
1 % with per-layer clips passed (card, "Input domain 1 %"); after the keyframe rotation, on the dataset of that
front end, 1 % layer / 1 % channel / 2 % layer pass and 2 % layer is chosen: the shipped file (card, "Shipped
file (session 14)").

Why: in the shipped model (input domain 0.5 %, relu layers clipped at the layer's training maximum) the
largest single term of the int8 gap is the rounding of the parallax input: its domain [0, 1.615] deg is set
by MH_03's few large-parallax frames, an int8 step of 0.0063 deg against a median parallax of 0.05-0.1 deg.
The trainer's input domain (percentile p, margin 0.25) narrows it; clip_relu_channels gives every hidden
channel the layer's 256 levels. Both change the float model (more rows clamped, channels saturating at their
own training maximum), hence the accuracy side of the rule.

For each seed s in {0, 1, 2} and each training sequence h: a relu log-step branch is trained on the other four
(tables.py's settings: 40 + 10 epochs, lr 1e-3) with input domain p, clipped (per layer at the training
maximum, as shipped, or per channel), exported with rule 2 calibrated on the four, judged on h: int8-vs-float
gap (% of the std of |t| over the training rows, pooled over the five h), held-out step RMSE of the float
branch, h's ATE SE(3) with the scale filter a = 0.01 (float and int8 step). Averaged over the seeds.

Rule, written before this run (after single-seed runs showed held-out ATE moving by up to 0.13 m on one
sequence between candidates whose training differs only in the input domain, so one seed cannot tell a
candidate from training noise): a candidate passes if its seed-averaged pooled gap is < 1.6 % (the shipped
model's validation gap was 1.25 x its pooled held-out gap: 2.34 vs 1.87 %), its seed-averaged mean held-out
int8 ATE is at most 1.02 x the reference's (domain 0.5 %, per-layer clip: the shipped configuration) and its
seed-averaged held-out step RMSE at most 1.01 x the reference's. Among passing candidates: the lowest
seed-averaged mean int8 ATE. Validation sequences are not read.
"""
import argparse
import os
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from tinyvo_tools import nnfmt, quant, train

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from quant_pact import judge_heldout, record_choice  # noqa: E402
from relscale_experiments import seq_data  # noqa: E402

TRAIN = ["MH_01", "MH_02", "MH_03", "V1_01", "V2_01"]
SEEDS = [0, 1, 2]
DOMAINS = [0.5, 1.0, 2.0]         # trainer input_clip: percentile of each input's training range
CLIPS = ["layer", "channel"]      # relu clip at the training maximum of each layer / of each channel
REFERENCE = (0.5, "layer")


def clipped(base, f, t, clip, seed):
    """The relu clip of this script (and quant_copies.py): at the training maximum of each layer ("layer",
    pact_finetune with 0 epochs) or of each channel ("channel", clip_relu_channels), on the rows f, t."""
    if clip == "layer":
        return train.pact_finetune(base, f, t, epochs=0, seed=seed, progress=False)
    return [quant.clip_relu_channels(b, f) for b in base]


def seed_summary(per, std):
    """per: for each seed, the judge_heldout dicts of the held-out sequences. -> pooled gap % (of std),
    held-out step RMSE, mean ATE float, mean ATE int8 per seed, and the seed-mean int8 ATE per sequence."""
    gap = [100 * np.sqrt(np.average([r["sq"] for r in p], weights=[r["w"] for r in p])) / std for p in per]
    rmse = [np.sqrt(np.average([r["se"] for r in p], weights=[r["w"] for r in p])) for p in per]
    af = [np.mean([r["ate_f"] for r in p]) for p in per]
    aq = [np.mean([r["ate_q"] for r in p]) for p in per]
    seqq = np.mean([[r["ate_q"] for r in p] for p in per], axis=0)
    return gap, rmse, af, aq, seqq


def run_seed(args):
    """All (domain, clip) configurations for one seed: per held-out sequence the squared gap, rows, squared
    step error, ATE float / int8."""
    a, seed = args
    f, t, seq = train.load_dataset(a.dataset)
    step = train.targets_with_step(t)[:, nnfmt.OUT_STEP].astype(np.float64)
    out = {}
    for h in TRAIN:
        rest, ho = np.isin(seq, [n for n in TRAIN if n != h]), seq == h
        seqd = seq_data(a.features, a.seq_root, h)
        for dom in DOMAINS:
            base = train.train(f[rest], t[rest], {nnfmt.DOF_LOG_STEP: "relu"}, epochs=40, joint_epochs=10,
                               lr=1e-3, seed=seed, dofs=[nnfmt.DOF_LOG_STEP], progress=False, input_clip=dom)
            for clip in CLIPS:
                br = clipped(base, f[rest], t[rest], clip, seed)
                j = judge_heldout(br, f[rest], f[ho], step[ho], seqd, os.path.join(a.out, f"{h}.s{seed}.d{dom}.{clip}"))
                out.setdefault(f"{dom}/{clip}", []).append(dict(seq=h, **j))
                print(f"seed {seed} {h} domain {dom} % {clip} clip: gap {100 * np.sqrt(j['sq']) / a.std:.2f} %,"
                      f" ATE float {j['ate_f']:.3f} int8 {j['ate_q']:.3f}", flush=True)
    return seed, out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    for k in ("dataset", "features", "seq-root", "out"):
        ap.add_argument(f"--{k}", required=True)
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    f, t, seq = train.load_dataset(a.dataset)
    a.std = float(train.targets_with_step(t)[np.isin(seq, TRAIN), nnfmt.OUT_STEP].astype(np.float64).std())
    with ProcessPoolExecutor(a.jobs) as ex:
        runs = dict(ex.map(run_seed, [(a, s) for s in SEEDS]))
    res = {}
    print("| input domain | clip | gap pooled % (per seed) | held-out step RMSE m | mean held-out ATE float / int8 m "
          "(per seed int8) | ATE int8 per sequence " + " / ".join(TRAIN) + " (seed mean) |")
    for dom in DOMAINS:
        for clip in CLIPS:
            key = f"{dom}/{clip}"
            per = [runs[s][key] for s in SEEDS]
            gap, rmse, af, aq, seqq = seed_summary(per, a.std)
            res[key] = dict(gap=float(np.mean(gap)), gap_seeds=[float(g) for g in gap], rmse=float(np.mean(rmse)),
                            ate_f=float(np.mean(af)), ate_q=float(np.mean(aq)), ate_q_seeds=[float(v) for v in aq],
                            ate_q_seq=[float(v) for v in seqq], runs=per)
            v = res[key]
            print(f"| {dom} % | {clip} | {v['gap']:.2f} ({' / '.join(f'{g:.2f}' for g in gap)}) | {v['rmse']:.5f} | "
                  f"{v['ate_f']:.3f} / {v['ate_q']:.3f} ({' / '.join(f'{x:.3f}' for x in aq)}) | "
                  + " / ".join(f"{x:.3f}" for x in seqq) + " |")
    ref = res[f"{REFERENCE[0]}/{REFERENCE[1]}"]
    ok = [k for k, v in res.items() if v["gap"] < 1.6 and v["ate_q"] <= 1.02 * ref["ate_q"]
          and v["rmse"] <= 1.01 * ref["rmse"]]
    record_choice(res, ok, lambda k: res[k]["ate_q"], a.out)


if __name__ == "__main__":
    main()
