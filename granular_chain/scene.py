"""Scene files: the pydantic schema, YAML loading and ``--set`` overrides.

A scene is the whole description of one run: the granules, their contacts and
walls, friction, units and how to step. This module is the first stage of the
one-way data flow ``YAML -> Scene -> Model -> kernel -> Result -> writers``: it
knows nothing of arrays or kernels, and every error it raises names the file,
the field as a dotted path and what is wrong, in one line (:class:`SceneError`).
"""

from __future__ import annotations

import difflib
import numbers
import re
import unicodedata
from pathlib import Path
from typing import Annotated, Any, Literal, Optional, Union

import numpy as np
import yaml
from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from .distributions import Distribution, check_draw, draw, is_recipe
from .initial_state import StateFileError, read_state

__all__ = [
    "Scene",
    "SceneError",
    "load_scene",
    "scene_from_dict",
    "apply_overrides",
    "set_path",
    "scene_json_schema",
    "read_scene_data",
    "parse_yaml_value",
    "MAX_SCENE_BYTES",
    "STEPPER_OPTIONS",
    "DEFAULT_ENERGY_TOLERANCE",
    "SCALE_MIN",
    "SCALE_MAX",
]

#: Largest scene file read (bytes): a scene is a few hundred bytes; per-item
#: lists of ~10^5 values still fit.
MAX_SCENE_BYTES = 1 << 20
#: Most YAML nodes that aliases may add by expansion (a "billion laughs" file
#: adds 10^9 from a few hundred bytes).
MAX_ALIAS_NODES = 100_000
#: Deepest nesting of YAML collections (a scene needs 4).
MAX_YAML_DEPTH = 64
#: Range of masses, radii and stiffnesses: 2^-511 .. 2^511, so that the product
#: of two (a reduced mass m_i m_j / (m_i + m_j), a force k delta) neither
#: underflows to a subnormal nor overflows double precision.
SCALE_MIN = 2.0 ** -511
SCALE_MAX = 2.0 ** 511



class SceneError(ValueError):
    """A scene that cannot be run: one line with file, dotted field path and reason.

    Parameters
    ----------
    source : str
        The scene's file name (or ``--set``, ``<scene>``), first in the message.
    field : str
        Dotted path of the offending field (``granules.mass``); empty for the
        file as a whole.
    problem : str
        What is wrong and what to change.
    """

    def __init__(self, source: str, field: str, problem: str):
        self.source, self.field, self.problem = source, field, problem
        where = f"{source}: {field}" if field else source
        super().__init__(f"{where}: {problem}")


def _kind(value) -> str:
    """How a value of the wrong type is named in messages."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, str):
        return f"the string {value!r}"
    if isinstance(value, float):
        return f"the decimal number {value!r}"
    return f"a {type(value).__name__}"


def _number(value):
    """Numbers only: YAML ints and floats, not booleans or (quoted) strings."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise PydanticCustomError("number_type", "must be a number, not {kind}",
                                  {"kind": _kind(value)})
    if isinstance(value, numbers.Integral) and abs(int(value)) > 2 ** 1023:
        raise PydanticCustomError("finite_number", "is too large for double precision")
    return value


#: Largest whole number a count, index or cadence may be (2^53: exact as a double and
#: as a 64-bit integer of the compiled kernels).
MAX_WHOLE = 2 ** 53


