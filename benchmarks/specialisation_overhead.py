"""'Leave out what the scene does not need', measured (issue 5).

The frictionless struck Hertz chain of benchmarks/throughput.py (m = 1, k = 1,
n = 5/2, touching, dt = 0.01, granule 0 at v = 1) run by the engine's compiled
Verlet kernel (granular_chain.steppers.verlet.verlet_chunk, through simulate:
per-granule parameter arrays, event counting, energy ledger, feature codes as
literals) against kernels written by hand for this scene only:

hand_3pass   the engine's algorithm (kick+drift / contact forces / net force+kick),
             with the scene's constants (m = k = 1, touching) folded in, no
             event counts, no ledger. Overhead = engine time / this time - 1 (goal <= 3%).
hand_fused   one pass per step (prototype of a kernel change): granule i+1 is
             kicked and drifted, contact i computed, granule i finished, in one
             sweep. u, v, f are each read and written once per step (48 B per
             grain-step instead of ~120 B), at the price of a loop-carried contact
             force (no SIMD).
hand_par     hand_3pass with numba prange on both cores (prototype: the
             parallel speed-up the issue asks about).

The hand kernels are checked against the engine's final state.

Second part, per-call overhead (matters for the two-granule maps, where a run is
microseconds): granular_chain._compile.specialised computes numba.typeof of
every argument (~28 for verlet_chunk) on *every* run to find the compiled entry
point. Prototype: a key of (literal values, dtype/ndim/layout of arrays, Python
type of scalars) checked first, falling back to ``specialised`` on a miss. It is
installed by monkeypatching for the measurement only (granular_chain is not
edited); collide() is timed with and without it. Since commit 39ebfe9 the engine's
own lookup uses such a key, so both rows now measure the same thing.

Third part (``--fused-only``): the engine's general verlet_chunk with its passes
fused into one sweep (fused_chunk), run through the real simulate(). The new u, v
of granule i+1 travel to the next iteration in registers and the last granule is
peeled off the loop (a version storing and reloading them, or testing i inside
the loop, was 3x slower than the engine). Measured 1.65-1.93x without friction,
1.2-1.4x with drag only, 0.25x with Coulomb friction (whose three-pass kick
loops vectorise): the proposal is the sweep for scenes without Coulomb friction.

    python benchmarks/specialisation_overhead.py          # about a minute
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


def run_hand(kernel, N, steps, dt=0.01):
    u = np.zeros(N)
    v = np.zeros(N)
    v[0] = 1.0
    f = np.zeros(N)
    c = np.zeros(N - 1)
    t0 = time.perf_counter()
    kernel(u, v, f, c, dt, steps)
    return time.perf_counter() - t0, u, v


def engine(N, steps):
    out = throughput.measure(N, steps, "frictionless")
    r = gc.simulate(throughput.chain_scene(N, steps, "frictionless"), progress=False)
    return out["seconds"], np.asarray(r.x_final) - np.asarray(r.x[0]), np.asarray(r.v_final)


# ---------------------------------------------------------------------------
# Prototype of a kernel change: the engine's verlet_chunk with its three passes
# fused into one sweep (same laws, kicks, drifts, walls, events, ledger). Granule
# i+1 gets its first half kick and drift, then contact i is evaluated, then
# granule i gets its second half kick: u, v, f are read and written once per
# step. Run through the real simulate() by swapping the dispatcher that
# _compile.specialised is asked for (granular_chain is not edited).
# ---------------------------------------------------------------------------

from granular_chain.forces import wall_forces  # noqa: E402
from granular_chain.laws.contact import contact_force  # noqa: E402
from granular_chain.steppers import verlet as _vl  # noqa: E402


@numba.njit(inline="always")
def _first_half(coulomb, viscous, i, u, v, f, m, inv_m, eta, eta_s, E, P1, P2, dt, inv_dt, h):
    """The engine's pass 1 for granule i, without stores.

    Returns (wc, wv, n_stop, n_slip, u_new, v_new, du_new)."""
    if viscous and not coulomb:
        vv = v[i]
        a = f[i] * inv_m[i]
        dui = vv * P1[i] + a * P2[i]
        return (0.0, -(0.5 * m[i] * vv * vv + 0.5 * f[i] * dui), 0, 0, u[i] + dui,
                vv * E[i] + a * (P1[i] - P2[i] * inv_dt), dui)
    v1, a, b, code = _vl.kick(coulomb, i, v[i], f[i], inv_m, eta, eta_s, h)
    wv = 0.0
    dui = 0.0
    if viscous:
        dui, v1, b = _vl.viscous_drift(v1, m[i], E[i], P1[i])
        wv = b
    else:
        dui = dt * v1
    return a, wv, code & 1, (code >> 1) & 1, u[i] + dui, v1, dui


@numba.njit(inline="always")
def _second_half(coulomb, viscous, i, F, ui, vi, dui, u, v, f, du, m, inv_m, eta, eta_s, P2,
                 inv_dt, h):
    """The engine's pass 3 for granule i (net force F), storing u, v, f: (wc, wv, n_stop, n_slip)."""
    f[i] = F
    u[i] = ui
    if viscous and not coulomb:
        v1 = vi + F * inv_m[i] * P2[i] * inv_dt
        du[i] = dui
        v[i] = v1
        return 0.0, 0.5 * m[i] * v1 * v1 - 0.5 * F * dui, 0, 0
    v1, a, b, code = _vl.kick(coulomb, i, vi, F, inv_m, eta, eta_s, h)
    v[i] = v1
    return a, 0.0, code & 1, (code >> 1) & 1


