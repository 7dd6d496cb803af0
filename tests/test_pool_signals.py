"""A signal to a command while its process pool works (a collision map on two worker
processes): the command ends, its workers with it. A worker forked while a run's stop
handler was in place once took the pool's SIGTERM as a stop request for its own run,
stayed alive blocked on a result queue no one read, and the command waited for it for
ever (``interrupts.pool_worker_signals``)."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import finish

pytestmark = pytest.mark.skipif(not Path("/proc/self/task").exists(),
                                reason="reads a process's children from /proc")

CHILD = """
import time
import numpy as np
from granular_chain.interrupts import raise_on_signals, stop_signals
from granular_chain.two_granules import collision_map, maps


def slow_task(task):  # a point block that takes long, as a large map's does, and ends
    with stop_signals() as stop:  # at a stop request as a batch does (its points
        start = time.monotonic()  # marked interrupted); its result (2000 points,
        while time.monotonic() - start < {seconds} and not stop.requested:  # 144 kB)
            time.sleep(0.01)  # is more than a pipe holds
    _, lo, hi = task
    n = hi - lo
    return (lo, hi, np.zeros(n, dtype=np.int64), np.zeros(n), np.zeros((n, 2)), np.zeros(n),
            np.zeros(n), np.ones(n), np.zeros((n, 2)))


maps._map_task = slow_task  # (the workers are forked: they run it)
e = np.linspace(0.0, 0.6, 100)
with raise_on_signals():  # as the command line runs every command
    collision_map(e, e, n=2.5, workers=2)
print("done", flush=True)
"""


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(c) for c in text.split()]


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"
    except OSError:
        return False


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("delay", [0.0, 0.3, 1.0])
def test_a_signal_during_a_pooled_map_ends_the_command_and_its_workers(signum, delay):
    subprocess.run([sys.executable, "-c", CHILD.format(seconds=0)], check=True,
                   capture_output=True)  # numba's cache filled: the signal finds the pool
    proc = subprocess.Popen([sys.executable, "-c", CHILD.format(seconds=60)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    workers = []
    while len(workers) < 2 and proc.poll() is None:  # the pool is up
        workers = _children(proc.pid)
        time.sleep(0.01)
    assert proc.poll() is None, proc.communicate()
    time.sleep(delay)
    proc.send_signal(signum)
    code, out, err = finish(proc, "a collision map on a pool after a signal", seconds=120)
    assert "done" not in out and code != 0, (code, out, err)
    deadline = time.monotonic() + 10
    while any(_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(_alive(w) for w in workers), [w for w in workers if _alive(w)]


def test_in_a_pool_worker_the_blocks_change_no_handler():
    code = """
import multiprocessing, signal
from granular_chain.interrupts import pool_worker_signals, stop_signals, raise_on_signals
def probe(_):
    seen = []
    with stop_signals(), raise_on_signals():
        seen.append((signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)))
    return seen[0] == (signal.SIG_DFL, signal.SIG_IGN)
with stop_signals():  # (forked while a run's handler is in place)
    with multiprocessing.get_context("fork").Pool(1, initializer=pool_worker_signals) as p:
        print(p.map(probe, [0]))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, env={**os.environ})
    assert out.stdout.strip() == "[True]", out.stderr
