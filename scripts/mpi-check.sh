#!/usr/bin/env bash
# The MPI transport: builds pvrsim with `--features mpi` (in its own target
# dir, target-mpi, so the normal build cache is kept), runs one small frame
# under mpirun (the coordinator on rank 0, one rank per node) with ERT off
# and on, and checks each image is bit-identical (cmp) to --transport
# threads; a 3-frame orbit on one MPI session, each frame equal to the
# threads' frame; the ranks reading their own pieces of a .pvtu (VTK's 4
# pieces on 3 and 8 ranks, 12 and 3 pieces of `pvrsim partition` on 8),
# each image equal to the single-process render of the mesh, rank 0
# reading no cells (the report's pieces section); a rank stopped with
# SIGSTOP: a named error within --recv-timeout + 5 s, a non-zero exit, no
# rank left. Also checks that a wrong `-n` fails with a clear error and no
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

# A 3-frame orbit on one MPI session: every frame equals the threads' frame.
"$PVRSIM" cluster "$SCENE" --nodes "$N" --canonical --ert 1 --no-baselines \
  --transport threads --frames 3 --turn 20 -o "$WORK/orbit-t-%d.png" > /dev/null
if timeout 300 "${MPIRUN[@]}" -n $((N + 1)) "$PVRSIM" cluster "$SCENE" --nodes "$N" --canonical \
    --ert 1 --no-baselines --transport mpi --frames 3 --turn 20 -o "$WORK/orbit-m-%d.png" \
    --report "$WORK/orbit.json" > /dev/null 2> "$WORK/orbit.err"; then
  same=0
  for f in 0 1 2; do cmp -s "$WORK/orbit-t-$f.png" "$WORK/orbit-m-$f.png" && same=$((same + 1)); done
  if [ $same = 3 ]; then
    echo "mpi-check: 3-frame orbit on one MPI session: every frame identical to --transport threads"
  else
    echo "mpi-check: 3-frame orbit: $((3 - same)) frame(s) differ from --transport threads" >&2
    status=1
  fi
else
  echo "mpi-check: the 3-frame MPI orbit failed:" >&2
  cat "$WORK/orbit.err" >&2
  status=1
fi

# Ranks that read their own pieces: the image of the whole mesh, bit for bit.
DATA=$(cd "$(dirname "$SCENE")" && pwd)/$(sed -n 's/^path *= *"\(.*\)"/\1/p' "$SCENE" | head -1)
mkdir -p "$WORK/vtk" "$WORK/p12" "$WORK/p3"
cp tests/data/pieces/aorta-small-raw* "$WORK/vtk/"
"$PVRSIM" partition "$DATA" --pieces 12 -o "$WORK/p12/m.pvtu" > /dev/null
"$PVRSIM" partition "$DATA" --pieces 3 -o "$WORK/p3/m.pvtu" > /dev/null
piece_scene() {  # the scene with its data the .pvtu $1, written to $2
  sed "s#^path *= *\".*\"#path = \"$1\"#" "$SCENE" > "$2"
}
for run in "vtk/aorta-small-raw.pvtu 3" "vtk/aorta-small-raw.pvtu 8" "p12/m.pvtu 8" "p3/m.pvtu 8"; do
  set -- $run
  pvtu=$1 ranks=$2 tag=$(echo "$1-$2" | tr '/.' '__')
  piece_scene "$WORK/$pvtu" "$WORK/$tag.toml"
  "$PVRSIM" cluster "$SCENE" --nodes "$ranks" --canonical --ert 1 --no-baselines \
    --transport threads -o "$WORK/$tag-whole.png" > /dev/null
  if ! timeout 300 "${MPIRUN[@]}" -n $((ranks + 1)) "$PVRSIM" cluster "$WORK/$tag.toml" \
      --nodes "$ranks" --canonical --ert 1 --no-baselines --transport mpi \
      -o "$WORK/$tag.png" --report "$WORK/$tag.json" > /dev/null 2> "$WORK/$tag.err"; then
    echo "mpi-check: $pvtu on $ranks ranks failed:" >&2
    cat "$WORK/$tag.err" >&2
    status=1
    continue
  fi
  if cmp -s "$WORK/$tag-whole.png" "$WORK/$tag.png"; then
    python3 - "$WORK/$tag.json" "$pvtu" "$ranks" <<'PY' || status=1
import json, sys
r = json.load(open(sys.argv[1]))
p = r["pieces"]
cells = [n["cells_initial"] for n in r["nodes"]]
print(f"mpi-check: {sys.argv[2]} ({p['pieces']} pieces) on {sys.argv[3]} ranks: image identical "
      f"to the whole mesh's; piece map {p['parts']}; cells read per rank {cells}; "
      f"rank 0 read {p['vertices_read_by_coordinator']} vertices, no cells")
if p.get("shares"):
    print(f"mpi-check:   split pieces, every rank works: {cells}")
sys.exit(0 if sum(cells) == r["cells_total"] and (not p.get("shares") or min(cells) > 0) else 1)
PY
  else
    echo "mpi-check: $pvtu on $ranks ranks: the image differs from the whole mesh's" >&2
    status=1
  fi
done

# A stalled rank (SIGSTOP) in a series: a named error within the deadline
# + 5 s, a non-zero exit, no rank left running.
"${MPIRUN[@]}" -n $((N + 1)) "$PVRSIM" cluster "$SCENE" --nodes "$N" --no-baselines \
  --transport mpi --frames 400 --turn 1 --recv-timeout 3 -o "$WORK/stall-%d.png" \
  > /dev/null 2> "$WORK/stall.err" &
job=$!
victim=""
for _ in $(seq 100); do
  sleep 0.1
  [ -e "$WORK/stall-2.png" ] || continue
  for p in $(pgrep -f "$PVRSIM cluster $SCENE" || true); do
    if tr '\0' '\n' < /proc/$p/environ 2>/dev/null | grep -qx 'OMPI_COMM_WORLD_RANK=2'; then victim=$p; fi
  done
  [ -n "$victim" ] && break
done
if [ -z "$victim" ]; then
  echo "mpi-check: stall: no MPI rank 2 found to stop" >&2
  status=1
  kill -9 $job 2>/dev/null || true
else
  kill -STOP "$victim"
  s=$(date +%s%N)
  code=0
  timeout 60 tail --pid=$job -f /dev/null || true
  wait $job || code=$?
  e=$(( ($(date +%s%N) - s) / 1000000 ))
  left=$(pgrep -f "$PVRSIM cluster $SCENE" || true)
  if [ $code != 0 ] && [ $e -le 8000 ] && [ -z "$left" ] && grep -q "MPI rank 2" "$WORK/stall.err"; then
    echo "mpi-check: a rank stopped mid-series: exit $code after $e ms (deadline 3 s), error names it: $(grep -m1 'MPI rank 2' "$WORK/stall.err" | cut -c1-160)"
  else
    echo "mpi-check: stopped rank: exit $code after $e ms, ranks left: ${left:-none}; stderr:" >&2
    head -20 "$WORK/stall.err" >&2
    status=1
  fi
  kill -9 $left "$victim" 2>/dev/null || true
fi

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
