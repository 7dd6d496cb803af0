"""Warnings go through ``warnings`` with the package's classes (notebooks and programs can
filter them), progress through the ``granular_chain`` logger; the command line prints
each as one line on stderr. Compiling kernels is announced once per feature set."""

import json
import logging
import os
import re
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numba
import numpy as np
import pytest

import granular_chain as gc
from granular_chain._compile import compile_scope, specialised
from granular_chain.cli import main
from granular_chain.cli.main import show_warning
from granular_chain.notices import COMPILE_NOTICE

ROOT = Path(__file__).resolve().parents[1]
HERTZ = str(ROOT / "scenarios" / "hertz_chain.yaml")
TWO = str(ROOT / "scenarios" / "two_granules.yaml")
# radius 0.5: the pulse's neighbouring overlaps add up to more than a diameter
# (1.18 > 1), so granules 0 and 2 overlap; output.dt = 0.5 is no multiple of
# run.dt = 0.0097, so the step is shortened to 0.5/52
WARNED = ["granules.radius=0.5", "run.t_end=3", "output.every=null", "output.dt=0.5",
          "run.dt=0.0097"]


def test_a_run_warns_through_warnings_with_the_package_classes():
    scene = gc.load_scene(HERTZ, WARNED)
    with pytest.warns(gc.GranularChainWarning) as record:
        result = gc.simulate(scene, progress=False)
    said = [(w.category, str(w.message)) for w in record  # (a cold cache: also a notice)
            if issubclass(w.category, gc.GranularChainWarning)
            and w.category is not gc.CompileNotice]
    assert said == [(gc.TimeStepWarning, result.info["warnings"][0]),
                    (gc.OverlapWarning, result.info["warnings"][1])]
    assert said[0][1].startswith("run.dt shortened from 0.0097 to 0.00961538")
    assert said[1][1].startswith("granules 0 and 2 overlap at t = 1.5 ")
    assert all(Path(w.filename).name == Path(__file__).name for w in record
               if w.category is not gc.CompileNotice)  # said at the caller's line
    with warnings.catch_warnings():  # the class filters them all
        warnings.simplefilter("error")
        warnings.simplefilter("ignore", gc.GranularChainWarning)
        gc.simulate(scene, progress=False)


def test_cli_prints_each_warning_as_one_line_on_stderr(tmp_path, capsys):
    argv = ["run", HERTZ, "--out", str(tmp_path / "r")]
    for item in WARNED:
        argv += ["--set", item]
    assert main(argv) == 0
    captured = capsys.readouterr()
    lines = [s for s in captured.err.splitlines() if "compiling kernels" not in s]
    assert len(lines) == 2
    assert lines[0].startswith("granular-chain: warning: run.dt shortened from 0.0097 ")
    assert lines[1].startswith("granular-chain: warning: granules 0 and 2 overlap at t = 1.5 ")
    assert "warning:" not in captured.out  # the report on stdout does not repeat them
    # summary.json still lists them
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert [w[:20] for w in summary["warnings"]] == [lines[0][25:45], lines[1][25:45]]


def test_show_warning_formats(capsys):
    show_warning(gc.OverlapWarning("a\nb"), gc.OverlapWarning, "f.py", 1)
    show_warning(gc.CompileNotice(f"{COMPILE_NOTICE}: x"), gc.CompileNotice, "f.py", 1)
    show_warning(gc.PlotSkippedWarning("frame.png skipped: y"), gc.PlotSkippedWarning, "f", 1)
    show_warning(DeprecationWarning("old"), DeprecationWarning, "f.py", 1)
    assert capsys.readouterr().err.splitlines() == [
        "granular-chain: warning: a b",
        f"granular-chain: {COMPILE_NOTICE}: x",
        "granular-chain: frame.png skipped: y",
        "granular-chain: warning: DeprecationWarning: old"]


def test_a_feature_set_in_words():
    from granular_chain.model import build_model

    words = build_model(gc.load_scene(ROOT / "scenarios" / "damped_chain.yaml")).features
    assert build_model(gc.load_scene(TWO)).features.in_words() == "linear (n=2), coulomb"
    assert words.in_words() == "hertz (n=5/2), damping viscoelastic"


def _fresh_kernel():
    """A jitted function never compiled before (no cache): calling it compiles."""
    @numba.njit(cache=False)
    def doubled(a):
        return 2.0 * a
    return doubled


