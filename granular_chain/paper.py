"""Closed forms and numerical claims of the two-granule paper, as printed and corrected.

Source: A. Rosas, J. Buceta and K. Lindenberg, *Dynamics of Two Granules*
(``shared/seed/two_granules_paper.tex``).  Every closed form and every numerical
claim of the paper is a function here, written exactly **as printed**; where the
printed statement is wrong, a ``*_corrected`` (or ``*_exact``) function sits next
to it and its docstring states the erratum.  ``docs/paper_check_draft.md`` lists
the verdicts and the measured errors; ``tests/test_paper_formulas.py`` proves them.

Units
-----
Everything is in the paper's scaled units (Appendix A): both masses are 1, the
contact *force* is ``delta**(n-1)`` while the overlap ``delta = x1 - x2`` is
positive and zero otherwise (so for ``n = 2`` the spring constant is 1), granule 1
starts at velocity 1 just touching granule 2, which is at rest.  ``x1, x2`` are
displacements from the initial positions, ``t`` is scaled time, ``eta_i`` is the
scaled kinetic (Coulomb) friction force, ``gamma_i`` the scaled hydrodynamic
friction coefficient (force ``-gamma_i * v_i``).

Arithmetic
----------
The closed forms accept floats or numpy arrays (computed in float64 with numpy)
*or* :class:`mpmath.mpf` scalars (computed with mpmath at the current
``mpmath.mp.dps``), so that an exact formula can be checked far below float64
roundoff.  Functions marked *exact/numerical* return mpmath numbers.

The independent reference, :func:`reference_collision_n2`, solves the ``n = 2``
two-granule problem for any ``(eta1, eta2, gamma1, gamma2)`` as a piecewise-linear
ODE: within each stick/slip mode the motion is linear with constant coefficients,
so the state is propagated with the matrix exponential (mpmath, 30+ digits) and
mode-switching events are located by sign change plus root finding.

This module deliberately imports nothing else from ``granular_chain`` and uses no
numba: it is the yardstick the engine is measured against.
"""
from __future__ import annotations

import math

import mpmath
import numpy as np
from scipy import optimize

__all__ = [
    # Sec I / Appendix A
    "hertz_potential_printed", "hertz_potential_corrected", "hertz_a_printed",
    "hertz_force_coefficient_spheres", "force_coefficient_from_potential_coefficient",
    "scaling_printed", "scaling_corrected",
    # Sec II A
    "iia_x1_phase1", "iia_t0", "iia_x1", "iia_x2", "iia_v1", "iia_v2", "iia_t1",
    "iia_v1s", "iia_v2s", "iia_eta_max", "iia_energy_ratio", "iia_energy_minimum",
    "iia_stuck_second_granule_v1",
    # Sec II B
    "iib_x1", "iib_x2", "iib_v1", "iib_v2", "iib_t0_small_eta",
    "iib_t0_small_eta_next_order", "iib_t0_exact", "iib_t0prime_exact",
    "iib_initial_conditions_small_eta", "iib_initial_conditions_exact",
    "iib_slip_force_printed", "iib_slip_critical_eta_printed",
    "iib_slip_critical_eta_exact", "iib_t1_small_eta", "iib_t1_small_eta_next_order",
    "iib_collision_exact",
    "iib_backscatter_threshold_eta_exact", "iib_max_backscatter_exact",
    # Sec III
    "iii_gammas", "iii_omega", "iii_t0", "iii_separates", "iii_xminus_zeroth",
    "iii_laplace_system_printed", "iii_laplace_exact", "iii_Xplus_first_order_printed",
    "iii_Xplus_first_order_corrected", "iii_Xminus_first_order", "iii_epsilon",
    "iii_t_separation_first_order", "iii_v1s_first_order", "iii_v2s_first_order",
    "iii_dvs_ddelta", "iii_energy_ratio_zeroth", "iii_optimal_gamma_zeroth",
    # reference solver
    "OUTCOMES", "reference_collision_n2", "reference_state_n2",
]

SQRT2 = math.sqrt(2.0)


# ----------------------------------------------------------------------------
# float64 / mpmath dispatch
# ----------------------------------------------------------------------------
class _NP:
    """numpy namespace for the float64 path."""

    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    sqrt = staticmethod(np.sqrt)
    exp = staticmethod(np.exp)
    asin = staticmethod(np.arcsin)

    @staticmethod
    def pi():
        return np.pi

    @staticmethod
    def num(x):
        return np.asarray(x, dtype=float) if np.ndim(x) else np.float64(x)


class _MP:
    """mpmath namespace for the multiprecision path."""

    sin = staticmethod(mpmath.sin)
    cos = staticmethod(mpmath.cos)
    sqrt = staticmethod(mpmath.sqrt)
    exp = staticmethod(mpmath.exp)
    asin = staticmethod(mpmath.asin)

    @staticmethod
    def pi():
        return +mpmath.pi

    @staticmethod
    def num(x):
        return mpmath.mpf(x)


def _ns(*xs):
    """Pick mpmath if any argument is an mpmath number, else numpy."""
    if any(isinstance(x, (mpmath.mpf, mpmath.mpc)) for x in xs):
        return _MP
    return _NP


# ============================================================================
# Sec. I eqs. (1)-(3) and Appendix A: potential, Hertz coefficient, scaling
# ============================================================================
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
    L = (v0**2 * m / a) ** (1.0 / n)
    return {"A": L, "B": L / v0, "eta": mu * g / (m * v0**2) * L,
            "gamma": gamma_tilde / (m * v0) * L}


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
    L = (v0**2 * m / k) ** (1.0 / n)
    B = L / v0
    return {"A": L, "B": B, "eta": mu * g * B**2 / L, "gamma": gamma_tilde * B / m}


# ============================================================================
# Sec. II A: frictionless first granule, kinetic friction eta on granule 2
# ============================================================================
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
    ns = _ns(t)
    return ns.sin(ns.num(t))


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
    ns = _ns(eta)
    return ns.asin(ns.num(eta))


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
    ns = _ns(tp, eta)
    tp, eta = ns.num(tp), ns.num(eta)
    c = ns.sqrt(1 - eta**2)
    r2 = ns.sqrt(ns.num(2))
    return (-eta * (-3 + tp**2) + 2 * c * tp + eta * ns.cos(r2 * tp)
            + r2 * c * ns.sin(r2 * tp)) / 4


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
    ns = _ns(tp, eta)
    tp, eta = ns.num(tp), ns.num(eta)
    c = ns.sqrt(1 - eta**2)
    r2 = ns.sqrt(ns.num(2))
    return -(eta * (-1 + tp**2) - 2 * c * tp + eta * ns.cos(r2 * tp)
             + r2 * c * ns.sin(r2 * tp)) / 4


