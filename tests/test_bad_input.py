"""The bad-input matrix: every case exits 2 with one line naming the field or flag.

Each case writes its files into tmp_path, runs ``granular_chain.cli.main`` in
this process (cwd = tmp_path, so default outputs/ would land there) and asserts:
exit status 2, exactly one stderr line starting "granular-chain:", naming the
field or flag, no traceback, and tmp_path unchanged (names, mtimes, hashes).
Memory is planned with 4 GiB (budget.available_memory patched), so the memory
cases do not depend on the machine. argparse's own errors (usage + error line)
are in a separate test. ``benchmarks/robustness_matrix.py bad-input`` prints the
same cases as a table.
"""

from __future__ import annotations

import copy
import hashlib
import os
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import yaml

from granular_chain import budget
from granular_chain.cli import main

ROOT = Path(__file__).resolve().parents[1]
MEMORY = 4 * 2 ** 30

BASE = {
    "name": "base",
    "granules": {"count": 3, "mass": 1.0, "radius": 0.5, "gap": 0.0,
                 "velocity": [1.0, 0.0, 0.0],
                 "friction": {"kinetic": 0.0, "static": 0.0, "viscous": 0.0}},
    "contacts": {"exponent": 2.0, "stiffness": 1.0},
    "walls": {"left": {"gap": 0.1, "stiffness": 1.0, "exponent": 2.0}},
    "run": {"stepper": "verlet", "dt": 0.01, "t_end": 1.0, "max_steps": 1_000_000,
            "stop_contact": 0},
    "output": {"every": 10, "trajectory": False},
}
HERTZ = {"contacts": {"exponent": 2.5, "stiffness": "hertz"},
         "granules.material": {"young": 1.0, "poisson": 0.3}}
_DELETE = object()


@dataclass
class Case:
    id: str
    argv: list  # "{dir}" is replaced by tmp_path, "{run}" by a finished run folder
    expect: list  # substrings of the one stderr line (the field or flag)
    files: dict = field(default_factory=dict)  # name -> str or bytes
    category: str = ""
    expected: str = "refused"  # what the docs table says should happen
    budget: bool = False  # refused by check_budget (after cmd_run has made outputs/)


def scene(**changes) -> dict:
    """BASE with dotted-path changes (``granules__mass=...`` or a dict of paths)."""
    data = copy.deepcopy(BASE)
    for path, value in changes.items():
        parts = path.replace("__", ".").split(".")
        target = data
        for p in parts[:-1]:
            target = target.setdefault(p, {})
        if value is _DELETE:
            target.pop(parts[-1], None)
        else:
            target[parts[-1]] = value
    return data


def dump(data) -> str:
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=False)


CASES: list[Case] = []


def add(id, argv, expect, files=None, category="", budget=False):
    CASES.append(Case(id, argv, [expect] if isinstance(expect, str) else expect,
                      files or {}, category, budget=budget))


def add_scene(id, data_or_text, expect, commands=("run",), category="scene", budget=False):
    text = data_or_text if isinstance(data_or_text, (str, bytes)) else dump(data_or_text)
    for cmd in commands:
        add(f"{cmd}-{id}", [cmd, "{dir}/s.yaml"], expect, {"s.yaml": text}, category,
            budget=budget)


# --- every numeric field x wrong types and values -------------------------------
PER_GRANULE = ["granules.mass", "granules.radius", "granules.velocity",
               "granules.friction.kinetic", "granules.friction.static",
               "granules.friction.viscous"]
PER_CONTACT = ["granules.gap", "contacts.exponent", "contacts.stiffness"]
SCALARS = ["walls.left.gap", "walls.left.stiffness", "walls.left.exponent", "run.dt",
           "run.t_end", "run.rtol", "run.atol", "output.dt"]
INTEGERS = ["granules.count", "run.stop_contact", "run.max_steps", "run.max_events",
            "output.every"]
EVENT_ONLY = {"run.rtol", "run.atol", "run.max_events"}
BAD_VALUES = {"bool": True, "string": "1", "null": None, "nan": float("nan"),
              "inf": float("inf"), "negative": -1, "zero": 0, "list": None}
# (field, value name) pairs that are valid scenes: not bad input
VALID = {("granules.velocity", "negative"), ("granules.velocity", "zero"),
         ("granules.gap", "zero"), ("walls.left.gap", "zero"),
         ("granules.friction.kinetic", "zero"), ("granules.friction.static", "zero"),
         ("granules.friction.viscous", "zero"), ("granules.friction.static", "null"),
         ("run.dt", "null"), ("output.dt", "null"), ("output.every", "null"),
         ("run.stop_contact", "zero")}

