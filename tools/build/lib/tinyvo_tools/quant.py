# SPDX-License-Identifier: Apache-2.0
"""Float per-DoF networks (torch-free) and their post-training int8 quantisation.

A FloatBranch is what the trainer's checkpoint holds for one DoF: the input feature ids, the input
normalisation (float32 scale/offset, fitted on the training data only), the float weights of an MLP
(hidden layers share one activation), and the target de-normalisation. `quantize_model` calibrates
activation ranges on calibration (training) features and produces an nnfmt.Model:
  - inputs: per-branch asymmetric int8 (min/max of the normalised calibration inputs, 0 included)
  - weights: symmetric int8 per output channel (max |w| / 127), biases int32 at scale s_in * s_w
  - hidden layers: pre-activation asymmetric int8 (calibrated), requantised by (M, shift) with
    M in [2^30, 2^31); activation as a 256-entry table to a post-activation int8 (calibrated)
  - last layer (1 output): accumulator dequantised to float32, then de-normalised.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from typing import List, Sequence

import numpy as np

from . import nnfmt

LEAKY_SLOPE = 0.01
SELU_ALPHA = 1.6732632423543772848170429916717
SELU_SCALE = 1.0507009873554804934193349852946


def activate(name: str, x: np.ndarray) -> np.ndarray:
    """The activations in float64 (same definitions as torch.nn defaults)."""
    x = np.asarray(x, np.float64)
    if name == "none":
        return x
    if name == "relu":
        return np.maximum(x, 0.0)
    if name == "leaky_relu":
        return np.where(x >= 0, x, LEAKY_SLOPE * x)
    if name == "elu":
        return np.where(x > 0, x, np.expm1(np.minimum(x, 0.0)))
    if name == "selu":
        return SELU_SCALE * np.where(x > 0, x, SELU_ALPHA * np.expm1(np.minimum(x, 0.0)))
    if name == "tanh":
        return np.tanh(x)
    if name == "sigmoid":
        return 1.0 / (1.0 + np.exp(-x))
    raise ValueError(f"unknown activation {name}")


@dataclass
class FloatBranch:
    dof: int
    feature_ids: List[int]
    norm_scale: np.ndarray
    norm_offset: np.ndarray
    weights: List[np.ndarray]   # (n_out, n_in) float
    biases: List[np.ndarray]    # (n_out,) float
    activation: str
    out_scale: float = 1.0
    out_offset: float = 0.0
    # optional input domain (normalised units, per input): the model clamps its normalised inputs to
    # [clip_lo, clip_hi] (train.py --input-clip); the int8 input stage then implements the same clamp
    clip_lo: np.ndarray = None
    clip_hi: np.ndarray = None
    # optional per hidden layer upper bound of a relu (PACT, train.pact_finetune): the float model's hidden
    # layer k is min(relu(a), act_clip[k]); the exporter (rule 2) requantises it over exactly [0, act_clip[k]]
    act_clip: List[float] = None

    def normalise(self, features: np.ndarray) -> np.ndarray:
        f = np.asarray(features, np.float32)[:, self.feature_ids]
        z = (f * np.asarray(self.norm_scale, np.float32) + np.asarray(self.norm_offset, np.float32)).astype(np.float64)
        if self.clip_lo is not None:
            z = np.clip(z, np.asarray(self.clip_lo, np.float64), np.asarray(self.clip_hi, np.float64))
        return z

    def forward_all(self, features: np.ndarray):
        """Normalised inputs, then (pre, post) activations of every layer, float64."""
        x = self.normalise(features)
        trace = [x]
        for k, (w, b) in enumerate(zip(self.weights, self.biases)):
            a = x @ np.asarray(w, np.float64).T + np.asarray(b, np.float64)
            last = k == len(self.weights) - 1
            x = a if last else activate(self.activation, a)
            if not last and self.act_clip is not None:
                x = np.minimum(x, float(self.act_clip[k]))
            trace.append((a, x))
        return trace

    def forward(self, features: np.ndarray) -> np.ndarray:
        y = self.forward_all(features)[-1][1][:, 0]
        return y * self.out_scale + self.out_offset


def float_run(branches: Sequence[FloatBranch], features: np.ndarray) -> np.ndarray:
    """(N, 7) float64 like nnfmt.reference_run: tx ty tz rx ry rz step (a log-step branch: exp of its
    value clamped to [LOG_STEP_MIN, LOG_STEP_MAX])."""
    features = np.atleast_2d(features)
    out = np.full((features.shape[0], nnfmt.OUT_COUNT), np.nan)
    for b in branches:
        y = b.forward(features)
        if b.dof == nnfmt.DOF_LOG_STEP:
            out[:, nnfmt.OUT_STEP] = np.exp(np.clip(y, nnfmt.LOG_STEP_MIN, nnfmt.LOG_STEP_MAX))
        else:
            out[:, min(b.dof, nnfmt.OUT_STEP)] = y
    return out


def quantize_multiplier(real: float):
    """real > 0 -> (M, shift) with real ~= M * 2^-shift, M in [2^30, 2^31), shift in [1, 62]."""
    if not (real > 0 and math.isfinite(real)):
        raise ValueError(f"bad multiplier {real}")
    m, e = math.frexp(real)  # real = m * 2^e, m in [0.5, 1)
    M = int(round(m * (1 << 31)))
    if M == 1 << 31:
        M //= 2
        e += 1
    shift = 31 - e
    if shift < 1:
        raise ValueError(f"multiplier {real} too large for the format")
    if shift > 62:  # below 2^-32: the output is the zero point anyway
        M, shift = 1 << 30, 62
    return M, shift


def asym_params(lo: float, hi: float):
    """Asymmetric int8 (scale, zero point) covering [lo, hi] (0 always included)."""
    lo, hi = min(float(lo), 0.0), max(float(hi), 0.0)
    if hi - lo < 1e-8:
        hi = lo + 1e-8
    scale = float(np.float32((hi - lo) / 255.0))
    zp = int(np.clip(round(-128 - lo / scale), -128, 127))
    return scale, zp


def make_lut(act: str, in_scale: float, in_zp: int, out_scale: float, out_zp: int) -> np.ndarray:
    q = np.arange(-128, 128)
    y = activate(act, (q - in_zp) * in_scale)
    r = np.rint(y / out_scale) + out_zp
    return np.clip(r, -128, 127).astype(np.int8)


# Calibration rules (quantize_model's `calibration`, export --calibration):
#   1: the rule of weights files exported before rule 2 existed (tinyvo_synth_euroc_t_sigmoid.tvonn, the
#      golden test models): input domain onto [-1, 1], every activation range min/max on the calibration
#      rows (0 included) before and after the activation.
#   2 (default): (a) a branch's input domain is intersected with the features' own range
#      (nnfmt.FEAT_RANGE) and its ends are the int8 levels -128 and 127 (DOMAIN_*); (b) relu layers are
#      requantised over [0, (1 + RELU_HEADROOM) max] with the identity as table (negative pre-activations
#      need no levels: relu zeroes them; the headroom keeps faster motion than in calibration from
#      saturating); (c) each layer's float weights and biases are re-fitted (ridge REFIT_RIDGE towards the
#      float ones, relu channels on the rows where the float channel is positive) to map the int8 inputs the
#      interpreter really gives that layer to the float model's pre-activations, before they are quantised.
#   Rule 2's settings were chosen on the training sequences only (models/MODEL_CARD.md, "Quantisation").
#   A relu branch whose float model clips its hidden layers (FloatBranch.act_clip, PACT fine-tuning:
#   train.pact_finetune) is requantised over exactly [0, act_clip[k]] instead (no headroom): the int8
#   saturation then is the float model's clip.
#   3 (not a default; tried, models/MODEL_CARD.md "Quantisation"): rule 2 with each layer's weights rounded
#      one input at a time with the least-squares compensation of the others and the bias (_sequential_round,
#      GPTQ-like) instead of to the nearest level.
CALIBRATION_DEFAULT = 2
RELU_HEADROOM = 0.75
REFIT_RIDGE = 0.01

# A branch with an input domain has it mapped onto the int8 input levels exactly: the domain's ends (where
# clamped inputs and features at their bounds, e.g. inlier ratio 1 or the rot_only flag, sit) are the levels
# -128 and 127 (scale DOMAIN_SCALE, zero point 0), never half-way between two levels.
DOMAIN_SCALE = float(np.float32(2.0 / 255.0))
DOMAIN_LO = -128.0 * DOMAIN_SCALE
DOMAIN_HI = 127.0 * DOMAIN_SCALE


def input_map(fb: FloatBranch, calib: np.ndarray, pct: float = 0.0, calibration: int = CALIBRATION_DEFAULT):
    """(a, c): the per-input affine map z' = a z + c of equalise_inputs (z the normalised, clamped input).
    The range mapped is the model's input domain (clip_lo/clip_hi) when it has one (rule 2: intersected
    with the features' own range, nnfmt.FEAT_RANGE in normalised units, onto [DOMAIN_LO, DOMAIN_HI]; rule
    1: onto [-1, 1]); else the calibration min/max (or pct percentiles) onto [-1, 1]."""
    if fb.clip_lo is not None and calibration >= 2:  # the model's own input domain
        lo, hi = np.asarray(fb.clip_lo, np.float64), np.asarray(fb.clip_hi, np.float64)
        ns = np.asarray(fb.norm_scale, np.float64)
        no = np.asarray(fb.norm_offset, np.float64)
        p = np.array([nnfmt.FEAT_RANGE[i] for i in fb.feature_ids], np.float64)
        with np.errstate(invalid="ignore"):
            a_lo = np.where(ns > 0, p[:, 0], p[:, 1]) * ns + no
            a_hi = np.where(ns > 0, p[:, 1], p[:, 0]) * ns + no
        a_lo = np.where(np.isfinite(a_lo), a_lo, -np.inf)
        a_hi = np.where(np.isfinite(a_hi), a_hi, np.inf)
        nlo, nhi = np.maximum(lo, a_lo), np.minimum(hi, a_hi)
        ok = nhi - nlo > 1e-6  # keep the domain where the intersection would be (almost) empty
        lo, hi = np.where(ok, nlo, lo), np.where(ok, nhi, hi)
        e_lo, e_hi = DOMAIN_LO, DOMAIN_HI
    elif fb.clip_lo is not None:
        lo, hi = np.asarray(fb.clip_lo, np.float64), np.asarray(fb.clip_hi, np.float64)
        e_lo, e_hi = -1.0, 1.0
    else:
        z = fb.normalise(calib)
        lo = np.percentile(z, pct, axis=0) if pct > 0 else z.min(axis=0)
        hi = np.percentile(z, 100 - pct, axis=0) if pct > 0 else z.max(axis=0)
        e_lo, e_hi = -1.0, 1.0
    span = np.where(hi - lo > 1e-6, hi - lo, 1.0)
    a = (e_hi - e_lo) / span
    return a, e_lo - a * lo


def equalise_inputs(fb: FloatBranch, calib: np.ndarray, pct: float = 0.0,
                    calibration: int = CALIBRATION_DEFAULT) -> FloatBranch:
    """The same float function with each normalised input re-scaled by input_map (z' = a z + c) so that
    its range maps to [-1, 1] (a branch with an input domain, rule 2: to [DOMAIN_LO, DOMAIN_HI]); the first layer
    absorbs the change (W' = W / a, b' = b - W' c). All inputs then share one int8 scale without wasting
    resolution on inputs with a narrow range."""
    a, c = input_map(fb, calib, pct, calibration)
    e_lo, e_hi = (DOMAIN_LO, DOMAIN_HI) if calibration >= 2 else (-1.0, 1.0)
    ns = np.asarray(fb.norm_scale, np.float64) * a
    no = np.asarray(fb.norm_offset, np.float64) * a + c
    w0 = np.asarray(fb.weights[0], np.float64) / a[None, :]
    b0 = np.asarray(fb.biases[0], np.float64) - w0 @ c
    # every other field (activation, output de-normalisation, relu clips, ...) carries over unchanged
    return replace(fb, feature_ids=list(fb.feature_ids), norm_scale=ns.astype(np.float32),
                   norm_offset=no.astype(np.float32), weights=[w0, *fb.weights[1:]], biases=[b0, *fb.biases[1:]],
                   clip_lo=None if fb.clip_lo is None else np.full(len(ns), e_lo),
                   clip_hi=None if fb.clip_hi is None else np.full(len(ns), e_hi),
                   act_clip=None if fb.act_clip is None else list(fb.act_clip))


def clip_relu_channels(fb: FloatBranch, features: np.ndarray, init: float = 1.0) -> FloatBranch:
    """Per-channel clipped relu layers, as a branch with one bound per layer (act_clip). Each hidden channel c
    of layer k becomes min(relu(a_c), m_c) with m_c = init x its largest activation on `features` (the
    training rows; with init >= 1 the function on them is unchanged), and is then rescaled by B_k / m_c
    (B_k = max_c m_c; relu and min commute with a positive scale), layer k + 1's column c absorbing
    m_c / B_k: the same float function, now with one bound B_k for the whole layer, so the exporter (rule 2)
    spends all 256 int8 levels of [0, B_k] on every channel instead of the few a channel with a small range
    reaches under a per-layer bound. A channel never active on `features` (m_c = 0) is set to 0 (weights and
    bias), as its clip at 0 would. Relu branches only; an existing act_clip stays in force (m_c is at most
    the layer's bound)."""
    if fb.activation != "relu":
        raise ValueError("clip_relu_channels: relu branches only")
    if not (math.isfinite(init) and init > 0):
        raise ValueError(f"clip_relu_channels: init {init} must be finite and > 0")
    trace = fb.forward_all(np.atleast_2d(features))
    w = [np.array(x, np.float64) for x in fb.weights]
    b = [np.array(x, np.float64) for x in fb.biases]
    bounds = []
    for k in range(len(w) - 1):
        m = trace[k + 1][1].max(axis=0) * init
        if fb.act_clip is not None:
            m = np.minimum(m, float(fb.act_clip[k]))
        dead = ~(m > 0)
        bound = float(m.max()) if not dead.all() else 1.0
        s = np.where(dead, 1.0, bound / np.where(dead, 1.0, m))
        w[k] *= s[:, None]
        b[k] *= s
        w[k][dead] = 0.0
        b[k][dead] = 0.0
        w[k + 1] /= s[None, :]
        bounds.append(bound)
    return replace(fb, weights=w, biases=b, act_clip=bounds)


def _range(v: np.ndarray, pct: float):
    if pct > 0:
        return np.percentile(v, pct), np.percentile(v, 100 - pct)
    return v.min(), v.max()


def _refit_layer(w: np.ndarray, b: np.ndarray, x: np.ndarray, target: np.ndarray, lam: float, mask=None):
    """Weights and biases that map the layer's int8 inputs x (dequantised, as the interpreter sees them) to
    the float model's pre-activations target (N, n_out) in the least-squares sense, pulled towards the float
    (w, b) by a ridge term lam * N * |[w b] - [w0 b0]|^2 (lam > 0). mask (N, n_out): per output channel,
    the rows fitted (None: all)."""
    n, m = x.shape
    X = np.hstack([x, np.ones((n, 1))])
    W0 = np.hstack([w, b[:, None]])                     # (n_out, m + 1)
    if mask is None:
        A = X.T @ X + lam * n * np.eye(m + 1)
        R = X.T @ target + lam * n * W0.T                  # (m + 1, n_out)
        sol = np.linalg.solve(A, R).T
        return sol[:, :m], sol[:, m]
    sol = W0.copy()
    for o in range(W0.shape[0]):
        Xo = X[mask[:, o]]
        A = Xo.T @ Xo + lam * n * np.eye(m + 1)
        sol[o] = np.linalg.solve(A, Xo.T @ target[mask[:, o], o] + lam * n * W0[o])
    return sol[:, :m], sol[:, m]


def _sequential_round(w: np.ndarray, b: np.ndarray, s_w: np.ndarray, x: np.ndarray, mask=None, damp: float = 0.01):
    """Rule 3's weight rounding (GPTQ / optimal brain quantisation, one output channel at a time): the
    channel's int8 inputs x (dequantised, N x m) give the Hessian H = X^T X of its squared pre-activation
    error (X = [x 1]: the bias is a continuous column, never rounded); weights are rounded to their channel's
    levels (s_w, clamped to +-127) one input at a time, each rounding error compensated by the inputs not yet
    rounded and by the bias (the least-squares update through the Cholesky factor of H^-1). mask (N, n_out):
    the rows of each channel (relu: where the float channel is positive), as the re-fit. Returns (w, b): w
    on the int8 levels (w / s_w integral), b continuous."""
    n, m = x.shape
    X = np.hstack([x, np.ones((n, 1))])
    w, b = np.array(w, np.float64), np.array(b, np.float64)
    for o in range(w.shape[0]):
        Xo = X if mask is None else X[mask[:, o]]
        H = Xo.T @ Xo
        H += damp * max(float(np.mean(np.diag(H))), 1e-12) * np.eye(m + 1)
        U = np.linalg.cholesky(np.linalg.inv(H)).T  # H^-1 = U^T U, U upper triangular
        v = np.append(w[o], b[o])
        for j in range(m):
            q = float(np.clip(np.rint(v[j] / s_w[o]), -127, 127)) * s_w[o]
            e = (v[j] - q) / U[j, j]
            v[j] = q
            v[j + 1:] -= e * U[j, j + 1:]
        w[o], b[o] = v[:m], v[m]
    return w, b


def copy_offsets(k: int) -> np.ndarray:
    """The k offsets, in int8 levels, of a channel's copies (hidden_copies): (j - (k - 1) / 2) / k, j < k,
    centred. By Hermite's identity (sum_j floor(x + j / k) = floor(k x)) the sum of the k copies'
    round-to-nearest levels, rint(u + o_j), is rint(k u): k copies of one int8 channel read with weight
    w / k each are one channel with k times finer levels over the same range, and their saturation at the
    range's ends is the channel's (all copies reach level -128 / 127 together)."""
    return (np.arange(k) - (k - 1) / 2.0) / k


def quantize_branch(fb: FloatBranch, calib: np.ndarray, pct: float = 0.0, equalise: bool = True,
                    calibration: int = CALIBRATION_DEFAULT, hidden_copies=None) -> nnfmt.Branch:
    """pct: clip calibration ranges at the pct / 100-pct percentiles (0 = min/max). A branch with an
    input domain (clip_lo/clip_hi) gets it as its int8 input range (equalise_inputs): the int8 input
    stage's clamp is then the model's own clamp (rule 2: within the features' own range). calibration:
    the rule (1 or 2, see CALIBRATION_DEFAULT). hidden_copies: per hidden layer, the number k >= 1 of int8
    copies of each of its channels (copy_offsets: the copies' biases are offset by a fraction of a level,
    the next layer reads each with 1 / k of the channel's weight): k times finer levels for that layer's
    output at k times its MACs and those of the next layer; the float model is unchanged (rule 2 only)."""
    if calibration not in (1, 2, 3):
        raise ValueError(f"calibration rule {calibration}: 1, 2 or 3")
    rule2 = calibration >= 2
    n = len(fb.weights)
    copies = [1] * (n - 1) if hidden_copies is None else [int(c) for c in hidden_copies]
    if len(copies) != n - 1 or any(c < 1 for c in copies):
        raise ValueError(f"hidden_copies {hidden_copies}: one count >= 1 per hidden layer ({n - 1})")
    if any(c > 1 for c in copies) and not (rule2 and fb.activation == "relu"):
        raise ValueError("hidden_copies: relu branches under calibration rule 2 or 3 only (identity tables)")
    if fb.clip_lo is not None and not equalise:
        raise ValueError("a branch with an input domain is quantised with equalise=True")
    if fb.act_clip is not None:
        if not rule2 or fb.activation != "relu":
            raise ValueError("a branch with clipped relu layers (act_clip) is quantised with rule 2, relu only")
        if len(fb.act_clip) != len(fb.weights) - 1 or not all(math.isfinite(c) and c > 0 for c in fb.act_clip):
            raise ValueError(f"act_clip {fb.act_clip}: one finite bound > 0 per hidden layer")
    if equalise:
        fb = equalise_inputs(fb, calib, pct, calibration)
    trace = fb.forward_all(calib)
    if fb.clip_lo is not None and rule2:  # the equalised domain [DOMAIN_LO, DOMAIN_HI] is int8 -128..127
        s_in, zp_in = DOMAIN_SCALE, 0
    elif fb.clip_lo is not None:
        s_in, zp_in = asym_params(-1.0, 1.0)
    else:
        s_in, zp_in = asym_params(*_range(trace[0], pct))
    br = nnfmt.Branch(dof=fb.dof, feature_ids=list(fb.feature_ids),
                      norm_scale=np.asarray(fb.norm_scale, np.float32),
                      norm_offset=np.asarray(fb.norm_offset, np.float32),
                      in_scale=s_in, in_zp=zp_in, out_scale=float(np.float32(fb.out_scale)),
                      out_offset=float(np.float32(fb.out_offset)))
    relu2 = rule2 and fb.activation == "relu"
    k_in = 1  # copies of each channel of the layer's input (those of the previous hidden layer)
    xq = nnfmt.quantize_input(br, calib) if rule2 else None  # the int8 inputs of the layer being quantised
    for k, (w, b) in enumerate(zip(fb.weights, fb.biases)):
        w = np.asarray(w, np.float64)
        b = np.asarray(b, np.float64)
        if k_in > 1:  # the input channels come in k_in copies (blocks of n_in): each read with w / k_in
            w = np.tile(w / k_in, (1, k_in))
        if rule2:
            pre_f = trace[k + 1][0]
            mask = (pre_f > 0) if (relu2 and k < n - 1) else None
            w, b = _refit_layer(w, b, (xq.astype(np.float64) - zp_in) * s_in, pre_f, REFIT_RIDGE, mask)
        amax = np.abs(w).max(axis=1)
        s_w = np.where(amax > 0, amax / 127.0, 1.0)
        if calibration >= 3:
            w, b = _sequential_round(w, b, s_w, (xq.astype(np.float64) - zp_in) * s_in, mask)
        wq = np.clip(np.rint(w / s_w[:, None]), -127, 127).astype(np.int8)
        acc_scale = s_in * s_w
        bq = np.clip(np.rint(b / acc_scale), -(2**30), 2**30).astype(np.int32)
        pre, post = trace[k + 1]
        if k == n - 1:
            L = nnfmt.Layer(w=wq, bias=bq, act="none", out_kind=nnfmt.OUT_F32, in_zp=zp_in, in_scale=s_in,
                            scale=acc_scale.astype(np.float32))
        else:
            lo_pre, hi_pre = _range(pre, pct)
            if relu2:
                # relu(clamp(a, lo, hi)) == relu(a) for every lo <= 0: the negative pre-activations need no
                # int8 levels, so the requantised range is [0, hi] (zero point -128) and the table is the
                # identity (same range after the activation): no level is spent on values relu zeroes
                lo_pre, hi_pre = 0.0, hi_pre * (1.0 + RELU_HEADROOM)
                if fb.act_clip is not None:  # a clipped relu (PACT): the range is the float model's own clip,
                    hi_pre = float(fb.act_clip[k])  # no headroom: saturation is exact, only rounding remains
            s_out, zp_out = asym_params(lo_pre, hi_pre)
            mult, shift = zip(*(quantize_multiplier(r) for r in acc_scale / s_out))
            L = nnfmt.Layer(w=wq, bias=bq, act=fb.activation, out_kind=nnfmt.OUT_S8, in_zp=zp_in,
                            out_zp=zp_out, in_scale=s_in, out_scale=s_out,
                            mult=np.array(mult, np.int32), shift=np.array(shift, np.int32))
            if fb.activation == "none":
                L.act_zp, L.act_scale = zp_out, s_out
            else:
                s_act, zp_act = (s_out, zp_out) if relu2 else asym_params(*_range(post, pct))
                L.act_zp, L.act_scale = zp_act, s_act
                L.lut = make_lut(fb.activation, s_out, zp_out, s_act, zp_act)
            if copies[k] > 1:  # the channels in copies[k] blocks, biases offset by copy_offsets levels
                off = np.rint(copy_offsets(copies[k])[:, None] * s_out / acc_scale[None, :])
                L.w = np.tile(L.w, (copies[k], 1))
                L.bias = np.clip(L.bias[None, :].astype(np.float64) + off, -(2**30), 2**30).astype(np.int32).ravel()
                L.mult, L.shift = np.tile(L.mult, copies[k]), np.tile(L.shift, copies[k])
            k_in = copies[k]
            s_in, zp_in = L.act_scale, L.act_zp
            if xq is not None:
                xq = np.clip(nnfmt.requantize(nnfmt.fc_acc(L, xq), L.mult, L.shift) + L.out_zp, -128, 127)
                xq = (L.lut[xq + 128] if L.lut is not None else xq).astype(np.int8)
        br.layers.append(L)
    return br


def quantize_model(branches: Sequence[FloatBranch], calib: np.ndarray, pct: float = 0.0,
                   equalise: bool = True, calibration: int = CALIBRATION_DEFAULT, hidden_copies=None) -> nnfmt.Model:
    return nnfmt.Model(branches=[quantize_branch(b, np.atleast_2d(calib), pct, equalise, calibration, hidden_copies)
                                 for b in branches])


def random_float_branch(rng: np.random.Generator, dof: int, activation: str, sizes=(256, 32, 32),
                        feature_ids=None, init_scale: float = 1.0) -> FloatBranch:
    """A random (He-initialised) branch for tests, golden vectors and benchmarks."""
    ids = list(range(nnfmt.FEAT_COUNT)) if feature_ids is None else list(feature_ids)
    dims = [len(ids), *sizes, 1]
    ws, bs = [], []
    for a, b in zip(dims[:-1], dims[1:]):
        ws.append(rng.normal(0, init_scale * math.sqrt(2.0 / a), (b, a)))
        bs.append(rng.normal(0, 0.1, b))
    return FloatBranch(dof=dof, feature_ids=ids,
                       norm_scale=rng.uniform(0.5, 2.0, len(ids)).astype(np.float32),
                       norm_offset=rng.uniform(-0.5, 0.5, len(ids)).astype(np.float32),
                       weights=ws, biases=bs, activation=activation,
                       out_scale=float(rng.uniform(0.05, 1.0)), out_offset=float(rng.uniform(-0.1, 0.1)))


def synthetic_features(rng: np.random.Generator, n: int) -> np.ndarray:
    """Plausible random front-end features (N, FEAT_COUNT) float32, for tests and calibration demos."""
    f = np.zeros((n, nnfmt.FEAT_COUNT), np.float32)
    f[:, 0:3] = rng.normal(0, 0.02, (n, 3))
    t = rng.normal(0, 1, (n, 3)) + np.array([0.0, 0.0, 0.5])
    f[:, 3:6] = t / np.linalg.norm(t, axis=1, keepdims=True)
    f[:, 6] = rng.uniform(0.3, 1.0, n)
    f[:, 7] = rng.gamma(2.0, 1.0, n)
    f[:, 8] = rng.uniform(0.1, 1.5, n)
    f[:, 9] = rng.choice([0.05, 0.1], n) * rng.uniform(0.98, 1.02, n)
    f[:, 10] = (rng.uniform(size=n) < 0.1).astype(np.float32)
    return f


# ---- float checkpoints (torch-free; written by train.py, read by export.py) ------------------

def save_checkpoint(path, branches: Sequence[FloatBranch], meta: dict) -> None:
    """A .npz: per branch d arrays b{d}_w{k}, b{d}_b{k}, b{d}_norm_scale, b{d}_norm_offset, and a JSON
    string 'meta' (training settings + per-branch dof/features/activation/output de-normalisation)."""
    import json
    arrays = {}
    meta = dict(meta)
    meta["branches"] = []
    for i, b in enumerate(branches):
        for k, (w, bb) in enumerate(zip(b.weights, b.biases)):
            arrays[f"b{i}_w{k}"] = np.asarray(w, np.float32)
            arrays[f"b{i}_b{k}"] = np.asarray(bb, np.float32)
        arrays[f"b{i}_norm_scale"] = np.asarray(b.norm_scale, np.float32)
        arrays[f"b{i}_norm_offset"] = np.asarray(b.norm_offset, np.float32)
        if b.clip_lo is not None:
            arrays[f"b{i}_clip_lo"] = np.asarray(b.clip_lo, np.float64)
            arrays[f"b{i}_clip_hi"] = np.asarray(b.clip_hi, np.float64)
        if b.act_clip is not None:
            arrays[f"b{i}_act_clip"] = np.asarray(b.act_clip, np.float64)
        meta["branches"].append({"dof": int(b.dof), "feature_ids": [int(x) for x in b.feature_ids],
                                 "activation": b.activation, "n_layers": len(b.weights),
                                 "out_scale": float(b.out_scale), "out_offset": float(b.out_offset)})
    arrays["meta"] = np.array(json.dumps(meta))
    if os.path.dirname(str(path)):
        os.makedirs(os.path.dirname(str(path)), exist_ok=True)
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)


def load_checkpoint(path):
    """-> (list of FloatBranch, meta dict)."""
    import json
    z = np.load(path, allow_pickle=False)
    meta = json.loads(str(z["meta"]))
    branches = []
    for i, m in enumerate(meta["branches"]):
        branches.append(FloatBranch(
            dof=m["dof"], feature_ids=m["feature_ids"], norm_scale=z[f"b{i}_norm_scale"],
            norm_offset=z[f"b{i}_norm_offset"],
            weights=[z[f"b{i}_w{k}"].astype(np.float64) for k in range(m["n_layers"])],
            biases=[z[f"b{i}_b{k}"].astype(np.float64) for k in range(m["n_layers"])],
            activation=m["activation"], out_scale=m["out_scale"], out_offset=m["out_offset"],
            clip_lo=z[f"b{i}_clip_lo"] if f"b{i}_clip_lo" in z else None,
            clip_hi=z[f"b{i}_clip_hi"] if f"b{i}_clip_hi" in z else None,
            act_clip=[float(c) for c in z[f"b{i}_act_clip"]] if f"b{i}_act_clip" in z else None))
    return branches, meta
