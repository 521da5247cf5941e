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


def test_mesh_read_and_scene_fit_take_a_pvtu(tmp):
    scene = pieces_scene(tmp, "raw")
    whole = pvrsim.Mesh.read(DATA / "aorta-small.vtk")
    m = pvrsim.Mesh.read(tmp / "a.pvtu")
    assert (m.n_points, m.n_tets) == (whole.n_points, whole.n_tets)
    assert m.file_cell_ids is None and m.file_vertex_ids is None
    fitted = pvrsim.Scene.fit(m, field="speed", size=(64, 48))
    assert fitted.field == "speed" and fitted.size == (64, 48)
    assert fitted.data_path.endswith("a.pvtu")
    assert scene.exists()


def test_a_scattered_file_is_renumbered_with_its_file_ids(tmp):
    # A lattice of 44^3 cubes (91,125 vertices), 6 tetrahedra each, its
    # vertices and cells written in a random order.
    n = 44
    g = np.arange(n + 1)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), z.ravel()], 1).astype(np.float64)
    idx = lambda i, j, k: i + (n + 1) * (j + (n + 1) * k)
    c = np.stack(np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij"), -1).reshape(-1, 3)
    i, j, k = c[:, 0], c[:, 1], c[:, 2]
    a, b = idx(i, j, k), idx(i + 1, j + 1, k + 1)
    tets = np.concatenate([
        np.stack([a, idx(i + 1, j, k), idx(i + 1, j + 1, k), b], 1),
        np.stack([a, idx(i + 1, j, k), idx(i + 1, j, k + 1), b], 1),
        np.stack([a, idx(i, j + 1, k), idx(i + 1, j + 1, k), b], 1),
        np.stack([a, idx(i, j + 1, k), idx(i, j + 1, k + 1), b], 1),
        np.stack([a, idx(i, j, k + 1), idx(i + 1, j, k + 1), b], 1),
        np.stack([a, idx(i, j, k + 1), idx(i, j + 1, k + 1), b], 1),
    ])
    rng = np.random.default_rng(3)
    vp, cp = rng.permutation(len(pts)), rng.permutation(len(tets))
    inv = np.empty_like(vp)
    inv[vp] = np.arange(len(vp))
    fpts, ftets = pts[vp], inv[tets[cp]]
    s = fpts @ np.array([1.0, 2.0, 3.0])
    pvrsim.Mesh.from_arrays(fpts, ftets, {"s": s}).save(tmp / "p.vtk")
    m = pvrsim.Mesh.read(tmp / "p.vtk")
    v, cells = m.file_vertex_ids, m.file_cell_ids
    assert v is not None and cells is not None
    assert np.array_equal(np.sort(v), np.arange(len(pts)))
    assert np.array_equal(m.points, fpts[v])
    assert np.array_equal(m.point_data["s"], s.astype(np.float32)[v])
    # Each new cell is its file cell, with the vertices renumbered.
    assert np.array_equal(v[m.tets], ftets[cells])
