"""Reading a scene file: YAML 1.2 numbers, bounded size, depth and aliases, one line
for a broken file."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Union

import yaml

from .values import MAX_ALIAS_NODES, MAX_SCENE_BYTES, MAX_YAML_DEPTH, SceneError


class _YamlRefused(yaml.YAMLError):
    """A YAML document refused by :class:`_SceneLoader` (one line, with the line number)."""


class _SceneLoader(yaml.SafeLoader):
    """SafeLoader for scene files: bounded alias expansion and nesting, duplicate
    keys refused at every level, and YAML 1.2 floats (``1e-3`` is a number, which
    YAML 1.1 reads as a string)."""

    def __init__(self, stream):
        super().__init__(stream)
        self._alias_nodes = 0
        self._depth = 0
        self._open: set = set()
        self._sizes: dict = {}

    def compose_node(self, parent, index):
        event = self.peek_event()
        line = event.start_mark.line + 1
        if isinstance(event, yaml.AliasEvent):
            node = self.anchors.get(event.anchor)
            if node is not None:
                if event.anchor in self._open:
                    raise _YamlRefused(f"line {line}: alias *{event.anchor} refers to the "
                                       f"collection that contains it (a recursive alias)")
                self._alias_nodes += self._size(node)
                if self._alias_nodes > MAX_ALIAS_NODES:
                    raise _YamlRefused(
                        f"line {line}: aliases expand to more than {MAX_ALIAS_NODES} values "
                        f"(alias *{event.anchor}); refused as a possible 'billion laughs' file")
            return super().compose_node(parent, index)
        self._depth += 1
        if self._depth > MAX_YAML_DEPTH:
            raise _YamlRefused(f"line {line}: nested deeper than {MAX_YAML_DEPTH} levels")
        anchor = getattr(event, "anchor", None)
        if anchor:
            self._open.add(anchor)
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1
            self._open.discard(anchor)

    def _size(self, node) -> int:
        """Nodes in ``node`` once every alias inside it is expanded (memoised)."""
        key = id(node)
        if key not in self._sizes:
            if isinstance(node, yaml.MappingNode):
                size = 1 + sum(self._size(k) + self._size(v) for k, v in node.value)
            elif isinstance(node, yaml.SequenceNode):
                size = 1 + sum(self._size(v) for v in node.value)
            else:
                size = 1
            self._sizes[key] = size
        return self._sizes[key]

    def get_single_node(self):
        node = super().get_single_node()
        if node is not None:
            self._check_duplicates(node, "", set())
        return node

    def _check_duplicates(self, node, path: str, seen: set) -> None:
        if id(node) in seen:
            return
        seen.add(id(node))
        if isinstance(node, yaml.SequenceNode):
            for i, item in enumerate(node.value):
                self._check_duplicates(item, f"{path}[{i}]", seen)
            return
        if not isinstance(node, yaml.MappingNode):
            return
        first: dict = {}
        for key_node, value_node in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self._key(key_node)
            name = f"{path}.{key}" if path else str(key)
            if key in first:
                raise _YamlRefused(
                    f"{name}: duplicate key at line {key_node.start_mark.line + 1} (first "
                    f"at line {first[key] + 1}); a later value would silently replace it")
            first[key] = key_node.start_mark.line
            self._check_duplicates(value_node, name, seen)

    def _key(self, node):
        if isinstance(node, yaml.ScalarNode):
            try:
                key = self.yaml_constructors[node.tag](self, node)
                hash(key)
                return key
            except Exception:  # an unusual key: compare it as written
                return (node.tag, node.value)
        return ("node", id(node))


# Numbers as YAML 1.2 (core schema) reads them, not as PyYAML's YAML 1.1: ``010`` is
# ten (not octal 8), ``1e-3`` is a float (not a string), and ``1:30`` (base 60: 90),
# ``1_000`` and ``0b101`` are not numbers (strings, which the schema refuses).
_INT_TAG, _FLOAT_TAG = "tag:yaml.org,2002:int", "tag:yaml.org,2002:float"
_SceneLoader.yaml_implicit_resolvers = {
    first: [(tag, regexp) for tag, regexp in resolvers if tag not in (_INT_TAG, _FLOAT_TAG)]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()}
_SceneLoader.add_implicit_resolver(
    _INT_TAG, re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$"), list("-+0123456789"))
_SceneLoader.add_implicit_resolver(
    _FLOAT_TAG,
    re.compile(r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
               r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"),
    list("-+0123456789."))


def _yaml12_int(loader, node) -> int:
    """An integer of the YAML 1.2 core schema: decimal (leading zeros allowed), 0o, 0x."""
    text = loader.construct_scalar(node)
    if text.startswith(("0o", "0x")):
        return int(text[2:], 8 if text[1] == "o" else 16)
    return int(text, 10)


_SceneLoader.add_constructor(_INT_TAG, _yaml12_int)


def _yaml_problem(exc: yaml.YAMLError) -> str:
    if isinstance(exc, _YamlRefused):
        return str(exc)
    mark = getattr(exc, "problem_mark", None)
    where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    return f"invalid YAML at {where}{problem}"


def parse_yaml_value(text: str) -> Any:
    """One YAML value with the scene file's rules (``1e-3`` is a float; aliases bounded).

    Parameters
    ----------
    text : str
        YAML text of one value (``0.3``, ``[0, 0.3]``, a whole mapping).

    Returns
    -------
    Any
        The parsed value.

    Raises
    ------
    yaml.YAMLError
        Text that is not YAML.
    """
    return yaml.load(text, Loader=_SceneLoader)


def read_scene_data(path: Union[str, Path]) -> Any:
    """The raw mapping of a scene file: size, aliases, nesting and duplicate keys checked.

    Parameters
    ----------
    path : str or pathlib.Path
        The scene's YAML file.

    Returns
    -------
    Any
        The parsed YAML document (a mapping for a scene file), not yet validated.

    Raises
    ------
    SceneError
        No such file, not a regular file, larger than MAX_SCENE_BYTES, not UTF-8, or
        invalid YAML (with line and column), in one line.
    """
    path = Path(path)
    source = str(path)
    if not path.exists():
        raise SceneError(source, "", "no such file")
    if path.is_dir():
        raise SceneError(source, "", "is a folder, not a scene file")
    if not path.is_file():
        raise SceneError(source, "", "is not a regular file")
    try:
        with open(path, "rb") as fh:
            raw = fh.read(MAX_SCENE_BYTES + 1)
    except OSError as exc:
        raise SceneError(source, "", f"cannot be read ({exc.strerror or exc})") from None
    if len(raw) > MAX_SCENE_BYTES:
        raise SceneError(source, "", f"is larger than {MAX_SCENE_BYTES} bytes (1 MiB), the "
                         f"largest scene file read; give long per-item lists as one value")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError(source, "", f"is not a UTF-8 text file (byte {exc.start}: "
                         f"{exc.reason})") from None
    try:
        return parse_yaml_value(text)
    except yaml.YAMLError as exc:
        raise SceneError(source, "", _yaml_problem(exc)) from None
    except RecursionError:
        raise SceneError(source, "", "invalid YAML: nested too deeply") from None
