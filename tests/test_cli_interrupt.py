"""An interrupted run (SIGINT, SIGTERM) leaves nothing that looks complete.

``granular-chain run`` is started in a subprocess on a scene that would step for
minutes; once it is stepping it gets the signal. The --out folder must not exist
and the hidden ``.NAME.partial-*`` folder it was writing into must be gone.
"""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CHAIN = ROOT / "scenarios" / "chain_friction.yaml"

# 5000 granules to t = 1e6: hours of stepping, so the signal always lands mid-run.
LONG = ["--set", "granules.count=5000", "--set", "run.t_end=1e6", "--set", "output.dt=1000"]


@pytest.fixture(scope="module", autouse=True)
def _compiled_kernel(tmp_path_factory):
    """Compile (or load) the scene's kernel first: a signal that lands while numba
    compiles is only handled once LLVM returns, which on a cold cache can take
    longer than the test waits."""
    out = tmp_path_factory.mktemp("warm") / "warm"
    subprocess.run([sys.executable, "-m", "granular_chain.cli", "run", str(CHAIN), "--out",
                    str(out), "--quiet", "--set", "granules.count=50", "--set", "run.t_end=1",
                    "--vtk", "--csv"], capture_output=True, text=True, check=True)


def _start(out: Path, *extra):
    return subprocess.Popen(
        [sys.executable, "-m", "granular_chain.cli", "run", str(CHAIN), "--out", str(out),
         "--quiet", *LONG, *extra],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=out.parent)


def _wait_until_stepping(proc, parent: Path, name: str, timeout=30.0):
    """Wait for the partial folder, then long enough for compilation to be over."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            pytest.fail(f"run ended early: {proc.returncode} {proc.stderr.read()}")
        if any(p.name.startswith(f".{name}.partial-") for p in parent.iterdir()):
            time.sleep(1.5)  # the kernel is cached on disk: by now it is stepping
            return
        time.sleep(0.05)
    pytest.fail("the run never created its partial output folder")


@pytest.mark.parametrize("sig, code, word", [(signal.SIGINT, 130, "interrupted"),
                                             (signal.SIGTERM, 143, "terminated")])
def test_signal_leaves_nothing_that_looks_complete(tmp_path, sig, code, word):
    out = tmp_path / "long_run"
    proc = _start(out, "--vtk", "--csv")
    try:
        _wait_until_stepping(proc, tmp_path, out.name)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == code, err
    assert f"granular-chain: {word}; nothing written to {out}" in err
    assert "Traceback" not in err
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []  # the .partial folder is cleaned up too


def test_interrupted_rerun_keeps_the_previous_output(tmp_path):
    out = tmp_path / "kept"
    done = subprocess.run(
        [sys.executable, "-m", "granular_chain.cli", "run", str(CHAIN), "--out", str(out),
         "--quiet", "--set", "run.t_end=2"], capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    before = (out / "summary.json").read_text()
    proc = _start(out)
    try:
        _wait_until_stepping(proc, tmp_path, out.name)
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130
    assert (out / "summary.json").read_text() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept"]
