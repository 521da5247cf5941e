#!/usr/bin/env bash
# The simulator against real runs over emulated links (docs/experiments/fidelity.md).
#
# 1. `pvrsim calibrate` fits this machine's node profile (thread / process CPU).
# 2. Per link (tbf at 1 Gbit and 100 Mbit, no netem on this kernel):
#    - TCP workers, each in its own network namespace joined through a
#      bridge by tbf-limited veth pairs (as scripts/netns-check.sh); the
#      ping-pong fit `pvrsim calibrate --network` from the coordinator's
#      namespace to worker 0 gives the network model of the modelled runs;
#    - worker processes (`--transport processes`) in one namespace whose
#      loopback is tbf-limited: every rank shares that one interface, so its
#      model is the ping-pong fit on it with the switch capacity
#      (`bisection_bytes_per_s`) set to the same rate (a shared medium);
#    - `pvrsim fidelity` runs each frame measured and modelled and appends
#      the rows to OUT/fidelity.{csv,json}, and draws OUT/fidelity-*.png.
# 3. `pvrsim fidelity --check LINK` holds the bands (exit 1 when one fails).
#
# Needs root, iproute2 (ip, tc). Addresses 10.78.0.0/24 inside the
# namespaces it creates; everything is removed on exit.
# Environment: PVRSIM (binary), OUT (results folder, default fidelity-out),
# LINKS ("1gbit 100mbit"), NODES ("2,4,8"), REPEATS (3), CHECK_LINK (100mbit),
# WORKLOADS (mesh,grid), MESH_VARIANTS (ert-off,ert), GRID_VARIANTS (binary-swap,master),
# TRANSPORTS ("tcp processes"), BURST (tbf bucket, 4kb).
set -euo pipefail

PVRSIM=${PVRSIM:-target/release/pvrsim}
OUT=${OUT:-fidelity-out}
LINKS=${LINKS:-"1gbit 100mbit"}
NODES=${NODES:-2,4,8}
REPEATS=${REPEATS:-3}
CHECK_LINK=${CHECK_LINK:-100mbit}
WORKLOADS=${WORKLOADS:-mesh,grid}
MESH_VARIANTS=${MESH_VARIANTS:-ert-off,ert}
GRID_VARIANTS=${GRID_VARIANTS:-binary-swap,master}
TRANSPORTS=${TRANSPORTS:-"tcp processes"}
# A small bucket: a real NIC sends no burst above its line rate, and a large
# tbf bucket lets messages below it leave at the veth's speed.
BURST=${BURST:-4kb}
P=pvrfid$$
WORK=$(mktemp -d)
PIDS=()

[ "$(id -u)" = 0 ] || { echo "fidelity-check: needs root (network namespaces)" >&2; exit 2; }
for t in ip tc; do
  command -v $t >/dev/null || { echo "fidelity-check: needs $t (iproute2)" >&2; exit 2; }
done
[ -x "$PVRSIM" ] || { echo "fidelity-check: no $PVRSIM (cargo build --release)" >&2; exit 2; }
PVRSIM=$(cd "$(dirname "$PVRSIM")" && pwd)/$(basename "$PVRSIM")
MAXN=$(echo "$NODES" | tr ',' '\n' | sort -n | tail -1)

cleanup() {
  for p in "${PIDS[@]:-}"; do [ -n "$p" ] && kill -9 "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  for ns in $(ip netns list | awk '{print $1}' | grep "^$P" || true); do ip netns del "$ns"; done
  rm -rf "$WORK"
}
trap cleanup EXIT

mkdir -p "$OUT"
rm -f "$OUT/fidelity.json" "$OUT/fidelity.csv"
echo "== calibrate (node profile, this machine)"
"$PVRSIM" calibrate --out "$OUT/profile.toml" --force | grep -v '^#     '
head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' > "$WORK/token"
chmod 600 "$WORK/token"

attach() {  # namespace, address, rate, veth suffix
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
  tc -n "$ns" qdisc add dev eth0 root tbf rate "$rate" burst "$BURST" latency 100ms
  tc -n ${P}sw qdisc add dev ${P}b$i root tbf rate "$rate" burst "$BURST" latency 100ms
}

wait_listening() {  # file
  for _ in $(seq 150); do [ -s "$1" ] && return 0; sleep 0.1; done
  echo "fidelity-check: a worker did not start ($1)" >&2; return 1
}

fidelity() {  # extra args...
  "$PVRSIM" fidelity --workloads "$WORKLOADS" --mesh-variants "$MESH_VARIANTS" \
    --grid-variants "$GRID_VARIANTS" --nodes "$NODES" --repeats "$REPEATS" \
    --profile "$OUT/profile.toml" --out "$OUT" --append "$@"
}

