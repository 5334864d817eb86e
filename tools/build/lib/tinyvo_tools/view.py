# SPDX-License-Identifier: Apache-2.0
"""A picture of what the VO sees: a replay rendered into an animated GIF or a video.

    tinyvo-view --seq DIR --tracks TRACKS.csv [--traj TRAJ.txt] -o OUT.gif|OUT.avi|OUT.mp4
                [--fps F] [--stride K] [--max-frames N] [--height PX] [--trail N] [--quiet]

Each output frame shows, on the left, the sequence's frame (the raw, distorted image) with the tracks alive
after it: inliers of the frame's pose in green, the other tracks (outliers, or tracks not used by the
pose) in red, a filled dot for a track that has a map landmark, a short tail through its last --trail
positions; a keyframe is framed in yellow and labelled. On the right, seen from above: the trajectory so
far (the two axes along which the whole trajectory extends most, equal scale), the keyframes' positions
(yellow squares) and the current position.

Inputs:
- DIR: the sequence folder tvo_replay read: EuRoC/ASL (DIR/mav0/cam0/data.csv and data/*.png, as
  tinyvo-synth writes; or a camera folder holding data.csv and data/), TUM RGB-D (rgb.txt) or KITTI
  odometry (times.txt, image_0/);
- TRACKS.csv: the per-frame tracks of ``tvo_replay --tracks FILE``: a header line ``t_ns,id,x,y,age,flags``,
  then one row per track alive after each frame: t_ns the frame's timestamp (ns), id the track's id, x y its
  position in pixels of the raw image, age in frames, flags bit 0 = inlier of this frame's pose, bit 1 =
  has a map landmark, bit 2 = the frame is a keyframe (set on every row of that frame); a frame's rows
  are those whose t_ns is nearest its timestamp, within 1 ms;
- TRAJ.txt (optional): the replay's TUM trajectory (``tvo_replay --out``: t tx ty tz qx qy qz qw, t in
  seconds), camera positions; frames are matched by timestamp (within 1 ms).

Output by extension: .gif (animated GIF, Pillow, adaptive palette per frame, loops), .avi (Motion-JPEG
through OpenCV's VideoWriter: always available in opencv-python-headless), .mp4 (MPEG-4 part 2, fourcc
mp4v, through the FFmpeg bundled with opencv-python(-headless) wheels). A GIF is held in memory until it
is written (about width x height bytes per frame): for long sequences use .avi / .mp4, or --stride and
--height. Frames with no row in TRACKS.csv
(e.g. the VO was lost) are drawn without tracks. Exit status: 0 written, 1 unreadable or malformed input
(one line naming the file and row), 2 usage error.
"""
from __future__ import annotations

import csv
import decimal
import os
import sys
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from . import cli

TRACKS_HEADER = ["t_ns", "id", "x", "y", "age", "flags"]
FLAG_INLIER, FLAG_LANDMARK, FLAG_KEYFRAME = 1, 2, 4
# BGR (OpenCV order)
INLIER_BGR = (60, 220, 60)
OUTLIER_BGR = (40, 40, 235)
KEYFRAME_BGR = (0, 215, 255)
TRAJ_BGR = (235, 235, 235)
PANEL_BG = (32, 32, 32)


@dataclass
class FrameTracks:
    ids: np.ndarray    # int64
    xy: np.ndarray     # (n, 2) float64, raw-image pixels
    age: np.ndarray    # int64
    flags: np.ndarray  # int64

    @property
    def keyframe(self) -> bool:
        return bool(len(self.flags) and (self.flags[0] & FLAG_KEYFRAME))