def _integer(value):
    """Whole numbers only: not 3.0 or 1e9 (floats), booleans or strings; |value| <= 2^53."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise PydanticCustomError(
            "integer_type", "must be a whole number written without a decimal point or "
            "exponent (e.g. 1000000), not {kind}", {"kind": _kind(value)})
    if abs(int(value)) > MAX_WHOLE:
        digits = len(str(abs(int(value))))
        raise PydanticCustomError(
            "integer_size", "is a whole number of {digits} digits, above 2^53 = "
            "9007199254740992, the largest count the engine represents exactly",
            {"digits": digits})
    return int(value)


def _index_key(value):
    """A granule index as a mapping key: a whole number, or its decimal digits (JSON,
    which stores the scene in summary.json and trajectory.h5, has only string keys)."""
    if isinstance(value, str) and value.isascii() and value.isdigit():
        return int(value)
    return _integer(value)


def _boolean(value):
    if not isinstance(value, (bool, np.bool_)):
        raise PydanticCustomError("bool_type", "must be true or false, not {kind}",
                                  {"kind": _kind(value)})
    return bool(value)


def _in_scale(value: float) -> float:
    if not SCALE_MIN <= value <= SCALE_MAX:
        raise PydanticCustomError(
            "scale", "{value} is outside the representable range 1.5e-154 .. 6.7e+153 "
            "(2^-511 .. 2^511): products of two such numbers (reduced masses, forces) "
            "would {what} double precision; choose other units",
            {"value": value, "what": "underflow" if value < SCALE_MIN else "overflow"})
    return value


def _name(value):
    """The scene name is a folder name under outputs/, never a path."""
    if not isinstance(value, str):
        raise PydanticCustomError("string_type", "must be a string, not {kind}",
                                  {"kind": _kind(value)})
    problem = ""
    bad = [ch for ch in value if unicodedata.category(ch) in ("Cc", "Cf", "Zl", "Zp")]
    if not value.strip():
        problem = "must not be empty (it names the folder outputs/<name>)"
    elif bad:
        problem = (f"contains the control character U+{ord(bad[0]):04X}; use letters, "
                   f"digits, '-', '_' or '.'")
    elif "/" in value or "\\" in value:
        problem = ("must be a plain folder name, not a path (it contains a slash); "
                   "choose another output folder with --out")
    elif value.startswith("."):
        problem = "must not start with '.' ('.', '..' and hidden folders are not names)"
    elif len(value.encode("utf-8")) > 255:
        problem = "is longer than 255 bytes, the longest folder name file systems allow"
    if problem:
        raise PydanticCustomError("name", problem)
    return value


Num = BeforeValidator(_number)
Finite = Annotated[float, Num, Field(allow_inf_nan=False)]
Positive = Annotated[float, Num, Field(gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Num, Field(ge=0, allow_inf_nan=False)]
#: A mass, radius or stiffness: positive and within SCALE_MIN .. SCALE_MAX.
Scale = Annotated[float, Num, Field(gt=0, allow_inf_nan=False), AfterValidator(_in_scale)]
Int = BeforeValidator(_integer)
Bool = Annotated[bool, BeforeValidator(_boolean)]
# A per-granule or per-contact quantity: one number for all, or one per item.
PerItem = Union[Finite, list[Finite]]
PerItemPositive = Union[Positive, list[Positive]]
PerItemScale = Union[Scale, list[Scale]]
PerItemNonNegative = Union[NonNegative, list[NonNegative]]
Exponent = Annotated[float, Num, Field(gt=1, allow_inf_nan=False)]
Poisson = Annotated[float, Num, Field(gt=-1, lt=0.5)]
# Per-granule fields also take a seeded distribution (see distributions.py).
PerGranule = Union[Finite, list[Finite], Distribution]
PerGranuleScale = Union[Scale, list[Scale], Distribution]
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

    young: PerItemScale = Field(..., description="Young's modulus E of each granule.")
    poisson: Union[Poisson, list[Poisson]] = Field(
        ..., description="Poisson ratio of each granule, in (-1, 0.5).")


class InitialState(_Strict):
    """Positions and velocities from a file (see :mod:`granular_chain.initial_state`)."""

    file: str = Field(..., min_length=1, description="A run's trajectory.h5, an .npz with "
                      "arrays x and v, or a .csv with columns x and v; a relative path is "
                      "taken from the scene file's folder.")
    frame: Annotated[int, Int] = Field(-1, description="Frame of a file with several "
                                       "(Python indexing: -1 is the last).")


class Granules(_Strict):
    """The N granules, indexed 0..N-1 from left to right."""

    count: Annotated[int, Int] = Field(..., ge=1, description="Number of granules N.")
    mass: PerGranuleScale = Field(1.0, description="Mass m_i (one value or N values).")
    radius: PerGranuleScale = Field(0.5, description="Radius r_i (one value or N values).")
    gap: PerGranule = Field(
        0.0,
        description="Gap between neighbours i and i+1 (one value or N-1 values): "
        "0 = just touching, negative = initial overlap (precompression).")
    velocity: Union[Finite, list[Finite],
                    dict[Annotated[int, BeforeValidator(_index_key)], Finite],
                    Distribution] = Field(
        0.0, description="Initial velocity v_i: one value, N values, or a mapping "
        "{index: value} with every other granule at rest (e.g. {0: 1.0} for a striker).")
    friction: Friction = Field(default_factory=Friction)
    material: Optional[Material] = Field(
        None, description="Elastic constants, used when contacts.stiffness is 'hertz'.")
    state: Optional[InitialState] = Field(
        None, description="Start from positions and velocities in a file (another run's "
        "trajectory.h5, an .npz or a .csv) instead of granules.gap and granules.velocity; "
        "walls keep their gaps to the end granules.")
    _x0: Optional[np.ndarray] = PrivateAttr(None)
    _v0: Optional[np.ndarray] = PrivateAttr(None)

    @field_validator("velocity", mode="before")
    @classmethod
    def _each_index_once(cls, value):
        """Refuse a sparse velocity giving one granule twice (``{0: 1.0, "0": 5.0}``):
        the keys are read as indices, and a later one would silently replace the first."""
        if not isinstance(value, dict) or "distribution" in value:
            return value
        seen: dict = {}
        for key in value:
            try:
                index = _index_key(key)
            except PydanticCustomError:
                continue  # the schema names the bad key
            if index in seen:
                raise _FieldProblem("granules.velocity", (
                    f"granule {index} is given twice (as {seen[index]!r} and {key!r}); "
                    f"give each index once"))
            seen[index] = key
        return value

    @model_validator(mode="after")
    def _state_from_file(self, info: ValidationInfo) -> "Granules":
        """Read granules.state now, so that a bad file is refused with the scene."""
        if self.state is None or (info.context or {}).get("stored"):
            return self
        given = {"gap", "velocity"} & self.model_fields_set
        if given:
            raise _FieldProblem("granules.state", f"sets positions and velocities: leave out "
                                f"granules.{' and granules.'.join(sorted(given))}")
        try:
            self._x0, self._v0 = read_state(self.state.file, self.state.frame, self.count)
        except StateFileError as exc:
            raise _FieldProblem("granules.state.file", str(exc)) from None
        return self

    def initial_gaps(self) -> np.ndarray:
        """Gaps of the N-1 contacts at t = 0: from the state file's positions when
        given, else granules.gap (0-d for one value)."""
        n = self.count
        if self._x0 is not None:
            radius = np.broadcast_to(_array(self.radius, n), (n,))
            return np.diff(self._x0) - radius[:-1] - radius[1:]
        return _array(self.gap, n - 1)

    @model_validator(mode="after")
    def _draws_in_bounds(self) -> "Granules":
        """Refuse a recipe whose values break the field's bounds (masses and radii:
        also the range SCALE_MIN .. SCALE_MAX of one number)."""
        n, fr = self.count, self.friction
        scale = (SCALE_MIN, SCALE_MAX)
        for path, value, bound, size, item, limits in (
                ("mass", self.mass, "positive", n, "granule", scale),
                ("radius", self.radius, "positive", n, "granule", scale),
                ("gap", self.gap, "finite", n - 1, "contact", None),
                ("velocity", self.velocity, "finite", n, "granule", None),
                ("friction.kinetic", fr.kinetic, "nonnegative", n, "granule", None),
                ("friction.static", fr.static, "nonnegative", n, "granule", None),
                ("friction.viscous", fr.viscous, "nonnegative", n, "granule", None)):
            problem = check_draw(value, size, bound, item, limits) if is_recipe(value) else ""
            if problem:
                raise _FieldProblem(f"granules.{path}", problem)
        return self


class Damping(_Strict):
    """Energy lost inside a contact: a dashpot in parallel with the spring.

    ``linear``: F_d = c d(delta)/dt (any exponent). ``viscoelastic``: F_d = A
    d/dt(k delta^(n-1)) = A k (n-1) delta^(n-2) d(delta)/dt (for n = 5/2 the
    Kuwabara-Kono / Brilliantov et al. viscoelastic Hertz force). ``restitution``:
    the dashpot whose two-body coefficient of restitution is ``value`` at the impact
    speed ``speed``: at n = 2 the linear dashpot (e holds at every speed; ``speed``
    is not needed), otherwise the viscoelastic one with A from
    :func:`granular_chain.restitution.solve_damping` (e depends on the speed there).
    The wall contacts are damped alike (the wall as an infinite mass).
    """

    model: Literal["linear", "viscoelastic", "restitution"] = Field(
        ..., description="Dashpot law: linear (c), viscoelastic (A) or restitution (e).")
    coefficient: Optional[NonNegative] = Field(
        None, description="c (mass/time) for model linear, A (time) for model viscoelastic.")
    value: Optional[Annotated[float, Num, Field(gt=0, le=1)]] = Field(
        None, description="Coefficient of restitution e in (0, 1] of two touching granules "
        "(model restitution; the granule and the wall for a wall contact).")
    speed: Optional[Positive] = Field(
        None, description="Impact (relative approach) speed at which value (e) holds "
        "(model restitution; needed when an exponent is not 2, where e depends on the speed).")

    @model_validator(mode="after")
    def _one_parameter(self) -> "Damping":
        if self.model == "restitution":
            if self.value is None:
                raise _FieldProblem("value", "model restitution needs value: e in (0, 1]")
            if self.coefficient is not None:
                raise _FieldProblem("coefficient", "model restitution takes value (e), "
                                    "not coefficient")
        elif self.speed is not None:
            raise _FieldProblem("speed", f"speed belongs to model restitution; model "
                                f"{self.model} takes coefficient")
        else:
            if self.coefficient is None:
                what = "c (mass/time)" if self.model == "linear" else "A (time)"
                raise _FieldProblem("coefficient", f"model {self.model} needs coefficient: {what}")
            if self.value is not None:
                raise _FieldProblem("value", f"value (e) belongs to model restitution; model "
                                    f"{self.model} takes coefficient")
        return self


class Contacts(_Strict):
    """One-sided power-law contacts: force k * delta^(n-1) while delta > 0."""

    exponent: Union[Exponent, list[Exponent]] = Field(
        2.0, description="Exponent n of the potential (2 linear, 2.5 Hertz); force ~ delta^(n-1); "
        "2.5 by default with stiffness: hertz.")
    stiffness: Union[Literal["hertz"], PerItemScale] = Field(
        1.0,
        description="Force coefficient k (force = k delta^(n-1)), one value or N-1 values, "
        "or 'hertz' to compute k = (4/3) E* sqrt(R*) from granules.material (then the "
        "exponent is 2.5, its default).")
    damping: Optional[Damping] = Field(
        None, description="Dissipation inside the contacts (absent: elastic contacts).")
    tensile: Bool = Field(
        False, description="false: the total contact force never pulls and the contact ends "
        "when it reaches zero; true: the contact ends at overlap 0 and may pull before.")

    @model_validator(mode="before")
    @classmethod
    def _hertz_exponent(cls, data):
        """``stiffness: hertz`` without an exponent means the Hertz exponent 5/2."""
        return _hertz_default_exponent(data)


def _hertz_default_exponent(data):
    """A contacts or wall mapping with ``stiffness: hertz`` and no exponent gets 2.5."""
    if isinstance(data, dict) and data.get("stiffness") == "hertz" and "exponent" not in data:
        return {**data, "exponent": 2.5}
    return data


class Sine(_Strict):
    """Oscillating wall: displacement amplitude * sin(2 pi frequency t)."""

    amplitude: Finite = Field(..., description="Displacement amplitude (length).")
    frequency: Positive = Field(..., description="Frequency f (1/time); angular 2 pi f.")


class Pulse(_Strict):
    """A piston: the wall moves at ``velocity`` for ``duration``, then stays."""

    velocity: Finite = Field(..., description="Wall velocity along +x while it moves.")
    duration: Positive = Field(..., description="How long the wall moves (time).")


class WallMotion(_Strict):
    """Prescribed motion of a wall along +x: give exactly one of the three."""

    velocity: Optional[Finite] = Field(None, description="Constant wall velocity along +x.")
    sine: Optional[Sine] = Field(None, description="Oscillation about the initial place.")
    pulse: Optional[Pulse] = Field(None, description="A piston stroke at constant velocity.")

    @model_validator(mode="after")
    def _exactly_one(self) -> "WallMotion":
        given = [k for k in ("velocity", "sine", "pulse") if getattr(self, k) is not None]
        if len(given) != 1:
            raise _FieldProblem("", "give exactly one of velocity, sine or pulse"
                                + (f" (got {', '.join(given)})" if given else ""))
        return self


class WallMaterial(_Strict):
    """Elastic constants of a wall, for its Hertz stiffness (sphere on a flat)."""

    young: Scale = Field(..., description="Young's modulus E of the wall.")
    poisson: Poisson = Field(..., description="Poisson ratio of the wall, in (-1, 0.5).")


class Wall(_Strict):
    """A wall beyond an end granule, with the same one-sided contact law; fixed
    unless it has a motion."""

    gap: Finite = Field(0.0, description="Gap between the wall and the end granule.")
    stiffness: Union[Literal["hertz"], Scale] = Field(
        1.0, description="Force coefficient k of the wall contact, or 'hertz' to compute "
        "k = (4/3) E* sqrt(r) (a sphere of radius r on a flat) from the wall's material and "
        "the end granule's granules.material (then the exponent is 2.5, its default).")
    exponent: Exponent = Field(
        2.0, description="Exponent n of the wall contact (2.5 by default with stiffness: "
        "hertz).")
    material: Optional[WallMaterial] = Field(
        None, description="Elastic constants of the wall (young, poisson), used when its "
        "stiffness is 'hertz'.")
    motion: Optional[WallMotion] = Field(
        None, description="Prescribed motion (absent: the wall is fixed).")

    @model_validator(mode="before")
    @classmethod
    def _hertz_exponent(cls, data):
        """``stiffness: hertz`` without an exponent means the Hertz exponent 5/2."""
        return _hertz_default_exponent(data)

    @model_validator(mode="after")
    def _hertz_needs_material(self) -> "Wall":
        if self.stiffness == "hertz":
            if self.material is None:
                raise _FieldProblem("stiffness", "'hertz' needs the wall's material "
                                    "(young, poisson)")
            if self.exponent != 2.5:
                raise _FieldProblem("exponent", "must be 2.5 when stiffness is 'hertz' "
                                    "(Hertz law for a sphere on a flat)")
        elif self.material is not None:
            raise _FieldProblem("material", "is read only with stiffness: hertz")
        return self


class BodyForce(_Strict):
    """A force on every granule along the chain axis: gravity ``m_i g`` or given forces."""

    g: Optional[NonNegative] = Field(
        None, description="Acceleration of gravity: granule i feels m_i g along direction.")
    direction: Literal[-1, 1] = Field(
        -1, description="-1: towards -x (towards the left wall), +1: towards +x.")
    force: Optional[PerGranule] = Field(
        None, description="Force on each granule along +x (one value or N values; "
        "instead of g).")

    @model_validator(mode="after")
    def _one_source(self) -> "BodyForce":
        if (self.g is None) == (self.force is None):
            raise _FieldProblem("", "give either g (with direction) or force, not "
                                + ("both" if self.g is not None else "neither"))
        return self


class Walls(_Strict):
    left: Optional[Wall] = None
    right: Optional[Wall] = None


class Output(_Strict):
    """What a run writes and how often (the cadence never changes the physics)."""

    every: Optional[Annotated[int, Int]] = Field(
        None, ge=1, description="Record a frame every this many steps (Verlet).")
    dt: Optional[Positive] = Field(
        None, description="Record a frame every dt of simulated time, on its multiples, and "
        "one at t_end (Verlet shortens run.dt, when needed, to the largest step that divides "
        "it; the event stepper also records one at each batch of events for N <= 64).")
    trajectory: Bool = Field(True, description="Write trajectory.h5 (t, x, v, energy ledger).")
    vtk: Bool = Field(
        False, description="Write a VTK time series for ParaView/pyvista: run.pvd indexing "
        "vtk/frame_NNNNNN.vtp (granules as points, contacts as line cells).")
    csv: Bool = Field(
        False, description="Write energy.csv (energy ledger per frame) and, when the stepper "
        "logged events, events.csv.")
    events: Bool = Field(
        False, description="Verlet: log every contact opening/closing and stick/slip change "
        "with step and time (trajectory.h5's event variables; events.csv with output.csv); "
        "the event stepper always logs.")
    plots: Bool = Field(
        False, description="Write PNG plots into plots/ (space-time velocity diagram, energy "
        "ledger, granule velocities, a rendered frame).")
    checkpoint_every: Optional[Annotated[int, Int]] = Field(
        None, ge=1, description="Steps between checkpoints (Verlet steps; Taylor steps with "
        "the event stepper): granular-chain run --restart RUN_DIR continues the run from the "
        "latest, bit for bit. A run also checkpoints when it is interrupted.")
    thermo: Optional[Annotated[int, Int]] = Field(
        None, ge=1, description="Steps between thermo lines (t, energies, dissipated energy, "
        "ledger error, closed contacts, sliding granules) printed by granular-chain run and "
        "saved as thermo.csv; default about 20 lines a run. The event stepper writes a line "
        "at its first frame after each 1/20 of t_end.")


#: The options only one stepper reads, by ``run.stepper``: ``run.dt`` and
#: ``run.check_dt`` (Verlet's time step), ``output.events`` (Verlet's event log:
#: the event stepper always logs) and ``output.thermo`` (steps between thermo
#: lines: the event stepper writes one after each 1/20 of t_end); ``run.rtol``,
#: ``run.atol`` and ``run.max_events`` (the event stepper's series tolerances and
#: event cap). Every other field of ``run`` and ``output`` is read by both.
#: Default of ``run.energy_tolerance`` (relative ledger error): see its description.
DEFAULT_ENERGY_TOLERANCE = 1e-2

STEPPER_OPTIONS = {
    "verlet": ("run.dt", "run.check_dt", "run.accept_inaccurate_dt", "output.events",
               "output.thermo"),
    "event": ("run.rtol", "run.atol", "run.max_events"),
}


#: Granule velocities given by index: {index: value}.
SparseVelocity = dict[Annotated[int, BeforeValidator(_index_key)], Finite]


class Stage(_Strict):
    """One stage of a staged run (``run.stages``): the run goes on from the state the
    stage before it ended in, changed as the stage says, until the stage's t_end.

    Only granule velocities change at a stage's start, and only those listed; the
    change's energy enters the ledger as ``stage_work``. The first stage runs the
    scene as written from t = 0.
    """

    t_end: Positive = Field(..., description="The stage ends at this time (the run's "
                            "clock, from t = 0 at the first stage's start); strictly "
                            "greater than the stage before's.")
    name: Optional[Annotated[str, BeforeValidator(_name)]] = Field(
        None, description="A name for the stage, recorded in summary.json (default "
        "stage<k>, k from 0).")
    velocity: SparseVelocity = Field(
        default_factory=dict, description="Velocities set at the stage's start, "
        "{index: value} (e.g. {0: 0.5} strikes granule 0); the others keep theirs. "
        "Not in the first stage (granules.velocity sets the start).")
    velocity_add: SparseVelocity = Field(
        default_factory=dict, description="Velocities added at the stage's start, "
        "{index: change}, after run.stages[k].velocity. Not in the first stage.")

    def changes(self) -> bool:
        """Whether the stage changes the state at its start."""
        return bool(self.velocity or self.velocity_add)


class Run(_Strict):
    """How to step and when to stop (:data:`STEPPER_OPTIONS`: which fields belong to
    one stepper)."""

    stepper: Literal["verlet", "event"] = Field("verlet", description="Time stepper.")
    dt: Optional[Positive] = Field(
        None, description="Verlet time step; default 1/200 of the shortest contact period.")
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
    stop_contact: Annotated[int, Int] = Field(0, ge=0, description="Contact index for stop: separation.")
    max_steps: Annotated[int, Int] = Field(2_000_000_000, ge=1, description="Refuse to take more steps.")
    energy_tolerance: Optional[Positive] = Field(
        DEFAULT_ENERGY_TOLERANCE, description="Largest relative energy-ledger error a "
        "successful run may have: a run that misses it ends with status inaccurate (exit "
        "status 1); null: no such judgement. Default 0.01: every shipped scene at its own dt "
        "keeps its Verlet ledger within 1.2e-4, so 0.01 flags only runs whose energy is "
        "visibly wrong (chain_walls.yaml with exponents 1.001: 0.046 at its default step). "
        "The event stepper also holds its runs to the far tighter tolerance it promises.")
    check_dt: Bool = Field(
        True, description="Refuse a Verlet dt above the stability limit of the stiffest "
        "contact (turn off only to study instability: the run then stops at the first "
        "non-finite state with status nonfinite); off, run.dt is not held to the accuracy "
        "bound either.")
    accept_inaccurate_dt: Bool = Field(
        False, description="Run a Verlet run.dt above the accuracy bound (1/50 of the "
        "shortest contact period or collision time; with linear dashpots also 1/40 of the "
        "shortest relaxation time m_eff/c), which is otherwise refused before the run with "
        "the bound in the message. The run is still judged by run.energy_tolerance.")
    rtol: Positive = Field(1e-12, description="Relative tolerance (event stepper, n != 2).")
    atol: Positive = Field(1e-14, description="Absolute tolerance (event stepper, n != 2).")
    max_events: Annotated[int, Int] = Field(1_000_000, ge=1, description="Event stepper: most events.")
    stages: Optional[list[Stage]] = Field(
        None, description="Run in stages, one after another in one run folder: each "
        "goes on from the state the stage before ended in, with the velocities its "
        "fields set or add, to its own t_end (e.g. settle under gravity, then strike). "
        "run.t_end may be left out (it is the last stage's) or equal to it. Not with "
        "run.stop conditions, moving walls, output.checkpoint_every or output.thermo; "
        "granular-chain run --restart does not continue a staged run.", min_length=1)

    @model_validator(mode="after")
    def _stage_times(self) -> "Run":
        """Stage ends strictly increasing; run.t_end, when given, the last stage's."""
        if not self.stages:
            return self
        for k in range(1, len(self.stages)):
            if not self.stages[k].t_end > self.stages[k - 1].t_end:
                raise _FieldProblem(f"run.stages[{k}].t_end", (
                    f"{self.stages[k].t_end:g} is not after the stage before's t_end "
                    f"{self.stages[k - 1].t_end:g}: stage ends must increase strictly"))
        first, last = self.stages[0], self.stages[-1].t_end
        if first.changes():
            raise _FieldProblem(f"run.stages[0].{'velocity' if first.velocity else 'velocity_add'}",
                                "the first stage starts from the scene as written: give "
                                "the starting velocities in granules.velocity")
        if "t_end" in self.model_fields_set and self.t_end != last:
            raise _FieldProblem("run.t_end", f"is {self.t_end:g} but the last stage ends at "
                                f"{last:g}: leave run.t_end out, or make them equal")
        self.__dict__["t_end"] = last  # (an assignment would validate the model again)
        return self


