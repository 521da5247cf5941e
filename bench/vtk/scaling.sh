#!/bin/sh
# VTK's unstructured-grid ray caster on the meshes of `pvrsim bench --scaling`
# (its --scaling-cache folder: c<N>/demo.toml), each point under a time limit
# (default 300 s: "as far as it finishes in a few minutes"); the cell counts
# are taken in ascending order and the run stops at the first point that does
# not finish. Writes CSV rows (header from scaling.py) to stdout; a point that
# timed out or failed is a row with "timeout"/"failed".
#   PY=/tmp/vtkenv/bin/python sh bench/vtk/scaling.sh CACHE_DIR [SIZES (512 2048)] [LIMIT_S (300)] [THREADS (1)]
# Needs python3 with vtk (see run.sh); off-screen rendering (xvfb-run if there is no display).
set -u
C=$1
SIZES=${2:-512 2048}
LIMIT=${3:-300}
THREADS=${4:-1}
PY=${PY:-python3}
B=$(dirname "$0")
RUN=""
if [ -z "${DISPLAY:-}" ] && command -v xvfb-run >/dev/null; then RUN="xvfb-run -a"; fi
echo "cells,image,threads,load_s,first_frame_s,frame_s,peak_rss_bytes,bytes_per_tet"
for d in $(ls -d "$C"/c* | sed 's/.*\/c//' | sort -n); do
    for s in $SIZES; do
        out=$(timeout "$LIMIT" $RUN "$PY" "$B/scaling.py" "$C/c$d/demo.toml" "$s" "$THREADS" 1 2>/dev/null)
        rc=$?
        out=$(printf '%s\n' "$out" | tail -1)
        if [ $rc -ne 0 ] || [ -z "$out" ]; then
            if [ $rc -eq 124 ]; then echo "$d,$s,$THREADS,timeout"; else echo "$d,$s,$THREADS,failed"; fi
            exit 0
        fi
        echo "$out"
    done
done
