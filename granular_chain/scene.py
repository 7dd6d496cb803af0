"""Scene files: the pydantic schema, YAML loading and ``--set`` overrides.

A scene is the whole description of one run: the granules, their contacts and
walls, friction, units and how to step. This module is the first stage of the
one-way data flow ``YAML -> Scene -> Model -> kernel -> Result -> writers``: it
knows nothing of arrays or kernels, and every error it raises names the file,
the field as a dotted path and what is wrong, in one line (:class:`SceneError`).
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Annotated, Any, Literal, Optional, Union

import yaml
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from .distributions import Distribution, check_draw, draw, is_recipe

__all__ = [
    "Scene",
    "SceneError",
    "load_scene",
    "scene_from_dict",
    "apply_overrides",
    "scene_json_schema",
]


class SceneError(ValueError):
    """A scene that cannot be run: one line with file, dotted field path and reason."""

    def __init__(self, source: str, field: str, problem: str):
        self.source, self.field, self.problem = source, field, problem
        where = f"{source}: {field}" if field else source
        super().__init__(f"{where}: {problem}")


Finite = Annotated[float, Field(allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]
# A per-granule or per-contact quantity: one number for all, or one per item.
PerItem = Union[Finite, list[Finite]]
PerItemPositive = Union[Positive, list[Positive]]
PerItemNonNegative = Union[NonNegative, list[NonNegative]]
# Per-granule fields also take a seeded distribution (see distributions.py).
PerGranule = Union[Finite, list[Finite], Distribution]
PerGranulePositive = Union[Positive, list[Positive], Distribution]
PerGranuleNonNegative = Union[NonNegative, list[NonNegative], Distribution]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", validate_assignment=True)


class Friction(_Strict):
    """Friction on each granule, as forces (scaled or SI), eq. (5)-(6) and Sec. III."""

    kinetic: PerGranuleNonNegative = Field(
        0.0, description="Coulomb (kinetic) friction force magnitude eta_i on each granule.")
    static: Optional[PerGranuleNonNegative] = Field(
        None, description="Static threshold; defaults to the kinetic value. Must be >= kinetic.")
    viscous: PerGranuleNonNegative = Field(
        0.0, description="Hydrodynamic friction coefficient gamma_i: force -gamma_i * v_i.")


class Material(_Strict):
    """Elastic constants for Hertz stiffness, k = (4/3) E* sqrt(R*) (paper eq. (1)-(3))."""

    young: PerItemPositive = Field(..., description="Young's modulus E of each granule.")
    poisson: Union[Annotated[float, Field(gt=-1, lt=0.5)], list[Annotated[float, Field(gt=-1, lt=0.5)]]] = Field(
        ..., description="Poisson ratio of each granule, in (-1, 0.5).")


class Granules(_Strict):
    """The N granules, indexed 0..N-1 from left to right."""

    count: int = Field(..., ge=1, description="Number of granules N.")
    mass: PerGranulePositive = Field(1.0, description="Mass m_i (one value or N values).")
    radius: PerGranulePositive = Field(0.5, description="Radius r_i (one value or N values).")
    gap: PerGranule = Field(
        0.0,
        description="Gap between neighbours i and i+1 (one value or N-1 values): "
        "0 = just touching, negative = initial overlap (precompression).")
    velocity: Union[Finite, list[Finite], dict[int, Finite], Distribution] = Field(
        0.0, description="Initial velocity v_i: one value, N values, or a mapping "
        "{index: value} with every other granule at rest (e.g. {0: 1.0} for a striker).")
    friction: Friction = Field(default_factory=Friction)
    material: Optional[Material] = Field(
        None, description="Elastic constants, used when contacts.stiffness is 'hertz'.")

    @model_validator(mode="after")
    def _draws_in_bounds(self) -> "Granules":
        """Refuse a distribution whose drawn values break the field's bounds."""
        n, fr = self.count, self.friction
        for path, value, bound, size, item in (
                ("mass", self.mass, "positive", n, "granule"),
                ("radius", self.radius, "positive", n, "granule"),
                ("gap", self.gap, "finite", n - 1, "contact"),
                ("velocity", self.velocity, "finite", n, "granule"),
                ("friction.kinetic", fr.kinetic, "nonnegative", n, "granule"),
                ("friction.static", fr.static, "nonnegative", n, "granule"),
                ("friction.viscous", fr.viscous, "nonnegative", n, "granule")):
            problem = check_draw(value, size, bound, item) if is_recipe(value) else ""
            if problem:
                raise _FieldProblem(f"granules.{path}", problem)
        return self


