"""Sweep axes: ``--grid`` ranges and ``--list`` values, their grid of points, and how a
coordinate is written in results.csv."""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import yaml

from ..scene import SceneError, parse_yaml_value
from ..scene import set_path as _scene_set_path

__all__ = ["SweepError", "Axis", "parse_grid", "parse_list", "grid_points", "coord_text",
           "set_path"]


class SweepError(ValueError):
    """A sweep that cannot start (bad axis, inconsistent resume)."""


@dataclass(frozen=True)
class Axis:
    """One axis of a sweep: a dotted path and its values (in order).

    Attributes
    ----------
    path : str
        Dotted path of the scene field varied.
    values : tuple
        Its values, in order.
    spec : str
        The ``--grid``/``--list`` text it was parsed from.
    """

    path: str
    values: tuple
    spec: str

    def __len__(self) -> int:
        return len(self.values)


def parse_grid(spec: str) -> Axis:
    """``path=start:stop:num`` (inclusive, like numpy.linspace) or ``...:num:log`` (geomspace).

    Parameters
    ----------
    spec : str
        ``path=start:stop:num`` or ``path=start:stop:num:log``.

    Returns
    -------
    Axis
        The axis.

    Raises
    ------
    SweepError
        A malformed spec.
    """
    path, _, rng = spec.partition("=")
    parts = rng.split(":")
    if not path or len(parts) not in (3, 4) or (len(parts) == 4 and parts[3] != "log"):
        raise SweepError(f"--grid {spec!r}: expected dotted.path=start:stop:num[:log]")
    try:
        a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise SweepError(f"--grid {spec!r}: start and stop must be numbers, num an integer") from None
    if n < 1:
        raise SweepError(f"--grid {spec!r}: num must be at least 1")
    if len(parts) == 4:
        if a <= 0 or b <= 0:
            raise SweepError(f"--grid {spec!r}: a log grid needs positive start and stop")
        vals = np.geomspace(a, b, n)
    else:
        vals = np.linspace(a, b, n)
    if _is_int(parts[0]) and _is_int(parts[1]) and all(float(v).is_integer() for v in vals):
        # whole-number ends and steps: the values are counts or indices, written as integers
        return Axis(path.strip(), tuple(int(v) for v in vals), spec)
    return Axis(path.strip(), tuple(float(v) for v in vals), spec)


def _is_int(text: str) -> bool:
    try:
        int(text)
    except ValueError:
        return False
    return True


def parse_list(spec: str) -> Axis:
    """``path=a,b,c``: values parsed as YAML (numbers, strings, ``[..]`` lists are not split).

    Parameters
    ----------
    spec : str
        ``path=a,b,c``.

    Returns
    -------
    Axis
        The axis.

    Raises
    ------
    SweepError
        A malformed spec.
    """
    path, _, raw = spec.partition("=")
    if not path or not raw:
        raise SweepError(f"--list {spec!r}: expected dotted.path=a,b,c")
    values = []
    for item in _split_top(raw):
        try:
            values.append(parse_yaml_value(item))
        except yaml.YAMLError:
            raise SweepError(f"--list {spec!r}: {item!r} is not valid YAML") from None
    return Axis(path.strip(), tuple(values), spec)


def _split_top(raw: str) -> list[str]:
    """Split on commas outside brackets, so ``[1, 2],[3, 4]`` is two items."""
    out, depth, cur = [], 0, ""
    for ch in raw:
        if ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        if ch == "," and depth == 0:
            out.append(cur)
            cur = ""
        else:
            cur += ch
    out.append(cur)
    return [s.strip() for s in out if s.strip()]


def grid_points(axes: Sequence[Axis]) -> list[tuple]:
    """Every combination of axis values, the last axis varying fastest.

    Parameters
    ----------
    axes : sequence of Axis
        The axes of the grid.

    Returns
    -------
    list of tuple
        One coordinate tuple per point.
    """
    return list(itertools.product(*(a.values for a in axes)))


def coord_text(value) -> str:
    """How a coordinate is written in the CSV (and matched on resume).

    Parameters
    ----------
    value : float, int, str or list
        A coordinate.

    Returns
    -------
    str
        ``repr`` for a float, ``str`` for int or text, JSON otherwise.
    """
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (int, str)) and not isinstance(value, bool):
        return str(value)
    return json.dumps(value)


def set_path(data: dict, path: str, value) -> None:
    """Set one field of a raw scene mapping with :func:`granular_chain.scene.set_path`
    (the engine's one dotted-path setter: ``c[i]`` sets one item of a list or of a
    per-granule field); a refusal is raised as :class:`SweepError`.

    Parameters
    ----------
    data : dict
        Raw scene mapping, changed in place.
    path : str
        Dotted path (``a.b[i]``).
    value : object
        New value.

    Raises
    ------
    SweepError
        The path or value is refused.
    """
    try:
        _scene_set_path(data, path, value, source="sweep")
    except SceneError as exc:
        raise SweepError(str(exc)) from None
