"""Dashpots, body forces and driven walls in the Taylor-series modes.

Compiled only into the kernels of scenes that have one of them (the kernel's
``dissip`` feature code); elastic chains between fixed walls never reach this
module. In a fixed mode the series of :mod:`.series` gain::

    m_i v_i' = c_i - c_(i+1) - gamma_i v_i - eta_i s_i + f_i     (f_i body force)
    delta_0' = s_L' - v_0,   delta_N' = v_(N-1) - s_R'           (driven walls)
    c_j = k_j delta_j^(n_j - 1) + D_j                            (closed contacts)
    D_j = c delta_j'                  linear dashpot
    D_j = A d/dt (k_j delta_j^(n_j - 1))   viscoelastic

Series rows (``work``): ``s_series`` the spring's force, ``g_series`` spring
plus dashpot (also for an open contact of positive overlap, whose total force
decides when it closes again), ``f_series`` the applied force (``g`` of a
closed contact). The dashpot of order k needs the overlap's (linear) or the
spring's (viscoelastic) coefficient k + 1, which the velocities of order k
already give, so the overlap and spring rows have P + 2 columns.

A non-tensile contact (``model.dashpot[1] == 0``) opens where its total force
reaches zero with the overlap still positive (a root of ``g``, candidate
:data:`FORCE_OPEN`) and closes again if that force turns positive
(:data:`FORCE_CLOSE`); a tensile one opens at overlap 0 like an elastic one.
A pulse wall's stop is a time event (:data:`TIME_EVENT`, no mode changes).

The ledger's terms are exact in the mode: the dashpot's work is the integral
of (g - s) delta' and the walls' work the integral of F_L s_L' - F_R s_R',
both products of series integrated to degree 2P.
"""

import math

import numba

from ..._compile import callee
from ...codes import EventKind
from ...laws.contact import LAW_LINEAR, contact_force
from ...laws.damping import DAMPING_LINEAR
from ...laws.wall_motion import WALL_PULSE, WALL_SINE, WALL_VELOCITY, wall_speed
from .roots import CENTRES_MEET, SWITCH_ON, first_root, switch_on_overlap
from .series import force_term

#: Candidate kind: a non-tensile contact's total force reaches zero (it opens, overlap > 0).
FORCE_OPEN = -3
#: Candidate kind: an open contact of positive overlap whose total force turns positive.
FORCE_CLOSE = -4
#: Candidate kind: a pulse wall stops (the wall series change; no mode does).
TIME_EVENT = -5
#: A total force within this many ulps of its parts counts as zero (just located).
ZERO_ULPS = 64.0


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _pulse_on(p2, t, tlo):
    """A pulse wall still moves at time t + tlo (its end, to a few ulps, counts as past)."""
    return (p2 - t) - tlo > 4.0 * 2.2e-16 * abs(p2)


@callee(error_model="numpy", _nrt=False)
def wall_rates(t, tlo, model, state):
    """The walls' velocities at time t + tlo into ``state.wall_rate``.

    Parameters
    ----------
    t : float
        Time, kernel units (high part of the double-double clock).
    tlo : float
        Low part of the time ``t``, kernel units.
    model : ChainArrays
        The chain's constants; ``wall_motion`` (2, 3) read.
    state : MotionState
        ``wall_rate`` (2,) written: s_L', s_R', kernel units (length / time).
    """
    for side in range(2):
        kind = int(model.wall_motion[side, 0])
        p1, p2 = model.wall_motion[side, 1], model.wall_motion[side, 2]
        if kind == WALL_PULSE:
            state.wall_rate[side] = p1 if _pulse_on(p2, t, tlo) else 0.0
        else:
            state.wall_rate[side] = wall_speed(kind, p1, p2, t + tlo)


