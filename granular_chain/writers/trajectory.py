"""trajectory.h5: positions, velocities, forces and the energy ledger at the output frames.

Self-describing HDF5: every dataset carries ``units`` and a ``description``
attribute, and the scene is stored as JSON in the file's ``scene`` attribute::

    import h5py; f = h5py.File("trajectory.h5"); f["x"][...]   # (frames, granules)
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

__all__ = ["write_trajectory", "read_trajectory"]


def write_trajectory(result, folder: Path, scene=None) -> Path:
    """Write ``folder/trajectory.h5`` from a Result."""
    path = Path(folder) / "trajectory.h5"
    units = (scene.units if scene is not None else "scaled")
    L, T, V, F, E = (("scaled length", "scaled time", "scaled velocity", "scaled force",
                      "scaled energy") if units == "scaled" else ("m", "s", "m/s", "N", "J"))
    with h5py.File(path, "w") as h5:
        def put(name, data, unit, text):
            ds = h5.create_dataset(name, data=np.asarray(data))
            ds.attrs["units"] = unit
            ds.attrs["description"] = text

        put("t", result.t, T, "time of each frame, shape (frames,)")
        put("x", result.x, L, "granule centre positions, shape (frames, granules)")
        put("v", result.v, V, "granule velocities, shape (frames, granules)")
        put("f", result.f, F, "net spring force on each granule, shape (frames, granules)")
        led = result.energy
        g = h5.create_group("energy")
        g.attrs["initial"] = led.initial
        g.attrs["units"] = E
        for name, arr, text in (
                ("kinetic", led.kinetic, "sum of m v^2/2"),
                ("potential", led.potential, "elastic energy of the contacts"),
                ("coulomb", led.coulomb, "energy dissipated by kinetic friction so far"),
                ("viscous", led.viscous, "energy dissipated by hydrodynamic friction so far"),
                ("balance", led.balance, "kinetic+potential+coulomb+viscous-initial")):
            ds = g.create_dataset(name, data=arr)
            ds.attrs["units"] = E
            ds.attrs["description"] = text
        if result.events:
            ev = h5.create_group("events")
            ev.attrs["description"] = "event log of the event stepper, one row per event"
            put("events/t", [e.t for e in result.events], T, "time of each event")
            put("events/kind", np.array([e.kind for e in result.events], dtype="S"), "",
                "contact_close, contact_open, stop or slip")
            put("events/index", np.array([e.index for e in result.events], dtype=np.int64),
                "", "contact (-1 left wall, N-1 right wall) or granule index")
        h5.attrs["status"] = result.status.name.lower()
        h5.attrs["message"] = result.message
        h5.attrs["stepper"] = result.stepper
        if result.dt is not None:
            h5.attrs["dt"] = result.dt
        if scene is not None:
            h5.attrs["scene"] = json.dumps(scene.model_dump(mode="json"))
    return path


def read_trajectory(folder):
    """Read ``folder/trajectory.h5`` (and summary.json if present) back into a Result.

    Returns
    -------
    result : Result
        Frames, energy ledger, status and message as written; ``steps`` and
        ``wall_time`` come from summary.json when it is there (else 0).
    scene : Scene or None
        The scene stored in the file's metadata.
    """
    from ..result import EnergyLedger, Event, Result, Status
    from ..scene import scene_from_dict

    folder = Path(folder)
    path = folder / "trajectory.h5"
    summary = {}
    if (folder / "summary.json").exists():
        summary = json.loads((folder / "summary.json").read_text())
    with h5py.File(path, "r") as h5:
        t, x, v, f = (h5[name][...] for name in ("t", "x", "v", "f"))
        g = h5["energy"]
        energy = EnergyLedger(kinetic=g["kinetic"][...], potential=g["potential"][...],
                              coulomb=g["coulomb"][...], viscous=g["viscous"][...],
                              initial=float(g.attrs["initial"]))
        events = []
        if "events" in h5:
            e = h5["events"]
            events = [Event(float(a), b.decode(), int(c))
                      for a, b, c in zip(e["t"][...], e["kind"][...], e["index"][...])]
        status = Status[str(h5.attrs["status"]).upper()]
        scene = None
        if "scene" in h5.attrs:
            scene = scene_from_dict(json.loads(h5.attrs["scene"]), source=str(path))
        result = Result(
            t=t, x=x, v=v, f=f, energy=energy, status=status, message=str(h5.attrs["message"]),
            steps=int(summary.get("steps", 0)), wall_time=float(summary.get("wall_time_s", 0.0)),
            stepper=str(h5.attrs["stepper"]), dt=float(h5.attrs["dt"]) if "dt" in h5.attrs else None,
            t_final=float(summary.get("t_final", t[-1])),
            x_final=np.asarray(summary.get("x_final", x[-1]), dtype=np.float64),
            v_final=np.asarray(summary.get("v_final", v[-1]), dtype=np.float64),
            events=events, event_counts=dict(summary.get("event_counts", {})))
    return result, scene
