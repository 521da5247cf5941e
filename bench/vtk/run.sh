#!/bin/sh
# slice3d against VTK's CPU ray caster (vtkFixedPointVolumeRayCastMapper) on
# the shared grid scenes, in one run, alternating, for docs/experiments/grids.md:
# frame time (median of the rounds' medians) and the error of both images
# against pvrsim's f64 grid reference (8-bit PNGs, max-abs and RMSE in 1/255).
#
# Needs: python3 with vtk, numpy, pillow (e.g. `python3 -m venv /tmp/vtkenv &&
# /tmp/vtkenv/bin/pip install vtk numpy pillow`; PY=/tmp/vtkenv/bin/python),
# an X server for VTK's window (`apt-get install xvfb`: the script uses
# xvfb-run), a release build of pvrsim, the shared data.
#   sh bench/vtk/run.sh [DATA_DIR (default ../shared/data)] [ROUNDS (default 3)]
set -e
D=${1:-../shared/data}
ROUNDS=${2:-3}
PY=${PY:-python3}
P=${PVRSIM:-target/release/pvrsim}
B=$(dirname "$0")
T=${TMPDIR:-/tmp}/pvrsim-vtk
mkdir -p "$T"
for s in mni152-view colin27-brain-view; do
    [ -f "$T/$s-ref.png" ] || "$P" render "$D/$s.toml" --renderer reference -o "$T/$s-ref.png" >/dev/null
    r=1
    while [ "$r" -le "$ROUNDS" ]; do
        xvfb-run -a "$PY" "$B/render_scene.py" "$D/$s.toml" --out "$T/$s-vtk" --threads 2 \
            --sample-distance 0.25 --repeats 5 |
            "$PY" -c 'import json,sys; print("vtk", json.load(sys.stdin)["median_ms"])'
        i=0
        for i in 1 2 3 4 5; do
            "$P" render "$D/$s.toml" -o "$T/$s-s3d.png" 2>&1 | sed -n 's/.*frame \([0-9.]*\) s.*/slice3d \1/p'
        done | "$PY" -c '
import statistics, sys
v = [float(l.split()[1]) * 1000 for l in sys.stdin]
print("slice3d", statistics.median(v))'
        r=$((r + 1))
    done | "$PY" -c "
import statistics, sys
t = {}
for l in sys.stdin:
    k, v = l.split(); t.setdefault(k, []).append(float(v))
vtk, ours = statistics.median(t['vtk']), statistics.median(t['slice3d'])
print(f'$s: VTK {vtk:.1f} ms, slice3d {ours:.1f} ms (median of $ROUNDS rounds of 5), VTK / slice3d = {vtk / ours:.2f}')"
    printf '%s error vs reference: VTK ' "$s"
    "$PY" "$B/compare.py" "$T/$s-vtk.png" "$T/$s-ref.png"
    printf '%s error vs reference: slice3d ' "$s"
    "$PY" "$B/compare.py" "$T/$s-s3d.png" "$T/$s-ref.png"
done
