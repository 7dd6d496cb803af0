"""Numba's alias analysis taken to its fixed point (granular_chain._alias_analysis).

The function's blocks here are stored with the block that reads a field of ``a``
before the block that binds ``a`` to the argument: numba's one sweep does not take the
field for the argument's (a write into it would be removed as dead); the repeated
sweep does. The end-to-end case, the Verlet kernel's event log losing its stops and
slips, is in tests/test_verlet_events.py.
"""

from types import SimpleNamespace

from numba.core import ir, ir_utils

from granular_chain import _alias_analysis as aa

LOC = ir.Loc("test_alias_analysis", 1)


def _function():
    """Blocks {1: b = a.x; c = b, 0: rec = arg(0); a = rec} (in that stored order), and
    a stand-in for the FunctionIR (numba reads only its blocks)."""
    scope = ir.Scope(None, LOC)
    rec, a, b, c = (scope.define(name, LOC) for name in ("rec", "a", "b", "c"))
    reads = ir.Block(scope, LOC)
    reads.append(ir.Assign(ir.Expr.getattr(a, "x", LOC), b, LOC))
    reads.append(ir.Assign(b, c, LOC))
    binds = ir.Block(scope, LOC)
    binds.append(ir.Assign(ir.Arg("rec", 0, LOC), rec, LOC))
    binds.append(ir.Assign(rec, a, LOC))
    blocks = {1: reads, 0: binds}
    return blocks, SimpleNamespace(blocks=blocks)


def test_numbas_one_sweep_misses_the_field_of_a_later_bound_argument():
    blocks, func_ir = _function()
    _, arg_aliases = aa._ORIGINAL["find_potential_aliases"](blocks, ["rec"], None, func_ir)
    assert arg_aliases == {"rec", "a"}  # b = a.x and c = b were seen before a was bound


def test_the_fixed_point_finds_every_alias_whatever_the_order():
    blocks, func_ir = _function()
    _, arg_aliases = aa.aliases_to_fixed_point(blocks, ["rec"], None, func_ir)
    assert arg_aliases == {"rec", "a", "b", "c"}
    in_order = {0: blocks[0], 1: blocks[1]}
    _, numba_in_order = aa._ORIGINAL["find_potential_aliases"](in_order, ["rec"], None,
                                                                SimpleNamespace(blocks=in_order))
    assert numba_in_order == arg_aliases  # what numba finds when the order is kind


def test_in_force_only_inside_the_block_and_on_this_numba():
    assert aa.applies()
    numbas = ir_utils.find_potential_aliases
    with aa.complete_aliases():
        assert ir_utils.find_potential_aliases is aa.aliases_to_fixed_point
        with aa.complete_aliases():  # nested: left to the outer block
            assert ir_utils.find_potential_aliases is aa.aliases_to_fixed_point
        assert ir_utils.find_potential_aliases is aa.aliases_to_fixed_point
    assert ir_utils.find_potential_aliases is numbas
