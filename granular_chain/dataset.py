"""A run as an ``xarray.Dataset``, laid out as trajectory.h5 (the ``analysis`` extra).

:meth:`Result.to_xarray <granular_chain.result.Result.to_xarray>` calls
:func:`to_xarray`; the names, units and attributes are :mod:`.conventions`'.
"""

from __future__ import annotations

import numpy as np

from .conventions import (FRAME_FIELDS, GRANULE_FIELDS, LEDGER_FIELDS, TIME_NAME, cf_attrs,
                          event_columns, final_attrs, granule_values, root_attrs)
from .extras import require

__all__ = ["to_xarray"]


def to_xarray(result, scene=None, model=None):
    """The run as an ``xarray.Dataset`` with the layout of trajectory.h5 (same names,
    dimensions, units and attributes).

    Parameters
    ----------
    result : Result
        A finished run, scene units.
    scene : Scene, optional
        The run's scene: sets the units attributes (scaled without it).
    model : Model, optional
        The run's chain constants (the per-granule variables; none without it).

    Returns
    -------
    xarray.Dataset
        Frames (time, granule), ledger (time), per-granule constants and final
        state (granule), events (event); scene units.
    """
    xr = require("xarray", "granular_chain to_xarray")

    units = scene.units if scene is not None else "scaled"
    coords = {"time": ("time", result.t, cf_attrs(units, "time", TIME_NAME)),
              "granule": ("granule", np.arange(result.x.shape[1], dtype=np.int64),
                          cf_attrs(units, "", "granule index, 0 at the left end")),
              "event": ("event", np.arange(len(result.events), dtype=np.int64),
                        cf_attrs(units, "", "event number"))}
    data = {name: (("time", "granule"), getattr(result, name), cf_attrs(units, kind, text))
            for name, (kind, text) in FRAME_FIELDS.items()}
    led = result.energy
    data.update({name: ("time", getattr(led, name), cf_attrs(units, "energy", text))
                 for name, text in LEDGER_FIELDS.items()})
    for name, values in granule_values(model).items():
        _, kind, text = GRANULE_FIELDS[name]
        data[name] = ("granule", values, cf_attrs(units, kind, text))
    data["x_final"] = ("granule", result.x_final,
                       cf_attrs(units, "length", "final granule position"))
    data["v_final"] = ("granule", result.v_final,
                       cf_attrs(units, "velocity", "final granule velocity"))
    for name, (values, kind, text) in event_columns(result.events).items():
        data[name] = ("event", values, cf_attrs(units, kind, text))
    return xr.Dataset(data, coords=coords, attrs={**root_attrs(scene), **final_attrs(result)})
