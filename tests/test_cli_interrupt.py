"""An interrupted run (SIGINT, SIGTERM) leaves nothing that looks complete.

``granular-chain run`` is started in a subprocess on a scene that would step for
minutes; once it is stepping it gets the signal. What was computed is in the
--out folder, marked incomplete in run.json; the hidden ``.NAME.partial-*``
folder it was writing into is gone; an earlier run in --out is kept.
"""

import json
import signal
import subprocess
import sys
from pathlib import Path
from xml.etree import ElementTree

import pytest

from conftest import wait_until_stepping

ROOT = Path(__file__).resolve().parents[1]
CHAIN = ROOT / "scenarios" / "chain_friction.yaml"

# 5000 granules to t = 1e6: hours of stepping, so the signal always lands mid-run.
LONG = ["--set", "granules.count=5000", "--set", "run.t_end=1e6", "--set", "output.dt=100"]


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


@pytest.mark.parametrize("sig, code, name", [(signal.SIGINT, 130, "SIGINT"),
                                             (signal.SIGTERM, 143, "SIGTERM")])
def test_signal_leaves_a_run_marked_incomplete(tmp_path, sig, code, name):
    out = tmp_path / "long_run"
    proc = _start(out, "--vtk", "--csv")
    try:
        wait_until_stepping(proc, tmp_path, out.name)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == code, err
    assert "Traceback" not in err and "marked incomplete" in err
    marker = json.loads((out / "run.json").read_text())
    assert marker["complete"] is False and f"interrupted by {name}" in marker["reason"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["success"] is False
    # the VTK series and the tables were written as the run went: whole frames, a valid index
    pvd = ElementTree.parse(out / "run.pvd").getroot()
    frames = pvd.findall("./Collection/DataSet")
    assert len(frames) >= 1 and all((out / f.get("file")).is_file() for f in frames)
    energy = (out / "energy.csv").read_text().splitlines()
    assert len(energy) >= 2 and all(len(row.split(",")) == 10 for row in energy)
    assert sorted(p.name for p in tmp_path.iterdir()) == [out.name]  # no .partial folder


def test_interrupted_rerun_keeps_the_previous_output(tmp_path):
    out = tmp_path / "kept"
    done = subprocess.run(
        [sys.executable, "-m", "granular_chain.cli", "run", str(CHAIN), "--out", str(out),
         "--quiet", "--set", "run.t_end=2"], capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    before = (out / "summary.json").read_text()
    proc = _start(out, "--overwrite")
    try:
        wait_until_stepping(proc, tmp_path, out.name)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130
    assert "--restart" in err and "earlier run" in err
    assert (out / "summary.json").read_text() == before
    assert json.loads((out / "run.json").read_text())["complete"] is True
    # the interrupted run is kept aside, marked incomplete, to be continued
    aside = [p for p in tmp_path.iterdir() if p.name != "kept"]
    assert len(aside) == 1 and aside[0].name.startswith(".kept.partial-")
    marker = json.loads((aside[0] / "run.json").read_text())
    assert marker["complete"] is False and (aside[0] / "checkpoint.npz").is_file()
