"""The paper's problem: two equal granules, the first striking the second.

=================  ===========================================================
module             contents
=================  ===========================================================
``outcomes``       :class:`Outcome`, the outcome names, and the rule naming them
``problem``        the scene (:func:`two_granule_scene`), :func:`collide`,
                   :class:`Collision`, :func:`classify`
``maps``           :func:`collision_map`: many collisions in a compiled loop
``boundaries``     where the outcome changes: :func:`find_boundaries`,
                   :func:`trace_curves`, ``granular-chain boundaries``
=================  ===========================================================

Scaled units (Appendix A of the paper; :mod:`granular_chain.units`).
"""

from .boundaries import (PARAMS, Boundaries, Boundary, BoundaryCurve, find_boundaries,
                         plot_curves, separation_limit, trace_curves, write_curves)
from .maps import CollisionMap, collision_map
from .outcomes import OUTCOMES, SEPARATION_SIGNS, Outcome
from .problem import Collision, classify, collide, two_granule_scene

__all__ = ["Outcome", "OUTCOMES", "SEPARATION_SIGNS", "Collision", "CollisionMap", "collide",
           "collision_map", "classify", "two_granule_scene", "PARAMS", "Boundary", "Boundaries",
           "find_boundaries", "separation_limit", "BoundaryCurve", "trace_curves",
           "write_curves", "plot_curves"]
