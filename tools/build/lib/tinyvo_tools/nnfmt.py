# SPDX-License-Identifier: Apache-2.0
"""tinyvo's flat weights file (docs/weights-format.md): writer, reader and the NumPy integer reference.

The reference (`reference_run`) performs exactly the arithmetic of lib/src/tvo_nn_*.c: float32 input
normalisation and quantisation (ties to even), int8 x int8 -> int32 fully connected layers,
requantisation ``floor((acc * M + 2^(s-1)) / 2^s)`` in 64 bits, 256-entry int8 lookup tables, and a
float32 dequantised last layer. The C interpreter must match it bit for bit.
"""
from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np

MAGIC = b"TVNN"
VERSION_MAJOR = 1
VERSION_MINOR = 1            # 1.1: DoF codes 6 (step length) and 7 (log step length)
HEADER_SIZE = 64
BRANCH_ENTRY_SIZE = 48
INPUT_ENTRY_SIZE = 12
LAYER_ENTRY_SIZE = 64
PAYLOAD_ALIGN = 16

FEAT_LAYOUT_ID = 1
FEATURES = ["rx", "ry", "rz", "tx", "ty", "tz", "inlier_ratio", "parallax_deg", "tracks", "dt", "rot_only"]
FEAT_COUNT = len(FEATURES)
# the range each feature of layout 1 can take by its definition (enum tvo_feature, nn.h): rotation vector
# components |r_i| <= pi, unit translation components in [-1, 1] (unit or zero), inlier ratio in [0, 1],
# parallax, tracks / 1000 and dt non-negative, rot_only 0 or 1. quant.equalise_inputs narrows a model's
# input domain to it, so that no int8 input level is spent on values no front end produces.
FEAT_RANGE = [(-np.pi, np.pi)] * 3 + [(-1.0, 1.0)] * 3 + [(0.0, 1.0), (0.0, np.inf), (0.0, np.inf),
                                                          (0.0, np.inf), (0.0, 1.0)]
DOFS = ["tx", "ty", "tz", "rx", "ry", "rz", "step", "log_step"]   # branch DoF codes 0..7
DOF_STEP = 6          # output: metric length |t| of the step (m), applied to the raw VO unit translation
DOF_LOG_STEP = 7      # output: its natural log; the interpreter returns exp of it (det_exp) as the step
OUT_COUNT = 7         # reference_run / tvo_nn_run_all outputs: tx ty tz rx ry rz step
OUT_STEP = 6
LOG_STEP_MIN = -16.0  # a log-step branch's value is clamped to [LOG_STEP_MIN, LOG_STEP_MAX] before exp
LOG_STEP_MAX = 8.0
STEP_MIN_M = 1e-4     # training: log targets of steps below this use this


def min_minor(dofs) -> int:
    """The lowest minor version that describes a file with these branch DoF codes."""
    return 1 if any(d >= DOF_STEP for d in dofs) else 0


def check_dofs(dofs) -> None:
    """Raise ValueError for a set of branch DoFs the C loader refuses (docs/weights-format.md)."""
    dofs = list(dofs)
    if len(set(dofs)) != len(dofs) or any(not 0 <= d < len(DOFS) for d in dofs):
        raise ValueError(f"DoF codes {dofs}: each of 0..{len(DOFS) - 1} at most once")
    if DOF_STEP in dofs and DOF_LOG_STEP in dofs:
        raise ValueError("a model holds one step-length branch (step or log_step), not both")
    if any(d >= DOF_STEP for d in dofs) and any(d < 3 for d in dofs):
        raise ValueError("a step-length branch cannot be mixed with tx/ty/tz branches")


# tvo_dm_exp's constants (lib/src/tvo_dmath.c): 1/ln 2, and ln 2 split so that k * EXP_LN2_HI is exact
EXP_INV_LN2 = float.fromhex("0x1.71547652b82fep+0")
EXP_LN2_HI = float.fromhex("0x1.62e42feep-1")
EXP_LN2_LO = float.fromhex("0x1.a39ef35793c76p-33")


