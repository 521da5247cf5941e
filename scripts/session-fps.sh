#!/usr/bin/env bash
# A 24-frame orbit of a mesh scene on 4 worker processes, run by two
# binaries in alternation (A B A B ...): per run, frames per second after
# the first and the median over frames 1.. of the frame's wall time over
# its phase 1 + phase 2 (the session's overhead: 1.0 = none).
#   scripts/session-fps.sh OLD_PVRSIM NEW_PVRSIM [SCENE] [PAIRS]
# Example (issue 54): scripts/session-fps.sh /tmp/landed/pvrsim target/release/pvrsim ../shared/data/aorta-view-b.toml 3
set -euo pipefail
old=$1; new=$2
scene=${3:-tests/data/aorta-small-view-b.toml}
pairs=${4:-3}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
run() {
  timeout 600 "$1" cluster "$scene" --nodes 4 --transport processes --frames 24 --turn 15 \
    --ert 1 --no-baselines -o "$tmp/f.png" --report "$tmp/r.json" >/dev/null 2>&1
  python3 - "$tmp/r.json" <<'PY'
import json, statistics, sys
s = json.load(open(sys.argv[1]))["series"]
later = s["frames"][1:]
ratio = statistics.median(f["frame_s"] / (f["phase1_s"] + f["composite_s"]) for f in later)
print(f"{s['fps_after_first']:.2f} {ratio:.3f}")
PY
}
echo "run binary fps_after_first frame/(phase1+phase2)"
for p in $(seq 1 "$pairs"); do
  echo "$p old $(run "$old")"
  echo "$p new $(run "$new")"
done
