# SPDX-License-Identifier: Apache-2.0
"""End to end on real car frames: tvo_replay with the local map and its own scale (--scale none) over the
shared KITTI sequences (ASL layout, in the data folder given by TVO_DATA_DIR; skipped without it),
evaluated by tinyvo_tools.eval (evo, Sim(3) ATE). The thresholds are what the current code meets with
margin (measured figures in the comments, and in docs/evaluation.md with the command)."""
import json
import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
REPLAY = pathlib.Path(os.environ.get("TVO_BUILD_DIR", ROOT / "build" / "release")) / "examples" / "replay" / "tvo_replay"
DATA = pathlib.Path(os.environ.get("TVO_DATA_DIR", ROOT.parent / "shared" / "data"))

# sequence: (max ATE Sim(3) m, max per-frame rotation RPE deg, frames, max frames before the map starts).
# Measured with the default seed, and over RANSAC seeds 75-89 (tools/seed-runs.sh, docs/rules.md). KITTI 01's
# map waits for 100 landmarks (the default 300 tracks / 3) and starts at frame 33; with 40 it started at
# frames 18-23 on a weaker pair and its ATE ranged from 0.38 to 0.80 m with the seed.
CASES = {
    # KITTI 07 with its lens refined on the run (the default): measured 0.216 m, 0.034 deg (15 seeds: 0.215-0.250
    # m; with the published lens, lens_refine=0: 0.423 m, 15 seeds 0.336-0.436 m); map at frame 6
    "kitti07_160": (0.32, 0.045, 160, 15),
    "kitti06_51": (0.07, 0.070, 51, 10),    # measured 0.034 m, 0.058 deg (15 seeds: 0.031-0.034 m); map at frame 1
    "kitti01_51": (0.20, 0.055, 51, 40),    # measured 0.112 m, 0.043 deg (15 seeds: 0.104-0.136 m, 0.042-0.044 deg)
}


def _kitti(name):
    """The shared KITTI sequence `name` (the test skips without it); fails when tvo_replay is not built."""
    seq = DATA / "kitti" / name
    if not seq.is_dir():
        pytest.skip(f"{seq} not found (set TVO_DATA_DIR to the shared data folder)")
    if not REPLAY.exists():
        pytest.fail(f"{REPLAY} not built (set TVO_BUILD_DIR)")
    return seq


def _replay_eval(seq, tmp_path, *args):
    """tvo_replay --scale none over seq (args added), then tinyvo_tools.eval against its ground truth:
    (stats, eval)."""
    traj, stats, ev = tmp_path / "traj.txt", tmp_path / "stats.json", tmp_path / "eval.json"
    subprocess.run([str(REPLAY), "--euroc", str(seq), "--out", str(traj), "--scale", "none",
                    "--stats", str(stats), "--quiet", *args], check=True)
    subprocess.run([sys.executable, "-m", "tinyvo_tools.eval", "--est", str(traj), "--gt", str(seq),
                    "--out", str(ev), "--quiet"], check=True, stdout=subprocess.DEVNULL)
    return json.loads(stats.read_text()), json.loads(ev.read_text())


@pytest.mark.parametrize("name", sorted(CASES))
def test_kitti_own_scale(name, tmp_path):
    seq = _kitti(name)
    max_ate, max_rot, frames, max_wait = CASES[name]
    st, e = _replay_eval(seq, tmp_path)
    assert st["frames"]["processed"] == frames
    assert st["map"]["enabled"] == 1
    assert st["map"]["losses"] == 0
    # the map starts once, within max_wait frames, and poses every frame after its first two keyframes
    states = st["map"]["states"]
    assert states["initialised"] == 1
    assert states["initialising"] <= max_wait
    assert states["tracking"] == frames - states["initialising"] - 1
    assert e["standard"]["alignment"]["type"] == "sim3"
    assert e["standard"]["ate_m"]["rmse"] < max_ate
    assert e["standard"]["rpe_frame"]["rotation_deg"]["rmse"] < max_rot


