"""The event stepper's Python driver: units, kernel calls in chunks, frames, checkpoints.

``simulate_events(scene, model) -> Result`` is what :func:`granular_chain.simulate`
calls for ``run.stepper: event``. It reads the scene once
(:func:`~.options.event_options`), runs the Model in its own scaled units
(:func:`granular_chain.units.internal_scales`), packs the kernel's records
(:mod:`.pack`), calls the compiled loop (:func:`~.kernel.run_events`) until it
returns a :class:`~granular_chain.codes.Status`, growing the buffers on
``Pause.LOG_FULL`` and checking for signals, handing on frames and taking
checkpoints on ``Pause.CHUNK_DONE`` (:class:`EventRun`), and builds the
:class:`~granular_chain.result.Result` (:mod:`.report`).

The event log uses the model's numbering (contact i between granules i and
i+1, -1 the left wall, N-1 the right wall).
"""

from __future__ import annotations

import math
import time
from typing import Optional

import numpy as np

from ...checkpoint import CHECKPOINT_FORMAT, check_checkpoint
from ...codes import Pause, Status
from ...errors import SimulationError
from ...frames import Frame, FrameLog
from ...interrupts import CHUNK_SECONDS
from ...ledger import ledger_verdict
from ...model import Model
from ...progress import progress_bar
from ...result import EnergyLedger, Event, Result, ledger_balance
from ...units import (internal_scales, scaled_model, scaled_parameters, speed_scale,
                      unit_factors)
from ..loop import Checkpoints, run_loop
from ..opening import opening_floor, resolved_opening
from .options import EventOptions, event_options
from .output import record_final_frame
from .pack import Packed, pack_run
from .report import build_result

__all__ = ["simulate_events", "checkpoint_state", "EventRun", "check_exponents",
           "MIN_EXPONENT", "MAX_EXPONENT", "next_budget"]

#: Smallest contact exponent the event stepper accepts. Below it the contact force
#: k delta^(n-1) has a derivative growing fast as delta -> 0 and the ledger error
#: grows far beyond the rtol-based promise (measured, two spheres, ledger error /
#: promise at rtol 1e-12: n = 1.01: 2.4e-3 / 3.2e-10; 1.5: 3.5e-10 / 3.1e-10;
#: 1.6: 0.1 of it; 1.75: 0.001 of it; docs/events.md). Verlet takes every n > 1.
MIN_EXPONENT = 1.75
#: Largest contact exponent the event stepper accepts. The error of its Taylor
#: series grows with n: two equal granules at rtol 1e-12 (exact: v1 = 0), ledger
#: error at n = 8, 10, 12, 14, 16, 20: 5.2e-12, 1.2e-11, 2.6e-11, 5.9e-11, 1.3e-10,
#: 6.7e-10, so from n = 16 on the error exceeds 100 rtol and at n = 20 v1 = -3.4e-10
#: names a backscatter the exact answer does not have (docs/events.md). 12 keeps
#: 4x below 100 rtol. Verlet takes larger exponents (n = 30-80) at its default step.
MAX_EXPONENT = 12.0
#: Taylor steps before the pace of a run is judged (its start and first events
#: can take short steps that later ones do not).
PACE_MIN_STEPS = 10_000
#: Main-loop passes of the first kernel call; later calls are sized from the
#: measured wall time (:func:`next_budget`).
FIRST_BUDGET = 64
#: Record groups of the kernel saved in a checkpoint (the buffers are saved live rows only).
_SAVED_GROUPS = ("state", "work")


