# SPDX-License-Identifier: Apache-2.0
"""tinyvo_tools.steprules on tiny data: two 16-frame rendered sequences, their dataset and features from
the real tvo_replay, each rule with one seed and one epoch, the oracle with the shipped step model. Checks
the tables, results.json (candidates, figures, passing and chosen consistent with the rule) and refusals."""
import json
import math
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
REPLAY = pathlib.Path(os.environ.get("TVO_BUILD_DIR", ROOT / "build" / "release")) / "examples" / "replay" / "tvo_replay"
MODEL = ROOT / "models" / "tinyvo_synth_euroc_logstep_relu.tvonn"


def run(*args):
    return subprocess.run([sys.executable, "-m", "tinyvo_tools.steprules", *map(str, args)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    if not REPLAY.exists():
        pytest.fail(f"{REPLAY} not built (set TVO_BUILD_DIR)")
    d = tmp_path_factory.mktemp("steprules")
    seqs = d / "seq"
    for name, builtin, seed in (("A", "line", 0), ("B", "handheld", 1)):
        subprocess.run([sys.executable, "-m", "tinyvo_tools.synth", "--out", str(seqs / name), "--builtin", builtin,
                        "--frames", "16", "--seed", str(seed), "--quiet"], check=True)
    subprocess.run([sys.executable, "-m", "tinyvo_tools.dataset", *[str(seqs / n) for n in "AB"],
                    "-o", str(d / "ds.npz"), "--replay", str(REPLAY), "--work", str(d / "feat")],
                   check=True, stdout=subprocess.DEVNULL)
    return d


SMALL = ["--train", "A,B", "--seeds", "0", "--epochs", "1", "--joint-epochs", "0", "--jobs", "1"]


def _common(d, out):
    return ["--dataset", d / "ds.npz", "--features", d / "feat", "--seq-root", d / "seq", "--out", out]


def test_domain_rule(data, tmp_path):
    p = run("domain", *_common(data, tmp_path), *SMALL)
    assert p.returncode == 0, p.stderr
    res = json.loads((tmp_path / "results.json").read_text())
    c = res["candidates"]
    assert set(c) == {f"{d}/{k}" for d in (0.5, 1.0, 2.0) for k in ("layer", "channel")}
    for v in c.values():
        assert len(v["runs"]) == 1 and len(v["runs"][0]) == 2            # one seed, two held-out sequences
        assert all(math.isfinite(v[k]) and v[k] >= 0 for k in ("gap", "rmse", "ate_f", "ate_q"))
    ref = c["0.5/layer"]
    want = [k for k, v in c.items() if v["gap"] < 1.6 and v["ate_q"] <= 1.02 * ref["ate_q"]
            and v["rmse"] <= 1.01 * ref["rmse"]]
    assert res["passing"] == want
    assert res["chosen"] == (min(want, key=lambda k: c[k]["ate_q"]) if want else None)
    assert p.stdout.count("\n| ") >= 6 and "chosen:" in p.stdout
    assert (tmp_path / "A.s0.d2.0.layer.int8.txt").is_file()


def test_copies_rule(data, tmp_path):
    p = run("copies", *_common(data, tmp_path), *SMALL, "--domain", "1")
    assert p.returncode == 0, p.stderr
    res = json.loads((tmp_path / "results.json").read_text())
    c = res["candidates"]
    assert list(c) == ["1,1,1", "1,1,2", "1,2,1", "1,2,2", "2,2,2", "1,4,4"] and res["domain"] == 1.0
    assert c["1,1,1"]["macs"] < c["1,1,2"]["macs"] < c["1,2,1"]["macs"]   # copies cost MACs
    want = [k for k, v in c.items() if v["gap"] <= 1.2 and abs(v["ate_q"] - v["ate_f"]) <= 0.01 * v["ate_f"]]
    assert res["passing"] == want
    assert res["chosen"] == (min(want, key=lambda k: c[k]["macs"]) if want else None)
    # the float model is the same for every candidate: the same float ATE
    assert len({round(v["ate_f"], 12) for v in c.values()}) == 1


def test_oracle(data, tmp_path):
    p = run("oracle", "--features", data / "feat", "--seq-root", data / "seq", "--out", tmp_path,
            "--train", "A", "--val", "B", "--model", MODEL)
    assert p.returncode == 0, p.stderr
    res = json.loads((tmp_path / "results.json").read_text())
    ate = res["ate_se3_m"]
    assert ate["ground-truth step"]["B"] < ate["training mean step (the constant prior)"]["B"] + 1e-9
    assert all(math.isfinite(v["B"]) for v in ate.values())
    assert res["const_step_m"] > 0 and "B" in res["log_error"]
    assert "| ground-truth step |" in p.stdout


def test_refusals(data, tmp_path):
    assert run("domain", *_common(data, tmp_path), "--train", "A,Z", "--seeds", "0", "--epochs", "1",
               "--jobs", "1").returncode == 2                             # no rows of Z
    assert run("copies", *_common(data, tmp_path), *SMALL[:2], "--epochs", "0").returncode == 2
    assert run("oracle", "--features", data / "feat", "--seq-root", data / "seq", "--out", tmp_path).returncode == 2
    assert run("--help").returncode == 0 and "domain" in run("--help").stdout
