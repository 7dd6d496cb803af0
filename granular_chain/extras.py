"""Optional dependencies: which extra installs each, and the one-line refusal when absent.

Every command and function that needs an optional library asks here, so the
message is the same everywhere::

    granular-chain plot: needs matplotlib, from the [plots] extra: pip install "granular_chain[plots]"

:func:`check` decides (a command calls it before any work or any file is
written); :func:`require` imports the module for the code that uses it. Both raise :class:`MissingExtraError`, an ``ImportError``; the command line
prints its message as the one line of a refusal (exit status 2).
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Sequence, Union

__all__ = ["EXTRAS", "MissingExtraError", "missing", "check", "require"]

#: module -> (name said to the user, the smallest extra that installs it). ``[viz]``
#: installs both ``[plots]`` and ``[vtk]``.
EXTRAS = {
    "matplotlib": ("matplotlib", "plots"),
    "pyvista": ("pyvista", "vtk"),
    "vtkmodules": ("vtk", "vtk"),
    "meshio": ("meshio", "vtk"),
    "distributed": ("dask.distributed", "sweep"),
    "xarray": ("xarray", "analysis"),
    "h5netcdf": ("h5netcdf", "analysis"),
    "pandas": ("pandas", "analysis"),
}


class MissingExtraError(ImportError):
    """An optional dependency is not installed; the message names it, its extra and
    the ``pip install`` command, in one line."""


def _absent(module: str) -> bool:
    # Imported, not only looked for: an installation that is there but cannot be
    # imported (a library of its own missing) is refused up front too. The code
    # that needs the module imports it anyway, so this costs nothing more.
    try:
        importlib.import_module(module)
    except ImportError:
        return True
    return False


def missing(modules: Union[str, Sequence[str]], what: str) -> str:
    """The one-line refusal for the modules of ``modules`` that are absent, or ''.

    Imports each module (a broken installation counts as absent).

    Parameters
    ----------
    modules : str or sequence of str
        Top-level module names, keys of :data:`EXTRAS`.
    what : str
        Who needs them, the start of the line (``"granular-chain plot"``,
        ``"Result.to_xarray"``).

    Returns
    -------
    str
        ``'<what>: needs <names>, from the [<extra>] extra: pip install
        "granular_chain[<extra>]"'``, or '' when every module is there.
    """
    names = [modules] if isinstance(modules, str) else list(modules)
    return _message([m for m in names if _absent(m)], what)


def _message(absent: Sequence[str], what: str) -> str:
    """The refusal naming ``absent`` (modules) and the extras that install them."""
    if not absent:
        return ""
    said = [EXTRAS.get(m, (m, "viz"))[0] for m in absent]
    extras = sorted({EXTRAS.get(m, (m, "viz"))[1] for m in absent})
    which = ", ".join(f"[{e}]" for e in extras)
    return (f"{what}: needs {' and '.join(said)}, from the {which} "
            f"extra{'s' if len(extras) > 1 else ''}: "
            f"pip install \"granular_chain[{','.join(extras)}]\"")


def check(modules: Union[str, Sequence[str]], what: str) -> None:
    """Raise :class:`MissingExtraError` when any of ``modules`` cannot be imported.

    Parameters
    ----------
    modules : str or sequence of str
        Top-level module names, keys of :data:`EXTRAS`.
    what : str
        Who needs them (see :func:`missing`).

    Raises
    ------
    MissingExtraError
        With the message of :func:`missing`.
    """
    message = missing(modules, what)
    if message:
        raise MissingExtraError(message)


def require(module: str, what: str) -> ModuleType:
    """Import the optional ``module``, or raise :class:`MissingExtraError` saying which
    extra installs it.

    Parameters
    ----------
    module : str
        A module name (``"matplotlib.pyplot"``); its top-level package names the extra.
    what : str
        Who needs it (see :func:`missing`).

    Returns
    -------
    module
        The imported module.

    Raises
    ------
    MissingExtraError
        The module (or one it imports) cannot be imported.
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        top = module.partition(".")[0]
        raise MissingExtraError(_message([top], what)) from exc