class Contacts(_Strict):
    """One-sided power-law contacts: force k * delta^(n-1) while delta > 0."""

    exponent: Union[Annotated[float, Field(gt=1, allow_inf_nan=False)], list[Annotated[float, Field(gt=1, allow_inf_nan=False)]]] = Field(
        2.0, description="Exponent n of the potential (2 linear, 2.5 Hertz); force ~ delta^(n-1).")
    stiffness: Union[Literal["hertz"], PerItemPositive] = Field(
        1.0,
        description="Force coefficient k (force = k delta^(n-1)), one value or N-1 values, "
        "or 'hertz' to compute k = (4/3) E* sqrt(R*) from granules.material (then n = 5/2).")


class Wall(_Strict):
    """A fixed wall beyond an end granule, with the same one-sided contact law."""

    gap: Finite = Field(0.0, description="Gap between the wall and the end granule.")
    stiffness: Positive = Field(1.0, description="Force coefficient k of the wall contact.")
    exponent: Annotated[float, Field(gt=1, allow_inf_nan=False)] = Field(
        2.0, description="Exponent n of the wall contact.")


class Walls(_Strict):
    left: Optional[Wall] = None
    right: Optional[Wall] = None


class Output(_Strict):
    """What a run writes and how often (the cadence never changes the physics)."""

    every: Optional[int] = Field(
        None, ge=1, description="Record a frame every this many steps (Verlet).")
    dt: Optional[Positive] = Field(
        None, description="Record a frame every dt of simulated time (rounded to whole steps).")
    trajectory: bool = Field(True, description="Write trajectory.h5 (t, x, v, energy ledger).")
    vtk: bool = Field(
        False, description="Write a VTK time series for ParaView/pyvista: run.pvd indexing "
        "vtk/frame_NNNNNN.vtp (granules as points, contacts as line cells).")
    csv: bool = Field(
        False, description="Write energy.csv (energy ledger per frame) and, when the stepper "
        "logged events, events.csv.")
    plots: bool = Field(
        False, description="Write PNG plots into plots/ (space-time velocity diagram, energy "
        "ledger, granule velocities, a rendered frame).")
    thermo: Optional[int] = Field(
        None, ge=1, description="Steps between thermo lines (t, energies, dissipated energy, "
        "ledger error, closed contacts, sliding granules) printed by granular-chain run and "
        "saved as thermo.csv; default about 20 lines a run. The event stepper writes a line "
        "at its first frame after each 1/20 of t_end.")


class Run(_Strict):
    """How to step and when to stop."""

    stepper: Literal["verlet", "event"] = Field("verlet", description="Time stepper.")
    dt: Optional[Positive] = Field(
        None, description="Verlet time step; default 1/100 of the shortest contact period.")
    t_end: Positive = Field(10.0, description="Stop at this time at the latest.")
    stop: Union[Literal["t_end", "separation", "rest"], list[Literal["separation", "rest"]]] = Field(
        "t_end",
        description="Extra stop condition(s) besides t_end: 'separation' = first opening of "
        "contact stop_contact after it has been closed, 'rest' = every granule at rest "
        "(exactly, held by static friction); a list stops at whichever comes first.")

    @property
    def stop_conditions(self) -> set:
        s = self.stop
        return set(s) if isinstance(s, list) else ({s} - {"t_end"})
    stop_contact: int = Field(0, ge=0, description="Contact index for stop: separation.")
    max_steps: int = Field(2_000_000_000, ge=1, description="Refuse to take more steps.")
    check_dt: bool = Field(
        True, description="Refuse a Verlet dt above the stability limit of the stiffest "
        "contact (turn off only to study instability: the run then stops at the first "
        "non-finite state with status nonfinite).")
    rtol: Positive = Field(1e-12, description="Relative tolerance (event stepper, n != 2).")
    atol: Positive = Field(1e-14, description="Absolute tolerance (event stepper, n != 2).")
    max_events: int = Field(1_000_000, ge=1, description="Event stepper: most events.")


