"""summary.json: status, final state, event counts, energy ledger, cost."""

from __future__ import annotations

import json
import math
from pathlib import Path


def finite_json(data) -> tuple:
    """``data`` with every NaN or Inf replaced by None, and why, keyed by dotted path.

    JSON has no NaN or Infinity; a quantity that overflowed double precision (an
    energy of a scene at extreme scales) is written as null and named in the
    reasons ({"energy.kinetic": "inf: overflowed double precision"}).

    Parameters
    ----------
    data : dict, list or scalar
        JSON-ready data, possibly with NaN or Inf floats.

    Returns
    -------
    (clean, reasons) : (same structure as data, dict)
    """
    reasons: dict = {}

    def clean(value, path):
        if isinstance(value, dict):
            return {k: clean(v, f"{path}.{k}" if path else str(k)) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return [clean(v, f"{path}[{i}]") for i, v in enumerate(value)]
        if isinstance(value, float) and not math.isfinite(value):
            reasons[path] = ("nan: undefined (e.g. inf - inf)" if math.isnan(value) else
                             f"{'-' if value < 0 else ''}inf: overflowed double precision")
            return None
        return value

    return clean(data, ""), reasons


def write_summary(result, folder: Path, scene=None) -> Path:
    """Write ``folder/summary.json`` from a Result (and the scene for reference).

    Non-finite numbers are written as null, with the reason under ``"non_finite"``.

    Parameters
    ----------
    result : Result
        The finished run.
    folder : str or Path
        Run folder written into.
    scene : Scene, optional
        The run's scene (recorded for reference).

    Returns
    -------
    Path
        ``folder/summary.json``.
    """
    data = result.summary()
    if scene is not None:
        data["scene"] = scene.model_dump(mode="json")
    data, reasons = finite_json(data)
    if reasons:
        data["non_finite"] = reasons
    path = Path(folder) / "summary.json"
    path.write_text(json.dumps(data, indent=2, allow_nan=False) + "\n")
    return path