@numba.njit(cache=True, fastmath={"reassoc", "contract", "nsz"})
def fused_chunk(law, coulomb, viscous, left_wall, right_wall, stop_mode,
                u, v, f, c, active, d0, k, n, walls, m, inv_m, eta, eta_s, E, P1, P2, du,
                dt, n_steps, stop_contact, ledger, counts):
    """verlet_chunk with one sweep per step; granule i's new u, v are carried in
    registers from the first half (done one iteration ahead) to the second half."""
    law = numba.literally(law)
    coulomb = numba.literally(coulomb)
    viscous = numba.literally(viscous)
    left_wall = numba.literally(left_wall)
    right_wall = numba.literally(right_wall)
    stop_mode = numba.literally(stop_mode)
    h = 0.5 * dt
    inv_dt = 1.0 / dt
    N = u.size
    for step in range(n_steps):
        watched_was = active[stop_contact]
        wc, wv, n_stop, n_slip, ui, vi, dui = _first_half(coulomb, viscous, 0, u, v, f, m, inv_m,
                                                          eta, eta_s, E, P1, P2, dt, inv_dt, h)
        left = 0.0
        if left_wall:
            left = contact_force(law, walls[0] - ui, walls[1], walls[2])
        n_close = 0
        n_open = 0
        # granules 0 .. N-2: the loop body has no test on i (that alone cost 3x)
        for i in range(N - 1):
            a, b, s1, s2, un, vn, dun = _first_half(coulomb, viscous, i + 1, u, v, f, m, inv_m,
                                                    eta, eta_s, E, P1, P2, dt, inv_dt, h)
            wc += a
            wv += b
            n_stop += s1
            n_slip += s2
            right = contact_force(law, d0[i] + ui - un, k[i], n[i])
            c[i] = right
            a, b, s1, s2 = _second_half(coulomb, viscous, i, left - right, ui, vi, dui, u, v, f,
                                        du, m, inv_m, eta, eta_s, P2, inv_dt, h)
            wc += a
            wv += b
            n_stop += s1
            n_slip += s2
            now = 1 if right > 0.0 else 0
            was = active[i]
            n_close += now & (1 - was)
            n_open += was & (1 - now)
            active[i] = now
            left = right
            ui = un
            vi = vn
            dui = dun
        right = 0.0
        if right_wall:
            right = contact_force(law, walls[3] + ui, walls[4], walls[5])
        a, b, s1, s2 = _second_half(coulomb, viscous, N - 1, left - right, ui, vi, dui, u, v, f,
                                    du, m, inv_m, eta, eta_s, P2, inv_dt, h)
        wc += a
        wv += b
        n_stop += s1
        n_slip += s2
        if coulomb:
            ledger[0] -= wc
            counts[_vl.EV_STOP] += n_stop
            counts[_vl.EV_SLIP] += n_slip
        if viscous:
            ledger[1] -= wv
        counts[_vl.EV_CLOSE] += n_close
        counts[_vl.EV_OPEN] += n_open
        if stop_mode & _vl.STOP_ON_SEPARATION:
            if watched_was == 1 and active[stop_contact] == 0:
                return step + 1, _vl.SEPARATED
        if stop_mode & _vl.STOP_ON_REST:
            rest = True
            for i in range(N):
                if v[i] != 0.0:
                    rest = False
                    break
            if rest:
                return step + 1, _vl.AT_REST
    return n_steps, _vl.RAN_CHUNK


