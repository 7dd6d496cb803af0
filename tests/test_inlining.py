"""granular_chain._inlining: numba's inline="always" with linear-cost copies compiles
the same code as numba's own inliner, and is in force only inside its block."""

import re

import numba
import numpy as np
import pytest
from numba.core import inline_closurecall

from granular_chain import _inlining
from granular_chain._inlining import linear_inlining


@numba.njit(inline="always")
def _leaf(a, n):
    s = 0.0
    for k in range(n):
        if a[k] > 0:
            s += a[k] * a[k]
        else:
            s -= a[k]
    return s


@numba.njit(inline="always")
def _middle(a, n):
    t = _leaf(a, n) + _leaf(a, n - 1)  # two call sites of one callee
    if t > 1.0:
        t = t - _leaf(a, 1)
    return t


def _top(a, n):
    acc = 0.0
    for r in range(3):
        acc += _middle(a, n) * (r + 1)
    return acc + _middle(a, 2)


def _shape(dispatcher) -> str:
    """The LLVM IR of the one compiled signature, without value names, numbers or
    spacing (the inliner names its variables by how often a name was inlined)."""
    text = dispatcher.inspect_llvm(dispatcher.signatures[0])
    text = re.sub(r"%[\w.$\"-]+", "%v", text)
    return re.sub(r"\s+", " ", re.sub(r"\d+", "N", text))


def test_the_installed_numba_is_the_one_rewritten():
    # Fails when a numba release changes inline_ir: the kernels then compile with
    # numba's own inliner (correct, slower); see whether numba fixed the copies.
    if numba.version_info[:2] >= (0, 70):
        pytest.skip(f"numba {numba.__version__}: rewrite checked against 0.6x")
    assert _inlining.applies()


def test_the_same_code_is_compiled_with_and_without_it():
    stock, linear = numba.njit(_top), numba.njit(_top)
    a = np.array([0.5, -1.0, 2.0, 3.0])
    expected = stock(a, 4)
    with linear_inlining():
        assert inline_closurecall.InlineWorker.inline_ir is not _inlining._ORIGINAL["inline_ir"]
        got = linear(a, 4)
    assert got == expected == 116.75
    assert _shape(linear) == _shape(stock)
    assert len(_shape(stock)) > 10_000  # (the loops and the three inlined levels are there)


def test_numba_own_inliner_is_back_after_the_block_even_on_error():
    with pytest.raises(RuntimeError):
        with linear_inlining():
            raise RuntimeError("inside")
    for name, method in _inlining._ORIGINAL.items():
        assert getattr(inline_closurecall.InlineWorker, name) is method


def test_a_nested_block_leaves_the_outer_one_in_force():
    with linear_inlining():
        with linear_inlining():
            pass
        assert inline_closurecall.InlineWorker.inline_ir is _inlining._FASTER["inline_ir"]
    assert inline_closurecall.InlineWorker.inline_ir is _inlining._ORIGINAL["inline_ir"]


def test_each_callee_is_made_untyped_once():
    _inlining._UNTYPED.clear()
    with linear_inlining():
        numba.njit(_top)(np.ones(3), 3)
    made = sorted(key[0].__name__ for key in _inlining._UNTYPED)
    assert made == ["_leaf", "_middle"]  # (three call sites of _leaf, two of _middle)
