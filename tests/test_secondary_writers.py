"""Every command that writes files follows ``run``'s rule, through one mechanism
(:func:`granular_chain.rundir.claim_folder` / :func:`~granular_chain.rundir.claim_file`):
a new folder, created and marked as the command's, or a folder the same command
wrote holding nothing else; never a file the user or another command wrote,
never a path inside another run's folder, never through a link.

Each refusal checks the exit status, the one line on stderr, and that every
file below the working folder is unchanged byte for byte. The work a command
would do (drawing, tracing, reading the run, simulating) is replaced by a
function that fails the test, so each refusal is shown to come before any work.
"""

import hashlib
import json
import os
import shutil
import stat
from pathlib import Path

import pytest

from conftest import patch_everywhere
from granular_chain.cli import main
from granular_chain.rundir import MARKER, read_marker

SCENE = """\
name: tiny
granules: {count: 2, velocity: [1.0, 0.0]}
run: {t_end: 0.5}
"""

#: the same scene, run in 500 steps with a checkpoint every 100 (for --restart)
CHECKPOINTED = SCENE.replace("run: {t_end: 0.5}", "run: {t_end: 0.5, dt: 0.001}\n"
                             "output: {checkpoint_every: 100}")

SWEEP = ["sweep", "scene.yaml", "--grid", "run.t_end=0.1:0.2:2", "--serial", "--quiet"]
PLANE = ["boundaries", "--param", "eta1", "--range", "0", "1", "--y-param", "eta2",
         "--y-range", "0", "1", "--grid", "4"]

#: the folder outputs of every secondary writer (``--out`` goes last)
FOLDER_COMMANDS = {
    "figures": ["figures", "--only", "energy"],
    "boundaries": PLANE,
    "plot": ["plot", "r1", "--no-render"],
    "export": ["export", "r1", "--format", "vtu"],
    "sweep": SWEEP,
    "classics": ["classics", "newtons_cradle"],
}


def snapshot(folder: Path) -> dict:
    """Every entry below ``folder`` (hidden ones too): a file's digest, a link's target."""
    out = {}
    for root, dirs, files in os.walk(folder):
        for name in files + dirs:
            p = Path(root) / name
            rel = p.relative_to(folder).as_posix()
            mode = p.lstat().st_mode
            if stat.S_ISLNK(mode):
                out[rel] = "link to " + os.readlink(p)
            elif stat.S_ISDIR(mode):
                out[rel + "/"] = "dir"
            elif stat.S_ISREG(mode):
                out[rel] = hashlib.sha1(p.read_bytes()).hexdigest()
            else:
                out[rel] = "special"
    return out


def refused(capsys, argv, *needles) -> str:
    """Run ``granular-chain argv``: exit 2, one line naming ``needles``, nothing changed."""
    capsys.readouterr()
    before = snapshot(Path.cwd())
    code = main(argv)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1 and lines[0].startswith("granular-chain: "), err
    for needle in needles:
        assert needle in lines[0], lines[0]
    assert snapshot(Path.cwd()) == before
    return lines[0]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Two finished runs of the tiny scene, r1 and r2 (made once, copied per test)."""
    base = tmp_path_factory.mktemp("runs")
    (base / "scene.yaml").write_text(SCENE)
    cwd = os.getcwd()
    os.chdir(base)
    try:
        for name in ("r1", "r2"):
            assert main(["run", "scene.yaml", "--out", name, "--quiet"]) == 0
    finally:
        os.chdir(cwd)
    return base


@pytest.fixture
def work(runs, tmp_path, monkeypatch):
    """The working folder: runs r1 and r2, the scene, and a user's folder ``mine``
    holding files named as the commands' outputs, a link to it, a user's file."""
    for name in ("r1", "r2"):
        shutil.copytree(runs / name, tmp_path / name)
    (tmp_path / "scene.yaml").write_text(SCENE)
    mine = tmp_path / "mine"
    mine.mkdir()
    for name in ("paper_energy.png", "boundaries_curves.csv", "energy.png", "results.csv",
                 "frame_000000.vtu", "classics_newtons_cradle.csv"):
        (mine / name).write_text(f"the user's {name}")
    (tmp_path / "linked").symlink_to("mine")
    (tmp_path / "notes.txt").write_text("the user's notes")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _no_work(*args, **kwargs):
    raise AssertionError("the command started its work before deciding on its output")


@pytest.fixture
def forbid(monkeypatch):
    """Every command's work fails the test: a refusal must come first."""
    from importlib import import_module

    for module, name in (("paper.figures", "make_figures"),
                         ("two_granules.curves", "trace_curves"),
                         ("readback", "read_trajectory"), ("readback", "read_run"),
                         ("simulate", "simulate"), ("sweep.execute", "run_batch")):
        patch_everywhere(monkeypatch, module, name, _no_work)
    monkeypatch.setattr(import_module("granular_chain.classics.experiment").Experiment, "run",
                        _no_work)


