"""``granular-chain export``: a run's frames in other mesh formats, read back with meshio."""

import os

import meshio
import numpy as np

import granular_chain as gc
from granular_chain.cli import main
from granular_chain.rundir import read_marker

SCENE = "name: ex\ngranules: {count: 6, velocity: {0: 1.0}}\nrun: {t_end: 4}\noutput: {every: 20}\n"


def _run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.yaml").write_text(SCENE)
    assert main(["run", "s.yaml", "--out", "r", "--quiet"]) == 0
    return gc.read_run(tmp_path / "r")


def test_xdmf_time_series_reads_back_the_frames(tmp_path, monkeypatch):
    result = _run(tmp_path, monkeypatch)
    before = sorted(os.listdir(tmp_path))
    assert main(["export", "r"]) == 0
    assert sorted(os.listdir(tmp_path)) == before  # nothing beside the run (meshio's .h5 too)
    folder = tmp_path / "r" / "export" / "xdmf"
    monkeypatch.chdir(folder)
    with meshio.xdmf.TimeSeriesReader("run.xdmf") as reader:
        points, cells = reader.read_points_cells()
        assert reader.num_steps == result.t.size > 5
        assert np.array_equal(points[:, 0], result.x[0])
        assert np.array_equal(cells[0].data, np.column_stack([np.arange(5), np.arange(1, 6)]))
        for q in (0, reader.num_steps // 2, reader.num_steps - 1):
            t, point_data, _ = reader.read_data(q)
            assert t == result.t[q]
            assert np.array_equal(point_data["displacement"][:, 0], result.x[q] - result.x[0])
            assert np.array_equal(point_data["velocity"], result.v[q])
    assert {"export/xdmf/run.xdmf", "export/xdmf/run.h5"} <= set(
        read_marker(tmp_path / "r")["files"])


def test_vtu_one_file_a_frame_and_refusals(tmp_path, monkeypatch, capsys):
    result = _run(tmp_path, monkeypatch)
    assert main(["export", "r", "--format", "vtu", "--out", "vtu"]) == 0
    files = sorted(p for p in (tmp_path / "vtu").iterdir() if p.name != "run.json")
    assert len(files) == result.t.size
    assert read_marker(tmp_path / "vtu")["command"] == "export"
    mesh = meshio.read(files[-1])
    assert np.array_equal(mesh.points[:, 0], result.x[-1])
    assert np.array_equal(mesh.point_data["net_force"], result.f[-1])
    capsys.readouterr()
    assert main(["export", "r", "--format", "vtu", "--out", "vtu"]) == 0  # its own folder
    (tmp_path / "mine").mkdir()
    assert main(["export", "r", "--format", "vtu", "--out", "mine"]) == 2  # the user's
    assert main(["export", "r", "--format", "nonsense"]) == 2
    assert main(["export", "missing"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and all(line.startswith("granular-chain: ") for line in err)