for path in PER_GRANULE + PER_CONTACT + SCALARS + INTEGERS:
    for kind, value in BAD_VALUES.items():
        if (path, kind) in VALID:
            continue
        if kind == "list":
            value = [1.0, 2.0, 3.0, 4.0] if path in PER_CONTACT else [1.0, 2.0]
        changes = {path: value}
        if path in EVENT_ONLY:  # fields of an event stepper's run only
            changes = {"run.stepper": "event", "run.dt": _DELETE,
                       **changes}
        if path == "output.dt":
            changes["output.every"] = _DELETE
        add_scene(f"{path}-{kind}", scene(**changes), path, category="types")

for path in ["output.trajectory", "output.vtk", "output.csv", "output.plots", "run.check_dt"]:
    for kind, value in {"int": 1, "string": "yes", "null": None, "float": 0.5}.items():
        add_scene(f"{path}-{kind}", scene(**{path: value}), path, category="types")

for path, value in [("run.stepper", "rk4"), ("run.stepper", 1), ("run.stepper", None),
                    ("units", "si"), ("units", True), ("run.stop", "never"),
                    ("run.stop", ["t_end"]), ("run.stop", 1),
                    ("granules.velocity", {"a": 1.0}), ("granules.velocity", {"true": 1.0}),
                    ("granules.velocity", "fast"), ("contacts.stiffness", "herts")]:
    add_scene(f"{path}-{value!r}", scene(**{path: value}), path, category="types")

# --- options the chosen stepper would ignore (scene.STEPPER_OPTIONS) -------------
EVENT = {"run.stepper": "event", "run.dt": _DELETE}
for id, changes, expect in [
        ("event-dt", {"run.stepper": "event"}, "run.dt"),
        ("event-check-dt", {**EVENT, "run.check_dt": False}, "run.check_dt"),
        ("event-output-events", {**EVENT, "output.events": True}, "output.events"),
        ("event-output-thermo", {**EVENT, "output.thermo": 5}, "output.thermo"),
        ("verlet-rtol", {"run.rtol": 1e-10}, "run.rtol"),
        ("verlet-atol", {"run.atol": 1e-10}, "run.atol"),
        ("verlet-max-events", {"run.max_events": 1000}, "run.max_events")]:
    owner = "event" if id.startswith("verlet") else "verlet"
    add_scene(f"stepper-{id}", scene(**changes),
              [f"s.yaml: {expect}: is read by the {owner} stepper only", "would be ignored"],
              commands=("run", "validate"), category="stepper options")
for cmd in ("run", "validate"):  # switching the stepper of a Verlet scene with a dt
    add(f"{cmd}-set-stepper-event", [cmd, "{dir}/s.yaml", "--set", "run.stepper=event"],
        ["run.dt: is read by the verlet stepper only", "set it to null"], {"s.yaml": dump(BASE)},
        category="stepper options")

# --- names that are paths or not names ------------------------------------------
for i, name in enumerate(["/some/folder", "../../home", "a/b", "a\\b", "a\0b", "tab\tname",
                          "new\nline", "", "   ", ".", "..", ".hidden", "x" * 300, 123, None,
                          ["a"], True]):
    add_scene(f"name-{i}-{name!r}"[:60], scene(name=name), "name", category="names")

# --- unknown fields and consistency ---------------------------------------------
for path in ["granule", "granules.masss", "run.dtt", "output.vtkk", "contacts.stifness",
             "walls.middle", "granules.friction.static_", "walls.left.k"]:
    add_scene(f"unknown-{path}", scene(**{path: 1}), path, category="fields")
for id, changes, expect in [
        ("velocity-index", {"granules.velocity": {5: 1.0}}, "granules.velocity[5]"),
        ("stop-contact", {"run.stop": "separation", "run.stop_contact": 5}, "run.stop_contact"),
        ("hertz-no-material", {"contacts.stiffness": "hertz", "contacts.exponent": 2.5},
         "contacts.stiffness"),
        ("hertz-exponent", {"contacts.stiffness": "hertz", "granules.material":
                            {"young": 1.0, "poisson": 0.3}}, "contacts.exponent"),
        ("static-below-kinetic", {"granules.friction.kinetic": 0.5,
                                  "granules.friction.static": 0.1}, "granules.friction.static"),
        ("every-and-dt", {"output.dt": 0.1}, "output"),
        ("wall-overlap", {"walls.left.gap": -0.6}, "walls.left.gap"),
        ("missing-granules", {"granules": _DELETE}, "granules"),
        ("missing-count", {"granules.count": _DELETE}, "granules.count"),
        ("granules-null", {"granules": None}, "granules"),
        ("run-list", {"run": [1, 2]}, "run"),
        ("poisson-0.5", {**HERTZ, "granules.material": {"young": 1.0, "poisson": 0.5}},
         "granules.material.poisson"),
        ("poisson-string", {**HERTZ, "granules.material": {"young": 1.0, "poisson": "0.3"}},
         "granules.material.poisson"),
        ("young-negative", {**HERTZ, "granules.material": {"young": -1.0, "poisson": 0.3}},
         "granules.material.young"),
        ("young-bool", {**HERTZ, "granules.material": {"young": True, "poisson": 0.3}},
         "granules.material.young")]:
    add_scene(id, scene(**changes), expect, category="consistency")

