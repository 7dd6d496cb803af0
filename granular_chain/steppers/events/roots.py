"""Roots of the event conditions: the first time in a step where a mode stops being valid.

Each event function g is a polynomial of the step (``sgn * poly(c) - shift``,
from the series) and g < 0 on the valid side of the mode. A rigorous
exclusion bound comes first, then sampling (sign changes, and interior maxima
for grazing), then Brent's method to machine precision.

Candidates (:func:`contact_candidates`, :func:`friction_candidates`) are
written to ``work.cand_kind / cand_index / cand_root``: a codes.EventKind, or
:data:`SWITCH_ON` (a contact's force switched on again, no event) or
:data:`CENTRES_MEET` (an overlap reached its limit: the run ends).
"""

import math

import numba

from ..._compile import callee
from ...codes import EventKind
from .series import horner_d

#: Candidate kind of a contact whose force is switched on again (no event).
SWITCH_ON = -1
#: Candidate kind of an overlap reaching its limit (the centres meet): ends the run.
CENTRES_MEET = -2
#: Samples of a step in the search for a sign change or a grazing maximum.
SAMPLES = 16


@callee(error_model="numpy", _nrt=False)
def _g(c, P, sgn, shift, deriv, x):
    s, d = horner_d(c, P, x)
    if deriv:
        return sgn * d
    return sgn * s - shift


@callee(error_model="numpy", _nrt=False)
def _brent(c, P, sgn, shift, deriv, xa, xb, fa, fb):
    """Brent's root of g on [xa, xb] with fa*fb <= 0 (scipy's brentq, rtol 4 eps)."""
    if fa == 0.0:
        return xa
    if fb == 0.0:
        return xb
    xpre, xcur = xa, xb
    fpre, fcur = fa, fb
    xblk = 0.0
    fblk = 0.0
    spre = 0.0
    scur = 0.0
    for _ in range(200):
        if fpre != 0.0 and fcur != 0.0 and (fpre > 0.0) != (fcur > 0.0):
            xblk = xpre
            fblk = fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre = xcur
            xcur = xblk
            xblk = xpre
            fpre = fcur
            fcur = fblk
            fblk = fpre
        delta = (4.4e-16 * abs(xcur) + 1e-300) / 2.0
        sbis = (xblk - xcur) / 2.0
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2.0 * abs(stry) < min(abs(spre), 3.0 * abs(sbis) - delta):
                spre = scur
                scur = stry
            else:
                spre = sbis
                scur = sbis
        else:
            spre = sbis
            scur = sbis
        xpre = xcur
        fpre = fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0 else -delta
        fcur = _g(c, P, sgn, shift, deriv, xcur)
    return xcur


