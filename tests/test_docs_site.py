"""The documentation site: strict build, generated references, no history wording.

- ``test_site_builds_strictly`` runs ``mkdocs build --strict`` (warnings, broken
  relative links and anchors, pages left out of the nav are errors); the build
  runs every tutorial under docs/tutorials/, with no time limit (a cold numba
  compile takes minutes), and fails if one fails. The built site is shared by the
  tests that read it: no page loads anything from the network (KaTeX and fonts are
  bundled), the API page shows no raw Sphinx role nor private base, every scene
  field is a whole readable row, the landing page has a figure and a 5-minute path,
  and (with headless Chromium) the maths is typeset offline and the scene tables fit.
- ``[docs]`` installs every module the tutorials and docs_build/ import.
- The scene reference must list every field of the scene schema (found here by an
  independent recursive walk of the JSON Schema), the CLI reference every option.
- docs/ and README.md must describe the engine as it is: no wording that tells
  history (CHANGELOG.md is the place for it).
"""

from __future__ import annotations

import argparse
import ast
import importlib.util
import os
import re
import shutil
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest

import granular_chain

try:
    import fcntl
except ImportError:  # not POSIX: each test process builds its own copy of the site
    fcntl = None

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
    """Dotted paths of every leaf field, descending through $ref/anyOf into models (into
    each member of a oneOf of models: ``run``, one per stepper); fields of the seeded
    distributions as ``<kind>.<field>``."""
    defs = schema["$defs"]

    def target(node):
        return defs[node["$ref"].split("/")[-1]] if "$ref" in node else node

    def leaves(model, prefix):
        for name, prop in model.get("properties", {}).items():
            members = prop.get("anyOf") or prop.get("oneOf") or [prop]
            subs = [target(a) for a in members
                    if "properties" in target(a) and "distribution" not in target(a)["properties"]]
            lists = [target(a["items"]) for a in members
                     if a.get("type") == "array" and "$ref" in a.get("items", {})]
            for sub in subs:
                yield from leaves(sub, f"{prefix}{name}.")
            if not subs:
                yield prefix + name
            if lists:  # a list of models (run.stages): its items' fields too
                yield from leaves(lists[0], f"{prefix}{name}[].")

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
    rows = {m.group(1).replace("<wbr>", ""): m.group(0)
            for m in re.finditer(r'^\| <code class="gc-field">([^`|]+)</code> \|.*$', page, re.M)}
    assert sorted(paths - set(rows)) == []
    assert sorted(set(rows) - paths) == []
    # each row carries the schema's default and description
    run = schema["$defs"]["RunEvent"]["properties"]
    assert "| `1.0e-12` |" in rows["run.rtol"] and run["rtol"]["description"] in rows["run.rtol"]
    # run.stepper tells the two members of run apart: its row offers both
    assert "'verlet' &#124; 'event'" in rows["run.stepper"] and "| `verlet` |" in rows["run.stepper"]
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


needs_docs = pytest.mark.skipif(
    not _have("mkdocs", "material", "mkdocstrings_handlers.python"),
    reason="needs the [docs] extra (mkdocs, mkdocs-material, mkdocstrings)")


