# SPDX-License-Identifier: Apache-2.0
"""tools/flight-rule.py, the whole-flight condition of docs/rules.md, on synthetic runs: the threshold is
the 99th percentile of the default's do-nothing splits, and a candidate passes only with (a) a geometric
mean within it, (b) every median within the default's largest run, (c) no more map losses."""
import json
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
RULE = ROOT / "tools" / "flight-rule.py"
NULL = tuple(range(75, 85))
SEEDS = tuple(range(80, 85))


def write_run(d, label, flight, seed, ate, losses=0):
    base = d / f"{label}_{flight}_s{seed}"
    (base.parent / (base.name + ".eval.json")).write_text(json.dumps({"standard": {"ate_m": {"rmse": ate}}}))
    (base.parent / (base.name + ".stats.json")).write_text(json.dumps({"map": {"losses": losses}}))


def write_default(d):
    """Two flights whose 10 runs spread evenly: A 0.040-0.058 m, B 0.010-0.019 m."""
    for k, seed in enumerate(NULL):
        write_run(d, "D", "A", seed, 0.040 + 0.002 * k)
        write_run(d, "D", "B", seed, 0.010 + 0.001 * k)


# Two flights whose runs lie within 2 % of one another but one, the last of each (a run that went wrong):
# a narrow do-nothing spread and a wide largest run
NARROW = (1.00, 1.01, 0.99, 1.02, 0.98, 1.00, 1.01, 0.99, 1.02, 1.30)


def write_narrow_default(d):
    for k, seed in enumerate(NULL):
        write_run(d, "D", "A", seed, 0.05 * NARROW[k])
        write_run(d, "D", "B", seed, 0.01 * NARROW[k])


def write_candidate(d, label, a, b, losses=0):
    for k, seed in enumerate(SEEDS):
        write_run(d, label, "A", seed, a[k], losses if k == 0 else 0)
        write_run(d, label, "B", seed, b[k])


def run(d, *args):
    return subprocess.run([sys.executable, str(RULE), str(d), *args], capture_output=True, text=True)


def test_threshold_is_the_defaults_own_spread(tmp_path):
    write_default(tmp_path)
    write_candidate(tmp_path, "same", [0.050, 0.052, 0.054, 0.056, 0.058], [0.015, 0.016, 0.017, 0.018, 0.019])
    r = run(tmp_path, "D", "same")
    assert r.returncode == 0 and "verdict: PASS" in r.stdout, r.stdout + r.stderr
    # 252 splits of 10 runs into two groups of 5; by symmetry half of them lie above 1
    assert "splits of seeds 75 76 77 78 79 80 81 82 83 84: 252" in r.stdout
    assert "above 1: 126" in r.stdout
    thr = float(r.stdout.split("threshold (99th percentile) ")[1].split()[0])
    assert 1.2 < thr < 2.0, r.stdout  # this spread is wide: a small change passes (a)


def test_each_condition_refuses(tmp_path):
    write_narrow_default(tmp_path)
    # (a): both flights 15 % worse: within the default's largest runs (b), far above its spread as a whole
    write_candidate(tmp_path, "worse", [0.05 * 1.15] * 5, [0.01 * 1.15] * 5)
    # (b): one flight's median above the default's largest run, the other much better
    write_candidate(tmp_path, "spike", [0.07] * 5, [0.005] * 5)
    # (c): one more map loss, the figures the default's
    write_candidate(tmp_path, "lost", [0.05] * 5, [0.01] * 5, losses=1)
    for label, line in (("worse", "(a) geometric mean"), ("spike", "(b) every median"), ("lost", "(c) map losses")):
        r = run(tmp_path, "D", label)
        assert r.returncode == 1 and "verdict: FAIL" in r.stdout, (label, r.stdout + r.stderr)
        assert [ln for ln in r.stdout.splitlines() if ln.startswith(line)][0].endswith("FAIL"), (label, r.stdout)


def test_bad_input(tmp_path):
    assert run(tmp_path, "D", "C").returncode == 2  # no runs at all
    write_default(tmp_path)
    assert run(tmp_path, "D", "C", "--null-seeds", "75 76 77").returncode == 2  # an odd number of null seeds
    assert run(tmp_path, "D", "C", "--seeds").returncode == 2
    r = run(tmp_path, "D", "C")  # the candidate's runs are missing
    assert r.returncode == 1 and "C missing" in r.stdout