def iia_v1(tp, eta):
    """Time derivative of Eq. (``eq:x1``) (not printed; used for v1^(s)).

    ``v1(t') = 1/4 [ -2 eta t' + 2c - sqrt2 eta sin(sqrt2 t') + 2c cos(sqrt2 t') ]``.
    """
    ns = _ns(tp, eta)
    tp, eta = ns.num(tp), ns.num(eta)
    c = ns.sqrt(1 - eta**2)
    r2 = ns.sqrt(ns.num(2))
    return (-2 * eta * tp + 2 * c - r2 * eta * ns.sin(r2 * tp) + 2 * c * ns.cos(r2 * tp)) / 4


def iia_v2(tp, eta):
    """Time derivative of Eq. (``eq:x2``) (not printed).

    ``v2(t') = 1/4 [ -2 eta t' + 2c + sqrt2 eta sin(sqrt2 t') - 2c cos(sqrt2 t') ]``.
    """
    ns = _ns(tp, eta)
    tp, eta = ns.num(tp), ns.num(eta)
    c = ns.sqrt(1 - eta**2)
    r2 = ns.sqrt(ns.num(2))
    return (-2 * eta * tp + 2 * c + r2 * eta * ns.sin(r2 * tp) - 2 * c * ns.cos(r2 * tp)) / 4


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
    ns = _ns(eta)
    return ns.pi() / ns.sqrt(ns.num(2))


def iia_v1s(eta):
    """Sec. II A: ``v1^(s) = -eta pi / (2 sqrt2)`` at separation (exact, eta < 0.669...).

    Parameters
    ----------
    eta : float, ndarray or mpf

    Returns
    -------
    Same type as ``eta``
        Velocity of granule 1 at separation (negative: backscattering).
    """
    ns = _ns(eta)
    eta = ns.num(eta)
    return -eta * ns.pi() / (2 * ns.sqrt(ns.num(2)))


