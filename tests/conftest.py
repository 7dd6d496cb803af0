"""Shared helpers for the test-suite."""

import atexit
import math
import os
import shutil
import signal
import subprocess
import tempfile
import time

import numpy as np
import pytest
from hypothesis import settings

from granular_chain._compile import LOCK_DIR_ENV
from granular_chain.result import EnergyLedger, Result, Status

# The workers (pytest-xdist) inherit this from the controller: a kernel one worker is
# compiling, the other waits for and loads from numba's cache instead of compiling it
# as well (cold CI runs compile the event kernels for about 40 s each).
if "PYTEST_XDIST_WORKER" not in os.environ and LOCK_DIR_ENV not in os.environ:
    _locks = tempfile.mkdtemp(prefix="gc-compile-locks-")
    os.environ[LOCK_DIR_ENV] = _locks
    atexit.register(shutil.rmtree, _locks, True)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_auto_num_workers(config):
    """``-n auto`` (or ``logical``): one test process more than pytest-xdist's own count
    of cores. A worker often waits without computing, for a kernel another is compiling
    (the compile locks above) or for a child process it signals; on two cores, with two
    workers, the cold suite kept the cores busy 182 % of the time, with three 196 %. An
    explicit ``-n N`` or ``PYTEST_XDIST_AUTO_NUM_WORKERS`` is taken as given."""
    if os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS"):
        return None
    from xdist.plugin import pytest_xdist_auto_num_workers as cores

    return cores(config) + 1


# A child process that never ends is a bug to be shown, not waited for: with Python's
# fault handler on, SIGABRT makes it print every thread's stack (see finish).
os.environ.setdefault("PYTHONFAULTHANDLER", "1")

#: Seconds a test waits for a child process it has told to stop (or that should end by
#: itself) before it takes that child for hung: far above any such wait seen, cold
#: compiles included; a guard against a hang, not a measure of speed.
HUNG_AFTER = 900.0


def finish(proc: subprocess.Popen, what: str, seconds: float = HUNG_AFTER, log=None,
           grace: float = 10.0):
    """Wait for ``proc`` to end, reading its pipes; if it has not ended after
    ``seconds``, make it print its threads' stacks (SIGABRT: Python's fault handler),
    kill it and fail the test with what it wrote on stderr.

    Parameters
    ----------
    proc : subprocess.Popen
        The child, started with this environment (PYTHONFAULTHANDLER=1).
    what : str
        What the child was asked to do, for the failure message.
    seconds : float
        How long to wait.
    log : path-like, optional
        The file the child's stderr goes to, when it is not a pipe.
    grace : float
        Seconds given to the child to print its stacks after SIGABRT, and to its pipes
        after it is killed.

    Returns
    -------
    tuple
        (exit status, stdout, stderr); None for a stream that is not a pipe.
    """
    try:
        out, err = proc.communicate(timeout=seconds)
        return proc.returncode, out, err
    except subprocess.TimeoutExpired:
        pass
    proc.send_signal(signal.SIGABRT)
    try:
        out, err = proc.communicate(timeout=grace)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = _read_after_kill(proc, grace)
    if log is not None:
        err = open(log, errors="replace").read()
    pytest.fail(f"hung: {what} had not ended after {seconds:.0f} s; its stacks:\n{err}")


def _read_after_kill(proc: subprocess.Popen, grace: float):
    """What a killed child wrote, read for at most ``grace`` seconds: a grandchild it
    left behind (a pool worker) can hold its pipes open, and reading to their end would
    wait for that grandchild too."""
    try:
        return proc.communicate(timeout=grace)
    except subprocess.TimeoutExpired:
        for pipe in (proc.stdout, proc.stderr):
            if pipe is not None:
                pipe.close()
        proc.wait()
        return None, "(its pipes were still held open by a process it started)"


