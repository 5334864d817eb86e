#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Apply the second accuracy rule of docs/rules.md to runs made by tools/seed-runs.sh.

    tools/seed-rule.py OUTDIR DEFAULT CANDIDATE [CANDIDATE ...] [--markdown]
    tools/seed-rule.py OUTDIR LABEL --null N


For every label, the 5 seeded runs are read from OUTDIR (LABEL_s<seed>.json, the suite's JSON, and the
trajectories of the two EuRoC samples, evaluated here). Per sequence and figure (Sim(3) ATE RMSE in m,
per-frame rotation RPE RMSE in deg), a configuration's figure is its median over the seeds. A candidate
passes when (1) on every sequence and figure its median is at most the default's largest run, (2) for
each figure the geometric mean over the sequences of candidate median / default median is at most 1,
(3) on no sequence the median count of LOST frames grows. Figures are compared at 4 significant digits.
Exit status 0 when every candidate passes, 1 when one fails, 2 on bad input. TVO_SEEDS="5 6 7 8 9" (as given
to tools/seed-runs.sh) reads other seeds than the default 24301 1 2 3 4.

--null N measures how often the rule refuses a change that changes nothing: LABEL's runs over TVO_SEEDS
(at least 10 seeds, say 15) are split N times at random into a "default" and a "candidate" of 5 seeds
each, both the same configuration, and each split is judged as above. It prints the share of splits that
fail and which conditions refuse them (exit status 0; the splits are drawn with a fixed generator, so
the figures repeat)."""
import json
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from tinyvo_tools import eval as tvo_eval  # noqa: E402
from tinyvo_tools import trajio  # noqa: E402

SEEDS = tuple(int(x) for x in os.environ.get("TVO_SEEDS", "24301 1 2 3 4").split())
EUROC = ("V1_01_easy_head", "V1_01_easy_keyframes")
# The calibrated rule's thresholds (docs/rules.md, "The second rule measured against itself"):
CAL_ALPHA = 0.002
CAL_GM = {"ate": 1.03, "rot": 1.01}


def sig4(x):
    return float(f"{x:.4g}")


def euroc_figures(traj, seq):
    """(ATE or None, rotation RPE, lost) of a EuRoC sample. The head sequence stands still: no alignment,
    so no ATE; the per-frame rotation RPE does not depend on the alignment and is computed directly."""
    stats = json.load(open(traj[:-4] + ".stats.json", encoding="utf-8"))
    lost = int(stats["frames"]["lost"])
    try:
        ev = tvo_eval.evaluate_files(traj, seq)
        std = ev.result["standard"]
        return std["ate_m"]["rmse"], std["rpe_frame"]["rotation_deg"]["rmse"], lost
    except ValueError:
        pass
    est = trajio.read_tum(traj, "camera")
    gt, yaml, _, _ = tvo_eval.load_groundtruth(seq)
    from evo.core import sync
    T_BS = trajio.read_sensor_yaml(yaml).T_BS
    ref, e = sync.associate_trajectories(tvo_eval._to_evo(gt.to_camera(T_BS)), tvo_eval._to_evo(est),
                                         max_diff=0.01)
    d = tvo_eval.per_dof_errors(np.array(ref.poses_se3), np.array(e.poses_se3))
    return None, float(np.sqrt(np.mean(np.sum(d[:, 3:] ** 2, axis=1)))), lost


def load(outdir, label, data, seeds=SEEDS):
    """{sequence: {"ate": [...], "rot": [...], "lost": [...]}} for one label, one entry per seed."""
    runs = {}
    for seed in seeds:
        base = os.path.join(outdir, f"{label}_s{seed}")
        suite = json.load(open(base + ".json", encoding="utf-8"))
        for r in suite["sequences"]:
            if "error" in r:
                raise SystemExit(f"seed-rule: {label} seed {seed}: {r['name']}: {r['error']}")
            d = runs.setdefault(r["name"], {"ate": [], "rot": [], "lost": []})
            d["ate"].append(r["ate_m"])
            d["rot"].append(r["rpe_rot_deg"])
            d["lost"].append(r["lost"])
        for e in EUROC:
            if not os.path.exists(f"{base}_{e}.txt"):
                if seed == seeds[0]:
                    print(f"seed-rule: {label}: no {e} runs, left out", file=sys.stderr)
                continue
            a, rot, lost = euroc_figures(f"{base}_{e}.txt", os.path.join(data, "euroc", e))
            d = runs.setdefault(e, {"ate": [], "rot": [], "lost": []})
            d["ate"].append(a)
            d["rot"].append(rot)
            d["lost"].append(lost)
    return runs


def judge_cells(D, C, cell, gm_max, same_count):
    """Rows and the verdict of candidate C against default D: cell(d_runs, c_runs) gives each sequence's
    and figure's (row cell, passes, log of the median ratio); the geometric means of the median ratios
    must be at most gm_max[figure]; the median count of LOST frames must not grow. same_count: a sequence
    whose candidate has another number of runs counts as missing."""
    rows, fails, logs = [], [], {"ate": [], "rot": []}
    for seq, d in D.items():
        if seq not in C or (same_count and len(C[seq]["rot"]) != len(d["rot"])):
            fails.append(f"{seq} missing")
            continue
        c = C[seq]
        row = {"seq": seq}
        for f in ("ate", "rot"):
            if d[f][0] is None:
                row[f] = None
                continue
            row[f], ok, log_ratio = cell(d[f], c[f])
            logs[f].append(log_ratio)
            if not ok:
                fails.append(f"{seq} {f}")
        dl, cl = float(np.median(d["lost"])), float(np.median(c["lost"]))
        row["lost"] = (dl, cl)
        if cl > dl:
            fails.append(f"{seq} lost")
        rows.append(row)
    gm = {f: math.exp(sum(v) / len(v)) if v else float("nan") for f, v in logs.items()}
    for f in ("ate", "rot"):
        if not sig4(gm[f]) <= gm_max[f]:
            fails.append(f"geometric mean {f} {gm[f]:.4f}")
    return rows, gm, fails


def second_cell(dv, cv):
    """The second rule's cell: the candidate's median at most the default's largest run."""
    dm, cm, dmax = sig4(float(np.median(dv))), sig4(float(np.median(cv))), sig4(max(dv))
    return (dm, dmax, cm, cm <= dmax), cm <= dmax, math.log(cm / dm)


