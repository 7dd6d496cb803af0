"""Optional extras: every command and API function that needs one says in one line which
extra is missing and how to install it (exit status 2, nothing written); PNG plots need
matplotlib alone, pyvista only frame.png."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import granular_chain as gc
from conftest import hand_made_result as _tiny_result
from granular_chain.cli import main
from granular_chain.extras import MissingExtraError, check, missing, require

ROOT = Path(__file__).resolve().parents[1]
SCENE = str(ROOT / "scenarios" / "hertz_chain.yaml")
TWO = str(ROOT / "scenarios" / "two_granules.yaml")


def _line(what, name, extra):
    return (f'{what}: needs {name}, from the [{extra}] extra: '
            f'pip install "granular_chain[{extra}]"')


# (modules made unimportable, command line, the one line it prints)
REFUSALS = [
    (["matplotlib"], ["plot", "{tmp}/run"], _line("granular-chain plot", "matplotlib", "plots")),
    (["meshio"], ["export", "{tmp}/run", "--out", "{tmp}/out"],
     _line("granular-chain export", "meshio", "vtk")),
    (["distributed"], ["sweep", TWO, "--grid", "granules.friction.kinetic[1]=0:0.5:3",
                       "--out", "{tmp}/out"],
     _line("granular-chain sweep", "dask.distributed", "sweep")),
    (["matplotlib"], ["sweep", TWO, "--serial", "--grid", "granules.friction.kinetic[1]=0:0.5:3",
                      "--grid", "granules.friction.kinetic[0]=0:0.5:3", "--quantity", "v1",
                      "--out", "{tmp}/out"],
     _line("granular-chain sweep --quantity", "matplotlib", "plots")),
    (["matplotlib"], ["figures", "--out", "{tmp}/out"],
     _line("granular-chain figures", "matplotlib", "plots")),
    (["matplotlib"], ["boundaries", "--param", "eta1", "--range", "0", "1", "--y-param", "eta2",
                      "--y-range", "0", "1", "--out", "{tmp}/out"],
     _line("granular-chain boundaries --y-param", "matplotlib", "plots")),
    (["distributed"], ["boundaries", "--param", "eta1", "--range", "0", "1", "--y-param", "eta2",
                       "--y-range", "0", "1", "--out", "{tmp}/out", "--dask"],
     _line("granular-chain boundaries --dask", "dask.distributed", "sweep")),
    (["matplotlib"], ["run", SCENE, "--plots", "--out", "{tmp}/out"],
     _line("granular-chain run --plots (output.plots)", "matplotlib", "plots")),
    (["pyvista"], ["run", SCENE, "--vtk", "--out", "{tmp}/out"],
     _line("granular-chain run --vtk (output.vtk)", "pyvista", "vtk")),
]


def _block(monkeypatch, modules):
    """Make ``modules`` unimportable in this process (an import raises ImportError)."""
    for name in modules:
        monkeypatch.setitem(sys.modules, name, None)


@pytest.mark.parametrize("blocked, argv, said", REFUSALS,
                         ids=[" ".join(r[1][:1] + r[1][-1:]) for r in REFUSALS])
def test_a_missing_extra_is_one_line_exit_2_nothing_written(blocked, argv, said, tmp_path,
                                                              monkeypatch, capsys):
    _block(monkeypatch, blocked)
    monkeypatch.chdir(tmp_path)
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.err == said + "\n" and captured.out == ""
    assert list(tmp_path.iterdir()) == []  # nothing written, not even a folder


def test_a_missing_extra_in_a_fresh_interpreter(tmp_path):
    """A real process where matplotlib cannot be imported at all (a stub package on the
    path that raises ImportError, as a broken installation would): the same one line."""
    code = ("import sys, types\n"
            "class Block:\n"
            "    def find_spec(self, name, path=None, target=None):\n"
            "        if name.split('.')[0] == 'matplotlib':\n"
            "            raise ImportError('blocked')\n"
            "sys.meta_path.insert(0, Block())\n"
            "from granular_chain.cli import main\n"
            f"sys.exit(main(['figures', '--out', {str(tmp_path / 'never')!r}]))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT)
    assert done.returncode == 2
    assert done.stderr == _line("granular-chain figures", "matplotlib", "plots") + "\n"
    assert list(tmp_path.iterdir()) == []


def test_the_api_raises_one_importerror_subclass(monkeypatch):
    _block(monkeypatch, ["xarray", "pandas"])
    result = _tiny_result()
    for method, name in ((result.to_xarray, "xarray"), (result.events_frame, "pandas"),
                         (result.ledger_frame, "pandas")):
        with pytest.raises(MissingExtraError) as err:
            method()
        assert isinstance(err.value, ImportError)
        assert str(err.value) == _line(f"Result.{method.__name__}", name, "analysis")
    assert gc.MissingExtraError is MissingExtraError


def test_helper_names_every_missing_module_and_its_extras(monkeypatch):
    _block(monkeypatch, ["matplotlib", "pyvista"])
    assert missing(("numpy", "matplotlib", "pyvista"), "x") == (
        'x: needs matplotlib and pyvista, from the [plots], [vtk] extras: '
        'pip install "granular_chain[plots,vtk]"')
    assert missing("numpy", "x") == ""
    check("numpy", "x")
    with pytest.raises(MissingExtraError, match=r"^granular_chain PNG plots: needs matplotlib"):
        from granular_chain.writers.plots import plot_energy
        plot_energy(_tiny_result(), "never.png")
    assert require("numpy", "x") is np


def test_png_plots_need_matplotlib_alone(monkeypatch, tmp_path):
    """Without pyvista the three plots are written and frame.png is skipped with a
    PlotSkippedWarning naming the extra, not an error."""
    from granular_chain.writers.plots import write_plots

    _block(monkeypatch, ["pyvista", "vtkmodules"])
    scene = gc.load_scene(TWO)
    with pytest.warns(gc.PlotSkippedWarning) as record:
        paths = write_plots(_tiny_result(), tmp_path, scene)
    assert [p.name for p in paths] == ["spacetime.png", "energy.png", "velocities.png"]
    assert all(p.stat().st_size > 1000 for p in paths)
    assert sorted(p.name for p in (tmp_path / "plots").iterdir()) == [
        "energy.png", "spacetime.png", "velocities.png"]
    assert [str(w.message) for w in record] == [
        "frame.png skipped: needs pyvista and vtk, from the [vtk] extra: "
        'pip install "granular_chain[vtk]"']


def test_cli_says_frame_skipped_in_one_line(monkeypatch, tmp_path, capsys):
    """`granular-chain plot` on a run folder without pyvista: exit 0, three PNGs, one
    line on stderr saying frame.png was skipped and why."""
    run_dir = tmp_path / "r"
    assert main(["run", SCENE, "--out", str(run_dir), "--quiet", "--set", "run.t_end=2"]) == 0
    capsys.readouterr()
    _block(monkeypatch, ["pyvista"])
    assert main(["plot", str(run_dir)]) == 0
    captured = capsys.readouterr()
    assert captured.err == ("granular-chain: frame.png skipped: needs pyvista, from the [vtk] "
                            'extra: pip install "granular_chain[vtk]"\n')
    assert [Path(p).name for p in captured.out.split()] == [
        "spacetime.png", "energy.png", "velocities.png"]