class Scene(_Strict):
    """A validated scene: everything one run needs, in scaled or SI units."""

    name: str = Field("scene", description="Used for the default output folder.")
    units: Literal["scaled", "physical"] = Field(
        "scaled",
        description="'scaled' (paper Appendix A: m = 1, force coefficient 1, v0 = 1) or "
        "'physical' (SI: kg, m, s, N); physical scenes report their scaled eta and gamma.")
    granules: Granules
    contacts: Contacts = Field(default_factory=Contacts)
    walls: Walls = Field(default_factory=Walls)
    run: Run = Field(default_factory=Run)
    output: Output = Field(default_factory=Output)

    @model_validator(mode="after")
    def _lengths_and_consistency(self) -> "Scene":
        n = self.granules.count
        per_granule = {
            "granules.mass": self.granules.mass,
            "granules.radius": self.granules.radius,
            "granules.velocity": self.granules.velocity,
            "granules.friction.kinetic": self.granules.friction.kinetic,
            "granules.friction.static": self.granules.friction.static,
            "granules.friction.viscous": self.granules.friction.viscous,
        }
        if self.granules.material is not None:
            per_granule["granules.material.young"] = self.granules.material.young
            per_granule["granules.material.poisson"] = self.granules.material.poisson
        per_contact = {
            "granules.gap": self.granules.gap,
            "contacts.exponent": self.contacts.exponent,
            "contacts.stiffness": self.contacts.stiffness,
        }
        vel = self.granules.velocity
        if isinstance(vel, dict):
            for i in vel:
                if not 0 <= i < n:
                    raise _FieldProblem(f"granules.velocity[{i}]",
                                        f"granule index out of range 0..{n - 1}")
        for path, value in per_granule.items():
            if isinstance(value, list) and len(value) != n:
                raise _FieldProblem(path, f"has {len(value)} values but granules.count is {n}")
        for path, value in per_contact.items():
            if isinstance(value, list) and len(value) != max(n - 1, 0):
                raise _FieldProblem(
                    path, f"has {len(value)} values but there are {n - 1} contacts "
                    f"(granules.count - 1)")
        if self.contacts.stiffness == "hertz":
            if self.granules.material is None:
                raise _FieldProblem("contacts.stiffness",
                                    "'hertz' needs granules.material (young, poisson)")
            exps = self.contacts.exponent
            if any(e != 2.5 for e in (exps if isinstance(exps, list) else [exps])):
                raise _FieldProblem("contacts.exponent",
                                    "must be 2.5 when stiffness is 'hertz' (Hertz law for spheres)")
        fr = self.granules.friction
        if fr.static is not None:
            kin = _expand(fr.kinetic, n)
            sta = _expand(fr.static, n)
            for i, (a, b) in enumerate(zip(kin, sta)):
                if b < a:
                    raise _FieldProblem(
                        "granules.friction.static",
                        f"static threshold {b} of granule {i} is below its kinetic friction {a}")
        radii = _expand(self.granules.radius, n)
        gaps = _expand(self.granules.gap, max(n - 1, 0))
        for i, g in enumerate(gaps):
            if -g >= min(radii[i], radii[i + 1]):
                raise _FieldProblem(
                    "granules.gap",
                    f"initial overlap {-g} of contact {i} is not smaller than the smaller radius "
                    f"{min(radii[i], radii[i + 1])}: granules would pass through each other")
        for side in ("left", "right"):
            wall = getattr(self.walls, side)
            end = radii[0] if side == "left" else radii[-1]
            if wall is not None and -wall.gap >= end:
                raise _FieldProblem(f"walls.{side}.gap",
                                    f"initial overlap {-wall.gap} is not smaller than the radius {end}")
        if "separation" in self.run.stop_conditions and self.run.stop_contact > n - 2:
            raise _FieldProblem("run.stop_contact",
                                f"is {self.run.stop_contact} but contacts are numbered 0..{n - 2}")
        if self.output.every is not None and self.output.dt is not None:
            raise _FieldProblem("output", "give either 'every' (steps) or 'dt' (time), not both")
        return self


