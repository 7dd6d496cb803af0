"""The Verlet event log (``output.events``): compiled buffers and their Python side.

With ``Features.log_events`` the kernels write each event into
:class:`~.records.EventBuffers` with a fill counter; a step starts only when
the buffers have room for its worst case (:func:`log_capacity`), else the call
returns ``Pause.LOG_FULL`` and :class:`EventLog` drains them and calls again
(the state lives in the arrays, so the resumed run is bit-identical). Nothing
is logged inside a loop with a floating-point sum (a branch there changes how
the sum vectorises, hence its last bits): the Coulomb kick codes go into a
block buffer scanned after the kick pass, the sweep's contacts are read before
the step and after its sums are stored, the walls at both ends of the step.
"""

from __future__ import annotations

import numba
import numpy as np

from ..._compile import kernel
from ...codes import EVENT_KINDS, EventKind, Pause
from ...forces import left_wall_overlap, right_wall_overlap
from ...laws.friction import coulomb_kick
from ...result import Event
from .records import Call, EventBuffers

__all__ = ["EventLog", "new_event_log", "log_capacity"]

CLOSE = int(EventKind.CONTACT_CLOSE)
OPEN = int(EventKind.CONTACT_OPEN)
STOP = int(EventKind.STOP)
SLIP = int(EventKind.SLIP)


@kernel()
def log_capacity(N, coulomb):
    """Entries an event log needs for one step of a chain of N granules: every
    contact (walls included) may close or open, and with Coulomb friction every
    granule may stop and slip in its kick. The kernel starts a step only with
    this much room left.

    Parameters
    ----------
    N : int
        Number of granules.
    coulomb : bool
        Whether the scene has Coulomb friction (stop and slip events).

    Returns
    -------
    int
        ``N + 1`` entries, plus ``2 N`` with Coulomb friction.
    """
    return N + 1 + (2 * N if coulomb else 0)


def new_event_log(N: int, coulomb: bool, log_events: int) -> EventBuffers:
    """Buffers for the kernels' ``log`` argument: room for at least 65536
    entries and one step when logging; empty otherwise (a kernel compiled
    without the log never touches them).

    Parameters
    ----------
    N : int
        Number of granules.
    coulomb : bool
        Whether the scene has Coulomb friction.
    log_events : int
        Nonzero when the kernel logs events.

    Returns
    -------
    EventBuffers
        ``step`` (int64), ``kind`` (int8), ``index`` (int64) of one length, and
        ``fill`` (int64, shape (1,), 0).
    """
    size = max(1 << 16, log_capacity(N, coulomb)) if log_events else 0
    return EventBuffers(np.zeros(size, dtype=np.int64), np.zeros(size, dtype=np.int8),
                        np.zeros(size, dtype=np.int64), np.zeros(1, dtype=np.int64))


@numba.njit(inline="always", cache=True)
def log_event(log, fill, step, kind, index):
    """Append (step, kind, index) at entry ``fill`` of the event log; the new fill."""
    log.step[fill] = step
    log.kind[fill] = kind
    log.index[fill] = index
    return fill + 1


@numba.njit(inline="always", cache=True)
def walls_closed(features, u, d0):
    """(left, right): 1 where that wall's contact is closed (delta > 0); 0 without the
    wall. ``d0``: the contact table's column (N+1,), the walls in rows 0 and N."""
    left = 0
    right = 0
    if features.left_wall:
        left = 1 if left_wall_overlap(d0[0], u[0]) > 0.0 else 0
    if features.right_wall:
        right = 1 if right_wall_overlap(d0[u.size], u[u.size - 1]) > 0.0 else 0
    return left, right


@numba.njit(inline="always", cache=True)
def log_walls(features, log, fill, step, u, d0, was):
    """Log the wall contacts that changed since they were ``was`` = (left, right); the new
    fill. ``d0`` as in :func:`walls_closed`."""
    left, right = walls_closed(features, u, d0)
    if left != was[0]:
        fill = log_event(log, fill, step, CLOSE if left else OPEN, -1)
    if right != was[1]:
        fill = log_event(log, fill, step, CLOSE if right else OPEN, u.size - 1)
    return fill


@numba.njit(inline="always", cache=True)
def closed(d0, ua, ub):
    """Whether a contact of initial overlap d0 between displacements ua, ub is
    closed (delta > 0), written so that the same two displacements always give
    the same answer (one subtraction and a comparison: nothing to reassociate)."""
    return 1 if ua - ub > -d0 else 0