def calibrated_cell(dv, cv):
    """The calibrated rule's cell: a one-sided Mann-Whitney test of "the candidate's runs are larger than
    the default's" at CAL_ALPHA, on the figures at 4 significant digits."""
    from scipy.stats import mannwhitneyu
    dv, cv = [sig4(x) for x in dv], [sig4(x) for x in cv]
    dm, cm = sig4(float(np.median(dv))), sig4(float(np.median(cv)))
    p = 1.0 if dv == cv or len(set(dv + cv)) == 1 else float(mannwhitneyu(cv, dv, alternative="greater").pvalue)
    return (dm, cm, p, p >= CAL_ALPHA), p >= CAL_ALPHA, math.log(cm / dm)


def judge(D, C):
    """The second rule: every median within the default's runs, geometric means at most 1."""
    return judge_cells(D, C, second_cell, {"ate": 1.0, "rot": 1.0}, True)


def judge_calibrated(D, C):
    """The calibrated rule: no cell refused by its Mann-Whitney test, geometric means at most CAL_GM."""
    return judge_cells(D, C, calibrated_cell, CAL_GM, False)


RULES = {"second": judge, "calibrated": judge_calibrated}


def subset(runs, idx, factor=1.0, only=None):
    """The runs of the seeds at positions idx, their figures times factor (on sequence `only`, or on all)."""
    out = {}
    for seq, d in runs.items():
        k = factor if only in (None, seq) else 1.0
        out[seq] = {f: [v[i] if v[i] is None or f == "lost" else v[i] * k for i in idx] for f, v in d.items()}
    return out


def null_rate(runs, n, k, rule, factor=1.0, only=None):
    """Share of n random splits of one configuration's runs into a "default" and a "candidate" of k seeds
    each that `rule` refuses (the candidate's figures times factor, on sequence `only` or on all), how
    often each condition refuses one, and the splits' geometric means: (share, {condition: count},
    {figure: [geometric mean per split]})."""
    m = len(next(iter(runs.values()))["rot"])
    if m < 2 * k:
        raise SystemExit(f"seed-rule: --null needs at least {2 * k} seeds, got {m}")
    rng = np.random.default_rng(20261205)
    failed, why, gms = 0, {}, {"ate": [], "rot": []}
    for _ in range(n):
        perm = rng.permutation(m)
        _, gm, fails = RULES[rule](subset(runs, perm[:k]), subset(runs, perm[k:2 * k], factor, only))
        failed += bool(fails)
        for f in gms:
            gms[f].append(gm[f])
        for f in fails:
            key = f.rsplit(" ", 1)[0] if f.startswith("geometric mean") else f
            why[key] = why.get(key, 0) + 1
    return failed / n, why, gms


