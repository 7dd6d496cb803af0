"""simulate(scene) -> Result: the driver that runs compiled chunks between output frames.

Python only runs between chunks: it records frames, checks the state for
NaN/Inf at the output cadence, updates the progress bar and decides when to
stop. The chunks themselves are compiled kernels (:mod:`.steppers.verlet`).
"""

from __future__ import annotations

import math
import sys
import time
from typing import Optional, Union

import numpy as np

from ._compile import specialised
from .budget import check_budget
from .forces import net_forces
from .laws.friction import drift_tables
from .model import Model, build_model
from .result import OVERLAP_ADVICE, EnergyLedger, Result, Status
from .scene import Scene
from .steppers import verlet
from .units import scaled_parameters

__all__ = ["simulate", "SimulationError", "default_dt", "check_dt"]

# Velocity Verlet on a linear contact of period T is unstable for dt > T/pi.
_STABILITY_FRACTION = 1.0 / math.pi
_DEFAULT_STEPS_PER_PERIOD = 200
_DEFAULT_FRAMES = 1000
_DEFAULT_FRAME_VALUES = 10_000_000  # per recorded array (x, v, f): 80 MB each
_UNSTABLE_BALANCE = 1.0
_KERNEL_PY = getattr(verlet.verlet_chunk, "py_func", verlet.verlet_chunk)  # NUMBA_DISABLE_JIT
_KERNEL_ARGS = _KERNEL_PY.__code__.co_varnames[:_KERNEL_PY.__code__.co_argcount]


class SimulationError(ValueError):
    """A run refused before it started (with the field to change and the limit)."""


def default_dt(model: Model, t_end: float = math.inf) -> float:
    """1/200 of the shortest contact period (or collision time), at most t_end/100,
    shortened so that a whole number of steps ends exactly at a finite t_end."""
    T = model.shortest_period()
    dt = T / _DEFAULT_STEPS_PER_PERIOD if math.isfinite(T) else 1e-2
    dt = min(dt, t_end / 100)
    if math.isfinite(t_end):
        dt = t_end / math.ceil(t_end / dt * (1 - 1e-12))
    return dt


def check_dt(model: Model, dt: float) -> None:
    """Refuse a Verlet step the stiffest contact cannot take (SimulationError names run.dt)."""
    T = model.shortest_period()
    if math.isfinite(T) and dt > _STABILITY_FRACTION * T:
        raise SimulationError(
            f"run.dt: {dt:g} is too large for the stiffest contact (period or collision "
            f"time {T:.4g}): velocity Verlet is unstable above {T / math.pi:.4g}; "
            f"use dt <= {T / 50:.3g} for accuracy")


def _drift_coefficients(model: Model, dt: float):
    cv = model.gamma * model.inv_mass
    E, P1, P2 = np.empty_like(cv), np.empty_like(cv), np.empty_like(cv)
    drift_tables(cv, dt, E, P1, P2)
    return E, P1, P2


class _Frames:
    """Growing lists of output frames (converted to arrays once at the end)."""

    def __init__(self):
        self.t, self.x, self.v, self.f = [], [], [], []
        self.ke, self.pe, self.dc, self.dv = [], [], [], []

    def record(self, t, x, v, f, ke, pe, dc, dv):
        self.t.append(t)
        self.x.append(x.copy())
        self.v.append(v.copy())
        self.f.append(f.copy())
        self.ke.append(ke)
        self.pe.append(pe)
        self.dc.append(dc)
        self.dv.append(dv)


def _net_forces(model: Model, u, c, f):
    feat = model.features
    args = (feat.law, int(feat.left_wall), int(feat.right_wall), u, model.d0, model.k,
            model.n, model.walls, c, f)
    specialised(net_forces, args, (0, 1, 2))(*args)


def simulate(scene: Union[Scene, Model], *, progress: Optional[bool] = None,
             run=None) -> Result:
    """Run a scene and return its :class:`Result`.

    Parameters
    ----------
    scene : Scene
        A validated scene (see :func:`granular_chain.load_scene`).
    progress : bool, optional
        Show a progress bar (default: only on a terminal, for runs longer than ~2 s).

    Returns
    -------
    Result
        Never contains NaN: a run whose state turns non-finite stops with
        ``Status.NONFINITE`` at its last finite frame.

    Raises
    ------
    SimulationError
        The run cannot start (for example dt too large for the stiffest contact).
    """
    model = check_budget(scene).model  # refuses, before allocating, what cannot run
    settings = scene.run
    if settings.stepper == "event":
        from .steppers.events import simulate_events  # the event stepper (issue 3)
        result = simulate_events(scene, model)
    else:
        result = _simulate_verlet(scene, model, progress)
    warning = next_neighbour_overlap(result.t, result.x, model.radius)
    if warning:
        result.info.setdefault("warnings", []).append(warning)
    return result


