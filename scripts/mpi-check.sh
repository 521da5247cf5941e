#!/usr/bin/env bash
# The MPI transport: builds pvrsim with `--features mpi` (in its own target
# dir, target-mpi, so the normal build cache is kept), runs one small frame
# under mpirun (the coordinator on rank 0, one rank per node) with ERT off
# and on, and checks each image is bit-identical (cmp) to --transport
# threads. Also checks that a wrong `-n` fails with a clear error and no
# hang. Installs nothing: needs OpenMPI and libclang (Debian:
# libopenmpi-dev openmpi-bin libclang-dev). Exits non-zero on any
# difference. Usage: scripts/mpi-check.sh [SCENE] [NODES]
set -euo pipefail
cd "$(dirname "$0")/.."

SCENE=${1:-tests/data/aorta-small-view-b.toml}
N=${2:-4}
export CARGO_TARGET_DIR=${MPI_TARGET_DIR:-target-mpi}
PVRSIM=$CARGO_TARGET_DIR/release/pvrsim
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

for t in mpirun mpicc; do
  command -v $t >/dev/null || {
    echo "mpi-check: needs $t (apt-get install libopenmpi-dev openmpi-bin libclang-dev)" >&2
    exit 2
  }
done

start=$(date +%s)
cargo build --release --features mpi
echo "mpi-check: build with --features mpi took $(( $(date +%s) - start )) s"

# As root (CI), OpenMPI needs --allow-run-as-root; 2 cores need --oversubscribe.
MPIRUN=(mpirun --oversubscribe)
if [ "$(id -u)" = 0 ]; then MPIRUN+=(--allow-run-as-root); fi

status=0
for ert in 1 0.9; do
  "$PVRSIM" cluster "$SCENE" --nodes "$N" --canonical --ert "$ert" --no-baselines \
    --transport threads -o "$WORK/threads-$ert.png" > /dev/null
  s=$(date +%s%N)
  if ! timeout 300 "${MPIRUN[@]}" -n $((N + 1)) "$PVRSIM" cluster "$SCENE" --nodes "$N" --canonical \
      --ert "$ert" --no-baselines --transport mpi -o "$WORK/mpi-$ert.png" \
      --report "$WORK/mpi-$ert.json" > "$WORK/mpi.out" 2> "$WORK/mpi.err"; then
    echo "mpi-check: the MPI frame failed (--ert $ert):" >&2
    cat "$WORK/mpi.err" >&2
    status=1
    continue
  fi
  e=$(( ($(date +%s%N) - s) / 1000000 ))
  if cmp "$WORK/threads-$ert.png" "$WORK/mpi-$ert.png"; then
    echo "mpi-check: --ert $ert: image identical to --transport threads (mpirun: ${e} ms)"
  else
    echo "mpi-check: --ert $ert: the MPI image differs from --transport threads" >&2
    status=1
  fi
  python3 - "$WORK/mpi-$ert.json" <<'PY' || status=1
import json, sys
t = json.load(open(sys.argv[1]))["transport"]
print(f"mpi-check:   phase-1 bytes = model: {t['phase1_bytes_match']}, "
      f"phase-2 bytes = model: {t['phase2_bytes_match']}")
sys.exit(0 if t["phase1_bytes_match"] and t["phase2_bytes_match"] else 1)
PY
done

# A wrong -n: a clear error, a non-zero exit, no hang.
if timeout 120 "${MPIRUN[@]}" -n "$N" "$PVRSIM" cluster "$SCENE" --nodes "$N" --canonical \
    --no-baselines --transport mpi -o "$WORK/bad.png" > /dev/null 2> "$WORK/bad.err"; then
  echo "mpi-check: mpirun -n $N for --nodes $N succeeded; it must fail" >&2
  status=1
elif grep -q "process(es) for --nodes $N" "$WORK/bad.err"; then
  echo "mpi-check: wrong -n: clear error, non-zero exit"
else
  echo "mpi-check: wrong -n: no clear error:" >&2
  cat "$WORK/bad.err" >&2
  status=1
fi
exit $status