def det_exp(x: np.ndarray) -> np.ndarray:
    """exp in float64 with the operations of the C interpreter's exp (tvo_dm_exp, lib/src/tvo_dmath.c) in
    the same order: k = floor(x / ln2 + 0.5) as x * (1/ln2) + 0.5, r = (x - k ln2_hi) - k ln2_lo, Horner
    p = 1 + p r / i for i = 17..1 from p = 1, then ldexp(p, k). Bit-exact with C (IEEE binary64, no fused
    operations) for the clamped log-step values [LOG_STEP_MIN, LOG_STEP_MAX]."""
    x = np.asarray(x, np.float64)
    k = np.floor(x * EXP_INV_LN2 + 0.5)
    r = (x - k * EXP_LN2_HI) - k * EXP_LN2_LO
    p = np.ones_like(x)
    for i in range(17, 0, -1):
        p = 1.0 + p * r / float(i)
    return np.ldexp(p, k.astype(np.int32))


def log_step_to_step(v: np.ndarray) -> np.ndarray:
    """A log-step branch's float32 output -> the float32 step length of the interpreter."""
    v = np.clip(np.asarray(v, np.float32), np.float32(LOG_STEP_MIN), np.float32(LOG_STEP_MAX))
    return det_exp(v.astype(np.float64)).astype(np.float32)

ACTS = ["none", "relu", "leaky_relu", "elu", "selu", "tanh", "sigmoid"]
ACT_CODE = {name: i for i, name in enumerate(ACTS)}
OUT_S8 = 0
OUT_F32 = 1


@dataclass
class Layer:
    """One fully connected layer. w is int8 (n_out, n_in); bias int32 (n_out,).
    S8 layers: mult/shift int32 (n_out,), optional lut int8 (256,) indexed by q + 128.
    F32 layer (the last one): scale float32 (n_out,) = dequantisation factor of the accumulator."""
    w: np.ndarray
    bias: np.ndarray
    act: str = "none"
    out_kind: int = OUT_S8
    in_zp: int = 0
    out_zp: int = 0
    act_zp: int = 0
    in_scale: float = 1.0
    out_scale: float = 1.0
    act_scale: float = 1.0
    mult: Optional[np.ndarray] = None
    shift: Optional[np.ndarray] = None
    scale: Optional[np.ndarray] = None
    lut: Optional[np.ndarray] = None

    @property
    def n_in(self) -> int:
        return int(self.w.shape[1])

    @property
    def n_out(self) -> int:
        return int(self.w.shape[0])


@dataclass
class Branch:
    dof: int
    feature_ids: List[int]
    norm_scale: np.ndarray   # float32 per input
    norm_offset: np.ndarray  # float32 per input
    in_scale: float
    in_zp: int
    out_scale: float         # output = y * out_scale + out_offset (float32)
    out_offset: float
    layers: List[Layer] = field(default_factory=list)


@dataclass
class Model:
    branches: List[Branch]
    layout_id: int = FEAT_LAYOUT_ID
    n_features: int = FEAT_COUNT
    version_major: int = VERSION_MAJOR
    version_minor: Optional[int] = None  # None: the lowest minor that describes the branches (min_minor)

    @property
    def output_mask(self) -> int:
        """Bit d for output d of tvo_nn_run_all (0..5 the DoFs, 6 = step for codes 6 and 7)."""
        m = 0
        for b in self.branches:
            m |= 1 << min(b.dof, OUT_STEP)
        return m

    @property
    def minor(self) -> int:
        return self.version_minor if self.version_minor is not None else min_minor(b.dof for b in self.branches)

    @property
    def macs(self) -> int:
        return sum(L.n_in * L.n_out for b in self.branches for L in b.layers)


def _f32(x) -> float:
    return float(np.float32(x))


