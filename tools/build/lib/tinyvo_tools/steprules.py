# SPDX-License-Identifier: Apache-2.0
"""The step-length model's selection rules and scale oracles, rerun whenever the front end's features change.

    python -m tinyvo_tools.steprules domain --dataset D.npz --features DIR --seq-root DIR --out DIR [options]
    python -m tinyvo_tools.steprules copies --dataset D.npz --features DIR --seq-root DIR --out DIR [options]
    python -m tinyvo_tools.steprules oracle --features DIR --seq-root DIR --model STEP.tvonn --out DIR [options]

Inputs: DATASET.npz from tinyvo_tools.dataset, the features folder it wrote (``<NAME>.features.csv`` of
``tvo_replay --features``, with the rel_scale column) and the folder holding the sequences by name.

``domain`` and ``copies`` judge candidates on the TRAINING sequences only (``--train``), leave one sequence
out, averaged over training seeds (``--seeds``): for every seed and every training sequence h a relu
log-step branch is trained on the other sequences with the shipped recipe (tables.py's settings: 40 + 10
epochs, lr 1e-3), clipped at the training maximum of each hidden layer (or channel), exported with the
exporter's rule 2 calibrated on those sequences and judged on h: the int8-vs-float gap (% of the std of |t|
over the training rows, pooled over the held-out sequences), the float branch's held-out step RMSE, and h's
ATE SE(3) with the scale filter a = 0.01 (the shipped use, integrated as tvo_replay does) with the float and
with the int8 step. The validation sequences are never read.

- ``domain``: input domain (the trainer's input clip percentile) in {0.5, 1, 2} % x relu clip per layer or
  per channel. Pass: seed-averaged pooled gap < 1.6 %, mean held-out int8 ATE <= 1.02 x the reference's
  (0.5 %, per layer) and held-out step RMSE <= 1.01 x the reference's; the lowest int8 ATE among passing.
- ``copies``: hidden-channel copies per hidden layer (quant.copy_offsets: k copies give a layer k times
  finer int8 levels for k times its MACs). Pass: pooled gap <= 1.2 % and int8 ATE within 1 % of the float
  ATE; the fewest MACs among passing. ``--domain`` / ``--clip`` give the recipe it runs with.
- ``oracle``: evaluation only, on the validation sequences (``--val``): the trajectories integrated with
  the raw VO rotation and direction and step lengths from oracles no monocular feature carries (ground-truth
  step, the sequence's own mean step, that level as the filter's prior, the ground-truth step with
  log-normal noise), next to the training mean step and the model's per-frame log error.

Each writes OUT/results.json (every figure, the passing candidates and the choice) and trajectories under
OUT/, and prints a markdown table. ``--seeds``, ``--epochs`` and ``--joint-epochs`` exist to run the rules
small (the tests do); the rules' figures are for the defaults.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from . import dataset as dsmod
from . import nnfmt, quant, tables, trajio, train

TRAIN = ["MH_01", "MH_02", "MH_03", "V1_01", "V2_01"]
VAL = ["MH_04", "V1_02", "V2_03"]
SEEDS = [0, 1, 2]
DOMAINS = [0.5, 1.0, 2.0]
CLIPS = ["layer", "channel"]
DOMAIN_REFERENCE = "0.5/layer"
COPIES = [(1, 1, 1), (1, 1, 2), (1, 2, 1), (1, 2, 2), (2, 2, 2), (1, 4, 4)]
FILTER_ALPHA = 0.01
ALPHAS = [0.0, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0]
SIGMAS = [0.05, 0.1, 0.2, 0.3, 0.5]
NOISE_DRAWS = 5


def seq_data(features_dir: str, seq_root: str, name: str):
    """(sequence folder, its features csv as read_features_csv, ground-truth camera poses T_W_C at the csv
    rows, ground-truth step length per row (0 for the first))."""
    sd = os.path.join(seq_root, name)
    fr = dsmod.read_features_csv(os.path.join(features_dir, f"{name}.features.csv"))
    gt_path, yml = dsmod.sequence_paths(sd)
    g = trajio.read_euroc_groundtruth(gt_path)
    T_BS = trajio.read_sensor_yaml(yml).T_BS if yml else trajio.EUROC_CAM0_T_BS
    T_wc = trajio.interpolate_poses(g.t_ns, g.poses, fr["t_ns"]) @ T_BS
    gs = np.zeros(len(fr["t_ns"]))
    gs[1:] = np.linalg.norm((trajio.inv_pose(T_wc[:-1]) @ T_wc[1:])[:, :3, 3], axis=1)
    return sd, fr, T_wc, gs


def ate_with_steps(seqd, steps, path: str) -> float:
    """ATE SE(3) (m) of the raw VO rotation and direction integrated with these step lengths."""
    sd, fr, T_wc, _ = seqd
    raw = np.hstack([fr["features"][:, 3:6], fr["features"][:, 0:3]])
    tables.integrate(fr["t_ns"], fr["state"], raw, steps, T_wc[0], path)
    return tables.evaluate(path, sd)["ate_se3_m"]


def judge_heldout(br, calib, f_ho, step_ho, seqd, prefix: str, hidden_copies=None) -> dict:
    """A step model (list of FloatBranch) judged on a held-out sequence: exported (rule 2) calibrated on the
    rows ``calib``; on the held-out dataset rows f_ho the squared int8-vs-float gap and the float model's
    squared step error against step_ho; the sequence's ATE SE(3) with the scale filter a = 0.01 with the float
    and with the int8 step (trajectories PREFIX.float.txt / PREFIX.int8.txt).
    -> dict(sq, w, se, macs, ate_f, ate_q)"""
    fr = seqd[1]
    x = fr["features"].astype(np.float32)
    model = quant.quantize_model(br, calib, hidden_copies=hidden_copies)
    fl = quant.float_run(br, f_ho)[:, nnfmt.OUT_STEP]
    q = nnfmt.reference_run(model, f_ho)[:, nnfmt.OUT_STEP].astype(np.float64)
    r = dict(sq=float(np.mean((q - fl) ** 2)), w=int(len(f_ho)), se=float(np.mean((fl - step_ho) ** 2)),
             macs=int(model.macs))
    for key, tag, s in (("ate_f", "float", quant.float_run(br, x)[:, nnfmt.OUT_STEP]),
                        ("ate_q", "int8", nnfmt.reference_run(model, x)[:, nnfmt.OUT_STEP].astype(np.float64))):
        steps = tables.filter_steps(fr["state"], fr["rel_scale"], s, FILTER_ALPHA)
        r[key] = ate_with_steps(seqd, steps, f"{prefix}.{tag}.txt")
    return r


def clipped(base, f, t, clip: str, seed: int):
    """Hidden relus clipped at the training maximum of each layer ("layer") or of each channel ("channel")."""
    if clip == "layer":
        return train.pact_finetune(base, f, t, epochs=0, seed=seed, progress=False)
    return [quant.clip_relu_channels(b, f) for b in base]


def seed_summary(per, std: float):
    """per: for each seed, the judge_heldout dicts of the held-out sequences -> pooled gap % (of std),
    held-out step RMSE, mean ATE float, mean ATE int8 (each per seed), seed-mean int8 ATE per sequence."""
    gap = [100 * np.sqrt(np.average([r["sq"] for r in p], weights=[r["w"] for r in p])) / std for p in per]
    rmse = [np.sqrt(np.average([r["se"] for r in p], weights=[r["w"] for r in p])) for p in per]
    af = [np.mean([r["ate_f"] for r in p]) for p in per]
    aq = [np.mean([r["ate_q"] for r in p]) for p in per]
    seqq = np.mean([[r["ate_q"] for r in p] for p in per], axis=0)
    return gap, rmse, af, aq, seqq


def record_choice(res: dict, ok, score, out: str) -> None:
    """res["passing"] = ok, res["chosen"] = the passing key with the lowest score (None if none); printed
    and written with everything else to OUT/results.json."""
    res["passing"] = ok
    res["chosen"] = min(ok, key=score) if ok else None
    print("passing:", ok, "chosen:", res["chosen"])
    with open(os.path.join(out, "results.json"), "w", encoding="utf-8") as fh:
        json.dump(res, fh, indent=1)


def _train_base(a, f, t, seed, domain):
    return train.train(f, t, {nnfmt.DOF_LOG_STEP: "relu"}, epochs=a.epochs, joint_epochs=a.joint_epochs, lr=1e-3,
                       seed=seed, dofs=[nnfmt.DOF_LOG_STEP], progress=False, input_clip=domain)


def _run_seed(job):
    """One seed of ``domain`` or ``copies``: {candidate key: [judge_heldout dict per held-out sequence]}."""
    a, seed = job
    f, t, seq = train.load_dataset(a.dataset)
    step = train.targets_with_step(t)[:, nnfmt.OUT_STEP].astype(np.float64)
    out = {}
    for h in a.train_names:
        rest, ho = np.isin(seq, [n for n in a.train_names if n != h]), seq == h
        seqd = seq_data(a.features, a.seq_root, h)
        if a.rule == "domain":
            for dom in DOMAINS:
                base = _train_base(a, f[rest], t[rest], seed, dom)
                for clip in CLIPS:
                    br = clipped(base, f[rest], t[rest], clip, seed)
                    j = judge_heldout(br, f[rest], f[ho], step[ho], seqd,
                                      os.path.join(a.out, f"{h}.s{seed}.d{dom}.{clip}"))
                    out.setdefault(f"{dom}/{clip}", []).append(dict(seq=h, **j))
        else:
            br = clipped(_train_base(a, f[rest], t[rest], seed, a.domain), f[rest], t[rest], a.clip, seed)
            for c in COPIES:
                key = ",".join(map(str, c))
                j = judge_heldout(br, f[rest], f[ho], step[ho], seqd, os.path.join(a.out, f"{h}.s{seed}.c{key}"),
                                  hidden_copies=c)
                out.setdefault(key, []).append(dict(seq=h, **j))
    return seed, out


def run_rule(a) -> dict:
    f, t, seq = train.load_dataset(a.dataset)
    missing = [n for n in a.train_names if not np.any(seq == n)]
    if missing or len(a.train_names) < 2:
        raise ValueError(f"the dataset has no rows of {missing} (need at least 2 training sequences)")
    a.std = float(train.targets_with_step(t)[np.isin(seq, a.train_names), nnfmt.OUT_STEP].astype(np.float64).std())
    jobs = [(a, s) for s in a.seed_list]
    if a.jobs > 1 and len(jobs) > 1:
        with ProcessPoolExecutor(min(a.jobs, len(jobs))) as ex:
            runs = dict(ex.map(_run_seed, jobs))
    else:
        runs = dict(map(_run_seed, jobs))
    keys = [f"{d}/{c}" for d in DOMAINS for c in CLIPS] if a.rule == "domain" else [",".join(map(str, c)) for c in COPIES]
    res = {"rule": a.rule, "train": a.train_names, "seeds": a.seed_list, "epochs": a.epochs,
           "joint_epochs": a.joint_epochs, "std_step_m": a.std, "candidates": {}}
    if a.rule == "copies":
        res.update(domain=a.domain, clip=a.clip)
    head = "input domain / clip" if a.rule == "domain" else "copies per hidden layer | MACs"
    print(f"| {head} | gap pooled % (per seed) | held-out step RMSE m | mean held-out ATE float / int8 m "
          f"(per seed int8) | ATE int8 per sequence {' / '.join(a.train_names)} (seed mean) |")
    for key in keys:
        per = [runs[s][key] for s in a.seed_list]
        gap, rmse, af, aq, seqq = seed_summary(per, a.std)
        v = dict(gap=float(np.mean(gap)), gap_seeds=[float(g) for g in gap], rmse=float(np.mean(rmse)),
                 ate_f=float(np.mean(af)), ate_q=float(np.mean(aq)), ate_q_seeds=[float(x) for x in aq],
                 ate_q_seq=[float(x) for x in seqq], runs=per)
        if a.rule == "copies":
            v["macs"] = int(per[0][0]["macs"])
        res["candidates"][key] = v
        label = key.replace("/", " % / ") if a.rule == "domain" else f"{key} | {v['macs']}"
        print(f"| {label} | {v['gap']:.2f} ({' / '.join(f'{g:.2f}' for g in gap)}) | {v['rmse']:.5f} | "
              f"{v['ate_f']:.3f} / {v['ate_q']:.3f} ({' / '.join(f'{x:.3f}' for x in aq)}) | "
              + " / ".join(f"{x:.3f}" for x in seqq) + " |")
    c = res["candidates"]
    if a.rule == "domain":
        ref = c[DOMAIN_REFERENCE]
        ok = [k for k, v in c.items() if v["gap"] < 1.6 and v["ate_q"] <= 1.02 * ref["ate_q"]
              and v["rmse"] <= 1.01 * ref["rmse"]]
        record_choice(res, ok, lambda k: c[k]["ate_q"], a.out)
    else:
        ok = [k for k, v in c.items() if v["gap"] <= 1.2 and abs(v["ate_q"] - v["ate_f"]) <= 0.01 * v["ate_f"]]
        record_choice(res, ok, lambda k: c[k]["macs"], a.out)
    return res


def run_oracle(a) -> dict:
    with open(a.model, "rb") as fh:
        model = nnfmt.read(fh.read())
    data = {n: seq_data(a.features, a.seq_root, n) for n in a.train_names + a.val_names}

    def used(n):  # the rows the integration composes with a translation
        return (data[n][1]["state"] == dsmod.STATE_OK) & (np.arange(len(data[n][3])) > 0)

    const = float(np.mean(np.concatenate([data[n][3][used(n)] for n in a.train_names])))
    rows, logerr = {}, {}
    for n in a.val_names:
        seqd = data[n]
        fr, gs = seqd[1], seqd[3]
        u = used(n)
        level = float(np.mean(gs[u]))
        net = nnfmt.reference_run(model, fr["features"].astype(np.float32))[:, nnfmt.OUT_STEP].astype(np.float64)
        filt = tables.filter_steps(fr["state"], fr["rel_scale"], net, FILTER_ALPHA)
        k = u & (gs > 1e-4) & (net > 0) & (filt > 0)
        logerr[n] = {"mean_gt_step_m": level,
                     "network_rms_log_error": float(np.sqrt(np.mean(np.log(net[k] / gs[k]) ** 2))),
                     "network_filter_rms_log_error": float(np.sqrt(np.mean(np.log(filt[k] / gs[k]) ** 2)))}
        p = lambda tag: os.path.join(a.out, f"{n}.{tag}.txt")  # noqa: E731
        r = rows.setdefault
        r("ground-truth step", []).append(ate_with_steps(seqd, gs, p("gt")))
        r("training mean step (the constant prior)", []).append(ate_with_steps(seqd, np.full(len(gs), const), p("const")))
        r("the model + filter a = 0.01", []).append(ate_with_steps(seqd, filt, p("model_filter")))
        r("oracle: the sequence's own mean step, constant", []).append(
            ate_with_steps(seqd, np.full(len(gs), level), p("level")))
        by_a = {al: ate_with_steps(seqd, tables.filter_steps(fr["state"], fr["rel_scale"], np.full(len(gs), level), al),
                                   p(f"levelfilter{al}")) for al in ALPHAS}
        r("oracle: that level as the filter's prior, best a per sequence", []).append(min(by_a.values()))
        r("oracle: that level as the filter's prior, a = 0.01", []).append(by_a[0.01])
        rng = np.random.default_rng(0)
        for sg in SIGMAS:
            v = [ate_with_steps(seqd, gs * np.exp(sg * rng.standard_normal(len(gs))), p(f"noise{sg}"))
                 for _ in range(NOISE_DRAWS)]
            r(f"ground-truth step x exp(N(0, {sg}^2)), mean of {NOISE_DRAWS} draws", []).append(float(np.mean(v)))
    print(f"ATE SE(3), m (training mean step {const:.4f} m)")
    print("| step source | " + " | ".join(a.val_names) + " | mean |")
    print("|---|" + "---|" * (len(a.val_names) + 1))
    for lab, v in rows.items():
        print(f"| {lab} | " + " | ".join(f"{x:.3f}" for x in v) + f" | {np.mean(v):.3f} |")
    for n, e in logerr.items():
        print(f"{n}: mean gt step {e['mean_gt_step_m']:.4f} m; per-frame RMS log error of the step: network "
              f"{e['network_rms_log_error']:.3f}, network + filter {e['network_filter_rms_log_error']:.3f}")
    res = {"rule": "oracle", "train": a.train_names, "val": a.val_names, "const_step_m": const,
           "ate_se3_m": {k: dict(zip(a.val_names, v), mean=float(np.mean(v))) for k, v in rows.items()},
           "log_error": logerr}
    with open(os.path.join(a.out, "results.json"), "w", encoding="utf-8") as fh:
        json.dump(res, fh, indent=1)
    return res


def _names(s: str):
    return [x for x in s.split(",") if x]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tinyvo_tools.steprules", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="rule", required=True)
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--features", required=True, help="folder of <NAME>.features.csv (tvo_replay --features)")
    common.add_argument("--seq-root", required=True, help="folder holding the sequences by name")
    common.add_argument("--out", required=True, help="output folder (results.json, trajectories)")
    common.add_argument("--train", default=",".join(TRAIN), help="training sequences (default %(default)s)")
    rules = argparse.ArgumentParser(add_help=False)
    rules.add_argument("--dataset", required=True, help="tinyvo_tools.dataset output (.npz)")
    rules.add_argument("--seeds", default=",".join(map(str, SEEDS)), help="training seeds (default %(default)s)")
    rules.add_argument("--epochs", type=int, default=40, help="per-branch epochs (default 40: the rule's)")
    rules.add_argument("--joint-epochs", type=int, default=10, help="joint epochs (default 10: the rule's)")
    rules.add_argument("--jobs", type=int, default=2, help="processes, one seed each (default 2)")
    sub.add_parser("domain", parents=[common, rules], help="input domain x relu clip rule")
    pc = sub.add_parser("copies", parents=[common, rules], help="hidden-channel copies rule")
    pc.add_argument("--domain", type=float, default=2.0, help="the recipe's input domain, %% (default 2)")
    pc.add_argument("--clip", choices=CLIPS, default="layer", help="the recipe's relu clip (default layer)")
    po = sub.add_parser("oracle", parents=[common], help="scale oracles on the validation sequences")
    po.add_argument("--model", required=True, help="the step model (.tvonn) whose log error is shown")
    po.add_argument("--val", default=",".join(VAL), help="validation sequences (default %(default)s)")
    a = ap.parse_args(argv)
    a.train_names = _names(a.train)
    os.makedirs(a.out, exist_ok=True)
    try:
        if a.rule == "oracle":
            a.val_names = _names(a.val)
            run_oracle(a)
        else:
            a.seed_list = [int(s) for s in _names(a.seeds)]
            if a.epochs < 1 or a.joint_epochs < 0 or not a.seed_list:
                ap.error("--epochs >= 1, --joint-epochs >= 0 and at least one seed")
            run_rule(a)
    except (OSError, ValueError) as e:
        print(f"steprules: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
