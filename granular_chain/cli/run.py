"""``granular-chain run SCENE``: run a scene with its writers attached and publish the
run folder; ``granular-chain run [SCENE] --restart RUN_DIR``: continue a run, or extend a
finished one to a later ``run.t_end`` (:mod:`granular_chain.restart`).

What ``run`` writes is asked for by the scene's ``output`` fields or, for one run,
by flags that override them (``--vtk``, ``--trajectory/--no-trajectory``, ``--csv``,
``--plots``): run.json and summary.json always, and only the writers asked for.
The scene stored in summary.json records the choices after the flags.

Where ``run`` writes, and what it may replace, is :mod:`granular_chain.rundir`'s
rule: a new folder, or an earlier run folder of the engine holding nothing else
(with ``--overwrite``); written beside the destination and renamed into place.
"""

from __future__ import annotations

import argparse
import errno
import sys
import warnings
from pathlib import Path
from typing import Optional

from ..checkpoint import CHECKPOINT, save_checkpoint
from ..errors import SimulationError
from ..extras import check
from ..interrupts import stop_signals
from ..notices import CompileNotice
from ..readback import read_run
from ..restart import WRITER_FLAGS, plan_restart
from ..result import Status
from ..rundir import OutputError, RunFolder, check_out, default_out, stale_partials
from ..scene import SceneError, load_scene
from ..simulate import prepare_run, simulate
from ..warmup import prepare_kernels
from ..writers.plots import write_plots
from ..writers.summary import write_summary
from ..writers.tables import EnergyTable, write_events_csv
from ..writers.thermo import ThermoLog
from ..writers.trajectory import TrajectoryFrames
from ..writers.vtk import FRAME_DIR, VTKFrames
from .exit_codes import EXIT_INTERRUPTED, EXIT_OK, EXIT_RUN_FAILED, fail


def add_parser(subparsers) -> None:
    """Register ``granular-chain run`` on the CLI's subparsers.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The CLI's subparsers (``parser.add_subparsers()``).
    """
    run = subparsers.add_parser("run", help="run a scene and write its outputs")
    run.add_argument("scene", nargs="?", default=None,
                     help="scene YAML file (optional with --restart: the run's own scene)")
    run.add_argument("--set", dest="overrides", action="append", default=[],
                     metavar="dotted.path=value", help="override a scene field (repeatable)")
    run.add_argument("--out", default=None,
                     help="output folder: a new one, or an earlier run folder with --overwrite "
                     "(default outputs/<scene name>, with a suffix for --set overrides)")
    run.add_argument("--restart", default=None, metavar="RUN_DIR",
                     help="continue an interrupted run from its checkpoint (bit for bit as "
                     "if it had never stopped), or extend a finished one to a later "
                     "run.t_end (--set run.t_end=T), in place; the scene is the run's own")
    run.add_argument("--overwrite", action="store_true",
                     help="replace the earlier run in --out (atomically; only a folder the "
                     "engine wrote, holding nothing else)")
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


def _writer_flags(args) -> dict:
    """The writer flags given (``--csv``, ``--no-trajectory``...): output field -> bool."""
    return {name: getattr(args, name) for name in WRITER_FLAGS
            if getattr(args, name, None) is not None}


def _apply_writer_flags(scene, args) -> None:
    for name, flag in _writer_flags(args).items():
        setattr(scene.output, name, flag)


class _Attached:
    """The writers attached to one run: they write while it goes, so the frames
    are not kept in memory (the plots, drawn after the run, read them back)."""

    def __init__(self, scene, ready, folder: Path, echo: bool, resume: Optional[dict] = None):
        model = ready.model
        out, run = scene.output, scene.run
        # a continued run reopens the files at the checkpoint's frame and thermo line
        frames = int(resume["log_count"]) if resume is not None else None
        lines = int(resume["thermo_lines"]) if resume is not None else None
        self.writers = []
        if out.trajectory:
            self.writers.append(TrajectoryFrames(folder, scene, model.count, frames,
                                                 model=model))
        if out.csv:
            self.writers.append(EnergyTable(folder, frames))
        self.streams = []  # subfolders that gain a file a frame
        if out.vtk:
            self.writers.append(VTKFrames(folder, model, resume_frames=frames))
            self.streams.append(FRAME_DIR)
        path = folder / "thermo.csv"
        if run.stepper == "verlet" and not run.stages:
            self.thermo = ThermoLog(model, ready.schedule.thermo_every, path, echo,
                                    resume_lines=lines)
        else:  # the event stepper and a staged run hand their frames on as they come:
            # thin them in time
            self.thermo = ThermoLog(model, 0, path, echo, dt=run.t_end / 20,
                                    resume_lines=lines)
            if resume is not None:
                self.thermo._last_t = float(resume["thermo_last_t"])
            self.writers.append(self.thermo)
        # Plots without a trajectory to read back need the frames in memory.
        self.keep_frames = out.plots and not out.trajectory

    def checkpoint(self, folder: Path, scene, noted=None):
        """The callback that saves a run's checkpoint with what the writers need to
        reopen their files at it (frames written, thermo lines), then calls
        ``noted(streams)`` (the run folder lists its files for --restart)."""

        def save(state: dict) -> None:
            state = dict(state)
            state["thermo_lines"] = self.thermo.lines
            state["thermo_last_t"] = float(self.thermo._last_t)
            save_checkpoint(folder, state, scene)
            if noted is not None:
                noted(self.streams)

        return save

    def abandon(self) -> None:
        """Close every file after a failure (the run folder is then removed)."""
        self.thermo.close()
        for w in self.writers:
            w.close(None)