def check_exponents(model: Model) -> None:
    """Refuse a scene whose contacts (walls included) have an exponent below
    MIN_EXPONENT or above MAX_EXPONENT (SimulationError naming contacts.exponent).

    Parameters
    ----------
    model : Model
        The scene's model; its contact exponents ``n`` and the walls' are
        dimensionless.

    Raises
    ------
    SimulationError
        When an exponent is below MIN_EXPONENT or above MAX_EXPONENT.
    """
    n = [float(x) for x in model.contacts.n[model.contacts.rows()]]
    high = [x for x in n if x > MAX_EXPONENT]
    if high:
        raise SimulationError(
            f"contacts.exponent: the event stepper accepts exponents n <= {MAX_EXPONENT:g}; "
            f"got n = {max(high):g}, for which its energy ledger misses the promised "
            f"tolerance (docs/events.md); use run.stepper: verlet")
    low = [x for x in n if x < MIN_EXPONENT]
    if low:
        raise SimulationError(
            f"contacts.exponent: the event stepper accepts exponents n >= {MIN_EXPONENT} "
            f"(n = 2 exactly, others to run.rtol); got n = {min(low):g}, for which its energy "
            f"ledger misses the promised tolerance (docs/events.md); use run.stepper: verlet")


def unscaled_atol(model: Model, atol: float) -> float:
    """atol for a scene run in its own units (:func:`~granular_chain.units.internal_scales`
    returned None).

    atol is absolute, meant for scaled units (speeds ~ 1). A scene whose scales are
    too extreme to apply (speeds of 1e-94 against a friction stopping them at once)
    runs as given, where an atol of 1e-14 exceeded every velocity and overlap: the
    step control saw nothing, took whole-run steps, and the series of a decaying
    velocity grew its energy 2.5e5-fold (found by hypothesis). It is scaled by the
    speed scale when that is below 1."""
    V = speed_scale(model)
    return atol * V if 0.0 < V < 1.0 else atol


def simulate_events(options, model: Model, log: FrameLog | None = None, *, resume=None,
                    checkpoint=None, checkpoint_every: int = 0,
                    progress: Optional[bool] = None) -> Result:
    """Run the scene with the event stepper in its own scaled units
    (:func:`granular_chain.units.internal_scales`).

    Parameters
    ----------
    options : EventOptions or Scene
        The run's options (:func:`~.options.event_options` of the scene; a Scene
        is read with it here), times in scene units.
    model : Model
        The scene's Model (:func:`granular_chain.simulate.preflight`), in the
        scene's units.
    log : FrameLog, optional
        Where the frames go as the run goes (the scene's units; ``Frame.step`` is
        the frame's number): handed on between kernel calls, so memory does not
        grow with the number of frames when ``log.keep`` is false. Closed with the
        Result at the end. Without it (and without ``resume`` and ``checkpoint``)
        the frames stay in the kernel's buffers and the Result holds them all.
    resume : dict, optional
        A :func:`checkpoint_state` of a run of the same scene: the run continues
        from it; the frames handed on and the end state are those the run would
        have had without the interruption, bit for bit. The Result's frames are
        those handed on after the resume (with ``log.keep`` false: the first and
        latest of the whole run, the checkpoint holds the first).
    checkpoint : callable, optional
        ``checkpoint(state)`` with a :func:`checkpoint_state` dictionary, every
        ``checkpoint_every`` Taylor steps (at the kernel's next return after
        them) and when a signal interrupts the run (before its final frame).
    checkpoint_every : int
        Taylor steps between checkpoints (0: only at an interruption).
    progress : bool, optional
        Progress bar of simulated time, updated between kernel calls
        (:func:`granular_chain.progress.progress_bar`; None: only in a notebook).

    Returns
    -------
    Result
        ``stepper='event'``, in the scene's units: frames (t, x, v, f and the
        energy ledger), the event log, the status and its message;
        ``info['event_stepper']`` holds the Taylor order, tolerances, ledger
        tolerance and the internal scales used.
    """
    check_exponents(model)
    if not isinstance(options, EventOptions):
        options = event_options(options)
    scales = internal_scales(model)
    streamed = log is not None or resume is not None or checkpoint is not None
    if streamed and log is None:
        log = FrameLog()
    kw = dict(log=log, resume=resume, checkpoint=checkpoint, checkpoint_every=checkpoint_every,
              progress=progress)
    if scales is None:
        atol = unscaled_atol(model, options.atol)
        if atol != options.atol:
            options = options._replace(atol=atol)
        return run_packed(options, model, None, **kw)
    M, A, B = scales
    units = unit_factors(M, A, B)

    def in_scene_units(r: Result) -> Result:
        _to_scene_units(r, units, streamed)
        r.info["event_stepper"]["internal_scales"] = {"mass": M, "length": A, "time": B}
        # the ledger in the scene's units (rounded again by the scaling): judged again
        r.status, r.message = ledger_verdict(r, r.info["event_stepper"]["ledger_tolerance"])
        if model.units == "physical":
            r.info["scaled"] = scaled_parameters(model)
        return r

    return run_packed(options.in_time_unit(B), scaled_model(model, M, A, B), units,
                      finish=in_scene_units, **kw)


