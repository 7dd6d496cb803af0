"""Validation errors said in one line: the file, the field as a dotted path, what is
wrong (and the nearest known field for a misspelt one)."""

from __future__ import annotations

import difflib
import re
from typing import Any, Optional

from pydantic import (
    BaseModel,
    ValidationError,
)

from .schema import Scene
from .values import SceneError, _FieldProblem


def _known_fields(model: type[BaseModel], loc: tuple) -> list[str]:
    """Names allowed at the location of an 'extra field' error, for suggestions
    (``loc`` as pydantic gives it: a ``stepper[...]`` tag picks that member of ``run``)."""
    stepper = next((str(p)[len("stepper["):-1] for p in loc
                    if str(p).startswith("stepper[")), None)
    current: Any = model
    for part in [p for p in loc if not _is_tag(p)][:-1]:
        if isinstance(part, int):
            continue
        fields = getattr(current, "model_fields", None)
        if not fields or part not in fields:
            return []
        ann = fields[part].annotation
        current = _submodel(ann, stepper)
        if current is None:
            return []
    return list(getattr(current, "model_fields", {}).keys())


def _submodel(annotation, stepper: Optional[str] = None) -> Optional[type[BaseModel]]:
    """The model an annotation holds (the member of that ``stepper`` in a union of
    ``run`` members), else None."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    found = [m for m in map(_submodel, getattr(annotation, "__args__", ()) or ()) if m]
    chosen = [m for m in found if "stepper" in m.model_fields
              and m.model_fields["stepper"].default == stepper]
    return (chosen or found or [None])[0]


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
        known = _known_fields(Scene, tuple(loc))
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
    tag = str(first.get("ctx", {}).get("tag", ""))
    if err_type == "union_tag_invalid" and tag.startswith("stepper["):
        return SceneError(source, f"{path}.stepper", f"Input should be 'verlet' or 'event' "
                          f"(got {tag.removeprefix('stepper[').removesuffix(']')!r})")
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
