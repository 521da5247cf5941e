"""Ctrl-C stops a long render and raises KeyboardInterrupt."""

from __future__ import annotations

import _thread
import threading
import time

import pvrsim
import pytest

from conftest import VIEW_B, kuhn_cube_mesh


def test_an_interrupted_render_raises_keyboard_interrupt_and_stops():
    pts, tets, r = kuhn_cube_mesh(48)  # 663552 tetrahedra: ~2 s at 800 x 800 on one thread
    scene = pvrsim.Scene.fit(pvrsim.Mesh.from_arrays(pts, tets, {"r": r}), field="r",
                             view="30,20", size=(800, 800))
    scene._file()  # write the data now, so the timer falls in the render
    threading.Timer(0.3, _thread.interrupt_main).start()
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        pvrsim.render(scene, threads=1, ert=1.0)
        time.sleep(5)  # (a render that ignored Ctrl-C ends here: the interrupt lands in the sleep)
    assert time.monotonic() - t0 < 1.3
    # The job itself has stopped, not only the wait for it.
    deadline = time.monotonic() + 1.0
    while pvrsim._native.jobs_running() and time.monotonic() < deadline:
        time.sleep(0.01)
    assert pvrsim._native.jobs_running() == 0
    # And the next job runs as usual.
    assert pvrsim.render(VIEW_B, threads=1).image[..., 3].any()
