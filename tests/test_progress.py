"""The run's progress bar (granular_chain.progress): shown by ``granular-chain run``
on a terminal and not when piped or with --quiet, for both steppers; in the API
with ``progress=True``, never by default outside a notebook."""

import fcntl
import io
import os
import pty
import select
import struct
import subprocess
import sys
import termios
import time
import types

import pytest
import yaml
from conftest import HUNG_AFTER, finish

import granular_chain as gc
from granular_chain import progress as gp
from granular_chain.scene import Scene

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BAR = b"simulating:"


def _chain(stepper: str) -> dict:
    return {"name": f"bar_{stepper}", "granules": {"count": 10, "velocity": {0: 1.0}},
            "contacts": {"exponent": 2.5}, "run": {"stepper": stepper, "t_end": 20.0},
            "output": {"dt": 0.5}}


def _write_scene(tmp_path, stepper: str):
    path = tmp_path / f"{stepper}.yaml"
    path.write_text(yaml.safe_dump(_chain(stepper)))
    return path


def _command(scene, out, *extra):
    return [sys.executable, "-m", "granular_chain", "run", str(scene), "--out", str(out),
            "--no-trajectory", "--no-csv", "--no-plots", "--no-vtk", *extra]


def _env():
    return {**os.environ, "PYTHONPATH": ROOT, "COLUMNS": "100"}


def _on_a_terminal(cmd) -> tuple:
    """Run ``cmd`` with stdout and stderr on a pseudo-terminal of 100 x 30 (a pty
    without a size makes tqdm draw nothing); returns (exit status, all output)."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 30, 100, 0, 0))
    proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=slave, stderr=slave,
                            env=_env(), cwd=ROOT)
    os.close(slave)
    chunks = []
    deadline = time.monotonic() + HUNG_AFTER
    while time.monotonic() < deadline:
        # (a read with nothing to read blocks: look first, and stop looking once the
        # child has ended and its last output is read)
        if not select.select([master], [], [], 0.5)[0]:
            if proc.poll() is not None:
                break
            continue
        try:
            data = os.read(master, 65536)
        except OSError:  # EIO: the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    return finish(proc, f"{cmd} on a terminal", seconds=60.0)[0], b"".join(chunks)


@pytest.mark.parametrize("stepper", ["verlet", "event"])
def test_run_shows_the_bar_on_a_terminal_only(tmp_path, stepper):
    scene = _write_scene(tmp_path, stepper)
    code, shown = _on_a_terminal(_command(scene, tmp_path / "tty"))
    assert code == 0, shown.decode(errors="replace")
    assert BAR in shown and b"t = " in shown and b"/20 [" in shown
    # the thermo lines are all there besides the bar (the last one at t_end)
    assert b"step" in shown and b"reached t_end = 20" in shown

    code, quiet = _on_a_terminal(_command(scene, tmp_path / "quiet", "--quiet"))
    assert code == 0 and BAR not in quiet

    piped = subprocess.run(_command(scene, tmp_path / "piped"), capture_output=True,
                           env=_env(), cwd=ROOT)
    assert piped.returncode == 0, piped.stderr
    assert BAR not in piped.stderr and BAR not in piped.stdout
    assert b"reached t_end = 20" in piped.stdout  # (the report itself is still there)


@pytest.mark.parametrize("stepper", ["verlet", "event"])
def test_api_progress_true_draws_the_bar_on_stderr(capsys, stepper):
    scene = Scene.model_validate(_chain(stepper))
    r = gc.simulate(scene, progress=True)
    assert r.success
    err = capsys.readouterr().err
    assert "simulating:" in err and "/20 [" in err  # simulated time out of t_end

    gc.simulate(scene)  # default None: no bar outside a notebook
    assert "simulating:" not in capsys.readouterr().err
    gc.simulate(scene, progress=False)
    assert "simulating:" not in capsys.readouterr().err


def test_the_bar_measures_simulated_time(monkeypatch):
    out = io.StringIO()
    monkeypatch.setattr(sys, "stderr", out)
    bar = gp.ProgressBar(t_end=8.0, scale=2.5)  # driver time 8 is scene time 20
    bar.start(2.0)
    assert bar.bar.n == pytest.approx(5.0) and bar.bar.total == pytest.approx(20.0)
    bar.update(4.0)
    assert bar.bar.n == pytest.approx(10.0)
    bar.update(3.0)  # never backwards
    bar.update(9.0)  # clipped at t_end
    assert bar.bar.n == pytest.approx(20.0)
    bar.close()
    assert "t = 5/20" in out.getvalue()


def test_none_means_a_notebook_only(monkeypatch):
    assert gp.progress_bar(None, 1.0) is None
    assert gp.progress_bar(False, 1.0) is None
    assert isinstance(gp.progress_bar(True, 1.0), gp.ProgressBar)

    class ZMQInteractiveShell:  # IPython's kernel shell, by its class name
        pass

    fake = types.SimpleNamespace(get_ipython=lambda: ZMQInteractiveShell())
    monkeypatch.setitem(sys.modules, "IPython", fake)
    assert gp.in_notebook()
    bar = gp.progress_bar(None, 1.0)
    assert isinstance(bar, gp.ProgressBar) and bar.notebook
    assert gp.progress_bar(False, 1.0) is None


def test_a_printed_line_clears_the_bar_first(monkeypatch):
    """echo() wipes a bar drawn on the terminal before the line is printed."""
    err, out = io.StringIO(), io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    monkeypatch.setattr(sys, "stdout", out)
    bar = gp.ProgressBar(t_end=10.0)
    bar.start(0.0)
    drawn = len(err.getvalue())
    gp.echo(lambda: print("a thermo line"))
    after = err.getvalue()[drawn:]
    bar.close()
    assert out.getvalue() == "a thermo line\n"
    assert after.startswith("\r") and "simulating:" in after  # cleared, then drawn again
