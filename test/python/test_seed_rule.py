# SPDX-License-Identifier: Apache-2.0
"""tools/seed-rule.py, the second accuracy rule of docs/rules.md, on synthetic suite results: a candidate
passes only when its median per sequence is within the default's largest run and the geometric mean of
the median ratios is at most 1."""
import json
import os
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
RULE = ROOT / "tools" / "seed-rule.py"
SEEDS = (24301, 1, 2, 3, 4)


def write_runs(d, label, figures, seeds=SEEDS):
    """figures: {sequence: [(ate, rot, lost) per seed]}"""
    for k, seed in enumerate(seeds):
        rows = [{"name": n, "ate_m": v[k][0], "rpe_rot_deg": v[k][1], "lost": v[k][2]} for n, v in figures.items()]
        (d / f"{label}_s{seed}.json").write_text(json.dumps({"sequences": rows}))


def run(d, *labels, seeds=None):
    env = dict(os.environ)
    env.pop("TVO_SEEDS", None)
    if seeds is not None:
        env["TVO_SEEDS"] = " ".join(map(str, seeds))
    return subprocess.run([sys.executable, str(RULE), str(d), *labels], capture_output=True, text=True, env=env)


def test_rule_verdicts(tmp_path):
    D = {"a": [(1.0, 0.10, 0), (1.2, 0.11, 0), (0.9, 0.12, 0), (1.1, 0.10, 0), (1.0, 0.30, 0)],
         "b": [(0.5, 0.05, 0)] * 5}
    write_runs(tmp_path, "D", D)
    # within the default's spread and better on the whole: passes
    write_runs(tmp_path, "good", {"a": [(1.15, 0.10, 0)] * 5, "b": [(0.4, 0.05, 0)] * 5})
    # median above the default's largest run on one sequence: fails even though better elsewhere
    write_runs(tmp_path, "spike", {"a": [(0.5, 0.05, 0)] * 5,
                                   "b": [(0.5, 0.06, 0), (0.5, 0.06, 0), (0.5, 0.06, 0), (0.5, 0.04, 0),
                                         (0.5, 0.04, 0)]})
    # within the spread everywhere but worse on the whole (geometric mean of the ATE ratios > 1)
    write_runs(tmp_path, "drift", {"a": [(1.2, 0.11, 0)] * 5, "b": [(0.5, 0.05, 0)] * 5})
    # more lost frames
    write_runs(tmp_path, "lost", {"a": [(1.0, 0.1, 2)] * 5, "b": [(0.5, 0.05, 0)] * 5})
    r = run(tmp_path, "D", "good")
    assert r.returncode == 0 and "verdict: PASS" in r.stdout, r.stdout + r.stderr
    for label, why in (("spike", "b rot"), ("drift", "geometric mean ate"), ("lost", "a lost")):
        r = run(tmp_path, "D", label)
        assert r.returncode == 1 and "verdict: FAIL" in r.stdout and why in r.stdout, (label, r.stdout)


def test_rule_refuses_missing_input(tmp_path):
    r = run(tmp_path, "D")
    assert r.returncode == 2
    write_runs(tmp_path, "D", {"a": [(1.0, 0.1, 0)] * 5})
    write_runs(tmp_path, "C", {"z": [(1.0, 0.1, 0)] * 5})
    r = run(tmp_path, "D", "C")
    assert r.returncode == 1 and "a missing" in r.stdout


def test_other_seeds(tmp_path):
    """TVO_SEEDS names the seeds read (as tools/seed-runs.sh wrote them); without it the default 5 are
    looked for."""
    seeds = (5, 6, 7, 8, 9)
    write_runs(tmp_path, "D", {"a": [(1.0, 0.1, 0)] * 5}, seeds)
    write_runs(tmp_path, "C", {"a": [(0.9, 0.1, 0)] * 5}, seeds)
    r = run(tmp_path, "D", "C", seeds=seeds)
    assert r.returncode == 0 and "seeds 5, 6, 7, 8, 9" in r.stdout, r.stdout + r.stderr
    r = run(tmp_path, "D", "C")
    assert r.returncode != 0


def spread_runs(n, base, step, lost=0):
    """n runs of one sequence whose figures climb evenly from base by step (a seed spread)."""
    return [(base + k * step, 0.1 * base + k * step * 0.01, lost) for k in range(n)]


