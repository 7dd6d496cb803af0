"""trajectory.h5 as netCDF-4/CF, reading a run back, Status names and Result's views."""

import dataclasses
import json
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest

import granular_chain as gc
from granular_chain.result import Event, Status
from granular_chain.writers.summary import write_summary
from granular_chain.writers.trajectory import TrajectoryWriter, write_trajectory

ROOT = Path(__file__).resolve().parents[1]
EVENTS = [Event(0.25, "contact_close", 0, 25), Event(0.5, "slip", 1, 50), Event(1.75, "stop", 1)]


@pytest.fixture(scope="module")
def run():
    """The default scene, shortened, with an event log put in (the layout is the stepper's)."""
    scene = gc.load_scene(ROOT / "scenarios" / "two_granules.yaml", ["output.every=500"])
    result = gc.simulate(scene, progress=False)
    return scene, dataclasses.replace(result, events=list(EVENTS))


def _folder(tmp_path, scene, result):
    write_trajectory(result, tmp_path, scene)
    write_summary(result, tmp_path, scene)
    return tmp_path


def _assert_same(back, result):
    """Every field of two Results equal: arrays bit for bit, the rest by ==."""
    for f in dataclasses.fields(result):
        a, b = getattr(back, f.name), getattr(result, f.name)
        if f.name == "energy":
            for name in ("kinetic", "potential", "coulomb", "viscous", "balance"):
                assert np.array_equal(getattr(a, name), getattr(b, name)), name
                assert getattr(a, name).dtype == np.float64
            assert a.initial == b.initial
        elif isinstance(b, np.ndarray):
            assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b), f.name
        else:
            assert a == b and type(a) is type(b), f.name


def test_read_run_equals_the_result_in_memory(run, tmp_path):
    scene, result = run
    back = gc.read_run(_folder(tmp_path, scene, result))
    _assert_same(back, result)
    assert back.scene == scene and back.status is Status.SEPARATED
    assert gc.read_run(tmp_path / "trajectory.h5").t_final == result.t_final  # the file itself


def test_xarray_opens_the_file_with_named_dimensions_and_no_warning(run, tmp_path):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    scene, result = run
    _folder(tmp_path, scene, result)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds = xr.open_dataset(tmp_path / "trajectory.h5", engine="h5netcdf")
    assert ds["x"].dims == ("time", "granule") and ds["kinetic"].dims == ("time",)
    assert dict(ds.sizes) == {"time": result.t.size, "granule": 2, "event": len(EVENTS)}
    assert np.array_equal(ds["time"].values, result.t) and ds["time"].dtype == np.float64
    assert np.array_equal(ds["v"].sel(granule=1).values, result.v[:, 1])
    assert ds["x"].attrs["units"] == "1" and "long_name" in ds["balance"].attrs
    meanings = ds["event_kind"].attrs["flag_meanings"].split()  # a CF flag variable
    assert [meanings[int(c)] for c in ds["event_kind"].values] == [e.kind for e in EVENTS]
    assert ds.attrs["status"] == "separated" and ds.attrs["Conventions"] == "CF-1.8"
    assert ds.attrs["engine_version"] == gc.__version__
    assert gc.load_scene  # the scene attribute is YAML text of the validated scene:
    import yaml
    assert gc.scene_from_dict(yaml.safe_load(ds.attrs["scene"])) == scene
    # Result.to_xarray builds the same dataset in memory (values, dims, attributes).
    xr.testing.assert_identical(ds.load(), result_with_scene(result, scene).to_xarray())
    ds.close()


def result_with_scene(result, scene):
    r = dataclasses.replace(result)
    r.scene = scene
    return r


def test_physical_scene_gets_si_units(run, tmp_path):
    scene, result = run
    phys = scene.model_copy(update={"units": "physical"})
    write_trajectory(result, tmp_path, phys)
    with h5py.File(tmp_path / "trajectory.h5") as h5:
        units = {n: h5[n].attrs["units"] for n in ("time", "x", "v", "f", "kinetic", "mass",
                                                   "friction_viscous", "granule")}
    assert units == {"time": "s", "x": "m", "v": "m s-1", "f": "N", "kinetic": "J",
                     "mass": "kg", "friction_viscous": "kg s-1", "granule": "1"}