def iia_v2s(eta):
    """Sec. II A: ``v2^(s) = (1-eta^2)^(1/2) - eta pi / (2 sqrt2)`` (exact, eta < 0.669...).

    Parameters
    ----------
    eta : float, ndarray or mpf

    Returns
    -------
    Same type as ``eta``
        Velocity of granule 2 at separation.
    """
    ns = _ns(eta)
    eta = ns.num(eta)
    return ns.sqrt(1 - eta**2) - eta * ns.pi() / (2 * ns.sqrt(ns.num(2)))


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

    Returns
    -------
    Same type as ``eta``
        Kinetic energy at separation over the initial kinetic energy.
    """
    ns = _ns(eta)
    eta = ns.num(eta)
    pi = ns.pi()
    return (1 - eta * ns.sqrt(1 - eta**2) * pi / ns.sqrt(ns.num(2))
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


# ============================================================================
# Sec. II B: kinetic friction eta on granule 1, frictionless granule 2
# ============================================================================
def iib_x1(t, eta):
    """Sec. II B Eq. (``eq:x1model2``), as printed (exact while v1 > 0).

    ``x1(t) = 1/4 [ -eta + 2t - eta t^2 + eta cos(sqrt2 t) + sqrt2 sin(sqrt2 t) ]``.

    Parameters
    ----------
    t : float, ndarray or mpf
        Scaled time, ``0 <= t <= t0`` (granule 1 still moving forward).
    eta : float or mpf
        Scaled friction of granule 1.

    Returns
    -------
    Same type as ``t``
    """
    ns = _ns(t, eta)
    t, eta = ns.num(t), ns.num(eta)
    r2 = ns.sqrt(ns.num(2))
    return (-eta + 2 * t - eta * t**2 + eta * ns.cos(r2 * t) + r2 * ns.sin(r2 * t)) / 4


def iib_x2(t, eta):
    """Sec. II B Eq. (``eq:x2model2``), as printed (exact while v1 > 0).

    ``x2(t) = 1/4 [ eta + 2t - eta t^2 - eta cos(sqrt2 t) - sqrt2 sin(sqrt2 t) ]``.
    """
    ns = _ns(t, eta)
    t, eta = ns.num(t), ns.num(eta)
    r2 = ns.sqrt(ns.num(2))
    return (eta + 2 * t - eta * t**2 - eta * ns.cos(r2 * t) - r2 * ns.sin(r2 * t)) / 4


def iib_v1(t, eta):
    """Sec. II B, printed ``v1(t) = 1/4 [2 - 2 eta t + 2 cos(sqrt2 t) - sqrt2 eta sin(sqrt2 t)]`` (exact)."""
    ns = _ns(t, eta)
    t, eta = ns.num(t), ns.num(eta)
    r2 = ns.sqrt(ns.num(2))
    return (2 - 2 * eta * t + 2 * ns.cos(r2 * t) - r2 * eta * ns.sin(r2 * t)) / 4


def iib_v2(t, eta):
    """Derivative of Eq. (``eq:x2model2``) (not printed).

    ``v2(t) = 1/4 [2 - 2 eta t - 2 cos(sqrt2 t) + sqrt2 eta sin(sqrt2 t)]``.
    """
    ns = _ns(t, eta)
    t, eta = ns.num(t), ns.num(eta)
    r2 = ns.sqrt(ns.num(2))
    return (2 - 2 * eta * t - 2 * ns.cos(r2 * t) + r2 * eta * ns.sin(r2 * t)) / 4


def iib_t0_small_eta(eta):
    """Sec. II B Eq. (``eq:t0model2``): ``t0 = pi/sqrt2 - (pi eta/sqrt2)^(1/2) + O(eta^(3/2))``.

    Stopping time of granule 1.  Verdict: correct to the stated order; our
    expansion gives the next term ``-(pi eta/sqrt2)^(3/2)/12``
    (:func:`iib_t0_small_eta_next_order`).

    Parameters
    ----------
    eta : float, ndarray or mpf

    Returns
    -------
    Same type as ``eta``
    """
    ns = _ns(eta)
    eta = ns.num(eta)
    r2 = ns.sqrt(ns.num(2))
    return ns.pi() / r2 - ns.sqrt(ns.pi() * eta / r2)


def iib_t0_small_eta_next_order(eta):
    """Eq. (``eq:t0model2``) with the next term (derived here, not printed).

    With ``a = pi eta / sqrt2``, ``t0 = pi/sqrt2 - a^(1/2) - a^(3/2)/12 + O(eta^(5/2))``
    (expand ``4 v1`` about ``pi/sqrt2``: ``2 tau^2 - sqrt2 pi eta - tau^4/3 + O(eta tau^3) = 0``).
    """
    ns = _ns(eta)
    eta = ns.num(eta)
    r2 = ns.sqrt(ns.num(2))
    a = ns.pi() * eta / r2
    return ns.pi() / r2 - ns.sqrt(a) - a * ns.sqrt(a) / 12


def _bracket_root(f, a, b):
    """Root of ``f`` on ``[a, b]`` (sign change required), at the working precision."""
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
    f0 = f

    def f(x):
        return f0(x) / scale
    fa, fb = fa / scale, fb / scale
    try:
        r = mpmath.findroot(f, (a, b), solver="anderson")
        if a <= r <= b:
            return r
    except (ValueError, ZeroDivisionError):
        pass
    # fall back to bisection (robust, slower)
    for _ in range(4 * mpmath.mp.prec):
        m = (a + b) / 2
        fm = f(m)
        if fm == 0 or b - a < mpmath.mpf(2) ** (-mpmath.mp.prec) * (1 + abs(m)):
            return m
        if (fm > 0) == (fa > 0):
            a, fa = m, fm
        else:
            b = m
    return (a + b) / 2


def _first_root_scan(f, t_end, h):
    """First sign change of ``f`` from its initial sign on ``(0, t_end]``, then refined."""
    t = mpmath.mpf(0)
    f0 = f(t + h / 1024)  # sign just after 0 (f(0) may vanish)
    while t < t_end:
        t2 = min(t + h, t_end)
        if (f(t2) > 0) != (f0 > 0):
            return _bracket_root(f, t, t2)
        t = t2
    return None


def iib_t0_exact(eta, dps=30):
    """Exact stopping time of granule 1 in Sec. II B: first root of the printed ``v1(t)``.

    ``v1`` decreases strictly while granule 1 slides forward, ``v1(0) = 1`` and
    ``v1(pi/sqrt2) = -sqrt2 pi eta / 4 < 0``, so the root is unique in ``(0, pi/sqrt2)``.

    Parameters
    ----------
    eta : float or mpf, > 0
    dps : int
        Decimal digits.

    Returns
    -------
    mpf
    """
    with mpmath.workdps(dps + 10):
        e = mpmath.mpf(eta)
        t0 = _bracket_root(lambda t: iib_v1(t, e), mpmath.mpf(0), mpmath.pi / mpmath.sqrt(2))
    return +t0


def iib_t0prime_exact(eta, dps=30):
    """Sec. II B: time ``t0'`` at which ``x1 = x2`` if Eqs. (x1model2, x2model2) stayed valid.

    Closed form (derived here): ``x1 - x2 = sin(theta)/sqrt2 - eta/2 (1 - cos theta)``,
    ``theta = sqrt2 t``, vanishes at ``tan(theta/2) = sqrt2/eta``:
    ``t0' = sqrt2 * arctan(sqrt2/eta)``.  Limits: ``pi/sqrt2`` as eta -> 0 and
    ``2/eta`` as eta -> infinity, as the paper states; the paper's claim that
    ``t0' > t0`` for all eta is checked in the tests.

    Parameters
    ----------
    eta : float or mpf, > 0
    dps : int

    Returns
    -------
    mpf
    """
    with mpmath.workdps(dps + 10):
        e = mpmath.mpf(eta)
        r = mpmath.sqrt(2) * mpmath.atan(mpmath.sqrt(2) / e)
    return +r


def iib_initial_conditions_small_eta(eta):
    """Sec. II B Eqs. (``ic1``)-(``ic4``), as printed (small-eta approximation).

    ``x1(t0) = [2 sqrt2 pi - (pi^2 + 4) eta] / 8``,
    ``x2(t0) = [2 sqrt2 pi - 4 (2^(3/4)) sqrt(pi eta) - (pi^2 - 4) eta] / 8``,
    ``v1(t0) = 0``, ``v2(t0) = [2 - sqrt2 pi eta] / 2``.

    Verdict: correct, each with error ``O(eta^(3/2))`` (the coefficient
    ``4 * 2^(3/4) = 8 * 2^(-1/4)`` is right: ``8 (pi eta/sqrt2)^(1/2)``).  With
    ``a = pi eta/sqrt2`` our expansion gives printed minus exact:
    ``x1: -a^(3/2)/3``, ``x2: -7 a^(3/2)/12``, ``v2: -eta a^(1/2)``, each + O(eta^2).

    Parameters
    ----------
    eta : float, ndarray or mpf

    Returns
    -------
    tuple
        ``(x1, x2, v1, v2)`` at ``t = t0``.
    """
    ns = _ns(eta)
    eta = ns.num(eta)
    pi = ns.pi()
    r2 = ns.sqrt(ns.num(2))
    x1 = (2 * r2 * pi - (pi**2 + 4) * eta) / 8
    x2 = (2 * r2 * pi - 4 * ns.num(2) ** ns.num(0.75) * ns.sqrt(pi * eta) - (pi**2 - 4) * eta) / 8
    v2 = (2 - r2 * pi * eta) / 2
    return x1, x2, 0 * eta, v2


def iib_initial_conditions_exact(eta, dps=30):
    """Exact ``(x1, x2, v1, v2)`` at the exact stopping time of granule 1 (Sec. II B).

    Printed Eqs. (x1model2, x2model2) at :func:`iib_t0_exact`; ``v2 = 1 - eta t0``
    (momentum balance: ``(x1+x2)'' = -eta`` while granule 1 slides forward).

    Returns
    -------
    tuple of mpf
    """
    with mpmath.workdps(dps + 10):
        e = mpmath.mpf(eta)
        t0 = iib_t0_exact(e, dps + 10)
        out = (iib_x1(t0, e), iib_x2(t0, e), mpmath.mpf(0), 1 - e * t0)
    return tuple(+v for v in out)


def iib_slip_force_printed(eta):
    """Sec. II B slip condition, left-hand side as printed.

    ``[x1(t0) - x2(t0)] = 1/2 [ -eta - eta cos(2^(1/4) sqrt(eta pi)) + sqrt2 sin(2^(1/4) sqrt(eta pi)) ]``;
    granule 1 slides back iff this exceeds ``eta``.

    It is the exact phase-1 spring force ``x1 - x2`` evaluated at the *small-eta*
    ``t0`` of Eq. (t0model2) (``sqrt2 (pi eta/sqrt2)^(1/2) = 2^(1/4) sqrt(pi eta)``).
    Verdict: approximate; printed minus exact force is ``-a^(3/2)/12 + O(eta^2)``,
    ``a = pi eta/sqrt2`` (the printed ``t0`` is late by ``a^(3/2)/12`` and
    ``u' = -v2 = -1 + O(eta)`` there).

    Parameters
    ----------
    eta : float, ndarray or mpf

    Returns
    -------
    Same type as ``eta``
    """
    ns = _ns(eta)
    eta = ns.num(eta)
    p = ns.num(2) ** ns.num(0.25) * ns.sqrt(eta * ns.pi())
    return (-eta - eta * ns.cos(p) + ns.sqrt(ns.num(2)) * ns.sin(p)) / 2


def iib_slip_critical_eta_printed(dps=30):
    """Sec. II B: critical ``eta = 0.439...`` of the printed slip condition.

    Root of ``iib_slip_force_printed(eta) = eta``: 0.438861157...  It reproduces
    the printed 0.439, but only for the approximated force; the exact threshold is
    :func:`iib_slip_critical_eta_exact` = 0.444021... (erratum: 1.2 % low).

    Returns
    -------
    mpf
    """
    with mpmath.workdps(dps + 10):
        r = _bracket_root(lambda e: iib_slip_force_printed(e) - e, mpmath.mpf("0.3"), mpmath.mpf("0.6"))
    return +r


def iib_slip_critical_eta_exact(dps=30):
    """Corrected critical friction for back-sliding of granule 1 (Sec. II B).

    Root of ``u(t0(eta)) = eta`` with the exact stopping time ``t0`` and the exact
    phase-1 force ``u = x1 - x2``: ``eta_c = 0.4440212486825...``.  Granule 1 slides
    back for ``eta < eta_c`` and sticks for ``eta >= eta_c`` (the printed 0.439 is
    the root of the small-eta approximation of the force).

    Returns
    -------
    mpf
    """
    with mpmath.workdps(dps + 10):
        def g(e):
            t0 = iib_t0_exact(e, dps + 10)
            return iib_x1(t0, e) - iib_x2(t0, e) - e
        r = _bracket_root(g, mpmath.mpf("0.3"), mpmath.mpf("0.6"))
    return +r


def iib_t1_small_eta(eta):
    """Sec. II B Eq. (``omega1``): ``t1 = (pi eta/sqrt2)^(1/2) - eta + O(eta^(3/2))``.

    Duration of the back-sliding phase (from the stop of granule 1 to separation)
    assuming granule 1 still slides back at separation.  Verdict: correct to the
    stated order; our expansion gives ``t1 = a^(1/2) - eta + a^(3/2)/12 + O(eta^2)``,
    ``a = pi eta/sqrt2`` (:func:`iib_t1_small_eta_next_order`).

    Parameters
    ----------
    eta : float, ndarray or mpf

    Returns
    -------
    Same type as ``eta``
    """
    ns = _ns(eta)
    eta = ns.num(eta)
    return ns.sqrt(ns.pi() * eta / ns.sqrt(ns.num(2))) - eta


def iib_t1_small_eta_next_order(eta):
    """Eq. (``omega1``) with the next term (derived here, not printed).

    ``t1 = a^(1/2) - eta + a^(3/2)/12 + O(eta^2)``, ``a = pi eta/sqrt2``: solve
    ``u(t1) = 0`` with ``u0 = a^(1/2) - eta - a^(3/2)/4``, ``v2(t0) = 1 - a + eta a^(1/2)``.
    """
    ns = _ns(eta)
    eta = ns.num(eta)
    a = ns.pi() * eta / ns.sqrt(ns.num(2))
    return ns.sqrt(a) - eta + a * ns.sqrt(a) / 12


def iib_collision_exact(eta, dps=30):
    """Exact solution of the Sec. II B problem (friction ``eta`` on granule 1 only).

    Closed-form phases, derived here independently of the generic solver:

    1. ``t < t0``: printed Eqs. (x1model2, x2model2); ``t0`` = :func:`iib_t0_exact`.
    2. If ``u0 = x1-x2 > eta`` at ``t0``: Eqs. (motionx1, motionx2) for ``t' = t - t0``,
       ``u(t') = eta/2 + (u0 - eta/2) cos(sqrt2 t') - v20/sqrt2 sin(sqrt2 t')``,
       ``v1(t') = [v20 (1 - cos(sqrt2 t')) + eta t' - sqrt2 (u0 - eta/2) sin(sqrt2 t')]/2``.
       ``t1`` is the first root of ``u``; ``t_stop`` the first root of ``v1`` (the
       granule-1 stopping time of the dashed curve of Fig. timecompare3).
    3. If granule 1 is at rest (stuck) while in contact, granule 2 (frictionless)
       leaves with ``v2 = sqrt(v2^2 + u^2)`` (spring energy), after ``atan(u/v2)``.

    Parameters
    ----------
    eta : float or mpf, > 0
    dps : int

    Returns
    -------
    dict
        ``t0``, ``u0``, ``v20`` (state at the stop), ``slides_back`` (bool),
        ``t1`` and ``t_stop`` (phase-2 times after ``t0``, mpf; ``None`` when
        ``slides_back`` is False), ``v1s``, ``v2s``, ``energy_ratio``,
        ``t_separation`` (from ``t = 0``), all mpf.
    """
    with mpmath.workdps(dps + 10):
        e = mpmath.mpf(eta)
        r2 = mpmath.sqrt(2)
        t0 = iib_t0_exact(e, dps + 10)
        u0 = iib_x1(t0, e) - iib_x2(t0, e)
        v20 = 1 - e * t0
        out = {"t0": t0, "u0": u0, "v20": v20, "slides_back": bool(u0 > e),
               "t1": None, "t_stop": None}
        if u0 > e:
            A = u0 - e / 2

            def u(tp):
                return e / 2 + A * mpmath.cos(r2 * tp) - v20 / r2 * mpmath.sin(r2 * tp)

            def v1(tp):
                return (v20 * (1 - mpmath.cos(r2 * tp)) + e * tp - r2 * A * mpmath.sin(r2 * tp)) / 2

            # u decreases from u0 > 0 to its minimum eta/2 - R < 0 at theta = pi - psi
            R = mpmath.sqrt(A**2 + v20**2 / 2)
            psi = mpmath.atan2(v20 / r2, A)
            t1 = _bracket_root(u, mpmath.mpf(0), (mpmath.pi - psi) / r2)
            # v1 < 0 just after 0 and v1(theta = 2 pi) = eta pi > 0
            t_stop = _first_root_scan(v1, mpmath.pi * r2, mpmath.mpf(1) / 64)
            out["t1"], out["t_stop"] = t1, t_stop
            if t_stop > t1:
                v1s = v1(t1)
                v2s = v20 + e * t1 - v1s
                t_sep = t0 + t1
            else:
                v2 = v20 + e * t_stop
                us = u(t_stop)
                v1s = mpmath.mpf(0)
                v2s = mpmath.sqrt(v2**2 + us**2)
                t_sep = t0 + t_stop + mpmath.atan2(us, v2)
        else:
            v1s = mpmath.mpf(0)
            v2s = mpmath.sqrt(v20**2 + u0**2)
            t_sep = t0 + mpmath.atan2(u0, v20)
        out.update(v1s=v1s, v2s=v2s, energy_ratio=v1s**2 + v2s**2, t_separation=t_sep)
        out = {k: (+v if isinstance(v, mpmath.mpf) else v) for k, v in out.items()}
    return out


def iib_backscatter_threshold_eta_exact(dps=30):
    """Sec. II B claim "backscattering (and propagation) if eta <~ 0.22", exact value.

    Root of ``t_stop(eta) = t1(eta)`` (granule 1 stops exactly at separation):
    ``eta_b = 0.2195624104...``.  Verdict: the printed ``~0.22`` is right to its 2 digits.

    Returns
    -------
    mpf
    """
    with mpmath.workdps(dps + 10):
        def g(e):
            c = iib_collision_exact(e, dps + 10)
            return c["t_stop"] - c["t1"]
        r = _bracket_root(g, mpmath.mpf("0.15"), mpmath.mpf("0.3"))
    return +r



def golden_min(f, a, b, tol):
    """Golden-section search for the minimum of a unimodal f on [a, b].

    Works in the number type of ``a`` and ``b`` (float or mpmath), to width ``tol``.
    """
    gr = ((a * 0 + 5) ** 0.5 - 1) / 2
    c, d = b - gr * (b - a), a + gr * (b - a)
    fc, fd = f(c), f(d)
    while b - a > tol:
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - gr * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + gr * (b - a)
            fd = f(d)
    return (a + b) / 2

def iib_max_backscatter_exact(dps=20):
    """Sec. II B claim: the backward speed of granule 1 peaks at "approximately 3%".

    Golden-section maximisation of ``-v1^(s)(eta)`` from :func:`iib_collision_exact`.

    Returns
    -------
    (mpf, mpf)
        ``(eta_star, -v1s_max)`` = ``(0.094024..., 0.0311918...)``: 3.1 % of the
        initial velocity (the printed "approximately 3%" is right).
    """
    with mpmath.workdps(dps + 10):
        def f(e):
            return iib_collision_exact(e, dps)["v1s"]  # minimise v1s
        e = golden_min(f, mpmath.mpf("0.02"), mpmath.mpf("0.2"),
                       mpmath.mpf(10) ** (-(dps // 2 + 2)))
        v = -f(e)
    return +e, +v


# ============================================================================
# Sec. III: hydrodynamic friction gamma_i = gamma (1 + delta_i), delta_1 = -delta_2 = delta
# ============================================================================
def iii_gammas(gamma, delta):
    """Sec. III definition ``gamma_i = gamma (1 + delta_i)``, ``delta_1 = -delta_2 = delta``.

    So ``delta > 0`` means ``gamma_1 > gamma_2``.  (The text after the velocity
    formulas says "gamma_2 > gamma_1 (delta > 0)", contradicting this definition
    and the caption of Fig. finalv1m5; see :func:`iii_dvs_ddelta`.)

    Returns
    -------
    (gamma1, gamma2)
    """
    return gamma * (1 + delta), gamma * (1 - delta)


def iii_omega(gamma):
    """Sec. III: ``omega = sqrt(8 - gamma^2) / 2`` (exact; real for gamma^2 < 8)."""
    ns = _ns(gamma)
    gamma = ns.num(gamma)
    return ns.sqrt(8 - gamma**2) / 2


def iii_separates(gamma):
    """Sec. III claim: for ``delta = 0`` the collision ends iff ``gamma^2 < 8`` (exact).

    ``x_-`` obeys ``x_-'' + gamma x_-' + 2 x_- = 0``, ``x_-(0) = 0``, ``x_-'(0) = 1``:
    for ``gamma^2 >= 8`` it is ``t e^{-sqrt2 t}`` or ``e^{-gamma t/2} sinh(kappa t)/kappa``,
    positive for all ``t > 0``.
    """
    return np.asarray(gamma, dtype=float) ** 2 < 8.0


def iii_t0(gamma):
    """Sec. III: separation time ``t0 = pi/omega`` for ``delta = 0`` (exact; inf if gamma^2 >= 8)."""
    ns = _ns(gamma)
    if ns is _MP:
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
    """
    ns = _ns(t, gamma)
    t, gamma = ns.num(t), ns.num(gamma)
    w = iii_omega(gamma)
    return ns.exp(-gamma * t / 2) * ns.sin(w * t) / w


