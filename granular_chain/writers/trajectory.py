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
        h5.attrs["status"] = result.status.name.lower()
        h5.attrs["message"] = result.message
        h5.attrs["stepper"] = result.stepper
        if result.dt is not None:
            h5.attrs["dt"] = result.dt
        if scene is not None:
            h5.attrs["scene"] = json.dumps(scene.model_dump(mode="json"))
    return path
