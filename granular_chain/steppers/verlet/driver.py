"""The Verlet driver: compiled chunks of steps between output frames.

Python runs only between compiled calls (:mod:`.kernel`): it
records frames (handing them to the writers attached to the run), checks the
state for NaN/Inf, runaway energy and passing granules at the output cadence,
prints thermo lines, updates the progress bar, honours stop requests (SIGINT,
SIGTERM) and decides when to stop. A call runs to the next frame or for about
:data:`~granular_chain.interrupts.CHUNK_SECONDS`, whichever comes first; where
calls end never changes the trajectory.

When the writers have a thread of their own and the frames are not kept in
memory (outside forced scenes and ``output.events``), a frame of the cadence is
only copied here and stepping goes on; that thread makes and checks it
(:meth:`VerletRun._defer`). A frame that ends the run there ends it as a check
at once would have: same status, message, step, time, frames and event counts.
"""

from __future__ import annotations

import math
import time
from functools import partial
from typing import NamedTuple, Optional

import numpy as np

from ..._compile import specialised
from ...checkpoint import CHECKPOINT_FORMAT, check_checkpoint
from ...codes import EVENT_KINDS, EventKind, Pause, Status
from ...errors import SimulationError
from ...forces import net_forces
from ...frames import Frame, FrameLog, RunEnds
from ...interrupts import CHUNK_SECONDS
from ...laws.friction import drift_tables
from ...model import Model
from ...progress import progress_bar
from ...result import OVERLAP_ADVICE, TERMS_ADDED, EnergyLedger, Event, Result, ledger_balance
from ...units import scaled_parameters
from ..opening import opening_floor, resolved_opening, roundoff_note
from ..loop import Checkpoints, run_loop
from ..schedule import Schedule
from .event_log import EventLog, new_event_log
from .forced import forced_chunk
from .forced_setup import FORCED_STATE_ARRAYS, body_work, forced_records, is_forced, walls_at
from .frame_scan import (CONTACT_PASSED, LEFT_WALL_PASSED, NO_PROBLEM, FrameArrays, Scan,
                         ScanCodes, scan_frame, settle_frame, stash_state)
from .kernel import chunk_kernel, synchronise
from .records import (PER_GRANULE, STOP_ON_REST, STOP_ON_SEPARATION, UNIFORM, UNIT, Call, Chain,
                      Features, State, Timestep)
from .timestep import STABILITY_FRACTION, check_dt, step_plan

__all__ = ["VerletRun"]

_UNSTABLE_BALANCE = 1.0


def _drift_coefficients(model: Model, dt: float):
    cv = model.gamma * model.inv_mass
    E, P1, P2 = np.empty_like(cv), np.empty_like(cv), np.empty_like(cv)
    drift_tables(cv, dt, E, P1, P2)
    return E, P1, P2


def _net_forces(model: Model, u, c, f, d0=None):
    """Contact forces c (N+1,, the table's rows) and net forces f (N,) at displacements
    u; ``d0`` (N+1,) replaces the contact table's initial overlaps when given."""
    feat, t = model.features, model.contacts
    args = (feat.law, int(feat.left_wall), int(feat.right_wall), u,
            t.d0 if d0 is None else d0, t.k, t.n, c, f)
    specialised(net_forces, args, (0, 1, 2))(*args)



