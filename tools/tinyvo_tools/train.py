"""Trainer of the per-DoF networks (the paper's deep-learning system), PyTorch (Debian's python3-torch).

    python -m tinyvo_tools.train DATASET.npz -o model.ckpt.npz [--act relu | --act tx=selu,ty=tanh,...]
           [--val-sequences MH_04,V1_02] [--epochs 100] [--joint-epochs 20] [--seed 0]

DATASET.npz (written by the dataset builder): `features` (N x 11 float32, enum tvo_feature),
`targets` (N x 6 float32: tx ty tz rx ry rz ground-truth relative pose prev->cur in the prev camera
frame, metres / rotation vector), `sequence` (N strings: the sequence of each row). `--dofs step` (or
`log_step`) trains one step-length branch instead of tx ty tz: its target is |t| (or log |t|), and the
interpreter applies it to the raw VO unit translation (docs/weights-format.md, DoF codes 6 and 7).

Stage 1 trains each branch alone (Huber loss on normalised targets, RMSprop as in the paper), one after
the other with a progress bar each; stage 2 combines them and fine-tunes all together on the summed
loss. Input normalisation (mean/std) and target normalisation are fitted on the training rows only and
stored in the checkpoint (tinyvo_tools.quant.save_checkpoint); export.py quantises it.
Seeded: same data + seed -> same checkpoint (single-threaded torch).
"""
from __future__ import annotations

import argparse
from typing import Dict, Optional, Sequence

import numpy as np

from . import __version__, nnfmt, quant

DEFAULT_SIZES = (256, 32, 32)


def _torch():
    import torch  # imported lazily: export/reference code must not need torch
    return torch


def _act_module(name: str):
    nn = _torch().nn
    return {"relu": nn.ReLU, "leaky_relu": lambda: nn.LeakyReLU(quant.LEAKY_SLOPE), "elu": nn.ELU,
            "selu": nn.SELU, "tanh": nn.Tanh, "sigmoid": nn.Sigmoid}[name]()


def build_branch(n_in: int, activation: str, sizes=DEFAULT_SIZES):
    nn = _torch().nn
    layers, prev = [], n_in
    for h in sizes:
        layers += [nn.Linear(prev, h), _act_module(activation)]
        prev = h
    layers.append(nn.Linear(prev, 1))
    return nn.Sequential(*layers)


def parse_activations(spec: str) -> Dict[int, str]:
    """'relu' (all branches) or 'tx=selu,ty=tanh,...' (others default to relu); 'step=' / 'log_step='
    name the step-length branch (nnfmt.DOF_STEP / DOF_LOG_STEP)."""
    acts = {d: "relu" for d in range(len(nnfmt.DOFS))}
    for part in spec.split(","):
        part = part.strip()
        if "=" in part:
            dof, act = part.split("=")
            acts[nnfmt.DOFS.index(dof.strip())] = act.strip()
        elif part:
            acts = {d: part for d in range(len(nnfmt.DOFS))}
    for a in acts.values():
        if a not in nnfmt.ACTS[1:]:
            raise ValueError(f"unknown activation {a}; choose from {nnfmt.ACTS[1:]}")
    return acts


def load_dataset(path):
    z = np.load(path, allow_pickle=False)
    feats = np.asarray(z["features"], np.float32)
    targ = np.asarray(z["targets"], np.float32)
    seq = np.asarray(z["sequence"]).astype(str) if "sequence" in z else np.array(["all"] * len(feats))
    if feats.ndim != 2 or feats.shape[1] != nnfmt.FEAT_COUNT or targ.shape != (feats.shape[0], 6):
        raise ValueError(f"dataset shapes {feats.shape} {targ.shape}: want (N, {nnfmt.FEAT_COUNT}) and (N, 6)")
    ok = np.isfinite(feats).all(axis=1) & np.isfinite(targ).all(axis=1)
    return feats[ok], targ[ok], seq[ok]


def targets_with_step(targets: np.ndarray) -> np.ndarray:
    """(N, 6) targets -> (N, 8): the six DoFs, then the step length |t| (m, DOF_STEP) and its natural log
    (DOF_LOG_STEP; steps below STEP_MIN_M count as STEP_MIN_M). Already (N, 8): returned unchanged."""
    targets = np.asarray(targets)
    if targets.shape[1] == len(nnfmt.DOFS):
        return targets
    s = np.linalg.norm(targets[:, :3].astype(np.float64), axis=1)
    return np.hstack([targets, s[:, None], np.log(np.maximum(s, nnfmt.STEP_MIN_M))[:, None]]).astype(targets.dtype)


