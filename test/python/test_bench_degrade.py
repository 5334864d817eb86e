# SPDX-License-Identifier: Apache-2.0
"""test/bench/bench_degrade.py's copies on a tiny ASL sequence written here: the frames each copy keeps,
the jerk, reversed, stop and start copies' evenly spaced times, the drops copy's missing frames and their
ground truth moved with their frames, the stop's held frames with fresh noise, the larger copies' frames and
intrinsics, and the refusal of a resized copy of a camera with distortion."""
import os
import pathlib
import sys

import cv2
import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "test" / "bench"))
sys.path.insert(0, str(ROOT / "tools"))
import bench_degrade  # noqa: E402
from tinyvo_tools import trajio  # noqa: E402

N, DT = 40, 50_000_000  # 20 Hz
T0 = 1_000_000_000_000


def _sequence(root: pathlib.Path, distortion=(0.0, 0.0, 0.0, 0.0)) -> pathlib.Path:
    """40 frames (each frame's grey level its index), a camera moving 0.1 m a frame along x."""
    cam = root / "mav0" / "cam0"
    (cam / "data").mkdir(parents=True)
    rows = []
    for k in range(N):
        name = f"{T0 + k * DT}.png"
        cv2.imwrite(str(cam / "data" / name), np.full((24, 32), k, np.uint8))
        rows.append(f"{T0 + k * DT},{name}\n")
    (cam / "data.csv").write_text("#timestamp [ns],filename\n" + "".join(rows))
    info = trajio.CameraInfo(width=32, height=24, intrinsics=(30.0, 30.0, 15.5, 11.5),
                             distortion=tuple(distortion), rate_hz=20, T_BS=np.eye(4))
    trajio.write_sensor_yaml(str(cam / "sensor.yaml"), info)
    gt = root / "mav0" / "state_groundtruth_estimate0"
    gt.mkdir(parents=True)
    t = np.array([T0 + k * DT for k in range(N)], np.int64)
    poses = np.repeat(np.eye(4)[None], N, axis=0)
    poses[:, 0, 3] = 0.1 * np.arange(N)
    trajio.write_euroc_groundtruth(str(gt / "data.csv"), trajio.Trajectory(t, poses))
    return root


def test_kept_frames():
    assert bench_degrade.kept_frames(7, 1) == list(range(7))
    assert bench_degrade.kept_frames(7, 2) == [0, 2, 4, 6]
    keep = bench_degrade.kept_frames(200, 0)
    steps = np.diff(keep)
    assert keep[0] == 0 and set(steps.tolist()) == {1, 2}
    assert 0.3 < np.mean(steps == 2) < 0.7  # both steps, about as often
    assert bench_degrade.kept_frames(200, 0) == keep  # seeded: the same copy every run
    assert bench_degrade.kept_frames(4, -1) == [3, 2, 1, 0]
    assert bench_degrade.kept_frames(4, -2) == [0, 1] + [2] * 50 + [2, 3]  # the middle frame held
    assert bench_degrade.kept_frames(3, -3) == [0] * 30 + [0, 1, 2]  # the first frame held


