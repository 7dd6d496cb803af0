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
import multiprocessing
import os
import threading
import time
from dataclasses import dataclass
from typing import Optional

import numba
import numpy as np

from .model import build_model, friction_features
from .result import Result, Status
from .scene import scene_from_dict
from .simulate import simulate
from .interrupts import stop_signals
from .steppers.events import CODE_STATUS, EventBatch, _scales

__all__ = ["Outcome", "OUTCOMES", "Collision", "CollisionMap", "collide", "collision_map",
           "classify", "two_granule_scene"]

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


#: Outcome codes of :class:`CollisionMap`: code i is ``OUTCOMES[i]`` (= ``list(Outcome)[i]``),
#: -1 a failed run (see its status).
OUTCOMES = tuple(Outcome)
_OC = {o: i for i, o in enumerate(OUTCOMES)}
_BOTH, _PROP, _BACK, _FWD, _STUCK, _NOSEP = (_OC[o] for o in (
    Outcome.backscatter_and_propagation, Outcome.propagation_only, Outcome.backscatter_only,
    Outcome.both_forward, Outcome.stuck, Outcome.no_separation))
_SEPARATED, _T_END, _AT_REST = int(Status.SEPARATED), int(Status.T_END), int(Status.AT_REST)


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


def _friction(eta, eta_static, gamma):
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
    eta, eta_static, gamma = _friction(eta, eta_static, gamma)
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
    if stepper == "event":
        fast = _collide_batched(n, eta, gamma, dt, eta_static, t_max, rtol, atol, rest_tol)
        if fast is not None:
            return fast
    scene = scene_from_dict(
        two_granule_scene(n, eta, gamma, stepper=stepper, dt=dt, eta_static=eta_static,
                          t_max=t_max, rtol=rtol, atol=atol),
        source="collide()")
    result = simulate(scene, progress=False)
    if rest_tol is None:
        rest_tol = _default_rest_tol(n, result.dt, scene.run.rtol)
    return classify(result, rest_tol)


def _default_rest_tol(n, dt, rtol) -> float:
    """collide()'s default rest_tol: dt^2 (Verlet), 1e-14 (event, n = 2), else 100 rtol."""
    if dt is not None:
        return dt ** 2
    if float(n) == 2.0:
        return _EVENT_REST_TOL
    return max(_EVENT_REST_TOL, 100 * rtol)


# Event-stepper batches of the two-granule scene, one per (n, options, friction
# features); per thread, since a batch's arrays are rewritten by every run.
_LOCAL = threading.local()
_MAX_BATCHES = 64


def _batch(n, dt, t_max, rtol, atol, coulomb: bool, viscous: bool, friction):
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
    if (model.features.coulomb, model.features.viscous) != (coulomb, viscous):
        raise AssertionError("internal error: friction features of the template scene")
    batch = EventBatch(scene, model) if _scales(model) is None else None
    if len(cache) >= _MAX_BATCHES:
        cache.clear()
    cache[key] = batch
    return batch


def _plain(x: float) -> bool:
    return math.isfinite(x) and x >= 0.0


def _collide_batched(n, eta, gamma, dt, eta_static, t_max, rtol, atol, rest_tol):
    """collide() with the event stepper through a cached :class:`EventBatch`: the
    scene is validated and packed once per (n, options, friction features), so a
    call costs the kernel, the Result and the classification. Returns None when
    the ordinary path must run: friction values the scene would refuse (it then
    raises its SceneError), a hashing problem with the options, or a scene
    outside the kernel's units."""
    e, s, g = _friction(eta, eta_static, gamma)
    if not all(_plain(x) for x in e + g + (s or ())):
        return None
    if s is not None and (s[0] < e[0] or s[1] < e[1]):
        return None
    pts = np.array([e]), np.array([s if s is not None else e]), np.array([g])
    coulomb, viscous = friction_features(*pts)
    try:
        batch = _batch(n, dt, t_max, rtol, atol, coulomb[0], viscous[0], (e, s, g))
    except TypeError:  # unhashable option values: let the ordinary path judge them
        return None
    if batch is None:
        return None
    result = batch.result(batch.run(*pts))
    if rest_tol is None:
        rest_tol = _default_rest_tol(n, None, batch.scene.run.rtol)
    return classify(result, rest_tol)