def read_tracks(path: str) -> Dict[int, FrameTracks]:
    """TRACKS.csv -> {t_ns: FrameTracks}. Raises ValueError naming the line for a bad header or row."""
    by_t: Dict[int, List[Tuple[int, float, float, int, int]]] = {}
    with open(path, "r", encoding="utf-8", newline="") as f:
        rd = csv.reader(f)
        header = next(rd, None)
        if header is None or [h.strip() for h in header] != TRACKS_HEADER:
            raise ValueError(f"{path}:1: header must be {','.join(TRACKS_HEADER)}, got {','.join(header or [])!r}")
        for row in rd:
            line = rd.line_num
            if not row or (len(row) == 1 and not row[0].strip()):
                continue
            if len(row) != 6:
                raise ValueError(f"{path}:{line}: {len(row)} fields, expected 6 ({','.join(TRACKS_HEADER)})")
            try:
                t, i, age, fl = int(row[0]), int(row[1]), int(row[4]), int(row[5])
                x, y = float(row[2]), float(row[3])
            except ValueError:
                raise ValueError(f"{path}:{line}: not numbers: {','.join(row)!r}") from None
            if not (np.isfinite(x) and np.isfinite(y)) or age < 0 or not 0 <= fl < 8:
                raise ValueError(f"{path}:{line}: x, y must be finite, age >= 0, flags in 0..7: {','.join(row)!r}")
            by_t.setdefault(t, []).append((i, x, y, age, fl))
    out = {}
    for t, rows in by_t.items():
        a = np.array(rows, dtype=np.float64)
        fl = a[:, 4].astype(np.int64)
        kf = fl & FLAG_KEYFRAME
        if kf.any() and not kf.all():
            raise ValueError(f"{path}: frame {t}: the keyframe flag (bit 2) is set on some rows only")
        out[t] = FrameTracks(a[:, 0].astype(np.int64), a[:, 1:3].copy(), a[:, 3].astype(np.int64), fl)
    return out


def _ns(token: str, where: str) -> int:
    """Seconds with a decimal fraction or an exponent ("1305031102.175304", "1.036000e-01") -> int ns,
    exactly (decimal arithmetic, as the C readers)."""
    try:
        return int((decimal.Decimal(token) * 1_000_000_000).to_integral_value(decimal.ROUND_HALF_EVEN))
    except decimal.InvalidOperation:
        raise ValueError(f"{where}: bad timestamp {token!r}") from None


