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

import math

import numpy as np

__all__ = ["scales", "scaled_parameters", "scaled_coulomb", "scaled_viscous"]


def scales(m: float, k: float, n: float, v0: float) -> tuple[float, float]:
    """Length scale A and time scale B of Appendix A (A in metres, B in seconds for SI input)."""
    if v0 <= 0:
        raise ValueError("the reference speed v0 must be positive")
    A = (m * v0 * v0 / k) ** (1.0 / n)
    return A, A / v0


def scaled_parameters(model) -> dict:
    """The scene's friction expressed in the paper's scaled units.

    The reference mass is granule 0's, the force coefficient and exponent
    those of contact 0 (or the left wall for N = 1), and v0 the largest initial
    speed. Returns a JSON-ready dict with A, B and the scaled eta, gamma.
    """
    if model.count > 1:
        k, n = float(model.k[0]), float(model.n[0])
    else:
        k, n = float(model.walls[1] or 1.0), float(model.walls[2] or 2.0)
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


# ----------------------------------------------------------------------------
# Friction in scaled units, one parameter at a time (also the paper module's
# Appendix A, granular_chain.paper.contact_and_scaling)
# ----------------------------------------------------------------------------
def scaled_coulomb(eta: float, m: float, v0: float, A: float) -> float:
    """Kinetic friction *force* ``eta`` in scaled units: ``eta A / (m v0^2)``."""
    return eta * A / (m * v0 * v0)


def scaled_viscous(gamma: float, m: float, v0: float, A: float) -> float:
    """Viscous coefficient ``gamma`` (force / speed) in scaled units: ``gamma A / (m v0)``."""
    return gamma * A / (m * v0)
