"""Feature codes read as constants before numba types a kernel, so that the branches of
absent features are cut before they are typed, lowered and optimised.

A kernel receives its feature codes as literal integer arguments (``law``, ``coulomb``)
or as the literal fields of a named tuple (``features.coulomb``). numba's pruning of dead
branches before type inference (``dead_branch_prune``) reads constants and globals, and
an argument only where it is compared with None: a literal argument (``if coulomb:``,
``law == 0``), a field of a literal named tuple and a code passed on into an inlined
callee are, to it, values known only at run time, so it types and lowers their dead
branches in every specialisation and leaves them for LLVM to delete.
:class:`FeatureCompiler` first rewrites every read of a literal code (the binding of a
literal integer argument, a field of a literal named-tuple argument, a copy of either,
numba's ``literally`` of one) into the constant it is; numba's own pruning then cuts
the branches. What is cut is code the specialisation can never run.
"""

from __future__ import annotations

import contextlib

import numba
from numba.core import ir, types
from numba.core.compiler import CompilerBase, DefaultPassBuilder
from numba.core.compiler_machinery import register_pass
from numba.core.ir_utils import build_definitions
from numba.core.untyped_passes import DeadBranchPrune

from ._alias_analysis import complete_aliases
from ._flag_lookups import quick_flag_lookups
from ._inlining import linear_inlining

__all__ = ["FeatureCompiler"]


def _definition(func_ir, var):
    """The expression that defines ``var`` (through copies), or None where it has more
    than one definition or none."""
    try:
        return func_ir.get_definition(var)
    except KeyError:
        return None


def _literal_code(func_ir, args, value, depth=0):
    """The integer ``value`` (an IR expression or variable) holds at compile time, or None.

    Parameters
    ----------
    func_ir : numba.core.ir.FunctionIR
        The function being compiled.
    args : tuple of numba types
        Its argument types.
    value : ir.Var or ir.Expr or ir.Arg or ir.Const
        What is read.
    depth : int
        Calls of ``literally`` followed so far (a guard against a cycle).

    Returns
    -------
    int or None
    """
    if isinstance(value, ir.Var):
        value = _definition(func_ir, value)
    if isinstance(value, ir.Arg):
        return _integer(args[value.index])
    if isinstance(value, ir.Const):
        return value.value if type(value.value) is int else None  # (a code folded before)
    if not isinstance(value, ir.Expr) or depth > 8:
        return None
    if value.op == "getattr":
        base = _definition(func_ir, value.value)
        if isinstance(base, ir.Arg):
            record = args[base.index]
            if isinstance(record, types.BaseNamedTuple) and value.attr in record.fields:
                return _integer(record.types[record.fields.index(value.attr)])
        return None
    if value.op == "call" and len(value.args) == 1 and not value.kws:
        if _global_value(func_ir, value.func) is numba.literally:
            return _literal_code(func_ir, args, value.args[0], depth + 1)
    return None


def _global_value(func_ir, var):
    """The object a global names, or ``numba.literally`` read as a module's attribute;
    else None."""
    found = _definition(func_ir, var)
    if isinstance(found, (ir.Global, ir.FreeVar)):
        return found.value
    if isinstance(found, ir.Expr) and found.op == "getattr" and found.attr == "literally":
        module = _definition(func_ir, found.value)
        if isinstance(module, (ir.Global, ir.FreeVar)):
            return getattr(module.value, found.attr, None)
    return None


def _integer(typ):
    """The value of an integer literal type, else None."""
    if isinstance(typ, types.IntegerLiteral):
        return int(typ.literal_value)
    return None


def fold_literal_codes(func_ir, args) -> int:
    """Rewrite every assignment whose value is a literal feature code into that constant
    (the binding of a literal argument too: the specialisation is compiled for that value).

    Parameters
    ----------
    func_ir : numba.core.ir.FunctionIR
        Changed in place (its definitions table rebuilt).
    args : tuple of numba types
        The argument types of this compilation.

    Returns
    -------
    int
        Assignments rewritten.
    """
    rewritten = 0
    for block in func_ir.blocks.values():
        for stmt in block.body:
            if not isinstance(stmt, ir.Assign) or \
                    not isinstance(stmt.value, (ir.Var, ir.Expr, ir.Arg)):
                continue
            code = _literal_code(func_ir, args, stmt.value)
            if code is not None:
                stmt.value = ir.Const(code, loc=stmt.loc)
                rewritten += 1
    if rewritten:
        func_ir._definitions = build_definitions(func_ir.blocks)
    return rewritten


@register_pass(mutates_CFG=True, analysis_only=False)
class FoldCodesThenPrune(DeadBranchPrune):
    """numba's dead branch pruning, after the literal feature codes are constants."""

    _name = "fold_codes_then_prune"

    def run_pass(self, state):
        """Fold, then prune (numba's pass)."""
        fold_literal_codes(state.func_ir, state.args)
        return super().run_pass(state)


@contextlib.contextmanager
def _engine_numba():
    """Within: numba's inliner, compile-flags look-ups and alias analysis as the engine
    compiles with them (:mod:`._inlining`, :mod:`._flag_lookups`, :mod:`._alias_analysis`);
    a compile nested in another leaves them to the outer one."""
    with linear_inlining(), quick_flag_lookups(), complete_aliases():
        yield


class FeatureCompiler(CompilerBase):
    """The engine's compiler: numba's nopython pipeline with :class:`FoldCodesThenPrune`
    in place of each of the three dead-branch pruning passes it lists
    (``numba.njit(pipeline_class=FeatureCompiler)``; the one inside numba's literal
    propagation runs only with ``literal_unroll``, which the engine does not use), run
    with numba's inliner and flags look-ups made linear and cheap and its alias analysis
    taken to its fixed point (the pruning changes where inlined code lands, and numba's
    one-sweep analysis depends on that order): every compile of a callee or kernel,
    however it is reached."""

    def define_pipelines(self):
        """The pipeline (one: nopython mode).

        Returns
        -------
        list of numba.core.compiler_machinery.PassManager
        """
        pm = DefaultPassBuilder.define_nopython_pipeline(self.state)
        pm.passes = [(FoldCodesThenPrune if p is DeadBranchPrune else p, d) for p, d in pm.passes]
        pm.finalize()
        return [pm]

    def compile_extra(self, func):
        """numba's, with the engine's numba adjustments (see the class).

        Parameters
        ----------
        func : function
            The Python function compiled.

        Returns
        -------
        numba.core.compiler.CompileResult
        """
        with _engine_numba():
            return super().compile_extra(func)

    def compile_ir(self, func_ir, lifted=(), lifted_from=None):
        """numba's, with the engine's numba adjustments (see the class).

        Parameters
        ----------
        func_ir : numba.core.ir.FunctionIR
            The function's IR.
        lifted, lifted_from
            numba's loop-lifting arguments, passed on.

        Returns
        -------
        numba.core.compiler.CompileResult
        """
        with _engine_numba():
            return super().compile_ir(func_ir, lifted, lifted_from)