# --- physical extremes (run and validate) ---------------------------------------
EXTREMES = [
    ("mass-5e-324", {"granules.mass": 5e-324}, "granules.mass"),
    ("mass-1e-300", {"granules.mass": 1e-300}, "granules.mass"),
    ("mass-1e300", {"granules.mass": 1e300}, "granules.mass"),
    ("mass-list-1e-300", {"granules.mass": [1.0, 1e-300, 1.0]}, "granules.mass[1]"),
    ("gap-1e300", {"granules.gap": 1e300}, "granules.gap"),
    ("gap-1e14", {"granules.gap": 1e14}, "granules.gap"),
    ("radius-1e-300", {"granules.radius": 1e-300}, "granules.radius"),
    ("radius-1e300", {"granules.radius": 1e300}, "granules.radius"),
    ("stiffness-negative", {"contacts.stiffness": -1}, ["contacts.stiffness", "must be positive"]),
    ("stiffness-1e300", {"contacts.stiffness": 1e300}, "contacts.stiffness"),
    ("stiffness-1e-300", {"contacts.stiffness": 1e-300}, "contacts.stiffness"),
    ("stiffness-1e150-steps", {"contacts.stiffness": 1e150, "run.dt": _DELETE,
                               "walls": {}}, ["run.max_steps", "= 1000000"]),
    ("stiffness-1e150-event", {"contacts.stiffness": 1e150, "run.stepper": "event",
                               "run.dt": _DELETE, "walls": {}}, ["run.t_end", "2^52"]),
    ("wall-stiffness-1e-300", {"walls.left.stiffness": 1e-300}, "walls.left.stiffness"),
    ("mass-stiffness-ratio", {"granules.mass": 2.0 ** -511, "contacts.stiffness": 2.0 ** 511},
     "contacts.stiffness"),
    ("velocity-1e300", {"granules.velocity": [1e300, 0.0, 0.0]}, "granules.velocity"),
    ("young-1e300", {**HERTZ, "granules.material": {"young": 1e300, "poisson": 0.3}},
     "granules.material.young"),
    ("count-0", {"granules.count": 0, "granules.velocity": 0.0}, "granules.count"),
    ("count-1e9-float", {"granules.count": 1e9}, ["granules.count", "whole number"]),
    ("count-1e9", {"granules.count": 1_000_000_000, "granules.velocity": {0: 1.0}},
     ["granules.count", "GB"]),
    ("count-3e7", {"granules.count": 30_000_000, "granules.velocity": {0: 1.0}},
     ["granules.count", "GB"]),
    ("count-3e7-event", {"granules.count": 30_000_000, "granules.velocity": {0: 1.0},
                         "run.stepper": "event", "run.dt": _DELETE}, ["granules.count", "GB"]),
    ("steps", {"run.t_end": 1e6, "run.dt": 1e-6}, ["run.max_steps", "1e+12", "1000000"]),
    ("steps-max-steps-10", {"run.max_steps": 10}, ["run.max_steps", "100", "10"]),
    ("dt-above-t_end", {"run.dt": 2.0, "run.t_end": 1.0, "contacts.stiffness": 1e-4,
                        "walls": {}}, ["run.dt", "run.t_end = 1"]),
    ("frames-every-1", {"run.t_end": 1e7, "run.max_steps": 2_000_000_000, "output.every": 1},
     ["output.every", "GB", "set output.every"]),
    ("frames-output-dt", {"run.t_end": 1e7, "run.max_steps": 2_000_000_000,
                          "output.every": _DELETE, "output.dt": 0.01},
     ["output.every", "set output.every"]),
    ("damping-restitution-hertz", {"contacts.exponent": 2.5,
                                   "contacts.damping": {"model": "restitution", "value": 0.8}},
     ["contacts.damping.speed", "needs speed", "depends on the speed"]),
    ("damping-no-coefficient", {"contacts.damping": {"model": "linear"}},
     ["contacts.damping.coefficient", "needs coefficient"]),
    ("damping-events-verlet", {"contacts.damping": {"model": "linear", "coefficient": 0.1},
                               "output.events": True}, ["output.events", "run.stepper: event"]),
    ("wall-two-motions", {"walls.left": {"motion": {"velocity": 1.0, "pulse": {
        "velocity": 1.0, "duration": 1.0}}}}, ["walls.left.motion", "exactly one"]),
    ("body-force-length", {"body_force": {"force": [1.0, 2.0]}},
     ["body_force.force", "granules.count"]),
]
# refused by check_budget (memory, steps, derived scales), not by the schema
BUDGET = {"gap-1e300", "gap-1e14", "stiffness-1e150-steps", "stiffness-1e150-event",
          "mass-stiffness-ratio", "velocity-1e300", "count-1e9", "count-3e7", "count-3e7-event",
          "steps", "steps-max-steps-10", "dt-above-t_end", "frames-every-1", "frames-output-dt"}
