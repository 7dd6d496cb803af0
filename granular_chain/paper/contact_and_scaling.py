"""The contact law and the units of the paper: Sec. I Eqs. (1)-(3) and Appendix A.

The potential and the Hertz coefficient exactly as printed, with the corrected
sign convention beside them, and the Appendix-A scaling as printed and
corrected. The scaling itself (``A``, ``B``, scaled friction) is the engine's,
:mod:`granular_chain.units`; the two functions here say which friction force
the printed and the corrected formula put into it.
"""
from __future__ import annotations

import math

import numpy as np

from .. import units

__all__ = ["hertz_potential_printed", "hertz_potential_corrected", "hertz_a_printed",
           "hertz_force_coefficient_spheres", "force_coefficient_from_potential_coefficient",
           "scaling_printed", "scaling_corrected"]


def hertz_potential_printed(delta, a, n):
    """Contact potential, Sec. I Eq. (1) (label ``hertz``) exactly as printed.

    Printed: ``V = a * delta**n`` for ``delta <= 0`` and ``V = 0`` for ``delta > 0``,
    with ``delta = 2R - [(z_{i+1}+x_{i+1}) - (z_i+x_i)]`` (Sec. I, Eq. (2)).

    Parameters
    ----------
    delta : float or ndarray
        ``2R`` minus the centre distance (positive when the grains overlap).
    a : float
        Potential coefficient of Eq. (3).
    n : float
        Exponent (5/2 Hertz spheres, 2 in most of the paper).

    Returns
    -------
    float or ndarray
        Potential energy as printed.  **Erratum**: with Eq. (2), ``delta > 0`` *is*
        the overlap, so the printed branches are swapped: the printed potential
        vanishes exactly when the grains overlap and, for non-integer ``n``, is
        not real when they do not (numpy gives ``nan``).  See
        :func:`hertz_potential_corrected`.
    """
    delta = np.asarray(delta, dtype=float)
    with np.errstate(invalid="ignore"):
        return np.where(delta <= 0, a * np.power(delta, n), 0.0)


def hertz_potential_corrected(delta, a, n):
    """Contact potential, Sec. I Eq. (1), corrected sign convention.

    ``V = a * delta**n`` for ``delta >= 0`` (overlap), ``V = 0`` for ``delta < 0``.
    The repulsive force along ``delta`` is ``-dV/d(centre distance) = dV/d(delta)
    = n * a * delta**(n-1)``: the ``a`` of Eqs. (1) and (3) is a *potential*
    coefficient, whereas Appendix A writes the force as ``a * delta**(n-1)``, i.e.
    uses ``a`` as the *force* coefficient.  The two differ by the factor ``n``
    (see :func:`force_coefficient_from_potential_coefficient`).

    Parameters
    ----------
    delta : float or ndarray
        Overlap ``2R - (centre distance)``, same length unit as ``a``.
    a : float
        Potential coefficient (energy / length**n).
    n : float
        Exponent.

    Returns
    -------
    float or ndarray
        Potential energy.
    """
    delta = np.asarray(delta, dtype=float)
    return np.where(delta >= 0, a * np.power(np.maximum(delta, 0.0), n), 0.0)


def hertz_a_printed(Y, sigma, R):
    """Hertz coefficient ``a``, Sec. I Eq. (3), as printed.

    ``a = 2 / (5 D) * (R/2)**(1/2)`` with ``D = (3/2) (1 - sigma**2) / Y``.

    This is the coefficient of the *potential* ``a delta**(5/2)`` for two identical
    elastic spheres of radius ``R``: it equals ``(2/5) k`` with the Hertz force
    coefficient ``k = (4/3) E* sqrt(R*)`` (see :func:`hertz_force_coefficient_spheres`).
    Verdict: correct as the potential coefficient of Eq. (1); inconsistent with
    Appendix A, which uses ``a`` as the force coefficient.

    Parameters
    ----------
    Y : float
        Young's modulus (Pa).
    sigma : float
        Poisson's ratio.
    R : float
        Sphere radius (m).

    Returns
    -------
    float
        ``a`` in J / m**(5/2).
    """
    D = 1.5 * (1.0 - sigma**2) / Y
    return 2.0 / (5.0 * D) * math.sqrt(R / 2.0)


