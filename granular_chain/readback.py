"""Reading a run back: ``read_run(path)`` gives the :class:`~granular_chain.result.Result`
a run folder holds, as it was in memory when the run ended.

A run folder written by ``granular-chain run`` holds ``trajectory.h5`` (every
frame, the final state, events and status; see :mod:`.writers.trajectory`)
and ``summary.json``. With the trajectory turned off only the summary exists;
the Result then has the final state, status and counts and no frames.

The chain constants of a run read back (``result.model``: radii, masses,
contact laws, walls) are built once from its stored scene (:func:`run_model`).
A run started from a state file that is gone still reads back, without them:
what needs them then says why.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

__all__ = ["read_run", "run_model", "summary_info"]


def read_run(path):
    """The Result of a finished (or interrupted) run.

    Parameters
    ----------
    path : str or Path
        A run folder, or its ``trajectory.h5``.

    Returns
    -------
    Result
        Frames, energy ledger, events, status, message and final state, every
        array equal bit for bit to the one the run computed; ``result.scene``
        is the scene the run was made from (None if the file does not hold it)
        and ``result.model`` its chain constants.

    Raises
    ------
    FileNotFoundError
        ``path`` holds neither trajectory.h5 nor summary.json.
    ValueError
        The trajectory was not finished (the writer was never closed).
    """
    path = Path(path)
    folder = path.parent if path.is_file() else path
    h5 = path if path.is_file() else folder / "trajectory.h5"
    summary = {}
    if (folder / "summary.json").is_file():
        summary = json.loads((folder / "summary.json").read_text())
    if h5.is_file():
        from .writers.trajectory import read_h5

        result, scene = read_h5(h5, summary)
    elif summary:
        result, scene = _from_summary(summary, folder)
    else:
        raise FileNotFoundError(f"{path}: not a run folder (no trajectory.h5, no summary.json)")
    result.scene = scene
    if scene is not None:
        from .initial_state import StateFileError
        try:
            run_model(result)
        except StateFileError:  # started from a state file that is gone: the frames
            pass  # still read back; run_model says why when the constants are asked for
    return result


def run_model(result, scene=None):
    """The chain constants of a run: ``result.model``, built from its scene if need be.

    :func:`granular_chain.simulate` attaches the Model it ran; a Result read
    back by :func:`read_run`, or put together by hand, gets it here, built once
    from ``scene`` (default ``result.scene``) and attached. This is the one
    place where a Result's Model is rebuilt from a Scene.

    Parameters
    ----------
    result : Result
        A run, as simulate() returned it or read_run() read it.
    scene : Scene, optional
        Scene to build the Model from (default ``result.scene``).

    Returns
    -------
    Model or None
        None when the Result has neither a Model nor a scene.
    """
    if result.model is None:
        scene = scene if scene is not None else result.scene
        if scene is not None:
            from .model import build_model
            result.model = build_model(scene)
    return result.model


_SUMMARY_KEYS = {"status", "status_code", "success", "message", "stepper", "dt", "t_final",
                 "x_final", "v_final", "event_counts", "energy", "steps", "frames",
                 "wall_time_s", "scene"}


def summary_info(summary: dict) -> dict:
    """``Result.info`` from summary.json, which writes its entries at the top level.

    Parameters
    ----------
    summary : dict
        The parsed summary.json.

    Returns
    -------
    dict
        The ``info`` entries.
    """
    return {k: v for k, v in summary.items() if k not in _SUMMARY_KEYS}


def _from_summary(summary: dict, folder: Path):
    """A Result without frames from summary.json (a run written without its trajectory)."""
    from .result import EnergyLedger, Result, Status
    from .scene import scene_from_dict

    n = len(summary["x_final"])
    empty = np.zeros(0)
    result = Result(
        t=empty, x=np.zeros((0, n)), v=np.zeros((0, n)), f=np.zeros((0, n)),
        energy=EnergyLedger(empty, empty.copy(), empty.copy(), empty.copy(),
                            initial=float(summary["energy"]["initial"])),
        status=Status[summary["status"].upper()], message=summary["message"],
        steps=int(summary["steps"]), wall_time=float(summary["wall_time_s"]),
        stepper=summary["stepper"], dt=summary["dt"], t_final=float(summary["t_final"]),
        x_final=np.asarray(summary["x_final"], dtype=np.float64),
        v_final=np.asarray(summary["v_final"], dtype=np.float64),
        event_counts=dict(summary["event_counts"]),
        info=summary_info(summary))
    scene = None
    if "scene" in summary:
        scene = scene_from_dict(summary["scene"], source=str(folder / "summary.json"), stored=True)
    return result, scene