class Scene(_Strict):
    """A validated scene: everything one run needs, in scaled or SI units."""

    name: Annotated[str, BeforeValidator(_name)] = Field(
        "scene", description="Used for the default output folder outputs/<name>: a plain "
        "folder name (no slashes, control characters or leading '.').")
    units: Literal["scaled", "physical"] = Field(
        "scaled",
        description="'scaled' (paper Appendix A: m = 1, force coefficient 1, v0 = 1) or "
        "'physical' (SI: kg, m, s, N); physical scenes report their scaled eta and gamma.")
    granules: Granules
    contacts: Contacts = Field(default_factory=Contacts)
    walls: Walls = Field(default_factory=Walls)
    body_force: Optional[BodyForce] = Field(
        None, description="Gravity or given forces along the chain axis (absent: none).")
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
        for side in ("left", "right"):
            wall = getattr(self.walls, side)
            if wall is not None and wall.stiffness == "hertz" and self.granules.material is None:
                raise _FieldProblem(f"walls.{side}.stiffness",
                                    "'hertz' needs granules.material (young, poisson)")
        fr = self.granules.friction
        if fr.static is not None:
            kin, sta = np.broadcast_arrays(_array(fr.kinetic, n), _array(fr.static, n))
            below = np.flatnonzero(sta < kin)
            if below.size:
                i = int(below[0])
                raise _FieldProblem(
                    "granules.friction.static",
                    f"static threshold {sta.flat[i]} of granule {i} is below its kinetic "
                    f"friction {kin.flat[i]}")
        self._check_overlaps(n)
        self._check_dissipation_and_forces(n)
        if "separation" in self.run.stop_conditions and self.run.stop_contact > n - 2:
            raise _FieldProblem("run.stop_contact",
                                f"is {self.run.stop_contact} but contacts are numbered 0..{n - 2}")
        if self.output.every is not None and self.output.dt is not None:
            raise _FieldProblem("output", "give either 'every' (steps) or 'dt' (time), not both")
        return self

    @model_validator(mode="after")
    def _stages_fit_the_scene(self) -> "Scene":
        """Stage granule indices in range; refuse what a staged run cannot continue
        across a stage boundary (its clock restarts there for the stepper)."""
        stages = self.run.stages
        if not stages:
            return self
        n = self.granules.count
        for k, stage in enumerate(stages):
            for name in ("velocity", "velocity_add"):
                for i in getattr(stage, name):
                    if not 0 <= i < n:
                        raise _FieldProblem(f"run.stages[{k}].{name}[{i}]",
                                            f"granule index out of range 0..{n - 1}")
        refused = [("run.stop", self.run.stop_conditions,
                    "a staged run goes to each stage's t_end"),
                   ("output.checkpoint_every", self.output.checkpoint_every is not None,
                    "a staged run writes no checkpoint (--restart does not continue it)"),
                   ("output.thermo", self.output.thermo is not None,
                    "a staged run writes a thermo line after each 1/20 of t_end")]
        for side in ("left", "right"):
            wall = getattr(self.walls, side)
            refused.append((f"walls.{side}.motion", wall is not None and wall.motion is not None,
                            "a wall's motion is a function of time, not carried across "
                            "stages"))
        for path, given, why in refused:
            if given:
                raise _FieldProblem(path, f"is not available with run.stages: {why}; "
                                    f"remove it, or run the stages as separate runs")
        return self

    @model_validator(mode="after")
    def _options_of_the_stepper(self, info: ValidationInfo) -> "Scene":
        """Refuse an option the chosen stepper would ignore (:data:`STEPPER_OPTIONS`):
        one set to anything but its default. The scene of a finished run, read back
        for its record, is taken as it was written."""
        if (info.context or {}).get("stored"):
            return self
        stepper = self.run.stepper
        for owner, paths in STEPPER_OPTIONS.items():
            if owner == stepper:
                continue
            for path in paths:
                group, name = path.split(".")
                section = getattr(self, group)
                default = type(section).model_fields[name].default
                if getattr(section, name) != default:
                    unset = "remove it (or set it to null)" if default is None else "remove it"
                    raise _FieldProblem(path, f"is read by the {owner} stepper only; with "
                                        f"run.stepper: {stepper} it would be ignored: {unset}, "
                                        f"or use run.stepper: {owner}")
        return self


    def _check_dissipation_and_forces(self, n: int) -> None:
        """Restitution away from n = 2 needs the speed at which e holds; per-granule
        body forces need one value per granule."""
        damping = self.contacts.damping
        if damping is not None and damping.model == "restitution" and damping.speed is None:
            exps = self.contacts.exponent
            named = [("contacts.exponent", e) for e in (exps if isinstance(exps, list) else [exps])]
            named += [(f"walls.{side}.exponent", getattr(self.walls, side).exponent)
                      for side in ("left", "right") if getattr(self.walls, side) is not None]
            bad = next(((path, e) for path, e in named if e != 2.0), None)
            if bad is not None:
                raise _FieldProblem(
                    "contacts.damping.speed", f"model restitution needs speed (the impact "
                    f"speed at which e = {damping.value} holds): {bad[0]} is {bad[1]}, and "
                    f"for n != 2 e depends on the speed")
        moving = any(w is not None and w.motion is not None
                     for w in (self.walls.left, self.walls.right))
        if (self.output.events and self.run.stepper == "verlet"
                and (damping is not None or self.body_force is not None or moving)):
            raise _FieldProblem("output.events", "the Verlet stepper does not log events for "
                                "scenes with contacts.damping, body_force or a moving wall: "
                                "leave it out, or use run.stepper: event (which logs every event)")
        body = self.body_force
        if body is not None and isinstance(body.force, list) and len(body.force) != n:
            raise _FieldProblem("body_force.force", f"has {len(body.force)} values but "
                                f"granules.count is {n}")

    def _check_overlaps(self, n: int) -> None:
        """Initial overlaps must be smaller than the radii. Scalars stay scalars (0-d):
        a scene of 10^9 granules is refused by its memory estimate, not by this loop."""
        radius = _array(self.granules.radius, n)
        if n > 1:
            r_min = np.minimum(radius[:-1], radius[1:]) if radius.ndim else radius
            gap = self.granules.initial_gaps()
            over = np.atleast_1d(-gap >= r_min)
            bad = np.flatnonzero(over)
            if bad.size:
                i = int(bad[0])
                g = float(np.broadcast_to(gap, over.shape)[i])
                rm = float(np.broadcast_to(r_min, over.shape)[i])
                raise _FieldProblem(
                    "granules.gap",
                    f"initial overlap {-g} of contact {i} is not smaller than the smaller "
                    f"radius {rm}: granules would pass through each other")
        ends = {"left": radius[0] if radius.ndim else radius,
                "right": radius[-1] if radius.ndim else radius}
        for side, end in ends.items():
            wall = getattr(self.walls, side)
            if wall is not None and -wall.gap >= end:
                raise _FieldProblem(
                    f"walls.{side}.gap",
                    f"initial overlap {-wall.gap} is not smaller than the radius {float(end)}")


