"""The Verlet step: its default, its stability limit and its accuracy bound.

The default is a fixed fraction of the shortest contact period or collision
time T (``model.shortest_period()``), shortened for dashpots and driven walls
(:func:`.forced_setup.forced_dt_limit`) and so that whole steps end at t_end.
Velocity Verlet on a linear contact of period T is stable for dt < T/pi; the
accuracy bound (T/50, and with linear dashpots m_eff/(40 c)) is where the energy
ledger stays trustworthy (docs/verlet_convergence.md).
"""

from __future__ import annotations

import math

from ...errors import SimulationError
from ...laws.damping import DAMPING_LINEAR, dashpot_rate
from ...model import Model
from ..schedule import StepPlan, plan_steps
from .forced_setup import forced_dt_limit, is_forced

__all__ = ["default_dt", "verlet_dt", "step_plan", "smallest_exponent", "check_dt", "accuracy_bound", "check_accuracy",
           "ACCURACY_STEPS_PER_PERIOD", "ACCURACY_STEPS_PER_RELAXATION", "NEAR_ONE_EXPONENT",
           "NEAR_ONE_STEPS_PER_PERIOD", "STABILITY_FRACTION"]

#: Velocity Verlet on a linear contact of period T is unstable for dt > T/pi.
STABILITY_FRACTION = 1.0 / math.pi
_DEFAULT_STEPS_PER_PERIOD = 200
#: Near n = 1 the force k delta^(n-1) is almost a step at contact and Verlet is
#: first order (docs/verlet_convergence.md): below NEAR_ONE_EXPONENT the default
#: step is 1/NEAR_ONE_STEPS_PER_PERIOD of the period (collide(1.01): ledger error
#: 2.2e-3 against 6.8e-3 at 1/200).
NEAR_ONE_EXPONENT = 1.5
NEAR_ONE_STEPS_PER_PERIOD = 800
#: The accuracy bound of run.dt: T / ACCURACY_STEPS_PER_PERIOD (T the shortest contact
#: period or collision time) and, with linear dashpots, m_eff / (c
#: ACCURACY_STEPS_PER_RELAXATION). Above it a run is refused unless
#: run.accept_inaccurate_dt (two_granules.yaml at dt = 0.5, 5.6 times the bound:
#: energy grows 6.4 %).
ACCURACY_STEPS_PER_PERIOD = 50
ACCURACY_STEPS_PER_RELAXATION = 40



def default_dt(model: Model, t_end: float = math.inf) -> float:
    """1/200 of the shortest contact period (or collision time; 1/800 when an
    exponent, walls' included, is below NEAR_ONE_EXPONENT), at most t_end/100,
    shortened so that a whole number of steps ends exactly at a finite t_end.
    With dashpots or a sine-driven wall, also at most what they allow
    (:func:`.forced_setup.forced_dt_limit`).

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.
    t_end : float
        End of the run, scene units of time (``inf``: no such bound).

    Returns
    -------
    float
        The step, scene units of time.
    """
    T = model.shortest_period()
    steps = (NEAR_ONE_STEPS_PER_PERIOD if smallest_exponent(model) < NEAR_ONE_EXPONENT
             else _DEFAULT_STEPS_PER_PERIOD)
    dt = T / steps if math.isfinite(T) else 1e-2
    if is_forced(model):
        dt = min(dt, forced_dt_limit(model))
    dt = min(dt, t_end / 100)
    if math.isfinite(t_end):
        dt = t_end / math.ceil(t_end / dt * (1 - 1e-12))
    return dt


def smallest_exponent(model: Model) -> float:
    """The smallest contact exponent n of the chain's contacts and walls (inf: none).

    Parameters
    ----------
    model : Model
        The compiled scene.

    Returns
    -------
    float
        Dimensionless.
    """
    t = model.contacts
    return min((float(x) for x in t.n[t.rows()]), default=math.inf)


