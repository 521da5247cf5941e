#!/usr/bin/env bash
# Across machines, emulated: each worker and the coordinator in its own
# Linux network namespace, joined through a bridge in a "switch" namespace by
# veth pairs whose egress is rate-limited with tbf (1 Gbit/s, then
# 100 Mbit/s). Checks that the frame completes, that the image is identical
# to the threads run, and that the phase-1 bytes and the phase-2 (worker to
# worker compositing) bytes measured at the transport equal the virtual
# model's bytes; prints a table (measured vs modelled time) for
# docs/experiments/transports.md.
#
# Needs root, iproute2 (ip, tc) and python3. Only addresses inside the
# namespaces it creates (10.77.0.0/24) are used; everything is removed on
# exit. Usage: sudo scripts/netns-check.sh [SCENE] [NODES]
set -euo pipefail

SCENE=${1:-tests/data/aorta-small-view-b.toml}
N=${2:-4}
PVRSIM=${PVRSIM:-target/release/pvrsim}
P=pvrns$$          # name prefix (unique per run)
WORK=$(mktemp -d)
PIDS=()

[ "$(id -u)" = 0 ] || { echo "netns-check: needs root (network namespaces)" >&2; exit 2; }
for t in ip tc python3; do
  command -v $t >/dev/null || { echo "netns-check: needs $t" >&2; exit 2; }
done
[ -x "$PVRSIM" ] || { echo "netns-check: no $PVRSIM (cargo build --release)" >&2; exit 2; }

cleanup() {
  for p in "${PIDS[@]:-}"; do [ -n "$p" ] && kill -9 "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  for ns in $(ip netns list | awk '{print $1}' | grep "^$P" || true); do ip netns del "$ns"; done
  rm -rf "$WORK"
}
trap cleanup EXIT

# switch namespace with a bridge
ip netns add ${P}sw
ip -n ${P}sw link add br0 type bridge
ip -n ${P}sw link set br0 up

# attach namespace $1 with address $2, egress limited to $3 on both ends
attach() {
  local ns=$1 addr=$2 rate=$3 i=$4
  ip netns add "$ns"
  ip -n "$ns" link set lo up
  ip link add ${P}a$i type veth peer name ${P}b$i
  ip link set ${P}a$i netns "$ns"
  ip link set ${P}b$i netns ${P}sw
  ip -n "$ns" link set ${P}a$i name eth0
  ip -n "$ns" addr add "$addr/24" dev eth0
  ip -n "$ns" link set eth0 up
  ip -n ${P}sw link set ${P}b$i master br0
  ip -n ${P}sw link set ${P}b$i up
  tc -n "$ns" qdisc add dev eth0 root tbf rate "$rate" burst 256kb latency 100ms
  tc -n ${P}sw qdisc add dev ${P}b$i root tbf rate "$rate" burst 256kb latency 100ms
}

# reference: the threads run in this namespace
"$PVRSIM" cluster "$SCENE" --nodes "$N" --canonical --ert 1 --no-baselines \
  --transport threads -o "$WORK/threads.png" >/dev/null

head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' > "$WORK/token"
chmod 600 "$WORK/token"

PROFILE=pentium4
[ -f configs/profiles/calibrated.toml ] && PROFILE=calibrated
echo "profile: $PROFILE"
printf '| link | nodes | image identical | phase-1 bytes = model | phase-1 measured (s) | phase-1 modelled (s) | phase-2 bytes = model | phase-2 payload bytes (measured / modelled) | phase-2 measured (s) | phase-2 modelled (s) | frame (s) | set-up (s) | cells bytes | ping-pong fit |\n'
printf '|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n'
status=0
round=0
for spec in "1gbit gbe" "100mbit fast-ethernet"; do
  set -- $spec; rate=$1; model=$2
  round=$((round + 1))
  # fresh namespaces per rate
  for ns in $(ip netns list | awk '{print $1}' | grep "^$P" | grep -v "^${P}sw$" || true); do ip netns del "$ns"; done
  attach ${P}c 10.77.0.100 "$rate" c$round
  workers=""
  for k in $(seq 0 $((N - 1))); do
    attach ${P}w$k 10.77.0.$((k + 1)) "$rate" w$round$k
    ip netns exec ${P}w$k "$PVRSIM" worker --listen 10.77.0.$((k + 1)):7700 \
      --token-file "$WORK/token" --once --accept-timeout 60 \
      > "$WORK/w$k.out" 2> "$WORK/w$k.err" &
    PIDS+=($!)
    workers="$workers${workers:+,}10.77.0.$((k + 1)):7700"
  done
  for k in $(seq 0 $((N - 1))); do
    for _ in $(seq 100); do [ -s "$WORK/w$k.out" ] && break; sleep 0.1; done
  done
  if ! ip netns exec ${P}c timeout 120 "$PVRSIM" cluster "$SCENE" --nodes "$N" --canonical --ert 1 \
      --no-baselines --transport tcp --workers "$workers" --token-file "$WORK/token" \
      --network "$model" --profile "$PROFILE" -o "$WORK/$rate.png" --report "$WORK/$rate.json" > "$WORK/c.out" 2> "$WORK/c.err"; then
    echo "netns-check: the frame failed on $rate:" >&2; cat "$WORK/c.err" >&2; status=1; continue
  fi
  same=no; cmp -s "$WORK/threads.png" "$WORK/$rate.png" && same=yes
  cat > "$WORK/row.py" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); t = r["transport"]
meas = sum(l["measured"]["bytes"] for l in t["phase2_by_kind"].values())
model = sum(l["modelled"]["bytes"] for l in t["phase2_by_kind"].values())
print(f"| {sys.argv[2]} | {sys.argv[3]} | {sys.argv[4]} | {'yes' if t['phase1_bytes_match'] else 'NO'} | "
      f"{t['phase1_measured_s']:.4f} | {t['phase1_modelled_s']:.4f} | "
      f"{'yes' if t['phase2_bytes_match'] else 'NO'} | {meas} / {model} (headers {t['phase2_header_bytes']}, root hand-off {t['phase2_handoff']['bytes']}) | "
      f"{t['phase2_measured_s']:.4f} | {t['phase2_modelled_s']:.4f} | {r['frame_s']:.4f} | {t['setup_s']:.4f} | "
      f"{t['setup_cells_bytes']} | {sys.argv[5]} |")
ok = t["phase1_bytes_match"] and t["phase2_bytes_match"] and sys.argv[4] == "yes"
sys.exit(0 if ok else 1)
PY
  # ping-pong over the same link: coordinator namespace -> worker 0's
  ip netns exec ${P}w0 "$PVRSIM" worker --listen 10.77.0.1:7701 --token-file "$WORK/token" \
    --once --accept-timeout 60 > "$WORK/probe.out" 2>/dev/null &
  PIDS+=($!)
  for _ in $(seq 100); do [ -s "$WORK/probe.out" ] && break; sleep 0.1; done
  fit=$(ip netns exec ${P}c timeout 120 "$PVRSIM" calibrate --network --peer 10.77.0.1:7701 \
    --peer-token-file "$WORK/token" --max-bytes $((16 << 20)) \
    --network-out "$WORK/net-$rate.toml" 2>&1 | grep '^alpha' || echo "failed")
  python3 "$WORK/row.py" "$WORK/$rate.json" "$rate" "$N" "$same" "$fit" || status=1
done
exit $status
