"""Modes: which contacts are closed, which granules slide, stick or move at all.

Contacts: closed iff delta > 0, or delta = 0 and the first non-zero derivative
(relative velocity, then relative acceleration) is positive. Granules with
Coulomb friction (``slide``): +-1 sliding along v when v != 0; at v = 0 stuck
(0) if |F| <= eta_static (slip at |F| = eta_static only if |F| is growing),
else sliding along F; 2 for a frictionless granule. :func:`settle` re-derives
the modes after an event batch and logs what changed.

The moving set (:func:`is_moving`: sliding granules, frictionless granules that
move or have a closed contact) is kept incrementally, and ``settle`` works on
a window around each batch, so steps and events cost O(active), not O(N).
"""

import numba

from ..._compile import callee, kernel
from ...codes import EventKind
from ...laws.contact import LAW_LINEAR, contact_energy, contact_force
from ...laws.damping import damped_contact_force, dashpot_force
from ...laws.wall_motion import WALL_PULSE


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _contact_force(law, model, state, j):
    """Force of contact j, its dashpot's included (0 when absent or open)."""
    if model.present[j] == 0 or state.closed[j] == 0:
        return 0.0
    if model.damping[j] != 0.0:
        d = state.overlap[j]
        if d == 0.0:
            # Closed at zero overlap (closing now, w >= 0): the dashpot's force
            # is its limit from d > 0, c w for a linear dashpot (A k w for a
            # viscoelastic one at n = 2), which the law (0 at d <= 0, an open
            # contact for Verlet) leaves out. Without it a stuck granule met by
            # the jump read F = 0 and slipped backwards (Zeno at first contact).
            d = 5e-324
        return damped_contact_force(law, model.dashpot[0], model.dashpot[1], d,
                                    _rate(state, j), model.stiffness[j], model.exponent[j],
                                    model.damping[j])
    return contact_force(law, state.overlap[j], model.stiffness[j], model.exponent[j])


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _rate(state, j):
    """d(delta_j)/dt now (the walls' velocities at the ends)."""
    N = state.v.size
    vl = state.v[j - 1] if j >= 1 else state.wall_rate[0]
    vr = state.v[j] if j < N else state.wall_rate[1]
    return vl - vr


@callee(error_model="numpy", _nrt=False)
def spring_force(law, model, state, i, skip):
    """Net contact force on granule i (contact ``skip`` left out; -5: none), plus
    its body force.

    Parameters
    ----------
    law : int
        Contact-law code (``laws.contact``; LAW_LINEAR for n = 2), a compile-time constant.
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).
    i : int
        Granule index, kernel numbering 0..N-1.
    skip : int
        Contact left out of the sum (kernel numbering; -5: none).

    Returns
    -------
    float
        The force, kernel units (positive towards increasing x).
    """
    f = 0.0
    if model.body[i] != 0.0:
        f = model.body[i]
    if skip != i:
        f += _contact_force(law, model, state, i)
    if skip != i + 1:
        f -= _contact_force(law, model, state, i + 1)
    return f


@callee(error_model="numpy", _nrt=False)
def force_rate(law, model, state, j):
    """Time derivative of the force of contact j, k (n - 1) delta^(n-2) w (0 when open).

    Parameters
    ----------
    law : int
        Contact-law code (``laws.contact``; LAW_LINEAR for n = 2), a compile-time constant.
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).
    j : int
        Contact index, kernel numbering 0..N (0: left wall, N: right wall).

    Returns
    -------
    float
        dF/dt, kernel units (force per time); 0 for an open or absent contact.
    """
    overlap = state.overlap
    if model.present[j] == 0 or state.closed[j] == 0 or overlap[j] < 0.0:
        return 0.0
    N = state.v.size
    vl = state.v[j - 1] if j >= 1 else 0.0
    vr = state.v[j] if j < N else 0.0
    w = vl - vr
    if law == LAW_LINEAR:
        return model.stiffness[j] * w
    if overlap[j] == 0.0:
        return 0.0
    a = model.exponent[j] - 1.0
    return model.stiffness[j] * a * overlap[j] ** (a - 1.0) * w