def _write_outputs(result, folder: Path, scene, stop) -> list[str]:
    """What is written once the run has ended, summary.json last; returns the
    writers a stop request skipped.

    The event table takes a fraction of a second and is always written; the
    plots can take long and are skipped once a stop is asked for
    (``granular-chain plot RUN_DIR`` draws them later).
    """
    out = scene.output
    missed = []
    if out.csv:
        write_events_csv(result, folder)
    if out.plots and stop.requested:
        missed.append("plots")
    elif out.plots:
        frames = result
        if out.trajectory:  # the run streamed its frames: read them back
            frames = read_run(folder / "trajectory.h5")
        write_plots(frames, folder, scene)
    write_summary(result, folder, scene)
    return missed


def _incomplete_reason(result, stop, missed: list[str]) -> str:
    """Why a published run is incomplete ('' when it is complete)."""
    parts = []
    if result.status == Status.INTERRUPTED:
        again = ("run it again: a staged run is not continued" if result.info.get("stages")
                 else "continue it with --restart")
        parts.append(f"interrupted by {stop.name or 'a signal'} at t = {result.t_final:.6g} "
                     f"({again})")
    if missed:
        parts.append(f"interrupted while writing: {', '.join(missed)} not (fully) written")
    return "; ".join(parts)


def _check_extras(scene) -> None:
    """Refuse --plots / --vtk up front when the library they need is not installed
    (:class:`~granular_chain.extras.MissingExtraError`); frame.png alone needs pyvista
    and is skipped with a note without it."""
    if scene.output.plots:
        check("matplotlib", "granular-chain run --plots (output.plots)")
    if scene.output.vtk:
        check(("pyvista", "vtkmodules"), "granular-chain run --vtk (output.vtk)")


def _output_folder(args, scene) -> tuple[Path, bool]:
    """The run's folder and whether it is the default one (not named by --out)."""
    if args.out:
        return Path(args.out), False
    return default_out(scene.name, args.overrides), True


def run(args) -> int:
    """Entry point of ``granular-chain run``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of ``granular-chain run``.

    Returns
    -------
    int
        Exit status: 0 ok, 1 run failed, 2 bad input (also a full disk or too little
        memory), 129/130/143 stopped by SIGHUP/SIGINT/SIGTERM.
    """
    if args.scene is None and not args.restart:
        return fail("run: give a SCENE file, or --restart RUN_DIR to continue a run "
                    "(see granular-chain run --help)")
    if args.quiet:  # (the command's warning filters are restored when it returns)
        warnings.simplefilter("ignore", CompileNotice)
    try:
        scene, ready, out, restart = _prepare_run(args)
    except (SceneError, OutputError) as exc:
        return fail(str(exc))
    except SimulationError as exc:
        return fail(f"{args.scene or args.restart}: {exc}")
    try:
        prepare_kernels(scene, quiet=args.quiet, model=ready.model)
    except KeyboardInterrupt as exc:  # (raise_on_signals: SIGTERM and SIGHUP too)
        signum = getattr(exc, "signum", 0)
        print(f"granular-chain: interrupted while compiling by {exc or 'SIGINT'}; nothing "
              f"written", file=sys.stderr)
        return 128 + signum if signum else EXIT_INTERRUPTED
    return _execute(args, scene, ready, out, restart)


def _prepare_run(args):
    """Scene, its :class:`~granular_chain.simulate.Preflight` (Model and Schedule),
    output folder and (for --restart) the run to continue; every refusal happens here,
    before anything is written."""
    restart = None
    if args.restart:
        restart = plan_restart(args)
        scene, out = restart.scene, restart.out
    else:
        scene = load_scene(args.scene, args.overrides)
        _apply_writer_flags(scene, args)
        out, is_default = _output_folder(args, scene)
        check_out(out, overwrite=args.overwrite, scene_source=args.scene, is_default=is_default)
        _note_killed_runs(out)
    _check_extras(scene)
    ready = prepare_run(scene)
    if restart is not None:
        restart.decide(ready.model)
        if restart.fresh:  # said even with --quiet: the run takes as long as a new one
            print(f"granular-chain: note: the run is computed again from t = 0 to t_end = "
                  f"{scene.run.t_end:g}: {restart.fresh}", file=sys.stderr)
    return scene, ready, out, restart


def _note_killed_runs(out: Path) -> None:
    """Say where a killed run to the same folder left a checkpoint (it is kept)."""
    parent = out.parent if str(out.parent) else Path(".")
    for tmp in stale_partials(parent, out.name, recoverable=True):
        print(f"granular-chain: note: a killed run to {out} left a checkpoint in {tmp}: "
              f"continue it with --restart {tmp}, or remove it", file=sys.stderr)


