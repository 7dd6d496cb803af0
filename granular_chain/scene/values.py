"""What a scene's values may be: numbers, counts, names and flags, each checked in one
place; :class:`SceneError`, the one-line refusal every check ends in."""

from __future__ import annotations

import numbers
import unicodedata
from typing import Annotated, Union

import numpy as np
from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
)
from pydantic_core import PydanticCustomError

from ..distributions import Distribution, draw, is_recipe


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


class _FieldProblem(ValueError):
    """Raised inside validators to carry an exact dotted path to :class:`SceneError`."""

    def __init__(self, path: str, problem: str):
        self.path, self.problem = path, problem
        super().__init__(f"{path}: {problem}")


def _array(value, n: int) -> np.ndarray:
    """A per-item field as an array: 0-d for one value, 1-d for a list or for
    the ``n`` values a distribution recipe draws."""
    if is_recipe(value):
        return draw(value, n)
    return np.asarray(value, dtype=np.float64)
