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
    the stepping runs ahead of it by as many frames as the log lets wait."""

    def __init__(self, pause=0.0):
        self.pause, self.frames = pause, []

    def write_frame(self, frame):
        time.sleep(self.pause)
        self.frames.append((frame.step, frame.t, frame.x.copy(), frame.v.copy(), frame.f.copy(),
                            frame.kinetic, frame.potential, frame.coulomb, frame.viscous))

    def close(self, result):
        pass


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


@pytest.mark.parametrize("friction", [None, {"viscous": 1e-3}], ids=["plain", "viscous"])
def test_a_frame_handed_on_ends_the_run_where_a_check_at_once_does(friction):
    scene = confined(friction)
    kept = gc.simulate(scene, progress=False)
    assert kept.status == Status.UNSTABLE and kept.t.size > 200  # (the case is what it says)
    sink = SlowCollect(pause=0.002)
    streamed = gc.simulate(scene, progress=False, writers=[sink], keep_frames=False)
    assert (streamed.status, streamed.message) == (kept.status, kept.message)
    assert streamed.steps == kept.steps and streamed.t_final == kept.t_final
    assert np.array_equal(streamed.x_final, kept.x_final)
    assert streamed.event_counts == kept.event_counts
    assert streamed.info["frames"] == kept.t.size == len(sink.frames)
    for q, (step, t, x, v, f, ke, pe, coulomb, viscous) in enumerate(sink.frames):
        assert t == kept.t[q] and step == 10 * q
        assert np.array_equal(x, kept.x[q]) and np.array_equal(v, kept.v[q])
        assert np.array_equal(f, kept.f[q])
        assert (ke, pe) == (kept.energy.kinetic[q], kept.energy.potential[q])
        assert (coulomb, viscous) == (kept.energy.coulomb[q], kept.energy.viscous[q])


def test_frames_handed_on_and_thermo_frames_keep_their_order(tmp_path):
    """Thermo lines are made at once, between frames handed on: every frame is
    written once, in order, as the run that keeps them all has them."""
    scene = gc.scene_from_dict({
        "name": "struck", "granules": {"count": 40, "velocity": {0: 1.0},
                                       "friction": {"kinetic": 2e-3}},
        "contacts": {"exponent": 2.5}, "run": {"dt": 0.02, "t_end": 40.0},
        "output": {"every": 20}})
    kept = gc.simulate(scene, progress=False)
    sink = SlowCollect()
    thermo = ThermoLog(build_model(scene), 30, tmp_path / "thermo.csv")
    streamed = gc.simulate(scene, progress=False, writers=[sink], keep_frames=False,
                           thermo=thermo)
    thermo.close()
    assert streamed.status == kept.status == Status.T_END
    assert [s[1] for s in sink.frames] == kept.t.tolist()
    for q, frame in enumerate(sink.frames):
        assert np.array_equal(frame[2], kept.x[q]) and np.array_equal(frame[3], kept.v[q])
    assert streamed.energy.balance_error == kept.energy.balance_error
    assert len((tmp_path / "thermo.csv").read_text().splitlines()) == 1 + 2000 // 30 + 2


def _run_with_thread(scene):
    log = FrameLog([SlowCollect()], keep=False, background=True)
    run = VerletRun(scene, build_model(scene), progress=False, log=log)
    assert run.deferring
    return run, log


def test_settle_is_check_on_a_copy_of_the_state():
    """The thread's frame (settle) is the frame the driver makes at once: the same
    arrays and energies bit for bit, the same verdict on a non-finite state."""
    run, log = _run_with_thread(confined({"kinetic": 1e-3}, dt=0.05, t_end=20.0))
    try:
        run.run()
        run.u[:] += np.linspace(0.0, 1e-3, run.u.size)  # (any state will do)
        x, v, f = log.lend(run.u.size)
        run._stash(run.u, run.vs, run.f, _frame_arrays(x, v, f))
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
        run._stash(run.u, run.vs, run.f, _frame_arrays(x, v, f))
        with pytest.raises(RunEnds) as end:
            run._settle(_mark(run), x, v, f)
        ended, _ = run._check(Pause.CHUNK_DONE)
        assert (end.value.status, end.value.message) == ended
        assert ended[0] == Status.NONFINITE and "granule 7" in ended[1]
    finally:
        log.finish()


def _frame_arrays(x, v, f):
    return FrameArrays(x, v, f, x)


def _mark(run):
    return _Mark(run.steps, run.t_now, run.ledger.copy(), run.counts.copy(), run.sync)