def _to_scene_units(r: Result, u, streamed: bool) -> None:
    """Put a Result computed in internal units in the scene's (a streamed run's
    frames and ledger already are)."""
    if not streamed:
        led = r.energy
        r.energy = EnergyLedger(kinetic=led.kinetic * u.e, potential=led.potential * u.e,
                                coulomb=led.coulomb * u.e, viscous=led.viscous * u.e,
                                initial=led.initial * u.e,
                                contact_dissipated=led.contact_dissipated * u.e,
                                wall_work=led.wall_work * u.e, body_work=led.body_work * u.e)
        r.t, r.x, r.v, r.f = r.t * u.t, r.x * u.x, r.v * u.v, r.f * u.f
    r.t_final, r.x_final, r.v_final = r.t_final * u.t, r.x_final * u.x, r.v_final * u.v
    r.events = [Event(e.t * u.t, e.kind, e.index) for e in r.events]


def run_packed(options: EventOptions, model: Model, units, log=None, resume=None,
               checkpoint=None, checkpoint_every=0, progress=None, finish=None) -> Result:
    """Run ``model`` (in the kernel's units) with ``options``; ``units`` the factors to
    the scene's own units (:class:`~granular_chain.units.UnitFactors`, None: the same),
    used for the streamed frames and for times in messages. With a ``log`` (or
    ``resume`` or ``checkpoint``) the frames are streamed (:class:`EventRun`);
    ``progress`` as :func:`simulate_events`'. ``finish`` (Result -> Result) puts the
    Result in the scene's units before the log is closed with it.

    Returns
    -------
    Result
        ``stepper='event'``, ``dt=None``; frames at t = 0, at every event batch
        for N <= 64 (longer chains: at the cadence only, to bound memory), at the
        ``output.dt`` cadence (see :func:`~.options.frame_interval`), and at the
        end; ``events`` the full event log; ``steps`` the Taylor steps taken.
    """
    packed = pack_run(model, options, stream=log is not None)
    run = EventRun(packed, log, units, checkpoint, checkpoint_every) if log is not None else None
    return run_loop(EventStepper(packed, run, options, model, units, progress, finish), resume)