def _build(site: Path) -> None:
    """``mkdocs build --strict`` into ``site``; its stderr in ``site``.failed if it fails."""
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q",
                           "--site-dir", str(site)], cwd=ROOT, capture_output=True, text=True,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1",
                               "GRANULAR_CHAIN_TUTORIAL_PATH": PACKAGE_PARENT})
    if done.returncode != 0:
        site.with_suffix(".failed").write_text(done.stderr[-5000:] or f"exit {done.returncode}")


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site built once by ``mkdocs build --strict`` (it runs every tutorial).

    No time limit: the tutorials compile kernels when numba's cache is cold
    (minutes on a loaded machine); they import the tested copy of the package
    (GRANULAR_CHAIN_TUTORIAL_PATH), whose kernels the other tests have cached.
    Under pytest-xdist the workers of one run share one build (the first to ask
    builds it under a lock, the others wait and read it).
    """
    if os.environ.get("PYTEST_XDIST_WORKER") and fcntl is not None:
        shared = tmp_path_factory.getbasetemp().parent  # one folder per run, all workers
        with open(shared / "docs-site.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            site = shared / "docs-site"
            if not site.exists() and not site.with_suffix(".failed").exists():
                _build(site)
    else:
        site = tmp_path_factory.mktemp("docs") / "site"
        _build(site)
    failed = site.with_suffix(".failed")
    assert not failed.exists(), failed.read_text()
    return site


@needs_docs
def test_site_builds_strictly(site):
    for page in ("reference/scene/index.html", "reference/cli/index.html", "api/index.html",
                 "changelog/index.html", "tutorials/struck_chain/index.html"):
        assert (site / page).is_file(), page
    scene_page = (site / "reference/scene/index.html").read_text().replace("<wbr>", "")
    assert "granules.friction.viscous" in scene_page
    assert list((site / "tutorials").rglob("*.png")), "the tutorials wrote no figures"


class _Tags(HTMLParser):
    """The tags of an HTML page (name and attributes), and the text of each table row."""

    def __init__(self):
        super().__init__()
        self.tags: list[tuple[str, dict]] = []
        self.rows: list[list[str]] = []
        self._cell: list[str] | None = None

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        if tag == "tr":
            self.rows.append([])
        elif tag in ("td", "th"):
            self._cell = []

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            self.rows[-1].append(" ".join("".join(self._cell).split()))
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def _parse(path: Path) -> _Tags:
    parser = _Tags()
    parser.feed(path.read_text(encoding="utf-8"))
    return parser


def _remote(url: str | None) -> bool:
    return bool(url) and re.match(r"^(https?:)?//", url) is not None


@needs_docs
def test_site_loads_nothing_from_the_network(site):
    """Every script and stylesheet of every page is a file of the site (maths included)."""
    pages = sorted(site.rglob("*.html"))
    assert len(pages) > 20
    loaded = set()
    for page in pages:
        for tag, attrs in _parse(page).tags:
            url = attrs.get("src") if tag == "script" else (
                attrs.get("href") if tag == "link" and attrs.get("rel") in ("stylesheet", "preload",
                                                                           "modulepreload") else None)
            if url is None:
                continue
            assert not _remote(url), f"{page.relative_to(site)} loads {url}"
            # 404.html, served for any path, names its files from the site root
            base = site if url.startswith("/") else page.parent
            target = (base / url.split("?")[0].lstrip("/")).resolve()
            assert target.is_file(), f"{page.relative_to(site)}: {url} is not in the site"
            loaded.add(target.name)
    assert {"katex.min.js", "auto-render.min.js", "katex.js", "katex.min.css"} <= loaded
    config = (ROOT / "mkdocs.yml").read_text()
    assert not re.search(r"^\s*-\s*(https?:)?//", config, re.M), "a CDN URL in mkdocs.yml"
    # every font katex.min.css asks for first (WOFF2) is bundled
    css = site / "javascripts/vendor/katex/katex.min.css"
    fonts = set(re.findall(r"url\((fonts/[^)]+\.woff2)\)", css.read_text()))
    assert len(fonts) == 20
    assert all((css.parent / font).is_file() for font in fonts)
    assert (ROOT / "docs/javascripts/vendor/katex/LICENSE").read_text().startswith("The MIT License")


@needs_docs
def test_theory_maths_is_marked_for_katex(site):
    """The theory page's maths is in arithmatex spans the bundled KaTeX typesets."""
    theory = (site / "theory/index.html").read_text()
    assert theory.count('class="arithmatex"') > 20
    assert r"\begin{cases}" in theory


@needs_docs
def test_api_page_renders_docstrings(site):
    """No raw Sphinx roles nor private bases; roles naming documented objects are links."""
    api = (site / "api/index.html").read_text()
    for raw in (":func:", ":class:", ":meth:", ":mod:", ":data:", ":attr:", "_Strict"):
        assert raw not in api, raw
    links = {attrs.get("href") for tag, attrs in _parse(site / "api/index.html").tags
             if tag == "a" and "autorefs-internal" in (attrs.get("class") or "")}
    assert {"#granular_chain.scene.SceneError", "#granular_chain.scene.apply_overrides"} <= links
    # numpy sections rendered as such
    assert "Parameters:" in api and "Returns:" in api


