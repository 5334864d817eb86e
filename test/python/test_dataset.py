# SPDX-License-Identifier: Apache-2.0
"""Tests of tinyvo_tools.dataset (features csv + ground truth -> training pairs) and of the pieces of
tinyvo_tools.tables that do not need training. Fast: a fake features csv and a generated trajectory; the
end-to-end test with tvo_replay on a tiny rendered sequence runs only when the replay binary is built."""
import os

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tinyvo_tools import dataset as ds
from tinyvo_tools import nnfmt, synth, tables, trajio
from tinyvo_tools.trajio import Trajectory

# a camera mount that is neither identity nor EuRoC's, so a wrong T_BS shows
T_BS = np.eye(4)
T_BS[:3, :3] = Rotation.from_euler("zyx", [90, 5, -10], degrees=True).as_matrix()
T_BS[:3, 3] = [0.05, -0.03, 0.02]


def write_sequence(root, n=60, seed=1):
    """EuRoC layout: ground truth (body) + cam0/sensor.yaml with T_BS. Returns the body trajectory."""
    g = synth.builtin_trajectory("handheld", n, seed=seed)
    mav = os.path.join(root, "mav0")
    os.makedirs(os.path.join(mav, "cam0"), exist_ok=True)
    os.makedirs(os.path.join(mav, "state_groundtruth_estimate0"), exist_ok=True)
    trajio.write_sensor_yaml(os.path.join(mav, "cam0", "sensor.yaml"), trajio.CameraInfo(T_BS=T_BS))
    trajio.write_euroc_groundtruth(os.path.join(mav, "state_groundtruth_estimate0", "data.csv"), g)
    return g


def write_features(path, t_ns, states, feats=None):
    feats = np.zeros((len(t_ns), nnfmt.FEAT_COUNT)) if feats is None else feats
    with open(path, "w") as f:
        f.write(",".join(ds.CSV_COLUMNS) + "\n")
        for t, s, x in zip(t_ns, states, feats):
            f.write(f"{int(t)},{s},0,0,10," + ",".join(f"{v:.9g}" for v in x) + "\n")


def test_targets_are_relative_camera_poses(tmp_path):
    g = write_sequence(str(tmp_path / "SEQ"))
    # image times between ground-truth rows (interpolation), one frame skipped by the VO
    t = g.t_ns[5:40].copy() + 1000
    t = np.delete(t, 10)
    states = [1] + [0] * (len(t) - 1)
    states[5] = 2   # rotation-only: kept
    states[7] = 3   # lost: dropped
    states[8] = 1   # initialising: dropped
    feats = np.random.default_rng(0).normal(size=(len(t), nnfmt.FEAT_COUNT))
    csv = str(tmp_path / "f.csv")
    write_features(csv, t, states, feats)
    data = ds.build([str(tmp_path / "SEQ") + ":" + csv], str(tmp_path / "work"), replay=None, log=lambda s: None)
    kept = [k for k in range(1, len(t)) if states[k] in (0, 2)]
    assert len(data["features"]) == len(kept)
    assert set(data["sequence"].tolist()) == {"SEQ"}
    np.testing.assert_allclose(data["features"], feats[kept].astype(np.float32))
    Twc = trajio.interpolate_poses(g.t_ns, g.poses, t) @ T_BS
    for row, k in enumerate(kept):
        T = trajio.inv_pose(Twc[k - 1]) @ Twc[k]   # prev = previous csv row, even across a skipped frame
        np.testing.assert_allclose(data["targets"][row, :3], T[:3, 3], atol=1e-6)
        np.testing.assert_allclose(data["targets"][row, 3:], Rotation.from_matrix(T[:3, :3]).as_rotvec(), atol=1e-6)
    # the step across the skipped frame is twice as long in time
    assert np.isclose(data["dt_gt"][kept.index(10)], (t[10] - t[9]) * 1e-9)
    # T_BS matters: body-frame relative translations differ from the camera-frame targets
    Twb = trajio.interpolate_poses(g.t_ns, g.poses, t)
    Tb = trajio.inv_pose(Twb[kept[3] - 1]) @ Twb[kept[3]]
    assert np.linalg.norm(Tb[:3, 3] - data["targets"][3, :3]) > 1e-4