@callee(error_model="numpy", _nrt=False)
def wall_series(P, t, tlo, model, work):
    """Taylor coefficients 1..P+1 of each wall's displacement at time t + tlo
    (coefficient 0 is not needed: overlaps are state variables).

    Parameters
    ----------
    P : int
        Taylor order; series arrays have P + 1 columns.
    t : float
        Time, kernel units (high part of the double-double clock).
    tlo : float
        Low part of the time ``t``, kernel units.
    model : ChainArrays
        The chain's constants; ``wall_motion`` (2, 3) read.
    work : Workspace
        ``wall_series`` (2, P + 2) written, kernel units (length / time^k).
    """
    W = work.wall_series
    T = t + tlo
    for side in range(2):
        kind = int(model.wall_motion[side, 0])
        p1, p2 = model.wall_motion[side, 1], model.wall_motion[side, 2]
        for k in range(P + 2):
            W[side, k] = 0.0
        if kind == WALL_VELOCITY:
            W[side, 1] = p1
        elif kind == WALL_PULSE:
            W[side, 1] = p1 if _pulse_on(p2, t, tlo) else 0.0
        elif kind == WALL_SINE:
            om = 2.0 * math.pi * p2
            sn, cs = math.sin(om * T), math.cos(om * T)
            c = p1
            for k in range(1, P + 2):
                c *= om / k
                r = k % 4  # d^k/dx^k sin = sin, cos, -sin, -cos
                W[side, k] = c * (sn if r == 0 else cs if r == 1 else -sn if r == 2 else -cs)


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def contact_rate(model, state, j):
    """d(delta_j)/dt now: v_(j-1) - v_j with the walls' velocities at the ends.

    Parameters
    ----------
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).
    j : int
        Contact index, kernel numbering 0..N.

    Returns
    -------
    float
        The overlap's rate, kernel units (length / time).
    """
    N = state.v.size
    vl = state.v[j - 1] if j >= 1 else state.wall_rate[0]
    vr = state.v[j] if j < N else state.wall_rate[1]
    return vl - vr


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def non_tensile(model, j):
    """Contact j has a dashpot and its total force may not pull."""
    return model.damping[j] != 0.0 and model.dashpot[1] == 0


@callee(error_model="numpy", _nrt=False)
def _spring_on(law, tol_v, j, model, state):
    """Whether contact j's spring (and a viscoelastic dashpot) series is computed:
    n = 2 always; other n once the impulse left out, spring ``k d^n/(n |w|)`` plus
    viscoelastic dashpot ``A k d^(n-1)``, exceeds a tenth of the velocity tolerance
    (the branch point at d = 0, as :func:`.series._switch_forces`)."""
    d = state.overlap[j]
    if law == LAW_LINEAR:
        return True
    if d <= 0.0:
        return False
    k, n = model.stiffness[j], model.exponent[j]
    w = abs(contact_rate(model, state, j))
    imp = k * d ** n
    if model.dashpot[0] != DAMPING_LINEAR:
        imp += model.damping[j] * k * d ** (n - 1.0) * n * w
    return imp > 0.1 * n * w * tol_v


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _dash_term(model, j, D, S, k):
    """k-th coefficient of contact j's dashpot force from its overlap and spring rows."""
    if model.dashpot[0] == DAMPING_LINEAR:
        return model.damping[j] * (k + 1) * D[j, k + 1]
    return model.damping[j] * (k + 1) * S[j, k + 1]


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _overlap_term(model, state, work, j, k):
    """Coefficient k + 1 of contact j's overlap from the velocities' (and walls') k-th."""
    N = state.v.size
    V, W = work.v_series, work.wall_series
    vl = 0.0
    vr = 0.0
    if j >= 1 and state.is_moving[j - 1] == 1:
        vl = V[j - 1, k]
    if j < N and state.is_moving[j] == 1:
        vr = V[j, k]
    d = (vl - vr) / (k + 1)
    if j == 0:
        d += W[0, k + 1]
    if j == N:
        d -= W[1, k + 1]
    return d


