"""Sec. III of the paper: hydrodynamic friction ``gamma_i = gamma (1 + delta_i)``,
``delta_1 = -delta_2 = delta``.

The contact is a damped linear oscillator; for ``delta = 0`` everything is
exact (separation iff ``gamma^2 < 8``, the optimal damping for backscattering),
for ``delta != 0`` the paper expands to first order in ``delta`` through the
Laplace transforms, printed here with their errata. Scaled units (Appendix A).
"""
from __future__ import annotations

import math

import mpmath
import numpy as np

from .arithmetic import Multiprecision, arithmetic_for

__all__ = ["iii_gammas", "iii_omega", "iii_separates", "iii_t0", "iii_xminus_zeroth",
           "iii_laplace_system_printed", "iii_laplace_exact", "iii_Xplus_first_order_printed",
           "iii_Xplus_first_order_corrected", "iii_Xminus_first_order", "iii_epsilon",
           "iii_t_separation_first_order", "iii_v1s_first_order", "iii_v2s_first_order",
           "iii_dvs_ddelta", "iii_energy_ratio_zeroth", "iii_optimal_gamma_zeroth"]


def iii_gammas(gamma, delta):
    """Sec. III definition ``gamma_i = gamma (1 + delta_i)``, ``delta_1 = -delta_2 = delta``.

    So ``delta > 0`` means ``gamma_1 > gamma_2``.  (The text after the velocity
    formulas says "gamma_2 > gamma_1 (delta > 0)", contradicting this definition
    and the caption of Fig. finalv1m5; see :func:`iii_dvs_ddelta`.)

    Parameters
    ----------
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).
    delta : float or mpmath.mpf
        Asymmetry of the two coefficients, dimensionless (``delta_1 = -delta_2 = delta``).

    Returns
    -------
    (gamma1, gamma2)
    """
    return gamma * (1 + delta), gamma * (1 - delta)


def iii_omega(gamma):
    """Sec. III: ``omega = sqrt(8 - gamma^2) / 2`` (exact; real for gamma^2 < 8).

    Parameters
    ----------
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).

    Returns
    -------
    float, ndarray or mpmath.mpf
        Angular frequency ``omega`` of the damped relative motion, units of ``1/B`` (NaN beyond ``gamma^2 = 8``).
    """
    arith = arithmetic_for(gamma)
    gamma = arith.num(gamma)
    return arith.sqrt(8 - gamma**2) / 2


def iii_separates(gamma):
    """Sec. III claim: for ``delta = 0`` the collision ends iff ``gamma^2 < 8`` (exact).

    ``x_-`` obeys ``x_-'' + gamma x_-' + 2 x_- = 0``, ``x_-(0) = 0``, ``x_-'(0) = 1``:
    for ``gamma^2 >= 8`` it is ``t e^{-sqrt2 t}`` or ``e^{-gamma t/2} sinh(kappa t)/kappa``,
    positive for all ``t > 0``.

    Parameters
    ----------
    gamma : float or ndarray
        Hydrodynamic friction coefficient, scaled (units of ``m/B``).

    Returns
    -------
    bool or ndarray of bool
        True where the collision ends.
    """
    return np.asarray(gamma, dtype=float) ** 2 < 8.0


