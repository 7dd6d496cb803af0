"""``granular-chain export``: a finished run in the formats of other mesh tools (meshio).

The run's frames (read back from its ``trajectory.h5``) become the granules as
points and the contacts i, i+1 as line cells:

- ``xdmf``: one XDMF time series (``run.xdmf`` and its HDF5 companion), the
  geometry written once at the initial positions and, per frame, the point
  data ``displacement`` (apply ParaView's *Warp By Vector* to see the motion),
  ``velocity`` and ``net_force``; ``radius`` and ``mass`` as constant data.
- any other format meshio writes from points and line cells (``vtu``, ``vtk``,
  ``xdmf``, ``med``, ``gmsh`` ...): one file per frame, ``frame_NNNNNN.EXT``,
  with the points at that frame's positions.

The engine's own VTK series (``--vtk``) streams while the run goes; this command
serves tools that read other formats, after the fact.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import numpy as np

from ..extras import require

__all__ = ["export_run"]


@contextlib.contextmanager
def _working_folder(folder: Path):
    """Run the block with ``folder`` as the working folder (restored after)."""
    before = os.getcwd()
    os.chdir(folder)
    try:
        yield
    finally:
        os.chdir(before)


def _points(x: np.ndarray) -> np.ndarray:
    """(N,) centre positions on the x axis as (N, 3) points."""
    pts = np.zeros((x.size, 3))
    pts[:, 0] = x
    return pts


def export_run(result, model, out: Path, fmt: str) -> list[Path]:
    """Write the frames of ``result`` into the folder ``out`` in format ``fmt``.

    Parameters
    ----------
    result : Result
        A run with its frames (``granular_chain.read_run``).
    model : Model
        Its chain (radii, masses).
    out : Path
        Folder to write into (created).
    fmt : str
        ``xdmf`` for one time series; otherwise a meshio format name, one file a frame.

    Returns
    -------
    list of Path
        The files written.
    """
    meshio = require("meshio", "granular_chain export")

    out.mkdir(parents=True, exist_ok=True)
    N = result.x.shape[1]
    cells = [("line", np.column_stack([np.arange(N - 1), np.arange(1, N)]))] if N > 1 else []
    if fmt == "xdmf":
        path = out / "run.xdmf"
        x0 = result.x[0]
        # meshio puts the HDF5 companion in the working folder: write from inside ``out``
        with _working_folder(out), meshio.xdmf.TimeSeriesWriter(path.name) as writer:
            writer.write_points_cells(_points(x0), cells)
            for q, t in enumerate(result.t):
                writer.write_data(float(t), point_data={
                    "displacement": _points(result.x[q] - x0), "velocity": result.v[q],
                    "net_force": result.f[q], "radius": model.radius, "mass": model.mass})
        return [path, path.with_suffix(".h5")]
    paths = []
    for q in range(result.t.size):
        mesh = meshio.Mesh(_points(result.x[q]), cells, point_data={
            "velocity": result.v[q], "net_force": result.f[q], "radius": model.radius,
            "mass": model.mass})
        path = out / f"frame_{q:06d}.{fmt}"
        meshio.write(path, mesh)
        paths.append(path)
    return paths
