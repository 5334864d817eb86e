#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Benchmark: which tracks live through a frame, by where they are in the image.

Replays an EuRoC/ASL sequence with `tvo_replay --tracks` (and the given replay arguments) and reads the
tracks after every frame: a track of age 0 was detected in that frame, and it was kept when the next
frame still has it (age 1: through LK with its forward-backward check, the lens and that frame's
epipolar or map inliers). It prints, for the tracks detected in a frame ("new") and for the older ones
("old"), how many there were and the share kept, over the whole image and in each horizontal band of
it (rows split into --bands equal bands, top first; a track counts in the band it was in before the
step). The totals are the replay's own `tracks` counts in `--stats` (checked).

Usage: .venv/bin/python test/bench/bench_track_survival.py --seq SEQ --replay BUILD/examples/replay/tvo_replay
           [--bands N] [--max-frames N] [-- REPLAY ARGS]
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
from collections import defaultdict

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from tinyvo_tools import cli  # noqa: E402


def read_tracks(path: str):
    """{frame index: {track id: (y, age)}} from a --tracks CSV, frames in time order."""
    by_t = defaultdict(dict)
    with open(path, newline="", encoding="utf-8") as f:
        for row in csv.DictReader(f):
            by_t[int(row["t_ns"])][int(row["id"])] = (float(row["y"]), int(row["age"]))
    return [by_t[t] for t in sorted(by_t)]


def survival(frames, height: int, bands: int):
    """Counts per band: {"new"|"old": [(tracks, kept) per band]}. A frame without tracks (the replay
    re-initialised, or nothing was tracked) has nothing to carry."""
    out = {k: [[0, 0] for _ in range(bands)] for k in ("new", "old")}
    for prev, cur in zip(frames, frames[1:]):
        for i, (y, age) in prev.items():
            b = min(bands - 1, max(0, int(y * bands / height)))
            c = out["new" if age == 0 else "old"][b]
            c[0] += 1
            c[1] += i in cur and cur[i][1] == age + 1
    return out


def main(argv=None) -> int:
    args, extra = cli.split_passthrough(argv)
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seq", required=True, help="EuRoC/ASL sequence folder")
    ap.add_argument("--replay", required=True, help="the tvo_replay binary")
    ap.add_argument("--bands", type=int, default=4, help="horizontal bands of the image (default 4)")
    ap.add_argument("--max-frames", type=int, default=0, help="replay only the first N frames")
    a = ap.parse_args(args)
    if a.bands < 1:
        ap.error("--bands must be at least 1")
    with tempfile.TemporaryDirectory() as work:
        tracks, stats = os.path.join(work, "tracks.csv"), os.path.join(work, "stats.json")
        cmd = [a.replay, "--euroc", a.seq, "--out", os.path.join(work, "traj.txt"), "--scale", "none",
               "--tracks", tracks, "--stats", stats, "--quiet", *extra]
        if a.max_frames > 0:
            cmd += ["--max-frames", str(a.max_frames)]
        p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        if p.returncode != 0:
            print(f"bench_track_survival: tvo_replay exit {p.returncode}: {p.stderr.strip()}", file=sys.stderr)
            return 1
        with open(stats, encoding="utf-8") as f:
            st = json.load(f)
        frames = read_tracks(tracks)
    counts = survival(frames, int(st["height"]), a.bands)
    tot = {k: [sum(c[0] for c in v), sum(c[1] for c in v)] for k, v in counts.items()}
    # the replay counts the same tracks (it also counts none across a re-initialisation)
    if any(tot[k] != [st["tracks"][k], st["tracks"][k + "_kept"]] for k in ("new", "old")):
        print(f"bench_track_survival: counts {tot} differ from the replay's {st['tracks']}", file=sys.stderr)
        return 1

    def share(c):
        return f"{100.0 * c[1] / c[0]:5.1f} % of {c[0]}" if c[0] else "    - of 0"

    print(f"{os.path.basename(os.path.normpath(a.seq))}: {len(frames)} frames, {st['height']} rows")
    print(f"{'rows':>12}  {'new tracks kept':>20}  {'old tracks kept':>20}")
    for b in range(a.bands):
        lo, hi = b * st["height"] // a.bands, (b + 1) * st["height"] // a.bands
        print(f"{f'{lo}-{hi}':>12}  {share(counts['new'][b]):>20}  {share(counts['old'][b]):>20}")
    print(f"{'all':>12}  {share(tot['new']):>20}  {share(tot['old']):>20}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