def test_kitti01_ground_truth_scale_before_the_map(tmp_path):
    """KITTI 01's map starts at frame 33 (highway, little parallax); with --scale gt the 33 frames before
    it take the ground truth's step lengths (the trajectory stood still there: 9.75 m SE(3) ATE)."""
    seq = _kitti("kitti01_51")
    traj, ev = tmp_path / "traj.txt", tmp_path / "eval.json"
    subprocess.run([str(REPLAY), "--euroc", str(seq), "--out", str(traj), "--scale", "gt", "--quiet"], check=True)
    subprocess.run([sys.executable, "-m", "tinyvo_tools.eval", "--est", str(traj), "--gt", str(seq), "--out", str(ev),
                    "--metric-scale", "--quiet"], check=True, stdout=subprocess.DEVNULL)
    e = json.loads(ev.read_text())
    assert e["standard"]["alignment"]["type"] == "se3"
    assert e["standard"]["ate_m"]["rmse"] < 0.3  # measured 0.115 m


def test_kitti07_reversed_keeps_map(tmp_path):
    """KITTI 07 driven backwards (bench_degrade.py's reversed copy): backing through the first turn the
    landmarks leave the view faster than the car moves the baseline a keyframe normally needs; near a loss
    (fewer than 2 x map_min_points landmarks) the map makes a keyframe anyway and keeps going. Measured:
    0.299 m, no loss (with the lens as published 0.555 m; with the baseline rule enforced there: one loss,
    1.39 m; docs/rules.md, "A twenty-first rule")."""
    seq = _kitti("kitti07_160")
    sys.path.insert(0, str(ROOT / "test" / "bench"))
    import bench_degrade  # noqa: E402  (beside the benchmarks)
    copy = tmp_path / "reverse"
    bench_degrade.write_copy(str(seq), str(copy), 1.0, -1, 0.0, 0.0)
    st, e = _replay_eval(copy, tmp_path)
    assert st["frames"]["processed"] == 160
    assert st["frames"]["lost"] == 0
    assert st["map"]["losses"] == 0
    assert e["standard"]["ate_m"]["rmse"] < 0.9


@pytest.mark.parametrize("name,max_lost", [("drops", 1), ("jitter10", 0)])
def test_kitti01_dropped_frames_and_jittered_stamps(name, max_lost, tmp_path):
    """KITTI 01 (33 frames before its map) with 1 frame in 25 dropped, and with every stamp moved by up to
    10 % of the frame interval (bench_degrade.py's copies): before the map the chain counts frames by the
    first interval, so a frame after dropped ones steps further and jittered stamps change nothing.
    Measured 0.114 m and 0.111 m (counting every frame as one unit: 2.35 m on the drops; timing the steps
    exactly: 0.447 m on the jitter; docs/rules.md, "A fifty-fifth rule" to "A fifty-seventh rule")."""
    seq = _kitti("kitti01_51")
    sys.path.insert(0, str(ROOT / "test" / "bench"))
    import bench_degrade  # noqa: E402  (beside the benchmarks)
    copy = tmp_path / name
    bench_degrade.write_copy(str(seq), str(copy), *bench_degrade.VARIANTS[name])
    st, e = _replay_eval(copy, tmp_path)
    assert st["frames"]["lost"] <= max_lost
    assert st["map"]["losses"] == 0
    assert e["standard"]["ate_m"]["rmse"] < 0.2


def test_kitti01_untrusted_pose_drawn_again(tmp_path):
    """KITTI 01 at RANSAC seed 78: frame 22's relative pose (the highway's far points at 0.28 deg of
    parallax) comes out low-confidence from that seed's draw, and the rotation-only fallback cannot hold a
    car moving forward. The VO draws the pose again with derived seeds and keeps the frame (it was lost:
    ATE 0.304 m, rotation RPE 0.381 deg; measured with the redraw 0.111 m, 0.043 deg; docs/rules.md, "A
    forty-seventh rule")."""
    seq = _kitti("kitti01_51")
    st, e = _replay_eval(seq, tmp_path, "--set", "relpose.seed=78")
    assert st["frames"]["lost"] == 0
    assert st["status"]["lost"] == 0
    assert e["standard"]["ate_m"]["rmse"] < 0.2
    assert e["standard"]["rpe_frame"]["rotation_deg"]["rmse"] < 0.055


