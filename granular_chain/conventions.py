"""The names, units and attributes of a run's stored variables (CF-1.8), written once.

trajectory.h5 (:mod:`.writers.trajectory`), the run read back (:mod:`.readback`) and
:meth:`Result.to_xarray <granular_chain.result.Result.to_xarray>` lay a run out with the
same variable names, dimensions, ``units`` and ``long_name`` attributes and global
attributes: this module holds them, so that none of the three imports another.
"""

from __future__ import annotations

import json

import h5py
import numpy as np
import yaml

from .codes import EVENT_KINDS
from .version import __version__

__all__ = ["FRAME_FIELDS", "LEDGER_FIELDS", "LEDGER_TERMS", "GRANULE_FIELDS", "EVENT_FIELDS",
           "TIME_NAME", "cf_attrs", "event_columns", "event_kind_names", "root_attrs",
           "final_attrs", "granule_values"]

UNITS = {  # CF / UDUNITS strings per kind of quantity
    "physical": {"time": "s", "length": "m", "velocity": "m s-1", "force": "N",
                 "energy": "J", "mass": "kg", "damping": "kg s-1", "": "1"},
}
SCALED = "scaled, paper Appendix A"
# The frames' time is elapsed time from the run's start, not a date: CF's time
# coordinate (axis T) needs units "<unit> since <date>", which a scaled time in
# units of "1" cannot have, so ``time`` is a plain coordinate with units s or 1.
TIME_NAME = "time since the start of the run"

#: (time, granule) arrays: name -> (kind, long_name)
FRAME_FIELDS = {
    "x": ("length", "granule centre position"),
    "v": ("velocity", "granule velocity"),
    "f": ("force", "net contact force on the granule from its neighbours and the walls"),
}
#: (time,) ledger arrays: name -> long_name (the columns of energy.csv)
LEDGER_FIELDS = {
    "kinetic": "kinetic energy, sum of m v^2/2",
    "potential": "elastic energy of the contacts",
    "coulomb": "energy dissipated by kinetic (Coulomb) friction so far",
    "viscous": "energy dissipated by hydrodynamic friction so far",
    "contact_dissipated": "energy dissipated by the contacts' dashpots so far",
    "wall_work": "work done on the chain by moving walls so far",
    "body_work": "work done on the chain by body forces so far",
    "stage_work": "energy put in by the velocity changes at stage starts so far",
    "balance": "kinetic + potential + coulomb + viscous + contact_dissipated - wall_work "
               "- body_work - stage_work - initial energy (integrator error)",
}
LEDGER_TERMS = tuple(name for name in LEDGER_FIELDS if name != "balance")
# (granule,) arrays of the model: name -> (Model attribute, kind, long_name)
GRANULE_FIELDS = {
    "mass": ("mass", "mass", "granule mass"),
    "radius": ("radius", "length", "granule radius"),
    "friction_kinetic": ("eta", "force", "kinetic (Coulomb) friction force"),
    "friction_static": ("eta_static", "force", "static friction threshold"),
    "friction_viscous": ("gamma", "damping", "hydrodynamic friction coefficient"),
}


# The event log's variables (dimension ``event``): name -> (Event attribute, numpy
# dtype, kind of unit, long name); written by the writer and by to_xarray alike.
EVENT_FIELDS = {
    "event_time": ("t", np.float64, "time", "time of the event"),
    "event_kind": ("kind", np.int8, "flag", "kind of event"),
    "event_index": ("index", np.int64, "",
                    "contact (-1 left wall, N-1 right wall) or granule index"),
    "event_step": ("step", np.int64, "",
                   "Verlet step at whose end the event was seen (-1: event stepper)"),
}


#: event_kind is a CF flag variable (CF section 3.5): the EventKind codes, named in
#: flag_meanings: CF's encoding of a few named codes (the CF checker refuses the
#: variable-length strings of earlier files, and classic netCDF has none).
EVENT_FLAGS = {"flag_values": np.arange(len(EVENT_KINDS), dtype=np.int8),
                "flag_meanings": " ".join(EVENT_KINDS)}


def _event_value(event, attr: str):
    """One event's value of ``attr``; its kind as its EventKind code."""
    value = getattr(event, attr)
    return EVENT_KINDS.index(str(value)) if attr == "kind" else value


