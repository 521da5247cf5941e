"""A partitioned mesh (.pvtu) on worker processes: each worker reads its own pieces."""

from __future__ import annotations

import shutil

import numpy as np
import pvrsim
import pytest

from conftest import DATA, VIEW_B


def pieces_scene(tmp, enc="zlib"):
    """VTK's own 4 pieces of the small aorta with view B's scene."""
    for k in range(4):
        name = f"aorta-small-{enc}_{k}.vtu"
        shutil.copy(DATA / "pieces" / name, tmp / name)
    shutil.copy(DATA / "pieces" / f"aorta-small-{enc}.pvtu", tmp / "a.pvtu")
    text = VIEW_B.read_text().replace('path  = "aorta-small.vtk"', 'path  = "a.pvtu"')
    assert "a.pvtu" in text
    scene = tmp / "scene.toml"
    scene.write_text(text)
    return scene


def test_workers_reading_their_pieces_render_the_single_process_image(tmp):
    scene = pieces_scene(tmp)
    single = pvrsim.render(scene, canonical=True, ert=1.0)
    cl = pvrsim.cluster(scene, nodes=3, transport="processes", canonical=True, ert=1.0)
    assert np.array_equal(cl.image, single.image)
    assert cl.report["placement"] == "pieces"
    assert cl.report["pieces"]["pieces"] == 4
    assert cl.report["pieces"]["parts"] == [[0], [1, 2], [3]]
    assert cl.report["cells_total"] == 20169


def test_a_truncated_piece_is_named(tmp):
    scene = pieces_scene(tmp, "raw")
    piece = tmp / "aorta-small-raw_1.vtu"
    piece.write_bytes(piece.read_bytes()[:-5000])
    with pytest.raises(pvrsim.Error, match="aorta-small-raw_1.vtu"):
        pvrsim.cluster(scene, nodes=2, transport="processes")
