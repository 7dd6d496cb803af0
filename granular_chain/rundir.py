"""Run folders: the only places the engine writes into, and the only things it removes.

A run folder carries a marker, ``run.json``, naming the engine, its version,
whether the run is complete (and if not, why), and every file the engine
wrote into the folder. The rules, as rsync and git keep them:

- The engine removes or replaces only files listed in a marker it wrote. A
  folder without a marker, or holding a file its marker does not list, is
  never touched: the run is refused before anything is computed.
- A run is written into a hidden temporary folder beside its destination
  (``.NAME.partial-XXXX``, itself marked incomplete from its first moment) and
  renamed into place when its writers have finished. An earlier run is
  replaced by a rename too, so a failure at any point leaves the old run whole.
- A run that is interrupted (SIGINT, SIGTERM) is published marked incomplete,
  with the reason; a run that fails is removed. A temporary folder left by a
  hard kill (SIGKILL, power loss) carries its own incomplete marker and is
  removed by the next run to the same destination once its process is gone.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Iterable, Optional, Sequence

import yaml

__all__ = ["MARKER", "OutputError", "RunFolder", "default_out", "read_marker", "check_out",
           "check_new_files", "adopt_files", "write_text_atomic", "stale_partials",
           "remove_files"]

MARKER = "run.json"
ENGINE = "granular_chain"


class OutputError(ValueError):
    """An output folder that cannot be used (one line naming ``--out`` and why)."""


def _version() -> str:
    from . import __version__
    return __version__


def default_out(scene_name: str, overrides: Sequence[str], root: Path = Path("outputs")) -> Path:
    """``outputs/<name>``, or ``outputs/<name>-<8 hex>`` when ``--set`` overrides were given.

    The suffix is a digest of the overrides as parsed values (the last one of a
    path wins), so runs of one scene with different overrides never share a
    folder, and the same overrides always find the same folder, whatever their
    order or spelling (``1`` and ``1.0`` differ; ``[0,1]`` and ``[0, 1]`` do not).

    Parameters
    ----------
    scene_name : str
        Name of the scene.
    overrides : sequence of str
        The ``--set path=value`` overrides, as typed.
    root : Path
        Folder that holds the run folders.

    Returns
    -------
    Path
        The run folder (not created).
    """
    if not overrides:
        return root / scene_name
    parsed = {}
    for item in overrides:
        path, _, raw = item.partition("=")
        try:
            parsed[path.strip()] = yaml.safe_load(raw)
        except yaml.YAMLError:
            parsed[path.strip()] = raw
    canon = json.dumps(sorted(parsed.items()), default=str, separators=(",", ":"))
    return root / f"{scene_name}-{hashlib.sha1(canon.encode()).hexdigest()[:8]}"


def read_marker(folder: Path) -> Optional[dict]:
    """The marker of a run folder, or None when ``folder`` is not one the engine wrote.

    Parameters
    ----------
    folder : Path
        Any folder.

    Returns
    -------
    dict or None
        The parsed marker.
    """
    try:
        data = json.loads((Path(folder) / MARKER).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("engine") != ENGINE:
        return None
    return data


def _files_below(folder: Path) -> list[str]:
    """Every file and link below ``folder``, as sorted POSIX paths relative to it."""
    found = []
    for root, dirs, files in os.walk(folder):
        rel = Path(root).relative_to(folder)
        for name in files + [d for d in dirs if (Path(root) / d).is_symlink()]:
            found.append((rel / name).as_posix())
    return sorted(found)


def _foreign_files(folder: Path, marker: dict) -> list[str]:
    """Files below a run folder that its marker does not list (the user's, not ours)."""
    ours = set(marker.get("files", [])) | {MARKER}
    return [f for f in _files_below(folder) if f not in ours]


def _pid_alive(pid) -> bool:
    if not isinstance(pid, int) or pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def check_out(out: Path, *, overwrite: bool, scene_source: str, is_default: bool) -> None:
    """Refuse an output folder the run must not write to (raises :class:`OutputError`).

    Called before anything is computed or created. ``out`` may be written when
    it does not exist, or when it is a complete run folder of the engine whose
    files are all the engine's and ``overwrite`` is given (or, for the default
    folder, the earlier run was of the same scene file).

    Parameters
    ----------
    out : Path
        The output folder asked for.
    overwrite : bool
        ``--overwrite`` was given.
    scene_source : str
        Path of the scene file (compared with the marker of an earlier run).
    is_default : bool
        ``out`` is the default folder (not named with ``--out``).

    Raises
    ------
    OutputError
        ``out`` must not be written.
    """
    name = f"--out {out}" if not is_default else f"output folder {out}"
    cwd = Path.cwd().resolve()
    resolved = out.resolve()
    if resolved == cwd or resolved in cwd.parents:
        raise OutputError(f"{name}: is the current folder or contains it; name a new folder "
                          f"for the run (for example --out runs/first)")
    if out.is_symlink():
        raise OutputError(f"{name}: is a symbolic link; name the folder itself")
    if not out.exists():
        for parent in out.parents:  # a file where a folder is needed: say so now
            if parent.exists() and not parent.is_dir():
                raise OutputError(f"{name}: {parent} is a file, not a folder")
        return
    if not out.is_dir():
        raise OutputError(f"{name}: is a file, not a folder; nothing was changed")
    marker = read_marker(out)
    if marker is None:
        what = "an empty folder" if not any(out.iterdir()) else "a folder"
        raise OutputError(f"{name}: exists and is {what} the engine did not write (no "
                          f"{MARKER}); nothing was changed: name a new folder")
    if not marker.get("complete") and _pid_alive(marker.get("pid")) \
            and marker.get("pid") != os.getpid():
        raise OutputError(f"{name}: a run is being written there (process {marker['pid']})")
    same_scene = marker.get("scene_source") == str(Path(scene_source).resolve())
    if not overwrite and not (is_default and same_scene):
        hint = "add --overwrite to replace it" if is_default is False else (
            f"it holds a run of {marker.get('scene_source')}: use --out, or --overwrite")
        raise OutputError(f"{name}: holds an earlier run; {hint}")
    foreign = _foreign_files(out, marker)
    if foreign:
        more = f" and {len(foreign) - 1} more" if len(foreign) > 1 else ""
        raise OutputError(f"{name}: {foreign[0]}{more} was not written by the engine; move "
                          f"it out of the folder before replacing the run")


class RunFolder:
    """The temporary folder a run is written into, and its publication.

    Use as a context manager: on entry the temporary folder exists (marked
    incomplete); :meth:`publish` renames it onto ``out``; leaving the block
    without publishing removes it (it holds nothing but what the run wrote).

    Parameters
    ----------
    out : Path
        Destination, already accepted by :func:`check_out`.
    about : dict
        Facts for the marker (scene name and source, overrides, stepper).
    """

    def __init__(self, out: Path, about: dict):
        self.out = Path(out)
        self.about = dict(about)
        self.tmp: Optional[Path] = None
        self.published = False
        self._made: list[Path] = []
        self._replaces = False

    def __enter__(self) -> "RunFolder":
        parent = self.out.parent
        # the folders this run creates, deepest first: removed again if it fails
        self._made = [p for p in [parent, *parent.parents] if not p.exists()]
        self._replaces = read_marker(self.out) is not None  # an earlier run, accepted
        try:
            parent.mkdir(parents=True, exist_ok=True)
            _remove_stale_partials(parent, self.out.name)
            self.tmp = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.partial-", dir=parent))
        except OSError as exc:
            raise OutputError(f"--out {self.out}: cannot be written "
                              f"({exc.strerror or exc})") from None
        self._write_marker(self.tmp, complete=False, reason="running", files=[])
        return self

    def __exit__(self, *exc) -> None:
        if self.published:
            return
        if self.tmp is not None and self.tmp.exists():
            shutil.rmtree(self.tmp, ignore_errors=True)
        for folder in self._made:
            try:
                folder.rmdir()
            except OSError:
                break  # not empty (or not ours to remove): leave it and its parents

    def _write_marker(self, folder: Path, *, complete: bool, reason: str,
                      files: Iterable[str]) -> None:
        data = {"engine": ENGINE, "version": _version(), "complete": complete,
                "reason": reason, "pid": os.getpid(), **self.about,
                "files": sorted(files)}
        tmp = folder / f".{MARKER}.tmp"
        tmp.write_text(json.dumps(data, indent=2) + "\n")
        os.replace(tmp, folder / MARKER)

    def keep(self, *, reason: str) -> Path:
        """Leave the run where it is (its hidden temporary folder), marked incomplete:
        an interrupted run that would have replaced an earlier one, which stays.

        Parameters
        ----------
        reason : str
            Why the run is incomplete (kept in the marker; '' for a complete run).

        Returns
        -------
        Path
            The temporary folder kept.
        """
        files = [f for f in _files_below(self.tmp) if f != MARKER]
        self._write_marker(self.tmp, complete=False, reason=reason, files=files)
        self.published = True  # (not removed on exit)
        return self.tmp

    def publish(self, *, complete: bool, reason: str = "") -> None:
        """Mark the run (complete or not, and why) and rename it onto ``out``.

        An earlier run at ``out`` (accepted by :func:`check_out` when the run
        started, and still an engine run folder holding nothing else) is moved
        aside first and removed file by file after the rename, only its marker's
        files. Anything else found at ``out`` now (it appeared while the run went)
        is left alone: the run is published beside it, and OutputError says where.

        Parameters
        ----------
        complete : bool
            Whether the run reached its end.
        reason : str
            Why the run is incomplete (kept in the marker; '' for a complete run).
        """
        files = [f for f in _files_below(self.tmp) if f != MARKER]
        self._write_marker(self.tmp, complete=complete, reason=reason, files=files)
        umask = os.umask(0)  # mkdtemp made the folder 0700; give it mkdir's mode
        os.umask(umask)
        os.chmod(self.tmp, 0o777 & ~umask)
        if not self.out.exists() and not self.out.is_symlink():
            self.tmp.rename(self.out)
            self.published = True
            return
        problem = self._replace_problem()
        if problem:
            beside = Path(tempfile.mkdtemp(prefix=f"{self.out.name}.run-", dir=self.out.parent))
            self.tmp.rename(beside)  # (onto the empty folder mkdtemp made)
            self.published = True
            raise OutputError(f"--out {self.out}: {problem}; it was left alone and the run "
                              f"was written to {beside}")
        old = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.old-", dir=self.out.parent))
        self.out.rename(old)  # (onto the empty folder mkdtemp made)
        try:
            self.tmp.rename(self.out)
        except BaseException:
            old.rename(self.out)  # put the earlier run back rather than leave no run
            raise
        self.published = True
        _remove_run(old)

    def _replace_problem(self) -> str:
        """Why ``out``, found at publication, must not be replaced ('' if it may)."""
        if not self._replaces:
            return "appeared while the run went"
        marker = read_marker(self.out)
        if marker is None or self.out.is_symlink():
            return "is no longer a run folder of the engine"
        foreign = _foreign_files(self.out, marker)
        if foreign:
            return f"{foreign[0]} was put there while the run went"
        return ""


def _remove_run(folder: Path) -> None:
    """Remove a run folder the engine wrote: its marker's files, then empty folders.

    Anything else found there is left in place, and the folder with it.
    """
    marker = read_marker(folder)
    if marker is not None:
        remove_files(folder, [*marker.get("files", []), MARKER])


def remove_files(folder: Path, files) -> None:
    """Remove the listed files (paths relative to ``folder``), then the folders that
    held them once they are empty, up to ``folder`` itself.

    A listed path that is absolute, climbs out with ``..`` or passes through a link
    to another folder is skipped (a marker edited by hand, or a subfolder replaced by
    a link, cannot reach outside the run folder); anything not listed stays, and the
    folders that hold it.

    Parameters
    ----------
    folder : Path
        A run folder.
    files : iterable of str
        Paths relative to ``folder`` (as listed in its marker).
    """
    folder = Path(folder)
    inside = folder.resolve()
    emptied = {folder}
    for rel in files:
        rel = Path(rel)
        if rel.is_absolute() or ".." in rel.parts:
            continue
        target = folder / rel
        if inside not in target.parent.resolve().parents and target.parent.resolve() != inside:
            continue  # a listed subfolder replaced by a link to elsewhere: not the engine's
        if target.is_file() or target.is_symlink():
            target.unlink()
            emptied.update(p for p in target.parents if folder in p.parents)
    for held in sorted(emptied, key=lambda p: len(p.parts), reverse=True):  # children first
        try:
            held.rmdir()
        except OSError:
            pass  # not empty: holds something that is not the engine's


def _remove_stale_partials(parent: Path, name: str) -> None:
    """Remove temporary folders of earlier runs to ``name`` whose process is gone."""
    for tmp in stale_partials(parent, name, recoverable=False):
        shutil.rmtree(tmp, ignore_errors=True)


def stale_partials(parent: Path, name: str, recoverable: bool) -> list[Path]:
    """Temporary folders of earlier runs to ``name`` whose process is gone: those with
    a checkpoint (``recoverable``: ``--restart`` continues them) or those without.

    Parameters
    ----------
    parent : Path
        Folder that holds the run folders.
    name : str
        Name of the run folder.
    recoverable : bool
        True: only folders with a checkpoint; False: only those without.

    Returns
    -------
    list of Path
        The temporary folders, sorted.
    """
    found = []
    for tmp in sorted(parent.glob(f".{name}.partial-*")):
        marker = read_marker(tmp)
        if tmp.is_dir() and marker is not None and not marker.get("complete") \
                and not _pid_alive(marker.get("pid")) \
                and (tmp / "checkpoint.npz").is_file() == recoverable:
            found.append(tmp)
    return found


def check_new_files(paths: Sequence[Path], what: str) -> None:
    """Refuse to write ``paths`` where a file exists that the engine did not write.

    A file inside a run folder and listed in its marker is the engine's and
    may be replaced; any other existing file is the user's.

    Parameters
    ----------
    paths : sequence of Path
        Files about to be written.
    what : str
        The flag or argument that chose them, for the message (``--out``).
    """
    for path in paths:
        path = Path(path)
        if not path.exists() and not path.is_symlink():
            continue
        for folder in path.parents:
            marker = read_marker(folder)
            if marker is not None:
                rel = path.relative_to(folder).as_posix()
                if rel in marker.get("files", []) and path.is_file():
                    break
        else:
            raise OutputError(f"{what}: {path} exists and was not written by the engine; "
                              f"nothing was changed: choose another place")


def adopt_files(folder: Path, paths: Sequence[Path]) -> None:
    """Add files the engine wrote later (plots of a finished run) to a run folder's marker.

    Parameters
    ----------
    folder : Path
        A run folder.
    paths : sequence of Path
        Files inside ``folder`` to add.
    """
    marker = read_marker(folder)
    if marker is None:
        return
    rel = {Path(p).resolve().relative_to(Path(folder).resolve()).as_posix() for p in paths}
    marker["files"] = sorted(set(marker.get("files", [])) | rel)
    write_text_atomic(Path(folder) / MARKER, json.dumps(marker, indent=2) + "\n")


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to a temporary name beside ``path`` and rename it into place.

    Parameters
    ----------
    path : Path
        File written.
    text : str
        Its whole content.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        tmp.write_text(text)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
