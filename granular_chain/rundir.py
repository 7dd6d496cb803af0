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
- Every other command that writes files claims them first (:func:`claim_folder`,
  :func:`claim_file`), before any work: a new folder, marked with the command's
  name; a folder the same command marked, holding nothing its marker does not
  list; or the run folder the command reads, whose marker records which command
  wrote each file it adds. Nothing inside another marked folder, no link, no
  file another command or the user wrote.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import stat
import tempfile
from pathlib import Path
from typing import Iterable, Optional, Sequence

import yaml

from .version import __version__
from .interrupts import Stopped, held_signals

__all__ = ["MARKER", "OutputError", "RunFolder", "default_out", "read_marker", "check_out",
           "Claim", "claim_folder", "claim_file", "write_atomic", "write_text_atomic",
           "stale_partials", "remove_files", "check_partial"]

MARKER = "run.json"
ENGINE = "granular_chain"


class OutputError(ValueError):
    """An output folder that cannot be used (one line naming ``--out`` and why)."""


def _version() -> str:
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
    owner = _owning_folder(resolved.parent)
    if owner is not None:
        raise OutputError(f"{name}: is inside {owner}, a folder of granular-chain "
                          f"{_command_of(read_marker(owner))}; name a folder outside it")
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
    if _command_of(marker) != "run":
        raise OutputError(f"{name}: holds the output of granular-chain {_command_of(marker)}; "
                          f"nothing was changed: name a new folder")
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
        # A signal acts before the temporary folder exists marked, or after; one that
        # acts as this ends (or an error) removes it again.
        try:
            with held_signals():
                try:
                    parent.mkdir(parents=True, exist_ok=True)
                    _remove_stale_partials(parent, self.out.name)
                    self.tmp = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.partial-",
                                                     dir=parent))
                    self._write_marker(self.tmp, complete=False, reason="running", files=[])
                except OSError as exc:
                    raise OutputError(f"--out {self.out}: cannot be written "
                                      f"({exc.strerror or exc})") from None
        except BaseException:
            self.__exit__()
            raise
        return self

    def __exit__(self, *exc) -> None:
        if self.published:
            return
        with held_signals():  # (removed whole: a signal now acts once it is gone)
            if self.tmp is not None and self.tmp.exists():
                shutil.rmtree(self.tmp, ignore_errors=True)
            for folder in self._made:
                try:
                    folder.rmdir()
                except OSError:
                    break  # not empty (or not ours to remove): leave it and its parents

    def _write_marker(self, folder: Path, *, complete: bool, reason: str,
                      files: Iterable[str], streams: Sequence[str] = ()) -> None:
        data = {"engine": ENGINE, "version": _version(), "command": "run",
                "complete": complete, "reason": reason, "pid": os.getpid(), **self.about,
                "files": sorted(files), **({"streams": list(streams)} if streams else {})}
        tmp = folder / f".{MARKER}.tmp"
        tmp.write_text(json.dumps(data, indent=2) + "\n")
        os.replace(tmp, folder / MARKER)

    def note_files(self, streams: Sequence[str] = ()) -> None:
        """List the files written so far in the temporary folder's marker (at a
        checkpoint): ``--restart`` of a killed run copies only what it lists.

        Parameters
        ----------
        streams : sequence of str
            Subfolders the writers keep adding frames to (frames after the
            checkpoint are the engine's too; a continued run drops them).
        """
        files = [f for f in _files_below(self.tmp) if f != MARKER]
        self._write_marker(self.tmp, complete=False, reason="running", files=files,
                           streams=streams)

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
        with held_signals():  # (the renames and the earlier run's removal are not cut)
            self._publish(complete, reason)

    def _publish(self, complete: bool, reason: str) -> None:
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


def check_partial(folder: Path, marker: dict, flag: str = "--restart") -> None:
    """Refuse to continue a run folder holding anything its marker does not vouch for.

    Every entry below ``folder`` must be a folder or a regular file (no link,
    device or pipe), and every file listed in the marker, or inside one of the
    marker's ``streams`` (frames a killed run wrote after its last checkpoint).

    Parameters
    ----------
    folder : Path
        An incomplete run folder, or a killed run's hidden partial folder.
    marker : dict
        Its marker.
    flag : str
        The flag that named ``folder``, for the message.

    Raises
    ------
    OutputError
        ``folder`` holds something else; nothing was copied.
    """
    listed = set(marker.get("files", [])) | {MARKER}
    streams = [s.rstrip("/") + "/" for s in marker.get("streams", [])]
    for root, dirs, files in os.walk(folder):
        for entry in sorted(dirs + files):
            path = Path(root) / entry
            rel = path.relative_to(folder).as_posix()
            mode = path.lstat().st_mode
            if stat.S_ISDIR(mode):
                continue
            if not stat.S_ISREG(mode):
                raise OutputError(f"{flag} {folder}: {rel} is not a regular file (a link, "
                                  f"device or pipe); nothing was copied")
            if rel not in listed and not any(rel.startswith(s) for s in streams):
                raise OutputError(f"{flag} {folder}: {rel} was not written by the engine (not "
                                  f"in its {MARKER}); nothing was copied: move it out first")


