# SPDX-License-Identifier: Apache-2.0
"""Tests of tinyvo_tools.eval: standard metrics (evo), per-DoF RPE, the paper protocol, T_BS, CLI."""
import json
import pathlib

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tinyvo_tools import eval as tev
from tinyvo_tools import synth, trajio
from tinyvo_tools.trajio import Trajectory, EUROC_CAM0_T_BS


def gt_body(n=200, seed=0):
    return synth.builtin_trajectory("handheld", n, seed=seed)


def cam(traj):
    return traj.to_camera(EUROC_CAM0_T_BS)


def euroc_folder(d, g):
    """A EuRoC folder at d holding ground truth g and the default camera's sensor.yaml."""
    (d / "mav0" / "state_groundtruth_estimate0").mkdir(parents=True)
    (d / "mav0" / "cam0").mkdir(parents=True)
    trajio.write_euroc_groundtruth(str(d / "mav0" / "state_groundtruth_estimate0" / "data.csv"), g)
    trajio.write_sensor_yaml(str(d / "mav0" / "cam0" / "sensor.yaml"), trajio.CameraInfo())
    return d


def test_gt_against_itself_is_zero():
    g = gt_body()
    ev = tev.evaluate(cam(g), g)
    s = ev.result["standard"]
    assert s["ate_m"]["rmse"] < 1e-9 and s["ate_rotation_deg"]["rmse"] < 1e-6
    assert s["rpe_frame"]["translation_m"]["rmse"] < 1e-9
    assert s["rpe_1m"]["translation_m"]["rmse"] < 1e-9
    for d in tev.DOFS:
        assert s["rpe_per_dof"][d]["rmse"] < 1e-6
    assert ev.result["paper_protocol"]["mean_translation_error_m"] < 1e-9
    assert ev.result["poses"]["associated"] == 200
    assert s["alignment"]["scale"] == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("metric", [False, True])
def test_known_perturbation_gives_known_ate(metric):
    # every pose twice; the copies are pushed +d and -d along world z: the offsets e have zero mean and
    # no correlation with the positions g, so Umeyama's rotation is the identity; SE(3): ATE RMSE = d;
    # Sim(3): scale s = var_g / (var_g + d^2), ATE^2 = (1 - s)^2 var_g + s^2 d^2
    g = gt_body(150)
    poses = np.repeat(g.poses, 2, axis=0)
    t_ns = g.t_ns[0] + np.arange(len(poses), dtype=np.int64) * 25_000_000
    gt = Trajectory(t_ns, poses)
    est = cam(gt)
    d = 0.05
    est.poses[0::2, 2, 3] += d
    est.poses[1::2, 2, 3] -= d
    ev = tev.evaluate(est, gt, metric_scale=metric)
    s = ev.result["standard"]
    assert s["alignment"]["type"] == ("se3" if metric else "sim3")
    gp = cam(gt).poses[:, :3, 3]
    var_g = np.mean(np.sum((gp - gp.mean(0)) ** 2, axis=1))
    sc = 1.0 if metric else var_g / (var_g + d * d)
    assert s["alignment"]["scale"] == pytest.approx(sc, rel=1e-9)
    assert s["ate_m"]["rmse"] == pytest.approx(np.sqrt((1 - sc) ** 2 * var_g + sc * sc * d * d), rel=1e-6)
    if metric:
        assert s["ate_m"]["rmse"] == pytest.approx(d, rel=1e-9) and s["ate_m"]["max"] == pytest.approx(d, rel=1e-9)


