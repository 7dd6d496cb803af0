"""Restitution of one damped contact: closed forms, their inverse, a high-precision reference.

Two granules of masses ``m1, m2`` (reduced mass ``m_eff = m1 m2 / (m1 + m2)``, kg)
meet at relative speed ``v`` (m/s).  Inside the contact the overlap ``xi >= 0`` (m)
obeys ``m_eff xi'' = -F`` with ``xi(0) = 0``, ``xi'(0) = v`` and one of the laws

* linear dashpot, any exponent ``n``:  ``F = k xi**(n-1) + c xi'``
  (``k`` in N/m**(n-1), ``c`` in kg/s);
* viscoelastic:  ``F = k xi**(n-1) + A d/dt(k xi**(n-1)) = k xi**(n-1) + A k (n-1) xi**(n-2) xi'``
  (``A`` in s; for ``n = 5/2`` the Kuwabara-Kono / Brilliantov et al. viscoelastic Hertz force).

How the contact ends:

* ``tensile=True``: when ``xi`` returns to 0 (the force may pull just before);
* ``tensile=False``: the force is ``max(0, F)``; the grains leave when ``F`` reaches 0,
  while ``xi > 0``, and then fly apart at constant speed.

The restitution coefficient is ``e = -xi'(t_c) / v`` with ``t_c`` the contact time.

Contents
--------
:func:`linear_dashpot`
    closed forms for ``n = 2`` with a linear dashpot, every damping regime.
:func:`choose_damping`
    the dashpot ``c`` that gives a target ``e`` (``n = 2``).
:func:`restitution_reference`
    independent mpmath integration of the contact (any rational ``n`` with
    denominator <= 12, either damping model, either end condition), 30+ digits.
:func:`hertz_contact_time`
    closed-form duration of an undamped power-law contact.
:func:`viscoelastic_series`
    small-speed series of ``e(v)`` for viscoelastic Hertz (Schwager and Poeschel 2008).
:func:`column_overlaps`
    static overlaps of a column of granules resting on a wall under gravity.

This module imports nothing else from ``granular_chain`` and uses no numba: it is the
yardstick the engine is measured against.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import mpmath as mp
import numpy as np

__all__ = ["Restitution", "linear_dashpot", "choose_damping", "restitution_reference",
           "contact_time_scale", "hertz_contact_time", "viscoelastic_group",
           "viscoelastic_series", "VISCOELASTIC_C1",
           "VISCOELASTIC_C2", "viscoelastic_c1_exact", "column_overlaps", "damping_group",
           "scaled_restitution", "scaled_damping", "solve_damping"]


@dataclass(frozen=True)
class Restitution:
    """Outcome of one contact.

    Attributes
    ----------
    e : float or mpmath.mpf
        Restitution coefficient ``-xi'(t_c)/v``, dimensionless (0 when the contact
        never ends).
    contact_time : float or mpmath.mpf
        Contact duration ``t_c`` (s); ``inf`` when the contact never ends.
    ended : bool
        False when the overlap never returns to zero in finite time (tensile,
        critically or over-damped ``n = 2``; or the reference reached ``t_max``).
    """

    e: object
    contact_time: object
    ended: bool


# ----------------------------------------------------------------------------
# n = 2, linear dashpot: closed forms
# ----------------------------------------------------------------------------
def _damping_ratio_terms(b, lib):
    """``(L, w0 t_c)`` of the force-zero end at damping ratio b.

    ``L = -ln e = beta t_c = b * w0 t_c`` with ``w0 t_c = 2 acos(b)/sqrt(1-b^2)`` (b < 1),
    ``2`` (b = 1), ``2 acosh(b)/sqrt(b^2-1)`` (b > 1).  Written so that no digits cancel
    near ``b = 1``: ``acos(b) = 2 asin(sqrt((1-b)/2))``, ``acosh(b) = log1p(u + sqrt(u(u+2)))``
    with ``u = b - 1``.
    """
    if b < 1:
        u = 1 - b
        wt = 4 * lib.asin(lib.sqrt(u / 2)) / lib.sqrt(u * (1 + b))
    elif b == 1:
        wt = 2 * lib.mpf(1) if lib is mp else 2.0
    else:
        u = b - 1
        wt = 2 * lib.log1p(u + lib.sqrt(u * (u + 2))) / lib.sqrt(u * (b + 1))
    return b * wt, wt


def linear_dashpot(c, k, m_eff, tensile=False, *, dps=None) -> Restitution:
    """Closed-form restitution and contact time of ``m_eff xi'' = -(k xi + c xi')``.

    With ``beta = c/(2 m_eff)`` (1/s), ``w0 = sqrt(k/m_eff)`` (rad/s) and the damping
    ratio ``b = beta/w0 = c/(2 sqrt(k m_eff))``, the overlap is the damped oscillator
    started at ``xi = 0, xi' = v``; ``e`` and ``t_c`` do not depend on ``v``.

    ``tensile=True`` (the contact ends at ``xi = 0``):

    * ``b < 1``: ``w = w0 sqrt(1-b^2)``, ``t_c = pi/w``, ``e = exp(-beta pi/w)``;
    * ``b >= 1`` (critical or overdamped): ``xi(t) = v t e^{-beta t}`` or a sum of two
      decaying exponentials of one sign, positive for every ``t > 0``: the overlap
      never returns to zero, the contact never ends; returned as ``e = 0``,
      ``t_c = inf``, ``ended = False`` (the relative speed decays to 0).

    ``tensile=False`` (the force ``k xi + c xi'`` reaches zero, i.e. ``xi'' = 0``, at the
    first ``t > 0``; Schwager and Poeschel, Granular Matter 9, 465 (2007)):

    * ``b < 1``: ``t_c = (pi - 2 arctan(beta/w))/w = 2 acos(b)/w``, equivalently
      ``(pi - arctan(2 beta w/(w0^2 - 2 beta^2)))/w`` for ``beta < w0/sqrt 2``,
      ``pi/(2w)`` at ``beta = w0/sqrt 2`` and ``arctan(2 beta w/(2 beta^2 - w0^2))/w``
      for ``w0/sqrt 2 < beta < w0``;
    * ``b = 1``: ``t_c = 2/w0``;
    * ``b > 1``: ``W = sqrt(beta^2 - w0^2)``, ``t_c = ln((beta + W)/(beta - W))/W
      = 2 acosh(b)/W``;

    and in every regime ``e = exp(-beta t_c)`` (for ``b > 1``:
    ``e = ((beta - W)/(beta + W))^(beta/W)``; at ``b = 1``: ``e = e^-2``).  The three
    branches are one analytic function of ``b``; ``e`` decreases from 1 (``b = 0``)
    to 0 (``b -> inf``, ``e ~ 1/(4 b^2)``), so every ``0 < e < 1`` is reachable.

    Parameters
    ----------
    c : float
        Dashpot coefficient (kg/s), ``>= 0``.
    k : float
        Spring stiffness (N/m), ``> 0``.
    m_eff : float
        Reduced mass (kg), ``> 0``.
    tensile : bool
        End condition (see above).
    dps : int, optional
        If given, evaluate with mpmath at this many digits and return mpf numbers.

    Returns
    -------
    Restitution
    """
    if not (k > 0 and m_eff > 0 and c >= 0):
        raise ValueError("need k > 0, m_eff > 0, c >= 0")
    if dps is not None:
        with mp.workdps(dps):
            r = _linear_dashpot(mp.mpf(c), mp.mpf(k), mp.mpf(m_eff), tensile, mp)
        return r
    return _linear_dashpot(float(c), float(k), float(m_eff), tensile, math)


def _linear_dashpot(c, k, m, tensile, lib):
    w0 = lib.sqrt(k / m)
    b = c / (2 * lib.sqrt(k * m))
    if tensile:
        if b >= 1:
            return Restitution(0 * w0, lib.inf, False)
        s = lib.sqrt((1 - b) * (1 + b))
        return Restitution(lib.exp(-lib.pi * b / s), lib.pi / (w0 * s), True)
    L, wt = _damping_ratio_terms(b, lib)
    return Restitution(lib.exp(-L), wt / w0, True)


def choose_damping(e, k, m_eff, tensile=False) -> float:
    """The linear-dashpot coefficient ``c`` (kg/s) giving restitution ``e`` at ``n = 2``.

    ``tensile=True``: inverting ``e = exp(-pi b/sqrt(1-b^2))`` gives
    ``b = -ln e / sqrt(pi^2 + ln^2 e)``, ``c = 2 b sqrt(k m_eff)``.

    ``tensile=False``: ``-ln e = b * w0 t_c(b)`` (see :func:`linear_dashpot`) is
    increasing in ``b`` from 0 to infinity; it is solved for ``b`` with Brent's
    method to a relative 4 ulp.  ``e < e^-2 = 0.1353`` needs an overdamped dashpot.

    Parameters
    ----------
    e : float
        Target restitution, dimensionless, ``0 < e <= 1`` (``e = 1`` gives ``c = 0``).
    k, m_eff : float
        Stiffness (N/m) and reduced mass (kg).
    tensile : bool
        End condition the target refers to.

    Returns
    -------
    float
        ``c`` in kg/s.
    """
    from scipy import optimize  # (on first use: tests/test_import_graph.py, DEFERRED)
    if not 0 < e <= 1:
        raise ValueError(f"restitution must be in (0, 1], got {e}")
    scale = 2.0 * math.sqrt(k * m_eff)
    target = -math.log(e)
    if target == 0:
        return 0.0
    if tensile:
        return scale * target / math.hypot(math.pi, target)
    # -ln e ~ pi b (b -> 0) and ~ 2 ln(2 b) (b -> inf): brackets the root.
    hi = max(1.0, math.exp(target / 2))
    while _damping_ratio_terms(hi, math)[0] < target:
        hi *= 2
    b = optimize.brentq(lambda x: _damping_ratio_terms(x, math)[0] - target, 0.0, hi,
                        xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=500)
    return scale * b


# ----------------------------------------------------------------------------
# High-precision reference for any exponent
# ----------------------------------------------------------------------------
_MAX_Q = 12


def _rational_exponent(n) -> Fraction:
    """``n`` as p/q with q <= 12 (the float ``2.7`` is read as exactly 27/10)."""
    fr = Fraction(n).limit_denominator(_MAX_Q)
    if float(fr) != float(n):
        raise NotImplementedError(f"exponent {n} is not p/q with q <= {_MAX_Q}")
    if fr <= 1:
        raise ValueError("exponent must be > 1")
    return fr


@dataclass
class _Law:
    """Scaled contact law ``X'' = -X^(n-1) - g D'``, D = X (linear) or X^(n-1) (viscoelastic)."""

    n: object       # mpf, p/q
    q: int          # denominator of n
    qn: int         # q n = p, exact
    qa: int         # q (n - 1) = p - q, exact
    visco: bool
    g: object       # scaled damping coefficient (mpf)

    def force(self, x, v):
        """Scaled force ``-X''`` at overlap x > 0 and rate v."""
        p = x ** (self.n - 1)
        return p + self.g * ((self.n - 1) * p / x * v if self.visco else v)


def _power_coefficient(a, x, P, m):
    """Coefficient m of ``P = X^a`` from ``x_0..x_m`` and ``P_0..P_(m-1)``.

    From ``X P' = a X' P``: ``m x_0 P_m = sum_{j=1..m} ((a+1) j - m) x_j P_(m-j)``.
    """
    xs, ps = x[1:m + 1], P[m - 1::-1]
    jx = [j * xj for j, xj in enumerate(xs, 1)]
    return ((a + 1) * mp.fdot(jx, ps) - m * mp.fdot(xs, ps)) / (m * x[0])


def _end_series(law, v0, g, nterms):
    """Coefficients ``z_m`` of ``X(tau) = tau * sum z_m s^m``, ``s = tau^(1/q)``.

    The motion starts at ``X = 0`` with speed ``v0 > 0`` and damping ``g`` (negative
    for the time-reversed end of a contact).  ``X^(n-1)`` is not analytic at ``X = 0``
    but ``X`` is a power series in ``s``: from the integral equation
    ``X = v0 tau - g int D - int (tau - sigma) X^(n-1)`` each ``z_M`` follows from
    earlier ones (``P = Z^(n-1)`` by the power recurrence of a series).
    """
    q, n = law.q, law.n
    qn, qa = law.qn, law.qa
    a = n - 1
    z = [mp.mpf(v0)] + [mp.mpf(0)] * nterms
    P = [z[0] ** a] + [mp.mpf(0)] * nterms
    for M in range(1, nterms + 1):
        e1 = 1 + mp.mpf(M) / q
        s = mp.mpf(0)
        if not law.visco and M >= q:
            s -= g * z[M - q] / e1
        if law.visco and M >= qa:
            s -= g * P[M - qa] / e1
        if M >= qn:
            s -= P[M - qn] / ((e1 - 1) * e1)
        z[M] = s
        P[M] = _power_coefficient(a, z, P, M)
    return z


def _series_reach(z, q, tol):
    """Largest tau where the last 2q terms of the series are below ``tol * z_0``."""
    nterms = len(z) - 1
    s0 = mp.inf
    for m in range(nterms - 2 * q + 1, nterms + 1):
        if z[m] != 0:
            s0 = min(s0, (tol * abs(z[0]) / abs(z[m])) ** (mp.mpf(1) / m))
    return s0 ** q


def _series_state(z, q, tau):
    """``(X, dX/dtau)`` of :func:`_end_series` at ``tau``."""
    s = tau ** (mp.mpf(1) / q)
    x = _horner(z, s) * tau
    v = _horner([zm * (1 + mp.mpf(m) / q) for m, zm in enumerate(z)], s)
    return x, v


def _taylor(law, x0, v0, order):
    """Taylor coefficients of X about a point with ``X = x0 > 0``, ``X' = v0``."""
    a = law.n - 1
    x = [x0, v0]
    P = [x0 ** a]
    for k in range(order - 1):
        m = k + 1  # P_m from x_0..x_m (X P' = a X' P)
        P.append(_power_coefficient(a, x, P, m))
        damp = (k + 1) * (P[k + 1] if law.visco else x[k + 1])
        x.append(-(P[k] + law.g * damp) / ((k + 1) * (k + 2)))
    return x


def _horner(c, h):
    """``sum c_j h^j`` (coefficients in ascending order)."""
    acc = c[-1]
    for cj in reversed(c[:-1]):
        acc = acc * h + cj
    return acc


def _poly(c, h, d=0):
    """d-th derivative of ``sum c_j h^j`` at h."""
    if d:
        c = [math.perm(j, d) * cj for j, cj in enumerate(c)][d:]
    return _horner(c, h)


def _taylor_step_size(x, tol):
    """Step where the last two Taylor terms fall below ``tol`` times the state scale."""
    scale = max(abs(x[0]), abs(x[1]))
    K = len(x) - 1
    h = mp.inf
    for j in (K - 1, K):
        if x[j] != 0:
            h = min(h, (tol * scale / abs(x[j])) ** (mp.mpf(1) / j))
    return h


def _first_crossing(f, a, b, tol, samples=16):
    """First root of f in (a, b] with f(a) > 0, or None.

    f is sampled at ``samples`` points (a long step may hold a root of f and f may
    come back positive within it); the first bracket is refined by Illinois.
    """
    ts = [a + (b - a) * mp.mpf(i) / samples for i in range(samples + 1)]
    for ta, tb in zip(ts, ts[1:]):
        if f(tb) <= 0:
            return mp.findroot(f, (ta, tb), solver="illinois", tol=tol ** 2, maxsteps=200)
    return None


def _start(law, tol, nterms, tensile):
    """State ``(t, x, v)`` where the start series hands over to Taylor stepping, or the end.

    Returns ``(t, x, v, None)``, or ``(t, x, v, "end")`` when the contact already
    ends inside the series' reach (the force vanishes under very heavy damping,
    ``tensile=False``; or X returns to 0).  Roots before ``reach/1024`` are not seen.
    """
    z = _end_series(law, 1, law.g, nterms)
    reach = _series_reach(z, law.q, tol)
    # The first sign change of the force (or of X) inside the reach ends the contact.
    if tensile:
        f = lambda t: _series_state(z, law.q, t)[0]
    else:
        f = lambda t: law.force(*_series_state(z, law.q, t))
    tc = _first_crossing(f, reach / 1024, reach, tol)
    if tc is not None:
        return (tc, *_series_state(z, law.q, tc), "end")
    return (reach, *_series_state(z, law.q, reach), None)


def _match_end(law, t, x, v, tol, nterms):
    """Tensile end of a non-analytic contact from a state ``x > 0, v < 0`` near it.

    Time reversal maps the last stretch of the contact onto a start series
    (:func:`_end_series`) with speed ``e = -X'(t_c)`` and damping ``-g``; ``e`` and
    the remaining time ``tau`` solve ``X_ser(tau; e) = x, X'_ser(tau; e) = -v``.
    """
    def residual(e, tau):
        xs, vs = _series_state(_end_series(law, e, -law.g, nterms), law.q, tau)
        return xs - x, vs + v
    e, tau = mp.findroot(residual, (-v, x / -v), tol=tol ** 2, maxsteps=50)
    reach = _series_reach(_end_series(law, e, -law.g, nterms), law.q, tol)
    if not 0 < tau <= reach:
        raise ArithmeticError("end series matched outside its reach")
    return e, t + tau


def _switch_overlap(law, v, tol, nterms):
    """Overlap below which the tensile end is taken from the time-reversed series."""
    return abs(v) * _series_reach(_end_series(law, -v, -law.g, nterms), law.q, tol) / 4


def _integrate(law, tensile, dps, t_max, max_steps=100000):
    """Scaled contact (``X'(0) = 1``): returns ``(e, t_c, ended)`` as mpf."""
    tol = mp.mpf(10) ** (-dps + 3)
    order, nterms = dps + 10, 30 * law.q + 30
    t, x, v, end = _start(law, tol, nterms, tensile)
    if end:
        return -v, t, True
    x_switch = None
    for _ in range(max_steps):
        c = _taylor(law, x, v, order)
        h = min(_taylor_step_size(c, tol), t_max - t)
        if not tensile:
            s = _first_crossing(lambda s: -_poly(c, s, 2), 0, h, tol)  # force = -X''
            if s is not None:
                return -_poly(c, s, 1), t + s, True
        elif law.q == 1:  # X^(n-1) analytic: the Taylor polynomial runs through X = 0
            s = _first_crossing(lambda s: _poly(c, s), 0, h, tol)
            if s is not None:
                return -_poly(c, s, 1), t + s, True
        elif v < 0:
            x_switch = x_switch or _switch_overlap(law, v, tol, nterms)
            s = _first_crossing(lambda s: _poly(c, s) - x_switch, 0, h, tol)
            if s is not None:
                return (*_match_end(law, t + s, x_switch, _poly(c, s, 1), tol, nterms), True)
        t, x, v = t + h, _poly(c, h), _poly(c, h, 1)
        if t >= t_max:
            return mp.mpf(0), mp.inf, False
    raise ArithmeticError(f"contact not ended after {max_steps} Taylor steps")


def contact_time_scale(v, k, m_eff, n):
    """Time unit ``tau_u = (m_eff v^(2-n) / k)^(1/n)`` (s) of an ``n``-power contact at speed v.

    In units ``tau_u`` (time) and ``v tau_u`` (overlap) the undamped contact is
    ``X'' = -X^(n-1)``, ``X(0) = 0``, ``X'(0) = 1``; for ``n = 5/2`` ``tau_u = (m_eff^2/(k^2 v))^(1/5)``.

    Parameters
    ----------
    v : float
        Impact (relative) speed, m/s.
    k : float
        Force coefficient of ``F = k xi^(n-1)``, N/m^(n-1).
    m_eff : float
        Reduced mass, kg.
    n : float
        Potential exponent, dimensionless (> 1).

    Returns
    -------
    float
        ``tau_u`` in seconds.
    """
    return (m_eff * v ** (2 - n) / k) ** (1 / n)


def restitution_reference(v, k, m_eff, n=2, model="linear", coefficient=0.0, tensile=False,
                          *, dps=40, t_max=1e4) -> Restitution:
    """Restitution and contact time by high-precision integration of the contact ODE.

    Solves ``m_eff xi'' = -F`` (see the module docstring; ``model`` is ``"linear"``,
    ``F = k xi^(n-1) + c xi'`` with ``c = coefficient``, or ``"viscoelastic"``,
    ``F = k xi^(n-1) + A k (n-1) xi^(n-2) xi'`` with ``A = coefficient``) in the
    scaled form ``X'' = -X^(n-1) - g D'`` (``D = X``, ``g = c tau_u/m_eff``; or
    ``D = X^(n-1)``, ``g = A/tau_u``; ``tau_u`` from :func:`contact_time_scale`),
    with mpmath at ``dps`` digits:

    * start: ``X`` is a power series in ``s = t^(1/q)`` (``n = p/q``) although
      ``X^(n-1)`` is not analytic at ``X = 0``; its coefficients follow from the
      integral form of the ODE, and it is summed while its terms are below 1e-(dps-3);
    * then Taylor steps of order ``dps + 10`` (coefficients by the exact recurrences
      of ``X^(n-1)``), each as long as its last two terms allow;
    * end: the first root of the force (``tensile=False``) or of ``X`` (``tensile=True``,
      integer ``n``) inside a step, by bracketing root finding on the step's polynomial;
      for ``tensile=True`` and non-integer ``n`` the last stretch is the time-reversed
      start series, matched in overlap and rate (unknowns: ``e`` and the time left).

    No damping with ``tensile=False`` is the same contact as ``tensile=True``.  The
    Taylor steps are explicit: a heavily overdamped contact (scaled ``g >> 1``) needs
    steps of order ``1/g``, slow when its overlap never returns to zero (``t_max``).
    Exponents with ``q > 2`` and ``tensile=True`` match the end by Newton on the
    series and take seconds.

    Parameters
    ----------
    v : float
        Impact speed (m/s), > 0.
    k : float
        Contact stiffness (N/m^(n-1)).
    m_eff : float
        Reduced mass (kg).
    n : float
        Force exponent ``p/q`` with ``q <= 12`` (``n = 2``: linear spring; ``2.5``: Hertz).
    model : {"linear", "viscoelastic"}
        Damping law.
    coefficient : float
        ``c`` (kg/s) or ``A`` (s), ``>= 0``.
    tensile : bool
        End condition.
    dps : int
        Working digits (accuracy about ``dps - 5`` digits).
    t_max : float
        Give up (``ended=False``, ``e = 0``) after this many units ``tau_u``:
        an overlap that decays without ever reaching zero.

    Returns
    -------
    Restitution
        mpf ``e`` and ``contact_time`` (s).
    """
    if model not in ("linear", "viscoelastic"):
        raise ValueError(f"unknown damping model {model!r}")
    if not (v > 0 and k > 0 and m_eff > 0 and coefficient >= 0):
        raise ValueError("need v, k, m_eff > 0 and coefficient >= 0")
    fr = _rational_exponent(n)
    with mp.workdps(dps + 5):
        nm = mp.mpf(fr.numerator) / fr.denominator
        tau_u = contact_time_scale(mp.mpf(v), mp.mpf(k), mp.mpf(m_eff), nm)
        visco = model == "viscoelastic"
        g = mp.mpf(coefficient) / tau_u if visco else mp.mpf(coefficient) * tau_u / m_eff
        law = _Law(nm, fr.denominator, fr.numerator, fr.numerator - fr.denominator, visco, g)
        e, t, ended = _integrate(law, tensile or g == 0, dps + 5, mp.mpf(t_max))
        return Restitution(+e, +(t * tau_u), ended)


def hertz_contact_time(v, k, m_eff, n=2.5):
    """Duration of an undamped ``F = k xi^(n-1)`` contact at impact speed v (s).

    Energy conservation ``X'^2/2 + X^n/n = 1/2`` (scaled) gives ``X_max = (n/2)^(1/n)`` and
    ``t_c = 2 X_max B(1/n, 1/2)/n * tau_u`` (``tau_u`` from :func:`contact_time_scale`);
    ``n = 2``: ``pi sqrt(m_eff/k)``; ``n = 5/2``:
    ``t_c = (4/5)(5/4)^(2/5) sqrt(pi) Gamma(2/5)/Gamma(9/10) (m_eff^2/(k^2 v))^(1/5)
    = 3.2145... (m_eff^2/(k^2 v))^(1/5)``.  Returns an mpf at the current precision.

    Parameters
    ----------
    v : float
        Impact (relative) speed, m/s.
    k : float
        Force coefficient of ``F = k xi^(n-1)``, N/m^(n-1).
    m_eff : float
        Reduced mass, kg.
    n : float
        Potential exponent, dimensionless (> 1); 5/2 (Hertz) by default.

    Returns
    -------
    mpmath.mpf
        Contact time ``t_c`` in seconds.
    """
    n = mp.mpf(n)
    const = 2 * (n / 2) ** (1 / n) * mp.beta(1 / n, mp.mpf(1) / 2) / n
    return const * contact_time_scale(mp.mpf(v), mp.mpf(k), mp.mpf(m_eff), n)


# ----------------------------------------------------------------------------
# Viscoelastic Hertz at small speed
# ----------------------------------------------------------------------------
def viscoelastic_c1_exact():
    """``C1 = sqrt(pi) Gamma(3/5) / (2^(1/5) 5^(2/5) Gamma(21/10))`` = 1.15344886... (mpf).

    First order in the damping: the energy lost along the undamped Hertz orbit,
    ``1 - e = 2 g int_0^Xmax (3/2) X^(1/2) sqrt(1 - (4/5) X^(5/2)) dX`` (scaled units of
    :func:`contact_time_scale`, ``g = A/tau_u``), is ``C1 * (3/2) g``; the integral is a
    Beta function.  :func:`restitution_reference` reproduces it (tests).

    Returns
    -------
    mpmath.mpf
        ``C1`` (dimensionless) at the current mpmath precision.
    """
    return (mp.sqrt(mp.pi) * mp.gamma(mp.mpf(3) / 5)
            / (mp.mpf(2) ** (mp.mpf(1) / 5) * mp.mpf(5) ** (mp.mpf(2) / 5) * mp.gamma(mp.mpf(21) / 10)))


#: Series coefficients as printed by Schwager and Poeschel (PRE 78, 021302, 2008);
#: ``C2 = (3/5) C1^2``.
VISCOELASTIC_C1 = 1.15344
VISCOELASTIC_C2 = 0.79826


def viscoelastic_group(v, k, A, m_eff):
    """Expansion variable ``G = (3/2) A (k/m_eff)^(2/5) v^(1/5)`` of the viscoelastic series.

    For ``m_eff xi'' = -k xi^(3/2) - (3/2) A k xi^(1/2) xi'`` the only dimensionless
    group is ``A (k/m_eff)^(2/5) v^(1/5)`` (= ``A/tau_u``); the factor 3/2 makes
    ``1 - e = C1 G + O(G^2)`` with ``C1 = 1.15344`` (i.e. the series' ``A alpha^(2/5)``
    with ``alpha = (3/2)^(5/2) k/m_eff``), as the reference integration confirms
    (without it the slope would be 1.5 C1 = 1.7302).

    Parameters
    ----------
    v : float or array_like
        Impact (relative) speed(s), m/s; any shape.
    k : float
        Hertz force coefficient, N/m^(3/2).
    A : float
        Viscoelastic dissipation time, s.
    m_eff : float
        Reduced mass, kg.

    Returns
    -------
    numpy.ndarray
        ``G``, dimensionless, the shape of ``v``.
    """
    return 1.5 * A * (k / m_eff) ** 0.4 * np.asarray(v, dtype=float) ** 0.2


def viscoelastic_series(v, k, A, m_eff, terms=2):
    """Small-speed series of the viscoelastic-Hertz restitution coefficient.

    For ``m_eff xi'' = -k xi^(3/2) - (3/2) A k xi^(1/2) xi'`` (``A`` in s, ``k`` in
    N/m^(3/2), ``v`` in m/s) and ``G = (3/2) A (k/m_eff)^(2/5) v^(1/5)``
    (:func:`viscoelastic_group`):

        ``e = 1 - C1 G + C2 G^2 + O(G^(5/2))``,  ``C1 = 1.15344``, ``C2 = 0.79826``

    (Schwager and Poeschel, Phys. Rev. E 78, 021302 (2008)), evaluated with all the
    digits of ``C1`` (:func:`viscoelastic_c1_exact`) and ``C2 = (3/5) C1^2``, which
    round to the printed values.  The reference
    integration gives the same ``C1`` and ``C2`` for both end conditions; ending at
    zero force (``tensile=False``) instead of zero overlap changes ``e`` only at order
    ``G^(5/2)`` (the overlap at separation is ``(3/2) A v_end`` in scaled units).

    Parameters
    ----------
    v : float or ndarray
        Impact speed (m/s).
    k, A, m_eff : float
        Hertz stiffness, viscoelastic time (s), reduced mass (kg).
    terms : {1, 2}
        Number of correction terms kept.

    Returns
    -------
    float or ndarray
        ``e`` (same shape as ``v``).
    """
    if terms not in (1, 2):
        raise ValueError("terms must be 1 or 2")
    G = viscoelastic_group(v, k, A, m_eff)
    c1 = float(viscoelastic_c1_exact())
    e = 1 - c1 * G
    if terms == 2:
        e = e + 0.6 * c1 ** 2 * G ** 2
    return e


# ----------------------------------------------------------------------------
# Static column under gravity
# ----------------------------------------------------------------------------
def column_overlaps(N, m, g, k, n):
    """Static overlaps of a vertical column of N granules resting on a wall.

    Granule i (1 = top) and the contact below it carry the weight of the i
    granules above and including it: ``k delta_i^(n-1) = g sum_{j<=i} m_j``, so for
    equal masses ``delta_i = (i m g / k)^(1/(n-1))``.  Contact N is the wall.

    Parameters
    ----------
    N : int
        Number of granules.
    m : float or ndarray, shape (N,)
        Masses (kg), top first.
    g : float
        Gravitational acceleration (m/s^2), > 0.
    k : float or ndarray, shape (N,)
        Stiffness of each contact (N/m^(n-1)); entry N-1 is the wall contact.
    n : float
        Force exponent.

    Returns
    -------
    ndarray, shape (N,)
        Overlaps (m), top contact first, the wall contact last.
    """
    load = g * np.cumsum(np.broadcast_to(np.asarray(m, dtype=float), (N,)))
    return (load / np.asarray(k, dtype=float)) ** (1.0 / (n - 1))


# ----------------------------------------------------------------------------
# A target restitution for any exponent: float64 e(g) and its inverse
# ----------------------------------------------------------------------------
#: Integration tolerances of :func:`scaled_restitution` (DOP853, relative and absolute).
_RTOL, _ATOL = 2.5e-14, 1e-17


def damping_group(A, speed, n, k, m_reduced):
    """The one dimensionless group ``g = A / tau_u`` of a viscoelastic contact.

    Scaling ``xi = v tau_u X``, ``t = tau_u T`` with ``tau_u`` of
    :func:`contact_time_scale` turns ``m xi'' = -k xi^(n-1) - A d/dt(k xi^(n-1))``
    into ``X'' = -X^(n-1) - g d/dT(X^(n-1))``, ``X(0) = 0``, ``X'(0) = 1``, with::

        g = A / tau_u = A (k / m)^(1/n) v^((n-2)/n)                  (R1)

    so ``e`` depends on ``A``, ``k``, ``m`` and ``v`` through ``g`` alone; ``g``
    does not depend on ``v`` at ``n = 2`` only (``n = 5/2``: ``g ~ A v^(1/5)``,
    ``n = 3``: ``g ~ A v^(1/3)``).

    Parameters
    ----------
    A : float or ndarray
        Viscoelastic dissipation time (s).
    speed : float or ndarray
        Impact (relative approach) speed (m/s), > 0.
    n : float
        Force exponent (> 1).
    k : float
        Force coefficient of ``F = k xi^(n-1)`` (N/m^(n-1)).
    m_reduced : float
        Reduced mass (kg).

    Returns
    -------
    float or ndarray
        ``g``, dimensionless.
    """
    return A / contact_time_scale(speed, k, m_reduced, n)


def _scaled_rhs(n, g):
    """Right-hand side of the first-order form of the scaled contact.

    With ``W = X' + g X^(n-1)`` the contact ``X'' = -P - g P'``, ``P = X^(n-1)``, is::

        X' = W - g P,   W' = -P                                       (R2)

    which holds no derivative of ``P`` and so no ``X^(n-2)`` (infinite at ``X = 0``
    for ``n < 2``, non-smooth for ``n < 3``); ``P`` is taken as 0 for ``X < 0``.
    """
    a = n - 1.0

    def rhs(t, y):
        p = y[0] ** a if y[0] > 0.0 else 0.0
        return np.array([y[1] - g * p, -p])
    return rhs


def _scaled_start(n, g):
    """``(T0, X(T0), W(T0))`` of the start series, with terms left out below 1e-17.

    From ``X = T - g int P - int int P`` (integrated (R2)), iterated twice::

        X = T - g T^n/n + (n-1) g^2 T^(2n-1)/(n(2n-1)) - T^(n+1)/(n(n+1)) + ...
        W = 1 - T^n/n + (n-1) g T^(2n-1)/(n(2n-1)) + ...

    the first terms left out being ``g^3 T^(3n-2)`` and ``g T^(2n)`` (X), ``g^2
    T^(3n-2)`` and ``T^(2n)`` (W); ``T0`` keeps them below 1e-17.
    """
    big = 1.0 + g
    t0 = min(1e-2, (1e-17 / big ** 3) ** (1.0 / (3 * n - 2)), (1e-17 / big) ** (1.0 / (2 * n)))
    tn = t0 ** n
    third = (n - 1) * g * t0 ** (2 * n - 1) / (n * (2 * n - 1))
    x = t0 - g * tn / n + g * third - tn * t0 / (n * (n + 1))
    w = 1.0 - tn / n + third
    return t0, x, w


def _contact_end(n, g, tensile):
    """Event function of the end of the scaled contact (terminal, decreasing).

    ``tensile``: ``X = 0``. Otherwise the force ``P + g (n-1) X^(n-2) X'`` reaches 0,
    i.e. ``X + g (n-1) X' = X + g (n-1) (W - g P) = 0`` (``X > 0``).
    """
    if tensile:
        def end(t, y):
            return y[0]
    else:
        a = n - 1.0

        def end(t, y):
            p = y[0] ** a if y[0] > 0.0 else 0.0
            return y[0] + g * a * (y[1] - g * p)
    end.terminal, end.direction = True, -1
    return end


def scaled_restitution(g, n, tensile=False):
    """Restitution ``e(g)`` of the scaled viscoelastic contact, float64.

    Integrates ``X'' = -X^(n-1) - g d/dT(X^(n-1))``, ``X(0) = 0``, ``X'(0) = 1``
    (the contact of :func:`damping_group`, eq. (R1)) in the form (R2) of
    :func:`_scaled_rhs` with DOP853 (relative tolerance 2.5e-14, the smallest scipy takes) from the start
    series of :func:`_scaled_start`, to the end of the contact (force 0, or
    ``X = 0`` when ``tensile``), located on the dense output and then reached by
    a last integration; ``e = -X'(T_c) = -(W - g P)``. ``n = 2`` is the linear
    dashpot of damping ratio ``c / (2 sqrt(k m)) = g / 2`` in closed form
    (:func:`linear_dashpot` with ``k = m = 1``, ``c = g``).
    Agrees with :func:`restitution_reference` to about 1e-13 (tests).

    Parameters
    ----------
    g : float
        Damping group (R1), dimensionless, ``>= 0``.
    n : float
        Force exponent (> 1).
    tensile : bool
        End condition (module docstring).

    Returns
    -------
    float
        ``e`` in [0, 1] (0 when a tensile contact never ends, ``n = 2``, ``g >= 2``).
    """
    from scipy.integrate import solve_ivp
    if not (g >= 0 and math.isfinite(g) and n > 1):
        raise ValueError(f"need g >= 0 finite and n > 1, got g = {g}, n = {n}")
    if g == 0:
        return 1.0
    if n == 2:
        return float(linear_dashpot(g, 1.0, 1.0, tensile).e)
    rhs, end = _scaled_rhs(n, g), _contact_end(n, g, tensile)
    t0, x0, w0 = _scaled_start(n, g)
    span = (t0, t0 + 1e3 * (1.0 + g))
    sol = solve_ivp(rhs, span, [x0, w0], method="DOP853", rtol=_RTOL, atol=_ATOL,
                    events=end)
    if sol.status != 1:
        raise ArithmeticError(f"scaled contact n = {n}, g = {g} did not end")
    tc = float(sol.t_events[0][0])
    last = solve_ivp(rhs, (t0, tc), [x0, w0], method="DOP853", rtol=_RTOL, atol=_ATOL)
    x, w = last.y[:, -1]
    p = max(x, 0.0) ** (n - 1.0)
    return float(-(w - g * p))


def scaled_damping(e, n, tensile=False):
    """The damping group ``g`` (eq. (R1)) whose scaled contact has restitution ``e``.

    Inverse of :func:`scaled_restitution`, which decreases from 1 (``g = 0``)
    towards 0 as ``g`` grows: Brent's method on a bracket found by doubling, to a
    relative 4 ulp in ``g``. ``n = 2``: ``g = 2 b`` with the damping ratio ``b`` of
    :func:`choose_damping` (closed form or one root), as the engine's linear dashpot.

    Parameters
    ----------
    e : float
        Target restitution, dimensionless, ``0 < e <= 1``.
    n : float
        Force exponent (> 1).
    tensile : bool
        End condition (module docstring).

    Returns
    -------
    float
        ``g >= 0`` (0 for ``e = 1``).
    """
    from scipy import optimize
    if not 0 < e <= 1:
        raise ValueError(f"restitution must be in (0, 1], got {e}")
    if not n > 1:
        raise ValueError(f"exponent must be > 1, got {n}")
    if e == 1:
        return 0.0
    if n == 2:
        return choose_damping(e, 1.0, 1.0, tensile)
    hi = 1.0
    while scaled_restitution(hi, n, tensile) > e:
        hi *= 2.0
        if hi > 1e12:
            raise ArithmeticError(f"restitution {e} not reached at n = {n}")
    return optimize.brentq(lambda g: scaled_restitution(g, n, tensile) - e, 0.0, hi,
                           xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=200)


def solve_damping(e, speed, n, k, m_reduced, tensile=False):
    """The viscoelastic constant ``A`` (s) giving restitution ``e`` at impact speed ``speed``.

    ``A = g(e) tau_u`` with ``g(e)`` from :func:`scaled_damping` and ``tau_u =
    (m v^(2-n) / k)^(1/n)`` (:func:`contact_time_scale`), from eq. (R1). For the
    force ``k xi^(n-1) + A d/dt(k xi^(n-1))`` at ``n = 2`` this is ``A = c / k``
    with ``c`` of :func:`choose_damping`, the same at every speed (``speed`` may
    be None there); for ``n != 2`` the contact has restitution ``e`` at ``speed``
    only (eq. (R1): ``g ~ A v^((n-2)/n)``).

    Parameters
    ----------
    e : float
        Target restitution, dimensionless, ``0 < e <= 1``.
    speed : float or None
        Impact (relative approach) speed at which ``e`` holds (m/s), > 0; unused
        (may be None) at ``n = 2``.
    n : float
        Force exponent (> 1).
    k : float
        Force coefficient of ``F = k xi^(n-1)`` (N/m^(n-1)), > 0.
    m_reduced : float
        Reduced mass (kg), > 0 (the granule's mass against a wall).
    tensile : bool
        End condition (module docstring).

    Returns
    -------
    float
        ``A`` in s.
    """
    if not (k > 0 and m_reduced > 0):
        raise ValueError("need k > 0 and m_reduced > 0")
    if n == 2:
        return choose_damping(e, k, m_reduced, tensile) / k
    if speed is None or not (speed > 0 and math.isfinite(speed)):
        raise ValueError(f"n = {n}: e depends on the impact speed; need speed > 0, got {speed}")
    return scaled_damping(e, n, tensile) * float(contact_time_scale(speed, k, m_reduced, n))
