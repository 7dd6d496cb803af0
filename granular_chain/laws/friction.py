"""Friction laws as exact sub-steps: Coulomb stick/slip kicks and viscous drifts.

The Verlet stepper splits each step into kick(dt/2) - drift(dt) - kick(dt/2)
(Strang splitting of three exactly solvable parts):

* the *kick* integrates the spring force (frozen) and Coulomb friction
  exactly over h = dt/2::

      m dv/dt = F - eta * sign(v)              (sliding, v != 0)
      v = 0 stays 0 while |F| <= eta_static    (stuck)

  so a granule stops exactly at v = 0 (no chattering about zero, no tanh
  smoothing), sticks when the spring cannot overcome the static threshold,
  and slips (or reverses) otherwise. The kick is the exact flow of an
  autonomous equation while F is frozen, so two kicks of h in a row are one
  kick of 2h: the stepper merges a step's last kick with the next step's first
  (:mod:`granular_chain.steppers.verlet`, "Merged kicks");
* the *drift* moves each granule under its viscous drag alone, exactly::

      v(t) = v0 exp(-c t),  u(t) = u0 + v0 phi1(c, t),  c = gamma / m,
      phi1 = (1 - exp(-c t)) / c  (-> t as c -> 0),

  so ``gamma dt`` far above 2 is neither unstable nor inaccurate: a granule
  whose velocity decays within one step still moves the right distance.

The work done by friction in each sub-step is exact for that sub-step, which
is what the energy ledger accumulates. Kicks return
``(v_new, w_coulomb, w_viscous, code)`` with works <= 0 and ``code`` having
bit 1 set when a sliding granule stopped and bit 2 when a granule at rest
started to slide (both for a reversal).
"""

import math

import numba

from .._compile import kernel

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
    """(t - phi1(c, t)) / c = integral of phi1, accurate for every c >= 0 (t^2/2 at c = 0).

    Parameters
    ----------
    c : float
        Drag rate gamma/m >= 0, 1/time (scene units).
    t : float
        Duration, scene units of time.

    Returns
    -------
    float
        ``phi2(c, t)``, units of time^2.
    """
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
def free_kick(v, F, inv_m, h):
    """No friction: v + h F / m."""
    return v + h * F * inv_m, 0.0, 0.0, 0


@numba.njit(inline="always", cache=True)
def viscous_drift(v, m, E, P1):
    """Exact drift under drag alone, m dv/dt = -gamma v, for the step dt.

    ``E = exp(-c dt)`` and ``P1 = phi1(c, dt)`` are precomputed per granule.
    Returns (displacement, v_new, w_viscous) with w_viscous = -(m v^2/2)(1 - E^2).
    """
    return v * P1, v * E, -0.5 * m * v * v * (1.0 - E * E)


@numba.njit(inline="always", cache=True)
def sliding(v, F, eta, inv_m):
    """(s, a): the sliding direction sign(v) (0 at rest) and the acceleration
    (F - eta s) / m of a granule moving at v under the frozen force F."""
    s = (1.0 if v > 0.0 else 0.0) - (1.0 if v < 0.0 else 0.0)
    return s, (F - eta * s) * inv_m


@numba.njit(inline="always", cache=True)
def coulomb_kick(v, F, eta, eta_s, inv_m, h):
    """Exact kick of duration h under a frozen spring force F and Coulomb stick/slip.

    Written without branches (selects only) so that chains where granules
    stick, slide and reverse at random cost the same as smooth ones.

    Parameters
    ----------
    v, F : float
        Velocity at the start of the kick (speed) and the frozen spring force
        (force), scene or internal units.
    eta, eta_s : float
        Kinetic friction force and static threshold (eta_s >= eta), units of force.
    inv_m : float
        1/mass, units of 1/mass.
    h : float
        Kick duration (dt/2), units of time.

    Returns
    -------
    tuple
        ``(v_new, w_coulomb, w_viscous, code)``: velocity after the kick (scene
        units), work of the kinetic friction (<= 0, scene units of energy), 0.0,
        and the int code (bit STOPPED, bit SLIPPED).
    """
    s, a = sliding(v, F, eta, inv_m)
    v1 = v + a * h
    through = v1 * s > 0.0  # slid the whole kick without stopping
    stopped = (not through) and s != 0.0
    # Stopping time |v|/|a| (0 from rest); when not through, a decelerates.
    t_stop = min(abs(v) / max(abs(a), 1e-300), h)
    rem = h - t_stop
    # At rest (from the start or after stopping): slide along F for the time
    # left if F beats the static threshold, else stay exactly at rest.
    slip = abs(F) > eta_s
    s2 = 1.0 if F > 0.0 else -1.0
    a2 = (F - eta * s2) * inv_m
    d1 = (v + 0.5 * a * h) * h * s if through else 0.5 * abs(v) * t_stop
    d2 = 0.5 * abs(a2) * rem * rem if (slip and not through) else 0.0
    v_new = v1 if through else (a2 * rem if slip else 0.0)
    code = (STOPPED if stopped else 0) | (SLIPPED if (slip and not through) else 0)
    return v_new, -eta * (d1 + d2), 0.0, code


@numba.njit(inline="always", cache=True)
def at_rest_by(v, v1, F, eta, inv_m, t):
    """1 if a kick from velocity v under force F that ended at rest (v1 = 0) had
    stopped by time t into it (|v| <= t |a| with a the sliding deceleration;
    from rest, at once), else 0. A granule at rest by t stays so: v1 = 0 means
    the spring could not beat the static threshold."""
    s, a = sliding(v, F, eta, inv_m)
    return 1 if (v1 == 0.0 and abs(v) <= t * abs(a)) else 0


@kernel()
def drift_tables(c, dt, E, P1, P2):
    """Per-granule drag coefficients for a step dt: exp(-c dt), phi1(c, dt), phi2(c, dt).

    Parameters
    ----------
    c : numpy.ndarray
        Shape (N,): drag rates gamma/m, 1/time (scene or internal units).
    dt : float
        Step, units of time matching ``c``.
    E, P1, P2 : numpy.ndarray
        Shape (N,) each, filled in place: exp(-c dt) (dimensionless),
        phi1(c, dt) (time) and phi2(c, dt) (time^2).
    """
    for i in range(c.size):
        E[i] = math.exp(-c[i] * dt)
        P1[i] = phi1(c[i], dt)
        P2[i] = phi2(c[i], dt)
