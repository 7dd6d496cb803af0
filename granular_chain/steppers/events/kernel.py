"""The event stepper's compiled loop: Taylor-series modes, polynomial events, mode switches.

Method (see docs/events.md)
---------------------------
Between two events the mode is fixed: which contacts are closed, and for each
granule with Coulomb friction whether it slides (+1, -1) or sticks (0). In a
fixed mode the motion is analytic, and the stepper advances it by its Taylor
series, computed to order ``P`` by automatic differentiation (recurrences)::

    u_i' = v_i
    m_i v_i' = c_i - c_(i+1) - gamma_i v_i - eta_i s_i          (s_i = sliding sign)
    delta_j' = v_(j-1) - v_j                                     (contact j between j-1, j)
    c_j = k_j delta_j^(n_j - 1)                                  (closed contacts)

* n = 2: the system is linear with constant coefficients and the series is the
  matrix exponential's; steps are chosen so the truncated terms are below
  1e-17 of the state and the terms never grow beyond ~2, so each mode is
  propagated exactly to roundoff (no tolerance).
* other n: ``delta^(n-1)`` is expanded by the power recurrence
  ``p_k = (1/(k d_0)) sum_{i<k} ((n-1)(k-i) - i) d_(k-i) p_i`` and the step
  follows Jorba & Zou's rule from the last two coefficients and rtol/atol. The
  only loss of smoothness is at delta = 0 (opening or closing), where the
  solution has a branch point: the contact force is switched off below the
  overlap ``delta_on`` at which its remaining impulse ``k delta^n/(n |w|)`` is
  below a tenth of the velocity tolerance, so every step integrates an
  analytic right-hand side and the order is not lost (measured in
  docs/events.md).

Overlaps are state variables of their own (never differences of
displacements), so a tiny late overlap keeps its relative precision.

Events are roots of the step's polynomials: a rigorous exclusion bound, then
sampling (sign changes, and interior maxima for grazing), then Brent's method
to machine precision. At an event the state is taken to the root, the event
quantity is set exactly (overlap 0 or velocity 0), all events within a
roundoff window are processed together, and the mode is re-derived from the
state (:func:`settle`), which also resolves ties (a contact touching with zero
relative velocity, a granule stopping exactly at the static threshold) from
the first non-vanishing derivative.

Only the moving set (sliding granules, frictionless granules that move or
have a closed contact), the contacts touching it and the stuck granules next
to those enter a step. The moving set is kept incrementally and ``settle``
works on a window around each event batch, so steps and events cost
O(active), not O(N); the rest of the chain costs nothing until a neighbour's
event reaches it.

N = 2 with a closed linear contact is evaluated in closed form instead
(:mod:`.modal_n2`, :mod:`.modal_step`): exact near critical damping,
where a stepper's rounding grows like s (t0 - s).
"""


import math

import numba
from numba import literally

from ..._compile import callee, kernel, run_time
from ...codes import EventKind, Pause, Status
from ...laws.contact import LAW_LINEAR
from . import modal_n2
from .modal_step import modal_step, try_jump
from .modes import all_at_rest, is_moving, log_event, settle, spring_force, update_moving_set
from .output import record_frame
from .records import GOING
from .roots import CENTRES_MEET, SWITCH_ON, contact_candidates, friction_candidates
from .dissipation import (FORCE_CLOSE, FORCE_OPEN, TIME_EVENT, branch_cap, build_dissipative,
                          dissipative_candidates, dissipative_increment, wall_rates, wall_series)
from .series import build_series, horner, increment, ledger_increment, step_size

#: Consecutive event batches in a vanishing time window that end a run as Zeno.
ZENO_BATCHES = 200


