"""Parameter sweeps: grids or lists of scene overrides, run on dask.distributed.

One sweep = one scene file, fixed overrides (``--set``) and axes::

    granular-chain sweep scenarios/chain_eta_map.yaml \\
        --grid 'granules.friction.kinetic[0]=0:0.5:100' \\
        --grid 'granules.friction.kinetic[1]=0:0.8:100' --quantity v1 --mask outcome=backscatter_and_propagation

Every point of the Cartesian product of the axes is a scene: load, apply the
overrides, validate, :func:`~granular_chain.simulate.simulate`, reduce the
result to a row of scalars (:data:`QUANTITIES`). Points are grouped in batches
(one dask task per batch, so the scheduler's per-task cost, ~1 ms, is paid once
per batch and not once per point) and sent to a ``LocalCluster`` of processes
(2 workers by default) or to an existing scheduler (``--scheduler ADDRESS``).

Results are one CSV, ``OUT/results.csv``: one row per point, the grid
coordinates first (named by their dotted paths), then the quantities. Rows are
appended and flushed as batches finish, so the file is always a valid prefix of
the sweep; a rerun of the same command reads it, skips every point already
there (matched by coordinates) and computes only the rest. A row cut short by
a hard kill is dropped and its point recomputed. ``OUT/sweep.json`` records the
scene's hash and the fixed overrides; a rerun with a different scene refuses
(start afresh with ``--restart``). Axes may change between runs: points of a
refined grid that were computed before are reused.

Dotted paths may index lists: ``granules.friction.kinetic[1]=...`` sets
granule 1's value; a scalar per-granule (per-contact) field is first expanded
to one value per granule (contact), so the scene file can keep ``0.0``
(:func:`granular_chain.scene.set_path`, the setter of ``--set`` too).

Modules: :mod:`.grid` (axes and points), :mod:`.point` (one point run and
reduced to a row), :mod:`.execute` (batches on dask.distributed),
:mod:`.resume` (results.csv and sweep.json), :mod:`.heatmap` (plots); the
command is :mod:`granular_chain.cli.sweep`.
"""

from __future__ import annotations

from .execute import SweepStats, run_sweep
from .grid import Axis, SweepError, grid_points, parse_grid, parse_list, set_path
from .heatmap import plot_heatmap
from .point import QUANTITIES, PointOptions, evaluate_point
from .resume import read_results

__all__ = [
    "Axis", "parse_grid", "parse_list", "grid_points", "set_path", "evaluate_point",
    "run_sweep", "SweepStats", "read_results", "plot_heatmap", "QUANTITIES",
    "SweepError", "PointOptions",
]
