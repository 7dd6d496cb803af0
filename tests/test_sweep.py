"""Sweeps: axes, overrides into lists, resumability (calls counted), dask, heat maps."""

import argparse
import csv
import json
from pathlib import Path

import numpy as np
import pytest

from granular_chain import sweep as sw
from granular_chain.cli import sweep as sweep_command
from granular_chain.sweep import point as sweep_point
from granular_chain.two_granules import collide

ROOT = Path(__file__).resolve().parents[1]
ETA_MAP = ROOT / "scenarios" / "chain_eta_map.yaml"
AXES = ["granules.friction.kinetic[0]=0:0.3:4", "granules.friction.kinetic[1]=0:0.6:3"]
TIMING = {"wall_time", "eval_time"}


def axes():
    return [sw.parse_grid(s) for s in AXES]


def rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def comparable(rs):
    """Rows keyed by coordinates, without the timing columns."""
    return {(r[AXES[0].split("=")[0]], r[AXES[1].split("=")[0]]):
            {k: v for k, v in r.items() if k not in TIMING} for r in rs}


@pytest.fixture
def counted(monkeypatch):
    """Count evaluate_point calls; raise KeyboardInterrupt at call number `stop_at`."""
    state = {"calls": 0, "stop_at": None}
    real = sweep_point.evaluate_point

    def wrapper(*a, **k):
        state["calls"] += 1
        if state["stop_at"] is not None and state["calls"] == state["stop_at"]:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(sweep_point, "evaluate_point", wrapper)
    return state


def test_axes_parse():
    a = sw.parse_grid("run.dt=1e-3:1e-1:3:log")
    assert a.values == pytest.approx((1e-3, 1e-2, 1e-1))
    assert sw.parse_grid("x=0:1:5").values == (0.0, 0.25, 0.5, 0.75, 1.0)
    assert sw.parse_list("granules.count=2,10,50").values == (2, 10, 50)
    assert sw.parse_list("g.v=[1, 0],[0.5, 0.5]").values == ([1, 0], [0.5, 0.5])
    for bad in ("x=0:1", "x=a:1:3", "=0:1:3", "x=0:1:0", "x=0:1:3:lin", "x=-1:1:3:log"):
        with pytest.raises(sw.SweepError):
            sw.parse_grid(bad)
    assert len(sw.grid_points(axes())) == 12


def test_set_path_expands_per_granule_fields():
    d = {"granules": {"count": 3, "velocity": {0: 1.0}, "friction": {"kinetic": 0.1}}}
    sw.set_path(d, "granules.friction.kinetic[2]", 0.5)
    sw.set_path(d, "granules.velocity[1]", -1.0)
    sw.set_path(d, "granules.gap[-1]", -0.01)
    sw.set_path(d, "run.dt", 1e-3)
    assert d["granules"]["friction"]["kinetic"] == [0.1, 0.1, 0.5]
    assert d["granules"]["velocity"] == [1.0, -1.0, 0.0]
    assert d["granules"]["gap"] == [0.0, -0.01]
    assert d["run"] == {"dt": 1e-3}
    with pytest.raises(sw.SweepError):
        sw.set_path(d, "granules.friction.kinetic[3]", 0.1)
    with pytest.raises(sw.SweepError):
        sw.set_path(d, "run.dt[0]", 0.1)


def test_set_and_sweep_axes_share_the_scene_setter():
    # --set takes the same dotted paths as a sweep axis, list items included.
    from granular_chain.scene import apply_overrides, load_scene

    d = {"granules": {"count": 3, "velocity": {0: 1.0}, "friction": {"kinetic": 0.1}}}
    apply_overrides(d, ["granules.friction.kinetic[2]=0.5", "granules.velocity[1]=-1.0",
                        "granules.gap[-1]=-0.01", "run.dt=1e-3"])
    assert d == {"granules": {"count": 3, "velocity": [1.0, -1.0, 0.0], "gap": [0.0, -0.01],
                              "friction": {"kinetic": [0.1, 0.1, 0.5]}}, "run": {"dt": 1e-3}}
    scene = load_scene(ETA_MAP, ["granules.friction.kinetic[1]=0.25"])
    assert scene.granules.friction.kinetic[1] == 0.25


def test_points_match_collide():
    # The sweep's N = 2 fields are the collide() outcome of the same collision.
    row = sw.evaluate_point({"granules": {"count": 2}, **_eta_scene()}, "t", 
                            ["granules.friction.kinetic[0]", "granules.friction.kinetic[1]"],
                            [0.05, 0.3])
    c = collide(2.5, (0.05, 0.3), dt=1e-3)
    assert row["outcome"] == c.outcome.name == "backscatter_and_propagation"
    assert row["v1"] == c.v1 and row["v2"] == c.v2 and row["energy_ratio"] == c.energy_ratio


def _eta_scene():
    import yaml
    return yaml.safe_load(ETA_MAP.read_text())


