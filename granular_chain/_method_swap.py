"""Methods of a class replaced for the duration of a block (the engine's faster
versions of a few numba methods, in force only while one of its kernels compiles)."""

from __future__ import annotations

import contextlib


@contextlib.contextmanager
def methods_swapped(owner: type, faster: dict, original: dict):
    """Within the block ``owner`` has the methods ``faster``; after it (also after an
    exception) those of ``original``.

    Parameters
    ----------
    owner : type
        The class whose methods are replaced.
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
