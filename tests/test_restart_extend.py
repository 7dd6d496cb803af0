"""``run --restart RUN_DIR`` without the scene, and a finished run extended to a later
``run.t_end`` in place: the folder then equals, file for file and bit for bit (wall
times aside), a run straight to the later t_end, for both steppers."""

import hashlib
import json
import signal
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

import granular_chain as gc
from granular_chain.cli import main
from granular_chain.model import build_model
from granular_chain.rundir import read_marker
from granular_chain.steppers.verlet import VerletRun

SCENES = Path(__file__).resolve().parents[1] / "scenarios"
WALL_TIMES = ("wall_time_s", "wall_time")


def assert_same_folder(a: Path, b: Path) -> None:
    """Every dataset and attribute of trajectory.h5, every number of summary.json and
    every table of ``a`` and ``b`` are equal bit for bit (wall times aside)."""
    tables = sorted({p.name for p in (*a.glob("*.csv"), *b.glob("*.csv"))})
    for name in tables:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    with h5py.File(a / "trajectory.h5") as ha, h5py.File(b / "trajectory.h5") as hb:
        names, other = [], []
        ha.visit(names.append)
        hb.visit(other.append)
        assert names == other
        for name in names:
            if isinstance(ha[name], h5py.Dataset):
                x, y = ha[name][...], hb[name][...]
                assert x.dtype == y.dtype and np.array_equal(x, y), name
        assert set(ha.attrs) == set(hb.attrs)
        for key in set(ha.attrs) - set(WALL_TIMES):
            assert np.array_equal(ha.attrs[key], hb.attrs[key]), key
    if (a / "vtk").exists() or (b / "vtk").exists():  # the VTK series, byte for byte
        frames = sorted(p.name for p in (a / "vtk").iterdir())
        assert frames == sorted(p.name for p in (b / "vtk").iterdir())
        for name in ["../run.pvd", *frames]:
            assert (a / "vtk" / name).read_bytes() == (b / "vtk" / name).read_bytes(), name
    sa, sb = (json.loads((p / "summary.json").read_text()) for p in (a, b))
    for key in WALL_TIMES:
        sa.pop(key, None), sb.pop(key, None)
    assert sa == sb
    assert read_marker(b)["complete"] is True


def run(*argv) -> int:
    return main(["run", *map(str, argv), "--quiet"])


def straight_and_extended(tmp_path, scene, t1, t2, *flags):
    """A run straight to ``t2`` (A), one to ``t1`` (B) extended to ``t2`` without the
    scene (``run --restart B --set run.t_end=t2``)."""
    assert run(scene, "--set", f"run.t_end={t2}", *flags, "--out", tmp_path / "A") == 0
    assert run(scene, "--set", f"run.t_end={t1}", *flags, "--out", tmp_path / "B") == 0
    assert run("--restart", tmp_path / "B", "--set", f"run.t_end={t2}") == 0
    return tmp_path / "A", tmp_path / "B"


@pytest.mark.parametrize("scene, t1, t2, flags", [
    # the paper's collision: t_end 1 is before separation, the extension separates
    ("two_granules.yaml", 1.0, 20.0, ["--set", "output.thermo=1000", "--csv", "--vtk"]),
    # Coulomb friction (merged kicks) and the event log; 10.0025 needs a shortened step
    ("chain_kinetic.yaml", 10.0025, 20.0,
     ["--set", "output.thermo=500", "--set", "output.events=true", "--csv"]),
    # a sine-driven wall (the forced kernel), both ends on whole steps
    ("driven_chain.yaml", 5.0, 12.0, ["--set", "output.thermo=50", "--csv"]),
])
def test_verlet_run_extended_equals_the_run_straight_to_the_later_end(
        tmp_path, capsys, scene, t1, t2, flags):
    a, b = straight_and_extended(tmp_path, SCENES / scene, t1, t2, *flags)
    assert "computed again" not in capsys.readouterr().err  # from the checkpoint
    assert_same_folder(a, b)
    marker = read_marker(b)
    assert marker["overrides"][-1] == f"run.t_end={t2}"
    assert marker["writers"] == {f[2:]: True for f in flags if f in ("--csv", "--vtk")}