class EventStepper:
    """The event stepper as :func:`..loop.run_loop` drives it (its ``Stepper``
    protocol): kernel calls sized to about CHUNK_SECONDS, frames handed on and
    checkpoints taken between them (:class:`EventRun`), the Result at the end.

    Parameters
    ----------
    packed : Packed
        The run's records (kernel units).
    run : EventRun or None
        Its streaming side (None: the frames stay in the kernel's buffers).
    options : EventOptions
        The run's options (kernel units).
    model : Model
        The model the kernel runs (kernel units).
    units : UnitFactors or None
        Factors to the scene's units (None: the same).
    progress : bool or None
        As :func:`simulate_events`'.
    finish : callable(Result) -> Result, optional
        Applied to the Result before it is returned (the scene's units).
    """

    def __init__(self, packed: Packed, run: Optional["EventRun"], options: EventOptions,
                 model: Model, units, progress=None, finish=None):
        self.packed, self.run, self.model, self.finish = packed, run, model, finish
        self.tscale = units.t if units is not None else 1.0
        self.t_end = options.t_end
        self.log = run.log if run is not None else None
        self.bar = progress_bar(progress, options.t_end, scale=self.tscale)
        self.pace = None

    def begin(self, resume: Optional[dict]) -> None:
        """Restore ``resume`` (the first frame is the kernel's own).

        Parameters
        ----------
        resume : dict or None
            A :func:`checkpoint_state` of a run of the same scene.
        """
        if resume is not None:
            self.run.restore(resume)
        self.pace = Pace(self.packed, self.run)

    def advance(self, stop) -> Optional[tuple]:
        """One kernel call and what follows it (:meth:`Pace.call`).

        Parameters
        ----------
        stop : StopRequest
            Whether a signal asks the run to stop.

        Returns
        -------
        tuple or None
            ``(status, message)`` when the run ends (message None: the report words
            it), else None.
        """
        code = self.pace.call(stop)
        if code is None:
            return None
        if code != Status.INTERRUPTED:
            return code, None  # (the report words it)
        return code, (f"stopped by {stop.name} at t = {self.time() * self.tscale:.12g} "
                      f"(t_end = {self.t_end * self.tscale:g}); the result holds the "
                      f"frames computed until then")

    def time(self) -> float:
        """The simulated time reached.

        Returns
        -------
        float
            Kernel units of time (the bar scales it).
        """
        return float(self.packed.clock.time)

    def checkpoint_state(self) -> dict:
        """:func:`checkpoint_state` of the streamed run now.

        Returns
        -------
        dict
            The checkpoint (:func:`checkpoint_state`).
        """
        return checkpoint_state(self.run, self.run.wall + self.pace.elapsed())

    def report(self, status, message: Optional[str], wall: float) -> Result:
        """The Result (:func:`.report.build_result`), in the scene's units.

        Parameters
        ----------
        status : int
            The kernel's end code.
        message : str or None
            The end in words (None: the report's own).
        wall : float
            Seconds of kernel calls in this process.

        Returns
        -------
        Result
            The run, in the scene's units.
        """
        run = self.run
        if run is not None:
            run.flush()
            wall += run.wall
        result = build_result(self.packed, status, wall, self.model, self.tscale, run)
        if message is not None:
            result.message = message
        return self.finish(result) if self.finish is not None else result


def next_budget(budget: int, seconds: float) -> int:
    """Passes for the next kernel call so that it lasts about CHUNK_SECONDS.

    Scaled by the time the last ``budget`` passes took, by at most 4x up and 8x
    down (one slow pass, e.g. a page fault, must not shrink the budget to nothing).

    Parameters
    ----------
    budget : int
        Main-loop passes of the last call, >= 1.
    seconds : float
        Wall time the last call took, seconds (<= 0: the budget is multiplied by 4).

    Returns
    -------
    int
        The next call's passes, in [budget / 8, 4 budget] and >= 1.
    """
    if seconds <= 0.0:
        return 4 * budget
    scaled = budget * (0.5 * CHUNK_SECONDS / seconds)  # aim at half: passes vary
    return int(min(max(scaled, budget / 8.0, 1.0), 4.0 * budget, 1 << 40))


