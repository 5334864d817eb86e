# SPDX-License-Identifier: Apache-2.0
"""tinyvo-lenscheck (tinyvo_tools.lenscheck): the adjustment finds a radial coefficient or a focal length
that is off, finds none when the calibration is right, tells when the run's two halves disagree, refuses a
run without translation, and its command line reports bad input. On synthetic tracks (no replay): a camera flying a curve through a field of points, the tracks the
points' exact projections through EuRoC's lens plus 0.1 px of noise, and the trajectory the truth's."""
import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from tinyvo_tools import cli, lenscheck, synth, trajio

ROOT = pathlib.Path(__file__).resolve().parents[2]
BUILD = pathlib.Path(os.environ.get("TVO_BUILD_DIR", ROOT / "build" / "release"))
REPLAY = BUILD / "examples" / "replay" / "tvo_replay"


def _rot_y(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _scene(seed=3, frames=60, translate=True, noise=0.1, later_lens=None):
    """(camera, trajectory of camera poses T_w_c, tracks t, id, xy) for a camera 0.1 m a frame along a
    curve, turning 0.6 degrees a frame, among points 3-12 m ahead; later_lens: the camera that makes the
    second half's tracks (a lens that changed half-way)."""
    rng = np.random.default_rng(seed)
    cam = trajio.CameraInfo()
    W, H = cam.width, cam.height
    pts = np.column_stack([rng.uniform(-8, 8, 3000), rng.uniform(-3, 3, 3000), rng.uniform(3, 18, 3000)])
    poses, t_ns = [], []
    for f in range(frames):
        T = np.eye(4)
        T[:3, :3] = _rot_y(np.radians(0.6 * f))
        T[:3, 3] = [0.1 * f * translate, 0.02 * np.sin(f / 7.0) * translate, 0.05 * f * translate]
        poses.append(T)
        t_ns.append(1_000_000_000 + 50_000_000 * f)
    traj = trajio.Trajectory(np.array(t_ns), np.array(poses), "camera")
    rows_t, rows_id, rows_xy = [], [], []
    for f, (T, t) in enumerate(zip(poses, t_ns)):
        T_c_w = trajio.inv_pose(T)
        Xc = pts @ T_c_w[:3, :3].T + T_c_w[:3, 3]
        front = Xc[:, 2] > 0.5
        uv = np.full((len(pts), 2), -1.0)
        uv[front] = synth.project_points(later_lens if later_lens and f >= frames // 2 else cam, Xc[front])
        inside = front & (uv[:, 0] > 2) & (uv[:, 0] < W - 3) & (uv[:, 1] > 2) & (uv[:, 1] < H - 3)
        idx = np.nonzero(inside)[0]
        rows_t.append(np.full(len(idx), t, np.int64))
        rows_id.append(idx.astype(np.int64))
        rows_xy.append(uv[idx] + rng.normal(0, noise, (len(idx), 2)))
    return cam, traj, np.concatenate(rows_t), np.concatenate(rows_id), np.concatenate(rows_xy)


def _with_k1(cam, dk1, f_scale=1.0):
    d = list(cam.distortion)
    d[0] += dk1
    fu, fv, cu, cv = cam.intrinsics
    return trajio.CameraInfo(cam.width, cam.height, (f_scale * fu, f_scale * fv, cu, cv), cam.distortion_model,
                             tuple(d))


def test_finds_a_radial_coefficient_that_is_off():
    cam, traj, t, ids, xy = _scene()
    r = lenscheck.check(_with_k1(cam, 0.005), traj, t, ids, xy, n_key=20, max_points=600)
    c = r["change"]["k1"]
    assert c["value"] == pytest.approx(-0.005, abs=4e-4), r
    assert abs(c["value"]) > 10 * c["stderr"]
    # with the coefficient free the tracks are explained to their noise (0.1 px a coordinate: a median
    # error of about 0.118 px); with it fixed the outer ring's error is half as large again
    assert r["freed"]["all"]["median_px"] < 0.125
    assert r["calibrated"]["outer"]["median_px"] > 1.5 * r["freed"]["outer"]["median_px"]
    assert r["shift_px"]["corners"] > r["shift_px"]["side_edges"] > 1.0


def test_finds_nothing_when_the_lens_is_right():
    cam, traj, t, ids, xy = _scene()
    r = lenscheck.check(cam, traj, t, ids, xy, n_key=20, max_points=600)
    c = r["change"]["k1"]
    assert abs(c["value"]) < 5e-4 and abs(c["value"]) < 4 * c["stderr"] + 1e-5, r
    assert r["freed"]["all"]["median_px"] == pytest.approx(r["calibrated"]["all"]["median_px"], rel=0.05)
    assert r["shift_px"]["side_edges"] < 0.3


def test_a_camera_without_distortion():
    """A sensor.yaml with no distortion model: the check starts from zero coefficients."""
    cam, traj, t, ids, xy = _scene()
    none = trajio.CameraInfo(cam.width, cam.height, cam.intrinsics, "none", ())
    r = lenscheck.check(none, traj, t, ids, xy, n_key=20, max_points=600)
    assert r["model"] == "radial-tangential" and r["distortion"] == [0.0, 0.0, 0.0, 0.0]
    # the tracks went through EuRoC's lens (k1 -0.283): freeing k1 alone takes a good part of it
    assert r["change"]["k1"]["value"] < -0.1 and r["freed"]["all"]["median_px"] < r["calibrated"]["all"]["median_px"]


def test_two_coefficients():
    cam, traj, t, ids, xy = _scene()
    r = lenscheck.check(_with_k1(cam, -0.004), traj, t, ids, xy, n_key=20, max_points=600, free=2)
    assert set(r["change"]) == {"k1", "k2"}
    assert r["change"]["k1"]["value"] == pytest.approx(0.004, abs=3e-4), r
    assert abs(r["change"]["k2"]["value"]) < 4 * r["change"]["k2"]["stderr"] + 1e-5, r
    assert r["freed"]["all"]["median_px"] < 0.125


def test_focal_length_and_radial_coefficients():
    """A calibration whose focal length is 1 % long and whose k1 is 0.004 off: both found, the halves agree;
    with the calibration right, neither moves."""
    cam, traj, t, ids, xy = _scene()
    r = lenscheck.check(_with_k1(cam, 0.004, 1.01), traj, t, ids, xy, n_key=20, max_points=600,
                        free=("f", "k1", "k2"))
    assert set(r["change"]) == {"f", "k1", "k2"}
    assert r["change"]["f"]["value"] == pytest.approx(1 / 1.01 - 1, abs=1e-3), r  # back to the true focal
    assert r["change"]["k1"]["value"] == pytest.approx(-0.004, abs=5e-4), r
    assert r["freed"]["all"]["median_px"] < 0.125 < r["calibrated"]["all"]["median_px"]
    assert r["consistent"] and r["halves"]["disagreement_sigmas"] <= lenscheck.AGREE_SIGMAS
    r = lenscheck.check(cam, traj, t, ids, xy, n_key=20, max_points=600, free=("f", "k1"))
    assert abs(r["change"]["f"]["value"]) < 4 * r["change"]["f"]["stderr"] + 1e-5, r
    assert abs(r["change"]["k1"]["value"]) < 4 * r["change"]["k1"]["stderr"] + 1e-5, r


def test_halves_that_disagree():
    """The lens changes half-way (k1 0.006 apart): the whole run's estimate is a compromise, its standard
    error small, and only the halves show that it fits neither."""
    cam, traj, t, ids, xy = _scene(later_lens=_with_k1(trajio.CameraInfo(), 0.006))
    r = lenscheck.check(cam, traj, t, ids, xy, n_key=20, max_points=600)
    first, second = (h["k1"]["value"] for h in r["halves"]["changes"])
    assert first == pytest.approx(0.0, abs=6e-4) and second == pytest.approx(0.006, abs=6e-4), r
    assert not r["consistent"] and r["halves"]["disagreement_sigmas"] > 10, r
    assert r["halves"]["apart_px"] > r["halves"]["limit_px"], r
    assert "DISAGREE" in lenscheck.format_report(r)
    # without the halves (halves=False) nothing is said about them
    assert "consistent" not in lenscheck.check(cam, traj, t, ids, xy, n_key=20, max_points=600, halves=False)


def test_halves_that_differ_by_little_next_to_the_change():
    """The lens is off by 0.0050 in the first half and 0.0044 in the second: with little noise the estimates are
    many standard errors apart, but their models lie close next to the change itself, so they agree."""
    off = _with_k1(trajio.CameraInfo(), 0.005)
    cam, traj, t, ids, xy = _scene(noise=0.02, later_lens=_with_k1(trajio.CameraInfo(), 0.0006))
    r = lenscheck.check(off, traj, t, ids, xy, n_key=20, max_points=600)
    h = r["halves"]
    assert h["disagreement_sigmas"] > lenscheck.AGREE_SIGMAS, r
    assert h["apart_px"] < h["limit_px"] and r["consistent"], r
    assert "they agree" in lenscheck.format_report(r)


def test_halves_that_cannot_be_adjusted():
    """Poses for the first half of the run only: the whole run is adjusted on its posed frames, the second
    half has none, so the halves are not compared and the estimate is not called consistent."""
    cam, traj, t, ids, xy = _scene()
    half = trajio.Trajectory(traj.t_ns[:30], traj.poses[:30], "camera")
    r = lenscheck.check(_with_k1(cam, 0.005), half, t, ids, xy, n_key=20, max_points=600)
    assert r["change"]["k1"]["value"] == pytest.approx(-0.005, abs=6e-4), r
    assert r["halves"]["disagreement_sigmas"] is None and "nothing to adjust" in r["halves"]["reason"]
    assert r["consistent"] is False
    assert "not checked" in lenscheck.format_report(r)


def test_parse_free():
    assert lenscheck.parse_free("k1") == ("k1",)
    assert lenscheck.parse_free("k1k2") == ("k1", "k2")
    assert lenscheck.parse_free("k2, f,k1") == ("f", "k1", "k2")
    for bad in ("k3", "", "k1,,k2"):
        with pytest.raises(ValueError):
            lenscheck.parse_free(bad)


def test_a_camera_that_only_turns_is_refused():
    cam, traj, t, ids, xy = _scene(translate=False)
    with pytest.raises(cli.Failure, match="translation"):
        lenscheck.check(cam, traj, t, ids, xy, n_key=20)


def test_frames_without_poses_are_refused():
    cam, traj, t, ids, xy = _scene()
    far = trajio.Trajectory(traj.t_ns + 10_000_000_000, traj.poses, "camera")
    with pytest.raises(cli.Failure, match="nothing to adjust"):
        lenscheck.check(cam, far, t, ids, xy)


def test_read_tracks(tmp_path):
    p = tmp_path / "tracks.csv"
    p.write_text("t_ns,id,x,y,age,flags\n1000000000000000001,3,1.50,2.25,4,3\n")
    t, ids, xy = lenscheck.read_tracks(str(p))
    assert t.tolist() == [1000000000000000001] and ids.tolist() == [3] and xy.tolist() == [[1.5, 2.25]]
    p.write_text("t_ns,id,x,y\n1,2,3,4\n")
    with pytest.raises(cli.Failure, match="6 columns"):
        lenscheck.read_tracks(str(p))
    with pytest.raises(cli.Failure, match="cannot read"):
        lenscheck.read_tracks(str(tmp_path / "missing.csv"))


def _run(*args):
    return subprocess.run([sys.executable, "-m", "tinyvo_tools.lenscheck", *args], capture_output=True, text=True,
                          cwd=ROOT / "tools")


def test_command_line_errors(tmp_path):
    r = _run("--replay", "x")
    assert r.returncode == 2 and r.stderr.startswith("tinyvo-lenscheck: error:") and "--seq" in r.stderr
    r = _run("--seq", str(tmp_path), "--replay", "x", "--keyframes", "2")
    assert r.returncode == 2 and "--keyframes" in r.stderr
    r = _run("--seq", str(tmp_path), "--replay", "x", "--free", "k1,k3")
    assert r.returncode == 2 and "unknown parameter 'k3'" in r.stderr
    r = _run("--seq", str(tmp_path), "--replay", "x", "--free", "f")
    assert r.returncode == 2 and "f needs k1" in r.stderr
    r = _run("--seq", str(tmp_path), "--replay", "x")
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "sensor.yaml" in r.stderr
    seq = tmp_path / "seq" / "mav0" / "cam0"
    seq.mkdir(parents=True)
    trajio.write_sensor_yaml(str(seq / "sensor.yaml"), trajio.CameraInfo())
    r = _run("--seq", str(tmp_path / "seq"), "--replay", str(tmp_path / "no-such-binary"))
    assert r.returncode == 1 and "not an executable" in r.stderr


def test_end_to_end_on_a_render(tmp_path):
    """tvo_replay on a short render whose sensor.yaml has k1 0.006 off: the check finds the change."""
    if not REPLAY.exists():
        pytest.fail(f"{REPLAY} not built (set TVO_BUILD_DIR)")
    seq = tmp_path / "seq"
    assert synth.main(["--out", str(seq), "--builtin", "handheld", "--frames", "150", "--quiet"]) == 0
    yaml = seq / "mav0" / "cam0" / "sensor.yaml"
    cam = trajio.read_sensor_yaml(str(yaml))
    trajio.write_sensor_yaml(str(yaml), trajio.CameraInfo(cam.width, cam.height, cam.intrinsics,
                                                          cam.distortion_model,
                                                          tuple(np.add(cam.distortion, [0.006, 0, 0, 0])),
                                                          cam.rate_hz, cam.T_BS, cam.comment))
    out, fixed = tmp_path / "r.json", tmp_path / "fixed.yaml"
    r = _run("--seq", str(seq), "--replay", str(REPLAY), "--keyframes", "25", "--out", str(out),
             "--write-yaml", str(fixed))
    assert r.returncode == 0, r.stderr
    assert "estimated change of k1" in r.stdout and "they agree" in r.stdout
    res = json.loads(out.read_text())
    assert res["consistent"] is True
    assert res["change"]["k1"]["value"] == pytest.approx(-0.006, abs=1.5e-3), res
    # the written calibration: the sequence's with the change applied, and the replay reads it
    new = trajio.read_sensor_yaml(str(fixed))
    assert new.distortion[0] == pytest.approx(cam.distortion[0] + 0.006 + res["change"]["k1"]["value"], abs=1e-12)
    assert tuple(new.distortion[1:]) == pytest.approx(tuple(cam.distortion[1:]), abs=1e-12)
    assert (new.width, new.height, tuple(new.intrinsics)) == (cam.width, cam.height, tuple(cam.intrinsics))
    p = subprocess.run([str(REPLAY), "--euroc", str(seq), "--calib", str(fixed), "--max-frames", "5",
                        "--out", str(tmp_path / "t.txt"), "--quiet"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
