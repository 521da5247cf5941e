#!/usr/bin/env bash
# Healthy-pool throughput, before/after: alternates two pvrsim binaries on
# the same frame over `--transport processes` and prints the median frame
# time (the report's frame_s: phase 1 + phase 2, wall clock) and the median
# wall time of the whole command (worker start, set-up, frame) of each.
# Usage: scripts/throughput-ab.sh BIN_A BIN_B [RUNS] [SCENE] [NODES]
set -euo pipefail
A=$1; B=$2; RUNS=${3:-7}
SCENE=${4:-../shared/data/aorta-view-b.toml}; N=${5:-4}
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
for i in $(seq "$RUNS"); do
  for bin in A B; do
    exe=${!bin}
    t0=$(date +%s.%N)
    "$exe" cluster "$SCENE" --nodes "$N" --transport processes --no-baselines \
      -o "$W/$bin.png" --report "$W/$bin-$i.json" > /dev/null 2>&1
    t1=$(date +%s.%N)
    echo "$bin $(python3 -c "import json; print(json.load(open('$W/$bin-$i.json'))['frame_s'])") $(python3 -c "print($t1 - $t0)")" >> "$W/times"
  done
done
python3 - "$W/times" "$A" "$B" <<'PY'
import sys, statistics as st
rows = [l.split() for l in open(sys.argv[1])]
for tag, exe in (("A", sys.argv[2]), ("B", sys.argv[3])):
    f = [float(r[1]) for r in rows if r[0] == tag]
    w = [float(r[2]) for r in rows if r[0] == tag]
    print(f"{tag} {exe}: frame median {st.median(f):.4f} s (min {min(f):.4f}, max {max(f):.4f}); "
          f"command median {st.median(w):.3f} s; {len(f)} runs")
PY
