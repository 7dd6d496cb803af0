"""What a run will cost, decided before it starts: steps, memory, representable scales.

:func:`check_budget` is called before any array of the run is allocated. It
refuses (:class:`~granular_chain.simulate.SimulationError`, one line naming the
field to change and the numbers) a scene that

* has a quantity double precision cannot represent (:func:`model.scale_problem`),
* asks the Verlet stepper for a step longer than the whole run (``run.dt > run.t_end``),
* needs more Verlet steps to reach ``run.t_end`` than ``run.max_steps`` allows
  (a run with a ``stop`` condition may end earlier: it runs and stops with status
  ``max_steps`` if it does not),
* asks the event stepper to resolve contact times below the resolution of time
  at ``run.t_end`` (t_end / T > 2^52: ``t + T == t``),
* does not fit in the available memory (state, kept frames, writers); the
  message names the ``output.every`` / ``output.dt`` that would fit.

The memory model (bytes, N granules, F frames kept, P + 1 Taylor coefficients)::

    Verlet state     VERLET_STATE_BYTES * N      (~24 float64 arrays of N)
    event state      (4 (P + 1) + 20) * 8 * N    (series of u, v, overlaps, forces)
    frames           F * (FRAME_BYTES_PER_GRANULE * N + FRAME_OVERHEAD)
                     (x, v, f per frame, in the list and once stacked: 48 N)
    writers          VTK 128 N, plots 64 bytes per space-time cell (<= 2e6 cells)

Steps and frames are the run's :class:`~granular_chain.steppers.schedule.Schedule`,
the one the steppers follow; the event stepper's frames at event batches
(N <= 64) grow with the events and are not estimated.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Optional

from .errors import SimulationError
from .model import build_model, scale_problem
from .steppers.schedule import Schedule, plan_run
from .steppers.verlet.timestep import verlet_dt

__all__ = ["Budget", "check_budget", "available_memory", "estimate_memory"]

VERLET_STATE_BYTES = 24 * 8
FRAME_BYTES_PER_GRANULE = 48
FRAME_OVERHEAD = 600  # three array headers, five Python floats in lists, stacked energies
EVENT_MAX_TERMS = 31  # Taylor order P <= 30 (steppers.events.series_order)
_PLOT_CELL_BYTES = 64
_PLOT_MAX_CELLS = 2_000_000
_VTK_BYTES_PER_GRANULE = 128
#: Below this estimate (bytes) memory is not looked up (/proc/meminfo costs ~100 us).
SMALL_RUN = 256 * 2 ** 20
#: t_end / (shortest contact time) above which t + T == t in double precision.
TIME_RESOLUTION = 2.0 ** 52


@dataclass
class Budget:
    """The estimate of one run.

    Attributes
    ----------
    steps : int or None
        Verlet steps to t_end, at most run.max_steps (None for the event stepper).
    dt : float or None
        Verlet step used.
    frames : int
        Frames kept in memory (event stepper: the part known in advance).
    state, frame_bytes, writers, available : int
        Bytes of the stepper's arrays, of the kept frames, of the writers
        asked for, and of memory available.
    model : Model or None
        The Model built for the checks (:func:`~granular_chain.simulate.simulate` runs it).
    schedule : Schedule or None
        The run's steps, frames and thermo lines (the steppers and writers follow it).
    """

    steps: Optional[int]
    dt: Optional[float]
    frames: int
    state: int
    frame_bytes: int
    writers: int
    available: int
    model: object = None  #: the Model built for the checks (simulate() runs it)
    schedule: Optional[Schedule] = None

    @property
    def total(self) -> int:
        """Bytes of the run: state, kept frames and writers."""
        return self.state + self.frame_bytes + self.writers


def available_memory() -> int:
    """Bytes of memory available to a new allocation (MemAvailable, else free pages).

    Returns
    -------
    int
        Bytes (``1 << 62`` when unknown: nothing is refused on memory).
    """
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 1 << 62  # unknown: do not refuse on memory


def _gb(nbytes: float) -> str:
    """Bytes in the largest unit that keeps the number >= 1 (B, kB, MB, GB, TB)."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= size:
            return f"{nbytes / size:.3g} {unit}"
    return f"{nbytes:.0f} B"


def _writer_bytes(scene) -> int:
    out = scene.output
    n = scene.granules.count
    return (_VTK_BYTES_PER_GRANULE * n if out.vtk else 0) + (
        _PLOT_CELL_BYTES * _PLOT_MAX_CELLS if out.plots else 0)


