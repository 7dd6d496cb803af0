"""Compiled core of the event stepper: Taylor-series modes, polynomial events, mode switches.

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
(:mod:`granular_chain.steppers.events_modal`): exact near critical damping,
where a stepper's rounding grows like s (t0 - s).
"""

import math

import numba
import numpy as np
from numba import literally

from ..laws.contact import LAW_LINEAR, contact_energy, contact_force
from ..laws.friction import phi1
from . import events_modal as EM
from .verlet import EV_CLOSE, EV_OPEN, EV_SLIP, EV_STOP  # one numbering of event kinds

# Return codes of run_events.
C_T_END = 0
C_SEPARATED = 1
C_AT_REST = 2
C_MAX_EVENTS = 3
C_ZENO = 4
C_MAX_STEPS = 5
C_BUFFER = 6
C_NONFINITE = 7
C_OVERLAP = 8
C_YIELD = 9  # the call's work budget (ist[I_BUDGET] loop passes) is spent: call again

# Candidate type of an overlap reaching its limit (the centres meet): ends the run.
CAND_OVERLAP = -2


# Float state slots.
S_T, S_TEND, S_OUTDT, S_WC, S_WV, S_LASTEV, S_JUMPFROM, S_HCAP, S_TLO = range(9)
# Time is carried as a double-double (S_T + S_TLO): with thousands of equal
# steps the rounding of t += h is biased, and a time label off by 1e-13 is a
# relative error g*1e-13 in a velocity decaying like exp(-g t).
# Int state slots.
(I_STEPS, I_NEV, I_NFR, I_WATCH, I_STOPSEP, I_STOPREST, I_MAXEV, I_MAXSTEPS, I_STARTED,
 I_WATCHED, I_ZENO, I_FRAMEEV, I_JUMPED, I_FRAMEK, I_EVERY, I_BATCHES, I_NM,
 I_OVERLAP, I_BUDGET) = range(19)
# I_BUDGET: passes of the main loop (a step, or an event batch with its step) one
# call may make before it returns C_YIELD (0: no limit). The state lives in the
# arrays and the check sits between passes, so the next call resumes exactly
# where this one stopped: splitting a run into calls does not change it.

ZENO_BATCHES = 200  # consecutive event batches in a vanishing time window = Zeno
SAMPLES = 16
WINDOW = 3  # samples per search window of the closed-form two-granule path


@numba.njit(inline="always", cache=True, error_model="numpy")
def _horner(c, P, x):
    s = c[P]
    for k in range(P - 1, -1, -1):
        s = s * x + c[k]
    return s


@numba.njit(inline="always", cache=True, error_model="numpy")
def _horner_d(c, P, x):
    """Value and derivative of sum c_k x^k."""
    s = c[P]
    d = 0.0
    for k in range(P - 1, -1, -1):
        d = d * x + s
        s = s * x + c[k]
    return s, d


@numba.njit(inline="always", cache=True, error_model="numpy")
def _increment(c, P, x):
    """sum_{k>=1} c_k x^k (the change over the step, without cancelling c_0)."""
    s = c[P]
    for k in range(P - 1, 0, -1):
        s = s * x + c[k]
    return s * x


@numba.njit(cache=True, error_model="numpy")
def _g(c, P, sgn, shift, deriv, x):
    s, d = _horner_d(c, P, x)
    if deriv:
        return sgn * d
    return sgn * s - shift


@numba.njit(cache=True, error_model="numpy")
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


