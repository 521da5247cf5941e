"""The example in python/examples runs and writes its figures."""

from __future__ import annotations

import subprocess
import sys

import pytest

from conftest import REPO


def test_quickstart_runs(tmp):
    pytest.importorskip("matplotlib")
    p = subprocess.run(
        [sys.executable, str(REPO / "python" / "examples" / "quickstart.py"), str(tmp)],
        capture_output=True, text=True, timeout=600,
    )
    assert p.returncode == 0, p.stderr
    for name in ("render.png", "height.png", "timeline.png", "sweep.png", "height.toml", "height.vtk"):
        assert (tmp / name).is_file(), name
    assert "refused: ert=1.5" in p.stdout