def test_extension_goes_on_from_the_end_checkpoint(tmp_path, capsys):
    """The extension starts at the checkpoint, not at t = 0: its thermo lines (printed
    without --quiet) begin after the run's last frame of the cadence before t_end."""
    scene = SCENES / "chain_kinetic.yaml"
    assert run(scene, "--set", "run.t_end=10.0025", "--set", "output.thermo=500",
               "--out", tmp_path / "B") == 0
    capsys.readouterr()
    assert main(["run", "--restart", str(tmp_path / "B"), "--set", "run.t_end=20"]) == 0
    steps = [int(line.split()[0]) for line in capsys.readouterr().out.splitlines()
             if line.split() and line.split()[0].isdigit()]
    # 2000 whole steps to t = 10, frames every 2: the checkpoint is at step 1998,
    # and the first thermo line (every 500) after it at 2000
    assert steps[0] == 2000 and steps[-1] > 2000


def _store_both_steppers_options(folder: Path) -> None:
    """Write the run's scene as it was stored when every scene held the options of
    both steppers (a Verlet run's summary.json and checkpoint with rtol, atol and
    max_events at their defaults)."""
    foreign = {"rtol": 1e-12, "atol": 1e-14, "max_events": 1_000_000}
    summary = json.loads((folder / "summary.json").read_text())
    summary["scene"]["run"].update(foreign)
    (folder / "summary.json").write_text(json.dumps(summary, indent=2))
    with np.load(folder / "checkpoint.npz") as data:
        arrays = {name: data[name] for name in data.files}
    stored = json.loads(str(arrays["scene_json"]))
    stored["run"].update(foreign)
    arrays["scene_json"] = np.array(json.dumps(stored))
    with open(folder / "checkpoint.npz", "wb") as f:
        np.savez(f, **arrays)


def test_run_stored_with_both_steppers_options_is_extended(tmp_path, capsys):
    """A run folder whose scene holds the other stepper's options at their defaults
    (as scenes were once stored) reads back without them, is still continued, and
    equals the run straight to the later end."""
    scene = SCENES / "two_granules.yaml"
    a, b = tmp_path / "A", tmp_path / "B"
    assert run(scene, "--set", "run.t_end=20.0", "--out", a) == 0
    assert run(scene, "--set", "run.t_end=1.0", "--out", b) == 0
    _store_both_steppers_options(b)
    stored = json.loads((b / "summary.json").read_text())["scene"]
    assert not hasattr(gc.scene_from_dict(stored, stored=True).run, "rtol")
    assert run("--restart", b, "--set", "run.t_end=20.0") == 0
    assert_same_folder(a, b)


@pytest.mark.parametrize("t1", [4.0, 4.005, 0.03, 0.005])
def test_end_checkpoint_continued_to_a_later_t_end(t1):
    """The state a finished run keeps, continued with a later t_end, ends bit for bit
    as the run straight there: t_end on a whole step or not, before the first frame
    of the cadence (every 5) or at it."""
    def scene(t_end):
        return gc.scene_from_dict({
            "granules": {"count": 6, "radius": 2.0, "velocity": {0: 1.0},
                         "friction": {"kinetic": 1e-3, "static": 2e-3}},
            "contacts": {"exponent": 2.5}, "walls": {"right": {"gap": 0.0, "exponent": 2.5}},
            "run": {"t_end": t_end, "dt": 0.005}, "output": {"every": 5, "events": True}})
    straight = VerletRun(scene(9.0), build_model(scene(9.0)), False).run()
    states = []
    VerletRun(scene(t1), build_model(scene(t1)), False, checkpoint=states.append,
              end_checkpoint=True).run()
    assert len(states) == 1 and int(states[0]["steps"]) % 5 == 0
    extended = VerletRun(scene(9.0), build_model(scene(9.0)), False).run(resume=states[0])
    assert extended.t_final == straight.t_final == 9.0 and extended.steps == straight.steps
    assert np.array_equal(extended.x_final, straight.x_final)
    assert np.array_equal(extended.v_final, straight.v_final)
    assert extended.energy.final() == straight.energy.final()
    assert extended.events == straight.events and extended.event_counts == straight.event_counts


def test_plan_that_depends_on_t_end_is_computed_again(tmp_path, capsys):
    """Without output.thermo a run has about 20 thermo lines, so a run to a later t_end
    does not pass through the checkpoint: the run is computed again, and says so."""
    a, b = straight_and_extended(tmp_path, SCENES / "chain_walls.yaml", 5.0, 9.0)
    err = capsys.readouterr().err
    assert "computed again from t = 0" in err and "output.thermo is not set" in err
    assert_same_folder(a, b)


EVENT_SCENE = """\
name: bouncing
granules: {count: 12, radius: 2.0, velocity: {0: 1.0}, friction: {viscous: 1.0e-6}}
contacts: {exponent: 2.5}
walls: {left: {gap: 0.0, exponent: 2.5}, right: {gap: 0.0, exponent: 2.5}}
run: {stepper: event, t_end: 60.0}
output: {dt: 1.0}
"""


