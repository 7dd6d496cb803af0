"""Kernel-only rate of the Verlet kernel, old vs new, interleaved in one process (tiled-verlet).

The old kernel is loaded from another checkout's ``granular_chain/steppers/verlet.py``
as a second module of this package (its laws and forces are the same), so both
kernels run in one process on identical arguments built as simulate() builds
them (benchmarks/throughput.py's scene: struck Hertz chain, or random velocities).
Each timed call starts from the same saved state (copied outside the timing) and
runs S steps; the rate is N S / t, best of ``--repeat`` interleaved calls (under
load the best call is the one that had a core to itself). ``--blocks`` times the
new kernel at several block sizes instead (verlet.BLOCK patched and the kernel
recompiled without the disk cache).

    python benchmarks/tiled_kernel_bench.py --old /tmp/old_tree --grains 1e2 1e3 1e4 1e5 1e6 1e7
    python benchmarks/tiled_kernel_bench.py --blocks 128 256 512 1024 2048 4096 --grains 1e4 1e7
"""

import argparse
import importlib.util
import json
import os
import sys
import time

import numba
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import throughput  # noqa: E402
sim = importlib.import_module("granular_chain.simulate")
from granular_chain._compile import specialised  # noqa: E402
from granular_chain.model import build_model  # noqa: E402
from granular_chain.steppers import verlet  # noqa: E402

CASES = [("frictionless", "struck"), ("coulomb+viscous", "struck"), ("coulomb+viscous", "random")]


def load_old(root):
    path = os.path.join(root, "granular_chain", "steppers", "verlet.py")
    spec = importlib.util.spec_from_file_location("granular_chain.steppers._verlet_old", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def build_args(N, features, initial, seed=1):
    scene = throughput.chain_scene(N, 10, features)
    model = build_model(scene)
    if initial == "random":
        model.v0[:] = np.random.default_rng(seed).uniform(-0.1, 0.1, model.count)
    feat = model.features
    dt = scene.run.dt
    u = np.zeros(N)
    v = model.v0.copy()
    f = np.zeros(N)
    c = np.zeros(max(N - 1, 1))
    sim._net_forces(model, u, c, f)
    active = (c[: max(N - 1, 0)] > 0).astype(np.uint8)
    E, P1, P2 = sim._drift_coefficients(model, dt)
    args = [feat.law, int(feat.coulomb), int(feat.viscous), int(feat.left_wall),
            int(feat.right_wall), 0, u, v, f, c, active, model.d0, model.k,
            model.n, model.walls, model.mass, model.inv_mass, model.eta,
            model.eta_static, E, P1, P2, np.zeros(N), dt, 0, 0, np.zeros(2), np.zeros(4, dtype=np.int64)]
    return args


def timed(kernel, args, saved, steps):
    for name, x in saved.items():
        args[name][:] = x
    args[24] = steps
    t = time.perf_counter()
    kernel(*args)
    return time.perf_counter() - t


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--old", default=None)
    p.add_argument("--blocks", type=int, nargs="*", default=None)
    p.add_argument("--grains", type=float, nargs="*", default=[1e2, 1e3, 1e4, 1e5, 1e6, 1e7])
    p.add_argument("--grain-steps", type=float, default=2e7, help="per timed call")
    p.add_argument("--repeat", type=int, default=7)
    p.add_argument("--cases", nargs="*", default=None)
    p.add_argument("--json", default=None)
    a = p.parse_args()
    cases = [c for c in CASES if a.cases is None or f"{c[0]} {c[1]}" in a.cases]
    for features, initial in cases:
        for N in (int(n) for n in a.grains):
            steps = max(10, int(a.grain_steps // N))
            if initial == "random":
                steps = min(steps, 1000)
            args = build_args(N, features, initial)
            saved = {i: args[i].copy() for i in (6, 7, 8, 10, 26, 27)}
            kernels = {}
            if a.blocks:
                for B in a.blocks:
                    verlet.BLOCK = B
                    # a fresh dispatcher: recompiled with this BLOCK, no disk cache
                    fresh = numba.njit(fastmath={"reassoc", "contract", "nsz"})(verlet.verlet_chunk.py_func)
                    kernels[f"B={B}"] = specialised(fresh, tuple(args), (0, 1, 2, 3, 4, 5))
                    timed(kernels[f"B={B}"], args, saved, 1)
                verlet.BLOCK = a.blocks[0]
            else:
                old = load_old(a.old)
                kernels["old"] = specialised(old.verlet_chunk, tuple(args), (0, 1, 2, 3, 4, 5))
                kernels["new"] = specialised(verlet.verlet_chunk, tuple(args), (0, 1, 2, 3, 4, 5))
                for k in kernels.values():
                    timed(k, args, saved, 1)
            best = {k: float("inf") for k in kernels}
            loads = [os.getloadavg()[0]]
            for _ in range(a.repeat):
                for name, k in kernels.items():
                    best[name] = min(best[name], timed(k, args, saved, steps))
            loads.append(os.getloadavg()[0])
            row = {"case": f"{features} {initial}", "grains": N, "steps": steps,
                   "load_min": min(loads), "load_max": max(loads)}
            row.update({name: N * steps / t / 1e6 for name, t in best.items()})
            print(json.dumps(row), flush=True)
            if a.json:
                with open(a.json, "a") as fh:
                    fh.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