def test_interrupted_sweep_resumes_without_recomputing(tmp_path, counted):
    full = sw.run_sweep(ETA_MAP, axes(), out_dir=tmp_path / "full", executor="serial",
                        batch_size=2)
    assert full.computed == 12 and counted["calls"] == 12

    counted.update(calls=0, stop_at=7)   # Ctrl-C inside the 4th batch
    part = sw.run_sweep(ETA_MAP, axes(), out_dir=tmp_path / "r", executor="serial",
                        batch_size=2)
    assert part.interrupted and part.computed == 6
    assert len(rows(tmp_path / "r" / "results.csv")) == 6

    counted.update(calls=0, stop_at=None)
    rest = sw.run_sweep(ETA_MAP, axes(), out_dir=tmp_path / "r", executor="serial",
                        batch_size=2)
    assert rest.skipped == 6 and rest.computed == 6 and counted["calls"] == 6
    assert comparable(rows(tmp_path / "r" / "results.csv")) == \
        comparable(rows(tmp_path / "full" / "results.csv"))

    counted.update(calls=0)               # a third run has nothing left to do
    again = sw.run_sweep(ETA_MAP, axes(), out_dir=tmp_path / "r", executor="serial")
    assert again.computed == 0 and again.skipped == 12 and counted["calls"] == 0


def test_row_cut_by_a_hard_kill_is_recomputed(tmp_path, counted):
    sw.run_sweep(ETA_MAP, axes(), out_dir=tmp_path / "o", executor="serial")
    path = tmp_path / "o" / "results.csv"
    text = path.read_text()
    path.write_text(text[: text.rstrip("\n").rfind("\n") + 1 + 25])  # last row half written
    counted["calls"] = 0
    st = sw.run_sweep(ETA_MAP, axes(), out_dir=tmp_path / "o", executor="serial")
    assert st.computed == 1 and counted["calls"] == 1
    assert len(rows(path)) == 12


def test_resume_refuses_a_changed_scene(tmp_path):
    scene = tmp_path / "s.yaml"
    scene.write_text(ETA_MAP.read_text())
    sw.run_sweep(scene, axes()[:1], out_dir=tmp_path / "o", executor="serial")
    scene.write_text(ETA_MAP.read_text().replace("dt: 1.0e-3", "dt: 2.0e-3"))
    with pytest.raises(sw.SweepError, match="scene_sha256"):
        sw.run_sweep(scene, axes()[:1], out_dir=tmp_path / "o", executor="serial")
    st = sw.run_sweep(scene, axes()[:1], out_dir=tmp_path / "o", executor="serial",
                      restart=True)
    assert st.computed == 4


def test_dask_local_cluster_resumes_a_partial_file(tmp_path):
    from distributed import Client, LocalCluster
    serial = sw.run_sweep(ETA_MAP, axes(), out_dir=tmp_path / "serial", executor="serial")
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        st = sw.run_sweep(ETA_MAP, axes(), out_dir=tmp_path / "d", client=client,
                          batch_size=3)
        assert st.computed == 12 and st.batches == 4 and st.workers == 2
        path = tmp_path / "d" / "results.csv"
        lines = path.read_text().splitlines(keepends=True)
        path.write_text("".join(lines[:6]))          # keep the header and 5 rows
        st = sw.run_sweep(ETA_MAP, axes(), out_dir=tmp_path / "d", client=client)
        assert st.skipped == 5 and st.computed == 7   # rows received = evaluations made
    assert comparable(rows(path)) == comparable(rows(serial.results))


def test_errors_become_rows_and_heat_maps_are_drawn(tmp_path):
    # eta2 = -0.1 is not a valid scene: that point is an 'error' row, the rest run.
    ax = [sw.parse_list("granules.friction.kinetic[1]=-0.1,0.0,0.3"),
          sw.parse_grid("granules.friction.kinetic[0]=0:0.2:3")]
    st = sw.run_sweep(ETA_MAP, ax, out_dir=tmp_path / "o", executor="serial")
    rs = rows(st.results)
    bad = [r for r in rs if r["status"] == "error"]
    assert len(bad) == 3 and "kinetic" in bad[0]["message"]
    for q, mask in (("v1", {"outcome": "backscatter_and_propagation"}), ("outcome", None)):
        png = sw.plot_heatmap(st.results, ax[1].path, ax[0].path, q, tmp_path / f"{q}.png",
                              mask=mask)
        assert png.stat().st_size > 1000


def test_sweep_command(tmp_path, capsys):
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    sweep_command.add_parser(sub)
    out = tmp_path / "o"
    args = parser.parse_args(["sweep", str(ETA_MAP), *sum((["--grid", a] for a in AXES), []),
                              "--serial", "--out", str(out), "--quantity", "v2",
                              "--quantity", "outcome", "--quiet"])
    assert sweep_command.run(args) == 0
    assert (out / "heatmap_v2.png").exists() and (out / "heatmap_outcome.png").exists()
    assert json.loads((out / "sweep.json").read_text())["axes"] == AXES
    args = parser.parse_args(["sweep", str(ETA_MAP), "--grid", "x=0:1", "--serial",
                              "--out", str(out)])
    assert sweep_command.run(args) == 2
    # A chain scene swept over N with --list, frames kept for the pulse speed.
    chain = ROOT / "scenarios" / "chain_striker.yaml"
    args = parser.parse_args(["sweep", str(chain), "--list", "granules.count=12,20",
                              "--set", "run.t_end=20", "--frames", "--serial", "--quiet",
                              "--out", str(tmp_path / "c")])
    assert sweep_command.run(args) == 0
    rs = rows(tmp_path / "c" / "results.csv")
    assert [r["granules.count"] for r in rs] == ["12", "20"]
    assert float(rs[1]["pulse_speed"]) == pytest.approx(0.84, abs=0.02)
