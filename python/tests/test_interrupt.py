"""Ctrl-C stops a long render and raises KeyboardInterrupt."""

from __future__ import annotations

import _thread
import threading
import time

import numpy as np
import pvrsim
import pytest

from conftest import VIEW_B, kuhn_cube_mesh


@pytest.fixture(scope="module")
def big_scene():
    pts, tets, r = kuhn_cube_mesh(48)  # 663552 tetrahedra: ~2 s at 800 x 800 on one thread
    scene = pvrsim.Scene.fit(pvrsim.Mesh.from_arrays(pts, tets, {"r": r}), field="r",
                             view="30,20", size=(800, 800))
    scene._file()  # write the data now, so the timer falls in the job
    return scene


def _stopped():
    deadline = time.monotonic() + 1.0
    while pvrsim._native.jobs_running() and time.monotonic() < deadline:
        time.sleep(0.01)
    return pvrsim._native.jobs_running() == 0


def test_an_interrupted_render_raises_keyboard_interrupt_and_stops(big_scene):
    scene = big_scene
    threading.Timer(0.3, _thread.interrupt_main).start()
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        pvrsim.render(scene, threads=1, ert=1.0)
        time.sleep(5)  # (a render that ignored Ctrl-C ends here: the interrupt lands in the sleep)
    assert time.monotonic() - t0 < 1.3
    # The job itself has stopped, not only the wait for it.
    assert _stopped()
    # And the next job runs as usual.
    assert pvrsim.render(VIEW_B, threads=1).image[..., 3].any()


def test_an_interrupted_sweep_raises_keyboard_interrupt_and_stops(big_scene, tmp):
    config = {
        "name": "long",
        "command": "render",
        "scene": big_scene._file(),
        "fixed": {"threads": 1},
        "vary": {"ert": [1.0, 0.999, 0.998, 0.997]},  # four renders of ~2 s
    }
    threading.Timer(0.5, _thread.interrupt_main).start()
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        pvrsim.sweep(config, out=tmp)
        time.sleep(10)
    assert time.monotonic() - t0 < 1.5
    assert _stopped()
    # The cut run is not recorded as a failed one.
    csv = tmp / "long" / "results.csv"
    assert not csv.exists() or "FAILED" not in csv.read_text().upper()


@pytest.fixture(scope="module")
def big_grid():
    z, y, x = np.mgrid[0:192, 0:192, 0:192].astype(np.float32)
    a = (np.sin(x / 9.0) * np.cos(y / 7.0) + z / 192.0).astype(np.float32)
    scene = pvrsim.Scene.fit(pvrsim.Volume.from_array(a), view="30,20", size=(800, 800))
    scene._file()
    return scene


def _interrupted(call, after: float, within: float) -> None:
    """``call`` is cut by Ctrl-C after ``after`` s, raises KeyboardInterrupt
    within ``within`` s, and its job has stopped (not only the wait)."""
    threading.Timer(after, _thread.interrupt_main).start()
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        call()
        time.sleep(10)  # (a job that ignored Ctrl-C ends here: the interrupt lands in the sleep)
    assert time.monotonic() - t0 < within
    assert _stopped()


@pytest.mark.parametrize("renderer", ["slice3d", "reference"])
def test_an_interrupted_grid_render_stops(big_grid, renderer):
    _interrupted(lambda: pvrsim.render(big_grid, threads=1, renderer=renderer), 0.3, 1.0)
    assert pvrsim.render(VIEW_B, threads=1).image[..., 3].any()


def test_an_interrupted_cluster_frame_stops(big_scene):
    _interrupted(lambda: pvrsim.cluster(big_scene, nodes=4, ert=1.0), 0.3, 1.0)
    assert pvrsim.cluster(VIEW_B, nodes=2).image[..., 3].any()


def test_an_interrupted_grid_cluster_frame_stops(big_grid):
    _interrupted(lambda: pvrsim.cluster(big_grid, nodes=4), 0.3, 1.0)
    assert pvrsim.cluster(VIEW_B, nodes=2).image[..., 3].any()
