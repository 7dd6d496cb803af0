"""The whole scene (:class:`Scene`): its sections checked against each other, and its
JSON schema."""

from __future__ import annotations

from typing import Annotated, Literal, Optional

import numpy as np
from pydantic import (
    BeforeValidator,
    Field,
    ValidationInfo,
    model_validator,
)

from ..laws.contact import contact_law
from .contacts import Contacts
from .granules import Granules
from .output import Output
from .run import Run, RunVerlet, STEPPER_OPTIONS
from .values import _FieldProblem, _Strict, _array, _name
from .walls import BodyForce, Walls


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
    run: Run = Field(default_factory=RunVerlet)
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
    def _law_fits(self, info: ValidationInfo) -> "Scene":
        """The contact law fits the scene (:meth:`_check_law`); a stored scene is taken
        as it was written."""
        if not (info.context or {}).get("stored"):
            self._check_law()
        return self

    @model_validator(mode="after")
    def _options_of_the_stepper(self, info: ValidationInfo) -> "Scene":
        """Refuse an ``output`` option the chosen stepper would ignore
        (:data:`STEPPER_OPTIONS`; the ``run`` ones are fields of one stepper's
        :data:`Run` only): one set to anything but its default. The scene of a
        finished run, read back for its record, is taken as it was written."""
        if (info.context or {}).get("stored"):
            return self
        stepper = self.run.stepper
        for owner, paths in STEPPER_OPTIONS.items():
            for path in paths:
                group, name = path.split(".")
                if owner == stepper or group != "output":
                    continue
                default = Output.model_fields[name].default
                if getattr(self.output, name) != default:
                    unset = "remove it (or set it to null)" if default is None else "remove it"
                    raise _FieldProblem(path, f"is read by the {owner} stepper only; with "
                                        f"run.stepper: {stepper} it would be ignored: {unset}, "
                                        f"or use run.stepper: {owner}")
        return self

    def _exponents(self) -> list:
        """(dotted path, exponent) of every contact's exponent, the walls' included."""
        exps = self.contacts.exponent
        named = [("contacts.exponent", e) for e in (exps if isinstance(exps, list) else [exps])]
        return named + [(f"walls.{side}.exponent", getattr(self.walls, side).exponent)
                        for side in ("left", "right") if getattr(self.walls, side) is not None]

    def _check_law(self) -> None:
        """A named law fits the exponents it stands for; a registered law (not built in)
        runs on the Verlet stepper, with no dashpot written for power laws."""
        if self.contacts.law == "auto":
            return
        law = contact_law(self.contacts.law)
        if law.exponent is not None:
            bad = next(((path, e) for path, e in self._exponents() if e != law.exponent), None)
            if bad is not None:
                raise _FieldProblem(bad[0], f"is {bad[1]:g} but contacts.law: {law.name} is "
                                    f"the n = {law.exponent:g} law")
        if law.builtin:
            return
        if self.run.stepper == "event":
            raise _FieldProblem("contacts.law", f"{law.name} is not built in: the event stepper "
                                f"has Taylor series only for linear, hertz and power; use "
                                f"run.stepper: verlet")
        damping = self.contacts.damping
        if damping is not None and damping.model != "linear":
            raise _FieldProblem("contacts.damping.model", f"{damping.model} is written for the "
                                f"power law k delta^(n-1), not for contacts.law: {law.name}; "
                                f"use model: linear")

    def _check_dissipation_and_forces(self, n: int) -> None:
        """Restitution away from n = 2 needs the speed at which e holds; per-granule
        body forces need one value per granule."""
        damping = self.contacts.damping
        if damping is not None and damping.model == "restitution" and damping.speed is None:
            bad = next(((path, e) for path, e in self._exponents() if e != 2.0), None)
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
