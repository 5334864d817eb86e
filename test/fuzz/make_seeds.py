# SPDX-License-Identifier: Apache-2.0
"""Writes the seed inputs of test/fuzz/corpus/<name>/ (seed-*; crash inputs found by the fuzzer are kept
beside them as crash-* / leak-* / timeout-* files, never regenerated). Deterministic.

    .venv/bin/python test/fuzz/make_seeds.py

Sources: exporter output (tinyvo_tools.nnfmt / nngolden: micro models written here, plus a copy of
test/data/nn/tiny.tvonn), files in the EuRoC/ASL formats written here by tinyvo_tools.trajio (the writer
the synth tool uses) with made-up values, small PNGs of a procedural texture, and hand-made edge cases.
Nothing comes from the data folder (TVO_DATA_DIR): its files must not be copied into the repository, not even in part.
"""
from __future__ import annotations

import argparse
import io
import pathlib
import struct
import zlib

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parents[1]


def put(d: pathlib.Path, name: str, data: bytes) -> None:
    d.mkdir(parents=True, exist_ok=True)
    (d / f"seed-{name}").write_bytes(data)


# ---- nn -------------------------------------------------------------------------------------------
def seeds_nn(out: pathlib.Path) -> None:
    from tinyvo_tools import nnfmt, nngolden

    rng = np.random.default_rng(7)
    tiny = (ROOT / "test" / "data" / "nn" / "tiny.tvonn").read_bytes()
    put(out, "tiny.tvonn", tiny)
    # micro models: one per activation, one hidden layer of 4 units (exporter output, ~1 kB each)
    for act in nngolden.BRANCH_ACTS:
        m, _, _ = nngolden.make_model(rng, (4,), acts=[act], calib_n=200)
        put(out, f"micro_{act}.tvonn", nnfmt.write(m))
    m, _, _ = nngolden.make_model(rng, (3, 2), acts=["relu", "tanh", "sigmoid"], calib_n=200)
    good = nnfmt.write(m)
    put(out, "three_branches.tvonn", good)
    # an extreme output scale: finite in the file, overflows float when the model runs
    m, _, _ = nngolden.make_model(rng, (4,), acts=["relu"], calib_n=200)
    m.branches[0].out_scale = 3.0e38
    put(out, "huge_out_scale.tvonn", nnfmt.write(m))
    # hand-made edge cases
    put(out, "empty", b"")
    put(out, "header_only", good[:64])
    bad = bytearray(good)
    bad[12] ^= 1  # wrong CRC
    put(out, "bad_crc.tvonn", bytes(bad))
    put(out, "truncated.tvonn", good[: len(good) - 7])
    bad = bytearray(good)
    bad[4] = 2  # major version 2
    nnfmt.fix_crc(bad)
    put(out, "major2.tvonn", bytes(bad))


# ---- csv ------------------------------------------------------------------------------------------
def seeds_csv(out: pathlib.Path) -> None:
    from tinyvo_tools import trajio

    # EuRoC layout, made-up values: cam data.csv, a ground-truth csv (17 columns) and an 8-column txt
    t0 = 1_400_000_000_000_000_000
    put(out, "cam0_data.csv", ("#timestamp [ns],filename\n" +
                               "".join(f"{t0 + k * 50_000_000},{t0 + k * 50_000_000}.png\n" for k in range(4))).encode())
    rng = np.random.default_rng(3)
    poses = np.stack([trajio.pose_from_pq(rng.normal(size=3), q / np.linalg.norm(q))
                      for q in rng.normal(size=(3, 4))])
    traj = trajio.Trajectory(np.array([t0 + k * 5_000_000 for k in range(3)], dtype=np.int64), poses)
    tmp = out / "tmp-gt.csv"
    out.mkdir(parents=True, exist_ok=True)
    trajio.write_euroc_groundtruth(str(tmp), traj)
    put(out, "groundtruth.csv", tmp.read_bytes())
    tmp.unlink()
    pos, quat = trajio.pq_from_pose(poses)
    put(out, "groundtruth.txt", "".join(
        f"{t} {' '.join(f'{v:.6f}' for v in p)} {' '.join(f'{v:.7f}' for v in q)}\n"
        for t, p, q in zip(traj.t_ns, pos, quat)).encode())
    put(out, "crlf.csv", b"#timestamp [ns],filename\r\n100,a.png\r\n200 , b.png \r\n")
    put(out, "gt_fraction.txt", b"1.5 0 0 0 1 0 0 0\n2.49,1e3,-2,3.5,0,1,0,0,9,9\n3 1 2 3 0.7071068 0.7071068 0 0\n")
    put(out, "gt_wide_gap.txt", b"0 0 0 0 1 0 0 0\n9223372036854775806 1 1 1 0 0 0 1\n")
    put(out, "bad_rows.csv", b"123\n,x.png\n-5,a.png\n7,../x.png\n8,a,b\n")
    put(out, "gt_not_unit.txt", b"1 0 0 0 2 0 0 0\n")


