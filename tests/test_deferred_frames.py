"""A Verlet run whose writers have a thread of their own hands each frame of the
cadence to that thread as a copy of the state and steps on; the thread makes
and checks the frame. A run so streamed ends where, and as, a run checked at
every frame at once ends, however far its stepping has gone past the frame
that ends it."""

import time

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.codes import Pause, Status
from granular_chain.frames import FrameLog, RunEnds
from granular_chain.model import build_model
from granular_chain.steppers.verlet import VerletRun
from granular_chain.steppers.verlet.driver import _Mark
from granular_chain.steppers.verlet.frame_scan import FrameArrays
from granular_chain.writers.thermo import ThermoLog


class SlowCollect:
    """A writer that keeps what it is given and takes ``pause`` seconds a frame, so
    the stepping runs ahead of it by as many frames as the log lets wait; ``leads``
    holds how many steps the run had taken past each frame when it was written."""

    def __init__(self, pause=0.0):
        self.pause, self.frames, self.leads, self.run = pause, [], [], None

    def write_frame(self, frame):
        time.sleep(self.pause)
        if self.run is not None:
            self.leads.append(self.run.steps - frame.step)
        self.frames.append((frame.step, frame.t, frame.x.copy(), frame.v.copy(), frame.f.copy(),
                            frame.kinetic, frame.potential, frame.coulomb, frame.viscous))

    def close(self, result):
        pass


def streamed(scene, sink, thermo=None):
    """Run ``scene`` as ``simulate`` streams it (frames not kept, writers on their
    own thread); the Result and the run."""
    log = FrameLog([sink], keep=False, background=True)
    run = VerletRun(scene, build_model(scene), progress=False, log=log, thermo=thermo)
    sink.run = run
    try:
        return run.run(), run
    finally:
        log.finish()


def assert_same_frames(sink, kept):
    assert len(sink.frames) == kept.t.size
    for q, (step, t, x, v, f, ke, pe, coulomb, viscous) in enumerate(sink.frames):
        assert t == kept.t[q]
        assert np.array_equal(x, kept.x[q]) and np.array_equal(v, kept.v[q])
        assert np.array_equal(f, kept.f[q])
        assert (ke, pe) == (kept.energy.kinetic[q], kept.energy.potential[q])
        assert (coulomb, viscous) == (kept.energy.coulomb[q], kept.energy.viscous[q])


def confined(friction=None, dt=1.001, t_end=30000.0):
    """20 linear granules squeezed between two walls, dt just above velocity
    Verlet's limit 1 (highest mode omega = 2): the highest mode grows from
    round-off until the ledger is off by the initial energy, hundreds of
    frames in (Status.UNSTABLE, found at a frame, never by the kernel)."""
    return gc.scene_from_dict({
        "name": "confined",
        "granules": {"count": 20, "velocity": {0: 1.0}, "radius": 1e6, "gap": -1.0,
                     "friction": friction or {}},
        "walls": {"left": {"gap": -1.0}, "right": {"gap": -1.0}},
        "run": {"dt": dt, "t_end": t_end, "check_dt": False},
        "output": {"every": 10}})


@pytest.mark.parametrize("friction", [None, {"viscous": 1e-3}, {"kinetic": 1e-6}],
                         ids=["plain", "viscous", "coulomb"])
def test_a_frame_handed_on_ends_the_run_where_a_check_at_once_does(friction, tmp_path):
    scene = confined(friction)
    kept = gc.simulate(scene, progress=False,
                       thermo=ThermoLog(build_model(scene), 300, tmp_path / "kept.csv"))
    assert kept.status == Status.UNSTABLE and kept.t.size > 200  # (the case is what it says)
    sink = SlowCollect(pause=0.002)
    thermo = ThermoLog(build_model(scene), 300, tmp_path / "streamed.csv")
    result, run = streamed(scene, sink, thermo)
    assert run.deferring and max(sink.leads) >= 100  # the stepping ran ten frames ahead
    assert (result.status, result.message) == (kept.status, kept.message)
    assert result.steps == kept.steps and result.t_final == kept.t_final
    assert np.array_equal(result.x_final, kept.x_final)
    assert result.event_counts == kept.event_counts
    assert result.info["frames"] == kept.t.size
    assert_same_frames(sink, kept)
    assert (tmp_path / "streamed.csv").read_bytes() == (tmp_path / "kept.csv").read_bytes()


