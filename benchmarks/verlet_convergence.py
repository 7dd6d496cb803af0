"""Velocity-Verlet convergence against closed forms (issue 2, "Must show" 1-3).

Prints markdown tables: error against the step h and the fitted order for
  1. collide(n=2, eta=(0, 0.3)) against the paper's Sec. II A closed forms,
     and collide(n=2, eta=(0.1, 0)) against the exact piecewise-linear
     reference (granular_chain.paper.reference_collision_n2, mpmath at 30 digits);
  2. two frictionless Hertz spheres: contact time against
     t_c = 2 delta_max int_0^1 dx / sqrt(1 - x^(5/2)), and the velocity exchange;
  3. the energy-ledger balance error with Coulomb and viscous friction on a
     chain, and momentum conservation of a frictionless chain.

Run:  python benchmarks/verlet_convergence.py > docs/verlet_convergence_tables.md
"""

import math
import time

import numpy as np
from scipy.special import gamma as Gamma

import granular_chain as gc
from granular_chain.two_granules import collide

H = [1e-2, 1e-3, 1e-4, 1e-5]


def order(h, e):
    e = np.abs(np.asarray(e))
    return float(np.polyfit(np.log(h), np.log(e), 1)[0])


def table(title, cols, rows, orders):
    print(f"\n### {title}\n")
    print("| h | " + " | ".join(cols) + " | time per collision (s) |")
    print("|---|" + "---|" * (len(cols) + 1))
    for h, errs, t in rows:
        print(f"| {h:.0e} | " + " | ".join(f"{e:.3e}" for e in errs) + f" | {t:.2e} |")
    print("| fitted order | " + " | ".join(f"{o:.2f}" for o in orders) + " | |")


def sweep(fn, exact):
    rows = []
    for h in H:
        collide_args = fn(h)
        t0 = time.perf_counter()
        c = collide(**collide_args)
        t = time.perf_counter() - t0
        rows.append((h, [c.v1 - exact[0], c.v2 - exact[1], c.energy_ratio - exact[2]], t))
    orders = [order(H, [r[1][j] for r in rows]) for j in range(3)]
    return rows, orders


def main():
    eta = 0.3
    v1 = -eta * math.pi / (2 * math.sqrt(2))
    v2 = math.sqrt(1 - eta ** 2) + v1
    rows, orders = sweep(lambda h: dict(n=2, eta=(0.0, eta), dt=h), (v1, v2, v1 ** 2 + v2 ** 2))
    table("eta = (0, 0.3), n = 2, against Sec. II A: v1 = -eta pi/(2 sqrt 2), "
          "v2 = sqrt(1-eta^2) + v1, E/E0 = v1^2 + v2^2",
          ["error v1", "error v2", "error E/E0"], rows, orders)

    from granular_chain.paper import reference_collision_n2
    ref = reference_collision_n2(0.1, 0.0)
    rows, orders = sweep(lambda h: dict(n=2, eta=(0.1, 0.0), dt=h),
                         (float(ref["v1"]), float(ref["v2"]), float(ref["energy_ratio"])))
    table(f"eta = (0.1, 0), n = 2, against the exact piecewise-linear solution "
          f"(v1 = {float(ref['v1']):.15f}, v2 = {float(ref['v2']):.15f})",
          ["error v1", "error v2", "error E/E0"], rows, orders)

    dmax = (5.0 / 8.0) ** 0.4
    tc = 2 * dmax * math.sqrt(math.pi) * Gamma(1.4) / Gamma(0.9)
    rows = []
    for h in H:
        t0 = time.perf_counter()
        c = collide(n=2.5, dt=h)
        rows.append((h, [c.t_separation - tc, c.v1, c.v2 - 1.0], time.perf_counter() - t0))
    orders = [order(H, [r[1][j] for r in rows]) for j in range(3)]
    table(f"two frictionless Hertz spheres, n = 5/2: contact time against t_c = {tc:.15f}, "
          "velocities against the exchange (v1 = 0, v2 = 1)",
          ["error t_c", "v1", "v2 - 1"], rows, orders)

    print("\n### energy ledger of a 20-granule Hertz chain (masses 1, 1.1, 1.2 repeating), "
          "t_end = 20\n")
    print("| h | Coulomb eta = 0.02 | viscous gamma = 0.05 | both (eta alternating 0/0.03, "
          "static 0.04, gamma 0.02) |")
    print("|---|---|---|---|")
    frictions = [{"kinetic": 0.02}, {"viscous": 0.05},
                 {"kinetic": [0.0, 0.03] * 10, "static": 0.04, "viscous": 0.02}]
    hs = [2e-2, 1e-2, 5e-3, 2.5e-3, 1.25e-3]
    table_rows = {h: [] for h in hs}
    for fr in frictions:
        for h in hs:
            r = gc.simulate(_chain(fr, h))
            table_rows[h].append(r.energy.balance_error)
    for h in hs:
        print(f"| {h:g} | " + " | ".join(f"{e:.3e}" for e in table_rows[h]) + " |")
    print("| fitted order | " + " | ".join(
        f"{order(hs, [table_rows[h][j] for h in hs]):.2f}" for j in range(3)) + " |")

    r = gc.simulate(_chain({}, 1e-2, t_end=30.0))
    m = np.array([1.0 + 0.1 * (i % 3) for i in range(20)])
    p = r.v @ m
    print(f"\nFrictionless chain, h = 0.01, t = 30 ({r.steps} steps): max |p(t) - p(0)| = "
          f"{np.max(np.abs(p - p[0])):.2e} (p(0) = {p[0]}); energy balance error "
          f"{r.energy.balance_error:.2e}")


def _chain(friction, dt, t_end=20.0):
    return gc.scene_from_dict({
        "name": "chain",
        "granules": {"count": 20, "mass": [1.0 + 0.1 * (i % 3) for i in range(20)],
                     "radius": 0.5, "velocity": {0: 1.0}, "friction": friction},
        "contacts": {"exponent": 2.5},
        "run": {"dt": dt, "t_end": t_end},
        "output": {"every": 50},
    })


if __name__ == "__main__":
    main()
