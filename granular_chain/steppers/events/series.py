"""Taylor series of a fixed mode: evaluation, the recurrences, the step size, the ledger.

In a fixed mode (which contacts are closed, which granules slide or stick) the
motion is analytic; its Taylor coefficients follow from automatic
differentiation of::

    u_i' = v_i
    m_i v_i' = c_i - c_(i+1) - gamma_i v_i - eta_i s_i          (s_i = sliding sign)
    delta_j' = v_(j-1) - v_j                                     (contact j between j-1, j)
    c_j = k_j delta_j^(n_j - 1)                                  (closed contacts)

``delta^(n-1)`` is expanded by the power recurrence
``p_k = (1/(k d_0)) sum_{i<k} ((n-1)(k-i) - i) d_(k-i) p_i`` (n = 2: linear).
Only the moving set and the contacts and stuck granules it touches enter a
step (``work.active[:na]``, ``state.moving[:nm]``).
"""

import math

import numba

from ..._compile import callee
from ...laws.contact import LAW_LINEAR, contact_force


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def horner(c, P, x):
    """sum_{k<=P} c_k x^k.

    Parameters
    ----------
    c : ndarray, shape (>= P + 1,)
        Taylor coefficients c_k of a series in the step time (units of the series'
        quantity per kernel time unit ** k).
    P : int
        Order: the last coefficient used is c[P].
    x : float
        Time from the step's start, kernel units.

    Returns
    -------
    float
        The series' value at ``x``, in the units of the quantity.
    """
    s = c[P]
    for k in range(P - 1, -1, -1):
        s = s * x + c[k]
    return s


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def horner_d(c, P, x):
    """Value and derivative of sum c_k x^k.

    Parameters
    ----------
    c : ndarray, shape (>= P + 1,)
        Taylor coefficients c_k of a series in the step time (units of the series'
        quantity per kernel time unit ** k).
    P : int
        Order: the last coefficient used is c[P].
    x : float
        Time from the step's start, kernel units.

    Returns
    -------
    value, derivative : float
        The series and its derivative in ``x`` (units of the quantity, and of
        the quantity per kernel time unit).
    """
    s = c[P]
    d = 0.0
    for k in range(P - 1, -1, -1):
        d = d * x + s
        s = s * x + c[k]
    return s, d


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def increment(c, P, x):
    """sum_{k>=1} c_k x^k (the change over the step, without cancelling c_0).

    Parameters
    ----------
    c : ndarray, shape (>= P + 1,)
        Taylor coefficients c_k of a series in the step time (units of the series'
        quantity per kernel time unit ** k).
    P : int
        Order: the last coefficient used is c[P].
    x : float
        Time from the step's start, kernel units.

    Returns
    -------
    float
        ``horner(c, P, x) - c[0]`` computed without the cancellation, units of the quantity.
    """
    s = c[P]
    for k in range(P - 1, 0, -1):
        s = s * x + c[k]
    return s * x