class Pace:
    """Kernel calls one at a time, each sized to return within about CHUNK_SECONDS.

    With a :class:`~granular_chain.interrupts.StopRequest`, each call makes a
    bounded number of main-loop passes and a requested stop ends the run with
    Status.INTERRUPTED between calls; the kernel resumes from its records, so the
    trajectory is the same bit for bit as in one call. With an :class:`EventRun`,
    the frames recorded by each call are handed on between calls and checkpoints
    are taken (:meth:`EventRun.between`), and the pace counters start from the run's.
    A run that cannot reach t_end within run.max_steps at its pace ends with
    Status.MAX_STEPS (``packed.out_of_steps``).

    Parameters
    ----------
    packed : Packed
        The run's records.
    run : EventRun or None
        Its streaming side.
    """

    def __init__(self, packed: Packed, run: Optional["EventRun"] = None):
        self.packed, self.run = packed, run
        self.budget = FIRST_BUDGET if run is None else run.budget
        clock = packed.clock
        self.mark = (float(clock.time), int(clock.steps)) if run is None else run.mark
        self.start = time.perf_counter()

    def elapsed(self) -> float:
        """Seconds since the first call.

        Returns
        -------
        float
        """
        return time.perf_counter() - self.start

    def call(self, stop=None) -> Optional[int]:
        """One kernel call and what follows it.

        Parameters
        ----------
        stop : StopRequest, optional
            Whether a signal asks the run to stop (None: one unbounded call).

        Returns
        -------
        int or None
            The run's end code, or None while it goes on.
        """
        packed, run = self.packed, self.run
        settings = packed.records.settings
        if stop is None:
            settings["budget"] = 0
        else:
            settings["budget"] = self.budget if run is None else run.passes(self.budget)
        t0 = time.perf_counter()
        code = packed.call()
        if code == Pause.LOG_FULL:
            if run is not None:
                run.flush()  # (the kernel resumes a step cut short by a full buffer)
            grow_buffers(packed)
        elif code == Pause.CHUNK_DONE:
            self.budget = next_budget(self.budget, time.perf_counter() - t0)
            if _out_of_steps(packed, self.mark):
                packed.out_of_steps = True
                _final_frame(packed)
                return self._end(Status.MAX_STEPS)
            clock = packed.clock
            self.mark = (float(clock.time), int(clock.steps))
        elif code == Status.SEPARATED and not _opening_resolved(packed):
            pass  # the overlap decayed through roundoff: the run goes on
        else:
            return self._end(code)
        interrupted = stop is not None and stop.requested
        if run is not None:
            run.between(self.budget, self.mark, self.elapsed(), interrupted)
        if interrupted:
            _final_frame(packed)
            return self._end(Status.INTERRUPTED)
        return None

    def _end(self, code) -> int:
        self.packed.records.settings["budget"] = 0
        return int(code)


def drive(packed: Packed, stop=None):
    """Call the kernel until it returns a Status (:class:`Pace`, no streaming): the
    collision maps' loop. Returns the code and the wall time (seconds)."""
    pace = Pace(packed)
    code = None
    while code is None:
        code = pace.call(stop)
    return code, pace.elapsed()


def _opening_resolved(packed: Packed) -> bool:
    """Whether the watched contact's opening the kernel stopped at is resolved
    (:func:`~granular_chain.steppers.opening.resolved_opening`: the kernel carries the
    overlap itself, so only the speeds' roundoff counts); an unresolved one is kept
    in ``packed.roundoff`` as (time, speed over its floor), for the end message."""
    j = int(packed.settings.watch)
    v = packed.records.state.v
    w = float(v[j] - v[j - 1])
    floor = opening_floor((v[j - 1], v[j]))
    if resolved_opening(w, floor):
        return True
    if packed.roundoff is None:
        packed.roundoff = (float(packed.clock.time), w / floor)
    return False


def _out_of_steps(packed: Packed, mark) -> bool:
    """True when t_end cannot be reached within run.max_steps even at the faster of
    two paces: the mean step over the run so far and over the last kernel call
    (``mark`` = (t, steps) at its start). Judged only after PACE_MIN_STEPS steps.

    The event stepper's steps are bounded by the fastest time scale of the mode
    (n = 2: a quarter of 1/(drag rate + contact rate); other n: the series'
    radius): an overdamped scene, drag rate gamma/m far above every contact
    rate, creeps on the slow time scale gamma/k and would need t_end gamma/m
    steps. Such a run ends at once with Status.MAX_STEPS and the numbers, not
    after hours. Sets ``packed.projection``.
    """
    clock, settings = packed.clock, packed.settings
    steps = int(clock.steps)
    if steps < PACE_MIN_STEPS or steps <= mark[1]:
        return False
    t = float(clock.time)
    pace = max(t / steps, (t - mark[0]) / (steps - mark[1]))
    left = int(settings.max_steps) - steps
    need = (float(settings.t_end) - t) / pace if pace > 0.0 else math.inf
    if need <= left:
        return False
    packed.projection = (need, pace)
    return True


