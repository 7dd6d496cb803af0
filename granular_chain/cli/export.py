"""``granular-chain export RUN_DIR --format FMT``: a finished run in another mesh format
(:mod:`granular_chain.writers.export`)."""

from __future__ import annotations

from pathlib import Path

from ..extras import check
from ..readback import read_run, run_model
from ..rundir import OutputError, claim_folder
from ..writers.export import export_run
from .exit_codes import fail


def add_parser(subparsers):
    """Register ``granular-chain export RUN_DIR --format FMT [--out DIR]``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The CLI's subparsers (``parser.add_subparsers()``).

    Returns
    -------
    argparse.ArgumentParser
        The ``export`` subparser.
    """
    p = subparsers.add_parser(
        "export", help="a finished run in another mesh format (meshio: xdmf, vtu, ...)",
        description="Write the frames of a run (RUN_DIR/trajectory.h5) for tools that read "
        "other mesh formats: xdmf (one time series) or one file a frame in any format "
        "meshio writes from points and lines (vtu, vtk, med, gmsh, ...).")
    p.add_argument("run_dir", metavar="RUN_DIR")
    p.add_argument("--format", dest="fmt", default="xdmf", help="xdmf (default), vtu, vtk, ...")
    p.add_argument("--out", default=None, help="a new folder, or one export wrote (default RUN_DIR/export/FORMAT)")
    return p


def run(args) -> int:
    """Entry point of ``granular-chain export``: 0 written, 2 bad input.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of ``granular-chain export``.

    Returns
    -------
    int
        The exit status.
    """
    check("meshio", "granular-chain export")
    import meshio

    run_dir = Path(args.run_dir)
    if not (run_dir / "trajectory.h5").is_file():
        return fail(f"{run_dir}: no trajectory.h5 to export (run with output.trajectory: true)")
    fmt = args.fmt.lower()
    if fmt != "xdmf" and fmt not in meshio._helpers._writer_map:
        return fail(f"--format: {args.fmt!r} is not a format meshio writes (known: xdmf, "
                    f"{', '.join(sorted(meshio._helpers._writer_map))})")
    out = Path(args.out) if args.out else run_dir / "export" / fmt
    where = {"flag": "--out" if args.out else "RUN_DIR", "home": run_dir}
    try:  # a new folder, one export wrote, or inside RUN_DIR (the files join its run.json)
        claim_folder(out, "export", [], **where)  # the folder, before the run is read
    except OutputError as exc:
        return fail(str(exc))
    try:
        result = read_run(run_dir)
    except (OSError, ValueError) as exc:
        return fail(f"{run_dir}: cannot be read ({exc})")
    model = run_model(result)
    names = ["run.xdmf", "run.h5"] if fmt == "xdmf" else [
        f"frame_{q:06d}.{fmt}" for q in range(result.t.size)]
    try:  # and each file, now that their names are known
        claim = claim_folder(out, "export", names, **where)
        with claim:  # written whole into a hidden folder, then renamed into place
            export_run(result, model, claim.stage(), fmt)
            paths = claim.publish()
    except OutputError as exc:
        return fail(str(exc))
    print(f"wrote {len(paths)} file(s) to {out}/")
    return 0
