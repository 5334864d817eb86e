# SPDX-License-Identifier: Apache-2.0
"""tinyvo-view (tinyvo_tools.view): a replay rendered into an animated GIF / a video.

The tracks file is made here from a 12-frame synthetic sequence with OpenCV (corners tracked by LK,
inliers of a RANSAC fundamental matrix, every 5th frame a keyframe), in the format tvo_replay --tracks
writes; the trajectory is the sequence's ground truth in TUM form. The outputs are decoded again: frame
count, size, the track colours at isolated inliers and outliers, the keyframe border, the trajectory
panel. The end-to-end test runs the real tvo_replay --tracks when the binary has the option."""
import os
import pathlib
import subprocess
import sys

import cv2
import numpy as np
import pytest
from PIL import Image

from tinyvo_tools import synth, trajio, view

ROOT = pathlib.Path(__file__).resolve().parents[2]
REPLAY = pathlib.Path(os.environ.get("TVO_BUILD_DIR", ROOT / "build" / "release")) / "examples" / "replay" / "tvo_replay"
N = 12
KEYFRAMES = (0, 5, 10)


@pytest.fixture(scope="module")
def replay_like(tmp_path_factory):
    """(seq dir, tracks csv, TUM trajectory, {frame index: FrameTracks}, (w, h))"""
    d = tmp_path_factory.mktemp("view")
    seq = d / "seq"
    assert synth.main(["--out", str(seq), "--builtin", "handheld", "--frames", str(N), "--quiet"]) == 0
    ts, files = view.read_frames(str(seq))
    assert len(ts) == N
    imgs = [cv2.imread(f, cv2.IMREAD_GRAYSCALE) for f in files]
    pts = cv2.goodFeaturesToTrack(imgs[0], 150, 0.01, 12).reshape(-1, 2).astype(np.float32)
    ids = np.arange(len(pts))
    age = np.ones(len(pts), np.int64)
    next_id = len(pts)
    rows = []
    prev_pts = pts
    for k in range(N):
        if k > 0:
            nxt, st, _ = cv2.calcOpticalFlowPyrLK(imgs[k - 1], imgs[k], prev_pts, None)
            st = st.reshape(-1).astype(bool)
            old, new = prev_pts[st], nxt.reshape(-1, 2)[st]
            ids, age = ids[st], age[st] + 1
            _, mask = cv2.findFundamentalMat(old, new, cv2.FM_RANSAC, 0.5, 0.999)
            inl = mask.reshape(-1).astype(bool) if mask is not None else np.zeros(len(new), bool)
            prev_pts = new
            if k % 4 == 0:  # re-detection: new tracks, not inliers yet
                extra = cv2.goodFeaturesToTrack(imgs[k], 20, 0.01, 12).reshape(-1, 2).astype(np.float32)
                prev_pts = np.vstack([prev_pts, extra])
                ids = np.concatenate([ids, np.arange(next_id, next_id + len(extra))])
                age = np.concatenate([age, np.ones(len(extra), np.int64)])
                inl = np.concatenate([inl, np.zeros(len(extra), bool)])
                next_id += len(extra)
        else:
            inl = np.zeros(len(prev_pts), bool)
        # frame 3: a few tracks are forced outliers so that both colours are present
        if k == 3:
            inl[::5] = False
        for i, (x, y), a, f in zip(ids, prev_pts, age, inl):
            flags = (view.FLAG_INLIER if f else 0) | (view.FLAG_LANDMARK if a >= 3 else 0) | \
                    (view.FLAG_KEYFRAME if k in KEYFRAMES else 0)
            if k == 7:
                continue  # frame 7: no tracks at all (as for a lost frame)
            rows.append(f"{ts[k]},{i},{x:.3f},{y:.3f},{a},{flags}")
    tracks = d / "tracks.csv"
    tracks.write_text("t_ns,id,x,y,age,flags\n" + "\n".join(rows) + "\n")
    gt = trajio.read_euroc_groundtruth(str(seq / "mav0" / "state_groundtruth_estimate0" / "data.csv"))
    cam = trajio.read_sensor_yaml(str(seq / "mav0" / "cam0" / "sensor.yaml"))
    traj = d / "traj.txt"
    trajio.write_tum(str(traj), gt.to_camera(cam.T_BS))
    by_frame = {k: ft for k, t in enumerate(ts) for ft in [view.read_tracks(str(tracks)).get(t)] if ft is not None}
    return seq, tracks, traj, by_frame, imgs[0].shape[::-1], ts