def test_null_rate_of_a_change_that_changes_nothing(tmp_path):
    """--null splits one configuration's runs into two groups and judges one by the other: without any
    spread nothing is refused; with a spread the second rule refuses some splits; a candidate made worse
    (--regress) is refused every time by both rules."""
    seeds = tuple(range(10, 40))
    write_runs(tmp_path, "flat", {"a": [(1.0, 0.1, 0)] * 30, "b": [(0.5, 0.05, 0)] * 30}, seeds)
    write_runs(tmp_path, "D", {"a": spread_runs(30, 1.0, 0.01), "b": spread_runs(30, 0.5, 0.02)}, seeds)
    r = run(tmp_path, "flat", "--null", "200", seeds=seeds)
    assert r.returncode == 0 and "refused: 0.0% of the splits" in r.stdout, r.stdout + r.stderr
    r = run(tmp_path, "D", "--null", "500", seeds=seeds)
    share = float(r.stdout.split("refused: ")[1].split("%")[0])
    assert r.returncode == 0 and 20.0 < share < 100.0, r.stdout + r.stderr
    for rule in ("second", "calibrated"):
        r = run(tmp_path, "D", "--null", "200", "--rule", rule, "--group", "15", "--regress", "1.5", seeds=seeds)
        assert "refused: 100.0% of the splits" in r.stdout, (rule, r.stdout + r.stderr)
    r = run(tmp_path, "D", "--null", "200", "--rule", "calibrated", "--group", "15", "--regress", "1.5",
            "--regress-only", "b", seeds=seeds)
    assert "refused: 100.0% of the splits" in r.stdout and "  b rot: 100.0%" in r.stdout, r.stdout
    a = [float(l.split(": ")[1].rstrip("%")) for l in r.stdout.splitlines() if l.startswith("  a ")]
    assert all(x < 5.0 for x in a), r.stdout  # the untouched sequence refuses a split only by chance
    # too few seeds for two groups
    r = run(tmp_path, "D", "--null", "10", "--group", "16", seeds=seeds)
    assert r.returncode != 0 and "at least 32 seeds" in (r.stdout + r.stderr)


def test_calibrated_rule_verdicts(tmp_path):
    """The calibrated rule refuses a candidate whose runs lie clearly above the default's on one cell, or
    whose geometric mean is beyond 1.03 (ATE), and passes one drawn from the same spread."""
    seeds = tuple(range(75, 90))
    write_runs(tmp_path, "D", {"a": spread_runs(15, 1.0, 0.01), "b": spread_runs(15, 0.5, 0.02)}, seeds)
    write_runs(tmp_path, "same", {"a": spread_runs(15, 1.0, 0.01)[::-1], "b": spread_runs(15, 0.5, 0.02)},
               seeds)
    # every run of b above every run of the default: refused on that cell
    write_runs(tmp_path, "above", {"a": spread_runs(15, 0.9, 0.01), "b": spread_runs(15, 0.9, 0.02)}, seeds)
    # within the spread on each cell (p above 0.002) but 4 % worse on the whole
    write_runs(tmp_path, "mean", {"a": spread_runs(15, 1.04, 0.01), "b": spread_runs(15, 0.52, 0.02)}, seeds)
    r = run(tmp_path, "D", "same", "--rule", "calibrated", seeds=seeds)
    assert r.returncode == 0 and "verdict: PASS" in r.stdout, r.stdout + r.stderr
    r = run(tmp_path, "D", "above", "--rule", "calibrated", seeds=seeds)
    assert r.returncode == 1 and "b ate" in r.stdout and "a ate" not in r.stdout.split("verdict")[1], r.stdout
    r = run(tmp_path, "D", "mean", "--rule", "calibrated", seeds=seeds)
    assert r.returncode == 1 and "geometric mean ate" in r.stdout, r.stdout


def test_candidate_seeds_and_bad_options(tmp_path):
    """--candidate-seeds reads the candidate's runs of other seeds; unknown rules, a non-positive number of
    splits or a --null with candidates are usage errors."""
    write_runs(tmp_path, "D", {"a": [(1.0, 0.1, 0)] * 5})
    write_runs(tmp_path, "C", {"a": [(0.9, 0.1, 0)] * 5}, (5, 6, 7, 8, 9))
    r = run(tmp_path, "D", "C", "--candidate-seeds", "5 6 7 8 9")
    assert r.returncode == 0 and "5, 6, 7, 8, 9 (candidate)" in r.stdout, r.stdout + r.stderr
    for bad in (["--rule", "third"], ["--null", "0"], ["--null", "x"], ["--regress", "0"], ["--null", "5", "C"]):
        r = run(tmp_path, "D", *bad)
        assert r.returncode == 2, (bad, r.stdout, r.stderr)
