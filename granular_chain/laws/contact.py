"""One-sided power-law contacts: small compiled scalar laws.

Force of a contact with overlap ``delta`` (positive when the granules
interpenetrate), force coefficient ``k`` and potential exponent ``n``::

    F(delta) = k * max(delta, 0)**(n - 1)          (repulsive, never attractive)
    V(delta) = k * max(delta, 0)**n / n            (F = dV/d(delta))

This is the paper's eq. (1) with ``V = a delta^n`` read on the overlap side
(the paper prints ``delta <= 0`` with ``delta`` defined positive on overlap: a
sign slip) and with ``k`` a *force* coefficient, ``k = n a``: the scaled
equations of Sec. II and Appendix A set the force coefficient to one.

Each law takes ``(delta, k, n)`` with ``delta >= 0`` already clipped, so the
kernels stay branch-free. ``n`` is ignored by the fixed-exponent laws; it is
passed so that every law has one signature and the kernels compose them.
"""

import math

import numba

LAW_LINEAR = 0
LAW_HERTZ = 1
LAW_POWER = 2


@numba.njit(inline="always", cache=True)
def linear_force(d, k, n):
    """n = 2: F = k d."""
    return k * d


@numba.njit(inline="always", cache=True)
def linear_energy(d, k, n):
    """n = 2: V = k d^2 / 2."""
    return 0.5 * k * d * d


@numba.njit(inline="always", cache=True)
def hertz_force(d, k, n):
    """n = 5/2: F = k d^(3/2), as d*sqrt(d) (a pow costs about three times more)."""
    return k * d * math.sqrt(d)


@numba.njit(inline="always", cache=True)
def hertz_energy(d, k, n):
    """n = 5/2: V = (2/5) k d^(5/2)."""
    return 0.4 * k * d * d * math.sqrt(d)


@numba.njit(inline="always", cache=True)
def power_force(d, k, n):
    """Any n > 1: F = k d^(n-1)."""
    return k * d ** (n - 1.0)


@numba.njit(inline="always", cache=True)
def power_energy(d, k, n):
    """Any n > 1: V = k d^n / n."""
    return k * d ** n / n


@numba.njit(inline="always", cache=True)
def contact_force(law, d, k, n):
    """Force of a contact of overlap ``d`` (any sign): zero unless ``d > 0``.

    ``law`` is a compile-time constant in the kernels, so only one branch is
    compiled into each specialisation.

    Parameters
    ----------
    law : int
        LAW_LINEAR, LAW_HERTZ or LAW_POWER.
    d : float
        Overlap, scene units of length (any sign).
    k : float
        Force coefficient, scene units of force / length^(n-1).
    n : float
        Potential exponent, dimensionless (ignored by the fixed-exponent laws).

    Returns
    -------
    float
        Repulsive force ``k max(d, 0)^(n-1)``, scene units of force.
    """
    d = max(d, 0.0)
    if law == LAW_LINEAR:
        return linear_force(d, k, n)
    elif law == LAW_HERTZ:
        return hertz_force(d, k, n)
    else:
        return power_force(d, k, n)


@numba.njit(inline="always", cache=True)
def contact_energy(law, d, k, n):
    """Potential energy stored in a contact of overlap ``d`` (any sign).

    Parameters
    ----------
    law : int
        LAW_LINEAR, LAW_HERTZ or LAW_POWER.
    d : float
        Overlap, scene units of length (any sign).
    k : float
        Force coefficient, scene units of force / length^(n-1).
    n : float
        Potential exponent, dimensionless (ignored by the fixed-exponent laws).

    Returns
    -------
    float
        ``k max(d, 0)^n / n``, scene units of energy.
    """
    d = max(d, 0.0)
    if law == LAW_LINEAR:
        return linear_energy(d, k, n)
    elif law == LAW_HERTZ:
        return hertz_energy(d, k, n)
    else:
        return power_energy(d, k, n)
