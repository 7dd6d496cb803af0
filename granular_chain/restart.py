"""``granular-chain run [SCENE] --restart RUN_DIR``: continue a run, or extend a finished one.

RUN_DIR is a run folder of the engine: one that did not complete (interrupted by Ctrl-C
or SIGTERM), the hidden ``.NAME.partial-XXXX`` folder a killed run left (it keeps its
checkpoint), or a complete run given a later ``run.t_end``. The scene is the run's own,
stored in the folder (its checkpoint's, else summary.json's): without SCENE it is used as
it is, with the command line's ``--set`` overrides and writer flags applied to it; with
SCENE, the run's own ``--set`` overrides and writer flags (run.json) are applied to
SCENE first. Either way the scene must equal the run's to the last field, except a later
``run.t_end``.

An interrupted run goes on from its checkpoint: its files are copied into a new
temporary folder, cut back to the checkpoint's frame (the frames written after it, and
an interrupted run's extra last frame, are dropped), and the run goes on. A later
``run.t_end`` goes on from the checkpoint too when a run straight to it passes through
that state: Verlet, whose step, frame cadence and thermo cadence do not depend on t_end
(run.dt set; output.every or output.dt; output.thermo), from the checkpoint a finished
Verlet run keeps at its last frame of the cadence before t_end. Otherwise (the event
stepper, whose steps before t_end depend on it; a Verlet plan that t_end changes; a run
without a checkpoint) the run is computed again from t = 0. Either way the result equals,
bit for bit, a run straight to the later t_end, and it is published in RUN_DIR's place (a
partial folder's destination) by a rename.
"""

from __future__ import annotations

import copy
import json
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

from .checkpoint import CHECKPOINT, load_checkpoint, save_checkpoint, scene_difference
from .rundir import (MARKER, OutputError, _pid_alive, check_out, check_partial, read_marker,
                     remove_files)
from .scene import (Scene, SceneError, apply_overrides, load_scene, own_stepper_options,
                    scene_from_dict)
from .steppers.schedule import thermo_every
from .steppers.verlet.timestep import step_plan

__all__ = ["RestartPlan", "plan_restart", "extension_problem", "WRITER_FLAGS"]

#: The scene's output fields that ``run``'s writer flags set (--vtk, --trajectory...).
WRITER_FLAGS = ("vtk", "trajectory", "csv", "plots")


@dataclass
class RestartPlan:
    """Where a continued run comes from and goes to, and its scene.

    Attributes
    ----------
    source : Path
        The run folder (or partial folder) continued.
    out : Path
        Where the continued run is published.
    partial : bool
        The source is a killed run's hidden partial folder (removed after).
    scene : Scene
        The continued run's scene.
    stored_t_end : float
        ``run.t_end`` of the run in ``source`` (scene units of time).
    complete : bool
        The run in ``source`` is complete (a later t_end extends it).
    checkpoint : bool
        ``source`` holds a checkpoint.
    scene_source, overrides, writers
        For the new marker: the scene file, the ``--set`` overrides and the writer
        flags of the run, its own and the command line's.
    fresh : str
        Why the run is computed again from t = 0 ('' when it goes on from the
        checkpoint); set by :meth:`decide`.
    """

    source: Path
    out: Path
    partial: bool
    scene: Scene
    stored_t_end: float
    complete: bool
    checkpoint: bool
    scene_source: str = ""
    overrides: list = field(default_factory=list)
    writers: dict = field(default_factory=dict)
    fresh: str = ""
    _copied: list = field(default_factory=list)  #: files prepare() copied, relative

    @property
    def extended(self) -> bool:
        """The run goes to a later ``run.t_end`` than the stored run's."""
        return self.scene.run.t_end > self.stored_t_end

    def decide(self, model, overwrite: bool = False) -> None:
        """Go on from the checkpoint, or compute the run again from t = 0 (sets
        :attr:`fresh`); the folder a run computed again replaces is checked here.

        Parameters
        ----------
        model : Model
            The continued run's model (scene units).
        overwrite : bool
            ``--overwrite`` was given (a partial folder's destination holds a run).

        Raises
        ------
        OutputError
            The run folder cannot be replaced (a file the engine did not write).
        """
        if not self.extended:
            return
        old = self.scene.model_copy(deep=True)
        old.run.t_end = self.stored_t_end
        self.fresh = extension_problem(old, self.scene, model)
        if not self.fresh and not self.checkpoint:
            self.fresh = ("the run has no checkpoint to extend it from (a finished Verlet "
                          "run keeps one when it reached t_end)")
        if self.fresh and not self.partial:  # replaced whole, as with --overwrite
            check_out(self.out, overwrite=True, scene_source=self.scene_source,
                      is_default=False)

    def prepare(self, tmp: Path) -> Optional[dict]:
        """Copy the source's files into the new run's folder ``tmp``; the checkpoint
        state (None: the run is computed again from t = 0, nothing is copied).

        Parameters
        ----------
        tmp : Path
            The new run's temporary folder.

        Returns
        -------
        dict or None
            The checkpoint's driver state.
        """
        if self.fresh:
            return None
        try:
            for path in sorted(self.source.rglob("*")):
                rel = path.relative_to(self.source)
                if path.is_symlink() or not path.is_file() or rel.as_posix() == MARKER:
                    continue  # (check_partial refused links; one made since is not copied)
                (tmp / rel).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(path, tmp / rel)
                self._copied.append(rel.as_posix())
            state, _ = load_checkpoint(tmp)
        except (OSError, ValueError) as exc:
            raise OutputError(f"--restart {self.source}: cannot be read ({exc})") from None
        if self.extended:  # the checkpoint now belongs to the run to the later t_end
            save_checkpoint(tmp, state, self.scene)
        return state

    def finish(self) -> None:
        """After publishing: a partial folder continued elsewhere is no longer needed.

        Only the files copied into the continued run (now published), or for a run
        computed again those the partial folder's marker lists, and the marker are
        removed, then the folders left empty; anything else stays.
        """
        if not self.partial or not self.source.exists():
            return
        listed = self._copied
        if self.fresh:
            listed = [*(read_marker(self.source) or {}).get("files", []), CHECKPOINT]
        remove_files(self.source, [*listed, MARKER])


