# SPDX-License-Identifier: Apache-2.0
"""Trainer of the per-DoF networks (the paper's deep-learning system), PyTorch (Debian's python3-torch).

    tinyvo-train DATASET.npz -o model.ckpt.npz [--act relu | --act tx=selu,ty=tanh,...]
           [--val-sequences MH_04,V1_02] [--epochs 100] [--joint-epochs 20] [--seed 0] [--quiet]

DATASET.npz (written by the dataset builder): `features` (N x 11 float32, enum tvo_feature),
`targets` (N x 6 float32: tx ty tz rx ry rz ground-truth relative pose prev->cur in the prev camera
frame, metres / rotation vector), `sequence` (N strings: the sequence of each row). `--dofs step` (or
`log_step`) trains one step-length branch instead of tx ty tz: its target is |t| (or log |t|), and the
interpreter applies it to the raw VO unit translation (docs/weights-format.md, DoF codes 6 and 7).

Stage 1 trains each branch alone (Huber loss on normalised targets, RMSprop as in the paper), one after
the other with a progress bar each; stage 2 combines them and fine-tunes all together on the summed
loss. Optional stage 3 (`--qat-epochs N`, off by default: none of its modes is used by a shipped model,
see models/MODEL_CARD.md "Quantisation") fine-tunes them against int8 rounding as the exporter's rule 2
makes it (`--qat-mode`): `fq` trains the fake-quantised forward pass (inputs on the int8 input levels,
weights per output channel, hidden layers requantised with the exporter's ranges, recalibrated on the
training rows every epoch; straight-through gradients), `noise` the float pass with uniform noise of one
int8 step on inputs and hidden pre-activations, `consist` the float pass plus `--qat-weight` x the mean
squared difference between the fake-quantised and the float output. `--pact-epochs N` (off by default;
instead of stage 3): PACT, each hidden relu clipped at a trained bound (pact_finetune; `tinyvo-pact`
applies it to a checkpoint, with 0 epochs the bound is the training rows' maximum, as
in the shipped step model). Input normalisation (mean/std) and target normalisation are fitted on the training rows only and
stored in the checkpoint (tinyvo_tools.quant.save_checkpoint); tinyvo-export quantises it.
Seeded: same data + seed -> same checkpoint (single-threaded torch).
"""
from __future__ import annotations

import sys
from typing import Dict, Optional, Sequence

import numpy as np

from . import __version__, cli, nnfmt, quant

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


QAT_MODES = ("fq", "noise", "consist")


def _fake_quant(x, scale: float, zp: int, noise_gen=None):
    """int8 fake quantisation (levels -128..127 of (scale, zp)): clamped to the representable range and
    rounded to a level in the forward pass, the rounding's gradient passed straight through. With noise_gen
    (qat mode noise): x plus uniform noise of one level's width instead."""
    torch = _torch()
    if noise_gen is not None:
        return x + (torch.rand(x.shape, generator=noise_gen) - 0.5) * scale
    xc = torch.clamp(x, (-128 - zp) * scale, (127 - zp) * scale)
    return xc + ((torch.round(xc / scale + zp) - zp) * scale - xc).detach()


def _fake_quant_weight(w, col_scale=None):
    """Symmetric per-output-channel int8 weights as quant.quantize_branch makes them (max |w| / 127); for
    the first layer of an equalised branch the quantised matrix is W / a (col_scale = a), mapped back."""
    torch = _torch()
    we = w / col_scale if col_scale is not None else w
    s = (we.detach().abs().amax(dim=1, keepdim=True) / 127.0).clamp_min(1e-12)
    wq = we + (torch.clamp(torch.round(we / s), -127, 127) * s - we).detach()
    return wq * col_scale if col_scale is not None else wq


