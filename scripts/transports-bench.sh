#!/usr/bin/env bash
# The same frame on --transport threads, processes, tcp (4 `pvrsim worker
# --once` on loopback) and mpi (mpirun -n N+1), REPS rounds alternating so
# that load changes hit every transport alike; checks the images are
# identical (cmp) and prints a table (median frame, phase-1, phase-2 and
# set-up seconds; bytes measured vs modelled) for
# docs/experiments/transports.md. Needs a `--features mpi` build
# (scripts/mpi-check.sh makes one) and OpenMPI. As root (mpirun needs
# --allow-run-as-root). Usage: scripts/transports-bench.sh
set -euo pipefail
cd "$(dirname "$0")/.."
P=${P:-target-mpi/release/pvrsim}; S=${S:-tests/data/aorta-small-view-b.toml}; N=${N:-4}; REPS=${REPS:-3}
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT; ARGS=(--nodes $N --canonical --ert 1 --no-baselines --width 400 --height 400)
for r in $(seq $REPS); do
  $P cluster $S "${ARGS[@]}" --transport threads -o $W/threads.png --report $W/threads-$r.json >/dev/null 2>&1
  $P cluster $S "${ARGS[@]}" --transport processes -o $W/processes.png --report $W/processes-$r.json >/dev/null 2>&1
  addrs=""; pids=()
  for k in $(seq $N); do
    $P worker --listen 127.0.0.1:0 --once --accept-timeout 60 > $W/w$k.out 2>/dev/null & pids+=($!)
  done
  for k in $(seq $N); do for _ in $(seq 100); do [ -s $W/w$k.out ] && break; sleep 0.05; done; addrs="$addrs${addrs:+,}$(head -1 $W/w$k.out)"; done
  $P cluster $S "${ARGS[@]}" --transport tcp --workers "$addrs" -o $W/tcp.png --report $W/tcp-$r.json >/dev/null 2>&1
  wait "${pids[@]}" || true
  mpirun --allow-run-as-root --oversubscribe -n $((N+1)) $P cluster $S "${ARGS[@]}" --transport mpi -o $W/mpi.png --report $W/mpi-$r.json >/dev/null 2>&1
done
for t in threads processes tcp mpi; do cmp -s $W/threads.png $W/$t.png && echo "$t: image identical to threads" || echo "$t: IMAGE DIFFERS"; done
python3 - "$REPS" "$W" <<'PY'
import json, sys, statistics as st
reps = int(sys.argv[1]); W = sys.argv[2]
print("| transport | frame (s), median of %d | phase 1 (s) | phase 2 (s) | set-up (s) | phase-1 bytes = model | phase-2 bytes = model | phase-2 payload bytes measured / modelled |" % reps)
print("|---|---|---|---|---|---|---|---|")
for t in ["threads", "processes", "tcp", "mpi"]:
    rs = [json.load(open(f"{W}/{t}-{r}.json")) for r in range(1, reps + 1)]
    fr = st.median(r["frame_s"] for r in rs)
    tr = [r.get("transport") for r in rs]
    if tr[0]:
        p1 = st.median(x["phase1_measured_s"] for x in tr); p2 = st.median(x["phase2_measured_s"] for x in tr)
        su = st.median(x["setup_s"] for x in tr)
        meas = sum(l["measured"]["bytes"] for l in tr[0]["phase2_by_kind"].values())
        mod = sum(l["modelled"]["bytes"] for l in tr[0]["phase2_by_kind"].values())
        print(f"| {t} | {fr:.4f} | {p1:.4f} | {p2:.4f} | {su:.4f} | {all(x['phase1_bytes_match'] for x in tr)} | {all(x['phase2_bytes_match'] for x in tr)} | {meas} / {mod} |")
    else:
        print(f"| {t} | {fr:.4f} | - | - | - | - | - | - |")
PY
