"""Output frames: what a driver hands to the writers attached to a run, and keeps.

A driver stops its compiled stepping at the output cadence and records a
:class:`Frame` in a :class:`FrameLog`. The log passes each frame to the
attached writers as the run goes (HOOMD-blue's writers on a trigger), keeps the
largest ledger error over the frames, and keeps the states themselves only
when asked: a run that streams its frames to disk holds a fixed number of
frames in memory (the first, the latest, and those waiting for the writers'
thread: about 16 MiB of frames, at most 68 and at least 8), whatever the
number of frames.

A driver may also hand a state that is not yet a frame to the writers' thread
(:meth:`FrameLog.defer`): the thread makes the frame, in order with the
others, and may find instead that the run ends there (:class:`RunEnds`).
"""

from __future__ import annotations

import operator
import threading
from collections import deque
from typing import NamedTuple, Optional, Protocol, Sequence

import numpy as np

from .result import TERMS_ADDED, ledger_balance

__all__ = ["Frame", "FrameWriter", "FrameLog", "RunEnds"]


class Frame(NamedTuple):
    """The state at one output frame (arrays are the driver's: copy to keep them).

    Attributes
    ----------
    step : int
        Steps taken (Verlet) or mode segments (event stepper) so far.
    t : float
        Time (the scene's unit).
    x, v, f : ndarray, shape (N,)
        Centre positions, velocities, net contact forces.
    kinetic, potential : float
        Kinetic energy sum(m v^2 / 2) and elastic energy of the contacts.
    coulomb, viscous : float
        Energy dissipated so far by kinetic and by hydrodynamic friction.
    initial : float
        Kinetic plus elastic energy at t = 0 (the ledger's reference).
    contact_dissipated, wall_work, body_work : float
        Energy dissipated so far by the contacts' dashpots, work done so far by
        moving walls and by body forces (0 in a scene without them).
    stage_work : float
        Energy put in so far by the velocity changes at stage starts (0 in a run
        without ``run.stages``).
    stage : int
        Index of the stage the frame belongs to (0 in a run without stages).
    """

    step: int
    t: float
    x: np.ndarray
    v: np.ndarray
    f: np.ndarray
    kinetic: float
    potential: float
    coulomb: float
    viscous: float
    initial: float
    contact_dissipated: float = 0.0
    wall_work: float = 0.0
    body_work: float = 0.0
    stage_work: float = 0.0
    stage: int = 0

    @property
    def balance(self) -> float:
        """The ledger's balance at this frame (:func:`granular_chain.result.ledger_balance`)."""
        return ledger_balance(self.kinetic, self.potential, self.coulomb, self.viscous,
                              self.contact_dissipated, self.wall_work, self.body_work,
                              self.initial, self.stage_work)

    @property
    def balance_error(self) -> float:
        """|balance| / initial (or absolute when the run starts with no energy)."""
        err = abs(self.balance)
        return err / self.initial if self.initial > 0 else err


class FrameWriter(Protocol):
    """What a writer attached to a run provides."""

    def write_frame(self, frame: Frame) -> None:
        """Write one frame (called in time order, from the driver's thread, or from
        the writers' thread when the log has one).

        Parameters
        ----------
        frame : Frame
            One output frame (time, positions, velocities, ledger; scene units).
        """

    def close(self, result) -> None:
        """The run has ended with ``result``: finish the file.

        Parameters
        ----------
        result : Result
            The finished run.
        """


class RunEnds(Exception):
    """Raised by a deferred frame's maker (:meth:`FrameLog.defer`): the run ends at
    that state instead of recording it.

    Parameters
    ----------
    status : granular_chain.codes.Status
        How the run ends there.
    message : str
        What happened, for the Result.
    mark : object
        What the driver needs to end the run there (for the Verlet driver, a
        ``_Mark``: its step, time, ledger, event counts and synchronising kick).
    """

    def __init__(self, status, message: str, mark):
        super().__init__(message)
        self.status, self.message, self.mark = status, message, mark


class _Slot:
    """Frame arrays the log lends to a driver, and who still holds them: the
    writers' thread (until written) and the log (while it is the latest frame)."""

    __slots__ = ("x", "v", "f", "holders")

    def __init__(self, count: int):
        self.x, self.v, self.f = np.empty(count), np.empty(count), np.empty(count)
        self.holders = 0