def test_known_step_error_gives_known_rpe():
    g = gt_body(120)
    G = cam(g).poses
    rel = trajio.inv_pose(G[:-1]) @ G[1:]
    delta = np.eye(4)
    delta[0, 3] = 0.01  # 1 cm extra along camera x every frame
    E = [G[0]]
    for r in rel:
        E.append(E[-1] @ r @ delta)
    est = Trajectory(g.t_ns, np.array(E))
    ev = tev.evaluate(est, g, metric_scale=True)
    s = ev.result["standard"]
    assert s["rpe_frame"]["translation_m"]["rmse"] == pytest.approx(0.01, rel=1e-6)
    assert s["rpe_frame"]["translation_m"]["min"] == pytest.approx(0.01, rel=1e-6)
    assert s["rpe_frame"]["rotation_deg"]["rmse"] < 1e-6
    dof = s["rpe_per_dof"]
    assert dof["tx"]["rmse"] == pytest.approx(0.01, rel=1e-6) and dof["tx"]["mean"] == pytest.approx(0.01, rel=1e-6)
    for d in ("ty", "tz", "rx", "ry", "rz"):
        assert dof[d]["rmse"] < 1e-6
    assert s["ate_m"]["rmse"] > 0.05  # the drift shows up in the ATE


def test_per_dof_rotation_components():
    g = gt_body(60)
    G = cam(g).poses
    rel = trajio.inv_pose(G[:-1]) @ G[1:]
    dR = np.eye(4)
    dR[:3, :3] = Rotation.from_rotvec(np.radians([0.0, 0.5, 0.0])).as_matrix()
    E = [G[0]]
    for r in rel:
        E.append(E[-1] @ r @ dR)
    err = tev.per_dof_errors(G, np.array(E))
    assert np.allclose(err[:, 4], 0.5, atol=1e-9) and np.allclose(err[:, [0, 1, 2, 3, 5]], 0, atol=1e-9)


def test_sim3_invariance_of_a_scaled_copy():
    g = gt_body(200)
    c = cam(g)
    s, R, t = 3.7, Rotation.from_rotvec([0.3, -1.2, 0.5]).as_matrix(), np.array([5.0, -2.0, 1.0])
    S = np.eye(4)
    S[:3, :3], S[:3, 3] = R, t
    P = S @ c.poses
    P[:, :3, 3] = (R @ c.poses[:, :3, 3].T).T * s + t  # scaled positions, rotated orientations
    est = Trajectory(g.t_ns, P)
    sim = tev.evaluate(est, g).result["standard"]
    assert sim["ate_m"]["rmse"] < 1e-8
    assert sim["alignment"]["scale"] == pytest.approx(1.0 / s, rel=1e-9)
    assert sim["rpe_frame"]["translation_m"]["rmse"] < 1e-8
    se3 = tev.evaluate(est, g, metric_scale=True).result["standard"]
    assert se3["ate_m"]["rmse"] > 0.5


def test_paper_protocol_is_labelled_unaligned_and_known():
    g = gt_body(101)
    c = cam(g)
    # a rigid copy far away: re-anchoring at the first gt pose removes it (no alignment needed)
    S = np.eye(4)
    S[:3, :3] = Rotation.from_rotvec([0, 0, 1.0]).as_matrix()
    S[:3, 3] = [10, 0, 0]
    pp = tev.evaluate(Trajectory(g.t_ns, S @ c.poses), g).result["paper_protocol"]
    assert pp["mean_translation_error_m"] < 1e-9
    # a world drift of k * delta per frame: mean error = |delta| * mean(k) = |delta| * (N - 1) / 2
    P = c.poses.copy()
    delta = np.array([0.002, -0.001, 0.0005])
    P[:, :3, 3] += np.arange(101)[:, None] * delta
    res = tev.evaluate(Trajectory(g.t_ns, P), g).result
    pp = res["paper_protocol"]
    assert pp["mean_translation_error_m"] == pytest.approx(np.linalg.norm(delta) * 50, rel=1e-9)
    assert pp["aligned"] is False and "NO alignment" in pp["label"] and "first ground-truth pose" in pp["label"]
    assert res["standard"]["ate_m"]["rmse"] < pp["mean_translation_error_m"]  # the aligned ATE differs
    # no scale correction in the paper protocol
    P = c.poses.copy()
    P[:, :3, 3] *= 2.0
    assert tev.evaluate(Trajectory(g.t_ns, P), g).result["paper_protocol"]["mean_translation_error_m"] > 0.1