def test_frames_handed_on_and_thermo_frames_keep_their_order(tmp_path):
    """Thermo lines are made at once, between frames handed on: every frame is
    written once, in order, as the run that keeps them all has them, and the thermo
    log is the one of that run."""
    scene = gc.scene_from_dict({
        "name": "struck", "granules": {"count": 40, "velocity": {0: 1.0},
                                       "friction": {"kinetic": 2e-3}},
        "contacts": {"exponent": 2.5}, "run": {"dt": 0.02, "t_end": 40.0},
        "output": {"every": 20}})
    kept = gc.simulate(scene, progress=False,
                       thermo=ThermoLog(build_model(scene), 30, tmp_path / "kept.csv"))
    sink = SlowCollect()
    result, run = streamed(scene, sink,
                           ThermoLog(build_model(scene), 30, tmp_path / "streamed.csv"))
    assert run.deferring and result.status == kept.status == Status.T_END
    assert_same_frames(sink, kept)
    assert result.energy.balance_error == kept.energy.balance_error
    assert (tmp_path / "streamed.csv").read_bytes() == (tmp_path / "kept.csv").read_bytes()


def test_long_chain_frames_made_on_the_writers_thread_are_the_kept_ones():
    """At N = 3 10^4 the kinetic energy's dot product is long enough for a threaded
    BLAS to split it: made on the writers' thread it is still the same number."""
    scene = gc.scene_from_dict({
        "name": "long", "granules": {"count": 30000, "velocity": {0: 1.0, 15000: -0.5}},
        "contacts": {"exponent": 2.5}, "run": {"dt": 0.01, "t_end": 3.0},
        "output": {"every": 30}})
    kept = gc.simulate(scene, progress=False)
    sink = SlowCollect()
    result, run = streamed(scene, sink)
    assert run.deferring and result.status == Status.T_END
    assert_same_frames(sink, kept)


def test_settle_is_check_on_a_copy_of_the_state():
    """The thread's frame (settle) is the frame the driver makes at once: the same
    arrays and energies bit for bit, the same verdict on a non-finite state."""
    scene = confined({"kinetic": 1e-3}, dt=0.05, t_end=20.0)
    log = FrameLog([SlowCollect()], keep=False, background=True)
    run = VerletRun(scene, build_model(scene), progress=False, log=log)
    try:
        assert run.deferring
        run.run()
        run.u[:] += np.linspace(0.0, 1e-3, run.u.size)  # (any state will do)
        x, v, f = log.lend(run.u.size)
        run._stash(run.u, run.vs, run.f, FrameArrays(x, v, f, x))
        settled = run._settle(_mark(run), x.copy(), v.copy(), f.copy())
        ended, scan = run._check(Pause.CHUNK_DONE)
        at_once = run.frame(scan)
        assert ended is None
        for name in ("x", "v", "f"):
            assert np.array_equal(getattr(settled, name), getattr(at_once, name))
        assert (settled.kinetic, settled.potential) == (at_once.kinetic, at_once.potential)
        assert (settled.coulomb, settled.viscous) == (at_once.coulomb, at_once.viscous)

        run.v[7] = run.vs[7] = np.nan
        x, v, f = log.lend(run.u.size)
        run._stash(run.u, run.vs, run.f, FrameArrays(x, v, f, x))
        with pytest.raises(RunEnds) as end:
            run._settle(_mark(run), x, v, f)
        ended, _ = run._check(Pause.CHUNK_DONE)
        assert (end.value.status, end.value.message) == ended
        assert ended[0] == Status.NONFINITE and "granule 7" in ended[1]
    finally:
        log.finish()


def test_a_log_that_keeps_every_frame_makes_them_on_the_stepping_thread():
    """Frames kept in memory take new arrays each: nothing would hold the stepping
    back from a frame that ends the run, so such a run makes each frame at once."""
    scene = confined(t_end=50.0)
    log = FrameLog([SlowCollect()], keep=True, background=True)
    try:
        assert not VerletRun(scene, build_model(scene), progress=False, log=log).deferring
    finally:
        log.finish()


class Failing:
    """A writer that raises at its ``at``-th frame."""

    def __init__(self, at):
        self.at, self.seen = at, 0

    def write_frame(self, frame):
        self.seen += 1
        if self.seen == self.at:
            raise OSError("disk full")

    def close(self, result):
        pass


def test_a_writer_error_reaches_the_caller_and_frees_every_frame_array():
    scene = gc.scene_from_dict({
        "name": "struck", "granules": {"count": 50, "velocity": {0: 1.0}},
        "contacts": {"exponent": 2.5}, "run": {"dt": 0.02, "t_end": 200.0},
        "output": {"every": 5}})
    sink = Failing(at=30)
    log = FrameLog([sink], keep=False, background=True)
    run = VerletRun(scene, build_model(scene), progress=False, log=log)
    with pytest.raises(OSError, match="disk full"):
        run.run()
    log.finish()
    assert sink.seen == 30  # nothing is written after the error
    held = [s for s in log._free if s.holders]
    assert not held and log._made - len(log._free) <= 2  # (the first and the latest frame)


def _mark(run):
    return _Mark(run.steps, run.t_now, run.ledger.copy(), run.counts.copy(), run.sync)