@kernel(error_model="numpy", _nrt=False)
def run_events(law, coulomb, viscous, dissip, settings_array, clock_array, model, state, work,
               frames, log):
    """Advance the event-driven motion until the run ends, a buffer fills or the
    call's work budget is spent.

    Parameters
    ----------
    law, coulomb, viscous : int
        Compile-time feature codes (contact law, Coulomb and viscous friction present).
    dissip : None or int
        None: an elastic chain between fixed walls; an int (1): dashpots, body
        forces or driven walls present (:mod:`.dissipation`). A type, not a
        literal value, because numba prunes ``dissip is None`` branches in every
        callee, inlined ones too, and a literal's branches only in the kernel
        itself: the elastic kernels then hold none of the dissipative code.
    settings_array, clock_array : ndarray, shape (1,)
        :data:`~.records.SETTINGS_DTYPE` and :data:`~.records.CLOCK_DTYPE` records.
    model, state, work, frames, log
        :class:`~.records.ChainArrays`, :class:`~.records.MotionState`,
        :class:`~.records.Workspace`, :class:`~.records.FrameBuffers`,
        :class:`~.records.EventLog`.

    Returns
    -------
    int
        A :class:`~granular_chain.codes.Status` (the run ended; reaching an
        overlap limit sets ``clock.overlap_contact``), or a
        :class:`~granular_chain.codes.Pause`: ``LOG_FULL`` (grow the frame or
        event buffers and call again) or ``CHUNK_DONE`` (``settings.budget``
        main-loop passes made). All state lives in the records and the check
        sits between passes, so splitting a run into calls does not change it.
    """
    law = literally(law)
    coulomb = literally(coulomb)
    viscous = literally(viscous)
    settings = settings_array[0]
    clock = clock_array[0]
    if clock.started == 0:
        code = _start(law, dissip, settings, clock, model, state, work, frames, log)
        if code != GOING:
            return code
    budget = settings.budget
    passes = 0
    while True:
        code = _before_pass(law, settings, clock, model, state, frames, log)
        if code != GOING:
            return code
        if budget > 0:
            if passes >= budget:
                return Pause.CHUNK_DONE.value
            passes += 1
        code, event, tau_e, ncand = _step(law, coulomb, viscous, dissip, settings, clock, model,
                                          state, work, frames)
        if code != GOING:
            return code
        if event == 0:
            continue
        code = _event_batch(law, dissip, tau_e, ncand, settings, clock, model, state, work,
                            frames, log)
        if code != GOING:
            return code


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _buffers_short(clock, state, frames, log):
    """Too little room for a pass: 4 frames, or an event per granule and contact."""
    N = state.u.size
    return (frames.t.size - clock.n_frames < 4
            or log.t.size - clock.n_events < 2 * N + 4)


@callee(error_model="numpy", _nrt=False)
def _start(law, dissip, settings, clock, model, state, work, frames, log):
    """The first call: settle the initial modes, build the moving set, record the
    first frame; the run may end at once (at rest, or the overdamped jump)."""
    N = state.u.size
    if _buffers_short(clock, state, frames, log):
        return Pause.LOG_FULL.value
    clock.started = 1
    work.window[0] = 0
    work.window[1] = N - 1
    if dissip is not None:
        wall_rates(clock.time, clock.time_lo, model, state)
    settle(law, clock.time, settings, clock, model, state, work, log)
    # The moving set (is_moving) is kept incrementally from here on.
    nm0 = 0
    for i in range(N):
        state.is_moving[i] = 0
        if is_moving(i, state, model) == 1:
            state.is_moving[i] = 1
            state.moving_pos[i] = nm0
            state.moving[nm0] = i
            nm0 += 1
    clock.n_moving = nm0
    record_frame(law, clock.time, clock, model, state, frames, 0.0, 0.0)
    clock.next_frame = 1
    if settings.stop_rest == 1 and all_at_rest(law, clock, model, state):
        return Status.AT_REST.value
    if dissip is None and try_jump(law, settings, clock, model, state):
        record_frame(law, clock.time, clock, model, state, frames, 0.0, 0.0)
        return Status.T_END.value
    return GOING


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _before_pass(law, settings, clock, model, state, frames, log):
    """Before a pass of the main loop: t_end reached, the step limit, room in the buffers."""
    t = clock.time
    if t >= settings.t_end:
        record_frame(law, t, clock, model, state, frames, 0.0, 0.0)  # (none if one is at t)
        return Status.T_END.value
    if clock.steps >= settings.max_steps:
        return Status.MAX_STEPS.value
    if _buffers_short(clock, state, frames, log):
        return Pause.LOG_FULL.value
    return GOING


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _step(law, coulomb, viscous, dissip, settings, clock, model, state, work, frames):
    """One step in the current mode, closed-form (two granules, n = 2, contact
    closed, no dashpot) or Taylor. Returns (code, event, tau_e, ncand) as
    :func:`taylor_step`."""
    N = state.u.size
    if (dissip is None and law == LAW_LINEAR and N == 2 and model.present[0] == 0
            and model.present[2] == 0 and state.closed[1] == 1):
        if modal_n2.setup(work.modal[0], coulomb, viscous, model, state):
            for j in range(N + 1):
                work.contact_flag[j] = 0
            for i in range(N):
                work.granule_flag[i] = 0
            # The closed form is of n = 2 alone: its compiled code is the same for
            # every law's kernel (one compile per friction set, not one per law).
            return modal_step(coulomb, viscous, settings, clock, model, state, work, frames)
    return taylor_step(law, coulomb, viscous, dissip, settings, clock, model, state, work, frames)


