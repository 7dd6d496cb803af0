"""CPU seconds to compile a mix of feature sets of both steppers in one process.

Four event-stepper feature sets (n = 2, n = 5/2, Coulomb friction, a viscoelastic
dashpot) and three Verlet ones (frictionless, Coulomb between walls, a linear dashpot),
each a 3-granule scene run by ``simulate``: run it on an empty cache, and two trees side
by side on the two cores (then with the cores swapped) to compare their compile cost::

    NUMBA_CACHE_DIR=$(mktemp -d) taskset -c 0 python benchmarks/compile_mix.py
"""

import time
import warnings

import granular_chain as gc


def scene(n, stepper, friction=None, walls=False, damping=None):
    """A 3-granule struck chain with these features."""
    d = {"name": "mix", "granules": {"count": 3, "radius": 1.0, "velocity": {0: 1.0}},
         "contacts": {"exponent": n}, "run": {"stepper": stepper, "t_end": 5.0},
         "output": {"every": 10}}
    if friction:
        d["granules"]["friction"] = friction
    if walls:
        d["walls"] = {"left": {"gap": 0.1}, "right": {"gap": 0.1}}
    if damping:
        d["contacts"]["damping"] = damping
    return gc.scene_from_dict(d)


SCENES = [scene(2.0, "event"), scene(2.5, "event"), scene(2.5, "event", {"kinetic": 0.01}),
          scene(2.5, "event", damping={"model": "viscoelastic", "coefficient": 0.01}),
          scene(2.5, "verlet"), scene(2.5, "verlet", {"kinetic": 0.01}, walls=True),
          scene(2.0, "verlet", damping={"model": "linear", "coefficient": 0.05})]

if __name__ == "__main__":
    warnings.simplefilter("ignore")
    for s in SCENES:
        gc.simulate(s, progress=False)
    print(f"cpu {time.process_time():.1f} s")