def extension_problem(old: Scene, new: Scene, model) -> str:
    """Why a run straight to ``new``'s later t_end does not pass through the checkpoint
    of a run of ``old`` ('' when it does: Verlet with the same step plan).

    Parameters
    ----------
    old, new : Scene
        The same scene but for ``run.t_end`` (``new``'s later).
    model : Model
        Their model (scene units; it does not depend on t_end).

    Returns
    -------
    str
        What depends on t_end, in words; '' when nothing does.
    """
    if new.run.stepper != "verlet":
        return ("the event stepper's steps before t_end depend on it (the last one ends "
                "at t_end, and events are searched within each step)")
    a, b = step_plan(model, old), step_plan(model, new)
    t0, t1 = old.run.t_end, new.run.t_end
    if a.dt != b.dt:
        return (f"run.dt is not set: the default step divides t_end ({a.dt:.6g} at "
                f"t_end = {t0:g}, {b.dt:.6g} at {t1:g})")
    if a.every != b.every:
        return (f"output.every and output.dt are not set: a run has about 1000 frames "
                f"(every {a.every} steps at t_end = {t0:g}, {b.every} at {t1:g})")
    every = new.output.thermo
    if thermo_every(a.steps, every) != thermo_every(b.steps, every):
        return (f"output.thermo is not set: a run has about 20 thermo lines (every "
                f"{thermo_every(a.steps, every)} steps at t_end = {t0:g}, "
                f"{thermo_every(b.steps, every)} at {t1:g})")
    return ""


def _read_checkpoint(folder: Path) -> tuple[dict, dict]:
    """:func:`load_checkpoint`, with a file that is not a whole checkpoint (truncated,
    corrupted, from another program) refused as an :class:`OutputError`."""
    try:
        return load_checkpoint(folder)
    except Exception as exc:  # zipfile, pickle, JSON and numpy errors alike: one line
        problem = " ".join(str(exc).split()) or type(exc).__name__
        raise OutputError(f"--restart {folder}: {CHECKPOINT} cannot be read, it is "
                          f"truncated or corrupted ({problem})") from None


def _summary_scene(folder: Path) -> dict:
    """The scene a complete run recorded in its summary.json (as a JSON mapping)."""
    try:
        scene = json.loads((folder / "summary.json").read_text())["scene"]
    except (OSError, ValueError, KeyError, TypeError):
        scene = None
    if not isinstance(scene, dict):
        raise OutputError(f"--restart {folder}: its summary.json does not hold the run's "
                          f"scene; it cannot be continued")
    return scene


def _source_folder(args) -> tuple[Path, dict]:
    """RUN_DIR and its marker; the refusals that need no scene."""
    source = Path(args.restart)
    cwd = Path.cwd().resolve()
    if source.resolve() == cwd or source.resolve() in cwd.parents:
        raise OutputError(f"--restart {source}: is the current folder or contains it; run "
                          f"from outside the run folder")
    if args.out:
        raise OutputError("--restart: the run goes on in RUN_DIR's place; leave out --out")
    if source.is_symlink():
        raise OutputError(f"--restart {source}: is a symbolic link; name the folder itself")
    if not source.is_dir():
        raise OutputError(f"--restart {source}: no such run folder")
    marker = read_marker(source)
    if marker is None:
        raise OutputError(f"--restart {source}: not a run folder of the engine (no {MARKER})")
    if ".partial-" in source.name and _pid_alive(marker.get("pid")):
        raise OutputError(f"--restart {source}: the run is still going (process {marker['pid']})")
    return source, marker


