"""Numba's alias analysis for dead-code removal, run until nothing changes.

Before it lowers a function numba removes statements it takes for dead
(``ir_utils.remove_dead``), among them a write into an array that nothing reads
afterwards, unless that array may be an argument or part of one: its alias analysis
(``ir_utils.find_potential_aliases``) collects the variables that may hold an
argument's memory. It does so in one sweep over the blocks in the order they are
stored, and each of its rules (``a = b``, ``a = b[i]``, ``a = b.c`` for an array field
of a record, ``a = b.ravel()``, ...) makes ``a`` an argument's alias only if the sweep
has already found ``b`` to be one. Where the block that binds ``b`` is stored after the
block that reads ``b.c``, the field is not taken for the argument's, and every write
into it is removed as dead. The order is an accident of inlining: in the Verlet kernel
with the event log, cutting an absent feature's branch before inlining
(:mod:`._literal_folding`) stores the inlined ``log_kicks``' binding of the log after
its writes, and numba's sweep alone removes every stop and slip it logs (the LLVM IR
holds no store of their kinds; ``tests/test_verlet_events.py`` counts them).

:func:`complete_aliases` repeats numba's sweep, each time from the argument aliases the
last one found, until the set stops growing: every variable numba's rules tie to an
argument is then found, whatever the order of the blocks. It only ever finds more
argument aliases, so it only ever keeps more statements; aliases among local arrays
are numba's, unchanged. In force while the engine's pipeline compiles
(:class:`._literal_folding.FeatureCompiler`); if the installed numba's function does not
take the arguments this calls it with, numba's own is used.
"""

from __future__ import annotations

import inspect

from numba.core import ir_utils

from ._method_swap import methods_swapped

__all__ = ["aliases_to_fixed_point", "complete_aliases"]

_ORIGINAL = {"find_potential_aliases": ir_utils.find_potential_aliases}
_SIGNATURE = ["blocks", "args", "typemap", "func_ir", "alias_map", "arg_aliases"]


def aliases_to_fixed_point(blocks, args, typemap, func_ir, alias_map=None, arg_aliases=None):
    """Numba's ``find_potential_aliases``, repeated until the argument aliases it finds
    stop growing.

    Parameters
    ----------
    blocks : dict
        Label -> numba IR block, the function's (or a part of it).
    args : iterable of str
        The function's argument names.
    typemap : dict or None
        Variable name -> numba type (None before typing).
    func_ir : numba.core.ir.FunctionIR
        The function.
    alias_map : dict, optional
        Variable name -> set of names it may alias, to start from.
    arg_aliases : set of str, optional
        Names that may hold an argument's memory, to start from.

    Returns
    -------
    (alias_map, arg_aliases) : (dict, set)
        As numba's, at the fixed point.
    """
    find = _ORIGINAL["find_potential_aliases"]
    alias_map, arg_aliases = find(blocks, args, typemap, func_ir, alias_map, arg_aliases)
    while True:
        found = len(arg_aliases)
        alias_map, arg_aliases = find(blocks, args, typemap, func_ir, alias_map, arg_aliases)
        if len(arg_aliases) == found:
            return alias_map, arg_aliases


def _takes_what_we_pass() -> bool:
    """Whether numba's function has the parameters :func:`aliases_to_fixed_point` passes."""
    try:
        names = list(inspect.signature(_ORIGINAL["find_potential_aliases"]).parameters)
    except (TypeError, ValueError):
        return False
    return names == _SIGNATURE


_COMPLETE = {"find_potential_aliases": aliases_to_fixed_point} if _takes_what_we_pass() else {}


def applies() -> bool:
    """Whether the installed numba's alias analysis is the one this module repeats."""
    return bool(_COMPLETE)


def complete_aliases():
    """Within the block numba's dead-code removal sees every argument alias.

    Returns
    -------
    context manager
        Numba's ``ir_utils.find_potential_aliases`` is :func:`aliases_to_fixed_point`
        inside it (not when numba's does not take the arguments it passes); a block
        inside another leaves it to the outer one.
    """
    return methods_swapped(ir_utils, _COMPLETE, _ORIGINAL)