def classify(result: Result, rest_tol: float = 0.0) -> Collision:
    """Turn the engine's result of the two-granule scene into a :class:`Collision`.

    A granule is at rest when ``|v| <= rest_tol * max(|v1|, |v2|)``; the
    velocities reported are the engine's, unrounded.
    """
    v1, v2 = (float(a) for a in result.v_final)
    e = result.energy
    ratio = _energy_ratio(float(e.kinetic[-1]), float(e.potential[-1]), e.initial)
    code = _outcome_code(int(result.status), v1, v2, float(rest_tol))
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


def _energy_ratio(kinetic, potential, initial):
    """E/E0 at the end: (kinetic + elastic) over the initial energy (arrays or floats)."""
    return (kinetic + potential) / initial


@numba.njit(cache=True)
def _outcome_code(status, v1, v2, rest_tol):
    """Index into OUTCOMES of a run that ended with ``status`` (a Status value) and
    velocities v1, v2; -1 for a failed run. A granule is at rest when
    ``|v| <= rest_tol * max(|v1|, |v2|)``."""
    scale = max(abs(v1), abs(v2))
    r1 = 0.0 if abs(v1) <= rest_tol * scale else v1
    r2 = 0.0 if abs(v2) <= rest_tol * scale else v2
    if status == _SEPARATED:
        if r1 < 0.0 and r2 > 0.0:
            return _BOTH
        if r1 == 0.0 and r2 > 0.0:
            return _PROP
        if r1 < 0.0 and r2 == 0.0:
            return _BACK
        if r1 > 0.0 and r2 > 0.0:
            return _FWD
        # Separated with neither moving: only at exactly zero overlap.
        return _STUCK
    if status == _T_END or status == _AT_REST:
        if r1 == 0.0 and r2 == 0.0 and status == _AT_REST:
            return _STUCK
        return _NOSEP
    return -1


@numba.njit(cache=True)
def _outcome_codes(status, v, rest_tol, out):
    for p in range(status.size):
        out[p] = _outcome_code(status[p], v[p, 0], v[p, 1], rest_tol)


# ----------------------------------------------------------------------------
# Maps: many collisions over (eta1, eta2) (and gamma), one call
# ----------------------------------------------------------------------------
@dataclass(frozen=True)
class CollisionMap:
    """Collisions over a grid of friction values (event stepper, scaled units).

    Every array has the broadcast shape of the inputs; point by point the
    numbers are bitwise those of ``collide(n, eta=(eta1, eta2), gamma=(gamma1,
    gamma2), stepper="event", ...)``.

    Attributes
    ----------
    v1, v2, energy_ratio, t_separation : ndarray of float
        As :class:`Collision` (``t_separation`` inf if the granules never
        separate). NaN exactly where the run failed (``status < 0``).
    outcome : ndarray of int8
        Index into :data:`OUTCOMES` (``list(Outcome)``): 0
        backscatter_and_propagation, 1 propagation_only, 2 backscatter_only,
        3 both_forward, 4 stuck, 5 no_separation; -1 where the run failed.
    status : ndarray of int8
        The engine's :class:`~granular_chain.result.Status` value of each run
        (``Status(int(m.status[i]))``); negative = the run failed (collide()
        would raise RuntimeError there).
    t_stop1, t_stop2 : ndarray of float
        Time of the first stop event of granule 1 / 2 (held by static
        friction), NaN if it never stops.
    wall_time : float
        Seconds for the whole call.
    workers : int
        Processes used.
    """

    v1: np.ndarray
    v2: np.ndarray
    energy_ratio: np.ndarray
    t_separation: np.ndarray
    outcome: np.ndarray
    status: np.ndarray
    t_stop1: np.ndarray
    t_stop2: np.ndarray
    wall_time: float
    workers: int

    def outcomes(self) -> np.ndarray:
        """The outcome codes as an object array of :class:`Outcome` (None where failed)."""
        table = np.array(list(OUTCOMES) + [None], dtype=object)
        return table[self.outcome]

    @property
    def failed(self) -> np.ndarray:
        """Boolean mask of the failed runs (status < 0)."""
        return self.status < 0


# Inherited by the fork workers of collision_map: (batches, per-group point arrays).
_MAP_WORK: dict = {}


def _map_task(task):
    gkey, lo, hi = task
    batch, eta, eta_s, gamma = _MAP_WORK[gkey]
    out = batch.run(eta[lo:hi], eta_s[lo:hi], gamma[lo:hi])
    return (lo, hi, out.code, out.t_final, out.v_final, out.kinetic, out.potential,
            out.initial, out.t_stop)


