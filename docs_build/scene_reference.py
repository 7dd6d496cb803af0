"""The scene reference page, generated from the pydantic schema of scene files.

Every field of ``granular_chain.scene.Scene.model_json_schema()`` becomes one row:
dotted path, type, default, units, description and an example. Descriptions,
types, defaults and bounds come from the schema; examples from the scene files
under ``scenarios/`` where one sets the field. Units are not yet part of the
schema, so :data:`UNITS` maps each dotted path to its dimension; a field missing
from it stops the build (:class:`MissingEntry`), so a new field cannot be
published without units.
"""

from __future__ import annotations

import html
from pathlib import Path
from typing import Iterator

import yaml

ROOT = Path(__file__).resolve().parents[1]

#: Dimension of each field, as "scaled unit (SI unit under ``units: physical``)".
#: A schema property ``units`` (``json_schema_extra``) takes precedence.
UNITS = {
    "name": "-", "units": "-",
    "granules.count": "-",
    "granules.mass": "mass (kg)",
    "granules.radius": "length (m)",
    "granules.gap": "length (m)",
    "granules.velocity": "velocity (m/s)",
    "granules.friction.kinetic": "force (N)",
    "granules.friction.static": "force (N)",
    "granules.friction.viscous": "force / velocity (N s/m)",
    "granules.material.young": "pressure (Pa)",
    "granules.material.poisson": "-",
    "granules.state.file": "-", "granules.state.frame": "-",
    "contacts.law": "-",
    "contacts.exponent": "-",
    "contacts.stiffness": "force / length^(n-1) (N/m^(n-1))",
    "walls.left.gap": "length (m)", "walls.right.gap": "length (m)",
    "walls.left.stiffness": "force / length^(n-1) (N/m^(n-1))",
    "walls.right.stiffness": "force / length^(n-1) (N/m^(n-1))",
    "walls.left.exponent": "-", "walls.right.exponent": "-",
    "contacts.damping": "-", "contacts.damping.model": "-",
    "contacts.damping.coefficient": "c: force / velocity (N s/m); A: time (s)",
    "contacts.damping.value": "-", "contacts.damping.speed": "velocity (m/s)",
    "contacts.tensile": "-",
    "walls.left.material": "-", "walls.right.material": "-",
    "walls.left.material.young": "pressure (Pa)", "walls.right.material.young": "pressure (Pa)",
    "walls.left.material.poisson": "-", "walls.right.material.poisson": "-",
    "walls.left.motion": "-", "walls.right.motion": "-",
    "walls.left.motion.velocity": "velocity (m/s)", "walls.right.motion.velocity": "velocity (m/s)",
    "walls.left.motion.sine": "-", "walls.right.motion.sine": "-",
    "walls.left.motion.pulse": "-", "walls.right.motion.pulse": "-",
    "walls.left.motion.sine.amplitude": "length (m)", "walls.right.motion.sine.amplitude": "length (m)",
    "walls.left.motion.sine.frequency": "1 / time (Hz)",
    "walls.right.motion.sine.frequency": "1 / time (Hz)",
    "walls.left.motion.pulse.velocity": "velocity (m/s)",
    "walls.right.motion.pulse.velocity": "velocity (m/s)",
    "walls.left.motion.pulse.duration": "time (s)", "walls.right.motion.pulse.duration": "time (s)",
    "body_force": "-", "body_force.g": "acceleration (m/s^2)", "body_force.direction": "-",
    "body_force.force": "force (N)",
    "run.stepper": "-", "run.dt": "time (s)", "run.t_end": "time (s)", "run.stop": "-",
    "run.stop_contact": "-", "run.max_steps": "steps", "run.energy_tolerance": "-",
    "run.check_dt": "-", "run.accept_inaccurate_dt": "-", "run.rtol": "-",
    "run.atol": "length, velocity (m, m/s)",
    "run.max_events": "events", "run.stages": "-",
    "run.stages[].t_end": "time (s)", "run.stages[].name": "-",
    "run.stages[].velocity": "velocity (m/s)", "run.stages[].velocity_add": "velocity (m/s)",
    "output.every": "steps", "output.dt": "time (s)", "output.trajectory": "-",
    "output.vtk": "-", "output.csv": "-", "output.events": "-", "output.plots": "-",
    "output.checkpoint_every": "steps", "output.thermo": "steps",
    # fields of a seeded distribution (any per-granule field may be one)
    "uniform.distribution": "-", "uniform.low": "as the field", "uniform.high": "as the field",
    "uniform.seed": "-",
    "normal.distribution": "-", "normal.mean": "as the field", "normal.std": "as the field",
    "normal.seed": "-",
    "lognormal.distribution": "-", "lognormal.median": "as the field", "lognormal.sigma": "-",
    "lognormal.seed": "-",
    "taper.distribution": "-", "taper.first": "as the field", "taper.ratio": "-",
    "repeat.distribution": "-", "repeat.values": "as the field",
}

