"""Root finding and minimisation at mpmath precision, for the paper's exact values.

The paper's thresholds (0.4440..., 0.2196...) and the reference solver's event
times are wanted to 30 digits and more, so scipy's float64 solvers
(``brentq``, ``minimize_scalar``) cannot serve; these are the multiprecision
counterparts, written once and used by every exact routine of the package.
A float64 root elsewhere in the package uses :func:`scipy.optimize.brentq`.
"""
from __future__ import annotations

import mpmath

__all__ = ["bracket_root", "first_root_after", "golden_min"]


def bracket_root(f, a, b):
    """Root of ``f`` on ``[a, b]`` at the working mpmath precision.

    Parameters
    ----------
    f : callable
        mpf -> mpf, with a sign change on ``[a, b]``.
    a, b : mpf
        The bracket, ``a < b``.

    Returns
    -------
    mpf
        Anderson's method (``mpmath.findroot``) when it lands inside the
        bracket, else bisection to the working precision.

    Raises
    ------
    ValueError
        ``f(a)`` and ``f(b)`` have the same sign.
    """
    fa, fb = f(a), f(b)
    if fa == 0:
        return a
    if fb == 0:
        return b
    if (fa > 0) == (fb > 0):
        raise ValueError("no sign change in bracket")
    # findroot's stopping test is on |f| in absolute terms: normalise f so that a
    # tiny function (e.g. a viscous overlap of 1e-80) is still solved to full precision
    scale = max(abs(fa), abs(fb))

    def normalised(x):
        return f(x) / scale
    fa = fa / scale
    try:
        r = mpmath.findroot(normalised, (a, b), solver="anderson")
        if a <= r <= b:
            return r
    except (ValueError, ZeroDivisionError):
        pass
    # fall back to bisection (robust, slower)
    for _ in range(4 * mpmath.mp.prec):
        m = (a + b) / 2
        fm = normalised(m)
        if fm == 0 or b - a < mpmath.mpf(2) ** (-mpmath.mp.prec) * (1 + abs(m)):
            return m
        if (fm > 0) == (fa > 0):
            a, fa = m, fm
        else:
            b = m
    return (a + b) / 2


def first_root_after(f, t_end, h):
    """First root of ``f`` on ``(0, t_end]``: scan in steps ``h`` for a change from the
    sign ``f`` has just after 0 (``f(0)`` may vanish), then :func:`bracket_root`.

    Parameters
    ----------
    f : callable
        ``f(t)`` of an mpf, continuous.
    t_end : mpf
        End of the scanned interval (same units as ``t``).
    h : mpf
        Scan step (same units as ``t``); a pair of roots closer than ``h`` can be missed.

    Returns
    -------
    mpf or None
        None when ``f`` keeps its sign up to ``t_end``.
    """
    t = mpmath.mpf(0)
    f_start = f(t + h / 1024)
    while t < t_end:
        t_next = min(t + h, t_end)
        if (f(t_next) > 0) != (f_start > 0):
            return bracket_root(f, t, t_next)
        t = t_next
    return None


def golden_min(f, a, b, tol):
    """Golden-section search for the minimum of a unimodal ``f`` on ``[a, b]``.

    Works in the number type of ``a`` and ``b`` (float or mpmath), to width ``tol``.

    Parameters
    ----------
    f : callable
        Unimodal function of one number on ``[a, b]``.
    a, b : float or mpf
        Ends of the interval.
    tol : float or mpf
        Width of the final interval (same units as ``a``).

    Returns
    -------
    float or mpf
        Midpoint of the final interval.
    """
    ratio = ((a * 0 + 5) ** 0.5 - 1) / 2
    c, d = b - ratio * (b - a), a + ratio * (b - a)
    fc, fd = f(c), f(d)
    while b - a > tol:
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - ratio * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + ratio * (b - a)
            fd = f(d)
    return (a + b) / 2