def iii_laplace_system_printed(s, gamma, delta):
    """Sec. III Eqs. (``eq:model5lt``) as printed: matrix ``M`` and right side ``b``.

    ``M @ [X_+, X_-] = b`` with
    ``M = [[gamma s + s^2, delta gamma s], [delta gamma s, 2 + gamma s + s^2]]``,
    ``b = [1, 1]``.  Verdict: correct (derived from Eqs. (model5) with
    ``x_i(0) = 0``, ``v1(0) = 1``, ``v2(0) = 0``).

    Parameters
    ----------
    s : complex or float
    gamma, delta : float

    Returns
    -------
    (ndarray (2, 2), ndarray (2,))
    """
    M = np.array([[gamma * s + s**2, delta * gamma * s],
                  [delta * gamma * s, 2 + gamma * s + s**2]])
    return M, np.array([1.0, 1.0])


def iii_laplace_exact(s, gamma, delta):
    """Exact Laplace transforms ``(X_+, X_-)`` straight from Eqs. (model5).

    Transforming ``x1'' = -gamma1 x1' - (x1 - x2)``, ``x2'' = -gamma2 x2' + (x1 - x2)``
    with ``x(0) = 0``, ``v1(0) = 1``, ``v2(0) = 0``:
    ``(s^2 + gamma1 s + 1) X1 - X2 = 1``, ``-X1 + (s^2 + gamma2 s + 1) X2 = 0``.

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
    """
    q = 2 + s * (gamma + s)
    return 1 / (s * (gamma + s)) - delta * gamma / (s * (gamma + s) * q)


