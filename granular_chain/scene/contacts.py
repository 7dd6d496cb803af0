"""``contacts``: the power law of every contact and its dashpot (``damping``)."""

from __future__ import annotations

from typing import Annotated, Literal, Optional, Union

from pydantic import (
    Field,
    ValidationInfo,
    field_validator,
    model_validator,
)

from ..laws.contact import contact_law
from .values import (Bool, Exponent, NonNegative, Num, PerItemScale, Positive, _FieldProblem,
                     _Strict)


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

    law: str = Field(
        "auto", description="Contact law: 'auto' (linear for n = 2, hertz for n = 5/2, power "
        "otherwise), one of those by name, or a law registered with "
        "granular_chain.register_contact_law (docs/architecture.md).")
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

    @field_validator("law")
    @classmethod
    def _known_law(cls, name: str, info: ValidationInfo) -> str:
        """'auto' or a registered law (an installed package's entry point included). The
        scene of a finished run, read back for its record, is taken as it was written
        (a law a script registered need not be registered to read its run)."""
        if name != "auto" and not (info.context or {}).get("stored"):
            try:
                contact_law(name)
            except KeyError as exc:
                raise ValueError(exc.args[0]) from None
        return name

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
