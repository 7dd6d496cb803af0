"""mkdocs hooks: generated reference pages and executed tutorials.

- ``changelog.md`` is the top-level CHANGELOG.md.
- ``reference/scene.md`` and ``reference/cli.md`` are generated from the scene
  schema and the argparse parser (:mod:`docs_build.scene_reference`,
  :mod:`docs_build.cli_reference`); they exist only in the built site.
- Every script ``docs/tutorials/*.py`` runs in its own process and folder when
  the site is built; a page line ``<!-- tutorial: NAME.py -->`` becomes the
  script's source and what it printed, and the PNG files it wrote are
  published as ``tutorials/NAME/FILE.png``. A script that fails stops the
  build, so a tutorial page cannot go stale.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from docs_build import cli_reference, scene_reference  # noqa: E402

_MARK = re.compile(r"^<!-- tutorial: ([\w.-]+\.py) -->$", re.M)
_outputs: dict[str, str] = {}
_workdir: list[str] = []


def run_tutorial(script: Path, folder: Path) -> str:
    """Run one tutorial script in ``folder``; its stdout, or PluginError if it fails."""
    folder.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, MPLBACKEND="Agg", PYVISTA_OFF_SCREEN="true")
    # GRANULAR_CHAIN_TUTORIAL_PATH: the folder to import granular_chain from instead of
    # this tree (the test suite passes the copy it tests, whose compiled kernels are cached)
    package = env.get("GRANULAR_CHAIN_TUTORIAL_PATH") or str(ROOT)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package, env.get("PYTHONPATH")) if p)
    start = time.perf_counter()
    # No time limit: a tutorial runs in seconds with numba's cache warm, but its first
    # run compiles kernels (minutes on a loaded machine), and a limit would fail that build.
    done = subprocess.run([sys.executable, str(script)], cwd=folder, env=env, text=True,
                          capture_output=True)
    if done.returncode != 0:
        raise PluginError(f"tutorial {script.name} failed (exit {done.returncode}):\n"
                          f"{done.stderr[-3000:]}")
    print(f"INFO    -  tutorial {script.name}: {time.perf_counter() - start:.1f} s",
          file=sys.stderr)
    return done.stdout


def changelog() -> str:
    """CHANGELOG.md for the site (its links to docs/ made relative to the site root)."""
    return (ROOT / "CHANGELOG.md").read_text().replace("](docs/", "](")


def on_files(files, config):
    """Add the generated reference pages and the tutorials' figures."""
    files.append(File.generated(config, "reference/scene.md", content=scene_reference.render()))
    files.append(File.generated(config, "reference/cli.md", content=cli_reference.render()))
    files.append(File.generated(config, "changelog.md", content=changelog()))
    work = Path(tempfile.mkdtemp(prefix="gc-tutorials-"))
    _workdir.append(str(work))
    for script in sorted((Path(config["docs_dir"]) / "tutorials").glob("*.py")):
        folder = work / script.stem
        _outputs[script.name] = run_tutorial(script, folder)
        for png in sorted(folder.glob("*.png")):
            files.append(File.generated(config, f"tutorials/{script.stem}/{png.name}",
                                        abs_src_path=str(png)))
    return files


def on_page_markdown(markdown, page, config, files):
    """Put each marked tutorial's source and printed output in its page."""
    def insert(match):
        name = match.group(1)
        if name not in _outputs:
            raise PluginError(f"{page.file.src_uri}: no tutorial script docs/tutorials/{name}")
        source = (Path(config["docs_dir"]) / "tutorials" / name).read_text().rstrip()
        output = _outputs[name].rstrip() or "(nothing printed)"
        return (f'```python title="{name}"\n{source}\n```\n\n'
                f'Output (computed when this page was built):\n\n```text\n{output}\n```')
    return _MARK.sub(insert, markdown)


def on_post_build(config):
    """Remove the tutorials' working folders."""
    while _workdir:
        shutil.rmtree(_workdir.pop(), ignore_errors=True)