def isolated(ft, mask, size, min_dist=14.0):
    """indices of tracks selected by mask, inside the image (w, h) by 6 px, with no other track within
    min_dist px"""
    out = []
    inside = ((ft.xy >= 6) & (ft.xy < np.array(size) - 6)).all(axis=1)
    for j in np.flatnonzero(mask & inside):
        d = np.linalg.norm(ft.xy - ft.xy[j], axis=1)
        d[j] = np.inf
        if d.min() >= min_dist:
            out.append(j)
    return out


def near(rgb, x, y, colour, r=4, tol=60):
    """True when a pixel within r of (x, y) is within tol (per channel) of colour (RGB)"""
    x, y = int(round(x)), int(round(y))
    win = rgb[max(0, y - r):y + r + 1, max(0, x - r):x + r + 1].astype(int)
    return bool((np.abs(win - np.array(colour)).max(axis=2) <= tol).any())


def gif_frames(path):
    im = Image.open(path)
    frames = []
    for k in range(im.n_frames):
        im.seek(k)
        frames.append(np.array(im.convert("RGB")))
    return im.n_frames, im.size, frames


def test_gif(replay_like, tmp_path):
    seq, tracks, traj, by_frame, (w, h), ts = replay_like
    out = tmp_path / "v.gif"
    assert view.main(["--seq", str(seq), "--tracks", str(tracks), "--traj", str(traj), "-o", str(out), "--quiet"]) == 0
    n, size, frames = gif_frames(out)
    assert n == N
    assert size == (w + h, h)  # image + square trajectory panel of the image's height
    inl_rgb, out_rgb, kf_rgb = view.INLIER_BGR[::-1], view.OUTLIER_BGR[::-1], view.KEYFRAME_BGR[::-1]
    # colours without the tails (another track's tail may pass near a point)
    out1 = tmp_path / "notail.gif"
    assert view.main(["--seq", str(seq), "--tracks", str(tracks), "-o", str(out1), "--trail", "1", "--quiet"]) == 0
    _, _, plain = gif_frames(out1)
    ft = by_frame[3]
    inl = ft.flags & view.FLAG_INLIER != 0
    ji, jo = isolated(ft, inl, (w, h)), isolated(ft, ~inl, (w, h))
    assert len(ji) >= 3 and len(jo) >= 3
    for j in ji:
        assert near(plain[3], *ft.xy[j], inl_rgb) and not near(plain[3], *ft.xy[j], out_rgb), j
    for j in jo:
        assert near(plain[3], *ft.xy[j], out_rgb) and not near(plain[3], *ft.xy[j], inl_rgb), j
    # tails: 3/4 of the way back from an isolated inlier in frame 3 to its frame-2 position, the tail is drawn (in the
    # inlier colour) with the default --trail, and nothing is drawn there without tails
    prev = by_frame[2]
    tailed = 0
    for j in ji:
        m = prev.ids == ft.ids[j]
        if m.any() and np.linalg.norm(prev.xy[m][0] - ft.xy[j]) > 10:  # the point is >= 7.5 px from the dot
            mid = ft.xy[j] + 0.75 * (prev.xy[m][0] - ft.xy[j])
            assert near(frames[3], *mid, inl_rgb, r=1), j
            assert not near(plain[3], *mid, inl_rgb, r=1), j
            tailed += 1
    assert tailed >= 1
    # keyframes framed in yellow, the others not
    for k in range(N):
        border = frames[k][2, w // 2]
        is_kf = np.abs(border.astype(int) - kf_rgb).max() <= 60
        assert is_kf == (k in KEYFRAMES), k
    # frame 7 has no tracks: no track colour anywhere in the image part
    img7 = frames[7][:, :w].astype(int)
    assert not (np.abs(img7 - inl_rgb).max(axis=2) <= 40).any()
    # the trajectory panel: the path so far grows (more non-background pixels in the last frame)
    bg = np.array(view.PANEL_BG[::-1])

    def drawn(f):
        return int((np.abs(f[30:, w:].astype(int) - bg).max(axis=2) > 40).sum())
    assert drawn(frames[N - 1]) > drawn(frames[1]) > 0


def test_video_and_options(replay_like, tmp_path):
    seq, tracks, traj, _, (w, h), _ = replay_like
    out = tmp_path / "v.avi"
    assert view.main(["--seq", str(seq), "--tracks", str(tracks), "--traj", str(traj), "-o", str(out),
                      "--height", "240", "--stride", "2", "--quiet"]) == 0
    cap = cv2.VideoCapture(str(out))
    frames = []
    while True:
        ok, f = cap.read()
        if not ok:
            break
        frames.append(f)
    assert len(frames) == N // 2
    sw = round(w * 240 / h)
    assert frames[0].shape == (240, sw + 240, 3)
    # .mp4 (mp4v through the FFmpeg of the opencv-python-headless wheel)
    mp4 = tmp_path / "v.mp4"
    assert view.main(["--seq", str(seq), "--tracks", str(tracks), "-o", str(mp4), "--max-frames", "5", "--quiet"]) == 0
    cap = cv2.VideoCapture(str(mp4))
    n = 0
    while cap.read()[0]:
        n += 1
    assert n == 5 and int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)) == w
    # without a trajectory: the image alone
    out2 = tmp_path / "nt.gif"
    assert view.main(["--seq", str(seq), "--tracks", str(tracks), "-o", str(out2), "--max-frames", "4",
                      "--quiet"]) == 0
    n, size, _ = gif_frames(out2)
    assert (n, size) == (4, (w, h))


