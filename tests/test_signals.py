"""Ctrl-C stops every long command within 2 s, wherever it lands.

For each of ``sweep --serial``, ``boundaries``, ``run`` (Verlet) and ``run`` (event
stepper): one unsignalled short run first (it fills numba's cache), then 8 trials
(``GRANULAR_CHAIN_SIGNAL_TRIALS=20`` for the 20 of the measurement in
docs/robustness.md).
Each trial starts the command on work that lasts far longer than the trial, waits
until the command has started (it has installed its SIGHUP handler, read from
/proc/PID/status: the command line catches SIGHUP from the command's start,
``raise_on_signals``, and a run, a sweep or a scan from its loop), sleeps a random
(seeded) time of up to 1.5 s, so that the signal lands in the command's start (scene,
kernels) or its loop, sends SIGINT and measures the time from the signal to the
process's exit. Imports take what they take; only the interval from the signal to the
exit is bounded, by the 2 s of the requirement.
"""

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import finish

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not Path("/proc/self/status").exists(),
                                 reason="reads the signal handlers from /proc")]

TRIALS = int(os.environ.get("GRANULAR_CHAIN_SIGNAL_TRIALS", "8"))
BOUND = 2.0  # seconds from SIGINT to exit (the requirement)
MAX_DELAY = 1.5  # seconds after the loop starts: signals land anywhere in its first chunks

VERLET = """\
name: sig_verlet
granules:
  count: 20
  radius: 2.0
  velocity: {0: 1.0}
walls:
  left: {gap: 0.0}
  right: {gap: 0.0}
run:
  t_end: T_END
  dt: 0.01
output:
  every: 1000
"""

EVENT = """\
name: sig_event
granules:
  count: 6
  radius: 2.0
  velocity: {0: 1.0}
walls:
  left: {gap: 0.0}
  right: {gap: 0.0}
run:
  stepper: event
  t_end: T_END
output:
  dt: 1000.0
"""


def _scene(folder: Path, text: str, t_end: float) -> Path:
    path = folder / f"scene_{t_end:g}.yaml"
    path.write_text(text.replace("T_END", repr(float(t_end))))
    return path


def _commands(folder: Path) -> dict:
    """name -> (warm-up command, long command factory(trial folder))."""
    verlet_short, verlet_long = (_scene(folder, VERLET, t) for t in (10.0, 1e7))
    event_short, event_long = (_scene(folder, EVENT, t) for t in (10.0, 1e7))
    sweep_short, sweep_long = (_scene(folder, VERLET, t) for t in (10.0, 2e3))
    cli = [sys.executable, "-m", "granular_chain.cli"]
    return {
        "sweep --serial": (
            cli + ["sweep", str(sweep_short), "--grid", "granules.friction.kinetic=0:0.001:2",
                   "--serial", "--quiet", "--out", str(folder / "warm_sweep")],
            lambda d: cli + ["sweep", str(sweep_long), "--grid",
                             "granules.friction.kinetic=0:0.001:400", "--serial", "--quiet",
                             "--out", str(d / "sweep")]),
        "boundaries": (
            cli + ["boundaries", "--param", "eta2", "--range", "0", "1", "--grid", "2"],
            lambda d: cli + ["boundaries", "--param", "eta2", "--range", "0", "1",
                             "--grid", "100000"]),
        "run verlet": (
            cli + ["run", str(verlet_short), "--quiet", "--out", str(folder / "warm_verlet")],
            lambda d: cli + ["run", str(verlet_long), "--quiet", "--out", str(d / "run")]),
        "run event": (
            cli + ["run", str(event_short), "--quiet", "--out", str(folder / "warm_event")],
            lambda d: cli + ["run", str(event_long), "--quiet", "--out", str(d / "run")]),
    }


def _catches_sighup(pid: int) -> bool:
    """Whether process ``pid`` has a handler for SIGHUP (bit 0 of SigCgt)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    caught = next(line for line in status.splitlines() if line.startswith("SigCgt:"))
    return bool(int(caught.split()[1], 16) & (1 << (signal.SIGHUP - 1)))


def _trial(command: list, folder: Path, delay: float) -> tuple[int, float, str]:
    """Start ``command``, SIGINT it ``delay`` s after it started: (status, seconds, stderr)."""
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True, cwd=folder)
    try:
        while not _catches_sighup(proc.pid):  # start-up: as long as it needs
            if proc.poll() is not None:
                pytest.fail(f"{command} ended before its loop: {proc.returncode} "
                            f"{proc.stderr.read()}")
            time.sleep(0.005)
        time.sleep(delay)
        assert proc.poll() is None, f"{command} ended before the signal"
        proc.send_signal(signal.SIGINT)
        sent = time.monotonic()
        code, _, err = finish(proc, f"{command} after SIGINT")
        seconds = time.monotonic() - sent
        return code, seconds, err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.parametrize("name", ["sweep --serial", "boundaries", "run verlet", "run event"])
def test_sigint_stops_within_two_seconds(tmp_path, name):
    warm, long = _commands(tmp_path)[name]
    subprocess.run(warm, cwd=tmp_path, capture_output=True, text=True, check=True)
    rng = random.Random(f"signals {name}")
    times = []
    for i in range(TRIALS):
        folder = tmp_path / f"trial{i}"
        folder.mkdir()
        status, seconds, err = _trial(long(folder), folder, rng.uniform(0.0, MAX_DELAY))
        assert status == 130, f"trial {i}: exit {status}: {err}"
        assert "Traceback" not in err, err
        times.append(seconds)
    print(f"{name}: signal to exit, {TRIALS} trials: max {max(times):.3f} s, "
          f"median {sorted(times)[TRIALS // 2]:.3f} s")
    assert max(times) < BOUND, f"{name}: signal to exit took {max(times):.3f} s: {times}"