def _align(n: int, a: int) -> int:
    return (n + a - 1) // a * a


def write(model: Model) -> bytes:
    """Serialise a model (little-endian, layout of docs/weights-format.md) with its CRC32."""
    nb = len(model.branches)
    off = HEADER_SIZE
    bt_off = off
    off += nb * BRANCH_ENTRY_SIZE
    tables = []  # (inputs_off, layers_off) per branch
    for b in model.branches:
        in_off = off
        off = _align(off + len(b.feature_ids) * INPUT_ENTRY_SIZE, 4)
        ly_off = off
        off += len(b.layers) * LAYER_ENTRY_SIZE
        tables.append((in_off, ly_off))
    payload = []  # (offset, bytes)
    layer_offs = []
    for b in model.branches:
        offs = []
        for L in b.layers:
            o = {}
            off = _align(off, PAYLOAD_ALIGN)
            o["w"] = off
            payload.append((off, np.ascontiguousarray(L.w, dtype=np.int8).tobytes()))
            off += L.n_in * L.n_out
            off = _align(off, 4)
            o["b"] = off
            payload.append((off, np.asarray(L.bias, dtype="<i4").tobytes()))
            off += 4 * L.n_out
            o["m"] = off
            if L.out_kind == OUT_S8:
                payload.append((off, np.asarray(L.mult, dtype="<i4").tobytes()))
                off += 4 * L.n_out
                o["s"] = off
                payload.append((off, np.asarray(L.shift, dtype="<i4").tobytes()))
                off += 4 * L.n_out
            else:
                payload.append((off, np.asarray(L.scale, dtype="<f4").tobytes()))
                off += 4 * L.n_out
                o["s"] = 0
            if L.lut is not None:
                off = _align(off, PAYLOAD_ALIGN)
                o["l"] = off
                payload.append((off, np.asarray(L.lut, dtype=np.int8).tobytes()))
                off += 256
            else:
                o["l"] = 0
            offs.append(o)
        layer_offs.append(offs)
    size = off
    buf = bytearray(size)
    struct.pack_into("<4sHHIIIIIIIIII", buf, 0, MAGIC, model.version_major, model.minor, size, 0,
                     HEADER_SIZE, model.layout_id, model.n_features, nb, bt_off, BRANCH_ENTRY_SIZE,
                     LAYER_ENTRY_SIZE, INPUT_ENTRY_SIZE)
    for i, b in enumerate(model.branches):
        in_off, ly_off = tables[i]
        struct.pack_into("<IIIIIfiff12x", buf, bt_off + i * BRANCH_ENTRY_SIZE, b.dof, len(b.feature_ids),
                         len(b.layers), in_off, ly_off, _f32(b.in_scale), int(b.in_zp), _f32(b.out_scale),
                         _f32(b.out_offset))
        for j, fid in enumerate(b.feature_ids):
            struct.pack_into("<Iff", buf, in_off + j * INPUT_ENTRY_SIZE, int(fid), _f32(b.norm_scale[j]),
                             _f32(b.norm_offset[j]))
        for k, L in enumerate(b.layers):
            o = layer_offs[i][k]
            struct.pack_into("<IIIIiiifffIIIIII", buf, ly_off + k * LAYER_ENTRY_SIZE, L.n_in, L.n_out,
                             ACT_CODE[L.act], L.out_kind, int(L.in_zp), int(L.out_zp), int(L.act_zp),
                             _f32(L.in_scale), _f32(L.out_scale), _f32(L.act_scale), o["w"], o["b"], o["m"],
                             o["s"], o["l"], 0)
    for o, data in payload:
        buf[o:o + len(data)] = data
    fix_crc(buf)
    return bytes(buf)


def fix_crc(buf: bytearray) -> None:
    """Recompute the header CRC32 (over bytes [16, end)) in place: tests use it after corrupting fields."""
    struct.pack_into("<I", buf, 12, zlib.crc32(bytes(buf[16:])) & 0xFFFFFFFF)