class VerletRun:
    """One velocity-Verlet run of a model: built once, then :meth:`run`.

    Parameters
    ----------
    scene : Scene
        Its ``run`` (t_end, stop conditions, max_steps) and ``output`` (cadence).
    model : Model
        The packed chain (:func:`granular_chain.model.build_model`).
    progress : bool, optional
        Progress bar (default: on a terminal, for runs longer than ~2 s).
    log : FrameLog, optional
        Where the output frames go; default: all kept in memory, no writers.
    thermo : writer with ``every`` (steps) and ``write_frame(frame)``, optional
        Called on its own cadence (LAMMPS' ``thermo N``), besides the frames.
    checkpoint : callable(dict), optional
        Given the run's state (:meth:`checkpoint_state`) every ``checkpoint_every``
        steps, once the writers have every frame so far on disk, and when the run
        is interrupted; :meth:`run` with that state continues the run bit for bit.
    checkpoint_every : int, optional
        Steps between checkpoints (None: only at an interruption).
    end_checkpoint : bool
        Also checkpoint at the last frame of the cadence before the run's last whole
        step (:attr:`end_ck`): a run to a later t_end passes through that state, so
        the finished run can be extended from it (``granular-chain run --restart``).
    schedule : Schedule, optional
        The run's :class:`~granular_chain.steppers.schedule.Schedule` (its step plan);
        worked out here when not given.
    """

    def __init__(self, scene, model: Model, progress: Optional[bool] = None,
                 log: Optional[FrameLog] = None, thermo=None, checkpoint=None,
                 checkpoint_every: Optional[int] = None, end_checkpoint: bool = False,
                 schedule: Optional[Schedule] = None):
        settings = scene.run
        self.model, self.thermo = model, thermo
        self.checkpoint_every = checkpoint_every
        self.next_ck = None
        self.T = model.shortest_period()  # period or collision time of the stiffest contact
        self.log = log if log is not None else FrameLog()
        self.checkpoints = Checkpoints(self.log, checkpoint)
        self.plan = plan = step_plan(model, scene) if schedule is None else schedule.plan
        if settings.check_dt:
            check_dt(model, plan.dt)
        self.t_end, self.max_steps = settings.t_end, settings.max_steps
        self.limited = plan.steps > settings.max_steps
        self.n_total = min(plan.steps, settings.max_steps)
        self.last_dt = 0.0 if self.limited else plan.last_dt
        # The end checkpoint: the last frame of the cadence before the last whole step.
        # A run to a later t_end takes the same steps and frames up to there; the last
        # whole step itself may not be (its time is t_end, and the shortened step and
        # the final frame follow it).
        self.end_ck = max(0, (plan.steps - 1) // plan.every * plan.every) \
            if end_checkpoint and checkpoint is not None else -1
        stops = settings.stop_conditions
        self.stop_mode = (STOP_ON_SEPARATION if "separation" in stops else 0) | (
            STOP_ON_REST if "rest" in stops else 0)
        self.stop_contact = settings.stop_contact if model.count > 1 else 0
        self.log_events = int(scene.output.events)
        self.roundoff_note = ""  # an opening of the watched contact below roundoff, in words
        self._init_state()
        self.bar = progress_bar(progress, self.t_end)

    def _init_state(self) -> None:
        model, N, dt = self.model, self.model.count, self.plan.dt
        self.u, self.v, self.f = np.zeros(N), model.v0.copy(), np.zeros(N)
        c = np.zeros(N + 1)
        _net_forces(model, self.u, c, self.f)
        active = (c[1:N] > 0).astype(np.uint8)  # the contacts between granules
        if active.size == 0:
            active = np.zeros(1, dtype=np.uint8)
        E, P1, P2 = _drift_coefficients(model, dt)
        self.ledger, self.counts = np.zeros(2), np.zeros(4, dtype=np.int64)
        # With Coulomb friction the kernel merges kicks (leapfrog form) and v holds
        # half-step velocities between calls; vs gets the synchronised ones for the
        # frames, and sync the half kick's work and counts that the ledger and the
        # counts lack at the frame's time.
        # A forced scene (dashpots, body forces, driven walls) runs the forced
        # kernel, which keeps v synchronised (its dashpot forces need them).
        self.forced = is_forced(model)
        if self.forced and self.log_events:
            raise SimulationError(
                "output.events: the event log is not available yet for scenes with "
                "contacts.damping, body_force or moving walls; leave it out")
        self.merged = bool(model.features.coulomb) and not self.forced
        self.vs = self.v.copy() if self.merged else self.v  # synchronised at t = 0
        self.sync = (0.0, 0, 0)
        feat = model.features
        self.event_log = EventLog(N, self.merged, dt, self.plan.steps, self.t_end) \
            if self.log_events else None
        self.features = Features(
            law=int(feat.law), coulomb=int(feat.coulomb), viscous=int(feat.viscous),
            left_wall=int(feat.left_wall), right_wall=int(feat.right_wall),
            stop_mode=self.stop_mode, uniform=_uniform_code(model, feat, E, P1, P2),
            log_events=self.log_events)
        table = model.contacts
        self.chain = Chain(table.d0, table.k, table.n, model.mass, model.inv_mass,
                           model.eta, model.eta_static, *_overlap_caps(model))
        self.timestep = Timestep(dt, E, P1, P2)
        self.state = State(self.u, self.v, self.f, active, self.ledger, self.counts)
        self.opening = 1  # the next call opens the leapfrog (Coulomb runs): v is synchronised
        self.buffers = self.event_log.buffers if self.event_log else new_event_log(N, 0, 0)
        self._call_key = self._call_records = None  # the last call's (steps, opening) and records
        if self.forced:
            self.forced_features, self.forcing, self.fstate = forced_records(
                model, self.state, self.stop_mode)
            self.kernel = specialised(forced_chunk, self._records(self._control(1)), (0,))
        else:
            self.kernel = specialised(chunk_kernel(self.features),
                                      self._records(self._control(1)), (0,))
        self._scan_codes = ScanCodes(int(feat.law), int(feat.left_wall), int(feat.right_wall))
        self._v2 = np.empty(N)
        self._d0_now = table.d0.copy()  # the table's d0 with driven walls where they are
        x = np.empty(N)
        self._scanner = specialised(scan_frame, (
            self._scan_codes, self.chain, table.d0, self.u, self.vs, self.f, model.x0,
            FrameArrays(x, x, x, self._v2), 1), (0,))
        # A run whose writers have a thread of their own hands each frame of the
        # cadence to it as a copy of the state, and steps on (see _defer). Only when
        # the log reuses its frame arrays: waiting for one bounds how far the stepping
        # runs ahead of the frames handed on (a log that keeps every frame would let
        # it run on past a frame that ends the run). Forced scenes and the event log
        # make every frame here.
        self.deferring = (self.log.background and not self.log.keep and not self.forced
                          and self.event_log is None)
        if self.deferring:
            frame_arrays = FrameArrays(x, x, x, x)
            self._stash = specialised(stash_state, (self.u, self.vs, self.f, frame_arrays), ())
            self._settle_v2 = np.empty(N)  # (the writers' thread's work array)
            self._settler = specialised(settle_frame, (
                self._scan_codes, self.chain, table.d0, model.x0, frame_arrays), (0,))
        ke0, pe0 = model.energies(self.u, self.v)
        self.e0 = ke0 + pe0
        self.steps, self.t_now, self.dt_now = 0, 0.0, dt
        self.short_taken = False

    def frame(self, scan: Optional[Scan] = None) -> Frame:
        """The synchronised state at the current time, with its ledger, in arrays
        lent by the frame log (``scan``: this state's :meth:`scan`, when already made).

        Parameters
        ----------
        scan : Scan, optional
            The scan of the current state; made when None.

        Returns
        -------
        Frame
            Step count, time, positions x0 + u, velocities, forces (shape (N,),
            scene units) and the ledger terms.
        """
        scan = scan if scan is not None else self.scan()
        x, v, f = self.log.lend(self.model.count)
        ke, pe = scan.kinetic, scan.potential
        if self.forced:
            return Frame(self.steps, self.t_now, x, v, f, ke, pe,
                         self.ledger[0], self.ledger[1], self.e0, *self._added_terms())
        return self._unforced_frame(self.steps, self.t_now, x, v, f, scan, self.ledger,
                                    self.sync)

    def _unforced_frame(self, steps, t_now, x, v, f, scan: Scan, ledger, sync) -> Frame:
        """A frame of a scene without forcing: the Coulomb work dissipated by ``t_now``
        is the ledger's less the synchronising half kick's, not yet taken (merged
        kicks; 0 otherwise)."""
        return Frame(steps, t_now, x, v, f, scan.kinetic, scan.potential,
                     ledger[0] - sync[0], ledger[1], self.e0)

    def scan(self, reach: bool = True) -> Scan:
        """Read the state off in one compiled call (:func:`.frame_scan.scan_frame`).

        Parameters
        ----------
        reach : bool
            Look for centres that met or a granule past a wall (False after a
            kernel call that ended with Pause.CHUNK_DONE: the kernel found none).

        Returns
        -------
        Scan
            The checks (first non-finite granule, a passed contact or wall) and the
            kinetic and elastic energies (scene units, the walls where they are at
            t_now); the frame's arrays are written into those the frame log lends.
        """
        x, v, f = self.log.lend(self.model.count)
        return Scan(*self._scanner(self._scan_codes, self.chain,
                                   walls_at(self.model, self.t_now, self._d0_now),
                                   self.u, self.vs, self.f, self.model.x0,
                                   FrameArrays(x, v, f, self._v2), int(reach)))

    def _added_terms(self):
        """(contact_dissipated, wall_work, body_work) now (forced scenes)."""
        return (float(self.fstate.work[0]), float(self.fstate.work[1]),
                body_work(self.model, self.u))

    def run(self, resume: Optional[dict] = None) -> Result:
        """Step to t_end or a stop condition (:func:`..loop.run_loop`); the Result.

        ``resume``: a state from :meth:`checkpoint_state` of the same scene; the
        run goes on from it as if it had never stopped (its writers must have
        been reopened at the checkpoint's frame and thermo line).

        Parameters
        ----------
        resume : dict, optional
            A checkpoint state (numpy arrays and numbers) to continue from.

        Returns
        -------
        Result
            The run's frames, ledger, final state and status, scene units.
        """
        return run_loop(self, resume)

    def begin(self, resume: Optional[dict]) -> None:
        """Record the first frame (and thermo line), or restore ``resume``; set the
        triggers: the next frame, thermo line and checkpoint.

        Parameters
        ----------
        resume : dict or None
            A :meth:`checkpoint_state` of a run of the same scene.
        """
        if resume is None:
            first = self.frame()
            self.log.record(first)
            if self.thermo is not None:
                self.thermo.write_frame(first)
            self._frame_after(0)
            self.next_thermo = self.thermo.every if self.thermo is not None else math.inf
            self._init_checkpoints()
            if self.end_ck == 0:
                self._checkpoint()
        else:
            # the frames before the checkpoint are in the writers' files, not here: the
            # Result keeps the first and the latest, and the ledger error over them all
            self.log.keep = False
            self._restore(resume)
        self.thermo_every = self.thermo.every if self.thermo is not None else 0
        self.chunk = _Chunk(self.model.count)
        self.ck_every = self.checkpoint_every or 0
        if not self.ck_every:
            self.next_ck = math.inf
        # The kernel reads rest off a kick only after a call's first step: a Coulomb
        # run that stops at rest is tested here at the end of every call, wherever
        # calls end, so its stop step does not depend on them.
        self.rest_watch = self.merged and bool(self.stop_mode & STOP_ON_REST)

    def time(self) -> float:
        """The simulated time reached.

        Returns
        -------
        float
            Scene units of time.
        """
        return self.t_now

    def report(self, status, message: str, wall: float) -> Result:
        """The Result of the run.

        Parameters
        ----------
        status : Status
            How the run ended.
        message : str
            The end in words.
        wall : float
            Seconds of stepping in this process.

        Returns
        -------
        Result
            Frames, ledger, final state and status (scene units).
        """
        self.counts[EventKind.STOP] += self.sync[1]
        self.counts[EventKind.SLIP] += self.sync[2]
        result = _assemble(self.log, self.model, self.e0, status, message, self.steps,
                           wall, self.plan.dt, self.counts)
        if self.event_log is not None:
            result.events = self.event_log.commit()  # with the last half kick's
        if self.plan.note:
            result.info.setdefault("warnings", []).append(self.plan.note)
        return result

    def _init_checkpoints(self) -> None:
        """The checkpoint cadence of a run that starts (a resumed one has its own)."""
        ck_every = self.checkpoint_every or 0
        self.next_ck = self.steps + ck_every if ck_every else math.inf

    def _frame_after(self, steps: int) -> None:
        """The next frame of the cadence after a frame at ``steps``: ``frame_due``,
        and ``next_frame`` that one or the run's last step, whichever is first."""
        self.frame_due = steps + self.plan.every
        self.next_frame = min(self.frame_due, self._last_step())

    def advance(self, stop) -> Optional[tuple]:
        """One compiled call, to the next frame, thermo line or checkpoint, or for about
        CHUNK_SECONDS, whichever is first, and what is due after it.

        Parameters
        ----------
        stop : StopRequest
            Whether a signal asks the run to stop (:func:`..loop.run_loop`'s).

        Returns
        -------
        tuple or None
            ``(status, message)`` when the run ends here, else None.
        """
        if not (self.steps < self.n_total or (self.last_dt and not self.short_taken)):
            return self._end()
        if self.steps == self.n_total:  # one shorter step ends the run exactly at t_end
            self._begin_short_step()  # (next_frame is already its end: _last_step)
        target = min(self.next_frame, self.next_thermo, self.next_ck,
                     self.steps + self.chunk.steps, self.n_total)
        code = self._advance(self.chunk, int(target) - self.steps)
        if code == Status.SEPARATED and not self._opening_resolved():
            code = _CHUNK_DONE  # the overlap decayed through roundoff: the run goes on
        if self.deferring and self.log.ended is not None:  # a frame handed on ended the run
            return self._drained()
        if self.rest_watch:
            code = self._synchronise(code)
        at_frame = self.steps >= self.next_frame or code != _CHUNK_DONE or stop.requested
        at_thermo = self.steps >= self.next_thermo
        at_ck = self.steps >= self.next_ck
        at_end_ck = self.steps == self.end_ck
        if self.deferring and at_frame and code == _CHUNK_DONE and not (
                at_thermo or at_ck or at_end_ck or stop.requested or self._finished()):
            if not self.rest_watch:
                self._synchronise(code)
            self._defer()
            return None
        if self.deferring and (at_frame or at_thermo or at_ck or at_end_ck):
            # what follows reads the frames handed on: they are all made first
            ended = self._drained()
            if ended is not None:
                return ended
        if at_frame or at_thermo:
            done = self._frame_due(code, at_frame, at_thermo, stop)
            if done is not None:
                return done
        if at_ck:  # (the cadence moves on first: the state saved holds the next one)
            self.next_ck = self.steps + self.ck_every
        if at_ck or at_end_ck:
            self._checkpoint()
        return None

    def _frame_due(self, code: int, at_frame: bool, at_thermo: bool, stop) -> Optional[tuple]:
        """Check the state and make the frame of a frame or thermo line due after a
        call; (status, message) when the run ends here."""
        if not self.rest_watch:
            code = self._synchronise(code)
        ended, scan = self._check(code)
        if ended is not None and ended[0] in (Status.NONFINITE, Status.OVERLAP,
                                              Status.UNSTABLE):
            return ended
        frame = self.frame(scan)
        if self.thermo is not None and (at_thermo or ended is not None):
            self.thermo.write_frame(frame)
            self.next_thermo = self.steps + self.thermo_every if self.thermo_every else math.inf
        if at_frame:
            return self._at_frame(frame, ended, stop)
        return None

    def _end(self) -> tuple:
        """(status, message) of a run that has taken every step of its plan."""
        ended = self._drained() if self.deferring else None
        if ended is not None:
            return ended
        if self.limited:
            return Status.MAX_STEPS, (
                f"stopped after run.max_steps = {self.max_steps} steps at t = {self.t_now:.6g} "
                f"before t_end = {self.t_end:g}; raise run.max_steps or run.dt")
        shortened = f" (the last one shortened to {self.last_dt:.6g})" if self.short_taken else ""
        return Status.T_END, (f"reached t_end = {self.t_now:.12g} after {self.steps} "
                              f"steps{shortened}{self.roundoff_note}")

    def _opening_resolved(self) -> bool:
        """Whether the watched contact's opening in the last step is resolved
        (:func:`~granular_chain.steppers.opening.resolved_opening`); an unresolved one
        is noted in :attr:`roundoff_note` (the run's end message)."""
        i, u, v = self.stop_contact, self.u, self.v
        w = v[i + 1] - v[i]
        floor = opening_floor((v[i], v[i + 1]), (self.model.d0[i], u[i], u[i + 1]), self.dt_now)
        if resolved_opening(w, floor):
            return True
        if not self.roundoff_note:
            self.roundoff_note = roundoff_note(i, self.t_now, w / floor)
        return False

    def _at_frame(self, frame: Frame, ended, stop):
        """Record a frame; (status, message) when the run ends here, else None.

        A stop request between two frames of the cadence checkpoints the run before
        its extra frame is recorded, so a run continued from it writes the frames of
        the cadence only, as the run that was never stopped.
        """
        finished = self._finished()
        if finished:
            stop = _NO_STOP  # every step is taken: the run ends as if no stop had come
        if stop.requested and ended is None and self.steps < self.next_frame:
            self._checkpoint()
            self.log.record(frame)
            return self._interrupted(stop)
        self.log.record(frame)
        self._frame_after(self.steps)
        if finished and ended is None and self.thermo is not None \
                and self.thermo.last_step != self.steps:
            self.thermo.write_frame(frame)  # the thermo log ends at the run's end
        if ended is not None:
            return ended
        if stop.requested:
            self._checkpoint()
            return self._interrupted(stop)
        return None

    def _interrupted(self, stop):
        """(status, message) of a run that a signal stops here."""
        return Status.INTERRUPTED, (
            f"interrupted by {stop.name} at t = {self.t_now:.12g} after {self.steps} of "
            f"{self.n_total} steps; the frames up to then are kept")

    _STATE_ARRAYS = ("u", "v", "f", "ledger", "counts")
    _STATE_SCALARS = ("steps", "t_now", "dt_now", "short_taken", "n_total", "next_frame",
                      "next_thermo", "next_ck", "e0")

    def checkpoint_state(self) -> dict:
        """Everything the run needs to go on from here: numpy arrays and numbers
        (``numpy.savez`` keeps them exactly).

        Returns
        -------
        dict
            The keys every checkpoint has (:mod:`granular_chain.checkpoint`: ``format``,
            ``stepper`` "verlet", the frame log's ``log_*``), then the run's own: name ->
            numpy array or numpy scalar (displacements, velocities, forces of shape
            (N,), ledger, clock, frame cadence, events so far).
        """
        state = {"format": CHECKPOINT_FORMAT, "stepper": "verlet"}
        state.update({name: getattr(self, name).copy() for name in self._STATE_ARRAYS})
        state.update({name: np.float64(getattr(self, name)) if name in (
            "t_now", "dt_now", "next_thermo", "next_ck", "e0") else np.int64(getattr(self, name))
            for name in self._STATE_SCALARS})
        state["active"] = self.state.active.copy()
        if self.forced:
            for name in FORCED_STATE_ARRAYS:
                state[f"forced_{name}"] = getattr(self.fstate, name).copy()
        state["opening"] = np.int64(self.opening)
        state["frame_due"] = np.int64(self.frame_due)
        state["thermo_lines"] = np.int64(getattr(self.thermo, "lines", 0))
        state.update(self.log.checkpoint_state())  # frames so far, first and latest
        if self.event_log is not None:  # the events logged so far (output.events)
            events = self.event_log.events
            state["events_t"] = np.array([e.t for e in events], dtype=np.float64)
            state["events_kind"] = np.array([EVENT_KINDS.index(e.kind) for e in events],
                                            dtype=np.int8)
            state["events_index"] = np.array([e.index for e in events], dtype=np.int64)
            state["events_step"] = np.array([e.step for e in events], dtype=np.int64)
        return state

    def _restore(self, state: dict) -> None:
        state = check_checkpoint(state, "verlet")
        for name in self._STATE_ARRAYS:
            getattr(self, name)[:] = state[name]
        self.state.active[:] = state["active"]
        if self.forced:
            for name in FORCED_STATE_ARRAYS:
                getattr(self.fstate, name)[:] = state[f"forced_{name}"]
        self.opening = int(state["opening"])
        # What the plan decides comes from this run's plan, not the state's: a run
        # continued to a later t_end has more steps (a checkpoint never falls after
        # the last whole step, so short_taken is False and dt_now the plan's step).
        for name in set(self._STATE_SCALARS) - {"n_total", "short_taken", "dt_now"}:
            value = state[name]
            setattr(self, name, bool(value) if name == "short_taken" else (
                float(value) if name in ("t_now", "dt_now", "next_thermo", "next_ck", "e0")
                else int(value)))
        # the frame cadence goes on from the checkpoint's, up to this run's last step
        self._frame_after(int(state["frame_due"]) - self.plan.every if "frame_due" in state
                          else self.next_frame - self.plan.every)
        self.log.restore(state)
        if self.event_log is not None:
            times = state["events_t"].tolist()
            steps = state["events_step"].tolist() if "events_step" in state else \
                [-1] * len(times)  # (a checkpoint written without the events' steps)
            self.event_log.events = [
                Event(t, EVENT_KINDS[k], i, s) for t, k, i, s in zip(
                    times, state["events_kind"].tolist(), state["events_index"].tolist(), steps)]

    def _last_step(self) -> int:
        """The run's last step: the shortened step after the whole ones when it is
        still to come (the run's last frame is there, not before it)."""
        return self.n_total + (1 if self.last_dt and not self.short_taken else 0)

    def _finished(self) -> bool:
        """Every step is taken (the run ends here whatever else happens)."""
        return self.steps >= self.n_total and (not self.last_dt or self.short_taken)

    def _checkpoint(self) -> None:
        if not self._finished():  # (a finished run has nothing to continue)
            self.checkpoints.write(self.checkpoint_state)

    def _control(self, n_steps: int) -> Call:
        return Call(n_steps=int(n_steps), opening=self.opening, stop_contact=self.stop_contact)

    def _records(self, control: Call) -> tuple:
        """The kernel's arguments for one call."""
        if self.forced:
            return (self.forced_features, self.chain, self.timestep, self.state, control,
                    self.forcing, self.fstate)
        return self.features, self.chain, self.timestep, self.state, control, self.buffers

    def _advance(self, chunk, n_steps: int) -> int:
        taken, code = self._call(chunk, n_steps)
        if taken == 0:  # a call always advances; guard against an endless loop
            raise RuntimeError("internal error: the Verlet kernel took no step")
        self.opening = 0
        self.steps += taken
        # the whole steps of the plan end at t_end itself (steps * dt may be an ulp off)
        ends = self.short_taken or (self.steps == self.plan.steps and not self.plan.last_dt)
        self.t_now = self.t_end if ends else self.steps * self.plan.dt
        return code

    def _call(self, chunk, n_steps: int):
        """One kernel call of at most ``n_steps`` steps (taken, code); with
        output.events, its events drained into the event log (calling again while
        the log fills)."""
        if self.event_log is not None:
            return self.event_log.call(lambda c: chunk.call(self.kernel, self._records(c)),
                                       self._control(n_steps), self.steps)
        key = (n_steps, self.opening)
        if key != self._call_key:  # (a frame cadence repeats the same call: built once)
            self._call_key, self._call_records = key, self._records(self._control(n_steps))
        return chunk.call(self.kernel, self._call_records)

    def _begin_short_step(self) -> None:
        if self.event_log is not None and self.merged:  # the half kick ending the last whole step
            self.event_log.half_kick(self.v, self.f, self.model, 0.5 * self.plan.dt, self.t_now,
                                    self.steps)
            self.event_log.commit()
        self.short_taken, self.dt_now = True, self.last_dt
        if self.merged:  # complete the pending half kick; the new step opens the leapfrog again
            _complete_half_kick(self.model, self.v, self.f, self.vs, self.ledger, self.counts,
                                0.5 * self.timestep.dt)
            self.opening = 1
        self.timestep = Timestep(self.last_dt, *_drift_coefficients(self.model, self.last_dt))
        self._call_key = None  # (the kernel's records hold the step)
        if self.forced:  # the short step starts at t_now: its clock restarts there
            self.fstate.clock[:] = (self.t_now, 0.0)
        self.n_total += 1

    def _synchronise(self, code: int) -> int:
        """Synchronise a merged-kick run's velocities (into vs); rest read off them."""
        if self.merged:
            m = self.model
            self.sync = synchronise(self.v, self.f, m.eta, m.eta_static, m.inv_mass,
                                           0.5 * self.dt_now, self.vs)
            if self.event_log is not None:  # held: only the run's last one is counted
                self.event_log.half_kick(self.v, self.f, m, 0.5 * self.dt_now, self.t_now,
                                        self.steps)
            if self.stop_mode & STOP_ON_REST and code == Pause.CHUNK_DONE \
                    and not self.vs.any():
                # at rest here (the kernel reads rest off the kick after the time
                # it holds, i.e. the next call's first step)
                code = Status.AT_REST
        return code

    def _check(self, code: int):
        """``((status, message) or None, scan)``: whether the run ends here, and the
        :meth:`scan` of the state it ends or goes on with."""
        scan = self.scan(reach=code != Pause.CHUNK_DONE)
        if scan.nonfinite >= 0:
            return self._nonfinite(scan, self.t_now), None
        ended = None
        if code == Status.SEPARATED:
            self.t_now = _backtrack_to_separation(self.model, self.u, self.vs, self.f,
                                                  self.ledger, self.stop_contact, self.dt_now,
                                                  self.t_now)
            scan = self.scan()
            ended = Status.SEPARATED, (
                f"contact {self.stop_contact} opened at t = {self.t_now:.12g} (located inside "
                f"the step by a second-order backtrack)")
        elif code == Status.AT_REST:
            held = "held by static friction, or still to roundoff" if self.forced else \
                "held by static friction"
            ended = Status.AT_REST, (
                f"every granule at rest ({held}) at t = {self.t_now:.12g}")
        broken = self._broken(scan, self.t_now, self.ledger, self.sync)
        if broken is not None:
            return broken, None
        return ended, scan

    def _nonfinite(self, scan: Scan, t_now: float) -> tuple:
        """(Status.NONFINITE, message) for a scan that found a non-finite granule."""
        return Status.NONFINITE, (
            f"non-finite state by t = {t_now:.6g} at granule {scan.nonfinite}: the step "
            f"dt = {self.plan.dt:g} is likely too large for the stiffest contact (period or "
            f"collision time {self.T:.4g}); reduce run.dt")

    def _broken(self, scan: Scan, t_now: float, ledger, sync) -> Optional[tuple]:
        """(status, message) when the scanned state at ``t_now`` has granules that passed
        each other or a wall, or a ledger off by the initial energy; else None.
        ``ledger`` and ``sync``: the run's ledger and synchronising kick's terms then."""
        dt, T = self.plan.dt, self.T
        if scan.problem != NO_PROBLEM:
            message = f"{_passed(scan, self.chain.olim)} at t = {t_now:.6g}; " + \
                OVERLAP_ADVICE
            if math.isfinite(T) and dt > STABILITY_FRACTION * T:
                message += (f"; or reduce run.dt: {dt:g} exceeds the stability limit "
                            f"{STABILITY_FRACTION * T:.4g} (run.check_dt is off)")
            return Status.OVERLAP, message
        ke, pe = scan.kinetic, scan.potential
        balance = abs(ke + pe + ledger[0] - sync[0] + ledger[1] - self.e0)
        scale = self.e0
        if self.forced:
            terms = self._added_terms()
            balance = abs(ledger_balance(ke, pe, ledger[0], ledger[1], *terms, self.e0))
            # (what the ledger holds: a column settling starts with no energy)
            scale = max(self.e0, ke + pe, *(abs(x) for x in terms))
        if scale > 0 and not balance <= _UNSTABLE_BALANCE * scale:
            # A stable run balances its ledger to O(dt^2); an error as large
            # as the initial energy itself means the integration blew up.
            return Status.UNSTABLE, (
                f"energy ledger off by {balance / scale:.3g} x the initial energy at "
                f"t = {t_now:.6g}: the integration is unstable; reduce run.dt (now "
                f"{dt:g}; stiffest contact time {T:.4g})")
        return None

    def _defer(self) -> None:
        """Hand the frame at this step of the cadence to the writers' thread and step
        on: copy the state into arrays the frame log lends (:func:`.frame_scan.stash_state`,
        a few microseconds); the thread makes the frame (:meth:`_settle`), checks
        it as :meth:`_check` would, keeps and writes it.

        A frame handed on may end the run (a non-finite state, a ledger off by the
        initial energy): the run then ends there, as if it had been checked at once
        (:meth:`_drained`), and the steps taken after it are dropped. Only frames
        of the cadence after a call that found nothing else (Pause.CHUNK_DONE) are
        handed on; a frame at a thermo line, a checkpoint, a stop request or the
        run's last step is made at once (:meth:`_loop`).
        """
        x, v, f = self.log.lend(self.model.count)
        self._stash(self.u, self.vs, self.f, FrameArrays(x, v, f, x))
        self.log.defer(partial(self._settle, _Mark(self.steps, self.t_now, self.ledger.copy(),
                                                   self.counts.copy(), self.sync)))
        self._frame_after(self.steps)

    def _settle(self, mark: "_Mark", x, v, f) -> Frame:
        """(On the writers' thread.) The frame of a state :meth:`_defer` copied into
        ``x`` (displacements), ``v``, ``f``; raises RunEnds when the run ends there."""
        first, ke, pe = self._settler(self._scan_codes, self.chain, self.chain.d0,
                                      self.model.x0, FrameArrays(x, v, f, self._settle_v2))
        scan = Scan(first, NO_PROBLEM, -1, 0.0, ke, pe)
        ended = self._nonfinite(scan, mark.t_now) if first >= 0 else \
            self._broken(scan, mark.t_now, mark.ledger, mark.sync)
        if ended is not None:
            raise RunEnds(*ended, mark)
        return self._unforced_frame(mark.steps, mark.t_now, x, v, f, scan, mark.ledger,
                                    mark.sync)

    def _drained(self) -> Optional[tuple]:
        """Wait until the frames handed on are made and written; (status, message) when
        one of them ended the run, whose step, time, ledger and counts are then
        those of that frame again; else None. (The state arrays u, v, f stay where
        the stepping went: a run that ends so is over, never checkpointed.)"""
        end = self.log.drain()
        if end is None:
            return None
        mark = end.mark
        self.steps, self.t_now, self.sync = mark.steps, mark.t_now, mark.sync
        self.ledger[:] = mark.ledger
        self.counts[:] = mark.counts
        return end.status, end.message


class _Mark(NamedTuple):
    """What a frame handed to the writers' thread needs of the run at its step."""

    steps: int
    t_now: float
    ledger: np.ndarray  #: (coulomb, viscous) dissipated so far (a copy)
    counts: np.ndarray  #: event counts so far (a copy)
    sync: tuple  #: the synchronising half kick's (work, stops, slips)


class _NoStop:
    requested = False


_NO_STOP = _NoStop()
_CHUNK_DONE = int(Pause.CHUNK_DONE)  # (a plain int: compared after every call)


def _assemble(log: FrameLog, model: Model, e0, status, message, steps, wall, dt, counts):
    """The Result of a Verlet run from its frame log."""
    energy = EnergyLedger(
        kinetic=log.array("kinetic"), potential=log.array("potential"),
        coulomb=log.array("coulomb"), viscous=log.array("viscous"), initial=e0,
        streamed_error=None if log.keep else log.max_balance_error,
        **{name: log.array(name) for name in TERMS_ADDED})
    x, v = log.array("x"), log.array("v")
    counts_d = dict(zip(EVENT_KINDS, (int(n) for n in counts)))
    info = {"features": model.features.describe(), "granules": model.count,
            "units": model.units}
    if not log.keep:
        info["frames"] = log.count
        info["frames_kept"] = "first and last (the others were streamed to the writers)"
    if model.units == "physical":
        info["scaled"] = scaled_parameters(model)
    t = log.array("t")
    return Result(
        t=t, x=x, v=v, f=log.array("f"), energy=energy, status=status,
        message=message, steps=steps, wall_time=wall, stepper="verlet", dt=dt,
        t_final=float(t[-1]), x_final=x[-1].copy(), v_final=v[-1].copy(),
        event_counts=counts_d, info=info)

def _complete_half_kick(model: Model, v, f, vs, ledger, counts, h: float) -> None:
    """Before the run's shorter last step, a Coulomb (merged-kick) run completes
    its pending half kick h: v becomes the synchronised velocity and the kick's
    work and counts enter the ledger, so the last step opens the leapfrog with
    its own half kick, exactly as at t = 0."""
    work, stops, slips = synchronise(v, f, model.eta, model.eta_static, model.inv_mass, h, vs)
    v[:] = vs
    ledger[0] -= work
    counts[EventKind.STOP] += stops
    counts[EventKind.SLIP] += slips


class _Chunk:
    """Steps per compiled call, adapted so that a call returns within about
    :data:`~granular_chain.interrupts.CHUNK_SECONDS`: a stop request is then
    honoured promptly whatever the chain length or the output cadence.

    Parameters
    ----------
    count : int
        Granules N; the first call takes about 2e6 granule-steps (a few ms).
    """

    def __init__(self, count: int):
        self.steps = max(1, 2_000_000 // max(count, 1))

    def call(self, kernel, records: tuple):
        """Call the kernel once and adapt :attr:`steps` to its measured rate
        (changing by at most 4x a call, so one slow call, such as the first,
        which may compile, does not swing it)."""
        begin = time.perf_counter()
        taken, code = kernel(*records)
        elapsed = time.perf_counter() - begin
        if taken > 0:
            target = taken * CHUNK_SECONDS / max(elapsed, 1e-6)
            self.steps = int(max(1, self.steps / 4, min(target, 4 * self.steps)))
        return taken, code


def _uniform_code(model: Model, feat, E, P1, P2) -> int:
    """Kernel feature code: UNIFORM when every granule has the same
    parameters and every contact the same (d0, k, n), so the single sweep reads
    scalars and streams only u, v, f; UNIT when moreover m = k = 1 and
    d0 = 0 (the scaled touching chain), compiled in as constants. Only the sweep
    (scenes without Coulomb friction) uses it; PER_GRANULE otherwise, so that
    Coulomb scenes do not compile a second, identical specialisation."""
    if feat.coulomb:
        return PER_GRANULE
    arrays = (model.mass, model.inv_mass, E, P1, P2, model.d0, model.k, model.n)
    if not all(a.size == 0 or bool(np.all(a == a[0])) for a in arrays):
        return PER_GRANULE
    unit = all(a.size == 0 or a[0] == value
               for a, value in ((model.mass, 1.0), (model.k, 1.0), (model.d0, 0.0)))
    return UNIT if unit and model.count > 1 else UNIFORM


def _overlap_limits(model: Model):
    """Overlaps at which centres meet: r_i + r_(i+1) for contacts, r for a wall's granule."""
    r = model.radius
    return r[:-1] + r[1:], r[0], r[-1]


def _overlap_caps(model: Model):
    """Kernel form of the limits: olim (N + 1,) (left wall, contacts, right wall)
    and the smallest contact force at which a contact reaches its limit."""
    lim, left, right = _overlap_limits(model)
    olim = np.concatenate(([left], lim, [right]))
    if not lim.size:
        return olim, math.inf
    # The contact law's force at each limit, from the law the kernels use
    # (laws.contact through net_forces with d0 = lim and u = 0, so delta = lim
    # exactly), not from a second formula.
    at_limit = np.zeros(model.count + 1)
    d0 = model.contacts.d0.copy()
    d0[1:-1] = lim
    _net_forces(model, np.zeros(model.count), at_limit, np.zeros(model.count), d0=d0)
    return olim, float(np.min(at_limit[1:-1]))


def _passed(scan: Scan, olim) -> str:
    """Describe the contact whose granules have passed each other, or the wall a
    granule has passed, that ``scan`` found.

    Checked at the output cadence. An overlap of r_i + r_(i+1) puts two centres
    on top of each other: beyond it the granules are in the wrong order (a
    crossing between two frames leaves them so), and the one-sided contact
    model no longer describes the scene. ``olim``: :attr:`.records.Chain.olim`.
    """
    i, d = scan.index, scan.overlap
    if scan.problem == CONTACT_PASSED:
        return (f"contact {i} overlaps by {d:.4g}, not less than the sum of the radii "
                f"{olim[i + 1]:.4g}")
    side = "left" if scan.problem == LEFT_WALL_PASSED else "right"
    return f"granule {i} overlaps the {side} wall by {d:.4g}, more than its radius"


def _backtrack_to_separation(model, u, v, f, ledger, i, dt, t_now):
    """Move the state back from the end of the step to the moment contact i opened.

    After opening, the overlap falls linearly at the relative speed to first
    order, so the opening happened tau = -delta / (v_(i+1) - v_i) ago (clamped
    to the step). Each granule is moved back along its acceleration at the end
    of the step (spring, Coulomb and viscous), a second-order Taylor step, and
    the friction work done in tau is taken off the ledger.
    """
    delta = model.d0[i] + u[i] - u[i + 1]
    w = v[i + 1] - v[i]
    tau = 0.0 if w <= 0 else min(max(-delta / w, 0.0), dt)
    if tau == 0.0:
        return t_now
    s = np.sign(v)
    acc = (f - model.eta * s - model.gamma * v) * model.inv_mass
    acc[v == 0.0] = 0.0  # a granule at rest at the end of the step was stuck during tau
    ledger[0] -= tau * float(np.dot(model.eta, np.abs(v)))
    ledger[1] -= tau * float(np.dot(model.gamma, v * v))
    u -= tau * v - 0.5 * tau * tau * acc
    v -= tau * acc
    _net_forces(model, u, np.zeros(model.count + 1), f)
    return t_now - tau