@numba.njit(inline="always", cache=True, _nrt=False)
def force_term(linear, on, k_c, n_c, Dj, Fj, k):
    """k-th Taylor coefficient of a contact force k_c delta^(n_c - 1).

    Computed from the overlap's coefficients Dj and the force's lower ones Fj
    (power recurrence); 0 when switched off.

    Parameters
    ----------
    linear : bool
        True for n = 2 (the coefficient is k_c Dj[k]).
    on : bool
        Whether the contact's force is switched on (``work.force_on``).
    k_c : float
        The contact's force coefficient k, kernel units (force / length^(n - 1)).
    n_c : float
        The contact's potential exponent n, dimensionless.
    Dj : ndarray, shape (>= k + 1,)
        Taylor coefficients of the overlap, kernel units (length / time^i).
    Fj : ndarray, shape (>= k,)
        The force's coefficients 0..k-1 already computed, kernel units (force / time^i).
    k : int
        Index of the coefficient wanted, k >= 1; Dj[0] must be nonzero unless linear.

    Returns
    -------
    float
        The force's k-th coefficient, kernel units (force / time^k).
    """
    if not on:
        return 0.0
    if linear:
        return k_c * Dj[k]
    al = n_c - 1.0
    s = 0.0
    for ii in range(k):
        s += (al * (k - ii) - ii) * Dj[k - ii] * Fj[ii]
    return s / (k * Dj[0])


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _switch_forces(law, tol_v, na, model, state, work):
    """Zeroth coefficients of the step's overlaps and forces, and which closed
    contacts have their force on (``work.force_on``): always for n = 2; for other
    n only once the force's remaining impulse ``k delta^n / (n |w|)`` exceeds a
    tenth of the velocity tolerance, so the series never straddles delta = 0,
    where the force has a branch point."""
    linear = law == LAW_LINEAR
    N = state.v.size
    v, overlap, stiffness, exponent = state.v, state.overlap, model.stiffness, model.exponent
    D, Fc, on = work.d_series, work.f_series, work.force_on
    for q in range(na):
        j = work.active[q]
        D[j, 0] = overlap[j]
        on[j] = 0.0
        if state.closed[j] == 1:
            if linear:
                on[j] = 1.0
            elif overlap[j] > 0.0:
                vl = v[j - 1] if j >= 1 else 0.0
                vr = v[j] if j < N else 0.0
                aexp = exponent[j]
                if stiffness[j] * overlap[j] ** aexp > 0.1 * aexp * abs(vl - vr) * tol_v:
                    on[j] = 1.0
        Fc[j, 0] = contact_force(law, overlap[j], stiffness[j], exponent[j]) if on[j] == 1.0 else 0.0


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def build_series(law, coulomb, viscous, P, tol_v, nm, na, model, state, work):
    """Taylor coefficients to order P of the moving granules' u, v and of the
    step's contacts' overlaps and forces (``work.*_series``).

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

    Notes
    -----
    Fills rows ``state.moving[:nm]`` of ``work.u_series`` and ``work.v_series``
    and rows ``work.active[:na]`` of ``work.d_series``, ``work.f_series`` and
    ``work.force_on``; returns nothing.
    """
    linear = law == LAW_LINEAR
    N = state.v.size
    mov, act, in_moving, slide = state.moving, work.active, state.is_moving, state.slide
    U, V, D, Fc, on = work.u_series, work.v_series, work.d_series, work.f_series, work.force_on
    stiffness, exponent, mass, eta, gamma = model.stiffness, model.exponent, model.mass, model.eta, model.gamma
    for q in range(nm):
        i = mov[q]
        U[i, 0] = state.u[i]
        V[i, 0] = state.v[i]
    _switch_forces(law, tol_v, na, model, state, work)
    for k in range(P):
        if k >= 1:
            for q in range(na):
                j = act[q]
                Fc[j, k] = force_term(linear, on[j] == 1.0, stiffness[j], exponent[j], D[j], Fc[j], k)
        for q in range(nm):
            i = mov[q]
            a = Fc[i, k] - Fc[i + 1, k]
            if viscous:
                a -= gamma[i] * V[i, k]
            if coulomb:
                if k == 0 and (slide[i] == 1 or slide[i] == -1):
                    a -= eta[i] * slide[i]
            V[i, k + 1] = a / (mass[i] * (k + 1))
            U[i, k + 1] = V[i, k] / (k + 1)
        for q in range(na):
            j = act[q]
            vl = 0.0
            vr = 0.0
            if j >= 1 and in_moving[j - 1] == 1:
                vl = V[j - 1, k]
            if j < N and in_moving[j] == 1:
                vr = V[j, k]
            D[j, k + 1] = (vl - vr) / (k + 1)
    for q in range(na):
        j = act[q]
        Fc[j, P] = force_term(linear, on[j] == 1.0, stiffness[j], exponent[j], D[j], Fc[j], P)


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def step_size(linear, P, rtol, atol, h, nm, na, state, work):
    """The step: ``h`` cut so that the last two terms of every controlled series
    are below ``rtol |x| + atol`` (Jorba & Zou).

    Rows under control: velocities, overlaps and (n != 2) the contact forces
    themselves. The forces are the slip events' functions; left uncontrolled,
    their truncation error is ~P tol/h (V only carries their integral), which
    put slip times off by 4e-12 at rtol 1e-12 and split one slip into a
    spurious slip/stop/slip triple.

    Parameters
    ----------
    linear : bool
        True for the linear law (n = 2), whose series are exact to roundoff.
    P : int
        Taylor order; series arrays have P + 1 columns.
    rtol : float
        Relative tolerance, dimensionless.
    atol : float
        Absolute tolerance, kernel units of each row's quantity (ignored for n = 2).
    h : float
        Largest step allowed, kernel time units.
    nm : int
        Size of the moving set, ``state.moving[:nm]``.
    na : int
        Number of the step's contacts, ``work.active[:na]``.
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).
    work : Workspace
        Scratch of the step: series (rows, P + 1 or P + 2), candidate lists, flags.

    Returns
    -------
    float
        The step, kernel time units, 0 < step <= ``h``.
    """
    nrow = nm + na
    if not linear:
        nrow += na
    for q in range(nrow):
        if q < nm:
            row = work.v_series[state.moving[q]]
        elif q < nm + na:
            row = work.d_series[work.active[q - nm]]
        else:
            jf = work.active[q - nm - na]
            if work.force_on[jf] == 0.0:
                continue
            row = work.f_series[jf]
        sc = max(abs(row[0]), abs(row[1]), abs(row[2]))
        if sc == 0.0:
            for k in range(P + 1):
                sc = max(sc, abs(row[k]))
        tl = rtol * sc + (0.0 if linear else atol)
        if tl <= 0.0:
            continue
        if row[P] != 0.0:
            h = min(h, (tl / abs(row[P])) ** (1.0 / P))
        if row[P - 1] != 0.0:
            h = min(h, (tl / abs(row[P - 1])) ** (1.0 / (P - 1)))
    if not linear:
        h = _grazing_cap(P, h, na, work)
    return h


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _grazing_cap(P, h, na, work):
    """Keep the step inside half the distance to the branch points of a closed
    contact near a grazing minimum (at tau_m, delta_m > 0).

    The force delta^(n-1) has branch points where delta = 0, near
    tau_m +- i sigma, sigma = sqrt(delta_m / D2). The series' first P terms can
    look converged (the singular part's amplitude is tiny) while past those
    points it sums to the other branch, an attractive force: a granule squeezed
    between two walls lost 1e-4 of its energy at any rtol (property tests). An
    actual crossing, delta_m <= 0, is an opening event and ends the step anyway.
    """
    D = work.d_series
    for q in range(na):
        j = work.active[q]
        d2_ = D[j, 2]
        if work.force_on[j] == 1.0 and d2_ > 0.0:
            tm = -D[j, 1] / (2.0 * d2_)
            if abs(tm) < 2.0 * h:
                if abs(tm) <= h:
                    dm = horner(D[j], P, tm)
                else:
                    dm = D[j, 0] + 0.5 * D[j, 1] * tm
                if dm > 0.0:
                    h = min(h, 0.5 * math.sqrt(tm * tm + dm / d2_))
    return h