def _final_frame(packed: Packed) -> None:
    """Record a frame at the state an interrupted run reached (kernel state is
    consistent between calls), unless the last frame is already there."""
    clock = packed.clock
    nfr = int(clock.n_frames)
    if packed.records.frames.t[nfr - 1] == clock.time:
        return
    if packed.records.frames.t.size - nfr < 1:
        grow_buffers(packed)
    rec = packed.records
    record_final_frame(packed.law, rec.clock, rec.model, rec.state, rec.frames)


def _grow(a: np.ndarray, n: int) -> np.ndarray:
    b = np.zeros((n,) + a.shape[1:], dtype=a.dtype)
    b[: a.shape[0]] = a
    return b


def grow_buffers(packed: Packed) -> None:
    """Grow whichever buffer is short (doubling), replacing it in ``packed.records``:
    the state lives in the records, so the kernel called again resumes where it
    stopped."""
    rec = packed.records
    clock = packed.clock
    N = rec.state.u.size
    frames, log = rec.frames, rec.log
    if frames.t.size - clock.n_frames < 8:
        n2 = 2 * frames.t.size
        frames = type(frames)(*(_grow(a, n2) for a in frames))
    if log.t.size - clock.n_events < 2 * N + 8:
        n2 = 2 * log.t.size
        log = log._replace(t=_grow(log.t, n2), kind=_grow(log.kind, n2),
                           index=_grow(log.index, n2))
    packed.records = rec._replace(frames=frames, log=log)


