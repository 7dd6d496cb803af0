"""The paper's problem: two equal granules, the first striking the second.

=================  ===========================================================
module             contents
=================  ===========================================================
``outcomes``       :class:`Outcome`, the outcome names, and the rule naming them
``problem``        the scene (:func:`two_granule_scene`), :func:`collide`,
                   :class:`Collision`, :func:`classify`
``maps``           :func:`collision_map`: many collisions in a compiled loop
``boundaries``     where the outcome changes along a path: :func:`find_boundaries`,
                   ``granular-chain boundaries``
``curves``         boundary curves in a plane of two frictions: :func:`trace_curves`
=================  ===========================================================

Scaled units (Appendix A of the paper; :mod:`granular_chain.units`).
"""

from .boundaries import PARAMS, Boundaries, Boundary, find_boundaries, separation_limit
from .curves import BoundaryCurve, plot_curves, trace_curves, write_curves
from .maps import CollisionMap, collision_map
from .outcomes import OUTCOMES, SEPARATION_SIGNS, Outcome
from .problem import Collision, classify, collide, two_granule_scene

__all__ = ["Outcome", "OUTCOMES", "SEPARATION_SIGNS", "Collision", "CollisionMap", "collide",
           "collision_map", "classify", "two_granule_scene", "PARAMS", "Boundary", "Boundaries",
           "find_boundaries", "separation_limit", "BoundaryCurve", "trace_curves",
           "write_curves", "plot_curves"]
