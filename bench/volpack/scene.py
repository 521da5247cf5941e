#!/usr/bin/env python3
"""VolPack's parameters for a pvrsim grid scene, and its image as a PNG.

  scene.py params SCENE.toml PVRSIM OUT_DIR FRAMES   -> OUT_DIR/NAME.params
  scene.py png SCENE.toml RGBA_RAW OUT.png           -> the image over the background

`params` reads the scene (scene contract: ../shared/spec/scene.md) and the
grid's dims, spacing and origin (`pvrsim info --json`), and writes what
volpack_bench.c reads: the u8 voxels (raw), the model matrix that takes
VolPack's object coordinates (voxel index i at (i - N/2) / max(N)) to the
scene's eye frame (x right, y up, z towards the eye; world units), the
orthographic window, pixel-aligned with pvrsim (VolPack samples final pixel
p at window coordinate p, pvrsim at p + 1/2: the window is moved by half a
pixel; VolPack's rows run bottom to top, `png` flips them), and per u8 value
the transfer function's colour (0..255) and opacity corrected for VolPack's
sample spacing in this view (one sample per slice of the principal axis:
delta = h_k / |f_k| in world units), 1 - (1 - o)^(delta / unit_distance).
Only orthographic scenes over u8 voxels (.nhdr raw, .nii, .nii.gz) are
supported; anything else is refused with a message.
"""
import gzip
import json
import math
import os
import struct
import subprocess
import sys
import tomllib
import zlib


def fail(msg):
    sys.stderr.write(f"scene.py: {msg}\n")
    sys.exit(2)


def load_scene(path):
    with open(path, "rb") as f:
        s = tomllib.load(f)
    data = os.path.join(os.path.dirname(path), s["data"]["path"])
    return s, data


def raw_voxels(data, dims, out_dir):
    """Path of a raw u8 file of the volume (x fastest)."""
    n = dims[0] * dims[1] * dims[2]
    if data.endswith(".nhdr"):
        fields = {}
        for line in open(data):
            if ":" in line and not line.startswith("#"):
                k, v = line.split(":", 1)
                fields[k.strip()] = v.strip()
        if fields.get("type") not in ("uint8", "uchar", "unsigned char") or fields.get("encoding") != "raw":
            fail(f"{data}: VolPack peer needs raw uint8 NRRD voxels")
        return os.path.abspath(os.path.join(os.path.dirname(data), fields["data file"]))
    if data.endswith(".nii.gz") or data.endswith(".nii"):
        b = gzip.open(data).read() if data.endswith(".gz") else open(data, "rb").read()
        if struct.unpack("<h", b[70:72])[0] != 2:
            fail(f"{data}: VolPack peer needs uint8 voxels")
        off = int(struct.unpack("<f", b[108:112])[0])
        out = os.path.join(out_dir, os.path.basename(data).split(".")[0] + ".raw")
        with open(out, "wb") as f:
            f.write(b[off:off + n])
        return out
    fail(f"{data}: VolPack peer reads .nhdr (raw), .nii and .nii.gz only")


def tf_at(points, s):
    """(r, g, b, opacity) of the piecewise-linear transfer function at s."""
    s = min(max(s, points[0][0]), points[-1][0])
    for a, b in zip(points, points[1:]):
        if a[0] <= s <= b[0]:
            w = 0.0 if b[0] == a[0] else (s - a[0]) / (b[0] - a[0])
            return [a[c] + w * (b[c] - a[c]) for c in range(1, 5)]
    return points[-1][1:5]


