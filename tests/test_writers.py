"""Writers: VTK time series read back by pyvista, CSV tables, HDF5 round trip, plots, CLI
selection of writers, and output cadence leaving the physics bit-identical."""

import dataclasses
import json
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest

from granular_chain import Event, load_scene, simulate
from conftest import patch_everywhere
from granular_chain.cli import main
from granular_chain.model import build_model

ROOT = Path(__file__).resolve().parents[1]
CHAIN = ROOT / "scenarios" / "chain_friction.yaml"
SHORT = ["run.t_end=20"]  # the pulse is a third of the way down the chain


@pytest.fixture(scope="module")
def run():
    scene = load_scene(CHAIN, SHORT)
    return scene, simulate(scene, progress=False)


# ---------------------------------------------------------------- VTK time series

def test_vtk_series_opens_in_pyvista_with_times_and_point_data(run, tmp_path):
    import pyvista as pv

    from granular_chain.writers.vtk import write_vtk

    scene, result = run
    model = build_model(scene)
    pvd = write_vtk(result, tmp_path, scene)
    reader = pv.get_reader(str(pvd))
    # repr() in the index: the reader's times are the Result's doubles, exactly.
    assert reader.number_time_points == result.t.size > 100
    assert np.array_equal(np.array(reader.time_values), result.t)
    F = result.t.size
    for i in (0, 1, F // 2, F - 1):
        reader.set_active_time_value(result.t[i])
        assert reader.active_time_value == result.t[i]
        frame = reader.read()[0]
        assert frame.n_points == 50 and frame.n_cells == 49
        assert np.array_equal(frame.points[:, 0], result.x[i])
        assert not frame.points[:, 1:].any()
        pd = frame.point_data
        assert np.array_equal(pd["velocity"], result.v[i])
        assert np.array_equal(pd["net_force"], result.f[i])
        assert np.array_equal(pd["radius"], model.radius)
        assert np.array_equal(pd["mass"], model.mass)
        assert np.array_equal(pd["friction_state"], np.where(result.v[i] == 0.0, 1, 0))
        assert frame.field_data["TimeValue"][0] == result.t[i]
        # Line cells join neighbours i, i+1.
        assert np.array_equal(frame.lines.reshape(-1, 3),
                              np.column_stack([np.full(49, 2), np.arange(49), np.arange(1, 50)]))
        x = result.x[i]
        overlap = 20.0 - np.diff(x)  # r_i + r_(i+1) = 20
        assert np.array_equal(frame.cell_data["overlap"], overlap)
        force = frame.cell_data["force"]
        closed = np.maximum(overlap, 0.0)  # the Hertz law of laws.contact: d sqrt(d)
        assert np.array_equal(force, closed * np.sqrt(closed))
        assert np.array_equal(frame.cell_data["in_contact"], overlap > 0)
        # Physics: the contact forces add up to the engine's net force on each
        # granule (f_i = F_(i-1) - F_i). The engine forms overlaps from
        # displacements, the writer from positions up to ~1000, so they agree to a few
        # ulps of 1000 times the contact stiffness 1.5 sqrt(delta) <= 2.
        net = np.concatenate([[0.0], force]) - np.concatenate([force, [0.0]])
        assert np.max(np.abs(net - result.f[i])) < 4 * np.spacing(x.max())
    # Frame 0: the striker moves, every other granule is at rest and held by friction.
    reader.set_active_time_value(result.t[0])
    state0 = reader.read()[0].point_data["friction_state"]
    assert state0[0] == 0 and np.all(state0[1:] == 1)
    # Mid-run the pulse is a closed, compressed group of contacts.
    reader.set_active_time_value(result.t[F // 2])
    mid = reader.read()[0]
    assert mid.cell_data["force"].max() > 0.1 and mid.point_data["velocity"].max() > 0.3


def test_pvd_index_is_vtk_collection_and_only_written_on_clean_exit(run, tmp_path):
    from granular_chain.writers.vtk import VTKSeriesWriter

    scene, result = run
    model = build_model(scene)
    args = (model.radius, model.mass, model.k, model.n, model.eta_static)
    with pytest.raises(RuntimeError):
        with VTKSeriesWriter(tmp_path / "cut", *args) as series:
            series.write_frame(result.t[0], result.x[0], result.v[0], result.f[0])
            raise RuntimeError("writer interrupted")
    assert (tmp_path / "cut" / "vtk" / "frame_000000.vtp").exists()
    assert not (tmp_path / "cut" / "run.pvd").exists()  # no index: not a complete series
    with VTKSeriesWriter(tmp_path / "ok", *args) as series:
        for i in range(3):
            series.write_frame(result.t[i], result.x[i], result.v[i], result.f[i])
    root = ET.parse(tmp_path / "ok" / "run.pvd").getroot()
    assert root.tag == "VTKFile" and root.attrib["type"] == "Collection"
    ds = root.find("Collection").findall("DataSet")
    assert [d.attrib["file"] for d in ds] == [f"vtk/frame_{i:06d}.vtp" for i in range(3)]
    assert [float(d.attrib["timestep"]) for d in ds] == list(result.t[:3])


def test_vtk_forces_are_the_engines_contact_law_with_the_walls(tmp_path):
    """Both walls pressing on a Hertz chain (run through the CLI, its VTK writer
    attached to the run): in every frame the cells' contact forces and the
    field data's wall forces add up to the engine's net force on each granule,
    the two end granules included, and at t = 0, where the writer's wall overlaps
    equal the engine's exactly, the wall forces are the engine's law bit for bit."""
    import pyvista as pv

    from granular_chain import read_run
    from granular_chain.laws.contact import contact_force

    out = tmp_path / "walls"
    assert main(["run", str(ROOT / "scenarios" / "chain_walls.yaml"), "--out", str(out),
                 "--quiet", "--vtk", "--set", "walls.left.gap=-0.02", "--set",
                 "walls.right.gap=-0.03", "--set", "run.t_end=60", "--set",
                 "output.every=200"]) == 0
    result = read_run(out)
    model = result.model
    law, walls = model.features.law, model.walls
    reader = pv.get_reader(str(out / "run.pvd"))
    assert np.array_equal(np.array(reader.time_values), result.t) and result.t.size == 31
    pressed = 0.0
    for i, t in enumerate(result.t):
        reader.set_active_time_value(t)
        frame = reader.read()[0]
        force = frame.cell_data["force"]
        wall = frame.field_data["wall_force"]
        net = np.concatenate([[wall[0]], force]) - np.concatenate([force, [wall[1]]])
        # The writer forms overlaps from positions x = x0 + u, the engine from the
        # displacements u: they differ by at most 2 ulps of the largest position,
        # times the contact stiffness dF/d(delta) = 1.5 sqrt(delta), twice (two
        # contacts per granule).
        delta = max(float(np.max(frame.cell_data["overlap"])),
                    float(np.nanmax(frame.field_data["wall_overlap"])))
        bound = 2 * 1.5 * np.sqrt(delta) * 2 * np.spacing(np.max(np.abs(result.x[i])))
        assert np.max(np.abs(net - result.f[i])) <= bound, (i, bound)
        pressed = max(pressed, float(np.min(wall)))
        if i == 0:  # u = 0: the wall overlaps are the engine's d0 exactly
            assert wall[0] == contact_force(law, walls[0], walls[1], walls[2])
            assert wall[1] == contact_force(law, walls[3], walls[4], walls[5])
            assert list(frame.field_data["wall_overlap"]) == [0.02, 0.03]
    # In some frames both walls press at once, by far more than the bound (forces
    # ~0.1): without the wall forces the end granules' net force would be missed.
    assert pressed > 1e-3


def test_friction_state_legend():
    from granular_chain.writers.vtk import friction_state

    v = np.array([0.0, 0.3, 0.0, -0.2, -0.0])
    eta_s = np.array([0.1, 0.1, 0.0, 0.0, 0.2])
    assert friction_state(v, eta_s).tolist() == [1, 0, -1, -1, 1]


# ---------------------------------------------------------------- tables and HDF5

def test_energy_csv_round_trips_the_ledger(run, tmp_path):
    from granular_chain.writers.tables import write_tables

    scene, result = run
    paths = write_tables(result, tmp_path, scene)
    assert [p.name for p in paths] == ["energy.csv"]  # Verlet logs no events
    assert (tmp_path / "energy.csv").read_text().splitlines()[0] == \
        "t,kinetic,potential,coulomb,viscous,contact_dissipated,wall_work,body_work,stage_work,balance"
    table = np.genfromtxt(tmp_path / "energy.csv", delimiter=",", names=True)
    led = result.energy
    for name, ref in (("t", result.t), ("kinetic", led.kinetic), ("potential", led.potential),
                      ("coulomb", led.coulomb), ("viscous", led.viscous),
                      ("balance", led.balance)):
        assert np.array_equal(table[name], ref), name
    # The ledger closes: balance is the integrator's error, tiny against E0 = 1/2.
    assert np.max(np.abs(table["balance"])) < 1e-4 * 0.5
    assert table["coulomb"][-1] > 0 and table["viscous"][-1] > 0


def test_events_csv_when_events_are_logged(run, tmp_path):
    from granular_chain.writers.tables import write_events_csv

    _, result = run
    events = [Event(0.125, "contact_close", 0, 5), Event(1.0 / 3.0, "stop", 7, 13),
              Event(2.5, "contact_open", -1)]
    path = write_events_csv(dataclasses.replace(result, events=events), tmp_path)
    rows = path.read_text().splitlines()
    assert rows[0] == "step,t,kind,index"
    back = [Event(float(t), k, int(i), int(s)) for s, t, k, i in (r.split(",") for r in rows[1:])]
    assert back == events and back[-1].step == -1
    assert write_events_csv(result, tmp_path / "none") is None


def test_trajectory_round_trip_with_events(run, tmp_path):
    from granular_chain.readback import read_trajectory
    from granular_chain.writers.trajectory import write_trajectory

    scene, result = run
    events = [Event(0.5, "slip", 3, 42)]
    write_trajectory(dataclasses.replace(result, events=events), tmp_path, scene)
    back, scene_back = read_trajectory(tmp_path)
    for name in ("t", "x", "v", "f"):
        assert np.array_equal(getattr(back, name), getattr(result, name)), name
    assert np.array_equal(back.energy.balance, result.energy.balance)
    assert back.events == events and back.status == result.status
    assert scene_back == scene
    with h5py.File(tmp_path / "trajectory.h5") as h5:
        assert h5["event_kind"][0] == 3 and h5["event_time"].attrs["units"] == "1"  # slip


# ---------------------------------------------------------------- plots

def _png(path):
    import matplotlib.image as mpimg

    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return mpimg.imread(path)


def test_plots_are_pngs_that_show_something(run, tmp_path):
    from granular_chain.writers.plots import write_plots

    scene, result = run
    paths = write_plots(result, tmp_path, scene, granules=[0, 10, 49])
    names = [p.name for p in paths]
    assert names[:3] == ["spacetime.png", "energy.png", "velocities.png"]
    for p in paths:
        img = _png(p)
        assert img.shape[0] > 300 and img.shape[1] > 500
        assert np.std(img[..., :3]) > 0.05  # not a blank canvas
    # Off-screen rendering through EGL works here (checked when this was written):
    # the frame PNG must exist and contain the velocity colours of the pulse.
    assert names[3] == "frame.png", "off-screen rendering failed; see the message above"
    frame = _png(paths[3])[..., :3]
    reddish = (frame[..., 0] > 0.6) & (frame[..., 2] < 0.5)
    assert reddish.sum() > 50


def test_plots_bad_granule_index(run, tmp_path):
    from granular_chain.writers.plots import plot_velocities

    _, result = run
    with pytest.raises(ValueError, match="outside 0..49"):
        plot_velocities(result, tmp_path / "v.png", granules=[0, 50])


# ---------------------------------------------------------------- CLI selection of writers

def _files(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def test_run_that_asks_for_nothing_writes_only_marker_and_summary(tmp_path):
    out = tmp_path / "none"
    assert main(["run", str(CHAIN), "--out", str(out), "--quiet", "--set", "run.t_end=5",
                 "--set", "output.trajectory=false"]) == 0
    # (a Verlet run that reached t_end keeps its checkpoint: a later t_end extends it)
    assert _files(out) == ["checkpoint.npz", "run.json", "summary.json", "thermo.csv"]
    out2 = tmp_path / "flag"
    assert main(["run", str(CHAIN), "--out", str(out2), "--quiet", "--set", "run.t_end=5",
                 "--no-trajectory"]) == 0
    assert _files(out2) == ["checkpoint.npz", "run.json", "summary.json", "thermo.csv"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["flag", "none"]


def test_flags_and_scene_fields_ask_for_writers(tmp_path):
    a, b = tmp_path / "flags", tmp_path / "fields"
    assert main(["run", str(CHAIN), "--out", str(a), "--quiet", "--set", "run.t_end=5",
                 "--vtk", "--csv", "--plots"]) == 0
    assert main(["run", str(CHAIN), "--out", str(b), "--quiet", "--set", "run.t_end=5",
                 "--set", "output.vtk=true", "--set", "output.csv=true",
                 "--set", "output.plots=true", "--set", "output.trajectory=false"]) == 0
    fa, fb = _files(a), _files(b)
    for name in ("summary.json", "energy.csv", "run.pvd", "vtk/frame_000000.vtp",
                 "plots/spacetime.png", "plots/energy.png", "plots/velocities.png"):
        assert name in fa and name in fb, name
    assert "trajectory.h5" in fa and "trajectory.h5" not in fb
    sa = json.loads((a / "summary.json").read_text())
    sb = json.loads((b / "summary.json").read_text())
    assert sa["scene"]["output"]["vtk"] is True  # the flags are recorded in the scene
    n_frames = sa["frames"]
    assert len([f for f in fa if f.startswith("vtk/")]) == n_frames
    # Writers do not touch the physics: bit-identical final state with and without.
    c = tmp_path / "bare"
    assert main(["run", str(CHAIN), "--out", str(c), "--quiet", "--set", "run.t_end=5",
                 "--no-trajectory"]) == 0
    sc = json.loads((c / "summary.json").read_text())
    assert sa["x_final"] == sb["x_final"] == sc["x_final"]
    assert sa["v_final"] == sb["v_final"] == sc["v_final"]


def test_plot_subcommand(tmp_path, capsys):
    run_dir = tmp_path / "r"
    assert main(["run", str(CHAIN), "--out", str(run_dir), "--quiet", "--set",
                 "run.t_end=5"]) == 0
    assert main(["plot", str(run_dir), "--granules", "0,3", "--no-render"]) == 0
    printed = capsys.readouterr().out.split()
    assert [Path(p).name for p in printed] == ["spacetime.png", "energy.png", "velocities.png"]
    assert all(Path(p).parent == run_dir / "plots" for p in printed)
    assert main(["plot", str(run_dir), "--granules", "0,60"]) == 2
    assert "--granules: indices must be in 0..49" in capsys.readouterr().err
    assert main(["plot", str(tmp_path / "missing")]) == 2
    assert "no trajectory.h5" in capsys.readouterr().err


def test_failing_writer_leaves_no_output_folder(tmp_path, monkeypatch):
    import granular_chain.writers.tables as tables

    def broken(*args, **kwargs):
        raise OSError("disk full (simulated)")

    monkeypatch.setattr(tables.EnergyTable, "write_frame", broken)  # fails while running
    out = tmp_path / "out"
    assert main(["run", str(CHAIN), "--out", str(out), "--quiet", "--set", "run.t_end=2",
                 "--csv"]) == 2  # a write error: one line, exit 2
    assert list(tmp_path.iterdir()) == []  # neither out nor a .partial folder


def test_failing_rerun_keeps_the_previous_run(tmp_path, monkeypatch):
    out = tmp_path / "out"
    assert main(["run", str(CHAIN), "--out", str(out), "--quiet", "--set", "run.t_end=2"]) == 0
    before = (out / "summary.json").read_text()
    patch_everywhere(monkeypatch, "writers.tables", "write_events_csv", lambda *a, **k: 1 / 0)  # after the run
    with pytest.raises(ZeroDivisionError):
        main(["run", str(CHAIN), "--out", str(out), "--quiet", "--set", "run.t_end=3", "--csv",
              "--overwrite"])
    assert (out / "summary.json").read_text() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


# ---------------------------------------------------------------- cadence and physics

@pytest.mark.parametrize("cadence", [["output.dt=0.5"], ["output.dt=null", "output.every=7"],
                                     ["output.dt=null", "output.every=1000"]])
def test_output_cadence_does_not_change_the_physics(cadence):
    other = simulate(load_scene(CHAIN, SHORT + cadence), progress=False)
    # (output.dt chooses the step: the largest that divides it; the reference takes it too)
    base = load_scene(CHAIN, SHORT + ["output.dt=null", "output.every=1", f"run.dt={other.dt!r}"])
    ref = simulate(base, progress=False)
    assert other.steps == ref.steps and other.t_final == ref.t_final
    assert ref.t.size == ref.steps + 1 and other.t.size < ref.t.size
    assert np.array_equal(other.x_final, ref.x_final)
    assert np.array_equal(other.v_final, ref.v_final)
    assert other.energy.coulomb[-1] == ref.energy.coulomb[-1]
    assert other.energy.viscous[-1] == ref.energy.viscous[-1]
    # Every frame of the coarse run is a frame of the step-by-step run.
    steps = np.rint(other.t / ref.dt).astype(int)
    assert np.array_equal(other.x, ref.x[steps]) and np.array_equal(other.v, ref.v[steps])