@kernel()
def sweep_contact_log(d0, u, seen, after, log, fill, step):
    """The sweep's contact events, read off the displacements before (``after`` 0:
    the states into ``seen``) and after the step (1: a log entry where a state
    changed); the new fill. Called, not inlined: code around the sweep changes
    how its sums are reassociated (the drag's work would then differ in the last
    bits from the run without the log). ``d0``: the contact table's column (N+1,);
    contact i, between granules i and i+1, is its row i+1."""
    for i in range(u.size - 1):
        # d0 is 0 on the UNIT chain, where the sweep adds the constant 0.0: the same test
        now = closed(d0[i + 1], u[i], u[i + 1])
        if not after:
            seen[i] = now
        elif now != seen[i]:
            fill = log_event(log, fill, step, CLOSE if now else OPEN, i)
    return fill


@kernel()
def kick_codes(v, f, eta, eta_s, inv_m, h, codes):
    """Stop/slip codes (bit 1 stop, bit 2 slip) of the half kick
    :func:`.kernel.synchronise` takes, per granule, into ``codes`` (int8, shape
    (N,)): the events behind the stop and slip counts it returns."""
    for i in range(v.size):
        v1, w1, w2, code = coulomb_kick(v[i], f[i], eta[i], eta_s[i], inv_m[i], h)
        codes[i] = code


class EventLog:
    """The driver's side of the event log: drains the kernel's buffers into a
    list of :class:`granular_chain.result.Event` after each call.

    An event's time is the end of the step that saw it, ``step * dt`` (t_end for
    the run's shortened last step), clamped to the time the call reached. The
    list grows by one Event (about 160 B) per event; the kernel's buffers stay
    at their size (:func:`new_event_log`).

    Parameters
    ----------
    N : int
        Granules.
    coulomb : bool
        Whether the kernel runs the Coulomb (merged-kick) passes.
    dt : float
        Step, units of time of the model.
    steps : int
        Whole steps of dt in the plan; later steps end at ``t_end``.
    t_end : float
        End of the run, units of time of the model.
    """

    def __init__(self, N: int, coulomb: bool, dt: float, steps: int, t_end: float):
        self.buffers = EventBuffers(*new_event_log(N, coulomb, 1))
        self.events: list = []
        self.dt, self.steps, self.t_end = dt, steps, t_end
        self._codes = np.zeros(N, dtype=np.int8)
        self._pending: list = []

    def call(self, call, control: Call, done: int):
        """``call(control)`` (one kernel call), draining the log after it and calling
        again while the kernel reports LOG_FULL; ``done`` = steps of the run before.
        Returns (steps taken, code) as one call would.

        Parameters
        ----------
        call : callable
            ``call(control) -> (steps taken, code)``: one kernel call.
        control : Call
            What the call is asked to do (:class:`.records.Call`).
        done : int
            Steps of the run taken before this call.

        Returns
        -------
        tuple of int
            ``(steps taken, code)``, code a :class:`granular_chain.codes.Pause`.
        """
        taken, code = call(control)
        self._drain(done, taken)
        while code == Pause.LOG_FULL:
            more, code = call(control._replace(opening=0, n_steps=control.n_steps - taken))
            self._drain(done + taken, more)
            taken += more
        return taken, code

    def _drain(self, done: int, taken: int) -> None:

        q = int(self.buffers.fill[0])
        s = np.minimum(self.buffers.step[:q], taken) + done
        t = np.where(s <= self.steps, s * self.dt, self.t_end)
        self.events.extend(Event(ti, EVENT_KINDS[k], i, si) for ti, k, i, si in zip(
            t.tolist(), self.buffers.kind[:q].tolist(), self.buffers.index[:q].tolist(),
            s.tolist()))
        self.buffers.fill[0] = 0

    def half_kick(self, v, f, model, h: float, t: float, step: int) -> None:
        """Hold the stop and slip events of the half kick :func:`.kernel.synchronise`
        takes at time t (v, f and h as given to it); :meth:`commit` adds them.

        Parameters
        ----------
        v, f : numpy.ndarray
            Shape (N,) each: velocities and net spring forces before the kick,
            units of the model.
        model : Model
            The compiled scene (friction forces, inverse masses).
        h : float
            Kick duration, units of time of the model.
        t : float
            Time the events are logged at, units of time of the model.
        step : int
            The step they are logged with (the run's steps so far).
        """
        kick_codes(v, f, model.eta, model.eta_static, model.inv_mass, h, self._codes)
        self._pending = [(t, str(kind), int(i), int(step)) for bit, kind in
                         ((1, EventKind.STOP), (2, EventKind.SLIP))
                         for i in np.flatnonzero(self._codes & bit)]

    def commit(self) -> list:
        """Add the held half-kick events (those the run's counts take in); the list.

        Returns
        -------
        list of Event
            Every event logged so far (times in the model's units).
        """
        self.events.extend(Event(*e) for e in sorted(self._pending, key=lambda e: e[2]))
        self._pending = []
        return self.events