@numba.njit(inline="always", cache=True, _nrt=False)
def _add_contacts(i, model, work, na):
    """Append the (present, not yet listed) contacts i and i+1 of granule i to active[:na]."""
    for j in range(i, i + 2):
        if model.present[j] == 1 and work.contact_flag[j] == 0:
            work.contact_flag[j] = 1
            work.active[na] = j
            na += 1
    return na


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _collect_active(dissip, nm, model, state, work):
    """The contacts of the moving set and the stuck granules they touch (and those
    granules' contacts), from the incrementally kept moving set: O(active), not
    O(N); a moving wall's contact always. Returns (na, nc): ``work.active[:na]``,
    ``work.stuck[:nc]``."""
    N = state.u.size
    na = 0
    nc = 0
    if dissip is not None:
        for side in range(2):
            j = side * N
            if model.wall_motion[side, 0] != 0.0 and model.present[j] == 1:
                work.contact_flag[j] = 1
                work.active[na] = j
                na += 1
    for q in range(nm):
        na = _add_contacts(state.moving[q], model, work, na)
    na1 = na
    for q in range(na1):
        j = work.active[q]
        for i in range(j - 1, j + 1):
            if i >= 0 and i < N and state.slide[i] == 0 and work.granule_flag[i] == 0:
                work.granule_flag[i] = 1
                work.stuck[nc] = i
                nc += 1
    for q in range(nc):
        na = _add_contacts(work.stuck[q], model, work, na)
    # the flags only de-duplicate: clear them for the event marks
    for q in range(na):
        work.contact_flag[work.active[q]] = 0
    for q in range(nc):
        work.granule_flag[work.stuck[q]] = 0
    return na, nc


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def taylor_step(law, coulomb, viscous, dissip, settings, clock, model, state, work, frames):
    """One Taylor step of the mode, to its first event or its step size.

    Parameters
    ----------
    law : int
        Contact-law code (``laws.contact``; LAW_LINEAR for n = 2), a compile-time constant.
    coulomb : int
        Compile-time feature code: nonzero when some granule has Coulomb friction.
    viscous : int
        Compile-time feature code: nonzero when some granule has viscous friction.
    dissip : None or int
        None: an elastic chain between fixed walls; an int: dashpots, body forces
        or driven walls present (see :func:`~.kernel.run_events`).
    settings : record of SETTINGS_DTYPE
        What the kernel is asked to do (end time, tolerances, stops), kernel units.
    clock : record of CLOCK_DTYPE
        The run's clock and work totals (kernel units), advanced in place.
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).
    work : Workspace
        Scratch of the step: series (rows, P + 1 or P + 2), candidate lists, flags.
    frames : FrameBuffers
        Frame buffers (F rows; ``x``, ``v``, ``f`` (F, N), ``e`` (F, 7)), kernel units.

    Returns
    -------
    code : int
        A Status (the run ended), a Pause, or GOING.
    event : int
        1 when the step ended at the earliest candidate root, else 0.
    tau_e : float
        That root, kernel time units from the step's start (0.0 without an event).
    ncand : int
        Candidates written to ``work.cand_*`` (0 without an event).
    """
    linear = law == LAW_LINEAR
    P = settings.order
    t, tlo, t_end = clock.time, clock.time_lo, settings.t_end
    nm = clock.n_moving
    na, nc = _collect_active(dissip, nm, model, state, work)
    if nm == 0 and na == 0:
        # Nothing moves and nothing can start moving: the state is final.
        record_frame(law, t_end, clock, model, state, frames, 0.0, 0.0)
        clock.jumped_from = t
        clock.time = t_end
        clock.time_lo = 0.0
        clock.jumped = 2
        return Status.T_END.value, 0, 0.0, 0
    vscale = 0.0
    for q in range(nm):
        vscale = max(vscale, abs(state.v[state.moving[q]]))
    if dissip is not None:  # a wall driven into granules at rest sets the speed scale
        vscale = max(vscale, abs(state.wall_rate[0]), abs(state.wall_rate[1]))
    tol_v = settings.rtol * vscale + settings.atol
    if dissip is not None:
        wall_series(P, t, tlo, model, work)
        build_dissipative(law, coulomb, viscous, P, tol_v, nm, na, model, state, work)
    else:
        build_series(law, coulomb, viscous, P, tol_v, nm, na, model, state, work)
    # n = 2: also h <= step_cap = 0.5/L, L a bound on the mode's eigenvalues: the
    # series of a decaying exponential e^(-L h) has terms up to e^(L h), and
    # keeping L h <= 1/2 keeps their cancellation below a factor 3.
    h = (t_end - t) - tlo
    if settings.step_cap > 0.0:
        h = min(h, settings.step_cap)
    h = step_size(linear, P, settings.rtol, settings.atol, h, nm, na, state, work)
    if dissip is not None:
        if not linear:
            h = branch_cap(h, na, model, work)
    if not (h > 0.0) or not math.isfinite(h):
        return Status.NONFINITE.value, 0, 0.0, 0
    if dissip is not None:
        tau_e, ncand = dissipative_candidates(linear, P, h, tol_v, t, tlo, na, model, state,
                                              work)
    else:
        tau_e, ncand = contact_candidates(linear, P, h, tol_v, na, model, state, work)
    if coulomb:
        tau_e, ncand = friction_candidates(P, h, settings.rtol, nm, nc, ncand, tau_e, model,
                                           state, work)
    event = tau_e <= h
    tau = tau_e if event else h
    # t_new = t + tau as a double-double (TwoSum, then renormalise)
    s_ = t + tau
    bb = s_ - t
    lo = tlo + ((t - (s_ - bb)) + (tau - bb))
    t_new = s_ + lo
    t_lo_new = lo - (t_new - s_)
    if not event and tau == h and h == (t_end - t) - tlo:
        t_new = t_end
        t_lo_new = 0.0
    if settings.frame_interval > 0.0:
        # (the friction codes at run time: frames are made at output times only)
        code = _frames_in_step(law, run_time(coulomb), run_time(viscous), dissip, t_new, na,
                               settings, clock, model, state, work, frames)
        if code != GOING:
            return code, 0, 0.0, 0
    if not _advance(coulomb, viscous, dissip, P, tau, t_new, t_lo_new, na, clock, model, state,
                    work):
        return Status.NONFINITE.value, 0, 0.0, 0
    if not event:
        if settings.every > 0 and clock.steps % settings.every == 0:
            record_frame(law, t_new, clock, model, state, frames, 0.0, 0.0)
        if t_new >= t_end:
            record_frame(law, t_end, clock, model, state, frames, 0.0, 0.0)
            return Status.T_END.value, 0, 0.0, 0
        return GOING, 0, 0.0, 0
    return GOING, 1, tau_e, ncand