# ----------------------------------------------------------------------------
# the destructive cases of the issue, one test each
# ----------------------------------------------------------------------------
def test_diagnose_out_refuses_the_runs_own_trajectory(work, capsys, forbid):
    refused(capsys, ["diagnose", "r1", "--out", "r1/trajectory.h5"],
            "--out r1/trajectory.h5", "was written by granular-chain run, not diagnose")


def test_diagnose_out_refuses_another_runs_summary(work, capsys, forbid):
    refused(capsys, ["diagnose", "r1", "--out", "r2/summary.json"],
            "--out r2/summary.json", "r2, a folder of granular-chain run")


def test_figures_out_refuses_a_user_folder(work, capsys, forbid):
    refused(capsys, ["figures", "--out", "mine", "--only", "energy"],
            "--out mine", "the engine did not write")


def test_figures_out_refuses_a_linked_user_folder(work, capsys, forbid):
    refused(capsys, ["figures", "--out", "linked", "--only", "energy"],
            "--out linked", "symbolic link (to mine)")


def test_figures_out_through_a_linked_folder_is_judged_where_it_points(work, capsys, forbid):
    (work / "via").symlink_to("r1")  # via/new is r1/new: inside a run's folder
    refused(capsys, ["figures", "--out", "via/new", "--only", "energy"],
            "--out via/new", "r1, a folder of granular-chain run")


def test_boundaries_plane_out_refuses_a_user_folder(work, capsys, forbid):
    refused(capsys, [*PLANE, "--out", "mine"], "--out mine", "the engine did not write")


def test_run_out_refuses_a_folder_inside_another_run(work, capsys, forbid):
    refused(capsys, ["run", "scene.yaml", "--quiet", "--out", "r1/sub"],
            "--out r1/sub", "r1, a folder of granular-chain run")


@pytest.mark.parametrize("argv", [
    ["run", "scene.yaml", "--quiet"], ["diagnose", "r1"], *FOLDER_COMMANDS.values()],
    ids=["run", "diagnose", *FOLDER_COMMANDS])
def test_empty_out_is_refused(work, capsys, forbid, argv):
    refused(capsys, [*argv, "--out", ""], "--out: is empty")


# ----------------------------------------------------------------------------
# --restart of a killed run's hidden partial folder
# ----------------------------------------------------------------------------
class _Killed(Exception):
    pass


@pytest.fixture
def killed(work, monkeypatch):
    """The hidden partial folder a run killed after its last checkpoint leaves
    (its writers done, its marker naming a process that is gone)."""
    import granular_chain.cli.run as cli
    from granular_chain.rundir import RunFolder

    def kill(*args, **kwargs):
        raise _Killed()

    (work / "k.yaml").write_text(CHECKPOINTED)
    with monkeypatch.context() as patch:
        patch.setattr(cli, "_write_outputs", kill)
        patch.setattr(RunFolder, "__exit__", lambda self, *exc: None)  # as SIGKILL: no cleanup
        with pytest.raises(_Killed):
            main(["run", "k.yaml", "--out", "k", "--quiet"])
    [partial] = work.glob(".k.partial-*")
    marker = json.loads((partial / MARKER).read_text())
    marker["pid"] = 2 ** 22 + 12345  # above any pid_max: no such process
    (partial / MARKER).write_text(json.dumps(marker))
    return partial