def test_tum_and_kitti_layouts(replay_like, tmp_path):
    """The same frames in the TUM RGB-D layout (rgb.txt, seconds) and the KITTI layout (times.txt, seconds
    from 0, image_0/%06d.png) render the same pictures as from the EuRoC folder."""
    seq, tracks, _, _, _, ts = replay_like
    _, files = view.read_frames(str(seq))
    tum, kitti = tmp_path / "tum", tmp_path / "kitti"
    (tum / "rgb").mkdir(parents=True)
    (kitti / "image_0").mkdir(parents=True)
    with open(tum / "rgb.txt", "w") as f:
        f.write("# color images\n# timestamp filename\n")
        for t, src in zip(ts, files):
            name = f"rgb/{t // 10**9}.{(t % 10**9) // 1000:06d}.png"
            os.symlink(src, tum / name)
            f.write(f"{t // 10**9}.{(t % 10**9) // 1000:06d} {name}\n")
    with open(kitti / "times.txt", "w") as f:
        for k, (t, src) in enumerate(zip(ts, files)):
            os.symlink(src, kitti / "image_0" / f"{k:06d}.png")
            f.write(f"{(t - ts[0]) * 1e-9:e}\n")
    lines = tracks.read_text().splitlines()
    shifted = tmp_path / "tracks_kitti.csv"
    shifted.write_text("\n".join([lines[0]] + [f"{int(r.split(',')[0]) - ts[0]},{r.split(',', 1)[1]}"
                                                for r in lines[1:]]) + "\n")
    outs = {}
    for name, d, tr in (("euroc", seq, tracks), ("tum", tum, tracks), ("kitti", kitti, shifted)):
        outs[name] = tmp_path / f"{name}.gif"
        assert view.main(["--seq", str(d), "--tracks", str(tr), "-o", str(outs[name]), "--max-frames", "6",
                          "--quiet"]) == 0, name
    ref = gif_frames(outs["euroc"])
    for name in ("tum", "kitti"):
        got = gif_frames(outs[name])
        assert got[:2] == ref[:2] == (6, ref[1]), name
        for a, b in zip(got[2], ref[2]):
            assert np.array_equal(a, b), name


