"""Initial positions and velocities read from a file (``granules.state``).

A scene can start where another run ended, or from a table made elsewhere::

    granules:
      count: 100
      state: {file: ../outputs/chain/trajectory.h5, frame: -1}

The file is one of

- ``.h5``: a run's ``trajectory.h5`` (variables ``x`` and ``v``, shape (frames, N));
- ``.npz``: arrays ``x`` and ``v``, of shape (N,) or (frames, N);
- ``.csv``: a header line naming the columns ``x`` and ``v`` (others are ignored), one
  row per granule, left to right.

``frame`` picks the frame (Python indexing, -1 the last) of a file that has several.
Positions are centre positions in the scene's length unit; the gaps follow from them and
the radii. Friction needs no state of its own: a granule at rest is held by static
friction, a moving one slides.
"""

from __future__ import annotations

import csv
from pathlib import Path

import h5py
import numpy as np

__all__ = ["read_state", "StateFileError"]


class StateFileError(ValueError):
    """The file cannot give the state (the message names the file and what is wrong)."""


def read_state(path, frame: int, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Positions and velocities of ``count`` granules from ``path``.

    Parameters
    ----------
    path : path
        ``.h5``, ``.npz`` or ``.csv`` file (see the module docstring).
    frame : int
        Frame of a file holding several (-1: the last).
    count : int
        Granules N the scene has.

    Returns
    -------
    x, v : ndarray, shape (N,)
        Centre positions and velocities, float64.

    Raises
    ------
    StateFileError
        Missing file, unknown format, missing column or variable, wrong length,
        frame out of range, non-finite values or granules out of order.
    """
    path = Path(path)
    if not path.is_file():
        raise StateFileError(f"{path}: no such file")
    readers = {".h5": _from_h5, ".hdf5": _from_h5, ".npz": _from_npz, ".csv": _from_csv}
    reader = readers.get(path.suffix.lower())
    if reader is None:
        raise StateFileError(f"{path}: unknown format {path.suffix!r} (use .h5, .npz or .csv)")
    try:
        x, v = reader(path, frame)
    except (OSError, ValueError, KeyError) as exc:
        if isinstance(exc, StateFileError):
            raise
        raise StateFileError(f"{path}: cannot be read ({exc})") from None
    for name, a in (("x", x), ("v", v)):
        if a.shape != (count,):
            raise StateFileError(f"{path}: column {name} has {a.size} values but "
                                 f"granules.count is {count}")
        if not np.all(np.isfinite(a)):
            i = int(np.flatnonzero(~np.isfinite(a))[0])
            raise StateFileError(f"{path}: column {name} is not finite at granule {i}")
    if count > 1 and not np.all(np.diff(x) > 0):
        i = int(np.flatnonzero(np.diff(x) <= 0)[0])
        raise StateFileError(f"{path}: positions x must increase from left to right "
                             f"(granule {i + 1} is not right of granule {i})")
    return x, v


def _pick(path, name: str, data: np.ndarray, frame: int) -> np.ndarray:
    data = np.asarray(data, dtype=np.float64)
    if data.ndim == 1:
        return data
    if data.ndim != 2:
        raise StateFileError(f"{path}: {name} has shape {data.shape}; expected (N,) or (frames, N)")
    if not -data.shape[0] <= frame < data.shape[0]:
        raise StateFileError(f"{path}: frame {frame} is out of range (the file has "
                             f"{data.shape[0]} frames)")
    return data[frame].copy()


def _from_h5(path, frame):
    with h5py.File(path, "r") as h5:
        missing = [name for name in ("x", "v") if name not in h5]
        if missing:
            raise StateFileError(f"{path}: has no variable {missing[0]!r} (a run's "
                                 f"trajectory.h5 has x and v)")
        n = h5["x"].shape[0]
        if h5["x"].ndim == 2 and not -n <= frame < n:
            raise StateFileError(f"{path}: frame {frame} is out of range (the file has "
                                 f"{n} frames)")
        pick = (frame,) if h5["x"].ndim == 2 else ()
        return (np.asarray(h5["x"][pick], dtype=np.float64),
                np.asarray(h5["v"][pick], dtype=np.float64))


def _from_npz(path, frame):
    with np.load(path) as data:
        missing = [name for name in ("x", "v") if name not in data.files]
        if missing:
            raise StateFileError(f"{path}: has no array {missing[0]!r} (arrays: "
                                 f"{', '.join(data.files) or 'none'})")
        return _pick(path, "x", data["x"], frame), _pick(path, "v", data["v"], frame)


def _from_csv(path, frame):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows:
        raise StateFileError(f"{path}: is empty")
    header = [h.strip() for h in rows[0]]
    columns = {}
    for name in ("x", "v"):
        if name not in header:
            raise StateFileError(f"{path}: has no column {name!r} (columns: {', '.join(header)})")
        columns[name] = header.index(name)
    values = {name: [] for name in columns}
    for line, row in enumerate(rows[1:], start=2):
        for name, col in columns.items():
            try:
                values[name].append(float(row[col]))
            except (IndexError, ValueError):
                raise StateFileError(f"{path}: line {line}, column {name}: not a number") from None
    return np.array(values["x"]), np.array(values["v"])