def write_text_atomic(path: Path, text: str) -> Path:
    """Write ``text`` to a temporary name beside ``path`` and rename it into place.

    Parameters
    ----------
    path : Path
        File written.
    text : str
        Its whole content.

    Returns
    -------
    Path
        ``path``.
    """
    return write_atomic(path, lambda tmp: Path(tmp).write_text(text))


# ----------------------------------------------------------------------------
# Output claims: the one rule of every command that writes files
# ----------------------------------------------------------------------------
def _command_of(marker: dict) -> str:
    """The command that made a marked folder (a run folder's marker may not say: ``run``)."""
    return marker.get("command", "run")


def _writer_of(marker: dict, rel: str) -> str:
    """The command that wrote the listed file ``rel`` of a marked folder."""
    return marker.get("written_by", {}).get(rel, _command_of(marker))


def _owning_folder(path: Path) -> Optional[Path]:
    """The nearest folder at or above ``path`` (resolved) with the engine's marker."""
    for folder in [path, *path.parents]:
        if read_marker(folder) is not None:
            return folder
    return None


def _refuse_place(out: Path, name: str) -> Path:
    """Refusals shared by every output path: empty, a link, the current folder or one
    holding it, a file on the way. Returns ``out`` resolved."""
    if str(out) in ("", "."):
        raise OutputError(f"{name}: is empty or the current folder; name a new folder")
    if out.is_symlink():
        raise OutputError(f"{name}: is a symbolic link (to {os.readlink(out)}); name the "
                          f"folder itself")
    resolved = out.resolve()
    cwd = Path.cwd().resolve()
    if resolved == cwd or resolved in cwd.parents:
        raise OutputError(f"{name}: is the current folder or contains it; name a new folder")
    for parent in resolved.parents:
        if parent.exists() and not parent.is_dir():
            raise OutputError(f"{name}: {parent} is a file, not a folder")
    return resolved


def _check_listed(owner: Path, marker: dict, folder: Path, names: Sequence[str],
                  command: str, name: str) -> None:
    """Each of ``names`` (in ``folder``, inside the marked ``owner``) is new, or a
    regular file the marker lists as written by ``command``."""
    for n in names:
        path = folder / n
        if not path.exists() and not path.is_symlink():
            continue
        rel = (folder.resolve() / n).relative_to(owner).as_posix()
        if rel not in marker.get("files", []) or path.is_symlink() or not path.is_file():
            raise OutputError(f"{name}: {path} exists and was not written by the engine; "
                              f"nothing was changed: choose another place")
        writer = _writer_of(marker, rel)
        if writer != command:
            raise OutputError(f"{name}: {path} was written by granular-chain {writer}, not "
                              f"{command}; nothing was changed: choose another place")