def iii_Xplus_first_order_corrected(s, gamma, delta):
    """Corrected first-order ``X_+(s) = 1/(s(gamma+s)) - delta gamma / ((gamma+s)[2 + s(gamma+s)])``."""
    q = 2 + s * (gamma + s)
    return 1 / (s * (gamma + s)) - delta * gamma / ((gamma + s) * q)


def iii_Xminus_first_order(s, gamma, delta):
    """Sec. III, first-order ``X_-(s)`` as printed (correct).

    ``X_- = 1/(2 + s(gamma+s)) - delta gamma / ((gamma+s)[2 + s(gamma+s)])``.
    """
    q = 2 + s * (gamma + s)
    return 1 / q - delta * gamma / ((gamma + s) * q)


def iii_epsilon(gamma, delta):
    """Sec. III: ``epsilon = -(delta gamma omega / 2)(1 + e^{-gamma pi/(2 omega)})`` (correct to O(delta)).

    Separation time ``t1 = pi/omega + epsilon/omega``; ``epsilon < 0`` for
    ``delta > 0`` (larger friction on granule 1 ends the collision earlier).
    """
    ns = _ns(gamma, delta)
    gamma, delta = ns.num(gamma), ns.num(delta)
    w = iii_omega(gamma)
    return -delta * gamma * w / 2 * (1 + ns.exp(-gamma * ns.pi() / (2 * w)))


