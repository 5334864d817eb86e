# SPDX-License-Identifier: Apache-2.0
"""Tests of tinyvo_tools.synth (synthetic EuRoC sequences) and tinyvo_tools.trajio."""
import os
import pathlib

import cv2
import numpy as np
import pytest

from tinyvo_tools import synth, trajio

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = pathlib.Path(os.environ.get("TVO_DATA_DIR", ROOT.parent / "shared" / "data"))
CAM = trajio.CameraInfo()
K = np.array([[CAM.intrinsics[0], 0, CAM.intrinsics[2]], [0, CAM.intrinsics[1], CAM.intrinsics[3]], [0, 0, 1]])
DIST = np.array(CAM.distortion)
SMALL = {"texture_size": 128}  # fast scenes for tests


def cv_undistort(pts):
    """OpenCV's iterative undistortion (independent of synth's Newton inverse), normalised coordinates."""
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14)
    return cv2.undistortPointsIter(np.asarray(pts, float).reshape(-1, 1, 2), K, DIST, None, None, crit).reshape(-1, 2)


def look_pose(pos, yaw_deg, pitch_deg=0.0):
    R = synth._look_rotation(np.radians([yaw_deg]), np.radians([pitch_deg]), np.zeros(1))[0]
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = pos
    return T


def room_scene(lo=(-3.0, -2.0, 0.0), hi=(4.0, 2.5, 3.0), boxes=()):
    """A scene with a given room and boxes (list of (lo, hi)) and small textures."""
    sc = synth.make_scene(np.array([lo, hi]) * 0.5, seed=3, boxes=False, **SMALL)
    sc.room_lo, sc.room_hi = np.array(lo, float), np.array(hi, float)
    if boxes:
        sc.box_lo = np.array([b[0] for b in boxes], float)
        sc.box_hi = np.array([b[1] for b in boxes], float)
        F = 6 * (len(boxes) + 1)
        rep = lambda a: np.resize(a, (F,) + a.shape[1:]).astype(a.dtype)  # noqa: E731
        sc.face_tex, sc.face_off, sc.face_inv_texel = rep(sc.face_tex), rep(sc.face_off), rep(sc.face_inv_texel)
        sc.face_gain, sc.face_bias = rep(sc.face_gain), rep(sc.face_bias)
    return sc


def test_radtan_inverse_is_exact():
    u, v = np.meshgrid(np.arange(0, 752, 7.5), np.arange(0, 480, 7.5))
    xd, yd = (u - CAM.intrinsics[2]) / CAM.intrinsics[0], (v - CAM.intrinsics[3]) / CAM.intrinsics[1]
    x, y = synth.undistort_radtan(xd, yd, CAM.distortion)
    x2, y2 = synth.distort_radtan(x, y, CAM.distortion)
    assert np.abs(x2 - xd).max() < 1e-10 and np.abs(y2 - yd).max() < 1e-10
    # and agrees with OpenCV's forward model
    pts = np.stack([x.ravel(), y.ravel(), np.ones(x.size)], 1)
    uv, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), K, DIST)
    assert np.abs(uv.reshape(-1, 2) - np.stack([u.ravel(), v.ravel()], 1)).max() < 1e-6


def test_equidistant_inverse_and_opencv_fisheye():
    """The fisheye preset's model: the inverse is exact to 1e-10, the forward model is OpenCV's
    cv2.fisheye.projectPoints, every pixel's ray stays below 90 degrees, and the sequence's yaml names the
    model with its coefficients."""
    cam = synth.CAMERAS["fisheye"]
    fu, fv, cu, cv = cam.intrinsics
    u, v = np.meshgrid(np.arange(0, cam.width, 7.5), np.arange(0, cam.height, 7.5))
    xd, yd = (u - cu) / fu, (v - cv) / fv
    x, y = synth.undistort_equidistant(xd, yd, cam.distortion)
    x2, y2 = synth.distort_equidistant(x, y, cam.distortion)
    assert np.abs(x2 - xd).max() < 1e-10 and np.abs(y2 - yd).max() < 1e-10
    assert np.degrees(np.arctan(np.hypot(x, y))).max() > 75  # a strong lens: the corners near 80 degrees
    pts = np.stack([x.ravel(), y.ravel(), np.ones(x.size)], 1).reshape(-1, 1, 3)
    Kf = np.array([[fu, 0, cu], [0, fv, cv], [0, 0, 1]], float)
    uv, _ = cv2.fisheye.projectPoints(pts, np.zeros(3), np.zeros(3), Kf, np.array(cam.distortion, float))
    assert np.abs(uv.reshape(-1, 2) - np.stack([u.ravel(), v.ravel()], 1)).max() < 1e-6
    uv2 = synth.project_points(cam, np.stack([x.ravel(), y.ravel(), np.ones(x.size)], 1) * 2.0)
    assert np.abs(uv2 - np.stack([u.ravel(), v.ravel()], 1)).max() < 1e-6
    px = synth.PixelRays(cam)
    assert px.rays[2].min() > np.cos(np.radians(85))
    with pytest.raises(ValueError):  # a lens whose image reaches 90 degrees is refused, not rendered wrong
        synth.undistort_equidistant(np.array([2.0]), np.array([0.0]), (0.0, 0.0, 0.0, 0.0))


