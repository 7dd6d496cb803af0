"""Hangs, tracebacks and silent slips of scene input and of the command line.

Each case runs the command (in-process through ``granular_chain.cli.main``, or as a
subprocess where a pipe or a signal is involved) and checks its exit status, its one
line on stderr and the files on disk.
"""

import errno
import json
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import finish, patch_everywhere, wait_until_stepping

from granular_chain.cli import main

TINY = """\
name: tiny
granules:
  count: 2
  velocity: [1.0, 0.0]
run:
  t_end: 1.0
"""

# a Verlet run of minutes: the signal always lands while it steps
LONG = """\
name: long
granules:
  count: 2
  velocity: [1.0, 0.0]
run:
  t_end: 1.0e+7
  dt: 0.01
output:
  every: 1000
"""


def _files(folder: Path) -> list:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))


def _scene(folder: Path, text: str, name: str = "s.yaml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("granular-chain: "), err
    assert "Traceback" not in err
    return lines[0]


def _refused(capsys, folder: Path, args: list, *words: str) -> str:
    """``main(args)`` exits 2 with one stderr line holding ``words``; nothing written."""
    before = _files(folder)
    code = main(args)
    line = _one_line(capsys.readouterr().err)
    assert code == 2, line
    for w in words:
        assert w in line, line
    assert _files(folder) == before
    return line


# --- refused scene input: (YAML text replacing TINY's, the words of the message) ---------

BIG = "1" + "0" * 400
REFUSED = {
    "output.dt forcing 1e300 steps": (
        TINY + "output:\n  dt: 1.0e-300\n",
        ("s.yaml: output.dt: 1e-300 forces a step of 1e-300", "1e+300 steps",
         "run.max_steps = 2000000000")),
    "sexagesimal 1:30": (TINY.replace("t_end: 1.0", "t_end: 1:30"),
                         ("run.t_end: must be a number, not the string '1:30'",)),
    "underscores 1_0": (TINY.replace("count: 2", "count: 1_0"),
                        ("granules.count: must be a whole number", "the string '1_0'")),
    "binary 0b10": (TINY.replace("count: 2", "count: 0b10"),
                    ("granules.count: must be a whole number", "the string '0b10'")),
    "velocity index twice": (
        TINY.replace("velocity: [1.0, 0.0]", "velocity: {0: 1.0, \"0\": 5.0}"),
        ("granules.velocity: granule 0 is given twice (as 0 and '0')",)),
    "thermo true": (TINY + "output:\n  thermo: true\n",
                    ("output.thermo: must be a whole number", "the boolean true")),
    "thermo '500'": (TINY + "output:\n  thermo: \"500\"\n",
                     ("output.thermo: must be a whole number", "the string '500'")),
    "thermo 500.0": (TINY + "output:\n  thermo: 500.0\n",
                     ("output.thermo: must be a whole number", "the decimal number 500.0")),
    "distribution string": (
        TINY.replace("count: 2\n", "count: 2\n  mass: {distribution: lognormal, "
                     "median: \"1\", sigma: 0.1, seed: 7}\n"),
        ("granules.mass.median: Input should be a valid number (got '1')",)),
    "distribution boolean": (
        TINY.replace("count: 2\n", "count: 2\n  mass: {distribution: uniform, "
                     "low: true, high: 2.0, seed: 7}\n"),
        ("granules.mass.low: Input should be a valid number (got True)",)),
    "distribution seed 7.0": (
        TINY.replace("count: 2\n", "count: 2\n  mass: {distribution: normal, "
                     "mean: 1.0, std: 0.1, seed: 7.0}\n"),
        ("granules.mass.seed: Input should be a valid integer (got 7.0)",)),
    "count 10^400": (TINY.replace("count: 2", f"count: {BIG}"),
                     ("granules.count: is a whole number of 401 digits, above 2^53",)),
    "max_events 10^30": (
        TINY.replace("t_end: 1.0", "t_end: 1.0\n  stepper: event\n  max_events: 1" + "0" * 30),
        ("run.max_events: is a whole number of 31 digits, above 2^53",)),
    "max_events 1e30": (
        TINY.replace("t_end: 1.0", "t_end: 1.0\n  stepper: event\n  max_events: 1e30"),
        ("run.max_events: must be a whole number",)),
}


@pytest.mark.parametrize("command", ["validate", "run"])
@pytest.mark.parametrize("case", sorted(REFUSED))
def test_refused_in_one_line_nothing_written(tmp_path, capsys, monkeypatch, command, case):
    text, words = REFUSED[case]
    scene = _scene(tmp_path, text)
    monkeypatch.chdir(tmp_path)  # run's default folder outputs/tiny must not appear
    _refused(capsys, tmp_path, [command, str(scene)], *words)


def test_yaml_12_leading_zero_is_decimal(tmp_path, capsys):
    """``count: 010`` is ten granules (YAML 1.2), not octal 8 (YAML 1.1)."""
    scene = _scene(tmp_path, TINY.replace("count: 2", "count: 010").replace(
        "velocity: [1.0, 0.0]", "velocity: {0: 1.0}"))
    assert main(["validate", str(scene)]) == 0
    assert json.loads(capsys.readouterr().out)["granules"] == 10


def test_yaml_12_numbers_in_set_overrides(tmp_path, capsys):
    """--set values follow the scene file's rules."""
    scene = _scene(tmp_path, TINY)
    _refused(capsys, tmp_path, ["validate", str(scene), "--set", "run.t_end=1:30"],
             "run.t_end: must be a number, not the string '1:30'")
    assert main(["validate", str(scene), "--set", "output.every=010"]) == 0
    capsys.readouterr()


def test_boundaries_refuses_a_grid_beyond_memory_before_any_collision(tmp_path, capsys,
                                                                       monkeypatch):
    from granular_chain.two_granules import boundaries

    def no_collision(*args, **kwargs):
        raise AssertionError("a collision ran before --grid was checked")

    monkeypatch.setattr(boundaries, "collide", no_collision)
    monkeypatch.chdir(tmp_path)
    _refused(capsys, tmp_path, ["boundaries", "--param", "eta2", "--range", "0", "1",
                                "--grid", "100000000"],
             "--grid 100000000: the scan keeps every point", "1.6 TB", "use at most --grid")


def test_sweep_whose_every_point_fails_exits_1(tmp_path, capsys):
    scene = _scene(tmp_path, TINY)
    out = tmp_path / "sweep"
    code = main(["sweep", str(scene), "--grid", "granules.mass=-2:-1:3", "--serial",
                 "--quiet", "--out", str(out)])
    line = _one_line(capsys.readouterr().err)
    assert code == 1, line
    assert "every point of the sweep failed (3 of 3" in line and "granules.mass" in line
    rows = (out / "results.csv").read_text().splitlines()
    assert len(rows) == 4 and all(",error," in r for r in rows[1:])


# --- failures during a run ------------------------------------------------------------


def test_quiet_run_still_says_why_it_failed(tmp_path, capsys):
    scene = _scene(tmp_path, TINY.replace("t_end: 1.0", "t_end: 5.0\n"
                                          "  energy_tolerance: 1.0e-300"))
    code = main(["run", str(scene), "--quiet", "--out", str(tmp_path / "out")])
    line = _one_line(capsys.readouterr().err)
    assert code == 1
    assert line.startswith("granular-chain: inaccurate: ") and "run.energy_tolerance" in line
    assert (tmp_path / "out" / "summary.json").is_file()


def test_full_disk_is_one_line_and_leaves_nothing(tmp_path, capsys, monkeypatch):
    def full(result, folder, scene):
        raise OSError(errno.ENOSPC, "No space left on device", str(folder / "summary.json"))

    patch_everywhere(monkeypatch, "writers.summary", "write_summary", full)
    scene = _scene(tmp_path, TINY)
    line = _refused(capsys, tmp_path, ["run", str(scene), "--quiet", "--out",
                                       str(tmp_path / "deep" / "out")],
                    "No space left on device", "free some space", "nothing written")
    assert "summary.json" in line


def test_memory_error_is_one_line_and_leaves_nothing(tmp_path, capsys, monkeypatch):
    def no_memory(*args, **kwargs):
        raise MemoryError

    patch_everywhere(monkeypatch, "simulate", "simulate", no_memory)
    scene = _scene(tmp_path, TINY)
    _refused(capsys, tmp_path, ["run", str(scene), "--quiet", "--out", str(tmp_path / "out")],
             "out of memory", "ulimit -v", "nothing written")


# --- subprocesses: closed pipes and SIGHUP ---------------------------------------------

CLI = [sys.executable, "-m", "granular_chain.cli"]


@pytest.mark.parametrize("command", ["validate", "run"])
def test_output_to_a_closed_pipe_is_dropped(tmp_path, command):
    """``granular-chain run S | head -1``: the reader has gone; the run goes on, is
    published and exits as the run (0); no BrokenPipeError."""
    scene = _scene(tmp_path, TINY)
    out = tmp_path / "out"
    args = [str(scene)] + (["--out", str(out)] if command == "run" else [])
    proc = subprocess.Popen(CLI + [command, *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    if command == "run":
        proc.stdout.readline()  # as head -1: one line, then the reader goes
    proc.stdout.close()  # (validate: gone before the report, printed after the imports)
    code, _, err = finish(proc, f"{command} writing to a closed pipe")
    assert code == 0, err
    assert "Traceback" not in err and "BrokenPipe" not in err, err
    if command == "run":
        assert json.loads((out / "run.json").read_text())["complete"] is True
        assert (out / "summary.json").is_file()


def _catches_sighup(pid: int) -> bool:
    status = Path(f"/proc/{pid}/status").read_text()
    caught = next(line for line in status.splitlines() if line.startswith("SigCgt:"))
    return bool(int(caught.split()[1], 16) & (1 << (signal.SIGHUP - 1)))


@pytest.fixture(scope="module")
def hung_up_run(tmp_path_factory):
    """A run stopped by SIGHUP (a closed terminal): its folder, scene and stderr."""
    if not Path("/proc/self/status").exists():
        pytest.skip("reads the signal handlers from /proc")
    folder = tmp_path_factory.mktemp("hup")
    scene = _scene(folder, LONG)
    out = folder / "out"
    proc = subprocess.Popen(CLI + ["run", str(scene), "--quiet", "--out", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            cwd=folder)
    try:
        wait_until_stepping(proc, folder, "out")
        assert _catches_sighup(proc.pid)
        proc.send_signal(signal.SIGHUP)
        _, _, err = finish(proc, "run after SIGHUP")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return out, scene, proc.returncode, err


def test_sighup_stops_a_run_as_sigterm_does(hung_up_run):
    out, scene, code, err = hung_up_run
    assert code == 129, err
    assert "Traceback" not in err and "interrupted by SIGHUP" in err
    marker = json.loads((out / "run.json").read_text())
    assert marker["complete"] is False and "interrupted by SIGHUP" in marker["reason"]
    assert (out / "checkpoint.npz").is_file()
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"


@pytest.mark.parametrize("damage, words", [
    ("checkpoint.npz", ("checkpoint.npz cannot be read, it is truncated or corrupted",)),
    ("trajectory.h5", ("its files cannot be continued from the checkpoint",
                       "truncated file")),
])
def test_restart_from_a_damaged_file_is_refused(hung_up_run, tmp_path, capsys, monkeypatch,
                                                damage, words):
    out, scene, _, _ = hung_up_run
    copy = tmp_path / "run"
    shutil.copytree(out, copy)
    path = copy / damage
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2])  # a copy cut short (a full disk, a crash)
    monkeypatch.chdir(tmp_path)
    _refused(capsys, tmp_path, ["run", str(scene), "--restart", str(copy), "--quiet"],
             f"--restart {copy}", *words)