#: Examples of fields no scene under scenarios/ sets and whose default is empty.
EXAMPLES = {
    "granules.friction.static": 0.35,
    "granules.material.young": 2.0e11,
    "granules.material.poisson": 0.3,
    "granules.state.file": "outputs/chain_striker/trajectory.h5",
    "run.dt": 1.0e-3,
    "run.energy_tolerance": 1.0e-9,
    "output.every": 100,
    "output.dt": 0.05,
    "output.checkpoint_every": 100000,
    "output.thermo": 1000,
    "run.stages[].t_end": 400, "run.stages[].name": "settle",
    "run.stages[].velocity": {7: -0.3}, "run.stages[].velocity_add": {0: 0.1},
    "contacts.damping.coefficient": 0.1, "contacts.damping.value": 0.8,
    "contacts.damping.speed": 1.0, "contacts.law": "hertz",
    "walls.left.material.young": 2.0e11, "walls.right.material.young": 2.0e11,
    "walls.left.material.poisson": 0.3, "walls.right.material.poisson": 0.3,
    "walls.left.motion.velocity": 0.05, "walls.right.motion.velocity": -0.05,
    "walls.left.motion.sine.amplitude": 0.01, "walls.right.motion.sine.amplitude": 0.01,
    "walls.left.motion.sine.frequency": 0.2, "walls.right.motion.sine.frequency": 0.2,
    "walls.left.motion.pulse.velocity": 1.0, "walls.right.motion.pulse.velocity": -1.0,
    "walls.left.motion.pulse.duration": 0.5, "walls.right.motion.pulse.duration": 0.5,
    "body_force.g": 9.81, "body_force.force": [0.0, 0.0, 1.0],
    "uniform.distribution": "uniform", "uniform.low": 0.9, "uniform.high": 1.1,
    "uniform.seed": 1,
    "normal.distribution": "normal", "normal.mean": 1.0, "normal.std": 0.05, "normal.seed": 2,
    "lognormal.distribution": "lognormal", "lognormal.median": 1.0, "lognormal.sigma": 0.1,
    "lognormal.seed": 3,
    "taper.distribution": "taper", "taper.first": 0.5, "taper.ratio": 0.97,
    "repeat.distribution": "repeat", "repeat.values": [1.0, 0.5],
}


class MissingEntry(KeyError):
    """A schema field without units or example: the page would be incomplete."""


def scene_schema() -> dict:
    """The JSON Schema of scene files, from the package (the one place it is defined)."""
    from granular_chain.scene import Scene
    return Scene.model_json_schema()


def _resolve(schema: dict, node: dict) -> dict:
    ref = node.get("$ref")
    return schema["$defs"][ref.rsplit("/", 1)[1]] if ref else node


def _alternatives(node: dict) -> list[dict]:
    return node.get("anyOf") or node.get("oneOf") or [node]


def _is_recipe(schema: dict, node: dict) -> bool:
    return "distribution" in _resolve(schema, node).get("properties", {})


def _submodels(schema: dict, node: dict) -> list[dict]:
    """The object schemas a property nests: a model, possibly Optional, or each
    member of a union of models (``run``: one per stepper); [] if none."""
    return [_resolve(schema, alt) for alt in _alternatives(node)
            if "properties" in _resolve(schema, alt) and not _is_recipe(schema, alt)]


def _merged(rows: list[tuple[str, dict, bool]]) -> Iterator[tuple[str, dict, bool]]:
    """Rows of the members of a union, each path once in first-seen order; a field
    every member holds as a different constant (``run.stepper``) lists them all."""
    by_path: dict[str, tuple[str, dict, bool]] = {}
    for path, prop, required in rows:
        if path not in by_path:
            by_path[path] = (path, prop, required)
            continue
        first = by_path[path][1]
        consts = first.get("enum", [first["const"]] if "const" in first else None)
        if consts is not None and "const" in prop and prop["const"] not in consts:
            merged = {k: v for k, v in first.items() if k != "const"}
            by_path[path] = (path, {**merged, "enum": [*consts, prop["const"]]}, required)
    yield from by_path.values()