def next_neighbour_overlap(t, x, radius) -> str:
    """Warn when granules i and i+2 overlapped at some frame, or ''.

    The model has contacts between neighbours i, i+1 only (as the paper's chain).
    Once the overlaps of contacts i and i+1 together exceed granule i+1's
    diameter, the spheres i and i+2 overlap too; a 3D DEM code (LAMMPS, checked:
    benchmarks/results/lammps.md) counts that contact and this model does not,
    so from then on the two disagree. Not an error (scaled scenes, such as the
    benchmark chain struck at v = 1 with k = 1, reach it by design); checked at
    the recorded frames only.

    Parameters
    ----------
    t : ndarray, shape (F,)
        Frame times.
    x : ndarray, shape (F, N)
        Centre positions at the frames.
    radius : ndarray, shape (N,)
        Radii.
    """
    if x.shape[1] < 3 or x.shape[0] == 0:
        return ""
    reach = radius[:-2] + radius[2:]
    for q in range(x.shape[0]):  # frame by frame: stops at the first, no (F, N) temporary
        gap = x[q, 2:] - x[q, :-2]
        bad = np.flatnonzero(gap < reach)
        if bad.size:
            i = int(bad[0])
            return (f"granules {i} and {i + 2} overlap at t = {t[q]:.6g} (first recorded frame; "
                    f"{bad.size} such pairs): the overlaps of contacts {i} and {i + 1} exceed "
                    f"granule {i + 1}'s diameter. The model has nearest-neighbour contacts "
                    f"only, so it ignores that contact (a 3D DEM code would not): raise "
                    f"contacts.stiffness or lower the velocities if it matters")
    return ""


