"""The feature codes are constants before typing: absent features' branches are cut
before numba types them (granular_chain._literal_folding).

Each kernel of the first tests holds, in the branch of an absent feature, code that
cannot be typed (``len`` of a float): numba's own pipeline types that branch and fails;
the engine's pipeline cuts it first and compiles. The kernels after them compile with
both pipelines and must give the same values as each other and as Python: a code
reassigned in a loop, a nested named tuple, literal and run-time fields side by side, a
code passed into an inlined callee inside a loop.
"""

from collections import namedtuple

import numba
import pytest
from numba import types
from numba.core.errors import TypingError

from granular_chain._compile import specialised
from granular_chain._literal_folding import FeatureCompiler, FoldCodesThenPrune

pytestmark = pytest.mark.filterwarnings("ignore::granular_chain.CompileNotice")

Codes = namedtuple("Codes", ["coulomb", "walls"])


def _kernels(pipeline):
    """The same three kernels, compiled with ``pipeline`` (None: numba's own)."""
    options = {} if pipeline is None else {"pipeline_class": pipeline}

    @numba.njit(inline="always")
    def helper(flag, x):
        if flag:
            return x + 1.0
        return len(x)  # untypable: must be cut when flag is 0

    @numba.njit(**options)
    def by_field(codes, x):
        if codes.coulomb:
            return len(x)  # untypable: cut when coulomb is 0
        if codes.walls == 1:
            return 2.0 * x
        return x

    @numba.njit(**options)
    def by_argument(flag, x):
        flag = numba.literally(flag)
        return helper(flag, x)

    @numba.njit(**options)
    def passed_on(codes, x):
        return helper(codes.walls, x)

    @numba.njit(**options)
    def direct(flag, x):  # a truth test of the literal argument itself
        if flag:
            return x + 1.0
        return len(x)

    return by_field, by_argument, passed_on, direct


def test_absent_features_are_cut_before_typing():
    by_field, by_argument, passed_on, direct = _kernels(FeatureCompiler)
    assert specialised(by_field, (Codes(0, 1), 3.0), (0,))(Codes(0, 1), 3.0) == 6.0
    assert specialised(by_field, (Codes(0, 0), 3.0), (0,))(Codes(0, 0), 3.0) == 3.0
    assert specialised(by_argument, (1, 3.0), (0,))(1, 3.0) == 4.0
    assert specialised(passed_on, (Codes(0, 1), 3.0), (0,))(Codes(0, 1), 3.0) == 4.0
    assert specialised(direct, (1, 3.0), (0,))(1, 3.0) == 4.0


@pytest.mark.parametrize("which", [0, 1, 2, 3], ids=["field", "argument", "passed on", "direct"])
def test_numbas_own_pipeline_types_them(which):
    """The check above can fail: without the folding, each of these does not compile."""
    kernel = _kernels(None)[which]
    args = {0: (Codes(0, 1), 3.0), 1: (1, 3.0), 2: (Codes(0, 1), 3.0), 3: (1, 3.0)}[which]
    with pytest.raises(TypingError):
        specialised(kernel, args, (0,))


def test_a_code_that_is_no_literal_is_left_alone():
    """An ordinary integer is read at run time: both branches typed (and the bad one
    refused), as numba does."""
    by_field = _kernels(FeatureCompiler)[0]
    with pytest.raises(TypingError):
        by_field.compile((types.NamedTuple((types.int64, types.int64), Codes), types.float64))


def test_every_pruning_pass_of_numbas_pipeline_folds_first():
    """numba's nopython pipeline lists three pruning passes; each is the folding pass here."""
    from numba.core.compiler import DefaultPassBuilder
    from numba.core.untyped_passes import DeadBranchPrune

    class State:  # what define_nopython_pipeline reads
        flags = numba.core.compiler.Flags()
        func_ir = None

    state = State()
    state.flags.enable_ssa = True
    numba_passes = [p for p, _ in DefaultPassBuilder.define_nopython_pipeline(state).passes]
    assert numba_passes.count(DeadBranchPrune) == 3
    compiler = FeatureCompiler.__new__(FeatureCompiler)
    compiler.state = state
    (ours,) = compiler.define_pipelines()
    passes = [p for p, _ in ours.passes]
    assert DeadBranchPrune not in passes
    assert passes == [FoldCodesThenPrune if p is DeadBranchPrune else p for p in numba_passes]


Mixed = namedtuple("Mixed", ["flag", "scale"])
Outer = namedtuple("Outer", ["inner", "flag"])
Inner = namedtuple("Inner", ["flag"])


def _same_kernels(pipeline):
    """Kernels numba's pipeline compiles too (no untypable branch)."""
    options = {} if pipeline is None else {"pipeline_class": pipeline}

    @numba.njit(inline="always")
    def step(flag, s, i):
        if flag:
            return s + i
        return s - 1

    @numba.njit(**options)
    def reassigned(law, n):
        law = numba.literally(law)
        s = 0
        for i in range(n):
            if law == 1:
                s += i
            law = law + 1  # a literal no more after the first pass of the loop
        return s, law

    @numba.njit(**options)
    def nested(outer, x):
        if outer.inner.flag:  # a field of a field: left to run time
            x = x * 2.0
        if outer.flag:
            x = x + 1.0
        return x

    @numba.njit(**options)
    def mixed(codes, x):
        if codes.flag:
            return x * codes.scale
        return x

    @numba.njit(**options)
    def passed_on_in_a_loop(codes, n):
        s = 0
        for i in range(n):
            s = step(codes.coulomb, s, i)
        return s

    return reassigned, nested, mixed, passed_on_in_a_loop

CASES = [
    ("reassigned", (types.literal(1), types.int64), (1, 10)),
    ("reassigned", (types.literal(0), types.int64), (0, 10)),
    ("nested", (types.NamedTuple((types.NamedTuple((types.literal(1),), Inner),
                                  types.literal(0)), Outer), types.float64),
     (Outer(Inner(1), 0), 3.0)),
    ("mixed", (types.NamedTuple((types.literal(1), types.float64), Mixed), types.float64),
     (Mixed(1, 2.5), 3.0)),
    ("mixed", (types.NamedTuple((types.literal(0), types.float64), Mixed), types.float64),
     (Mixed(0, 2.5), 3.0)),
    ("passed_on_in_a_loop", (types.NamedTuple((types.literal(1), types.literal(0)), Codes),
                             types.int64), (Codes(1, 0), 7)),
    ("passed_on_in_a_loop", (types.NamedTuple((types.literal(0), types.literal(0)), Codes),
                             types.int64), (Codes(0, 0), 7)),
]
NAMES = ["reassigned", "nested", "mixed", "passed_on_in_a_loop"]


@pytest.mark.parametrize("name, signature, args", CASES,
                         ids=[f"{c[0]}-{i}" for i, c in enumerate(CASES)])
def test_folded_kernels_compute_what_numbas_do(name, signature, args):
    ours = _same_kernels(FeatureCompiler)[NAMES.index(name)]
    numbas = _same_kernels(None)[NAMES.index(name)]
    results = []
    for kernel in (ours, numbas):
        kernel.compile(signature)
        results.append(kernel.overloads[tuple(signature)].entry_point(*args))
    assert results[0] == results[1] == ours.py_func(*args)
