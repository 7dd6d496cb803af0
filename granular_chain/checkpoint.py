"""Checkpoints: the state a run can be continued from (``granular-chain run --restart``).

A checkpoint is ``checkpoint.npz`` in the run folder: the driver's state (numpy arrays and
numbers, kept exactly by ``numpy.savez``) and the scene it belongs to (JSON), written to a
temporary name and renamed, so the file on disk is always a whole checkpoint. It is written
every ``output.checkpoint_every`` steps, once the writers have the frames so far on disk,
and when a run is interrupted. A run that completes removes it, except a Verlet run that
reached t_end, which keeps the one taken at its last frame of the cadence before its last
whole step: a later ``run.t_end`` extends the run from it (:mod:`granular_chain.restart`).

Every checkpoint has the same frame: ``format`` (:data:`CHECKPOINT_FORMAT`), ``stepper``
("verlet" or "event"), the frame log's part (``log_count``, ``log_max_balance_error``,
``log_keep``, the first and latest frames ``log_first_<field>``, ``log_last_<field>``:
:meth:`granular_chain.frames.FrameLog.checkpoint_state`), what ``granular-chain run``
adds for its writers (``thermo_lines``, ``thermo_last_t``) and ``scene_json``; then the
stepper's own state (:meth:`granular_chain.steppers.verlet.driver.VerletRun.checkpoint_state`,
:func:`granular_chain.steppers.events.driver.checkpoint_state`). Checkpoints written
before this frame (a Verlet one without ``format``, an event one of format 3) are read
in its terms (:func:`upgrade`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

__all__ = ["CHECKPOINT", "CHECKPOINT_FORMAT", "save_checkpoint", "load_checkpoint",
           "upgrade", "check_checkpoint", "scene_difference"]

CHECKPOINT = "checkpoint.npz"
#: The checkpoints' format: 4 since both steppers write the same frame.
CHECKPOINT_FORMAT = 4


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
    return upgrade(state), scene


def upgrade(state: dict) -> dict:
    """A checkpoint state in the terms of :data:`CHECKPOINT_FORMAT` (itself when it is).

    The event stepper's format 3 had every key of format 4 but ``stepper``. A Verlet
    checkpoint written before format 4 has no ``format`` and kept its frame log as
    ``frames``, ``max_error`` and ``first_<field>``, without the latest frame. Any other
    state (an older event format) is returned as it is, for :func:`check_checkpoint` to
    refuse.

    Parameters
    ----------
    state : dict
        A checkpoint state as stored.

    Returns
    -------
    dict
        The state with ``format``, ``stepper`` and the ``log_*`` keys.
    """
    if "stepper" in state:
        return state
    state = dict(state)
    if "format" in state:
        if int(state["format"]) != 3:
            return state  # no layout this reads: check_checkpoint refuses it, naming it
        state["stepper"] = "event"
    else:
        state["stepper"] = "verlet"
        state["log_count"] = state.pop("frames")
        state["log_max_balance_error"] = state.pop("max_error")
        for key in [key for key in state if key.startswith("first_")]:
            state["log_" + key] = state.pop(key)
    state["format"] = CHECKPOINT_FORMAT
    return state


def check_checkpoint(state: dict, stepper: str) -> dict:
    """The state in the terms of :data:`CHECKPOINT_FORMAT` (:func:`upgrade`), refused
    unless it is a checkpoint of ``stepper``.

    Parameters
    ----------
    state : dict
        A checkpoint state, as stored or as a driver gave it.
    stepper : str
        "verlet" or "event": the stepper that is to continue it.

    Returns
    -------
    dict
        The upgraded state.

    Raises
    ------
    ValueError
        Naming what the state is instead.
    """
    state = upgrade(state)
    fmt, made_by = int(state.get("format", -1)), str(state.get("stepper", "?"))
    if fmt != CHECKPOINT_FORMAT or made_by != stepper:
        raise ValueError(f"not a checkpoint of the {stepper} stepper of format "
                         f"{CHECKPOINT_FORMAT} (format {fmt}, stepper {made_by})")
    return state


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
