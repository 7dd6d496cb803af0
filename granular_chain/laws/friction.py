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


@numba.njit(cache=True)
def _viscous_coulomb_stop(v, F, eta, m, c, h, a, s, slip, s2, a2):
    """A granule sliding in direction s under Coulomb and viscous friction stops at
    t* inside the kick of length h, then sticks or slides along F: (v, w_c, w_v)."""
    t_stop = min(phi1_inverse(c, -v / (a - c * v)), h)
    disp = v * phi1(c, t_stop) + a * phi2(c, t_stop)
    w_c = -eta * s * disp
    w_v = -0.5 * m * v * v - F * disp - w_c
    v_new = 0.0
    if slip:
        rem = h - t_stop
        v_new = a2 * phi1(c, rem)
        dd = a2 * phi2(c, rem)
        w_c2 = -eta * s2 * dd
        w_c += w_c2
        w_v += 0.5 * m * v_new * v_new - F * dd - w_c2
    return v_new, w_c, w_v


@numba.njit(inline="always", cache=True)
def coulomb_kick(viscous, v, F, eta, eta_s, m, inv_m, c, E, P1, P2, h):
    """Exact kick under Coulomb stick/slip (and, if ``viscous``, drag -gamma v).

    Written without branches (selects only) so that chains where granules
    stick, slide and reverse at random cost the same as smooth ones and the
    loop can vectorise. The one exception is a *viscous* granule that stops
    inside the kick: its stopping time needs a logarithm, computed only then.

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
    s = (1.0 if v > 0.0 else 0.0) - (1.0 if v < 0.0 else 0.0)
    a = (F - eta * s) * inv_m
    # Starting from rest (s = 0) or after a stop: slide along F if it beats the
    # static threshold, for the time left in the kick.
    slip = abs(F) > eta_s
    s2 = 1.0 if F > 0.0 else -1.0
    a2 = (F - eta * s2) * inv_m
    if viscous:
        v1 = v * E + a * P1
        through = v1 * s > 0.0  # slid the whole kick without stopping
        disp1 = v * P1 + a * P2
        # From rest at the start of the kick: rem = h, so phi1, phi2 are P1, P2.
        v2 = a2 * P1
        disp2 = a2 * P2
        w_c = -eta * (s * disp1 if through else (abs(disp2) if slip else 0.0))
        w_v = 0.5 * m * (v1 * v1 - v * v) - F * disp1 + eta * s * disp1 if through else (
            0.5 * m * v2 * v2 - F * disp2 + eta * abs(disp2) if slip else 0.0)
        v_new = v1 if through else (v2 if slip else 0.0)
        stopped = (not through) and s != 0.0
        if stopped:
            # Rare: a sliding granule stops inside the kick (needs a logarithm);
            # out of line so that the hot loop stays small.
            v_new, w_c, w_v = _viscous_coulomb_stop(v, F, eta, m, c, h, a, s, slip, s2, a2)
    else:
        v1 = v + a * h
        through = v1 * s > 0.0
        stopped = (not through) and s != 0.0
        # Stopping time |v|/|a| (0 from rest); a decelerates when not through.
        t_stop = min(abs(v) / max(abs(a), 1e-300), h)
        rem = h - t_stop
        v2 = a2 * rem
        d1 = (v + 0.5 * a * h) * h * s if through else 0.5 * abs(v) * t_stop
        d2 = 0.5 * abs(a2) * rem * rem if (slip and not through) else 0.0
        w_c = -eta * (d1 + d2)
        w_v = 0.0
        v_new = v1 if through else (v2 if slip else 0.0)
    code = (STOPPED if stopped else 0) | (SLIPPED if (slip and not through) else 0)
    return v_new, w_c, w_v, code


@numba.njit(cache=True)
def kick_tables(c, h, E, P1, P2):
    """Per-granule kick coefficients for a kick of duration h: exp(-c h), phi1, phi2."""
    for i in range(c.size):
        E[i] = math.exp(-c[i] * h)
        P1[i] = phi1(c[i], h)
        P2[i] = phi2(c[i], h)