def iii_t_separation_first_order(gamma, delta):
    """Sec. III: ``t1 = t0 + epsilon/omega = pi/omega + epsilon/omega`` (error O(delta^2))."""
    ns = _ns(gamma, delta)
    w = iii_omega(ns.num(gamma))
    return (ns.pi() + iii_epsilon(gamma, delta)) / w


def iii_v1s_first_order(gamma, delta):
    """Sec. III, first-order ``v1^(s)`` as printed (correct to O(delta); error O(delta^2)).

    ``v1 = (1 - e^{g})/2 e^{-2g} + delta gamma^2/4 (1 + 2 e^{g} + e^{2g}) e^{-3g}``,
    ``g = gamma pi / (2 omega)``.
    """
    ns = _ns(gamma, delta)
    gamma, delta = ns.num(gamma), ns.num(delta)
    g = gamma * ns.pi() / (2 * iii_omega(gamma))
    return ((1 - ns.exp(g)) / 2 * ns.exp(-2 * g)
            + delta * gamma**2 / 4 * (1 + 2 * ns.exp(g) + ns.exp(2 * g)) * ns.exp(-3 * g))


def iii_v2s_first_order(gamma, delta):
    """Sec. III, first-order ``v2^(s)`` as printed (correct to O(delta); error O(delta^2)).

    ``v2 = (1 + e^{g})/2 e^{-2g} + delta gamma^2/(32 omega^2)
    [8 omega^2 + (12 omega^2 - gamma^2 + 8) e^{g} + (4 omega^2 - gamma^2 + 8) e^{2g}] e^{-3g}``.
    Since ``8 - gamma^2 = 4 omega^2`` the bracket is ``8 omega^2 (1 + e^g)^2`` and the
    first-order term equals that of ``v1``: see :func:`iii_dvs_ddelta`.
    """
    ns = _ns(gamma, delta)
    gamma, delta = ns.num(gamma), ns.num(delta)
    w = iii_omega(gamma)
    g = gamma * ns.pi() / (2 * w)
    return ((1 + ns.exp(g)) / 2 * ns.exp(-2 * g)
            + delta * gamma**2 / (32 * w**2)
            * (8 * w**2 + (12 * w**2 - gamma**2 + 8) * ns.exp(g)
               + (4 * w**2 - gamma**2 + 8) * ns.exp(2 * g)) * ns.exp(-3 * g))


def iii_dvs_ddelta(gamma):
    """``d v1^(s)/d delta = d v2^(s)/d delta = (gamma^2/4) E (1 + E)^2`` at delta = 0, ``E = e^{-gamma pi/(2 omega)}``.

    Simplified from the printed first-order terms (derived here).  It is positive:
    raising ``delta`` (more friction on granule 1) makes ``v1^(s)`` less negative,
    so backscattering is larger for ``delta < 0``, i.e. ``gamma_2 > gamma_1``.
    **Erratum** in the text: "greater if gamma_2 > gamma_1 (delta > 0)" must read
    "(delta < 0)"; the caption of Fig. finalv1m5 (``gamma_1 > gamma_2`` for
    ``delta = 0.1``) agrees with the definition.
    """
    ns = _ns(gamma)
    gamma = ns.num(gamma)
    E = ns.exp(-gamma * ns.pi() / (2 * iii_omega(gamma)))
    return gamma**2 / 4 * E * (1 + E) ** 2


def iii_energy_ratio_zeroth(gamma):
    """Sec. III claim "energy at the end of the collision decreases monotonically with gamma".

    For ``delta = 0`` (exact): ``E^(s)/E0 = v1^2 + v2^2 = (E^4 + E^2)/2`` with
    ``E = e^{-gamma pi/(2 omega)}``, decreasing in gamma on ``0 <= gamma < sqrt8``.
    """
    ns = _ns(gamma)
    gamma = ns.num(gamma)
    E = ns.exp(-gamma * ns.pi() / (2 * iii_omega(gamma)))
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


# ============================================================================
# Exact reference solver for n = 2
# ============================================================================
OUTCOMES = ("backscatter_and_propagation", "propagation_only", "backscatter_only",
            "both_forward", "stuck", "no_separation")

_FREE, _STICK = "free", "stick"  # a sliding granule is represented by its direction +1 / -1


def _mode_matrix(modes, eta, gamma):
    """Generator of ``z' = M z`` for ``z = [u, s, v1, v2, 1]`` (u = x1-x2 > 0, s = x1+x2)."""
    M = mpmath.zeros(5, 5)
    M[0, 2], M[0, 3] = 1, -1
    M[1, 2], M[1, 3] = 1, 1
    for i, sign in ((0, -1), (1, 1)):  # spring force on granule i is sign * u
        row = 2 + i
        if modes[i] == _STICK:
            continue
        M[row, 0] = sign
        M[row, row] = -gamma[i]
        if modes[i] != _FREE:
            M[row, 4] = -eta[i] * modes[i]
    return M


def _events(modes, eta):
    """Event functionals ``g = c . z``; an event fires when g goes from > 0 to <= 0."""
    ev = [("separation", None, (1, 0, 0, 0, 0))]
    for i in (0, 1):
        if modes[i] == _STICK:
            ev.append(("slip", i, (-1, 0, 0, 0, eta[i])))  # |spring force| = u exceeds eta_i
        elif modes[i] != _FREE:
            c = [0, 0, 0, 0, 0]
            c[2 + i] = modes[i]
            ev.append(("stop", i, tuple(c)))  # velocity along the slide direction reaches 0
    return ev