def norm(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def params(scene_path, pvrsim, out_dir, frames):
    s, data = load_scene(scene_path)
    cam, img, tf = s["camera"], s["image"], s["transfer"]
    if cam.get("projection", "orthographic") != "orthographic":
        fail(f"{scene_path}: VolPack peer renders orthographic scenes only")
    info = json.loads(subprocess.check_output([pvrsim, "info", "--json", data]))
    if info["voxel_type"] != "u8":
        fail(f"{data}: VolPack peer needs u8 voxels, got {info['voxel_type']}")
    dims, h, origin = info["dims"], info["spacing"], info["origin"]
    r0, r1 = s["data"].get("range", info["value_range"])
    raw = raw_voxels(data, dims, out_dir)
    w, hh = img["width"], img["height"]
    eye, target, up = cam["eye"], cam["target"], cam["up"]
    fwd = norm([t - e for t, e in zip(target, eye)])
    right = norm(cross(fwd, up))
    upv = cross(right, fwd)
    ps = cam["height"] / hh
    # VolPack object coordinates o -> world p = origin + h (max(N) o + N / 2).
    m = max(dims)
    centre = [origin[a] + h[a] * dims[a] / 2 for a in range(3)]
    zc = dot(fwd, [c - e for c, e in zip(centre, eye)])
    rows = []
    # Rows: right, up, and the view direction itself (VolPack's eye frame has
    # its third axis pointing away from the viewer: with -forward it
    # composites the far side first and shows the volume from behind).
    for axis, sign, shift in ((right, 1, 0.0), (upv, 1, 0.0), (fwd, 1, zc)):
        lin = [sign * axis[a] * h[a] * m for a in range(3)]
        t = sign * (dot(axis, [c - e for c, e in zip(centre, eye)]) - shift)
        rows.append(lin + [t])
    rows.append([0.0, 0.0, 0.0, 1.0])
    left, bottom = (-w / 2 + 0.5) * ps, (-hh / 2 + 0.5) * ps
    depth = 0.5 * math.sqrt(sum((h[a] * dims[a]) ** 2 for a in range(3))) + 1.0
    window = [left, left + w * ps, bottom, bottom + hh * ps, -depth, depth]
    # VolPack's step: one slice of the principal axis (largest |f_a / h_a|).
    k = max(range(3), key=lambda a: abs(fwd[a] / h[a]))
    delta = h[k] / abs(fwd[k])
    ud = tf["unit_distance"]
    opac, colour = [], []
    for v in range(256):
        r, g, b, o = tf_at(tf["points"], (v - r0) / (r1 - r0))
        o = min(o, 1 - 1e-6)
        opac.append(1 - (1 - o) ** (delta / ud))
        colour += [255 * r, 255 * g, 255 * b]
    name = os.path.basename(scene_path).rsplit(".", 1)[0]
    out = os.path.join(out_dir, name + ".params")
    with open(out, "w") as f:
        f.write(f"{raw} {dims[0]} {dims[1]} {dims[2]} {w} {hh} {frames}\n")
        for row in rows:
            f.write(" ".join(repr(x) for x in row) + "\n")
        f.write(" ".join(repr(x) for x in window) + "\n")
        f.write(" ".join(repr(x) for x in opac) + "\n")
        f.write(" ".join(repr(x) for x in colour) + "\n")
        f.write(os.path.join(out_dir, name + ".rgba") + "\n")
    print(out)


def png(scene_path, raw_path, out_png):
    s, _ = load_scene(scene_path)
    w, hh = s["image"]["width"], s["image"]["height"]
    bg = s["image"].get("background", [0, 0, 0])
    b = open(raw_path, "rb").read()
    if len(b) != 4 * w * hh:
        fail(f"{raw_path}: expected {4 * w * hh} bytes, got {len(b)}")
    lines = []
    for y in range(hh):
        src = hh - 1 - y  # VolPack's rows run bottom to top
        row = bytearray([0])
        for x in range(w):
            p = b[4 * (src * w + x):4 * (src * w + x) + 4]
            t = 1 - p[3] / 255
            row += bytes(min(255, max(0, round(p[c] + t * 255 * bg[c]))) for c in range(3))
        lines.append(bytes(row))
    def chunk(kind, data):
        c = kind + data
        return struct.pack(">I", len(data)) + c + struct.pack(">I", zlib.crc32(c) & 0xFFFFFFFF)
    with open(out_png, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, hh, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(b"".join(lines), 6)))
        f.write(chunk(b"IEND", b""))


if __name__ == "__main__":
    if len(sys.argv) == 6 and sys.argv[1] == "params":
        params(sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5]))
    elif len(sys.argv) == 5 and sys.argv[1] == "png":
        png(sys.argv[2], sys.argv[3], sys.argv[4])
    else:
        fail(__doc__.split("\n\n")[1])