def _write(w, result, a, b):
    """Frames a..b-1 of ``result`` through a TrajectoryWriter."""
    led = result.energy
    for i in range(a, b):
        w.write_frame(result.t[i], result.x[i], result.v[i], result.f[i], led.kinetic[i],
                      led.potential[i], led.coulomb[i], led.viscous[i])


def test_writer_streams_in_bounded_chunks(run, tmp_path):
    """Frames reach the file chunk by chunk (every variable the same frames); memory
    holds one chunk of chunk_frames frames."""
    scene, result = run
    led = result.energy
    n = result.t.size
    with TrajectoryWriter(tmp_path, scene, 2, chunk_frames=3) as w:
        _write(w, result, 0, 7)
        h5 = w._h5
        assert w._states.values["x"].shape == (3, 2) and h5["x"].chunks == (3, 2)
        assert w.frames == 7 and h5["x"].shape == (6, 2) and h5["time"].shape == (6,)
        assert np.array_equal(h5["v"][...], result.v[:6])
        assert np.array_equal(h5["kinetic"][...], led.kinetic[:6])
        w.flush()  # the partial chunk too
        assert h5["x"].shape == (7, 2) and np.array_equal(h5["time"][...], result.t[:7])
        _write(w, result, 7, 9)  # a chunk just full, the ledger's not: flushed, no chunk past it
        w.flush()
        assert h5["x"].shape == (9, 2) and h5["time"].shape == (9,)
        assert h5["x"].id.get_num_chunks() == 3
        _write(w, result, 9, n)
        w.close(result)
    _assert_same(gc.read_run(tmp_path), result)


def test_a_file_continued_inside_a_chunk_keeps_its_frames(run, tmp_path):
    """A run restarted at a frame inside a chunk: the chunk's first frames are read
    back and written again with the ones that follow, later frames of the first
    run are dropped, and the file equals one written in one go."""
    scene, result = run
    with TrajectoryWriter(tmp_path, scene, 2, chunk_frames=4) as w:
        _write(w, result, 0, 10)
        w.flush()  # a checkpoint at frame 10, inside the third chunk
        _write(w, result, 10, 13)  # frames after it, then the run is stopped
    with TrajectoryWriter(tmp_path, scene, 2, chunk_frames=4, resume_frames=10) as w:
        assert w.frames == 10 and w._states.base == 8 and w._states.fill == 2
        _write(w, result, 10, result.t.size)
        w.close(result)
    _assert_same(gc.read_run(tmp_path), result)


def test_a_failed_write_is_raised_and_the_file_closed(run, tmp_path):
    """An error writing a chunk reaches the caller, and the file is closed all the
    same with the chunks written before it."""
    scene, result = run
    w = TrajectoryWriter(tmp_path, scene, 2, chunk_frames=2)
    written = w._states.write

    def fail():
        if w._states.base > 0:
            raise OSError("disk full")
        written()

    w._states.write = fail
    with pytest.raises(OSError, match="disk full"):
        with w:
            for i in range(5):  # the second chunk fails
                w.write_frame(result.t[i], result.x[i], result.v[i], result.f[i], 0.5, 0.0, 0.0,
                              0.0)
    assert not w._h5.id.valid
    with h5py.File(tmp_path / "trajectory.h5") as h5:
        assert np.array_equal(h5["x"][...], result.x[:2])


def test_an_unclosed_trajectory_is_refused_and_keeps_its_frames(run, tmp_path):
    scene, result = run
    with TrajectoryWriter(tmp_path, scene, 2, chunk_frames=4) as w:
        for i in range(5):
            w.write_frame(result.t[i], result.x[i], result.v[i], result.f[i], 0.5, 0.0, 0.0, 0.0)
    with h5py.File(tmp_path / "trajectory.h5") as h5:
        assert np.array_equal(h5["x"][...], result.x[:5])
    with pytest.raises(ValueError, match="did not finish writing"):
        gc.read_run(tmp_path)
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    with xr.open_dataset(tmp_path / "trajectory.h5", engine="h5netcdf") as ds:  # still readable
        assert dict(ds.sizes) == {"time": 5, "granule": 2} and "balance" not in ds


