"""The paper's problem: two equal granules, the first striking the second.

Rosas, Buceta and Lindenberg, "Dynamics of Two Granules": scaled units
(Appendix A: m = 1, force coefficient 1, v0 = 1), granules just touching,
granule 1 arriving at v = 1, granule 2 at rest; kinetic friction ``eta_i`` (a
force) or hydrodynamic friction ``gamma_i`` on either. The collision ends at
the first loss of contact. This module is a thin layer over the general engine:
the problem is the engine's N = 2 scene (:func:`two_granule_scene`), run by
:func:`~granular_chain.simulate.simulate` or, for the event stepper, by a
cached :class:`~granular_chain.steppers.events.EventBatch` of it.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..codes import Status
from ..model import build_model, friction_features
from ..restitution import linear_dashpot
from ..result import Result
from ..scene import scene_from_dict
from ..simulate import simulate
from ..steppers.events import EventBatch, check_exponents
from ..steppers.verlet.timestep import NEAR_ONE_EXPONENT
from .outcomes import OUTCOMES, Outcome, outcome_code

__all__ = ["Collision", "collide", "classify", "two_granule_scene", "energy_ratio"]

# Speeds (scaled, v0 = 1) the event stepper cannot tell from rest: roundoff.
_EVENT_REST_TOL = 1e-14


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
        How the collision ended.
    message : str
        What happened, in words (the outcome, or why the run failed).
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


def _friction_pairs(eta, eta_static, gamma):
    """(eta, eta_static or None, gamma) as pairs of floats, as the scene receives them."""
    pair = lambda a: (float(a[0]), float(a[1]))  # noqa: E731
    return pair(eta), (None if eta_static is None else pair(eta_static)), pair(gamma)


def two_granule_scene(n: float = 2.0, eta=(0.0, 0.0), gamma=(0.0, 0.0), *,
                      stepper: str = "verlet", dt: Optional[float] = None,
                      eta_static=None, t_max: float = 1000.0, rtol: Optional[float] = None,
                      atol: Optional[float] = None) -> dict:
    """The scene mapping of the paper's problem (see :func:`collide`).

    Only displacements enter the scaled problem; the radius 1 keeps the overlap
    (which reaches 1 when granule 2 is held fast and granule 1 stops) below the
    sum of the radii, where the engine would refuse the scene as unphysical.

    Parameters
    ----------
    n : float
        Potential exponent (2 linear, 5/2 Hertz).
    eta : (float, float)
        Kinetic friction forces (eta1, eta2), scaled (units of ``m v0^2/A``).
    gamma : (float, float)
        Hydrodynamic friction coefficients (gamma1, gamma2), scaled (units of ``m/B``).
    stepper : {'verlet', 'event'}
        The stepper of the scene.
    dt : float, optional
        Verlet step, units of ``B`` (default 1/200 of the contact period).
    eta_static : (float, float), optional
        Static friction thresholds, scaled like ``eta`` (default equal to eta).
    t_max : float
        End time of the run, units of ``B``.
    rtol, atol : float, optional
        Event-stepper tolerances (relative, and absolute in scene units).

    Returns
    -------
    dict
        A scene mapping, as read from a scene file.
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
    eta, eta_static, gamma = _friction_pairs(eta, eta_static, gamma)
    friction = {"kinetic": list(eta), "viscous": list(gamma)}
    if eta_static is not None:
        friction["static"] = list(eta_static)
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
            rest_tol: Optional[float] = None, damping: Optional[dict] = None,
            tensile: bool = False) -> Collision:
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
        Which stepper runs the collision (event: exact for n = 2).
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
        dt^2 for Verlet, whose frictionless granule 1 ends at v1 = O(dt^2), and dt
        for it below n = 1.5, where it is first order (v1 about -0.3 dt at n = 1.01).
        Relative, so that a collision ending with both speeds tiny (near
        critical damping, ~1e-20) is still named by their signs.
    damping : mapping, optional
        The contact's dashpot, as the scene's ``contacts.damping``:
        ``{"model": "linear", "coefficient": c}``, ``{"model": "viscoelastic",
        "coefficient": A}`` or ``{"model": "restitution", "value": e}`` (n = 2).
        Absent: the paper's elastic contact.
    tensile : bool
        The scene's ``contacts.tensile``: False (default), the contact ends when
        its total force reaches zero; True, at overlap zero (it may pull before).

    Returns
    -------
    Collision
    """
    if stepper == "event" and damping is None:
        fast = _collide_batched(n, eta, gamma, dt, eta_static, t_max, rtol, atol, rest_tol)
        if fast is not None:
            return fast
    spec = two_granule_scene(n, eta, gamma, stepper=stepper, dt=dt, eta_static=eta_static,
                             t_max=t_max, rtol=rtol, atol=atol)
    never_opens = False
    if damping is not None:
        spec["contacts"]["damping"] = dict(damping)
        spec["contacts"]["tensile"] = bool(tensile)
        # (the steppers do not stop at the decaying overlap's roundoff-level "opening":
        # steppers/opening.py; the closed form names the reason in the message)
        never_opens = _never_opens(n, eta, gamma, damping, tensile)
    scene = scene_from_dict(spec, source="collide()")
    result = simulate(scene, progress=False)
    if never_opens and result.status.success:
        result.message += (f"; the contact never opens (tensile linear dashpot at damping "
                           f"ratio {_damping_ratio(damping):.4g} >= 1: "
                           f"restitution.linear_dashpot)")
    if rest_tol is None:
        event_rtol = scene.run.rtol if scene.run.stepper == "event" else None
        rest_tol = default_rest_tol(n, result.dt, event_rtol)
    return classify(result, rest_tol)


def _damping_ratio(damping) -> float:
    """Damping ratio c / (2 sqrt(k m_eff)) of the paper's contact (k = 1, m_eff = 1/2)."""
    return float(damping["coefficient"]) / (2.0 * math.sqrt(0.5))