def run_fused(scene, fused, random_v=False):
    """simulate(scene) with verlet_chunk (fused=False) or fused_chunk (fused=True)."""
    from granular_chain import _compile
    from granular_chain.model import build_model
    gsim = sys.modules["granular_chain.simulate"]
    orig = gsim.specialised

    def swap(dispatcher, args, literal):
        if fused and dispatcher is _vl.verlet_chunk:
            dispatcher = fused_chunk
        return _compile.specialised(dispatcher, args, literal)
    gsim.specialised = swap
    try:
        model = build_model(scene)
        if random_v:
            model.v0[:] = np.random.default_rng(1).uniform(-0.1, 0.1, model.count)
        return gsim._simulate_verlet(scene, model, False)
    finally:
        gsim.specialised = orig


def fused_prototype(Ns=(1000, 100_000, 10_000_000), grain_steps=1e8, repeat=3,
                    cases=(("frictionless", "struck"), ("coulomb+viscous", "struck"),
                           ("coulomb", "random"), ("coulomb+viscous", "random"))):
    out = []
    for features, initial in cases:
        for N in Ns:
            steps = max(20, int(grain_steps // N))
            if initial == "random":
                steps = min(steps, 1000)
            scene = throughput.chain_scene(N, steps, features)
            small = throughput.chain_scene(N, 2, features)
            run_fused(small, False, initial == "random")
            run_fused(small, True, initial == "random")
            best = {False: math.inf, True: math.inf}
            res = {}
            for _ in range(repeat):
                for fz in (False, True):
                    r = run_fused(scene, fz, initial == "random")
                    best[fz] = min(best[fz], r.wall_time)
                    res[fz] = r
            a, b = res[False], res[True]
            diff = float(max(np.max(abs(a.x_final - b.x_final)), np.max(abs(a.v_final - b.v_final))))
            row = {"features": features, "initial": initial, "grains": N, "steps": steps,
                   "engine_Mps": N * steps / best[False] / 1e6,
                   "fused_Mps": N * steps / best[True] / 1e6,
                   "speedup": best[False] / best[True], "max_state_diff": diff,
                   "same_event_counts": a.event_counts == b.event_counts,
                   "event_counts": [a.event_counts, b.event_counts],
                   "ledger_diff": float(abs(a.energy.balance_error - b.energy.balance_error)),
                   "load": os.getloadavg()[0]}
            out.append(row)
            print(f"fused prototype {features:16s} {initial:6s} N={N:>9d}: engine {row['engine_Mps']:7.1f} "
                  f"M/s, fused {row['fused_Mps']:7.1f} M/s (x{row['speedup']:.2f}); state diff {diff:.1e}, "
                  f"same event counts {row['same_event_counts']} (load {row['load']:.2f})"
                  + ("" if row["same_event_counts"] else f" {a.event_counts} vs {b.event_counts}"), flush=True)
    return out


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
    import granular_chain.steppers.events  # noqa: F401
    # the package re-exports the function simulate under the module's name
    gsim = sys.modules["granular_chain.simulate"]
    gev = sys.modules["granular_chain.steppers.events"]
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
    p.add_argument("--grain-steps", type=float, default=2e8)
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--skip-kernels", action="store_true")
    p.add_argument("--fused-only", action="store_true",
                   help="only the fused-sweep prototype of verlet_chunk")
    a = p.parse_args()
    if a.fused_only:
        fz = fused_prototype()
        os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
        with open(os.path.join(HERE, "results", "fused_prototype.json"), "w") as fh:
            json.dump(fz, fh, indent=1)
        return
    disp = dispatch_overhead()
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    with open(os.path.join(HERE, "results", "dispatch_overhead.json"), "w") as fh:
        json.dump(disp, fh, indent=1)
    if a.skip_kernels:
        return
    for k in (hand_3pass, hand_fused, hand_par):
        run_hand(k, 10, 2)
    res = []
    for N in a.grains:
        steps = max(10, int(a.grain_steps // N))
        if N >= 1_000_000:
            steps = max(10, min(steps, 20))
        row = {"grains": N, "steps": steps, "load": os.getloadavg()[0]}
        t_eng, ue, ve = math.inf, None, None
        times = {k: math.inf for k in ("hand_3pass", "hand_fused", "hand_par")}
        # interleave the repeats so that load changes hit all variants alike
        for _ in range(a.repeat):
            out = throughput.measure(N, steps, "frictionless")
            t_eng = min(t_eng, out["seconds"])
            for name, k in (("hand_3pass", hand_3pass), ("hand_fused", hand_fused),
                            ("hand_par", hand_par)):
                t, u, v = run_hand(k, N, steps)
                times[name] = min(times[name], t)
                row[f"{name}_state"] = (u, v)
        r = gc.simulate(throughput.chain_scene(N, steps, "frictionless"), progress=False)
        ue, ve = np.asarray(r.x_final) - np.asarray(r.x[0]), np.asarray(r.v_final)
        gs = N * steps
        row["engine_Mps"] = gs / t_eng / 1e6
        for name in times:
            u, v = row.pop(f"{name}_state")
            row[f"{name}_Mps"] = gs / times[name] / 1e6
            row[f"{name}_maxdiff"] = float(max(np.max(abs(u - ue)), np.max(abs(v - ve))))
        row["overhead_vs_hand_3pass"] = t_eng / times["hand_3pass"] - 1.0
        row["fused_speedup_vs_engine"] = t_eng / times["hand_fused"]
        row["parallel_speedup_vs_hand_3pass"] = times["hand_3pass"] / times["hand_par"]
        row["load_end"] = os.getloadavg()[0]
        res.append(row)
        print(f"N={N:>9d} steps={steps:>7d} engine {row['engine_Mps']:8.1f} M/s | hand_3pass "
              f"{row['hand_3pass_Mps']:8.1f} (overhead {100 * row['overhead_vs_hand_3pass']:+.1f}%) | "
              f"fused {row['hand_fused_Mps']:8.1f} | par(2) {row['hand_par_Mps']:8.1f} "
              f"(x{row['parallel_speedup_vs_hand_3pass']:.2f}) | max diff "
              f"{row['hand_3pass_maxdiff']:.1e}/{row['hand_fused_maxdiff']:.1e} "
              f"(load {row['load']:.2f}-{row['load_end']:.2f})", flush=True)
    os.makedirs(os.path.join(HERE, "results"), exist_ok=True)
    with open(os.path.join(HERE, "results", "specialisation_overhead.json"), "w") as fh:
        json.dump(res, fh, indent=1)


if __name__ == "__main__":
    main()
