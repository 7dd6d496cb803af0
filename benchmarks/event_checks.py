"""Numbers for docs/events.md (issue 3, "Must show" 1-5).

    python benchmarks/event_checks.py [--chain N]

Prints: (1) worst relative errors of the n = 2 event stepper against the
paper's Sec. IIA and Sec. III closed forms, and near-critical damping
(gamma^2 -> 8, down to 8 - gamma^2 = 1e-12) against 60-digit mpmath, (2) the
n = 5/2 contact time error against the closed form for several rtol, (3)
Verlet against the event answer, (4) a chain with friction on every granule:
event counts, cost per event and agreement with Verlet; an n = 5/2 Coulomb
chain against rtol 1e-14; cost vs N for a narrow pulse (N = 1e2..1e5) with
the growth exponent, (5) the stuck and no_separation outcomes, with timings.
"""

import argparse
import math
import time

import numpy as np
from scipy.special import gamma as Gamma

from granular_chain import scene_from_dict
from granular_chain.simulate import simulate
from granular_chain.two_granules import collide


def sec2a():
    worst = 0.0
    for eta in np.linspace(0.01, 0.65, 60):
        v1 = -eta * math.pi / (2 * math.sqrt(2))
        v2 = math.sqrt(1 - eta * eta) + v1
        ref = (v1, v2, v1 * v1 + v2 * v2, math.asin(eta) + math.pi / math.sqrt(2))
        c = collide(2, (0.0, eta), stepper="event")
        got = (c.v1, c.v2, c.energy_ratio, c.t_separation)
        worst = max(worst, max(abs(a / b - 1) for a, b in zip(got, ref)))
    return worst


def sec3(gs):
    import mpmath as mp
    mp.mp.dps = 50
    out = []
    for g in gs:
        G = mp.mpf(float(g))
        w = mp.sqrt(8 - G * G) / 2
        ref = ((1 - mp.exp(G * mp.pi / (2 * w))) * mp.exp(-G * mp.pi / w) / 2,
               (1 + mp.exp(G * mp.pi / (2 * w))) * mp.exp(-G * mp.pi / w) / 2, mp.pi / w)
        c = collide(2, gamma=(g, g), stepper="event", t_max=1e5)
        got = (c.v1, c.v2, c.t_separation)
        out.append((g, max(float(abs(a / b - 1)) for a, b in zip(got, ref)), c.result.steps))
    return out


def near_critical():
    """gamma^2 -> 8: relative errors of t0, v1, v2 against 50-digit mpmath (same float gamma).

    The velocities are ~exp(-gamma t0 / 2): below 1e-308 (subnormal, then 0)
    once 8 - gamma^2 < ~1.6e-4, where only t0 can be compared.
    """
    import mpmath as mp
    mp.mp.dps = 60
    for g in (2.82, 2.828, 2.8284, 2.82842, math.sqrt(8 - 1e-8), math.sqrt(8 - 1e-12)):
        G = mp.mpf(float(g))
        w = mp.sqrt(8 - G * G) / 2
        ref = ((1 - mp.exp(G * mp.pi / (2 * w))) * mp.exp(-G * mp.pi / w) / 2,
               (1 + mp.exp(G * mp.pi / (2 * w))) * mp.exp(-G * mp.pi / w) / 2, mp.pi / w)
        c = collide(2, gamma=(g, g), stepper="event", t_max=1e9)
        err = [float(abs(mp.mpf(a) / b - 1)) for a, b in zip((c.v1, c.v2, c.t_separation), ref)]
        print(f"   near-critical gamma={g:.12g} (8-g^2={8 - g * g:.2e}, t0={float(ref[2]):.4g}, "
              f"v1={float(ref[0]):.3e}): rel. err v1 {err[0]:.1e} v2 {err[1]:.1e} "
              f"t0 {err[2]:.1e} ({c.result.steps} modal steps)")


def timing(fn, reps=200):
    fn()
    t0 = time.perf_counter()
    for _ in range(reps):
        r = fn()
    return (time.perf_counter() - t0) / reps, r


