"""The README's two set-up commands, run as a new user runs them.

Each command is read from README.md's "Set-up" section (so the test follows the
README, not a copy of it) and run with ``bash -c`` in a fresh copy of the
repository's tracked files, with a fresh virtual environment and an empty numba
cache (``NUMBA_CACHE_DIR`` pointed at a new folder): the cold start a user meets
on a new machine. The test checks that both exit 0 and that the first one wrote
a complete run; it prints how long each took (no time limit: a cold compile on a
loaded machine takes what it takes). ``docs/performance.md`` quotes the times.

Command 1 runs in every suite (CI included). Command 2 is the whole test suite
again, cold: CI's ``.ci/run`` is that very command on a fresh clone with an empty
cache (a test checks that the two are the same text), so here it runs only when
``GRANULAR_CHAIN_README_TEST=1``; the inner suite runs without that flag, so it does
not recurse.
"""

import json
import os
import re
import shutil
import subprocess
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ENV_FLAG = "GRANULAR_CHAIN_README_TEST"

cold_only = pytest.mark.skipif(os.environ.get(ENV_FLAG) != "1",
                               reason=f"runs the README's commands cold; set {ENV_FLAG}=1")


def readme_commands(readme: Path = ROOT / "README.md") -> list[str]:
    """The bash blocks of the README's "Set-up" section, in order.

    Parameters
    ----------
    readme : Path
        The README to read.

    Returns
    -------
    list of str
        One command line per fenced ``bash`` block of the section.
    """
    text = readme.read_text()
    section = re.search(r"^## Set-up.*?(?=^## )", text, flags=re.M | re.S)
    assert section, "README.md has no '## Set-up' section"
    return [block.strip() for block in re.findall(r"```bash\n(.*?)```", section.group(0), re.S)]


def test_readme_has_two_setup_commands():
    commands = readme_commands()
    assert len(commands) == 2
    assert "pip install ." in commands[0] and "granular-chain run" in commands[0]
    assert 'pip install ".[test]"' in commands[1] and commands[1].endswith("pytest")


def _tracked_copy(dest: Path) -> None:
    """Copy the repository's tracked files (as a fresh clone would hold them)."""
    files = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, check=True,
                           capture_output=True).stdout.decode().split("\0")
    for name in filter(None, files):
        source = ROOT / name
        if source.is_file():
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, dest / name)


def _run_cold(command: str, workdir: Path, cache: Path) -> tuple[int, float, str]:
    env = {k: v for k, v in os.environ.items()  # (a user's shell: none of the suite's settings)
           if k not in (ENV_FLAG, "VIRTUAL_ENV", "PYTHONPATH", "GRANULAR_CHAIN_COMPILE_LOCKS")
           and not k.startswith("PYTEST")}
    env["NUMBA_CACHE_DIR"] = str(cache)
    start = time.perf_counter()
    proc = subprocess.run(["bash", "-c", command], cwd=workdir, env=env,
                          capture_output=True, text=True)
    return proc.returncode, time.perf_counter() - start, proc.stdout[-3000:] + proc.stderr[-3000:]


def test_ci_runs_the_readmes_test_command():
    """CI (``.ci/run``) is README command 2 itself, on a fresh clone: the suite there is
    that command's cold run."""
    assert readme_commands()[1] in (ROOT / ".ci" / "run").read_text()


@pytest.mark.slow
@pytest.mark.parametrize("which", [0, pytest.param(1, marks=cold_only)],
                         ids=["install-and-run", "install-and-test"])
def test_readme_command_passes_cold(which, tmp_path):
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs the git checkout to copy its tracked files")
    workdir, cache = tmp_path / "repo", tmp_path / "numba-cache"
    workdir.mkdir()
    cache.mkdir()
    _tracked_copy(workdir)
    code, seconds, tail = _run_cold(readme_commands()[which], workdir, cache)
    print(f"README command {which + 1}: exit {code} in {seconds:.0f} s (cold numba cache)")
    assert code == 0, tail
    assert any(cache.iterdir()), "the command compiled nothing into the fresh numba cache"
    if which == 0:
        markers = list((workdir / "outputs").glob("*/run.json"))
        assert len(markers) == 1, markers
        assert json.loads(markers[0].read_text())["complete"] is True
