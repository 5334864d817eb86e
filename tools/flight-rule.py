#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The whole-flight condition of docs/rules.md ("A forty-sixth rule"), on runs made by tools/flight-runs.sh.

    tools/flight-rule.py OUTDIR DEFAULT CANDIDATE [--seeds "80 81 82 83 84"]
                         [--null-seeds "75 76 77 78 79 80 81 82 83 84"]

A flight's ATE is the Sim(3)-aligned ATE RMSE of OUTDIR/LABEL_<flight>_s<seed>.eval.json, its map losses
`map.losses` of the .stats.json beside it. The flights are those DEFAULT has at every seed.

The threshold comes from DEFAULT's own spread: its runs at the 2k null seeds are split every way into two
groups of k (both orders), and for each split the geometric mean over the flights of one group's median
ATE over the other's is taken; the threshold is the 99th percentile of those values (the
ceil(0.99 n)-th smallest of n). A condition "geometric mean at most 1" would refuse half of the changes
that do nothing: swapping the groups turns r into 1 / r.

The candidate passes when, at --seeds (k of them), (a) the geometric mean over the flights of its median
ATE over DEFAULT's is at most the threshold, (b) on every flight its median is at most DEFAULT's largest run
(4 significant digits), and (c) its map losses in total are no more than DEFAULT's. Exit status 0 when it
passes, 1 when it fails, 2 on bad input."""
import functools
import glob
import itertools
import json
import math
import os
import statistics
import sys

QUANTILE = 0.99


def sig4(x):
    return float(f"{x:.4g}")


@functools.lru_cache(maxsize=None)
def read_run(outdir, label, flight, seed):
    """(ATE m, map losses) of one run, or None when it is missing (each file read once)."""
    base = os.path.join(outdir, f"{label}_{flight}_s{seed}")
    try:
        with open(base + ".eval.json", encoding="utf-8") as f:
            ate = float(json.load(f)["standard"]["ate_m"]["rmse"])
        with open(base + ".stats.json", encoding="utf-8") as f:
            losses = int(json.load(f)["map"]["losses"])
    except FileNotFoundError:
        return None
    return ate, losses


def flights_of(outdir, label, seeds):
    """The flights LABEL has a run of at every seed, sorted."""
    names = set()
    prefix = f"{label}_"
    for path in glob.glob(os.path.join(outdir, f"{label}_*_s*.eval.json")):
        stem = os.path.basename(path)[len(prefix):-len(".eval.json")]
        names.add(stem.rsplit("_s", 1)[0])
    return sorted(n for n in names if all(read_run(outdir, label, n, s) is not None for s in seeds))


def gm_ratio(runs, flights, num, den):
    """Geometric mean over the flights of median(runs[f][i], i in num) / median(runs[f][i], i in den)."""
    lg = 0.0
    for f in flights:
        lg += math.log(statistics.median(runs[f][i] for i in num) / statistics.median(runs[f][i] for i in den))
    return math.exp(lg / len(flights))


def null_threshold(runs, flights, n_runs):
    """(threshold, sorted values) of the do-nothing splits of n_runs runs a flight into two halves."""
    k = n_runs // 2
    vals = []
    for g in itertools.combinations(range(n_runs), k):
        h = tuple(i for i in range(n_runs) if i not in g)
        vals.append(gm_ratio(runs, flights, g, h))
    vals.sort()
    return vals[math.ceil(QUANTILE * len(vals)) - 1], vals


def option(argv, name, default):
    if name in argv:
        i = argv.index(name)
        if i + 1 >= len(argv):
            raise ValueError(f"{name} needs a value")
        value = argv[i + 1]
        del argv[i:i + 2]
        return value
    return default


def judge(outdir, dlabel, clabel, seeds, null_seeds):
    """Prints the verdict; returns the exit status."""
    flights = flights_of(outdir, dlabel, sorted(set(seeds) | set(null_seeds)))
    if not flights:
        print(f"flight-rule: no flight with runs of {dlabel} at seeds {null_seeds} and {seeds}", file=sys.stderr)
        return 2
    null = {f: [read_run(outdir, dlabel, f, s)[0] for s in null_seeds] for f in flights}
    thr, vals = null_threshold(null, flights, len(null_seeds))
    print(f"flights: {', '.join(flights)}")
    print(f"{dlabel}'s do-nothing splits of seeds {' '.join(map(str, null_seeds))}: {len(vals)}; median "
          f"{statistics.median(vals):.4f}, above 1: {sum(v > 1.0 for v in vals)}; threshold (99th percentile) "
          f"{thr:.4f}")
    ok_b, lg, loss_d, loss_c = True, 0.0, 0, 0
    for f in flights:
        d = [read_run(outdir, dlabel, f, s) for s in seeds]
        c = [read_run(outdir, clabel, f, s) for s in seeds]
        if any(r is None for r in c):
            print(f"  {f}: {clabel} missing at some of seeds {seeds}")
            return 1
        md, mc = statistics.median(r[0] for r in d), statistics.median(r[0] for r in c)
        top = max(r[0] for r in d)
        within = sig4(mc) <= sig4(top)
        ok_b = ok_b and within
        lg += math.log(mc / md)
        loss_d += sum(r[1] for r in d)
        loss_c += sum(r[1] for r in c)
        print(f"  {f:<10} {dlabel} {md:.4f} (largest {top:.4f})  {clabel} {mc:.4f}  ratio {mc / md:.4f}"
              f"{'' if within else '  above the largest run'}")
    gm = math.exp(lg / len(flights))
    ok_a, ok_c = gm <= thr, loss_c <= loss_d
    print(f"(a) geometric mean {gm:.4f} against {thr:.4f}: {'pass' if ok_a else 'FAIL'}")
    print(f"(b) every median within {dlabel}'s largest run: {'pass' if ok_b else 'FAIL'}")
    print(f"(c) map losses {loss_c} against {loss_d}: {'pass' if ok_c else 'FAIL'}")
    passed = ok_a and ok_b and ok_c
    print(f"verdict: {'PASS' if passed else 'FAIL'}")
    return 0 if passed else 1


def main(argv):
    argv = list(argv)
    try:
        seeds = [int(x) for x in option(argv, "--seeds", "80 81 82 83 84").split()]
        null_seeds = [int(x) for x in option(argv, "--null-seeds", "75 76 77 78 79 80 81 82 83 84").split()]
    except ValueError as e:
        print(f"flight-rule: {e}", file=sys.stderr)
        return 2
    if len(argv) != 3 or len(null_seeds) < 4 or len(null_seeds) % 2 or len(seeds) != len(null_seeds) // 2:
        print(__doc__.split("\n\n")[1], file=sys.stderr)
        print("(an even number of at least 4 null seeds, and half as many seeds)", file=sys.stderr)
        return 2
    return judge(argv[0], argv[1], argv[2], seeds, null_seeds)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