def _simulate_verlet(scene: Scene, model: Model, progress: Optional[bool]) -> Result:
    settings = scene.run
    feat = model.features
    N = model.count
    T = model.shortest_period()
    dt = settings.dt if settings.dt is not None else default_dt(model, settings.t_end)
    if settings.check_dt:
        check_dt(model, dt)
    t_end = settings.t_end
    n_total = int(math.ceil(t_end / dt * (1 - 1e-12)))
    limited = n_total > settings.max_steps
    n_total = min(n_total, settings.max_steps)
    out = scene.output
    if out.every is not None:
        every = out.every
    elif out.dt is not None:
        every = max(1, int(round(out.dt / dt)))
    else:
        # About 1000 frames, fewer for long chains: the frames are kept in memory.
        frames_wanted = max(2, min(_DEFAULT_FRAMES, _DEFAULT_FRAME_VALUES // max(N, 1)))
        every = max(1, n_total // frames_wanted)

    stops = settings.stop_conditions
    stop_mode = (verlet.STOP_ON_SEPARATION if "separation" in stops else 0) | (
        verlet.STOP_ON_REST if "rest" in stops else 0)
    stop_contact = settings.stop_contact if N > 1 else 0

    u = np.zeros(N)
    v = model.v0.copy()
    f = np.zeros(N)
    c = np.zeros(max(N - 1, 1))
    _net_forces(model, u, c, f)
    active = (c[: max(N - 1, 0)] > 0).astype(np.uint8)
    if active.size == 0:
        active = np.zeros(1, dtype=np.uint8)
    E, P1, P2 = _drift_coefficients(model, dt)
    ledger = np.zeros(2)
    counts = np.zeros(4, dtype=np.int64)
    # With Coulomb friction the kernel merges kicks (leapfrog form) and v holds
    # half-step velocities between chunks; vs gets the synchronised ones for the
    # frames, and sync the half kick's work and counts that the ledger and the
    # counts lack at the frame's time.
    merged = bool(feat.coulomb)
    vs = np.empty(N) if merged else v
    sync = (0.0, 0, 0)

    limits = _overlap_limits(model)
    frames = _Frames()
    ke0, pe0 = model.energies(u, v)
    e0 = ke0 + pe0
    frames.record(0.0, model.x0 + u, v, f, ke0, pe0, 0.0, 0.0)

    bar = _progress_bar(progress, n_total)
    status = Status.T_END
    message = ""
    steps = 0
    t_now = 0.0
    start = time.perf_counter()
    args = [feat.law, int(feat.coulomb), int(feat.viscous), int(feat.left_wall),
            int(feat.right_wall), stop_mode, _uniform_code(model, feat, E, P1, P2),
            u, v, f, active, model.d0, model.k, model.n, model.walls, model.mass,
            model.inv_mass, model.eta, model.eta_static, E, P1, P2, dt, 0, 1, stop_contact,
            ledger, counts,
            *_overlap_caps(model)]
    kernel = specialised(verlet.verlet_chunk, tuple(args), (0, 1, 2, 3, 4, 5, 6))
    n_steps_at = _KERNEL_ARGS.index("n_steps")
    opening_at = _KERNEL_ARGS.index("opening")
    try:
        while steps < n_total:
            args[n_steps_at] = min(every, n_total - steps)
            taken, code = kernel(*args)
            if taken == 0:  # a chunk always advances; guard against an endless loop
                raise RuntimeError("internal error: the Verlet kernel took no step")
            args[opening_at] = 0
            if merged:
                sync = verlet.synchronise(v, f, model.eta, model.eta_static, model.inv_mass,
                                          0.5 * dt, vs)
                if stop_mode & verlet.STOP_ON_REST and code == verlet.RAN_CHUNK and not vs.any():
                    # at rest at the chunk's end (the kernel reads rest off the kick
                    # after the time it holds, i.e. the next chunk's first step)
                    code = verlet.AT_REST
            steps += taken
            t_now = steps * dt
            if bar is not None:
                bar.update(taken)
                bar.set_postfix_str(f"t = {t_now:.4g} / {t_end:g}", refresh=False)
            if not (np.all(np.isfinite(u)) and np.all(np.isfinite(vs))):
                bad = int(np.flatnonzero(~(np.isfinite(u) & np.isfinite(vs)))[0])
                status = Status.NONFINITE
                message = (f"non-finite state by t = {t_now:.6g} at granule {bad}: the step "
                           f"dt = {dt:g} is likely too large for the stiffest contact "
                           f"(period or collision time {T:.4g}); reduce run.dt")
                break
            if code == verlet.SEPARATED:
                t_now = _backtrack_to_separation(model, u, vs, f, ledger, stop_contact, dt, t_now)
                status = Status.SEPARATED
                message = (f"contact {stop_contact} opened at t = {t_now:.12g} (located "
                           f"inside the step by a second-order backtrack)")
            elif code == verlet.AT_REST:
                status = Status.AT_REST
                message = f"every granule at rest (held by static friction) at t = {t_now:.12g}"
            problem = _overlap_problem(model, u, limits)
            if problem:
                status = Status.OVERLAP
                message = f"{problem} at t = {t_now:.6g}; " + OVERLAP_ADVICE
                if math.isfinite(T) and dt > _STABILITY_FRACTION * T:
                    message += (f"; or reduce run.dt: {dt:g} exceeds the stability limit "
                                f"{_STABILITY_FRACTION * T:.4g} (run.check_dt is off)")
                break
            ke, pe = model.energies(u, vs)
            coulomb_work = ledger[0] - sync[0]
            balance = abs(ke + pe + coulomb_work + ledger[1] - e0)
            if e0 > 0 and not balance <= _UNSTABLE_BALANCE * e0:
                # A stable run balances its ledger to O(dt^2); an error as large
                # as the initial energy itself means the integration blew up.
                status = Status.UNSTABLE
                message = (f"energy ledger off by {balance / e0:.3g} x the initial energy at "
                           f"t = {t_now:.6g}: the integration is unstable; reduce run.dt "
                           f"(now {dt:g}; stiffest contact time {T:.4g})")
                break
            frames.record(t_now, model.x0 + u, vs, f, ke, pe, coulomb_work, ledger[1])
            if code != verlet.RAN_CHUNK:
                break
        else:
            if limited:
                status = Status.MAX_STEPS
                message = (f"stopped after run.max_steps = {settings.max_steps} steps at "
                           f"t = {t_now:.6g} before t_end = {t_end:g}; raise run.max_steps "
                           f"or run.dt")
            else:
                message = f"reached t_end = {t_now:.12g} after {steps} steps"
    finally:
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - start
    counts[verlet.EV_STOP] += sync[1]
    counts[verlet.EV_SLIP] += sync[2]
    return _assemble(frames, model, e0, status, message, steps, wall, dt, counts)




def _uniform_code(model: Model, feat, E, P1, P2) -> int:
    """Kernel feature code: verlet.UNIFORM when every granule has the same
    parameters and every contact the same (d0, k, n), so the single sweep reads
    scalars and streams only u, v, f; verlet.UNIT when moreover m = k = 1 and
    d0 = 0 (the scaled touching chain), compiled in as constants. Only the sweep
    (scenes without Coulomb friction) uses it; PER_GRANULE otherwise, so that
    Coulomb scenes do not compile a second, identical specialisation."""
    if feat.coulomb:
        return verlet.PER_GRANULE
    arrays = (model.mass, model.inv_mass, E, P1, P2, model.d0, model.k, model.n)
    if not all(a.size == 0 or bool(np.all(a == a[0])) for a in arrays):
        return verlet.PER_GRANULE
    unit = all(a.size == 0 or a[0] == value
               for a, value in ((model.mass, 1.0), (model.k, 1.0), (model.d0, 0.0)))
    return verlet.UNIT if unit and model.count > 1 else verlet.UNIFORM


def _overlap_limits(model: Model):
    """Overlaps at which centres meet: r_i + r_(i+1) for contacts, r for a wall's granule."""
    r = model.radius
    return r[:-1] + r[1:], r[0], r[-1]


def _overlap_caps(model: Model):
    """Kernel form of the limits: olim (N + 1,) (left wall, contacts, right wall)
    and the smallest contact force at which a contact reaches its limit."""
    lim, left, right = _overlap_limits(model)
    olim = np.concatenate(([left], lim, [right]))
    with np.errstate(over="ignore"):
        f_at = model.k * lim ** (model.n - 1.0)
    fcap = float(np.min(f_at)) if f_at.size else math.inf
    return olim, fcap


def _overlap_problem(model: Model, u, limits) -> str:
    """Describe the first contact whose granules have passed each other, or ''.

    Checked at the output cadence. An overlap of r_i + r_(i+1) puts two centres
    on top of each other: beyond it the granules are in the wrong order (a
    crossing between two frames leaves them so), and the one-sided contact
    model no longer describes the scene.
    """
    lim, left, right = limits
    if model.count > 1:
        delta = model.d0 + u[:-1] - u[1:]
        bad = np.flatnonzero(delta >= lim)
        if bad.size:
            i = int(bad[0])
            return (f"contact {i} overlaps by {delta[i]:.4g}, not less than the sum of the "
                    f"radii {lim[i]:.4g}")
    w = model.walls
    if model.features.left_wall and w[0] - u[0] >= left:
        return f"granule 0 overlaps the left wall by {w[0] - u[0]:.4g}, more than its radius"
    if model.features.right_wall and w[3] + u[-1] >= right:
        return (f"granule {model.count - 1} overlaps the right wall by {w[3] + u[-1]:.4g}, "
                f"more than its radius")
    return ""


def _backtrack_to_separation(model, u, v, f, ledger, i, dt, t_now):
    """Move the state back from the end of the step to the moment contact i opened.

    After opening, the overlap falls linearly at the relative speed to first
    order, so the opening happened tau = -delta / (v_(i+1) - v_i) ago (clamped
    to the step). Each granule is moved back along its acceleration at the end
    of the step (spring, Coulomb and viscous), a second-order Taylor step, and
    the friction work done in tau is taken off the ledger.
    """
    delta = model.d0[i] + u[i] - u[i + 1]
    w = v[i + 1] - v[i]
    tau = 0.0 if w <= 0 else min(max(-delta / w, 0.0), dt)
    if tau == 0.0:
        return t_now
    s = np.sign(v)
    acc = (f - model.eta * s - model.gamma * v) * model.inv_mass
    acc[v == 0.0] = 0.0  # a granule at rest at the end of the step was stuck during tau
    ledger[0] -= tau * float(np.dot(model.eta, np.abs(v)))
    ledger[1] -= tau * float(np.dot(model.gamma, v * v))
    u -= tau * v - 0.5 * tau * tau * acc
    v -= tau * acc
    _net_forces(model, u, np.zeros(max(model.count - 1, 1)), f)
    return t_now - tau


def _progress_bar(progress: Optional[bool], total: int):
    if progress is False:
        return None
    if progress is None and not sys.stderr.isatty():
        return None
    from tqdm import tqdm
    return tqdm(total=total, desc="simulating", unit="step", unit_scale=True, mininterval=0.5, delay=2.0,
                file=sys.stderr, leave=False)


def _assemble(frames: _Frames, model: Model, e0, status, message, steps, wall, dt, counts):
    energy = EnergyLedger(
        kinetic=np.array(frames.ke), potential=np.array(frames.pe),
        coulomb=np.array(frames.dc), viscous=np.array(frames.dv), initial=e0)
    x = np.array(frames.x)
    v = np.array(frames.v)
    counts_d = dict(zip(verlet.EVENT_KINDS, (int(n) for n in counts)))
    info = {"features": model.features.describe(), "granules": model.count,
            "units": model.units}
    if model.units == "physical":
        info["scaled"] = scaled_parameters(model)
    return Result(
        t=np.array(frames.t), x=x, v=v, f=np.array(frames.f), energy=energy, status=status,
        message=message, steps=steps, wall_time=wall, stepper="verlet", dt=dt,
        t_final=float(frames.t[-1]), x_final=x[-1].copy(), v_final=v[-1].copy(),
        event_counts=counts_d, info=info)
