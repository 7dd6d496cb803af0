"""Checkpoints: the state a run can be continued from (``granular-chain run --restart``).

A checkpoint is ``checkpoint.npz`` in the run folder: the driver's state (numpy arrays and
numbers, kept exactly by ``numpy.savez``) and the scene it belongs to (JSON), written to a
temporary name and renamed, so the file on disk is always a whole checkpoint. It is written
every ``output.checkpoint_every`` steps, once the writers have the frames so far on disk,
and when a run is interrupted. A run that completes removes it, except a Verlet run that
reached t_end, which keeps the one taken at its last frame of the cadence before its last
whole step: a later ``run.t_end`` extends the run from it (:mod:`granular_chain.restart`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

__all__ = ["CHECKPOINT", "save_checkpoint", "load_checkpoint", "scene_difference"]

CHECKPOINT = "checkpoint.npz"


def save_checkpoint(folder, state: dict, scene) -> Path:
    """Write ``folder/checkpoint.npz`` from a driver state and its scene.

    Parameters
    ----------
    folder : str or Path
        The run's (temporary) folder.
    state : dict
        The driver's state: arrays and scalars (positions in scene length units, etc.).
    scene : Scene
        The scene the state belongs to (stored as JSON beside it).

    Returns
    -------
    Path
        The file written.
    """
    path = Path(folder) / CHECKPOINT
    tmp = path.with_name(f".{CHECKPOINT}.tmp")
    with open(tmp, "wb") as fh:
        np.savez(fh, **state, scene_json=np.array(json.dumps(scene.model_dump(mode="json"))))
    os.replace(tmp, path)
    return path


def load_checkpoint(folder) -> tuple[dict, dict]:
    """The state and the scene (as a JSON mapping) of ``folder/checkpoint.npz``.

    Parameters
    ----------
    folder : str or Path
        A folder holding ``checkpoint.npz``.

    Returns
    -------
    (dict, dict)
        The driver state and the scene mapping.
    """
    with np.load(Path(folder) / CHECKPOINT) as data:
        state = {name: data[name] for name in data.files if name != "scene_json"}
        scene = json.loads(str(data["scene_json"]))
    return state, scene


def scene_difference(a, b, path: str = "") -> str:
    """The first dotted path where two scene mappings differ ('' when equal).

    Parameters
    ----------
    a, b : object
        Two scene mappings (or any JSON values inside them).
    path : str
        Dotted path of ``a`` and ``b`` inside the whole scene ('' at the top).

    Returns
    -------
    str
        The dotted path, or '' when equal.
    """
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            found = scene_difference(a.get(key), b.get(key), f"{path}.{key}" if path else key)
            if found:
                return found
        return ""
    return "" if a == b else (path or "the scene")
