"""Scale experiments of models/MODEL_CARD.md ("Experiments on scale"): float step-length networks
(t = s * raw unit direction; s or log s regressed by one MLP branch), with and without speed augmentation
and input subsets, against the constant-step prior and raw VO with ground-truth scale.

    cd tools && ../.venv/bin/python ../models/experiments/scale_experiments.py \
        --dataset ../out/model/dataset.npz --aug-dataset ../out/model/h/dataset_aug2.npz \
        --features ../out/model/features --seq-root ../out/model/seq --out ../out/model/h/exp/traj2

--aug-dataset: tinyvo_tools.dataset with --speedup 2,3 --speedup-seqs MH_01,MH_02,MH_03,V1_01,V2_01.
Networks train on the training sequences only; the figures are on the validation sequences, so choosing
among these variants from them would be tuning on validation (the card says so). Trajectories are
integrated like tvo_replay (tables.integrate) and evaluated like tables.py.
"""
import argparse
import itertools
import json
import os

import numpy as np

from tinyvo_tools import dataset as dsmod, nnfmt, tables, train, trajio

TRAIN = ["MH_01", "MH_02", "MH_03", "V1_01", "V2_01"]
VAL = ["MH_04", "V1_02", "V2_03"]
SUBSETS = {"all": None, "noPar": [0, 1, 2, 3, 4, 5, 6, 8, 9, 10], "rotdir": [0, 1, 2, 3, 4, 5]}


def load(path, aug):
    f, t, s = train.load_dataset(path)
    names = TRAIN + ([f"{n}_x{k}" for n in TRAIN for k in (2, 3)] if aug else [])
    return f, t, np.isin(s, names)


def val_data(features_dir, seq_root):
    out = {}
    for name in VAL:
        sd = os.path.join(seq_root, name)
        fr = dsmod.read_features_csv(os.path.join(features_dir, f"{name}.features.csv"))
        gt_path, yml = dsmod.sequence_paths(sd)
        T_wc = trajio.interpolate_poses(*(lambda g: (g.t_ns, g.poses))(trajio.read_euroc_groundtruth(gt_path)),
                                        fr["t_ns"]) @ trajio.read_sensor_yaml(yml).T_BS
        gs = np.zeros(len(fr["t_ns"]))
        gs[1:] = np.linalg.norm((trajio.inv_pose(T_wc[:-1]) @ T_wc[1:])[:, :3, 3], axis=1)
        out[name] = (sd, fr, T_wc, gs)
    return out


def unit_and_rot(x):
    u = x[:, 3:6].astype(np.float64)
    n = np.linalg.norm(u, axis=1, keepdims=True)
    return np.where(n > 1e-9, u / np.maximum(n, 1e-12), 0.0), x[:, 0:3].astype(np.float64)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    for k in ("dataset", "aug-dataset", "features", "seq-root", "out"):
        ap.add_argument(f"--{k}", required=True)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    vd = val_data(a.features, a.seq_root)
    res = {}

    def evaluate(label, stepfn):
        r = {}
        for name, (sd, fr, T_wc, gs) in vd.items():
            steps, sc = stepfn(fr["features"].astype(np.float32), gs)
            p = os.path.join(a.out, f"{name}.{label}.txt")
            tables.integrate(fr["t_ns"], fr["state"], steps, sc, T_wc[0], p)
            r[name] = tables.evaluate(p, sd)
        ate = [r[n]["ate_se3_m"] for n in VAL]
        rpe = {d: float(np.mean([r[n]["rpe_dof"][d] for n in VAL])) for d in nnfmt.DOFS}
        res[label] = {"ate": ate, "mean": float(np.mean(ate)), "rpe": rpe}
        print(f"{label:32s} ATE " + " ".join(f"{x:.3f}" for x in ate) + f" mean {np.mean(ate):.3f} | RPE t " +
              " ".join(f"{rpe[d]:.4f}" for d in ("tx", "ty", "tz")), flush=True)

    for aug in (False, True):
        f, t, tr = load(a.aug_dataset if aug else a.dataset, aug)
        tag = "aug" if aug else "base"
        cs = float(np.linalg.norm(t[tr, :3], axis=1).mean())
        print(f"--- {tag}: {int(tr.sum())} training rows, constant step {cs:.4f} m")
        evaluate(f"{tag}_const", lambda x, gs: (np.hstack([x[:, 3:6], x[:, 0:3]]), np.full(len(x), cs)))
        if not aug:
            evaluate("gt_scale", lambda x, gs: (np.hstack([x[:, 3:6], x[:, 0:3]]), gs))
        runs = [("all", act, tg) for act, tg in itertools.product(("relu", "elu", "sigmoid"), ("log", "lin"))]
        runs += [("noPar", "sigmoid", "lin"), ("rotdir", "sigmoid", "lin")]
        for sub, act, target in runs:
            s = np.linalg.norm(t[tr, :3], axis=1)
            Y = np.zeros((int(tr.sum()), 6), np.float32)
            Y[:, 0] = np.log(np.maximum(s, 1e-4)) if target == "log" else s
            br = train.train(f[tr], Y, {0: act}, epochs=40, joint_epochs=0, lr=1e-3, seed=0, dofs=[0],
                             progress=False, feature_ids=SUBSETS[sub])[0]

            def fn(x, gs, br=br, target=target):
                v = br.forward(x)
                step = np.exp(v) if target == "log" else np.maximum(v, 0.0)
                u, r = unit_and_rot(x)
                return np.hstack([u * step[:, None], r]), np.ones(len(x))
            evaluate(f"{tag}_step_{sub}_{act}_{target}", fn)
    with open(os.path.join(a.out, "results.json"), "w", encoding="utf-8") as fh:
        json.dump(res, fh, indent=1)


if __name__ == "__main__":
    main()