def _never_opens(n, eta, gamma, damping, tensile) -> bool:
    """True when the engine's closed form (:func:`~granular_chain.restitution.linear_dashpot`)
    says the contact never opens: n = 2, no friction, a tensile linear dashpot at
    damping ratio >= 1 (the overlap decays to 0 without reaching it).

    Then the steppers' overlap, the difference of two positions of order 1, falls
    to roundoff after a few tens of relaxation times and may change sign there; an
    opening found then is roundoff, not the end of the collision.
    """
    frictionless = not any(float(a) for a in (*eta, *gamma))
    if not (tensile and float(n) == 2.0 and frictionless
            and damping.get("model") == "linear" and "coefficient" in damping):
        return False
    return not linear_dashpot(float(damping["coefficient"]), 1.0, 0.5, tensile=True).ended


def default_rest_tol(n, dt, rtol) -> float:
    """collide()'s default rest_tol: dt^2 (Verlet; dt below NEAR_ONE_EXPONENT, where it
    is first order: docs/verlet_convergence.md), 1e-14 (event, n = 2), else 100 rtol
    (``rtol`` the event stepper's; None for a Verlet run, which has none)."""
    if dt is not None:
        return dt if float(n) < NEAR_ONE_EXPONENT else dt ** 2
    if float(n) == 2.0:
        return _EVENT_REST_TOL
    return max(_EVENT_REST_TOL, 100 * rtol)


# Event-stepper batches of the two-granule scene, one per (n, options, friction
# features); per thread, since a batch's arrays are rewritten by every run.
_LOCAL = threading.local()
_MAX_BATCHES = 64