class FrameLog:
    """The frames of a run: handed to writers as they come, kept as asked.

    Parameters
    ----------
    writers : sequence of FrameWriter
        Called for every frame, in order.
    keep : bool
        Keep every frame in memory for the Result; when false only the first
        and the latest are kept, so memory does not grow with the number of
        frames (the writers have them all), and the largest ledger error over
        every frame is tracked in :attr:`max_balance_error`.
    background : bool
        Call the writers from a thread of their own, so that writing a frame
        overlaps the compiled stepping that follows it (the kernels release the
        GIL). At most :attr:`queued` frames wait, so memory stays bounded; the
        writers' ``close`` is called from the caller's thread once every frame
        is written.

    Notes
    -----
    A driver may fill a frame's arrays in place: :meth:`lend` gives it arrays
    for the next frame and :meth:`record` then takes them without a copy. With
    ``keep`` false the log reuses them once the writers have written the frame
    and a later frame has replaced it, so a streamed run allocates nothing per
    frame. A driver may instead copy its state into the lent arrays and hand
    them on with :meth:`defer`, which the writers' thread makes into a frame:
    the stepping thread then spends on a frame only the copy (the Verlet
    driver does when the writers have a thread and the frames are not kept,
    outside forced scenes and ``output.events``).

    The writers' thread looks for recorded frames every :data:`POLL_SECONDS`
    (less often while none comes, down to every :data:`IDLE_POLL_SECONDS`)
    rather than being woken for each: waking a thread costs the recording
    thread tens of microseconds, as much as writing a frame of 10^4 granules.
    It is woken only when the caller waits for it (a checkpoint's
    :meth:`sync`, :meth:`drain`, :meth:`finish`, or every frame array in its
    hands), and then tells the caller as soon as a frame is written.
    It takes each frame soon after it is recorded, so the same few arrays
    cycle and stay in the recording core's cache: filling arrays that have
    left it costs twice as much.
    """

    _FIELDS = ("step", "t", "x", "v", "f", "kinetic", "potential", "coulomb", "viscous",
               *TERMS_ADDED, "stage")
    _VALUES = operator.attrgetter(*_FIELDS)  # a frame's kept values, in one call
    QUEUED = 4  #: frames that may wait for the writers' thread, at least
    QUEUED_BYTES = 16 * 2 ** 20  #: ... and more, up to 64, while they fit in this
    POLL_SECONDS = 0.0005  #: how often the writers' thread looks for recorded frames
    IDLE_POLL_SECONDS = 0.008  #: ... and how seldom, at most, while none comes

    def __init__(self, writers: Sequence[FrameWriter] = (), keep: bool = True,
                 background: bool = False):
        self.writers = list(writers)
        self.keep = keep
        self.kept = {name: [] for name in self._FIELDS}  # (sets _newest too)
        self.count = 0
        self.max_balance_error = 0.0
        self.queued = self.QUEUED
        self._thread = self._error = None
        self._lent = self._latest = None
        # Lists and deques shared with the writers' thread: their append and pop
        # are atomic under the GIL, so neither thread takes a lock for them.
        self._pending: deque = deque()  # (frame, slot) recorded, not yet written
        self._free: list = []  # the slot freed last is reused first: the likeliest in cache
        self._handed = self._written = 0
        self._closing = False
        self._wake = threading.Event()  # set when the caller waits for the writers' thread
        self._progress = threading.Event()  # set by that thread after a frame, while one waits
        self._waiting = False
        self._made = 0
        self._lock = threading.Lock()
        self.ended: Optional[RunEnds] = None  #: set by the writers' thread (see :meth:`defer`)
        self._failed = False  # a writer raised: the thread writes nothing more
        if background and self.writers:
            self._thread = threading.Thread(target=self._write_loop, name="frame-writers",
                                            daemon=True)
            self._thread.start()

    @property
    def kept(self) -> dict:
        """The kept frames: field name -> list of values, one per kept frame (every
        frame, or the first and the latest)."""
        if self._newest is not None:  # the latest frame, taken in only when read
            frame, self._newest = self._newest, None
            kept = self._kept
            for name, value in zip(self._FIELDS, self._VALUES(frame)):
                kept[name][-1] = value
        return self._kept

    @kept.setter
    def kept(self, kept: dict) -> None:
        self._kept, self._newest = kept, None

    def lend(self, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Arrays (x, v, f), each of shape (count,), for the driver to fill with the
        next frame and pass to :meth:`record` (the same ones again until it does).

        Waits, when the writers' thread has every array in hand, until it has
        written one frame: this bounds the frames waiting for the writers.

        Parameters
        ----------
        count : int
            Granules N.

        Returns
        -------
        tuple of ndarray
            Positions, velocities and forces to fill, shape (count,) each.
        """
        if self._lent is None:
            self._lent = self._slot(int(count))
        slot = self._lent
        return slot.x, slot.v, slot.f

    def _slot(self, count: int) -> _Slot:
        if self.keep or self.count == 0:
            return _Slot(count)  # kept for good (the Result's frames, the first frame)
        if self._made == 0:
            self.queued = int(np.clip(self.QUEUED_BYTES // (24 * max(count, 1)), self.QUEUED, 64))
        if self._free:
            return self._free.pop()
        # the frames waiting, the one being written, the latest and this one
        if self._made < self.queued + 3:
            self._made += 1
            return _Slot(count)
        # every slot is held: wait for the writers' thread to free one
        self._wait_for_writers(lambda: self._free or self._error is not None)
        self._raise_error()
        return self._free.pop()

    def _release(self, slot: Optional[_Slot]) -> None:
        """One holder of ``slot`` is done with it: reuse it when none is left."""
        if slot is None:
            return
        with self._lock:
            slot.holders -= 1
            free = slot.holders == 0
        if free and not self.keep:
            self._free.append(slot)

    def record(self, frame: Frame) -> None:
        """Take one frame: arrays lent by :meth:`lend` are taken as they are, others
        are copied (the caller may reuse them).

        Parameters
        ----------
        frame : Frame
            One output frame (time, positions, velocities, ledger; scene units).
        """
        slot = self._lent if self._lent is not None else self._slot(frame.x.size)
        self._lent = None
        if not (frame.x is slot.x and frame.v is slot.v and frame.f is slot.f):
            np.copyto(slot.x, frame.x)
            np.copyto(slot.v, frame.v)
            np.copyto(slot.f, frame.f)
            frame = frame._replace(x=slot.x, v=slot.v, f=slot.f)
        slot.holders = 1 + (self._thread is not None)  # the log, the writers' thread
        self._hand_on(frame, slot)
        self._keep(frame, slot)

    def defer(self, make) -> None:
        """Take the arrays last lent, filled with a state that is not yet a frame,
        and ``make``: the writers' thread calls ``make(x, v, f)`` with them, in
        order with the frames recorded, for the :class:`Frame` to keep and write.

        ``make`` raises :class:`RunEnds` when the run ends at that state instead
        (the frame is then not recorded): the thread sets :attr:`ended`, makes
        no later deferred frame, and :meth:`drain` returns it.

        Parameters
        ----------
        make : callable(x, v, f) -> Frame
            Called from the writers' thread (only a log with ``background`` and
            writers has one: see :attr:`background`).
        """
        self._raise_error()  # (before the lent arrays are taken: they stay lent)
        slot, self._lent = self._lent, None
        slot.holders = 2  # the log (while it is the latest frame), the writers' thread
        self._queue(make, slot, True)

    @property
    def background(self) -> bool:
        """Whether the writers run on a thread of their own (:meth:`defer` needs one)."""
        return self._thread is not None

    def drain(self) -> Optional["RunEnds"]:
        """Wait until every frame handed on is made and written (raises a writer's error).

        Returns
        -------
        RunEnds or None
            What the deferred frame that ended the run raised, or None.
        """
        if self._thread is not None:
            self._wait_for_writers(lambda: self._written >= self._handed)
        self._raise_error()
        return self.ended

    def _keep(self, frame: Frame, slot: _Slot) -> None:
        """Count a recorded frame, track its ledger error, keep it as asked."""
        self.count += 1
        self.max_balance_error = max(self.max_balance_error, frame.balance_error)
        if not self.keep and len(self._kept["t"]) >= 2:
            self._newest = frame  # replaces the latest kept, when next read (:attr:`kept`)
        else:
            kept = self.kept
            for name, value in zip(self._FIELDS, self._VALUES(frame)):
                kept[name].append(value)
        if self.count > 1:  # (the first frame is kept for good)
            self._latest, superseded = slot, self._latest
            self._release(superseded)

    def _hand_on(self, frame: Frame, slot: Optional[_Slot]) -> None:
        if self._thread is None:
            for w in self.writers:
                w.write_frame(frame)
            return
        self._queue(frame, slot, False)

    def _queue(self, item, slot: _Slot, deferred: bool) -> None:
        """Hand a frame (or a deferred frame's maker) to the writers' thread."""
        self._raise_error()
        self._pending.append((item, slot, deferred))
        self._handed += 1

    def _write_loop(self) -> None:
        pending, pause = self._pending, self.POLL_SECONDS
        while True:
            try:
                frame, slot, deferred = pending.popleft()
            except IndexError:
                if self._closing:  # (frames recorded before closing are in the deque by now)
                    if not pending:
                        return
                    continue
                self._wake.wait(pause)
                self._wake.clear()
                # looked in vain: look less often, down to IDLE_POLL_SECONDS
                pause = min(2 * pause, self.IDLE_POLL_SECONDS)
                continue
            pause = self.POLL_SECONDS
            try:
                if deferred:
                    frame = self._make(frame, slot)
                if not self._failed and frame is not None:
                    # (after a writer's error, drain: the caller raises that error)
                    for w in self.writers:
                        w.write_frame(frame)
            except BaseException as exc:  # handed to the caller's thread
                self._error, self._failed = exc, True
            finally:
                self._release(slot)
                self._written += 1
                if self._waiting:
                    self._progress.set()

    def _make(self, make, slot: _Slot) -> Optional[Frame]:
        """A deferred frame, made and kept; None once the run has ended at one or a
        writer has failed (the slot then goes back to the driver at once)."""
        frame = None
        try:
            if self.ended is None and not self._failed:
                frame = make(slot.x, slot.v, slot.f)
        except RunEnds as end:
            self.ended = end.with_traceback(None)  # (the maker's frames are not kept alive)
        finally:
            if frame is None:
                self._release(slot)  # the log's hold: it never becomes the latest frame
        if frame is not None:
            self._keep(frame, slot)
        return frame

    def _wait_for_writers(self, done) -> None:
        """Wake the writers' thread (it may be looking seldom, after a pause in the
        frames) and wait until ``done()`` is true or the thread has ended."""
        # The thread sets _progress after each frame while _waiting: the caller
        # goes on as soon as it may, not at its next look.
        self._waiting = True
        try:
            while self._thread.is_alive():
                self._progress.clear()
                if done():
                    break
                self._wake.set()
                self._progress.wait(self.POLL_SECONDS)
        finally:
            self._waiting = False

    def sync(self) -> None:
        """Every frame handed on is written and on disk (for a checkpoint): wait for
        the writers' thread, then flush each writer that buffers."""
        self.drain()  # every frame handed on is written
        for w in self.writers:
            flush = getattr(w, "flush", None)
            if flush is not None:
                flush()

    def checkpoint_state(self) -> dict:
        """The log's part of a checkpoint (the same keys for both steppers;
        :mod:`granular_chain.checkpoint`).

        Returns
        -------
        dict
            ``log_count`` (frames recorded), ``log_max_balance_error`` (largest relative
            ledger error over them), ``log_keep``, and the run's first and latest frames
            as ``log_first_<field>``, ``log_last_<field>`` (fields in :attr:`_FIELDS`;
            arrays of shape (N,) or numbers, scene units), when a frame was recorded.
        """
        state = {"log_count": self.count,
                 "log_max_balance_error": float(self.max_balance_error),
                 "log_keep": bool(self.keep)}
        if self.count:
            kept = self.kept
            for which, k in (("first", 0), ("last", -1)):
                for name in self._FIELDS:
                    value = kept[name][k]
                    state[f"log_{which}_{name}"] = np.array(value) if isinstance(
                        value, np.ndarray) else value
        return state

    def restore(self, state: dict) -> None:
        """Continue the log of a run restarted from a checkpoint: its count and largest
        ledger error, and, for a log that keeps the first and the latest frame only
        (``keep`` False), those two, which a Result reads. A log that keeps every frame
        keeps those computed after the resume (the ones before are in the writers'
        files).

        Parameters
        ----------
        state : dict
            A checkpoint state holding :meth:`checkpoint_state`'s keys. A ledger term
            the checkpoint predates is taken as 0.
        """
        self.count = int(state["log_count"])
        self.max_balance_error = float(state["log_max_balance_error"])
        if self.keep or self.count == 0:
            return
        which = ("first", "last") if self.count >= 2 and "log_last_t" in state else ("first",)
        kept = {}
        for name in self._FIELDS:
            values = [state.get(f"log_{w}_{name}", 0 if name == "stage" else 0.0)
                      for w in which]
            kept[name] = [np.asarray(v).item() if np.ndim(v) == 0 else v for v in values]
        self.kept = kept

    def _raise_error(self) -> None:
        if self._error is not None:
            error, self._error = self._error, None
            raise error

    def finish(self) -> None:
        """Wait until every frame handed on is written (raises a writer's error)."""
        if self._thread is not None:
            self._closing = True
            self._wake.set()
            self._thread.join()
            self._thread = None
        self._raise_error()

    def array(self, name: str) -> np.ndarray:
        """A kept field over the kept frames: shape (F,) or (F, N).

        Parameters
        ----------
        name : str
            A field of :class:`Frame` (``t``, ``x``, ``v``...).

        Returns
        -------
        ndarray
            Shape (F,) or (F, N), in scene units.
        """
        return np.array(self.kept[name])

    def close(self, result) -> None:
        """Every frame written; then tell every writer the run has ended.

        Parameters
        ----------
        result : Result
            The finished run.
        """
        self.finish()
        for w in self.writers:
            w.close(result)