def test_restart_continues_a_partial_folder_holding_only_its_files(killed, work):
    assert {"checkpoint.npz", "thermo.csv", "trajectory.h5"} <= set(
        read_marker(killed)["files"])
    assert main(["run", "k.yaml", "--restart", killed.name, "--quiet"]) == 0
    assert read_marker(work / "k")["complete"] is True and not killed.exists()


def test_restart_refuses_a_partial_folder_holding_a_link(killed, work, capsys):
    (work / "my_thesis.tex").write_text("the user's thesis")
    (killed / "notes.tex").symlink_to(work / "my_thesis.tex")
    refused(capsys, ["run", "k.yaml", "--restart", killed.name, "--quiet"],
            f"--restart {killed.name}: notes.tex is not a regular file", "nothing was copied")
    assert not (work / "k").exists()


def test_restart_refuses_a_partial_folder_holding_an_unlisted_file(killed, work, capsys):
    (killed / "extra.bin").write_bytes(b"\0" * 64)
    refused(capsys, ["run", "k.yaml", "--restart", killed.name, "--quiet"],
            "extra.bin was not written by the engine", "nothing was copied")
    assert not (work / "k").exists()


# (a link to /dev/null, not /dev/zero: code without the check copies it, and must not
# fill the disk doing so)
@pytest.mark.parametrize("special", ["device", "fifo"])
def test_restart_refuses_a_partial_folder_holding_a_device_or_pipe(killed, work, capsys,
                                                                   special):
    if special == "device":
        (killed / "trajectory.h5").unlink()  # a listed name, replaced by a link to a device
        (killed / "trajectory.h5").symlink_to("/dev/null")
    else:
        os.mkfifo(killed / "thermo.csv.pipe")
    refused(capsys, ["run", "k.yaml", "--restart", killed.name, "--quiet"],
            "is not a regular file")
    assert not (work / "k").exists()


# ----------------------------------------------------------------------------
# the rule, for every secondary writer and every place it must not write
# ----------------------------------------------------------------------------
PLACES = {  # --out value -> what the refusal says
    "mine": "the engine did not write",  # a user's folder (holding files named as ours)
    "linked": "symbolic link",
    "notes.txt": "is a file",
    "r2/sub": "r2, a folder of granular-chain run",  # inside another run's folder
    "r2": "holds the output of granular-chain run",  # a folder another command made
    ".": "current folder",
}


@pytest.mark.parametrize("place", PLACES)
@pytest.mark.parametrize("command", FOLDER_COMMANDS)
def test_folder_outputs_follow_the_rule(work, capsys, forbid, command, place):
    refused(capsys, [*FOLDER_COMMANDS[command], "--out", place], f"--out {place}",
            PLACES[place])


@pytest.mark.parametrize("place, says", [
    ("notes.txt", "exists and was not written by the engine"),
    ("mine", "is a folder"),
    ("r1/summary.json", "was written by granular-chain run, not diagnose"),
    ("r2/new.json", "r2, a folder of granular-chain run"),
    ("nowhere/report.json", "the folder nowhere does not exist"),
])
def test_diagnose_file_output_follows_the_rule(work, capsys, forbid, place, says):
    refused(capsys, ["diagnose", "r1", "--out", place], f"--out {place}", says)


def test_diagnose_out_refuses_a_link(work, capsys, forbid):
    (work / "report.json").symlink_to("notes.txt")
    refused(capsys, ["diagnose", "r1", "--out", "report.json"], "symbolic link")