def test_fisheye_sequence_yaml(tmp_path):
    cam = synth.CAMERAS["fisheye"]
    traj = synth.builtin_trajectory("handheld", 10, rate_hz=cam.rate_hz, seed=1)
    info = synth.render_sequence(str(tmp_path), traj, 2, seed=1, cam=cam, progress=False, scene_kwargs=SMALL)
    assert info["frames"] == 2
    back = trajio.read_sensor_yaml(str(tmp_path / "mav0" / "cam0" / "sensor.yaml"))
    assert back.distortion_model == "equidistant" and np.allclose(back.distortion, cam.distortion)
    assert (back.width, back.height) == (cam.width, cam.height) and np.allclose(back.intrinsics, cam.intrinsics)


def test_room_depth_matches_analytic_planes():
    sc = room_scene()
    r = synth.Renderer(sc, CAM)
    T = look_pose([0.3, -0.2, 1.4], 10.0, 5.0)
    img, rng = r.render(T)
    assert img.shape == (480, 752) and rng.shape == (480, 752)
    # independent rays: OpenCV's undistortPoints, intersected analytically with the six room planes
    vv, uu = np.mgrid[0:480:13, 0:752:13]
    pts = np.stack([uu.ravel(), vv.ravel()], 1).astype(np.float64)
    n = cv_undistort(pts)
    d = np.stack([n[:, 0], n[:, 1], np.ones(len(n))], 1)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    dw = d @ T[:3, :3].T
    o = T[:3, 3]
    with np.errstate(divide="ignore"):
        t = np.where(dw > 0, (sc.room_hi - o) / dw, (sc.room_lo - o) / dw)
    t_expect = t.min(1)
    got = rng[vv.ravel(), uu.ravel()]
    assert np.allclose(got, t_expect, rtol=2e-4, atol=1e-4)


def test_box_seen_where_its_corners_project():
    box = ((2.0, -0.4, 1.0), (2.6, 0.5, 1.8))
    sc = room_scene(boxes=[box])
    r = synth.Renderer(sc, CAM)
    T = look_pose([0.0, 0.0, 1.3], 0.0)
    _, rng = r.render(T)
    # the front face (x = 2.0) projected with OpenCV's model
    face = np.array([[2.0, -0.4, 1.0], [2.0, 0.5, 1.0], [2.0, 0.5, 1.8], [2.0, -0.4, 1.8]])
    Xc = (face - T[:3, 3]) @ T[:3, :3]
    uv, _ = cv2.projectPoints(Xc, np.zeros(3), np.zeros(3), K, DIST)
    uv = uv.reshape(-1, 2)
    assert np.all((uv > 5) & (uv < [747, 475])), "box must be fully in view for this test"
    # inside the projected face (2 px margin): the depth of the x = 2 plane; outside: farther
    u0, u1 = int(np.ceil(uv[:, 0].min())) + 2, int(np.floor(uv[:, 0].max())) - 2
    v0, v1 = int(np.ceil(uv[:, 1].min())) + 2, int(np.floor(uv[:, 1].max())) - 2
    uc, vc = (u0 + u1) // 2, (v0 + v1) // 2
    ray = cv_undistort([[uc, vc]]).ravel()
    dcam = np.array([ray[0], ray[1], 1.0])
    dw = T[:3, :3] @ (dcam / np.linalg.norm(dcam))
    assert rng[vc, uc] == pytest.approx((2.0 - T[0, 3]) / dw[0], rel=1e-4)
    inside = rng[v0:v1, u0:u1]
    assert inside.max() < 2.0 / np.cos(np.radians(45))
    # left and right of the face: the far wall (x = 4) or beyond
    for u in (int(uv[:, 0].min()) - 3, int(uv[:, 0].max()) + 3):
        assert rng[vc, u] > 3.9


