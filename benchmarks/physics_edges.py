"""Measurements behind the valid ranges of docs/robustness.md ("Valid range of each stepper").

  python benchmarks/physics_edges.py verlet-near-one 1.01 1.1 1.5
      Verlet on two equal frictionless granules (exact: v1 = 0, v2 = 1) at
      dt = T/200 / 2^k, k = 0..6 (T the collision time): error, ledger, outcome,
      and the fitted order over the last five halvings (docs/verlet_convergence.md).
  python benchmarks/physics_edges.py event-exponents 2 4 8 12 16 20
      The event stepper's two-granule collision at each n, frictionless and with
      eta = (0, 0.1): ledger error against its promise, |v1|, |v2 - 1| (the
      MAX_EXPONENT refusal is lifted here, for the measurement only).
  python benchmarks/physics_edges.py scenes
      The Verlet ledger error of every shipped scene at its own dt (the default
      run.energy_tolerance is chosen above all of them).
"""

import glob
import math
import sys
import time

import numpy as np


def verlet_near_one(ns):
    from granular_chain import scene_from_dict
    from granular_chain.model import build_model
    from granular_chain.simulate import default_dt
    from granular_chain.steppers.verlet.timestep import _DEFAULT_STEPS_PER_PERIOD
    from granular_chain.two_granules import collide
    from granular_chain.two_granules.problem import two_granule_scene

    for n in ns:
        T = build_model(scene_from_dict(two_granule_scene(n))).shortest_period()
        dts, errs = [], []
        for k in range(7):
            dt = T / _DEFAULT_STEPS_PER_PERIOD / 2 ** k
            c = collide(n, stepper="verlet", dt=dt)
            errs.append(max(abs(c.v1), abs(c.v2 - 1)))
            dts.append(dt)
            print(f"n={n} dt=T/{T / dt:.0f} v1={c.v1:.3e} v2-1={c.v2 - 1:.3e} "
                  f"ledger={c.result.energy.balance_error:.2e} {c.outcome.name}", flush=True)
        order = np.polyfit(np.log(dts[2:]), np.log(errs[2:]), 1)[0]
        print(f"n={n}: fitted order {order:.2f}; default dt {default_dt(build_model(scene_from_dict(two_granule_scene(n))), 1000.0):.4g}", flush=True)


def event_exponents(ns):
    import granular_chain.steppers.events.driver as driver
    from granular_chain.two_granules import collide

    driver.MAX_EXPONENT = math.inf  # measure beyond the accepted range
    for n in ns:
        for eta in ((0.0, 0.0), (0.0, 0.1)):
            t = time.time()
            c = collide(n, eta=eta, stepper="event")
            r = c.result
            tol = r.info["event_stepper"]["ledger_tolerance"]
            err = r.energy.balance_error
            print(f"n={n} eta={eta}: status={r.status} ledger={err:.2e} promise={tol:.2e} "
                  f"ratio={err / tol:.3g} v1={c.v1:.3e} v2-1={c.v2 - 1:.3e} "
                  f"({time.time() - t:.0f} s)", flush=True)


def scenes():
    from granular_chain import load_scene, simulate

    for path in sorted(glob.glob("scenarios/*.yaml")):
        scene = load_scene(path, ["run.energy_tolerance=null"])
        r = simulate(scene, progress=False)
        print(f"{path}: status={r.status} ledger={r.energy.balance_error:.3e}", flush=True)


if __name__ == "__main__":
    what, args = sys.argv[1], [float(a) for a in sys.argv[2:]]
    {"verlet-near-one": verlet_near_one, "event-exponents": event_exponents,
     "scenes": lambda _: scenes()}[what](args)