def check_dt(model: Model, dt: float) -> None:
    """Refuse a Verlet step the stiffest contact, or the strongest linear dashpot,
    cannot take (SimulationError names run.dt).

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.
    dt : float
        The proposed step, scene units of time.

    Raises
    ------
    SimulationError
        When ``dt`` exceeds T/pi (T the shortest contact period or collision
        time) or, with linear dashpots, ``dt c / m_eff >= 2``.
    """
    T = model.shortest_period()
    if math.isfinite(T) and dt > STABILITY_FRACTION * T:
        raise SimulationError(
            f"run.dt: {dt:g} is too large for the stiffest contact (period or collision "
            f"time {T:.4g}): velocity Verlet is unstable above {T / math.pi:.4g}; "
            f"use dt <= {T / ACCURACY_STEPS_PER_PERIOD:.3g} for accuracy")
    rate = dashpot_rate(model) if is_forced(model) else 0.0
    if model.features.damping == DAMPING_LINEAR and dt * rate >= 2.0:
        raise SimulationError(
            f"run.dt: {dt:g} is too large for the strongest dashpot (relaxation time "
            f"m_eff/c = {1 / rate:.4g}): the step is unstable from 2 m_eff/c = {2 / rate:.4g} "
            f"on; use dt <= {1 / (ACCURACY_STEPS_PER_RELAXATION * rate):.3g} for accuracy")


def accuracy_bound(model: Model) -> tuple[float, str]:
    """The largest Verlet step run.dt may take without run.accept_inaccurate_dt.

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.

    Returns
    -------
    (float, str)
        The bound (scene units of time; ``inf`` when nothing bounds it) and what
        sets it, in words for a message.
    """
    T = model.shortest_period()
    bound, why = math.inf, ""
    if math.isfinite(T):
        bound = T / ACCURACY_STEPS_PER_PERIOD
        why = f"1/{ACCURACY_STEPS_PER_PERIOD} of the shortest contact time {T:.4g}"
    rate = dashpot_rate(model) if is_forced(model) else 0.0
    if model.features.damping == DAMPING_LINEAR and rate > 0.0:
        by_dashpot = 1.0 / (ACCURACY_STEPS_PER_RELAXATION * rate)
        if by_dashpot < bound:
            bound = by_dashpot
            why = (f"1/{ACCURACY_STEPS_PER_RELAXATION} of the strongest dashpot's relaxation "
                   f"time m_eff/c = {1 / rate:.4g}")
    return bound, why


def check_accuracy(model: Model, dt: float) -> None:
    """Refuse a Verlet step above :func:`accuracy_bound` (SimulationError naming run.dt).

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.
    dt : float
        The step the scene asks for, scene units of time.

    Raises
    ------
    SimulationError
        When ``dt`` exceeds the accuracy bound; the message gives the bound and
        run.accept_inaccurate_dt.
    """
    bound, why = accuracy_bound(model)
    if dt > bound:
        raise SimulationError(
            f"run.dt: {dt:g} is above the accuracy bound {bound:.3g} ({why}), where the "
            f"energy ledger is no longer trusted; use run.dt <= {bound:.3g}, or set "
            f"run.accept_inaccurate_dt: true to run it anyway")


def verlet_dt(scene, model: Model) -> float:
    """The Verlet step a scene asks for: ``run.dt``, or :func:`default_dt`.

    Parameters
    ----------
    scene : Scene
        Its ``run`` (dt, t_end).
    model : Model
        ``build_model(scene)``, scene units.

    Returns
    -------
    float
        Scene units of time (before output.dt's cadence may shorten it).
    """
    run = scene.run
    return run.dt if run.dt is not None else default_dt(model, run.t_end)


def step_plan(model: Model, scene) -> StepPlan:
    """The Verlet steps and frame cadence of a scene
    (:func:`~granular_chain.steppers.schedule.plan_steps` of :func:`verlet_dt`).

    Parameters
    ----------
    model : Model
        The compiled scene, scene units (sets the default dt).
    scene : Scene
        Its ``run`` (t_end, dt) and ``output`` (dt, every) settings.

    Returns
    -------
    StepPlan
        Steps, step sizes (scene units of time) and the frame cadence.
    """
    return plan_steps(scene, verlet_dt(scene, model), model.count)
