#!/usr/bin/env bash
# Order check of the alternating-pair design: runs one pvrsim binary's
# `render SCENE` at `--ert A` then `--ert B` in each of PAIRS pairs and
# prints the median per-pair ratio second / first of the whole-process wall
# time (bash's EPOCHREALTIME) and of the frame's total (the `time:` line).
# With A = B the ratio shows the design's own bias (1 if none).
# Usage: scripts/pair-order.sh BIN PAIRS A B [SCENE]
# e.g.   scripts/pair-order.sh target/release/pvrsim 60 1 0.99
set -euo pipefail
BIN=$1; PAIRS=$2; A=$3; B=$4
SCENE=${5:-../shared/data/aorta-view-a.toml}
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
for i in $(seq "$PAIRS"); do
  for ert in "$A" "$B"; do
    t0=$EPOCHREALTIME
    "$BIN" render "$SCENE" --threads 1 --ert "$ert" -o "$W/x.png" > "$W/out" 2>/dev/null
    t1=$EPOCHREALTIME
    tot=$(grep 'time:' "$W/out" | sed 's/.*total \([0-9.]*\) s.*/\1/')
    echo "$t0 $t1 $tot" >> "$W/times"
  done
done
python3 - "$W/times" <<'PY'
import sys, statistics as st
rows = [l.split() for l in open(sys.argv[1])]
first, second = rows[0::2], rows[1::2]
wall = [(float(b[1]) - float(b[0])) / (float(a[1]) - float(a[0])) for a, b in zip(first, second)]
total = [float(b[2]) / float(a[2]) for a, b in zip(first, second)]
print(f"second / first per pair: wall median {st.median(wall):.4f}, "
      f"frame total median {st.median(total):.4f} ({len(wall)} pairs)")
PY
