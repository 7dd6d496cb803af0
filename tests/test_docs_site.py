"""The documentation site: strict build, generated references, no history wording.

- ``test_site_builds_strictly`` runs ``mkdocs build --strict`` (warnings, broken
  relative links and anchors, pages left out of the nav are errors); the build
  runs every tutorial under docs/tutorials/ and fails if one fails.
- The scene reference must list every field of the scene schema (found here by an
  independent recursive walk of the JSON Schema), the CLI reference every option.
- docs/ and README.md must describe the engine as it is: no wording that tells
  history (CHANGELOG.md is the place for it).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import granular_chain

ROOT = Path(__file__).resolve().parents[1]
#: Where the tested granular_chain lives (the tutorials import that copy, whose
#: compiled kernels the other tests share).
PACKAGE_PARENT = str(Path(granular_chain.__file__).resolve().parents[1])
sys.path.insert(0, str(ROOT))

from docs_build import cli_reference, scene_reference  # noqa: E402

#: Wording that tells the project's history rather than how the engine is.
HISTORY = [r"\bpreviously\b", r"\bused to\b", r"\bno longer\b", r"\bnow\b", r"\bwas fixed\b",
           r"\bfixed since\b", r"\bin this session\b", r"\bsessions?\b", r"\bwe added\b",
           r"\bearlier versions?\b", r"\bissue #", r"\bstep of the work\b", r"\boriginally\b",
           r"\bnew:", r"\blanded\b", r"\b(before|after) the fix", r"\bany more\b",
           r"\b20\d\d-\d\d-\d\d\b"]
_HISTORY = re.compile("|".join(HISTORY), re.I)


def _history_hits(paths, root: Path = ROOT) -> list[str]:
    """``file:line: 'match' in line`` for every line of ``paths`` with history wording."""
    hits = []
    for path in paths:
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            match = _HISTORY.search(line)
            if match:
                hits.append(f"{path.relative_to(root)}:{number}: {match.group(0)!r} in {line.strip()[:100]}")
    return hits


def test_docs_free_of_history_words():
    pages = [*sorted((ROOT / "docs").rglob("*.md")), *sorted((ROOT / "docs").rglob("*.py")),
             ROOT / "README.md"]
    assert len(pages) > 10
    hits = _history_hits(pages)
    assert not hits, "history wording (move it to CHANGELOG.md):\n" + "\n".join(hits)


def test_history_check_catches_wording(tmp_path):
    """The check fails on each listed wording, and not on plain present tense."""
    page = tmp_path / "docs" / "page.md"
    page.parent.mkdir()
    samples = ["This was fixed in step 3.", "It previously diverged.", "The kernel now inlines.",
               "Fixed since 2026-11-22.", "issue #20 asks", "New: a flag"]
    page.write_text("\n".join(samples + ["The kernel inlines the law; it is known to hold."]))
    hits = _history_hits([page], root=tmp_path)
    assert [h.split(":")[1] for h in hits] == [str(i) for i in range(1, len(samples) + 1)]


def _schema_paths(schema: dict) -> set[str]:
    """Dotted paths of every leaf field, descending through $ref/anyOf into models;
    fields of the seeded distributions as ``<kind>.<field>``."""
    defs = schema["$defs"]

    def target(node):
        return defs[node["$ref"].split("/")[-1]] if "$ref" in node else node

    def leaves(model, prefix):
        for name, prop in model.get("properties", {}).items():
            subs = [target(a) for a in prop.get("anyOf", [prop])
                    if "properties" in target(a) and "distribution" not in target(a)["properties"]]
            if subs:
                yield from leaves(subs[0], f"{prefix}{name}.")
            else:
                yield prefix + name

    paths = set(leaves(schema, ""))
    for model in defs.values():
        props = model.get("properties", {})
        if "distribution" in props:
            paths |= {f"{props['distribution']['const']}.{p}" for p in props}
    return paths


def test_scene_reference_lists_every_schema_field():
    schema = scene_reference.scene_schema()
    page = scene_reference.render()
    paths = _schema_paths(schema)
    # the schema really nests: friction, material, state, walls.left/right, run, output
    assert {"granules.friction.kinetic", "granules.state.frame", "walls.right.exponent",
            "run.rtol", "output.thermo", "normal.std"} <= paths
    rows = {m.group(1): m.group(0) for m in re.finditer(r"^\| `([^`]+)` \|.*$", page, re.M)}
    assert sorted(paths - set(rows)) == []
    assert sorted(set(rows) - paths) == []
    # each row carries the schema's default and description
    run = schema["$defs"]["Run"]["properties"]
    assert "| `1.0e-12` |" in rows["run.rtol"] and run["rtol"]["description"] in rows["run.rtol"]
    assert "| required |" in rows["granules.count"]


def test_scene_reference_is_generated_not_written():
    """The page exists only in the built site: docs/ holds no hand-written copy."""
    assert not (ROOT / "docs" / "reference" / "scene.md").exists()
    assert not (ROOT / "docs" / "reference" / "cli.md").exists()


def test_cli_reference_lists_every_option():
    parser = cli_reference.build_parser()
    page = cli_reference.render()
    subs = cli_reference.subcommands(parser)
    assert {"run", "validate", "schema", "sweep", "boundaries", "export"} <= set(subs)
    for name, sub in subs.items():
        section = page.split(f"## `{name}`\n", 1)[1].split("\n## ", 1)[0]
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            for flag in action.option_strings or [action.metavar or action.dest]:
                assert f"`{flag}" in section, f"{name}: {flag} missing from the CLI reference"


def _have(*modules) -> bool:
    return all(importlib.util.find_spec(m) is not None for m in modules)


@pytest.mark.skipif(not _have("mkdocs", "material", "mkdocstrings_handlers.python"),
                    reason="needs the [docs] extra (mkdocs, mkdocs-material, mkdocstrings)")
def test_site_builds_strictly(tmp_path):
    site = tmp_path / "site"
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q",
                           "--site-dir", str(site)], cwd=ROOT, capture_output=True, text=True,
                          timeout=600, env={**os.environ, "NO_MKDOCS_2_WARNING": "1",
                                            "GRANULAR_CHAIN_TUTORIAL_PATH": PACKAGE_PARENT})
    assert done.returncode == 0, done.stderr[-5000:]
    for page in ("reference/scene/index.html", "reference/cli/index.html", "api/index.html",
                 "changelog/index.html", "tutorials/struck_chain/index.html"):
        assert (site / page).is_file(), page
    scene_page = (site / "reference/scene/index.html").read_text()
    assert "granules.friction.viscous" in scene_page
    assert list((site / "tutorials").rglob("*.png")), "the tutorials wrote no figures"
