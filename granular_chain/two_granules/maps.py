"""Maps: many two-granule collisions over a grid of friction values, one call.

The scene is validated and packed once per friction feature set (Coulomb and
viscous friction present or not); each point then only resets the event
kernel's state, sets its friction and runs, in a compiled loop
(:class:`~granular_chain.steppers.events.EventBatch`), on a ``fork`` process
pool for large maps.
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing
import os
import time
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..codes import Status
from ..interrupts import held_signals, pool_worker_signals, stop_signals
from ..model import friction_features
from ..scene import scene_from_dict
from ..simulate import simulate
from .outcomes import OUTCOMES, outcome_codes
from .problem import default_rest_tol, energy_ratio, event_batch, two_granule_scene

__all__ = ["CollisionMap", "collision_map"]


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
        Index into :data:`~granular_chain.two_granules.OUTCOMES` (``list(Outcome)``): 0
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
        """The outcome codes as an object array of :class:`Outcome` (None where failed).

        Returns
        -------
        ndarray of object
            Same shape as ``outcome``.
        """
        table = np.array(list(OUTCOMES) + [None], dtype=object)
        return table[self.outcome]

    @property
    def failed(self) -> np.ndarray:
        """Boolean mask of the failed runs (status < 0)."""
        return self.status < 0


# Inherited by the fork workers of collision_map: group key -> (batch, eta, eta_static,
# gamma) of the group's points.
_MAP_WORK: dict = {}


def _map_task(task):
    """Run the points lo .. hi-1 of one group: their end state, as arrays."""
    group, lo, hi = task
    batch, eta, eta_static, gamma = _MAP_WORK[group]
    out = batch.run(eta[lo:hi], eta_static[lo:hi], gamma[lo:hi])
    return (lo, hi, out.code, out.t_final, out.v_final, out.kinetic, out.potential,
            out.initial, out.t_stop)


def _status_values(batch_codes: np.ndarray) -> np.ndarray:
    """The :class:`~granular_chain.codes.Status` value of each run of an event batch
    (the batch returns them as they are), shape (M,), int8."""
    return np.asarray(batch_codes).astype(np.int8)


def _check_friction(name, values):
    bad = ~(np.isfinite(values) & (values >= 0))
    if bad.any():
        i = np.unravel_index(int(np.flatnonzero(bad)[0]), values.shape)
        raise ValueError(f"collision_map: {name} must be finite and >= 0; got {values[i]!r} at "
                         f"index {tuple(int(k) for k in i)}")


def _friction_points(eta1, eta2, gamma, eta_static):
    """The friction of every point, validated: (shape, eta, eta_static, gamma), the
    last three of shape (M, 2) (eta_static a copy of eta when not given)."""
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
    eta = np.stack([arrays[0].ravel(), arrays[1].ravel()], axis=1)
    gam = np.stack([arrays[2].ravel(), arrays[3].ravel()], axis=1)
    if eta_static is None:
        return shape, eta, eta.copy(), gam
    eta_s = np.stack([arrays[4].ravel(), arrays[5].ravel()], axis=1)
    below = eta_s < eta
    if below.any():
        p, i = (int(k) for k in np.argwhere(below)[0])
        raise ValueError(f"collision_map: eta_static[{i}] = {eta_s[p, i]!r} is below the "
                         f"kinetic friction eta{i + 1} = {eta[p, i]!r} at index "
                         f"{tuple(int(k) for k in np.unravel_index(p, shape))}")
    return shape, eta, eta_s, gam


def _worker_count(workers, points: int) -> int:
    """Processes for a map of ``points`` points (default: every core from 20 000 on)."""
    if workers is None:
        try:
            cores = len(os.sched_getaffinity(0))
        except AttributeError:  # pragma: no cover - not Linux
            cores = os.cpu_count() or 1
        workers = cores if points >= 20_000 else 1
    workers = max(1, int(workers))
    if workers > 1 and "fork" not in multiprocessing.get_all_start_methods():
        workers = 1  # pragma: no cover
    return workers


def _feature_groups(n, eta, eta_s, gam, static_given, t_max, rtol, atol):
    """The points grouped by friction features, each group with its event batch:
    ({(coulomb, viscous): (batch, eta, eta_s, gamma, indices)}, indices of the points
    whose scene the batch cannot run, the run's rtol or None)."""
    coulomb, viscous = friction_features(eta, eta_s, gam)
    groups, slow, rtol_run = {}, [], None
    for has_coulomb in (False, True):
        for has_viscous in (False, True):
            idx = np.flatnonzero((coulomb == has_coulomb) & (viscous == has_viscous))
            if idx.size == 0:
                continue
            p = int(idx[0])
            friction = (tuple(eta[p]), tuple(eta_s[p]) if static_given else None, tuple(gam[p]))
            batch = event_batch(n, None, t_max, rtol, atol, has_coulomb, has_viscous, friction)
            if batch is None:
                slow.extend(idx.tolist())
                continue
            rtol_run = batch.scene.run.rtol
            groups[(has_coulomb, has_viscous)] = (
                batch, np.ascontiguousarray(eta[idx]), np.ascontiguousarray(eta_s[idx]),
                np.ascontiguousarray(gam[idx]), idx)
    return groups, slow, rtol_run


def _run_groups(groups, workers, ends):
    """Run every group's points (row blocks, on a fork pool when workers > 1) and
    store their end state into ``ends`` (dict of (M, ...) arrays, by point index)."""
    size = max(2000, -(-ends["code"].size // (workers * 16))) if workers > 1 else ends["code"].size
    tasks = [(g, lo, min(lo + size, len(w[4]))) for g, w in groups.items()
             for lo in range(0, len(w[4]), size)]
    _MAP_WORK.clear()
    _MAP_WORK.update({g: w[:4] for g, w in groups.items()})
    try:
        if workers > 1 and len(tasks) > 1:
            with contextlib.ExitStack() as stack:
                # a signal while the pool starts acts once the pool is in the block that
                # ends it (terminate): one cut into Pool() left its workers running,
                # and a replacement the pool forked meanwhile orphaned
                with held_signals():
                    pool = stack.enter_context(multiprocessing.get_context("fork").Pool(
                        min(workers, len(tasks)), initializer=pool_worker_signals))
                parts = [(t[0],) + r for t, r in zip(tasks, pool.map(_map_task, tasks,
                                                                    chunksize=1))]
        else:
            # one stop request for every task: after SIGINT/SIGTERM the tasks left
            # return at once with their points marked INTERRUPTED
            with stop_signals():
                parts = [(t[0],) + _map_task(t) for t in tasks]
    finally:
        _MAP_WORK.clear()
    keys = ("code", "t_final", "v", "kinetic", "potential", "initial", "t_stop")
    for group, lo, hi, *values in parts:
        idx = groups[group][4][lo:hi]
        for key, value in zip(keys, values):
            ends[key][idx] = value


def _run_slow_points(points, n, eta, eta_s, gam, static_given, t_max, rtol, atol, ends):
    """Points whose scene is outside the kernel's units: run the ordinary way
    (scene -> simulate). Stores Status values into ``ends["status"]``; returns
    the run's rtol or None."""
    rtol_run = None
    for p in points:
        scene = scene_from_dict(
            two_granule_scene(n, eta[p], gam[p], stepper="event",
                              eta_static=eta_s[p] if static_given else None,
                              t_max=t_max, rtol=rtol, atol=atol), source="collision_map()")
        r = simulate(scene, progress=False)
        rtol_run = scene.run.rtol
        ends["status"][p] = int(r.status)
        ends["t_final"][p] = r.t_final
        ends["v"][p] = r.v_final
        ends["kinetic"][p] = r.energy.kinetic[-1]
        ends["potential"][p] = r.energy.potential[-1]
        ends["initial"][p] = r.energy.initial
        for i in (0, 1):
            stops = [e.t for e in r.events if e.kind == "stop" and e.index == i]
            ends["t_stop"][p, i] = stops[0] if stops else math.nan
    return rtol_run


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
    shape, eta, eta_s, gam = _friction_points(eta1, eta2, gamma, eta_static)
    M = eta.shape[0]
    workers = _worker_count(workers, M)
    ends = {"code": np.zeros(M, dtype=np.int64), "t_final": np.zeros(M), "v": np.zeros((M, 2)),
            "kinetic": np.zeros(M), "potential": np.zeros(M), "initial": np.ones(M),
            "t_stop": np.zeros((M, 2))}
    static_given = eta_static is not None
    groups, slow, rtol_run = _feature_groups(n, eta, eta_s, gam, static_given, t_max, rtol, atol)
    _run_groups(groups, workers, ends)
    ends["status"] = _status_values(ends["code"])
    rtol_slow = _run_slow_points(slow, n, eta, eta_s, gam, static_given, t_max, rtol, atol, ends)
    rtol_run = rtol_slow if rtol_slow is not None else rtol_run
    if rest_tol is None:
        rest_tol = default_rest_tol(n, None, rtol_run if rtol_run is not None else 1e-12)
    status, v = ends["status"], ends["v"]
    outcome = np.zeros(M, dtype=np.int64)
    outcome_codes(status.astype(np.int64), v, float(rest_tol), outcome)
    failed = outcome < 0
    ratio = energy_ratio(ends["kinetic"], ends["potential"], ends["initial"])
    t_sep = np.where(status == int(Status.SEPARATED), ends["t_final"], math.inf)
    for a in (v[:, 0], v[:, 1], ratio, t_sep):
        a[failed] = math.nan
    column = lambda a, i: np.ascontiguousarray(a[:, i]).reshape(shape)  # noqa: E731
    return CollisionMap(
        v1=column(v, 0), v2=column(v, 1), energy_ratio=ratio.reshape(shape),
        t_separation=t_sep.reshape(shape), outcome=outcome.astype(np.int8).reshape(shape),
        status=status.reshape(shape), t_stop1=column(ends["t_stop"], 0),
        t_stop2=column(ends["t_stop"], 1), wall_time=time.perf_counter() - start,
        workers=workers)