def _dot(c, z):
    return sum(ci * z[k] for k, ci in enumerate(c) if ci)


def _homogeneous_horizon(modes, gamma, z):
    """For a mode without Coulomb sliding: time after which no event can occur.

    Returns ``mpmath.inf`` when separation is certain (march until found),
    a finite horizon otherwise, or the string ``"monotone"`` for the one-granule
    case in which separation is impossible and the caller stops once ``u' < 0``.
    """
    u, v1, v2 = z[0], z[2], z[3]
    free = [i for i in (0, 1) if modes[i] == _FREE]
    if len(free) == 1:
        # the other granule is stuck: u'' + g u' + u = 0 for the free granule's g
        g = gamma[free[0]]
        if g < 2:
            return mpmath.inf
        r_fast = (-g - mpmath.sqrt(g * g - 4)) / 2
        du = v1 - v2
        # u = A e^{r_slow t} + B e^{r_fast t}: crosses 0 for t > 0 iff A < 0 iff u' < r_fast u
        return mpmath.inf if du < r_fast * u else "monotone"
    # both granules free (eta1 = eta2 = 0): reduced system on (u, v1, v2)
    g1, g2 = gamma
    if g1 == g2:
        # x_- decouples: u'' + g u' + 2u = 0, u(0)=0, u'(0)=1 (mode starts at t = 0)
        return mpmath.inf if g1 * g1 < 8 else mpmath.mpf(0)
    A = mpmath.matrix([[0, 1, -1], [-1, -g1, 0], [1, 0, -g2]])
    lam, V = mpmath.eig(A)
    gaps = [abs(lam[i] - lam[j]) for i in range(3) for j in range(i)]
    if min(gaps) < mpmath.mpf(10) ** (-12):
        raise NotImplementedError("nearly repeated eigenvalues in the viscous mode")
    coef = mpmath.lu_solve(V, mpmath.matrix([u, v1, v2]))
    c = [V[0, k] * coef[k] for k in range(3)]  # u(t) = sum c_k exp(lam_k t)
    scale = max(abs(ck) for ck in c)
    keep = [k for k in range(3) if abs(c[k]) > scale * mpmath.mpf(10) ** (-(mpmath.mp.dps - 8))]
    kd = max(keep, key=lambda k: mpmath.re(lam[k]))
    lead = mpmath.re(lam[kd])
    tiny = mpmath.mpf(10) ** (-(mpmath.mp.dps - 8))
    # mpmath.eig returns real eigenvalues with ~1e-40 imaginary noise
    if abs(mpmath.im(lam[kd])) > tiny * (1 + abs(lam[kd])) or mpmath.re(c[kd]) < 0:
        return mpmath.inf  # oscillating or negative tail: separation is certain
    others = [k for k in keep if mpmath.re(lam[k]) < lead - mpmath.mpf(10) ** (-20)]
    if not others:
        return mpmath.mpf(0)
    rest = sum(abs(c[k]) for k in others)
    gap = lead - max(mpmath.re(lam[k]) for k in others)
    # beyond T the leading positive term dominates all others: u > 0
    return max(mpmath.mpf(0), mpmath.log(rest / mpmath.re(c[kd])) / gap) + 1


def _classify(v1, v2, dps):
    """Outcome name from the velocities at separation.

    A velocity counts as rest when ``|v| <= 1e-(dps-5) * max(|v1|, |v2|)`` (roundoff
    of an exactly zero velocity, e.g. granule 1 in the frictionless exchange);
    the scale is relative because viscous collisions may end with tiny velocities.
    """
    scale = max(abs(v1), abs(v2))
    if scale == 0:
        return "stuck"  # pragma: no cover - both at rest exactly at separation
    tol = mpmath.mpf(10) ** (-(dps - 5)) * scale
    a1 = 0 if abs(v1) <= tol else (1 if v1 > 0 else -1)
    a2 = 0 if abs(v2) <= tol else (1 if v2 > 0 else -1)
    if a2 > 0:
        return {-1: "backscatter_and_propagation", 0: "propagation_only", 1: "both_forward"}[a1]
    if a1 < 0:
        return "backscatter_only"
    return "stuck"  # pragma: no cover - granule 2 is never pushed backwards


