"""``--restart``: a run stopped by SIGINT, or killed outright, continued from its
checkpoint equals the run that was never stopped, file for file and bit for bit."""

import json
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest

from granular_chain.cli import main
from granular_chain.rundir import read_marker

SCENE = """\
name: long
granules:
  count: 2000
  radius: 2.0
  velocity: {0: 1.0}
  friction: {kinetic: 1.0e-4, static: 2.0e-4, viscous: 1.0e-4}
contacts: {exponent: 2.5}
walls: {right: {gap: 0.0, exponent: 2.5}}
run: {t_end: 4000.0, dt: 0.0101}
output: {every: 1000, thermo: 20000, checkpoint_every: 50000}
"""


def scene_file(folder, t_end=4000.0):
    path = folder / ("s.yaml" if t_end == 4000.0 else "short.yaml")
    path.write_text(SCENE.replace("t_end: 4000.0", f"t_end: {t_end}"))
    return path


def run_reference(folder):
    assert main(["run", str(scene_file(folder)), "--out", str(folder / "A"), "--quiet",
                 "--csv", "--vtk"]) == 0
    return folder / "A"


def start_and_stop(folder, signum, lines, scene=None, flags=("--csv", "--vtk")):
    """Start the run in a child; after ``lines`` thermo lines send ``signum``."""
    scene = scene or scene_file(folder)
    child = subprocess.Popen([sys.executable, "-m", "granular_chain.cli", "run",
                              str(scene), "--out", "B", *flags],
                             cwd=folder, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
    for _ in range(lines + 1):  # the header, then the lines
        assert child.stdout.readline(), child.stderr.read()
    child.send_signal(signum)
    child.communicate(timeout=120)
    return child.returncode


def assert_same_run(a, b, vtk=True):
    for name in ("energy.csv", "thermo.csv") + (("events.csv",) if (a / "events.csv").exists()
                                                else ()):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    with h5py.File(a / "trajectory.h5") as ha, h5py.File(b / "trajectory.h5") as hb:
        for name in ("time", "x", "v", "f", "kinetic", "potential", "coulomb", "viscous",
                     "balance", "x_final", "v_final"):
            assert np.array_equal(ha[name][...], hb[name][...]), name
    sa, sb = (json.loads((p / "summary.json").read_text()) for p in (a, b))
    for key in ("status", "t_final", "x_final", "v_final", "event_counts", "energy", "steps",
                "frames"):
        assert sa[key] == sb[key], key
    if vtk:
        assert sorted(p.name for p in (a / "vtk").iterdir()) == sorted(
            p.name for p in (b / "vtk").iterdir())
    # a finished Verlet run that reached t_end keeps its checkpoint (to be extended)
    extendable = sb["stepper"] == "verlet" and sb["status"] == "t_end"
    assert read_marker(b)["complete"] is True and (b / "checkpoint.npz").exists() == extendable


def test_sigint_then_restart_equals_the_run_never_stopped(tmp_path):
    ref = run_reference(tmp_path)
    assert start_and_stop(tmp_path, signal.SIGINT, lines=3) == 130
    marker = read_marker(tmp_path / "B")
    assert marker["complete"] is False and "--restart" in marker["reason"]
    assert "checkpoint.npz" in marker["files"]
    assert main(["run", str(scene_file(tmp_path)), "--restart", str(tmp_path / "B"), "--quiet",
                 "--csv", "--vtk"]) == 0
    assert_same_run(ref, tmp_path / "B")


def test_killed_run_continues_from_its_last_checkpoint(tmp_path, capsys):
    ref = run_reference(tmp_path)
    assert start_and_stop(tmp_path, signal.SIGKILL, lines=4) == -signal.SIGKILL
    partial = [p for p in tmp_path.iterdir() if p.name.startswith(".B.partial-")]
    assert len(partial) == 1 and (partial[0] / "checkpoint.npz").is_file()
    # a new run to B says where the checkpoint is, and keeps it
    capsys.readouterr()
    assert main(["run", str(scene_file(tmp_path, 1.0)), "--out", str(tmp_path / "B"),
                 "--quiet"]) == 0
    assert f"--restart {partial[0]}" in capsys.readouterr().err and partial[0].exists()
    # continued in its destination, B, which now holds that other run: --overwrite
    assert main(["run", str(scene_file(tmp_path)), "--restart", str(partial[0]), "--quiet",
                 "--csv", "--vtk"]) == 2
    assert main(["run", str(scene_file(tmp_path)), "--restart", str(partial[0]), "--quiet",
                 "--csv", "--vtk", "--overwrite"]) == 0
    assert_same_run(ref, tmp_path / "B")
    assert not partial[0].exists()


def test_restart_refusals(tmp_path, capsys):
    ref = run_reference(tmp_path)
    scene = str(scene_file(tmp_path))
    assert main(["run", scene, "--restart", str(ref), "--quiet"]) == 2  # complete
    assert main(["run", scene, "--restart", str(tmp_path), "--quiet"]) == 2  # not a run
    assert main(["run", scene, "--restart", str(ref), "--out", "x", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and "is complete" in err[0] and "not a run folder" in err[1]
    assert "leave out --out" in err[2]


def rest_scene():
    import granular_chain as gc
    return gc.load_scene(__import__("pathlib").Path(__file__).parents[1] / "scenarios" /
                         "chain_kinetic.yaml", ["output.every=7"])


def test_rest_stop_does_not_depend_on_where_compiled_calls_end(monkeypatch):
    """A Coulomb run stopping at rest stops at the same step whatever the thermo,
    checkpoint and wall-clock boundaries of the compiled calls."""
    import granular_chain as gc
    from granular_chain.model import build_model
    from granular_chain.steppers.verlet import VerletRun
    from granular_chain.steppers.verlet import driver as verlet_driver
    from granular_chain.writers.thermo import ThermoLog

    base = gc.simulate(rest_scene(), progress=False)
    assert base.status == gc.Status.AT_REST
    rest = base.steps
    runs = []
    scene = rest_scene()
    runs.append(VerletRun(scene, build_model(scene), False,
                          thermo=ThermoLog(build_model(scene), rest)).run())
    scene = rest_scene()
    scene.output.checkpoint_every = rest
    runs.append(VerletRun(scene, build_model(scene), False, checkpoint=lambda s: None,
                          checkpoint_every=rest).run())
    monkeypatch.setattr(verlet_driver, "CHUNK_SECONDS", 1e-5)  # calls of a few steps
    runs.append(gc.simulate(rest_scene(), progress=False))
    for r in runs:
        assert r.status == gc.Status.AT_REST and r.steps == rest
        assert np.array_equal(r.x_final, base.x_final) and r.event_counts == base.event_counts


def test_no_checkpoint_once_every_step_is_taken():
    import granular_chain as gc
    from granular_chain.model import build_model
    from granular_chain.steppers.verlet import VerletRun

    scene = gc.scene_from_dict({"granules": {"count": 5, "velocity": {0: 1.0}},
                                "run": {"t_end": 4.0, "dt": 0.01}})
    states = []
    whole = VerletRun(scene, build_model(scene), False, checkpoint=states.append,
                      checkpoint_every=100).run()
    assert [int(s["steps"]) for s in states] == [100, 200, 300]  # not at 400, the end
    resumed = VerletRun(scene, build_model(scene), False).run(resume=states[-1])
    assert resumed.t_final == whole.t_final == 4.0
    assert np.array_equal(resumed.x_final, whole.x_final)


def test_restart_from_inside_the_run_folder_is_refused(tmp_path, monkeypatch, capsys):
    run_dir = tmp_path / "R"
    run_dir.mkdir()
    monkeypatch.chdir(run_dir)
    assert main(["run", str(scene_file(tmp_path)), "--restart", ".", "--quiet"]) == 2
    assert "current folder" in capsys.readouterr().err


EVENT_SCENE = """\
name: bouncing
granules: {count: 100, radius: 2.0, velocity: {0: 1.0}, friction: {viscous: 1.0e-6}}
contacts: {exponent: 2.5}
walls: {left: {gap: 0.0, exponent: 2.5}, right: {gap: 0.0, exponent: 2.5}}
run: {stepper: event, t_end: 300.0}
output: {dt: 1.0, checkpoint_every: 20000}
"""


def test_event_stepper_run_continued_after_sigint(tmp_path):
    scene = tmp_path / "ev.yaml"
    scene.write_text(EVENT_SCENE)
    assert main(["run", str(scene), "--out", str(tmp_path / "A"), "--quiet", "--csv"]) == 0
    assert start_and_stop(tmp_path, signal.SIGINT, lines=3, scene=scene, flags=("--csv",)) == 130
    assert read_marker(tmp_path / "B")["complete"] is False
    assert main(["run", str(scene), "--restart", str(tmp_path / "B"), "--quiet", "--csv"]) == 0
    assert_same_run(tmp_path / "A", tmp_path / "B", vtk=False)


def test_resumed_run_keeps_the_event_log():
    """output.events: the events logged before the checkpoint are part of the state."""
    import granular_chain as gc
    from granular_chain.model import build_model
    from granular_chain.steppers.verlet import VerletRun

    scene = gc.scene_from_dict({
        "granules": {"count": 20, "radius": 2.0, "velocity": {0: 1.0},
                     "friction": {"kinetic": 2e-3, "static": 3e-3}},
        "contacts": {"exponent": 2.5}, "walls": {"right": {"gap": 0.0, "exponent": 2.5}},
        "run": {"t_end": 60.0, "dt": 0.013}, "output": {"events": True, "every": 17}})
    states = []
    whole = VerletRun(scene, build_model(scene), False, checkpoint=states.append,
                      checkpoint_every=1000).run()
    assert len(whole.events) > 50 and {e.kind for e in whole.events} == {
        "contact_close", "contact_open", "stop", "slip"}
    for state in states[1:3]:
        resumed = VerletRun(scene, build_model(scene), False).run(resume=state)
        assert resumed.events == whole.events
        assert np.array_equal(resumed.x_final, whole.x_final)


def test_resumed_run_with_dashpots_gravity_and_a_driven_wall():
    """The forced kernel's state (contact overlaps, forces, dashpot primitives, the
    dashpots' and walls' work, the clock) is checkpointed: a run continued from any
    checkpoint ends bit for bit as the run never stopped, its shortened last step
    included (t_end is no multiple of dt)."""
    import granular_chain as gc
    from granular_chain.model import build_model
    from granular_chain.steppers.verlet import VerletRun

    scene = gc.scene_from_dict({
        "granules": {"count": 8, "radius": 2.0, "velocity": {7: -0.5}, "gap": 0.0,
                     "friction": {"kinetic": 0.02, "static": 0.03, "viscous": 0.05}},
        "contacts": {"damping": {"model": "linear", "coefficient": 0.2}},
        "walls": {"left": {"gap": 0.0, "motion": {"sine": {"amplitude": 0.1, "frequency": 0.2}}},
                  "right": {"gap": 0.3, "motion": {"pulse": {"velocity": -0.1, "duration": 2.0}}}},
        "body_force": {"g": 0.05, "direction": -1},
        "run": {"t_end": 30.005, "dt": 0.01}, "output": {"every": 70}})
    states = []
    whole = VerletRun(scene, build_model(scene), False, checkpoint=states.append,
                      checkpoint_every=450).run()
    led = whole.energy
    assert min(led.contact_dissipated[-1], abs(led.wall_work[-1]), abs(led.body_work[-1]),
               led.coulomb[-1], led.viscous[-1]) > 1e-3
    assert len(states) == 6
    for state in (states[0], states[3], states[-1]):
        resumed = VerletRun(scene, build_model(scene), False).run(resume=state)
        assert resumed.t_final == whole.t_final == 30.005
        assert np.array_equal(resumed.x_final, whole.x_final)
        assert np.array_equal(resumed.v_final, whole.v_final)
        assert resumed.energy.final() == led.final()
        assert resumed.event_counts == whole.event_counts