class Claim:
    """Files one command may write into one folder, decided before any work.

    Made by :func:`claim_folder` or :func:`claim_file` (which refuse what the
    command must not write). Use as a context manager around the writing: on
    entry a new folder is created with its marker, and the claimed names are
    listed in the owning folder's marker as written by the command (before a
    byte is written, so a killed command leaves files its next run may
    replace); on exit the names not written are dropped from the listing and a
    new folder left empty is removed again. Files are written whole to a
    temporary name and renamed (:func:`write_atomic`, or :meth:`stage` then
    :meth:`publish` for writers that name their own files).

    Parameters
    ----------
    folder : Path
        Where the files go.
    names : sequence of str
        The files, relative to ``folder``.
    owner : Path or None
        The marked folder (resolved) whose marker lists them (None: a new file
        outside any marked folder).
    command : str
        The command writing (``figures``, ``plot``...), recorded in the marker.
    new_marker : bool
        ``folder`` is new: created and marked as the command's on entry.
    """

    def __init__(self, folder: Path, names: Sequence[str], owner: Optional[Path],
                 command: str, new_marker: bool):
        self.folder, self.names, self.owner = Path(folder), tuple(names), owner
        self.command, self._new_marker = command, new_marker
        self._made: list[Path] = []
        self._stage: Optional[Path] = None

    def __enter__(self) -> "Claim":
        # A signal acts before the folder is made and marked, or after; one that acts
        # as this ends (or an error) undoes it, as the end of the claim would.
        try:
            with held_signals():
                self._made = [p for p in [self.folder, *self.folder.parents]
                              if not p.exists()]
                try:
                    self.folder.mkdir(parents=True, exist_ok=True)
                    if self._new_marker:
                        data = {"engine": ENGINE, "version": _version(),
                                "command": self.command, "complete": False,
                                "reason": "writing", "pid": os.getpid(), "files": []}
                        write_text_atomic(self.folder / MARKER,
                                          json.dumps(data, indent=2) + "\n")
                    self._list(keep=lambda p: True)
                except OSError as exc:
                    raise OutputError(f"{self.folder}: cannot be written "
                                      f"({exc.strerror or exc})") from None
        except BaseException as exc:
            self.__exit__(type(exc), exc, None)
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        """Drop the names not written; a claim cut short (a signal, an error) that
        wrote some files leaves its new folder marked incomplete, with the reason."""
        reason = ("" if exc_type is None else f"interrupted by {exc}" if isinstance(exc, Stopped)
                  else "interrupted" if isinstance(exc, KeyboardInterrupt)
                  else f"stopped by an error: {exc_type.__name__}: {exc}")
        with held_signals():
            if self._stage is not None:
                shutil.rmtree(self._stage, ignore_errors=True)
            self._list(keep=lambda p: p.is_file(), complete=True, reason=reason)
            self._undo()

    def _undo(self) -> None:
        """Remove the new folder's marker when no claimed file was written, then the
        folders this claim created, deepest first, while empty."""
        if self._new_marker and not any(p.is_file() for p in self.paths):
            (self.folder / MARKER).unlink(missing_ok=True)
        for folder in self._made:
            try:
                folder.rmdir()
            except OSError:
                break

    @property
    def written(self) -> list[Path]:
        """The claimed files that exist now (all of them whole: each is renamed into
        place when written)."""
        return [p for p in self.paths if p.is_file()]

    @property
    def paths(self) -> list[Path]:
        """The claimed files, as paths."""
        return [self.folder / n for n in self.names]

    def _list(self, keep, complete: bool = False, reason: str = "") -> None:
        """List the claimed names that pass ``keep`` in the owner's marker (the
        others are dropped), as written by this command; ``complete``: mark the
        claim's own folder (new, or one the command marked) complete, or incomplete
        with ``reason`` if one is given."""
        marker = read_marker(self.owner) if self.owner is not None else None
        if marker is None:
            return
        here = self.folder.resolve()
        rels = {(here / n).relative_to(self.owner).as_posix(): p
                for n, p in zip(self.names, self.paths)}
        files = set(marker.get("files", [])) - set(rels)
        files |= {r for r, p in rels.items() if keep(p)}
        marker["files"] = sorted(files)
        if _command_of(marker) != self.command:
            written = {k: v for k, v in marker.get("written_by", {}).items() if k in files}
            written.update({r: self.command for r in rels if r in files})
            marker["written_by"] = dict(sorted(written.items()))
        if complete and (self._new_marker or self.owner == here
                         and _command_of(marker) == self.command):  # (the claim's own folder)
            marker.update(complete=not reason, reason=reason)
        write_text_atomic(self.owner / MARKER, json.dumps(marker, indent=2) + "\n")

    def stage(self) -> Path:
        """A hidden temporary folder inside :attr:`folder` for writers that name their
        own files; :meth:`publish` renames them into place.

        Returns
        -------
        Path
            The temporary folder (removed when the claim ends).
        """
        if self._stage is None:
            self._stage = Path(tempfile.mkdtemp(prefix=f".{self.command}.tmp-",
                                                dir=self.folder))
        return self._stage

    def publish(self) -> list[Path]:
        """Rename every claimed file written into :meth:`stage` into place.

        Returns
        -------
        list of Path
            The files published.
        """
        done = []
        for n, path in zip(self.names, self.paths):
            staged = self.stage() / n
            if staged.is_file():
                os.replace(staged, path)
                done.append(path)
        return done


