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

__all__ = ["export_run", "add_export_parser", "run_export_command"]


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
    import meshio

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


def add_export_parser(subparsers):
    """Register ``granular-chain export RUN_DIR --format FMT [--out DIR]``."""
    p = subparsers.add_parser(
        "export", help="a finished run in another mesh format (meshio: xdmf, vtu, ...)",
        description="Write the frames of a run (RUN_DIR/trajectory.h5) for tools that read "
        "other mesh formats: xdmf (one time series) or one file a frame in any format "
        "meshio writes from points and lines (vtu, vtk, med, gmsh, ...).")
    p.add_argument("run_dir", metavar="RUN_DIR")
    p.add_argument("--format", dest="fmt", default="xdmf", help="xdmf (default), vtu, vtk, ...")
    p.add_argument("--out", default=None, help="a new folder (default RUN_DIR/export/FORMAT)")
    return p


def run_export_command(args) -> int:
    """Entry point of ``granular-chain export``: 0 written, 2 bad input."""
    import sys

    from ..model import build_model
    from ..readback import read_run
    from ..rundir import OutputError, adopt_files, check_new_files

    def fail(message: str) -> int:
        print(f"granular-chain: {message}", file=sys.stderr)
        return 2

    run_dir = Path(args.run_dir)
    if not (run_dir / "trajectory.h5").is_file():
        return fail(f"{run_dir}: no trajectory.h5 to export (run with output.trajectory: true)")
    try:
        import meshio
    except ImportError:
        return fail("export needs meshio: pip install 'granular_chain[viz]'")
    fmt = args.fmt.lower()
    if fmt != "xdmf" and fmt not in meshio._helpers._writer_map:
        return fail(f"--format: {args.fmt!r} is not a format meshio writes (known: xdmf, "
                    f"{', '.join(sorted(meshio._helpers._writer_map))})")
    out = Path(args.out) if args.out else run_dir / "export" / fmt
    if args.out and out.exists():
        return fail(f"--out {out}: exists; name a new folder")
    try:
        result = read_run(run_dir)
    except (OSError, ValueError) as exc:
        return fail(f"{run_dir}: cannot be read ({exc})")
    model = build_model(result.scene)
    try:
        names = ["run.xdmf", "run.h5"] if fmt == "xdmf" else [
            f"frame_{q:06d}.{fmt}" for q in range(result.t.size)]
        check_new_files([out / n for n in names], "--out" if args.out else "RUN_DIR")
    except OutputError as exc:
        return fail(str(exc))
    try:
        paths = export_run(result, model, out, fmt)
    finally:  # the files written so far, even if stopped, join the run's marker
        if not args.out:
            adopt_files(run_dir, [out / n for n in names if (out / n).is_file()])
    print(f"wrote {len(paths)} file(s) to {out}/")
    return 0