def read(data: bytes) -> Model:
    """Parse a weights file (basic checks only: the C loader is the strict validator)."""
    magic, vmaj, vmin, size, crc, hsize, layout, nfeat, nb, bt_off = struct.unpack_from("<4sHHIIIIIII", data, 0)
    if magic != MAGIC or vmaj != VERSION_MAJOR:
        raise ValueError("not a tinyvo weights file of a supported version")
    if size != len(data) or zlib.crc32(data[16:]) & 0xFFFFFFFF != crc:
        raise ValueError("size or CRC mismatch")
    branches = []
    for i in range(nb):
        dof, n_in, n_layers, in_off, ly_off, in_scale, in_zp, out_scale, out_offset = struct.unpack_from(
            "<IIIIIfiff", data, bt_off + i * BRANCH_ENTRY_SIZE)
        ids, ns, no = [], [], []
        for j in range(n_in):
            fid, s, o = struct.unpack_from("<Iff", data, in_off + j * INPUT_ENTRY_SIZE)
            ids.append(fid)
            ns.append(s)
            no.append(o)
        layers = []
        prev = n_in
        for k in range(n_layers):
            (li, lo, act, kind, izp, ozp, azp, isc, osc, asc, w_off, b_off, m_off, s_off,
             l_off, _) = struct.unpack_from("<IIIIiiifffIIIIII", data, ly_off + k * LAYER_ENTRY_SIZE)
            if li != prev:
                raise ValueError("layer sizes do not chain")
            prev = lo
            w = np.frombuffer(data, np.int8, li * lo, w_off).reshape(lo, li).copy()
            L = Layer(w=w, bias=np.frombuffer(data, "<i4", lo, b_off).astype(np.int32), act=ACTS[act],
                      out_kind=kind, in_zp=izp, out_zp=ozp, act_zp=azp, in_scale=isc, out_scale=osc,
                      act_scale=asc)
            if kind == OUT_S8:
                L.mult = np.frombuffer(data, "<i4", lo, m_off).astype(np.int32)
                L.shift = np.frombuffer(data, "<i4", lo, s_off).astype(np.int32)
            else:
                L.scale = np.frombuffer(data, "<f4", lo, m_off).astype(np.float32)
            if l_off:
                L.lut = np.frombuffer(data, np.int8, 256, l_off).copy()
            layers.append(L)
        branches.append(Branch(dof=dof, feature_ids=ids, norm_scale=np.array(ns, np.float32),
                               norm_offset=np.array(no, np.float32), in_scale=in_scale, in_zp=in_zp,
                               out_scale=out_scale, out_offset=out_offset, layers=layers))
    return Model(branches=branches, layout_id=layout, n_features=nfeat, version_major=vmaj, version_minor=vmin)


# ---- the integer reference -------------------------------------------------------------------

def requantize(acc: np.ndarray, mult: np.ndarray, shift: np.ndarray) -> np.ndarray:
    """floor((acc * mult + 2^(shift-1)) / 2^shift), exact in int64 (ties toward +infinity)."""
    acc = acc.astype(np.int64)
    mult = np.asarray(mult, np.int64)
    shift = np.asarray(shift, np.int64)
    v = acc * mult + np.left_shift(np.int64(1), shift - 1)
    return np.right_shift(v, shift)  # arithmetic shift = floor for int64


def quantize_input(b: Branch, features: np.ndarray) -> np.ndarray:
    f = np.asarray(features, np.float32)[:, b.feature_ids]
    if not np.all(np.isfinite(f)):
        raise ValueError("non-finite feature")
    t = f * np.asarray(b.norm_scale, np.float32)
    t = t + np.asarray(b.norm_offset, np.float32)
    u = t / np.float32(b.in_scale)
    u = np.clip(u, np.float32(-512.0), np.float32(512.0))
    v = np.rint(u).astype(np.int32) + np.int32(b.in_zp)
    return np.clip(v, -128, 127).astype(np.int8)