def chain(N, n, eta, gamma, t_end, stepper, dt=None):
    d = {"granules": {"count": N, "velocity": [1.0] + [0.0] * (N - 1),
                      "friction": {"kinetic": eta, "viscous": gamma}},
         "contacts": {"exponent": n},
         "run": {"stepper": stepper, "t_end": t_end,
                 **({"max_events": 10 ** 8} if stepper == "event" else {})},
         "output": {"dt": t_end, "trajectory": False}}
    if dt:
        d["run"]["dt"] = dt
    return simulate(scene_from_dict(d))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--chain", type=int, default=1000)
    ap.add_argument("--t-end", type=float, default=100.0)
    a = ap.parse_args()
    print("1. n=2 Sec IIA worst rel. error (eta in [0.01, 0.65], 60 values):", f"{sec2a():.2e}")
    gs = list(np.linspace(0.05, 2.8, 56))
    res = sec3(gs)
    print("   n=2 Sec III worst rel. error (gamma in [0.05, 2.8]):", f"{max(e for _, e, _ in res):.2e}")
    near_critical()
    tc = 2 * (5 / 8) ** 0.4 * math.sqrt(math.pi) * Gamma(1.4) / Gamma(0.9)
    print("2. n=5/2 frictionless contact time: rtol, rel. error, steps, kernel us")
    for rt in (1e-6, 1e-8, 1e-10, 1e-12, 1e-13, 1e-14):
        c = collide(2.5, stepper="event", rtol=rt, atol=rt * 1e-2)
        print(f"   {rt:.0e}  {abs(c.t_separation / tc - 1):.2e}  {c.result.steps}  "
              f"{c.result.wall_time * 1e6:.1f}")
    print("3. Verlet -> event answer, max |dv| at separation")
    for n, eta in ((2, (0.0, 0.3)), (2, (0.1, 0.0)), (2.5, (0.0, 0.3)), (2.5, (0.1, 0.1))):
        ev = collide(n, eta, stepper="event")
        row = [f"{max(abs(collide(n, eta, dt=h).v1 - ev.v1), abs(collide(n, eta, dt=h).v2 - ev.v2)):.2e}"
               for h in (1e-2, 1e-3, 1e-4)]
        print(f"   n={n} eta={eta}: dt=1e-2,1e-3,1e-4 -> {row}")
    for label, f in (("n=2 eta=(0,0.3)", lambda: collide(2, (0, 0.3), stepper="event")),
                     ("n=2 gamma=(1,1)", lambda: collide(2, gamma=(1, 1), stepper="event")),
                     ("n=5/2 rtol=1e-10", lambda: collide(2.5, (0, 0.3), stepper="event",
                                                         rtol=1e-10))):
        tot, r = timing(f, 100)
        print(f"   timing {label}: kernel {r.result.wall_time * 1e6:.1f} us, collide() {tot * 1e6:.0f} us")
    N = a.chain
    t0 = time.perf_counter()
    ev = chain(N, 2.5, 0.01, 0.0, a.t_end, "event")
    el = time.perf_counter() - t0
    nev = len(ev.events)
    print(f"4. chain N={N} n=5/2 eta=0.01 t_end={a.t_end}: {ev.status.name}, events {ev.event_counts}, "
          f"steps {ev.steps}, kernel {ev.wall_time:.3f} s, {ev.wall_time / max(nev, 1) * 1e6:.1f} us/event"
          f" (total incl. compile {el:.1f} s)")
    for h in (2e-3, 1e-3, 5e-4):
        r = chain(N, 2.5, 0.01, 0.0, a.t_end, "verlet", h)
        print(f"   verlet dt={h}: max|dv| {np.max(np.abs(r.v_final - ev.v_final)):.2e}, "
              f"max|dx| {np.max(np.abs(r.x_final - ev.x_final)):.2e}, {r.wall_time:.2f} s")
    print("   n=5/2 chain N=8 eta=0.02 t=6: max|dv| vs rtol=1e-14, ledger balance")
    d = {"granules": {"count": 8, "velocity": [1.0] + [0.0] * 7,
                      "friction": {"kinetic": 0.02, "viscous": 0.0}},
         "contacts": {"exponent": 2.5}, "run": {"stepper": "event", "t_end": 6.0},
         "output": {"trajectory": False}}
    runs = {}
    for rt in (1e-10, 1e-12, 1e-14):
        d["run"].update(rtol=rt, atol=rt * 1e-2)
        runs[rt] = simulate(scene_from_dict(d))
    for rt in (1e-10, 1e-12):
        print(f"   rtol {rt:.0e}: max|dv| {np.max(np.abs(runs[rt].v_final - runs[1e-14].v_final)):.1e}, "
              f"ledger {runs[rt].energy.balance_error:.1e}, steps {runs[rt].steps}")
    Ms = (100, 1000, 10000, 100000)
    ts = []
    for M in Ms:
        best = math.inf
        for _ in range(3 if M <= 10000 else 1):
            r = chain(M, 2.5, 0.01, 0.0, 30.0, "event")
            best = min(best, r.wall_time)
        fixed = chain(M, 2.5, 0.01, 0.0, 1e-3, "event").wall_time
        ts.append(best)
        print(f"   cost vs N (t_end=30): N={M}: {len(r.events)} events, {r.steps} steps, "
              f"kernel {best * 1e3:.1f} ms (of which one-time O(N) setup/frames ~{fixed * 1e3:.1f} ms)")
    slope = np.polyfit(np.log(Ms), np.log(ts), 1)[0]
    print(f"   growth exponent of the kernel time in N: {slope:.2f}")
    c = collide(2, (0.9, 0.9), stepper="event")
    print(f"5. eta=(0.9,0.9): {c.outcome.name}, {c.result.status.name}, t={c.result.t_final:.6g}, "
          f"kernel {c.result.wall_time * 1e6:.1f} us")
    c = collide(2, gamma=(3, 3), stepper="event")
    print(f"   gamma=(3,3): {c.outcome.name}, {c.result.message}, kernel {c.result.wall_time * 1e6:.1f} us")


if __name__ == "__main__":
    main()