for id, changes, expect in EXTREMES:
    add_scene(id, scene(**changes), expect, commands=("run", "validate"), category="extremes",
              budget=id in BUDGET)

# --- YAML edge cases (run and validate) -----------------------------------------
LAUGHS = "a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + "".join(
    f"{c}: &{c} [{', '.join(['*' + p] * 10)}]\n" for p, c in zip("abcdefgh", "bcdefghi"))
GOOD = dump(BASE)
YAML_CASES = [
    ("billion-laughs", LAUGHS, ["aliases expand", "line"]),
    ("deep-nesting", "a: " + "[" * 200 + "]" * 200 + "\n", ["nested deeper", "line 1"]),
    ("recursive-alias", "granules: &g\n  count: 2\n  more: *g\n", "recursive alias"),
    ("undefined-alias", "granules: *nothing\n", "invalid YAML at line 1"),
    ("duplicate-top", GOOD + "name: again\n", ["name: duplicate key", "line 1"]),
    ("duplicate-nested", GOOD.replace("  mass: 1.0\n", "  mass: 1.0\n  mass: 2.0\n"),
     ["granules.mass: duplicate key at line 5", "first at line 4"]),
    ("duplicate-deep", GOOD.replace("    kinetic: 0.0\n", "    kinetic: 0.0\n    kinetic: 0.1\n"),
     ["granules.friction.kinetic: duplicate key"]),
    ("duplicate-walls", GOOD.replace("    stiffness: 1.0\n    exponent: 2.0\n",
                                     "    stiffness: 1.0\n    exponent: 2.0\n    gap: 0.3\n"),
     "walls.left.gap: duplicate key"),
    ("duplicate-velocity-index", dump(scene(**{"granules.velocity": {0: 1.0}})).replace(
        "    0: 1.0\n", "    0: 1.0\n    0: 2.0\n"), "granules.velocity.0: duplicate key"),
    ("too-large", GOOD + ("#" * 1000 + "\n") * 1100, ["larger than 1048576 bytes", "1 MiB"]),
    ("tab-indent", "granules:\n\tcount: 2\n", "invalid YAML at line 2"),
    ("unclosed-bracket", "granules: [\n", "invalid YAML"),
    ("two-documents", GOOD + "---\n" + GOOD, "invalid YAML"),
    ("top-level-list", "- 1\n- 2\n", "a scene must be a mapping"),
    ("top-level-scalar", "42\n", "a scene must be a mapping"),
    ("empty", "", "the file is empty"),
    ("comments-only", "# nothing\n", "the file is empty"),
    ("only-document-marker", "---\n", "the file is empty"),
    ("binary", b"\x89PNG\r\n\x1a\n\x00\x00\xff\xfe", "not a UTF-8 text file"),
    ("nul-character", "granules:\n  count: 2\x00\n", "invalid YAML"),
    ("python-tag", "granules: !!python/object/apply:os.system ['true']\n", "invalid YAML"),
    ("unknown-tag", "granules: !foo 1\n", "invalid YAML"),
    ("quoted-number", GOOD.replace("mass: 1.0", "mass: '1.0'"), ["granules.mass", "string"]),
    ("yaml11-yes", GOOD.replace("mass: 1.0", "mass: yes"), ["granules.mass", "boolean"]),
    ("quoted-exponent", GOOD.replace("mass: 1.0", "mass: '1e-3'"), ["granules.mass", "string"]),
    ("count-exponent", GOOD.replace("count: 3", "count: 3e0"), ["granules.count", "whole number"]),
    ("count-decimal", GOOD.replace("count: 3", "count: 3.0"), ["granules.count", "whole number"]),
    ("timestamp", GOOD.replace("t_end: 1.0", "t_end: 2001-12-14"), ["run.t_end", "number"]),
    ("invalid-utf8", GOOD.encode() + b"# \xc3\x28\n", "not a UTF-8 text file"),
    ("non-string-key", GOOD + "1: 2\n", "Keys should be strings"),
]
for id, text, expect in YAML_CASES:
    add_scene(id, text, expect, commands=("run", "validate"), category="yaml")