@callee(error_model="numpy", _nrt=False)
def first_root(c, P, sgn, shift, h):
    """First tau in [0, h] where g = sgn * poly(c) - shift reaches 0 from below.

    g < 0 is the valid side of the mode. Returns inf when g stays negative on
    [0, h] (proved by a bound, or by sampling plus a check of every interior
    maximum for a grazing touch).

    Parameters
    ----------
    c : ndarray, shape (>= P + 1,)
        Taylor coefficients of the event function's series in the step time
        (kernel units of its quantity: overlap, velocity or force).
    P : int
        Taylor order (last coefficient c[P]).
    sgn : float
        +1.0 or -1.0: the sign the series is taken with, dimensionless.
    shift : float
        Level subtracted, in the units of the series' quantity (0 for a sign change).
    h : float
        End of the interval searched, kernel time units.

    Returns
    -------
    float
        The root, kernel time units in [0, h], or ``math.inf`` when there is none.
    """
    g0 = sgn * c[0] - shift
    bound = 0.0
    hk = 1.0
    for k in range(1, P + 1):
        hk *= h
        bound += abs(c[k]) * hk
    if g0 + bound < 0.0:
        return math.inf
    if g0 > 0.0:
        return 0.0
    if g0 == 0.0:
        flat = True
        for k in range(1, P + 1):
            if c[k] != 0.0:
                flat = False
                if sgn * c[k] > 0.0:
                    return 0.0
                break
        if flat:
            return math.inf  # g = 0 identically (touching, nothing moves): no crossing
    a = 0.0
    ga = g0
    da = sgn * c[1]
    for s in range(1, SAMPLES + 1):
        b = h * s / SAMPLES
        vb, dvb = horner_d(c, P, b)
        gb = sgn * vb - shift
        db = sgn * dvb
        if gb > 0.0:
            if ga == 0.0:
                # Started exactly on g = 0 going negative: find a point inside with g < 0.
                # Halve down to the smallest double if need be: a granule leaving a
                # wall at 1e-100 under friction has g < 0 only for tau < 2e-98, and
                # 80 halvings returned a root at 0 that the modes undid (Zeno).
                x = b
                for _ in range(1100):
                    x *= 0.5
                    gx = _g(c, P, sgn, shift, False, x)
                    if gx < 0.0:
                        a = x
                        ga = gx
                        break
                if ga == 0.0:
                    return 0.0
            return _brent(c, P, sgn, shift, False, a, b, ga, gb)
        if da > 0.0 and db < 0.0:
            # An interior maximum: a grazing touch may hide between two samples.
            xm = _brent(c, P, sgn, 0.0, True, a, b, da, db)
            gm = _g(c, P, sgn, shift, False, xm)
            if gm > 0.0:
                if ga == 0.0:
                    return xm
                return _brent(c, P, sgn, shift, False, a, xm, ga, gm)
        a = b
        ga = gb
        da = db
    return math.inf


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _add(work, ncand, kind, index, root):
    work.cand_kind[ncand] = kind
    work.cand_index[ncand] = index
    work.cand_root[ncand] = root
    return ncand + 1


