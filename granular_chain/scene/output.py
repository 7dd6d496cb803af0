"""``output``: which writers a run feeds, and how often."""

from __future__ import annotations

from typing import Annotated, Optional

from pydantic import (
    Field,
)

from .values import Bool, Int, Positive, _Strict


class Output(_Strict):
    """What a run writes and how often (the cadence never changes the physics)."""

    every: Optional[Annotated[int, Int]] = Field(
        None, ge=1, description="Record a frame every this many steps (Verlet).")
    dt: Optional[Positive] = Field(
        None, description="Record a frame every dt of simulated time, on its multiples, and "
        "one at t_end (Verlet shortens run.dt, when needed, to the largest step that divides "
        "it; the event stepper also records one at each batch of events for N <= 64).")
    trajectory: Bool = Field(True, description="Write trajectory.h5 (t, x, v, energy ledger).")
    vtk: Bool = Field(
        False, description="Write a VTK time series for ParaView/pyvista: run.pvd indexing "
        "vtk/frame_NNNNNN.vtp (granules as points, contacts as line cells).")
    csv: Bool = Field(
        False, description="Write energy.csv (energy ledger per frame) and, when the stepper "
        "logged events, events.csv.")
    events: Bool = Field(
        False, description="Verlet: log every contact opening/closing and stick/slip change "
        "with step and time (trajectory.h5's event variables; events.csv with output.csv); "
        "the event stepper always logs.")
    plots: Bool = Field(
        False, description="Write PNG plots into plots/ (space-time velocity diagram, energy "
        "ledger, granule velocities, a rendered frame).")
    checkpoint_every: Optional[Annotated[int, Int]] = Field(
        None, ge=1, description="Steps between checkpoints (Verlet steps; Taylor steps with "
        "the event stepper): granular-chain run --restart RUN_DIR continues the run from the "
        "latest, bit for bit. A run also checkpoints when it is interrupted.")
    thermo: Optional[Annotated[int, Int]] = Field(
        None, ge=1, description="Steps between thermo lines (t, energies, dissipated energy, "
        "ledger error, closed contacts, sliding granules) printed by granular-chain run and "
        "saved as thermo.csv; default about 20 lines a run. The event stepper writes a line "
        "at its first frame after each 1/20 of t_end.")