def test_read_run_without_trajectory_uses_the_summary(run, tmp_path):
    scene, result = run
    write_summary(result, tmp_path, scene)
    back = gc.read_run(tmp_path)
    assert back.t.size == 0 and back.x.shape == (0, 2)
    assert np.array_equal(back.x_final, result.x_final) and back.t_final == result.t_final
    assert back.status == result.status and back.info == result.info and back.scene == scene
    with pytest.raises(FileNotFoundError, match="not a run folder"):
        gc.read_run(tmp_path / "nothing")


def test_files_of_the_earlier_layout_still_read(run, tmp_path):
    """t, energy/* and events/*, the scene as JSON, the final state in summary.json."""
    scene, result = run
    write_summary(result, tmp_path, scene)
    led = result.energy
    with h5py.File(tmp_path / "trajectory.h5", "w") as h5:
        for name in ("t", "x", "v", "f"):
            h5[name] = getattr(result, name)
        for name in ("kinetic", "potential", "coulomb", "viscous"):
            h5[f"energy/{name}"] = getattr(led, name)
        h5["energy"].attrs["initial"] = led.initial
        h5["events/t"] = [e.t for e in EVENTS]
        h5["events/kind"] = np.array([e.kind for e in EVENTS], dtype="S")
        h5["events/index"] = [e.index for e in EVENTS]
        h5.attrs.update(status="separated", message=result.message, stepper="verlet",
                        dt=result.dt, scene=json.dumps(scene.model_dump(mode="json")))
    # (that layout kept no step with an event: they read back as -1)
    _assert_same(gc.read_run(tmp_path), dataclasses.replace(
        result, events=[dataclasses.replace(e, step=-1) for e in EVENTS]))


def test_status_prints_as_its_name_and_stays_an_int():
    s = Status.AT_REST
    assert str(s) == "at_rest" and f"{s}" == "at_rest" and f"{s:>9}" == "  at_rest"
    assert f"{s:d}" == "2" and int(s) == 2 and s == 2 and s > Status.SEPARATED
    assert s.name == "AT_REST" and Status["AT_REST"] is s and repr(s) == "<Status.AT_REST: 2>"
    assert str(Status.INTERRUPTED) == "interrupted" and not Status.INTERRUPTED.success


def test_summary_status_success_and_message_agree(run):
    scene, result = run
    for status in Status:
        s = dataclasses.replace(result, status=status, message=f"ended: {status}").summary()
        assert s["status"] == status.name.lower() and s["status_code"] == int(status)
        assert s["success"] is (int(status) >= 0) and s["message"].endswith(s["status"])


def test_repr_is_one_short_line(run, tmp_path):
    scene, result = run
    back = gc.read_run(_folder(tmp_path, scene, result))
    text = repr(back)
    assert text == (f"Result('two_granules', N=2, frames={result.t.size}, steps={result.steps}, "
                     f"status=separated, t={result.t_final:.6g})")
    assert "\n" not in repr(result) and "array" not in repr(result)


def test_events_and_ledger_as_dataframes(run):
    pytest.importorskip("pandas")
    scene, result = run
    ev = result.events_frame()
    assert list(ev.columns) == ["step", "t", "kind", "index"] and len(ev) == len(EVENTS)
    assert ev["step"].tolist() == [e.step for e in EVENTS]
    assert ev["t"].tolist() == [e.t for e in EVENTS] and ev["kind"].tolist() == [
        e.kind for e in EVENTS] and ev["index"].tolist() == [e.index for e in EVENTS]
    led = result.ledger_frame()
    assert led.index.name == "t" and np.array_equal(led.index.values, result.t)
    assert np.array_equal(led["balance"].values, result.energy.balance)
    assert list(led.columns) == ["kinetic", "potential", "coulomb", "viscous", "contact_dissipated",
                                 "wall_work", "body_work", "stage_work", "balance"]


# ---------------------------------------------------------------- plots at any N

