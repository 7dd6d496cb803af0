"""Outcome boundaries of the two-granule collision: :mod:`granular_chain.two_granules.boundaries`.

Kept importable here (``from granular_chain.boundaries import find_boundaries``).
"""

from .two_granules.boundaries import (PARAMS, Boundaries, Boundary,  # noqa: F401
                                      find_boundaries, separation_limit)
from .two_granules.curves import BoundaryCurve, plot_curves, trace_curves, write_curves  # noqa: F401

__all__ = ["PARAMS", "Boundary", "Boundaries", "find_boundaries", "separation_limit",
           "BoundaryCurve", "trace_curves", "write_curves", "plot_curves"]
