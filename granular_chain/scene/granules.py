"""``granules``: masses, radii, gaps, velocities, friction and materials, per granule."""

from __future__ import annotations

from typing import Annotated, Optional, Union

import numpy as np
from pydantic import (
    BeforeValidator,
    Field,
    PrivateAttr,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from ..distributions import Distribution, check_draw, is_recipe
from ..initial_state import StateFileError, read_state
from .values import (Finite, Int, PerGranule, PerGranuleNonNegative, PerGranuleScale, PerItemScale,
                     Poisson, SCALE_MAX, SCALE_MIN, _FieldProblem, _Strict, _array, _index_key)


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
        given, else granules.gap.

        Returns
        -------
        ndarray, shape (N-1,) or ()
            Gaps (length; negative: an initial overlap); 0-d for one value of granules.gap.
        """
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