def test_tile_culling_equals_brute_force(monkeypatch):
    traj = synth.builtin_trajectory("handheld", 120, seed=5).to_camera(CAM.T_BS)
    sc = synth.make_scene(traj.positions, seed=5, **SMALL)
    assert sc.nboxes > 5
    r = synth.Renderer(sc, CAM)
    poses = list(traj.poses[::30])
    # plus poses right beside a box (near-plane clipping of the projected box)
    b0, b1 = sc.box_lo[0], sc.box_hi[0]
    c = 0.5 * (b0 + b1)
    for yaw in (0, 60, 120, 180, 240, 300):
        p = np.array([b0[0] - 0.05, c[1], min(c[2], sc.room_hi[2] - 0.1)])
        if np.all(p > sc.room_lo) and np.all(p < sc.room_hi):
            poses.append(look_pose(p, yaw, 20))
    culled = [r.cast(T)[0].copy() for T in poses]
    monkeypatch.setattr(synth.Renderer, "_box_tiles", lambda self, *a: np.arange(self.px.ntiles))
    for T, t in zip(poses, culled):
        assert np.array_equal(r.cast(T)[0], t)


def test_texture_sampling_exact_at_texel_centres():
    rng = np.random.default_rng(0)
    tex = rng.random((2, 32, 32)).astype(np.float32)
    mt = synth.MipTextures(tex)
    x = rng.integers(-64, 64, 200)
    y = rng.integers(-64, 64, 200)
    t = rng.integers(0, 2, 200)
    got = mt.sample(t, (x + 0.5).astype(np.float32), (y + 0.5).astype(np.float32), np.zeros(200, np.float32))
    want = np.rint(tex[t, y % 32, x % 32] * 255)
    assert np.allclose(got, want, atol=1e-3)
    # level 1 = 2x2 box average
    got1 = mt.sample(t, (2 * x + 1.0).astype(np.float32), (2 * y + 1.0).astype(np.float32),
                     np.ones(200, np.float32))
    assert np.allclose(got1, np.rint(mt.levels[1][t, y % 16, x % 16] * 255), atol=1e-3)


def _files(d):
    out = {}
    for p in sorted(pathlib.Path(d).rglob("*")):
        if p.is_file():
            out[str(p.relative_to(d))] = p.read_bytes()
    return out


def test_deterministic_and_valid_euroc_layout(tmp_path):
    traj = synth.builtin_trajectory("handheld", 10, seed=1)
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    for d, seed in ((a, 1), (b, 1), (c, 2)):
        synth.render_sequence(str(d), traj, n_frames=4, seed=seed, progress=False, scene_kwargs=SMALL)
    fa, fb, fc = _files(a), _files(b), _files(c)
    assert fa == fb, "same seed must give the same bytes"
    assert {k for k in fa if k.endswith(".png")} == {k for k in fc if k.endswith(".png")}
    assert any(fa[k] != fc[k] for k in fa if k.endswith(".png")), "another seed must change the images"

    mav = a / "mav0"
    rows = [l.split(",") for l in (mav / "cam0" / "data.csv").read_text().splitlines()]
    assert rows[0][0].startswith("#timestamp")
    ts = [int(r[0]) for r in rows[1:]]
    assert len(ts) == 4 and all(np.diff(ts) == 50_000_000)
    for t, name in rows[1:]:
        assert name == f"{t}.png"
        img = cv2.imread(str(mav / "cam0" / "data" / name), cv2.IMREAD_UNCHANGED)
        assert img is not None and img.dtype == np.uint8 and img.shape == (480, 752)
        assert img.std() > 20, "textured image expected"
    cam = trajio.read_sensor_yaml(str(mav / "cam0" / "sensor.yaml"))
    assert cam.intrinsics == CAM.intrinsics and cam.distortion == CAM.distortion
    assert cam.distortion_model == "radial-tangential" and (cam.width, cam.height, cam.rate_hz) == (752, 480, 20)
    assert np.array_equal(cam.T_BS, trajio.EUROC_CAM0_T_BS)
    fs = cv2.FileStorage(str(mav / "cam0" / "sensor.yaml"), cv2.FILE_STORAGE_READ)  # OpenCV reads it too
    assert fs.getNode("T_BS").getNode("rows").real() == 4
    fs.release()
    gt = trajio.read_euroc_groundtruth(str(a))
    assert list(gt.t_ns) == ts
    want = trajio.interpolate_poses(traj.t_ns, traj.poses, gt.t_ns)
    assert np.abs(gt.poses - want).max() < 1e-8
    head = (mav / "state_groundtruth_estimate0" / "data.csv").read_text().splitlines()[0]
    assert head.startswith("#timestamp, p_RS_R_x [m]") and "q_RS_w []" in head


