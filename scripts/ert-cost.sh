#!/usr/bin/env bash
# What ERT costs where it skips (almost) nothing: alternates one pvrsim
# binary's `render SCENE` at `--ert 1` (off) and at the default threshold
# (0.99), and prints per setting the median whole-process wall time
# (bash's EPOCHREALTIME, microseconds), the frame's total and project + scan
# (the `time:` line), then the median per-pair ratios default / off. One
# thread by default.
# Usage: scripts/ert-cost.sh BIN [PAIRS] [SCENE] [RENDER ARGS...]
# e.g.   scripts/ert-cost.sh target/release/pvrsim 25 ../shared/data/aorta-view-a.toml
set -euo pipefail
BIN=$1; PAIRS=${2:-15}
SCENE=${3:-../shared/data/aorta-view-a.toml}
if [ $# -gt 3 ]; then shift 3; ARGS=("$@"); else ARGS=(--threads 1); fi
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
for i in $(seq "$PAIRS"); do
  for ert in 1 0.99; do
    t0=$EPOCHREALTIME
    "$BIN" render "$SCENE" "${ARGS[@]}" --ert "$ert" -o "$W/x.png" > "$W/out" 2>/dev/null
    t1=$EPOCHREALTIME
    python3 -c "print(f'{$t1 - $t0:.6f}')" > "$W/wall"
    phases=$(grep 'time:' "$W/out" |
      sed 's/.*project \([0-9.]*\) s, scan \([0-9.]*\) s.*total \([0-9.]*\) s.*/\1 \2 \3/')
    echo "$ert $(cat "$W/wall") $phases" >> "$W/times"
  done
done
python3 - "$W/times" <<'PY'
import sys, statistics as st
rows = [l.split() for l in open(sys.argv[1])]
runs = {e: [(float(w), float(tot), float(p) + float(s)) for t, w, p, s, tot in rows if t == e]
        for e in ("1", "0.99")}
for e, name in (("1", "--ert 1   "), ("0.99", "--ert 0.99")):
    print(f"{name}: wall median {st.median(r[0] for r in runs[e]):.3f} s, "
          f"frame total {st.median(r[1] for r in runs[e]):.4f} s, "
          f"project+scan {st.median(r[2] for r in runs[e]):.4f} s ({len(runs[e])} runs)")
for k, what in ((0, "wall"), (1, "frame total"), (2, "project+scan")):
    r = [b[k] / a[k] for a, b in zip(runs["1"], runs["0.99"])]
    print(f"0.99 / 1 per pair, {what}: median {st.median(r):.3f} ({min(r):.2f}-{max(r):.2f})")
PY
