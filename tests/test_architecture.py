"""docs/architecture.md's worked example runs as printed."""

import re
from pathlib import Path

PAGE = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"


def _python_blocks() -> list:
    return re.findall(r"```python\n(.*?)```", PAGE.read_text(), flags=re.S)


def test_the_writer_example_runs(tmp_path):
    blocks = _python_blocks()
    assert len(blocks) == 1 and "class MomentumTable" in blocks[0]
    namespace = {"OUT": tmp_path}
    exec(compile(blocks[0], str(PAGE), "exec"), namespace)
    assert (tmp_path / "momentum.csv").read_text().startswith("t,centre_of_mass,momentum\n")


def test_the_page_names_files_that_exist():
    """Every ``file.py`` the page names exists: under granular_chain/ (named from
    anywhere inside it), or at its path from the top (tests/, benchmarks/)."""
    root = PAGE.parents[1]
    named = set(re.findall(r"`((?:[a-z_]+/)*[a-z_0-9]+\.py)`", PAGE.read_text()))
    missing = [n for n in named if not (root / n).is_file()
               and not any(p.as_posix().endswith(n) for p in (root / "granular_chain").rglob("*.py"))]
    assert len(named) > 15 and not missing, missing
