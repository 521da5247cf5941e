#!/usr/bin/env bash
# Bit-identity check of two pvrsim binaries: renders the same scenes and
# options (ERT off and on: thresholds, structures, spans, update rates)
# with both and compares the PNGs byte for byte (`cmp`). Exit 1 if
# any differ or fail. DATA is the shared data folder (the aorta scenes);
# BIG, if given, a large scene (e.g. the 20 M demo) rendered on 2 threads.
# Usage: scripts/same-images.sh BIN_A BIN_B [DATA] [BIG]
set -uo pipefail
A=$1; B=$2; DATA=${3:-../shared/data}; BIG=${4:-}
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
# A perspective view B and view B at 1200x1000, from the shared scene.
sed "s/projection = \"orthographic\"/projection = \"perspective\"\nfov_y_deg = 30.0/; s#path  = \"aorta.vtk\"#path = \"$(realpath "$DATA")/aorta.vtk\"#" \
  "$DATA/aorta-view-b.toml" > "$W/persp-b.toml"
sed "s/width      = 300/width = 1200/; s/height     = 300/height = 1000/; s#path  = \"aorta.vtk\"#path = \"$(realpath "$DATA")/aorta.vtk\"#" \
  "$DATA/aorta-view-b.toml" > "$W/big-b.toml"
fail=0; i=0
while IFS='|' read -r scene args; do
  [ -z "$scene" ] && continue
  i=$((i + 1))
  # shellcheck disable=SC2086
  if ! "$A" render "$scene" $args -o "$W/a$i.png" > /dev/null 2>&1 ||
     ! "$B" render "$scene" $args -o "$W/b$i.png" > /dev/null 2>&1; then
    echo "FAILED $scene $args"; fail=1; continue
  fi
  if cmp -s "$W/a$i.png" "$W/b$i.png"; then echo "same  $scene $args"; else echo "DIFF  $scene $args"; fail=1; fi
done <<LIST
$DATA/aorta-view-a.toml|--threads 1 --ert 1
$DATA/aorta-view-a.toml|--threads 2
$DATA/aorta-view-b.toml|--threads 1 --ert 1
$DATA/aorta-view-b.toml|--threads 2 --ert 1 --canonical
$DATA/aorta-view-b.toml|--threads 2
$DATA/aorta-view-b.toml|--threads 1 --ert 1 --cell-order stored
$DATA/aorta-view-b.toml|--threads 1 --ert 1 --tile 7
$DATA/aorta-view-b.toml|--threads 1 --ert 1 --integrator midpoint
$DATA/aorta-view-b.toml|--threads 1 --ert 1 --no-partial-composition
$W/persp-b.toml|--threads 1 --ert 1
$W/persp-b.toml|--threads 2
$W/big-b.toml|--threads 2 --ert 1
tests/data/spx.toml|--threads 1 --ert 1
$DATA/aorta-view-a.toml|--threads 1
$DATA/aorta-view-a.toml|--threads 1 --ert 0.5 --ert-structure flat
$DATA/aorta-view-a.toml|--threads 1 --ert 0.999 --integrator midpoint
$DATA/aorta-view-b.toml|--threads 2 --ert 0.9 --canonical
$DATA/aorta-view-b.toml|--threads 1 --ert 0.95 --no-partial-composition
$DATA/aorta-view-b.toml|--threads 1 --ert 0.9 --tile 7 --ert-update 10
$DATA/aorta-view-b.toml|--threads 1 --ert 0.8 --ert-structure flat --ert-span single
$W/persp-b.toml|--threads 2 --ert 0.9
tests/data/spx.toml|--threads 1 --ert 0.9
${BIG:+$BIG|--threads 2 --ert 1}
LIST
exit $fail
