"""The module's overhead: ``pvrsim.render`` (the call, numpy image included)
against ``pvrsim render`` (the whole command-line process, writing its PNG)
with the same options, alternating, one of each per round.

    python python/benches/overhead.py SCENE [--rounds 15] [--threads 1] [--cli PATH]

Prints each side's median wall time and the median of the per-round ratios
(module / CLI). ``--cli`` defaults to target/release/pvrsim (build it with
``cargo build --release``). docs/python.md quotes a run.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pvrsim

REPO = Path(__file__).resolve().parents[2]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--cli", default=str(REPO / "target" / "release" / "pvrsim"))
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        png = os.path.join(tmp, "cli.png")
        cli = [a.cli, "render", a.scene, "-o", png, "--threads", str(a.threads)]
        subprocess.run(cli, check=True, capture_output=True)  # warm-up: file cache
        pvrsim.render(a.scene, threads=a.threads)
        t_cli, t_mod = [], []
        for _ in range(a.rounds):
            t = time.perf_counter()
            subprocess.run(cli, check=True, capture_output=True)
            t_cli.append(time.perf_counter() - t)
            t = time.perf_counter()
            img = pvrsim.render(a.scene, threads=a.threads).image
            t_mod.append(time.perf_counter() - t)
            assert img.shape[2] == 4
    ratios = [m / c for m, c in zip(t_mod, t_cli)]
    print(f"scene {a.scene}, --threads {a.threads}, {a.rounds} rounds (alternating)")
    print(f"pvrsim render (process): median {statistics.median(t_cli):.4f} s  [min {min(t_cli):.4f}, max {max(t_cli):.4f}]")
    print(f"pvrsim.render (call):    median {statistics.median(t_mod):.4f} s  [min {min(t_mod):.4f}, max {max(t_mod):.4f}]")
    print(f"ratio module / CLI per round: median {statistics.median(ratios):.3f}  [min {min(ratios):.3f}, max {max(ratios):.3f}]")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
