#!/usr/bin/env bash
# Extra CI steps for the real transports (call from .ci/run after the README's
# test command; CI runs as root). Installs iproute2 (ip, tc) and python3 if
# missing, builds the release binary, and runs the namespace checks (the
# transports, then network faults: a link down mid-frame, one at a crawl,
# then the fidelity check); then
# installs OpenMPI and libclang (apt-get update first) and runs the MPI
# check. On a developer's machine that check builds `--features mpi` in
# target-mpi/ so target/ stays valid; CI's target/ is thrown away after
# this step, so CI builds in target/ (MPI_TARGET_DIR=target): only mpi-sys,
# mpi and pvrsim itself are compiled again, not every dependency.
set -euo pipefail
if ! command -v ip >/dev/null || ! command -v tc >/dev/null || ! command -v python3 >/dev/null; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq iproute2 python3
fi
cargo build --release
scripts/netns-check.sh tests/data/aorta-small-view-b.toml 4
scripts/netns-faults.sh tests/data/aorta-small-view-b.toml
# The simulator against measured runs: calibrate, then 2 and 4 nodes over TCP
# workers and worker processes on the 100 Mbit emulated link; exits 1 when a
# ratio leaves its band (docs/experiments/fidelity.md). About 1.5 min. Every
# band of issue 24 is held: the 4-node CPU and phase-2 bands and the 2-node
# frame band (0.69-0.95 over 24 local values on 2026-12-04, one below 0.70;
# mesh frames measured warm since 2026-12-07: 0.77-0.83).
# The bands compare a calibration with frames run a minute later, and a
# shared host's speed moves by up to 15 % between identical runs; a failed
# check runs once more, calibration included: a model that is off fails both.
fidelity() {
  LINKS=100mbit NODES=2,4 REPEATS=5 OUT=target/fidelity-ci${1:-} scripts/fidelity-check.sh
}
fidelity || { echo "fidelity check failed; once more, calibration included"; fidelity -again; }

if ! command -v mpirun >/dev/null || ! command -v mpicc >/dev/null \
    || ! ls /usr/lib/llvm-*/lib/libclang*.so* >/dev/null 2>&1; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libopenmpi-dev openmpi-bin libclang-dev
fi
MPI_TARGET_DIR=target scripts/mpi-check.sh tests/data/aorta-small-view-b.toml 4