def test_roles_rewrite():
    """Each role form becomes inline code in an optional cross-reference."""
    pytest.importorskip("griffe")
    from docs_build.griffe_roles import rewrite
    text = rewrite(":func:`simulate` and :class:`~granular_chain.result.Result`, "
                   ":attr:`status`, :mod:`granular_chain.scene`", "granular_chain.simulate",
                   scope="granular_chain.result.Result")
    found = re.findall(r'<autoref identifier="([^"]+)" optional><code>([^<]+)</code></autoref>', text)
    assert found == [("granular_chain.simulate.simulate", "simulate()"),
                     ("granular_chain.result.Result", "Result"),
                     ("granular_chain.result.Result.status", "status"),
                     ("granular_chain.scene", "granular_chain.scene")]


@needs_docs
def test_scene_reference_rows_readable(site):
    """Every schema field is a whole row of the built page: six cells, the schema's
    description as text (nothing swallowed as an HTML tag)."""
    schema = scene_reference.scene_schema()
    described = {path: " ".join(prop.get("description", "").split())
                 for path, prop, _ in [*scene_reference.walk(schema),
                                       *scene_reference.recipe_fields(schema)]}
    rows = {row[0]: row for row in _parse(site / "reference/scene/index.html").rows
            if row and row[0] != "field"}
    assert sorted(rows) == sorted(described)
    for path, row in rows.items():
        assert len(row) == 6, (path, row)
        assert row[4] == described[path], (path, row[4], described[path])
    assert "outputs/<name>" in rows["name"][4]
    # a field breaks after a dot only, and the page leaves the tables the whole width
    page = (site / "reference/scene/index.html").read_text()
    assert '<code class="gc-field">walls.<wbr>right.<wbr>motion.<wbr>pulse.<wbr>duration</code>' in page
    assert re.search(r'<div class="md-sidebar md-sidebar--secondary"[^>]*data-md-type="toc" hidden>',
                     page), "the table-of-contents sidebar takes width from the tables"


@needs_docs
def test_landing_page_has_a_figure_and_a_five_minute_path(site):
    page = site / "index.html"
    images = [attrs["src"] for tag, attrs in _parse(page).tags if tag == "img"]
    assert images, "no figure on the landing page"
    for src in images:
        assert (page.parent / src).is_file(), src
    text = page.read_text()
    assert "5-minute path" in text
    for step in ("pip install", "granular-chain run", "trajectory.h5", "Where next"):
        assert step in text, step


def test_tutorials_run_without_a_time_limit(tmp_path, monkeypatch):
    """The build runs a tutorial with no timeout (a cold compile takes minutes)."""
    pytest.importorskip("mkdocs")
    from docs_build import hooks
    seen = {}
    real_run = subprocess.run

    def run(*args, **kwargs):
        seen.update(kwargs)
        return real_run(*args, **kwargs)

    monkeypatch.setattr(hooks.subprocess, "run", run)
    script = tmp_path / "hello.py"
    script.write_text("print('hello')\n")
    assert hooks.run_tutorial(script, tmp_path / "work") == "hello\n"
    assert seen.get("timeout") is None
    assert not hasattr(hooks, "TUTORIAL_TIMEOUT")


def _imports(path: Path) -> set[str]:
    """Top-level modules ``path`` imports, except inside ``try`` (optional imports)."""
    tree = ast.parse(path.read_text())
    optional = {id(n) for t in ast.walk(tree) if isinstance(t, ast.Try)
                for s in t.body for n in ast.walk(s)}
    names = set()
    for node in ast.walk(tree):
        if id(node) in optional:
            continue
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            names.add(node.module.split(".")[0])
    # xarray's engines are imported by name
    names |= set(re.findall(r'engine="(\w+)"', path.read_text()))
    return names


