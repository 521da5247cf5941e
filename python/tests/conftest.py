"""Shared fixtures: the repository's paths and the command line to compare with.

The command line is the repository's release binary when it is built
(``cargo build --release``; CI builds it with ``cargo test --release``
before this suite), else the same command line from the module
(``python -m pvrsim``).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import List

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "tests" / "data"
VIEW_B = DATA / "aorta-small-view-b.toml"
AORTA = DATA / "aorta-small.vtk"


def cli_command() -> List[str]:
    exe = REPO / "target" / "release" / ("pvrsim.exe" if os.name == "nt" else "pvrsim")
    if exe.is_file() and os.environ.get("PVRSIM_TEST_CLI") != "module":
        return [str(exe)]
    return [sys.executable, "-m", "pvrsim"]


def run_cli(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    """Runs ``pvrsim ARGS``; returns the completed process (text output)."""
    p = subprocess.run(
        cli_command() + list(args), capture_output=True, text=True, timeout=600
    )
    if check and p.returncode != 0:
        raise AssertionError(f"pvrsim {' '.join(args)} failed:\n{p.stderr}")
    return p


def cli_error(*args: str) -> List[str]:
    """The message ``pvrsim ARGS`` fails with: its ``error: ...`` line and
    each ``caused by: ...`` line, without those prefixes."""
    p = run_cli(*args, check=False)
    assert p.returncode != 0, f"pvrsim {' '.join(args)} should fail"
    out = []
    for line in p.stderr.splitlines():
        line = line.strip()
        for prefix in ("error: ", "caused by: "):
            if line.startswith(prefix):
                out.append(line[len(prefix):])
    assert out, p.stderr
    return out


def read_png(path: Path) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(path))


def kuhn_cube_mesh(n: int):
    """An n x n x n block of unit cubes, six tetrahedra each, and a radial field."""
    g = np.arange(n + 1)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), z.ravel()], 1).astype(np.float64)

    def idx(i, j, k):
        return (k * (n + 1) + j) * (n + 1) + i

    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij"))
    c = [idx(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1)) for b in range(8)]
    paths = [(1, 3), (1, 5), (2, 3), (2, 6), (4, 5), (4, 6)]
    tets = np.concatenate([np.stack([c[0], c[a], c[b], c[7]], 1) for a, b in paths])
    r = np.linalg.norm(pts - n / 2, axis=1)
    return pts, tets, r


@pytest.fixture
def tmp(tmp_path: Path) -> Path:
    return tmp_path
