"""Sec. II A of the paper: frictionless granule 1, kinetic friction ``eta`` on granule 2.

Granule 2 stays put until the spring force ``x1 = sin t`` reaches ``eta`` (at
``t0 = arcsin eta``); then both move, linearly, until the contact opens
``pi/sqrt2`` later. Closed forms as printed (all exact), the threshold
``(1 + pi^2/8)^(-1/2) = 0.669...`` of backscattering and propagation, and the
energy minimum the paper remarks on. Scaled units (Appendix A).
"""
from __future__ import annotations

import math

import mpmath

from .arithmetic import arithmetic_for

__all__ = ["iia_x1_phase1", "iia_t0", "iia_x1", "iia_x2", "iia_v1", "iia_v2", "iia_t1",
           "iia_v1s", "iia_v2s", "iia_eta_max", "iia_energy_ratio", "iia_energy_minimum",
           "iia_stuck_second_granule_v1"]

SQRT2 = math.sqrt(2.0)


def iia_x1_phase1(t):
    """Sec. II A Eq. (``eq:sol1``): ``x1(t) = sin t`` while granule 2 is stuck.

    Valid for ``0 <= t <= t0 = arcsin(eta)`` (exact).

    Parameters
    ----------
    t : float, ndarray or mpf
        Scaled time.

    Returns
    -------
    Same type as ``t``
        Displacement of granule 1.
    """
    arith = arithmetic_for(t)
    return arith.sin(arith.num(t))


def iia_t0(eta):
    """Sec. II A: granule 2 starts to slide at ``t0 = arcsin(eta)`` (exact, eta < 1).

    Parameters
    ----------
    eta : float, ndarray or mpf
        Scaled kinetic friction of granule 2.

    Returns
    -------
    Same type as ``eta``
        Time at which the spring force ``x1 = sin t`` reaches ``eta``.
    """
    arith = arithmetic_for(eta)
    return arith.asin(arith.num(eta))


def iia_x1(tp, eta):
    """Sec. II A Eq. (``eq:x1``), as printed (exact).

    ``x1(t') = 1/4 [ -eta(-3 + t'^2) + 2 c t' + eta cos(sqrt2 t') + sqrt2 c sin(sqrt2 t') ]``,
    ``c = (1 - eta^2)^(1/2)``, ``t' = t - t0``; valid while both granules move
    and are in contact (``0 <= t' <= pi/sqrt2`` when ``eta < 0.669...``).

    Parameters
    ----------
    tp : float, ndarray or mpf
        ``t' = t - arcsin(eta)``.
    eta : float or mpf
        Scaled friction on granule 2, ``0 <= eta < 1``.

    Returns
    -------
    Same type as ``tp``
        Displacement of granule 1.
    """
    arith = arithmetic_for(tp, eta)
    tp, eta = arith.num(tp), arith.num(eta)
    c = arith.sqrt(1 - eta**2)
    r2 = arith.sqrt(arith.num(2))
    return (-eta * (-3 + tp**2) + 2 * c * tp + eta * arith.cos(r2 * tp)
            + r2 * c * arith.sin(r2 * tp)) / 4


def iia_x2(tp, eta):
    """Sec. II A Eq. (``eq:x2``), as printed (exact).

    ``x2(t') = -1/4 [ eta(-1 + t'^2) - 2 c t' + eta cos(sqrt2 t') + sqrt2 c sin(sqrt2 t') ]``.

    Parameters
    ----------
    tp : float, ndarray or mpf
        ``t' = t - arcsin(eta)``.
    eta : float or mpf
        Scaled friction on granule 2.

    Returns
    -------
    Same type as ``tp``
        Displacement of granule 2.
    """
    arith = arithmetic_for(tp, eta)
    tp, eta = arith.num(tp), arith.num(eta)
    c = arith.sqrt(1 - eta**2)
    r2 = arith.sqrt(arith.num(2))
    return -(eta * (-1 + tp**2) - 2 * c * tp + eta * arith.cos(r2 * tp)
             + r2 * c * arith.sin(r2 * tp)) / 4


def iia_v1(tp, eta):
    """Time derivative of Eq. (``eq:x1``) (not printed; used for v1^(s)).

    ``v1(t') = 1/4 [ -2 eta t' + 2c - sqrt2 eta sin(sqrt2 t') + 2c cos(sqrt2 t') ]``.

    Parameters
    ----------
    tp : float, ndarray or mpf
        Time since the phase began, ``t' = t - t0``, units of ``B``.
    eta : float, ndarray or mpf
        Kinetic friction force on granule 2, scaled (units of ``m v0^2/A``).

    Returns
    -------
    same type as ``tp``
        Velocity of granule 1, units of ``v0``.
    """
    arith = arithmetic_for(tp, eta)
    tp, eta = arith.num(tp), arith.num(eta)
    c = arith.sqrt(1 - eta**2)
    r2 = arith.sqrt(arith.num(2))
    return (-2 * eta * tp + 2 * c - r2 * eta * arith.sin(r2 * tp) + 2 * c * arith.cos(r2 * tp)) / 4


