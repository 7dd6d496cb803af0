"""The installed package carries what type checkers and pip users need: the PEP 561
marker, and extras that install what each one promises."""

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _project():
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        tomllib = pytest.importorskip("tomli")
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_py_typed_marker_is_package_data():
    """granular_chain/py.typed exists and setuptools ships it (package-data), so a
    wheel carries it and type checkers read the package's annotations."""
    assert (ROOT / "granular_chain" / "py.typed").is_file()
    config = _project()["tool"]["setuptools"]
    assert "py.typed" in config["package-data"]["granular_chain"]
    pyproject = pytest.importorskip("setuptools.config.pyprojecttoml")
    read = pyproject.read_configuration(ROOT / "pyproject.toml", expand=False)
    assert "py.typed" in read["tool"]["setuptools"]["package-data"]["granular_chain"]


def test_extras_install_what_the_messages_name():
    """Each extra a refusal names (granular_chain.extras.EXTRAS) installs that library,
    and [viz] is [plots] and [vtk] together."""
    from packaging.requirements import Requirement

    from granular_chain.extras import EXTRAS

    extras = _project()["project"]["optional-dependencies"]
    names = {e: {Requirement(r).name for r in reqs} for e, reqs in extras.items()}
    distribution = {"matplotlib": "matplotlib", "pyvista": "pyvista", "vtkmodules": "pyvista",
                    "meshio": "meshio", "distributed": "dask", "xarray": "xarray",
                    "h5netcdf": "h5netcdf", "pandas": "pandas"}
    for module, (_, extra) in EXTRAS.items():
        assert distribution[module] in names[extra], (module, extra)
    assert [str(Requirement(r)) for r in extras["viz"]] == ["granular_chain[plots,vtk]"]
