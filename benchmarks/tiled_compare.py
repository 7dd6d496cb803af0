"""Final states of the Verlet kernel in two checkouts, compared (tiled-verlet check).

Runs a set of scenes (every feature set, walls, the three contact laws, stop
modes, random initial velocities so that granules stick, slip and reverse) and
writes the final x, v, f, energy ledger, event counts, status and steps to an
.npz; ``--compare a.npz b.npz`` prints the largest differences.

    PYTHONPATH=<old checkout> python benchmarks/tiled_compare.py --dump old.npz
    PYTHONPATH=<new checkout> python benchmarks/tiled_compare.py --dump new.npz
    python benchmarks/tiled_compare.py --compare old.npz new.npz
"""

import argparse
import json

import numpy as np

FRICTION = {"frictionless": {}, "coulomb": {"kinetic": 1e-3, "static": 2e-3},
            "viscous": {"viscous": 1e-2}, "coulomb+viscous": {"kinetic": 1e-3, "viscous": 1e-2}}


def scenes():
    out = {}
    for feat in FRICTION:
        out[f"chain1e5 {feat} random"] = dict(N=100_000, feat=feat, steps=2000, walls=False,
                                              exponent=2.5, stop=None)
    for exponent in (2.0, 2.5, 3.0):
        for feat in FRICTION:
            out[f"walls n={exponent} {feat}"] = dict(N=3001, feat=feat, steps=20000, walls=True,
                                                     exponent=exponent, stop=None)
    out["N=1 walls"] = dict(N=1, feat="coulomb+viscous", steps=5000, walls=True, exponent=2.5, stop=None)
    out["N=2 frictionless"] = dict(N=2, feat="frictionless", steps=5000, walls=False, exponent=2.5, stop=None)
    out["N=1025 walls viscous"] = dict(N=1025, feat="viscous", steps=5000, walls=True, exponent=2.5, stop=None)
    out["stop separation"] = dict(N=5000, feat="frictionless", steps=200000, walls=False, exponent=2.5,
                                  stop="separation", struck=True)
    out["stop rest"] = dict(N=2000, feat="coulomb", steps=2_000_000, walls=False, exponent=2.5,
                            stop="rest")
    # paths of the single sweep (scenes without Coulomb friction, verlet-sweep branch)
    for feat in ("frictionless", "viscous"):
        out[f"N=1 walls {feat}"] = dict(N=1, feat=feat, steps=5000, walls=True, exponent=2.5, stop=None)
        out[f"N=2 walls {feat} n=2"] = dict(N=2, feat=feat, steps=5000, walls=True, exponent=2.0,
                                            stop=None)
        out[f"overlap {feat}"] = dict(N=50, feat=feat, steps=5000, walls=False, exponent=2.5, stop=None,
                                      struck=True, v=20.0)
    out["stop separation viscous"] = dict(N=5000, feat="viscous", steps=200000, walls=False,
                                          exponent=2.5, stop="separation", struck=True)
    # well-conditioned separations (the touching chain's "stop separation" above is
    # not: behind the pulse its contacts sit at delta = 0 to roundoff, so whether
    # contact 100 opens depends on the last bit of the displacements)
    for feat in ("frictionless", "viscous"):
        out[f"stop separation gap {feat}"] = dict(N=500, feat=feat, steps=200000, walls=False,
                                                  exponent=2.5, stop="separation", struck=True,
                                                  gap=0.01)
    out["chain1e5 frictionless struck n=3"] = dict(N=100_000, feat="frictionless", steps=3000,
                                                   walls=False, exponent=3.0, stop=None, struck=True)
    return out


def run(spec, seed=1):
    import granular_chain as gc
    from granular_chain.model import build_model
    from granular_chain.simulate import _simulate_verlet
    N = spec["N"]
    run = {"stepper": "verlet", "dt": 0.01, "t_end": spec["steps"] * 0.01}
    if spec["stop"]:
        run["stop"] = spec["stop"]
        if spec["stop"] == "separation":
            run["stop_contact"] = 100
    d = {"name": "cmp",
         "granules": {"count": N, "mass": 1.0, "radius": 0.5, "gap": spec.get("gap", 0.0),
                      "velocity": {0: spec.get("v", 1.0)}, "friction": FRICTION[spec["feat"]]},
         "contacts": {"exponent": spec["exponent"], "stiffness": 1.0},
         "run": run, "output": {"every": max(1, spec["steps"] // 3), "trajectory": False}}
    if spec["walls"]:
        d["walls"] = {"left": {"gap": 0.01, "exponent": spec["exponent"], "stiffness": 1.0},
                      "right": {"gap": 0.01, "exponent": spec["exponent"], "stiffness": 1.0}}
    scene = gc.scene_from_dict(d)
    model = build_model(scene)
    if not spec.get("struck"):
        model.v0[:] = np.random.default_rng(seed).uniform(-0.1, 0.1, model.count)
    r = _simulate_verlet(scene, model, False)
    return r


def dump(path, only=None):
    res = {}
    meta = {}
    for name, spec in scenes().items():
        if only and not any(o in name for o in only):
            continue
        r = run(spec)
        res[name + "|x"] = r.x_final
        res[name + "|v"] = r.v_final
        res[name + "|f"] = r.f[-1]
        res[name + "|ledger"] = np.array([r.energy.coulomb[-1], r.energy.viscous[-1]])
        meta[name] = {"status": r.status.name, "steps": r.steps, "events": r.event_counts,
                      "balance": r.energy.balance_error}
        print(name, meta[name], flush=True)
    np.savez(path, meta=json.dumps(meta), **res)


def compare(pa, pb):
    a, b = np.load(pa), np.load(pb)
    ma, mb = json.loads(str(a["meta"])), json.loads(str(b["meta"]))
    worst = 0.0
    for name in ma:
        diffs = {}
        for q in ("x", "v", "f", "ledger"):
            xa, xb = a[f"{name}|{q}"], b[f"{name}|{q}"]
            diffs[q] = float(np.max(np.abs(xa - xb))) if xa.size else 0.0
        same = {k: ma[name][k] == mb[name][k] for k in ("status", "steps", "events")}
        worst = max(worst, diffs["x"], diffs["v"])
        print(f"{name:32s} max|dx| {diffs['x']:.2e} max|dv| {diffs['v']:.2e} max|df| {diffs['f']:.2e} "
              f"ledger {diffs['ledger']:.2e}  status/steps/events equal: {all(same.values())} "
              f"({ma[name]['status']} {ma[name]['steps']} {ma[name]['events']})"
              + ("" if all(same.values()) else f" vs ({mb[name]['status']} {mb[name]['steps']} {mb[name]['events']})"))
    print(f"largest |dx|, |dv| over all scenes: {worst:.3e}")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dump")
    p.add_argument("--compare", nargs=2)
    p.add_argument("--only", nargs="*", help="dump only the scenes whose names contain one of these")
    a = p.parse_args()
    if a.dump:
        dump(a.dump, a.only)
    if a.compare:
        compare(*a.compare)