def fc_acc(L: Layer, x: np.ndarray) -> np.ndarray:
    acc = (x.astype(np.int64) - L.in_zp) @ L.w.astype(np.int64).T + L.bias.astype(np.int64)
    if acc.size and (acc.max() > 2**31 - 1 or acc.min() < -2**31):
        raise OverflowError("int32 accumulator overflow")
    return acc.astype(np.int32)


def run_branch(b: Branch, features: np.ndarray) -> np.ndarray:
    """Float32 outputs (N,) of one branch for features (N, FEAT_COUNT)."""
    x = quantize_input(b, features)
    for L in b.layers:
        acc = fc_acc(L, x)
        if L.out_kind == OUT_F32:
            y = acc.astype(np.float32) * np.asarray(L.scale, np.float32)
            y = y[:, 0] * np.float32(b.out_scale)
            return y + np.float32(b.out_offset)
        q = requantize(acc, L.mult, L.shift) + L.out_zp
        x = np.clip(q, -128, 127).astype(np.int8)
        if L.lut is not None:
            x = np.asarray(L.lut, np.int8)[x.astype(np.int32) + 128]
    raise ValueError("branch without a float output layer")


def reference_run(model: Model, features: np.ndarray) -> np.ndarray:
    """(N, 7) float32: tx ty tz rx ry rz step, NaN for outputs the model does not provide; bit-exact with
    tvo_nn_run_all() (tvo_nn_run() returns the first six). A log-step branch's value v gives
    step = (float)det_exp(clamp(v, LOG_STEP_MIN, LOG_STEP_MAX))."""
    features = np.atleast_2d(np.asarray(features, np.float32))
    out = np.full((features.shape[0], OUT_COUNT), np.nan, np.float32)
    for b in model.branches:
        y = run_branch(b, features)
        if b.dof == DOF_LOG_STEP:
            out[:, OUT_STEP] = log_step_to_step(y)
        else:
            out[:, min(b.dof, OUT_STEP)] = y
    return out


# ---- golden vectors --------------------------------------------------------------------------

GOLDEN_MAGIC = b"TVNG"
GOLDEN_VERSION = 2          # 1: 6 outputs per record; 2: 7 (tx ty tz rx ry rz step)
GOLDEN_OUTPUTS = {1: 6, 2: 7}


def write_golden(path, features: np.ndarray, outputs: np.ndarray, generator: str) -> None:
    """Golden vectors: "TVNG", u32 version, u32 n, u32 n_features, char generator[32] (the writing
    script and its version), then n records of n_features float32 features + 7 float32 outputs (LE;
    version 1 files, still read, have 6). Outputs with 6 columns are written as version 1."""
    features = np.asarray(features, "<f4")
    outputs = np.asarray(outputs, "<f4")
    ver = 1 if outputs.shape[1] == 6 else GOLDEN_VERSION
    gen = generator.encode()[:31].ljust(32, b"\0")
    with open(path, "wb") as fh:
        fh.write(struct.pack("<4sIII32s", GOLDEN_MAGIC, ver, features.shape[0], features.shape[1], gen))
        fh.write(np.concatenate([features, outputs], axis=1).astype("<f4").tobytes())


def read_golden(path):
    data = open(path, "rb").read()
    magic, ver, n, nf, gen = struct.unpack_from("<4sIII32s", data, 0)
    if magic != GOLDEN_MAGIC or ver not in GOLDEN_OUTPUTS:
        raise ValueError("not a golden file")
    no = GOLDEN_OUTPUTS[ver]
    rec = np.frombuffer(data, "<f4", n * (nf + no), 48).reshape(n, nf + no)
    return rec[:, :nf].copy(), rec[:, nf:].copy(), gen.rstrip(b"\0").decode()
