"""The Verlet driver's compiled frame scan agrees with the numpy it replaces, bit for
bit, and the frame log's reused arrays reach every writer intact."""

import time

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.frames import Frame, FrameLog
from granular_chain.model import build_model
from granular_chain.steppers.verlet.driver import VerletRun
from granular_chain.steppers.verlet.frame_scan import (CONTACT_PASSED, LEFT_WALL_PASSED,
                                                       NO_PROBLEM, RIGHT_WALL_PASSED, Scan)

SCENES = {
    "linear, walls": {"granules": {"count": 9, "velocity": {0: 0.3}},
                      "contacts": {"exponent": 2.0},
                      "walls": {"left": {"gap": 0.0}, "right": {"gap": 0.01}}},
    "hertz": {"granules": {"count": 40, "velocity": {0: 1.0}}, "contacts": {"exponent": 2.5}},
    "power, per grain": {
        "granules": {"count": 12, "velocity": {0: 0.5},
                     "mass": {"distribution": "uniform", "low": 0.5, "high": 2.0, "seed": 3},
                     "gap": {"distribution": "uniform", "low": -0.01, "high": 0.01, "seed": 4}},
        "contacts": {"exponent": 2.2}, "walls": {"right": {"gap": 0.0, "exponent": 2.2}}},
}


def _run(spec):
    scene = gc.scene_from_dict({"name": "scan", **spec, "run": {"t_end": 1.0, "dt": 0.01}})
    model = build_model(scene)
    return VerletRun(scene, model, progress=False, log=FrameLog(keep=False)), model


@pytest.mark.parametrize("name", SCENES)
def test_scan_equals_the_numpy_it_replaces(name):
    run, model = _run(SCENES[name])
    rng = np.random.default_rng(11)
    for _ in range(20):  # random states, contacts open and closed
        run.u[:] = rng.normal(0.0, 0.02, model.count)
        run.vs[:] = rng.normal(0.0, 1.0, model.count)
        run.f[:] = rng.normal(0.0, 1.0, model.count)
        scan = run.scan()
        assert (scan.kinetic, scan.potential) == model.energies(run.u, run.vs)
        x, v, f = run.log.lend(model.count)
        assert np.array_equal(x, model.x0 + run.u)
        assert np.array_equal(v, run.vs) and np.array_equal(f, run.f)
        assert scan.nonfinite == -1 and scan.problem == NO_PROBLEM


def test_scan_finds_the_first_nonfinite_granule():
    run, model = _run(SCENES["hertz"])
    run.u[:], run.vs[:] = 0.0, 0.0
    assert run.scan().nonfinite == -1
    run.u[7] = np.nan
    run.vs[3] = -np.inf
    assert run.scan().nonfinite == 3
    run.vs[3] = 0.0
    assert run.scan().nonfinite == 7


def test_scan_finds_passed_contacts_and_walls():
    run, model = _run(SCENES["linear, walls"])
    olim = run.chain.olim
    run.u[:] = 0.0
    assert run.scan() == Scan(-1, NO_PROBLEM, -1, 0.0, *model.energies(run.u, run.vs))
    run.u[4], run.u[5] = 0.5 * olim[5], -0.5 * olim[5]  # contact 4 at its limit exactly
    run.u[6] = run.u[5] - 2 * olim[6]  # contact 5 beyond it: the first (4) is reported
    scan = run.scan()
    assert (scan.problem, scan.index) == (CONTACT_PASSED, 4)
    assert scan.overlap == model.d0[4] + run.u[4] - run.u[5]
    run.u[:] = 0.0
    run.u[0] = -olim[0] + model.walls[0]  # granule 0 a radius into the left wall
    run.u[-1] = olim[-1] - model.walls[3]  # granule N-1 a radius into the right wall
    assert run.scan()[1:3] == (LEFT_WALL_PASSED, 0)
    run.u[0] = 0.0
    assert run.scan()[1:3] == (RIGHT_WALL_PASSED, model.count - 1)


def test_scan_without_reach_skips_only_the_passing_check():
    """After a kernel call that ended with CHUNK_DONE the driver scans without
    looking for passed contacts (the kernel checked every step): the frame's arrays,
    energies and NaN check are the same, only ``problem`` stays NO_PROBLEM."""
    run, model = _run(SCENES["linear, walls"])
    olim = run.chain.olim
    run.u[:] = 0.0
    run.u[4], run.u[5] = 0.5 * olim[5], -0.5 * olim[5]  # contact 4 at its limit
    run.vs[:] = np.linspace(-1.0, 1.0, model.count)
    full = run.scan()
    x_full = run.log.lend(model.count)[0].copy()
    run.u[2] = np.nan
    assert run.scan(reach=False).nonfinite == 2
    run.u[2] = 0.0
    fast = run.scan(reach=False)
    assert full.problem == CONTACT_PASSED
    assert fast == Scan(-1, NO_PROBLEM, -1, 0.0, full.kinetic, full.potential)
    assert np.array_equal(run.log.lend(model.count)[0], x_full)


def test_reused_frame_arrays_reach_a_slow_writer_intact():
    """Frames of 3 granules through the writers' thread, which is slower than the
    frames come: the log reuses a frame's arrays only once they are written."""

    class Slow:
        def __init__(self):
            self.seen = []

        def write_frame(self, frame):
            time.sleep(0.002)
            self.seen.append((frame.step, frame.x.copy(), frame.v.copy(), frame.f.copy()))

        def close(self, result):
            pass

    writer = Slow()
    log = FrameLog([writer], keep=False, background=True)
    made = set()
    for step in range(300):
        x, v, f = log.lend(3)
        made.add(id(x))
        x[:], v[:], f[:] = step, -step, 2 * step
        log.record(Frame(step, float(step), x, v, f, 0.0, 0.0, 0.0, 0.0, 1.0))
    log.finish()
    assert [s for s, *_ in writer.seen] == list(range(300))
    for step, x, v, f in writer.seen:
        assert (x == step).all() and (v == -step).all() and (f == 2 * step).all()
    assert len(made) < 300  # arrays were reused (bounded memory)...
    assert log.kept["x"][0][0] == 0 and log.kept["x"][-1][0] == 299  # ...but not the kept ones


class _Sink:
    """A frame writer that notes the steps of the frames it is given."""

    def __init__(self):
        self.seen = []

    def write_frame(self, frame):
        self.seen.append(frame.step)

    def close(self, result):
        pass


def _record(log, steps, count):
    for step in range(steps):
        x, v, f = log.lend(count)
        log.record(Frame(step, float(step), x, v, f, 0.0, 0.0, 0.0, 0.0, 1.0))


def test_a_waiting_frame_reaches_the_writers_without_the_next_one():
    """The writers' thread finds recorded frames by itself: none waits for a later
    frame or for a driver's call (ParaView follows a running job)."""
    sink = _Sink()
    log = FrameLog([sink], keep=False, background=True)
    _record(log, 3, 10_000)  # in quick succession, then nothing
    deadline = time.monotonic() + 10
    while sink.seen != [0, 1, 2] and time.monotonic() < deadline:
        time.sleep(0.001)
    assert sink.seen == [0, 1, 2]
    log.finish()


def test_frames_recorded_just_before_finish_are_all_written():
    """finish() ends the writers' thread only once it has every frame recorded before."""
    for _ in range(20):
        sink = _Sink()
        log = FrameLog([sink], keep=False, background=True)
        _record(log, 5, 4)
        log.finish()
        assert sink.seen == list(range(5))