@callee(error_model="numpy", _nrt=False)
def acceleration(law, model, state, i, skip):
    """Acceleration of granule i in its mode (0 when stuck or outside the chain).

    Parameters
    ----------
    law : int
        Contact-law code (``laws.contact``; LAW_LINEAR for n = 2), a compile-time constant.
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).
    i : int
        Granule index, kernel numbering (outside 0..N-1: 0 returned).
    skip : int
        Contact left out of the sum (kernel numbering; -5: none).

    Returns
    -------
    float
        The acceleration, kernel units (length / time^2).
    """
    N = state.v.size
    if i < 0 or i >= N:
        return 0.0
    s = state.slide[i]
    if s == 0:
        return 0.0
    a = spring_force(law, model, state, i, skip) - model.gamma[i] * state.v[i]
    if s == 1 or s == -1:
        a -= model.eta[i] * s
    return a / model.mass[i]


@kernel(error_model="numpy", _nrt=False)
def initial_friction_modes(model, state):
    """Friction modes at the start.

    ``has_coulomb`` 1 where a static threshold exists (Coulomb friction),
    ``slide`` the sign of v there, 2 (no friction) elsewhere; both written in place.

    Parameters
    ----------
    model : ChainArrays
        The chain's constants; ``eta_static`` (N,) read, ``has_coulomb`` (N,) written.
    state : MotionState
        ``v`` (N,) read (kernel units), ``slide`` (N,) written.
    """
    v, slide = state.v, state.slide
    for i in range(v.size):
        if model.eta_static[i] > 0.0:
            model.has_coulomb[i] = 1
            slide[i] = 1 if v[i] > 0.0 else (-1 if v[i] < 0.0 else 0)
        else:
            model.has_coulomb[i] = 0
            slide[i] = 2


@callee(error_model="numpy", _nrt=False)
def _force_mode(law, j, model, state):
    """Mode of a non-tensile contact of positive overlap: closed while its total force
    (spring + dashpot) pushes; a force within 64 ulps of its parts (a zero just
    located) keeps the mode."""
    d, k, n, c = state.overlap[j], model.stiffness[j], model.exponent[j], model.damping[j]
    w = _rate(state, j)
    spring = contact_force(law, d, k, n)
    dash = dashpot_force(law, model.dashpot[0], d, w, k, n, c)
    f = spring + dash
    if abs(f) <= 64.0 * 2.2e-16 * (abs(spring) + abs(dash)):
        return state.closed[j]
    return 1 if f > 0.0 else 0


@callee(error_model="numpy", _nrt=False)
def _contact_mode(law, j, model, state, work):
    """The mode contact j must have now (1 closed, 0 open)."""
    N = state.v.size
    d = state.overlap[j]
    forced = work.contact_flag[j]
    if forced >= 2 and (d == 0.0 or (model.damping[j] != 0.0 and model.dashpot[1] == 0)):
        # closed or opened by a located root: the root's direction (from the
        # series) decides, not a roundoff-level derivative.
        return 1 if forced == 2 else 0
    if d > 0.0:
        if model.damping[j] != 0.0 and model.dashpot[1] == 0:
            return _force_mode(law, j, model, state)
        return 1
    if d < 0.0:
        return 0
    vl = state.v[j - 1] if j >= 1 else 0.0
    vr = state.v[j] if j < N else 0.0
    w = vl - vr
    if j == 0:
        w += state.wall_rate[0]
    elif j == N:
        w -= state.wall_rate[1]
    if w > 0.0:
        return 1
    if w < 0.0:
        return 0
    ar = acceleration(law, model, state, j - 1, j) - acceleration(law, model, state, j, j)
    if ar > 0.0:
        return 1
    if ar < 0.0 or state.closed[j] == 0:
        return 0
    # delta, w and the relative acceleration all vanish: a touching contact that
    # a pulse has not reached yet (a chain of touching grains). The sign is set
    # by a higher derivative, which the step's series has to order P: keep the
    # mode, and the step's root search at tau = 0 (first non-zero coefficient)
    # opens it if it must. Deciding "open" here reopened the contact a batch
    # had just closed, and a struck chain of 4 touching grains chattered to a
    # Zeno stop at t = 0.
    return 1