def option(args, name, convert, default):
    """Remove `name VALUE` from args and return the converted value (default when absent)."""
    if name not in args:
        return default
    i = args.index(name)
    try:
        value = convert(args[i + 1])
    except (IndexError, ValueError):
        raise SystemExit(f"seed-rule: {name} needs a value") from None
    del args[i:i + 2]
    return value


def print_table(rows, rule, md):
    if rule == "second":
        head = ("ATE D median / D max / C median", "rot RPE D median / D max / C median")
    else:
        head = ("ATE D median / C median / p", "rot RPE D median / C median / p")
    if md:
        print(f"| sequence | {head[0]} | {head[1]} | lost D / C |")
        print("|---|---|---|---|")
    for r in rows:
        cells = []
        for f in ("ate", "rot"):
            if r[f] is None:
                cells.append("-")
            elif rule == "second":
                dm, dmax, cm, ok = r[f]
                cells.append(f"{dm:.4g} / {dmax:.4g} / {cm:.4g}{'' if ok else ' **worse**'}")
            else:
                dm, cm, p, ok = r[f]
                cells.append(f"{dm:.4g} / {cm:.4g} / {p:.2g}{'' if ok else ' **worse**'}")
        lost = f"{r['lost'][0]:g} / {r['lost'][1]:g}"
        print(f"| {r['seq']} | {cells[0]} | {cells[1]} | {lost} |" if md else
              f"  {r['seq']:<22} ATE {cells[0]:<36} rot {cells[1]:<36} lost {lost}")


def main(argv):
    args = list(argv)
    md = "--markdown" in args
    args = [a for a in args if a != "--markdown"]
    try:
        null = option(args, "--null", int, 0)
        rule = option(args, "--rule", str, "second")
        group = option(args, "--group", int, 5)
        factor = option(args, "--regress", float, 1.0)
        only = option(args, "--regress-only", str, None)
        cand_seeds = option(args, "--candidate-seeds", lambda v: tuple(int(x) for x in v.split()), SEEDS)
    except SystemExit as e:
        print(e, file=sys.stderr)
        return 2
    if rule not in RULES or null < 0 or group < 1 or not factor > 0:
        print("seed-rule: --rule second|calibrated, --null N >= 1, --group K >= 1, --regress F > 0",
              file=sys.stderr)
        return 2
    if len(args) != 2 if null else len(args) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    outdir, dlabel, cands = args[0], args[1], args[2:]
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    data = os.environ.get("TVO_DATA_DIR", os.path.join(root, "..", "shared", "data"))
    D = load(outdir, dlabel, data)
    if null:
        share, why, gms = null_rate(D, null, group, rule, factor, only)
        what = "itself" if factor == 1.0 else f"itself times {factor:g}" + (f" on {only}" if only else "")
        print(f"{dlabel} against {what}, {rule} rule: {null} random splits of seeds "
              f"{', '.join(map(str, SEEDS))} into two groups of {group}")
        print(f"refused: {share:.1%} of the splits")
        for f, c in sorted(why.items(), key=lambda x: (-x[1], x[0])):
            print(f"  {f}: {c / null:.1%}")
        for f in ("ate", "rot"):
            q = np.percentile(gms[f], [5, 50, 95, 99])
            print(f"geometric mean of the median ratios, {f}: 5 / 50 / 95 / 99th percentiles "
                  + " / ".join(f"{x:.4f}" for x in q))
        return 0
    status = 0
    for cl in cands:
        rows, gm, fails = RULES[rule](D, load(outdir, cl, data, cand_seeds))
        seeds = ", ".join(map(str, SEEDS))
        if cand_seeds != SEEDS:
            seeds = f"{seeds} (default), {', '.join(map(str, cand_seeds))} (candidate)"
        print(f"\n{cl} against {dlabel}, {rule} rule (medians over seeds {seeds}"
              + ("; D max = the default's largest run)" if rule == "second" else
                 f"; p: one-sided Mann-Whitney, C above D, refused below {CAL_ALPHA:g})"))
        print_table(rows, rule, md)
        print(f"geometric mean of C/D medians: ATE {gm['ate']:.4f}, rot RPE {gm['rot']:.4f}")
        print(f"verdict: {'PASS' if not fails else 'FAIL (' + '; '.join(fails) + ')'}")
        status |= 1 if fails else 0
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
