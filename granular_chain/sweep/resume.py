"""The results of a sweep on disk: ``results.csv`` (one row per point, appended as
batches finish) and ``sweep.json`` (what the rows were made from); a rerun reads
them and computes only the points that are not there yet."""

from __future__ import annotations

import csv
import hashlib
import io
import json
from pathlib import Path
from typing import Sequence

import numpy as np

from ..rundir import OutputError, claim_folder, write_text_atomic
from .grid import Axis, SweepError

__all__ = ["open_results", "read_results", "scene_text_hash", "read_done"]

#: The sweep.json entries a resumed sweep must share with the one that wrote the rows.
_SAME_AS_BEFORE = ("scene_sha256", "fixed", "frames", "first")


def scene_text_hash(text: str) -> str:
    """First 16 hex digits of the SHA-256 of the scene file's text.

    Parameters
    ----------
    text : str
        The scene file's text.

    Returns
    -------
    str
        16 hex digits.
    """
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def open_results(out_dir: Path, meta: dict, axes: Sequence[Axis], header: list[str],
                 restart: bool) -> tuple[Path, set]:
    """Prepare ``out_dir`` for a sweep: ``(results.csv path, coordinates already done)``.

    Parameters
    ----------
    out_dir : Path
        The sweep's folder: a new one (created and marked as the sweep's), or one
        an earlier sweep wrote holding nothing else
        (:func:`granular_chain.rundir.claim_folder`); any other is refused.
    meta : dict
        What the rows are made from (scene hash, fixed overrides, options): a
        results.csv made from something else is refused; written to sweep.json
        with the axes.
    axes : sequence of Axis
        The sweep's axes.
    header : list of str
        The CSV columns, the axes' dotted paths first.
    restart : bool
        Discard an existing results.csv.

    Returns
    -------
    (Path, set of tuple)
        results.csv and the coordinates (as text) already in it.
    """
    try:
        claim = claim_folder(out_dir, "sweep", ["results.csv", "sweep.json"])
    except OutputError as exc:
        raise SweepError(str(exc)) from None
    results = out_dir / "results.csv"
    meta_path = out_dir / "sweep.json"
    with claim:  # both files listed in the folder's run.json: a rerun may append, resume
        if restart and results.exists():
            results.unlink()
        if results.exists() and meta_path.exists():
            old = json.loads(meta_path.read_text())
            for key in _SAME_AS_BEFORE:
                if old.get(key) != meta[key]:
                    raise SweepError(
                        f"{results} was made with a different {key} ({old.get(key)!r}, now "
                        f"{meta[key]!r}); use another --out, or --restart to discard it")
        done = read_done(results, header, [a.path for a in axes])
        meta = {**meta, "axes": [a.spec for a in axes]}
        write_text_atomic(meta_path, json.dumps(meta, indent=2) + "\n")
        results.touch()  # (rows are appended as batches finish)
    return results, done


def read_done(path: Path, header: list[str], paths: Sequence[str]) -> set:
    """Coordinates already in results.csv; drops a last row cut short by a hard kill.

    Parameters
    ----------
    path : Path
        results.csv (may be missing).
    header : list of str
        Expected columns.
    paths : sequence of str
        Dotted paths of the axes, in order.

    Returns
    -------
    set of tuple
        Coordinates (as written by :func:`coord_text`) of the rows present.
    """
    if not path.exists():
        return set()
    text = path.read_text()
    if not text:
        return set()
    if not text.endswith("\n"):  # a partial last line: cut it off, the point reruns
        text = text[: text.rfind("\n") + 1]
        with open(path, "r+") as fh:
            fh.truncate(len(text.encode()))
    reader = csv.reader(io.StringIO(text))
    try:
        found = next(reader)
    except StopIteration:
        return set()
    if found != header:
        raise SweepError(
            f"{path}: its columns {found[:len(paths)]}... differ from this sweep's "
            f"{header[:len(paths)]}...; use another --out or --restart")
    k = len(paths)
    return {tuple(r[:k]) for r in reader if len(r) == len(header)}


def read_results(path) -> dict[str, np.ndarray]:
    """results.csv as columns: numbers as float arrays (blank = nan), the rest as str arrays.

    Parameters
    ----------
    path : str or Path
        A results.csv.

    Returns
    -------
    dict of ndarray
        Column -> values.
    """
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    cols = {}
    names = rows[0].keys() if rows else []
    for name in names:
        raw = [r[name] for r in rows]
        try:
            cols[name] = np.array([float(x) if x != "" else np.nan for x in raw])
        except ValueError:
            cols[name] = np.array(raw, dtype=object)
    return cols
