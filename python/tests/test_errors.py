"""Errors: the documented classes, with the command line's messages."""

from __future__ import annotations

import numpy as np
import pvrsim
import pytest

from conftest import AORTA, REPO, VIEW_B, cli_error


def test_a_bad_option_is_a_value_error_naming_it_with_the_cli_message():
    cli = cli_error("render", str(VIEW_B), "--ert", "1.5", "-o", "/dev/null.png")
    with pytest.raises(pvrsim.OptionError) as e:
        pvrsim.render(VIEW_B, ert=1.5)
    assert isinstance(e.value, ValueError) and isinstance(e.value, pvrsim.Error)
    assert str(e.value).startswith("ert=1.5: ")
    assert all(line in str(e.value) for line in cli), (cli, str(e.value))
    assert e.value.option == "ert"


def test_a_malformed_value_carries_clap_s_message():
    with pytest.raises(pvrsim.OptionError, match="integrator=\"bogus\".*possible values: exact, midpoint"):
        pvrsim.render(VIEW_B, integrator="bogus")
    with pytest.raises(pvrsim.OptionError, match="nodes=0"):
        pvrsim.cluster(VIEW_B, nodes=0)


def test_an_unknown_keyword_is_named():
    with pytest.raises(pvrsim.UnknownOptionError, match="'ert_tabel'.*ert_table") as e:
        pvrsim.render(VIEW_B, ert_tabel=20)
    assert isinstance(e.value, TypeError) and isinstance(e.value, ValueError)
    with pytest.raises(pvrsim.UnknownOptionError, match="'share'"):
        pvrsim.render(VIEW_B, share=True)  # a cluster option, not a render one


def test_missing_and_corrupt_files_are_os_errors_naming_the_file(tmp):
    missing = tmp / "missing.toml"
    cli = cli_error("render", str(missing), "-o", str(tmp / "x.png"))
    with pytest.raises(pvrsim.FileError) as e:
        pvrsim.render(missing)
    assert isinstance(e.value, OSError)
    assert all(line in str(e.value) for line in cli) and str(missing) in str(e.value)
    with pytest.raises(OSError, match="missing.vtk") as e:
        pvrsim.Mesh.read(tmp / "missing.vtk")
    # The problem is named once (issue 55: the OS message came twice).
    assert str(e.value).count("No such file or directory") == 1, str(e.value)
    with pytest.raises(pvrsim.FileError) as e:
        pvrsim.render(missing)
    assert str(e.value).count("No such file or directory") == 1, str(e.value)
    with pytest.raises(pvrsim.FileError, match="missing.toml"):
        pvrsim.Scene.load(missing)
    bad = tmp / "bad.toml"
    bad.write_text(VIEW_B.read_text().replace("up         = [0, 1, 0]", "up         = [0, 1]"))
    cli = cli_error("render", str(bad), "-o", str(tmp / "x.png"))
    with pytest.raises(pvrsim.FileError) as e:
        pvrsim.render(bad)
    assert "camera.up" in str(e.value) and all(line in str(e.value) for line in cli)
    assert e.value.filename == str(bad)
    corrupt = tmp / "corrupt.vtk"
    corrupt.write_bytes(AORTA.read_bytes()[:3000])
    with pytest.raises(pvrsim.FileError, match="corrupt.vtk"):
        pvrsim.Mesh.read(corrupt)


def _tet():
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
    tets = np.array([[0, 1, 2, 3]])
    return points, tets


def test_bad_arrays_raise_data_errors_with_the_cli_messages():
    points, tets = _tet()
    pvrsim.Mesh.from_arrays(points, tets, {"s": np.arange(4)})
    with pytest.raises(pvrsim.DataError, match=r"points: expected shape \(N, 3\), got \(4, 2\)"):
        pvrsim.Mesh.from_arrays(points[:, :2], tets)
    with pytest.raises(pvrsim.DataError, match=r"tets: expected shape \(M, 4\)"):
        pvrsim.Mesh.from_arrays(points, tets[:, :3])
    nan = points.copy()
    nan[2, 1] = np.nan
    with pytest.raises(pvrsim.DataError, match="point 2: coordinate is not finite") as e:
        pvrsim.Mesh.from_arrays(nan, tets)
    assert isinstance(e.value, ValueError)
    with pytest.raises(pvrsim.DataError, match=r"cell 0: vertex index 9 is out of range \(the mesh has 4 points\)"):
        pvrsim.Mesh.from_arrays(points, np.array([[0, 1, 2, 9]]))
    with pytest.raises(pvrsim.DataError, match="cell 0: vertex index -1 is out of range"):
        pvrsim.Mesh.from_arrays(points, np.array([[0, 1, 2, -1]]))
    with pytest.raises(pvrsim.DataError, match=r"field \"s\".*not finite"):
        pvrsim.Mesh.from_arrays(points, tets, {"s": [0, 1, np.inf, 3]})
    with pytest.raises(pvrsim.DataError, match="spacing along axis 0 is -1; it must be finite and > 0"):
        pvrsim.Volume.from_array(np.zeros((2, 3, 4), np.uint8), spacing=(-1, 1, 1))
    with pytest.raises(pvrsim.DataError, match="expected a 3-D array"):
        pvrsim.Volume.from_array(np.zeros((3, 4)))


def test_the_messages_are_the_readers_own(tmp):
    # The same NaN through a file: the CLI's reader says the same words.
    text = "# vtk DataFile Version 3.0\nnan\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n" \
           "0 0 0 1 0 0 0 nan 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n"
    f = tmp / "nan.vtk"
    f.write_text(text)
    cli = cli_error("info", str(f))
    reader = [line for line in cli if "point 2: coordinate is not finite" in line]
    assert reader, cli
    with pytest.raises(pvrsim.FileError) as e:
        pvrsim.Mesh.read(f)
    assert reader[0] in str(e.value) and e.value.filename == str(f)


def test_a_panic_never_reaches_python_and_the_module_runs_from_anywhere(tmp):
    import subprocess
    import sys

    p = subprocess.run([sys.executable, "-c", "import pvrsim; print(pvrsim.__version__)"],
                       cwd=tmp, capture_output=True, text=True)
    assert p.returncode == 0 and p.stdout.strip(), p.stderr
