"""Rest stop of merged-kick Verlet runs against a plain two-half-kick numpy Verlet (issue 5 check).

Random Coulomb chains (2-29 granules, random masses, gaps, stiffnesses, kinetic and
static friction, drag on every other scene, walls), random initial speeds and a
random output cadence, run with ``stop: rest``. For each, the engine's stop step,
event counts and final positions are compared with tests/test_verlet_merged.py's
numpy reference, which kicks twice per step and stops at its first step with every
velocity exactly zero. Prints one line per mismatch and a summary.

    python benchmarks/merged_kick_fuzz.py --scenes 120
"""

import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))

import test_verlet_merged as T  # noqa: E402

import granular_chain as gc  # noqa: E402
from granular_chain.model import build_model  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenes", type=int, default=120)
    p.add_argument("--seed", type=int, default=1000)
    a = p.parse_args()
    mismatches = at_rest = 0
    worst = 0.0
    for k in range(a.scenes):
        rng = np.random.default_rng(a.seed + k)
        N = int(rng.integers(2, 30))
        speed = float(rng.uniform(0.005, 0.05))
        every = int(rng.integers(1, 400))
        scene = T._chain(N, bool(k % 2), "rest", every, seed=a.seed + k, t_end=300.0, speed=speed)
        r = gc.simulate(scene, progress=False)
        ref = T._Reference(build_model(scene), 0.01)
        rest = None
        for step in range(1, r.steps + 3):  # two steps past the engine's stop
            ref.step()
            if not ref.v.any():
                rest = step
                break
        if r.status == gc.Status.AT_REST:
            at_rest += 1
            ok = rest == r.steps and r.event_counts == ref.counts
            worst = max(worst, float(np.max(np.abs(r.x_final - (ref.model.x0 + ref.u)))))
        else:
            ok = rest is None
        if not ok:
            mismatches += 1
            print(f"mismatch: scene {k}, N = {N}, every = {every}: engine {r.status.name} at "
                  f"{r.steps} {r.event_counts}, reference rest at {rest} {ref.counts}")
    print(f"{a.scenes} scenes, {at_rest} at rest, {mismatches} mismatches, "
          f"worst |dx| at rest {worst:.2e}")


if __name__ == "__main__":
    main()