@callee(error_model="numpy", _nrt=False)
def _friction_mode(law, i, model, state, work):
    """The friction mode granule i (with Coulomb friction) must have now."""
    v = state.v[i]
    if v > 0.0:
        return 1
    if v < 0.0:
        return -1
    if work.granule_flag[i] == 2:  # a slip located by a root: kept
        return state.slide[i]
    F = spring_force(law, model, state, i, -5)
    es = model.eta_static[i]
    if F > es:
        return 1
    if F < -es:
        return -1
    if abs(F) == es and es > 0.0:
        dF = force_rate(law, model, state, i) - force_rate(law, model, state, i + 1)
        if F > 0.0 and dF > 0.0:
            return 1
        if F < 0.0 and dF < 0.0:
            return -1
    return 0


@callee(error_model="numpy", _nrt=False)
def _save_old(state, work, a, b):
    """Save the modes of granules a..b and contacts a..b+1 (clipped)."""
    N = state.slide.size
    for i in range(max(a, 0), min(b, N - 1) + 1):
        work.old_slide[i] = state.slide[i]
    for j in range(max(a, 0), min(b + 1, N) + 1):
        work.old_closed[j] = state.closed[j]


@callee(error_model="numpy", _nrt=False)
def _settle_window(law, model, state, work):
    """Iterate the modes of the window ``work.window`` to a fixed point.

    Modes change only next to an event, and a change propagates to its
    neighbours only, so the window grows by one on a side where something
    changed at its edge. On return ``work.window`` holds the final window.
    """
    N = state.v.size
    closed, slide = state.closed, state.slide
    lo = max(work.window[0], 0)
    hi = min(work.window[1], N - 1)
    _save_old(state, work, lo, hi)
    for _ in range(64):
        changed = False
        nlo = lo
        nhi = hi
        for j in range(lo, hi + 2):
            if model.present[j] == 0:
                continue
            new = _contact_mode(law, j, model, state, work)
            if new != closed[j]:
                closed[j] = new
                changed = True
                nlo = min(nlo, j - 2)
                nhi = max(nhi, j + 1)
        for i in range(lo, hi + 1):
            if model.has_coulomb[i] == 0:
                continue
            new = _friction_mode(law, i, model, state, work)
            if new != slide[i]:
                slide[i] = new
                changed = True
                nlo = min(nlo, i - 1)
                nhi = max(nhi, i + 1)
        nlo = max(nlo, 0)
        nhi = min(nhi, N - 1)
        # newly included granules and contacts (untouched so far): save their modes
        for i in range(nlo, lo):
            work.old_slide[i] = slide[i]
            work.old_closed[i] = closed[i]
        for i in range(hi + 1, nhi + 1):
            work.old_slide[i] = slide[i]
            work.old_closed[i + 1] = closed[i + 1]
        lo = nlo
        hi = nhi
        if not changed:
            break
    work.window[0] = lo
    work.window[1] = hi


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def log_event(t, kind, index, clock, log):
    """Append an event (time, codes.EventKind, model index) to the log.

    Parameters
    ----------
    t : float
        Time of the event, kernel units.
    kind : int
        A :class:`~granular_chain.codes.EventKind` code.
    index : int
        Model numbering: contact i between granules i, i + 1 (-1: left wall), or granule i.
    clock : record of CLOCK_DTYPE
        The run's clock and work totals (kernel units), advanced in place.
    log : EventLog
        The event log (E rows), grown by the driver.
        Must have room for row ``clock.n_events``.
    """
    n = clock.n_events
    log.t[n] = t
    log.kind[n] = kind
    log.index[n] = index
    clock.n_events = n + 1
    log.counts[kind] += 1