def iia_v2(tp, eta):
    """Time derivative of Eq. (``eq:x2``) (not printed).

    ``v2(t') = 1/4 [ -2 eta t' + 2c + sqrt2 eta sin(sqrt2 t') - 2c cos(sqrt2 t') ]``.

    Parameters
    ----------
    tp : float, ndarray or mpf
        Time since the phase began, ``t' = t - t0``, units of ``B``.
    eta : float, ndarray or mpf
        Kinetic friction force on granule 2, scaled (units of ``m v0^2/A``).

    Returns
    -------
    same type as ``tp``
        Velocity of granule 2, units of ``v0``.
    """
    arith = arithmetic_for(tp, eta)
    tp, eta = arith.num(tp), arith.num(eta)
    c = arith.sqrt(1 - eta**2)
    r2 = arith.sqrt(arith.num(2))
    return (-2 * eta * tp + 2 * c + r2 * eta * arith.sin(r2 * tp) - 2 * c * arith.cos(r2 * tp)) / 4


def iia_t1(eta=None):
    """Sec. II A: contact lasts ``t1 = pi/sqrt2`` after ``t0`` (exact, eta < 0.669...).

    ``x1 - x2 = eta/2 (1 + cos(sqrt2 t')) + c/sqrt2 sin(sqrt2 t')`` is positive on
    ``(0, pi/sqrt2)`` and vanishes at ``pi/sqrt2`` for every eta.

    Parameters
    ----------
    eta : float, mpf or None
        Ignored except to choose float or mpmath output.

    Returns
    -------
    float or mpf
        ``pi / sqrt(2)``.
    """
    arith = arithmetic_for(eta)
    return arith.pi() / arith.sqrt(arith.num(2))


def iia_v1s(eta):
    """Sec. II A: ``v1^(s) = -eta pi / (2 sqrt2)`` at separation (exact, eta < 0.669...).

    Parameters
    ----------
    eta : float, ndarray or mpf
        Kinetic friction force on granule 2, scaled (units of ``m v0^2/A``).

    Returns
    -------
    Same type as ``eta``
        Velocity of granule 1 at separation (negative: backscattering).
    """
    arith = arithmetic_for(eta)
    eta = arith.num(eta)
    return -eta * arith.pi() / (2 * arith.sqrt(arith.num(2)))


def iia_v2s(eta):
    """Sec. II A: ``v2^(s) = (1-eta^2)^(1/2) - eta pi / (2 sqrt2)`` (exact, eta < 0.669...).

    Parameters
    ----------
    eta : float, ndarray or mpf
        Kinetic friction force on granule 2, scaled (units of ``m v0^2/A``).

    Returns
    -------
    Same type as ``eta``
        Velocity of granule 2 at separation.
    """
    arith = arithmetic_for(eta)
    eta = arith.num(eta)
    return arith.sqrt(1 - eta**2) - eta * arith.pi() / (2 * arith.sqrt(arith.num(2)))


def iia_eta_max(exact=False):
    """Sec. II A: backscattering and propagation for ``0 < eta < (1 + pi^2/8)^(-1/2) = 0.669...``.

    Exact: ``v2^(s) > 0`` iff ``eta`` is below this value, and granule 2 (whose
    acceleration ``x1-x2-eta`` changes sign once) keeps ``v2 > 0`` during the
    contact iff ``v2^(s) > 0``.  For ``0.669... < eta < 1`` granule 2 stops and
    sticks before separation (outcome ``backscatter_only``).

    Parameters
    ----------
    exact : bool
        Return an mpf at the current mpmath precision instead of a float.

    Returns
    -------
    float or mpf
        0.66907...
    """
    if exact:
        return 1 / mpmath.sqrt(1 + mpmath.pi**2 / 8)
    return (1.0 + math.pi**2 / 8.0) ** -0.5


def iia_energy_ratio(eta):
    """Sec. II A: ``E^(s)/E0 = 1 - eta (1-eta^2)^(1/2) pi / sqrt2 + (pi^2/4 - 1) eta^2`` (exact).

    ``E^(s)/E0 = (v1^(s))^2 + (v2^(s))^2`` with ``E0 = 1/2``; the printed
    expression is algebraically identical to it (verdict: correct).

    Parameters
    ----------
    eta : float, ndarray or mpf
        Kinetic friction force on granule 2, scaled (units of ``m v0^2/A``).

    Returns
    -------
    Same type as ``eta``
        Kinetic energy at separation over the initial kinetic energy.
    """
    arith = arithmetic_for(eta)
    eta = arith.num(eta)
    pi = arith.pi()
    return (1 - eta * arith.sqrt(1 - eta**2) * pi / arith.sqrt(arith.num(2))
            + (pi**2 / 4 - 1) * eta**2)


def iia_energy_minimum():
    """Sec. II A claim: E^(s)/E0 has a minimum inside ``0 < eta < 0.669...``.

    "Curiously, there is a region where this ratio increases with increasing
    friction coefficient."  Returns the minimiser of :func:`iia_energy_ratio`.

    Returns
    -------
    (float, float)
        ``(eta_min, E_min/E0)`` = ``(0.473725..., 0.402529...)``; the ratio increases
        on ``(eta_min, 0.669...)``.
    """
    from scipy import optimize
    def dE(e):
        c = math.sqrt(1 - e * e)
        return -math.pi / SQRT2 * (c - e * e / c) + 2 * (math.pi**2 / 4 - 1) * e

    e = optimize.brentq(dE, 0.1, iia_eta_max(), xtol=1e-15)
    return e, float(iia_energy_ratio(e))


def iia_stuck_second_granule_v1():
    """Sec. II A claim: if granule 2 never moves, granule 1 leaves with ``v1 = -1``.

    Exact for ``eta >= 1``: the spring force ``sin t`` never exceeds ``eta``, so
    granule 1 bounces elastically off a fixed wall and separates at ``t = pi``.

    Returns
    -------
    float
        -1.0
    """
    return -1.0