def test_png_encoder_roundtrip():
    img = (np.arange(37 * 53) * 7 % 256).astype(np.uint8).reshape(37, 53)
    data = synth.encode_png_gray8(img)
    back = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    assert np.array_equal(back, img)


@pytest.mark.parametrize("name", synth.BUILTINS)
def test_builtin_trajectories_are_enclosed_and_clear_of_boxes(name):
    body = synth.builtin_trajectory(name, 400, seed=4)
    cam = body.to_camera(CAM.T_BS)
    steps = np.linalg.norm(np.diff(cam.positions, axis=0), axis=1)
    if name == "drive":  # 7.7-12.3 m/s at the default 20 Hz
        assert steps.min() > 0.38 and steps.max() < 0.62
    else:
        assert steps.max() < 0.1, "smooth: under 2 m/s"
    sc = synth.make_scene(cam.positions, seed=4, **SMALL)
    assert np.all(cam.positions > sc.room_lo + [1.5, 1.5, 0.6]) and np.all(cam.positions < sc.room_hi - [1.5, 1.5, 1.0])
    for b0, b1 in zip(sc.box_lo, sc.box_hi):
        assert synth._box_distance(cam.positions, b0, b1).min() >= 0.45
    if name == "handheld":  # rotation-heavy parts: some frame-to-frame rotations above 2 deg
        rel = trajio.inv_pose(cam.poses[:-1]) @ cam.poses[1:]
        ang = np.degrees(np.arccos(np.clip((np.trace(rel[:, :3, :3], axis1=1, axis2=2) - 1) / 2, -1, 1)))
        assert ang.max() > 2.0 and np.median(ang) < ang.max() / 2


@pytest.mark.parametrize("preset", ["kitti", "tum"])
def test_camera_presets(tmp_path, preset):
    """Another camera: frame size, pinhole intrinsics (no distortion), frame rate and yaml as the preset; a
    box corner projects where the pinhole model puts it (the distortion-free ray set)."""
    cam = synth.CAMERAS[preset]
    traj = synth.builtin_trajectory("drive", 10, rate_hz=cam.rate_hz, seed=1)
    info = synth.render_sequence(str(tmp_path), traj, 3, seed=1, cam=cam, progress=False, scene_kwargs=SMALL)
    assert info["frames"] == 3
    back = trajio.read_sensor_yaml(str(tmp_path / "mav0" / "cam0" / "sensor.yaml"))
    assert (back.width, back.height) == (cam.width, cam.height) and back.rate_hz == cam.rate_hz
    assert np.allclose(back.intrinsics, cam.intrinsics) and not any(back.distortion)
    rows = (tmp_path / "mav0" / "cam0" / "data.csv").read_text().splitlines()[1:]
    t = [int(r.split(",")[0]) for r in rows]
    assert np.all(np.diff(t) == int(round(1e9 / cam.rate_hz)))
    img = cv2.imread(str(tmp_path / "mav0" / "cam0" / "data" / rows[0].split(",")[1]), cv2.IMREAD_UNCHANGED)
    assert img.shape == (cam.height, cam.width) and img.dtype == np.uint8 and img.std() > 10
    px = synth.PixelRays(cam)
    fu, fv, cu, cv = cam.intrinsics
    ray = px.rays[:, 0, 17]  # tile 0, pixel (row 1, column 1)
    assert np.allclose([fu * ray[0] / ray[2] + cu, fv * ray[1] / ray[2] + cv], [1.0, 1.0], atol=1e-4)
    uv = synth.project_points(cam, [[0.3, -0.2, 2.0]])[0]
    assert np.allclose(uv, [fu * 0.15 + cu, fv * -0.1 + cv])


