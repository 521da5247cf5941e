"""``pvrsim.Session``: ten frames at different cameras on one session equal
the one-off ``cluster`` frames at those cameras (threads and worker
processes, canonical lists, ERT off: bit for bit); bad frames raise."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import pvrsim

from conftest import AORTA, VIEW_B

try:
    import tomllib
except ImportError:  # Python < 3.11
    tomllib = pytest.importorskip("tomli")

COMMON = dict(nodes=3, ert=1, canonical=True, no_baselines=True)


def cameras(base: dict, n: int) -> list:
    """``n`` cameras orbiting ``base``'s target about its up axis (z)."""
    eye = np.array(base["eye"], float)
    target = np.array(base["target"], float)
    out = []
    for k in range(n):
        a = math.radians(17.0 * k)
        d = eye - target
        rot = np.array([d[0] * math.cos(a) - d[1] * math.sin(a), d[0] * math.sin(a) + d[1] * math.cos(a), d[2]])
        cam = dict(base)
        cam["eye"] = [float(x) for x in target + rot]
        out.append(cam)
    return out


@pytest.mark.parametrize("transport", ["threads", "processes"])
def test_ten_session_frames_equal_one_off_frames(tmp_path, transport):
    doc = tomllib.loads(VIEW_B.read_text())
    doc["data"]["path"] = str(AORTA)
    with pvrsim.Session(VIEW_B, transport=transport, **COMMON) as s:
        for k, cam in enumerate(cameras(doc["camera"], 10)):
            got = s.render(camera=cam)
            one = tmp_path / f"one-{k}.toml"
            one.write_text(pvrsim._native.toml_from_json(json.dumps({**doc, "camera": cam})))
            want = pvrsim.cluster(str(one), transport="threads", **COMMON)
            assert np.array_equal(got.image, want.image), f"{transport}: frame {k}"
        assert s.frames == 10


def test_bad_frames_raise_and_the_session_keeps_serving():
    with pvrsim.Session(VIEW_B, **COMMON) as s:
        with pytest.raises(pvrsim.OptionError, match="time step 4 does not exist"):
            s.render(step=4)
        with pytest.raises(pvrsim.OptionError, match="cannot change in a session"):
            s._live().render('{"data": {"path": "x.vtk"}}', None, None)
        with pytest.raises(pvrsim.Error):
            s.render(camera={"eye": [0, 0, 0]})
        assert s.render().image.shape[2] == 4
    with pytest.raises(pvrsim.OptionError, match="closed"):
        s.render()
    with pytest.raises(pvrsim.OptionError, match="series option"):
        pvrsim.Session(VIEW_B, frames=3, **COMMON)