def _array(value, n: int) -> np.ndarray:
    """A per-item field as an array: 0-d for one value, 1-d for a list or for
    the ``n`` values a distribution recipe draws."""
    if is_recipe(value):
        return draw(value, n)
    return np.asarray(value, dtype=np.float64)


class _FieldProblem(ValueError):
    """Raised inside validators to carry an exact dotted path to :class:`SceneError`."""

    def __init__(self, path: str, problem: str):
        self.path, self.problem = path, problem
        super().__init__(f"{path}: {problem}")


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
              "uniform", "normal", "lognormal", "taper", "repeat"}  # the last five: recipes


def _is_tag(part) -> bool:
    """Union-member tags pydantic puts in error locations ('constrained-float', ...)."""
    if isinstance(part, int):
        return False
    return part in _TYPE_TAGS or bool(_TAG.match(part))


# 'constrained-float', 'function-before[_number(), float]', "literal['hertz']",
# 'list[...]', '[key]', 'tagged-union[...]' (a distribution recipe); a user's key
# such as 'x-wall' or '-1' is not one.
_TAG = re.compile(r"^(constrained-\w+|function-(before|after|wrap|plain)\[.*\]|tagged-union\[.*\]"
                  r"|\w*\[.*\])$")


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


# Errors of a union member the input was not meant for ("Input should be a valid
# list" for a number): the member that matches what was written speaks first.
_OTHER_MEMBER = {"list_type", "dict_type", "model_type", "model_attributes_type"}