def test_tbs_is_applied():
    g = gt_body(100)
    est = cam(g)
    assert tev.evaluate(est, g, T_BS=EUROC_CAM0_T_BS, metric_scale=True).result["standard"]["ate_m"]["rmse"] < 1e-9
    off = tev.evaluate(est, g, T_BS=np.eye(4), metric_scale=True).result["standard"]
    assert off["ate_m"]["rmse"] > 1e-3 or off["ate_rotation_deg"]["rmse"] > 1.0
    body = tev.evaluate(g, g, frame="body").result["standard"]
    assert body["ate_m"]["rmse"] < 1e-9


def test_scale_parts_see_a_drifting_scale_and_not_a_constant_one():
    g = gt_body(400)
    c = cam(g)
    # one scale for the whole run (and a rotated, shifted world): every part's scale is the whole run's
    P = c.poses.copy()
    P[:, :3, 3] = c.poses[:, :3, 3] * 0.25 + np.array([1.0, 2.0, 3.0])
    sp = tev.evaluate(Trajectory(g.t_ns, P), g).result["standard"]["scale_parts"]
    assert len(sp) == 4 and all(v == pytest.approx(1.0, abs=1e-9) for v in sp)
    # the estimate's steps shrink from 1x to 0.5x over the run: metres per estimate unit grow part by part
    steps = np.diff(c.poses[:, :3, 3], axis=0) * np.linspace(1.0, 0.5, len(g) - 1)[:, None]
    P = c.poses.copy()
    P[1:, :3, 3] = c.poses[0, :3, 3] + np.cumsum(steps, axis=0)
    ev = tev.evaluate(Trajectory(g.t_ns, P), g, parts=5).result["standard"]
    sp = ev["scale_parts"]
    assert len(sp) == 5 and all(b > a for a, b in zip(sp, sp[1:]))
    assert sp[0] < 1.0 < sp[-1] and sp[-1] / sp[0] == pytest.approx(0.95 / 0.55, rel=0.1)
    # a part standing still has no scale; SE(3) alignment has no scale to compare
    P = c.poses.copy()
    P[300:, :3, 3] = P[300, :3, 3]
    assert tev.evaluate(Trajectory(g.t_ns, P), g).result["standard"]["scale_parts"][3] is None
    assert "scale_parts" not in tev.evaluate(Trajectory(g.t_ns, P), g, metric_scale=True).result["standard"]
    with pytest.raises(ValueError, match="parts"):
        tev.evaluate(Trajectory(g.t_ns, c.poses), g, parts=0)


def test_rpe_over_k_frames_grows_with_a_chained_error_and_not_with_a_fixed_one():
    g = gt_body(300)
    c = cam(g)
    rng = np.random.default_rng(4)
    # a small random turn added to every step and chained: the error of two poses k apart grows with k
    steps = [np.linalg.inv(c.poses[i]) @ c.poses[i + 1] for i in range(len(g) - 1)]
    P = [c.poses[0]]
    for S in steps:
        N = np.eye(4)
        N[:3, :3] = Rotation.from_rotvec(rng.normal(0.0, 1e-3, 3)).as_matrix()
        P.append(P[-1] @ S @ N)
    ev = tev.evaluate(Trajectory(g.t_ns, np.array(P)), g, rpe_deltas=(1, 10, 100)).result["standard"]
    r = [ev["rpe_frames"][k]["rotation_deg"]["rmse"] for k in ("1", "10", "100")]
    assert r[0] == pytest.approx(ev["rpe_frame"]["rotation_deg"]["rmse"], rel=1e-9)
    assert r[1] > 2.0 * r[0] and r[2] > 2.0 * r[1]
    # the same size of error on each pose alone, not chained: no growth
    Q = c.poses.copy()
    for i in range(len(Q)):
        Q[i, :3, :3] = Q[i, :3, :3] @ Rotation.from_rotvec(rng.normal(0.0, 1e-3, 3)).as_matrix()
    ev = tev.evaluate(Trajectory(g.t_ns, Q), g, rpe_deltas=(1, 100)).result["standard"]
    assert ev["rpe_frames"]["100"]["rotation_deg"]["rmse"] == pytest.approx(
        ev["rpe_frames"]["1"]["rotation_deg"]["rmse"], rel=0.2)
    assert "rpe_frames" not in tev.evaluate(Trajectory(g.t_ns, Q), g).result["standard"]
    for bad in ((0,), (2.5,)):
        with pytest.raises(ValueError, match="deltas"):
            tev.evaluate(Trajectory(g.t_ns, Q), g, rpe_deltas=bad)


