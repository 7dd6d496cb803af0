"""The paper's problem: two equal granules, the first striking the second.

Rosas, Buceta and Lindenberg, "Dynamics of Two Granules": scaled units
(Appendix A: m = 1, force coefficient 1, v0 = 1), granules just touching,
granule 1 arriving at v = 1, granule 2 at rest; kinetic friction ``eta_i`` (a
force) or hydrodynamic friction ``gamma_i`` on either. The collision ends at
the first loss of contact. This module is a thin layer over the general engine:
the problem is the engine's N = 2 scene.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from typing import Optional

from .result import Result, Status
from .scene import scene_from_dict
from .simulate import simulate

__all__ = ["Outcome", "Collision", "collide", "two_granule_scene"]

# Speeds (scaled, v0 = 1) the event stepper cannot tell from rest: roundoff.
_EVENT_REST_TOL = 1e-14


class Outcome(enum.Enum):
    """How a two-granule collision ends (``.name`` is the public contract)."""

    backscatter_and_propagation = "granule 1 moves back and granule 2 forward"
    propagation_only = "granule 1 at rest, granule 2 moves forward"
    backscatter_only = "granule 1 moves back, granule 2 at rest"
    both_forward = "both granules move forward"
    stuck = "both granules held by static friction while still compressed: the collision never ends"
    no_separation = "overdamped: the overlap decays without ever reaching zero"


@dataclass(frozen=True)
class Collision:
    """The end of a two-granule collision (scaled units).

    Attributes
    ----------
    v1, v2 : float
        Velocities at the first loss of contact (at the end of the run if the
        granules never separate).
    energy_ratio : float
        E/E0: total (kinetic plus elastic) energy then over the initial 1/2.
    t_separation : float
        Time of the first loss of contact, ``math.inf`` if it never happens.
    outcome : Outcome
    message : str
    result : Result
        The engine's full result (trajectory, ledger, events).
    """

    v1: float
    v2: float
    energy_ratio: float
    t_separation: float
    outcome: Outcome
    message: str
    result: Result


def two_granule_scene(n: float = 2.0, eta=(0.0, 0.0), gamma=(0.0, 0.0), *,
                      stepper: str = "verlet", dt: Optional[float] = None,
                      eta_static=None, t_max: float = 1000.0, rtol: Optional[float] = None,
                      atol: Optional[float] = None) -> dict:
    """The scene mapping of the paper's problem (see :func:`collide`).

    Only displacements enter the scaled problem; the radius 1 keeps the overlap
    (which reaches 1 when granule 2 is held fast and granule 1 stops) below the
    sum of the radii, where the engine would refuse the scene as unphysical.
    """
    # Stop at separation (the collision ends) or when both granules are at rest:
    # with Coulomb friction a collision that sticks while compressed is a fixed
    # point, and waiting for t_max would only cost time.
    run = {"stepper": stepper, "t_end": t_max, "stop": ["separation", "rest"],
           "stop_contact": 0}
    if dt is not None:
        run["dt"] = dt
    if rtol is not None:
        run["rtol"] = rtol
    if atol is not None:
        run["atol"] = atol
    friction = {"kinetic": [float(eta[0]), float(eta[1])],
                "viscous": [float(gamma[0]), float(gamma[1])]}
    if eta_static is not None:
        friction["static"] = [float(eta_static[0]), float(eta_static[1])]
    return {
        "name": "two_granules",
        "granules": {"count": 2, "mass": 1.0, "radius": 1.0, "gap": 0.0,
                     "velocity": [1.0, 0.0], "friction": friction},
        "contacts": {"exponent": float(n), "stiffness": 1.0},
        "run": run,
        "output": {"every": 1_000_000_000, "trajectory": False},
    }


def collide(n: float = 2, eta=(0.0, 0.0), gamma=(0.0, 0.0), stepper: str = "verlet",
            dt: Optional[float] = None, *, eta_static=None, t_max: float = 1000.0,
            rtol: Optional[float] = None, atol: Optional[float] = None,
            rest_tol: Optional[float] = None) -> Collision:
    """Collide two granules as in the paper and classify the outcome.

    Parameters
    ----------
    n : float
        Potential exponent (2 linear, 5/2 Hertz).
    eta : (float, float)
        Kinetic friction forces (eta1, eta2) in scaled units.
    gamma : (float, float)
        Hydrodynamic friction coefficients (gamma1, gamma2) in scaled units.
    stepper : {'verlet', 'event'}
    dt : float, optional
        Verlet step (default 1/200 of the contact period).
    eta_static : (float, float), optional
        Static thresholds (default equal to eta).
    t_max : float
        Give up waiting for separation after this time; the outcome is then
        ``stuck`` (both at rest, compressed) or ``no_separation``.
    rtol, atol : float, optional
        Event-stepper tolerances (n != 2).
    rest_tol : float, optional
        Speed below which a granule counts as at rest when naming the outcome.
        Relative to the faster granule: a granule is at rest when
        ``|v| <= rest_tol * max(|v1|, |v2|)`` (a stuck granule is exactly at
        rest). Default: 1e-14 for the event stepper at n = 2 (a frictionless
        granule 1 ends at roundoff instead of 0), 100 rtol for it at other n,
        dt^2 for Verlet, whose frictionless granule 1 ends at v1 = O(dt^2).
        Relative, so that a collision ending with both speeds tiny (near
        critical damping, ~1e-20) is still named by their signs.

    Returns
    -------
    Collision
    """
    scene = scene_from_dict(
        two_granule_scene(n, eta, gamma, stepper=stepper, dt=dt, eta_static=eta_static,
                          t_max=t_max, rtol=rtol, atol=atol),
        source="collide()")
    result = simulate(scene, progress=False)
    if rest_tol is None:
        if result.dt is not None:
            rest_tol = result.dt ** 2
        elif float(n) == 2.0:
            rest_tol = _EVENT_REST_TOL
        else:
            rest_tol = max(_EVENT_REST_TOL, 100 * scene.run.rtol)
    return classify(result, rest_tol)


def classify(result: Result, rest_tol: float = 0.0) -> Collision:
    """Turn the engine's result of the two-granule scene into a :class:`Collision`.

    A granule is at rest when ``|v| <= rest_tol * max(|v1|, |v2|)``; the
    velocities reported are the engine's, unrounded.
    """
    v1, v2 = (float(a) for a in result.v_final)
    scale = max(abs(v1), abs(v2))
    r1 = 0.0 if abs(v1) <= rest_tol * scale else v1
    r2 = 0.0 if abs(v2) <= rest_tol * scale else v2
    e = result.energy
    ratio = (float(e.kinetic[-1]) + float(e.potential[-1])) / e.initial
    if result.status == Status.SEPARATED:
        t_sep = float(result.t_final)
        if r1 < 0.0 and r2 > 0.0:
            outcome = Outcome.backscatter_and_propagation
        elif r1 == 0.0 and r2 > 0.0:
            outcome = Outcome.propagation_only
        elif r1 < 0.0 and r2 == 0.0:
            outcome = Outcome.backscatter_only
        elif r1 > 0.0 and r2 > 0.0:
            outcome = Outcome.both_forward
        else:
            # Separated with neither moving: only at exactly zero overlap.
            outcome = Outcome.stuck
        message = f"{outcome.name}: {outcome.value} (separated at t = {t_sep:.12g})"
    elif result.status in (Status.T_END, Status.AT_REST):
        t_sep = math.inf
        if r1 == 0.0 and r2 == 0.0 and result.status == Status.AT_REST:
            outcome = Outcome.stuck
        else:
            outcome = Outcome.no_separation
        message = f"{outcome.name}: {outcome.value} ({result.message})"
    else:
        raise RuntimeError(f"the collision run failed: {result.message}")
    return Collision(v1=v1, v2=v2, energy_ratio=ratio, t_separation=t_sep, outcome=outcome,
                     message=message, result=result)
