"""Functions compiled with ``_compile.callee`` have no entry point from Python (no
CPython wrapper: calling one from Python would crash the interpreter). No Python code of
the repository calls one: each is reached only from compiled code."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "granular_chain"
#: Decorators of compiled functions, whose bodies are compiled code (the name called).
COMPILED = {"njit", "jit", "callee", "kernel", "register_jitable", "vectorize", "guvectorize"}


def _module(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _compiled(node) -> bool:
    for decorator in node.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        if (target.attr if isinstance(target, ast.Attribute)
                else getattr(target, "id", "")) in COMPILED:
            return True
    return False


def _callees() -> dict:
    """module -> names of its functions decorated with ``callee(...)``, and of the
    callees it imports from another module (re-exported there)."""
    found, trees = {}, {}
    for path in PACKAGE.rglob("*.py"):
        trees[path] = tree = ast.parse(path.read_text())
        names = {f.name for f in tree.body if isinstance(f, ast.FunctionDef)
                 and any(ast.unparse(d).startswith("callee(") for d in f.decorator_list)}
        if names:
            found[_module(path)] = names
    for _ in range(3):  # (re-exports of re-exports)
        for path, tree in trees.items():
            for node in tree.body:
                if isinstance(node, ast.ImportFrom):
                    source = _absolute(node.level, node.module, path)
                    names = {a.asname or a.name for a in node.names
                             if a.name in found.get(source, ())}
                    if names:
                        found.setdefault(_module(path), set()).update(names)
    return found


def _absolute(level: int, name: str | None, path: Path) -> str:
    """The absolute module of ``from <level dots><name> import ...`` in ``path``."""
    if level == 0:
        return name or ""
    base = _module(path).split(".")
    if path.name != "__init__.py":
        base = base[:-1]
    base = base[:len(base) - (level - 1)]
    return ".".join(base + ([name] if name else []))


def _python_uses(path: Path, callees: dict) -> list[str]:
    """Where Python (not compiled) code of ``path`` names a callee."""
    tree = ast.parse(path.read_text())
    here = _module(path) if path.is_relative_to(PACKAGE) else ""
    names = {n: (here, n) for n in callees.get(here, ())}  # local name -> (module, name)
    modules = {}  # local name -> module
    uses = []
    where = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path.name
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            source = _absolute(node.level, node.module, path)
            for alias in node.names:
                local = alias.asname or alias.name
                if alias.name == "*" and source in callees:
                    uses.append(f"{where}:{node.lineno} import * from {source}")
                if alias.name in callees.get(source, ()):
                    names[local] = (source, alias.name)
                if f"{source}.{alias.name}" in callees:
                    modules[local] = f"{source}.{alias.name}"
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name in callees:
                    modules[alias.asname or alias.name] = alias.name
    inside = {id(n) for f in ast.walk(tree) if isinstance(f, ast.FunctionDef) and _compiled(f)
              for n in ast.walk(f)}
    for node in ast.walk(tree):
        if id(node) in inside:
            continue
        if isinstance(node, ast.Name) and node.id in names \
                and isinstance(node.ctx, ast.Load):
            uses.append(f"{where}:{node.lineno} {node.id}")
        elif isinstance(node, ast.Attribute) and ast.unparse(node.value) in modules \
                and node.attr in callees[modules[ast.unparse(node.value)]]:
            uses.append(f"{where}:{node.lineno} {ast.unparse(node)}")
    return uses


def test_the_event_stepper_has_callees():
    callees = _callees()
    assert "settle" in callees["granular_chain.steppers.events.modes"]
    assert sum(len(v) for v in callees.values()) > 40


def test_no_python_code_calls_a_callee():
    callees = _callees()
    uses = [u for folder in ("granular_chain", "tests", "benchmarks", "docs", "docs_build")
            for path in sorted((ROOT / folder).rglob("*.py"))
            for u in _python_uses(path, callees)]
    assert uses == []


def test_the_check_sees_a_python_call(tmp_path):
    """The check finds a callee named from Python code, imported either way, and not
    one named inside a compiled function."""
    callees = {"granular_chain.steppers.events.modes": {"settle"}}
    probe = tmp_path / "probe.py"
    probe.write_text("import numba\n"
                     "from granular_chain.steppers.events.modes import settle\n"
                     "from granular_chain.steppers.events import modes\n"
                     "import granular_chain.steppers.events.modes as m\n"
                     "from granular_chain.steppers.events.modes import *\n"
                     "settle(1)\nmodes.settle(2)\nm.settle(3)\n"
                     "@numba.njit\ndef f():\n    return settle(4)\n")
    assert sorted(_python_uses(probe, callees)) == [
        "probe.py:5 import * from granular_chain.steppers.events.modes", "probe.py:6 settle",
        "probe.py:7 modes.settle", "probe.py:8 m.settle"]


def test_a_re_exported_callee_is_a_callee():
    """``events/kernel.py`` imports ``settle`` from ``modes``: from there it is one too."""
    assert "settle" in _callees()["granular_chain.steppers.events.kernel"]

