"""Where a cold test suite spends its time compiling: numba's compile events, per test.

As a pytest plugin it logs every ``numba:compile`` event of the test processes (the
function, its depth among nested compiles, the seconds, the test running) to one
JSON-lines file per process in ``$SUITE_COMPILE_LOG``; run from the command line it
sums the top-level compiles per function and lists the specialisations of the
costliest ones with the test that compiled each. Empty numba's cache of the
installed package first, or every kernel loads from it and nothing is logged::

    export SUITE_COMPILE_LOG=/tmp/compile-log
    PYTHONPATH=benchmarks pytest -p suite_compile_log
    python benchmarks/suite_compile_log.py /tmp/compile-log

Every Python process of the suite, its children included (the command-line and signal
tests, the tutorials of the docs build, dask's workers), is logged with
``benchmarks/compile_log_site`` on ``PYTHONPATH``: its ``sitecustomize`` registers the
listener as numba's event module is imported; a child's compiles are given the test that
started it (``PYTEST_CURRENT_TEST``) or its command line::

    PYTHONPATH=benchmarks:benchmarks/compile_log_site pytest
"""

import collections
import json
import os
import re
import sys
import time
from pathlib import Path

_TEST = [None]
_REGISTERED = []


def _listener():
    from numba.core import event

    class CompileLog(event.Listener):
        def __init__(self, folder: Path):
            self.path = folder / f"compile-{os.getpid()}.jsonl"
            self.started = []

        def on_start(self, ev):
            self.started.append(time.process_time())  # CPU s: the suite is CPU-bound

        def on_end(self, ev):
            seconds = time.process_time() - self.started.pop()
            fn = getattr(ev.data["dispatcher"], "py_func", None)
            name = f"{fn.__module__}.{fn.__qualname__}" if fn else str(ev.data["dispatcher"])
            codes = re.findall(r"Literal\[int\]\((-?\d+)\)", str(ev.data.get("args")))
            with self.path.open("a") as f:
                f.write(json.dumps({"test": _TEST[0] or _caller(), "function": name,
                                    "seconds": seconds,
                                    "depth": len(self.started), "codes": codes}) + "\n")

    if _REGISTERED:  # (the plugin in a process that sitecustomize already logs)
        return
    _REGISTERED.append(True)
    folder = Path(os.environ["SUITE_COMPILE_LOG"])
    folder.mkdir(parents=True, exist_ok=True)
    event.register("numba:compile", CompileLog(folder))


def _caller() -> str:
    """What a child process of the suite runs for: the test that started it, and its
    command line."""
    test = os.environ.get("PYTEST_CURRENT_TEST", "").split(" ")[0]
    return f"{test} [{' '.join(getattr(sys, 'orig_argv', sys.argv)[1:4])[:80]}]"


def install_on_numba_import() -> None:
    """Register the listener as soon as numba's event module is imported (from a
    ``sitecustomize``: nothing of numba is imported before it is needed)."""
    import importlib.abc
    import importlib.machinery

    class Finder(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path, target=None):
            if name != "numba.core.event":
                return None
            sys.meta_path.remove(self)
            spec = importlib.machinery.PathFinder.find_spec(name, path)
            run_module = spec.loader.exec_module

            def exec_module(module):
                run_module(module)
                _listener()
            spec.loader.exec_module = exec_module
            return spec

    if os.environ.get("SUITE_COMPILE_LOG"):
        sys.meta_path.insert(0, Finder())


def pytest_configure(config):
    if os.environ.get("SUITE_COMPILE_LOG"):
        _listener()


def pytest_runtest_setup(item):
    _TEST[0] = item.nodeid


def summary(folder: Path, functions: int = 12, detail: int = 3) -> None:
    """Print the top-level compile time per function, and each compile of the costliest."""
    rows = [json.loads(line) for path in sorted(folder.glob("compile-*.jsonl"))
            for line in path.read_text().splitlines()]
    top = [r for r in rows if r["depth"] == 0]
    print(f"{len(top)} top-level compiles, {sum(r['seconds'] for r in top):.1f} s in all")
    per = collections.defaultdict(list)
    for r in top:
        per[r["function"]].append(r)
    ranked = sorted(per.items(), key=lambda kv: -sum(r["seconds"] for r in kv[1]))
    for name, runs in ranked[:functions]:
        print(f"{sum(r['seconds'] for r in runs):8.1f} s {len(runs):4d} x  {name}")
    for name, runs in ranked[:detail]:
        print(f"\n{name}:")
        for r in sorted(runs, key=lambda r: -r["seconds"]):
            print(f"  {r['seconds']:6.1f} s  codes {','.join(r['codes'])}  {r['test']}")


if __name__ == "__main__":
    summary(Path(sys.argv[1]))
