# SPDX-License-Identifier: Apache-2.0
"""test/bench/bench_dso.py around a stand-in for DSO's dso_dataset (a shell script that writes a given
result.txt and log): DSO's poses back on the sequence's own timestamps, the summary of a run that never
initialised (an empty result.txt) and of one that did, a result time that matches no frame refused, and
the camera.txt of a pinhole camera cropped to multiples of 16."""
import json
import os
import pathlib
import stat
import subprocess
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "test" / "bench"))
sys.path.insert(0, str(ROOT / "tools"))
import bench_dso  # noqa: E402
from tinyvo_tools import trajio  # noqa: E402

T0, DT, N = 2_000_000_000_000, 50_000_000, 5  # 20 Hz

FAKE_DSO = """#!/bin/sh
# stands in for dso_dataset: copies $FAKE_DSO_RESULT to result.txt in the working folder
echo "RESETTING!"
cat "$FAKE_DSO_RESULT" > result.txt
echo "======= 12.5ms per frame (single core) ======="
"""


def _sequence(root: pathlib.Path) -> pathlib.Path:
    """An ASL folder of N frames (the PNG bytes are never read: DSO gets symlinks)."""
    cam = root / "mav0" / "cam0"
    (cam / "data").mkdir(parents=True)
    names = [f"{T0 + k * DT}.png" for k in range(N)]
    for name in names:
        (cam / "data" / name).write_bytes(b"")
    (cam / "data.csv").write_text("#timestamp [ns],filename\n" + "".join(f"{n[:-4]},{n}\n" for n in names))
    info = trajio.CameraInfo(width=40, height=36, intrinsics=(30.0, 31.0, 19.5, 17.5),
                             distortion=(0.0, 0.0, 0.0, 0.0), rate_hz=20, T_BS=np.eye(4))
    trajio.write_sensor_yaml(str(cam / "sensor.yaml"), info)
    return root


def _run(tmp_path, result_text: str):
    seq = _sequence(tmp_path / "seq")
    fake = tmp_path / "dso_dataset"
    fake.write_text(FAKE_DSO)
    fake.chmod(fake.stat().st_mode | stat.S_IXUSR)
    result = tmp_path / "result_in.txt"
    result.write_text(result_text)
    out = tmp_path / "out"
    env = dict(os.environ, FAKE_DSO_RESULT=str(result))
    proc = subprocess.run([sys.executable, str(ROOT / "test" / "bench" / "bench_dso.py"), "--dso-bin", str(fake),
                           "--seq", str(seq), "--preset", "0", "--out", str(out)],
                          env=env, capture_output=True, text=True)
    return proc, out


def test_never_initialised(tmp_path):
    proc, out = _run(tmp_path, "")
    assert proc.returncode == 0, proc.stderr
    assert (out / "traj.txt").read_text() == ""
    s = json.loads((out / "summary.json").read_text())
    assert s["initialised"] is False and s["frames_posed"] == 0 and s["first_posed"] is None
    assert s["dso_ms_per_frame"] is None and s["resets"] == 1
    assert "never initialised" in proc.stdout


def test_poses_on_the_sequence_times(tmp_path):
    # frames 0, 2, 3 (seconds since the first frame), the camera moving along x, turned 90 deg about z at 3
    rows = ["0.000000 0 0 0 0 0 0 1", "0.100000 0.5 0 0 0 0 0 1",
            "0.150000 1.5 0 0 0 0 0.70710678118 0.70710678118"]
    proc, out = _run(tmp_path, "\n".join(rows) + "\n")
    assert proc.returncode == 0, proc.stderr
    traj = trajio.read_tum(str(out / "traj.txt"))
    assert traj.t_ns.tolist() == [T0, T0 + 2 * DT, T0 + 3 * DT]
    assert np.allclose(traj.poses[:, 0, 3], [0.0, 0.5, 1.5])
    assert np.allclose(traj.poses[2, :3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-9)
    s = json.loads((out / "summary.json").read_text())
    assert s["initialised"] is True and s["frames_posed"] == 3
    assert (s["first_posed"], s["tracking_from"], s["last_posed"]) == (0, 2, 3)
    assert s["dso_ms_per_frame"] == 12.5 and s["frames"] == N and s["output_size"] == [32, 32]
    assert sorted(os.listdir(out / "images")) == [f"{k}.png" for k in range(N)]


def test_time_of_no_frame_refused(tmp_path):
    proc, _ = _run(tmp_path, "0.000000 0 0 0 0 0 0 1\n0.120000 0 0 0 0 0 0 1\n")
    assert proc.returncode != 0
    assert "matches no frame" in proc.stderr


def test_pinhole_camera_txt():
    info = trajio.CameraInfo(width=40, height=36, intrinsics=(30.0, 31.0, 19.5, 17.5),
                             distortion=(0.0, 0.0, 0.0, 0.0))
    text, size = bench_dso.camera_txt(info, None)
    lines = text.splitlines()
    assert size == (32, 32) and lines[1] == "40 36" and lines[3] == "32 32"
    assert lines[0].split()[0] == "Pinhole"
    # centred crop by (4, 2) px: DSO's relative output intrinsics give back the same focal and the shifted
    # centre, K = (f w, f h, c w - 0.5, c h - 0.5)
    fx, fy, cx, cy, _ = (float(v) for v in lines[2].split())
    assert np.allclose([fx * 32, fy * 32, cx * 32 - 0.5, cy * 32 - 0.5], [30.0, 31.0, 15.5, 15.5])
