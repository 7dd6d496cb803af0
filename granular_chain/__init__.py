"""granular_chain: discrete-element dynamics of one-dimensional chains of granules.

Data flows one way: scene file -> :class:`Scene` -> packed :class:`Model` ->
compiled kernel -> :class:`Result` -> writers. See README.md.
"""

from .result import Event, Result, Status
from .scene import Scene, SceneError, load_scene, scene_from_dict
from .simulate import SimulationError, simulate

__all__ = ["Scene", "SceneError", "load_scene", "scene_from_dict", "simulate", "Result",
           "Status", "Event", "SimulationError"]
__version__ = "0.1.0"
