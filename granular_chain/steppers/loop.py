"""One run loop for both steppers: signals, progress, checkpoints and the Result.

As scipy's ``solve_ivp`` drives any of its ``OdeSolver`` classes step by step, and
HOOMD-blue runs its operations between triggers, :func:`run_loop` drives a
:class:`Stepper`: an object that advances the run to its next trigger (a frame of
the cadence, a thermo line, a checkpoint, the end, or about
:data:`~granular_chain.interrupts.CHUNK_SECONDS` of compiled work, whichever is
first), gives its state for a checkpoint, restores one, and reports its Result.
The loop owns what is the same for every stepper:

- the signals: SIGINT and SIGTERM are caught for the run (:func:`stop_signals`);
  the stepper sees the request after each advance and ends the run at its next
  frame, as ``Status.INTERRUPTED``;
- the progress bar, moved to the simulated time after each advance;
- the stepping wall time, from the first frame (or the restored state) on;
- the checkpoints' writing (:class:`Checkpoints`): every frame so far reaches the
  writers before the state that follows them;
- the end: the signal that stopped the run in ``result.info``, then the frame log
  closed with the Result (the writers' ``close``).

Each stepper decides *when* (its triggers are its own: Verlet counts steps, the
event stepper Taylor steps and simulated time), so a run continued from a
checkpoint takes exactly the steps of a run never stopped.
"""

from __future__ import annotations

import time
from typing import Callable, Optional, Protocol

from ..frames import FrameLog
from ..interrupts import StopRequest, stop_signals
from ..result import Result, Status


class Stepper(Protocol):
    """What :func:`run_loop` needs of a stepper (``VerletRun``, ``EventStepper``).

    Attributes
    ----------
    log : FrameLog or None
        Where the run's frames go (None: the stepper keeps them for its Result).
    bar : ProgressBar or None
        The run's progress bar, in the units of :meth:`time`.
    """

    log: Optional[FrameLog]
    bar: object

    def begin(self, resume: Optional[dict]) -> None:
        """Record the first frame, or restore ``resume`` (a :meth:`checkpoint_state`)."""

    def advance(self, stop: StopRequest) -> Optional[tuple]:
        """Step to the next trigger; None while the run goes on, else ``(status,
        message)`` (``message`` None: the stepper's own words in :meth:`report`)."""

    def time(self) -> float:
        """The simulated time reached, in the units of :attr:`bar`."""

    def checkpoint_state(self) -> dict:
        """Everything needed to go on from here (:mod:`granular_chain.checkpoint`)."""

    def report(self, status, message: Optional[str], wall: float) -> Result:
        """The run's Result, with ``wall`` seconds of stepping in this process."""


class Checkpoints:
    """Where a run's checkpoints go: the writers get every frame so far first
    (``log.sync()``), then ``save`` gets the stepper's state.

    Parameters
    ----------
    log : FrameLog
        The run's frame log.
    save : callable(dict) or None
        Given each state (:func:`granular_chain.checkpoint.save_checkpoint` writes it
        to disk for ``granular-chain run``); None: no checkpoints.
    """

    def __init__(self, log: Optional[FrameLog], save: Optional[Callable[[dict], None]]):
        self.log, self.save = log, save

    def __bool__(self) -> bool:
        return self.save is not None

    def write(self, state: Callable[[], dict]) -> None:
        """Sync the writers, then save ``state()`` (made only when it is saved).

        Parameters
        ----------
        state : callable() -> dict
            The stepper's ``checkpoint_state``.
        """
        if self.save is None:
            return
        if self.log is not None:
            self.log.sync()
        self.save(state())


def run_loop(stepper: Stepper, resume: Optional[dict] = None) -> Result:
    """Run ``stepper`` to its end; its Result.

    Parameters
    ----------
    stepper : Stepper
        A stepper built for one run.
    resume : dict, optional
        A state the stepper gave for a checkpoint: the run goes on from it.

    Returns
    -------
    Result
        The stepper's report; ``info["signal"]`` names the signal of an interrupted run.
    """
    stepper.begin(resume)
    bar = stepper.bar
    start = time.perf_counter()  # stepping time: from the first frame on
    if bar is not None:
        bar.start(stepper.time())
    ended = None
    try:
        with stop_signals() as stop:
            while ended is None:
                ended = stepper.advance(stop)
                if bar is not None:
                    bar.update(stepper.time())
    finally:
        if bar is not None:
            bar.close()
    result = stepper.report(*ended, time.perf_counter() - start)
    if result.status == Status.INTERRUPTED:
        result.info["signal"] = stop.signum
    if stepper.log is not None:
        stepper.log.close(result)
    return result