class EventRun:
    """The driver's side of an event run whose frames are streamed.

    Between kernel calls the frames the kernel recorded since the last call are
    handed to ``log`` (in the scene's units: exactly the numbers the Result of
    an unstreamed run holds) and the frame buffers are emptied but for their
    last frame, whose time the kernel reads; the event log stays in memory (a
    few numbers an event, not frames). Checkpoints (:func:`checkpoint_state`)
    go to ``checkpoint`` every ``checkpoint_every`` Taylor steps and when the
    run is interrupted.

    Parameters
    ----------
    packed : Packed
        The run's records (kernel units).
    log : FrameLog
        Receives the frames, in the scene's units.
    units : UnitFactors or None
        Factors from kernel units to the scene's (None: the same units).
    checkpoint : callable, optional
        ``checkpoint(state)`` with a :func:`checkpoint_state` dictionary.
    checkpoint_every : int
        Taylor steps between checkpoints (0: only at an interruption).
    """

    def __init__(self, packed: Packed, log: FrameLog, units, checkpoint=None,
                 checkpoint_every: int = 0):
        self.packed, self.log, self.units = packed, log, units
        self.checkpoints = Checkpoints(log, checkpoint)
        self.every = int(checkpoint_every) if checkpoint is not None else 0
        self.handed = 0  #: rows of the frame buffers already handed on
        self.frames = 0  #: frames handed on over the whole run (Frame.step)
        self.pe0 = math.nan  #: elastic energy of the first frame (kernel units)
        self.balance = 0.0  #: largest |ledger balance| over the frames (kernel units)
        self.budget, self.mark = FIRST_BUDGET, (float(packed.clock.time), 0)
        self.next_checkpoint = self.every
        self.wall = 0.0  #: wall time of the kernel calls before a resume
        self.resumed = False

    def passes(self, budget: int) -> int:
        """The work budget of the next call: ``budget``, cut so that the call returns
        at the next checkpoint (the trajectory does not depend on where calls end).

        Parameters
        ----------
        budget : int
            Main-loop passes the driver would give the call.

        Returns
        -------
        int
            Passes for the call, >= 1 (``budget`` itself without checkpoints).
        """
        if self.every <= 0:
            return budget
        left = self.next_checkpoint - int(self.packed.clock.steps)
        return int(min(budget, max(left, 1)))

    def between(self, budget: int, mark, wall: float, interrupted: bool) -> None:
        """After a kernel call: hand on its frames, checkpoint when due or interrupted.

        Parameters
        ----------
        budget : int
            The driver's current pass budget (saved in a checkpoint).
        mark : tuple of (float, int)
            (time in kernel units, steps) at the start of the pace window.
        wall : float
            Wall time of the kernel calls of this session so far, seconds.
        interrupted : bool
            A signal stops the run: a checkpoint is taken now.
        """
        self.budget, self.mark = budget, mark
        self.flush()
        steps = int(self.packed.clock.steps)
        due = self.every > 0 and steps >= self.next_checkpoint
        if due:
            self.next_checkpoint = steps + self.every
        if due or interrupted:
            self.checkpoints.write(lambda: checkpoint_state(self, self.wall + wall, interrupted))

    def flush(self) -> None:
        """Hand on the frames recorded since the last flush; keep the last one in row 0."""
        pk = self.packed
        nfr = int(pk.clock.n_frames)
        if nfr == 0:
            return
        frames = pk.records.frames
        fr_e = frames.e
        if self.frames == 0 and self.handed == 0:
            self.pe0 = float(fr_e[0, 1])
        e0 = pk.ke0 + self.pe0
        if nfr > self.handed:
            block = fr_e[self.handed:nfr]
            # the ledger error in kernel units, as EnergyLedger.balance_error forms it
            cols = [block[:, c] for c in range(7)]
            worst = float(np.max(np.abs(ledger_balance(*cols, e0))))
            if not math.isnan(self.balance) and not worst <= self.balance:
                self.balance = worst
        self._hand_on(self.handed, nfr, e0)
        if nfr > 1:
            for buf in frames:
                buf[0] = buf[nfr - 1]
            pk.records.clock["n_frames"] = 1
        self.handed = 1

    def _hand_on(self, lo: int, hi: int, e0: float) -> None:
        """Rows lo..hi-1 of the frame buffers to the log, in the scene's units."""
        frames, u, record = self.packed.records.frames, self.units, self.log.record
        xs, vs, fs = frames.x, frames.v, frames.f
        ts, es = frames.t[lo:hi].tolist(), frames.e[lo:hi].tolist()  # exact floats
        if u is not None:
            e0 = e0 * u.e
        for q in range(lo, hi):
            t, (ke, pe, wc, wv, wd, ww, wb) = ts[q - lo], es[q - lo]
            x, v, f = xs[q], vs[q], fs[q]
            if u is not None:
                t, x, v, f = t * u.t, x * u.x, v * u.v, f * u.f
                ke, pe, wc, wv = ke * u.e, pe * u.e, wc * u.e, wv * u.e
                wd, ww, wb = wd * u.e, ww * u.e, wb * u.e
            record(Frame(self.frames, t, x, v, f, ke, pe, wc, wv, e0, wd, ww, wb))
            self.frames += 1

    def restore(self, state: dict) -> None:
        """Continue from ``state`` (:func:`checkpoint_state` of a run of the same scene).

        Parameters
        ----------
        state : dict
            The checkpoint dictionary (arrays in kernel numbering and units).

        Raises
        ------
        ValueError
            When ``state`` is not a checkpoint of this format, or its arrays do not
            fit the scene's.
        """
        state = check_checkpoint(state, "event")
        pk = self.packed
        rec = pk.records
        _restore_array(rec.clock, state["k_clock"], "clock")
        for group in _SAVED_GROUPS:
            for name, old in getattr(rec, group)._asdict().items():
                _restore_array(old, state[f"k_{group}_{name}"], f"{group}.{name}")
        _restore_array(rec.log.counts, state["events_counts"], "log.counts")
        live = int(pk.clock.n_frames)
        rows = max(rec.frames.t.shape[0], 2 * live + 16)
        frames = {name: _grown_copy(state["frames_" + name], old, rows, live)
                  for name, old in rec.frames._asdict().items()}
        live = int(pk.clock.n_events)
        rows = max(rec.log.t.shape[0], 2 * live + 16)
        log = {name: _grown_copy(state["events_" + name], getattr(rec.log, name), rows, live)
               for name in ("t", "kind", "index")}
        rec = rec._replace(frames=rec.frames._replace(**frames), log=rec.log._replace(**log))
        pk.records = rec
        self.handed, self.frames = int(state["handed"]), int(state["frames"])
        self.pe0, self.balance = float(state["pe0"]), float(state["kernel_balance"])
        self.budget = int(state["budget"])
        self.mark = (float(state["mark_t"]), int(state["mark_steps"]))
        steps = int(pk.clock.steps)
        self.next_checkpoint = steps + self.every if self.every > 0 else 0
        self.wall = float(state["wall_time"])
        self.resumed = True
        self.log.restore(state)