def _state_bytes(scene) -> int:
    n = scene.granules.count
    if scene.run.stepper == "event":
        return (4 * EVENT_MAX_TERMS + 20) * 8 * n
    return VERLET_STATE_BYTES * n


def _frame_bytes(n: int) -> int:
    return FRAME_BYTES_PER_GRANULE * n + FRAME_OVERHEAD


def _refuse(field: str, problem: str):
    return SimulationError(f"{field}: {problem}")


def _check_state_fits(scene, available: Optional[int]) -> None:
    n = scene.granules.count
    need = _state_bytes(scene) + _writer_bytes(scene) + 3 * _frame_bytes(n)
    if need <= SMALL_RUN and available is None:
        return
    available = available_memory() if available is None else available
    if need > available:
        raise _refuse("granules.count", (
            f"{n} granules need about {_gb(need)} for the {scene.run.stepper} stepper's "
            f"state and three frames alone, but {_gb(available)} of memory is available"))


def _check_time_resolution(scene, model) -> None:
    T = model.shortest_period()
    if T > 0 and scene.run.t_end / T > TIME_RESOLUTION:
        raise _refuse("run.t_end", (
            f"{scene.run.t_end:g} is {scene.run.t_end / T:.3g} times the shortest contact "
            f"time {T:.3g}: beyond 2^52 times, t + T == t in double precision and no "
            f"contact can be resolved; shorten run.t_end or soften the contacts"))


def estimate_memory(scene, model, available: Optional[int] = None) -> Budget:
    """The :class:`Budget` of a run (steps and dt checked for Verlet, see the module doc).

    ``available`` defaults to :func:`available_memory`, looked up only for runs
    estimated above SMALL_RUN (otherwise reported as -1: not looked up).

    Parameters
    ----------
    scene : Scene
        The validated scene of the run.
    model : Model
        ``build_model(scene)``.
    available : int, optional
        Bytes of memory to plan with.

    Returns
    -------
    Budget
        Steps, dt, frames and bytes of the run.
    """
    n = scene.granules.count
    asked = verlet_dt(scene, model) if scene.run.stepper == "verlet" else None
    schedule = plan_run(scene, model, asked)
    plan = schedule.plan
    steps = None if plan is None else min(schedule.steps, scene.run.max_steps)
    b = Budget(steps=steps, dt=plan.dt if plan is not None else None,
               frames=schedule.frames, state=_state_bytes(scene),
               frame_bytes=schedule.frames * _frame_bytes(n), writers=_writer_bytes(scene),
               available=-1 if available is None else available, model=model,
               schedule=schedule)
    if available is None and b.total > SMALL_RUN:
        b.available = available_memory()
    return b


def _cadence_that_fits(scene, b: Budget) -> str:
    """'set output.every: K (or output.dt: X)' for the most frames that fit."""
    n = scene.granules.count
    fit = (b.available - b.state - b.writers) // _frame_bytes(n) - 2
    if b.steps is not None:
        every = max(1, -(-b.steps // max(fit, 1)))
        return (f"set output.every: {every} (or output.dt: {every * b.dt:.4g}) to keep "
                f"{-(-b.steps // every) + 2} frames")
    return f"set output.dt: {scene.run.t_end / max(fit - 16, 1):.4g} to keep at most {fit} frames"


def check_budget(scene, model=None, available: Optional[int] = None) -> Budget:
    """Refuse a run that cannot be represented, is too long, or does not fit in memory.

    Parameters
    ----------
    scene : Scene
        The validated scene of the run.
    model : Model, optional
        ``build_model(scene)``; built here (after the memory of the state is
        known to fit) when not given.
    available : int, optional
        Bytes of memory to plan with (default :func:`available_memory`).

    Returns
    -------
    Budget
        With the model it checked (``.model``), so the caller need not build it again.

    Raises
    ------
    SimulationError
        One line: ``dotted.field: what is wrong, with the numbers``.
    """
    _check_state_fits(scene, available)
    if model is None:
        model = build_model(scene)
    problem = scale_problem(model)
    if problem:
        raise _refuse(*problem)
    if scene.run.stepper == "event":
        _check_time_resolution(scene, model)
    b = estimate_memory(scene, model, available)
    if b.available >= 0 and b.total > b.available:
        raise _refuse("output.every" if b.steps is not None else "output.dt", (
            f"the run would keep {b.frames} frames of {scene.granules.count} granules: about "
            f"{_gb(b.total)} (state {_gb(b.state)}, frames {_gb(b.frame_bytes)}, writers "
            f"{_gb(b.writers)}) but {_gb(b.available)} of memory is available; "
            f"{_cadence_that_fits(scene, b)}"))
    return b