def reference_collision_n2(eta1, eta2, gamma1=0, gamma2=0, dps=30, t_cap=1000):
    """Exact collision of two granules for ``n = 2`` with Coulomb and viscous friction.

    Scaled model (Sec. II, III, Appendix A): masses 1, spring force ``u = x1 - x2``
    while ``u > 0``; granule ``i`` feels ``-eta_i sign(v_i) - gamma_i v_i``; a granule
    at rest stays at rest while ``|spring force| <= eta_i`` (stick) and slides in the
    direction of the spring force once it exceeds ``eta_i`` (slip).  Initially
    ``x1 = x2 = 0``, ``v1 = 1``, ``v2 = 0``.

    Within a mode (each granule free, sticking, or sliding in a fixed direction) the
    dynamics is linear with constant coefficients, ``z' = M z`` for
    ``z = [x1-x2, x1+x2, v1, v2, 1]``, so ``z(t) = expm(M t) z(0)`` exactly.  The
    solver marches with the exact propagator on a grid (step <= 1/32), detects sign
    changes of the event functions (contact opening ``u -> 0``, a sliding granule
    stopping, a stuck granule's spring force exceeding ``eta_i``) and refines each
    root with ``expm`` at ``dps + 10`` digits.  Results are accurate to about
    ``10**-(dps-5)``.

    Parameters
    ----------
    eta1, eta2 : float or mpf, >= 0
        Scaled kinetic friction forces.
    gamma1, gamma2 : float or mpf, >= 0
        Scaled hydrodynamic friction coefficients.
    dps : int
        Decimal digits of the mpmath arithmetic.
    t_cap : float
        Give up (``RuntimeError``) if a Coulomb-sliding mode lasts longer.

    Returns
    -------
    dict
        ``v1``, ``v2`` : mpf, velocities at separation (0 for ``stuck`` and
        ``no_separation``, their limits as ``t -> inf``);
        ``energy_ratio`` : mpf, ``(v1**2 + v2**2) / 2 / E0`` with ``E0 = 1/2``
        (kinetic energy only);
        ``t_separation`` : mpf, or ``math.inf`` if contact never ends;
        ``x1``, ``x2`` : mpf displacements at separation (``None`` if never);
        ``outcome`` : one of :data:`OUTCOMES`;
        ``events`` : list of dicts ``{t, kind, granule, x1, x2, v1, v2}``
        (``kind`` in ``stop``, ``slip``, ``stick``, ``reverse``, ``separation``);
        ``segments`` : list of ``(t_start, t_end, M, z_start)`` for
        :func:`reference_state_n2`.

    Notes
    -----
    Viscous-only modes that never reach ``u = 0`` are recognised analytically
    (eigen-decomposition of the mode, or the closed form for one moving granule);
    exactly repeated eigenvalues are supported only in the symmetric case
    ``gamma1 == gamma2`` and for one moving granule.
    """
    with mpmath.workdps(dps + 10):
        eta = (mpmath.mpf(eta1), mpmath.mpf(eta2))
        gamma = (mpmath.mpf(gamma1), mpmath.mpf(gamma2))
        if min(eta) < 0 or min(gamma) < 0:
            raise ValueError("friction parameters must be non-negative")
        h = min(mpmath.mpf(1) / 32, mpmath.mpf(1) / (2 * (1 + gamma[0] + gamma[1])))
        modes = [1 if eta[0] > 0 else _FREE, _STICK if eta[1] > 0 else _FREE]
        z = mpmath.matrix([0, 0, 1, 0, 1])
        t = mpmath.mpf(0)
        events, segments = [], []

        def record(kind, granule, tt, zz):
            events.append({"t": tt, "kind": kind, "granule": granule,
                           "x1": (zz[1] + zz[0]) / 2, "x2": (zz[1] - zz[0]) / 2,
                           "v1": zz[2], "v2": zz[3]})

        def finish(outcome, t_sep, zz):
            if zz is None:
                v1 = v2 = mpmath.mpf(0)
                x1 = x2 = None
            else:
                v1, v2 = zz[2], zz[3]
                x1, x2 = (zz[1] + zz[0]) / 2, (zz[1] - zz[0]) / 2
            res = {"v1": +v1, "v2": +v2, "energy_ratio": +(v1**2 + v2**2),
                   "t_separation": t_sep if t_sep == math.inf else +t_sep,
                   "x1": x1, "x2": x2, "outcome": outcome,
                   "events": events, "segments": segments, "dps": dps}
            return res

        while True:
            if modes[0] == _STICK and modes[1] == _STICK:
                segments.append((t, mpmath.inf, _mode_matrix(modes, eta, gamma), z.copy()))
                return finish("stuck", math.inf, None)
            M = _mode_matrix(modes, eta, gamma)
            evs = _events(modes, eta)
            sliding = any(m not in (_FREE, _STICK) for m in modes)
            horizon = mpmath.mpf(t_cap) if sliding else _homogeneous_horizon(modes, gamma, z)
            z_start_mode = z.copy()
            if (not sliding and modes == [_FREE, _FREE] and gamma[0] == gamma[1]
                    and horizon == mpmath.inf):
                # symmetric viscous case: u = e^{-g t/2} sin(w t)/w, v1 + v2 = e^{-g t};
                # marching is pointless when the contact lasts longer than t_cap
                # (gamma just below sqrt 8, w -> 0), so use the closed form there
                w = mpmath.sqrt(8 - gamma[0] ** 2) / 2
                t_sep = mpmath.pi / w
                if t_sep > t_cap:
                    vp = mpmath.exp(-gamma[0] * t_sep)
                    vm = -mpmath.exp(-gamma[0] * t_sep / 2)
                    z = mpmath.matrix([0, (1 - vp) / gamma[0], (vp + vm) / 2, (vp - vm) / 2, 1])
                    segments.append((t, t_sep, M, z_start_mode))
                    record("separation", None, t_sep, z)
                    return finish(_classify(z[2], z[3], dps), t_sep, z)
            P = mpmath.expm(M * h)
            t_start, z_start = t, z.copy()
            k = 0
            hit = None
            while hit is None:
                if horizon == "monotone":
                    if z[2] - z[3] < 0:
                        segments.append((t_start, mpmath.inf, M, z_start))
                        return finish("no_separation", math.inf, None)
                elif k * h > horizon or t_start + k * h > t_cap:
                    if sliding or horizon == mpmath.inf:
                        raise RuntimeError("no event before t_cap = %s" % t_cap)
                    segments.append((t_start, mpmath.inf, M, z_start))
                    return finish("no_separation", math.inf, None)
                z_next = P * z
                g_now = [_dot(c, z) for _, _, c in evs]
                g_next = [_dot(c, z_next) for _, _, c in evs]
                fired = [j for j in range(len(evs)) if g_now[j] > 0 and g_next[j] <= 0]
                if fired:
                    zk = z.copy()

                    def gfun(tau, c):
                        return _dot(c, mpmath.expm(M * tau) * zk)
                    roots = []
                    for j in fired:
                        c = evs[j][2]
                        roots.append((_bracket_root(lambda tau: gfun(tau, c), mpmath.mpf(0), h), j))
                    tau, j = min(roots)
                    hit = (tau, j, zk)
                else:
                    z = z_next
                    k += 1
            tau, j, zk = hit
            t_event = t_start + k * h + tau
            z = mpmath.expm(M * tau) * zk
            segments.append((t_start, t_event, M, z_start))
            t = t_event
            kind, i, _ = evs[j]
            if kind == "separation":
                z[0] = mpmath.mpf(0)
                record("separation", None, t, z)
                return finish(_classify(z[2], z[3], dps), t, z)
            if kind == "stop":
                z[2 + i] = mpmath.mpf(0)
                if z[0] > eta[i]:
                    modes[i] = -1 if i == 0 else 1  # slide along the spring force
                    record("reverse", i, t, z)
                else:
                    modes[i] = _STICK
                    record("stick", i, t, z)
            else:  # slip
                modes[i] = -1 if i == 0 else 1
                record("slip", i, t, z)


def reference_state_n2(result, t):
    """State ``(x1, x2, v1, v2)`` at time ``t`` of a :func:`reference_collision_n2` result.

    Parameters
    ----------
    result : dict
        Output of :func:`reference_collision_n2`.
    t : float or mpf
        Scaled time, ``0 <= t <= t_separation``.

    Returns
    -------
    tuple of mpf
    """
    with mpmath.workdps(result["dps"] + 10):
        t = mpmath.mpf(t)
        for t0, t1, M, z0 in result["segments"]:
            if t0 <= t <= t1:
                z = mpmath.expm(M * (t - t0)) * z0
                return (+(z[1] + z[0]) / 2, +(z[1] - z[0]) / 2, +z[2], +z[3])
    raise ValueError("t outside the computed contact interval")