@callee(error_model="numpy", _nrt=False)
def _start_rows(law, tol_v, na, model, state, work):
    """Order 0 of the step's contacts: overlap, spring, which springs are computed
    (``work.force_on``: closed and on, as the elastic path's) and, in ``work.row``
    per contact (indexed by j), 1.0 where the force series are computed at all."""
    D, S, on, comp = work.d_series, work.s_series, work.force_on, work.row
    for q in range(na):
        j = work.active[q]
        D[j, 0] = state.overlap[j]
        closed = state.closed[j] == 1
        virtual = (not closed) and non_tensile(model, j) and state.overlap[j] > 0.0
        spring = (closed or virtual) and _spring_on(law, tol_v, j, model, state)
        on[j] = 1.0 if (closed and spring) else 0.0
        comp[j] = 1.0 if (closed or virtual) else 0.0
        S[j, 0] = contact_force(law, state.overlap[j], model.stiffness[j],
                                model.exponent[j]) if spring else 0.0
        # spring computed but left out of on[] for a virtual contact: mark it 2
        if spring and not closed:
            comp[j] = 2.0


@callee(error_model="numpy", _nrt=False)
def build_dissipative(law, coulomb, viscous, P, tol_v, nm, na, model, state, work):
    """Taylor coefficients to order P of the moving granules' u, v and of the step's
    contacts' overlaps and forces with dashpots, body forces and moving walls
    (``work.*_series``; ``work.wall_series`` already set for the step).

    Parameters
    ----------
    law : int
        Contact-law code (``laws.contact``; LAW_LINEAR for n = 2), a compile-time constant.
    coulomb : int
        Compile-time feature code: nonzero when some granule has Coulomb friction.
    viscous : int
        Compile-time feature code: nonzero when some granule has viscous friction.
    P : int
        Taylor order; series arrays have P + 1 columns.
    tol_v : float
        Velocity tolerance, kernel units (length / time in units of the scene's
        length and time scale).
    nm : int
        Size of the moving set, ``state.moving[:nm]``.
    na : int
        Number of the step's contacts, ``work.active[:na]``.
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).
    work : Workspace
        Scratch of the step: series (rows, P + 1 or P + 2), candidate lists, flags.
    """
    linear = law == LAW_LINEAR
    mov, act, slide = state.moving, work.active, state.slide
    U, V, D, S, G, Fc = (work.u_series, work.v_series, work.d_series, work.s_series,
                         work.g_series, work.f_series)
    on, comp = work.force_on, work.row
    stiffness, exponent = model.stiffness, model.exponent
    for q in range(nm):
        i = mov[q]
        U[i, 0] = state.u[i]
        V[i, 0] = state.v[i]
    _start_rows(law, tol_v, na, model, state, work)
    for k in range(P + 1):
        for q in range(na):
            j = act[q]
            D[j, k + 1] = _overlap_term(model, state, work, j, k)
            spring = on[j] == 1.0 or comp[j] == 2.0
            S[j, k + 1] = force_term(linear, spring, stiffness[j], exponent[j], D[j], S[j], k + 1)
            g = 0.0
            if comp[j] != 0.0:
                g = S[j, k]
                if model.damping[j] != 0.0 and (spring or model.dashpot[0] == DAMPING_LINEAR):
                    g += _dash_term(model, j, D, S, k)
            G[j, k] = g
            Fc[j, k] = g if state.closed[j] == 1 else 0.0
        if k == P:
            break
        for q in range(nm):
            i = mov[q]
            a = Fc[i, k] - Fc[i + 1, k]
            if viscous:
                a -= model.gamma[i] * V[i, k]
            if k == 0:
                a += model.body[i]
                if coulomb and (slide[i] == 1 or slide[i] == -1):
                    a -= model.eta[i] * slide[i]
            V[i, k + 1] = a / (model.mass[i] * (k + 1))
            U[i, k + 1] = V[i, k] / (k + 1)


@callee(error_model="numpy", _nrt=False)
def _add(work, ncand, kind, index, root):
    work.cand_kind[ncand] = kind
    work.cand_index[ncand] = index
    work.cand_root[ncand] = root
    return ncand + 1