def _one_granule_pulse(N, F):
    """A synthetic run: granule pos(k) moves at v = 1 in frame k, all others rest."""
    from granular_chain.model import build_model
    from granular_chain.result import EnergyLedger, Result

    scene = gc.load_scene(ROOT / "scenarios" / "hertz_chain.yaml", [f"granules.count={N}"])
    x = np.broadcast_to(build_model(scene).x0, (F, N)).copy()
    v = np.zeros((F, N))
    v[np.arange(F), (np.arange(F) * (N - 1)) // (F - 1)] = 1.0
    z = np.zeros(F)
    result = Result(t=np.linspace(0.0, 100.0, F), x=x, v=v, f=np.zeros((F, N)),
                    energy=EnergyLedger(z, z, z, z, 1.0), status=Status.T_END, message="",
                    steps=F, wall_time=0.0, stepper="verlet", dt=0.01, t_final=100.0,
                    x_final=x[-1], v_final=v[-1])
    return scene, result


def test_peak_blocks_keep_the_signed_peak_of_each_block():
    from granular_chain.writers.plots import peak_blocks

    v = np.array([[0.0, -3.0, 1.0, 0.5, 0.2], [2.0, 0.0, 0.0, -0.1, 0.0],
                  [0.0, 0.0, 0.0, 0.0, -7.0]])
    assert np.array_equal(peak_blocks(v, 2, 2), [[-3.0, 1.0, 0.2], [0.0, 0.0, -7.0]])
    assert np.array_equal(peak_blocks(v, 1, 1), v)


def test_spacetime_diagram_keeps_a_one_granule_pulse_at_large_n(tmp_path):
    mpimg = pytest.importorskip("matplotlib.image")
    from granular_chain.writers.plots import plot_spacetime

    scene, result = _one_granule_pulse(20000, 400)
    img = mpimg.imread(plot_spacetime(result, tmp_path / "s.png", scene))[..., :3]
    H, W, _ = img.shape
    axes = img[int(0.06 * H):int(0.9 * H), int(0.1 * W):int(0.8 * W)]  # inside the axes
    pulse = (axes[..., 0] - axes[..., 1]) > 0.25  # the red end of the colour map
    # Every pixel row crossed by the pulse shows it (a stride of 40 granules would
    # show it in one row of 40).
    assert pulse.any(axis=1).mean() > 0.95


def test_frame_of_a_long_chain_shows_the_pulse(tmp_path):
    mpimg = pytest.importorskip("matplotlib.image")
    pytest.importorskip("pyvista")
    from granular_chain.writers.plots import frame_window, render_frame

    scene, result = _one_granule_pulse(20000, 50)
    assert frame_window(result.v[25]) == (10103, 10303)  # 200 granules around 10203
    assert frame_window(result.v[0]) == (0, 200) and frame_window(result.v[49]) == (19800, 20000)
    img = mpimg.imread(render_frame(result, tmp_path / "f.png", scene))[..., :3]
    pulse = (img[..., 0] - img[..., 1]) > 0.25
    assert pulse.sum() > 30 and np.std(img) > 0.05  # the red granule, not a blank strip


def test_event_stepper_run_reads_back_with_its_event_log(tmp_path):
    scene = gc.load_scene(ROOT / "scenarios" / "two_granules.yaml", ["run.stepper=event", "run.dt=null"])
    result = gc.simulate(scene, progress=False)
    assert [e.kind for e in result.events] == ["contact_close", "slip", "contact_open"]
    back = gc.read_run(_folder(tmp_path, scene, result))
    _assert_same(back, result)
    assert back.dt is None and back.stepper == "event"


# ---------------------------------------------------------------- install and first run

def test_version_and_python_dash_m(capsys):
    import subprocess
    import sys

    from granular_chain.cli import main

    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0 and capsys.readouterr().out == f"granular-chain {gc.__version__}\n"
    done = subprocess.run([sys.executable, "-m", "granular_chain", "--version"],
                          capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0 and done.stdout.strip() == f"granular-chain {gc.__version__}"


def test_prepare_kernels_leaves_the_run_unchanged():
    from granular_chain.warmup import prepare_kernels

    scene = gc.load_scene(ROOT / "scenarios" / "two_granules.yaml", ["output.every=500"])
    before = gc.simulate(scene, progress=False)
    copy = scene.model_copy(deep=True)
    assert prepare_kernels(scene, quiet=True) >= 0.0
    assert scene == copy  # the two-step run was made on a copy
    after = gc.simulate(scene, progress=False)
    assert np.array_equal(before.x, after.x) and before.t_final == after.t_final