def _rank(err) -> int:
    if err["type"] in _OTHER_MEMBER:
        return 0
    if err["type"] == "literal_error" and not isinstance(err.get("input"), str):
        return 1  # a number given for "stiffness: hertz | number": the number's error
    return 2


def _explain(exc: ValidationError, source: str) -> SceneError:
    """The most specific validation error as one SceneError line (file, field, problem)."""
    errors = exc.errors(include_url=False)
    # A per-item field is a union (number or list): each member reports its own
    # error. The one with the deepest real path (an index into the list) is the
    # one that speaks of what the user wrote; at equal depth, the member of the
    # input's own type.
    errors = _recipe_errors(errors)
    first = max(errors, key=lambda e: (len(_dotted(e["loc"]).replace("[", ".[").split(".")),
                                       _rank(e), -errors.index(e)))
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
        # Validators of the scene's sections name the whole path; those of the small
        # models (damping, wall motion, body force) name their field relative to them.
        whole = fp.path if not path or fp.path.startswith(path) else ".".join(
            p for p in (path, fp.path) if p)
        return SceneError(source, whole, fp.problem)
    if err_type == "union_tag_invalid":
        return SceneError(source, f"{path}.distribution", "must be taper, repeat, uniform, "
                          f"normal or lognormal (got {first.get('ctx', {}).get('tag')!r}; "
                          f"see docs/chains.md, Per-granule values)")
    if err_type == "value_error" and path.split(".")[-1] in ("mass", "radius", "gap", "velocity",
                                                           "kinetic", "static", "viscous"):
        return SceneError(source, path, first["msg"].removeprefix("Value error, "))
    if err_type == "missing":
        return SceneError(source, path, "is required but missing")
    return SceneError(source, path, _problem(first))


