"""Physical <-> scaled units, after the paper's Appendix A.

With a reference mass ``m``, force coefficient ``k`` (force = k y^(n-1)) and
impact speed ``v0``, the length and time scales are::

    A = (m v0^2 / k)^(1/n),      B = A / v0,

and the scaled friction parameters are (Appendix A; ``eta`` is a *force*,
``mu g m`` in the paper's notation)::

    eta_scaled   = eta * A / (m v0^2),
    gamma_scaled = gamma * A / (m v0).

A scaled scene (m = 1, k = 1, v0 = 1) has A = B = 1.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple, Optional

import numpy as np

from .laws.damping import DAMPING_LINEAR, dashpot_rate
from .laws.wall_motion import WALL_PULSE, WALL_SINE, WALL_VELOCITY

__all__ = ["scales", "scaled_parameters", "scaled_coulomb", "scaled_viscous", "speed_scale",
           "internal_scales", "scaled_model", "scaled_wall_motion", "UnitFactors", "unit_factors"]


def scales(m: float, k: float, n: float, v0: float) -> tuple[float, float]:
    """Length scale A and time scale B of Appendix A (A in metres, B in seconds for SI input).

    Parameters
    ----------
    m : float
        Reference mass (kg for SI input).
    k : float
        Force coefficient, force = k y^(n-1) (N/m^(n-1) for SI input).
    n : float
        Potential exponent (force = k y^(n-1)), dimensionless; 5/2 for Hertz.
    v0 : float
        Reference (impact) speed, > 0 (m/s for SI input).

    Returns
    -------
    tuple of float
        ``(A, B)``: length scale (units of length of the input) and time scale
        ``A / v0``.

    Raises
    ------
    ValueError
        When ``v0`` is not positive.
    """
    if v0 <= 0:
        raise ValueError("the reference speed v0 must be positive")
    A = (m * v0 * v0 / k) ** (1.0 / n)
    return A, A / v0


def scaled_parameters(model) -> dict:
    """The scene's friction expressed in the paper's scaled units.

    The reference mass is granule 0's, the force coefficient and exponent
    those of contact 0 (or the left wall for N = 1), and v0 the largest initial
    speed. Returns a JSON-ready dict with A, B and the scaled eta, gamma.

    Parameters
    ----------
    model : Model
        The compiled scene (:class:`granular_chain.model.Model`), scene units.

    Returns
    -------
    dict
        ``reference`` (mass, stiffness, exponent, v0), ``length_scale_A``,
        ``time_scale_B`` (scene units) and the lists ``eta_scaled``,
        ``gamma_scaled`` (dimensionless), or ``{"note": ...}`` when every
        granule starts at rest.
    """
    t = model.contacts
    if model.count > 1:
        k, n = float(t.k[1]), float(t.n[1])
    else:
        k, n = float(t.k[0] or 1.0), float(t.n[0] or 2.0)
    m = float(model.mass[0])
    v0 = float(np.max(np.abs(model.v0)))
    if v0 == 0.0:
        return {"note": "all granules start at rest: no impact speed to scale by"}
    A, B = scales(m, k, n, v0)
    return {
        "reference": {"mass": m, "stiffness": k, "exponent": n, "v0": v0},
        "length_scale_A": A,
        "time_scale_B": B,
        "eta_scaled": [scaled_coulomb(float(e), m, v0, A) for e in model.eta],
        "gamma_scaled": [scaled_viscous(float(g), m, v0, A) for g in model.gamma],
    }


def speed_scale(model) -> float:
    """Speed scale of a scene: the larger of the speed a granule of mass m_0 would
    have with the most energetic granule's kinetic energy and the one it would have
    with the initial elastic energy (a precompressed scene starting at rest or at a
    tiny speed is scaled by the motion it will have).

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.

    Returns
    -------
    float
        Speed scale V, scene units of speed (0 when nothing moves or is
        compressed).
    """
    M = float(model.mass[0])
    V = float(np.max(np.abs(model.v0) * np.sqrt(model.mass / M)))
    pe0 = model.energies(np.zeros(model.count), model.v0)[1]
    return max(V, math.sqrt(2.0 * pe0 / M))


def internal_scales(model) -> Optional[tuple[float, float, float]]:
    """Mass, length and time scales (M, A, B) in which a stepper with absolute
    tolerances (the event stepper) runs a scene, or None to run it as given.

    Appendix A's scales with the reference mass m_0, the first contact's (or
    wall's) force coefficient K0 and exponent n0, and the speed scale V
    (:func:`speed_scale`), written as ``A = (M/K0)^(1/n0) V^(2/n0)`` so that no
    factor underflows for tiny speeds. A drag or a kinetic friction stopping
    the motion far faster than the collision (tiny speeds make B huge) sets the
    time scale instead: a series in units of B would overflow. None when the
    scene is already scaled, nothing sets a scale, or the scales themselves
    would lose their digits (speeds near 1e-300: such a scene hardly moves).

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.

    Returns
    -------
    tuple of float or None
        ``(M, A, B)``: mass, length and time scales in scene units, or None.
    """
    M = float(model.mass[0])
    rows = model.contacts.rows()  # the first neighbour contact, else a wall
    if rows.size == 0:
        return None
    K0, n0 = float(model.contacts.k[rows[0]]), float(model.contacts.n[rows[0]])
    V = speed_scale(model)
    if V == 0.0:
        return None
    A = (M / K0) ** (1.0 / n0) * V ** (2.0 / n0)
    B = (M / K0) ** (1.0 / n0) * V ** (2.0 / n0 - 1.0)
    rate = max(float(np.max(model.gamma * model.inv_mass)) * B,
               float(np.max(model.eta * model.inv_mass)) * B / V,
               dashpot_rate(model) * B)
    if rate > 1e3:
        B /= rate
        A /= rate
    if M == 1.0 and A == 1.0 and B == 1.0:
        return None
    # (short-circuit: a rate that overflowed to inf leaves B = 0, and A / B must not be formed)
    if not (1e-100 < A < 1e100 and 1e-100 < B < 1e100 and 1e-100 < A / B < 1e100):
        return None
    return M, A, B


def scaled_model(model, M: float, A: float, B: float):
    """The Model in units of mass M, length A and time B.

    Force coefficients ``k A^n / (F A)`` with ``F = M A / B^2`` the force scale are
    written as ``k A^(n-2) B^2 / M`` and ``1/F`` as ``(B/M)(B/A)``, so that no factor
    underflows for tiny speeds (A ~ 1e-300 at v = 1e-300).

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.
    M : float
        Mass scale, scene units of mass.
    A : float
        Length scale, scene units of length.
    B : float
        Time scale, scene units of time.

    Returns
    -------
    Model
        A copy of ``model`` with every dimensional field divided by its scale.
    """
    inv_F = (B / M) * (B / A)
    # A linear dashpot c is a mass/time like gamma; a viscoelastic A is a time.
    dashpot = (B / M) if model.features.damping == DAMPING_LINEAR else (1.0 / B)
    return dataclasses.replace(
        model, mass=model.mass / M, inv_mass=model.inv_mass * M, radius=model.radius / A,
        x0=model.x0 / A, v0=model.v0 * (B / A), contacts=_scaled_contacts(model, M, A, B, dashpot),
        eta=model.eta * inv_F, eta_static=model.eta_static * inv_F, gamma=model.gamma * (B / M),
        body_force=model.body_force * inv_F)


def _scaled_contacts(model, M: float, A: float, B: float, dashpot: float):
    """The contact table in units of mass M, length A and time B (``dashpot``: the
    factor of a dashpot coefficient). The walls' coefficients are formed as
    ``k A^(n-2) B B / M`` one factor at a time, the neighbour contacts' as
    ``k A^(n-2) (B B / M)``: two roundings that have always been so, kept so that
    scaled runs keep their bits."""
    t, N = model.contacts, model.count
    k = np.empty(N + 1)
    k[1:N] = t.between_granules(t.k) * A ** (t.between_granules(t.n) - 2.0) * (B * B / M)
    for j in (0, N):
        k[j] = t.k[j] * A ** (t.n[j] - 2.0) * B * B / M
    return dataclasses.replace(t, d0=t.d0 / A, k=k, damping=t.damping * dashpot,
                               wall_motion=scaled_wall_motion(t.wall_motion, A, B))


def scaled_wall_motion(motion: np.ndarray, A: float, B: float) -> np.ndarray:
    """Wall motions (kind, p1, p2), shape (2, 3), in units of length A and time B:
    velocities by B/A, an amplitude by 1/A, a frequency by B, a duration by 1/B.

    Parameters
    ----------
    motion : numpy.ndarray
        Shape (2, 3): rows left, right wall; columns kind code, p1, p2 in
        scene units (speed; amplitude and frequency; speed and duration).
    A : float
        Length scale, scene units of length.
    B : float
        Time scale, scene units of time.

    Returns
    -------
    numpy.ndarray
        Shape (2, 3), the same motions in units of A and B (a copy).
    """
    out = motion.copy()
    for j in range(2):
        kind = int(motion[j, 0])
        if kind == WALL_VELOCITY:
            out[j, 1] *= B / A
        elif kind == WALL_SINE:
            out[j, 1] /= A
            out[j, 2] *= B
        elif kind == WALL_PULSE:
            out[j, 1] *= B / A
            out[j, 2] /= B
    return out


class UnitFactors(NamedTuple):
    """Factors from internal units (mass M, length A, time B) to the scene's."""

    t: float  #: time, B
    x: float  #: length, A
    v: float  #: speed, A / B
    f: float  #: force, M A / B^2
    e: float  #: energy, M A^2 / B^2


def unit_factors(M: float, A: float, B: float) -> UnitFactors:
    """The :class:`UnitFactors` of the internal units (M, A, B).

    Parameters
    ----------
    M : float
        Mass scale, scene units of mass.
    A : float
        Length scale, scene units of length.
    B : float
        Time scale, scene units of time.

    Returns
    -------
    UnitFactors
        Multipliers taking time, length, speed, force and energy from internal
        units to scene units.
    """
    return UnitFactors(B, A, A / B, M * A / (B * B), M * A * A / (B * B))


# ----------------------------------------------------------------------------
# Friction in scaled units, one parameter at a time (also the paper module's
# Appendix A, granular_chain.paper.contact_and_scaling)
# ----------------------------------------------------------------------------
def scaled_coulomb(eta: float, m: float, v0: float, A: float) -> float:
    """Kinetic friction *force* ``eta`` in scaled units: ``eta A / (m v0^2)``.

    Parameters
    ----------
    eta : float
        Kinetic friction force (N for SI input).
    m : float
        Reference mass (kg for SI input).
    v0 : float
        Reference speed (m/s for SI input).
    A : float
        Length scale from :func:`scales` (m for SI input).

    Returns
    -------
    float
        Scaled friction force, dimensionless.
    """
    return eta * A / (m * v0 * v0)


def scaled_viscous(gamma: float, m: float, v0: float, A: float) -> float:
    """Viscous coefficient ``gamma`` (force / speed) in scaled units: ``gamma A / (m v0)``.

    Parameters
    ----------
    gamma : float
        Viscous coefficient, force / speed (kg/s for SI input).
    m : float
        Reference mass (kg for SI input).
    v0 : float
        Reference speed (m/s for SI input).
    A : float
        Length scale from :func:`scales` (m for SI input).

    Returns
    -------
    float
        Scaled viscous coefficient, dimensionless.
    """
    return gamma * A / (m * v0)