def test_kitti07_lens_refined_on_the_run(tmp_path):
    """KITTI 07's published lens is off (tinyvo-lenscheck over the whole run: k1 +0.0256, k2 -0.0091;
    docs/camera.md). With lens_refine (the default) the map's windows find the change on the run and adopt
    it once two windows agree (measured at the replay's seed: k1 +0.0236, k2 -0.0084 at 4.9 s of 16.5 s; ATE
    0.216 m against 0.423 m with the published lens, lens_refine=0; docs/rules.md, "A forty-eighth rule")."""
    seq = _kitti("kitti07_160")
    st, e = _replay_eval(seq, tmp_path)
    assert st["lens"]["refine"] == 1
    assert st["lens"]["updates"] >= 1
    assert 0.015 < st["lens"]["dk1"] < 0.035
    assert -0.02 < st["lens"]["dk2"] < 0.0
    assert st["map"]["losses"] == 0
    off = tmp_path / "off"
    off.mkdir()
    st0, e0 = _replay_eval(seq, off, "--set", "lens_refine=0")
    assert st0["lens"]["refine"] == 0 and st0["lens"]["updates"] == 0
    assert e["standard"]["ate_m"]["rmse"] < 0.7 * e0["standard"]["ate_m"]["rmse"]
    assert e["standard"]["rpe_frame"]["rotation_deg"]["rmse"] < 1.05 * e0["standard"]["rpe_frame"]["rotation_deg"]["rmse"]


@pytest.mark.parametrize("name", ["kitti01_51", "kitti06_51"])
def test_kitti_lens_not_changed_without_evidence(name, tmp_path):
    """KITTI 01's lens estimate is wrong (the whole run's halves disagree by 27 standard errors, and every
    estimate made its replay worse), KITTI 06's windows are loose (51 frames of a straight road): with
    lens_refine (the default) neither changes its lens. KITTI 01's 51 frames end before the map has two windows of its
    own; test_lens.c's drift test is where blocks like its windows' are refused."""
    seq = _kitti(name)
    st, _ = _replay_eval(seq, tmp_path)
    assert st["lens"]["refine"] == 1
    assert st["lens"]["updates"] == 0
    assert st["lens"]["dk1"] == 0.0 and st["lens"]["dk2"] == 0.0


def test_kitti07_dark_copy_thresholds_follow_the_exposure(tmp_path):
    """KITTI 07 with every grey level times 0.12 (bench_exposure.py's dark12 copy: a camera out of exposure
    range in a dim scene). With the FAST thresholds fixed the frames hold too few corners for a first map
    until frame 118 (measured: ATE 0.763 m); with fast_range_ref=255 they follow the frame's grey-level
    range and the map starts at frame 8, as on the clean frames (measured: 0.202 m, no loss; docs/rules.md,
    "A forty-ninth rule")."""
    seq = _kitti("kitti07_160")
    sys.path.insert(0, str(ROOT / "test" / "bench"))
    import bench_exposure  # noqa: E402  (beside the benchmarks)
    copy = tmp_path / "dark12"
    bench_exposure.write_copy(str(seq), str(copy), bench_exposure.GAINS["dark12"])
    on = tmp_path / "on"
    on.mkdir()
    st, e = _replay_eval(copy, on, "--set", "fast_range_ref=255")
    assert st["frames"]["lost"] == 0 and st["map"]["losses"] == 0
    assert st["map"]["states"]["initialising"] <= 15
    assert e["standard"]["ate_m"]["rmse"] < 0.32
    off = tmp_path / "off"
    off.mkdir()
    st0, _ = _replay_eval(copy, off, "--set", "fast_range_ref=0")
    assert st0["map"]["states"]["initialising"] > 60
