"""Shared helpers for the test-suite."""

import atexit
import math
import os
import shutil
import tempfile

import numpy as np
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

# The suite draws the same examples on every run (a check that lands must not
# depend on luck); HYPOTHESIS_PROFILE=explore draws fresh ones to look for new
# failures, which then join the tests as @example.
settings.register_profile("fixed", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "fixed"))


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