def wait_until_stepping(proc: subprocess.Popen, parent, name: str, seconds: float = HUNG_AFTER):
    """Wait until the ``granular-chain run --out parent/name`` started as ``proc`` is
    stepping: its partial folder's trajectory has grown past its first frames (a
    compile or a load from numba's cache, however slow on a loaded machine, is over
    then; a fixed sleep is not enough there).

    Parameters
    ----------
    proc : subprocess.Popen
        The run; the test fails with its stderr if it ends first.
    parent : pathlib.Path
        The folder the run writes its ``.NAME.partial-*`` folder in.
    name : str
        The output folder's name.
    seconds : float
        How long to wait before taking the run for hung.
    """
    first = None
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            pytest.fail(f"run ended early: {proc.returncode} {proc.stderr.read()}")
        for path in parent.glob(f".{name}.partial-*/trajectory.h5"):
            try:
                size = path.stat().st_size
            except FileNotFoundError:
                continue
            if first is None:
                first = size
            elif size > first:
                return
        time.sleep(0.05)
    pytest.fail(f"the run had not begun stepping after {seconds:.0f} s")

# The suite draws the same examples on every run (a check that lands must not
# depend on luck); HYPOTHESIS_PROFILE=explore draws fresh ones to look for new
# failures, which then join the tests as @example.
settings.register_profile("fixed", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "fixed"))


def patch_everywhere(monkeypatch, module: str, name: str, replacement) -> None:
    """Replace ``granular_chain.<module>.<name>`` and every binding of the same object in
    the package's loaded modules (a ``from .. import name`` at a module's top holds its
    own reference), for the test's duration."""
    import importlib
    import sys

    original = getattr(importlib.import_module(f"granular_chain.{module}"), name)
    for mod_name, mod in list(sys.modules.items()):
        if (mod_name == "granular_chain" or mod_name.startswith("granular_chain.")) \
                and getattr(mod, name, None) is original:
            monkeypatch.setattr(mod, name, replacement)


def fitted_order(h, err):
    """Least-squares slope of log|err| against log h (the measured order)."""
    h = np.asarray(h, dtype=float)
    e = np.abs(np.asarray(err, dtype=float))
    return float(np.polyfit(np.log(h), np.log(e), 1)[0])


def paper_sec2a(eta):
    """Sec. II A closed forms (frictionless granule 1, kinetic friction eta on granule 2)."""
    v1 = -eta * math.pi / (2 * math.sqrt(2))
    v2 = math.sqrt(1 - eta * eta) + v1
    return v1, v2, (v1 * v1 + v2 * v2)  # E/E0 = (v1^2 + v2^2)/2 / (1/2)


#: Tests that take a minute or more on a cold numba cache (CI, --durations): run
#: first, so that no worker is left running one of them alone at the end.
SLOW_FIRST = ("test_docs_site.py::test_site_builds_strictly",
              "test_collision_map.py::test_coulomb_grid_n2_bitwise")


def pytest_collection_modifyitems(config, items):
    items.sort(key=lambda item: not any(s in item.nodeid for s in SLOW_FIRST))


def hand_made_result(frames=40, count=6):
    """A Result put together by hand (no kernel compiled): a bump moving right."""
    t = np.linspace(0.0, 1.0, frames)
    v = np.exp(-((np.arange(count)[None, :] - 5 * t[:, None]) ** 2))
    x = np.cumsum(v, axis=0) * (t[1] - t[0]) + 2.0 * np.arange(count)
    kin = 0.5 * np.sum(v * v, axis=1)
    led = EnergyLedger(kinetic=kin, potential=kin[0] - kin, coulomb=0 * t, viscous=0 * t,
                       initial=float(kin[0]))
    return Result(t=t, x=x, v=v, f=0 * v, energy=led, status=Status.T_END,
                  message="reached t_end", steps=frames, wall_time=0.01, stepper="verlet",
                  dt=0.025, t_final=1.0, x_final=x[-1], v_final=v[-1])
