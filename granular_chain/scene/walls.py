"""``walls`` and ``body_force``: fixed or driven walls at the chain's ends, and gravity."""

from __future__ import annotations

from typing import Literal, Optional, Union

from pydantic import (
    Field,
    model_validator,
)

from .contacts import _hertz_default_exponent
from .values import (Exponent, Finite, NonNegative, PerGranule, Poisson, Positive, Scale,
                     _FieldProblem, _Strict)


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
    """The walls at the chain's ends (absent: an open end)."""

    left: Optional[Wall] = None
    right: Optional[Wall] = None
