"""Ctrl-C and SIGTERM stop a run within a second, keep what was computed, and
mark the run folder incomplete (the command exits 128 + the signal number).

Each case runs in a child process that first runs the same scene briefly (so
the kernel is compiled or loaded from the cache before the clock starts), says
"ready", then starts the long run; the parent sends the signal once the long run
is stepping and measures how long the child takes to stop.
"""

import json
import signal
import subprocess
import sys
import textwrap
import time

import h5py
import pytest

from granular_chain.rundir import read_marker

CHILD = textwrap.dedent("""
    import json, sys, time
    import granular_chain as gc
    from granular_chain.cli import main

    mode, scene = sys.argv[1], json.loads(sys.argv[2])
    warm = json.loads(sys.argv[2])
    warm["run"]["t_end"] = warm["run"].pop("warm_t_end")
    scene["run"].pop("warm_t_end")
    gc.simulate(gc.scene_from_dict(warm), progress=False)
    if mode == "api":
        print("ready", flush=True)
        r = gc.simulate(gc.scene_from_dict(scene), progress=False)
        print(json.dumps({"status": r.status.name, "t_final": r.t_final, "frames": int(r.t.size),
                          "signal": r.info.get("signal"), "stopped_at": time.monotonic()}),
              flush=True)
    else:
        import yaml
        with open("scene.yaml", "w") as fh:
            yaml.safe_dump(scene, fh)
        print("ready", flush=True)
        code = main(["run", "scene.yaml", "--out", "run", "--quiet"])
        print(json.dumps({"stopped_at": time.monotonic()}), flush=True)
        sys.exit(code)
""")


def chain(count, friction, stepper="verlet", t_end=1e7, warm=0.5, exponent=2.5):
    return {"name": "long",
            "granules": {"count": count, "velocity": {0: 1.0}, "friction": friction},
            "contacts": {"exponent": exponent},
            "run": {"stepper": stepper, "t_end": t_end, "warm_t_end": warm}}


SCENES = {
    "verlet frictionless N=2000": chain(2000, {}),
    "verlet coulomb+viscous N=2000": chain(2000, {"kinetic": 1e-3, "static": 2e-3,
                                                  "viscous": 1e-2}),
    "verlet heavy drag N=3": chain(3, {"viscous": 1e6}, exponent=2.0),
}


def start(mode, scene, cwd):
    child = subprocess.Popen([sys.executable, "-c", CHILD, mode, json.dumps(scene)], cwd=cwd,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = child.stdout.readline()
    assert line.strip() == "ready", child.stderr.read()
    if mode == "cli":
        # The command installs its signal handlers before it makes the run's folder
        # (.run.partial-*): once that exists, a signal finds the run, however slowly a
        # loaded machine got through loading the scene.
        deadline = time.monotonic() + 60
        while not any(cwd.glob(".run.partial-*/trajectory.h5")):
            assert time.monotonic() < deadline and child.poll() is None, child.stderr.read()
            time.sleep(0.05)
    time.sleep(0.5)  # let the long run get going
    return child


def stop(child, signum):
    sent = time.monotonic()
    child.send_signal(signum)
    out, err = child.communicate(timeout=60)
    report = json.loads(out.strip().splitlines()[-1])
    return report, report["stopped_at"] - sent, err


@pytest.mark.parametrize("name", list(SCENES))
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_simulate_stops_within_a_second(tmp_path, name, signum):
    child = start("api", SCENES[name], tmp_path)
    report, latency, err = stop(child, signum)
    assert child.returncode == 0, err
    assert report["status"] == "INTERRUPTED" and report["signal"] == signum
    assert report["frames"] >= 2 and report["t_final"] > 0
    assert latency < 1.0, f"{name}: stopped {latency:.2f} s after the signal"


@pytest.mark.parametrize("signum, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_cli_writes_what_was_computed_marked_incomplete(tmp_path, signum, code):
    child = start("cli", SCENES["verlet coulomb+viscous N=2000"], tmp_path)
    report, latency, err = stop(child, signum)
    assert child.returncode == code, err
    assert latency < 1.0
    run = tmp_path / "run"
    marker = read_marker(run)
    assert marker["complete"] is False
    assert f"interrupted by {signal.Signals(signum).name}" in marker["reason"]
    summary = json.loads((run / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["success"] is False
    with h5py.File(run / "trajectory.h5") as h5:
        assert h5["time"].shape[0] >= 2 and h5["time"][-1] == pytest.approx(summary["t_final"])
    assert "marked incomplete" in err
    debris = [p.name for p in tmp_path.iterdir() if p.name.startswith(".")]
    assert debris == []