def _check_friction(name, a):
    bad = ~(np.isfinite(a) & (a >= 0))
    if bad.any():
        i = np.unravel_index(int(np.flatnonzero(bad)[0]), a.shape)
        raise ValueError(f"collision_map: {name} must be finite and >= 0; got {a[i]!r} at "
                         f"index {tuple(int(k) for k in i)}")


def collision_map(eta1, eta2, n: float = 2.0, gamma=(0.0, 0.0), *, eta_static=None,
                  rtol: Optional[float] = None, atol: Optional[float] = None,
                  t_max: float = 1000.0, rest_tol: Optional[float] = None,
                  workers: Optional[int] = None) -> CollisionMap:
    """Collide two granules (event stepper) at every point of a friction grid.

    The scene is validated and packed once per friction feature set (Coulomb
    and viscous friction present or not); each point then only resets the
    kernel's state, sets its friction and runs the compiled kernel, in a
    compiled loop (:class:`~granular_chain.steppers.events.EventBatch`).
    Point by point the result is bitwise that of :func:`collide` with
    ``stepper="event"`` and the same options (same rest tolerance rule).

    Parameters
    ----------
    eta1, eta2 : array_like
        Kinetic friction forces of granules 1 and 2 (scaled), broadcast together.
    n : float
        Potential exponent.
    gamma : (array_like, array_like)
        Hydrodynamic friction (gamma1, gamma2): scalars or arrays broadcasting
        with eta1, eta2.
    eta_static : (array_like, array_like), optional
        Static thresholds (default equal to eta), broadcasting likewise.
    rtol, atol, t_max, rest_tol
        As :func:`collide`.
    workers : int, optional
        Processes (``fork``; the parent's compiled kernels are inherited). Default:
        every available core for maps of 20 000 points or more, else 1.

    Returns
    -------
    CollisionMap

    Raises
    ------
    ValueError
        Inputs that do not broadcast together, negative or non-finite friction,
        a static threshold below the kinetic friction, or options the scene refuses.
    """
    start = time.perf_counter()
    for name, pair in (("gamma", gamma), ("eta_static", eta_static)):
        if pair is not None and not (isinstance(pair, (tuple, list)) and len(pair) == 2):
            raise ValueError(f"collision_map: {name} must be a pair ({name}1, {name}2) of "
                             f"numbers or arrays, got {type(pair).__name__}")
    names = ["eta1", "eta2", "gamma[0]", "gamma[1]"]
    inputs = [eta1, eta2, gamma[0], gamma[1]]
    if eta_static is not None:
        names += ["eta_static[0]", "eta_static[1]"]
        inputs += [eta_static[0], eta_static[1]]
    try:
        arrays = [np.asarray(a, dtype=np.float64) for a in inputs]
    except (TypeError, ValueError) as exc:
        raise ValueError(f"collision_map: friction values must be numbers ({exc})") from None
    try:
        arrays = np.broadcast_arrays(*arrays)
    except ValueError:
        shapes = ", ".join(f"{nm} {a.shape}" for nm, a in zip(names, arrays))
        raise ValueError(f"collision_map: the friction arrays do not broadcast to one shape: "
                         f"{shapes}") from None
    for nm, a in zip(names, arrays):
        _check_friction(nm, a)
    shape = arrays[0].shape
    M = arrays[0].size
    eta = np.stack([arrays[0].ravel(), arrays[1].ravel()], axis=1)
    gam = np.stack([arrays[2].ravel(), arrays[3].ravel()], axis=1)
    if eta_static is not None:
        eta_s = np.stack([arrays[4].ravel(), arrays[5].ravel()], axis=1)
        below = eta_s < eta
        if below.any():
            p, i = (int(k) for k in np.argwhere(below)[0])
            raise ValueError(f"collision_map: eta_static[{i}] = {eta_s[p, i]!r} is below the "
                             f"kinetic friction eta{i + 1} = {eta[p, i]!r} at index "
                             f"{tuple(int(k) for k in np.unravel_index(p, shape))}")
    else:
        eta_s = eta.copy()
    if workers is None:
        try:
            cores = len(os.sched_getaffinity(0))
        except AttributeError:  # pragma: no cover - not Linux
            cores = os.cpu_count() or 1
        workers = cores if M >= 20_000 else 1
    workers = max(1, int(workers))
    if workers > 1 and "fork" not in multiprocessing.get_all_start_methods():
        workers = 1  # pragma: no cover

    code = np.zeros(M, dtype=np.int64)
    t_fin = np.zeros(M)
    v = np.zeros((M, 2))
    ke, pe, e0 = np.zeros(M), np.zeros(M), np.ones(M)
    t_stop = np.zeros((M, 2))
    coulomb, viscous = friction_features(eta, eta_s, gam)
    groups = {}
    slow = []
    rtol_run = None
    for c in (False, True):
        for vis in (False, True):
            idx = np.flatnonzero((coulomb == c) & (viscous == vis))
            if idx.size == 0:
                continue
            p = int(idx[0])
            friction = (tuple(eta[p]), None if eta_static is None else tuple(eta_s[p]),
                        tuple(gam[p]))
            batch = _batch(n, None, t_max, rtol, atol, c, vis, friction)
            if batch is None:
                slow.extend(idx.tolist())
                continue
            rtol_run = batch.scene.run.rtol
            groups[(c, vis)] = (batch, np.ascontiguousarray(eta[idx]),
                                np.ascontiguousarray(eta_s[idx]), np.ascontiguousarray(gam[idx]),
                                idx)

    # Tasks: row blocks of each group, enough of them that both workers stay busy.
    size = max(2000, -(-M // (workers * 16))) if workers > 1 else M
    tasks = [(g, lo, min(lo + size, len(w[4]))) for g, w in groups.items()
             for lo in range(0, len(w[4]), size)]
    _MAP_WORK.clear()
    _MAP_WORK.update({g: w[:4] for g, w in groups.items()})
    try:
        if workers > 1 and len(tasks) > 1:
            with multiprocessing.get_context("fork").Pool(min(workers, len(tasks))) as pool:
                parts = [(t[0],) + r for t, r in zip(tasks, pool.map(_map_task, tasks,
                                                                    chunksize=1))]
        else:
            # one stop request for every task: after SIGINT/SIGTERM the tasks left
            # return at once with their points marked INTERRUPTED
            with stop_signals():
                parts = [(t[0],) + _map_task(t) for t in tasks]
    finally:
        _MAP_WORK.clear()
    for g, lo, hi, c_, t_, v_, ke_, pe_, e0_, ts_ in parts:
        idx = groups[g][4][lo:hi]
        code[idx], t_fin[idx], v[idx], ke[idx], pe[idx], e0[idx], t_stop[idx] = (
            c_, t_, v_, ke_, pe_, e0_, ts_)

    status = np.zeros(M, dtype=np.int8)
    for kc, st in CODE_STATUS.items():
        status[code == kc] = int(st)
    # A scene outside the kernel's units (not the paper's scene): the ordinary way.
    for p in slow:
        scene = scene_from_dict(
            two_granule_scene(n, eta[p], gam[p], stepper="event",
                              eta_static=None if eta_static is None else eta_s[p],
                              t_max=t_max, rtol=rtol, atol=atol), source="collision_map()")
        r = simulate(scene, progress=False)
        rtol_run = scene.run.rtol
        status[p] = int(r.status)
        t_fin[p] = r.t_final
        v[p] = r.v_final
        ke[p], pe[p], e0[p] = r.energy.kinetic[-1], r.energy.potential[-1], r.energy.initial
        for i in (0, 1):
            s_ = [e.t for e in r.events if e.kind == "stop" and e.index == i]
            t_stop[p, i] = s_[0] if s_ else math.nan

    if rest_tol is None:
        rest_tol = _default_rest_tol(n, None, rtol_run if rtol_run is not None else 1e-12)
    outcome = np.zeros(M, dtype=np.int64)
    _outcome_codes(status.astype(np.int64), v, float(rest_tol), outcome)
    failed = outcome < 0
    ratio = _energy_ratio(ke, pe, e0)
    t_sep = np.where(status == _SEPARATED, t_fin, math.inf)
    for a in (v[:, 0], v[:, 1], ratio, t_sep):
        a[failed] = math.nan
    v1 = np.ascontiguousarray(v[:, 0])
    v2 = np.ascontiguousarray(v[:, 1])
    return CollisionMap(
        v1=v1.reshape(shape), v2=v2.reshape(shape), energy_ratio=ratio.reshape(shape),
        t_separation=t_sep.reshape(shape), outcome=outcome.astype(np.int8).reshape(shape),
        status=status.reshape(shape), t_stop1=np.ascontiguousarray(t_stop[:, 0]).reshape(shape),
        t_stop2=np.ascontiguousarray(t_stop[:, 1]).reshape(shape),
        wall_time=time.perf_counter() - start, workers=workers)