def iii_t0(gamma):
    """Sec. III: separation time ``t0 = pi/omega`` for ``delta = 0`` (exact; inf if gamma^2 >= 8).

    Parameters
    ----------
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).

    Returns
    -------
    float or mpmath.mpf
        Separation time, units of ``B``.
    """
    arith = arithmetic_for(gamma)
    if arith is Multiprecision:
        g = mpmath.mpf(gamma)
        return mpmath.inf if g**2 >= 8 else mpmath.pi / iii_omega(g)
    g = np.asarray(gamma, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(g**2 < 8, np.pi / np.sqrt(np.maximum(8 - g**2, 0.0)) * 2, np.inf)
    return out if out.ndim else float(out)


def iii_xminus_zeroth(t, gamma):
    """Sec. III: ``x_-(t) = e^{-gamma t/2} sin(omega t)/omega`` for ``delta = 0`` (exact).

    (The paper writes ``x_-(t_0) = e^{-gamma t_0/2} sin(omega t)/omega``; the mixed
    ``t_0``/``t`` is a harmless typo.)

    Parameters
    ----------
    t : float, ndarray or mpmath.mpf
        Time since first contact, units of ``B``.
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).

    Returns
    -------
    float, ndarray or mpmath.mpf
        Relative coordinate ``x_-``, units of ``A``.
    """
    arith = arithmetic_for(t, gamma)
    t, gamma = arith.num(t), arith.num(gamma)
    w = iii_omega(gamma)
    return arith.exp(-gamma * t / 2) * arith.sin(w * t) / w


def iii_laplace_system_printed(s, gamma, delta):
    """Sec. III Eqs. (``eq:model5lt``) as printed: matrix ``M`` and right side ``b``.

    ``M @ [X_+, X_-] = b`` with
    ``M = [[gamma s + s^2, delta gamma s], [delta gamma s, 2 + gamma s + s^2]]``,
    ``b = [1, 1]``.  Verdict: correct (derived from Eqs. (model5) with
    ``x_i(0) = 0``, ``v1(0) = 1``, ``v2(0) = 0``).

    Parameters
    ----------
    s : complex or float
        Laplace variable, units of ``1/B``.
    gamma, delta : float
        Mean hydrodynamic friction (units of ``m/B``) and its asymmetry (dimensionless).

    Returns
    -------
    (ndarray (2, 2), ndarray (2,))
        ``M`` and ``b``.
    """
    M = np.array([[gamma * s + s**2, delta * gamma * s],
                  [delta * gamma * s, 2 + gamma * s + s**2]])
    return M, np.array([1.0, 1.0])


def iii_laplace_exact(s, gamma, delta):
    """Exact Laplace transforms ``(X_+, X_-)`` straight from Eqs. (model5).

    Transforming ``x1'' = -gamma1 x1' - (x1 - x2)``, ``x2'' = -gamma2 x2' + (x1 - x2)``
    with ``x(0) = 0``, ``v1(0) = 1``, ``v2(0) = 0``:
    ``(s^2 + gamma1 s + 1) X1 - X2 = 1``, ``-X1 + (s^2 + gamma2 s + 1) X2 = 0``.

    Parameters
    ----------
    s : complex, float or mpmath number
        Laplace variable, units of ``1/B``.
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).
    delta : float or mpmath.mpf
        Asymmetry of the two coefficients, dimensionless (``delta_1 = -delta_2 = delta``).

    Returns
    -------
    (X_plus, X_minus)
    """
    g1, g2 = gamma * (1 + delta), gamma * (1 - delta)
    a, d = s**2 + g1 * s + 1, s**2 + g2 * s + 1
    det = a * d - 1
    X1, X2 = d / det, 1 / det
    return X1 + X2, X1 - X2


def iii_Xplus_first_order_printed(s, gamma, delta):
    """Sec. III, first-order ``X_+(s)`` as printed.

    ``X_+ = 1/(s(gamma+s)) - delta gamma / (s (gamma+s) [2 + s(gamma+s)])``.

    **Erratum**: the correction carries a spurious factor ``1/s``; from the first of
    Eqs. (model5lt), ``X_+ = [1 - delta gamma s X_-^{(0)}] / (s(s+gamma))`` with
    ``X_-^{(0)} = 1/(2 + s(s+gamma))``, so the ``s`` cancels
    (:func:`iii_Xplus_first_order_corrected`).  The printed velocities ``v^(s)``
    are nevertheless right, so this is a typo in the intermediate result.

    Parameters
    ----------
    s : complex, float or mpmath number
        Laplace variable, units of ``1/B``.
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).
    delta : float or mpmath.mpf
        Asymmetry of the two coefficients, dimensionless (``delta_1 = -delta_2 = delta``).

    Returns
    -------
    same type as s
        ``X_+(s)``, units of ``A B``.
    """
    q = 2 + s * (gamma + s)
    return 1 / (s * (gamma + s)) - delta * gamma / (s * (gamma + s) * q)


def iii_Xplus_first_order_corrected(s, gamma, delta):
    """Corrected first-order ``X_+(s) = 1/(s(gamma+s)) - delta gamma / ((gamma+s)[2 + s(gamma+s)])``.

    Parameters
    ----------
    s : complex, float or mpmath number
        Laplace variable, units of ``1/B``.
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).
    delta : float or mpmath.mpf
        Asymmetry of the two coefficients, dimensionless (``delta_1 = -delta_2 = delta``).

    Returns
    -------
    same type as s
        ``X_+(s)``, units of ``A B``.
    """
    q = 2 + s * (gamma + s)
    return 1 / (s * (gamma + s)) - delta * gamma / ((gamma + s) * q)


def iii_Xminus_first_order(s, gamma, delta):
    """Sec. III, first-order ``X_-(s)`` as printed (correct).

    ``X_- = 1/(2 + s(gamma+s)) - delta gamma / ((gamma+s)[2 + s(gamma+s)])``.

    Parameters
    ----------
    s : complex, float or mpmath number
        Laplace variable, units of ``1/B``.
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).
    delta : float or mpmath.mpf
        Asymmetry of the two coefficients, dimensionless (``delta_1 = -delta_2 = delta``).

    Returns
    -------
    same type as s
        ``X_-(s)``, units of ``A B``.
    """
    q = 2 + s * (gamma + s)
    return 1 / q - delta * gamma / ((gamma + s) * q)


def iii_epsilon(gamma, delta):
    """Sec. III: ``epsilon = -(delta gamma omega / 2)(1 + e^{-gamma pi/(2 omega)})`` (correct to O(delta)).

    Separation time ``t1 = pi/omega + epsilon/omega``; ``epsilon < 0`` for
    ``delta > 0`` (larger friction on granule 1 ends the collision earlier).

    Parameters
    ----------
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).
    delta : float or mpmath.mpf
        Asymmetry of the two coefficients, dimensionless (``delta_1 = -delta_2 = delta``).

    Returns
    -------
    float, ndarray or mpmath.mpf
        ``epsilon``, dimensionless (a phase).
    """
    arith = arithmetic_for(gamma, delta)
    gamma, delta = arith.num(gamma), arith.num(delta)
    w = iii_omega(gamma)
    return -delta * gamma * w / 2 * (1 + arith.exp(-gamma * arith.pi() / (2 * w)))


def iii_t_separation_first_order(gamma, delta):
    """Sec. III: ``t1 = t0 + epsilon/omega = pi/omega + epsilon/omega`` (error O(delta^2)).

    Parameters
    ----------
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).
    delta : float or mpmath.mpf
        Asymmetry of the two coefficients, dimensionless (``delta_1 = -delta_2 = delta``).

    Returns
    -------
    float, ndarray or mpmath.mpf
        Separation time ``t1``, units of ``B``.
    """
    arith = arithmetic_for(gamma, delta)
    w = iii_omega(arith.num(gamma))
    return (arith.pi() + iii_epsilon(gamma, delta)) / w


def iii_v1s_first_order(gamma, delta):
    """Sec. III, first-order ``v1^(s)`` as printed (correct to O(delta); error O(delta^2)).

    ``v1 = (1 - e^{g})/2 e^{-2g} + delta gamma^2/4 (1 + 2 e^{g} + e^{2g}) e^{-3g}``,
    ``g = gamma pi / (2 omega)``.

    Parameters
    ----------
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).
    delta : float or mpmath.mpf
        Asymmetry of the two coefficients, dimensionless (``delta_1 = -delta_2 = delta``).

    Returns
    -------
    float, ndarray or mpmath.mpf
        ``v1^(s)``, units of ``v0``.
    """
    arith = arithmetic_for(gamma, delta)
    gamma, delta = arith.num(gamma), arith.num(delta)
    g = gamma * arith.pi() / (2 * iii_omega(gamma))
    return ((1 - arith.exp(g)) / 2 * arith.exp(-2 * g)
            + delta * gamma**2 / 4 * (1 + 2 * arith.exp(g) + arith.exp(2 * g)) * arith.exp(-3 * g))


def iii_v2s_first_order(gamma, delta):
    """Sec. III, first-order ``v2^(s)`` as printed (correct to O(delta); error O(delta^2)).

    ``v2 = (1 + e^{g})/2 e^{-2g} + delta gamma^2/(32 omega^2)
    [8 omega^2 + (12 omega^2 - gamma^2 + 8) e^{g} + (4 omega^2 - gamma^2 + 8) e^{2g}] e^{-3g}``.
    Since ``8 - gamma^2 = 4 omega^2`` the bracket is ``8 omega^2 (1 + e^g)^2`` and the
    first-order term equals that of ``v1``: see :func:`iii_dvs_ddelta`.

    Parameters
    ----------
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).
    delta : float or mpmath.mpf
        Asymmetry of the two coefficients, dimensionless (``delta_1 = -delta_2 = delta``).

    Returns
    -------
    float, ndarray or mpmath.mpf
        ``v2^(s)``, units of ``v0``.
    """
    arith = arithmetic_for(gamma, delta)
    gamma, delta = arith.num(gamma), arith.num(delta)
    w = iii_omega(gamma)
    g = gamma * arith.pi() / (2 * w)
    return ((1 + arith.exp(g)) / 2 * arith.exp(-2 * g)
            + delta * gamma**2 / (32 * w**2)
            * (8 * w**2 + (12 * w**2 - gamma**2 + 8) * arith.exp(g)
               + (4 * w**2 - gamma**2 + 8) * arith.exp(2 * g)) * arith.exp(-3 * g))


def iii_dvs_ddelta(gamma):
    """``d v1^(s)/d delta = d v2^(s)/d delta = (gamma^2/4) E (1 + E)^2`` at delta = 0, ``E = e^{-gamma pi/(2 omega)}``.

    Simplified from the printed first-order terms (derived here).  It is positive:
    raising ``delta`` (more friction on granule 1) makes ``v1^(s)`` less negative,
    so backscattering is larger for ``delta < 0``, i.e. ``gamma_2 > gamma_1``.
    **Erratum** in the text: "greater if gamma_2 > gamma_1 (delta > 0)" must read
    "(delta < 0)"; the caption of Fig. finalv1m5 (``gamma_1 > gamma_2`` for
    ``delta = 0.1``) agrees with the definition.

    Parameters
    ----------
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).

    Returns
    -------
    float, ndarray or mpmath.mpf
        The derivative, units of ``v0``.
    """
    arith = arithmetic_for(gamma)
    gamma = arith.num(gamma)
    E = arith.exp(-gamma * arith.pi() / (2 * iii_omega(gamma)))
    return gamma**2 / 4 * E * (1 + E) ** 2


def iii_energy_ratio_zeroth(gamma):
    """Sec. III claim "energy at the end of the collision decreases monotonically with gamma".

    For ``delta = 0`` (exact): ``E^(s)/E0 = v1^2 + v2^2 = (E^4 + E^2)/2`` with
    ``E = e^{-gamma pi/(2 omega)}``, decreasing in gamma on ``0 <= gamma < sqrt8``.

    Parameters
    ----------
    gamma : float, ndarray or mpmath.mpf
        Mean hydrodynamic friction coefficient, scaled (units of ``m/B``).

    Returns
    -------
    float, ndarray or mpmath.mpf
        ``E^(s)/E0``, dimensionless.
    """
    arith = arithmetic_for(gamma)
    gamma = arith.num(gamma)
    E = arith.exp(-gamma * arith.pi() / (2 * iii_omega(gamma)))
    return (E**4 + E**2) / 2


def iii_optimal_gamma_zeroth():
    """Sec. III claim "an optimal dissipation for which backscattering is greatest", delta = 0.

    ``v1^(s) = (E^2 - E)/2`` is minimal at ``E = 1/2``, i.e. ``gamma pi/(2 omega) = ln 2``:
    ``gamma* = sqrt8 k / sqrt(1 + k^2)``, ``k = ln2/pi``; ``v1^(s) = -1/8`` (derived here).

    Returns
    -------
    (float, float)
        ``(gamma*, v1^(s)(gamma*))`` = ``(0.6094..., -0.125)``.
    """
    k = math.log(2.0) / math.pi
    g = math.sqrt(8.0) * k / math.sqrt(1.0 + k * k)
    return g, -0.125
