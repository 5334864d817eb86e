# SPDX-License-Identifier: Apache-2.0
"""test/bench/bench_track_survival.py: its counts on hand-made tracks (kept means the same id one age
older in the next frame; bands by the row before the step; nothing carried into an empty frame), and on
a short rendered sequence with the real tvo_replay, whose stats it must match (it exits 1 otherwise)."""
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "test" / "bench"))
import bench_track_survival as bts  # noqa: E402

REPLAY = pathlib.Path(os.environ.get("TVO_BUILD_DIR", ROOT / "build" / "release")) / "examples" / "replay" / "tvo_replay"


def test_counts_by_band():
    frames = [
        {1: (10.0, 0), 2: (90.0, 0), 3: (50.0, 4)},  # two new tracks (top, bottom band), one old
        {1: (12.0, 1), 3: (52.0, 5), 4: (95.0, 0)},  # 1 and 3 kept, 2 lost, 4 new
        {},                                          # re-initialised: 1, 3 and 4 not carried
        {7: (20.0, 0)},
        {7: (21.0, 0)},                              # the same id at age 0 again: not a kept track
    ]
    c = bts.survival(frames, 100, 2)
    assert c["new"] == [[1 + 1, 1], [1 + 1, 0]]  # top: 1 kept, 7 not; bottom: 2 and 4 lost
    assert c["old"] == [[1, 0], [2, 1]]          # 1 lost at age 1; 3 (row 50: bottom) kept, then lost
    one = bts.survival(frames, 100, 1)
    assert one["new"] == [[4, 1]] and one["old"] == [[3, 1]]
    # a row on or past the last one still falls in the last band
    assert bts.survival([{1: (100.0, 0)}, {1: (99.0, 1)}], 100, 4)["new"][3] == [1, 1]


def test_read_tracks_orders_frames_by_time(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("t_ns,id,x,y,age,flags\n20,5,1.0,2.5,1,0\n10,5,1.0,2.0,0,0\n10,6,3.0,4.0,3,1\n")
    assert bts.read_tracks(str(p)) == [{5: (2.0, 0), 6: (4.0, 3)}, {5: (2.5, 1)}]


def test_replay_counts_match(tmp_path):
    if not REPLAY.exists():
        pytest.fail(f"{REPLAY} not built (set TVO_BUILD_DIR)")
    seq = tmp_path / "line"
    subprocess.run([sys.executable, "-m", "tinyvo_tools.synth", "--out", str(seq), "--builtin", "line",
                    "--frames", "20", "--quiet"], check=True, cwd=ROOT / "tools")
    p = subprocess.run([sys.executable, str(ROOT / "test" / "bench" / "bench_track_survival.py"), "--seq",
                        str(seq), "--replay", str(REPLAY), "--bands", "3"],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    assert lines[0].startswith("line: 20 frames")
    body = [ln.split() for ln in lines[2:]]
    assert len(body) == 4 and body[-1][0] == "all"
    # old tracks of the rendered line are kept nearly all; the band counts add up to the total
    olds = [int(r[-1]) for r in body]
    assert sum(olds[:3]) == olds[3] > 0 and float(body[-1][-4]) > 90.0
    bad = subprocess.run([sys.executable, str(ROOT / "test" / "bench" / "bench_track_survival.py"), "--seq",
                          str(seq), "--replay", str(REPLAY), "--bands", "0"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert bad.returncode == 2 and "--bands" in bad.stderr
