"""granular_chain._flag_lookups: numba's compile flags hashed and compared faster give
the same answers as numba's own methods, and only inside the block."""

import itertools
import re

import numba
import numpy as np
import pytest
from numba.core.compiler import Flags
from numba.core.targetconfig import TargetConfig

from granular_chain import _flag_lookups
from granular_chain._flag_lookups import quick_flag_lookups

_ORIGINAL = _flag_lookups._ORIGINAL


def _flags_variety():
    """Flags objects: default, set to their default, set otherwise, copies."""
    plain = Flags()
    explicit = Flags()
    explicit.nrt = False  # (the default, but set: numba's values() are equal)
    nrt = Flags()
    nrt.nrt = True
    fast = Flags()
    fast.fastmath = True
    fast_nrt = Flags(copy_from=fast)
    fast_nrt.nrt = True
    wrapperless = Flags()
    wrapperless.no_cpython_wrapper = True
    slow = Flags()
    slow.fastmath = False  # (a new object equal to the default one)
    return [plain, explicit, nrt, fast, fast_nrt, wrapperless, slow, Flags(copy_from=nrt),
            Flags(copy_from=fast_nrt)]


def test_the_installed_numba_is_the_one_sped_up():
    # Fails when a numba release changes TargetConfig's hash or equality: the kernels
    # then compile with numba's own (correct, slower); see whether numba changed them.
    if numba.version_info[:2] >= (0, 70):
        pytest.skip(f"numba {numba.__version__}: checked against 0.6x")
    assert _flag_lookups.applies()


def test_same_hash_and_equality_as_numba():
    """Every pair of a variety of flags: the hash and == of numba's methods."""
    variety = _flags_variety()
    expected_hash = [_ORIGINAL["__hash__"](f) for f in variety]
    expected_eq = {(i, j): _ORIGINAL["__eq__"](a, b)
                   for (i, a), (j, b) in itertools.product(enumerate(variety), repeat=2)}
    assert sum(expected_eq.values()) > len(variety)  # some distinct objects are equal
    assert not all(expected_eq.values())  # and some are not
    with quick_flag_lookups():
        assert [hash(f) for f in variety] == expected_hash
        for (i, a), (j, b) in itertools.product(enumerate(variety), repeat=2):
            assert (a == b) == expected_eq[i, j], (a, b)
        assert (variety[0] == 1) is False  # not a TargetConfig: numba's answer


def test_in_force_only_inside_the_block():
    with quick_flag_lookups():
        assert TargetConfig.__dict__["__eq__"] is _flag_lookups._eq
        with quick_flag_lookups():  # nested: left to the outer block
            pass
        assert TargetConfig.__dict__["__hash__"] is _flag_lookups._hash
    for name, method in _ORIGINAL.items():
        assert TargetConfig.__dict__[name] is method
    with pytest.raises(RuntimeError):
        with quick_flag_lookups():
            raise RuntimeError("a failed compile")
    for name, method in _ORIGINAL.items():
        assert TargetConfig.__dict__[name] is method


def test_the_same_code_is_compiled_with_and_without_it():
    """A function calling @overload implementations (numpy, math, min): the same LLVM
    IR, compiled with numba's methods and with the faster ones."""
    def f(a):
        s = 0.0
        for k in range(a.size):
            s += min(np.sqrt(abs(a[k])), 2.0) + np.sum(a[:k])
        return s

    stock, quick = numba.njit(f), numba.njit(f)
    a = np.array([0.5, -1.0, 2.0, 3.0])
    expected = stock(a)
    with quick_flag_lookups():
        assert quick(a) == expected
    assert _shape(stock) == _shape(quick)


def _shape(dispatcher) -> str:
    """The LLVM IR of the one compiled signature without numbers (each compile of a
    function numbers its mangled names apart)."""
    return re.sub(r"\d+", "N", dispatcher.inspect_llvm(dispatcher.signatures[0]))
