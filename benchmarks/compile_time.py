"""Compile time of the kernels, cold (empty numba cache) and cached (issue 5).

Each measurement is a fresh Python process with NUMBA_CACHE_DIR pointing to a
new temporary directory (cold: every kernel compiled) and then a second process
with the same directory (cached: kernels loaded from disk). A process times
``import granular_chain`` and then the first ``simulate`` of a tiny scene (10
granules, 10 steps) for each stepper and feature set in turn, so each line is the
extra time of that specialisation on top of what the earlier lines compiled.

    python benchmarks/compile_time.py            # about a minute
    python benchmarks/compile_time.py --scenes   # each scenarios/*.yaml on its own cold cache

``--scenes``: for each scene file, a fresh process on an empty cache runs what
``granular-chain run SCENE`` compiles (the scene cut to a few steps, its
feature set unchanged), then a second process on the same cache does it again
(loaded from disk). Wall and CPU seconds of both are printed: on a shared
machine the CPU seconds are the steadier figure.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile

CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import granular_chain as gc
out = {"import": time.perf_counter() - t0}
from granular_chain.two_granules import collide
FR = {"frictionless": {}, "coulomb+viscous": {"kinetic": 1e-3, "viscous": 1e-2}}
def scene(features, stepper, n=2.5):
    run = {"stepper": stepper, "t_end": 0.1}
    if stepper == "verlet":
        run["dt"] = 0.01
    return gc.scene_from_dict({"name": "c", "granules": {"count": 10, "mass": 1.0, "radius": 0.5,
        "gap": 0.0, "velocity": {0: 1.0}, "friction": FR[features]},
        "contacts": {"exponent": n, "stiffness": 1.0}, "run": run,
        "output": {"every": 10, "trajectory": False}})
for stepper in ("verlet", "event"):
    for features in ("frictionless", "coulomb+viscous"):
        s = scene(features, stepper)
        t0 = time.perf_counter()
        gc.simulate(s, progress=False)
        out[f"{stepper} {features} n=5/2"] = time.perf_counter() - t0
t0 = time.perf_counter()
collide(2.0, (0.0, 0.3), stepper="event")
out["event collide n=2 eta"] = time.perf_counter() - t0
t0 = time.perf_counter()
collide(2.0, (0.0, 0.3), stepper="verlet", dt=0.01)
out["verlet collide n=2 eta"] = time.perf_counter() - t0
print(json.dumps(out))
"""


SCENE_CHILD = r"""
import json, sys, time
w0, c0 = time.perf_counter(), time.process_time()
import granular_chain as gc
from granular_chain.warmup import prepare_kernels
scene = gc.load_scene(sys.argv[1])
prepare_kernels(scene, quiet=True)  # what the CLI compiles before a run: the scene cut to 2 steps
print(json.dumps({"wall": time.perf_counter() - w0, "cpu": time.process_time() - c0}))
"""


def run(cache_dir, child=CHILD, args=()):
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    p = subprocess.run([sys.executable, "-c", child, *args], env=env, capture_output=True,
                       text=True, check=True)
    return json.loads(p.stdout.strip().splitlines()[-1])


def scenes():
    """Cold and cached compile time of each scene file (import included)."""
    import glob
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenarios")
    res = {"load_start": os.getloadavg()[0], "scenes": {}}
    print(f"{'scene':32s} {'cold wall':>9s} {'cold cpu':>9s} {'cached wall':>11s} "
          f"{'cached cpu':>10s}  (s)")
    for path in sorted(glob.glob(os.path.join(root, "*.yaml"))):
        with tempfile.TemporaryDirectory(prefix="numba_cache_") as d:
            cold = run(d, SCENE_CHILD, (path,))
            cached = run(d, SCENE_CHILD, (path,))
        name = os.path.basename(path)
        res["scenes"][name] = {"cold": cold, "cached": cached}
        print(f"{name:32s} {cold['wall']:9.2f} {cold['cpu']:9.2f} {cached['wall']:11.2f} "
              f"{cached['cpu']:10.2f}", flush=True)
    res["load_end"] = os.getloadavg()[0]
    print(f"load {res['load_start']:.2f} -> {res['load_end']:.2f}")
    out = os.path.join(os.path.dirname(__file__), "results", "compile_time_scenes.json")
    with open(out, "w") as fh:
        json.dump(res, fh, indent=1)


def main():
    import argparse
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", action="store_true",
                        help="cold and cached compile time of each scenarios/*.yaml")
    if parser.parse_args().scenes:
        return scenes()
    res = {"load_start": os.getloadavg()[0]}
    with tempfile.TemporaryDirectory(prefix="numba_cache_") as d:
        res["cold"] = run(d)
        res["cached"] = run(d)
        res["cached_again"] = run(d)
    res["load_end"] = os.getloadavg()[0]
    for k in ("cold", "cached", "cached_again"):
        res[k]["total"] = sum(res[k].values())
    print(f"{'':28s} {'cold (s)':>10s} {'cached (s)':>10s}")
    for k in res["cold"]:
        print(f"{k:28s} {res['cold'][k]:10.3f} {min(res['cached'][k], res['cached_again'][k]):10.3f}")
    print(f"load {res['load_start']:.2f} -> {res['load_end']:.2f}")
    os.makedirs(os.path.join(os.path.dirname(__file__), "results"), exist_ok=True)
    with open(os.path.join(os.path.dirname(__file__), "results", "compile_time.json"), "w") as fh:
        json.dump(res, fh, indent=1)


if __name__ == "__main__":
    main()