for cmd in ("run", "validate"):
    add(f"{cmd}-missing-file", [cmd, "{dir}/nope.yaml"], "nope.yaml: no such file",
        category="files")
    add(f"{cmd}-directory", [cmd, "{dir}/folder"], "is a folder",
        {"folder/keep.txt": "x"}, category="files")

# --- --set overrides --------------------------------------------------------------
SETS = [("no-equals", "run.dt", "dotted.path=value"), ("empty-path", "=1", "empty field name"),
        ("empty-part", "run..dt=1", "empty field name"), ("bad-yaml", "run.dt=[", "not valid YAML"),
        ("not-a-group", "granules.mass.x=1", "'mass' is not a group"),
        ("unknown", "run.dtt=1", "run.dtt: unknown field"), ("bool", "run.dt=true", "run.dt"),
        ("quoted", "run.dt='1'", "run.dt"), ("name-path", "name=../x", "name"),
        ("count-float", "granules.count=1e9", "granules.count"),
        ("alias", "run.dt=*a", "not valid YAML"), ("mass-tiny", "granules.mass=1e-300",
                                                    "granules.mass"),
        ("negative-stiffness", "contacts.stiffness=-1", "must be positive"),
        ("index-not-a-list", "run.dt[0]=1", ["run.dt[0]", "'dt' is not a list"]),
        ("index-out-of-range", "granules.mass[3]=2", ["granules.mass[3]", "out of range"])]
for id, item, expect in SETS:
    for cmd in ("run", "validate"):
        add(f"{cmd}-set-{id}", [cmd, "{dir}/s.yaml", "--set", item], expect,
            {"s.yaml": GOOD}, category="--set")

# --- sweep --------------------------------------------------------------------------
SW = ["sweep", "{dir}/s.yaml", "--serial", "--quiet"]
for id, extra, expect in [
        ("no-axes", [], "--grid or --list"),
        ("grid-syntax", ["--grid", "run.dt"], "--grid"),
        ("grid-two-parts", ["--grid", "run.dt=1:2"], "--grid"),
        ("grid-not-numbers", ["--grid", "run.dt=a:b:3"], "--grid"),
        ("grid-num-zero", ["--grid", "run.dt=0.1:1:0"], "--grid"),
        ("grid-num-float", ["--grid", "run.dt=0.1:1:2.5"], "--grid"),
        ("grid-log-zero", ["--grid", "run.dt=0:1:3:log"], "--grid"),
        ("grid-bad-mode", ["--grid", "run.dt=0.1:1:3:lin"], "--grid"),
        ("duplicate-axes", ["--grid", "run.dt=0.1:1:3", "--list", "run.dt=0.1,0.2"],
         "same dotted path"),
        ("list-syntax", ["--list", "run.dt"], "--list"),
        ("list-bad-yaml", ["--list", "run.dt=[1,"], "--list"),
        ("mask-syntax", ["--list", "run.dt=0.1", "--mask", "status"], "--mask"),
        ("set-syntax", ["--list", "run.dt=0.1", "--set", "noequals"], "dotted.path=value")]:
    add(f"sweep-{id}", SW + extra, expect, {"s.yaml": GOOD}, category="sweep")
add("sweep-missing-scene", ["sweep", "{dir}/nope.yaml", "--serial", "--list", "run.dt=0.1"],
    "nope.yaml", category="sweep")
add("sweep-scene-not-mapping", SW + ["--list", "run.dt=0.1"], "must be a mapping",
    {"s.yaml": "- 1\n"}, category="sweep")

# --- plot and diagnose --------------------------------------------------------------
add("plot-missing-dir", ["plot", "{dir}/no_run"], "no trajectory.h5", category="plot")
add("plot-file-not-dir", ["plot", "{dir}/s.yaml"], "no trajectory.h5", {"s.yaml": GOOD},
    category="plot")
add("plot-empty-dir", ["plot", "{dir}/folder"], "no trajectory.h5", {"folder/x": "1"},
    category="plot")
add("plot-granules-text", ["plot", "{run}", "--granules", "a,b"], "--granules", category="plot")
add("plot-granules-range", ["plot", "{run}", "--granules", "0,99"], "--granules", category="plot")
add("plot-granules-negative", ["plot", "{run}", "--granules", "-1"], "--granules",
    category="plot")
add("diagnose-missing", ["diagnose", "{dir}/nope.yaml"], "no such file", category="diagnose")
add("diagnose-empty-dir", ["diagnose", "{dir}/folder"], "no trajectory.h5", {"folder/x": "1"},
    category="diagnose")