def event_batch(n, dt, t_max, rtol, atol, coulomb: bool, viscous: bool, friction):
    """The :class:`EventBatch` of the paper's scene for these options and friction
    features (validated, built and packed on first use), or None when the scene is
    not in the kernel's units (then every run goes the ordinary way).

    ``friction`` (eta, eta_static or None, gamma): a point with these features,
    used to build the scene the first time (the full scene validation runs on it).
    """
    key = (float(n), dt, float(t_max), rtol, atol, bool(coulomb), bool(viscous))
    cache = getattr(_LOCAL, "batches", None)
    if cache is None:
        cache = _LOCAL.batches = {}
    if key in cache:
        return cache[key]
    eta, eta_static, gamma = friction
    scene = scene_from_dict(
        two_granule_scene(n, eta, gamma, stepper="event", dt=dt, eta_static=eta_static,
                          t_max=t_max, rtol=rtol, atol=atol),
        source="collide()")
    model = build_model(scene)
    check_exponents(model)  # the event stepper's valid range of n, as simulate() checks it
    if (model.features.coulomb, model.features.viscous) != (coulomb, viscous):
        raise AssertionError("internal error: friction features of the template scene")
    try:
        batch = EventBatch(scene, model)
    except ValueError:  # the stepper runs this scene in internal units of its own
        batch = None
    if len(cache) >= _MAX_BATCHES:
        cache.clear()
    cache[key] = batch
    return batch


def _finite_non_negative(x: float) -> bool:
    return math.isfinite(x) and x >= 0.0


def _collide_batched(n, eta, gamma, dt, eta_static, t_max, rtol, atol, rest_tol):
    """collide() with the event stepper through a cached :class:`EventBatch`: the
    scene is validated and packed once per (n, options, friction features), so a
    call costs the kernel, the Result and the classification. Returns None when
    the ordinary path must run: friction values the scene would refuse (it then
    raises its SceneError), a hashing problem with the options, or a scene
    outside the kernel's units."""
    kinetic, static, viscous = _friction_pairs(eta, eta_static, gamma)
    if not all(_finite_non_negative(x) for x in kinetic + viscous + (static or ())):
        return None
    if static is not None and (static[0] < kinetic[0] or static[1] < kinetic[1]):
        return None
    point = (np.array([kinetic]), np.array([static if static is not None else kinetic]),
             np.array([viscous]))
    has_coulomb, has_viscous = friction_features(*point)
    try:
        batch = event_batch(n, dt, t_max, rtol, atol, has_coulomb[0], has_viscous[0],
                            (kinetic, static, viscous))
    except TypeError:  # unhashable option values: let the ordinary path judge them
        return None
    if batch is None:
        return None
    result = batch.result(batch.run(*point))
    if rest_tol is None:
        rest_tol = default_rest_tol(n, None, batch.scene.run.rtol)
    return classify(result, rest_tol)


def classify(result: Result, rest_tol: float = 0.0) -> Collision:
    """Turn the engine's result of the two-granule scene into a :class:`Collision`.

    A granule is at rest when ``|v| <= rest_tol * max(|v1|, |v2|)``; the
    velocities reported are the engine's, unrounded.

    Parameters
    ----------
    result : Result
        The engine's result of :func:`two_granule_scene`.
    rest_tol : float
        A granule is at rest when ``|v| <= rest_tol * max(|v1|, |v2|)`` (dimensionless).

    Returns
    -------
    Collision
        Velocities, energy ratio, separation time and outcome.
    """
    v1, v2 = (float(a) for a in result.v_final)
    e = result.energy
    ratio = energy_ratio(float(e.kinetic[-1]), float(e.potential[-1]), e.initial)
    code = outcome_code(int(result.status), v1, v2, float(rest_tol))
    if code < 0:
        raise RuntimeError(f"the collision run failed: {result.message}")
    outcome = OUTCOMES[code]
    if result.status == Status.SEPARATED:
        t_sep = float(result.t_final)
        message = f"{outcome.name}: {outcome.value} (separated at t = {t_sep:.12g})"
    else:
        t_sep = math.inf
        message = f"{outcome.name}: {outcome.value} ({result.message})"
    return Collision(v1=v1, v2=v2, energy_ratio=ratio, t_separation=t_sep, outcome=outcome,
                     message=message, result=result)


def energy_ratio(kinetic, potential, initial):
    """E/E0 at the end: (kinetic + elastic) over the initial energy (arrays or floats).

    Parameters
    ----------
    kinetic, potential : float or ndarray
        Final kinetic and elastic energies (scene units).
    initial : float or ndarray
        Initial energy (same units).

    Returns
    -------
    float or ndarray
        E/E0, dimensionless.
    """
    return (kinetic + potential) / initial
