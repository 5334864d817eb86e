# SPDX-License-Identifier: Apache-2.0
"""Evaluation suite: tvo_replay over several EuRoC/ASL sequences, one table.

    tinyvo-suite --replay PATH/tvo_replay --seq DIR [--seq DIR ...]
                                 [--scale none|gt|propagate|model|const] [--repeat N] [--out RESULTS.json]
                                 [--keep DIR] [-- extra tvo_replay arguments]

``--seq`` takes a sequence folder (one holding ``mav0/cam0/data.csv`` and ground truth in
``mav0/state_groundtruth_estimate0/data.csv``) or a folder of such folders (every subfolder that is a
sequence, sorted by name). A folder whose frames are not a regular sequence (more than a quarter of the
frame intervals longer than 1.5 frame periods of its ``sensor.yaml`` rate, e.g. a set of keyframes) is
skipped with a message: a set of frames far apart is not what a VO is measured on.

For each sequence the replay runs with ``--scale MODE --stats`` (single thread, as always) and the extra
arguments after ``--`` (e.g. ``-- --model FILE`` for ``--scale model``); the trajectory is evaluated by
tinyvo_tools.eval (evo): ATE RMSE after Sim(3) alignment for ``--scale none`` (unit steps: only the shape
counts) and after SE(3) alignment for the metric modes (gt, propagate, model, const). The table has per
sequence: frames processed, ATE RMSE (m), per-frame rotation RPE RMSE (deg), lost frames (the replay's
``frames.lost`` in its stats JSON), and the median and p90 of the VO's time per frame (ms; the replay's
``timing_us.total``, PNG decoding excluded), and the share of tracks kept from one frame to the next
(the replay's ``tracks`` counts, in %): "new kept" of those detected in the previous frame, "old kept" of
those older (on real frames far fewer new tracks survive their first step than old ones; on renders
nearly all do). With ``--repeat N`` each sequence is replayed N times and the
time columns are the medians of the N runs' figures (the trajectory of the last run is evaluated; a run
whose trajectory differs from the first one's is reported, since the VO is deterministic).

The last row ("total") sums frames and lost frames and gives the mean over sequences of the ATE, the RPE
and the two time columns. Exit status: 0, 1 when a replay or an evaluation failed (its row says why), 2 for
bad arguments.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

from . import cli, eval as tvo_eval
from . import trajio

METRIC_MODES = ("gt", "propagate", "model", "const")
SCALE_MODES = ("none",) + METRIC_MODES
# the suite sets these itself
_RESERVED = ("--euroc", "--out", "--stats", "--scale", "--cam")


def _frame_times(seq_dir: str):
    return trajio.read_cam_frames(os.path.join(seq_dir, "mav0", "cam0"))[0]


def is_sequence_dir(path: str) -> bool:
    """True for a folder in EuRoC/ASL layout with cam0 frames and ground truth."""
    return (os.path.isfile(os.path.join(path, "mav0", "cam0", "data.csv")) and
            os.path.isfile(os.path.join(path, "mav0", "state_groundtruth_estimate0", "data.csv")))


def irregular_reason(seq_dir: str):
    """None for a regular frame sequence, else a sentence saying why it is not one."""
    t = _frame_times(seq_dir)
    if len(t) < 3:
        return f"{len(t)} frames"
    yaml = os.path.join(seq_dir, "mav0", "cam0", "sensor.yaml")
    rate = trajio.read_sensor_yaml(yaml).rate_hz if os.path.isfile(yaml) else 20.0
    period = 1e9 / rate
    dt = np.diff(t)
    long_gaps = int(np.sum(dt > 1.5 * period))
    if long_gaps * 4 > len(dt):
        return (f"not a regular sequence: {long_gaps} of {len(dt)} frame intervals are longer than 1.5 "
                f"periods at {rate:g} Hz (median interval {np.median(dt) * 1e-9:.3f} s)")
    return None


def expand_sequences(paths):
    """(sequence folders, [(folder, reason) skipped]) from the --seq arguments."""
    seqs, skipped = [], []
    for p in paths:
        p = os.path.abspath(p)
        if not os.path.isdir(p):
            raise ValueError(f"{p}: no such folder")
        if is_sequence_dir(p):
            cands = [p]
        else:
            cands = [os.path.join(p, d) for d in sorted(os.listdir(p))
                     if os.path.isdir(os.path.join(p, d)) and is_sequence_dir(os.path.join(p, d))]
            if not cands:
                raise ValueError(f"{p}: neither a sequence (mav0/cam0/data.csv and "
                                 "mav0/state_groundtruth_estimate0/data.csv) nor a folder of sequences")
        for c in cands:
            why = irregular_reason(c)
            if why:
                skipped.append((c, why))
            elif c not in seqs:
                seqs.append(c)
    return seqs, skipped


def _names(seqs):
    """Short unique names: the folder name, with its parent's when two folders share a name."""
    base = [os.path.basename(s) for s in seqs]
    return [os.path.join(os.path.basename(os.path.dirname(s)), b) if base.count(b) > 1 else b
            for s, b in zip(seqs, base)]