def _grown_copy(saved, old: np.ndarray, rows: int, live: int) -> np.ndarray:
    """A buffer like ``old`` with ``rows`` rows, its first ``live`` the saved ones."""
    buf = np.zeros((rows,) + old.shape[1:], dtype=old.dtype)
    buf[:live] = saved
    return buf


def _restore_array(old: np.ndarray, saved, name: str) -> None:
    """Copy a checkpointed array into the kernel's array of the same shape."""
    new = np.asarray(saved)
    if new.shape != old.shape or new.dtype != old.dtype:
        raise ValueError(f"checkpoint: {name} has shape {new.shape} ({new.dtype}), the scene "
                         f"gives {old.shape} ({old.dtype}) (another scene?)")
    old[...] = new


def checkpoint_state(run: EventRun, wall: float = 0.0, interrupted: bool = False) -> dict:
    """Everything an event run needs to continue exactly (plain numpy arrays and
    Python scalars, for ``numpy.savez``).

    Parameters
    ----------
    run : EventRun
        The streamed run, between kernel calls.
    wall : float
        Wall time of its kernel calls so far, seconds.
    interrupted : bool
        Taken because a signal stops the run.

    Returns
    -------
    dict
        The keys every checkpoint has (:mod:`granular_chain.checkpoint`: ``format``,
        ``stepper`` "event", the frame log's ``log_*``), then the run's own:
        ``steps`` (steps taken); ``k_clock`` the kernel's clock
        record (:data:`~.records.CLOCK_DTYPE`: time, step, event and frame counts,
        the cadence position...); ``k_<group>_<field>`` every array of the kernel's
        ``state`` and ``work`` records (positions ``k_state_u``,
        velocities ``k_state_v``, overlaps, contact and friction modes, the kept
        moving set, ...); the live rows of the frame buffers ``frames_t, frames_x,
        frames_v, frames_f, frames_e`` (the last frame, already handed on) and the
        event log so far ``events_t, events_kind, events_index``, ``events_counts`` (kernel
        numbering and units); the driver's counters ``handed``, ``frames`` (frames
        handed on so far), ``pe0``, ``kernel_balance``, ``budget``, ``mark_t``,
        ``mark_steps``, ``wall_time`` (seconds of kernel calls so far),
        ``interrupted`` (taken because a signal stops the run).
    """
    pk = run.packed
    rec = pk.records
    state = {"format": CHECKPOINT_FORMAT, "stepper": "event", "steps": int(pk.clock.steps),
             "k_clock": np.array(rec.clock)}
    for group in _SAVED_GROUPS:
        for name, arr in getattr(rec, group)._asdict().items():
            state[f"k_{group}_{name}"] = np.array(arr)
    nfr, nev = int(pk.clock.n_frames), int(pk.clock.n_events)
    for name, arr in rec.frames._asdict().items():
        state["frames_" + name] = np.array(arr[:nfr])
    for name in ("t", "kind", "index"):
        state["events_" + name] = np.array(getattr(rec.log, name)[:nev])
    state["events_counts"] = np.array(rec.log.counts)
    state.update(handed=run.handed, frames=run.frames, pe0=run.pe0,
                 kernel_balance=run.balance, budget=int(run.budget),
                 mark_t=float(run.mark[0]), mark_steps=int(run.mark[1]), wall_time=float(wall),
                 interrupted=bool(interrupted))
    state.update(run.log.checkpoint_state())
    return state