def walk(schema: dict, node: dict | None = None, prefix: str = "") -> Iterator[tuple[str, dict, bool]]:
    """Every field as (dotted path, property schema, required), depth first.

    Models nested in a field (``granules.friction``) are descended into, each
    member of a union of models too (``run``: the fields of both steppers), and so
    are the models of a list of them (``run.stages``: its row, then its items'
    fields as ``run.stages[].t_end``); seeded distributions are not (see
    :func:`recipe_fields`).
    """
    node = schema if node is None else node
    required = set(node.get("required", ()))
    for name, prop in node.get("properties", {}).items():
        path = f"{prefix}{name}"
        subs = _submodels(schema, prop)
        items = _item_model(schema, prop)
        if subs:
            yield from _merged([row for sub in subs for row in walk(schema, sub, path + ".")])
        elif items is not None:
            yield path, prop, name in required
            yield from walk(schema, items, path + "[].")
        else:
            yield path, prop, name in required


def _item_model(schema: dict, node: dict) -> dict | None:
    """The model of a list-of-models property's items (possibly Optional), else None."""
    for alt in _alternatives(node):
        if alt.get("type") == "array" and "$ref" in alt.get("items", {}):
            return _resolve(schema, alt["items"])
    return None


def recipe_fields(schema: dict) -> Iterator[tuple[str, dict, bool]]:
    """Fields of the recipes (seeded distributions, sequences) as ``<kind>.<field>``
    (e.g. ``normal.std``, ``taper.ratio``)."""
    for model in schema["$defs"].values():
        props = model.get("properties", {})
        if "distribution" in props:
            kind = props["distribution"]["const"]
            for name, prop in props.items():
                yield f"{kind}.{name}", prop, name in model.get("required", ())


def _bounds(node: dict) -> str:
    marks = {"gt": ">", "exclusiveMinimum": ">", "ge": ">=", "minimum": ">=",
             "lt": "<", "exclusiveMaximum": "<", "le": "<=", "maximum": "<=",
             "minLength": "length >="}
    return ", ".join(f"{m} {node[k]}" for k, m in marks.items() if k in node)


def type_text(schema: dict, node: dict) -> str:
    """A short type for a property: ``number (> 0)``, ``list of number``, ``'a' | 'b'``."""
    parts = []
    for alt in _alternatives(node):
        if _is_recipe(schema, alt):
            if "recipe" not in parts:
                parts.append("recipe")
            continue
        if "discriminator" in alt:
            parts.append("recipe")
            continue
        kind = alt.get("type")
        if "$ref" in alt:  # a list of models: their fields have rows of their own
            parts.append("mapping (fields below)")
        elif "const" in alt:
            parts.append(repr(alt["const"]))
        elif "enum" in alt:
            parts.append(" | ".join(repr(v) for v in alt["enum"]))
        elif kind == "array":
            parts.append("list of " + type_text(schema, alt["items"]))
        elif kind == "object":
            parts.append("mapping {index: " + type_text(schema, alt.get("additionalProperties", {}))
                         + "}")
        elif kind == "null":
            continue
        elif kind:
            b = _bounds(alt)
            parts.append(f"{kind} ({b})" if b else kind)
    return " or ".join(dict.fromkeys(parts)) or "any"


def scenario_examples() -> dict:
    """The first value each dotted path takes in the scene files under scenarios/."""
    found = {}

    seen: dict[str, list] = {}

    def visit(data, prefix, source):
        mapping = isinstance(data, dict) and data and all(isinstance(k, int) for k in data)
        if isinstance(data, dict) and not mapping and "distribution" not in data:
            for key, value in data.items():
                visit(value, f"{prefix}.{key}" if prefix else str(key), source)
        else:
            seen.setdefault(prefix, []).append((_cell(data), source))

    for path in sorted((ROOT / "scenarios").glob("*.yaml")):
        visit(yaml.safe_load(path.read_text()), "", path.name)
    # the shortest value each field takes: an example, not a data dump
    return {path: min(values, key=lambda vs: len(vs[0])) for path, values in seen.items()}


