"""The Verlet driver's former module path: see :mod:`granular_chain.steppers.verlet.driver`."""

from .verlet.driver import *  # noqa: F401,F403
from .verlet.driver import (  # noqa: F401  (private names that tests and benchmarks use)
    _backtrack_to_separation,
    _drift_coefficients,
    _net_forces,
    _overlap_caps,
    _uniform_code,
)
