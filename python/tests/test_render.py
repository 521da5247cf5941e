"""render: the CLI's pixels, arrays in, fitted scenes, options by keyword."""

from __future__ import annotations

import numpy as np
import pvrsim
import pytest

from conftest import AORTA, VIEW_B, read_png, run_cli


def test_render_equals_the_cli_png_bit_for_bit(tmp):
    png = tmp / "cli.png"
    run_cli("render", str(VIEW_B), "-o", str(png), "--threads", "1")
    res = pvrsim.render(VIEW_B, threads=1)
    assert res.image.shape == (100, 100, 4) and res.image.dtype == np.uint8
    cli = read_png(png)
    assert cli.shape == (100, 100, 3)
    assert np.array_equal(res.image[..., :3], cli)
    assert res.image[..., 3].any(), "the aorta covers some pixels"
    assert res.stats["cells_projected"] > 0 and "time_total_s" in res.stats


def test_render_options_by_keyword_match_the_cli(tmp):
    png = tmp / "cli.png"
    stats = tmp / "cli.json"
    run_cli("render", str(VIEW_B), "-o", str(png), "--threads", "1", "--ert", "0.9",
            "--integrator", "midpoint", "--tile", "16", "--stats", str(stats))
    out = tmp / "py.png"
    res = pvrsim.render(str(VIEW_B), threads=1, ert=0.9, integrator="midpoint", tile=16,
                        output=out, stats=tmp / "py.json")
    assert np.array_equal(res.image[..., :3], read_png(png))
    assert np.array_equal(read_png(out), read_png(png)), "output= writes the CLI's PNG"
    import json

    cli_stats = json.loads(stats.read_text())
    assert set(cli_stats) == set(res.stats)
    assert cli_stats["segments_generated"] == res.stats["segments_generated"]


def test_a_mesh_from_arrays_renders_the_image_of_the_file_mesh():
    m = pvrsim.Mesh.read(AORTA)
    assert m.points.dtype == np.float32 and m.points.shape == (5326, 3)
    assert m.tets.dtype == np.int64 and m.tets.shape == (20169, 4)
    assert m.point_data["speed"].shape == (5326,)
    a = pvrsim.Mesh.from_arrays(
        m.points.astype(np.float64), m.tets.astype(np.uint32),
        {"speed": m.point_data["speed"].astype(np.float32)},
    )
    assert a.path is None
    from_file = pvrsim.Scene.fit(m, field="speed", view="-y", size=(120, 90))
    from_arrays = pvrsim.Scene.fit(a, field="speed", view="-y", size=(120, 90))
    assert from_arrays.data_path == "<in memory>"
    r1 = pvrsim.render(from_file, threads=1)
    r2 = pvrsim.render(from_arrays, threads=1)
    assert r1.image.shape == (90, 120, 4)
    assert r1.image[..., 3].any()
    assert np.array_equal(r1.image, r2.image)


def test_a_volume_from_an_array_renders_and_round_trips(tmp):
    z, y, x = np.mgrid[0:24, 0:20, 0:16]
    a = np.sqrt((x - 8.0) ** 2 + (y - 10.0) ** 2 + (z - 12.0) ** 2).astype(np.float64)
    v = pvrsim.Volume.from_array(a, spacing=(1, 1, 2), origin=(0, 0, 0), field="r")
    assert v.dims == (16, 20, 24) and v.array.dtype == np.float32 and v.array.shape == (24, 20, 16)
    assert np.array_equal(v.array, a.astype(np.float32))
    scene = pvrsim.Scene.fit(v, view="+z", size=(64, 64))
    img = pvrsim.render(scene, threads=1).image
    assert img.shape == (64, 64, 4) and img[..., 3].any()
    scene.save(tmp / "vol.toml")
    assert (tmp / "vol.nrrd").is_file()
    back = pvrsim.Volume.read(tmp / "vol.nrrd")
    assert np.array_equal(back.array, v.array) and back.spacing == (1.0, 1.0, 2.0)
    again = pvrsim.render(pvrsim.Scene.load(tmp / "vol.toml"), threads=1).image
    assert np.array_equal(again, img)


def test_scene_load_save_and_to_toml(tmp):
    s = pvrsim.Scene.load(VIEW_B)
    assert s.size == (100, 100) and s.field == "speed"
    assert s.to_toml() == VIEW_B.read_text()
    s.save(tmp / "elsewhere.toml")  # the data path is kept valid from there
    r1 = pvrsim.render(s, threads=1).image
    r2 = pvrsim.render(tmp / "elsewhere.toml", threads=1).image
    assert np.array_equal(r1, r2)


def test_meshio_and_pyvista_shapes_are_duck_typed():
    m = pvrsim.Mesh.read(AORTA)

    class Block:
        type = "tetra"
        data = m.tets

    class MeshioLike:
        points = m.points
        cells = [Block()]
        point_data = {"speed": m.point_data["speed"]}

    class PyvistaLike:
        points = m.points
        cells_dict = {10: m.tets}
        point_data = {"speed": m.point_data["speed"]}

    for mesh in (pvrsim.Mesh.from_meshio(MeshioLike()), pvrsim.Mesh.from_pyvista(PyvistaLike())):
        assert np.array_equal(mesh.tets, m.tets)
        assert np.array_equal(mesh.point_data["speed"], m.point_data["speed"])

    class Hexes(MeshioLike):
        cells = [Block(), type("B", (), {"type": "hexahedron", "data": np.zeros((1, 8))})()]

    with pytest.raises(pvrsim.DataError, match="hexahedron"):
        pvrsim.Mesh.from_meshio(Hexes())


def test_help_teaches():
    assert "A tour" in pvrsim.__doc__
    doc = pvrsim.render.__doc__
    for name in ("ert_table", "integrator", "threads", "[default: 0.99]"):
        assert name in doc, name
    assert "transport" in pvrsim.cluster.__doc__
