#!/bin/sh
# Ours (slice3d, and shearwarp, the default for orthographic grid views) beside VolPack (Lacroute's
# shear-warp, classified volume) on mni152-view and colin27-brain-view:
# one thread each, per frame, view-independent preparation excluded on both
# sides (our min-max blocks and tiled texture, our shear-warp run-length
# encodings, VolPack's classification),
# the two binaries alternating ROUNDS times in this one run; prints each
# side's median of the per-round medians (wall time on both sides: the
# alternation spreads the load of a shared machine over both) and the ratio.
#   sh bench/volpack/peer.sh [DATA_DIR (default ../shared/data)] [ROUNDS (default 3)] [FRAMES (default 9)]
# Needs the release build of the example (cargo build --release --example
# slice3d_frames). Without libvolpack1-dev it times ours only and says how
# to install VolPack.
set -e
D=${1:-../shared/data}
ROUNDS=${2:-3}
FRAMES=${3:-9}
HERE=$(dirname "$0")
ROOT=$HERE/../..
OURS=$ROOT/target/release/examples/slice3d_frames
T=${TMPDIR:-/tmp}/pvrsim-volpack-peer
mkdir -p "$T"
[ -x "$OURS" ] || { echo "build ours first: nice -n 5 cargo build --release --example slice3d_frames"; exit 2; }
HAVE_VP=1
if [ ! -f /usr/include/volpack.h ]; then
    HAVE_VP=0
    echo "VolPack not installed: apt-get update && apt-get install -y libvolpack1-dev (Debian/Ubuntu); timing ours only"
fi
: > "$T/log"
for r in $(seq "$ROUNDS"); do
    if [ $HAVE_VP = 1 ]; then
        sh "$HERE/run.sh" "$D" "$FRAMES" | sed "s/^/round $r /" >> "$T/log"
    fi
    for s in mni152-view colin27-brain-view; do
        RAYON_NUM_THREADS=1 LAYOUT=tiled "$OURS" "$D/$s.toml" "$FRAMES" | grep median | sed "s/^/round $r ours $s /" >> "$T/log"
        RAYON_NUM_THREADS=1 RENDERER=shearwarp "$OURS" "$D/$s.toml" "$FRAMES" | grep median | sed "s/^/round $r ours $s /" >> "$T/log"
    done
done
# Errors against the f64 grid reference, all three the same way: the 8-bit
# PNGs against the reference's PNG (examples/png_diff, RGB, 1/255).
PVRSIM=$ROOT/target/release/pvrsim
DIFF=$ROOT/target/release/examples/png_diff
VPT=${TMPDIR:-/tmp}/pvrsim-volpack
if [ -x "$PVRSIM" ] && [ -x "$DIFF" ]; then
    for s in mni152-view colin27-brain-view; do
        "$PVRSIM" render "$D/$s.toml" --renderer reference -o "$T/$s-ref.png" > /dev/null
        "$PVRSIM" render "$D/$s.toml" --renderer slice3d -o "$T/$s.png" > /dev/null
        "$PVRSIM" render "$D/$s.toml" --renderer shearwarp -o "$T/$s-sw.png" > /dev/null
        "$DIFF" "$T/$s.png" "$T/$s-ref.png" | sed "s/^/error ours $s /" >> "$T/log"
        "$DIFF" "$T/$s-sw.png" "$T/$s-ref.png" | sed "s/^/error shearwarp $s /" >> "$T/log"
        if [ -f "$VPT/$s-volpack.png" ]; then
            "$DIFF" "$VPT/$s-volpack.png" "$T/$s-ref.png" | sed "s/^/error volpack $s /" >> "$T/log"
        fi
    done
else
    echo "no error columns: build pvrsim and the png_diff example (cargo build --release --examples)"
fi
python3 - "$T/log" <<'PY'
import re, sys, statistics
vp = {"197x233x189": [], "301x370x316": []}
ours = {"mni152-view": [], "colin27-brain-view": []}
sw = {"mni152-view": [], "colin27-brain-view": []}
err = {"ours": {}, "shearwarp": {}, "volpack": {}}
for line in open(sys.argv[1]):
    m = re.search(r"volpack (\d+x\d+x\d+) .*frame median cpu [\d.]+ ms, wall ([\d.]+) ms", line)
    if m:
        vp[m.group(1)].append(float(m.group(2)))
    m = re.search(r"error (ours|shearwarp|volpack) (\S+) max (\d+)/255.*RMSE ([\d.]+)/255", line)
    if m:
        err[m.group(1)][m.group(2)] = f"{m.group(3)} / {float(m.group(4)):.2f}"
        continue
    m = re.search(r"ours (\S+) Tiled: median ([\d.]+) ms", line)
    if m:
        ours[m.group(1)].append(float(m.group(2)))
    m = re.search(r"ours (\S+) ShearWarp: median ([\d.]+) ms", line)
    if m:
        sw[m.group(1)].append(float(m.group(2)))
print("| scene | ours slice3d ms | ours shearwarp ms | VolPack ms | shearwarp / VolPack | slice3d max / RMSE | shearwarp max / RMSE | VolPack max / RMSE |")
print("|---|---|---|---|---|---|---|---|")
def e(who, s):
    return err[who].get(s, "-")
for s, v in [("mni152-view", "197x233x189"), ("colin27-brain-view", "301x370x316")]:
    o = statistics.median(ours[s])
    q = statistics.median(sw[s]) if sw[s] else float("nan")
    if vp[v]:
        w = statistics.median(vp[v])
        print(f"| {s} | {o:.1f} | {q:.1f} | {w:.1f} | {q / w:.2f} | {e('ours', s)} | {e('shearwarp', s)} | {e('volpack', s)} |")
    else:
        print(f"| {s} | {o:.1f} | {q:.1f} | (not installed) | | {e('ours', s)} | {e('shearwarp', s)} | - |")
print("One thread each, medians of the per-round medians; VolPack's classification and our")
print("preparation excluded.")
print("Errors (max / RMSE, 1/255): each 8-bit PNG against the f64 grid reference's PNG, RGB;")
print("VolPack renders RGBA with the scene's camera, pixel-aligned (bench/volpack/scene.py).")
PY