def run_sequence(replay: str, seq: str, scale: str, work: str, extra=(), repeat: int = 1) -> dict:
    """Replay one sequence ``repeat`` times and evaluate it. Returns the row (a dict); ``error`` is set
    when the replay or the evaluation failed."""
    traj = os.path.join(work, "traj.txt")
    stats_path = os.path.join(work, "stats.json")
    cmd = [replay, "--euroc", seq, "--out", traj, "--scale", scale, "--stats", stats_path, "--quiet",
           *extra]
    row = {"path": seq, "command": cmd, "repeat": repeat}
    meds, p90s, first = [], [], None
    for _ in range(repeat):
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        if p.returncode != 0:
            msg = (p.stderr.strip().splitlines() or [""])[-1]
            row["error"] = f"tvo_replay exit {p.returncode}: {msg}"
            return row
        with open(stats_path, "r", encoding="utf-8") as f:
            stats = json.load(f)
        meds.append(stats["timing_us"]["total"]["median"] / 1e3)
        p90s.append(stats["timing_us"]["total"]["p90"] / 1e3)
        with open(traj, "r", encoding="utf-8") as f:
            text = f.read()
        if first is None:
            first = text
        elif text != first:
            row["nondeterministic"] = True
    row["stats"] = stats
    row["frames"] = int(stats["frames"]["processed"])
    row["frames_total"] = int(stats["frames"]["total"])
    row["lost"] = int(stats["frames"]["lost"])
    tr = stats.get("tracks", {})
    for k in ("new", "old"):
        n = tr.get(k, 0)
        row[f"kept_{k}"] = tr[f"{k}_kept"] / n if n > 0 else None
    row["median_ms"] = float(np.median(meds))
    row["p90_ms"] = float(np.median(p90s))
    row["runs_ms"] = [{"median": m, "p90": q} for m, q in zip(meds, p90s)]
    try:
        ev = tvo_eval.evaluate_files(traj, seq, metric_scale=scale in METRIC_MODES,
                                     out_json=os.path.join(work, "eval.json"))
    except (OSError, ValueError) as e:
        row["error"] = f"evaluation failed: {e}"
        return row
    std = ev.result["standard"]
    row["alignment"] = std["alignment"]["type"]
    row["sim3_scale"] = std["alignment"]["scale"]
    row["ate_m"] = std["ate_m"]["rmse"]
    row["rpe_rot_deg"] = std["rpe_frame"]["rotation_deg"]["rmse"]
    row["rpe_trans_m"] = std["rpe_frame"]["translation_m"]["rmse"]
    row["gt_path_length_m"] = ev.result["gt_path_length_m"]
    return row


def totals(rows) -> dict:
    good = [r for r in rows if "error" not in r]
    out = {"sequences": len(rows), "failed": len(rows) - len(good),
           "frames": int(sum(r["frames"] for r in good)), "lost": int(sum(r["lost"] for r in good))}
    for k in ("ate_m", "rpe_rot_deg", "median_ms", "p90_ms"):
        out[f"mean_{k}"] = float(np.mean([r[k] for r in good])) if good else None
    return out