# ---- yaml -----------------------------------------------------------------------------------------
YAML_EQUI = b"""%YAML:1.0
camera_model: pinhole
intrinsics: [190.97, 190.97, 254.93, 256.90]
resolution: [512, 512]
distortion_model: equidistant
distortion_coefficients: [0.0034, 0.0007, -0.0020, 0.0002]
T_BS:
  rows: 4
  cols: 4
  data: [1, 0, 0, 0.1,
         0, 1, 0, 0,
         0, 0, 1, 0,
         0, 0, 0, 1]
rate_hz: 20
"""


def seeds_yaml(out: pathlib.Path) -> None:
    from tinyvo_tools import trajio

    # the ASL sensor.yaml layout as the synth tool writes it (made-up calibration, 4 and 5 coefficients)
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / "tmp-sensor.yaml"
    for name, dist in (("radtan4_sensor.yaml", (-0.25, 0.07, 0.0002, 0.00002)),
                       ("radtan5_sensor.yaml", (-0.3, 0.1, 0.001, -0.001, -0.02))):
        T_BS = np.array([[0.0, -1.0, 0.0, -0.02], [1.0, 0.0, 0.0, -0.06], [0.0, 0.0, 1.0, 0.01], [0, 0, 0, 1.0]])
        cam = trajio.CameraInfo(width=640, height=480, intrinsics=(450.0, 451.0, 321.5, 239.5), distortion=dist,
                                T_BS=T_BS, comment="fuzz seed")
        trajio.write_sensor_yaml(str(tmp), cam)
        put(out, name, tmp.read_bytes())
    tmp.unlink()
    put(out, "equidistant.yaml", YAML_EQUI)
    put(out, "radtan5.yaml", b"intrinsics: [700, 700, 640, 360]\nresolution: [1280, 720]\n"
        b"distortion_coefficients: [-0.3, 0.1, 0.001, -0.001, -0.02]\n"
        b"T_BS:\n  data: [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\n")
    # the real calibration files of the import tests (Kalibr, ROS, OpenCV, EuRoC layouts; sources in
    # test/data/calib/SOURCES.md)
    for f in sorted((ROOT / "test" / "data" / "calib").iterdir()):
        if f.suffix in (".yaml", ".yml"):
            put(out, "calib_" + f.name, f.read_bytes())
    put(out, "flow_map.yaml", b"image_width: 64\nimage_height: 48\ncamera_matrix: {rows: 3, cols: 3,\n"
        b"  data: [50, 0, 32, 0, 50, 24, 0, 0, 1]}\ndistortion_model: equidistant\n"
        b"distortion_coefficients: {rows: 1, cols: 4, data: [0.1, 0.01, 0, 0]}\n")
    put(out, "unclosed.yaml", b"intrinsics: [1, 2, 3, 4\nresolution: [1, 1]\n")
    put(out, "strong_distortion.yaml", b"intrinsics: [100, 100, 50, 50]\nresolution: [100, 100]\n"
        b"distortion_model: radtan\ndistortion_coefficients: [5, -40, 0.5, 0.5, 100]\n"
        b"T_BS:\n  data: [0,-1,0,0, 1,0,0,0, 0,0,1,0, 0,0,0,1]\n")


