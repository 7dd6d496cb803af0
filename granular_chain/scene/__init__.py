"""Scene files: the pydantic schema, YAML loading and ``--set`` overrides.

A scene is the whole description of one run: the granules, their contacts and
walls, friction, units and how to step. This package is the first stage of the
one-way data flow ``YAML -> Scene -> Model -> kernel -> Result -> writers``: it
knows nothing of arrays or kernels, and every error it raises names the file,
the field as a dotted path and what is wrong, in one line (:class:`SceneError`).

One module a concern:

- :mod:`.values`: numbers, counts, names and flags, and :class:`SceneError`;
- one schema module a section: :mod:`.granules`, :mod:`.contacts`, :mod:`.walls`
  (with ``body_force``), :mod:`.output`, :mod:`.run`; :mod:`.schema` the whole
  :class:`Scene` and its JSON schema;
- :mod:`.reading` (the YAML file), :mod:`.overrides` (``--set``),
  :mod:`.messages` (validation errors in one line) and :mod:`.loading`
  (:func:`load_scene`, :func:`scene_from_dict`).
"""

from .contacts import Contacts, Damping
from .granules import Friction, Granules, InitialState, Material
from .loading import load_scene, scene_from_dict
from .output import Output
from .overrides import apply_overrides, set_path
from .reading import parse_yaml_value, read_scene_data
from .run import (DEFAULT_ENERGY_TOLERANCE, STEPPER_OPTIONS, Run, RunEvent, RunVerlet, Stage,
                  own_stepper_options)
from .schema import Scene, scene_json_schema
from .values import MAX_SCENE_BYTES, SCALE_MAX, SCALE_MIN, SceneError
from .walls import BodyForce, Pulse, Sine, Wall, WallMaterial, WallMotion, Walls

__all__ = [
    "Scene",
    "SceneError",
    "load_scene",
    "scene_from_dict",
    "apply_overrides",
    "set_path",
    "scene_json_schema",
    "read_scene_data",
    "parse_yaml_value",
    "MAX_SCENE_BYTES",
    "STEPPER_OPTIONS",
    "own_stepper_options",
    "DEFAULT_ENERGY_TOLERANCE",
    "SCALE_MIN",
    "SCALE_MAX",
    "Granules", "Friction", "Material", "InitialState", "Contacts", "Damping", "Walls", "Wall",
    "WallMotion", "WallMaterial", "Sine", "Pulse", "BodyForce", "Output", "Run", "RunVerlet", "RunEvent",
    "Stage",
]
