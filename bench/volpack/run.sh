#!/bin/sh
# VolPack (shear-warp, Debian libvolpack1-dev) on pvrsim's grid scenes: the
# scene's orthographic camera, pixel-aligned with pvrsim, RGB colours and
# opacities from its transfer function (bench/volpack/scene.py), one thread.
# Prints one timing line per scene and writes OUT/NAME-volpack.png (the image
# over the scene's background). Needs: apt-get install libvolpack1-dev, a C
# compiler, python3 (3.11+), the release pvrsim binary, the shared data.
#   sh bench/volpack/run.sh [DATA_DIR (default ../shared/data)] [FRAMES (default 9)] [SCENE.toml ...]
# Default scenes: mni152-view and colin27-brain-view.
set -e
D=${1:-../shared/data}
FRAMES=${2:-9}
[ $# -ge 2 ] && shift 2 || shift $#
HERE=$(dirname "$0")
PVRSIM=$HERE/../../target/release/pvrsim
T=${TMPDIR:-/tmp}/pvrsim-volpack
mkdir -p "$T"
[ -f /usr/include/volpack.h ] || { echo "VolPack not installed: apt-get update && apt-get install -y libvolpack1-dev"; exit 2; }
[ -x "$PVRSIM" ] || { echo "build pvrsim first: cargo build --release"; exit 2; }
cc -O2 -o "$T/volpack_bench" "$HERE/volpack_bench.c" -lvolpack -lm
[ $# -gt 0 ] || set -- "$D/mni152-view.toml" "$D/colin27-brain-view.toml"
for s in "$@"; do
    name=$(basename "$s" .toml)
    P=$(python3 "$HERE/scene.py" params "$s" "$PVRSIM" "$T" "$FRAMES")
    "$T/volpack_bench" "$P"
    python3 "$HERE/scene.py" png "$s" "$T/$name.rgba" "$T/$name-volpack.png"
done