@callee(error_model="numpy", _nrt=False)
def ledger_increment(coulomb, viscous, P, nm, model, state, work, tau):
    """Energy dissipated by Coulomb and viscous friction over [0, tau] of the step,
    as (coulomb, viscous).

    The viscous work integrates v^2, the square of the step's velocity polynomial
    (degree 2P, all of it) term by term: truncating the square at degree P left
    out terms the velocity's step control never sees (v^2 decays twice as fast),
    and a free granule under drag (n = 5/2, c h = 1.5 per step) lost 1.7e-10 of
    the energy in 16 steps.

    Parameters
    ----------
    coulomb : int
        Feature code: nonzero when some granule has Coulomb friction (a literal in
        the step, a run-time value where frames are made).
    viscous : int
        Feature code: nonzero when some granule has viscous friction (the same).
    P : int
        Taylor order; series arrays have P + 1 columns.
    nm : int
        Size of the moving set, ``state.moving[:nm]``.
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
    coulomb, viscous : float
        Work of Coulomb and of viscous friction over [0, tau], energy in kernel
        units (>= 0 for a granule sliding with the sign of its velocity).
    """
    U, V, slide, eta, gamma = work.u_series, work.v_series, state.slide, model.eta, model.gamma
    wc = 0.0
    wv = 0.0
    for q in range(nm):
        i = state.moving[q]
        if coulomb:
            if slide[i] == 1 or slide[i] == -1:
                wc += eta[i] * slide[i] * increment(U[i], P, tau)
        if viscous:
            if gamma[i] > 0.0:
                wv += square_integral(gamma[i], V[i], P, tau)
    return wc, wv


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def square_integral(weight, c, P, tau):
    """Integral over [0, tau] of weight * (sum_{k<=P} c_k x^k)^2, all 2P + 1 terms.

    The products c_a c_b overflow when the step is far shorter than the
    series' radius (a Hertz force from an overlap of 4e-33 has coefficients
    near 1e300; a granule's stop then ended the step at 1e-98 and the ledger
    read NaN): then the sum is taken again over the coefficients scaled by
    tau^k, the same value without the overflow.

    Parameters
    ----------
    weight : float
        Constant factor (a drag coefficient gamma), kernel units.
    c : ndarray, shape (>= P + 1,)
        Taylor coefficients of the integrand's root (a velocity), kernel units.
    P : int
        Order: the last coefficient used is c[P].
    tau : float
        Upper limit, kernel time units.

    Returns
    -------
    float
        The integral, in the units of weight c^2 times time (an energy).
    """
    s = 0.0
    for kk in range(2 * P, -1, -1):
        acc = 0.0
        for a in range(max(0, kk - P), min(kk, P) + 1):
            acc += c[a] * c[kk - a]
        s = s * tau + acc / (kk + 1)
    if math.isfinite(s):
        return weight * s * tau
    s = 0.0
    for kk in range(2 * P + 1):
        acc = 0.0
        for a in range(max(0, kk - P), min(kk, P) + 1):
            acc += (c[a] * tau ** a) * (c[kk - a] * tau ** (kk - a))
        s += acc / (kk + 1)
    return weight * s * tau