def _problem(err) -> str:
    """What is wrong with one value, in words (pydantic's wording kept in brackets)."""
    msg, kind, value = err["msg"], err["type"], err.get("input")
    bound = next(iter(err.get("ctx", {}).values()), None)
    if kind in ("number_type", "integer_type", "integer_size", "bool_type", "string_type",
                "name", "scale", "index_twice"):
        return msg
    if kind == "finite_number":
        return f"must be a finite number (NaN and Inf are not allowed; got {value!r})"
    if kind == "greater_than" and bound == 0:
        return f"{msg}: it must be positive (got {value!r})"
    if kind == "greater_than_equal" and bound == 0:
        return f"{msg}: it must not be negative (got {value!r})"
    return f"{msg} (got {value!r})"


def scene_from_dict(data: Any, source: str = "<scene>", *, stored: bool = False) -> Scene:
    """Validate a mapping into a :class:`Scene`, raising :class:`SceneError` on any problem.

    ``stored``: the scene of a finished run, read back for its record; a state file
    it started from is then not read again (it may have moved since).

    Parameters
    ----------
    data : Any
        The raw scene mapping (from YAML or a dict), scaled or SI units as its
        ``units`` says.
    source : str
        Name of where ``data`` came from, first in error messages.
    stored : bool
        True for the scene of a finished run read back (see above).

    Returns
    -------
    Scene
        The validated scene.

    Raises
    ------
    SceneError
        On any problem, naming the dotted field.
    """
    if not isinstance(data, dict):
        raise SceneError(source, "", f"a scene must be a mapping of fields, got {type(data).__name__}")
    try:
        return Scene.model_validate(data, context={"stored": stored})
    except ValidationError as exc:
        raise _explain(exc, source) from None


class _YamlRefused(yaml.YAMLError):
    """A YAML document refused by :class:`_SceneLoader` (one line, with the line number)."""