def read_frames(seq: str) -> Tuple[List[int], List[str]]:
    """Timestamps (ns) and image paths of a sequence folder, in the layouts tvo_replay reads: EuRoC/ASL
    (mav0/cam0/data.csv + data/, or a camera folder holding data.csv), TUM RGB-D (rgb.txt) or KITTI
    odometry (times.txt + image_0/)."""
    cam = os.path.join(seq, "mav0", "cam0")
    if not os.path.isfile(os.path.join(cam, "data.csv")):
        cam = seq
    csv_path = os.path.join(cam, "data.csv")
    ts, files = [], []
    if os.path.isfile(csv_path):
        kind, path = "euroc", csv_path
    elif os.path.isfile(os.path.join(seq, "rgb.txt")):
        kind, path = "tum", os.path.join(seq, "rgb.txt")
    elif os.path.isfile(os.path.join(seq, "times.txt")):
        kind, path = "kitti", os.path.join(seq, "times.txt")
    else:
        raise cli.Failure(f"{seq}: no mav0/cam0/data.csv, rgb.txt or times.txt (not an EuRoC, TUM or KITTI sequence)")
    with open(path, "r", encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            where = f"{path}:{n}"
            if kind == "euroc":
                parts = [p.strip() for p in s.split(",")]
                try:
                    t = int(parts[0])
                except ValueError:
                    raise ValueError(f"{where}: bad timestamp {parts[0]!r}") from None
                if len(parts) < 2 or not parts[1]:
                    raise ValueError(f"{where}: no file name")
                name = os.path.join(cam, "data", parts[1])
            elif kind == "tum":
                parts = s.split()
                if len(parts) < 2:
                    raise ValueError(f"{where}: expected 'timestamp filename'")
                t, name = _ns(parts[0], where), os.path.join(seq, parts[1])
            else:
                t, name = _ns(s.split()[0], where), os.path.join(seq, "image_0", f"{len(ts):06d}.png")
            ts.append(t)
            files.append(name)
    if not ts:
        raise cli.Failure(f"{path}: no frames")
    return ts, files


class _Nearest:
    """Lookup of the entry whose timestamp is nearest t, within tol_ns (the tracks and trajectory files
    may carry a frame's time rounded differently from the frame list)."""

    def __init__(self, t_ns: Sequence[int], tol_ns: int = 1_000_000):
        self.t = np.asarray(sorted(t_ns), dtype=np.int64)
        self.tol = tol_ns

    def index(self, t: int) -> Optional[int]:
        if len(self.t) == 0:
            return None
        j = int(np.searchsorted(self.t, t))
        best = min((c for c in (j - 1, j) if 0 <= c < len(self.t)), key=lambda c: abs(int(self.t[c]) - t))
        return best if abs(int(self.t[best]) - t) <= self.tol else None

    def key(self, t: int) -> Optional[int]:
        i = self.index(t)
        return None if i is None else int(self.t[i])


def read_positions(path: str) -> Tuple[np.ndarray, np.ndarray]:
    """TUM trajectory -> (t_ns, positions (n, 3))."""
    from . import trajio
    tr = trajio.read_tum(path)
    return tr.t_ns, tr.positions


def plane_axes(p: np.ndarray) -> Tuple[int, int]:
    """The two coordinate axes along which positions p extend most (the 'top view' of the trajectory),
    in increasing order."""
    if len(p) == 0:
        return 0, 2
    ext = p.max(axis=0) - p.min(axis=0)
    a, b = sorted(np.argsort(-ext, kind="stable")[:2].tolist())
    return a, b


class TrajPanel:
    """Maps trajectory positions on the plane of axes (a, b) into a size x size panel (equal scale)."""

    def __init__(self, p: np.ndarray, size: int):
        self.size = size
        self.a, self.b = plane_axes(p)
        q = p[:, [self.a, self.b]] if len(p) else np.zeros((1, 2))
        lo, hi = q.min(axis=0), q.max(axis=0)
        span = max(float((hi - lo).max()), 1e-6)
        self.centre = (lo + hi) / 2
        self.scale = (size - 40) / span

    def px(self, p: np.ndarray) -> np.ndarray:
        q = (np.atleast_2d(p)[:, [self.a, self.b]] - self.centre) * self.scale
        # panel x = axis a, panel y = axis b upwards
        return np.stack([self.size / 2 + q[:, 0], self.size / 2 - q[:, 1]], axis=1)


def _text(img: np.ndarray, text: str, org: Tuple[int, int], colour, scale: float = 0.45) -> None:
    """text at org (baseline left) on a dark box, legible on any image"""
    import cv2
    (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    x, y = org
    cv2.rectangle(img, (x - 3, y - th - 3), (x + tw + 3, y + base + 1), (0, 0, 0), -1)
    cv2.putText(img, text, (x, y), cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv2.LINE_AA)


def render_frame(img: np.ndarray, tracks: Optional[FrameTracks], history: Dict[int, List[Tuple[float, float]]],
                 panel: Optional[TrajPanel], traj_px: np.ndarray, kf_px: np.ndarray, scale: float,
                 label: str) -> np.ndarray:
    """One output frame (BGR uint8): the image with the tracks and, when a trajectory is given, the panel."""
    import cv2
    h, w = img.shape[:2]
    left = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR) if img.ndim == 2 else img.copy()
    if scale != 1.0:
        left = cv2.resize(left, (round(w * scale), round(h * scale)), interpolation=cv2.INTER_AREA)
    if tracks is not None:
        for i, (x, y), fl in zip(tracks.ids, tracks.xy, tracks.flags):
            col = INLIER_BGR if fl & FLAG_INLIER else OUTLIER_BGR
            tail = history.get(int(i), [])
            for (x0, y0), (x1, y1) in zip(tail[:-1], tail[1:]):
                cv2.line(left, (round(x0 * scale), round(y0 * scale)), (round(x1 * scale), round(y1 * scale)),
                         col, 1, cv2.LINE_AA)
            c = (round(x * scale), round(y * scale))
            cv2.circle(left, c, 3, col, -1 if fl & FLAG_LANDMARK else 1, cv2.LINE_AA)
        if tracks.keyframe:
            cv2.rectangle(left, (1, 1), (left.shape[1] - 2, left.shape[0] - 2), KEYFRAME_BGR, 3)
            _text(left, "keyframe", (8, left.shape[0] - 10), KEYFRAME_BGR, 0.5)
        n_in = int(np.count_nonzero(tracks.flags & FLAG_INLIER))
        label = f"{label}  tracks {len(tracks.ids)}  inliers {n_in}"
    else:
        label = f"{label}  no tracks"
    _text(left, label, (8, 18), (255, 255, 255))
    if panel is None:
        return left
    right = np.full((left.shape[0], panel.size, 3), PANEL_BG, np.uint8)
    off = (left.shape[0] - panel.size) // 2
    if len(traj_px) > 1:
        pts = np.round(traj_px + [0, off]).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(right, [pts], False, TRAJ_BGR, 1, cv2.LINE_AA)
    for x, y in kf_px:
        cv2.rectangle(right, (round(x) - 3, round(y + off) - 3), (round(x) + 3, round(y + off) + 3), KEYFRAME_BGR, 1)
    if len(traj_px):
        x, y = traj_px[-1]
        cv2.circle(right, (round(x), round(y + off)), 4, INLIER_BGR, -1, cv2.LINE_AA)
    axes = "xyz"
    _text(right, f"trajectory ({axes[panel.a]}-{axes[panel.b]} plane)", (8, 18), (255, 255, 255))
    return np.hstack([left, right])


class _Writer:
    def __init__(self, path: str, fps: float):
        self.path, self.fps = path, fps
        self.ext = os.path.splitext(path)[1].lower()
        self.frames: List = []
        self.video = None

    def add(self, bgr: np.ndarray) -> None:
        if self.ext == ".gif":
            from PIL import Image
            rgb = Image.fromarray(np.ascontiguousarray(bgr[:, :, ::-1]))
            self.frames.append(rgb.convert("P", palette=Image.Palette.ADAPTIVE, colors=256))
            return
        import cv2
        if self.video is None:
            fourcc = cv2.VideoWriter_fourcc(*("MJPG" if self.ext == ".avi" else "mp4v"))
            self.video = cv2.VideoWriter(self.path, fourcc, self.fps, (bgr.shape[1], bgr.shape[0]))
            if not self.video.isOpened():
                raise cli.Failure(f"{self.path}: OpenCV cannot write {self.ext} here (try .gif or .avi)")
        self.video.write(bgr)

    def close(self) -> None:
        if self.ext == ".gif":
            if self.frames:
                # duration in ms per frame; disposal 1: each frame replaces the previous one whole
                self.frames[0].save(self.path, save_all=True, append_images=self.frames[1:], loop=0,
                                    duration=max(20, round(1000 / self.fps)), optimize=False, disposal=1)
        elif self.video is not None:
            self.video.release()


def render(seq: str, tracks_path: str, out: str, traj_path: Optional[str] = None, fps: Optional[float] = None,
           stride: int = 1, max_frames: int = 0, height: int = 0, trail: int = 10,
           progress: bool = False) -> Dict[str, int]:
    """Render the replay; returns {"frames": written, "width": .., "height": .., "with_tracks": ..}."""
    import cv2
    ts, files = read_frames(seq)
    tracks = read_tracks(tracks_path)
    sel = list(range(0, len(ts), stride))
    if max_frames:
        sel = sel[:max_frames]
    if fps is None:
        dt = np.diff(ts)
        fps = float(1e9 / np.median(dt)) / stride if len(dt) and np.median(dt) > 0 else 10.0
    tpos = tp = None
    if traj_path:
        tpos, tp = read_positions(traj_path)
        order = np.argsort(tpos, kind="stable")
        tpos, tp = tpos[order], tp[order]
    near_tracks = _Nearest(tracks.keys())
    near_traj = _Nearest(tpos if tpos is not None else [])

    def tracks_at(t):
        key = near_tracks.key(t)
        return None if key is None else tracks[key]
    panel, traj_pts = None, []
    history: Dict[int, List[Tuple[float, float]]] = {}
    kf_pos: List[np.ndarray] = []
    w = _Writer(out, fps)
    size = None
    n_tracks = 0
    for n, k in enumerate(sel):
        img = cv2.imread(files[k], cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise cli.Failure(f"{files[k]}: cannot read the frame")
        scale = height / img.shape[0] if height else 1.0
        if panel is None and tp is not None:
            panel = TrajPanel(tp, round(img.shape[0] * scale))
        t = ts[k]
        ft = tracks_at(t)
        # every frame of the sequence (also those skipped by --stride) extends the tails
        for kk in range(sel[n - 1] + 1 if n else 0, k + 1):
            fk = tracks_at(ts[kk])
            if fk is None:
                continue
            alive = set(fk.ids.tolist())
            for i in list(history):
                if i not in alive:
                    del history[i]
            for i, (x, y) in zip(fk.ids.tolist(), fk.xy):
                history.setdefault(i, []).append((float(x), float(y)))
                del history[i][:-max(trail, 1)]
        if ft is not None:
            n_tracks += 1
        cur = None
        if tp is not None:
            j = near_traj.index(t)
            if j is not None:
                cur = tp[j]
        if cur is not None:
            traj_pts.append(cur)
            if ft is not None and ft.keyframe:
                kf_pos.append(cur)
        traj_px = panel.px(np.array(traj_pts)) if panel is not None and traj_pts else np.zeros((0, 2))
        kf_px = panel.px(np.array(kf_pos)) if panel is not None and kf_pos else np.zeros((0, 2))
        frame = render_frame(img, ft, history if trail > 1 else {}, panel, traj_px, kf_px, scale,
                             f"{n + 1}/{len(sel)}  t {(t - ts[0]) * 1e-9:.2f} s")
        if size is None:
            size = frame.shape[1], frame.shape[0]
        w.add(frame)
        if progress and (n + 1) % 50 == 0:
            print(f"tinyvo-view: {n + 1}/{len(sel)} frames", file=sys.stderr)
    w.close()
    return {"frames": len(sel), "width": size[0] if size else 0, "height": size[1] if size else 0,
            "with_tracks": n_tracks}


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = cli.parser("tinyvo-view", __doc__)
    ap.add_argument("--seq", required=True, help="sequence folder: EuRoC/ASL (mav0/), TUM RGB-D (rgb.txt) or KITTI (times.txt)")
    ap.add_argument("--tracks", required=True, help="per-frame tracks csv (tvo_replay --tracks)")
    ap.add_argument("--traj", default=None, help="the replay's TUM trajectory (tvo_replay --out): adds the panel")
    ap.add_argument("-o", "--out", required=True, help="output file: .gif, .avi (MJPG) or .mp4 (mp4v)")
    ap.add_argument("--fps", type=float, default=None, help="frames per second (default: the sequence's rate / stride)")
    ap.add_argument("--stride", type=int, default=1, help="draw every K-th frame (default 1)")
    ap.add_argument("--max-frames", type=int, default=0, help="stop after N output frames (0: all)")
    ap.add_argument("--height", type=int, default=0, help="scale the image to this height in pixels (0: as is)")
    ap.add_argument("--trail", type=int, default=10, help="tail length of each track in frames (1: no tail)")
    a = ap.parse_args(argv)
    if os.path.splitext(a.out)[1].lower() not in (".gif", ".avi", ".mp4"):
        ap.error(f"--out {a.out!r}: the extension must be .gif, .avi or .mp4")
    if a.fps is not None and not (np.isfinite(a.fps) and 0 < a.fps <= 1000):
        ap.error("--fps must be in (0, 1000]")
    if a.stride < 1 or a.max_frames < 0 or a.trail < 1 or not 0 <= a.height <= 4096:
        ap.error("--stride and --trail must be >= 1, --max-frames >= 0, --height in 0..4096")
    return cli.run(ap.prog, lambda: _main(a))


def _main(a) -> int:
    info = render(a.seq, a.tracks, a.out, a.traj, a.fps, a.stride, a.max_frames, a.height, a.trail,
                  progress=not a.quiet)
    cli.log(a.quiet, f"tinyvo-view: {info['frames']} frames ({info['with_tracks']} with tracks), "
                     f"{info['width']}x{info['height']} -> {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