# ---- dataset (TUM RGB-D, KITTI odometry) ----------------------------------------------------------
def seeds_dataset(out: pathlib.Path) -> None:
    """Frame list, then "\\n---\\n", then a pose file (fuzz_dataset.c); made-up values in the formats of
    TUM's rgb.txt / groundtruth.txt and KITTI's times.txt / calib.txt / poses."""
    from tinyvo_tools import trajio

    rng = np.random.default_rng(5)
    poses = np.stack([trajio.pose_from_pq(rng.normal(size=3), q / np.linalg.norm(q)) for q in rng.normal(size=(3, 4))])
    t = np.array([1305031102_175304000 + k * 33_333_000 for k in range(3)], dtype=np.int64)
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / "tmp-gt.txt"
    trajio.write_tum(str(tmp), trajio.Trajectory(t, poses))
    tum_gt = b"# ground truth trajectory\n# timestamp tx ty tz qx qy qz qw\n" + tmp.read_bytes()
    trajio.write_kitti_poses(str(tmp), trajio.Trajectory(t, poses))
    kitti_poses = tmp.read_bytes()
    tmp.unlink()
    rgb = (b"# color images\n# timestamp filename\n1305031102.175304 rgb/a.png\n"
           b"1305031102.208637 rgb/a.png\n1305031102.241970 rgb/missing.png\n")
    put(out, "tum.txt", rgb + b"\n---\n" + tum_gt)
    put(out, "tum_bad_rows.txt", rgb + b"1305031102.3 ../x.png\nx rgb/a.png\n1.5\n" + b"\n---\n" + tum_gt)
    times = b"0.000000e+00\n1.036000e-01\n2.073000e-01\n"
    put(out, "kitti.txt", times + b"\n---\n" + kitti_poses)
    put(out, "kitti_bad_time.txt", b"0.0\nnan\n0.2\n" + b"\n---\n" + kitti_poses)
    put(out, "kitti_calib.txt", b"P0: 7.070912e+02 0 6.018873e+02 0 0 7.070912e+02 1.831104e+02 0 0 0 1 0\n"
        b"P1: 7.070912e+02 0 6.018873e+02 -3.798145e+02 0 7.070912e+02 1.831104e+02 0 0 0 1 0\n")
    put(out, "kitti_not_rigid.txt", times + b"\n---\n" + b"1 0 0 0 0 2 0 0 0 0 1 0\n" * 3)


# ---- png ------------------------------------------------------------------------------------------
def png_chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)


