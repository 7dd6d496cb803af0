"""Numba's ``inline="always"`` at a cost linear in the size of what it inlines.

The event kernel inlines its per-step phases (``inline="always"``, numba's IR-level
inlining): without it each phase would be a call passing the records' arrays as
hundreds of flattened arguments (``docs/performance.md``, "Compile time"). Numba
(0.68) makes every such inline cost more than it should, in two ways:

- ``InlineWorker.inline_ir`` copies the callee's IR one block at a time, each block
  with a fresh ``copy.deepcopy`` memo, so the scope every block refers to (all the
  callee's variables) is copied once per block: blocks x variables, quadratic in
  the size of the callee. Copied in one ``deepcopy`` of all its blocks, the scope
  is copied once.
- ``InlineWorker.inline_function`` runs the untyped compiler passes on the callee
  at every call site and for every specialisation compiled, although their result
  depends only on the callee and the compile flags. It is kept here, one per
  callee and flags, and copied by ``inline_ir`` before each use as before. (The
  module constants an inlined callee reads are then those of its first inline in
  the process, as a kernel loaded from numba's on-disk cache keeps those it was
  compiled with.)

Upstream: numba issues 8989 and 9204, numba-cuda issue 688. :func:`linear_inlining`
applies both while one of the engine's kernels compiles and restores numba's own
methods after. The same IR reaches typing, up to the names of its variables (numba
numbers a name by how often it was inlined), so the machine code is the same:
``tests/test_inlining.py`` compares the LLVM IR, ``benchmarks/tiled_compare.py`` the
results, bit for bit. If the installed numba's ``inline_ir`` is not the text this
rewrites, numba's own is used unchanged.
"""

from __future__ import annotations

import inspect
import textwrap

from numba.core import inline_closurecall

from ._method_swap import methods_swapped

_Worker = inline_closurecall.InlineWorker

#: The copy, in numba's ``inline_ir`` (dedented), that costs blocks x variables ...
_COPY_BLOCK_BY_BLOCK = (
    "        kernel_copy.blocks = {}\n"
    "        for block_label, block in the_ir.blocks.items():\n"
    "            new_block = copy.deepcopy(the_ir.blocks[block_label])\n"
    "            kernel_copy.blocks[block_label] = new_block\n")
#: ... and the same copy made at once: one memo, so the shared scope is copied once.
_COPY_AT_ONCE = "        kernel_copy.blocks = copy.deepcopy(the_ir.blocks)\n"

#: Untyped IR of each inlined callee: (function, flags, locals) -> numba FunctionIR.
#: Only ever copied (``inline_ir`` copies its callee before changing it).
_UNTYPED: dict = {}


def _inline_ir_copying_once():
    """Numba's ``InlineWorker.inline_ir`` with the block copy made at once.

    Returns
    -------
    function or None
        The rewritten method, compiled in ``inline_closurecall``'s namespace; None
        when the installed numba's source is not the text this rewrites.
    """
    try:
        source = textwrap.dedent(inspect.getsource(_Worker.inline_ir))
    except (OSError, TypeError):
        return None
    if source.count(_COPY_BLOCK_BY_BLOCK) != 1:
        return None
    namespace = dict(vars(inline_closurecall))
    code = compile(source.replace(_COPY_BLOCK_BY_BLOCK, _COPY_AT_ONCE),
                   inline_closurecall.__file__, "exec")
    exec(code, namespace)  # noqa: S102 (numba's own method, one copy rewritten)
    return namespace["inline_ir"]


def _inline_function_once(self, caller_ir, block, i, function, arg_typs=None):
    """``InlineWorker.inline_function`` with the callee's untyped IR made once."""
    self.flags.enable_ssa = False  # (what run_untyped_passes sets, hit or miss)
    key = (function, self.flags.copy(), tuple(sorted((self.locals or {}).items())))
    untyped = _UNTYPED.get(key)
    if untyped is None:
        untyped = _UNTYPED[key] = self.run_untyped_passes(function)
    return self.inline_ir(caller_ir, block, i, untyped, function.__code__.co_freevars,
                          arg_typs=arg_typs)


_ORIGINAL = {"inline_ir": _Worker.inline_ir, "inline_function": _Worker.inline_function}
_REWRITTEN = _inline_ir_copying_once()
#: What linear_inlining puts in place: nothing when numba is not the one rewritten.
_FASTER = {} if _REWRITTEN is None else {"inline_ir": _REWRITTEN,
                                         "inline_function": _inline_function_once}


def applies() -> bool:
    """Whether the installed numba's inliner is the one this module rewrites."""
    return bool(_FASTER)


def linear_inlining():
    """Compile with the faster inliner inside the block, numba's own outside it.

    Returns
    -------
    context manager
        Within it numba's ``InlineWorker`` has this module's ``inline_ir`` and
        ``inline_function`` (not when numba is not the one this module rewrites); a
        block inside another leaves them to the outer one.
    """
    return methods_swapped(_Worker, _FASTER, _ORIGINAL)
