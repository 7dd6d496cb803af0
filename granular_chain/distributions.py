"""Recipes for per-granule (and per-contact) scene values: seeded draws and sequences.

Instead of a list of N numbers, a per-granule field of a scene may hold a
recipe::

    granules:
      count: 1000
      mass: {distribution: lognormal, median: 1.0, sigma: 0.1, seed: 7}
      velocity: {distribution: normal, mean: 0.0, std: 0.01, seed: 8}
      friction: {kinetic: {distribution: uniform, low: 0.0, high: 0.05, seed: 9}}
      radius: {distribution: taper, first: 0.5, ratio: 0.97}

The two sequences (no seed, no randomness), for ``i = 0 .. n-1``::

    taper      value_i = first * ratio**i          (numpy: first * ratio ** arange(n))
    repeat     value_i = values[i % len(values)]   (a dimer: values: [1.0, 0.5])

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

Nothing is clipped or redrawn: values that break the field's bounds (a
negative mass from a wide normal, a radius tapered below the smallest number
the scene takes, say) are refused, naming the field, the granule and the
value; pick another seed, a narrower spread, lognormal, or another ratio.
Two fields with the same seed draw from the same stream (their values are
correlated); give each field its own seed.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

__all__ = ["Uniform", "Normal", "LogNormal", "Taper", "Repeat", "Distribution", "draw",
           "check_draw", "is_recipe"]

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


class Taper(_Recipe):
    """A geometric sequence: value_i = first * ratio**i."""

    distribution: Literal["taper"]
    first: Annotated[_Finite, Field(description="Value of item 0.")]
    ratio: Annotated[float, Field(strict=True, gt=0, allow_inf_nan=False,
                                  description="Ratio of item i+1 to item i (> 0).")]


class Repeat(_Recipe):
    """A repeated pattern: value_i = values[i % len(values)]."""

    distribution: Literal["repeat"]
    values: Annotated[list[_Finite], Field(min_length=1, description="The pattern, repeated "
                                           "from item 0 (a dimer: two values).")]


Distribution = Annotated[Union[Uniform, Normal, LogNormal, Taper, Repeat],
                         Field(discriminator="distribution")]
_RECIPES = (Uniform, Normal, LogNormal, Taper, Repeat)


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
    if isinstance(recipe, Taper):  # may overflow to inf: check_draw refuses it
        return recipe.first * recipe.ratio ** np.arange(n, dtype=np.float64)
    if isinstance(recipe, Repeat):
        return np.resize(np.asarray(recipe.values, dtype=np.float64), n)
    rng = np.random.default_rng(recipe.seed)
    if isinstance(recipe, Uniform):
        return rng.uniform(recipe.low, recipe.high, n)
    if isinstance(recipe, Normal):
        return rng.normal(recipe.mean, recipe.std, n)
    return rng.lognormal(math.log(recipe.median), recipe.sigma, n)


def check_draw(recipe, n: int, bound: str, item: str = "granule", scale=None) -> str:
    """What is wrong with the drawn values for a field with this bound, or ''.

    Parameters
    ----------
    recipe : Uniform, Normal, LogNormal, Taper or Repeat
        A recipe (see the module docstring).
    n : int
        Number of values.
    bound : str
        ``positive``, ``nonnegative`` or ``finite``.
    item : str
        What the values are indexed by, for the message (``granule`` or ``contact``).
    scale : (float, float), optional
        Smallest and largest value the field takes (masses and radii), besides ``bound``.

    Returns
    -------
    str
        The message, or '' when the values are fine.
    """
    with np.errstate(over="ignore"):
        values = draw(recipe, n)
    # the first check that fails speaks: finite, then the bound, then the range
    checks = [("finite", np.isfinite(values)),
              (">= 0" if bound == "nonnegative" else "> 0",
               values >= 0 if bound == "nonnegative" else values > 0)]
    if bound == "finite":
        checks = checks[:1]
    if scale is not None:
        checks.append((f"within {scale[0]:.3g} .. {scale[1]:.3g}",
                       (values >= scale[0]) & (values <= scale[1])))
    need, bad = next(((need, ~ok) for need, ok in checks if not ok.all()), ("", None))
    if bad is None:
        return ""
    i = int(np.argmax(bad))
    if isinstance(recipe, (Taper, Repeat)):
        source = f"the {recipe.distribution} values give"
        fix = "change first or ratio" if isinstance(recipe, Taper) else "change the values"
    else:
        source = f"the {recipe.distribution} draw with seed {recipe.seed} gives"
        fix = "change the seed or the parameters" + (
            ", or use lognormal" if bound == "positive" else "")
    return (f"{source} {values[i]:.6g} for {item} {i} ({int(bad.sum())} of {n} values not "
            f"{need}); values must be {need}: {fix}")


def is_recipe(value) -> bool:
    """Whether a field's value is a recipe (see the module docstring).

    Parameters
    ----------
    value : object
        A field of a validated scene.

    Returns
    -------
    bool
    """
    return isinstance(value, _RECIPES)
