"""summary.json: status, final state, event counts, energy ledger, cost."""

from __future__ import annotations

import json
from pathlib import Path


def write_summary(result, folder: Path, scene=None) -> Path:
    """Write ``folder/summary.json`` from a Result (and the scene for reference)."""
    data = result.summary()
    if scene is not None:
        data["scene"] = scene.model_dump(mode="json")
    path = Path(folder) / "summary.json"
    path.write_text(json.dumps(data, indent=2, allow_nan=False) + "\n")
    return path
