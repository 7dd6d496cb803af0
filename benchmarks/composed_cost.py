"""What composing dissipation and forcing into one kernel costs an elastic scene.

Both steppers have a kernel that composes the contact law with dashpots, body forces
and driven walls, each pruned at compile time when the scene has none (Verlet:
``steppers/verlet/forced.py``; the event stepper: its ``dissip`` specialisation,
``steppers/events/dissipation.py``), beside the kernels elastic scenes with fixed
walls run (Verlet's sweep and blocked passes; the event stepper's ``dissip = None``).
This runs the same elastic scenes through both, with everything the composed kernel
could add pruned, and prints the stepping time of each (best of ``--repeat``), the
ratio, and the largest difference of the final positions:

    python benchmarks/composed_cost.py [--grains 10000] [--repeat 3] [--json FILE]

A ratio above 1 is what an elastic scene would pay if the composed kernel were the
only one.
"""

import argparse
import json
import time

import numpy as np

import granular_chain.steppers.events.pack as event_pack
import granular_chain.steppers.verlet.driver as verlet_driver
from granular_chain.simulate import simulate
from throughput import chain_scene

FEATURES = ("frictionless", "coulomb+viscous")


def _timed(scene, repeat):
    """(best stepping seconds, final positions) of ``repeat`` runs after a warm-up."""
    simulate(scene, progress=False)  # compiles (or loads) the kernel
    best, result = np.inf, None
    for _ in range(repeat):
        result = simulate(scene, progress=False)
        best = min(best, result.wall_time)
    return best, result


def _composed(stepper):
    """Make the runs take the composed kernel (a context's enter/exit pair)."""
    if stepper == "verlet":
        module, name, value = verlet_driver, "is_forced", lambda model: True
    else:
        module, name, value = event_pack, "dissipative", lambda model: 1
    saved = getattr(module, name)
    return (lambda: setattr(module, name, value)), (lambda: setattr(module, name, saved))


def compare(stepper, grains, steps, features, repeat):
    scene = chain_scene(grains, steps, features, stepper=stepper)
    own, a = _timed(scene, repeat)
    enter, leave = _composed(stepper)
    enter()
    try:
        composed, b = _timed(scene, repeat)
    finally:
        leave()
    return {"stepper": stepper, "grains": grains, "steps": int(a.steps), "features": features,
            "own_kernel_s": own, "composed_kernel_s": composed, "ratio": composed / own,
            "max_abs_dx": float(np.max(np.abs(a.x_final - b.x_final))),
            "same_steps": int(a.steps) == int(b.steps)}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grains", type=int, default=10_000)
    p.add_argument("--event-grains", type=int, default=100)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--json", help="append one JSON line per case to this file")
    args = p.parse_args()
    cases = [("verlet", args.grains, 20_000, f) for f in FEATURES]
    cases += [("event", args.event_grains, 20_000, f) for f in FEATURES]
    for case in cases:
        row = compare(*case, args.repeat)
        print(f"{row['stepper']:6s} N={row['grains']:<6d} {row['features']:16s} own "
              f"{row['own_kernel_s']:.3f} s, composed {row['composed_kernel_s']:.3f} s, "
              f"ratio {row['ratio']:.3f}, max |dx| {row['max_abs_dx']:.2g}, "
              f"same steps {row['same_steps']}", flush=True)
        if args.json:
            with open(args.json, "a") as fh:
                fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
