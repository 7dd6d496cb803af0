"""Outcome boundaries of the two-granule collision: :mod:`granular_chain.two_granules.boundaries`.

Kept importable here (``from granular_chain.boundaries import find_boundaries``).
"""

from .two_granules.boundaries import (PARAMS, Boundaries, Boundary, BoundaryCurve,  # noqa: F401
                                      find_boundaries, plot_curves, separation_limit,
                                      trace_curves, write_curves)

__all__ = ["PARAMS", "Boundary", "Boundaries", "find_boundaries", "separation_limit",
           "BoundaryCurve", "trace_curves", "write_curves", "plot_curves"]