def test_bad_inputs():
    g = gt_body(50)
    far = Trajectory(g.t_ns + 10_000_000_000_000, cam(g).poses)
    with pytest.raises(ValueError):
        tev.evaluate(far, g)
    with pytest.raises(ValueError):
        tev.evaluate(Trajectory(g.t_ns[:1], g.poses[:1]), g)
    nan = cam(g)
    nan.poses[3, 0, 3] = np.nan
    with pytest.raises(ValueError):
        tev.evaluate(nan, g)
    with pytest.raises(ValueError):
        tev.evaluate(cam(g), g, frame="world")


def test_cli_writes_json_and_plots(tmp_path, capsys):
    g = gt_body(120)
    synth_dir = euroc_folder(tmp_path / "seq", g)
    est = cam(g)
    est.poses[:, :3, 3] *= 0.5  # monocular scale
    trajio.write_tum(str(tmp_path / "est.txt"), est)
    out = tmp_path / "r" / "result.json"
    rc = tev.main(["--est", str(tmp_path / "est.txt"), "--gt", str(synth_dir), "--out", str(out),
                   "--plots", str(tmp_path / "plots")])
    assert rc == 0
    printed = capsys.readouterr().out
    assert "ATE RMSE (sim3" in printed and "paper protocol" in printed
    res = json.loads(out.read_text())
    assert res["inputs"]["T_BS"].endswith("cam0/sensor.yaml")
    assert res["standard"]["ate_m"]["rmse"] < 1e-8
    assert res["standard"]["alignment"]["scale"] == pytest.approx(2.0)
    for p in res["plots"]:
        data = open(p, "rb").read()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000
    # no overlap in time: a clear error and exit code 2
    far = Trajectory(g.t_ns + 10**13, est.poses)
    trajio.write_tum(str(tmp_path / "far.txt"), far)
    assert tev.main(["--est", str(tmp_path / "far.txt"), "--gt", str(synth_dir), "--quiet"]) == 1
    assert "association failed" in capsys.readouterr().err
    assert tev.main(["--est", str(tmp_path / "missing.txt"), "--gt", str(synth_dir), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "missing.txt" in err and "Traceback" not in err


# ---- ground-truth formats: EuRoC csv, TUM, KITTI, and the files that could be more than one --------

TUM_HEADER = "# ground truth trajectory\n# file: 'rgbd_dataset_freiburg1_xyz.bag'\n# timestamp tx ty tz qx qy qz qw\n"


def write_tum_gt(path, traj, header=TUM_HEADER):
    """A TUM RGB-D groundtruth.txt: TUM's three header lines, then t tx ty tz qx qy qz qw (seconds)."""
    trajio.write_tum(str(path), traj)
    body = path.read_text()
    path.write_text(header + body)


def test_tum_groundtruth_is_read_with_w_last(tmp_path):
    """The reported failure: a TUM ground truth (quaternion x y z w) was read w first, giving a rotation
    ATE of ~178 deg. Read by its header now, with T_BS identity (TUM poses are camera poses)."""
    g = cam(gt_body(150))
    write_tum_gt(tmp_path / "groundtruth.txt", g)
    trajio.write_tum(str(tmp_path / "est.txt"), g)
    fmt, why = trajio.detect_pose_format(str(tmp_path / "groundtruth.txt"))
    assert fmt == "tum" and "header" in why
    ev = tev.evaluate_files(str(tmp_path / "est.txt"), str(tmp_path / "groundtruth.txt"), metric_scale=True)
    s = ev.result["standard"]
    assert s["ate_rotation_deg"]["rmse"] < 1e-6 and s["ate_m"]["rmse"] < 1e-9
    assert s["rpe_frame"]["rotation_deg"]["rmse"] < 1e-6
    assert ev.result["inputs"]["ground_truth_format"] == "tum"
    assert ev.result["inputs"]["T_BS"].startswith("identity")
    # the same file read w first (what happened before): a wrong rotation, so the check above can fail
    wrong = trajio.read_euroc_groundtruth(str(tmp_path / "groundtruth.txt"))
    bad = tev.evaluate(g, wrong, T_BS=np.eye(4), metric_scale=True).result["standard"]
    assert bad["ate_rotation_deg"]["rmse"] > 10.0
    # a TUM folder: its groundtruth.txt
    assert tev.load_groundtruth(str(tmp_path))[2] == "tum"
    # without the header: 8 space-separated columns with seconds is TUM too
    trajio.write_tum(str(tmp_path / "plain.txt"), g)
    assert trajio.detect_pose_format(str(tmp_path / "plain.txt"))[0] == "tum"


def test_euroc_csv_detected(tmp_path):
    g = gt_body(80)
    trajio.write_euroc_groundtruth(str(tmp_path / "data.csv"), g)
    fmt, why = trajio.detect_pose_format(str(tmp_path / "data.csv"))
    assert fmt == "euroc" and "w first" in why
    # header-less EuRoC csv: commas and ns
    (tmp_path / "nohead.csv").write_text("".join(ln for ln in (tmp_path / "data.csv").read_text().splitlines(True)
                                                 if not ln.startswith("#")))
    assert trajio.detect_pose_format(str(tmp_path / "nohead.csv"))[0] == "euroc"
    tr, fmt, _ = trajio.read_trajectory(str(tmp_path / "nohead.csv"))
    assert fmt == "euroc" and np.allclose(tr.poses, g.poses, atol=1e-8)


def test_cam_frames_read_in_order_and_bad_rows_refused(tmp_path):
    cam = tmp_path / "cam0"
    cam.mkdir()
    (cam / "data.csv").write_text("#timestamp [ns],filename\n\n1403715273262142976,a.png\n"
                                  "1403715273312143104, b.png \n# a comment\n1403715273362142976,c.png\n")
    t, names = trajio.read_cam_frames(str(cam))
    assert t.dtype == np.int64 and t.tolist() == [1403715273262142976, 1403715273312143104,
                                                  1403715273362142976]
    assert names == ["a.png", "b.png", "c.png"]
    for bad in ("1403715273262142976\n", "1.5e18,a.png\n", "x,a.png\n", "1403715273262142976,\n"):
        (cam / "data.csv").write_text("#timestamp [ns],filename\n" + bad)
        with pytest.raises(ValueError, match="data.csv:2"):
            trajio.read_cam_frames(str(cam))


def test_ambiguous_files_are_refused(tmp_path):
    g = gt_body(60)
    p, q = trajio.pq_from_pose(g.poses)
    # 8 space-separated columns, ns timestamps, no header: EuRoC order or TUM with ns?
    amb = tmp_path / "amb.txt"
    amb.write_text("".join(f"{t} {' '.join(map(str, pi))} {' '.join(map(str, qi))}\n" for t, pi, qi in zip(g.t_ns, p, q)))
    with pytest.raises(ValueError, match="cannot tell the quaternion order.*timestamps in ns.*--gt-format"):
        trajio.detect_pose_format(str(amb))
    est = tmp_path / "est.txt"
    trajio.write_tum(str(est), cam(g))
    with pytest.raises(ValueError, match="cannot tell"):
        tev.evaluate_files(str(est), str(amb))
    # named: read as EuRoC (w first) it is the trajectory
    ev = tev.evaluate_files(str(est), str(amb), gt_format="euroc", metric_scale=True)
    assert ev.result["standard"]["ate_m"]["rmse"] < 1e-6
    assert ev.result["inputs"]["ground_truth_format_why"] == "named (euroc)"
    # comma-separated with seconds: neither EuRoC (ns) nor TUM (spaces)
    sec = tmp_path / "sec.csv"
    sec.write_text("".join(f"{t / 1e9:.6f},{','.join(map(str, pi))},{','.join(map(str, qi))}\n"
                           for t, pi, qi in zip(g.t_ns, p, q)))
    with pytest.raises(ValueError, match="8 comma-separated columns.*timestamps in s"):
        trajio.detect_pose_format(str(sec))
    # not a quaternion in columns 5-8
    nq = tmp_path / "nq.txt"
    nq.write_text("1.0 0 0 0 0.5 0.5 0.5 0.1\n2.0 0 0 0 0.5 0.5 0.5 0.1\n")
    with pytest.raises(ValueError, match="not a unit quaternion"):
        trajio.detect_pose_format(str(nq))
    seven = tmp_path / "seven.txt"
    seven.write_text("1 2 3 4 5 6 7\n")
    with pytest.raises(ValueError, match="7 space-separated columns"):
        trajio.detect_pose_format(str(seven))
    mixed = tmp_path / "mixed.txt"
    mixed.write_text("1 0 0 0 0 0 0 1\n2 0 0 0 0 0 0 1 5\n")
    with pytest.raises(ValueError, match="rows of"):
        trajio.detect_pose_format(str(mixed))


def test_kitti_poses_and_times(tmp_path):
    g = cam(gt_body(70))
    t0 = g.t_ns[0]
    seq = tmp_path / "sequences" / "04"
    seq.mkdir(parents=True)
    (tmp_path / "poses").mkdir()
    trajio.write_kitti_poses(str(tmp_path / "poses" / "04.txt"), g)
    (seq / "times.txt").write_text("".join(f"{(t - t0) * 1e-9:.6e}\n" for t in g.t_ns))
    fmt, why = trajio.detect_pose_format(str(tmp_path / "poses" / "04.txt"))
    assert fmt == "kitti" and "rotation" in why
    # times found in KITTI's layout (../sequences/04/times.txt)
    tr, fmt, _ = trajio.read_trajectory(str(tmp_path / "poses" / "04.txt"))
    assert fmt == "kitti" and len(tr) == 70
    assert np.allclose(tr.poses, g.poses, atol=1e-8)
    assert abs(int(tr.t_ns[5]) - int(g.t_ns[5] - t0)) <= 500  # %.6e keeps us over these few seconds
    # the sequence folder itself
    tr2, fmt2, _ = trajio.read_trajectory(str(seq))
    assert fmt2 == "kitti" and np.allclose(tr2.poses, tr.poses)
    # an estimate on KITTI's clock against it: ~0
    est = Trajectory(tr.t_ns, tr.poses)
    trajio.write_tum(str(tmp_path / "est.txt"), est)
    ev = tev.evaluate_files(str(tmp_path / "est.txt"), str(tmp_path / "poses" / "04.txt"), metric_scale=True)
    assert ev.result["standard"]["ate_m"]["rmse"] < 1e-6 and ev.result["inputs"]["T_BS"].startswith("identity")
    # no times anywhere: refused, naming the option
    (tmp_path / "lone").mkdir()
    trajio.write_kitti_poses(str(tmp_path / "lone" / "p.txt"), g)
    with pytest.raises(ValueError, match="no timestamps.*--gt-times"):
        trajio.read_trajectory(str(tmp_path / "lone" / "p.txt"))
    tr3, _, _ = trajio.read_trajectory(str(tmp_path / "lone" / "p.txt"), times=str(seq / "times.txt"))
    assert len(tr3) == 70
    # a times file of another length
    (tmp_path / "short.txt").write_text("0.0\n0.1\n")
    with pytest.raises(ValueError, match="70 poses but 2 times"):
        trajio.read_kitti_poses(str(tmp_path / "lone" / "p.txt"), str(tmp_path / "short.txt"))


def test_kitti_real_poses(tmp_path):
    """KITTI 06's real camera poses (the shared sample stores them as a EuRoC csv) written as a KITTI
    poses file with its times: read back identically."""
    import os
    d = os.environ.get("TVO_DATA_DIR") or str(pathlib.Path(__file__).resolve().parents[2] / ".." / "shared" / "data")
    gt_csv = pathlib.Path(d) / "kitti" / "kitti06_51" / "mav0" / "state_groundtruth_estimate0" / "data.csv"
    if not gt_csv.exists():
        pytest.skip(f"{gt_csv} not found (shared KITTI sample)")
    src = trajio.read_euroc_groundtruth(str(gt_csv))
    trajio.write_kitti_poses(str(tmp_path / "06.txt"), src)
    (tmp_path / "times.txt").write_text("".join(f"{(t - src.t_ns[0]) * 1e-9:.9e}\n" for t in src.t_ns))
    tr, fmt, _ = trajio.read_trajectory(str(tmp_path / "06.txt"))
    assert fmt == "kitti" and len(tr) == len(src) == 51
    assert np.allclose(tr.poses, src.poses, atol=1e-8)
    assert np.all(np.abs((tr.t_ns + src.t_ns[0]) - src.t_ns) <= 1)


def test_cli_gt_format(tmp_path, capsys):
    g = cam(gt_body(90))
    p, q = trajio.pq_from_pose(g.poses)
    amb = tmp_path / "amb.txt"
    amb.write_text("".join(f"{t} {' '.join(map(str, pi))} {' '.join(map(str, qi))}\n" for t, pi, qi in zip(g.t_ns, p, q)))
    trajio.write_tum(str(tmp_path / "est.txt"), g)
    assert tev.main(["--est", str(tmp_path / "est.txt"), "--gt", str(amb), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("tinyvo-eval: error:") and "cannot tell" in err and err.count("\n") == 1
    assert tev.main(["--est", str(tmp_path / "est.txt"), "--gt", str(amb), "--gt-format", "euroc", "--tbs",
                     "/nonexistent.yaml"]) == 1
    capsys.readouterr()
    rc = tev.main(["--est", str(tmp_path / "est.txt"), "--gt", str(amb), "--gt-format", "euroc",
                   "--metric-scale", "--frame", "body"])
    out = capsys.readouterr().out
    assert rc == 0 and out.startswith("ground truth: euroc (named (euroc))")
    with pytest.raises(SystemExit) as e:
        tev.main(["--est", "x", "--gt", "y", "--gt-format", "evo"])
    assert e.value.code == 2
    assert "--gt-format" in capsys.readouterr().err


def test_same_frames_as_restricts_to_the_peers_frames(tmp_path):
    """--same-frames-as: only the estimate's frames that the other trajectory also has are evaluated. The
    estimate is exact except for its first 10 frames (pushed 1 m away), and the peer starts after them:
    on the common frames the ATE is zero, on all frames it is not."""
    g = gt_body(120)
    synth_dir = euroc_folder(tmp_path / "seq", g)
    est = cam(g)
    est.poses[:10, 0, 3] += 1.0
    trajio.write_tum(str(tmp_path / "est.txt"), est)
    peer = Trajectory(est.t_ns[10:] + 2_000_000, est.poses[10:])  # 2 ms off: still the same frames
    trajio.write_tum(str(tmp_path / "peer.txt"), peer)
    ev_all = tev.evaluate_files(str(tmp_path / "est.txt"), str(synth_dir))
    ev = tev.evaluate_files(str(tmp_path / "est.txt"), str(synth_dir), same_frames_as=str(tmp_path / "peer.txt"))
    assert ev_all.result["standard"]["ate_m"]["rmse"] > 0.05
    assert ev.result["standard"]["ate_m"]["rmse"] < 1e-8
    assert ev.result["poses"]["associated"] == 110
    assert ev.result["inputs"]["same_frames_as"]["frames_kept"] == 110
    assert ev.result["inputs"]["same_frames_as"]["frames_of_estimate"] == 120
    # no frame in common: a clear error
    far = Trajectory(est.t_ns + 10**12, est.poses)
    trajio.write_tum(str(tmp_path / "far.txt"), far)
    with pytest.raises(ValueError, match="frames in common"):
        tev.evaluate_files(str(tmp_path / "est.txt"), str(synth_dir), same_frames_as=str(tmp_path / "far.txt"))


def test_static_estimate_is_a_clear_error():
    """A trajectory that does not move (a camera that only turns: every position the same) has no Sim(3)
    alignment: a ValueError saying so (one line from the CLI, a FAILED row in the suite), not evo's
    exception."""
    g = gt_body(60)
    est = cam(g)
    est.poses[:, :3, 3] = 0.0
    with pytest.raises(ValueError, match="alignment is not possible"):
        tev.evaluate(est, g)


def test_replay_header_names_the_camera_frame_and_unit(tmp_path, capsys):
    """tvo_replay's first line says whose pose each row is: a cam1 replay is compared with cam1's
    ground truth (not cam0's, 11 cm away), and options that contradict the header are refused."""
    g = gt_body(120)
    seq = euroc_folder(tmp_path / "seq", g)
    cam1 = EUROC_CAM0_T_BS.copy()
    cam1[:3, 3] += [0.0, 0.11, 0.0]  # EuRoC's cam1 sits about 11 cm from cam0
    (seq / "mav0" / "cam1").mkdir()
    trajio.write_sensor_yaml(str(seq / "mav0" / "cam1" / "sensor.yaml"), trajio.CameraInfo(T_BS=cam1))
    est = g.to_camera(cam1)
    est.poses[:, :3, 3] *= 0.5

    def write(name, header):
        p = tmp_path / name
        trajio.write_tum(str(p), est)
        p.write_text(header + p.read_text())
        return str(p)

    with_hdr = write("cam1.txt",
                     "# tvo_replay frame=camera source=euroc camera=cam1 scale=none: t tx ty tz qx qy qz qw\n")
    bare = write("bare.txt", "")
    assert trajio.read_replay_header(with_hdr) == {"frame": "camera", "source": "euroc", "camera": "cam1",
                                                    "scale": "none"}
    assert trajio.read_replay_header(bare) == {}
    ev = tev.evaluate_files(with_hdr, str(seq))
    assert ev.result["inputs"]["T_BS"].endswith("cam1/sensor.yaml") and ev.result["inputs"]["camera"] == "cam1"
    assert ev.result["standard"]["ate_m"]["rmse"] < 1e-8
    # without the header the file is taken for cam0's: the lever arm turning with the body is the error
    assert tev.evaluate_files(bare, str(seq)).result["standard"]["ate_m"]["rmse"] > 0.005
    assert tev.evaluate_files(bare, str(seq), cam="cam1").result["standard"]["ate_m"]["rmse"] < 1e-8
    # contradictions and a metric evaluation of the map's own unit: one line, exit 1
    for args, words in ((["--cam", "cam0"], "replay of cam1"), (["--frame", "body"], "holds camera poses"),
                        (["--metric-scale"], "--scale none")):
        assert tev.main(["--est", with_hdr, "--gt", str(seq), "--quiet"] + args) == 1
        err = capsys.readouterr().err
        assert words in err and err.count("\n") == 1
    cam2 = write("cam2.txt", "# tvo_replay frame=camera source=euroc camera=cam2 scale=none: t tx ty tz qx qy qz qw\n")
    with pytest.raises(ValueError, match="cam2/sensor.yaml"):
        tev.evaluate_files(cam2, str(seq))
    for bad in ("frame=world camera=cam0", "frame=camera camera=../../etc"):
        p = write("bad.txt", f"# tvo_replay {bad} source=euroc scale=none: t tx ty tz qx qy qz qw\n")
        with pytest.raises(ValueError, match="tvo_replay header"):
            tev.evaluate_files(p, str(seq))
    # a KITTI or TUM replay names its image folder: no EuRoC camera, so no effect on T_BS
    kitti = write("k.txt", "# tvo_replay frame=camera source=kitti camera=image_0 scale=none: t tx ty tz qx qy qz qw\n")
    assert tev.estimate_frame_and_camera(kitti, None, None, False) == ("camera", "cam0")
