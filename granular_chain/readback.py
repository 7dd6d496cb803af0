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
from typing import Optional

import h5py
import numpy as np

from .conventions import FRAME_FIELDS, event_kind_names
from .initial_state import StateFileError
from .result import TERMS_ADDED, EnergyLedger, Event, Result, Status, run_model
from .scene import parse_yaml_value, scene_from_dict

__all__ = ["read_run", "read_h5", "read_trajectory", "run_model", "summary_info"]


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
        result, scene = read_h5(h5, summary)
    elif summary:
        result, scene = _from_summary(summary, folder)
    else:
        raise FileNotFoundError(f"{path}: not a run folder (no trajectory.h5, no summary.json)")
    result.scene = scene
    if scene is not None:
        try:
            run_model(result)
        except StateFileError:  # started from a state file that is gone: the frames
            pass  # still read back; run_model says why when the constants are asked for
    return result


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


def _scene_from_attr(h5, path):
    """The scene stored in the file (YAML; JSON in older files, which YAML reads too)."""
    if "scene" not in h5.attrs:
        return None
    return scene_from_dict(parse_yaml_value(str(h5.attrs["scene"])), source=str(path),
                           stored=True)


def read_h5(path, summary: Optional[dict] = None):
    """Read a trajectory.h5 into ``(Result, Scene or None)``, every array as written.

    ``summary`` (summary.json's content) supplies what files of the earlier
    layout (``t``, ``energy/*``, ``events/*``) did not hold: final state, steps,
    wall time and event counts.

    Parameters
    ----------
    path : path
        The trajectory.h5 file.
    summary : dict, optional
        summary.json's content (needed only for files of the earlier layout).

    Returns
    -------
    tuple
        ``(Result, Scene or None)``, in the units the file was written in.

    Raises
    ------
    ValueError
        When the file has no status (the run did not finish writing it).
    """
    summary = summary or {}
    with h5py.File(path, "r") as h5:
        a = h5.attrs
        if "status" not in a:
            raise ValueError(f"{path}: the run did not finish writing this file (no status)")
        legacy = "time" not in h5
        t = h5["t" if legacy else "time"][...]
        x, v, f = (h5[name][...] for name in FRAME_FIELDS)
        g = h5["energy"] if legacy else h5
        initial = float(g.attrs["initial"] if legacy else a["energy_initial"])
        energy = EnergyLedger(*(g[name][...] for name in ("kinetic", "potential", "coulomb",
                                                          "viscous")), initial=initial,
                              **{name: g[name][...] for name in TERMS_ADDED if name in g})
        if legacy:
            ev = h5["events"] if "events" in h5 else None
            cols = (ev["t"][...], ev["kind"][...], ev["index"][...]) if ev else ((), (), ())
        else:
            cols = (h5["event_time"][...], event_kind_names(h5["event_kind"]),
                    h5["event_index"][...])
        steps = h5["event_step"][...] if "event_step" in h5 else np.full(len(cols[0]), -1)
        events = [Event(float(s), k.decode() if isinstance(k, bytes) else str(k), int(i), int(n))
                  for s, k, i, n in zip(*cols, steps)]
        fin = {**summary, "info": summary_info(summary)} if legacy else {
            "x_final": h5["x_final"][...], "v_final": h5["v_final"][...],
            "t_final": a["t_final"], "steps": a["steps"], "wall_time_s": a["wall_time_s"],
            "event_counts": json.loads(a["event_counts"]), "info": json.loads(a["info"])}
        result = Result(
            t=t, x=x, v=v, f=f, energy=energy, status=Status[str(a["status"]).upper()],
            message=str(a["message"]), steps=int(fin.get("steps", 0)),
            wall_time=float(fin.get("wall_time_s", 0.0)), stepper=str(a["stepper"]),
            dt=float(a["dt"]) if "dt" in a else None,
            t_final=float(fin.get("t_final", t[-1] if t.size else 0.0)),
            x_final=np.asarray(fin.get("x_final", x[-1] if t.size else []), dtype=np.float64),
            v_final=np.asarray(fin.get("v_final", v[-1] if t.size else []), dtype=np.float64),
            events=events, event_counts=dict(fin.get("event_counts", {})),
            info=dict(fin.get("info", {})))
        scene = _scene_from_attr(h5, path)
    return result, scene


def read_trajectory(folder):
    """Read a run folder back: ``(Result, Scene or None)`` (see :func:`granular_chain.read_run`).

    Parameters
    ----------
    folder : path
        A run's output folder.

    Returns
    -------
    tuple
        ``(Result, Scene or None)``, scene units.
    """
    result = read_run(folder)
    return result, result.scene
