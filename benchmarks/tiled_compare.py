"""Bit-for-bit fingerprints of the engine's results: every scene, both steppers, the paper's cases.

A refactor must not change a single bit of any result. This script runs a
fixed set of cases through the public interface only (``scene_from_dict``,
``simulate``, ``collide``, ``collision_map``, ``reference_collision_n2``), so it
runs unchanged on any checkout, and records for each case the SHA-256 of every
result array (final positions, velocities, the energy ledger's final terms,
CollisionMap fields...) plus its status, step count and event counts.

The cases:
- ``verlet/...``: every feature set (frictionless, Coulomb, viscous, both), the
  three contact laws with walls, stop modes, random initial velocities so that
  granules stick, slip and reverse, the chain sizes of the tiled and sweep
  paths (N = 1 to 1e5);
- ``event/...``: the same physics at the event stepper's sizes;
- ``scene/<file>/<stepper>``: every ``scenarios/*.yaml`` with both steppers
  (the event stepper where it accepts the scene), ``t_end`` shortened;
- ``paper/...``: ``collide`` at the paper's friction points (both steppers,
  n = 2 and 5/2), ``collision_map`` grids, the exact n = 2 reference.

Usage::

    python benchmarks/tiled_compare.py --dump new.json [--only verlet/ ...]
    python benchmarks/tiled_compare.py --compare old.json new.json

``tests/test_bit_identical.py`` runs the same cases against the stored
fingerprints in ``tests/reference/bit_identical.json``. The fingerprints hold
on the machine type they were made on (numba compiles for the host CPU: a
different instruction set may round differently); the file records the CPU.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import platform
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FRICTION = {"frictionless": {}, "coulomb": {"kinetic": 1e-3, "static": 2e-3},
            "viscous": {"viscous": 1e-2}, "coulomb+viscous": {"kinetic": 1e-3, "viscous": 1e-2}}
WALL = {"gap": 0.01, "stiffness": 1.0}


def _chain(N, feat, *, exponent=2.5, walls=False, stop=None, struck=False, v=1.0, gap=0.0,
           stepper="verlet", t_end, dt=0.01, seed=1, **run):
    """A chain scene as a dict: struck at granule 0, or random velocities in [-0.1, 0.1)."""
    if struck:
        velocity = {0: v}
    else:
        velocity = {"distribution": "uniform", "low": -0.1, "high": 0.1, "seed": seed}
    run = {"stepper": stepper, "t_end": t_end, **run}
    if stepper == "verlet":
        run["dt"] = dt
    if stop:
        run["stop"] = stop
        if stop == "separation":
            run["stop_contact"] = min(100, N - 2)
    scene = {"name": "cmp",
             "granules": {"count": N, "mass": 1.0, "radius": 0.5, "gap": gap,
                          "velocity": velocity, "friction": FRICTION[feat]},
             "contacts": {"exponent": exponent, "stiffness": 1.0},
             "run": run, "output": {"every": 1000, "trajectory": False}}
    if stepper == "event":
        scene["output"] = {"trajectory": False}
    if walls:
        scene["walls"] = {"left": {**WALL, "exponent": exponent},
                          "right": {**WALL, "exponent": exponent}}
    return scene


def verlet_cases() -> dict:
    out = {}
    for feat in FRICTION:
        out[f"verlet/chain1e5 {feat} random"] = _chain(100_000, feat, t_end=10.0)
    for exponent in (2.0, 2.5, 3.0):
        for feat in FRICTION:
            out[f"verlet/walls n={exponent} {feat}"] = _chain(3001, feat, exponent=exponent,
                                                              walls=True, t_end=100.0)
    out["verlet/N=1 walls"] = _chain(1, "coulomb+viscous", walls=True, t_end=50.0)
    out["verlet/N=2 frictionless"] = _chain(2, "frictionless", t_end=50.0)
    out["verlet/N=1025 walls viscous"] = _chain(1025, "viscous", walls=True, t_end=50.0)
    out["verlet/stop rest"] = _chain(2000, "coulomb", stop="rest", t_end=20000.0)
    for feat in ("frictionless", "viscous"):
        out[f"verlet/N=1 walls {feat}"] = _chain(1, feat, walls=True, t_end=50.0)
        out[f"verlet/N=2 walls {feat} n=2"] = _chain(2, feat, walls=True, exponent=2.0, t_end=50.0)
        out[f"verlet/overlap {feat}"] = _chain(50, feat, struck=True, v=20.0, t_end=50.0)
        out[f"verlet/stop separation gap {feat}"] = _chain(
            500, feat, stop="separation", struck=True, gap=0.01, t_end=2000.0)
    out["verlet/chain1e5 frictionless struck n=3"] = _chain(100_000, "frictionless", exponent=3.0,
                                                            struck=True, t_end=30.0)
    return out


def event_cases() -> dict:
    out = {}
    for exponent in (2.0, 2.5):
        for feat in FRICTION:
            out[f"event/N=20 n={exponent} {feat} random"] = _chain(
                20, feat, exponent=exponent, stepper="event", t_end=20.0)
        # walls: each feature set is a kernel compiled for these cases alone (the
        # test's time is mostly compilation); none and both frictions cover the code
        for feat in ("frictionless", "coulomb+viscous"):
            out[f"event/N=5 walls n={exponent} {feat}"] = _chain(
                5, feat, exponent=exponent, walls=True, stepper="event", t_end=20.0)
        out[f"event/N=30 struck n={exponent}"] = _chain(30, "frictionless", exponent=exponent,
                                                       struck=True, stepper="event", t_end=40.0)
        out[f"event/N=30 stop separation gap n={exponent}"] = _chain(
            30, "viscous", exponent=exponent, struck=True, gap=0.01, stop="separation",
            stepper="event", t_end=200.0)
    out["event/N=10 stop rest"] = _chain(10, "coulomb", stop="rest", stepper="event", t_end=1e4)
    return out


def scene_cases() -> dict:
    import yaml
    out = {}
    for path in sorted((ROOT / "scenarios").glob("*.yaml")):
        base = yaml.safe_load(path.read_text())
        # The event stepper's runs of the scenes with dashpots, body forces or moving
        # walls are left out: each would compile an event kernel for this check alone
        # (tests/test_events_dissipation.py checks that stepper's physics).
        added = ("damping" in base.get("contacts", {}) or "body_force" in base
                 or any("motion" in (w or {}) for w in base.get("walls", {}).values()))
        for stepper in ("verlet",) if added else ("verlet", "event"):
            d = json.loads(json.dumps(base))
            run = d.setdefault("run", {})
            if stepper == "event":
                run.pop("dt", None)
            elif run.get("stepper") == "event":
                continue
            run["stepper"] = stepper
            if not run.get("stages"):  # (a staged run ends with its last stage)
                run["t_end"] = min(float(run.get("t_end", 20.0)), 20.0)
            d["output"] = {"trajectory": False}
            out[f"scene/{path.stem}/{stepper}"] = d
    return out


PAPER_POINTS = [  # (n, eta, gamma): the paper's figures' corners and interiors
    (2.0, (0.0, 0.0), (0.0, 0.0)), (2.0, (0.0, 0.2), (0.0, 0.0)), (2.0, (0.3, 0.1), (0.0, 0.0)),
    (2.0, (0.0, 0.0), (0.5, 1.0)), (2.0, (0.1, 0.2), (0.3, 0.3)), (2.5, (0.0, 0.3), (0.0, 0.0)),
    (2.5, (0.2, 0.05), (0.0, 0.0)), (2.5, (0.0, 0.0), (1.0, 0.2)), (2.5, (0.1, 0.1), (0.2, 0.4)),
]


def paper_cases() -> dict:
    out = {}
    for n, eta, gamma in PAPER_POINTS:
        for stepper in ("verlet", "event"):
            out[f"paper/collide n={n} eta={eta} gamma={gamma} {stepper}"] = (
                "collide", dict(n=n, eta=eta, gamma=gamma, stepper=stepper))
    for n in (2.0, 2.5):
        out[f"paper/collision_map n={n}"] = ("map", dict(n=n))
        out[f"paper/collision_map n={n} viscous"] = ("map", dict(n=n, gamma=(0.3, 0.1)))
    for point in ((0.1, 0.3, 0.0, 0.0), (0.05, 0.0, 0.2, 0.4)):
        out[f"paper/reference_collision_n2 {point}"] = ("reference", dict(point=point))
    return out


def cases() -> dict:
    return {**verlet_cases(), **event_cases(), **scene_cases(), **paper_cases()}


def _digest(a) -> str:
    a = np.ascontiguousarray(np.asarray(a))
    return hashlib.sha256(str(a.dtype).encode() + str(a.shape).encode() + a.tobytes()).hexdigest()[:32]


def _result_record(r) -> dict:
    ledger = r.energy
    arrays = {"x": r.x_final, "v": r.v_final, "t": np.array([r.t_final]),
              "ledger": np.array([ledger.kinetic[-1], ledger.potential[-1], ledger.coulomb[-1],
                                  ledger.viscous[-1]])}
    return {"digests": {k: _digest(a) for k, a in arrays.items()},
            "status": str(r.status), "steps": int(r.steps),
            "events": {k: int(v) for k, v in sorted(r.event_counts.items())},
            "sample": {"x0": float(r.x_final[0]), "v0": float(r.v_final[0]), "t": float(r.t_final)}}


def _exact(value) -> str:
    """A number as text that compares exactly: an mpmath mpf by its (sign, mantissa,
    exponent, bits) tuple, whatever the working precision; anything else by repr."""
    return repr(getattr(value, "_mpf_", value))


def run_case(name: str, spec) -> dict:
    """Run one case and return its fingerprint record."""
    import granular_chain as gc
    if isinstance(spec, dict):
        return _result_record(gc.simulate(gc.scene_from_dict(spec), progress=False))
    kind, kw = spec
    if kind == "collide":
        from granular_chain.two_granules import collide
        c = collide(kw["n"], eta=kw["eta"], gamma=kw["gamma"], stepper=kw["stepper"])
        rec = _result_record(c.result)
        rec["digests"]["collision"] = _digest([c.v1, c.v2, c.energy_ratio, c.t_separation])
        rec["outcome"] = c.outcome.name
        return rec
    if kind == "map":
        from granular_chain.two_granules import collision_map
        eta1, eta2 = np.meshgrid(np.linspace(0.0, 0.4, 5), np.linspace(0.0, 0.4, 5))
        m = collision_map(eta1, eta2, n=kw["n"], gamma=kw.get("gamma", (0.0, 0.0)), workers=1)
        fields = ("v1", "v2", "energy_ratio", "t_separation", "outcome", "status", "t_stop1",
                  "t_stop2")
        return {"digests": {f: _digest(getattr(m, f)) for f in fields}}
    if kind == "reference":
        from granular_chain.paper import reference_collision_n2
        ref = reference_collision_n2(*kw["point"])
        values = {k: _exact(ref[k]) for k in ("v1", "v2", "energy_ratio", "t_separation", "x1", "x2",
                                             "outcome")}
        values["events"] = [{k: _exact(v) for k, v in sorted(e.items())} for e in ref["events"]]
        return {"values": values}
    raise ValueError(kind)


def machine() -> dict:
    import numba
    return {"cpu": numba.config.CPU_NAME or _host_cpu(), "numba": numba.__version__,
            "numpy": np.__version__, "python": platform.python_version()}


def _host_cpu() -> str:
    import llvmlite.binding as llvm
    return llvm.get_host_cpu_name()


def dump(path: str, only=None) -> None:
    records = {}
    for name, spec in cases().items():
        if only and not any(o in name for o in only):
            continue
        records[name] = run_case(name, spec)
        print(name, records[name].get("status", ""), records[name].get("steps", ""), flush=True)
    Path(path).write_text(json.dumps({"machine": machine(), "cases": records}, indent=1,
                                     sort_keys=True) + "\n")


def compare(path_a: str, path_b: str) -> int:
    a, b = (json.loads(Path(p).read_text())["cases"] for p in (path_a, path_b))
    bad = 0
    for name in sorted(set(a) | set(b)):
        if a.get(name) != b.get(name):
            bad += 1
            print(f"DIFFERS {name}\n  a: {a.get(name)}\n  b: {b.get(name)}")
    print(f"{len(set(a) & set(b))} cases in both, {bad} differ")
    return 1 if bad else 0


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dump")
    p.add_argument("--compare", nargs=2)
    p.add_argument("--only", nargs="*", help="only the cases whose names contain one of these")
    args = p.parse_args()
    if args.dump:
        dump(args.dump, args.only)
    if args.compare:
        sys.exit(compare(*args.compare))