@callee(error_model="numpy", _nrt=False)
def _frames_in_step(law, coulomb, viscous, dissip, t_new, na, settings, clock, model, state,
                    work, frames):
    """Frames at the output cadence inside the step, up to t_new, from the series.
    Returns Pause.LOG_FULL when the buffers are full (state untouched: the step is
    redone after they grow), else GOING."""
    P = settings.order
    t, tlo, t_end, out_dt = clock.time, clock.time_lo, settings.t_end, settings.frame_interval
    nm = clock.n_moving
    u, v, overlap, mov = state.u, state.v, state.overlap, state.moving
    while True:
        tf = clock.next_frame * out_dt
        if tf > t_new or tf > t_end:
            break
        if clock.n_frames >= frames.t.size - 3:
            return Pause.LOG_FULL.value
        x = (tf - t) - tlo
        for q in range(nm):
            i = mov[q]
            work.saved_u[i] = u[i]
            work.saved_v[i] = v[i]
            u[i] = horner(work.u_series[i], P, x)
            v[i] = horner(work.v_series[i], P, x)
        for q in range(na):
            j = work.active[q]
            work.saved_overlap[j] = overlap[j]
            overlap[j] = horner(work.d_series[j], P, x)
        dwc, dwv = ledger_increment(coulomb, viscous, P, nm, model, state, work, x)
        if dissip is not None:
            _dissipative_frame(law, tf, P, na, x, dwc, dwv, clock, model, state, work, frames)
        else:
            record_frame(law, tf, clock, model, state, frames, dwc, dwv)
        for q in range(nm):
            i = mov[q]
            u[i] = work.saved_u[i]
            v[i] = work.saved_v[i]
        for q in range(na):
            j = work.active[q]
            overlap[j] = work.saved_overlap[j]
        clock.next_frame += 1
    return GOING


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _advance(coulomb, viscous, dissip, P, tau, t_new, t_lo_new, na, clock, model, state, work):
    """Take the state to the end of the step (tau from its start, time t_new +
    t_lo_new) and add the friction (and dashpot and wall) work. False if the
    state turned non-finite."""
    nm = clock.n_moving
    u, v, overlap, mov = state.u, state.v, state.overlap, state.moving
    dwc, dwv = ledger_increment(coulomb, viscous, P, nm, model, state, work, tau)
    clock.work_coulomb += dwc
    clock.work_viscous += dwv
    if dissip is not None:
        dwd, dww = dissipative_increment(P, na, model, state, work, tau)
        clock.work_contact += dwd
        clock.work_wall += dww
        wall_rates(t_new, t_lo_new, model, state)
    for q in range(nm):
        i = mov[q]
        u[i] = u[i] + increment(work.u_series[i], P, tau)
        v[i] = horner(work.v_series[i], P, tau)
    for q in range(na):
        j = work.active[q]
        overlap[j] = horner(work.d_series[j], P, tau)
    clock.time = t_new
    clock.time_lo = t_lo_new
    clock.steps += 1
    for q in range(nm):
        if not (math.isfinite(u[mov[q]]) and math.isfinite(v[mov[q]])):
            return False
    return True


