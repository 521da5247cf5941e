"""cluster (threads and worker processes) and sweep."""

from __future__ import annotations

import numpy as np
import pvrsim
import pytest

from conftest import REPO, VIEW_B, read_png, run_cli


@pytest.mark.parametrize("transport", ["threads", "processes"])
def test_cluster_on_four_nodes_returns_report_nodes_and_timeline(transport):
    cl = pvrsim.cluster(VIEW_B, nodes=4, transport=transport, ert=0.9)
    assert cl.image.shape == (100, 100, 4) and cl.image[..., 3].any()
    assert cl.report["n_nodes"] == 4
    assert cl.ranks == 4
    assert len(cl.nodes) == 4
    assert cl.nodes["cells_processed"].sum() > 0
    t = cl.timeline
    assert list(t.columns[:4]) == ["node", "activity", "start_s", "end_s"]
    assert set(t["node"]) >= {0, 1, 2, 3}
    assert (t["end_s"] >= t["start_s"]).all()
    assert "scan" in set(t["activity"])


def test_cluster_report_is_the_cli_report(tmp):
    png, report = tmp / "cli.png", tmp / "cli.json"
    run_cli("cluster", str(VIEW_B), "--nodes", "4", "-o", str(png), "--report", str(report))
    cl = pvrsim.cluster(VIEW_B, nodes=4)
    import json

    cli = json.loads(report.read_text())
    assert set(cli) == set(cl.report)
    assert cli["cells_total"] == cl.report["cells_total"]
    assert np.array_equal(cl.image[..., :3], read_png(png))


def test_sweep_of_the_smoke_config_returns_its_rows(capsys):
    df = pvrsim.sweep(REPO / "configs" / "smoke.toml", progress=True)
    # 2 integrators x 4 tiles x 2 image sizes x 2 repetitions.
    assert len(df) == 32
    assert set(df["integrator"]) == {"exact", "midpoint"}
    assert sorted(set(df["tile"])) == [8, 16, 32, 64]
    assert set(df["width"]) == {100, 200}
    assert (df["status"] == "ok").all()
    assert (df["time_scan_s"] > 0).all()
    assert "time_scan_s" in df.attrs["summary"]
    printed = capsys.readouterr().out.splitlines()
    assert len([l for l in printed if l.startswith("[")]) == 32, printed


def test_sweep_from_a_dict_and_kept_results(tmp):
    config = {
        "name": "mini",
        "command": "render",
        "scene": str(VIEW_B),
        "fixed": {"threads": 1},
        "vary": {"ert": [0.9, 1.0]},
    }
    df = pvrsim.sweep(config, out=tmp)
    assert list(df["ert"]) == [0.9, 1.0] and (df["status"] == "ok").all()
    assert (tmp / "mini" / "results.csv").is_file()
    again = pvrsim.sweep(config, out=tmp)  # resumes: nothing left to run
    assert len(again) == 2


def test_a_mesh_series_writes_every_frame_its_rows_and_fps(tmp):
    cl = pvrsim.cluster(
        VIEW_B,
        nodes=2,
        frames=3,
        turn=30,
        no_baselines=True,
        output=str(tmp / "f-%02d.png"),
        series_csv=str(tmp / "s.csv"),
    )
    series = cl.report["series"]
    assert series["n_frames"] == 3 and series["fps"] > 0
    assert [f["frame"] for f in series["frames"]] == [0, 1, 2]
    assert (tmp / "s.csv").read_text().count("\n") == 4
    # Every frame written and returned; the last is the image.
    assert len(cl.images) == 3 and len(cl.frames) == 3
    for k, img in enumerate(cl.images):
        assert np.array_equal(img[..., :3], read_png(tmp / f"f-{k:02d}.png"))
    assert np.array_equal(cl.image, cl.images[-1])
    assert not np.array_equal(read_png(tmp / "f-00.png"), read_png(tmp / "f-02.png"))
