"""The classic experiments by name (one module of this package each)."""

from __future__ import annotations

from . import (backscatter_friction, dimers, heavy_striker, newtons_cradle, precompressed,
               solitary_wave, tapered)
from .experiment import Experiment

__all__ = ["EXPERIMENTS", "experiment"]

#: name -> Experiment, in the order ``granular-chain classics`` lists them.
EXPERIMENTS = {e.name: e for e in (
    solitary_wave.EXPERIMENT, heavy_striker.EXPERIMENT, newtons_cradle.EXPERIMENT,
    dimers.EXPERIMENT, tapered.EXPERIMENT, precompressed.EXPERIMENT,
    backscatter_friction.EXPERIMENT)}


def experiment(name: str) -> Experiment:
    """The experiment called ``name``.

    Parameters
    ----------
    name : str
        A key of :data:`EXPERIMENTS`.

    Returns
    -------
    Experiment

    Raises
    ------
    KeyError
        No such experiment (the message lists the names).
    """
    if name not in EXPERIMENTS:
        raise KeyError(f"unknown experiment {name!r}; choose from {', '.join(EXPERIMENTS)} "
                       f"or all")
    return EXPERIMENTS[name]
