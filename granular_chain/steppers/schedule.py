"""When a run records: its steps, frames and thermo lines, decided once before it starts.

As diffrax's ``SaveAt`` is given to its solve, a :class:`Schedule` is worked out
from the scene and its Model before anything runs (:func:`plan_run`) and handed
to everything that needs it: the memory and step-count budget
(:mod:`granular_chain.budget`), the Verlet driver (its :class:`StepPlan`), the
event stepper (the default frame count of a long chain) and the thermo writer
(lines every ``thermo_every`` steps). Each rule below is written once.

* Verlet: ``steps`` whole steps of ``dt`` and a last shorter step ending at
  t_end; a frame every ``every`` steps: ``output.every``, or the steps between
  multiples of ``output.dt`` (dt shortened so that they fall on steps), or about
  :data:`DEFAULT_FRAMES` frames a run (:func:`default_frames`).
* Event stepper: chains of up to :data:`FRAMES_AT_EVENTS_MAX_N` granules get a
  frame at every event batch; longer ones frames at the ``output.dt`` cadence,
  every ``output.every`` steps, or :func:`default_frames` frames a run.
* Thermo lines: every ``output.thermo`` steps, or about :data:`THERMO_LINES` a run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

from ..errors import SimulationError
from ..model import Model

__all__ = ["Schedule", "StepPlan", "plan_run", "plan_steps", "event_schedule", "default_frames", "thermo_every",
           "DEFAULT_FRAMES", "DEFAULT_FRAME_VALUES", "FRAMES_AT_EVENTS_MAX_N", "THERMO_LINES"]

#: Frames of a run that does not say (output.every or output.dt).
DEFAULT_FRAMES = 1000
#: ... fewer for long chains: at most this many values per recorded array (x, v, f: 80 MB).
DEFAULT_FRAME_VALUES = 10_000_000
#: Event stepper: chains up to this many granules get a frame at every event batch;
#: longer ones at the output.dt cadence only (a frame holds 3 N values; a long chain
#: has thousands of event batches).
FRAMES_AT_EVENTS_MAX_N = 64
#: Thermo lines of a run that does not say (output.thermo).
THERMO_LINES = 20
#: Event stepper: frames beyond the output.dt cadence kept for (the start, the end,
#: a stop, an interruption): the budget's margin.
EVENT_EXTRA_FRAMES = 16
#: Event stepper, frames at event batches: the initial buffer (it grows with the events).
EVENT_INITIAL_FRAMES = 64


def default_frames(count: int) -> int:
    """Frames of a run that does not set output.every or output.dt.

    Parameters
    ----------
    count : int
        Granules N.

    Returns
    -------
    int
        ``max(2, min(DEFAULT_FRAMES, DEFAULT_FRAME_VALUES // N))``.
    """
    return max(2, min(DEFAULT_FRAMES, DEFAULT_FRAME_VALUES // max(count, 1)))


def thermo_every(steps: int, every: Optional[int]) -> int:
    """Steps between thermo lines: ``every`` when given, else about THERMO_LINES a run.

    Parameters
    ----------
    steps : int
        Verlet steps of the run.
    every : int, optional
        Steps between lines asked for (``output.thermo``).

    Returns
    -------
    int
        At least 1.
    """
    if every is not None:
        return int(every)
    return max(1, math.ceil(steps / THERMO_LINES))


@dataclass(frozen=True)
class StepPlan:
    """The Verlet run's steps: ``steps`` of ``dt``, then one of ``last_dt`` (0: none)
    so that the run ends exactly at t_end; a frame every ``every`` steps.

    Attributes
    ----------
    dt : float
        Step (the scene's time unit); shortened, when ``output.dt`` is given, to
        the largest step that divides it, so frames fall on multiples of it.
    steps : int
        Whole steps of ``dt`` (``steps * dt`` <= t_end).
    last_dt : float
        A final shorter step ending at t_end (scene's time unit), or 0 when
        ``steps * dt`` is t_end to within 1e-9 dt.
    every : int
        Steps between frames.
    note : str
        What was shortened, for the run's warnings ('' when nothing was).
    """

    dt: float
    steps: int
    last_dt: float
    every: int
    note: str

    @property
    def total_steps(self) -> int:
        """Steps to t_end, the last shorter one included."""
        return self.steps + (1 if self.last_dt > 0.0 else 0)


@dataclass(frozen=True)
class Schedule:
    """What a run records and when (see the module doc), fixed before it starts.

    Attributes
    ----------
    stepper : str
        ``"verlet"`` or ``"event"``.
    plan : StepPlan or None
        The Verlet steps and frame cadence (None for the event stepper).
    frames : int
        Frames the run keeps: the Verlet cadence's, with the first and the last;
        the event stepper's at its output.dt or default cadence, or its initial
        buffer when frames come at event batches (they grow with the events).
    cadence_frames : int
        Event stepper without output.dt or output.every, chain longer than
        FRAMES_AT_EVENTS_MAX_N: frames spread evenly over t_end (0 otherwise).
    frames_at_events : bool
        Event stepper: a frame at every event batch.
    thermo_every : int
        Verlet steps between thermo lines (0 for the event stepper, whose lines
        are thinned in time).
    """

    stepper: str
    plan: Optional[StepPlan]
    frames: int
    cadence_frames: int
    frames_at_events: bool
    thermo_every: int

    @property
    def steps(self) -> Optional[int]:
        """Verlet steps to t_end (the last shorter one included); None for events."""
        return self.plan.total_steps if self.plan is not None else None


def _frame_steps(out_dt: Optional[float], dt: float) -> tuple[float, Optional[int]]:
    """(step, steps between frames) so that frames fall on multiples of ``out_dt``:
    ``dt`` and ``out_dt / dt`` when that is whole to 1e-9, else ``out_dt / ceil(out_dt
    / dt)`` and that ceiling; (dt, None) without output.dt."""
    if out_dt is None:
        return dt, None
    per_frame = out_dt / dt
    m = round(per_frame)
    if m >= 1 and abs(m - per_frame) <= 1e-9 * per_frame:
        return dt, m
    m = math.ceil(per_frame)
    return out_dt / m, m


def plan_steps(scene, asked: float, count: int) -> StepPlan:
    """Plan the Verlet steps of a scene (see :class:`StepPlan`).

    Parameters
    ----------
    scene : Scene
        Its ``run`` (t_end, dt) and ``output`` (dt, every) settings.
    asked : float
        The step asked for: ``run.dt``, or the default
        (:func:`~granular_chain.steppers.verlet.timestep.verlet_dt`), scene units.
    count : int
        Granules N (the default frame count).

    Returns
    -------
    StepPlan
        Steps, step sizes (scene units of time) and the frame cadence.
    """
    run, out = scene.run, scene.output
    t_end = run.t_end
    dt, every = _frame_steps(out.dt, asked)
    note = ""
    if dt != asked and run.dt is not None:
        note = (f"run.dt shortened from {asked:.6g} to {dt:.6g} so that frames fall "
                f"on multiples of output.dt = {out.dt:g}")
    whole = round(t_end / dt)
    if whole >= 1 and abs(whole * dt - t_end) <= 1e-9 * dt:
        steps, last_dt = whole, 0.0
    else:
        steps = int(math.floor(t_end / dt))
        last_dt = t_end - steps * dt
    if out.every is not None:
        every = out.every
    elif out.dt is None:
        every = max(1, steps // default_frames(count))
    return StepPlan(dt=dt, steps=steps, last_dt=last_dt, every=every, note=note)


def _check_step_count(scene, model: Model, asked: float) -> None:
    """Refuse a Verlet run of more than run.max_steps steps (naming output.dt when
    its cadence shortens the step), before a step count is formed: t_end / dt may be
    beyond any integer. A run with stop conditions may have more (it may stop first)."""
    run = scene.run
    if run.dt is not None and run.dt > run.t_end:
        raise SimulationError(f"run.dt: {run.dt:g} is longer than the whole run, run.t_end "
                              f"= {run.t_end:g}; use run.dt <= run.t_end")
    dt = _frame_steps(scene.output.dt, asked)[0]
    ratio = run.t_end / dt
    if ratio <= run.max_steps or (run.stop_conditions and ratio < 2 ** 62):
        return
    if dt < asked:
        raise SimulationError(
            f"output.dt: {scene.output.dt:g} forces a step of {dt:.4g} (frames fall on its "
            f"multiples; the step would be {asked:.4g}): reaching run.t_end = {run.t_end:g} "
            f"takes {ratio:.4g} steps, more than run.max_steps = {run.max_steps}; raise "
            f"output.dt or run.max_steps, or shorten run.t_end")
    how = "" if run.dt is not None else (
        f" (the default dt: 1/200 of the shortest contact time {model.shortest_period():.4g}, "
        f"or less for dashpots or a driven wall)")
    raise SimulationError(
        f"run.max_steps: reaching run.t_end = {run.t_end:g} with run.dt = {dt:.4g}{how} "
        f"takes {ratio:.4g} steps, more than run.max_steps = {run.max_steps}; raise "
        f"run.max_steps or run.dt, or shorten run.t_end")


def event_schedule(scene) -> Schedule:
    """The event stepper's :class:`Schedule` of a scene (no Model needed).

    Parameters
    ----------
    scene : Scene
        Its ``output`` (dt, every), ``run.t_end`` and ``granules.count``.

    Returns
    -------
    Schedule
        Frames at event batches (N <= FRAMES_AT_EVENTS_MAX_N), at the output.dt
        cadence, or :func:`default_frames` spread over t_end; no step plan.
    """
    out, n = scene.output, scene.granules.count
    at_events = n <= FRAMES_AT_EVENTS_MAX_N
    cadence = 0
    if out.dt is not None:
        frames = int(scene.run.t_end / out.dt) + EVENT_EXTRA_FRAMES
    elif at_events or out.every is not None:
        frames = EVENT_INITIAL_FRAMES
    else:
        cadence = default_frames(n)
        frames = cadence + EVENT_EXTRA_FRAMES
    return Schedule(stepper="event", plan=None, frames=frames, cadence_frames=cadence,
                    frames_at_events=at_events, thermo_every=0)


def plan_run(scene, model: Model, asked: Optional[float]) -> Schedule:
    """The :class:`Schedule` of a run; refuses (SimulationError naming the field) a
    Verlet run of more steps than run.max_steps allows.

    Parameters
    ----------
    scene : Scene
        The validated scene.
    model : Model
        ``build_model(scene)``.
    asked : float or None
        The Verlet step asked for (``run.dt`` or the model's default,
        :func:`~granular_chain.steppers.verlet.timestep.verlet_dt`); None for the
        event stepper.

    Returns
    -------
    Schedule
        Steps, frames and thermo lines of the run.
    """
    if scene.run.stepper == "event":
        return event_schedule(scene)
    _check_step_count(scene, model, asked)
    plan = plan_steps(scene, asked, model.count)
    steps = min(plan.total_steps, scene.run.max_steps)
    return Schedule(stepper="verlet", plan=plan, frames=-(-steps // plan.every) + 2,
                    cadence_frames=0, frames_at_events=False,
                    thermo_every=thermo_every(plan.steps, scene.output.thermo))