def _continued_scene(args, source: Path, marker: dict, stored: dict):
    """The continued run's scene, its scene file, overrides and writer flags.

    Without SCENE: the stored scene with the command line's ``--set`` and writer
    flags. With SCENE: SCENE with the run's own overrides and writer flags, then the
    command line's.
    """
    overrides = [*marker.get("overrides", []), *args.overrides]
    given = {name: getattr(args, name) for name in WRITER_FLAGS
             if getattr(args, name, None) is not None}
    writers = {**marker.get("writers", {}), **given}  # the run's flags, then these
    if args.scene:
        scene = load_scene(args.scene, overrides)
        scene_source = str(Path(args.scene).resolve())
        applied = writers
    else:
        data = copy.deepcopy(stored)
        name = f"{source} (the run's scene)"
        if args.overrides:
            apply_overrides(data, list(args.overrides), source=f"{name} (--set)")
        scene = scene_from_dict(data, source=name)
        scene_source = marker.get("scene_source", "")
        applied = given  # (the stored scene holds the run's own choices already)
    for name, flag in applied.items():
        if name in WRITER_FLAGS:
            setattr(scene.output, name, bool(flag))
    return scene, scene_source, overrides, writers


def _refuse_stages(source, scene: Scene) -> None:
    """A staged run (``run.stages``) writes no checkpoint and is not continued."""
    if scene.run.stages:
        raise OutputError(f"--restart {source}: the scene has run.stages; a staged run "
                          f"is not continued from a checkpoint: run it again")


def _with_defaults(stored: dict) -> dict:
    """The stored scene as the schema reads it now: a field added since the run was
    written compares as its default (a missing ``contacts.law`` as 'auto'); a mapping
    the schema no longer reads is compared as stored."""
    try:
        return scene_from_dict(stored, stored=True).model_dump(mode="json")
    except SceneError:
        return stored


def _check_scene(source: Path, stored: dict, scene: Scene, complete: bool) -> None:
    """Refuse a scene that is not the run's own but for a later ``run.t_end``."""
    _refuse_stages(source, scene)
    given = scene.model_dump(mode="json")
    stored = _with_defaults(stored)
    t_old, t_new = stored.get("run", {}).get("t_end"), scene.run.t_end
    differs = scene_difference(stored, {**given, "run": {**given["run"], "t_end": t_old}})
    if differs:
        hint = (" (the run's writer flags: --csv, --vtk, --plots, --no-trajectory)"
                if differs in {f"output.{name}" for name in WRITER_FLAGS} else "")
        raise OutputError(f"--restart {source}: the scene differs from the run's at {differs}"
                          f"{hint}; a run continues only with its own scene (or a later "
                          f"run.t_end)")
    if t_new < t_old:
        raise OutputError(f"--restart {source}: run.t_end = {t_new:g} is before the run's "
                          f"t_end = {t_old:g}; a run continues to its own t_end or a later one")
    if complete and t_new == t_old:
        raise OutputError(f"--restart {source}: the run is complete at its t_end = {t_old:g}; "
                          f"nothing to continue: extend it with a later run.t_end (--set "
                          f"run.t_end=T)")
    if scene.output.plots and not scene.output.trajectory:
        raise OutputError(f"--restart {source}: the plots of a continued run are drawn from "
                          f"its trajectory.h5; this run writes none (output.trajectory: false)")


def plan_restart(args) -> RestartPlan:
    """Check ``--restart RUN_DIR`` and build the continued run's scene (raises
    :class:`OutputError`, or :class:`~granular_chain.scene.SceneError` for a bad scene).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed ``granular-chain run`` arguments (``scene`` may be None,
        ``--restart``, ``--set``, ``--out``, writer flags...).

    Returns
    -------
    RestartPlan
        Source, destination and scene of the continued run (call
        :meth:`RestartPlan.decide` with its model next).

    Raises
    ------
    OutputError
        The folder cannot be continued with this scene.
    """
    if args.scene:  # refused before the folder is looked at
        _refuse_stages(args.restart, load_scene(args.scene, list(args.overrides)))
    source, marker = _source_folder(args)
    complete = bool(marker.get("complete"))
    has_checkpoint = (source / CHECKPOINT).is_file()
    if not complete and not has_checkpoint:
        raise OutputError(f"--restart {source}: has no {CHECKPOINT} (a run writes one when "
                          f"interrupted, and every output.checkpoint_every steps)")
    if has_checkpoint:
        # every file copied must be one the run wrote: listed, and a regular file
        check_partial(source, {**marker, "files": [*marker.get("files", []), CHECKPOINT]})
        _, stored = _read_checkpoint(source)
    else:
        stored = _summary_scene(source)
    stored = own_stepper_options(stored)
    scene, scene_source, overrides, writers = _continued_scene(args, source, marker, stored)
    _check_scene(source, stored, scene, complete)
    partial = ".partial-" in source.name
    out = source
    if partial:
        out = Path(marker.get("destination")
                   or source.with_name(source.name.split(".partial-")[0][1:]))
        check_out(out, overwrite=args.overwrite, scene_source=scene_source, is_default=False)
    return RestartPlan(source, out, partial, scene, float(stored["run"]["t_end"]), complete,
                       has_checkpoint, scene_source, overrides, writers)