def _attach(args, scene, ready, folder: Path, resume) -> _Attached:
    """The run's writers; a continued run's files that cannot be reopened (a truncated
    or corrupted trajectory.h5) are refused in one line."""
    if resume is None:
        return _Attached(scene, ready, folder, not args.quiet, resume)
    try:
        return _Attached(scene, ready, folder, not args.quiet, resume)
    except (OSError, ValueError, KeyError) as exc:
        raise OutputError(f"--restart {args.restart}: its files cannot be continued from "
                          f"the checkpoint ({' '.join(str(exc).split())})") from None


def _execute(args, scene, ready, out: Path, restart) -> int:
    """Run with the writers attached, then publish the run folder."""
    about = {"scene_name": scene.name, "stepper": scene.run.stepper,
             "destination": str(out.resolve())}
    if restart is None:
        about.update(scene_source=str(Path(args.scene).resolve()),
                     overrides=list(args.overrides), writers=_writer_flags(args))
    else:
        about.update(scene_source=restart.scene_source, overrides=restart.overrides,
                     writers=restart.writers)
    with stop_signals() as stop:
        try:
            with RunFolder(out, about) as folder:
                resume = restart.prepare(folder.tmp) if restart is not None else None
                attached = _attach(args, scene, ready, folder.tmp, resume)
                try:
                    result = simulate(
                        scene, progress=_bar_wanted(args), writers=attached.writers,
                        keep_frames=attached.keep_frames, thermo=attached.thermo,
                        checkpoint=attached.checkpoint(folder.tmp, scene, folder.note_files),
                        resume=resume, end_checkpoint=True, model=ready.model,
                        schedule=ready.schedule)
                except BaseException:
                    attached.abandon()
                    raise
                attached.thermo.close()
                if (result.status == Status.INTERRUPTED and out.exists()
                        and (restart is None or restart.fresh)
                        and not scene.run.stages):  # (a staged run is not continued)
                    # the earlier run stays; this one is kept aside, to be continued
                    _write_outputs(result, folder.tmp, scene, stop)
                    kept = folder.keep(reason=_incomplete_reason(result, stop, []))
                    print(f"granular-chain: interrupted at t = {result.t_final:.6g}; the "
                          f"earlier run in {out} is kept; this one is in {kept}: continue "
                          f"it with --restart {kept}", file=sys.stderr)
                    return stop.exit_code
                missed = _write_outputs(result, folder.tmp, scene, stop)
                reason = _incomplete_reason(result, stop, missed)
                if not reason and not _extendable(result):
                    (folder.tmp / CHECKPOINT).unlink(missing_ok=True)
                folder.publish(complete=not reason, reason=reason)
                if restart is not None:
                    restart.finish()
        except OutputError as exc:
            return fail(str(exc))
        except OSError as exc:  # a full disk, a quota, an I/O error: the folder is removed
            return fail(f"{out}: cannot be written ({_os_problem(exc)}); nothing written")
        except KeyboardInterrupt:  # a second signal: nothing kept, nothing left behind
            print(f"granular-chain: interrupted; nothing written to {out}", file=sys.stderr)
            return stop.exit_code or EXIT_INTERRUPTED
    _report(args, result, out, reason)
    if reason:  # stopped by a signal: the run folder is marked incomplete
        return stop.exit_code or EXIT_INTERRUPTED
    return EXIT_OK if result.success else EXIT_RUN_FAILED


def _bar_wanted(args) -> bool:
    """A progress bar on standard error: on a terminal, unless --quiet (piped or
    redirected output gets the thermo lines and the report only)."""
    return not args.quiet and sys.stderr.isatty()


def _extendable(result) -> bool:
    """A finished run keeps its last checkpoint when a later run.t_end can go on from
    it: a Verlet run that reached t_end (:mod:`granular_chain.restart`)."""
    return result.stepper == "verlet" and result.status == Status.T_END


def _os_problem(exc: OSError) -> str:
    """An OSError in words: its reason, and the file when it names one."""
    what = exc.strerror or str(exc)
    if exc.errno in (errno.ENOSPC, errno.EDQUOT):
        what += ": free some space, or write elsewhere with --out"
    return f"{exc.filename}: {what}" if exc.filename else what


def _report(args, result, out: Path, reason: str) -> None:
    if reason:  # said even with --quiet: the folder is not what a finished run leaves
        print(f"granular-chain: {reason}; wrote {out}/ marked incomplete", file=sys.stderr)
    if args.quiet:
        if not reason and not result.success:  # why the run failed, in one line
            print(f"granular-chain: {result.status.name.lower()}: {result.message}; wrote "
                  f"{out}/", file=sys.stderr)
        return
    print(f"{result.status.name.lower()}: {result.message}")
    print(f"t_final = {result.t_final:.12g}, steps = {result.steps}, "
          f"energy balance error = {result.energy.balance_error:.3g} (relative)")
    print(f"wrote {out}/")
