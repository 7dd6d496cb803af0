"""Seeded distributions for per-granule (and per-contact) scene values.

Instead of a list of N numbers, a per-granule field of a scene may hold a
recipe::

    granules:
      count: 1000
      mass: {distribution: lognormal, median: 1.0, sigma: 0.1, seed: 7}
      velocity: {distribution: normal, mean: 0.0, std: 0.01, seed: 8}
      friction: {kinetic: {distribution: uniform, low: 0.0, high: 0.05, seed: 9}}

Fields that take one: ``granules.mass``, ``radius``, ``velocity``, ``gap``
(N-1 values, one per contact) and ``granules.friction.kinetic``, ``static``,
``viscous``. The scene keeps the recipe (``granular-chain run`` stores it in
summary.json and trajectory.h5), and the values are drawn from it whenever
the scene is validated or packed, so they are reproducible from the stored
scene alone.

The draw, exactly (``rng = numpy.random.default_rng(seed)``, PCG64, ``n`` the
field's length)::

    uniform    rng.uniform(low, high, n)                     low + (high - low) * U[0, 1)
    normal     rng.normal(mean, std, n)                      mean + std * Z
    lognormal  rng.lognormal(math.log(median), sigma, n)     exp(log(median) + sigma * Z)

Uniform and normal draws involve only arithmetic on the generator's stream,
so they are identical on every machine with the same NumPy version (NumPy
keeps a Generator's stream for a given version; see NEP 19); lognormal also
calls the C library's ``exp``, correctly rounded in practice on glibc.

Nothing is clipped or redrawn: a draw that breaks the field's bounds (a
negative mass from a wide normal, say) is refused, naming the field, the
granule and the value; pick another seed, a narrower spread or lognormal.
Two fields with the same seed draw from the same stream (their values are
correlated); give each field its own seed.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

__all__ = ["Uniform", "Normal", "LogNormal", "Distribution", "draw", "check_draw"]

# strict: a number is a number (not true or "0.5"), a seed a whole number (not 7.0)
_Finite = Annotated[float, Field(strict=True, allow_inf_nan=False)]
_Seed = Annotated[int, Field(strict=True, ge=0, description="Seed of numpy.random.default_rng.")]


class _Recipe(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Uniform(_Recipe):
    """Values uniform on [low, high)."""

    distribution: Literal["uniform"]
    low: _Finite
    high: _Finite
    seed: _Seed

    @model_validator(mode="after")
    def _ordered(self) -> "Uniform":
        if not self.high > self.low:
            raise ValueError(f"high ({self.high}) must be greater than low ({self.low})")
        return self


class Normal(_Recipe):
    """Normal values with this mean and standard deviation."""

    distribution: Literal["normal"]
    mean: _Finite
    std: Annotated[float, Field(strict=True, gt=0, allow_inf_nan=False)]
    seed: _Seed


class LogNormal(_Recipe):
    """Positive values whose logarithm is normal: exp(log(median) + sigma * Z)."""

    distribution: Literal["lognormal"]
    median: Annotated[float, Field(strict=True, gt=0, allow_inf_nan=False)]
    sigma: Annotated[float, Field(strict=True, gt=0, allow_inf_nan=False)]
    seed: _Seed


Distribution = Annotated[Union[Uniform, Normal, LogNormal], Field(discriminator="distribution")]


def draw(recipe, n: int) -> np.ndarray:
    """The ``n`` values of a recipe, shape (n,), float64 (see the module docstring).

    Parameters
    ----------
    recipe : float, list or mapping
        A per-granule field of the scene file: one value, N values, or a
        distribution recipe (see the module docstring).
    n : int
        Number of values.

    Returns
    -------
    ndarray, shape (n,)
        float64, in the unit of the field.
    """
    rng = np.random.default_rng(recipe.seed)
    if isinstance(recipe, Uniform):
        return rng.uniform(recipe.low, recipe.high, n)
    if isinstance(recipe, Normal):
        return rng.normal(recipe.mean, recipe.std, n)
    return rng.lognormal(math.log(recipe.median), recipe.sigma, n)


def check_draw(recipe, n: int, bound: str, item: str = "granule") -> str:
    """What is wrong with the drawn values for a field with this bound, or ''.

    Parameters
    ----------
    recipe : float, list or mapping
        A per-granule field of the scene file: one value, N values, or a
        distribution recipe (see the module docstring).
    n : int
        Number of values.
    bound : str
        ``positive``, ``nonnegative`` or ``finite``.
    item : str
        What the values are indexed by, for the message (``granule`` or ``contact``).

    Returns
    -------
    str
        The message, or '' when the values are fine.
    """
    values = draw(recipe, n)
    bad = {"positive": values <= 0, "nonnegative": values < 0,
           "finite": ~np.isfinite(values)}[bound]
    if not bad.any():
        return ""
    i = int(np.argmax(bad))
    need = {"positive": "> 0", "nonnegative": ">= 0", "finite": "finite"}[bound]
    return (f"the {recipe.distribution} draw with seed {recipe.seed} gives {values[i]:.6g} for "
            f"{item} {i} ({int(bad.sum())} of {n} values not {need}); values must be {need}: "
            f"change the seed or the parameters" +
            (", or use lognormal" if bound == "positive" else ""))


def is_recipe(value) -> bool:
    return isinstance(value, (Uniform, Normal, LogNormal))
