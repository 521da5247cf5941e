#!/usr/bin/env bash
# One binary, two scenes (a mesh in its own order and a randomly permuted
# copy, `pvrsim generate permuted`): alternates `render SCENE_A` and
# `render SCENE_B` and prints, per scene, the median and minimum of load and
# of project + scan (the `time:` line's phases; one thread, ERT off by
# default) and the median per-pair ratio B/A of project + scan.
# Usage: scripts/order-ab.sh BIN RUNS SCENE_A SCENE_B [RENDER ARGS...]
# e.g.   scripts/order-ab.sh target/release/pvrsim 7 d/demo.toml d/perm.toml --threads 1 --ert 1
set -euo pipefail
BIN=$1; RUNS=$2; A=$3; B=$4
if [ $# -gt 4 ]; then shift 4; ARGS=("$@"); else ARGS=(--threads 1 --ert 1); fi
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
for i in $(seq "$RUNS"); do
  for s in A B; do
    line=$("$BIN" render "${!s}" "${ARGS[@]}" -o "$W/$s.png" 2>/dev/null | grep 'time:')
    echo "$s $(echo "$line" | sed 's/.*load \([0-9.]*\) s, project \([0-9.]*\) s, scan \([0-9.]*\) s.*/\1 \2 \3/')" >> "$W/times"
  done
done
python3 - "$W/times" "$A" "$B" <<'PY'
import sys, statistics as st
rows = [l.split() for l in open(sys.argv[1])]
runs = {t: [tuple(map(float, r[1:4])) for r in rows if r[0] == t] for t in "AB"}
for tag, scene in (("A", sys.argv[2]), ("B", sys.argv[3])):
    ps = [p + s for _, p, s in runs[tag]]
    ld = [l for l, _, _ in runs[tag]]
    print(f"{tag} {scene}: load median {st.median(ld):.3f} s (min {min(ld):.3f}); "
          f"project+scan median {st.median(ps):.3f} s (min {min(ps):.3f}); "
          f"project {st.median(p for _, p, _ in runs[tag]):.3f}, scan {st.median(s for _, _, s in runs[tag]):.3f}; {len(ps)} runs")
ratios = [(b[1] + b[2]) / (a[1] + a[2]) for a, b in zip(runs["A"], runs["B"])]
print(f"B/A project+scan per pair: median {st.median(ratios):.3f} ({min(ratios):.2f}-{max(ratios):.2f})")
PY