class _FieldProblem(ValueError):
    """Raised inside validators to carry an exact dotted path to :class:`SceneError`."""

    def __init__(self, path: str, problem: str):
        self.path, self.problem = path, problem
        super().__init__(f"{path}: {problem}")


def _expand(value, n: int) -> list[float]:
    if is_recipe(value):
        return draw(value, n).tolist()
    return list(value) if isinstance(value, list) else [value] * n


def _known_fields(model: type[BaseModel], loc: tuple) -> list[str]:
    """Names allowed at the location of an 'extra field' error, for suggestions."""
    current: Any = model
    for part in loc[:-1]:
        if isinstance(part, int):
            continue
        fields = getattr(current, "model_fields", None)
        if not fields or part not in fields:
            return []
        ann = fields[part].annotation
        current = _submodel(ann)
        if current is None:
            return []
    return list(getattr(current, "model_fields", {}).keys())


def _submodel(annotation) -> Optional[type[BaseModel]]:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in getattr(annotation, "__args__", ()) or ():
        found = _submodel(arg)
        if found is not None:
            return found
    return None


_TYPE_TAGS = {"float", "int", "str", "bool", "list", "dict", "none",
              "uniform", "normal", "lognormal"}  # the last three: distribution recipes


def _is_tag(part) -> bool:
    """Union-member tags pydantic puts in error locations ('constrained-float', ...)."""
    if isinstance(part, int):
        return False
    return part in _TYPE_TAGS or any(ch in part for ch in "[-(")


def _dotted(loc: tuple) -> str:
    parts = []
    for p in loc:
        if _is_tag(p):
            continue
        if isinstance(p, int):
            parts.append(f"[{p}]")
        else:
            parts.append(("." if parts else "") + str(p))
    return "".join(parts)


def _recipe_errors(errors: list) -> list:
    """For a field written as a distribution recipe (a mapping with 'distribution'),
    only the errors of the recipe branch: they speak of what the user wrote."""
    def recipe(e):
        given = e.get("input")
        return isinstance(given, dict) and "distribution" in given and _is_tag(e["loc"][-1])
    fields = {e["loc"][:-1] for e in errors if recipe(e)}

    def keep(e):
        return not any(e["loc"][:len(f)] == f for f in fields) or \
            any(str(p).startswith("tagged-union") for p in e["loc"])
    return [e for e in errors if keep(e)]


