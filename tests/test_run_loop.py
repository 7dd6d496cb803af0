"""One run loop for both steppers (``steppers/loop.py``): the Stepper protocol, and
what the loop owns (signals, progress, checkpoints, the end of the run)."""

import inspect
import os
import signal

import numpy as np

import granular_chain as gc
from granular_chain.codes import Status
from granular_chain.frames import Frame, FrameLog
from granular_chain.result import EnergyLedger, Result
from granular_chain.steppers import loop
from granular_chain.steppers.events.driver import EventStepper
from granular_chain.steppers.verlet.driver import VerletRun

PROTOCOL = ("begin", "advance", "time", "checkpoint_state", "report")


class Sink:
    """A writer that keeps what it is given."""

    def __init__(self):
        self.frames, self.closed_with = [], None

    def write_frame(self, frame):
        self.frames.append(frame.t)

    def close(self, result):
        self.closed_with = result


class Counter:
    """A stepper of a clock that ticks by 1: a frame a tick, a checkpoint every 3 ticks,
    and on the 5th tick a SIGINT sent to this very process."""

    def __init__(self, log, save, t_end=10):
        self.log, self.bar, self.t, self.t_end = log, None, 0, t_end
        self.checkpoints = loop.Checkpoints(log, save)
        self.calls = []

    def begin(self, resume):
        self.calls.append("begin")
        self.t = 0 if resume is None else resume["t"]
        self._record()

    def advance(self, stop):
        self.t += 1
        if self.t == 5:
            os.kill(os.getpid(), signal.SIGINT)   # delivered before the next check
        self._record()
        if self.t % 3 == 0:
            self.checkpoints.write(self.checkpoint_state)
        if stop.requested:
            return Status.INTERRUPTED, f"interrupted at {self.t}"
        return (Status.T_END, "done") if self.t >= self.t_end else None

    def time(self):
        return float(self.t)

    def checkpoint_state(self):
        return {"t": self.t, "frames_written": len(self.log.writers[0].frames)}

    def report(self, status, message, wall):
        self.calls.append("report")
        z = np.zeros(1)
        return Result(t=np.array([float(self.t)]), x=z[None], v=z[None], f=z[None],
                      energy=EnergyLedger(z, z, z, z, 0.0), status=status, message=message,
                      steps=self.t, wall_time=wall, stepper="counter", dt=1.0,
                      t_final=float(self.t), x_final=z, v_final=z)

    def _record(self):
        z = np.zeros(1)
        self.log.record(Frame(self.t, float(self.t), z, z, z, 0.0, 0.0, 0.0, 0.0, 0.0))


def test_the_loop_owns_signals_checkpoints_and_the_end():
    sink, saved = Sink(), []
    log = FrameLog([sink], keep=False, background=True)
    stepper = Counter(log, saved.append)
    before = signal.getsignal(signal.SIGINT)
    result = loop.run_loop(stepper)
    log.finish()
    assert stepper.calls == ["begin", "report"]
    assert result.status == Status.INTERRUPTED and result.info["signal"] == signal.SIGINT
    assert result.message == "interrupted at 5"
    # the checkpoint at t = 3 came after the writers had every frame up to it
    assert saved == [{"t": 3, "frames_written": 4}]
    assert sink.closed_with is result and sink.frames == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    # the loop leaves the signals as it found them
    assert signal.getsignal(signal.SIGINT) is before


def test_a_run_goes_on_from_its_checkpoint():
    sink = Sink()
    log = FrameLog([sink], keep=False)
    result = loop.run_loop(Counter(log, None, t_end=4), resume={"t": 3})
    assert result.status == Status.T_END and sink.frames == [3.0, 4.0]


def test_no_checkpoint_is_made_without_a_place_for_it():
    made = []
    checkpoints = loop.Checkpoints(FrameLog(), None)
    assert not checkpoints
    checkpoints.write(lambda: made.append(1))
    assert made == []


def test_both_steppers_are_driven_by_the_loop():
    for stepper in (VerletRun, EventStepper):
        for name in PROTOCOL:
            assert callable(getattr(stepper, name)), (stepper, name)
        assert list(inspect.signature(stepper.report).parameters)[1:] == \
            ["status", "message", "wall"]
    assert "run_loop(self, resume)" in inspect.getsource(VerletRun.run)
    from granular_chain.steppers.events import driver
    assert "run_loop(EventStepper(" in inspect.getsource(driver.run_packed)


def test_both_steppers_report_an_interrupted_run_the_same_way(monkeypatch):
    """A stop request seen after the first advance ends either stepper's run with
    Status.INTERRUPTED, the signal named in info, and the writers closed."""
    scene = gc.scene_from_dict({"granules": {"count": 6, "velocity": {0: 1.0}},
                                "run": {"dt": 0.01, "t_end": 50.0}})
    for stepper in ("verlet", "event"):
        over = {"run": {"stepper": stepper, "t_end": 50.0}} if stepper == "event" else {}
        s = scene if stepper == "verlet" else gc.scene_from_dict(
            {"granules": {"count": 6, "velocity": {0: 1.0}}, **over})
        sink = Sink()
        real = loop.stop_signals

        class Asked:
            requested, signum, name = True, signal.SIGTERM, "SIGTERM"

        class Now:
            def __enter__(self):
                return Asked()

            def __exit__(self, *exc):
                return False

        monkeypatch.setattr(loop, "stop_signals", Now)
        r = gc.simulate(s, writers=[sink], keep_frames=False)
        monkeypatch.setattr(loop, "stop_signals", real)
        assert sink.closed_with is r, stepper
        assert r.status == Status.INTERRUPTED and r.info["signal"] == signal.SIGTERM, stepper
        assert "SIGTERM" in r.message and r.t_final < 50.0 and sink.frames, stepper