@callee(error_model="numpy", _nrt=False)
def settle(law, t, settings, clock, model, state, work, log):
    """Re-derive the modes in ``work.window`` from the state at an event batch
    (time t) and log what changed.

    Cost: the window, not N (see :func:`_settle_window`).

    Parameters
    ----------
    law : int
        Contact-law code (``laws.contact``; LAW_LINEAR for n = 2), a compile-time constant.
    t : float
        Time of the event batch, kernel units.
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
    log : EventLog
        The event log (E rows), grown by the driver.

    Returns
    -------
    int
        1 if the watched contact (``settings.watch``) opened, else 0.
    """
    _settle_window(law, model, state, work)
    lo, hi = work.window[0], work.window[1]
    closed, slide, old_c, old_s = state.closed, state.slide, work.old_closed, work.old_slide
    opened = 0
    for j in range(lo, hi + 2):
        if closed[j] != old_c[j]:
            if model.damping[j] != 0.0 and state.overlap[j] > 0.0:
                # a non-tensile contact opening (closing) at overlap > 0: its spring's
                # energy leaves (enters) the elastic energy, which counts closed contacts
                e = contact_energy(law, state.overlap[j], model.stiffness[j], model.exponent[j])
                clock.work_contact += e if closed[j] == 0 else -e
            kind = EventKind.CONTACT_CLOSE if closed[j] == 1 else EventKind.CONTACT_OPEN
            log_event(t, kind, j - 1, clock, log)
            if j == settings.watch:
                if closed[j] == 1:
                    clock.watched = 1
                elif clock.watched == 1:
                    opened = 1
    for i in range(lo, hi + 1):
        if model.has_coulomb[i] == 0 or state.v[i] != 0.0:
            continue
        if (old_s[i] == 1 or old_s[i] == -1) and work.granule_flag[i] == 3:
            log_event(t, EventKind.STOP, i, clock, log)
        if (slide[i] == 1 or slide[i] == -1) and slide[i] != old_s[i]:
            log_event(t, EventKind.SLIP, i, clock, log)
    return opened


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def is_moving(i, state, model):
    """Member of the moving set: sliding, or frictionless and not at rest
    force-free (v != 0 or a closed contact).

    A frictionless granule at rest with open contacts stays at rest until one
    of them closes, which is an event of its moving neighbour, so it costs
    nothing until then.

    Parameters
    ----------
    i : int
        Granule index, kernel numbering 0..N-1.
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).

    Returns
    -------
    int
        1 if granule i belongs to the moving set, else 0.
    """
    s = state.slide[i]
    if s == 1 or s == -1:
        return 1
    if s == 0:
        return 0
    if state.v[i] != 0.0 or model.body[i] != 0.0:
        return 1
    if model.present[i] == 1 and state.closed[i] == 1:
        return 1
    if model.present[i + 1] == 1 and state.closed[i + 1] == 1:
        return 1
    return 0


@callee(error_model="numpy", _nrt=False)
def update_moving_set(lo, hi, clock, model, state):
    """Add to or remove from the moving set the granules lo..hi whose membership changed.

    Parameters
    ----------
    lo, hi : int
        First and last granule (kernel numbering, inclusive) to re-examine.
    clock : record of CLOCK_DTYPE
        The run's clock and work totals (kernel units), advanced in place.
        ``n_moving`` is updated.
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).
        ``moving``, ``is_moving``, ``moving_pos`` are updated.
    """
    in_moving, pos, mov = state.is_moving, state.moving_pos, state.moving
    nmv = clock.n_moving
    for i in range(lo, hi + 1):
        inn = is_moving(i, state, model)
        if inn == 1 and in_moving[i] == 0:
            in_moving[i] = 1
            pos[i] = nmv
            mov[nmv] = i
            nmv += 1
        elif inn == 0 and in_moving[i] == 1:
            in_moving[i] = 0
            last = mov[nmv - 1]
            mov[pos[i]] = last
            pos[last] = pos[i]
            nmv -= 1
    clock.n_moving = nmv


@callee(error_model="numpy", _nrt=False)
def all_at_rest(law, clock, model, state):
    """Every granule at rest for good.

    Granules outside the moving set are stuck (v = 0 exactly): only the moving
    set needs a look. A moving wall (or a pulse about to move) means not at rest.

    Parameters
    ----------
    law : int
        Contact-law code (``laws.contact``; LAW_LINEAR for n = 2), a compile-time constant.
    clock : record of CLOCK_DTYPE
        The run's clock and work totals (kernel units), advanced in place.
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).

    Returns
    -------
    bool
        True when nothing can move again.
    """
    for side in range(2):
        # a wall that moves (or will: a sine at a turning point) can set them going
        kind = model.wall_motion[side, 0]
        if kind != 0.0 and (kind != WALL_PULSE or state.wall_rate[side] != 0.0):
            return False
    for q in range(clock.n_moving):
        i = state.moving[q]
        if state.v[i] != 0.0:
            return False
        if model.has_coulomb[i] == 0:
            if spring_force(law, model, state, i, -5) != 0.0:
                return False
        elif state.slide[i] != 0:
            return False
    return True
