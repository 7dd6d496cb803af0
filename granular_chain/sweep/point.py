"""One point of a sweep: the scene with the point's overrides, run and reduced to a row."""

from __future__ import annotations

import copy
import time
import warnings
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from .. import diagnostics as dg
from ..errors import SimulationError
from ..notices import OverlapWarning, TimeStepWarning
from ..scene import SceneError, scene_from_dict, set_path
from ..simulate import simulate
from ..two_granules import classify
from .grid import SweepError, coord_text

__all__ = ["QUANTITIES", "PointOptions", "evaluate_point", "value_columns"]

#: Columns every row has, after the coordinates (empty when not applicable).
QUANTITIES = (
    "status",            # t_end, separated, at_rest, max_steps, nonfinite, ... or error
    "success",           # 1 / 0
    "t_final",           # time of the final state
    "steps",             # Verlet steps taken
    "E0",                # initial (kinetic + elastic) energy
    "kinetic", "potential", "coulomb", "viscous",  # final ledger
    "energy_ratio",      # (kinetic + potential) / E0 at the end
    "balance_error",     # max |ledger balance| / E0 over the frames
    "momentum",          # final sum m v
    "backscatter_velocity",   # most negative final velocity of the first 3 granules (0 if none)
    "backscatter_energy",     # sum m v^2/2 over the granules moving backward at the end
    "backscatter_count",      # how many move backward at the end
    "penetration_depth",      # granules that ever moved
    "backscatter_energy_max",  # largest backward kinetic energy of the first 3 over the frames (--frames)
    "pulse_death_time",       # mechanical energy < 1e-3 E0 (needs frames; inf if never)
    "pulse_speed",            # granules per unit time (only with --frames, N >= 8)
    "pulse_v_peak",           # peak velocity of the pulse (only with --frames)
    "v1", "v2", "outcome", "t_separation",  # N = 2: the collide() outcome fields
    "wall_time",         # seconds stepping (compiled kernel)
    "eval_time",         # seconds for the whole point (validation, model, run, reduction)
    "message",           # the run's message, or the error for a point that could not run
)


@dataclass(frozen=True)
class PointOptions:
    """How each point is run and reduced (sent to the workers with every batch).

    Attributes
    ----------
    frames : bool
        Keep the scene's output cadence (the pulse quantities need frames).
    granules : tuple of int
        Granules whose final velocity is a column (negative counts from the end).
    first : int
        Backscatter quantities over the first this many granules.
    """

    frames: bool = False       # keep the scene's output cadence (pulse quantities need it)
    granules: tuple = (0, 1, -1)  # v_final columns
    first: int = 3             # backscatter: the first this many granules


def value_columns(granules) -> list[str]:
    """The ``v_final[g]`` columns of the granules ``granules``.

    Parameters
    ----------
    granules : sequence of int
        Granule indices.

    Returns
    -------
    list of str
        Column names.
    """
    return [f"v_final[{g}]" for g in granules]


def evaluate_point(scene_data: dict, source: str, paths: Sequence[str], coords: Sequence,
                   options: PointOptions = PointOptions()) -> dict:
    """Run one point: overrides on a copy of the scene mapping, simulate, reduce to a row.

    Never raises for a bad point: a scene error or a refused run becomes a row
    with ``status = error`` and the reason in ``message`` (the sweep goes on, and
    the point counts as done).

    Parameters
    ----------
    scene_data : dict
        The scene file's mapping (as read from YAML), not yet validated.
    source : str
        Path of the scene file (for messages and relative paths).
    paths : sequence of str
        Dotted paths of the axes, in order.
    coords : sequence
        One value per path.
    options : PointOptions
        How each point is run and reduced.

    Returns
    -------
    dict
        Column -> value: the coordinates, :data:`QUANTITIES` and the ``v_final[g]`` columns.
    """
    start = time.perf_counter()
    row: dict[str, Any] = {p: coord_text(c) for p, c in zip(paths, coords)}
    data = copy.deepcopy(scene_data)
    try:
        for p, c in zip(paths, coords):
            set_path(data, p, c, source=f"{source} (sweep axis)")
        if not options.frames:
            # Only the final state: one frame at the end (a chunk per frame costs Python time).
            out = data.setdefault("output", {})
            out.pop("dt", None)
            out["every"] = 2_000_000_000
        scene = scene_from_dict(data, source=source)
        with warnings.catch_warnings():  # a warning about a point's run would repeat for
            # thousands of points; the row is the point's report
            warnings.simplefilter("ignore", OverlapWarning)
            warnings.simplefilter("ignore", TimeStepWarning)
            result = simulate(scene, progress=False)
    except (SceneError, SimulationError, SweepError) as exc:
        row.update(status="error", success=0, message=str(exc),
                   eval_time=time.perf_counter() - start)
        return row
    _reduce(result, options, row)
    row["eval_time"] = time.perf_counter() - start
    return row


def _reduce(result, options: PointOptions, row: dict) -> None:
    """The quantities of one finished run, added to ``row``."""
    model = result.model
    N = model.count
    e = result.energy
    b = dg.backscatter(result, model, first=options.first)
    row.update(
        status=result.status.name.lower(), success=int(result.success),
        t_final=result.t_final, steps=result.steps, E0=e.initial,
        kinetic=float(e.kinetic[-1]), potential=float(e.potential[-1]),
        coulomb=float(e.coulomb[-1]), viscous=float(e.viscous[-1]),
        energy_ratio=float(e.kinetic[-1] + e.potential[-1]) / (e.initial or 1.0),
        balance_error=e.balance_error,
        momentum=float(np.dot(model.mass, result.v_final)),
        backscatter_velocity=b["velocity"], backscatter_energy=b["energy"],
        backscatter_count=b["count"], penetration_depth=dg.penetration_depth(result),
        pulse_death_time=dg.pulse_death_time(result) if options.frames else "",
        backscatter_energy_max=b["energy_max"] if options.frames else "",
        wall_time=result.wall_time, message=result.message)
    for g in options.granules:
        if -N <= g < N:
            row[f"v_final[{g}]"] = float(result.v_final[g])
    if options.frames and N >= 8:
        try:
            fit = dg.pulse_speed(result)
            row.update(pulse_speed=fit.speed, pulse_v_peak=fit.v_peak)
        except ValueError:
            pass
    if N == 2 and result.stepper is not None:
        try:
            c = classify(result, 0.0 if result.dt is None else result.dt ** 2)
            row.update(v1=c.v1, v2=c.v2, outcome=c.outcome.name, t_separation=c.t_separation,
                       energy_ratio=c.energy_ratio)
        except RuntimeError as exc:
            row.update(outcome="failed", message=str(exc))
