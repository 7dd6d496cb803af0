"""Throughput of the steppers on a struck Hertz chain (issue 5).

A chain of N touching granules (m = 1, radius 0.5, k = 1, n = 5/2, dt = 0.01,
scaled units), granule 0 struck with v = 1, friction on every granule when
asked (eta = 1e-3, gamma = 1e-2). Prints one JSON object (with --json) or a
line: grains, steps, seconds (stepping alone: the kernel is compiled, or loaded
from numba's cache, by a warm-up run first), grain_steps_per_s, and the
energy-ledger balance error at the end.

    python benchmarks/throughput.py --grains 10000 --steps 20000 --features coulomb+viscous --json
    python benchmarks/throughput.py --grains 1000 --steps 20000 --features coulomb+viscous --initial random --stop rest --json

``--stop rest`` ends the run when every granule is at rest (Coulomb friction holds
the random chain after t ~ 100); ``steps`` in the output is then the steps taken.
"""

import argparse
import json
import time

import granular_chain as gc

FRICTION = {
    "frictionless": {},
    "coulomb": {"kinetic": 1e-3},
    "viscous": {"viscous": 1e-2},
    "coulomb+viscous": {"kinetic": 1e-3, "viscous": 1e-2},
}


def chain_scene(grains, steps, features, dt=0.01, stepper="verlet", stop="t_end"):
    return gc.scene_from_dict({
        "name": "throughput",
        "granules": {"count": grains, "mass": 1.0, "radius": 0.5, "gap": 0.0,
                     "velocity": {0: 1.0}, "friction": FRICTION[features]},
        "contacts": {"exponent": 2.5, "stiffness": 1.0},
        "run": {"stepper": stepper, "t_end": steps * dt, "stop": stop,
                **({"dt": dt} if stepper == "verlet" else {})},  # Verlet's option only
        # one frame at the end: the run is a single compiled chunk
        "output": {"every": steps, "trajectory": False},
    })


def _run(scene, initial, seed=1):
    """simulate(scene); with initial='random' every granule starts with a velocity
    uniform in [-0.1, 0.1] (grains collide, stick, slip and reverse at random)."""
    if initial == "struck":
        return gc.simulate(scene, progress=False)
    import numpy as np
    from granular_chain.model import build_model
    from granular_chain.simulate import _simulate_verlet
    model = build_model(scene)
    model.v0[:] = np.random.default_rng(seed).uniform(-0.1, 0.1, model.count)
    return _simulate_verlet(scene, model, False)


def measure(grains, steps, features, stepper="verlet", initial="struck", stop="t_end"):
    if initial != "struck" and stepper != "verlet":
        raise SystemExit("--initial random is only implemented for --stepper verlet")
    _run(chain_scene(grains, 2, features, stepper=stepper, stop=stop), initial)  # warm-up
    scene = chain_scene(grains, steps, features, stepper=stepper, stop=stop)
    t0 = time.perf_counter()
    r = _run(scene, initial)
    total = time.perf_counter() - t0
    out = {
        "grains": grains, "steps": r.steps, "features": features, "stepper": stepper, "initial": initial,
        "stop": stop,
        "seconds": r.wall_time, "seconds_with_setup": total,
        "energy_balance_error": r.energy.balance_error, "status": r.status.name.lower(),
    }
    if stepper == "verlet":
        out["grain_steps_per_s"] = grains * r.steps / r.wall_time
    else:
        n_events = sum(r.event_counts.values())
        out["events"] = n_events
        out["events_per_s"] = n_events / r.wall_time if r.wall_time > 0 else None
        out["seconds_per_event"] = r.wall_time / n_events if n_events else None
    return out


def case_grid(cases, selected, grains, grain_steps, min_steps):
    """(features, initial, N, steps) for every case (a (features, initial) pair, kept
    if ``selected`` is None or names it as "features initial") and every N: about
    ``grain_steps`` grain-steps per run, at least ``min_steps`` steps, and at most
    1000 for random starts (such a chain comes to rest by t ~ 100, and a chain at
    rest is the cheap case)."""
    for features, initial in cases:
        if selected is not None and f"{features} {initial}" not in selected:
            continue
        for N in (int(n) for n in grains):
            steps = max(min_steps, int(grain_steps // N))
            if initial == "random":
                steps = min(steps, 1000)
            yield features, initial, N, steps


def emit(row: dict, path=None) -> None:
    """Print a result row as one JSON line, and append it to ``path`` if given."""
    line = json.dumps(row)
    print(line, flush=True)
    if path:
        with open(path, "a") as fh:
            fh.write(line + "\n")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grains", type=int, default=10000)
    p.add_argument("--steps", type=int, default=10000)
    p.add_argument("--features", choices=sorted(FRICTION), default="frictionless")
    p.add_argument("--stepper", choices=["verlet", "event"], default="verlet")
    p.add_argument("--initial", choices=["struck", "random"], default="struck",
                   help="struck: granule 0 at v = 1 (default); random: every granule at a "
                        "velocity uniform in [-0.1, 0.1] (Verlet only)")
    p.add_argument("--stop", choices=["t_end", "rest"], default="t_end",
                   help="rest: also stop when every granule is at rest")
    p.add_argument("--json", action="store_true")
    a = p.parse_args()
    out = measure(a.grains, a.steps, a.features, a.stepper, a.initial, a.stop)
    if a.json:
        print(json.dumps(out))
    else:
        rate = out.get("grain_steps_per_s") or out.get("events_per_s")
        print(f"{a.stepper} {a.features} N={a.grains}: {out['seconds']:.3f} s, {rate:.4g} /s, "
              f"balance error {out['energy_balance_error']:.2e}")


if __name__ == "__main__":
    main()