@pytest.mark.parametrize("name,k", [("stop", N // 2), ("start", 0)])
def test_hold_copy(tmp_path, name, k):
    src = _sequence(tmp_path / "src")
    dst = tmp_path / name
    bench_degrade.write_copy(str(src), str(dst), *bench_degrade.VARIANTS[name])
    hold = bench_degrade.HOLD_FRAMES[bench_degrade.VARIANTS[name][1]]
    t, names = trajio.read_cam_frames(str(dst / "mav0" / "cam0"))
    assert len(names) == N + hold and len(set(names)) == N + hold  # every held copy its own file
    assert (np.diff(t) == DT).all() and t[0] == T0  # evenly spaced at the original rate
    imgs = [cv2.imread(str(dst / "mav0" / "cam0" / "data" / n), cv2.IMREAD_GRAYSCALE).astype(int) for n in names]
    for j in range(N + hold):
        src_k = j if j <= k else (k if j <= k + hold else j - hold)
        assert abs(float(np.mean(imgs[j])) - src_k) < 1.5  # frame j shows the source frame src_k
    assert (imgs[k] == k).all()  # the first of the held frames as it was
    held = imgs[k + 1:k + hold + 1]
    assert all(np.std(h - k) > 1.0 for h in held)  # each held copy with noise (sigma 2)
    assert not (held[0] == held[1]).all()  # fresh noise on each
    gt = trajio.read_euroc_groundtruth(str(dst))
    np.testing.assert_array_equal(gt.t_ns, t)
    x = gt.poses[:, 0, 3]
    np.testing.assert_allclose(x[k:k + hold + 1], 0.1 * k, atol=1e-9)  # standing still
    np.testing.assert_allclose(x[-1], 0.1 * (N - 1), atol=1e-9)


def test_reverse_copy(tmp_path):
    src = _sequence(tmp_path / "src")
    dst = tmp_path / "reverse"
    bench_degrade.write_copy(str(src), str(dst), *bench_degrade.VARIANTS["reverse"])
    t, names = trajio.read_cam_frames(str(dst / "mav0" / "cam0"))
    assert len(names) == N and (np.diff(t) == DT).all() and t[0] == T0
    for j in range(N):
        img = cv2.imread(str(dst / "mav0" / "cam0" / "data" / names[j]), cv2.IMREAD_GRAYSCALE)
        assert int(img[0, 0]) == N - 1 - j  # the last frame first
    gt = trajio.read_euroc_groundtruth(str(dst))
    np.testing.assert_array_equal(gt.t_ns, t)
    np.testing.assert_allclose(gt.poses[:, 0, 3], 0.1 * (N - 1 - np.arange(N)), atol=1e-9)


def test_jerk_copy(tmp_path):
    src = _sequence(tmp_path / "src")
    dst = tmp_path / "jerk"
    bench_degrade.write_copy(str(src), str(dst), *bench_degrade.VARIANTS["jerk"])
    t, names = trajio.read_cam_frames(str(dst / "mav0" / "cam0"))
    keep = bench_degrade.kept_frames(N, 0)
    assert len(names) == len(keep)
    assert (np.diff(t) == DT).all() and t[0] == T0  # evenly spaced at the original rate
    for j, k in enumerate(keep):
        img = cv2.imread(str(dst / "mav0" / "cam0" / "data" / names[j]), cv2.IMREAD_GRAYSCALE)
        assert int(img[0, 0]) == k  # frame j of the copy is frame keep[j] of the source
    gt = trajio.read_euroc_groundtruth(str(dst))
    np.testing.assert_array_equal(gt.t_ns, t)
    np.testing.assert_allclose(gt.poses[:, 0, 3], 0.1 * np.array(keep), atol=1e-9)
    assert trajio.read_sensor_yaml(str(dst / "mav0" / "cam0" / "sensor.yaml")).rate_hz == 20


def test_skip_copy_keeps_times_and_ground_truth(tmp_path):
    src = _sequence(tmp_path / "src")
    dst = tmp_path / "skip2"
    bench_degrade.write_copy(str(src), str(dst), *bench_degrade.VARIANTS["skip2"])
    t, _ = trajio.read_cam_frames(str(dst / "mav0" / "cam0"))
    np.testing.assert_array_equal(t, T0 + DT * np.arange(0, N, 2))
    assert (dst / "mav0" / "state_groundtruth_estimate0" / "data.csv").read_bytes() == \
        (src / "mav0" / "state_groundtruth_estimate0" / "data.csv").read_bytes()


def test_drops_copy_keeps_times_rate_and_ground_truth(tmp_path):
    """The drops copy: seeded frames missing (the first five always kept, a burst of three in the middle
    third), the others at their own times, the rate and the ground truth unchanged."""
    keep = bench_degrade.kept_frames(640, bench_degrade.DROPS)
    assert keep == bench_degrade.kept_frames(640, bench_degrade.DROPS)  # seeded: the same copy every run
    gone = sorted(set(range(640)) - set(keep))
    assert keep[:5] == [0, 1, 2, 3, 4] and 640 // 30 <= len(gone) <= 640 // 15
    assert any(gone[i + 2] - gone[i] == 2 and 640 // 3 <= gone[i] < 2 * 640 // 3 for i in range(len(gone) - 2))
    src = _sequence(tmp_path / "src")
    dst = tmp_path / "drops"
    bench_degrade.write_copy(str(src), str(dst), *bench_degrade.VARIANTS["drops"])
    t, _ = trajio.read_cam_frames(str(dst / "mav0" / "cam0"))
    kept = bench_degrade.kept_frames(N, bench_degrade.DROPS)
    assert len(kept) <= N - 3
    np.testing.assert_array_equal(t, T0 + DT * np.array(kept))
    assert trajio.read_sensor_yaml(str(dst / "mav0" / "cam0" / "sensor.yaml")).rate_hz == 20
    assert (dst / "mav0" / "state_groundtruth_estimate0" / "data.csv").read_bytes() == \
        (src / "mav0" / "state_groundtruth_estimate0" / "data.csv").read_bytes()


def test_jitter_copy_moves_only_the_stamps(tmp_path):
    """The jitter copy: every frame as it was, each stamp but the first and the last moved by at most 10 %
    of the frame interval (seeded, not all the same way), the order kept, the ground truth unchanged."""
    src = _sequence(tmp_path / "src")
    dst = tmp_path / "jitter10"
    bench_degrade.write_copy(str(src), str(dst), *bench_degrade.VARIANTS["jitter10"])
    t, names = trajio.read_cam_frames(str(dst / "mav0" / "cam0"))
    t0, names0 = trajio.read_cam_frames(str(src / "mav0" / "cam0"))
    assert list(names) == list(names0)
    for n in names:
        assert (dst / "mav0" / "cam0" / "data" / n).read_bytes() == (src / "mav0" / "cam0" / "data" / n).read_bytes()
    shift = np.asarray(t, dtype=np.int64) - np.asarray(t0, dtype=np.int64)
    assert shift[0] == 0 and shift[-1] == 0
    assert (np.abs(shift) <= 0.1 * DT).all() and (shift[1:-1] > 0).any() and (shift[1:-1] < 0).any()
    assert (np.diff(t) > 0).all()
    t2 = bench_degrade.jittered_times([int(x) for x in t0])
    np.testing.assert_array_equal(t, t2)  # seeded: the same copy every run
    assert (dst / "mav0" / "state_groundtruth_estimate0" / "data.csv").read_bytes() == \
        (src / "mav0" / "state_groundtruth_estimate0" / "data.csv").read_bytes()


def test_distortion(tmp_path):
    src = _sequence(tmp_path / "src", distortion=(-0.28, 0.07, 0.0002, 0.00002))
    bench_degrade.write_copy(str(src), str(tmp_path / "jerk"), *bench_degrade.VARIANTS["jerk"])
    info = trajio.read_sensor_yaml(str(tmp_path / "jerk" / "mav0" / "cam0" / "sensor.yaml"))
    assert tuple(info.distortion) == (-0.28, 0.07, 0.0002, 0.00002)  # the lens kept
    with pytest.raises(SystemExit, match="distortion"):
        bench_degrade.write_copy(str(src), str(tmp_path / "half"), *bench_degrade.VARIANTS["half"])
    assert not os.path.exists(tmp_path / "half" / "mav0" / "cam0" / "data.csv")


@pytest.mark.parametrize("name,scale", [("up15", 1.5), ("up2", 2.0)])
def test_larger_copy_scales_frames_and_intrinsics(tmp_path, name, scale):
    src = _sequence(tmp_path / "src")
    dst = tmp_path / name
    bench_degrade.write_copy(str(src), str(dst), *bench_degrade.VARIANTS[name])
    cam = dst / "mav0" / "cam0"
    t, names = trajio.read_cam_frames(str(cam))
    assert len(names) == N and t[0] == T0
    w, h = round(32 * scale), round(24 * scale)
    for k in (0, N - 1):
        img = cv2.imread(str(cam / "data" / names[k]), cv2.IMREAD_GRAYSCALE)
        assert img.shape == (h, w) and (img == k).all()  # a flat frame stays flat through INTER_CUBIC
    info = trajio.read_sensor_yaml(str(cam / "sensor.yaml"))
    assert (info.width, info.height) == (w, h)
    # the same rays: pixel centres scale about (-0.5, -0.5)
    np.testing.assert_allclose(info.intrinsics, (30.0 * scale, 30.0 * scale, 16.0 * scale - 0.5, 12.0 * scale - 0.5))
    assert (dst / "mav0" / "state_groundtruth_estimate0" / "data.csv").read_bytes() == \
        (src / "mav0" / "state_groundtruth_estimate0" / "data.csv").read_bytes()