def claim_folder(out, command: str, names: Sequence[str], *, flag: str = "--out",
                 home: Optional[Path] = None) -> Claim:
    """Decide, before any work, whether ``command`` may write ``names`` into ``out``.

    ``out`` may be a new folder (created and marked as the command's), or a
    folder the engine marked for the same command holding nothing its marker
    does not list (its files are then replaced), or a folder inside ``home``, the
    run folder the command reads (its files join that run's marker, as written
    by the command, and replace only files the command wrote there). A folder
    the engine did not mark, one another command made, a link, a file, the
    current folder and any folder inside another marked folder are refused.

    Parameters
    ----------
    out : str or Path
        The folder asked for.
    command : str
        The command writing (recorded in the marker).
    names : sequence of str
        The files it will write, relative to ``out``.
    flag : str
        The flag or argument that chose ``out``, for the message.
    home : Path, optional
        The run folder the command reads (``plot``, ``export``).

    Returns
    -------
    Claim
        Use as a context manager around the writing.

    Raises
    ------
    OutputError
        ``out`` must not be written (one line; nothing was changed).
    """
    out = Path(out)
    name = f"{flag} {out}"
    resolved = _refuse_place(out, name)
    if resolved.exists() and not resolved.is_dir():
        raise OutputError(f"{name}: is a file, not a folder; nothing was changed")
    owner = _owning_folder(resolved)
    if owner is None:
        if resolved.exists():
            what = "an empty folder" if not any(resolved.iterdir()) else "a folder"
            raise OutputError(f"{name}: exists and is {what} the engine did not write (no "
                              f"{MARKER}); nothing was changed: name a new folder")
        return Claim(out, names, resolved, command, new_marker=True)
    marker = read_marker(owner)
    if home is not None and owner == Path(home).resolve():
        _check_listed(owner, marker, out, names, command, name)
        return Claim(out, names, owner, command, new_marker=False)
    made_by = _command_of(marker)
    if owner != resolved:
        raise OutputError(f"{name}: is inside {owner}, a folder of granular-chain {made_by}; "
                          f"nothing was changed: name a folder outside it")
    if made_by != command:
        raise OutputError(f"{name}: holds the output of granular-chain {made_by}; nothing "
                          f"was changed: name a new folder")
    foreign = _foreign_files(owner, marker)
    if foreign:
        more = f" and {len(foreign) - 1} more" if len(foreign) > 1 else ""
        raise OutputError(f"{name}: {foreign[0]}{more} was not written by the engine; "
                          f"nothing was changed: move it out of the folder, or name a new one")
    _check_listed(owner, marker, out, names, command, name)
    return Claim(out, names, owner, command, new_marker=False)


def claim_file(path, command: str, *, flag: str = "--out",
               home: Optional[Path] = None) -> Claim:
    """Decide, before any work, whether ``command`` may write the file ``path``.

    ``path`` may be a new file outside any marked folder, or a file inside
    ``home`` (the run folder the command reads; the file joins its marker as
    written by the command) that is new or that the command wrote there
    before. A file the engine did not write, one another command wrote (a
    run's ``trajectory.h5``), a link and any file inside another marked folder
    are refused.

    Parameters
    ----------
    path : str or Path
        The file asked for (its folder must exist).
    command : str
        The command writing (recorded in the marker).
    flag : str
        The flag that chose ``path``, for the message.
    home : Path, optional
        The run folder the command reads (``diagnose RUN_DIR``).

    Returns
    -------
    Claim
        Use as a context manager around the writing; the file is ``claim.paths[0]``.

    Raises
    ------
    OutputError
        ``path`` must not be written (one line; nothing was changed).
    """
    path = Path(path)
    name = f"{flag} {path}"
    if str(path) == "":
        raise OutputError(f"{name}: is empty; name a new file")
    if path.is_symlink():
        raise OutputError(f"{name}: is a symbolic link (to {os.readlink(path)}); name a "
                          f"new file")
    if path.is_dir():
        raise OutputError(f"{name}: is a folder; name a new file")
    parent = path.parent.resolve()
    if not parent.is_dir():
        raise OutputError(f"{name}: the folder {path.parent} does not exist")
    owner = _owning_folder(parent)
    if owner is None:
        if path.exists():
            raise OutputError(f"{name}: {path} exists and was not written by the engine; "
                              f"nothing was changed: choose another place")
        return Claim(path.parent, [path.name], None, command, new_marker=False)
    if home is None or owner != Path(home).resolve():
        raise OutputError(f"{name}: is inside {owner}, a folder of granular-chain "
                          f"{_command_of(read_marker(owner))}; nothing was changed: choose "
                          f"another place")
    _check_listed(owner, read_marker(owner), path.parent, [path.name], command, name)
    return Claim(path.parent, [path.name], owner, command, new_marker=False)


def write_atomic(path: Path, write) -> Path:
    """Call ``write(tmp)`` to write a temporary name beside ``path``, then rename it
    into place: ``path`` is whole at every moment.

    Parameters
    ----------
    path : Path
        File written.
    write : callable
        Writes the whole file to the path it is given.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}{path.suffix}")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