round=0
for rate in $LINKS; do
  round=$((round + 1))
  for ns in $(ip netns list | awk '{print $1}' | grep "^$P" || true); do ip netns del "$ns"; done
  if [[ " $TRANSPORTS " == *" tcp "* ]]; then
    echo "== $rate: TCP workers in namespaces"
    ip netns add ${P}sw
    ip -n ${P}sw link add br0 type bridge
    ip -n ${P}sw link set br0 up
    attach ${P}c 10.78.0.100 "$rate" c$round
    workers=""
    for k in $(seq 0 $((MAXN - 1))); do
      attach ${P}w$k 10.78.0.$((k + 1)) "$rate" w$round$k
      ip netns exec ${P}w$k "$PVRSIM" worker --listen 10.78.0.$((k + 1)):7700 \
        --token-file "$WORK/token" --accept-timeout 900 \
        > "$WORK/w$k.out" 2> "$WORK/w$k.err" &
      PIDS+=($!)
      workers="$workers${workers:+,}10.78.0.$((k + 1)):7700"
    done
    ip netns exec ${P}w0 "$PVRSIM" worker --listen 10.78.0.1:7701 --token-file "$WORK/token" \
      --once --accept-timeout 120 > "$WORK/probe.out" 2>/dev/null &
    PIDS+=($!)
    for k in $(seq 0 $((MAXN - 1))); do wait_listening "$WORK/w$k.out"; done
    wait_listening "$WORK/probe.out"
    ip netns exec ${P}c "$PVRSIM" calibrate --network --peer 10.78.0.1:7701 \
      --peer-token-file "$WORK/token" --max-bytes $((16 << 20)) \
      --network-out "$OUT/net-$rate.toml" --network-name "veth-$rate" | grep '^alpha'
    ip netns exec ${P}c timeout 900 bash -c "$(declare -f fidelity); PVRSIM='$PVRSIM' WORKLOADS='$WORKLOADS' \
      MESH_VARIANTS='$MESH_VARIANTS' GRID_VARIANTS='$GRID_VARIANTS' NODES='$NODES' REPEATS='$REPEATS' OUT='$OUT' \
      fidelity --transports tcp --workers '$workers' --token-file '$WORK/token' \
        --network '$OUT/net-$rate.toml' --link '$rate'" > "$WORK/tcp-$rate.txt"
    grep -c '^| ' "$WORK/tcp-$rate.txt" | sed "s/^/rows (tcp, $rate): /"
  fi
  if [[ " $TRANSPORTS " == *" processes "* ]]; then
    echo "== $rate: worker processes on one tbf-limited loopback"
    ip netns add ${P}p$round
    ip -n ${P}p$round link set lo up
    # An Ethernet's frames (tbf drops packets larger than its burst).
    ip -n ${P}p$round link set lo mtu 1500
    tc -n ${P}p$round qdisc add dev lo root tbf rate "$rate" burst "$BURST" latency 100ms
    ip netns exec ${P}p$round "$PVRSIM" calibrate --network --max-bytes $((16 << 20)) \
      --network-out "$OUT/net-lo-$rate.toml" --network-name "lo-$rate" | grep '^alpha'
    beta=$(awk -F' = ' '/^bandwidth_bytes_per_s/ {print $2}' "$OUT/net-lo-$rate.toml")
    echo "# One interface for every rank: the switch passes what the loopback does." >> "$OUT/net-lo-$rate.toml"
    echo "bisection_bytes_per_s = $beta" >> "$OUT/net-lo-$rate.toml"
    ip netns exec ${P}p$round timeout 900 bash -c "$(declare -f fidelity); PVRSIM='$PVRSIM' WORKLOADS='$WORKLOADS' \
      MESH_VARIANTS='$MESH_VARIANTS' GRID_VARIANTS='$GRID_VARIANTS' NODES='$NODES' REPEATS='$REPEATS' OUT='$OUT' \
      fidelity --transports processes --network '$OUT/net-lo-$rate.toml' --link '$rate'" > "$WORK/proc-$rate.txt"
    grep -c '^| ' "$WORK/proc-$rate.txt" | sed "s/^/rows (processes, $rate): /"
  fi
done

echo "== table and bands ($CHECK_LINK)"
# REPORT_BANDS="frame" prints the bands whose text holds a word without
# failing on them (a known gap; docs/experiments/fidelity.md).
RB=""
for t in ${REPORT_BANDS:-}; do RB="$RB --report-band $t"; done
"$PVRSIM" fidelity --report-only --out "$OUT" --check "$CHECK_LINK" $RB
