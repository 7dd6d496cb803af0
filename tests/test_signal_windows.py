"""Signals outside a run's stepping loop: before it (scene loading, kernel compilation)
and after it (a 2-D ``boundaries`` writing its curves).

Each trial starts the command in a subprocess, waits until the command line has taken
over SIGHUP (read from /proc/PID/status: it does so as the command starts), then sends
the signal at a chosen moment and checks what the command did and left on disk: exit
128 + the signal number, one line on stderr and no traceback, and either nothing or a
folder marked incomplete that lists every file in it; nothing else anywhere.
"""

import json
import os
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

CLI = [sys.executable, "-m", "granular_chain.cli"]
PLANE = ["boundaries", "--param", "eta1", "--range", "0", "1", "--y-param", "eta2",
         "--y-range", "0", "1", "--grid", "4"]
SCENE = """\
name: early
granules: {count: 4, radius: 2.0, velocity: {0: 1.0}}
run: {t_end: 100.0, dt: 0.01}
output: {every: 100}
"""


def _catches_sighup(pid: int) -> bool:
    """Whether process ``pid`` has a handler for SIGHUP (bit 0 of SigCgt)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    caught = next(line for line in status.splitlines() if line.startswith("SigCgt:"))
    return bool(int(caught.split()[1], 16) & (1 << (signal.SIGHUP - 1)))


def _signalled(command, cwd, signum, when, env=None):
    """Run ``command``; once it handles SIGHUP, wait until ``when()`` is true and send
    ``signum``. Returns (exit status, stderr, whether the signal was sent)."""
    proc = subprocess.Popen(command, cwd=cwd, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, env=env)
    try:
        while not _catches_sighup(proc.pid) and proc.poll() is None:
            time.sleep(0.002)
        while proc.poll() is None and not when():
            time.sleep(0.002)
        sent = proc.poll() is None
        if sent:
            proc.send_signal(signum)
        code, _, err = finish(proc, f"{command} after signal {signum}")
        return code, err, sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def _entries(folder: Path) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))


def _left_clean(work: Path, out: Path) -> str:
    """'' when ``work`` holds nothing but ``out``, absent or marked incomplete listing
    every file in it; else what is wrong."""
    others = [e for e in _entries(work) if e != out.name and not e.startswith(out.name + "/")]
    if others:
        return f"debris beside {out.name}: {others}"
    if not out.exists():
        return ""
    marker = json.loads((out / "run.json").read_text())
    files = [e for e in _entries(out) if e != "run.json"]
    if marker["complete"] or not marker["reason"].startswith("interrupted"):
        return f"marker {marker}"
    if sorted(marker["files"]) != files:
        return f"files {files} but the marker lists {marker['files']}"
    return ""


def _plane_moments(out: Path):
    """Moments of a 2-D boundaries run: as it starts, into its scan, as its folder is
    claimed, with its first file written."""
    def after(seconds):
        start = []
        return lambda: bool(start.append(time.monotonic()) or
                            time.monotonic() - start[0] >= seconds)
    return {"start": lambda: True, "scan 0.5 s": after(0.5), "scan 3 s": after(3.0),
            "folder claimed": lambda: out.exists(),
            "first file": lambda: (out / "boundaries_curves.csv").exists()}


def test_interrupted_plane_leaves_nothing_or_a_folder_marked_incomplete(tmp_path):
    """granular-chain boundaries --y-param ... --out DIR, SIGINT at five moments: exit
    130 and nothing but DIR, absent or marked incomplete listing all it holds (no
    claimed folder left empty, no temporary file)."""
    warm = tmp_path / "warm"
    warm.mkdir()
    subprocess.run(CLI + PLANE + ["--out", "curves"], cwd=warm, check=True,
                   capture_output=True)  # fills numba's cache; the full result
    assert _entries(warm / "curves") == ["boundaries_curves.csv", "boundaries_curves.json",
                                         "boundaries_curves.png", "run.json"]
    for i, (name, when) in enumerate(_plane_moments(Path("curves")).items()):
        work = tmp_path / f"trial{i}"
        work.mkdir()
        out = work / "curves"
        moments = _plane_moments(out)
        status, err, sent = _signalled(CLI + PLANE + ["--out", "curves"], work,
                                       signal.SIGINT, moments[name])
        assert "Traceback" not in err, f"{name}: {err}"
        marker = out / "run.json"
        if not sent or status == 0 or (marker.is_file()
                                       and json.loads(marker.read_text())["complete"]):
            # the command ended before the moment came (on a fast machine the scan takes
            # under 3 s; no signal sent), or the signal came as it ended, its result
            # published whole (exit 0, or 130 when it came after the publication):
            # every file listed, no debris
            listed = json.loads(marker.read_text())
            assert status in (0, 130) and listed["complete"], f"{name}: {status} {listed}"
            assert sorted(listed["files"]) == [e for e in _entries(out) if e != "run.json"]
            assert _entries(work) == ["curves"] + [f"curves/{e}" for e in _entries(out)]
            continue
        assert status == (130 if sent else 0), f"{name}: exit {status}: {err}"
        assert _left_clean(work, out) == "", f"{name}: {_left_clean(work, out)}"


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_signal_before_the_loop_stops_a_run_cleanly(tmp_path, signum):
    """A signal as soon as granular-chain run handles it (scene loading, model build,
    kernels loaded): exit 128 + N, one line, no output folder and nothing else."""
    (tmp_path / "scene.yaml").write_text(SCENE)
    status, err, sent = _signalled(CLI + ["run", "scene.yaml", "--out", "out"], tmp_path,
                                   signum, lambda: True)
    assert sent
    assert status == 128 + signum, err
    assert len(err.strip().splitlines()) == 1 and "interrupted" in err, err
    assert _entries(tmp_path) == ["scene.yaml"]


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_signal_while_compiling_stops_a_run_cleanly(tmp_path, signum):
    """A fresh NUMBA_CACHE_DIR: the run compiles its kernels (it says so on stderr) and
    the signal comes then: exit 128 + N, no traceback, nothing on disk but the cache."""
    (tmp_path / "scene.yaml").write_text(SCENE)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    log = tmp_path / "cache" / "stderr"
    log.parent.mkdir()
    with log.open("w") as stderr:
        proc = subprocess.Popen(CLI + ["run", "scene.yaml", "--out", "out"], cwd=tmp_path,
                                stdout=subprocess.DEVNULL, stderr=stderr, env=env)
        try:
            while "compiling" not in log.read_text() and proc.poll() is None:
                time.sleep(0.002)
            assert proc.poll() is None, log.read_text()
            proc.send_signal(signum)
            finish(proc, f"run while compiling, after signal {signum}", log=log)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    err = log.read_text()
    assert proc.returncode == 128 + signum, err
    assert "Traceback" not in err and "nothing written" in err, err
    assert _entries(tmp_path) == [e for e in _entries(tmp_path) if e.startswith("cache")] + \
        ["scene.yaml"]


# The process ending: its command is done; an exit function stands in for the moment
# (it runs where the interpreter's teardown, with the signals' default actions, ran).
_ENDING = """\
import atexit, os, signal, sys, threading, time
from granular_chain.cli import main
{setup}
sys.argv = ["granular-chain", "schema"]
main()
"""


def _ending(setup: str):
    return subprocess.run([sys.executable, "-c", _ENDING.format(setup=setup)],
                          capture_output=True, text=True, timeout=300)


def test_a_signal_as_the_process_ends_exits_at_once_without_a_traceback():
    """SIGINT after the command is done (its output whole): exit 130 at once, one
    whole output, no traceback (not a KeyboardInterrupt in the interpreter's teardown,
    nor the process killed by the signal)."""
    done = _ending("atexit.register(lambda: (os.kill(os.getpid(), signal.SIGINT), "
                   "time.sleep(60), print('not reached', file=sys.stderr)))")
    assert done.returncode == 130, done.stderr
    assert "Traceback" not in done.stderr and "not reached" not in done.stderr
    assert json.loads(done.stdout)["title"]


def test_the_process_ends_after_its_threads_and_exit_functions():
    """The quick end still joins the threads that are not daemons and runs the exit
    functions, as the interpreter's exit does."""
    done = _ending("threading.Thread(target=lambda: (time.sleep(0.3), "
                   "print('thread done', file=sys.stderr))).start()\n"
                   "atexit.register(lambda: print('exit function', file=sys.stderr))")
    assert done.returncode == 0, done.stderr
    assert done.stderr.splitlines()[-2:] == ["thread done", "exit function"]
