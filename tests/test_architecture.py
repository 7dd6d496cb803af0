"""docs/architecture.md's worked example runs as printed."""

import re
import sys
from pathlib import Path

PAGE = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"


def _python_blocks() -> list:
    return re.findall(r"```python\n(.*?)```", PAGE.read_text(), flags=re.S)


def test_the_writer_example_runs(tmp_path):
    blocks = _python_blocks()
    assert len(blocks) == 3 and "class MomentumTable" in blocks[0]
    namespace = {"OUT": tmp_path}
    exec(compile(blocks[0], str(PAGE), "exec"), namespace)
    assert (tmp_path / "momentum.csv").read_text().startswith("t,centre_of_mass,momentum\n")


def test_the_contact_law_example_runs(tmp_path, monkeypatch):
    """The law's file as printed, imported as a module (so numba caches its kernels as
    a user's would be), then the page's run of it."""
    from granular_chain.laws import contact

    law_file, use = _python_blocks()[1:]
    assert law_file.startswith("# cone_law.py\n") and "register_contact_law" in law_file
    (tmp_path / "cone_law.py").write_text(law_file)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(contact, "_BY_NAME", dict(contact._BY_NAME))
    monkeypatch.setattr(contact, "_BY_CODE", dict(contact._BY_CODE))
    monkeypatch.delitem(sys.modules, "cone_law", raising=False)
    namespace = {}
    exec(compile(use, str(PAGE), "exec"), namespace)
    assert namespace["cone"].model.features.describe()["law"] == "cone (n=3)"
    monkeypatch.delitem(sys.modules, "cone_law")


def test_the_page_names_files_that_exist():
    """Every ``file.py`` the page names exists: under granular_chain/ (named from
    anywhere inside it), or at its path from the top (tests/, benchmarks/)."""
    root = PAGE.parents[1]
    named = set(re.findall(r"`((?:[a-z_]+/)*[a-z_0-9]+\.py)`", PAGE.read_text()))
    missing = [n for n in named if not (root / n).is_file()
               and not any(p.as_posix().endswith(n) for p in (root / "granular_chain").rglob("*.py"))]
    assert len(named) > 15 and not missing, missing