@numba.njit(cache=True, error_model="numpy")
def first_root(c, P, sgn, shift, h):
    """First tau in [0, h] where g = sgn * poly(c) - shift reaches 0 from below.

    g < 0 is the valid side of the mode. Returns inf when g stays negative on
    [0, h] (proved by a bound, or by sampling plus a check of every interior
    maximum for a grazing touch).
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
        vb, dvb = _horner_d(c, P, b)
        gb = sgn * vb - shift
        db = sgn * dvb
        if gb > 0.0:
            if ga == 0.0:
                # Started exactly on g = 0 going negative: find a point inside with g < 0.
                x = b
                for _ in range(80):
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


@numba.njit(inline="always", cache=True, error_model="numpy")
def _cforce(law, closed, present, dl, kc, nexp, j):
    if present[j] == 0 or closed[j] == 0:
        return 0.0
    return contact_force(law, dl[j], kc[j], nexp[j])


@numba.njit(cache=True, error_model="numpy")
def _spring(law, closed, present, dl, kc, nexp, i, skip):
    """Net spring force on granule i (contact ``skip`` left out)."""
    f = 0.0
    if skip != i:
        f += _cforce(law, closed, present, dl, kc, nexp, i)
    if skip != i + 1:
        f -= _cforce(law, closed, present, dl, kc, nexp, i + 1)
    return f


@numba.njit(cache=True, error_model="numpy")
def _dforce(law, closed, present, dl, kc, nexp, v, j):
    """Time derivative of the force of contact j (0 when open)."""
    if present[j] == 0 or closed[j] == 0 or dl[j] < 0.0:
        return 0.0
    N = v.size
    vl = v[j - 1] if j >= 1 else 0.0
    vr = v[j] if j < N else 0.0
    w = vl - vr
    if law == LAW_LINEAR:
        return kc[j] * w
    if dl[j] == 0.0:
        return 0.0
    a = nexp[j] - 1.0
    return kc[j] * a * dl[j] ** (a - 1.0) * w


@numba.njit(cache=True, error_model="numpy")
def _acc(law, closed, present, dl, kc, nexp, v, slide, mass, eta, gamma, i, skip):
    N = v.size
    if i < 0 or i >= N:
        return 0.0
    if slide[i] == 0:
        return 0.0
    a = _spring(law, closed, present, dl, kc, nexp, i, skip) - gamma[i] * v[i]
    if slide[i] == 1 or slide[i] == -1:
        a -= eta[i] * slide[i]
    return a / mass[i]


@numba.njit(cache=True, error_model="numpy")
def _save_old(closed, slide, old_c, old_s, a, b):
    """Save the modes of granules a..b and contacts a..b+1 (clipped)."""
    N = slide.size
    for i in range(max(a, 0), min(b, N - 1) + 1):
        old_s[i] = slide[i]
    for j in range(max(a, 0), min(b + 1, N) + 1):
        old_c[j] = closed[j]


@numba.njit(cache=True, error_model="numpy")
def settle(law, t, v, dl, closed, present, slide, csl, kc, nexp, mass, eta, eta_s, gamma,
           old_c, old_s, ev_t, ev_k, ev_i, ist, counts, watch_flag, forced, forced_c,
           win):
    """Re-derive the mode from the state at an event and log what changed.

    Contacts: closed iff delta > 0, or delta = 0 and the first non-zero
    derivative (relative velocity, then relative acceleration) is positive.
    Granules with Coulomb friction: slide along v when v != 0; at v = 0 stick
    if |F| <= eta_static (slip at |F| = eta_static only if |F| is growing),
    else slide along F. Iterated to a fixed point (modes depend on each other
    only through these ties). Returns 1 if the watched contact opened.

    Only the window ``win = [lo, hi]`` of granules (contacts lo..hi+1) is
    examined: modes change only next to an event, and a change propagates to
    its neighbours only, so the window grows by one on a side where something
    changed at its edge. On return ``win`` holds the final window (the caller
    updates its active set there). Cost: the window, not N.
    """
    N = v.size
    lo = max(win[0], 0)
    hi = min(win[1], N - 1)
    _save_old(closed, slide, old_c, old_s, lo, hi)
    for _ in range(64):
        changed = False
        nlo = lo
        nhi = hi
        for j in range(lo, hi + 2):
            if present[j] == 0:
                continue
            d = dl[j]
            if d == 0.0 and forced_c[j] >= 2:
                # closed or opened by a located root: the root's direction
                # (from the series) decides, not a roundoff-level derivative.
                new = 1 if forced_c[j] == 2 else 0
            elif d > 0.0:
                new = 1
            elif d < 0.0:
                new = 0
            else:
                vl = v[j - 1] if j >= 1 else 0.0
                vr = v[j] if j < N else 0.0
                w = vl - vr
                if w > 0.0:
                    new = 1
                elif w < 0.0:
                    new = 0
                else:
                    ar = (_acc(law, closed, present, dl, kc, nexp, v, slide, mass, eta, gamma,
                               j - 1, j)
                          - _acc(law, closed, present, dl, kc, nexp, v, slide, mass, eta, gamma,
                                 j, j))
                    if ar > 0.0:
                        new = 1
                    elif ar < 0.0 or closed[j] == 0:
                        new = 0
                    else:
                        # delta, w and the relative acceleration all vanish: a
                        # touching contact that a pulse has not reached yet (a
                        # chain of touching grains). The sign is set by a higher
                        # derivative, which the step's series has to order P:
                        # keep the mode, and the step's root search at tau = 0
                        # (first non-zero coefficient) opens it if it must.
                        # Deciding "open" here reopened the contact a batch
                        # had just closed, and a struck chain of 4 touching
                        # grains chattered to a Zeno stop at t = 0.
                        new = 1
            if new != closed[j]:
                closed[j] = new
                changed = True
                nlo = min(nlo, j - 2)
                nhi = max(nhi, j + 1)
        for i in range(lo, hi + 1):
            if csl[i] == 0:
                continue
            if v[i] > 0.0:
                new = 1
            elif v[i] < 0.0:
                new = -1
            elif forced[i] == 2:
                new = slide[i]
            else:
                F = _spring(law, closed, present, dl, kc, nexp, i, -5)
                es = eta_s[i]
                if F > es:
                    new = 1
                elif F < -es:
                    new = -1
                elif abs(F) == es and es > 0.0:
                    dF = (_dforce(law, closed, present, dl, kc, nexp, v, i)
                          - _dforce(law, closed, present, dl, kc, nexp, v, i + 1))
                    if F > 0.0 and dF > 0.0:
                        new = 1
                    elif F < 0.0 and dF < 0.0:
                        new = -1
                    else:
                        new = 0
                else:
                    new = 0
            if new != slide[i]:
                slide[i] = new
                changed = True
                nlo = min(nlo, i - 1)
                nhi = max(nhi, i + 1)
        nlo = max(nlo, 0)
        nhi = min(nhi, N - 1)
        # newly included granules and contacts (untouched so far): save their modes
        for i in range(nlo, lo):
            old_s[i] = slide[i]
            old_c[i] = closed[i]
        for i in range(hi + 1, nhi + 1):
            old_s[i] = slide[i]
            old_c[i + 1] = closed[i + 1]
        lo = nlo
        hi = nhi
        if not changed:
            break
    win[0] = lo
    win[1] = hi
    opened = 0
    nev = ist[I_NEV]
    for j in range(lo, hi + 2):
        if closed[j] != old_c[j]:
            kind = EV_CLOSE if closed[j] == 1 else EV_OPEN
            ev_t[nev] = t
            ev_k[nev] = kind
            ev_i[nev] = j - 1
            nev += 1
            counts[kind] += 1
            if j == watch_flag:
                if closed[j] == 1:
                    ist[I_WATCHED] = 1
                elif ist[I_WATCHED] == 1:
                    opened = 1
    for i in range(lo, hi + 1):
        if csl[i] == 0 or v[i] != 0.0:
            continue
        if (old_s[i] == 1 or old_s[i] == -1) and forced[i] == 3:
            ev_t[nev] = t
            ev_k[nev] = EV_STOP
            ev_i[nev] = i
            nev += 1
            counts[EV_STOP] += 1
        if (slide[i] == 1 or slide[i] == -1) and slide[i] != old_s[i]:
            ev_t[nev] = t
            ev_k[nev] = EV_SLIP
            ev_i[nev] = i
            nev += 1
            counts[EV_SLIP] += 1
    ist[I_NEV] = nev
    return opened


@numba.njit(cache=True, error_model="numpy")
def _record(law, t, x0, u, v, dl, closed, present, kc, nexp, mass, st, ist,
            fr_t, fr_x, fr_v, fr_f, fr_e, dwc, dwv):
    N = u.size
    k = ist[I_NFR]
    fr_t[k] = t
    ke = 0.0
    pe = 0.0
    for i in range(N):
        fr_x[k, i] = x0[i] + u[i]
        fr_v[k, i] = v[i]
        ke += 0.5 * mass[i] * v[i] * v[i]
        fr_f[k, i] = 0.0
    for j in range(N + 1):
        if present[j] == 0:
            continue
        c = contact_force(law, dl[j], kc[j], nexp[j])
        pe += contact_energy(law, dl[j], kc[j], nexp[j])
        if j >= 1:
            fr_f[k, j - 1] -= c
        if j < N:
            fr_f[k, j] += c
    fr_e[k, 0] = ke
    fr_e[k, 1] = pe
    fr_e[k, 2] = st[S_WC] + dwc
    fr_e[k, 3] = st[S_WV] + dwv
    ist[I_NFR] = k + 1


@numba.njit(cache=True, error_model="numpy")
def _ledger(coulomb, viscous, P, nm, mov, slide, eta, gamma, U, V, Q, tau):
    """Energy dissipated by Coulomb and viscous friction over [0, tau] of the step."""
    wc = 0.0
    wv = 0.0
    for q in range(nm):
        i = mov[q]
        if coulomb:
            if slide[i] == 1 or slide[i] == -1:
                wc += eta[i] * slide[i] * _increment(U[i], P, tau)
        if viscous:
            if gamma[i] > 0.0:
                # integral of v^2: the square of the step's velocity polynomial
                # (degree 2P, all of it), integrated term by term. Truncating the
                # square at degree P left out terms the velocity's step control
                # never sees (v^2 decays twice as fast): a free granule under drag
                # (n = 5/2, c h = 1.5 per step) lost 1.7e-10 of the energy in 16 steps.
                s = 0.0
                for kk in range(2 * P, -1, -1):
                    acc = 0.0
                    for a in range(max(0, kk - P), min(kk, P) + 1):
                        acc += V[i, a] * V[i, kk - a]
                    s = s * tau + acc / (kk + 1)
                wv += gamma[i] * s * tau
    return wc, wv


@numba.njit(cache=True, error_model="numpy")
def _try_jump(law, coulomb, st, ist, u, v, dl, closed, present, csl, kc, mass, gamma):
    """N = 2, n = 2, viscous only, gamma/m equal: decide from the exact modal solution
    whether the closed contact can ever open; if not, move the state to t_end.

    delta'' + c delta' + K delta = 0 (c = gamma/m, K = k (1/m1 + 1/m2)) with
    c^2 >= 4K: delta is a sum of two decaying exponentials (or (a + b t) e^(-ct/2)
    at critical damping), whose only zero is found in closed form.
    """
    N = u.size
    if N != 2 or law != LAW_LINEAR or present[0] == 1 or present[2] == 1 or closed[1] == 0:
        return False
    if csl[0] == 1 or csl[1] == 1:
        return False
    c = gamma[0] / mass[0]
    if c <= 0.0 or gamma[1] / mass[1] != c:
        return False
    K = kc[1] * (1.0 / mass[0] + 1.0 / mass[1])
    disc = c * c - 4.0 * K
    if disc < 0.0:
        return False
    d0 = dl[1]
    w0 = v[0] - v[1]
    T = (st[S_TEND] - st[S_T]) - st[S_TLO]
    if disc > 0.0:
        sq = math.sqrt(disc)
        lp = -EM.slow_rate(K, 0.5 * c, 0.5 * sq)  # sq = 2 kap
        lm = 0.5 * (-c - sq)
        A = (w0 - lm * d0) / (lp - lm)
        B = d0 - A
        if A != 0.0 and -B / A > 1.0:
            return False  # opens at t = ln(-B/A)/(lp - lm) > 0: let the stepper find it
        ep = math.exp(lp * T)
        em = math.exp(lm * T)
        dT = A * ep + B * em
        wT = A * lp * ep + B * lm * em
    else:
        q = w0 + 0.5 * c * d0
        if q != 0.0 and -d0 / q > 0.0:
            return False
        e = math.exp(-0.5 * c * T)
        dT = (d0 + q * T) * e
        wT = (q - 0.5 * c * (d0 + q * T)) * e
    M = mass[0] + mass[1]
    V0 = (mass[0] * v[0] + mass[1] * v[1]) / M
    U0 = (mass[0] * u[0] + mass[1] * u[1]) / M
    VT = V0 * math.exp(-c * T)
    UT = U0 + V0 * phi1(c, T)
    r = (u[0] - u[1]) + (dT - d0)
    e_before = (0.5 * mass[0] * v[0] ** 2 + 0.5 * mass[1] * v[1] ** 2
                + 0.5 * kc[1] * max(d0, 0.0) ** 2)
    u[0] = UT + mass[1] / M * r
    u[1] = UT - mass[0] / M * r
    v[0] = VT + mass[1] / M * wT
    v[1] = VT - mass[0] / M * wT
    dl[1] = dT
    e_after = (0.5 * mass[0] * v[0] ** 2 + 0.5 * mass[1] * v[1] ** 2
               + 0.5 * kc[1] * max(dT, 0.0) ** 2)
    # The viscous work of the jumped tail, by the energy theorem (closed form).
    st[S_WV] += e_before - e_after
    st[S_JUMPFROM] = st[S_T]
    st[S_T] = st[S_TEND]
    st[S_TLO] = 0.0
    ist[I_JUMPED] = 1
    return True


@numba.njit(cache=True, error_model="numpy")
def _modal_setup(coulomb, viscous, pm, v, dl, slide, csl, kc, mass, eta, eta_s, gamma):
    """N = 2, n = 2, closed contact: fill the modal record (events_modal) if the
    mode is covered (see events_modal.setup)."""
    if dl[1] < 0.0:
        return False
    g0 = gamma[0] if viscous else 0.0
    g1 = gamma[1] if viscous else 0.0
    e0 = eta[0] if coulomb else 0.0
    e1 = eta[1] if coulomb else 0.0
    s0 = slide[0]
    s1 = slide[1]
    es = 0.0
    if s0 != 0 and s1 == 0:
        es = eta_s[1]
    elif s0 == 0 and s1 != 0:
        es = eta_s[0]
    return EM.setup(pm, mass[0], mass[1], g0, g1, kc[1], e0, e1, s0, s1, dl[1], v[0], v[1],
                    es)


@numba.njit(cache=True, error_model="numpy")
def _modal_energy(pm, mass, kc, d, v0, v1, du0, du1, slide, eta, coulomb):
    e = 0.5 * mass[0] * v0 * v0 + 0.5 * mass[1] * v1 * v1
    if d > 0.0:
        e += 0.5 * kc[1] * d * d
    wc = 0.0
    if coulomb:
        if slide[0] == 1 or slide[0] == -1:
            wc += eta[0] * slide[0] * du0
        if slide[1] == 1 or slide[1] == -1:
            wc += eta[1] * slide[1] * du1
    return e, wc


@numba.njit(cache=True, error_model="numpy")
def _modal_step(law, coulomb, viscous, pm, st, ist, x0, u, v, dl, closed, present, slide, kc,
                nexp, mass, eta, ctype, cidx, croot, fr_t, fr_x, fr_v, fr_f, fr_e, lim):
    """One step of the exact modal solution (events_modal) from the mode's start.

    Returns (code, event, tau_e, ncand): code >= 0 ends the run; event = 1 when
    the step ended at the earliest candidate root (ctype/cidx/croot filled).
    Viscous work = energy lost - Coulomb work (both exact in the mode), so
    the ledger closes by the energy theorem within the mode. ``lim`` is the
    overlap at which the centres meet; a step can span a whole contact, so
    reaching it is a root like the others (searched only when the mode's
    energy bound does not exclude it).
    """
    t = st[S_T]
    tlo = st[S_TLO]
    t_end = st[S_TEND]
    rem = (t_end - t) - tlo
    h = rem
    s0 = slide[0]
    s1 = slide[1]
    sl0 = coulomb and (s0 == 1 or s0 == -1)
    sl1 = coulomb and (s1 == 1 or s1 == -1)
    case = pm[EM.P_CASE]
    slipc = case != 0.0
    pm[EM.P_LIM] = lim
    deep = EM.overlap_bound(pm) >= lim
    sampled = pm[EM.P_B] != 0.0 or sl0 or sl1 or slipc or deep
    dts = h
    dts_max = h
    if sampled:
        dts = EM.sample_step(pm)
        # Overdamped (D <= 0): after the fast transient the mode creeps at the
        # slow rate ~K/c, so the windows double their sampling interval up to
        # a quarter of the slow time scale (a sum of real exponentials has at
        # most two extrema, so coarse samples miss nothing the transient's fine
        # ones do not catch). With the fast scale alone, gamma = 1e6 needed
        # ~1e10 steps to reach t_end: an apparent hang.
        dts_max = EM.slow_sample_step(pm)
        h = min(h, 256.0 * dts_max)
    # Search the candidates window by window (WINDOW samples each) and stop at
    # the first window holding a root: most modes end within a period, so
    # sampling all of h (up to 256 samples per event function) cost 4-5x the rest
    # of a collision. Roots beyond the window are not needed: the step ends
    # at the earliest root.
    analytic = pm[EM.P_B] == 0.0
    ah = math.inf
    al = 0.0
    if analytic:
        ah, al = EM.open_root_analytic(pm, h)
    lo = 0.0
    while True:
        hi = min(h, lo + WINDOW * dts) if sampled else h
        nsamp = max(1, int(math.ceil((hi - lo) / dts))) if sampled else 0
        bh = math.inf
        bl = 0.0
        if analytic:
            rh, rl = ah, al
        else:
            rh, rl = EM.first_root(pm, 0, lo, hi, nsamp)
        ctype[0] = EV_OPEN
        cidx[0] = 1
        croot[0] = rh + rl
        ncand = 1
        if rh < bh or (rh == bh and rl < bl):
            bh, bl = rh, rl
        for q in range(3):
            if q == 0 and not sl0:
                continue
            if q == 1 and not sl1:
                continue
            if q == 2 and not slipc:
                continue
            rh, rl = EM.first_root(pm, q + 1, lo, hi, nsamp)
            ctype[ncand] = EV_SLIP if q == 2 else EV_STOP
            cidx[ncand] = q if q < 2 else (1 if case == 1.0 else 0)
            croot[ncand] = rh + rl
            ncand += 1
            if rh < bh or (rh == bh and rl < bl):
                bh, bl = rh, rl
        if deep:
            rh, rl = EM.first_root(pm, 4, lo, hi, nsamp)
            ctype[ncand] = CAND_OVERLAP
            cidx[ncand] = 1
            croot[ncand] = rh + rl
            ncand += 1
            if rh < bh or (rh == bh and rl < bl):
                bh, bl = rh, rl
        if bh + bl <= hi or hi >= h:
            break
        lo = hi
        dts = min(2.0 * dts, dts_max)
    event = bh + bl <= h
    if event:
        th, tl = bh, bl
    else:
        th, tl = h, 0.0
    s_, e_ = EM.two_sum(t, th)
    t_new, t_lo_new = EM.two_sum(s_, e_ + tlo + tl)
    if not event and h == rem:
        t_new = t_end
        t_lo_new = 0.0
    e0, _ = _modal_energy(pm, mass, kc, dl[1], v[0], v[1], 0.0, 0.0, slide, eta, coulomb)
    out_dt = st[S_OUTDT]
    if out_dt > 0.0:
        while True:
            tf = ist[I_FRAMEK] * out_dt
            if tf > t_new or tf > t_end:
                break
            if ist[I_NFR] >= fr_t.size - 3:
                return C_BUFFER, 0, 0.0, 0
            x = (tf - t) - tlo
            d, w, v0, v1, du0, du1 = EM.state(pm, x, 0.0)
            ex, wc = _modal_energy(pm, mass, kc, d, v0, v1, du0, du1, slide, eta, coulomb)
            wv = (e0 - ex - wc) if viscous else 0.0
            su0, su1, sv0, sv1, sd = u[0], u[1], v[0], v[1], dl[1]
            u[0] += du0
            u[1] += du1
            v[0] = v0
            v[1] = v1
            dl[1] = d
            _record(law, tf, x0, u, v, dl, closed, present, kc, nexp, mass, st, ist,
                    fr_t, fr_x, fr_v, fr_f, fr_e, wc, wv)
            u[0], u[1], v[0], v[1], dl[1] = su0, su1, sv0, sv1, sd
            ist[I_FRAMEK] += 1
    d, w, v0, v1, du0, du1 = EM.state(pm, th, tl)
    ex, wc = _modal_energy(pm, mass, kc, d, v0, v1, du0, du1, slide, eta, coulomb)
    st[S_WC] += wc
    if viscous:
        st[S_WV] += e0 - ex - wc
    u[0] += du0
    u[1] += du1
    v[0] = v0
    v[1] = v1
    dl[1] = d
    st[S_T] = t_new
    st[S_TLO] = t_lo_new
    ist[I_STEPS] += 1
    if not (math.isfinite(u[0]) and math.isfinite(u[1]) and math.isfinite(v[0])
            and math.isfinite(v[1]) and math.isfinite(d)):
        return C_NONFINITE, 0, 0.0, 0
    if not event:
        if t_new >= t_end:
            _record(law, t_end, x0, u, v, dl, closed, present, kc, nexp, mass, st, ist,
                    fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
            return C_T_END, 0, 0.0, 0
        return -1, 0, 0.0, 0
    return -1, 1, bh + bl, ncand


@numba.njit(inline="always", cache=True, error_model="numpy")
def _is_moving(i, v, closed, present, slide):
    """Member of the moving set: sliding, or frictionless and not at rest
    force-free (v != 0 or a closed contact). A frictionless granule at rest
    with open contacts stays at rest until one of them closes, which is an
    event of its moving neighbour, so it costs nothing until then."""
    s = slide[i]
    if s == 1 or s == -1:
        return 1
    if s == 0:
        return 0
    if v[i] != 0.0:
        return 1
    if present[i] == 1 and closed[i] == 1:
        return 1
    if present[i + 1] == 1 and closed[i + 1] == 1:
        return 1
    return 0


@numba.njit(cache=True, error_model="numpy")
def _all_at_rest(law, v, dl, closed, present, slide, csl, kc, nexp, mov, nm):
    # Granules outside the moving set are stuck (v = 0 exactly): only the
    # moving set needs a look.
    for q in range(nm):
        i = mov[q]
        if v[i] != 0.0:
            return False
        if csl[i] == 0:
            if _spring(law, closed, present, dl, kc, nexp, i, -5) != 0.0:
                return False
        elif slide[i] != 0:
            return False
    return True



@numba.njit(inline="always", cache=True)
def _force_term(linear, on, k_c, n_c, Dj, Fj, k):
    """k-th Taylor coefficient of a contact force k_c delta^(n_c - 1) from the overlap's
    coefficients Dj and the force's lower ones Fj (power recurrence); 0 when switched off."""
    if not on:
        return 0.0
    if linear:
        return k_c * Dj[k]
    al = n_c - 1.0
    s = 0.0
    for ii in range(k):
        s += (al * (k - ii) - ii) * Dj[k - ii] * Fj[ii]
    return s / (k * Dj[0])