class _SceneLoader(yaml.SafeLoader):
    """SafeLoader for scene files: bounded alias expansion and nesting, duplicate
    keys refused at every level, and YAML 1.2 floats (``1e-3`` is a number, which
    YAML 1.1 reads as a string)."""

    def __init__(self, stream):
        super().__init__(stream)
        self._alias_nodes = 0
        self._depth = 0
        self._open: set = set()
        self._sizes: dict = {}

    def compose_node(self, parent, index):
        event = self.peek_event()
        line = event.start_mark.line + 1
        if isinstance(event, yaml.AliasEvent):
            node = self.anchors.get(event.anchor)
            if node is not None:
                if event.anchor in self._open:
                    raise _YamlRefused(f"line {line}: alias *{event.anchor} refers to the "
                                       f"collection that contains it (a recursive alias)")
                self._alias_nodes += self._size(node)
                if self._alias_nodes > MAX_ALIAS_NODES:
                    raise _YamlRefused(
                        f"line {line}: aliases expand to more than {MAX_ALIAS_NODES} values "
                        f"(alias *{event.anchor}); refused as a possible 'billion laughs' file")
            return super().compose_node(parent, index)
        self._depth += 1
        if self._depth > MAX_YAML_DEPTH:
            raise _YamlRefused(f"line {line}: nested deeper than {MAX_YAML_DEPTH} levels")
        anchor = getattr(event, "anchor", None)
        if anchor:
            self._open.add(anchor)
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1
            self._open.discard(anchor)

    def _size(self, node) -> int:
        """Nodes in ``node`` once every alias inside it is expanded (memoised)."""
        key = id(node)
        if key not in self._sizes:
            if isinstance(node, yaml.MappingNode):
                size = 1 + sum(self._size(k) + self._size(v) for k, v in node.value)
            elif isinstance(node, yaml.SequenceNode):
                size = 1 + sum(self._size(v) for v in node.value)
            else:
                size = 1
            self._sizes[key] = size
        return self._sizes[key]

    def get_single_node(self):
        node = super().get_single_node()
        if node is not None:
            self._check_duplicates(node, "", set())
        return node

    def _check_duplicates(self, node, path: str, seen: set) -> None:
        if id(node) in seen:
            return
        seen.add(id(node))
        if isinstance(node, yaml.SequenceNode):
            for i, item in enumerate(node.value):
                self._check_duplicates(item, f"{path}[{i}]", seen)
            return
        if not isinstance(node, yaml.MappingNode):
            return
        first: dict = {}
        for key_node, value_node in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self._key(key_node)
            name = f"{path}.{key}" if path else str(key)
            if key in first:
                raise _YamlRefused(
                    f"{name}: duplicate key at line {key_node.start_mark.line + 1} (first "
                    f"at line {first[key] + 1}); a later value would silently replace it")
            first[key] = key_node.start_mark.line
            self._check_duplicates(value_node, name, seen)

    def _key(self, node):
        if isinstance(node, yaml.ScalarNode):
            try:
                key = self.yaml_constructors[node.tag](self, node)
                hash(key)
                return key
            except Exception:  # an unusual key: compare it as written
                return (node.tag, node.value)
        return ("node", id(node))


# Numbers as YAML 1.2 (core schema) reads them, not as PyYAML's YAML 1.1: ``010`` is
# ten (not octal 8), ``1e-3`` is a float (not a string), and ``1:30`` (base 60: 90),
# ``1_000`` and ``0b101`` are not numbers (strings, which the schema refuses).
_INT_TAG, _FLOAT_TAG = "tag:yaml.org,2002:int", "tag:yaml.org,2002:float"
_SceneLoader.yaml_implicit_resolvers = {
    first: [(tag, regexp) for tag, regexp in resolvers if tag not in (_INT_TAG, _FLOAT_TAG)]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()}
