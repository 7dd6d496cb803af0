"""A scene from a file or a mapping: read, overridden, validated, its state file resolved."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Optional, Union

from pydantic import (
    ValidationError,
)

from .messages import _explain
from .overrides import apply_overrides
from .reading import read_scene_data
from .schema import Scene
from .values import SceneError


def scene_from_dict(data: Any, source: str = "<scene>", *, stored: bool = False) -> Scene:
    """Validate a mapping into a :class:`~granular_chain.scene.Scene`, raising :class:`~granular_chain.scene.SceneError` on any problem.

    ``stored``: the scene of a finished run, read back for its record; a state file
    it started from is then not read again (it may have moved since).

    Parameters
    ----------
    data : Any
        The raw scene mapping (from YAML or a dict), scaled or SI units as its
        ``units`` says.
    source : str
        Name of where ``data`` came from, first in error messages.
    stored : bool
        True for the scene of a finished run read back (see above).

    Returns
    -------
    Scene
        The validated scene.

    Raises
    ------
    SceneError
        On any problem, naming the dotted field.
    """
    if not isinstance(data, dict):
        raise SceneError(source, "", f"a scene must be a mapping of fields, got {type(data).__name__}")
    try:
        return Scene.model_validate(data, context={"stored": stored})
    except ValidationError as exc:
        raise _explain(exc, source) from None


def load_scene(path: Union[str, Path], overrides: Optional[list[str]] = None) -> Scene:
    """Read, override and validate a scene file.

    Parameters
    ----------
    path : str or Path
        YAML scene file.
    overrides : list of str, optional
        ``dotted.path=value`` items applied before validation (see :func:`~granular_chain.scene.apply_overrides`).

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        One line naming the file, the dotted field and the problem.
    """
    path = Path(path)
    data = read_scene_data(path)
    if data is None:
        raise SceneError(str(path), "", "the file is empty")
    if overrides:
        if not isinstance(data, dict):
            raise SceneError(str(path), "", "a scene must be a mapping of fields")
        apply_overrides(data, overrides, source=f"{path} (--set)")
    _resolve_state_file(data, path.parent)
    return scene_from_dict(data, source=str(path))


def _resolve_state_file(data, folder: Path) -> None:
    """A relative granules.state.file is taken from the scene file's folder."""
    granules = data.get("granules") if isinstance(data, dict) else None
    state = granules.get("state") if isinstance(granules, dict) else None
    if not isinstance(state, dict) or not isinstance(state.get("file"), str):
        return
    file = Path(state["file"])
    if not file.is_absolute():
        state["file"] = str(folder / file)