def split_rows(seq: np.ndarray, val_sequences: Sequence[str]):
    val = np.isin(seq, list(val_sequences)) if val_sequences else np.zeros(len(seq), bool)
    return ~val, val


def synthetic_dataset(rng: np.random.Generator, n: int, sequences=("SYN_A", "SYN_B")):
    """A stand-in dataset until the VO replay's builder exists: plausible features and targets that
    depend smoothly on them (metric step ~ dt * speed, rotation ~ raw rotation), with noise."""
    f = quant.synthetic_features(rng, n)
    speed = 0.5 + 0.3 * np.tanh(f[:, 7] - 2.0) + 0.1 * f[:, 8]
    step = f[:, 9] * speed * (1.0 - f[:, 10])
    t = f[:, 3:6] * step[:, None] + rng.normal(0, 0.002, (n, 3))
    r = f[:, 0:3] * (1.0 + 0.05 * f[:, 6:7]) + rng.normal(0, 0.001, (n, 3))
    seq = np.array([sequences[i * len(sequences) // n] for i in range(n)])
    return f, np.concatenate([t, r], axis=1).astype(np.float32), seq


def train(features: np.ndarray, targets: np.ndarray, activations: Dict[int, str], *,
          sizes=DEFAULT_SIZES, epochs: int = 100, joint_epochs: int = 20, batch: int = 256,
          lr: float = 2e-4, joint_lr: Optional[float] = None, seed: int = 0, feature_ids=None,
          dofs: Sequence[int] = range(6), progress: bool = True, huber_delta: float = 1.0,
          input_clip: float = 0.0, input_clip_margin: float = 0.25):
    """Returns a list of quant.FloatBranch (one per DoF in `dofs`).

    input_clip > 0: the model's input domain. Each normalised input is clamped to its training
    [input_clip, 100 - input_clip] percentile range widened by input_clip_margin of its width on each side
    (room for faster motion than in training), in training and in the model (FloatBranch.clip_lo/hi).
    The int8 input stage maps exactly that range to its 256 levels, so rare outliers (a 30 deg
    twisted-pair rotation among 0.5 deg ones) no longer set the int8 step of every other row."""
    torch = _torch()
    from tqdm import tqdm
    torch.manual_seed(seed)
    torch.set_num_threads(1)
    rng = np.random.default_rng(seed)
    ids = list(range(nnfmt.FEAT_COUNT)) if feature_ids is None else list(feature_ids)
    x = features[:, ids].astype(np.float64)
    mean, std = x.mean(axis=0), x.std(axis=0)
    std = np.where(std > 1e-6, std, 1.0)
    norm_scale = (1.0 / std).astype(np.float32)
    norm_offset = (-mean / std).astype(np.float32)
    xn_np = (x.astype(np.float32) * norm_scale + norm_offset).astype(np.float32)
    clip_lo = clip_hi = None
    if input_clip > 0:
        plo, phi = np.percentile(xn_np.astype(np.float64), [input_clip, 100 - input_clip], axis=0)
        w = np.where(phi - plo > 1e-6, phi - plo, 1.0)  # a constant input (dt of a fixed-rate camera)
        clip_lo, clip_hi = plo - input_clip_margin * w, phi + input_clip_margin * w
        xn_np = np.clip(xn_np, clip_lo, clip_hi).astype(np.float32)
    xn = torch.from_numpy(xn_np)
    if any(d >= 6 for d in dofs):
        targets = targets_with_step(targets)
    t_mean, t_std = targets.mean(axis=0), targets.std(axis=0)
    t_std = np.where(t_std > 1e-9, t_std, 1.0)
    yn = torch.from_numpy(((targets - t_mean) / t_std).astype(np.float32))
    loss_fn = torch.nn.HuberLoss(delta=huber_delta)
    n = len(xn)
    nets = {}
    for d in dofs:  # stage 1: one branch at a time
        net = build_branch(len(ids), activations[d], sizes)
        opt = torch.optim.RMSprop(net.parameters(), lr=lr)
        bar = tqdm(range(epochs), desc=f"branch {nnfmt.DOFS[d]} ({activations[d]})", disable=not progress,
                   leave=True)
        for _ in bar:
            perm = torch.from_numpy(rng.permutation(n))
            total = 0.0
            for s in range(0, n, batch):
                idx = perm[s:s + batch]
                opt.zero_grad()
                loss = loss_fn(net(xn[idx])[:, 0], yn[idx, d])
                loss.backward()
                opt.step()
                total += float(loss) * len(idx)
            bar.set_postfix(loss=f"{total / n:.4f}")
        nets[d] = net
    if joint_epochs > 0:  # stage 2: combined fine-tuning
        params = [p for net in nets.values() for p in net.parameters()]
        opt = torch.optim.RMSprop(params, lr=joint_lr if joint_lr is not None else lr * 0.25)
        bar = tqdm(range(joint_epochs), desc="joint fine-tuning", disable=not progress, leave=True)
        for _ in bar:
            perm = torch.from_numpy(rng.permutation(n))
            total = 0.0
            for s in range(0, n, batch):
                idx = perm[s:s + batch]
                opt.zero_grad()
                loss = sum(loss_fn(net(xn[idx])[:, 0], yn[idx, d]) for d, net in nets.items())
                loss.backward()
                opt.step()
                total += float(loss) * len(idx)
            bar.set_postfix(loss=f"{total / n:.4f}")
    branches = []
    for d, net in nets.items():
        lin = [m for m in net if isinstance(m, torch.nn.Linear)]
        branches.append(quant.FloatBranch(
            dof=d, feature_ids=ids, norm_scale=norm_scale, norm_offset=norm_offset,
            weights=[m.weight.detach().numpy().astype(np.float64) for m in lin],
            biases=[m.bias.detach().numpy().astype(np.float64) for m in lin],
            activation=activations[d], out_scale=float(t_std[d]), out_offset=float(t_mean[d]),
            clip_lo=clip_lo, clip_hi=clip_hi))
    return branches


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dataset", help=".npz with features, targets, sequence (or 'synthetic' for a demo)")
    ap.add_argument("-o", "--out", required=True, help="checkpoint to write (.npz)")
    ap.add_argument("--act", default="relu", help="activation for all branches or tx=selu,ty=tanh,...")
    ap.add_argument("--dofs", default="tx,ty,tz,rx,ry,rz",
                    help="branches to train: DoF names, or 'step' / 'log_step' (one step-length branch, alone "
                         "or with rx,ry,rz; never with tx ty tz)")
    ap.add_argument("--val-sequences", default="", help="comma-separated sequences held out (never fitted)")
    ap.add_argument("--epochs", type=int, default=100)
    ap.add_argument("--joint-epochs", type=int, default=20)
    ap.add_argument("--batch", type=int, default=256)
    ap.add_argument("--lr", type=float, default=2e-4)
    ap.add_argument("--sizes", default="256,32,32", help="hidden layer sizes")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--input-clip", type=float, default=0.0,
                    help="input domain: clamp each input to its training [p, 100-p] percentiles (+margin); 0: off")
    ap.add_argument("--input-clip-margin", type=float, default=0.25)
    args = ap.parse_args(argv)
    if args.dataset == "synthetic":
        f, t, seq = synthetic_dataset(np.random.default_rng(args.seed), 20000)
    else:
        f, t, seq = load_dataset(args.dataset)
    val = [s for s in args.val_sequences.split(",") if s]
    tr, _ = split_rows(seq, val)
    sizes = tuple(int(s) for s in args.sizes.split(","))
    acts = parse_activations(args.act)
    dofs = [nnfmt.DOFS.index(d.strip()) for d in args.dofs.split(",") if d.strip()]
    nnfmt.check_dofs(dofs)
    branches = train(f[tr], t[tr], acts, sizes=sizes, dofs=dofs, epochs=args.epochs, joint_epochs=args.joint_epochs,
                     batch=args.batch, lr=args.lr, seed=args.seed,
                     input_clip=args.input_clip, input_clip_margin=args.input_clip_margin)
    quant.save_checkpoint(args.out, branches, {
        "tinyvo_tools": __version__, "dataset": args.dataset, "val_sequences": val,
        "train_sequences": sorted(set(seq[tr].tolist())), "sizes": list(sizes), "epochs": args.epochs,
        "joint_epochs": args.joint_epochs, "lr": args.lr, "batch": args.batch, "seed": args.seed,
        "input_clip": args.input_clip,
        "input_clip_margin": args.input_clip_margin,
        "feature_layout_id": nnfmt.FEAT_LAYOUT_ID})
    print(f"wrote {args.out}: {len(branches)} branches, trained on {int(tr.sum())} rows")


if __name__ == "__main__":
    main()
