#!/usr/bin/env bash
# Network faults on an emulated LAN (issue 25): the coordinator and 4
# workers each in its own network namespace, joined through a bridge by
# veth pairs (as scripts/netns-check.sh). Worker 2's link is slowed with tbf
# (1 Mbit/s) so that a frame takes seconds, then:
#
#   down      its link is taken down (`ip link set down`) once its phase 1
#             has started: with --on-failure reassign the frame completes on
#             the 3 others with the undisturbed image; with abort it fails
#             naming worker 2, within the heartbeat deadline + 2 s of the cut;
#   crawl     its link is throttled to a crawl (tbf 8 kbit/s, short queue)
#             from the start: the same checks (its frames stop making
#             progress and it is declared lost);
#
# and after each, with worker 2's link restored, the same pool renders a
# clean frame with the undisturbed image. Needs root, iproute2 (ip, tc).
# Only 10.78.0.0/24 inside its own namespaces is used; everything is
# removed on exit. Usage: sudo scripts/netns-faults.sh [SCENE]
set -euo pipefail

SCENE=${1:-tests/data/aorta-small-view-b.toml}
N=4
HB=1
PVRSIM=${PVRSIM:-target/release/pvrsim}
P=pvrnf$$
WORK=$(mktemp -d)
PIDS=()

[ "$(id -u)" = 0 ] || { echo "netns-faults: needs root (network namespaces)" >&2; exit 2; }
for t in ip tc timeout; do
  command -v $t >/dev/null || { echo "netns-faults: needs $t" >&2; exit 2; }
done
[ -x "$PVRSIM" ] || { echo "netns-faults: no $PVRSIM (cargo build --release)" >&2; exit 2; }

cleanup() {
  for p in "${PIDS[@]:-}"; do [ -n "$p" ] && kill -9 "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  for ns in $(ip netns list | awk '{print $1}' | grep "^$P" || true); do ip netns del "$ns"; done
  rm -rf "$WORK"
}
trap cleanup EXIT

ip netns add ${P}sw
ip -n ${P}sw link add br0 type bridge
ip -n ${P}sw link set br0 up
attach() {
  local ns=$1 addr=$2 i=$3
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
}
# shape worker 2's link (both directions) to $1 with queue latency $2
shape() {
  for side in "-n ${P}w2 eth0" "-n ${P}sw ${P}b2"; do
    set -- "$1" "$2" $side
    tc "$3" "$4" qdisc replace dev "$5" root tbf rate "$1" burst 4kb latency "$2"
  done
}
unshape() {
  tc -n ${P}w2 qdisc del dev eth0 root 2>/dev/null || true
  tc -n ${P}sw qdisc del dev ${P}b2 root 2>/dev/null || true
}

head -c 32 /dev/urandom | od -An -tx1 | tr -d ' \n' > "$WORK/token"
chmod 600 "$WORK/token"
attach ${P}c 10.78.0.100 c
workers=""
for k in $(seq 0 $((N - 1))); do
  attach ${P}w$k 10.78.0.$((k + 1)) $k
  ip netns exec ${P}w$k "$PVRSIM" worker --listen 10.78.0.$((k + 1)):7700 \
    --token-file "$WORK/token" --heartbeat-timeout $HB --accept-timeout 300 \
    > "$WORK/w$k.out" 2> "$WORK/w$k.err" &
  PIDS+=($!)
  workers="$workers${workers:+,}10.78.0.$((k + 1)):7700"
done
for k in $(seq 0 $((N - 1))); do
  for _ in $(seq 100); do [ -s "$WORK/w$k.out" ] && break; sleep 0.1; done
done

# frame NAME [extra args]: the frame from the coordinator's namespace
frame() {
  local name=$1; shift
  ip netns exec ${P}c timeout 120 "$PVRSIM" cluster "$SCENE" --nodes $N --canonical --ert 1 \
    --no-baselines --transport tcp --workers "$workers" --token-file "$WORK/token" \
    --heartbeat-timeout $HB -o "$WORK/$name.png" --report "$WORK/$name.json" "$@" \
    > "$WORK/$name.out" 2> "$WORK/$name.err"
}

frame reference || { echo "netns-faults: the undisturbed frame failed:" >&2; cat "$WORK/reference.err" >&2; exit 1; }
status=0
printf '| fault | --on-failure | outcome | seconds after the fault | image | clean frame after |\n|---|---|---|---|---|---|\n'
for fault in down crawl; do
  for mode in reassign abort; do
    : > "$WORK/w2.err"
    if [ $fault = down ]; then shape 1mbit 400ms; else shape 8kbit 20ms; fi
    t0=$(date +%s.%N)
    frame "$fault-$mode" --on-failure $mode &
    fpid=$!
    if [ $fault = down ]; then
      for _ in $(seq 600); do grep -q "phase 1 started" "$WORK/w2.err" && break; sleep 0.05; done
      t0=$(date +%s.%N)
      ip -n ${P}w2 link set eth0 down
    fi
    rc=0; wait $fpid || rc=$?
    took=$(python3 -c "import time; print(f'{time.time() - $t0:.1f}')" 2>/dev/null || echo "?")
    ip -n ${P}w2 link set eth0 up
    unshape
    same=-
    if [ $mode = reassign ]; then
      if [ $rc = 0 ] && cmp -s "$WORK/reference.png" "$WORK/$fault-$mode.png"; then
        outcome="completed on 3"; same=identical
      else
        outcome="FAILED (exit $rc)"; status=1; sed 's/^/    /' "$WORK/$fault-$mode.err" >&2
      fi
    else
      if [ $rc != 0 ] && grep -q "worker 2" "$WORK/$fault-$mode.err"; then
        outcome="error naming worker 2"
        python3 -c "import sys; sys.exit(0 if float('$took') <= $HB + 2 else 1)" 2>/dev/null \
          || { [ $fault = crawl ] || { outcome="$outcome, too late"; status=1; }; }
      else
        outcome="NO ERROR NAMING WORKER 2 (exit $rc)"; status=1; sed 's/^/    /' "$WORK/$fault-$mode.err" >&2
      fi
    fi
    # the same pool, link restored: a clean frame (a worker still ending
    # the failed frame answers "busy" for at most its deadline)
    clean=no
    for _ in 1 2 3 4 5; do
      if frame "$fault-$mode-clean" && cmp -s "$WORK/reference.png" "$WORK/$fault-$mode-clean.png"; then
        clean=identical; break
      fi
      sleep 1
    done
    [ $clean = identical ] || { status=1; sed 's/^/    /' "$WORK/$fault-$mode-clean.err" >&2; }
    printf '| %s | %s | %s | %s | %s | %s |\n' "$fault" "$mode" "$outcome" "$took" "$same" "$clean"
  done
done
exit $status
