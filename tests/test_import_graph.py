"""The package's import graph, computed here from the source (every import, those inside
functions included): no circle, and no import from a stage of the data flow to a later
one (scene -> model -> result -> steppers -> simulate -> applications -> command line);
and no import inside a function except of an optional extra.
"""

import ast
import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "granular_chain"

#: Each top-level module or sub-package of granular_chain and its stage: a module may
#: import its own stage and earlier ones only. A new module gets its place here.
STAGES = [
    # what every stage may use: errors, codes, warnings, signals, compiling, the laws,
    # units, the CF names of stored variables, run folders
    {"version", "errors", "codes", "notices", "extras", "interrupts", "_compile", "_inlining",
     "_method_swap", "_flag_lookups", "_literal_folding", "_alias_analysis", "plotting",
     "progress", "distributions", "initial_state", "checkpoint", "conventions", "laws", "units", "rundir"},
    {"scene", "forces"},                          # the scene; the neighbour loop of the laws
    {"model", "contact_table", "restitution"},    # scene -> arrays and constants
    {"result", "dataset", "frames", "ledger"},    # what a run gives, frame by frame
    {"steppers", "stages", "budget", "readback", "diagnostics", "writers"},
    {"simulate"},                                 # scene -> Result, through a stepper
    {"warmup", "restart", "two_granules", "boundaries", "paper", "sweep",  # built on runs
     "classics"},
    {"granular_chain"},                           # the package's face
    {"cli", "__main__"},                          # the command line
]


def _module(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> dict:
    """module -> the package's modules it imports (at the top or inside a function)."""
    files = {_module(p): p for p in PACKAGE.rglob("*.py")}
    graph = {m: set() for m in files}
    for mod, path in files.items():
        here = mod.split(".") if path.name == "__init__.py" else mod.split(".")[:-1]
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = (".".join(here[: len(here) - node.level + 1] + [node.module or ""])
                        if node.level else node.module or "").rstrip(".")
                named = [f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in files]
                targets = named or [base]
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                continue
            for target in targets:
                while target and target not in files:  # a name inside a module: the module
                    target = target.rpartition(".")[0]
                if target.startswith("granular_chain") and target != mod:
                    graph[mod].add(target)
    return graph


def _circles(graph: dict) -> list:
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def _stage(module: str) -> int:
    top = module.split(".")[1] if "." in module else module
    for rank, names in enumerate(STAGES):
        if top in names:
            return rank
    raise AssertionError(f"{module}: give granular_chain.{top} a stage in STAGES")


def test_the_graph_is_read_from_every_module():
    graph = import_graph()
    assert len(graph) > 80
    assert "granular_chain.model" in graph["granular_chain.simulate"]
    assert "granular_chain.result" in graph["granular_chain.readback"]


def test_the_package_has_no_import_circle():
    assert _circles(import_graph()) == []


def test_no_module_imports_a_later_stage():
    upward = [f"{a} -> {b}" for a, deps in sorted(import_graph().items()) for b in sorted(deps)
              if _stage(b) > _stage(a)]
    assert upward == []


def test_the_check_finds_a_circle_and_an_upward_import():
    graph = {"granular_chain.scene": {"granular_chain.model"},
             "granular_chain.model": {"granular_chain.scene"}}
    assert _circles(graph) == [["granular_chain.model", "granular_chain.scene"]]
    assert _stage("granular_chain.model") > _stage("granular_chain.scene")


def test_the_kernel_free_parts_hold_no_kernel_and_no_kernel_imports_them():
    """granular_chain.KERNEL_FREE stays out of the digest that drops stale compiled
    kernels: it must hold no numba code, and no other module may import it."""
    from granular_chain import KERNEL_FREE

    def free(module: str) -> bool:
        parts = module.split(".")
        return len(parts) > 1 and (parts[1] in KERNEL_FREE or f"{parts[1]}.py" in KERNEL_FREE)

    graph = import_graph()
    importers = [f"{a} -> {b}" for a, deps in sorted(graph.items()) for b in sorted(deps)
                 if free(b) and not free(a)]
    assert importers == []
    def compiles(text: str) -> bool:  # numba, or the package's njit of _compile
        return "numba" in text or "_compile import" in text

    numba = [str(p) for part in KERNEL_FREE for p in sorted((PACKAGE / part).rglob("*.py"))
             if compiles(p.read_text())] + (
        [part for part in KERNEL_FREE if part.endswith(".py")
         and compiles((PACKAGE / part).read_text())])
    assert numba == []
    assert free("granular_chain.cli.run") and free("granular_chain.classics.registry")
    assert not free("granular_chain.steppers.events.kernel")


#: What a function may import where it is needed: the optional extras (pyproject's
#: [project.optional-dependencies]; a command that lacks one says which in one line).
OPTIONAL = {"matplotlib", "pyvista", "vtkmodules", "meshio", "dask", "distributed", "xarray",
            "h5netcdf", "pandas", "IPython", "mkdocs"}
#: ... and the heavy modules a function imports on first use, each with why: the command
#: line imports the package at every start, and never needs them for most scenes.
DEFERRED = {"scipy": "scipy.optimize and scipy.integrate take about 0.5 s of every start of "
                     "the command line; only solvers and references use them"}


def _function_imports(tree) -> list:
    """(line, name) of every import inside a function of ``tree`` other than of an
    optional extra (a relative import is named with its leading dots)."""
    found = []
    for func in ast.walk(tree):
        if not isinstance(func, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        for node in ast.walk(func):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = ["." * node.level + (node.module or "")]
            else:
                continue
            found += [(node.lineno, n) for n in names
                      if n.split(".")[0] not in OPTIONAL | set(DEFERRED)]
    return sorted(set(found))


def test_functions_import_only_optional_extras():
    found = [f"{_module(path)}:{line} {name}" for path in sorted(PACKAGE.rglob("*.py"))
             for line, name in _function_imports(ast.parse(path.read_text()))]
    assert found == []


def test_the_command_line_starts_without_the_deferred_modules():
    """What DEFERRED keeps out of every start of ``granular-chain``: no module of scipy's
    optimize or integrate packages is imported with the command line and its parser
    (which imports every subcommand's module)."""
    code = ("import importlib, sys; importlib.import_module('granular_chain.cli.main')"
            ".build_parser(); print(sorted(m for m in sys.modules "
            "if m.startswith(('scipy.optimize', 'scipy.integrate'))))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    assert done.stdout.strip() == "[]"


def test_the_check_finds_an_import_inside_a_function():
    source = ("import os\n"
              "def f():\n"
              "    from ..scene import Scene\n"
              "    import matplotlib.pyplot as plt\n"
              "    class C:\n"
              "        def g(self):\n"
              "            import json\n")
    assert _function_imports(ast.parse(source)) == [(3, "..scene"), (7, "json")]