@callee(error_model="numpy", _nrt=False)
def _force_root(P, h, sgn, j, work):
    """First root in [0, h] of contact j's total force going the way ``sgn`` says
    (-1: down to zero, +1: up). A total force within ZERO_ULPS of its parts at
    the start is the zero an event just located, not a crossing."""
    G, S = work.g_series, work.s_series
    g0 = G[j, 0]
    scale = abs(S[j, 0]) + abs(G[j, 0] - S[j, 0])
    if sgn * g0 > 0.0 and abs(g0) <= ZERO_ULPS * 2.2e-16 * scale:
        G[j, 0] = 0.0
        r = first_root(G[j], P, sgn, 0.0, h)
        G[j, 0] = g0
        return r
    return first_root(G[j], P, sgn, 0.0, h)


@callee(error_model="numpy", _nrt=False)
def _switch_on(P, h, tol_v, j, model, state, work):
    """Root of a closed contact whose spring is off reaching the overlap ``don`` at
    which it is switched on, inf when none: the rule of
    :func:`.roots.switch_on_overlap` with the overlap rate counting a moving
    wall's velocity (a wall driven into a granule at rest closes a contact that
    no granule's velocity shows), and a viscoelastic dashpot's impulse
    ``A k d^(n-1)`` counting too."""
    D = work.d_series
    n, k = model.exponent[j], model.stiffness[j]
    don = switch_on_overlap(P, tol_v, contact_rate(model, state, j), n, k, D[j])
    if model.damping[j] != 0.0 and model.dashpot[0] != DAMPING_LINEAR:
        d2 = 1.5 * (0.1 * tol_v / (model.damping[j] * k)) ** (1.0 / (n - 1.0))
        don = d2 if don < 0.0 else min(don, d2)
    if D[j, 0] < don:
        return first_root(D[j], P, 1.0, don, h)
    return math.inf


@callee(error_model="numpy", _nrt=False)
def dissipative_candidates(linear, P, h, tol_v, t, tlo, na, model, state, work):
    """Roots of every contact's event functions within [0, h] with dashpots and
    moving walls, and a pulse wall's stop.

    Parameters
    ----------
    linear : bool
        True for the linear law (n = 2), whose series are exact to roundoff.
    P : int
        Taylor order; series arrays have P + 1 columns.
    h : float
        Trial step, kernel time units.
    tol_v : float
        Velocity tolerance, kernel units (length / time in units of the scene's
        length and time scale).
    t : float
        Time, kernel units (high part of the double-double clock).
    tlo : float
        Low part of the time ``t``, kernel units.
    na : int
        Number of the step's contacts, ``work.active[:na]``.
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).
    work : Workspace
        Scratch of the step: series (rows, P + 1 or P + 2), candidate lists, flags.

    Returns
    -------
    tau_e : float
        Earliest root, kernel time units (``math.inf``: none in [0, h]).
    ncand : int
        Number of candidates written to ``work.cand_*``.
    """
    D = work.d_series
    tau_e = math.inf
    ncand = 0
    for q in range(na):
        j = work.active[q]
        if state.closed[j] == 1:
            r = first_root(D[j], P, -1.0, 0.0, h)
            ncand = _add(work, ncand, EventKind.CONTACT_OPEN, j, r)
            if non_tensile(model, j):
                r1 = _force_root(P, h, -1.0, j, work)
                ncand = _add(work, ncand, FORCE_OPEN, j, r1)
                r = min(r, r1)
            if not linear and work.force_on[j] == 0.0:
                r2 = _switch_on(P, h, tol_v, j, model, state, work)
                ncand = _add(work, ncand, SWITCH_ON, j, r2)
                r = min(r, r2)
            r3 = first_root(D[j], P, 1.0, model.overlap_limit[j], h)
            ncand = _add(work, ncand, CENTRES_MEET, j, r3)
            r = min(r, r3)
        elif non_tensile(model, j) and D[j, 0] > 0.0:
            # the total force of an overlap that is still positive: past the
            # overlap's zero the force is not defined (and a Hertz spring's series
            # sums its other branch), so a root there is none
            r_d = first_root(D[j], P, -1.0, 0.0, h)
            r = _force_root(P, min(h, r_d), 1.0, j, work)
            ncand = _add(work, ncand, FORCE_CLOSE, j, r)
        else:
            r = first_root(D[j], P, 1.0, 0.0, h)
            ncand = _add(work, ncand, EventKind.CONTACT_CLOSE, j, r)
        tau_e = min(tau_e, r)
    for side in range(2):
        if int(model.wall_motion[side, 0]) == WALL_PULSE:
            p2 = model.wall_motion[side, 2]
            if _pulse_on(p2, t, tlo):
                r = (p2 - t) - tlo
                if r <= h:
                    ncand = _add(work, ncand, TIME_EVENT, 0, r)
                    tau_e = min(tau_e, r)
    return tau_e, ncand


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _product_integral(a, b, P, tau):
    """Integral over [0, tau] of (sum_{k<=P} a_k x^k)(sum_{k<=P} (k+1) b_(k+1) x^k):
    a series times the derivative of another (b has P + 2 coefficients), all
    2P + 1 terms of the product."""
    s = 0.0
    for kk in range(2 * P, -1, -1):
        acc = 0.0
        for i in range(max(0, kk - P), min(kk, P) + 1):
            acc += a[i] * (kk - i + 1) * b[kk - i + 1]
        s = s * tau + acc / (kk + 1)
    return s * tau


