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

CASES = [("frictionless", "struck"), ("viscous", "struck"), ("coulomb+viscous", "struck"),
         ("coulomb+viscous", "random")]


def load_old(root):
    path = os.path.join(root, "granular_chain", "steppers", "verlet.py")
    spec = importlib.util.spec_from_file_location("granular_chain.steppers._verlet_old", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def build_args(N, features, initial, seed=1, per_granule=False):
    """The kernel's arguments by name, built as simulate() builds them (the old
    kernel's unused ``c`` and ``du`` included, so either signature can be served)."""
    scene = throughput.chain_scene(N, 10, features)
    model = build_model(scene)
    if initial == "random":
        model.v0[:] = np.random.default_rng(seed).uniform(-0.1, 0.1, model.count)
    if per_granule:
        # masses and stiffnesses varied by +-0.1 %: the same physics, but the
        # parameters are no longer uniform (the kernel streams them)
        rng = np.random.default_rng(seed + 1)
        model.mass[:] *= 1.0 + 1e-3 * rng.uniform(-1.0, 1.0, model.count)
        model.inv_mass[:] = 1.0 / model.mass
        model.k[:] *= 1.0 + 1e-3 * rng.uniform(-1.0, 1.0, model.k.size)
    feat = model.features
    dt = scene.run.dt
    u = np.zeros(N)
    v = model.v0.copy()
    f = np.zeros(N)
    c = np.zeros(max(N - 1, 1))
    sim._net_forces(model, u, c, f)
    active = (c[: max(N - 1, 0)] > 0).astype(np.uint8)
    E, P1, P2 = sim._drift_coefficients(model, dt)
    olim, fcap = sim._overlap_caps(model)
    return dict(law=feat.law, coulomb=int(feat.coulomb), viscous=int(feat.viscous),
                left_wall=int(feat.left_wall), right_wall=int(feat.right_wall), stop_mode=0,
                uniform=sim._uniform_code(model, feat, E, P1, P2),
                u=u, v=v, f=f, c=c, active=active, d0=model.d0, k=model.k, n=model.n,
                walls=model.walls, m=model.mass, inv_m=model.inv_mass, eta=model.eta,
                eta_s=model.eta_static, E=E, P1=P1, P2=P2, du=np.zeros(N), dt=dt, n_steps=0, opening=1,
                stop_contact=0, ledger=np.zeros(2), counts=np.zeros(4, dtype=np.int64),
                olim=olim, fcap=fcap, log_events=0, events=verlet.new_event_log(N, 0, 0))


STATE = ("u", "v", "f", "active", "ledger", "counts")
FEATURES = ("law", "coulomb", "viscous", "left_wall", "right_wall", "stop_mode", "uniform",
            "log_events")


def bind(dispatcher, named):
    """(compiled entry point, its argument list, index of n_steps) for a kernel of
    either signature (arguments looked up by name)."""
    py = getattr(dispatcher, "py_func", dispatcher)
    names = py.__code__.co_varnames[:py.__code__.co_argcount]
    args = [named[a] for a in names]
    literal = tuple(i for i, a in enumerate(names) if a in FEATURES)
    return specialised(dispatcher, tuple(args), literal), args, names.index("n_steps")


def timed(kernel, named, saved, steps):
    entry, args, at = kernel
    for name, x in saved.items():
        named[name][:] = x
    args[at] = steps
    t = time.perf_counter()
    entry(*args)
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
    p.add_argument("--per-granule", action="store_true",
                   help="vary masses and stiffnesses by +-0.1 %% (non-uniform parameters)")
    a = p.parse_args()
    for features, initial, N, steps in throughput.case_grid(CASES, a.cases, a.grains,
                                                            a.grain_steps, 10):
        named = build_args(N, features, initial, per_granule=a.per_granule)
        saved = {name: named[name].copy() for name in STATE}
        kernels = {}
        if a.blocks:
            for B in a.blocks:
                verlet.BLOCK = B
                # a fresh dispatcher: recompiled with this BLOCK, no disk cache
                fresh = numba.njit(fastmath={"reassoc", "contract", "nsz"})(verlet.verlet_chunk.py_func)
                kernels[f"B={B}"] = bind(fresh, named)
                timed(kernels[f"B={B}"], named, saved, 1)
            verlet.BLOCK = a.blocks[0]
        else:
            old = load_old(a.old)
            kernels["old"] = bind(old.verlet_chunk, named)
            kernels["new"] = bind(verlet.verlet_chunk, named)
            for k in kernels.values():
                timed(k, named, saved, 1)
        best = {k: float("inf") for k in kernels}
        loads = [os.getloadavg()[0]]
        for _ in range(a.repeat):
            for name, k in kernels.items():
                best[name] = min(best[name], timed(k, named, saved, steps))
        loads.append(os.getloadavg()[0])
        row = {"case": f"{features} {initial}" + (" per-granule" if a.per_granule else ""),
               "grains": N, "steps": steps, "uniform": named["uniform"],
               "load_min": min(loads), "load_max": max(loads)}
        row.update({name: N * steps / t / 1e6 for name, t in best.items()})
        throughput.emit(row, a.json)


if __name__ == "__main__":
    main()