def seeds_png(out: pathlib.Path) -> None:
    from PIL import Image

    # 32 x 24 px of a procedural texture (smooth blobs plus fine grain), not a real frame
    yy, xx = np.mgrid[0:24, 0:32]
    tex = 128 + 60 * np.sin(xx * 0.45) * np.cos(yy * 0.6) + 30 * np.sin(xx * yy * 0.05)
    crop = Image.fromarray(np.clip(tex, 0, 255).astype(np.uint8), "L")

    def save(name, img, **kw):
        b = io.BytesIO()
        img.save(b, format="PNG", **kw)
        put(out, name, b.getvalue())

    save("gray8.png", crop)
    save("gray1.png", crop.convert("1"))
    save("gray16.png", Image.fromarray(np.asarray(crop).astype(np.uint16) * 257))
    rgb = Image.merge("RGB", (crop, crop.transpose(Image.FLIP_LEFT_RIGHT), crop.transpose(Image.FLIP_TOP_BOTTOM)))
    save("rgb8.png", rgb)
    save("rgba8.png", rgb.convert("RGBA"))
    save("palette.png", rgb.convert("P", palette=Image.ADAPTIVE, colors=16))
    save("gray_alpha.png", crop.convert("LA"))
    save("downscale.png", crop.resize((8, 6)))
    # hand-made: 2-bit grey and an Adam7-interlaced 4x4 grey 8-bit image, written byte by byte
    sig = b"\x89PNG\r\n\x1a\n"

    def raw_png(w, h, depth, color, interlace, raw):
        ihdr = struct.pack(">IIBBBBB", w, h, depth, color, 0, 0, interlace)
        return sig + png_chunk(b"IHDR", ihdr) + png_chunk(b"IDAT", zlib.compress(raw)) + png_chunk(b"IEND", b"")

    put(out, "gray2.png", raw_png(4, 2, 2, 0, 0, b"\x00\x1b\x00\xe4"))
    # an Adam7-interlaced 1x1 image: a single pass
    put(out, "interlaced_1x1.png", raw_png(1, 1, 8, 0, 1, b"\x00\x80"))
    g8 = (out / "seed-gray8.png").read_bytes()
    put(out, "truncated.png", g8[: len(g8) // 2])
    put(out, "huge_dims.png", raw_png(8193, 1, 8, 0, 0, b"\x00" * 8194))
    put(out, "zero_width.png", raw_png(0, 1, 8, 0, 0, b"\x00"))


# ---- vo -------------------------------------------------------------------------------------------
def vo_header(w, h, dist, fx_code, strength, max_tracks, level, fast, seed, win, portable=0, grid=5):
    return bytes([(w - 16) % 81, (h - 16) % 81, (fx_code << 2) | dist, strength & 0xFF, max_tracks - 16,
                  (fast << 2) | level, seed, win | (portable << 3) | (grid << 4)])


def seeds_vo(out: pathlib.Path) -> None:
    # moving texture: 8 frames translating 0.5 px/frame (kind 1), +50 ms each
    h = vo_header(64, 48, 0, 50, 0, 200, 2, 5, 11, 4)
    frames = b"".join(bytes([1, (8 * k) & 0xFF, (4 * k) & 0xFF, 0]) for k in range(8))
    put(out, "texture_pan", h + frames)
    # zoom (forward motion) with radtan distortion and 3 levels
    h = vo_header(80, 64, 1, 55, -60, 150, 3, 3, 3, 3)
    frames = b"".join(bytes([1, 0, 0, (6 * k) & 0xFF]) for k in range(8))
    put(out, "texture_zoom_radtan", h + frames)
    # equidistant, timestamps: repeat, back in time, raw int64 extremes, reset
    h = vo_header(48, 48, 2, 20, 90, 100, 1, 4, 7, 2)
    frames = (bytes([1, 0, 0, 0]) + bytes([1 | 4, 8, 0, 0, 0, 0]) + bytes([1 | 12, 16, 0, 0, 5, 0])
              + bytes([1 | 8, 24, 0, 0]) + struct.pack("<q", -(2 ** 63)) + bytes([1 | 8, 32, 0, 0])
              + struct.pack("<q", 2 ** 63 - 1) + bytes([1 | 16, 40, 0, 0]))
    put(out, "timestamps", h + frames)
    # flat frames and patched frames (no corners, single bright pixels), row stride padding
    h = vo_header(32, 32, 0, 10, 0, 16, 0, 0, 1, 1)
    frames = bytes([3, 128, 2 | (3 << 5), 2, 0, 1, 255, 100, 0, 0, 3, 0, 1, 0, 0, 0])
    put(out, "flat_patched", h + frames)
    # raw bytes: two 64x48 windows of a procedural texture 1 px apart, then the first again
    yy, xx = np.mgrid[0:49, 0:65]
    tex = np.clip(128 + 70 * np.sin(xx * 0.7 + np.sin(yy * 0.3)) * np.cos(yy * 0.5) + 25 * np.cos(xx * yy * 0.11),
                  0, 255).astype(np.uint8)
    c0 = tex[0:48, 0:64].tobytes()
    c1 = tex[1:49, 1:65].tobytes()
    h = vo_header(64, 48, 1, 50, -70, 120, 2, 4, 0, 4)
    put(out, "texture_crops_raw", h + bytes([0]) + c0 + bytes([0]) + c1 + bytes([0]) + c0)
    put(out, "empty", b"")
    put(out, "header_only", vo_header(16, 16, 0, 0, 0, 16, 3, 0, 0, 0))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.parse_args()
    corpus = HERE / "corpus"
    for old in corpus.glob("*/seed-*"):
        old.unlink()
    seeds_nn(corpus / "nn")
    seeds_csv(corpus / "csv")
    seeds_yaml(corpus / "yaml")
    seeds_dataset(corpus / "dataset")
    seeds_png(corpus / "png")
    seeds_vo(corpus / "vo")
    total = sum(p.stat().st_size for p in corpus.rglob("*") if p.is_file())
    print(f"make_seeds: {sum(1 for p in corpus.rglob('seed-*'))} seeds, corpus {total} bytes")


if __name__ == "__main__":
    main()
