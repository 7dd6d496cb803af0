"""The package's shape rules: every function short enough to read whole, every
compiled kernel with a short parameter list (records, not slot lists)."""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "granular_chain"
MAX_LINES = 120
MAX_KERNEL_PARAMETERS = 12


def _functions():
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                yield path.relative_to(PACKAGE.parent), node


def _compiled(node) -> bool:
    """Decorated with numba's njit/jit/vectorize (called or not, any alias of numba) or
    with the package's ``callee``/``kernel`` (``_compile``: njit with its options)."""
    for decorator in node.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if name in {"njit", "jit", "vectorize", "guvectorize", "generated_jit", "callee",
                    "kernel"}:
            return True
    return False


def _parameters(node) -> int:
    a = node.args
    return len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + bool(a.vararg) + bool(a.kwarg)


def test_the_rules_see_the_package():
    """Guard against a scan that finds nothing (and so passes by accident)."""
    found = list(_functions())
    assert len(found) > 300
    assert sum(_compiled(f) for _, f in found) > 30
    assert sum(_compiled(f) and "callee" in ast.unparse(f.decorator_list[0])
               for _, f in found) > 40


def test_no_function_longer_than_120_lines():
    long = [f"{path}:{f.lineno} {f.name} ({f.end_lineno - f.lineno + 1} lines)"
            for path, f in _functions() if f.end_lineno - f.lineno + 1 > MAX_LINES]
    assert not long, "functions over 120 lines:\n" + "\n".join(long)


def test_no_compiled_kernel_with_more_than_12_parameters():
    wide = [f"{path}:{f.lineno} {f.name} ({_parameters(f)} parameters)"
            for path, f in _functions() if _compiled(f) and _parameters(f) > MAX_KERNEL_PARAMETERS]
    assert not wide, "compiled functions over 12 parameters:\n" + "\n".join(wide)


@pytest.mark.parametrize("source, lines, compiled, parameters", [
    ("def f(a, b):\n    return a\n", 2, False, 2),
    ("@numba.njit(cache=True)\ndef f(*a, b=1, **k):\n    pass\n", 2, True, 3),
    ("@njit\ndef f(a, /, b):\n    pass\n", 2, True, 2),
    ("@callee(error_model='numpy')\ndef f(a):\n    pass\n", 2, True, 1),
    ("@kernel()\ndef f(a):\n    pass\n", 2, True, 1),
])
def test_the_rules_measure_what_they_say(source, lines, compiled, parameters):
    f = ast.parse(source).body[0]
    assert (f.end_lineno - f.lineno + 1, _compiled(f), _parameters(f)) == (lines, compiled, parameters)
