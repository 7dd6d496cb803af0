"""``--set dotted.path=value``: one field of a raw scene mapping changed before
validation (list items too: ``a.b[i]=v``)."""

from __future__ import annotations

import re

import yaml

from .reading import _yaml_problem, parse_yaml_value
from .values import SceneError


_INDEX = re.compile(r"^(?P<name>[A-Za-z_][A-Za-z0-9_]*)\[(?P<i>-?\d+)\]$")
#: Fields with one value per granule or per contact: one of their items can be set
#: even where the scene gives a single value for all (it is expanded first).
_PER_GRANULE = {"granules.mass", "granules.radius", "granules.velocity",
                "granules.friction.kinetic", "granules.friction.static",
                "granules.friction.viscous", "granules.material.young",
                "granules.material.poisson"}
_PER_CONTACT = {"granules.gap", "contacts.exponent", "contacts.stiffness"}
#: Values of per-item fields the scene leaves out (the schema's defaults).
_ITEM_DEFAULTS = {"granules.mass": 1.0, "granules.radius": 0.5}


def set_path(data: dict, path: str, value, source: str = "--set") -> None:
    """Set one field of a raw scene mapping: ``data[a][b][c] = value`` for ``a.b.c``.

    The one dotted-path setter of the engine (``--set``, sweep axes). A last part
    ``c[i]`` sets item i of a list; a per-granule (per-contact) field that holds
    a single number, or a sparse ``{index: value}`` velocity, is first expanded to
    one value per granule (contact), so that one of them can be set. Missing
    groups are created; nothing is validated here (:func:`scene_from_dict` does).

    Parameters
    ----------
    data : dict
        The raw scene mapping, modified in place.
    path : str
        Dotted field path, ``a.b.c`` or ``a.b.c[i]``.
    value : Any
        The new value, in the scene's units.
    source : str
        Name used in error messages.

    Raises
    ------
    SceneError
        An empty part, a part that is not a group of fields, an index into a field
        that is not a list, or an index out of range.
    """
    parts = path.split(".")
    if not path or any(not p for p in parts):
        raise SceneError(source, path, "empty field name in dotted path")
    target = data
    for part in parts[:-1]:
        nxt = target.get(part)
        if nxt is None:
            nxt = target[part] = {}
        if not isinstance(nxt, dict):
            raise SceneError(source, path, f"'{part}' is not a group of fields")
        target = nxt
    last = _INDEX.match(parts[-1])
    if last is None:
        target[parts[-1]] = value
        return
    name, i = last["name"], int(last["i"])
    items = _item_list(data, ".".join(parts[:-1] + [name]), target.get(name), source, path)
    if not -len(items) <= i < len(items):
        raise SceneError(source, path, f"index {i} out of range for {len(items)} values")
    items[i] = value
    target[name] = items


def _item_list(data: dict, plain: str, current, source: str, path: str) -> list:
    """A copy of the list a ``name[i]`` path indexes: the list itself, or a per-item
    field's single value (or sparse velocity mapping) expanded to one per item."""
    if isinstance(current, list):
        return list(current)
    granules = data.get("granules")
    count = granules.get("count", 0) if isinstance(granules, dict) else 0
    if not isinstance(count, int) or isinstance(count, bool):
        raise SceneError(source, path, "needs granules.count, a whole number, to expand "
                         "a per-item field")
    if plain in _PER_GRANULE:
        size = count
    elif plain in _PER_CONTACT:
        size = count - 1
    else:
        raise SceneError(source, path, f"'{plain.rsplit('.', 1)[-1]}' is not a list and "
                         f"not a per-granule field")
    if isinstance(current, dict):  # a sparse velocity mapping {index: value}
        if "distribution" in current:
            raise SceneError(source, path, "is a distribution recipe: set the whole field")
        full = [0.0] * size
        try:
            for k, item in current.items():
                full[int(k)] = item
        except (ValueError, TypeError, IndexError):
            raise SceneError(source, path, f"{plain} holds a granule index out of range "
                             f"0..{size - 1}") from None
        return full
    return [_ITEM_DEFAULTS.get(plain, 0.0) if current is None else current] * size


def apply_overrides(data: dict, overrides: list[str], source: str = "--set") -> dict:
    """Apply ``dotted.path=value`` overrides (values parsed as YAML) to a scene mapping.

    Parameters
    ----------
    data : dict
        The raw scene mapping (modified in place and returned).
    overrides : list of str
        Items like ``granules.friction.kinetic=[0, 0.3]``, ``run.dt=1e-4`` or
        ``granules.friction.kinetic[1]=0.3`` (see :func:`set_path`).
    source : str
        Name used in error messages.

    Returns
    -------
    dict
        ``data``, with the overrides applied.

    Raises
    ------
    SceneError
        An item without ``=``, an empty field name, a value that is not YAML, or a path
        :func:`set_path` refuses.
    """
    for item in overrides:
        if "=" not in item:
            raise SceneError(source, item, "an override must look like dotted.path=value")
        path, raw = item.split("=", 1)
        path = path.strip()
        if not path or any(not p for p in path.split(".")):
            raise SceneError(source, path or item, "empty field name in dotted path")
        try:
            value = parse_yaml_value(raw)
        except yaml.YAMLError as exc:
            raise SceneError(source, path, f"value {raw!r} is not valid YAML "
                             f"({_yaml_problem(exc)})") from None
        set_path(data, path, value, source)
    return data
