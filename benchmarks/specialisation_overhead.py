"""'Leave out what the scene does not need', measured (issue 5).

The frictionless struck Hertz chain of benchmarks/throughput.py (m = 1, k = 1,
n = 5/2, touching, dt = 0.01, granule 0 at v = 1) run by the engine's compiled
Verlet kernel (granular_chain.steppers.verlet.verlet_chunk: for this scene the
single sweep with the ``uniform`` feature code, contact events, the every-step
overlap guard) against kernels written by hand for this scene only. Every hand
kernel knows what the engine's ``uniform`` specialisation knows (one mass, one
stiffness, one d0) and more: m = k = 1 and d0 = 0 are folded in as constants.

hand_fused         one sweep per step (the engine's algorithm for this scene), no
                   event counts, no overlap guard: the least a kernel can do.
hand_fused_events  hand_fused that also reports what the engine's Result reports for
                   this scene: contact closings and openings (from the overlaps' signs
                   before and after the step, as the engine) and the every-step
                   overlap guard (an integer count of contacts whose force reaches
                   the force at which the centres meet, k (r_i + r_(i+1))^(3/2) = 1).
hand_uniform_events
                   hand_fused_events with the mass, stiffness and d0 as run-time
                   scalars (a kernel for any uniform Hertz chain): exactly what the
                   engine's ``uniform`` specialisation knows, and no more.
hand_3pass         the three-pass algorithm (kick+drift / contact forces / net
                   force+kick), for reference: the engine's old frictionless kernel.
hand_par           hand_3pass with numba prange on both cores (``--parallel``).

Engine rate: the kernel alone, called as simulate() calls it, on arrays restored
outside the timing (kernel); and simulate()'s Result.wall_time, which adds one
output frame's O(N) numpy checks (wall: meaningless at N = 1e7, where 10-20
steps cost less than the frame). The hand kernels run on the engine's own u, v, f
arrays, reset outside the timing (same memory, no first-touch page faults). Overhead =
engine time / hand time - 1 (goal <= 3 %). Best of ``--repeat``, interleaved.
The hand kernels' final states are checked against the engine's.

Second part, per-call overhead (matters for the two-granule maps, where a run is
microseconds): collide() timed with the engine's own specialisation lookup and
with a prototype key (kept for the record: since 39ebfe9 the engine's lookup
uses such a key, so both rows measure the same thing).

The fused-sweep prototype that used to live here (``--fused-only``,
``fused_chunk``) is gone: verlet_chunk now contains the sweep.

    python benchmarks/specialisation_overhead.py --skip-dispatch   # kernels only, a few minutes
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numba
import numpy as np
from numba import prange

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import throughput  # noqa: E402

import granular_chain as gc  # noqa: E402


@numba.njit(cache=True, fastmath={"reassoc", "contract", "nsz"})
def hand_3pass(u, v, f, c, dt, n_steps):
    h = 0.5 * dt
    N = u.size
    for _ in range(n_steps):
        for i in range(N):
            v[i] += h * f[i]
            u[i] += dt * v[i]
        for i in range(N - 1):
            d = max(u[i] - u[i + 1], 0.0)
            c[i] = d * math.sqrt(d)
        for i in range(N):
            left = c[i - 1] if i > 0 else 0.0
            right = c[i] if i < N - 1 else 0.0
            F = left - right
            f[i] = F
            v[i] += h * F


@numba.njit(cache=True, fastmath={"reassoc", "contract", "nsz"})
def hand_fused(u, v, f, c, dt, n_steps):
    h = 0.5 * dt
    N = u.size
    for _ in range(n_steps):
        vi = v[0] + h * f[0]
        ui = u[0] + dt * vi
        left = 0.0
        for i in range(N - 1):
            vn = v[i + 1] + h * f[i + 1]
            un = u[i + 1] + dt * vn
            d = max(ui - un, 0.0)
            cr = d * math.sqrt(d)
            F = left - cr
            f[i] = F
            v[i] = vi + h * F
            u[i] = ui
            left = cr
            vi = vn
            ui = un
        F = left
        f[N - 1] = F
        v[N - 1] = vi + h * F
        u[N - 1] = ui


@numba.njit(cache=True, fastmath={"reassoc", "contract", "nsz"})
def hand_uniform_events(u, v, f, c, dt, n_steps, m=1.0, k=1.0, d0=0.0, fcap=1.0):
    """hand_fused plus the engine's outputs for this scene: contact closings and
    openings (overlap sign before and after the step) and the overlap guard.

    Called with m, k, d0, fcap as run-time scalars it is a kernel for any uniform
    Hertz chain (what the engine's ``uniform`` specialisation knows, and no more);
    called without them (``hand_fused_events``), numba compiles the omitted defaults
    as constants and folds m = k = 1, d0 = 0 in: a kernel for this scene only."""
    h = 0.5 * dt
    hm = h / m
    N = u.size
    n_close = 0
    n_open = 0
    for step in range(n_steps):
        uo = u[0]
        vi = v[0] + hm * f[0]
        ui = uo + dt * vi
        left = 0.0
        n_hard = 0
        n_change = 0
        n_net = 0
        for i in range(N - 1):
            uon = u[i + 1]
            vn = v[i + 1] + hm * f[i + 1]
            un = uon + dt * vn
            d = max(d0 + ui - un, 0.0)
            cr = k * d * math.sqrt(d)
            n_hard += 1 if cr >= fcap else 0
            was = 1 if uo - uon > -d0 else 0
            now = 1 if ui - un > -d0 else 0
            n_change += now ^ was
            n_net += now - was
            F = left - cr
            f[i] = F
            v[i] = vi + hm * F
            u[i] = ui
            left = cr
            uo = uon
            vi = vn
            ui = un
        F = left
        f[N - 1] = F
        v[N - 1] = vi + hm * F
        u[N - 1] = ui
        n_close += (n_change + n_net) >> 1
        n_open += (n_change - n_net) >> 1
        if n_hard > 0:
            for i in range(N - 1):
                if d0 + u[i] - u[i + 1] >= 1.0:
                    return n_close, n_open, step + 1
    return n_close, n_open, n_steps


@numba.njit(cache=True, parallel=True, fastmath={"reassoc", "contract", "nsz"})
def hand_par(u, v, f, c, dt, n_steps):
    h = 0.5 * dt
    N = u.size
    for _ in range(n_steps):
        for i in prange(N):
            v[i] += h * f[i]
            u[i] += dt * v[i]
        for i in prange(N - 1):
            d = max(u[i] - u[i + 1], 0.0)
            c[i] = d * math.sqrt(d)
        for i in prange(N):
            left = c[i - 1] if i > 0 else 0.0
            right = c[i] if i < N - 1 else 0.0
            F = left - right
            f[i] = F
            v[i] += h * F


def hand_fused_events(u, v, f, c, dt, n_steps):
    """hand_uniform_events with m = k = 1, d0 = 0, fcap = 1 folded in as constants."""
    return hand_uniform_events(u, v, f, c, dt, n_steps)


HAND = {"hand_fused": hand_fused, "hand_fused_events": hand_fused_events,
        "hand_uniform_events": hand_uniform_events, "hand_3pass": hand_3pass, "hand_par": hand_par}


def hand_state(N):
    """Preallocated, touched arrays for a hand kernel: u, v, f, c."""
    return np.zeros(N), np.zeros(N), np.zeros(N), np.zeros(max(N - 1, 1))


# Run-time scalars for hand_uniform_events: passed explicitly, because a numba
# function called without its default arguments compiles them as constants (it
# then folds m = k = 1, d0 = 0: 71 instructions per 16 granules in its vector
# loop; with run-time scalars 79, the engine's 80). hand_fused_events is that
# constant-folded call.
UNIFORM_SCALARS = {"hand_uniform_events": (1.0, 1.0, 0.0, 1.0)}


def run_hand(kernel, state, steps, dt=0.01):
    """Reset the struck chain in place (outside the timing) and time ``steps`` steps."""
    u, v, f, c = state
    u[:] = 0.0
    v[:] = 0.0
    v[0] = 1.0
    f[:] = 0.0
    extra = UNIFORM_SCALARS.get(getattr(kernel, "__name__", ""), ())
    t0 = time.perf_counter()
    kernel(u, v, f, c, dt, steps, *extra)
    return time.perf_counter() - t0


def overhead_table(grains, grain_steps, repeat, parallel):
    """Engine (kernel alone; simulate's Result.wall_time) against the hand kernels."""
    import tiled_kernel_bench as tkb
    from granular_chain.steppers import verlet
    names = [n for n in HAND if parallel or n != "hand_par"]
    for n in names:
        run_hand(HAND[n], hand_state(10), 2)
    res = []
    for N in grains:
        steps = max(10, int(grain_steps // N))
        if N >= 1_000_000:
            steps = max(10, min(steps, 20))
        named = tkb.build_args(N, "frictionless", "struck")
        saved = {k: named[k].copy() for k in tkb.STATE}
        kern = tkb.bind(verlet.verlet_chunk, named)
        tkb.timed(kern, named, saved, 1)
        scene = throughput.chain_scene(N, steps, "frictionless")
        gc.simulate(throughput.chain_scene(N, 2, "frictionless"), progress=False)
        # The hand kernels run on the engine's own u, v, f arrays (reset before each
        # call): the same memory, so that placement (alignment, cache-set and 4K
        # aliasing) cannot favour either side; measured to matter at N = 1e5.
        shared = (named["u"], named["v"], named["f"], np.zeros(max(N - 1, 1)))
        states = {n: shared for n in names}
        finals = {}
        best = {k: math.inf for k in ["engine_kernel", "engine_wall"] + names}
        loads = [os.getloadavg()[0]]
        # interleave the repeats so that load changes hit all variants alike
        for _ in range(repeat):
            best["engine_kernel"] = min(best["engine_kernel"], tkb.timed(kern, named, saved, steps))
            r = gc.simulate(scene, progress=False)
            best["engine_wall"] = min(best["engine_wall"], r.wall_time)
            for n in names:
                best[n] = min(best[n], run_hand(HAND[n], states[n], steps))
                finals[n] = (shared[0].copy(), shared[1].copy())
        loads.append(os.getloadavg()[0])
        ue = np.asarray(r.x_final) - np.asarray(r.x[0])
        ve = np.asarray(r.v_final)
        gs = N * steps
        row = {"grains": N, "steps": steps, "load_min": min(loads), "load_max": max(loads),
               "engine_event_counts": r.event_counts}
        for k, t in best.items():
            row[f"{k}_Mps"] = gs / t / 1e6
        for n in names:
            u, v = finals[n]
            row[f"{n}_maxdiff"] = float(max(np.max(abs(u - ue)), np.max(abs(v - ve))))
        row["hand_fused_events_counts"] = list(hand_fused_events(*hand_state_struck(N), 0.01, steps))
        for e in ("engine_kernel", "engine_wall"):
            for n in ("hand_fused", "hand_fused_events", "hand_uniform_events"):
                row[f"overhead_{e}_vs_{n}"] = best[e] / best[n] - 1.0
        res.append(row)
        print(f"N={N:>9d} steps={steps:>7d} engine kernel {row['engine_kernel_Mps']:7.0f} wall "
              f"{row['engine_wall_Mps']:7.0f} | hand_fused {row['hand_fused_Mps']:7.0f} "
              f"(overhead kernel {100 * row['overhead_engine_kernel_vs_hand_fused']:+.1f}%, wall "
              f"{100 * row['overhead_engine_wall_vs_hand_fused']:+.1f}%) | hand_fused_events "
              f"{row['hand_fused_events_Mps']:7.0f} (overhead kernel "
              f"{100 * row['overhead_engine_kernel_vs_hand_fused_events']:+.1f}%, wall "
              f"{100 * row['overhead_engine_wall_vs_hand_fused_events']:+.1f}%) | hand_uniform_events "
              f"{row['hand_uniform_events_Mps']:7.0f} (overhead kernel "
              f"{100 * row['overhead_engine_kernel_vs_hand_uniform_events']:+.1f}%, wall "
              f"{100 * row['overhead_engine_wall_vs_hand_uniform_events']:+.1f}%) | hand_3pass "
              f"{row['hand_3pass_Mps']:7.0f}"
              + (f" | par(2) {row['hand_par_Mps']:7.0f}" if parallel else "")
              + f" | max diff {max(row[f'{n}_maxdiff'] for n in names):.1e} | events engine "
              f"{r.event_counts['contact_close']}/{r.event_counts['contact_open']} hand "
              f"{row['hand_fused_events_counts'][0]}/{row['hand_fused_events_counts'][1]} "
              f"(load {row['load_min']:.2f}-{row['load_max']:.2f})", flush=True)
    return res


def hand_state_struck(N):
    u, v, f, c = hand_state(N)
    v[0] = 1.0
    return u, v, f, c


_FAST = {}


def specialised_fast(dispatcher, args, literal, _orig=None):
    """Prototype of a cheaper lookup for granular_chain._compile.specialised."""
    from granular_chain import _compile
    key = (dispatcher,) + tuple(
        a if i in literal else
        ((a.dtype.char, a.ndim, a.flags.c_contiguous, a.flags.writeable)
         if isinstance(a, np.ndarray) else type(a))
        for i, a in enumerate(args))
    entry = _FAST.get(key)
    if entry is None:
        entry = _compile.specialised(dispatcher, args, literal)
        _FAST[key] = entry
    return entry


def breakdown(kw, repeat=300):
    """Where collide()'s time goes: scene dict -> validated Scene -> Model -> simulate -> kernel."""
    from granular_chain.model import build_model
    from granular_chain.scene import scene_from_dict
    from granular_chain.two_granules import two_granule_scene
    kw = dict(kw)
    n, eta = kw.pop("n"), kw.pop("eta")
    t = {"scene_us": math.inf, "model_us": math.inf, "simulate_us": math.inf, "kernel_us": math.inf}
    for _ in range(repeat):
        t0 = time.perf_counter()
        sc = scene_from_dict(two_granule_scene(n, eta, **kw), source="bench")
        t1 = time.perf_counter()
        build_model(sc)
        t2 = time.perf_counter()
        r = gc.simulate(sc, progress=False)
        t3 = time.perf_counter()
        t["scene_us"] = min(t["scene_us"], (t1 - t0) * 1e6)
        t["model_us"] = min(t["model_us"], (t2 - t1) * 1e6)
        t["simulate_us"] = min(t["simulate_us"], (t3 - t2) * 1e6)
        t["kernel_us"] = min(t["kernel_us"], r.wall_time * 1e6)
    return {"breakdown_" + k: v for k, v in t.items()}


def dispatch_overhead(repeat=2000):
    """collide() and its kernel time per call, with the engine's lookup and the prototype."""
    import granular_chain.simulate  # noqa: F401
    import granular_chain.steppers.events.pack  # noqa: F401
    # the package re-exports the function simulate under the module's name
    gsim = sys.modules["granular_chain.simulate"]
    gev = sys.modules["granular_chain.steppers.events.pack"]  # (where the event kernel is looked up)
    from granular_chain.two_granules import collide
    cases = {"verlet n=2 eta=(0,0.3) dt=0.1": dict(n=2.0, eta=(0.0, 0.3), stepper="verlet", dt=0.1),
             "event n=2 eta=(0,0.3)": dict(n=2.0, eta=(0.0, 0.3), stepper="event"),
             "event n=5/2 eta=(0,0.3) rtol=1e-10": dict(n=2.5, eta=(0.0, 0.3), stepper="event",
                                                       rtol=1e-10, atol=1e-12)}
    orig = (gsim.specialised, gev.specialised)
    out = {}
    for name, kw in cases.items():
        row = {}
        for variant in ("engine", "prototype"):
            if variant == "prototype":
                gsim.specialised = gev.specialised = specialised_fast
            try:
                collide(**kw)
                best_call, best_kernel = math.inf, math.inf
                for _ in range(5):
                    t0 = time.perf_counter()
                    ks = []
                    for _ in range(repeat // 5):
                        ks.append(collide(**kw).result.wall_time)
                    best_call = min(best_call, (time.perf_counter() - t0) / (repeat // 5))
                    best_kernel = min(best_kernel, float(np.median(ks)))
            finally:
                gsim.specialised, gev.specialised = orig
            row[f"{variant}_call_us"] = best_call * 1e6
            row[f"{variant}_kernel_us"] = best_kernel * 1e6
        row.update(breakdown(kw))
        row["load"] = os.getloadavg()[0]
        out[name] = row
        print(f"{name:38s} collide() {row['engine_call_us']:7.1f} -> {row['prototype_call_us']:7.1f} us, "
              f"Result.wall_time {row['engine_kernel_us']:7.1f} -> {row['prototype_kernel_us']:7.1f} us "
              f"(load {row['load']:.2f}); breakdown: scene {row['breakdown_scene_us']:.0f}, model "
              f"{row['breakdown_model_us']:.0f}, simulate {row['breakdown_simulate_us']:.0f} "
              f"(of which Result.wall_time {row['breakdown_kernel_us']:.0f}) us", flush=True)
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grains", type=int, nargs="*", default=[1000, 10_000, 100_000, 10_000_000])
    p.add_argument("--grain-steps", type=float, default=1e8)
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--skip-kernels", action="store_true")
    p.add_argument("--skip-dispatch", action="store_true")
    p.add_argument("--parallel", action="store_true", help="also time hand_par (prange, 2 threads)")
    p.add_argument("--out", default=os.path.join(HERE, "results", "specialisation_overhead.json"))
    a = p.parse_args()
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    if not a.skip_dispatch:
        disp = dispatch_overhead()
        with open(os.path.join(HERE, "results", "dispatch_overhead.json"), "w") as fh:
            json.dump(disp, fh, indent=1)
    if a.skip_kernels:
        return
    res = overhead_table(a.grains, a.grain_steps, a.repeat, a.parallel)
    with open(a.out, "w") as fh:
        json.dump(res, fh, indent=1)


if __name__ == "__main__":
    main()
