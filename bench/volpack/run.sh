#!/bin/sh
# VolPack (shear-warp, Debian libvolpack1-dev) timing on the shared grids with
# the views and opacities of mni152-view.toml and colin27-brain-view.toml, for
# docs/experiments/grids.md. Needs: apt-get install libvolpack1-dev, a C
# compiler, python3, the shared data.
#   sh bench/volpack/run.sh [DATA_DIR (default ../shared/data)] [FRAMES (default 9)]
set -e
D=${1:-../shared/data}
FRAMES=${2:-9}
T=${TMPDIR:-/tmp}/pvrsim-volpack
mkdir -p "$T"
cc -O2 -o "$T/volpack_bench" "$(dirname "$0")/volpack_bench.c" -lvolpack -lm
# Per-voxel opacity tables from the scenes' transfer functions:
# o(s) piecewise linear, s = (v - r0) / (r1 - r0), corrected to one voxel:
# 1 - (1 - o)^(voxel / unit_distance).
python3 - "$D" "$T" <<'PY'
import sys, tomllib, gzip, struct
d, t = sys.argv[1], sys.argv[2]
def table(scene, r0, r1, voxel):
    tf = tomllib.load(open(f"{d}/{scene}", "rb"))["transfer"]
    pts, ud = tf["points"], tf["unit_distance"]
    out = []
    for v in range(256):
        s = min(max((v - r0) / (r1 - r0), 0.0), 1.0)
        for a, b in zip(pts, pts[1:]):
            if a[0] <= s <= b[0]:
                w = 0.0 if b[0] == a[0] else (s - a[0]) / (b[0] - a[0])
                o = a[4] + w * (b[4] - a[4])
                break
        out.append(1 - (1 - min(o, 1 - 1e-6)) ** (voxel / ud))
    return out
open(f"{t}/mni.txt", "w").write("\n".join(map(str, table("mni152-view.toml", 0, 255, 1.0))))
open(f"{t}/colin.txt", "w").write("\n".join(map(str, table("colin27-brain-view.toml", 0, 130, 0.5))))
b = gzip.open(f"{d}/colin27-brain.nii.gz").read()
off = int(struct.unpack("<f", b[108:112])[0])
assert struct.unpack("<h", b[70:72])[0] == 2, "colin27: expected uint8 voxels"
open(f"{t}/colin27.raw", "wb").write(b[off:off + 301 * 370 * 316])
PY
"$T/volpack_bench" "$D/mni152_t1.raw" 197 233 189 320 -192 -144 0 0 1 256 "$FRAMES" "$T/mni.txt"
"$T/volpack_bench" "$T/colin27.raw" 301 370 316 320 -191.75 -155.75 0 0 1 256 "$FRAMES" "$T/colin.txt"