def _qat_calibrate(net, x, activation: str):
    """Per hidden layer ((pre scale, zp), (post scale, zp)) from the float net on the rows x, with the
    exporter's rule 2 (quant.quantize_branch): min/max with 0 included; relu: [0, (1 + RELU_HEADROOM) max]."""
    torch = _torch()
    mods = list(net)
    out = []
    with torch.no_grad():
        h = x
        for k in range(0, len(mods) - 1, 2):
            pre = mods[k](h)
            h = mods[k + 1](pre)
            if activation == "relu":
                rng = (0.0, float(pre.max()) * (1.0 + quant.RELU_HEADROOM))
            else:
                rng = (float(pre.min()), float(pre.max()))
            out.append((quant.asym_params(*rng), quant.asym_params(float(h.min()), float(h.max()))))
    return out


def _qat_forward(net, x, col_scale, calib, activation: str, noise_gen=None):
    """The float net with the int8 interpreter's roundings on inputs x (already on the int8 input levels),
    or with noise of their size (noise_gen: mode noise, float weights)."""
    mods = list(net)
    h = x
    for k in range(0, len(mods), 2):
        lin = mods[k]
        w = lin.weight if noise_gen is not None else _fake_quant_weight(lin.weight, col_scale if k == 0 else None)
        h = h @ w.t() + lin.bias
        if k + 1 < len(mods):
            (s_pre, zp_pre), (s_post, zp_post) = calib[k // 2]
            h = mods[k + 1](_fake_quant(h, s_pre, zp_pre, noise_gen))
            if activation != "relu":  # relu's table is the identity (rule 2: same range before and after)
                h = _fake_quant(h, s_post, zp_post, noise_gen)
    return h


def _pact_module(alpha: float):
    """A relu clipped at a trained bound (PACT, Choi et al. 2018): y = relu(x) - relu(x - alpha) =
    clamp(x, 0, alpha) for alpha > 0; the gradient reaches alpha where x > alpha."""
    torch = _torch()

    class Pact(torch.nn.Module):
        def __init__(self, a):
            super().__init__()
            self.alpha = torch.nn.Parameter(torch.tensor(float(a)))

        def forward(self, x):
            return torch.relu(x) - torch.relu(x - self.alpha)

    return Pact(alpha)


def _net_from_branch(fb: "quant.FloatBranch"):
    torch = _torch()
    sizes = tuple(w.shape[0] for w in fb.weights[:-1])
    net = build_branch(len(fb.feature_ids), fb.activation, sizes)
    lin = [m for m in net if isinstance(m, torch.nn.Linear)]
    with torch.no_grad():
        for m, w, b in zip(lin, fb.weights, fb.biases):
            m.weight.copy_(torch.from_numpy(np.asarray(w, np.float32)))
            m.bias.copy_(torch.from_numpy(np.asarray(b, np.float32)))
    return net


def _fit(opt, batch_loss, n: int, epochs: int, rng, batch: int, desc: str, progress: bool, *,
         before_epoch=None, after_step=None, postfix=None):
    """The trainer's epoch loop, shared by every stage: per epoch a permutation of the n rows from rng, then
    mini-batches of `batch` rows, each one optimiser step on batch_loss(idx) (a scalar tensor);
    before_epoch() runs at the start of each epoch, after_step() after each step; the progress bar shows
    the epoch's mean loss and postfix()'s items."""
    torch = _torch()
    from tqdm import tqdm
    bar = tqdm(range(epochs), desc=desc, disable=not progress, leave=True)
    for _ in bar:
        if before_epoch is not None:
            before_epoch()
        perm = torch.from_numpy(rng.permutation(n))
        total = 0.0
        for s in range(0, n, batch):
            idx = perm[s:s + batch]
            opt.zero_grad()
            loss = batch_loss(idx)
            loss.backward()
            opt.step()
            if after_step is not None:
                after_step()
            total += float(loss) * len(idx)
        bar.set_postfix(loss=f"{total / n:.4f}", **(postfix() if postfix is not None else {}))


def pact_finetune(branches, features: np.ndarray, targets: np.ndarray, *, epochs: int = 10, lr: float = 1e-4,
                  decay: float = 0.0, init: float = 1.0, alpha_lr: Optional[float] = None, batch: int = 256, seed: int = 0,
                  huber_delta: float = 1.0, progress: bool = True):
    """PACT fine-tuning of the relu branches among `branches` (quant.FloatBranch; others returned as they
    are): every hidden relu becomes min(relu(a), alpha_k) with alpha_k a trained parameter initialised to
    init x the layer's largest pre-activation on `features` (the training rows: with init >= 1 the function
    on them is unchanged at the start); then all weights and bounds are fine-tuned together for `epochs`
    (RMSprop at lr, the bounds at alpha_lr (default 100 x lr: an RMSprop step moves a parameter by about its
    learning rate, and a bound is O(1..10) where a weight is O(0.1)), the trainer's Huber loss on the branch's
    normalised target, plus decay x sum alpha_k^2, PACT's L2 term that trades clipping against resolution). Returns new FloatBranches with act_clip set:
    the float model then clips exactly where the int8 interpreter saturates (quant.quantize_branch).
    Seeded and single-threaded like train()."""
    torch = _torch()
    torch.manual_seed(seed)
    torch.set_num_threads(1)
    rng = np.random.default_rng(seed)
    targets = targets_with_step(targets)
    out = []
    for fb in branches:
        if fb.activation != "relu":
            out.append(fb)
            continue
        net = _net_from_branch(fb)
        xn = torch.from_numpy(fb.normalise(features).astype(np.float32))
        yn = torch.from_numpy(((targets[:, fb.dof] - fb.out_offset) / fb.out_scale).astype(np.float32))
        mods = list(net)
        with torch.no_grad():
            h = xn
            for k in range(0, len(mods) - 1, 2):
                pre = mods[k](h)
                prev = fb.act_clip[k // 2] if fb.act_clip is not None else float("inf")
                net[k + 1] = _pact_module(min(float(pre.max()) * init, prev))
                h = net[k + 1](pre)
        alphas = [m.alpha for m in net if not isinstance(m, torch.nn.Linear)]
        others = [p for m in net if isinstance(m, torch.nn.Linear) for p in m.parameters()]
        opt = torch.optim.RMSprop([{"params": others},
                                   {"params": alphas, "lr": alpha_lr if alpha_lr is not None else 100.0 * lr}], lr=lr)
        loss_fn = torch.nn.HuberLoss(delta=huber_delta)
        def keep_positive(alphas=alphas):
            with torch.no_grad():  # a bound stays > 0 (a zero bound would be a dead layer)
                for a in alphas:
                    a.clamp_(min=1e-3)

        _fit(opt, lambda idx, net=net, xn=xn, yn=yn, alphas=alphas:
             loss_fn(net(xn[idx])[:, 0], yn[idx]) + decay * sum(a ** 2 for a in alphas),
             len(xn), epochs, rng, batch, f"PACT fine-tuning {nnfmt.DOFS[fb.dof]}", progress,
             after_step=keep_positive,
             postfix=lambda alphas=alphas: {"alpha": "/".join(f"{float(a):.2f}" for a in alphas)})
        lin = [m for m in net if isinstance(m, torch.nn.Linear)]
        out.append(quant.FloatBranch(
            dof=fb.dof, feature_ids=list(fb.feature_ids), norm_scale=fb.norm_scale, norm_offset=fb.norm_offset,
            weights=[m.weight.detach().numpy().astype(np.float64) for m in lin],
            biases=[m.bias.detach().numpy().astype(np.float64) for m in lin],
            activation=fb.activation, out_scale=fb.out_scale, out_offset=fb.out_offset,
            clip_lo=fb.clip_lo, clip_hi=fb.clip_hi, act_clip=[float(a.detach()) for a in alphas]))
    return out


def train(features: np.ndarray, targets: np.ndarray, activations: Dict[int, str], *,
          sizes=DEFAULT_SIZES, epochs: int = 100, joint_epochs: int = 20, batch: int = 256,
          lr: float = 2e-4, joint_lr: Optional[float] = None, seed: int = 0, feature_ids=None,
          dofs: Sequence[int] = range(6), progress: bool = True, huber_delta: float = 1.0,
          input_clip: float = 0.0, input_clip_margin: float = 0.25, qat_epochs: int = 0,
          qat_lr: Optional[float] = None, qat_mode: str = "fq", qat_weight: float = 100.0,
          pact_epochs: int = 0, pact_lr: Optional[float] = None, pact_decay: float = 0.0, pact_init: float = 1.0):
    """Returns a list of quant.FloatBranch (one per DoF in `dofs`).

    qat_epochs > 0: stage 3 (module docstring), all branches together, RMSprop at qat_lr (default lr / 10),
    qat_mode in QAT_MODES, qat_weight the weight of the consistency term (mode consist).

    pact_epochs > 0 (instead of stage 3): pact_finetune after stage 2 on the same rows (lr pact_lr, default
    lr / 10; pact_decay, pact_init: its decay and init).

    input_clip > 0: the model's input domain. Each normalised input is clamped to its training
    [input_clip, 100 - input_clip] percentile range widened by input_clip_margin of its width on each side
    (room for faster motion than in training), in training and in the model (FloatBranch.clip_lo/hi).
    The int8 input stage maps exactly that range to its 256 levels, so rare outliers (a 30 deg
    twisted-pair rotation among 0.5 deg ones) no longer set the int8 step of every other row."""
    torch = _torch()
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
        _fit(opt, lambda idx, net=net, d=d: loss_fn(net(xn[idx])[:, 0], yn[idx, d]), n, epochs, rng, batch,
             f"branch {nnfmt.DOFS[d]} ({activations[d]})", progress)
        nets[d] = net
    if joint_epochs > 0:  # stage 2: combined fine-tuning
        params = [p for net in nets.values() for p in net.parameters()]
        opt = torch.optim.RMSprop(params, lr=joint_lr if joint_lr is not None else lr * 0.25)
        _fit(opt, lambda idx: sum(loss_fn(net(xn[idx])[:, 0], yn[idx, d]) for d, net in nets.items()), n,
             joint_epochs, rng, batch, "joint fine-tuning", progress)
    if qat_epochs > 0 and pact_epochs > 0:
        raise ValueError("stage 3 (qat_epochs) and PACT (pact_epochs) are alternatives")
    if qat_epochs > 0:  # stage 3: fine-tuning against int8 rounding
        if qat_mode not in QAT_MODES:
            raise ValueError(f"qat_mode {qat_mode}: one of {QAT_MODES}")
        qin = {}
        for d in nets:  # inputs on the exporter's int8 input levels (the map depends on the domain only)
            fb = quant.FloatBranch(dof=d, feature_ids=ids, norm_scale=norm_scale, norm_offset=norm_offset,
                                   weights=[], biases=[], activation=activations[d], clip_lo=clip_lo,
                                   clip_hi=clip_hi)
            a_np, c_np = quant.input_map(fb, features)
            u = xn_np * a_np + c_np
            s_in, zp_in = (quant.DOMAIN_SCALE, 0) if clip_lo is not None else quant.asym_params(u.min(), u.max())
            u = np.clip(np.rint(u / s_in) + zp_in, -128, 127)
            qin[d] = (torch.from_numpy(((u - zp_in) * s_in - c_np) / a_np).float(),
                      torch.from_numpy(a_np[None, :]).float(), torch.from_numpy((s_in / a_np)[None, :]).float())
        gen = torch.Generator().manual_seed(seed) if qat_mode == "noise" else None
        params = [p for net in nets.values() for p in net.parameters()]
        opt = torch.optim.RMSprop(params, lr=qat_lr if qat_lr is not None else lr * 0.1)
        calib = {}

        def recalibrate():  # the int8 ranges of the current weights, once per epoch
            calib.update({d: _qat_calibrate(net, xn, activations[d]) for d, net in nets.items()})

        def qat_loss(idx):
            loss = 0.0
            for d, net in nets.items():
                xq, col, step = qin[d]
                if qat_mode == "noise":
                    x = xn[idx] + (torch.rand((len(idx), xn.shape[1]), generator=gen) - 0.5) * step
                    loss = loss + loss_fn(_qat_forward(net, x, col, calib[d], activations[d], gen)[:, 0], yn[idx, d])
                elif qat_mode == "fq":
                    loss = loss + loss_fn(_qat_forward(net, xq[idx], col, calib[d], activations[d])[:, 0], yn[idx, d])
                else:
                    yf = net(xn[idx])[:, 0]
                    yq = _qat_forward(net, xq[idx], col, calib[d], activations[d])[:, 0]
                    loss = loss + loss_fn(yf, yn[idx, d]) + qat_weight * ((yq - yf) ** 2).mean()
            return loss

        _fit(opt, qat_loss, n, qat_epochs, rng, batch, f"int8-aware fine-tuning ({qat_mode})", progress,
             before_epoch=recalibrate)
    branches = []
    for d, net in nets.items():
        lin = [m for m in net if isinstance(m, torch.nn.Linear)]
        branches.append(quant.FloatBranch(
            dof=d, feature_ids=ids, norm_scale=norm_scale, norm_offset=norm_offset,
            weights=[m.weight.detach().numpy().astype(np.float64) for m in lin],
            biases=[m.bias.detach().numpy().astype(np.float64) for m in lin],
            activation=activations[d], out_scale=float(t_std[d]), out_offset=float(t_mean[d]),
            clip_lo=clip_lo, clip_hi=clip_hi))
    if pact_epochs > 0:
        branches = pact_finetune(branches, features, targets, epochs=pact_epochs,
                                 lr=pact_lr if pact_lr is not None else lr * 0.1, decay=pact_decay, init=pact_init,
                                 batch=batch, seed=seed, huber_delta=huber_delta, progress=progress)
    return branches


def main(argv=None):
    ap = cli.parser("tinyvo-train", __doc__)
    ap.add_argument("dataset", help=".npz with features, targets, sequence (or 'synthetic' for a demo)")
    ap.add_argument("-o", "--out", required=True, help="checkpoint to write (.npz)")
    ap.add_argument("--act", default="relu", help="activation for all branches or tx=selu,ty=tanh,...")
    ap.add_argument("--dofs", default="tx,ty,tz,rx,ry,rz",
                    help="branches to train: DoF names, or 'step' / 'log_step' (one step-length branch, alone "
                         "or with rx,ry,rz; never with tx ty tz)")
    ap.add_argument("--val-sequences", default="", help="comma-separated sequences held out (never fitted)")
    ap.add_argument("--epochs", type=int, default=100, help="stage-1 epochs per branch (default 100)")
    ap.add_argument("--joint-epochs", type=int, default=20, help="stage-2 joint fine-tuning epochs (default 20)")
    ap.add_argument("--batch", type=int, default=256, help="minibatch rows (default 256)")
    ap.add_argument("--lr", type=float, default=2e-4, help="RMSprop learning rate (default 2e-4)")
    ap.add_argument("--sizes", default="256,32,32", help="hidden layer sizes (default 256,32,32)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the initialisation and the batch order (default 0)")
    ap.add_argument("--input-clip", type=float, default=0.0,
                    help="input domain: clamp each input to its training [p, 100-p] percentiles (+margin); 0: off")
    ap.add_argument("--input-clip-margin", type=float, default=0.25,
                    help="margin added to each side of the input domain, in units of its width (default 0.25)")
    ap.add_argument("--qat-epochs", type=int, default=0, help="stage 3: int8-aware fine-tuning epochs (0: off)")
    ap.add_argument("--qat-lr", type=float, default=None, help="its learning rate (default: lr / 10)")
    ap.add_argument("--qat-mode", default="fq", choices=QAT_MODES,
                    help="stage 3: fake-quantised pass (fq), int8-step noise (noise) or consistency loss (consist)")
    ap.add_argument("--qat-weight", type=float, default=100.0, help="consistency weight (--qat-mode consist)")
    ap.add_argument("--pact-epochs", type=int, default=0,
                    help="PACT fine-tuning epochs after stage 2 (relu branches clip at trained bounds; 0: off)")
    ap.add_argument("--pact-lr", type=float, default=None, help="its learning rate (default: lr / 10)")
    ap.add_argument("--pact-decay", type=float, default=0.0, help="its L2 weight on the bounds")
    ap.add_argument("--pact-init", type=float, default=1.0, help="initial bound: this x the layer's training max")
    args = ap.parse_args(argv)
    try:
        sizes = tuple(int(s) for s in args.sizes.split(","))
    except ValueError:
        ap.error(f"--sizes {args.sizes!r}: comma-separated integers")
    try:
        acts = parse_activations(args.act)
    except ValueError as e:
        ap.error(f"--act {args.act!r}: {e}")
    try:
        dofs = [nnfmt.DOFS.index(d.strip()) for d in args.dofs.split(",") if d.strip()]
        nnfmt.check_dofs(dofs)
    except ValueError as e:
        ap.error(f"--dofs {args.dofs!r}: {e}")
    if args.epochs < 0 or args.joint_epochs < 0 or args.batch < 1:
        ap.error("--epochs and --joint-epochs must be >= 0, --batch >= 1")
    return cli.run(ap.prog, lambda: _main(args, sizes, acts, dofs))


def _main(args, sizes, acts, dofs) -> int:
    if args.dataset == "synthetic":
        f, t, seq = synthetic_dataset(np.random.default_rng(args.seed), 20000)
    else:
        f, t, seq = load_dataset(args.dataset)
    val = [s for s in args.val_sequences.split(",") if s]
    tr, _ = split_rows(seq, val)
    branches = train(f[tr], t[tr], acts, sizes=sizes, dofs=dofs, epochs=args.epochs, joint_epochs=args.joint_epochs,
                     batch=args.batch, lr=args.lr, seed=args.seed,
                     input_clip=args.input_clip, input_clip_margin=args.input_clip_margin,
                     qat_epochs=args.qat_epochs, qat_lr=args.qat_lr, qat_mode=args.qat_mode,
                     qat_weight=args.qat_weight, pact_epochs=args.pact_epochs, pact_lr=args.pact_lr,
                     pact_decay=args.pact_decay, pact_init=args.pact_init, progress=not args.quiet)
    quant.save_checkpoint(args.out, branches, {
        "tinyvo_tools": __version__, "dataset": args.dataset, "val_sequences": val,
        "train_sequences": sorted(set(seq[tr].tolist())), "sizes": list(sizes), "epochs": args.epochs,
        "joint_epochs": args.joint_epochs, "lr": args.lr, "batch": args.batch, "seed": args.seed,
        "input_clip": args.input_clip,
        "input_clip_margin": args.input_clip_margin, "qat_epochs": args.qat_epochs, "qat_lr": args.qat_lr,
        "qat_mode": args.qat_mode, "qat_weight": args.qat_weight, "pact_epochs": args.pact_epochs,
        "pact_lr": args.pact_lr, "pact_decay": args.pact_decay, "pact_init": args.pact_init,
        "feature_layout_id": nnfmt.FEAT_LAYOUT_ID})
    cli.log(args.quiet, f"wrote {args.out}: {len(branches)} branches, trained on {int(tr.sum())} rows")
    return 0


if __name__ == "__main__":
    sys.exit(main())