def test_rows_outside_groundtruth_are_dropped(tmp_path):
    g = write_sequence(str(tmp_path / "SEQ"), n=30)
    t = np.concatenate([[g.t_ns[0] - 10**8], g.t_ns[:10], [g.t_ns[-1] + 10**8]])
    csv = str(tmp_path / "f.csv")
    write_features(csv, t, [0] * len(t))
    data = ds.build([str(tmp_path / "SEQ") + ":" + csv], str(tmp_path / "w"), log=lambda s: None)
    assert len(data["features"]) == 9  # rows 2..10; row 1 (prev before gt) and the last are dropped


def test_malformed_features_csv(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("t_ns,state\n123,0,0\n")
    with pytest.raises(ValueError):
        ds.read_features_csv(str(p))
    p.write_text(",".join(["1"] * 4) + ",x" + ",0" * 11 + "\n")
    with pytest.raises(ValueError):
        ds.read_features_csv(str(p))
    write_sequence(str(tmp_path / "SEQ"), n=20)
    g = trajio.read_euroc_groundtruth(str(tmp_path / "SEQ/mav0/state_groundtruth_estimate0/data.csv"))
    f = {"t_ns": np.array([5, 3], np.int64), "state": np.zeros(2, int), "features": np.zeros((2, 11))}
    with pytest.raises(ValueError):
        ds.pair_sequence(f, g, T_BS)


def test_features_csv_relative_scale_columns(tmp_path):
    """tvo_replay's csv with the rel_scale columns is read (and carried into the dataset); the older
    16-column files read as 'not available'; a NaN or negative rel_scale or a wrong column count is refused."""
    g = write_sequence(str(tmp_path / "SEQ"), n=30)
    t = g.t_ns[2:12] + 1000
    head = ",".join(ds.CSV_COLUMNS + ds.CSV_EXTRA)
    rows = [f"{int(x)},0,0,0,10," + ",".join(["0.5"] * nnfmt.FEAT_COUNT) + f",{0.9 + 0.01 * k:.9g},{40 + k}"
            for k, x in enumerate(t)]
    p = tmp_path / "new.csv"
    p.write_text(head + "\n" + "\n".join(rows) + "\n")
    fr = ds.read_features_csv(str(p))
    np.testing.assert_allclose(fr["rel_scale"], 0.9 + 0.01 * np.arange(len(t)))
    assert fr["rel_scale_points"].tolist() == list(range(40, 40 + len(t)))
    data = ds.build([str(tmp_path / "SEQ") + ":" + str(p)], str(tmp_path / "w"), log=lambda s: None)
    np.testing.assert_allclose(data["rel_scale"], (0.9 + 0.01 * np.arange(len(t)))[1:])
    old = tmp_path / "old.csv"
    write_features(str(old), t, [0] * len(t))
    fo = ds.read_features_csv(str(old))
    assert np.all(fo["rel_scale"] == 0) and np.all(fo["rel_scale_points"] == 0)
    for bad in ("nan", "-1"):
        q = tmp_path / f"bad_{bad}.csv"
        q.write_text(rows[0].rsplit(",", 2)[0] + f",{bad},3\n")
        with pytest.raises(ValueError):
            ds.read_features_csv(str(q))
    q = tmp_path / "bad_cols.csv"
    q.write_text(rows[0] + ",7\n")
    with pytest.raises(ValueError):
        ds.read_features_csv(str(q))


def test_dataset_roundtrip_is_trainer_readable(tmp_path):
    from tinyvo_tools import train
    g = write_sequence(str(tmp_path / "SEQ"), n=40)
    csv = str(tmp_path / "f.csv")
    write_features(csv, g.t_ns[:30], [0] * 30, np.random.default_rng(1).normal(size=(30, 11)))
    data = ds.build([str(tmp_path / "SEQ") + ":" + csv], str(tmp_path / "w"), log=lambda s: None)
    out = str(tmp_path / "d.npz")
    ds.save(out, data)
    f, t, s = train.load_dataset(out)
    assert f.shape == (29, 11) and t.shape == (29, 6) and list(set(s)) == ["SEQ"]


def test_constant_step_and_baselines(tmp_path):
    g = synth.builtin_trajectory("line", 20, seed=0).to_camera(np.eye(4))
    unit = g.poses.copy()
    unit[:, :3, 3] = unit[0, :3, 3] + (unit[:, :3, 3] - unit[0, :3, 3]) / 0.02
    trajio.write_tum(str(tmp_path / "u.txt"), Trajectory(g.t_ns, unit, "camera"))
    tables.constant_step_traj(str(tmp_path / "u.txt"), str(tmp_path / "c.txt"), 0.02)
    c = trajio.read_tum(str(tmp_path / "c.txt"), "camera")
    np.testing.assert_allclose(c.poses[:, :3, 3], g.poses[:, :3, 3], atol=1e-5)
    feat = np.zeros((2, 11))
    feat[:, 3:6] = [[0, 0, 1], [1, 0, 0]]
    feat[:, 0:3] = 0.01
    targ = np.array([[0, 0, 0.5, 0.01, 0.01, 0.01], [0.2, 0, 0, 0.01, 0.01, 0.02]])
    gts, cst = tables.step_baselines(feat, targ, 0.1)
    np.testing.assert_allclose(gts[:, :3], targ[:, :3])
    np.testing.assert_allclose(cst[:, :3], [[0, 0, 0.1], [0.1, 0, 0]])
    r = tables.step_rmse(gts, targ)
    assert r["tx"] == 0 and r["rx"] == 0 and np.isclose(r["rz"], np.degrees(0.01) / np.sqrt(2))


@pytest.mark.skipif(ds.default_replay() is None, reason="tvo_replay not built (build/*/examples/replay)")
def test_end_to_end_on_tiny_render(tmp_path):
    root = str(tmp_path / "R")
    synth.render_sequence(root, synth.builtin_trajectory("handheld", 10, seed=3), 10, seed=3, progress=False)
    data = ds.build([root], str(tmp_path / "w"), ds.default_replay(), log=lambda s: None)
    assert 0 < len(data["features"]) <= 9
    assert np.all(np.isfinite(data["features"])) and np.all(np.isfinite(data["targets"]))
    # the raw VO translation direction agrees with the ground-truth direction on ok frames
    ok = data["state"] == 0
    if ok.sum() >= 3:
        u = data["features"][ok, 3:6]
        gdir = data["targets"][ok, :3] / np.linalg.norm(data["targets"][ok, :3], axis=1, keepdims=True)
        assert np.median(np.sum(u * gdir, axis=1)) > 0.8


def test_speedup_sequence(tmp_path):
    src = str(tmp_path / "SEQ")
    g = write_sequence(src, n=40)
    cam = os.path.join(src, "mav0", "cam0")
    os.makedirs(os.path.join(cam, "data"), exist_ok=True)
    t = g.t_ns[:30]
    with open(os.path.join(cam, "data.csv"), "w") as f:
        f.write("#timestamp [ns],filename\n")
        for x in t:
            f.write(f"{x},{x}.png\n")
    dst = ds.speedup_sequence(src, str(tmp_path / "SEQ_x2"), 2)
    rows = [ln.strip().split(",") for ln in open(os.path.join(dst, "mav0/cam0/data.csv")) if not ln.startswith("#")]
    assert len(rows) == 15 and rows[1][1] == f"{t[2]}.png"
    t2 = np.array([int(r[0]) for r in rows])
    assert np.all(np.diff(t2) == (t[2] - t[0]) // 2)           # same frame rate as the source
    g2 = trajio.read_euroc_groundtruth(os.path.join(dst, "mav0/state_groundtruth_estimate0/data.csv"))
    p_src = trajio.interpolate_poses(g.t_ns, g.poses, t[::2])
    p_dst = trajio.interpolate_poses(g2.t_ns, g2.poses, t2)
    np.testing.assert_allclose(p_dst, p_src, atol=1e-6)          # same poses, twice as fast
    assert os.path.isdir(os.path.join(dst, "mav0/cam0/data"))
    np.testing.assert_allclose(trajio.read_sensor_yaml(os.path.join(dst, "mav0/cam0/sensor.yaml")).T_BS, T_BS)
    with pytest.raises(ValueError):
        ds.speedup_sequence(src, str(tmp_path / "bad"), 1)