def test_compile_is_announced_by_warning_and_logger(caplog):
    """A compile through the package's dispatch: one CompileNotice per scope (a feature
    set), every kernel on the ``granular_chain`` logger; a cached one says nothing."""
    caplog.set_level(logging.INFO, logger="granular_chain")
    a = np.ones(3)
    words = f"verlet stepper: feature words {time.perf_counter_ns()}"  # new to the process
    with pytest.warns(gc.CompileNotice) as record:
        with compile_scope(words):
            specialised(_fresh_kernel(), (a,), ())
            specialised(_fresh_kernel(), (a,), ())
    notices = [str(w.message) for w in record if w.category is gc.CompileNotice]
    assert notices == [f"{COMPILE_NOTICE}: {words}"]
    said = [r.getMessage() for r in caplog.records if r.name == "granular_chain"]
    assert [s.split(" in ")[0] for s in said] == ["compiling doubled", "compiled doubled"] * 2
    with pytest.warns(gc.CompileNotice, match=f"^{re.escape(COMPILE_NOTICE)}: doubled$"):
        specialised(_fresh_kernel(), (a,), ())  # outside a scope: named by its kernel
    kernel = _fresh_kernel()
    with pytest.warns(gc.CompileNotice):
        specialised(kernel, (a,), ())
    caplog.clear()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        specialised(kernel, (a,), ())  # compiled already: no notice, no record
    assert caplog.records == []


def test_a_feature_set_is_announced_once_per_process(caplog):
    """A second scope of the same feature set that compiles again (the run after the
    two-step warm-up compiling a writer's kernel) logs its compile but gives no second
    notice, even where ``catch_warnings`` has reset Python's once-per-place rule (as
    ``prepare_kernels`` does); another feature set is announced."""
    caplog.set_level(logging.INFO, logger="granular_chain")
    a = np.ones(3)
    words = f"verlet stepper: words {time.perf_counter_ns()}"  # new to this process
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        for _ in range(2):
            with compile_scope(words):
                specialised(_fresh_kernel(), (a,), ())
        with compile_scope(words + ", coulomb"):
            specialised(_fresh_kernel(), (a,), ())
    notices = [str(w.message) for w in seen if w.category is gc.CompileNotice]
    assert notices == [f"{COMPILE_NOTICE}: {words}", f"{COMPILE_NOTICE}: {words}, coulomb"]
    said = [r.getMessage() for r in caplog.records if r.name == "granular_chain"]
    assert [s.split(" in ")[0] for s in said] == ["compiling doubled", "compiled doubled"] * 3


@pytest.mark.slow
def test_first_run_of_a_feature_set_announces_its_compilation(tmp_path):
    """A real first run (an empty NUMBA_CACHE_DIR, two granules on Verlet): one
    CompileNotice naming the feature set, the logger's records of the kernels; the
    same scene again compiles nothing and says nothing."""
    code = """
import json, logging, sys, warnings
import granular_chain as gc
records = []
class Keep(logging.Handler):
    def emit(self, record):
        records.append(record.getMessage())
logging.getLogger("granular_chain").addHandler(Keep())
logging.getLogger("granular_chain").setLevel(logging.INFO)
scene = gc.load_scene(sys.argv[1], ["run.t_end=1"])
with warnings.catch_warnings(record=True) as first:
    warnings.simplefilter("always")
    gc.simulate(scene, progress=False)
logged = list(records)
with warnings.catch_warnings(record=True) as second:
    warnings.simplefilter("always")
    gc.simulate(scene, progress=False)
print(json.dumps({"first": [[w.category.__name__, str(w.message)] for w in first],
                  "second": [str(w.message) for w in second], "logged": logged,
                  "after": records[len(logged):]}))
"""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    done = subprocess.run([sys.executable, "-c", code, str(ROOT / "scenarios" /
                                                            "two_granules.yaml")],
                          capture_output=True, text=True, cwd=ROOT, env=env)
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout.strip().splitlines()[-1])
    notices = [m for c, m in out["first"] if c == "CompileNotice"]
    assert notices == [f"{COMPILE_NOTICE}: verlet stepper: linear (n=2), coulomb"]
    assert any(s.startswith("compiling ") for s in out["logged"])
    assert any(re.fullmatch(r"compiled \w+ in \d+\.\d s", s) for s in out["logged"])
    assert out["second"] == [] and out["after"] == []
    assert any(tmp_path.rglob("*.nbi"))  # it was compiled into the fresh cache