add("diagnose-set-on-run", ["diagnose", "{run}", "--set", "run.dt=1"], "--set",
    category="diagnose")
add("diagnose-bad-field", ["diagnose", "{dir}/s.yaml"], "granules.mass",
    {"s.yaml": dump(scene(**{"granules.mass": -1}))}, category="diagnose")
add("diagnose-mass-5e-324", ["diagnose", "{dir}/s.yaml"], "granules.mass",
    {"s.yaml": dump(scene(**{"granules.mass": 5e-324}))}, category="diagnose")
add("diagnose-steps", ["diagnose", "{dir}/s.yaml"], "run.max_steps",
    {"s.yaml": dump(scene(**{"run.dt": 1e-9}))}, category="diagnose")

ARGPARSE = [
    ("no-command", [], "required"), ("unknown-command", ["frobnicate"], "invalid choice"),
    ("run-unknown-flag", ["run", "s.yaml", "--frobnicate"],
                                          "--frobnicate"),
    ("run-vtk-value", ["run", "s.yaml", "--vtk=1"], "--vtk"),
    ("plot-time-text", ["plot", "x", "--time", "abc"], "--time"),
    ("diagnose-first-text", ["diagnose", "x", "--first", "x"], "--first"),
    ("sweep-workers-text", ["sweep", "s.yaml", "--workers", "two"], "--workers"),
    ("validate-two-scenes", ["validate", "a.yaml", "b.yaml"], "unrecognized"),
    ("figures-grid-text", ["figures", "--out", "x", "--grid", "many"], "--grid"),
]


def snapshot(folder: Path) -> dict:
    """Every path under ``folder`` with its mtime and content hash."""
    out = {}
    for p in sorted(folder.rglob("*")):
        st = p.lstat()
        digest = hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir"
        out[str(p.relative_to(folder))] = (st.st_mtime_ns, digest)
    return out


def _write(folder: Path, files: dict) -> None:
    for name, content in files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content, encoding="utf-8")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """A finished run with trajectory.h5 (for plot/diagnose cases)."""
    folder = tmp_path_factory.mktemp("finished")
    (folder / "s.yaml").write_text(dump(scene(**{"output.trajectory": True, "walls": {}})))
    assert main(["run", str(folder / "s.yaml"), "--out", str(folder / "run"), "--quiet"]) == 0
    return folder / "run"


def run_case(case: Case, folder: Path, run: Path, capsys) -> tuple:
    """(exit status, stderr) of one case, run in ``folder``."""
    argv = [a.replace("{dir}", str(folder)).replace("{run}", str(run)) for a in case.argv]
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    return code, capsys.readouterr().err


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input_is_refused(case, tmp_path, capsys, monkeypatch, request):
    run = request.getfixturevalue("run_dir") if "{run}" in " ".join(case.argv) else Path("-")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(budget, "available_memory", lambda: MEMORY)
    _write(tmp_path, case.files)
    before = snapshot(tmp_path)
    run_before = snapshot(run) if run.exists() else None
    code, err = run_case(case, tmp_path, run, capsys)
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1, err
    assert lines[0].startswith("granular-chain: "), err
    assert "Traceback" not in err
    for fragment in case.expect:
        assert fragment in lines[0], (fragment, lines[0])
    after = snapshot(tmp_path)
    assert after == before
    if run_before is not None:
        assert snapshot(run) == run_before


