# SPDX-License-Identifier: Apache-2.0
"""tinyvo_tools.suite on a tiny rendered sequence with the real tvo_replay: the table, the JSON rows (taken
from the replay's stats and from tinyvo_tools.eval), folder expansion, the skipping of an irregular
(keyframe) folder, the alignment per scale mode, --repeat, and the refusals."""
import json
import math
import os
import pathlib
import shutil
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
REPLAY = pathlib.Path(os.environ.get("TVO_BUILD_DIR", ROOT / "build" / "release")) / "examples" / "replay" / "tvo_replay"


def suite(*args):
    return subprocess.run([sys.executable, "-m", "tinyvo_tools.suite", *map(str, args)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.fixture(scope="module")
def seqs(tmp_path_factory):
    if not REPLAY.exists():
        pytest.fail(f"{REPLAY} not built (set TVO_BUILD_DIR)")
    d = tmp_path_factory.mktemp("suite")
    root = d / "seqs"
    line = root / "line"
    subprocess.run([sys.executable, "-m", "tinyvo_tools.synth", "--out", str(line), "--builtin", "line",
                    "--frames", "20", "--quiet"], check=True)
    # a "keyframes" folder: the same frames, but only every 4th one, so that every interval is 4 periods
    kf = d / "kf"
    shutil.copytree(line, kf)
    csv = kf / "mav0" / "cam0" / "data.csv"
    rows = csv.read_text().splitlines()
    csv.write_text("\n".join([rows[0]] + rows[1::4]) + "\n")
    return d, line, kf


def test_table_and_json_none(seqs, tmp_path):
    d, line, _ = seqs
    out = tmp_path / "r.json"
    p = suite("--replay", REPLAY, "--seq", d / "seqs", "--scale", "none", "--out", out, "--keep", tmp_path / "k")
    assert p.returncode == 0, p.stderr
    res = json.loads(out.read_text())
    assert [r["name"] for r in res["sequences"]] == ["line"]  # the folder of sequences was expanded
    r = res["sequences"][0]
    stats = json.loads((tmp_path / "k" / "line" / "stats.json").read_text())
    ev = json.loads((tmp_path / "k" / "line" / "eval.json").read_text())
    assert r["frames"] == stats["frames"]["processed"] == 20
    assert r["lost"] == stats["frames"]["lost"]
    assert r["median_ms"] == pytest.approx(stats["timing_us"]["total"]["median"] / 1e3)
    assert r["p90_ms"] == pytest.approx(stats["timing_us"]["total"]["p90"] / 1e3)
    assert r["alignment"] == ev["standard"]["alignment"]["type"] == "sim3"
    assert r["ate_m"] == ev["standard"]["ate_m"]["rmse"]
    assert r["rpe_rot_deg"] == ev["standard"]["rpe_frame"]["rotation_deg"]["rmse"]
    assert math.isfinite(r["ate_m"]) and 0 <= r["ate_m"] < 0.2
    assert 0 < r["median_ms"] <= r["p90_ms"]
    assert res["total"]["frames"] == 20 and res["total"]["failed"] == 0
    assert res["total"]["mean_ate_m"] == r["ate_m"]
    # the printed table: a header naming the alignment, the row and the total with the same figures
    lines = p.stdout.splitlines()
    assert any("ATE Sim(3) m" in ln for ln in lines)
    row = next(ln for ln in lines if ln.startswith("line "))
    f = row.split()
    assert f[1] == "20" and float(f[2]) == pytest.approx(r["ate_m"], abs=1e-4)
    assert float(f[3]) == pytest.approx(r["rpe_rot_deg"], abs=1e-3) and int(f[4]) == r["lost"]
    # the shares of tracks kept: the replay's counts, each share within [0, 100] % and in the row
    tr = stats["tracks"]
    assert 0 <= tr["new_kept"] <= tr["new"] and 0 < tr["old_kept"] <= tr["old"]
    assert r["kept_old"] == tr["old_kept"] / tr["old"]
    assert float(f[8]) == pytest.approx(100 * r["kept_old"], abs=0.05)
    if tr["new"] > 0:
        assert float(f[7]) == pytest.approx(100 * r["kept_new"], abs=0.05)
    else:
        assert r["kept_new"] is None and f[7] == "-"
    assert any(ln.startswith("total ") and ln.split()[1] == "20" for ln in lines)


def test_metric_mode_se3_repeat_and_keyframes_skipped(seqs, tmp_path):
    _, line, kf = seqs
    out = tmp_path / "r.json"
    p = suite("--replay", REPLAY, "--seq", line, "--seq", kf, "--scale", "gt", "--repeat", "2", "--out", out)
    assert p.returncode == 0, p.stderr
    assert "skipping" in p.stderr and str(kf) in p.stderr and "not a regular sequence" in p.stderr
    res = json.loads(out.read_text())
    assert len(res["sequences"]) == 1 and res["skipped"][0]["path"] == str(kf)
    r = res["sequences"][0]
    assert r["alignment"] == "se3" and "ATE SE(3) m" in p.stdout
    assert len(r["runs_ms"]) == 2 and not r.get("nondeterministic")
    # ground-truth step lengths on a straight walk: metric and close to the truth
    assert r["ate_m"] < 0.05
    assert r["command"][r["command"].index("--scale") + 1] == "gt"


def test_extra_args_reach_the_replay_and_failures_are_rows(seqs, tmp_path):
    _, line, _ = seqs
    out = tmp_path / "r.json"
    p = suite("--replay", REPLAY, "--seq", line, "--out", out, "--", "--max-frames", "12")
    assert p.returncode == 0, p.stderr
    assert json.loads(out.read_text())["sequences"][0]["frames"] == 12
    p = suite("--replay", REPLAY, "--seq", line, "--scale", "model", "--out", out, "--", "--model",
              tmp_path / "missing.tvonn")
    assert p.returncode == 1
    r = json.loads(out.read_text())["sequences"][0]
    assert r["error"].startswith("tvo_replay exit") and "FAILED" in p.stdout


def test_refusals(seqs, tmp_path):
    _, line, kf = seqs
    # usage errors: exit 2
    for args in (["--seq", line, "--", "--scale", "gt"],        # the suite sets --scale itself
                 ["--seq", line, "--repeat", "0"]):
        p = suite("--replay", REPLAY, *args)
        assert p.returncode == 2, args
    # runtime errors (missing or unusable inputs): exit 1, one line
    for args in (["--seq", tmp_path / "nowhere"],
                 ["--seq", kf],                                  # nothing left to run
                 ["--seq", tmp_path]):                           # no sequence in it
        p = suite("--replay", REPLAY, *args)
        assert p.returncode == 1, args
    p = suite("--replay", tmp_path / "no_replay", "--seq", line)
    assert p.returncode == 1 and "not an executable" in p.stderr and len(p.stderr.strip().splitlines()) == 1