@pytest.mark.slow
def test_event_stepper_run_extended_equals_the_run_straight_to_the_later_end(tmp_path, capsys):
    scene = tmp_path / "ev.yaml"
    scene.write_text(EVENT_SCENE)
    a, b = straight_and_extended(tmp_path, scene, 25.0, 60.0, "--csv")
    err = capsys.readouterr().err
    assert "computed again from t = 0" in err and "event stepper" in err
    assert (b / "events.csv").stat().st_size > 100
    assert_same_folder(a, b)


SIGINT_SCENE = """\
name: long
granules:
  count: 500
  radius: 2.0
  velocity: {0: 1.0}
  friction: {kinetic: 1.0e-4, static: 2.0e-4, viscous: 1.0e-4}
contacts: {exponent: 2.5}
walls: {right: {gap: 0.0, exponent: 2.5}}
run: {t_end: 4000.0, dt: 0.0101}
output: {every: 1000, thermo: 20000}
"""


def stopped(folder: Path, argv, lines: int = 3) -> int:
    """Run ``granular-chain run *argv`` in a child; SIGINT after ``lines`` thermo lines."""
    child = subprocess.Popen([sys.executable, "-m", "granular_chain.cli", "run", *argv],
                             cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
    for _ in range(lines + 1):  # the header, then the lines
        assert child.stdout.readline(), child.stderr.read()
    child.send_signal(signal.SIGINT)
    child.communicate(timeout=300)
    return child.returncode


@pytest.mark.slow
def test_restart_alone_after_sigint_and_an_interrupted_extension(tmp_path):
    """``run --restart B`` alone continues a run started with --set and --csv (run.json
    holds them); an extension stopped by SIGINT leaves B marked incomplete, and
    ``run --restart B`` alone finishes it: both equal the run straight to the end."""
    scene = tmp_path / "s.yaml"
    scene.write_text(SIGINT_SCENE)
    assert run(scene, "--set", "run.t_end=3000", "--csv", "--out", tmp_path / "A") == 0
    assert stopped(tmp_path, [str(scene), "--set", "run.t_end=1500", "--csv", "--out",
                              "B"]) == 130
    assert read_marker(tmp_path / "B")["complete"] is False
    assert run("--restart", tmp_path / "B") == 0
    assert read_marker(tmp_path / "B")["complete"] is True
    assert stopped(tmp_path, ["--restart", "B", "--set", "run.t_end=3000"]) == 130
    marker = read_marker(tmp_path / "B")
    assert marker["complete"] is False and "--restart" in marker["reason"]
    assert run("--restart", tmp_path / "B") == 0
    assert_same_folder(tmp_path / "A", tmp_path / "B")


def snapshot(folder: Path) -> dict:
    """Every file below ``folder``: its bytes' digest and its modification time."""
    return {p.relative_to(folder).as_posix(): (hashlib.sha256(p.read_bytes()).hexdigest(),
                                               p.stat().st_mtime_ns)
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_refusals_are_one_line_and_change_nothing(tmp_path, capsys):
    scene = SCENES / "two_granules.yaml"
    b = tmp_path / "B"
    assert run(scene, "--set", "run.t_end=1", "--set", "output.thermo=1000", "--out", b) == 0
    before = snapshot(tmp_path)
    capsys.readouterr()
    cases = [
        (["run", str(scene), "--restart", str(b), "--set", "run.t_end=2",
          "--set", "granules.mass=2.0"], "differs from the run's at granules.mass"),
        (["run", str(SCENES / "chain_kinetic.yaml"), "--restart", str(b)],
         "differs from the run's at"),
        (["run", "--restart", str(b), "--set", "run.t_end=0.5"], "is before the run's"),
        (["run", "--restart", str(b)], "is complete at its t_end = 1"),
        (["run", str(scene), "--restart", str(b)], "is complete at its t_end = 1"),
        (["run", "--restart", str(tmp_path / "missing")], "no such run folder"),
        (["run", "--restart", str(tmp_path / "missing"), "--set", "run.t_end=5"],
         "no such run folder"),
        (["run", "--set", "run.t_end=5"], "give a SCENE file, or --restart RUN_DIR"),
        (["run", "--restart", str(b), "--set", "run.t_end=5", "--out", str(tmp_path / "C")],
         "leave out --out"),
    ]
    for argv, said in cases:
        assert main([*argv, "--quiet"]) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and said in err[0], (argv, err)
    assert snapshot(tmp_path) == before