def _cell(value) -> str:
    """A value as inline code, in YAML flow style (as it is written in a scene)."""
    text = value if isinstance(value, str) else yaml.safe_dump(
        value, default_flow_style=True, width=1 << 16).strip().removesuffix("...").strip()
    return "`" + text.replace("|", "\\|") + "`"


def field_cell(path: str) -> str:
    """A dotted path as inline code that a narrow column breaks after a dot only
    (``<wbr>`` adds no character: the path copies as written)."""
    return f'<code class="gc-field">{path.replace(".", ".<wbr>")}</code>'


def _row(schema, path, prop, required, examples) -> str:
    units = prop.get("units", UNITS.get(path))
    if units is None:
        raise MissingEntry(f"scene field {path}: no units (add it to docs_build/scene_reference.py UNITS)")
    if path in examples:
        value, source = examples[path]
        example = f"{value}<br>({source})"
    elif path in EXAMPLES:
        example = _cell(EXAMPLES[path])
    elif prop.get("default") is not None:
        example = _cell(prop["default"])
    else:
        raise MissingEntry(f"scene field {path}: no example (set it in a scenario or EXAMPLES)")
    default = "required" if required else _cell(prop.get("default"))
    # escaped: a description's "<name>" is text, not an HTML tag that would swallow the row
    description = html.escape(" ".join(prop.get("description", "").split()), quote=False)
    description = description.replace("|", "\\|")
    return (f"| {field_cell(path)} | {type_text(schema, prop).replace('|', '&#124;')} | {default} | "
            f"{units} | {description} | {example} |")


HEADER = "| field | type | default | units | description | example |\n|---|---|---|---|---|---|"


def _anchor(top: str) -> str:
    """The heading id mkdocs gives a section (``## `granules` `` -> ``granules``)."""
    return "top-level" if top == "scene" else top


def render() -> str:
    """The whole scene reference page (markdown)."""
    schema = scene_schema()
    examples = scenario_examples()
    groups: dict[str, list[str]] = {}
    for path, prop, required in walk(schema):
        top = path.split(".")[0] if "." in path else "scene"
        groups.setdefault(top, []).append(_row(schema, path, prop, required, examples))
    sections = " · ".join(f"[{'top level' if top == 'scene' else top}](#{_anchor(top)})"
                          for top in groups)
    lines = [
        # the six-column tables take the page's whole width: no table-of-contents
        # sidebar, whose sections are linked below the title instead
        "---", "hide:", "  - toc", "---", "",
        "# Scene reference",
        "",
        f"Sections: {sections} · [recipes](#recipes).",
        "",
        "A scene is a YAML file validated by the schema below (`granular-chain schema` prints it",
        "as JSON Schema). This page is generated from that schema when the site is built:",
        "every field, its type and bounds, its default, its units, its description and an",
        "example (from the file under `scenarios/` named beside it, where one sets the field).",
        "",
        "Units: `units: scaled` (the default) measures everything in the paper's Appendix-A",
        "units (mass m = 1, force coefficient 1, impact speed v0 = 1, see [Theory](../theory.md#units-and-scaling));",
        "`units: physical` reads SI, given in parentheses. `-` marks a pure number or a name.",
        "Per-granule fields take one value, a list of N values, or a recipe (a seeded",
        "distribution, a taper or a repeated pattern): every form, with its formula, is in",
        "[Per-granule values](../chains.md#per-granule-values);",
        "per-contact fields one value or N - 1 values. Any field can be changed for one run",
        "with `--set dotted.path=value`.",
        "",
    ]
    for top, rows in groups.items():
        lines += [f"## `{top}`" if top != "scene" else "## Top level", "", HEADER, *rows, ""]
    lines += ["## Recipes", "",
              "A per-granule field (`granules.mass`, `radius`, `gap`, `velocity`, `friction.*`)",
              "may be a mapping that makes its N values: drawn from a seeded generator, e.g.",
              "`mass: {distribution: normal, mean: 1.0, std: 0.05, seed: 2}`, or a sequence,",
              "`radius: {distribution: taper, first: 0.5, ratio: 0.97}` (`first * ratio**i`),",
              "`mass: {distribution: repeat, values: [1.0, 0.5]}` (`values[i % len(values)]`);",
              "see [Per-granule values](../chains.md#per-granule-values).", "",
              HEADER]
    lines += [_row(schema, p, prop, req, {}) for p, prop, req in recipe_fields(schema)]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(render())