@callee(error_model="numpy", _nrt=False)
def _dissipative_frame(law, tf, P, na, x, dwc, dwv, clock, model, state, work, frames):
    """A frame inside a step (state already at x from the step's start) with the
    dashpot and wall work up to it: the clock's totals are raised for the frame
    and put back exactly (the step adds its whole increment at its end)."""
    dwd, dww = dissipative_increment(P, na, model, state, work, x)
    wd, ww = clock.work_contact, clock.work_wall
    rl, rr = state.wall_rate[0], state.wall_rate[1]
    clock.work_contact = wd + dwd
    clock.work_wall = ww + dww
    wall_rates(tf, 0.0, model, state)  # (the walls' dashpots in the frame's forces)
    record_frame(law, tf, clock, model, state, frames, dwc, dwv)
    clock.work_contact = wd
    clock.work_wall = ww
    state.wall_rate[0] = rl
    state.wall_rate[1] = rr


@callee(error_model="numpy", _nrt=False)
def _apply_roots(law, limit, ncand, model, state, work):
    """Set the event quantities of every candidate with a root <= limit exactly
    (overlap 0, velocity 0, the slip's direction) and mark them for settle."""
    for q in range(ncand):
        if work.cand_root[q] <= limit:
            kind = work.cand_kind[q]
            i = work.cand_index[q]
            if kind == EventKind.CONTACT_OPEN or kind == EventKind.CONTACT_CLOSE:
                state.overlap[i] = 0.0
                work.contact_flag[i] = 2 if kind == EventKind.CONTACT_CLOSE else 3
            elif kind == FORCE_OPEN or kind == FORCE_CLOSE:
                # the overlap stays (positive): the total force is what reached zero
                work.contact_flag[i] = 2 if kind == FORCE_CLOSE else 3
            elif kind == EventKind.STOP:
                state.v[i] = 0.0
                work.granule_flag[i] = 3
            elif kind == EventKind.SLIP:
                F = spring_force(law, model, state, i, -5)
                state.slide[i] = 1 if F > 0.0 else -1
                work.granule_flag[i] = 2  # settle keeps this root-located slip


@callee(error_model="numpy", _nrt=False)
def _batch_window(limit, ncand, N, work):
    """The granules settle looks at: around the batch's events (it grows the
    window where a change reaches its edge); empty when no event changes a mode."""
    wlo = N
    whi = -1
    for q in range(ncand):
        kind = work.cand_kind[q]
        if work.cand_root[q] <= limit and (kind >= 0 or kind == FORCE_OPEN
                                             or kind == FORCE_CLOSE):
            c_ = work.cand_index[q]
            if kind < 0 or kind == EventKind.CONTACT_OPEN or kind == EventKind.CONTACT_CLOSE:
                wlo = min(wlo, c_ - 2)
                whi = max(whi, c_ + 1)
            else:
                wlo = min(wlo, c_ - 1)
                whi = max(whi, c_ + 1)
    if whi < wlo:
        wlo = 0
        whi = -1
    work.window[0] = max(wlo, 0)
    work.window[1] = min(whi, N - 1)