@callee(error_model="numpy", _nrt=False)
def dissipative_increment(P, na, model, state, work, tau):
    """(dashpot work, wall work) over [0, tau] of the step.

    The integrals of (g - s) delta' over the closed contacts with a dashpot and
    of F_L s_L' - F_R s_R' over the moving walls.

    Parameters
    ----------
    P : int
        Taylor order; series arrays have P + 1 columns.
    na : int
        Number of the step's contacts, ``work.active[:na]``.
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).
    work : Workspace
        Scratch of the step: series (rows, P + 1 or P + 2), candidate lists, flags.
    tau : float
        Time from the step's start, kernel units, 0 <= tau <= step.

    Returns
    -------
    dashpot, wall : float
        Work of the dashpots and work done by the walls over [0, tau], energy in
        kernel units.
    """
    N = state.v.size
    G, S, D, W, Fc = work.g_series, work.s_series, work.d_series, work.wall_series, work.f_series
    row = work.row
    wd = 0.0
    ww = 0.0
    for q in range(na):
        j = work.active[q]
        if state.closed[j] == 1 and model.damping[j] != 0.0:
            for k in range(P + 1):
                row[k] = G[j, k] - S[j, k]
            wd += _product_integral(row, D[j], P, tau)
        if j == 0 and model.wall_motion[0, 0] != 0.0 and state.closed[0] == 1:
            ww += _product_integral(Fc[0], W[0], P, tau)
        if j == N and model.wall_motion[1, 0] != 0.0 and state.closed[N] == 1:
            ww -= _product_integral(Fc[N], W[1], P, tau)
    return wd, ww


@callee(error_model="numpy", _nrt=False)
def branch_cap(h, na, model, work):
    """Keep the step within half the distance ``delta / |delta'|`` to the branch point
    at delta = 0 of a switched-on viscoelastic contact (n != 2).

    Its force has a ``delta^(n-2) delta'`` term, as singular there as the
    spring's derivative; just after the switch-on that point lies a step behind,
    and the step control, scaled by the first coefficients, let a step of 1.5
    times that distance through: its force series summed to a spurious zero
    (a two-grain collision at rtol 1e-12 opened 2e-8 after it began).

    Parameters
    ----------
    h : float
        Step proposed, kernel time units.
    na : int
        Number of the step's contacts, ``work.active[:na]``.
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).
    work : Workspace
        Scratch of the step: series (rows, P + 1 or P + 2), candidate lists, flags.

    Returns
    -------
    float
        The step, kernel time units, <= ``h``.
    """
    if model.dashpot[0] == DAMPING_LINEAR:
        return h
    D = work.d_series
    for q in range(na):
        j = work.active[q]
        if work.force_on[j] == 1.0 and model.damping[j] != 0.0 and D[j, 1] != 0.0:
            h = min(h, 0.5 * D[j, 0] / abs(D[j, 1]))
    return h
