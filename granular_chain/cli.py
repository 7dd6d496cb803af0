"""The ``granular-chain`` command: run | validate | schema | plot | sweep | diagnose | figures.

Exit status: 0 success, 1 a run that ended without success (its outputs say
why), 2 bad input (one line on stderr naming the file, the field and the
problem; nothing written), 130 interrupted (Ctrl-C; nothing written), 143
terminated (SIGTERM; nothing written).

What ``run`` writes is asked for by the scene's ``output`` fields or, for one run,
by flags that override them (``--vtk``, ``--trajectory/--no-trajectory``, ``--csv``,
``--plots``): summary.json always, and only the writers asked for. The scene stored
in summary.json records the choices after the flags.

Writing is atomic: everything goes to a hidden ``.NAME.partial-XXXX`` folder beside
``--out``, renamed onto ``--out`` only when every writer has finished; a run that
fails, raises or is interrupted removes it. summary.json is written last, so even a
partial folder left by a hard kill (SIGKILL, power loss) has none.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import signal
import sys
import tempfile
from pathlib import Path

from .scene import SceneError, load_scene, scene_json_schema

EXIT_OK, EXIT_RUN_FAILED, EXIT_BAD_INPUT = 0, 1, 2
EXIT_INTERRUPTED, EXIT_TERMINATED = 130, 143  # 128 + signal number, as shells report


class _Terminated(BaseException):
    """SIGTERM turned into an exception, so the same clean-up as Ctrl-C runs."""


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="granular-chain", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run a scene and write its outputs")
    run.add_argument("scene", help="scene YAML file")
    run.add_argument("--set", dest="overrides", action="append", default=[],
                     metavar="dotted.path=value", help="override a scene field (repeatable)")
    run.add_argument("--out", default=None,
                     help="output folder (default outputs/<scene name>); replaced atomically")
    run.add_argument("--quiet", action="store_true", help="no progress bar, no report")
    writers = run.add_argument_group(
        "writers", "override the scene's output fields for this run "
        "(summary.json is always written)")
    writers.add_argument("--vtk", action=argparse.BooleanOptionalAction, default=None,
                         help="VTK time series: run.pvd + vtk/frame_NNNNNN.vtp (output.vtk)")
    writers.add_argument("--trajectory", action=argparse.BooleanOptionalAction, default=None,
                         help="trajectory.h5 (output.trajectory)")
    writers.add_argument("--csv", action=argparse.BooleanOptionalAction, default=None,
                         help="energy.csv and, with events, events.csv (output.csv)")
    writers.add_argument("--plots", action=argparse.BooleanOptionalAction, default=None,
                         help="PNG plots in plots/ (output.plots)")

    val = sub.add_parser("validate", help="check a scene file and report what it contains")
    val.add_argument("scene")
    val.add_argument("--set", dest="overrides", action="append", default=[],
                     metavar="dotted.path=value")

    sub.add_parser("schema", help="print the JSON Schema of scene files")

    plot = sub.add_parser("plot", help="PNG plots of a finished run (reads RUN_DIR/trajectory.h5)")
    plot.add_argument("run_dir", metavar="RUN_DIR", help="output folder of a run")
    plot.add_argument("--granules", default=None, metavar="I,J,...",
                      help="granules for velocities.png (default: first, quarters, last)")
    plot.add_argument("--time", dest="frame_time", type=float, default=None,
                      help="time of the frame rendered in frame.png (default: mid-run)")
    plot.add_argument("--no-render", dest="render", action="store_false",
                      help="skip frame.png (the pyvista off-screen rendering)")
    plot.add_argument("--out", default=None,
                      help="folder for the PNGs (default RUN_DIR/plots)")
    from .diagnostics import add_diagnose_parser
    from .figures import add_figures_parser
    from .sweep import add_sweep_parser

    add_sweep_parser(sub)
    add_diagnose_parser(sub)
    add_figures_parser(sub)
    return p


def _fail(message: str) -> int:
    print(f"granular-chain: {message}", file=sys.stderr)
    return EXIT_BAD_INPUT


def _prepare_output(out: Path) -> Path:
    """A fresh temporary folder beside ``out`` (renamed onto it when the run is complete)."""
    parent = out.parent if str(out.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        return Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-", dir=parent))
    except OSError as exc:
        raise SceneError("--out", str(out), f"cannot be written ({exc.strerror or exc})") from None


def _publish(tmp: Path, out: Path) -> None:
    """Move the finished temporary folder onto ``out`` (replacing an older run)."""
    # mkdtemp makes the folder private (0700); the published run gets the
    # permissions an ordinary mkdir would have given it.
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)
    if out.exists():
        old = out.with_name(f".{out.name}.old-{os.getpid()}")
        out.rename(old)
        try:
            tmp.rename(out)
        except BaseException:
            old.rename(out)  # put the previous run back rather than leave no --out
            raise
        shutil.rmtree(old, ignore_errors=True)
    else:
        tmp.rename(out)


def _apply_writer_flags(scene, args) -> None:
    for name in ("vtk", "trajectory", "csv", "plots"):
        flag = getattr(args, name, None)
        if flag is not None:
            setattr(scene.output, name, flag)


def _write_outputs(result, folder: Path, scene, progress: bool) -> None:
    """Every writer the scene asks for, then summary.json last (the completion mark)."""
    out = scene.output
    if out.trajectory:
        from .writers.trajectory import write_trajectory
        write_trajectory(result, folder, scene)
    if out.csv:
        from .writers.tables import write_tables
        write_tables(result, folder, scene)
    if out.vtk:
        from .writers.vtk import write_vtk
        write_vtk(result, folder, scene, progress=progress)
    if out.plots:
        from .writers.plots import write_plots
        write_plots(result, folder, scene)
    from .writers.summary import write_summary
    write_summary(result, folder, scene)


@contextlib.contextmanager
def _sigterm_as_exception():
    """While running, SIGTERM raises :class:`_Terminated` (main thread only)."""
    def handler(signum, frame):
        raise _Terminated()
    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def cmd_run(args) -> int:
    from .simulate import SimulationError, simulate

    try:
        scene = load_scene(args.scene, args.overrides)
    except SceneError as exc:
        return _fail(str(exc))
    _apply_writer_flags(scene, args)
    out = Path(args.out) if args.out else Path("outputs") / scene.name
    if out.exists() and not out.is_dir():
        return _fail(f"--out: {out} exists and is not a folder")
    progress = None if not args.quiet else False
    tmp = None
    published = False
    try:
        with _sigterm_as_exception():
            tmp = _prepare_output(out)
            try:
                result = simulate(scene, progress=progress)
            except SimulationError as exc:
                shutil.rmtree(tmp, ignore_errors=True)
                return _fail(f"{args.scene}: {exc}")
            _write_outputs(result, tmp, scene,
                           progress=(not args.quiet) and sys.stderr.isatty())
            _publish(tmp, out)
            published = True
    except SceneError as exc:  # --out cannot be created (raised before tmp exists)
        return _fail(str(exc))
    except BaseException as exc:
        if tmp is not None and not published:
            shutil.rmtree(tmp, ignore_errors=True)
        if published:  # interrupted after the rename: the output is complete
            raise
        if isinstance(exc, KeyboardInterrupt):
            print(f"granular-chain: interrupted; nothing written to {out}", file=sys.stderr)
            return EXIT_INTERRUPTED
        if isinstance(exc, _Terminated):
            print(f"granular-chain: terminated; nothing written to {out}", file=sys.stderr)
            return EXIT_TERMINATED
        raise
    if not args.quiet:
        print(f"{result.status.name.lower()}: {result.message}")
        for w in result.info.get("warnings", []):
            print(f"warning: {w}")
        print(f"t_final = {result.t_final:.12g}, steps = {result.steps}, "
              f"energy balance error = {result.energy.balance_error:.3g} (relative)")
        print(f"wrote {out}/")
    return EXIT_OK if result.success else EXIT_RUN_FAILED


def cmd_plot(args) -> int:
    run_dir = Path(args.run_dir)
    if not (run_dir / "trajectory.h5").is_file():
        return _fail(f"{run_dir}: no trajectory.h5 to plot (run with --trajectory, the "
                     f"default, or output.trajectory: true)")
    granules = None
    if args.granules:
        try:
            granules = [int(g) for g in args.granules.split(",") if g.strip()]
        except ValueError:
            return _fail(f"--granules: {args.granules!r} is not a comma-separated list of "
                         f"granule indices")
    from .writers.plots import PLOT_DIR, write_plots
    from .writers.trajectory import read_trajectory

    result, scene = read_trajectory(run_dir)
    count = result.x.shape[1]
    if granules is not None and any(not 0 <= g < count for g in granules):
        return _fail(f"--granules: indices must be in 0..{count - 1}, got {args.granules}")
    # --out names the PNG folder itself; by default they go to RUN_DIR/plots/.
    folder, subdir = (Path(args.out), "") if args.out else (run_dir, PLOT_DIR)
    paths = write_plots(result, folder, scene, granules=granules, frame_time=args.frame_time,
                        render=args.render, subdir=subdir)
    for path in paths:
        print(path)
    return EXIT_OK


def cmd_validate(args) -> int:
    from .budget import check_budget
    from .model import build_model
    from .simulate import SimulationError, check_dt, default_dt

    try:
        scene = load_scene(args.scene, args.overrides)
        check_budget(scene)
    except SceneError as exc:
        return _fail(str(exc))
    except SimulationError as exc:
        return _fail(f"{args.scene}: {exc}")
    model = build_model(scene)
    dt = scene.run.dt if scene.run.dt is not None else default_dt(model, scene.run.t_end)
    if scene.run.stepper == "verlet":
        try:
            check_dt(model, dt)
        except SimulationError as exc:
            return _fail(f"{args.scene}: {exc}")
    print(json.dumps({
        "scene": args.scene, "valid": True, "granules": model.count,
        "features": model.features.describe(), "stepper": scene.run.stepper,
        "dt": dt, "shortest_contact_time": model.shortest_period(),
    }, indent=2))
    return EXIT_OK


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "run":
        return cmd_run(args)
    if args.command == "validate":
        return cmd_validate(args)
    if args.command == "plot":
        return cmd_plot(args)
    if args.command == "figures":
        from .figures import run_figures_command
        return run_figures_command(args)
    if args.command == "sweep":
        from .sweep import run_sweep_command
        return run_sweep_command(args)
    if args.command == "diagnose":
        from .diagnostics import run_diagnose_command
        return run_diagnose_command(args)
    if args.command == "schema":
        print(json.dumps(scene_json_schema(), indent=2))
        return EXIT_OK
    return EXIT_BAD_INPUT  # argparse already refused unknown commands


if __name__ == "__main__":
    sys.exit(main())
