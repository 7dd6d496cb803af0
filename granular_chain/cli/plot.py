"""``granular-chain plot RUN_DIR``: PNG plots of a finished run (reads its trajectory.h5)."""

from __future__ import annotations

from pathlib import Path

from ..extras import check
from ..readback import read_trajectory
from ..rundir import OutputError, claim_folder
from ..writers.plots import PLOT_DIR, write_plots
from .exit_codes import EXIT_OK, fail


def add_parser(subparsers) -> None:
    """Register ``granular-chain plot`` on the CLI's subparsers.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The CLI's subparsers (``parser.add_subparsers()``).
    """
    plot = subparsers.add_parser(
        "plot", help="PNG plots of a finished run (reads RUN_DIR/trajectory.h5)")
    plot.add_argument("run_dir", metavar="RUN_DIR", help="output folder of a run")
    plot.add_argument("--granules", default=None, metavar="I,J,...",
                      help="granules for velocities.png (default: first, quarters, last)")
    plot.add_argument("--time", dest="frame_time", type=float, default=None,
                      help="time of the frame rendered in frame.png (default: mid-run)")
    plot.add_argument("--no-render", dest="render", action="store_false",
                      help="skip frame.png (the pyvista off-screen rendering; skipped "
                      "with a note when pyvista is not installed)")
    plot.add_argument("--out", default=None,
                      help="a new folder for the PNGs, or one plot wrote (default "
                      "RUN_DIR/plots)")


def run(args) -> int:
    """Entry point of ``granular-chain plot``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of ``granular-chain plot``.

    Returns
    -------
    int
        Exit status: 0 written, 2 bad input (also matplotlib not installed).
    """
    check("matplotlib", "granular-chain plot")  # (frame.png alone needs pyvista: skipped)
    run_dir = Path(args.run_dir)
    if not (run_dir / "trajectory.h5").is_file():
        return fail(f"{run_dir}: no trajectory.h5 to plot (run with --trajectory, the "
                    f"default, or output.trajectory: true)")
    granules = None
    if args.granules:
        try:
            granules = [int(g) for g in args.granules.split(",") if g.strip()]
        except ValueError:
            return fail(f"--granules: {args.granules!r} is not a comma-separated list of "
                        f"granule indices")
    # --out names the PNG folder itself; by default they go to RUN_DIR/plots/.
    folder = Path(args.out) if args.out else run_dir / PLOT_DIR
    names = ("spacetime.png", "energy.png", "velocities.png", "frame.png")
    try:  # a new folder, one plot wrote, or inside RUN_DIR (the PNGs join its run.json)
        claim = claim_folder(folder, "plot", names, flag="--out" if args.out else "RUN_DIR",
                             home=run_dir)
    except OutputError as exc:
        return fail(str(exc))
    try:
        result, scene = read_trajectory(run_dir)
    except (OSError, ValueError) as exc:
        return fail(f"{run_dir}/trajectory.h5: cannot be read ({exc})")
    count = result.x.shape[1]
    if granules is not None and any(not 0 <= g < count for g in granules):
        return fail(f"--granules: indices must be in 0..{count - 1}, got {args.granules}")
    try:
        with claim:
            paths = write_plots(result, claim.folder, scene, granules=granules,
                                frame_time=args.frame_time, render=args.render, subdir="")
    except OutputError as exc:
        return fail(str(exc))
    for path in paths:
        print(path)
    return EXIT_OK