def hertz_force_coefficient_spheres(Y, sigma, R):
    """Hertz force coefficient ``k`` for two identical spheres (textbook Hertz law).

    ``F = k delta**(3/2)`` with ``k = (4/3) E* sqrt(R*)``, ``1/E* = 2 (1-sigma**2)/Y``
    and ``R* = R/2`` (Landau & Lifshitz: ``k = sqrt(R/2) / D`` with the ``D`` of
    Eq. (3)).  Not printed in the paper; used to decide what Eq. (3)'s ``a`` is.

    Parameters
    ----------
    Y, sigma, R : float
        Young's modulus (Pa), Poisson's ratio, radius (m).

    Returns
    -------
    float
        ``k`` in N / m**(3/2).  Equals ``(5/2) * hertz_a_printed(Y, sigma, R)``.
    """
    e_star = Y / (2.0 * (1.0 - sigma**2))
    return 4.0 / 3.0 * e_star * math.sqrt(R / 2.0)


def force_coefficient_from_potential_coefficient(a, n):
    """Force coefficient of ``V = a delta**n``: ``F = dV/d(delta) = n a delta**(n-1)``.

    The scaled equations of Sec. II-III and Appendix A (``x'' = -(x1-x2)**(n-1)``)
    set the *force* coefficient to 1, i.e. ``n * a_Eq3 = 1``, not ``a_Eq3 = 1`` as
    the sentence "set the coefficient a = 1 in Eq. (1)" says.

    Parameters
    ----------
    a : float
        Potential coefficient.
    n : float
        Exponent.

    Returns
    -------
    float
        ``n * a``.
    """
    return n * a


def scaling_printed(m, v0, a, n, mu=0.0, g=9.81, gamma_tilde=0.0):
    """Appendix A scaling, as printed.

    ``A = (v0**2 m / a)**(1/n)``, ``B = A / v0``,
    ``eta = mu g / (m v0**2) * (v0**2 m / a)**(1/n)``,
    ``gamma = gamma_tilde / (m v0) * (v0**2 m / a)**(1/n)``;
    physical ``y = A x`` and ``tau = B t``.

    These follow from the printed equation ``m y'' = +-mu g - a (y_i - y_j)**(n-1)``
    (force coefficient ``a``).  **Erratum (dimensional)**: a Coulomb friction force
    is ``mu m g`` (``mu`` dimensionless), so ``mu g`` on the right-hand side is an
    acceleration, not a force; with the physical friction force ``mu m g`` the
    scaled friction is ``eta = mu g / v0**2 * (v0**2 m / a)**(1/n)`` (no ``1/m``),
    see :func:`scaling_corrected`.  ``A``, ``B`` and ``gamma`` are right (the
    intermediate hydrodynamic equation drops the ``m`` of its left-hand side, but
    the final ``gamma_i`` includes it).  ``a`` here must be the *force* coefficient
    (``n`` times Eq. (3)'s ``a``).

    Parameters
    ----------
    m : float
        Granule mass (kg).
    v0 : float
        Initial velocity of granule 1 (m/s).
    a : float
        Coefficient of ``(y_i-y_j)**(n-1)`` in the force (N / m**(n-1)).
    n : float
        Exponent.
    mu : float, optional
        Friction coefficient.
    g : float, optional
        Gravitational acceleration (m/s**2).
    gamma_tilde : float, optional
        Hydrodynamic friction coefficient (kg/s).

    Returns
    -------
    dict
        ``A`` (m), ``B`` (s), ``eta`` and ``gamma`` (dimensionless), as printed.
    """
    A, B = units.scales(m, a, n, v0)
    # the printed eta is the scaled friction of a "force" mu g
    return {"A": A, "B": B, "eta": units.scaled_coulomb(mu * g, m, v0, A),
            "gamma": units.scaled_viscous(gamma_tilde, m, v0, A)}


def scaling_corrected(m, v0, k, n, mu=0.0, g=9.81, gamma_tilde=0.0):
    """Appendix A scaling for friction force ``mu m g`` and force coefficient ``k``.

    Physical model: ``m y_i'' = -+ mu_i m g - gamma_tilde_i y_i' - k (y_i-y_j)**(n-1)``
    (while in contact).  With ``A = (m v0**2 / k)**(1/n)`` and ``B = A / v0`` the
    scaled equations of the paper follow with
    ``eta = mu g B**2 / A = mu g / v0**2 * (m v0**2 / k)**(1/n)`` and
    ``gamma = gamma_tilde B / m``.  ``k = n * a_Eq3`` (Hertz spheres:
    ``k = (4/3) E* sqrt(R*)``).

    Parameters
    ----------
    m, v0, k, n, mu, g, gamma_tilde : float
        As in :func:`scaling_printed`, with ``k`` the force coefficient.

    Returns
    -------
    dict
        ``A`` (m), ``B`` (s), ``eta``, ``gamma`` (dimensionless).
    """
    A, B = units.scales(m, k, n, v0)
    return {"A": A, "B": B, "eta": units.scaled_coulomb(mu * m * g, m, v0, A),
            "gamma": units.scaled_viscous(gamma_tilde, m, v0, A)}