@callee(error_model="numpy", _nrt=False)
def _event_batch(law, dissip, tau_e, ncand, settings, clock, model, state, work, frames, log):
    """The events of a step ending at its earliest root tau_e: roots of different
    event functions at one true instant agree to a few ulps of tau, so all
    within 16 ulps are processed together (simultaneous events). Then the modes
    are settled and the run's ends checked (:func:`_after_batch`)."""
    N = state.u.size
    t_new = clock.time
    limit = tau_e + 16 * 2.2e-16 * tau_e
    for q in range(ncand):
        if work.cand_kind[q] == CENTRES_MEET and work.cand_root[q] <= limit:
            clock.overlap_contact = work.cand_index[q]
            record_frame(law, t_new, clock, model, state, frames, 0.0, 0.0)
            return Status.OVERLAP.value
    _apply_roots(law, limit, ncand, model, state, work)
    nev_before = clock.n_events
    _batch_window(limit, ncand, N, work)
    opened = 0
    if work.window[1] >= work.window[0]:
        opened = settle(law, t_new, settings, clock, model, state, work, log)
    update_moving_set(work.window[0], work.window[1], clock, model, state)
    for q in range(ncand):
        if work.cand_root[q] <= limit:
            i = work.cand_index[q]
            kind = work.cand_kind[q]
            # A slip decided at the root is logged here (settle saw the new mode already).
            if kind == EventKind.SLIP and state.slide[i] != 0 and state.v[i] == 0.0:
                log_event(t_new, EventKind.SLIP, i, clock, log)
    for q in range(ncand):
        if work.cand_root[q] <= limit:
            kind = work.cand_kind[q]
            if (kind == EventKind.CONTACT_OPEN or kind == EventKind.CONTACT_CLOSE
                    or kind == SWITCH_ON or kind == FORCE_OPEN or kind == FORCE_CLOSE):
                work.contact_flag[work.cand_index[q]] = 0
            elif kind == TIME_EVENT:
                continue
            else:
                work.granule_flag[work.cand_index[q]] = 0
    return _after_batch(law, dissip, t_new, tau_e, nev_before, opened, settings, clock, model,
                        state, frames)


@callee(error_model="numpy", _nrt=False)
def _after_batch(law, dissip, t_new, tau_e, nev_before, opened, settings, clock, model, state,
                 frames):
    """The run's ends after an event batch: Zeno, separation, rest, the event
    limit, the overdamped jump. Returns a Status or GOING."""
    if tau_e == 0.0 and clock.n_events == nev_before:
        # A root at the step's start that changes no mode: count it as a batch
        # that does not advance time, so a loop ends as Zeno.
        clock.zeno += 1
        if clock.zeno >= ZENO_BATCHES:
            record_frame(law, t_new, clock, model, state, frames, 0.0, 0.0)
            return Status.ZENO.value
    if clock.n_events <= nev_before:
        return GOING
    # Zeno: many event batches in a window that does not advance time.
    if t_new - clock.last_event <= 1e-12 * max(abs(t_new), 1.0):
        clock.zeno += 1
    else:
        clock.zeno = 0
    clock.last_event = t_new
    clock.batches += 1
    at_events = settings.frames_at_events == 1
    if at_events or opened == 1:
        record_frame(law, t_new, clock, model, state, frames, 0.0, 0.0)
    if opened == 1 and settings.stop_separation == 1:
        return Status.SEPARATED.value
    code = GOING
    if settings.stop_rest == 1 and all_at_rest(law, clock, model, state):
        code = Status.AT_REST.value
    elif clock.n_events >= settings.max_events:
        code = Status.MAX_EVENTS.value
    elif clock.zeno >= ZENO_BATCHES:
        code = Status.ZENO.value
    if code != GOING:
        if not at_events:
            record_frame(law, t_new, clock, model, state, frames, 0.0, 0.0)
        return code
    if dissip is None and try_jump(law, settings, clock, model, state):
        record_frame(law, clock.time, clock, model, state, frames, 0.0, 0.0)
        return Status.T_END.value
    return GOING