def _explain(exc: ValidationError, source: str) -> SceneError:
    """The most specific validation error as one SceneError line (file, field, problem)."""
    errors = exc.errors(include_url=False)
    # A per-item field is a union (number or list): each member reports its own
    # error. The one with the deepest real path (an index into the list) is the
    # one that speaks of what the user wrote.
    errors = _recipe_errors(errors)
    first = max(errors, key=lambda e: (len(_dotted(e["loc"]).replace("[", ".[").split(".")),
                                       -errors.index(e)))
    loc = first["loc"]
    path = _dotted(loc)
    err_type = first["type"]
    if err_type == "extra_forbidden":
        name = str(loc[-1])
        known = _known_fields(Scene, tuple(p for p in loc if not _is_tag(p)))
        close = difflib.get_close_matches(name, known, n=1)
        hint = f"; did you mean '{close[0]}'?" if close else (
            f"; known fields: {', '.join(known)}" if known else "")
        return SceneError(source, path, f"unknown field{hint}")
    if err_type == "value_error" and isinstance(first.get("ctx", {}).get("error"), _FieldProblem):
        fp = first["ctx"]["error"]
        return SceneError(source, fp.path, fp.problem)
    if err_type == "union_tag_invalid":
        return SceneError(source, f"{path}.distribution", "must be uniform, normal or "
                          f"lognormal (got {first.get('ctx', {}).get('tag')!r})")
    if err_type == "value_error" and path.split(".")[-1] in ("mass", "radius", "gap", "velocity",
                                                           "kinetic", "static", "viscous"):
        return SceneError(source, path, first["msg"].removeprefix("Value error, "))
    if err_type == "missing":
        return SceneError(source, path, "is required but missing")
    msg = first["msg"]
    if err_type == "finite_number":
        msg = "must be a finite number (NaN and Inf are not allowed)"
    return SceneError(source, path, f"{msg} (got {first.get('input')!r})")


def scene_from_dict(data: Any, source: str = "<scene>") -> Scene:
    """Validate a mapping into a :class:`Scene`, raising :class:`SceneError` on any problem."""
    if not isinstance(data, dict):
        raise SceneError(source, "", f"a scene must be a mapping of fields, got {type(data).__name__}")
    try:
        return Scene.model_validate(data)
    except ValidationError as exc:
        raise _explain(exc, source) from None


def _read_yaml(path: Path) -> Any:
    source = str(path)
    if not path.exists():
        raise SceneError(source, "", "no such file")
    if path.is_dir():
        raise SceneError(source, "", "is a folder, not a scene file")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(source, "", f"cannot be read ({exc.__class__.__name__}: {exc})") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise SceneError(source, "", f"invalid YAML at {where}{problem}") from None


def apply_overrides(data: dict, overrides: list[str], source: str = "--set") -> dict:
    """Apply ``dotted.path=value`` overrides (values parsed as YAML) to a scene mapping.

    Parameters
    ----------
    data : dict
        The raw scene mapping (modified in place and returned).
    overrides : list of str
        Items like ``granules.friction.kinetic=[0, 0.3]`` or ``run.dt=1e-4``.
    """
    for item in overrides:
        if "=" not in item:
            raise SceneError(source, item, "an override must look like dotted.path=value")
        path, raw = item.split("=", 1)
        path = path.strip()
        if not path or any(not p for p in path.split(".")):
            raise SceneError(source, path or item, "empty field name in dotted path")
        try:
            value = yaml.safe_load(raw)
        except yaml.YAMLError:
            raise SceneError(source, path, f"value {raw!r} is not valid YAML") from None
        target = data
        parts = path.split(".")
        for part in parts[:-1]:
            nxt = target.get(part) if isinstance(target, dict) else None
            if nxt is None:
                nxt = {}
                target[part] = nxt
            if not isinstance(nxt, dict):
                raise SceneError(source, path, f"'{part}' is not a group of fields")
            target = nxt
        target[parts[-1]] = value
    return data


def load_scene(path: Union[str, Path], overrides: Optional[list[str]] = None) -> Scene:
    """Read, override and validate a scene file.

    Parameters
    ----------
    path : str or Path
        YAML scene file.
    overrides : list of str, optional
        ``dotted.path=value`` items applied before validation (see :func:`apply_overrides`).

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        One line naming the file, the dotted field and the problem.
    """
    path = Path(path)
    data = _read_yaml(path)
    if data is None:
        raise SceneError(str(path), "", "the file is empty")
    if overrides:
        if not isinstance(data, dict):
            raise SceneError(str(path), "", "a scene must be a mapping of fields")
        apply_overrides(data, overrides, source=f"{path} (--set)")
    return scene_from_dict(data, source=str(path))


def scene_json_schema() -> dict:
    """The JSON Schema of a scene file."""
    return Scene.model_json_schema()
