#!/usr/bin/env bash
# One frame, before/after: alternates two pvrsim binaries on `render SCENE`
# and prints, per binary, the median and minimum of project + scan (the
# `time:` line's phases, one thread by default) and the median per-pair ratio.
# Usage: scripts/frame-ab.sh BIN_A BIN_B [RUNS] [SCENE] [RENDER ARGS...]
# e.g.   scripts/frame-ab.sh old/pvrsim target/release/pvrsim 10 a20/demo.toml --threads 1 --ert 1
set -euo pipefail
A=$1; B=$2; RUNS=${3:-7}
SCENE=${4:-../shared/data/aorta-view-b.toml}
if [ $# -gt 4 ]; then shift 4; ARGS=("$@"); else ARGS=(--threads 1); fi
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
for i in $(seq "$RUNS"); do
  for bin in A B; do
    exe=${!bin}
    line=$("$exe" render "$SCENE" "${ARGS[@]}" -o "$W/$bin.png" 2>/dev/null | grep 'time:')
    echo "$bin $(echo "$line" | sed 's/.*project \([0-9.]*\) s, scan \([0-9.]*\) s.*/\1 \2/')" >> "$W/times"
  done
done
python3 - "$W/times" "$A" "$B" <<'PY'
import sys, statistics as st
rows = [l.split() for l in open(sys.argv[1])]
runs = {t: [(float(r[1]), float(r[2])) for r in rows if r[0] == t] for t in "AB"}
for tag, exe in (("A", sys.argv[2]), ("B", sys.argv[3])):
    ps = [p + s for p, s in runs[tag]]
    print(f"{tag} {exe}: project+scan median {st.median(ps):.3f} s (min {min(ps):.3f}); "
          f"project {st.median(p for p, _ in runs[tag]):.3f}, scan {st.median(s for _, s in runs[tag]):.3f}; {len(ps)} runs")
ratios = [sum(a) / sum(b) for a, b in zip(runs["A"], runs["B"])]
print(f"A/B per pair: median {st.median(ratios):.3f} ({min(ratios):.2f}-{max(ratios):.2f})")
PY