@pytest.mark.parametrize("argv, flag", [a[1:] for a in ARGPARSE], ids=[a[0] for a in ARGPARSE])
def test_argparse_errors_exit_2_naming_the_flag(argv, flag, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert err.strip().splitlines()[-1].startswith("granular-chain")
    assert flag in err.strip().splitlines()[-1] and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_matrix_has_at_least_250_cases():
    assert len([c for c in CASES if not (c.budget and c.argv[0] == "run")]) >= 250
    assert len({c.id for c in CASES}) == len(CASES)


def test_base_scene_is_valid(tmp_path, capsys):
    """The matrix changes one thing of a valid scene: the base itself validates."""
    (tmp_path / "s.yaml").write_text(GOOD)
    assert main(["validate", str(tmp_path / "s.yaml")]) == 0


@pytest.mark.parametrize("id", ["billion-laughs", "duplicate-nested", "mass-5e-324",
                                "count-1e9-float"])
def test_console_no_traceback(id, tmp_path):
    """End to end in a subprocess: exit 2, one line, no traceback, well under a second
    of work for the alias bomb (bounded by the 30 s hang guard)."""
    case = next(c for c in CASES if c.id in (f"run-{id}",))
    _write(tmp_path, case.files)
    before = snapshot(tmp_path)
    argv = [a.replace("{dir}", str(tmp_path)) for a in case.argv]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    p = subprocess.run([sys.executable, "-m", "granular_chain.cli", *argv], cwd=tmp_path,
                       capture_output=True, text=True, env=env, timeout=30)
    assert p.returncode == 2, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and "Traceback" not in p.stderr
    assert all(f in p.stderr for f in case.expect)
    assert snapshot(tmp_path) == before


def test_step_plan_keeps_a_dividing_dt_bit_for_bit():
    from granular_chain.model import build_model
    from granular_chain.scene import scene_from_dict
    from granular_chain.steppers.verlet.timestep import step_plan
    from granular_chain.steppers.verlet.timestep import default_dt

    def plan(t_end, dt=None, k=1.0):
        sc = scene_from_dict(scene(**{"run.t_end": t_end, "run.dt": dt, "contacts.stiffness": k,
                                      "run.accept_inaccurate_dt": True, "run.check_dt": False}))
        return step_plan(build_model(sc), sc)

    for t_end, dt, steps in ((1.0, 0.01, 100), (20.0, 1e-4, 200_000), (0.3, 0.1, 3)):
        p = plan(t_end, dt)  # (3 * 0.1 = 0.30000000000000004: within 1e-9 dt of 0.3)
        assert (p.dt, p.steps, p.last_dt, p.total_steps) == (dt, steps, 0.0, steps)
    p = plan(10.0, 0.03)  # 333 steps of 0.03 and one of 0.01 end at t_end
    assert (p.dt, p.steps, p.total_steps) == (0.03, 333, 334)
    assert p.last_dt == pytest.approx(0.01, rel=1e-12) and p.steps * p.dt + p.last_dt == 10.0
    for t_end, k in ((10.0, 1.0), (7.3, 3.7), (1e3, 1e4)):
        sc = scene_from_dict(scene(**{"run.t_end": t_end, "contacts.stiffness": k,
                                      "run.dt": None}))
        model = build_model(sc)
        p = step_plan(model, sc)
        assert p.dt == default_dt(model, t_end) and p.last_dt == 0.0


def test_summary_json_has_null_and_a_reason_for_non_finite(tmp_path):
    import json
    import math

    from granular_chain.writers.summary import write_summary

    class Fake:
        def summary(self):
            return {"energy": {"kinetic": math.inf, "balance_error": math.nan},
                    "v_final": [1.0, -math.inf]}

    data = json.loads(write_summary(Fake(), tmp_path).read_text())
    assert data["energy"] == {"kinetic": None, "balance_error": None}
    assert data["v_final"] == [1.0, None]
    assert data["non_finite"] == {"energy.kinetic": "inf: overflowed double precision",
                                  "energy.balance_error": "nan: undefined (e.g. inf - inf)",
                                  "v_final[1]": "-inf: overflowed double precision"}


def test_memory_refusal_names_a_cadence_that_fits():
    """The suggested output.every, applied, passes the same memory check."""
    from granular_chain.scene import scene_from_dict
    from granular_chain.simulate import SimulationError

    data = scene(**{"run.t_end": 1e6, "run.max_steps": 2_000_000_000, "output.every": 1})
    with pytest.raises(SimulationError, match=r"output.every: .* set output.every: (\d+)") as exc:
        budget.check_budget(scene_from_dict(data), available=MEMORY)
    every = int(exc.value.args[0].split("set output.every: ")[1].split()[0])
    data["output"]["every"] = every
    b = budget.check_budget(scene_from_dict(data), available=MEMORY)
    assert b.total <= MEMORY and b.steps == 100_000_000
    data["output"]["every"] = max(1, every // 2)
    with pytest.raises(SimulationError):
        budget.check_budget(scene_from_dict(data), available=MEMORY)


def test_yaml_that_is_fine_still_loads(tmp_path):
    """Anchors within the limit, merge keys, 1e-3 numbers and int-for-float stay valid."""
    from granular_chain.scene import load_scene

    path = tmp_path / "ok.yaml"
    path.write_text("wall: &w {gap: 1e-1, stiffness: 2, exponent: 2.5}\n"
                    "granules: {count: 3, mass: 1, velocity: {0: 1e0}, radius: [0.5, 0.5, 0.5]}\n"
                    "contacts: {exponent: 2.5}\n"
                    "walls: {left: *w, right: {<<: *w, gap: 2e-1}}\n"
                    "run: {dt: 1e-3, t_end: 1}\n"
                    "output: {every: 10}\n".replace("wall: &w", "name: ok\nx-wall: &w"))
    with pytest.raises(Exception, match="x-wall: unknown field"):
        load_scene(path)  # the anchor holder itself is not a scene field
    path.write_text(path.read_text().replace("x-wall: &w {gap: 1e-1, stiffness: 2, exponent: 2.5}\n", "")
                    .replace("left: *w", "left: &w {gap: 1e-1, stiffness: 2, exponent: 2.5}"))
    s = load_scene(path)
    assert s.run.dt == 1e-3 and s.granules.mass == 1.0 and s.granules.velocity == {0: 1.0}
    assert (s.walls.right.gap, s.walls.right.stiffness, s.walls.left.gap) == (0.2, 2.0, 0.1)


def test_each_stepper_takes_its_own_options_and_ignores_the_others():
    """The split of STEPPER_OPTIONS is the engines': each stepper accepts its own
    options, and a finished run's record holding the other stepper's (read back
    with ``stored=True``, as older runs may) gives the same bits as without them,
    so those options really are not read."""
    from granular_chain import simulate
    from granular_chain.scene import STEPPER_OPTIONS, scene_from_dict

    assert set(STEPPER_OPTIONS) == {"verlet", "event"}
    event = {"run.stepper": "event", "run.dt": _DELETE, "walls": {}}
    own = scene_from_dict(scene(**event, **{"run.rtol": 1e-10, "run.max_events": 50}))
    assert (own.run.rtol, own.run.max_events) == (1e-10, 50)
    own = scene_from_dict(scene(**{"run.check_dt": False, "output.events": True,
                                   "output.thermo": 5}))
    assert own.output.thermo == 5 and own.output.events
    for plain, foreign in (
            (event, {**event, "run.dt": 0.5, "run.check_dt": False}),
            ({"walls": {}}, {"walls": {}, "run.rtol": 1e-3, "run.atol": 1e-3,
                             "run.max_events": 1})):
        a = simulate(scene_from_dict(scene(**plain)), progress=False)
        b = simulate(scene_from_dict(scene(**foreign), stored=True), progress=False)
        assert a.status == b.status and a.steps == b.steps and a.t.size == b.t.size
        for name in ("t", "x", "v", "f"):
            assert getattr(a, name).tobytes() == getattr(b, name).tobytes(), name


def test_run_is_one_stepper_and_holds_its_options_only():
    """``run`` is the member of its stepper (a union told apart by ``run.stepper``): the
    other stepper's options are not fields of it, so reading one is an AttributeError
    and setting one is refused by name. Null unsets an option, which is how a Verlet
    scene with a dt switches stepper on the command line."""
    from granular_chain.scene import RunEvent, RunVerlet, load_scene, scene_from_dict

    verlet = scene_from_dict(scene())
    event = scene_from_dict(scene(**{"run.stepper": "event", "run.dt": _DELETE}))
    assert type(verlet.run) is RunVerlet and type(event.run) is RunEvent
    assert set(RunVerlet.model_fields) - set(RunEvent.model_fields) == {
        "dt", "check_dt", "accept_inaccurate_dt"}
    assert set(RunEvent.model_fields) - set(RunVerlet.model_fields) == {
        "rtol", "atol", "max_events"}
    with pytest.raises(AttributeError):
        verlet.run.rtol
    with pytest.raises(AttributeError):
        event.run.dt
    assert "rtol" not in verlet.model_dump()["run"] and "dt" not in event.model_dump()["run"]
    assert type(scene_from_dict({"granules": {"count": 2}}).run) is RunVerlet  # the default
    with pytest.raises(ValueError, match="run.rtol: is read by the event stepper only"):
        verlet.run.model_validate({"stepper": "verlet", "rtol": 1e-9})


def test_stepper_switched_on_the_command_line_with_its_step_unset(tmp_path):
    from granular_chain.scene import RunEvent, load_scene

    path = tmp_path / "s.yaml"
    path.write_text(dump(BASE))
    switched = load_scene(path, ["run.stepper=event", "run.dt=null", "run.rtol=1e-10"])
    assert type(switched.run) is RunEvent and switched.run.rtol == 1e-10
    assert switched.model_dump()["run"]["stepper"] == "event"


def test_json_schema_offers_each_stepper_with_its_own_options():
    from granular_chain.scene import scene_json_schema

    schema = scene_json_schema()
    members = [ref["$ref"].rsplit("/", 1)[1] for ref in schema["properties"]["run"]["oneOf"]]
    assert members == ["RunVerlet", "RunEvent"]
    verlet, event = (schema["$defs"][m]["properties"] for m in members)
    assert verlet["stepper"]["const"] == "verlet" and event["stepper"]["const"] == "event"
    assert "dt" in verlet and "dt" not in event and "rtol" in event and "rtol" not in verlet
