"""Methods of a class, or functions of a module, replaced for the duration of a block
(the engine's versions of a few of numba's, in force only while its kernels compile)."""

from __future__ import annotations

import contextlib


@contextlib.contextmanager
def methods_swapped(owner, faster: dict, original: dict):
    """Within the block ``owner`` has the methods ``faster``; after it (also after an
    exception) those of ``original``.

    Parameters
    ----------
    owner : type or module
        The class whose methods, or the module whose functions, are replaced.
    faster : dict
        Method name -> function to put in place; empty: nothing is replaced.
    original : dict
        Method name -> function to put back.

    Yields
    ------
    None
        A block inside another that swapped the same methods leaves them to the outer.
    """
    first = next(iter(faster), None)
    if first is None or owner.__dict__.get(first) is faster[first]:
        yield  # (nothing to swap, or already inside such a block)
        return
    for name, method in faster.items():
        setattr(owner, name, method)
    try:
        yield
    finally:
        for name, method in original.items():
            setattr(owner, name, method)