def test_a_folder_one_command_made_is_refused_to_another(work, capsys):
    assert main(["plot", "r1", "--no-render", "--out", "figs"]) == 0
    refused(capsys, [*SWEEP, "--out", "figs"], "holds the output of granular-chain plot")
    refused(capsys, ["run", "scene.yaml", "--quiet", "--out", "figs", "--overwrite"],
            "holds the output of granular-chain plot")


# ----------------------------------------------------------------------------
# what each command may do: a new folder, its own folder again, its own run folder
# ----------------------------------------------------------------------------
def test_plot_out_makes_a_marked_folder_and_replaces_only_its_own_files(work, capsys):
    assert main(["plot", "r1", "--no-render", "--out", "figs"]) == 0
    marker = read_marker(work / "figs")
    assert marker["command"] == "plot" and marker["complete"] is True
    assert marker["files"] == ["energy.png", "spacetime.png", "velocities.png"]
    (work / "figs" / "energy.png").write_bytes(b"an earlier plot")  # (still the plot's)
    assert main(["plot", "r1", "--no-render", "--out", "figs"]) == 0
    assert (work / "figs" / "energy.png").read_bytes()[:4] == b"\x89PNG"
    (work / "figs" / "notes.txt").write_text("the user's")
    refused(capsys, ["plot", "r1", "--no-render", "--out", "figs"],
            "notes.txt was not written by the engine")


def test_plot_into_its_run_joins_the_runs_marker_as_plots(work, capsys):
    assert main(["plot", "r1", "--no-render"]) == 0
    marker = read_marker(work / "r1")
    assert {"plots/energy.png", "plots/spacetime.png"} <= set(marker["files"])
    assert marker["written_by"]["plots/energy.png"] == "plot"
    assert main(["plot", "r1", "--no-render"]) == 0  # its own PNGs may be redrawn


def test_diagnose_out_inside_its_run_is_adopted(work, capsys):
    assert main(["diagnose", "r1", "--out", "r1/diagnostics.json"]) == 0
    marker = read_marker(work / "r1")
    assert "diagnostics.json" in marker["files"]
    assert marker["written_by"] == {"diagnostics.json": "diagnose"}
    assert json.loads((work / "r1" / "diagnostics.json").read_text())["energy"]["initial"] == 0.5
    assert main(["diagnose", "r1", "--out", "r1/diagnostics.json"]) == 0  # its own file
    # the run replaced: the adopted file goes with it, as every file of the run
    assert main(["run", "scene.yaml", "--quiet", "--out", "r1", "--overwrite"]) == 0
    assert not (work / "r1" / "diagnostics.json").exists()


def test_export_out_makes_a_marked_folder_and_replaces_its_own_files(work):
    assert main(["export", "r1", "--format", "vtu", "--out", "vtu"]) == 0
    marker = read_marker(work / "vtu")
    assert marker["command"] == "export" and len(marker["files"]) > 1
    assert sorted(p.name for p in (work / "vtu").iterdir()) == sorted(
        [*marker["files"], MARKER])  # nothing else: no temporary folder left
    assert main(["export", "r1", "--format", "vtu", "--out", "vtu"]) == 0


def test_figures_out_makes_a_marked_folder(work, monkeypatch):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import granular_chain.paper.figures as figures

    def cheap(out):  # the engine's collisions are tested elsewhere: a figure, saved
        fig, ax = plt.subplots()
        ax.plot([0, 1], [0, 1])
        return figures._save(fig, out, "energy")

    monkeypatch.setitem(figures.FIGURES, "energy", cheap)
    assert main(["figures", "--out", "figs", "--only", "energy"]) == 0
    marker = read_marker(work / "figs")
    assert marker["command"] == "figures" and marker["files"] == ["paper_energy.png"]
    assert main(["figures", "--out", "figs", "--only", "energy"]) == 0


def test_sweep_out_makes_a_marked_folder_and_resumes_in_it(work):
    assert main([*SWEEP, "--out", "sw"]) == 0
    marker = read_marker(work / "sw")
    assert marker["command"] == "sweep" and marker["files"] == ["results.csv", "sweep.json"]
    rows = (work / "sw" / "results.csv").read_text()
    assert main([*SWEEP, "--out", "sw"]) == 0  # nothing left to compute
    assert (work / "sw" / "results.csv").read_text() == rows


