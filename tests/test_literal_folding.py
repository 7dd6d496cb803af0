"""The feature codes are constants before typing: absent features' branches are cut
before numba types them (granular_chain._literal_folding).

Each kernel here holds, in the branch of an absent feature, code that cannot be typed
(``len`` of a float). numba's own pipeline types that branch and fails; the engine's
pipeline cuts it first and compiles. The live branch gives the same value either way.
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

    return by_field, by_argument, passed_on


def test_absent_features_are_cut_before_typing():
    by_field, by_argument, passed_on = _kernels(FeatureCompiler)
    assert specialised(by_field, (Codes(0, 1), 3.0), (0,))(Codes(0, 1), 3.0) == 6.0
    assert specialised(by_field, (Codes(0, 0), 3.0), (0,))(Codes(0, 0), 3.0) == 3.0
    assert specialised(by_argument, (1, 3.0), (0,))(1, 3.0) == 4.0
    assert specialised(passed_on, (Codes(0, 1), 3.0), (0,))(Codes(0, 1), 3.0) == 4.0


@pytest.mark.parametrize("which", [0, 1, 2], ids=["field", "argument", "passed on"])
def test_numbas_own_pipeline_types_them(which):
    """The check above can fail: without the folding, each of these does not compile."""
    kernel = _kernels(None)[which]
    args = {0: (Codes(0, 1), 3.0), 1: (1, 3.0), 2: (Codes(0, 1), 3.0)}[which]
    with pytest.raises(TypingError):
        specialised(kernel, args, (0,))


def test_a_code_that_is_no_literal_is_left_alone():
    """An ordinary integer is read at run time: both branches typed (and the bad one
    refused), as numba does."""
    by_field = _kernels(FeatureCompiler)[0]
    with pytest.raises(TypingError):
        by_field.compile((types.NamedTuple((types.int64, types.int64), Codes), types.float64))


def test_every_pruning_pass_of_numbas_pipeline_folds_first():
    """numba's nopython pipeline prunes three times; each is the folding pass here."""
    from numba.core.compiler import DefaultPassBuilder
    from numba.core.untyped_passes import DeadBranchPrune

    class State:  # what define_nopython_pipeline reads
        flags = numba.core.compiler.Flags()
        func_ir = None

    state = State()
    state.flags.enable_ssa = True
    numba_passes = [p for p, _ in DefaultPassBuilder.define_nopython_pipeline(state).passes]
    assert numba_passes.count(DeadBranchPrune) >= 2
    compiler = FeatureCompiler.__new__(FeatureCompiler)
    compiler.state = state
    (ours,) = compiler.define_pipelines()
    passes = [p for p, _ in ours.passes]
    assert DeadBranchPrune not in passes
    assert passes == [FoldCodesThenPrune if p is DeadBranchPrune else p for p in numba_passes]