def format_table(rows, tot, scale: str) -> str:
    al = "SE(3)" if scale in METRIC_MODES else "Sim(3)"
    w = max([len("sequence"), len("total")] + [len(r["name"]) for r in rows])
    head = (f"{'sequence':<{w}}  {'frames':>6}  {'ATE ' + al + ' m':>14}  {'RPE rot deg':>11}  {'lost':>5}  "
            f"{'median ms':>9}  {'p90 ms':>7}  {'new kept %':>10}  {'old kept %':>10}")
    lines = [head, "-" * len(head)]
    for r in rows:
        if "error" in r:
            lines.append(f"{r['name']:<{w}}  FAILED: {r['error']}")
            continue
        flag = "  (trajectory differed between runs)" if r.get("nondeterministic") else ""
        kept = "".join(f"  {'-' if r.get(k) is None else format(100.0 * r[k], '.1f'):>10}"
                       for k in ("kept_new", "kept_old"))
        lines.append(f"{r['name']:<{w}}  {r['frames']:>6d}  {r['ate_m']:>14.4f}  {r['rpe_rot_deg']:>11.3f}  "
                     f"{r['lost']:>5d}  {r['median_ms']:>9.2f}  {r['p90_ms']:>7.2f}{kept}{flag}")
    lines.append("-" * len(head))
    if tot["mean_ate_m"] is None:
        lines.append(f"{'total':<{w}}  no sequence evaluated")
    else:
        lines.append(f"{'total':<{w}}  {tot['frames']:>6d}  {tot['mean_ate_m']:>14.4f}  "
                     f"{tot['mean_rpe_rot_deg']:>11.3f}  {tot['lost']:>5d}  {tot['mean_median_ms']:>9.2f}  "
                     f"{tot['mean_p90_ms']:>7.2f}")
        lines.append(f"(total: frames and lost summed; ATE, RPE and times are means over "
                     f"{len(rows) - tot['failed']} sequences)")
    return "\n".join(lines)


def main(argv=None) -> int:
    argv, extra = cli.split_passthrough(argv)
    ap = cli.parser("tinyvo-suite", __doc__)
    ap.add_argument("--replay", required=True, help="the tvo_replay binary")
    ap.add_argument("--seq", action="append", required=True,
                    help="sequence folder (EuRoC/ASL layout) or a folder of them; repeatable")
    ap.add_argument("--scale", choices=SCALE_MODES, default="none",
                    help="tvo_replay --scale mode (default none: Sim(3) ATE; the others SE(3))")
    ap.add_argument("--repeat", type=int, default=1, help="replay each sequence N times (time columns: "
                    "median of the runs)")
    ap.add_argument("--out", help="write every row (with the replay's stats) and the total as JSON here")
    ap.add_argument("--keep", help="keep each sequence's trajectory, stats and evaluation in DIR/<name>/ "
                    "(default: a temporary folder, removed)")
    a = ap.parse_args(argv)
    if a.repeat < 1:
        ap.error("--repeat must be >= 1")
    bad = [x for x in extra if x.split("=")[0] in _RESERVED]
    if bad:
        ap.error(f"the suite sets {', '.join(_RESERVED)} itself (got {' '.join(bad)} after --)")
    def body():
        if not (os.path.isfile(a.replay) and os.access(a.replay, os.X_OK)):
            raise cli.Failure(f"--replay {a.replay}: not an executable file")
        try:
            seqs, skipped = expand_sequences(a.seq)
        except (OSError, ValueError) as e:
            raise cli.Failure(str(e)) from None
        for s, why in skipped:
            print(f"suite: skipping {s}: {why}", file=sys.stderr)
        if not seqs:
            raise cli.Failure("no sequence to run")
        tmp = None
        base = os.path.abspath(a.keep) if a.keep else (tmp := tempfile.mkdtemp(prefix="tvo_suite_"))
        rows = []
        try:
            for name, seq in zip(_names(seqs), seqs):
                work = os.path.join(base, name.replace(os.sep, "_"))
                os.makedirs(work, exist_ok=True)
                row = run_sequence(os.path.abspath(a.replay), seq, a.scale, work, extra, a.repeat)
                row["name"] = name
                rows.append(row)
                if "error" in row:
                    print(f"suite: {name}: {row['error']}", file=sys.stderr)
        finally:
            if tmp:
                shutil.rmtree(tmp, ignore_errors=True)
        tot = totals(rows)
        sys.stderr.flush()
        if not a.quiet:
            print(f"tvo_replay --scale {a.scale}{(' ' + ' '.join(extra)) if extra else ''} "
                  f"({a.replay}; repeat {a.repeat})")
            print(format_table(rows, tot, a.scale))
        if a.out:
            d = os.path.dirname(os.path.abspath(a.out))
            os.makedirs(d, exist_ok=True)
            with open(a.out, "w", encoding="utf-8") as f:
                json.dump({"tool": "tinyvo_tools.suite", "replay": os.path.abspath(a.replay), "scale": a.scale,
                           "extra_args": extra, "repeat": a.repeat,
                           "skipped": [{"path": s, "reason": w} for s, w in skipped],
                           "sequences": rows, "total": tot}, f, indent=2)
        return 1 if tot["failed"] else 0

    return cli.run(ap.prog, body)


if __name__ == "__main__":
    sys.exit(main())