@numba.njit(inline="always", cache=True)
def _add_contacts(i, present, cflag, act, na):
    """Append the (present, not yet listed) contacts i and i+1 of granule i to act[:na]."""
    for j in range(i, i + 2):
        if present[j] == 1 and cflag[j] == 0:
            cflag[j] = 1
            act[na] = j
            na += 1
    return na

@numba.njit(cache=True, error_model="numpy")
def run_events(law, coulomb, viscous, P, rtol, atol, st, ist, x0, u, v, dl, closed, present,
               slide, csl, kc, nexp, mass, eta, eta_s, gamma, U, V, D, Fc, Q, wrk,
               mov, act, cand, cflag, gflag, old_c, old_s, ctype, cidx, croot,
               fr_t, fr_x, fr_v, fr_f, fr_e, ev_t, ev_k, ev_i, counts, pm, win, am, pos,
               olim):
    """Advance the event-driven motion until a stop, t_end or a full buffer.

    All state lives in the arrays passed in, so the driver can grow the frame
    and event buffers and call again (code C_BUFFER). Shapes: N granules,
    N + 1 contacts (0 = left wall, N = right wall, ``present`` marks which
    exist), series arrays (rows, P + 1). ``olim`` (N + 1,): the overlap of
    each contact at which the centres meet (r_(j-1) + r_j; a wall: the
    granule's radius); reaching it ends the run with C_OVERLAP at the exact
    time (ist[I_OVERLAP] = the contact), since past it the granules would
    pass through each other.
    """
    law = literally(law)
    coulomb = literally(coulomb)
    viscous = literally(viscous)
    N = u.size
    watch = ist[I_WATCH]
    fr_cap = fr_t.size
    ev_cap = ev_t.size
    if ist[I_STARTED] == 0:
        if fr_cap - ist[I_NFR] < 4 or ev_cap - ist[I_NEV] < 2 * N + 4:
            return C_BUFFER
        ist[I_STARTED] = 1
        win[0] = 0
        win[1] = N - 1
        settle(law, st[S_T], v, dl, closed, present, slide, csl, kc, nexp, mass, eta, eta_s,
               gamma, old_c, old_s, ev_t, ev_k, ev_i, ist, counts, watch, gflag, cflag, win)
        # The moving set (_is_moving) is kept incrementally from here on:
        # mov[0:nm] its members, pos[i] the place of i in it, am[i] membership.
        nm0 = 0
        for i in range(N):
            am[i] = 0
            if _is_moving(i, v, closed, present, slide) == 1:
                am[i] = 1
                pos[i] = nm0
                mov[nm0] = i
                nm0 += 1
        ist[I_NM] = nm0
        _record(law, st[S_T], x0, u, v, dl, closed, present, kc, nexp, mass, st, ist,
                fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
        ist[I_FRAMEK] = 1
        if ist[I_STOPREST] == 1 and _all_at_rest(law, v, dl, closed, present, slide, csl,
                                                  kc, nexp, mov, ist[I_NM]):
            return C_AT_REST
        if _try_jump(law, coulomb, st, ist, u, v, dl, closed, present, csl, kc, mass, gamma):
            _record(law, st[S_T], x0, u, v, dl, closed, present, kc, nexp, mass, st, ist,
                    fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
            return C_T_END
    linear = law == LAW_LINEAR
    out_dt = st[S_OUTDT]
    budget = ist[I_BUDGET]
    passes = 0
    while True:
        t = st[S_T]
        t_end = st[S_TEND]
        if t >= t_end:
            if fr_t[ist[I_NFR] - 1] != t:
                _record(law, t, x0, u, v, dl, closed, present, kc, nexp, mass, st, ist,
                        fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
            return C_T_END
        if ist[I_STEPS] >= ist[I_MAXSTEPS]:
            return C_MAX_STEPS
        if fr_cap - ist[I_NFR] < 4 or ev_cap - ist[I_NEV] < 2 * N + 4:
            return C_BUFFER
        if budget > 0:
            if passes >= budget:
                return C_YIELD
            passes += 1
        modal = False
        if linear and N == 2 and present[0] == 0 and present[2] == 0 and closed[1] == 1:
            modal = _modal_setup(coulomb, viscous, pm, v, dl, slide, csl, kc, mass, eta,
                                 eta_s, gamma)
        if modal:
            for j in range(N + 1):
                cflag[j] = 0
            for i in range(N):
                gflag[i] = 0
            code_m, ev_m, tau_m, nc_m = _modal_step(
                law, coulomb, viscous, pm, st, ist, x0, u, v, dl, closed, present, slide, kc,
                nexp, mass, eta, ctype, cidx, croot, fr_t, fr_x, fr_v, fr_f, fr_e, olim[1])
            if code_m >= 0:
                return code_m
            if ev_m == 0:
                continue
            tau_e = tau_m
            ncand = nc_m
            t_new = st[S_T]
        else:
            # --- the moving set and the contacts and stuck granules it touches,
            # built from the incrementally kept moving set: O(active), not O(N).
            nm = ist[I_NM]
            na = 0
            nc = 0
            for q in range(nm):
                i = mov[q]
                na = _add_contacts(i, present, cflag, act, na)
            na1 = na
            for q in range(na1):
                j = act[q]
                for i in range(j - 1, j + 1):
                    if i >= 0 and i < N and slide[i] == 0 and gflag[i] == 0:
                        gflag[i] = 1
                        cand[nc] = i
                        nc += 1
            for q in range(nc):
                na = _add_contacts(cand[q], present, cflag, act, na)
            # the flags only de-duplicate: clear them for the event marks below
            for q in range(na):
                cflag[act[q]] = 0
            for q in range(nc):
                gflag[cand[q]] = 0
            if nm == 0:
                # Nothing moves and nothing can start moving: the state is final.
                _record(law, t_end, x0, u, v, dl, closed, present, kc, nexp, mass, st, ist,
                        fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
                st[S_JUMPFROM] = t
                st[S_T] = t_end
                st[S_TLO] = 0.0
                ist[I_JUMPED] = 2
                return C_T_END
            # --- Taylor series of the mode
            vscale = 0.0
            for q in range(nm):
                vscale = max(vscale, abs(v[mov[q]]))
            tol_v = rtol * vscale + atol
            for q in range(nm):
                i = mov[q]
                U[i, 0] = u[i]
                V[i, 0] = v[i]
            for q in range(na):
                j = act[q]
                D[j, 0] = dl[j]
                wrk[j] = 0.0  # force-on flag
                if closed[j] == 1:
                    if linear:
                        wrk[j] = 1.0
                    elif dl[j] > 0.0:
                        vl = v[j - 1] if j >= 1 else 0.0
                        vr = v[j] if j < N else 0.0
                        aexp = nexp[j]
                        if kc[j] * dl[j] ** aexp > 0.1 * aexp * abs(vl - vr) * tol_v:
                            wrk[j] = 1.0
                Fc[j, 0] = contact_force(law, dl[j], kc[j], nexp[j]) if wrk[j] == 1.0 else 0.0
            for k in range(P):
                if k >= 1:
                    for q in range(na):
                        j = act[q]
                        Fc[j, k] = _force_term(linear, wrk[j] == 1.0, kc[j], nexp[j], D[j], Fc[j], k)
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
                    if j >= 1 and am[j - 1] == 1:
                        vl = V[j - 1, k]
                    if j < N and am[j] == 1:
                        vr = V[j, k]
                    D[j, k + 1] = (vl - vr) / (k + 1)
            for q in range(na):
                j = act[q]
                Fc[j, P] = _force_term(linear, wrk[j] == 1.0, kc[j], nexp[j], D[j], Fc[j], P)
            # --- step size (Jorba & Zou: last two terms below the tolerance). For
            # n = 2 also h <= S_HCAP = 0.5/L, L a bound on the mode's eigenvalues: the
            # series of a decaying exponential e^(-L h) has terms up to e^(L h), and
            # keeping L h <= 1/2 keeps their cancellation below a factor 3.
            tlo = st[S_TLO]
            h = (t_end - t) - tlo
            if st[S_HCAP] > 0.0:
                h = min(h, st[S_HCAP])
            # Rows under control: velocities, overlaps and (n != 2) the contact
            # forces themselves. The forces are the slip events' functions; left
            # uncontrolled, their truncation error is ~P tol/h (V only carries
            # their integral), which put slip times off by 4e-12 at rtol 1e-12 and
            # split one slip into a spurious slip/stop/slip triple.
            nrow = nm + na
            if not linear:
                nrow += na
            for q in range(nrow):
                if q < nm:
                    row = V[mov[q]]
                elif q < nm + na:
                    row = D[act[q - nm]]
                else:
                    jf = act[q - nm - na]
                    if wrk[jf] == 0.0:
                        continue
                    row = Fc[jf]
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
                # A closed contact near a grazing minimum (at tau_m, delta_m > 0): the
                # force delta^(n-1) has branch points where delta = 0, near
                # tau_m +- i sigma, sigma = sqrt(delta_m / D2). The series' first P
                # terms can look converged (the singular part's amplitude is tiny)
                # while past those points it sums to the other branch, an attractive
                # force. Found by the property tests: a granule squeezed between two
                # walls lost 1e-4 of its energy at any rtol. Keep the step inside
                # half the distance to them (an actual crossing, delta_m <= 0, is an
                # opening event and ends the step anyway).
                for q in range(na):
                    j = act[q]
                    d2_ = D[j, 2]
                    if wrk[j] == 1.0 and d2_ > 0.0:
                        tm = -D[j, 1] / (2.0 * d2_)
                        if abs(tm) < 2.0 * h:
                            if abs(tm) <= h:
                                dm = _horner(D[j], P, tm)
                            else:
                                dm = D[j, 0] + 0.5 * D[j, 1] * tm
                            if dm > 0.0:
                                h = min(h, 0.5 * math.sqrt(tm * tm + dm / d2_))
            if not (h > 0.0) or not math.isfinite(h):
                return C_NONFINITE
            # --- events: first root of every candidate
            tau_e = math.inf
            ncand = 0
            for q in range(na):
                j = act[q]
                r = math.inf
                if closed[j] == 1:
                    r = first_root(D[j], P, -1.0, 0.0, h)
                    ctype[ncand] = EV_OPEN
                    cidx[ncand] = j
                    croot[ncand] = r
                    ncand += 1
                    if wrk[j] == 0.0 and not linear:
                        # Force switched off (a contact about to open, or closing from
                        # rest): switch it on again where delta reaches delta_on. Also
                        # when delta is falling now: near a grazing minimum it turns
                        # round without opening, and the force left out over the
                        # whole dip cost 5e-3 of the energy (property tests).
                        aexp = nexp[j]
                        don = -1.0
                        if D[j, 1] != 0.0:
                            vl = v[j - 1] if j >= 1 else 0.0
                            vr = v[j] if j < N else 0.0
                            don = 1.5 * (0.1 * aexp * abs(vl - vr) * tol_v / kc[j]) ** (
                                1.0 / aexp)
                        elif D[j, 2] > 0.0:
                            # Closing from rest (a granule slipped into a touching
                            # neighbour): w = 0 and delta = a tau^2/2, so the rule above
                            # would never switch the force on. The force left out
                            # until delta reaches don has impulse
                            # k don^(n-1) sqrt(2 don/a)/(2n - 1); keep it below tol/10.
                            # (delta^(n-1) = (a/2)^(n-1) tau^(2n-2) is analytic here.)
                            acc = 2.0 * D[j, 2]
                            don = (0.1 * tol_v * (2.0 * aexp - 1.0) * math.sqrt(0.5 * acc)
                                   / kc[j]) ** (1.0 / (aexp - 0.5))
                        if D[j, 0] < don:
                            r2 = first_root(D[j], P, 1.0, don, h)
                            ctype[ncand] = -1
                            cidx[ncand] = j
                            croot[ncand] = r2
                            ncand += 1
                            r = min(r, r2)
                    # the centres meet: the contact model ends here (bound-excluded
                    # at once unless the step can reach it)
                    r3 = first_root(D[j], P, 1.0, olim[j], h)
                    ctype[ncand] = CAND_OVERLAP
                    cidx[ncand] = j
                    croot[ncand] = r3
                    ncand += 1
                    r = min(r, r3)
                else:
                    r = first_root(D[j], P, 1.0, 0.0, h)
                    ctype[ncand] = EV_CLOSE
                    cidx[ncand] = j
                    croot[ncand] = r
                    ncand += 1
                tau_e = min(tau_e, r)
            if coulomb:
                for q in range(nm):
                    i = mov[q]
                    if slide[i] == 1 or slide[i] == -1:
                        for k in range(P + 1):
                            Q[0, k] = V[i, k]
                        if V[i, 0] == 0.0 and slide[i] * V[i, 1] < 0.0 and (
                                abs(V[i, 1]) * mass[i] <= max(1e-13, 10.0 * rtol) * eta_s[i]):
                            # Just slipped at |F| = eta_s = eta: the initial
                            # deceleration is the error of F at the located root
                            # (roundoff, or the series tolerance), not physics.
                            Q[0, 1] = 0.0
                        r = first_root(Q[0], P, -1.0 * slide[i], 0.0, h)
                        ctype[ncand] = EV_STOP
                        cidx[ncand] = i
                        croot[ncand] = r
                        ncand += 1
                        tau_e = min(tau_e, r)
                for q in range(nc):
                    i = cand[q]
                    for k in range(P + 1):
                        Q[0, k] = Fc[i, k] - Fc[i + 1, k]
                    r = min(first_root(Q[0], P, 1.0, eta_s[i], h),
                            first_root(Q[0], P, -1.0, eta_s[i], h))
                    ctype[ncand] = EV_SLIP
                    cidx[ncand] = i
                    croot[ncand] = r
                    ncand += 1
                    tau_e = min(tau_e, r)
            event = tau_e <= h
            tau = tau_e if event else h
            # --- frames at the output cadence inside the step
            # t_new = t + tau as a double-double (TwoSum, then renormalise)
            s_ = t + tau
            bb = s_ - t
            lo = tlo + ((t - (s_ - bb)) + (tau - bb))
            t_new = s_ + lo
            t_lo_new = lo - (t_new - s_)
            if not event and tau == h and h == (t_end - t) - tlo:
                t_new = t_end
                t_lo_new = 0.0
            if out_dt > 0.0:
                while True:
                    tf = ist[I_FRAMEK] * out_dt
                    if tf > t_new or tf > t_end:
                        break
                    if ist[I_NFR] >= fr_cap - 3:
                        return C_BUFFER  # state untouched: the step is redone after growing
                    x = (tf - t) - tlo
                    for q in range(nm):
                        i = mov[q]
                        wrk[N + 1 + i] = u[i]
                        wrk[2 * N + 1 + i] = v[i]
                        u[i] = _horner(U[i], P, x)
                        v[i] = _horner(V[i], P, x)
                    for q in range(na):
                        j = act[q]
                        Q[1, j] = dl[j]
                        dl[j] = _horner(D[j], P, x)
                    dwc, dwv = _ledger(coulomb, viscous, P, nm, mov, slide, eta, gamma, U, V, Q, x)
                    _record(law, tf, x0, u, v, dl, closed, present, kc, nexp, mass, st, ist,
                            fr_t, fr_x, fr_v, fr_f, fr_e, dwc, dwv)
                    for q in range(nm):
                        i = mov[q]
                        u[i] = wrk[N + 1 + i]
                        v[i] = wrk[2 * N + 1 + i]
                    for q in range(na):
                        j = act[q]
                        dl[j] = Q[1, j]
                    ist[I_FRAMEK] += 1
            # --- advance to the end of the step (or the event)
            dwc, dwv = _ledger(coulomb, viscous, P, nm, mov, slide, eta, gamma, U, V, Q, tau)
            st[S_WC] += dwc
            st[S_WV] += dwv
            for q in range(nm):
                i = mov[q]
                u[i] = u[i] + _increment(U[i], P, tau)
                v[i] = _horner(V[i], P, tau)
            for q in range(na):
                j = act[q]
                dl[j] = _horner(D[j], P, tau)
            st[S_T] = t_new
            st[S_TLO] = t_lo_new
            ist[I_STEPS] += 1
            bad = False
            for q in range(nm):
                if not (math.isfinite(u[mov[q]]) and math.isfinite(v[mov[q]])):
                    bad = True
            if bad:
                return C_NONFINITE
            if not event:
                if ist[I_EVERY] > 0 and ist[I_STEPS] % ist[I_EVERY] == 0:
                    _record(law, t_new, x0, u, v, dl, closed, present, kc, nexp, mass, st, ist,
                            fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
                if t_new >= t_end:
                    _record(law, t_end, x0, u, v, dl, closed, present, kc, nexp, mass, st, ist,
                            fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
                    return C_T_END
                continue
        # --- the event: set the event quantities exactly, for every tie
        # Roots of different event functions at one true instant agree to a few
        # ulps of tau: those are processed together (simultaneous events).
        tie = 16 * 2.2e-16 * tau_e
        for q in range(ncand):
            if ctype[q] == CAND_OVERLAP and croot[q] <= tau_e + tie:
                ist[I_OVERLAP] = cidx[q]
                _record(law, t_new, x0, u, v, dl, closed, present, kc, nexp, mass, st, ist,
                        fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
                return C_OVERLAP
        for q in range(ncand):
            if croot[q] <= tau_e + tie:
                kind = ctype[q]
                if kind == EV_OPEN or kind == EV_CLOSE:
                    dl[cidx[q]] = 0.0
                    cflag[cidx[q]] = 2 if kind == EV_CLOSE else 3
                elif kind == EV_STOP:
                    v[cidx[q]] = 0.0
                    gflag[cidx[q]] = 3
                elif kind == EV_SLIP:
                    i = cidx[q]
                    F = _spring(law, closed, present, dl, kc, nexp, i, -5)
                    slide[i] = 1 if F > 0.0 else -1
                    gflag[i] = 2  # settle keeps this root-located slip
        nev_before = ist[I_NEV]
        # settle only around the events of the batch (see settle: the window grows
        # where a change reaches its edge)
        wlo = N
        whi = -1
        for q in range(ncand):
            if croot[q] <= tau_e + tie and ctype[q] >= 0:
                c_ = cidx[q]
                if ctype[q] == EV_OPEN or ctype[q] == EV_CLOSE:
                    wlo = min(wlo, c_ - 2)
                    whi = max(whi, c_ + 1)
                else:
                    wlo = min(wlo, c_ - 1)
                    whi = max(whi, c_ + 1)
        if whi < wlo:
            wlo = 0
            whi = -1
        win[0] = max(wlo, 0)
        win[1] = min(whi, N - 1)
        if win[1] >= win[0]:
            opened = settle(law, t_new, v, dl, closed, present, slide, csl, kc, nexp, mass,
                            eta, eta_s, gamma, old_c, old_s, ev_t, ev_k, ev_i, ist, counts,
                            watch, gflag, cflag, win)
        else:
            opened = 0
        # update the moving set inside the settled window
        nmv = ist[I_NM]
        for i in range(win[0], win[1] + 1):
            inn = _is_moving(i, v, closed, present, slide)
            if inn == 1 and am[i] == 0:
                am[i] = 1
                pos[i] = nmv
                mov[nmv] = i
                nmv += 1
            elif inn == 0 and am[i] == 1:
                am[i] = 0
                last = mov[nmv - 1]
                mov[pos[i]] = last
                pos[last] = pos[i]
                nmv -= 1
        ist[I_NM] = nmv
        # A slip decided at the root is logged here (settle saw the new mode already).
        for q in range(ncand):
            if croot[q] <= tau_e + tie and ctype[q] == EV_SLIP:
                i = cidx[q]
                if slide[i] != 0 and v[i] == 0.0:
                    n_ = ist[I_NEV]
                    ev_t[n_] = t_new
                    ev_k[n_] = EV_SLIP
                    ev_i[n_] = i
                    ist[I_NEV] = n_ + 1
                    counts[EV_SLIP] += 1
        for q in range(ncand):
            if croot[q] <= tau_e + tie:
                if ctype[q] == EV_OPEN or ctype[q] == EV_CLOSE or ctype[q] == -1:
                    cflag[cidx[q]] = 0
                else:
                    gflag[cidx[q]] = 0
        if tau_e == 0.0 and ist[I_NEV] == nev_before:
            # A root at the step's start that changes no mode: count it as a
            # batch that does not advance time, so a loop ends as Zeno.
            ist[I_ZENO] += 1
            if ist[I_ZENO] >= ZENO_BATCHES:
                _record(law, t_new, x0, u, v, dl, closed, present, kc, nexp, mass, st,
                        ist, fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
                return C_ZENO
        if ist[I_NEV] > nev_before:
            # Zeno: many event batches in a window that does not advance time.
            if t_new - st[S_LASTEV] <= 1e-12 * max(abs(t_new), 1.0):
                ist[I_ZENO] += 1
            else:
                ist[I_ZENO] = 0
            st[S_LASTEV] = t_new
            ist[I_BATCHES] += 1
            if ist[I_FRAMEEV] == 1 or opened == 1:
                _record(law, t_new, x0, u, v, dl, closed, present, kc, nexp, mass, st, ist,
                        fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
            if opened == 1 and ist[I_STOPSEP] == 1:
                return C_SEPARATED
            if ist[I_STOPREST] == 1 and _all_at_rest(law, v, dl, closed, present, slide, csl,
                                                      kc, nexp, mov, ist[I_NM]):
                if ist[I_FRAMEEV] == 0:
                    _record(law, t_new, x0, u, v, dl, closed, present, kc, nexp, mass, st,
                            ist, fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
                return C_AT_REST
            if ist[I_NEV] >= ist[I_MAXEV]:
                if ist[I_FRAMEEV] == 0:
                    _record(law, t_new, x0, u, v, dl, closed, present, kc, nexp, mass, st,
                            ist, fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
                return C_MAX_EVENTS
            if ist[I_ZENO] >= ZENO_BATCHES:
                if ist[I_FRAMEEV] == 0:
                    _record(law, t_new, x0, u, v, dl, closed, present, kc, nexp, mass, st,
                            ist, fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
                return C_ZENO
            if _try_jump(law, coulomb, st, ist, u, v, dl, closed, present, csl, kc, mass,
                         gamma):
                _record(law, st[S_T], x0, u, v, dl, closed, present, kc, nexp, mass, st, ist,
                        fr_t, fr_x, fr_v, fr_f, fr_e, 0.0, 0.0)
                return C_T_END
