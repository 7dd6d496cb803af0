"""Accuracy of the Verlet stepper with dashpots, body forces and driven walls, and its speed.

Prints, for the scenes of tests/test_verlet_dissipation.py run at more steps:

* the two-grain restitution error of a linear dashpot (n = 2) against
  restitution.linear_dashpot at M steps per contact time, and the fitted order;
* the viscoelastic Hertz error against restitution.restitution_reference;
* the largest relative energy-ledger error per new ledger term, and its order;
* the N = 10 column's largest relative overlap error against column_overlaps;
* steps/s of a chain of 10^4 granules, elastic kernel against the forced one.

Run: ``PYTHONPATH=. python benchmarks/verlet_dissipation.py``
"""

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import granular_chain as gc  # noqa: E402
import test_verlet_dissipation as T  # noqa: E402
from conftest import fitted_order  # noqa: E402
from granular_chain.restitution import linear_dashpot, restitution_reference  # noqa: E402

STEPS = (50, 100, 200, 400)


def restitution():
    for tensile, b in ((True, 0.1), (False, 0.1), (True, 0.7), (False, 0.7), (False, 2.0)):
        ref = linear_dashpot(T.linear_c(b), 1.0, T.M_EFF, tensile)
        damping = {"damping": {"model": "linear", "coefficient": T.linear_c(b)},
                   "tensile": tensile}
        err = [T.collide(damping, 2 * ref.contact_time, ref.contact_time / M)[0] - ref.e
               for M in STEPS]
        print(f"linear dashpot tensile={tensile} b={b}: e={ref.e:.6f} errors "
              f"{' '.join(f'{e:.2e}' for e in err)} order {-fitted_order(STEPS, err):.2f}")
    for v in (1.0, 0.1, 0.01):
        ref = restitution_reference(v, 1.0, T.M_EFF, 2.5, "viscoelastic", 0.1, tensile=False,
                                    dps=30)
        tc = float(ref.contact_time)
        err = [T.collide({"damping": {"model": "viscoelastic", "coefficient": 0.1}}, 2 * tc,
                         tc / M, v=v, n=2.5)[0] - float(ref.e) for M in STEPS]
        print(f"viscoelastic Hertz A=0.1 v={v}: e={float(ref.e):.6f} errors "
              f"{' '.join(f'{e:.2e}' for e in err)} order {-fitted_order(STEPS, err):.2f}")


def ledgers():
    cases = {
        "contact_dissipated": ({"granules": {"count": 5, "velocity": {0: 1.0}, "gap": 0.0,
                                             "radius": 2.0},
                                "contacts": {"damping": {"model": "linear", "coefficient": 0.3}},
                                "walls": {"right": {"gap": 0.1}}, "run": {"t_end": 30.0}}, T.DTS),
        "body_work": ({"granules": {"count": 3, "velocity": 0.0, "gap": 0.3, "radius": 2.0},
                       "contacts": T.ELASTIC, "walls": {"left": {"gap": 0.2}},
                       "body_force": {"g": 0.2, "direction": -1}, "run": {"t_end": 15.0}}, T.DTS),
    }
    for name, motion in (("velocity", {"velocity": 0.05}),
                         ("sine", {"sine": {"amplitude": 0.2, "frequency": 0.1}}),
                         ("pulse", {"pulse": {"velocity": 0.4, "duration": 3.3}})):
        cases[f"wall_work ({name})"] = (
            {"granules": {"count": 4, "velocity": 0.0, "gap": 0.0, "radius": 2.0},
             "contacts": T.ELASTIC,
             "walls": {"left": {"gap": 0.0, "motion": motion}, "right": {"gap": 0.5}},
             "run": {"t_end": 20.0}}, T.DTS_WALL)
    for name, (spec, dts) in cases.items():
        spec["output"] = {"every": 10}
        err, _ = T.ledger(spec, dts)
        print(f"ledger {name}: dt {dts} errors {' '.join(f'{e:.2e}' for e in err)} "
              f"order {fitted_order(dts, err):.2f}")


def column():
    for n, damping in ((2.0, {"model": "linear", "coefficient": 5.0}),
                       (2.5, {"model": "viscoelastic", "coefficient": 2.0})):
        s = T.scene({"count": 10, "velocity": 0.0, "gap": 0.0}, 5000.0,
                    0.01 if n == 2.5 else None, contacts={"exponent": n, "damping": damping},
                    walls={"left": {"gap": 0.0, "exponent": n}},
                    body_force={"g": 0.01, "direction": -1})
        s.run.stop = "rest"
        r = gc.simulate(s, progress=False)
        m, u = r.model, r.x_final - r.model.x0
        delta = np.concatenate(([m.walls[0] - u[0]], m.d0 + u[:-1] - u[1:]))[::-1]
        err = np.max(np.abs(delta / T.column_overlaps(10, 1.0, 0.01, 1.0, n) - 1))
        print(f"column n={n}: {r.status.name} at t={r.t_final:g} after {r.steps} steps, "
              f"overlap error {err:.2e}")


def speed():
    base = {"count": 10_000, "velocity": {0: 1.0}, "radius": 2.0}
    for label, contacts in (("elastic (sweep kernel)", {}),
                            ("linear dashpot (forced kernel)",
                             {"damping": {"model": "linear", "coefficient": 0.01}})):
        s = T.scene(base, 200.0, 0.02, contacts=contacts)
        gc.simulate(T.scene(base, 0.1, 0.02, contacts=contacts), progress=False)  # compile
        start = time.perf_counter()
        r = gc.simulate(s, progress=False)
        rate = r.steps * 10_000 / (time.perf_counter() - start)
        print(f"N=10^4 {label}: {rate:.3g} granule-steps/s")


if __name__ == "__main__":
    restitution()
    ledgers()
    column()
    speed()