def test_low_room_of_a_short_trajectory_near_the_floor():
    # A few frames of a drone still on the floor give a room about 2.1 m high; a tall wall panel drawn
    # for it has no valid height interval (numpy raised "high - low < 0" for 6 of these 40 seeds).
    P = np.array([[0.0, 0.0, 0.1], [0.05, 0.02, 0.12]])
    for seed in range(40):
        sc = synth.make_scene(P, seed=seed, **SMALL)
        assert sc.room_hi[2] - sc.room_lo[2] < 2.2
        for b0, b1 in zip(sc.box_lo, sc.box_hi):
            assert np.all(b0 >= sc.room_lo) and np.all(b1 <= sc.room_hi)
            assert synth._box_distance(P, b0, b1).min() >= 0.45


def test_bad_arguments(tmp_path):
    with pytest.raises(ValueError):
        synth.builtin_trajectory("nope", 10)
    traj = synth.builtin_trajectory("line", 10)
    with pytest.raises(ValueError):
        synth.render_sequence(str(tmp_path), traj, 5, start_time_s=100.0, progress=False, scene_kwargs=SMALL)
    with pytest.raises(SystemExit):
        synth.main(["--out", str(tmp_path), "--frames", "0"])
    with pytest.raises(SystemExit):
        synth.main(["--out", str(tmp_path), "--noise", "-1"])
    for rate in ("0", "-5", "nan", "inf", "5000"):
        with pytest.raises(SystemExit):
            synth.main(["--out", str(tmp_path), "--rate", rate])
    with pytest.raises(SystemExit):
        synth.main(["--out", str(tmp_path), "--camera", "nope"])
    sc = room_scene()
    with pytest.raises(ValueError):
        synth.Renderer(sc, CAM).render(look_pose([10.0, 0, 1], 0))  # outside the room


def test_renders_along_real_euroc_trajectory(tmp_path):
    gt_file = DATA / "euroc" / "groundtruth" / "V1_01_easy.csv"
    if not gt_file.is_file():
        pytest.skip(f"shared EuRoC data not found at {DATA} (set TVO_DATA_DIR)")
    body = synth.load_trajectory(str(gt_file))
    synth.render_sequence(str(tmp_path), body, 3, start_time_s=20.0, progress=False, scene_kwargs=SMALL)
    src = trajio.read_euroc_groundtruth(str(gt_file))
    gt = trajio.read_euroc_groundtruth(str(tmp_path))
    assert len(gt) == 3 and gt.t_ns[0] == src.t_ns[0] + 20_000_000_000
    want = trajio.interpolate_poses(src.t_ns, src.poses, gt.t_ns)
    assert np.abs(gt.poses - want).max() < 1e-8


def test_trajio_tum_and_association(tmp_path):
    traj = synth.builtin_trajectory("handheld", 30, seed=2)
    p = tmp_path / "t.txt"
    trajio.write_tum(str(p), traj)
    back = trajio.read_tum(str(p))
    assert np.array_equal(back.t_ns, traj.t_ns) and np.abs(back.poses - traj.poses).max() < 1e-8
    ia, ib = trajio.associate([0, 100, 205, 300, 10_000], [88, 101, 200, 90_000], max_diff_ns=10)
    assert ia.tolist() == [1, 2] and ib.tolist() == [1, 2]
    bad = tmp_path / "bad.txt"
    bad.write_text("1.0 0 0 0 0 0 0\n")
    with pytest.raises(ValueError):
        trajio.read_tum(str(bad))
    bad.write_text("1.0 0 0 nan 0 0 0 1\n")
    with pytest.raises(ValueError):
        trajio.read_tum(str(bad))
    bad.write_text("%YAML:1.0\nresolution: [752, 480]\n")
    with pytest.raises(ValueError):
        trajio.read_sensor_yaml(str(bad))