def event_columns(events) -> dict:
    """The event log's variables, one value an event.

    Parameters
    ----------
    events : sequence of Event
        The run's event log.

    Returns
    -------
    dict
        Variable name -> (values of shape (events,), kind of unit, long name).
    """
    return {name: (np.array([_event_value(e, attr) for e in events], dtype=dtype), kind, text)
            for name, (attr, dtype, kind, text) in EVENT_FIELDS.items()}


def event_kind_names(variable) -> list:
    """The event kinds stored in an ``event_kind`` variable, as names.

    Parameters
    ----------
    variable : h5py.Dataset
        ``event_kind``: flag codes with ``flag_values`` and ``flag_meanings``, or
        (files of earlier versions) variable-length strings.

    Returns
    -------
    list of str
        One name an event (``contact_close``, ``contact_open``, ``stop``, ``slip``).
    """
    if h5py.check_string_dtype(variable.dtype) is not None:
        return [str(k) for k in variable.asstr()[...]]
    meanings = str(variable.attrs["flag_meanings"]).split()
    names = dict(zip((int(v) for v in variable.attrs["flag_values"]), meanings))
    return [names[int(code)] for code in variable[...]]



def cf_attrs(units_system: str, kind: str, long_name: str) -> dict:
    """CF ``units`` and ``long_name`` of a variable of this kind (a flag variable:
    ``flag_values`` and ``flag_meanings`` instead of units).

    Parameters
    ----------
    units_system : str
        ``"physical"`` (SI) or ``"scaled"`` (CF's dimensionless ``"1"``).
    kind : str
        Kind of quantity (``"time"``, ``"length"``, ``"velocity"``, ``"force"``,
        ``"energy"``, ``"mass"``, ``"damping"``, ``"flag"``, or ``""`` for a count).
    long_name : str
        What the variable is.

    Returns
    -------
    dict
        The variable's attributes.
    """
    if kind == "flag":
        return {"long_name": long_name, **EVENT_FLAGS}
    if units_system == "physical" or not kind:
        return {"units": UNITS["physical"][kind], "long_name": long_name}
    return {"units": "1", "long_name": f"{long_name} ({SCALED})"}


def root_attrs(scene) -> dict:
    """Global attributes known before the run: conventions, engine, the scene as YAML.

    Parameters
    ----------
    scene : Scene or None
        The run's scene (None: scaled units, no scene stored).

    Returns
    -------
    dict
        Attribute name -> value.
    """
    attrs = {"Conventions": "CF-1.8", "source": f"granular_chain {__version__}",
             "engine": "granular_chain", "engine_version": __version__,
             "units_system": scene.units if scene is not None else "scaled"}
    if scene is not None:
        attrs["title"] = f"granular_chain run of scene {scene.name}"
        attrs["scene_name"] = scene.name
        dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)  # libyaml's: the same text, faster
        attrs["scene"] = yaml.dump(scene.model_dump(mode="json"), Dumper=dumper, sort_keys=False)
    return attrs


def _plain(value):
    """JSON form of what json cannot write itself: NumPy scalars and arrays, else text."""
    return value.tolist() if hasattr(value, "tolist") else str(value)


def final_attrs(result) -> dict:
    """Global attributes known when the run has ended (status, cost, counts).

    Parameters
    ----------
    result : Result
        The finished run.

    Returns
    -------
    dict
        Attribute name -> value.
    """
    attrs = {"status": str(result.status), "status_code": int(result.status),
             "success": np.int8(result.success), "message": result.message,
             "stepper": result.stepper, "steps": np.int64(result.steps),
             "wall_time_s": float(result.wall_time), "t_final": float(result.t_final),
             "energy_initial": float(result.energy.initial),
             "event_counts": json.dumps({k: int(n) for k, n in result.event_counts.items()}),
             "info": json.dumps(result.info, default=_plain)}
    if result.dt is not None:
        attrs["dt"] = float(result.dt)
    return attrs


def granule_values(model) -> dict:
    """The per-granule arrays of the run's Model stored with it.

    Parameters
    ----------
    model : Model or None
        The run's chain constants.

    Returns
    -------
    dict
        Variable name -> array of shape (N,) (empty without a Model).
    """
    if model is None:
        return {}
    return {name: getattr(model, attr) for name, (attr, _, _) in GRANULE_FIELDS.items()}
