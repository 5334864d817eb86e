# SPDX-License-Identifier: Apache-2.0
"""What the benchmarks on modified copies of a sequence share (bench_exposure.py, bench_degrade.py): the
folder the copies go to, and one replay of a copy with `tvo_replay --scale none` and its figures."""
import contextlib
import json
import os
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "tools"))
from tinyvo_tools import eval as tvo_eval  # noqa: E402


@contextlib.contextmanager
def work_folder(work, prefix):
    """work, or a temporary folder removed at the end."""
    path = work or tempfile.mkdtemp(prefix=prefix)
    try:
        yield path
    finally:
        if not work:
            shutil.rmtree(path, ignore_errors=True)


def pick(only, known, prog):
    """The copies named in `only` (comma-separated; empty: every one of `known`, in its order); exits with
    a message naming the known ones when a name is not among them."""
    names = [n for n in only.split(",") if n] or list(known)
    for n in names:
        if n not in known:
            raise SystemExit(f"{prog}: unknown copy {n} (known: {', '.join(known)})")
    return names


def fresh(work, name):
    """work/name, emptied: the place for one copy."""
    dst = os.path.join(work, name)
    if os.path.exists(dst):
        shutil.rmtree(dst)
    return dst


def replay(replay_bin, seq, args, tmp, after_map=False):
    """Replay seq with `--scale none` and args: the Sim(3) ATE (m), per-frame rotation RPE (deg) (NaN when
    the trajectory cannot be aligned: too few poses, or none that move), frames without a pose and map
    losses; with after_map also the frames before the map's first pose (the map state `initialising`) and
    the ATE of the frames from there on (NaN when there are none)."""
    traj, stats = os.path.join(tmp, "traj.txt"), os.path.join(tmp, "stats.json")
    subprocess.run([replay_bin, "--euroc", seq, "--scale", "none", "--out", traj, "--stats", stats, "--quiet"]
                   + args, check=True)
    with open(stats, encoding="utf-8") as f:
        st = json.load(f)
    try:
        std = tvo_eval.evaluate_files(traj, seq).result["standard"]
        ate, rot = std["ate_m"]["rmse"], std["rpe_frame"]["rotation_deg"]["rmse"]
    except ValueError:  # too few poses, or positions that do not span enough to align: no figure
        ate = rot = float("nan")
    out = {"ate": ate, "rot": rot, "lost": st["frames"]["lost"], "losses": st.get("map", {}).get("losses", 0)}
    if after_map:
        init = int(st.get("map", {}).get("states", {}).get("initialising", 0))
        # the trajectory holds one row per posed frame, in order
        with open(traj, encoding="utf-8") as f:
            lines = [ln for ln in f if ln.strip() and not ln.startswith("#")]
        after = os.path.join(tmp, "after.txt")
        with open(after, "w", encoding="utf-8") as f:
            f.writelines(lines[init:])
        try:
            out["ate_after"] = tvo_eval.evaluate_files(after, seq).result["standard"]["ate_m"]["rmse"]
        except ValueError:
            out["ate_after"] = float("nan")
        out["init"] = init
    return out
