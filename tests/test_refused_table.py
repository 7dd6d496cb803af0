"""docs/robustness.md, "What is refused": every row of the table is run as written.

The row's example command runs in-process (``granular_chain.cli.main``) with ``S`` the
scene the section gives; it must exit with the row's code and print exactly one line on
stderr that holds the row's message, and write nothing. So the table cannot drift from
the code.
"""

import re
import shlex
from pathlib import Path

import pytest

from granular_chain.cli import main

DOC = Path(__file__).resolve().parents[1] / "docs" / "robustness.md"


def _section() -> str:
    text = DOC.read_text()
    start = text.index("\n## What is refused\n")
    end = text.find("\n## ", start + 1)
    return text[start:end if end > 0 else len(text)]


def _scene() -> str:
    return re.search(r"```yaml\n(.*?)```", _section(), re.S).group(1)


def _rows() -> list:
    rows = []
    for line in _section().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split(" | ")]
        if len(cells) != 4 or not cells[1].startswith("`granular-chain "):
            continue
        rows.append(pytest.param(cells[1].strip("`"), cells[2].strip("`"), int(cells[3]),
                                 id=cells[0]))
    return rows


def test_the_table_has_its_rows():
    assert len(_rows()) >= 15


def _files(folder: Path) -> list:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))


@pytest.mark.parametrize("command, message, code", _rows())
def test_row_is_what_the_command_does(tmp_path, capsys, monkeypatch, command, message, code):
    scene = tmp_path / "S"
    scene.write_text(_scene())
    monkeypatch.chdir(tmp_path)
    before = _files(tmp_path)
    status = main(shlex.split(command)[1:])
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert status == code, err
    assert len(lines) == 1 and "Traceback" not in err, err
    prefix = "granular-chain: S: " if " S " in f"{command} " else "granular-chain: "
    assert lines[0].startswith(prefix + message), (lines[0], message)
    assert _files(tmp_path) == before