def _docs_requirements() -> set[str]:
    """Distributions ``pip install ".[docs]"`` installs (names normalised), following
    the project's own extras and the installed distributions' requirements."""
    from importlib import metadata

    from packaging.requirements import Requirement
    from packaging.utils import canonicalize_name
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        tomllib = pytest.importorskip("tomli")
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    todo = [Requirement(r) for r in project["optional-dependencies"]["docs"]]
    todo += [Requirement(r) for r in project["dependencies"]]
    names: set[str] = set()
    while todo:
        req = todo.pop()
        name = canonicalize_name(req.name)
        if name == "granular-chain":
            for extra in req.extras:
                todo += [Requirement(r) for r in project["optional-dependencies"][extra]]
            continue
        if name in names:
            continue
        names.add(name)
        try:
            requires = metadata.requires(req.name) or []
        except metadata.PackageNotFoundError:
            continue
        for text in requires:
            sub = Requirement(text)
            if sub.marker is None or any(sub.marker.evaluate({"extra": e})
                                         for e in (req.extras or {""})):
                todo.append(sub)
    return names


def test_docs_extra_holds_what_the_build_imports():
    """Every module docs/tutorials/*.py and docs_build/*.py import comes with [docs]."""
    pytest.importorskip("packaging")
    from importlib import metadata

    from packaging.utils import canonicalize_name
    scripts = [*sorted((ROOT / "docs" / "tutorials").glob("*.py")),
               *sorted((ROOT / "docs_build").glob("*.py"))]
    modules = set().union(*map(_imports, scripts)) - set(sys.stdlib_module_names)
    modules -= {"granular_chain", "docs_build"}
    assert {"matplotlib", "pyvista", "xarray", "h5netcdf", "mkdocs"} <= modules
    providers = metadata.packages_distributions()
    installed = _docs_requirements()
    missing = {m: providers.get(m) for m in modules
               if not {canonicalize_name(d) for d in providers.get(m, [m])} & installed}
    assert not missing, f"imported by the site build, not installed by [docs]: {missing}"


def _chromium() -> str | None:
    return next(filter(None, map(shutil.which, ("chromium", "chromium-browser",
                                                 "google-chrome"))), None)


def _dom(page: Path, width: int = 1280) -> str:
    """The DOM of ``page`` after its scripts ran, in headless Chromium with every
    host name unresolvable (no network)."""
    done = subprocess.run([_chromium(), "--headless", "--no-sandbox", "--disable-gpu",
                           "--host-resolver-rules=MAP * ~NOTFOUND", f"--window-size={width},1000",
                           "--virtual-time-budget=10000", "--dump-dom", page.as_uri()],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


@needs_docs
@pytest.mark.skipif(_chromium() is None, reason="needs headless Chromium (apt-get install chromium)")
def test_browser_renders_maths_offline_and_fits_the_scene_tables(site, tmp_path):
    """In a browser without network: every arithmatex element of the theory page is
    typeset by KaTeX without error, and no scene-reference table is wider than the
    text column (the table frame would clip it)."""
    theory = _dom(site / "theory" / "index.html")
    spans = theory.count('class="arithmatex"')
    assert spans > 100
    assert theory.count('class="katex"') == spans, "maths left as raw TeX"
    assert theory.count('class="katex-display"') == theory.count('<div class="arithmatex"') > 5
    assert "katex-error" not in theory
    # a copy of the page that records, once laid out, how many tables overflow their frame
    # (a copy outside the site, its relative links resolved against the page's folder;
    # measured after load: Material wraps the tables in their frame from its script)
    page = site / "reference" / "scene" / "index.html"
    probe = tmp_path / "probe.html"
    probe.write_text(page.read_text().replace(
        "<head>", f'<head><base href="{page.parent.as_uri()}/">', 1).replace("</body>", """<script>
    window.addEventListener("load", () => setTimeout(() => {
      const text = document.querySelector("article").getBoundingClientRect();
      const tables = [...document.querySelectorAll("article table")];
      const wide = tables.filter(t => t.scrollWidth > t.clientWidth + 1
                                      || t.getBoundingClientRect().right > text.right + 1);
      document.body.setAttribute("data-tables", tables.length);
      document.body.setAttribute("data-overflowing", wide.length);
    }, 100));
    </script></body>"""))
    for width in (1280, 1024):
        dom = _dom(probe, width)
        assert int(re.search(r'data-tables="(\d+)"', dom).group(1)) == 8
        assert re.search(r'data-overflowing="(\d+)"', dom).group(1) == "0", width
