"""The user's files are never touched: where ``granular-chain run`` may write, what
it may replace, and what an interrupted or failed run leaves behind.

Every destructive case puts a sentinel file in the user's folder and checks
that it survives byte for byte, and that nothing else in the folder changed.
"""

import hashlib
import json
import os
from pathlib import Path

import pytest

from conftest import patch_everywhere
from granular_chain.cli import main
from granular_chain.rundir import MARKER, default_out, read_marker

SCENE = """\
name: tiny
granules: {count: 2, velocity: [1.0, 0.0]}
run: {t_end: 0.5}
"""


def snapshot(folder: Path) -> dict:
    """Every file below ``folder`` (hidden ones too) with its content digest."""
    out = {}
    for root, dirs, files in os.walk(folder):
        for name in files:
            p = Path(root) / name
            out[p.relative_to(folder).as_posix()] = hashlib.sha1(p.read_bytes()).hexdigest()
        for name in dirs:
            out[(Path(root) / name).relative_to(folder).as_posix() + "/"] = "dir"
    return out


@pytest.fixture
def work(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scene.yaml").write_text(SCENE)
    return tmp_path


def run(*args):
    return main(["run", "scene.yaml", "--quiet", *args])


def refused(capsys, *args) -> str:
    code = run(*args)
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("granular-chain: "), err
    assert "Traceback" not in err
    return lines[0]


def with_sentinel(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    sentinel = folder / "my_thesis.tex"
    sentinel.write_text("three years of work\n")
    return sentinel


def test_existing_user_folder_is_refused_and_untouched(work, capsys):
    sentinel = with_sentinel(work / "results")
    before = snapshot(work)
    line = refused(capsys, "--out", "results")
    assert "--out results" in line and "did not write" in line
    assert snapshot(work) == before
    assert sentinel.read_text() == "three years of work\n"


def test_existing_user_folder_is_refused_even_with_overwrite(work, capsys):
    with_sentinel(work / "results")
    before = snapshot(work)
    refused(capsys, "--out", "results", "--overwrite")
    assert snapshot(work) == before


def test_empty_user_folder_is_refused(work, capsys):
    (work / "empty").mkdir()
    before = snapshot(work)
    assert "empty folder" in refused(capsys, "--out", "empty")
    assert snapshot(work) == before


@pytest.mark.parametrize("target", [".", "./", "..", "sub/..", str(Path("/"))])
def test_current_folder_and_its_parents_are_refused(work, capsys, target):
    with_sentinel(work)
    before = snapshot(work)
    line = refused(capsys, "--out", target)
    assert "current folder" in line
    assert snapshot(work) == before


def test_out_onto_a_file_is_refused(work, capsys):
    (work / "notes.txt").write_text("mine")
    before = snapshot(work)
    assert "is a file" in refused(capsys, "--out", "notes.txt")
    assert "is a file" in refused(capsys, "--out", "notes.txt/run")
    assert snapshot(work) == before


def test_out_onto_a_symlink_is_refused(work, capsys):
    with_sentinel(work / "real")
    (work / "link").symlink_to(work / "real")
    before = snapshot(work)
    assert "symbolic link" in refused(capsys, "--out", "link")
    assert snapshot(work) == before


def test_earlier_run_needs_overwrite(work, capsys):
    assert run("--out", "r") == 0
    first = snapshot(work / "r")
    line = refused(capsys, "--out", "r")
    assert "--overwrite" in line
    assert snapshot(work / "r") == first


def test_overwrite_replaces_an_earlier_run_and_leaves_no_debris(work):
    assert run("--out", "r") == 0
    assert run("--out", "r", "--overwrite", "--set", "run.t_end=0.25") == 0
    summary = json.loads((work / "r" / "summary.json").read_text())
    assert summary["t_final"] == pytest.approx(0.25)
    hidden = [p.name for p in work.iterdir() if p.name.startswith(".")]
    assert hidden == []


def test_overwrite_refuses_a_run_folder_holding_a_user_file(work, capsys):
    assert run("--out", "r") == 0
    sentinel = with_sentinel(work / "r")
    before = snapshot(work)
    line = refused(capsys, "--out", "r", "--overwrite")
    assert "my_thesis.tex" in line and "not written by the engine" in line
    assert snapshot(work) == before and sentinel.exists()


def test_forged_marker_of_another_program_is_not_a_run(work, capsys):
    folder = work / "r"
    with_sentinel(folder)
    (folder / MARKER).write_text(json.dumps({"engine": "someone_else", "files": []}))
    before = snapshot(work)
    refused(capsys, "--out", "r", "--overwrite")
    assert snapshot(work) == before


def test_marker_lists_every_file_written(work):
    assert run("--out", "r", "--csv") == 0
    marker = read_marker(work / "r")
    assert marker["complete"] is True and marker["reason"] == ""
    on_disk = {p.relative_to(work / "r").as_posix() for p in (work / "r").rglob("*")
               if p.is_file()} - {MARKER}
    assert set(marker["files"]) == on_disk
    assert {"summary.json", "trajectory.h5", "energy.csv"} <= on_disk


def test_default_folder_gets_a_stable_suffix_per_overrides(work):
    assert run() == 0
    assert run("--set", "run.t_end=0.25") == 0
    assert run("--set", "run.t_end=0.3") == 0
    names = sorted(p.name for p in (work / "outputs").iterdir())
    assert names[0] == "tiny" and len(names) == 3 and len(set(names)) == 3
    assert default_out("tiny", ["run.t_end=0.25"]) == Path("outputs") / names[1] or \
        default_out("tiny", ["run.t_end=0.25"]) == Path("outputs") / names[2]
    # the same overrides, spelled differently or reordered, find the same folder
    a = default_out("tiny", ["run.t_end=0.25", "granules.velocity=[1,0]"])
    b = default_out("tiny", ["granules.velocity=[1, 0]", "run.t_end=0.25"])
    assert a == b != default_out("tiny", ["run.t_end=0.25"])


def test_default_folder_is_replaced_by_a_rerun_of_the_same_scene(work):
    assert run() == 0
    assert run() == 0
    assert read_marker(work / "outputs" / "tiny")["complete"] is True


def test_default_folder_of_another_scene_file_is_not_replaced(work, capsys):
    assert run() == 0
    (work / "other.yaml").write_text(SCENE)
    before = snapshot(work / "outputs")
    code = main(["run", "other.yaml", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "holds an earlier run" in err and "scene.yaml" in err
    assert snapshot(work / "outputs") == before


def test_refused_run_creates_nothing(work, capsys):
    (work / "bad.yaml").write_text(SCENE.replace("t_end: 0.5", "t_end: 0.5, dt: 10.0"))
    before = snapshot(work)
    code = main(["run", "bad.yaml", "--out", "new/deep/folder"])
    assert code == 2 and "run.dt" in capsys.readouterr().err
    assert snapshot(work) == before


def test_failed_writer_leaves_nothing(work, monkeypatch):
    def broken(*args, **kwargs):
        raise OSError("disk full")

    patch_everywhere(monkeypatch, "writers.summary", "write_summary", broken)
    with_sentinel(work)
    before = snapshot(work)
    assert run("--out", "r") == 2  # said in one line (tests/test_hangs_input.py)
    assert snapshot(work) == before


def test_stale_partial_folder_of_a_killed_run_is_cleared(work):
    stale = work / ".r.partial-abc123"
    stale.mkdir()
    (stale / "trajectory.h5").write_bytes(b"half")
    (stale / MARKER).write_text(json.dumps(
        {"engine": "granular_chain", "complete": False, "reason": "running",
         "pid": 2 ** 22 + 12345, "files": []}))
    user_hidden = work / ".r.partial-mine"  # looks alike, but has no marker: not ours
    with_sentinel(user_hidden)
    assert run("--out", "r") == 0
    assert not stale.exists() and (user_hidden / "my_thesis.tex").exists()


def test_sweep_refuses_a_user_folder(work, capsys):
    with_sentinel(work / "results")
    before = snapshot(work)
    code = main(["sweep", "scene.yaml", "--grid", "run.t_end=0.1:0.2:2", "--serial",
                 "--out", "results", "--restart", "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "--out results" in err and "the engine did not write" in err
    assert snapshot(work) == before


def test_diagnose_out_never_overwrites_a_file(work, capsys):
    (work / "report.json").write_text("my notes")
    before = snapshot(work)
    code = main(["diagnose", "scene.yaml", "--out", "report.json"])
    err = capsys.readouterr().err
    assert code == 2 and "report.json exists" in err
    assert snapshot(work) == before


def test_plot_refuses_user_pngs_and_plots_join_the_run(work, capsys):
    assert run("--out", "r") == 0
    (work / "figs").mkdir()
    (work / "figs" / "energy.png").write_bytes(b"my figure")
    before = snapshot(work)
    code = main(["plot", "r", "--out", "figs", "--no-render"])
    err = capsys.readouterr().err
    assert code == 2 and "--out figs" in err and "the engine did not write" in err
    assert snapshot(work) == before
    assert main(["plot", "r", "--no-render"]) == 0
    assert "plots/energy.png" in read_marker(work / "r")["files"]
    assert main(["plot", "r", "--no-render"]) == 0  # its own plots may be redrawn
    assert run("--out", "r", "--overwrite") == 0  # and the run replaced, plots included
    assert not (work / "r" / "plots").exists()


def test_failed_run_removes_the_folders_it_created(work, monkeypatch):
    def broken(*args, **kwargs):
        raise OSError("disk full")

    patch_everywhere(monkeypatch, "writers.summary", "write_summary", broken)
    before = snapshot(work)
    assert run("--out", "deep/er/run") == 2  # a write error: one line, exit 2
    assert snapshot(work) == before and not (work / "deep").exists()


def test_replacing_a_run_with_subfolders_leaves_no_debris(work):
    assert run("--out", "r", "--vtk") == 0
    assert run("--out", "r", "--vtk", "--overwrite") == 0
    assert run("--out", "r", "--vtk", "--overwrite") == 0
    assert sorted(p.name for p in work.iterdir()) == ["r", "scene.yaml"]


def test_a_folder_that_appears_during_the_run_is_left_alone(work, monkeypatch, capsys):
    import granular_chain.cli.run as cli

    original = cli._write_outputs

    def user_mkdir_meanwhile(*args, **kwargs):
        with_sentinel(work / "r")
        return original(*args, **kwargs)

    monkeypatch.setattr(cli, "_write_outputs", user_mkdir_meanwhile)
    assert run("--out", "r") == 2
    err = capsys.readouterr().err
    assert "appeared while the run went" in err and "my_thesis.tex" not in err
    assert sorted(p.name for p in (work / "r").iterdir()) == ["my_thesis.tex"]
    beside = [p for p in work.iterdir() if p.name.startswith("r.run-")]
    assert len(beside) == 1 and read_marker(beside[0])["complete"] is True


def test_remove_files_stays_inside_its_folder_and_keeps_unlisted_folders(tmp_path):
    from granular_chain.rundir import remove_files
    run = tmp_path / "run"
    (run / "frames").mkdir(parents=True)
    (run / "frames" / "f0.vtp").write_text("engine")
    (run / "summary.json").write_text("engine")
    (run / "mine").mkdir()  # an empty folder of the user's
    outside = tmp_path / "outside.txt"
    outside.write_text("user")
    remove_files(run, ["frames/f0.vtp", "summary.json", "../outside.txt", str(outside)])
    assert outside.read_text() == "user"
    assert sorted(p.name for p in run.iterdir()) == ["mine"]


def test_remove_files_does_not_follow_a_linked_subfolder(tmp_path):
    """A listed subfolder replaced by a link to the user's folder: its files stay."""
    from granular_chain.rundir import remove_files
    run, elsewhere = tmp_path / "run", tmp_path / "user_data"
    run.mkdir()
    elsewhere.mkdir()
    (elsewhere / "f0.vtp").write_text("user")
    (run / "vtk").symlink_to(elsewhere, target_is_directory=True)
    (run / "summary.json").write_text("engine")
    remove_files(run, ["vtk/f0.vtp", "summary.json"])
    assert (elsewhere / "f0.vtp").read_text() == "user"
    assert not (run / "summary.json").exists()
