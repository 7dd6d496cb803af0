"""``granular-chain run SCENE --restart RUN_DIR``: continue a run from its checkpoint.

RUN_DIR is a run that did not complete: a run folder marked incomplete (interrupted by
Ctrl-C or SIGTERM), or the hidden ``.NAME.partial-XXXX`` folder a killed run left (it
keeps its checkpoint). The scene must be the run's own, to the last field. The run's
files are copied into a new temporary folder, cut back to the checkpoint's frame (the
frames written after it, and an interrupted run's extra last frame, are dropped) and the
run goes on from the checkpoint: trajectory, tables, thermo log, VTK series and final
state are those of the run that was never stopped, bit for bit. The continued run is
published in RUN_DIR's place (a partial folder's destination), replacing it by a rename.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass, field
from pathlib import Path

from .checkpoint import CHECKPOINT, load_checkpoint, scene_difference
from .rundir import (MARKER, OutputError, _pid_alive, check_out, check_partial, read_marker,
                     remove_files)

__all__ = ["RestartPlan", "plan_restart"]


@dataclass
class RestartPlan:
    """Where a continued run comes from and goes to.

    Attributes
    ----------
    source : Path
        The incomplete run folder (or partial folder) with the checkpoint.
    out : Path
        Where the continued run is published.
    partial : bool
        The source is a killed run's hidden partial folder (removed after).
    """

    source: Path  #: the incomplete run folder (or partial folder) with the checkpoint
    out: Path  #: where the continued run is published
    partial: bool  #: the source is a killed run's hidden partial folder (removed after)
    _copied: list = field(default_factory=list)  #: files prepare() copied, relative

    def prepare(self, tmp: Path) -> dict:
        """Copy the source's files into the new run's folder ``tmp``; the checkpoint state.

        Parameters
        ----------
        tmp : Path
            The new run's temporary folder.

        Returns
        -------
        dict
            The checkpoint's driver state.
        """
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
        return state

    def finish(self) -> None:
        """After publishing: a partial folder continued elsewhere is no longer needed.

        Only the files copied into the continued run (now published) and the
        marker are removed, then the folders left empty; anything else stays.
        """
        if not self.partial or not self.source.exists():
            return
        remove_files(self.source, [*self._copied, MARKER])


def _read_checkpoint(folder: Path) -> tuple[dict, dict]:
    """:func:`load_checkpoint`, with a file that is not a whole checkpoint (truncated,
    corrupted, from another program) refused as an :class:`OutputError`."""
    try:
        return load_checkpoint(folder)
    except Exception as exc:  # zipfile, pickle, JSON and numpy errors alike: one line
        problem = " ".join(str(exc).split()) or type(exc).__name__
        raise OutputError(f"--restart {folder}: {CHECKPOINT} cannot be read, it is "
                          f"truncated or corrupted ({problem})") from None


def plan_restart(args, scene) -> RestartPlan:
    """Check ``--restart RUN_DIR`` against the scene (raises :class:`OutputError`).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed ``granular-chain run`` arguments (``--restart``, ``--out``...).
    scene : Scene
        The scene of the continued run (must match the checkpoint's).

    Returns
    -------
    RestartPlan
        Source and destination of the continued run.

    Raises
    ------
    OutputError
        The folder cannot be continued with this scene.
    """
    source = Path(args.restart)
    if scene.run.stages:
        raise OutputError(f"--restart {source}: the scene has run.stages; a staged run "
                          f"is not continued from a checkpoint: run it again")
    cwd = Path.cwd().resolve()
    if source.resolve() == cwd or source.resolve() in cwd.parents:
        raise OutputError(f"--restart {source}: is the current folder or contains it; run "
                          f"from outside the run folder")
    if args.out:
        raise OutputError("--restart: the run goes on in RUN_DIR's place; leave out --out")
    if source.is_symlink():
        raise OutputError(f"--restart {source}: is a symbolic link; name the folder itself")
    marker = read_marker(source)
    if marker is None:
        raise OutputError(f"--restart {source}: not a run folder of the engine (no {MARKER})")
    if marker.get("complete"):
        raise OutputError(f"--restart {source}: the run is complete; nothing to continue")
    partial = ".partial-" in source.name
    if partial and _pid_alive(marker.get("pid")):
        raise OutputError(f"--restart {source}: the run is still going (process {marker['pid']})")
    if not (source / CHECKPOINT).is_file():
        raise OutputError(f"--restart {source}: has no {CHECKPOINT} (a run writes one when "
                          f"interrupted, and every output.checkpoint_every steps)")
    # every file copied must be one the run wrote: listed, and a regular file
    check_partial(source, {**marker, "files": [*marker.get("files", []), CHECKPOINT]})
    _, stored = _read_checkpoint(source)
    differs = scene_difference(stored, scene.model_dump(mode="json"))
    if differs:
        hint = (" (repeat the run's output flags: --csv, --vtk, --plots, --no-trajectory)"
                if differs.startswith("output.") else "")
        raise OutputError(f"--restart {source}: the scene differs from the run's at {differs}"
                          f"{hint}; a run continues only with its own scene")
    if scene.output.plots and not scene.output.trajectory:
        raise OutputError(f"--restart {source}: the plots of a continued run are drawn from "
                          f"its trajectory.h5; this run writes none (output.trajectory: false)")
    if not partial:
        return RestartPlan(source, source, False)
    out = Path(marker.get("destination") or source.with_name(source.name.split(".partial-")[0][1:]))
    check_out(out, overwrite=args.overwrite, scene_source=args.scene, is_default=False)
    return RestartPlan(source, out, True)