@callee(error_model="numpy", _nrt=False)
def switch_on_overlap(P, tol_v, w, n, k, Dj):
    """Overlap ``delta_on`` at which a closed contact whose force is off gets it
    back (-1: none), so that the impulse left out stays below tol_v / 10.

    Where a term ``a tau^m`` (``a = Dj[m] > 0``) carries the overlap's growth,
    leaving the force ``k delta^(n-1)`` out until ``delta = don`` omits the
    impulse ``k don^(n-1) (don / a)^(1/m) / (m (n - 1) + 1)``.

    * m = 1 (``w != 0``): also when delta is falling now: near a grazing minimum
      it turns round without opening, and the force left out over the whole dip
      cost 5e-3 of the energy (property tests); ``don`` is 1.5 times the
      overlap whose remaining impulse ``k don^n / (n |w|)`` is tol_v / 10.
    * w = 0: a contact closing from rest (a granule slipped into a touching
      neighbour, m = 2; at its static threshold, where its acceleration
      vanishes too, m = 3); ``don`` is the smallest over the growing terms.
      Without a switch-on root the force stayed off for a whole Taylor step
      and the ledger missed by up to 5e-7 (property tests).

    Parameters
    ----------
    P : int
        Taylor order; ``Dj`` has P + 1 coefficients.
    tol_v : float
        Velocity tolerance, kernel units.
    w : float
        Overlap rate now (walls included), kernel units.
    n, k : float
        The contact's exponent and force coefficient, kernel units.
    Dj : ndarray, shape (>= P + 1,)
        Taylor coefficients of the overlap in the step time.

    Returns
    -------
    float
        ``delta_on``, kernel length units; -1 when the overlap does not grow.
    """
    if Dj[1] != 0.0:
        return 1.5 * (0.1 * n * abs(w) * tol_v / k) ** (1.0 / n)
    # The smallest don over the growing terms: roundoff can leave a tiny term
    # of either sign below the one that carries the growth (a slip located at
    # its threshold has an acceleration of ~1e-17, not 0), and switching on
    # early costs only shorter steps.
    don = -1.0
    for m in range(2, P + 1):
        a = Dj[m]
        if a > 0.0:
            # (delta^(n-1) = a^(n-1) tau^(m(n-1)) is analytic here.)
            dm = (0.1 * tol_v * (m * (n - 1.0) + 1.0) * a ** (1.0 / m)
                  / k) ** (1.0 / (n - 1.0 + 1.0 / m))
            don = dm if don < 0.0 else min(don, dm)
    return don


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def contact_candidates(linear, P, h, tol_v, na, model, state, work):
    """Roots of every contact's event functions within [0, h].

    Opening (and the force switched on again, and the centres meeting) of a
    closed contact, closing of an open one; each is written to
    ``work.cand_kind/cand_index/cand_root`` from index 0.

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
        Number of candidates written.
    """
    D = work.d_series
    tau_e = math.inf
    ncand = 0
    for q in range(na):
        j = work.active[q]
        if state.closed[j] == 1:
            r = first_root(D[j], P, -1.0, 0.0, h)
            ncand = _add(work, ncand, EventKind.CONTACT_OPEN, j, r)
            if work.force_on[j] == 0.0 and not linear:
                vl = state.v[j - 1] if j >= 1 else 0.0
                vr = state.v[j] if j < state.v.size else 0.0
                don = switch_on_overlap(P, tol_v, vl - vr, model.exponent[j],
                                        model.stiffness[j], D[j])
                if D[j, 0] < don:
                    r2 = first_root(D[j], P, 1.0, don, h)
                    ncand = _add(work, ncand, SWITCH_ON, j, r2)
                    r = min(r, r2)
            # the centres meet: the contact model ends here (bound-excluded at
            # once unless the step can reach it)
            r3 = first_root(D[j], P, 1.0, model.overlap_limit[j], h)
            ncand = _add(work, ncand, CENTRES_MEET, j, r3)
            r = min(r, r3)
        else:
            r = first_root(D[j], P, 1.0, 0.0, h)
            ncand = _add(work, ncand, EventKind.CONTACT_CLOSE, j, r)
        tau_e = min(tau_e, r)
    return tau_e, ncand


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def friction_candidates(P, h, rtol, nm, nc, ncand, tau_e, model, state, work):
    """Coulomb friction's roots within [0, h].

    A sliding granule stopping, a stuck one (``work.stuck[:nc]``) whose spring
    force reaches its static threshold; appended to the candidate lists after
    the first ``ncand``.

    Parameters
    ----------
    P : int
        Taylor order; series arrays have P + 1 columns.
    h : float
        Trial step, kernel time units.
    rtol : float
        Relative tolerance of the step control, dimensionless.
    nm : int
        Size of the moving set, ``state.moving[:nm]``.
    nc : int
        Number of stuck granules next to the step's contacts, ``work.stuck[:nc]``.
    ncand : int
        Candidates already written (by :func:`contact_candidates`).
    tau_e : float
        Earliest root so far, kernel time units (``math.inf``: none).
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
        Earliest root so far, kernel time units (``math.inf``: none).
    ncand : int
        Candidates written in all.
    """
    Q = work.row
    V = work.v_series
    slide, mass, eta_s = state.slide, model.mass, model.eta_static
    for q in range(nm):
        i = state.moving[q]
        if slide[i] == 1 or slide[i] == -1:
            for k in range(P + 1):
                Q[k] = V[i, k]
            if V[i, 0] == 0.0 and slide[i] * V[i, 1] < 0.0 and (
                    abs(V[i, 1]) * mass[i] <= max(1e-13, 10.0 * rtol) * eta_s[i]):
                # Just slipped at |F| = eta_s = eta: the initial deceleration is
                # the error of F at the located root (roundoff, or the series
                # tolerance), not physics.
                Q[1] = 0.0
            r = first_root(Q, P, -1.0 * slide[i], 0.0, h)
            ncand = _add(work, ncand, EventKind.STOP, i, r)
            tau_e = min(tau_e, r)
    Fc = work.f_series
    for q in range(nc):
        i = work.stuck[q]
        for k in range(P + 1):
            Q[k] = Fc[i, k] - Fc[i + 1, k]
        if model.body[i] != 0.0:
            Q[0] += model.body[i]
        r = min(first_root(Q, P, 1.0, eta_s[i], h), first_root(Q, P, -1.0, eta_s[i], h))
        ncand = _add(work, ncand, EventKind.SLIP, i, r)
        tau_e = min(tau_e, r)
    return tau_e, ncand
