"""Friction laws as exact velocity kicks: Coulomb stick/slip and viscous drag.

The Verlet stepper splits each step into kick(dt/2) - drift(dt) - kick(dt/2).
During a kick the spring force ``F`` on a granule is frozen, and the friction
law is then integrated *exactly* over the kick duration ``h``::

    m dv/dt = F - eta * sign(v) - gamma * v          (sliding, v != 0)
    v = 0 stays 0 while |F| <= eta_static            (stuck)

so that a granule stops exactly at v = 0 (no chattering about zero, no tanh
smoothing), sticks when the spring cannot overcome the static threshold, and
slips (or reverses) otherwise. Viscous damping is treated by its exponential,
so ``gamma * dt`` larger than 2 stays stable. With ``c = gamma / m`` the
solution of the linear law over a time ``t`` is::

    v(t) = v0 + (a - c v0) * phi1(c, t),      a = (F - eta s) / m,
    displacement(t) = v0 * phi1(c, t) + a * phi2(c, t),
    phi1 = (1 - exp(-c t)) / c  (-> t),       phi2 = (t - phi1) / c  (-> t^2/2).

The work done by friction during the kick follows from the energy theorem
``dKE = F * displacement + W_friction`` (and ``W_coulomb = -eta |displacement|``
while sliding), which is what the energy ledger accumulates.

Every function returns ``(v_new, w_coulomb, w_viscous, code)`` where the works
are <= 0 and ``code`` has bit 1 set when a sliding granule stopped and bit 2
when a granule at rest started to slide (both for a reversal).
"""

import math

import numba

STOPPED = 1
SLIPPED = 2


@numba.njit(inline="always", cache=True)
def phi1(c, t):
    """(1 - exp(-c t)) / c, accurate for every c >= 0 (t at c = 0)."""
    if c == 0.0:
        return t
    return -math.expm1(-c * t) / c


@numba.njit(inline="always", cache=True)
def phi2(c, t):
    """(t - phi1(c, t)) / c = integral of phi1, accurate for every c >= 0 (t^2/2 at c = 0)."""
    x = c * t
    if x < 0.5:
        # Series sum_j (-x)^j / (j+2)! in nested (Horner) form: the direct form
        # cancels for small x. 20 terms reach roundoff for x < 0.5.
        s = 1.0
        for j in range(22, 2, -1):
            s = 1.0 + (-x) / j * s
        return 0.5 * s * t * t
    return (t - phi1(c, t)) / c


@numba.njit(inline="always", cache=True)
def phi1_inverse(c, q):
    """The t with phi1(c, t) = q (t = q at c = 0); inf when c q >= 1 (never reached)."""
    if c == 0.0:
        return q
    y = c * q
    if y >= 1.0:
        return math.inf
    return -math.log1p(-y) / c


@numba.njit(inline="always", cache=True)
def free_kick(v, F, inv_m, h):
    """No friction: v + h F / m."""
    return v + h * F * inv_m, 0.0, 0.0, 0


@numba.njit(inline="always", cache=True)
def viscous_kick(v, F, m, inv_m, E, P1, P2):
    """Exact kick under m dv/dt = F - gamma v for the kick duration h.

    ``E = exp(-c h)``, ``P1 = phi1(c, h)``, ``P2 = phi2(c, h)`` are precomputed per
    granule (c = gamma/m), so the kick costs two multiply-adds and no exp.
    """
    a = F * inv_m
    v1 = v * E + a * P1
    disp = v * P1 + a * P2
    w_visc = 0.5 * m * (v1 * v1 - v * v) - F * disp
    return v1, 0.0, w_visc, 0


@numba.njit(inline="always", cache=True)
def coulomb_kick(viscous, v, F, eta, eta_s, m, inv_m, c, E, P1, P2, h):
    """Exact kick under Coulomb stick/slip (and, if ``viscous``, drag -gamma v).

    Parameters
    ----------
    viscous : int
        Compile-time flag: include the drag term (c = gamma/m may still be 0).
    v, F : float
        Velocity at the start of the kick and the frozen spring force.
    eta, eta_s : float
        Kinetic friction force and static threshold (eta_s >= eta).
    m, inv_m, c : float
        Mass, 1/mass and gamma/mass.
    E, P1, P2 : float
        exp(-c h), phi1(c, h), phi2(c, h) (only used when ``viscous``).
    h : float
        Kick duration (dt/2).
    """
    s = 0.0
    if v > 0.0:
        s = 1.0
    elif v < 0.0:
        s = -1.0
    a = (F - eta * s) * inv_m
    if viscous:
        v1 = v * E + a * P1
    else:
        v1 = v + a * h
    if v1 * s > 0.0:
        # Slid the whole kick without stopping: the common case, no branch below.
        if viscous:
            disp = v * P1 + a * P2
            w_c = -eta * s * disp
            w_v = 0.5 * m * (v1 * v1 - v * v) - F * disp - w_c
        else:
            disp = (v + 0.5 * a * h) * h
            w_c = -eta * s * disp
            w_v = 0.0
        return v1, w_c, w_v, 0
    code = 0
    w_c = 0.0
    w_v = 0.0
    rem = h
    if s != 0.0:
        # Stops inside the kick at t*, where v(t*) = 0.
        code = STOPPED
        if viscous:
            t_stop = phi1_inverse(c, -v / (a - c * v))
            t_stop = min(t_stop, h)
            disp = v * phi1(c, t_stop) + a * phi2(c, t_stop)
            w_c = -eta * s * disp
            w_v = -0.5 * m * v * v - F * disp - w_c
        else:
            t_stop = min(-v / a, h)
            disp = 0.5 * v * t_stop
            w_c = -eta * s * disp
        rem = h - t_stop
    if abs(F) <= eta_s:
        return 0.0, w_c, w_v, code
    # The spring beats the static threshold: slide along F for the remaining time.
    s2 = 1.0 if F > 0.0 else -1.0
    a2 = (F - eta * s2) * inv_m
    if viscous:
        p1 = phi1(c, rem)
        p2 = phi2(c, rem)
        v2 = a2 * p1
        disp2 = a2 * p2
        w_c2 = -eta * s2 * disp2
        w_v += 0.5 * m * v2 * v2 - F * disp2 - w_c2
    else:
        v2 = a2 * rem
        disp2 = 0.5 * a2 * rem * rem
        w_c2 = -eta * s2 * disp2
    return v2, w_c + w_c2, w_v, code | SLIPPED


@numba.njit(cache=True)
def kick_tables(c, h, E, P1, P2):
    """Per-granule kick coefficients for a kick of duration h: exp(-c h), phi1, phi2."""
    for i in range(c.size):
        E[i] = math.exp(-c[i] * h)
        P1[i] = phi1(c[i], h)
        P2[i] = phi2(c[i], h)