# --- a signal while a claim makes, writes or undoes its folder ----------------------

def _signal_self(signum):
    import signal as _signal
    os.kill(os.getpid(), getattr(_signal, signum))


@pytest.mark.parametrize("signum", ["SIGINT", "SIGTERM", "SIGHUP"])
def test_signal_as_a_claim_makes_its_folder_leaves_nothing(tmp_path, monkeypatch, signum):
    """The signal arrives while the claimed folder is made and marked (held until the
    folder is whole), then acts: the claim is undone, nothing is left."""
    import granular_chain.rundir as rundir
    from granular_chain.interrupts import Stopped, raise_on_signals

    real = rundir.write_text_atomic
    monkeypatch.setattr(rundir, "write_text_atomic",
                        lambda path, text: (_signal_self(signum), real(path, text))[1])
    claim = rundir.claim_folder(tmp_path / "new" / "out", "boundaries", ["a.csv"])
    # another thread, as a writer's or a progress bar's: the signal may be delivered
    # to it, and its Python handler then runs in the main thread at any moment
    import threading
    done = threading.Event()
    other = threading.Thread(target=done.wait)
    other.start()
    try:
        with raise_on_signals(), pytest.raises(Stopped):
            with claim:
                pytest.fail("the claim's body ran")
    finally:
        done.set()
        other.join()
    assert list(tmp_path.iterdir()) == []


def test_signal_while_a_claim_writes_marks_its_folder_incomplete(tmp_path):
    """Stopped after one of two files: the folder stays, marked incomplete with the
    reason, listing the file written and nothing else; stopped before any file: nothing."""
    from granular_chain.interrupts import Stopped
    from granular_chain.rundir import claim_folder, write_text_atomic

    import signal as _signal
    out = tmp_path / "out"
    with pytest.raises(Stopped):
        with claim_folder(out, "boundaries", ["a.csv", "b.csv"]) as claim:
            write_text_atomic(claim.folder / "a.csv", "x\n")
            raise Stopped(_signal.SIGINT)
    marker = read_marker(out)
    assert sorted(os.listdir(out)) == ["a.csv", MARKER]
    assert marker["files"] == ["a.csv"] and marker["complete"] is False
    assert marker["reason"] == "interrupted by SIGINT"
    assert claim.written == [out / "a.csv"]
    with pytest.raises(Stopped):
        with claim_folder(tmp_path / "none", "boundaries", ["a.csv"]):
            raise Stopped(_signal.SIGTERM)
    assert sorted(os.listdir(tmp_path)) == ["out"]
    # the same command writes the incomplete folder again, and completes it
    with claim_folder(out, "boundaries", ["a.csv", "b.csv"]) as claim:
        for name in ("a.csv", "b.csv"):
            write_text_atomic(claim.folder / name, "y\n")
    assert read_marker(out)["complete"] is True and read_marker(out)["reason"] == ""


def test_a_signal_inside_the_compilers_callback_comes_again():
    """A signal that came inside llvmlite's callback (where an exception is dropped) is
    not raised there but sent again a moment later, and then unwinds the command."""
    import signal as _signal
    import time as _time

    from granular_chain.interrupts import Stopped, raise_on_signals

    code = compile("import sys\nframe = sys._getframe()",
                   "/site-packages/llvmlite/binding/ffi.py", "exec")
    scope: dict = {}
    exec(code, scope)
    with pytest.raises(Stopped) as stopped:
        with raise_on_signals():
            handler = _signal.getsignal(_signal.SIGTERM)
            handler(_signal.SIGTERM, scope["frame"])  # dropped there: nothing raised
            for _ in range(1000):  # the signal sent again ends this wait
                _time.sleep(0.01)
    assert stopped.value.signum == _signal.SIGTERM