_SceneLoader.add_implicit_resolver(
    _INT_TAG, re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$"), list("-+0123456789"))
_SceneLoader.add_implicit_resolver(
    _FLOAT_TAG,
    re.compile(r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
               r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"),
    list("-+0123456789."))


def _yaml12_int(loader, node) -> int:
    """An integer of the YAML 1.2 core schema: decimal (leading zeros allowed), 0o, 0x."""
    text = loader.construct_scalar(node)
    if text.startswith(("0o", "0x")):
        return int(text[2:], 8 if text[1] == "o" else 16)
    return int(text, 10)


_SceneLoader.add_constructor(_INT_TAG, _yaml12_int)


def _yaml_problem(exc: yaml.YAMLError) -> str:
    if isinstance(exc, _YamlRefused):
        return str(exc)
    mark = getattr(exc, "problem_mark", None)
    where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    return f"invalid YAML at {where}{problem}"


def parse_yaml_value(text: str) -> Any:
    """One YAML value with the scene file's rules (``1e-3`` is a float; aliases bounded).

    Parameters
    ----------
    text : str
        YAML text of one value (``0.3``, ``[0, 0.3]``, a whole mapping).

    Returns
    -------
    Any
        The parsed value.

    Raises
    ------
    yaml.YAMLError
        Text that is not YAML.
    """
    return yaml.load(text, Loader=_SceneLoader)


def read_scene_data(path: Union[str, Path]) -> Any:
    """The raw mapping of a scene file: size, aliases, nesting and duplicate keys checked.

    Parameters
    ----------
    path : str or pathlib.Path
        The scene's YAML file.

    Returns
    -------
    Any
        The parsed YAML document (a mapping for a scene file), not yet validated.

    Raises
    ------
    SceneError
        No such file, not a regular file, larger than MAX_SCENE_BYTES, not UTF-8, or
        invalid YAML (with line and column), in one line.
    """
    path = Path(path)
    source = str(path)
    if not path.exists():
        raise SceneError(source, "", "no such file")
    if path.is_dir():
        raise SceneError(source, "", "is a folder, not a scene file")
    if not path.is_file():
        raise SceneError(source, "", "is not a regular file")
    try:
        with open(path, "rb") as fh:
            raw = fh.read(MAX_SCENE_BYTES + 1)
    except OSError as exc:
        raise SceneError(source, "", f"cannot be read ({exc.strerror or exc})") from None
    if len(raw) > MAX_SCENE_BYTES:
        raise SceneError(source, "", f"is larger than {MAX_SCENE_BYTES} bytes (1 MiB), the "
                         f"largest scene file read; give long per-item lists as one value")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SceneError(source, "", f"is not a UTF-8 text file (byte {exc.start}: "
                         f"{exc.reason})") from None
    try:
        return parse_yaml_value(text)
    except yaml.YAMLError as exc:
        raise SceneError(source, "", _yaml_problem(exc)) from None
    except RecursionError:
        raise SceneError(source, "", "invalid YAML: nested too deeply") from None


#: ``name[i]``: item i of a list field (negative i counts from the end).
_INDEX = re.compile(r"^(?P<name>[A-Za-z_][A-Za-z0-9_]*)\[(?P<i>-?\d+)\]$")
#: Fields with one value per granule or per contact: one of their items can be set
#: even where the scene gives a single value for all (it is expanded first).
_PER_GRANULE = {"granules.mass", "granules.radius", "granules.velocity",
                "granules.friction.kinetic", "granules.friction.static",
                "granules.friction.viscous", "granules.material.young",
                "granules.material.poisson"}
_PER_CONTACT = {"granules.gap", "contacts.exponent", "contacts.stiffness"}
#: Values of per-item fields the scene leaves out (the schema's defaults).
_ITEM_DEFAULTS = {"granules.mass": 1.0, "granules.radius": 0.5}


def set_path(data: dict, path: str, value, source: str = "--set") -> None:
    """Set one field of a raw scene mapping: ``data[a][b][c] = value`` for ``a.b.c``.

    The one dotted-path setter of the engine (``--set``, sweep axes). A last part
    ``c[i]`` sets item i of a list; a per-granule (per-contact) field that holds
    a single number, or a sparse ``{index: value}`` velocity, is first expanded to
    one value per granule (contact), so that one of them can be set. Missing
    groups are created; nothing is validated here (:func:`scene_from_dict` does).

    Parameters
    ----------
    data : dict
        The raw scene mapping, modified in place.
    path : str
        Dotted field path, ``a.b.c`` or ``a.b.c[i]``.
    value : Any
        The new value, in the scene's units.
    source : str
        Name used in error messages.

    Raises
    ------
    SceneError
        An empty part, a part that is not a group of fields, an index into a field
        that is not a list, or an index out of range.
    """
    parts = path.split(".")
    if not path or any(not p for p in parts):
        raise SceneError(source, path, "empty field name in dotted path")
    target = data
    for part in parts[:-1]:
        nxt = target.get(part)
        if nxt is None:
            nxt = target[part] = {}
        if not isinstance(nxt, dict):
            raise SceneError(source, path, f"'{part}' is not a group of fields")
        target = nxt
    last = _INDEX.match(parts[-1])
    if last is None:
        target[parts[-1]] = value
        return
    name, i = last["name"], int(last["i"])
    items = _item_list(data, ".".join(parts[:-1] + [name]), target.get(name), source, path)
    if not -len(items) <= i < len(items):
        raise SceneError(source, path, f"index {i} out of range for {len(items)} values")
    items[i] = value
    target[name] = items


def _item_list(data: dict, plain: str, current, source: str, path: str) -> list:
    """A copy of the list a ``name[i]`` path indexes: the list itself, or a per-item
    field's single value (or sparse velocity mapping) expanded to one per item."""
    if isinstance(current, list):
        return list(current)
    granules = data.get("granules")
    count = granules.get("count", 0) if isinstance(granules, dict) else 0
    if not isinstance(count, int) or isinstance(count, bool):
        raise SceneError(source, path, "needs granules.count, a whole number, to expand "
                         "a per-item field")
    if plain in _PER_GRANULE:
        size = count
    elif plain in _PER_CONTACT:
        size = count - 1
    else:
        raise SceneError(source, path, f"'{plain.rsplit('.', 1)[-1]}' is not a list and "
                         f"not a per-granule field")
    if isinstance(current, dict):  # a sparse velocity mapping {index: value}
        if "distribution" in current:
            raise SceneError(source, path, "is a distribution recipe: set the whole field")
        full = [0.0] * size
        try:
            for k, item in current.items():
                full[int(k)] = item
        except (ValueError, TypeError, IndexError):
            raise SceneError(source, path, f"{plain} holds a granule index out of range "
                             f"0..{size - 1}") from None
        return full
    return [_ITEM_DEFAULTS.get(plain, 0.0) if current is None else current] * size


def apply_overrides(data: dict, overrides: list[str], source: str = "--set") -> dict:
    """Apply ``dotted.path=value`` overrides (values parsed as YAML) to a scene mapping.

    Parameters
    ----------
    data : dict
        The raw scene mapping (modified in place and returned).
    overrides : list of str
        Items like ``granules.friction.kinetic=[0, 0.3]``, ``run.dt=1e-4`` or
        ``granules.friction.kinetic[1]=0.3`` (see :func:`set_path`).
    source : str
        Name used in error messages.

    Returns
    -------
    dict
        ``data``, with the overrides applied.

    Raises
    ------
    SceneError
        An item without ``=``, an empty field name, a value that is not YAML, or a path
        :func:`set_path` refuses.
    """
    for item in overrides:
        if "=" not in item:
            raise SceneError(source, item, "an override must look like dotted.path=value")
        path, raw = item.split("=", 1)
        path = path.strip()
        if not path or any(not p for p in path.split(".")):
            raise SceneError(source, path or item, "empty field name in dotted path")
        try:
            value = parse_yaml_value(raw)
        except yaml.YAMLError as exc:
            raise SceneError(source, path, f"value {raw!r} is not valid YAML "
                             f"({_yaml_problem(exc)})") from None
        set_path(data, path, value, source)
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
    data = read_scene_data(path)
    if data is None:
        raise SceneError(str(path), "", "the file is empty")
    if overrides:
        if not isinstance(data, dict):
            raise SceneError(str(path), "", "a scene must be a mapping of fields")
        apply_overrides(data, overrides, source=f"{path} (--set)")
    _resolve_state_file(data, path.parent)
    return scene_from_dict(data, source=str(path))


def _resolve_state_file(data, folder: Path) -> None:
    """A relative granules.state.file is taken from the scene file's folder."""
    granules = data.get("granules") if isinstance(data, dict) else None
    state = granules.get("state") if isinstance(granules, dict) else None
    if not isinstance(state, dict) or not isinstance(state.get("file"), str):
        return
    file = Path(state["file"])
    if not file.is_absolute():
        state["file"] = str(folder / file)


def scene_json_schema() -> dict:
    """The JSON Schema of a scene file.

    Returns
    -------
    dict
        The schema (JSON-ready), with each field's description and units.
    """
    return _json_schema_bounds(Scene.model_json_schema())


# Bounds pydantic leaves under its own names in the schemas of annotated types.
_BOUNDS = {"ge": "minimum", "gt": "exclusiveMinimum", "le": "maximum", "lt": "exclusiveMaximum"}


def _json_schema_bounds(node):
    """``node`` with pydantic's ge/gt/le/lt named as JSON Schema's bounds, so that
    other validators see them (in schema objects only: those with a ``type``)."""
    if isinstance(node, list):
        return [_json_schema_bounds(item) for item in node]
    if not isinstance(node, dict):
        return node
    typed = "type" in node
    return {(_BOUNDS.get(key, key) if typed else key): _json_schema_bounds(value)
            for key, value in node.items()}