def run_view(*args):
    return subprocess.run([sys.executable, "-m", "tinyvo_tools.view", *map(str, args)], capture_output=True,
                          text=True)


def test_bad_inputs(replay_like, tmp_path):
    seq, tracks, traj, _, _, _ = replay_like
    r = run_view("--seq", seq, "--tracks", tmp_path / "missing.csv", "-o", tmp_path / "x.gif")
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "missing.csv" in r.stderr, r.stderr
    lines = tracks.read_text().splitlines()
    cases = {
        "header": (["t,id,x,y,age,flags"] + lines[1:], ":1:"),
        "fields": (lines[:2] + ["1,2,3,4,5"] + lines[2:], ":3:"),
        "number": (lines[:3] + [f"{lines[1].split(',')[0]},9999,abc,1,1,1"] + lines[3:], ":4:"),
        "flags": (lines[:2] + [f"{lines[1].split(',')[0]},9999,1.0,1.0,1,9"] + lines[2:], ":3:"),
    }
    for name, (content, where) in cases.items():
        p = tmp_path / f"{name}.csv"
        p.write_text("\n".join(content) + "\n")
        r = run_view("--seq", seq, "--tracks", p, "-o", tmp_path / "x.gif")
        assert r.returncode == 1 and r.stderr.count("\n") == 1, (name, r.stderr)
        assert f"{p.name}{where}" in r.stderr and "Traceback" not in r.stderr, (name, r.stderr)
    r = run_view("--seq", tmp_path, "--tracks", tracks, "-o", tmp_path / "x.gif")
    assert r.returncode == 1 and "data.csv" in r.stderr, r.stderr
    r = run_view("--seq", seq, "--tracks", tracks, "-o", tmp_path / "x.png")
    assert r.returncode == 2 and r.stderr.startswith("tinyvo-view: error: --out"), r.stderr
    r = run_view("--seq", seq, "--tracks", tracks, "-o", tmp_path / "x.gif", "--stride", "0")
    assert r.returncode == 2 and "--stride" in r.stderr, r.stderr


def replay_has_tracks():
    if not REPLAY.exists():
        return False
    r = subprocess.run([str(REPLAY), "--help"], capture_output=True, text=True)
    return "--tracks" in r.stdout + r.stderr


def test_replay_tracks_end_to_end(replay_like, tmp_path):
    """tvo_replay --tracks on the synthetic sequence, then tinyvo-view on its output."""
    if not REPLAY.exists():
        pytest.fail(f"{REPLAY} not built (set TVO_BUILD_DIR)")
    if not replay_has_tracks():
        pytest.skip(f"{REPLAY} has no --tracks option (yet): the end-to-end view test needs it")
    seq, _, _, _, (w, h), ts = replay_like
    traj, tracks = tmp_path / "traj.txt", tmp_path / "tracks.csv"
    subprocess.run([str(REPLAY), "--euroc", str(seq), "--out", str(traj), "--scale", "gt", "--tracks", str(tracks),
                    "--quiet"], check=True)
    assert tracks.read_text().splitlines()[0] == "t_ns,id,x,y,age,flags"
    by_t = view.read_tracks(str(tracks))
    assert set(by_t) <= set(ts) and len(by_t) >= N - 2
    # the map starts (its initialisation makes a keyframe) and its tracks carry landmarks; tracked frames
    # have inliers
    assert any(ft.keyframe for ft in by_t.values())
    assert any((ft.flags & view.FLAG_LANDMARK).any() for ft in by_t.values())
    assert sum(int((ft.flags & view.FLAG_INLIER).any()) for ft in by_t.values()) >= N - 3
    for ft in by_t.values():
        assert ((ft.xy >= -1) & (ft.xy <= [w, h])).all()
    out = tmp_path / "e2e.gif"
    r = subprocess.run([sys.executable, "-m", "tinyvo_tools.view", "--seq", str(seq), "--tracks", str(tracks),
                        "--traj", str(traj), "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith(f"tinyvo-view: {N} frames")
    n, size, _ = gif_frames(out)
    assert (n, size) == (N, (w + h, h))
