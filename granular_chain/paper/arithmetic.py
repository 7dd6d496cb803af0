"""Float64 or multiprecision: the arithmetic a closed form of the paper runs in.

Every closed form accepts floats or numpy arrays (computed in float64 with
numpy) *or* :class:`mpmath.mpf` scalars (computed with mpmath at the current
``mpmath.mp.dps``), so that an exact formula can be checked far below float64
roundoff. A closed form asks :func:`arithmetic_for` for the namespace of its
arguments and calls ``sin``, ``sqrt``, ``pi()``... from it.
"""
from __future__ import annotations

import mpmath
import numpy as np

__all__ = ["Float64", "Multiprecision", "arithmetic_for"]


class Float64:
    """numpy namespace for the float64 path."""

    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    sqrt = staticmethod(np.sqrt)
    exp = staticmethod(np.exp)
    asin = staticmethod(np.arcsin)

    @staticmethod
    def pi():
        """The number pi as a numpy float64.

        Returns
        -------
        float
            pi, dimensionless.
        """
        return np.pi

    @staticmethod
    def num(x):
        """``x`` as float64: a numpy array when ``x`` has dimensions, else ``np.float64``.

        Parameters
        ----------
        x : float or array_like
            Value(s) in any unit (the caller's).

        Returns
        -------
        numpy.float64 or ndarray
        """
        return np.asarray(x, dtype=float) if np.ndim(x) else np.float64(x)


class Multiprecision:
    """mpmath namespace for the multiprecision path."""

    sin = staticmethod(mpmath.sin)
    cos = staticmethod(mpmath.cos)
    sqrt = staticmethod(mpmath.sqrt)
    exp = staticmethod(mpmath.exp)
    asin = staticmethod(mpmath.asin)

    @staticmethod
    def pi():
        """The number pi at the current ``mpmath.mp.dps``.

        Returns
        -------
        mpmath.mpf
            pi, dimensionless.
        """
        return +mpmath.pi

    @staticmethod
    def num(x):
        """``x`` as an :class:`mpmath.mpf` at the current precision.

        Parameters
        ----------
        x : float, str or mpf
            Value in any unit (the caller's).

        Returns
        -------
        mpmath.mpf
        """
        return mpmath.mpf(x)


def arithmetic_for(*xs):
    """:class:`Multiprecision` if any argument is an mpmath number, else :class:`Float64`.

    Parameters
    ----------
    *xs : float, ndarray or mpmath number
        The arguments of a closed form.

    Returns
    -------
    type
        :class:`Multiprecision` or :class:`Float64`.
    """
    if any(isinstance(x, (mpmath.mpf, mpmath.mpc)) for x in xs):
        return Multiprecision
    return Float64
