"""Accuracy of the event stepper with dashpots, body forces and driven walls (docs/events.md).

    python benchmarks/event_dissipation.py

Prints the errors the tests in tests/test_events_dissipation.py bound, with all
digits: two-grain restitution against restitution.linear_dashpot (n = 2) and
restitution_reference (viscoelastic Hertz), the small-speed slope against
viscoelastic_series, the column against column_overlaps, driven walls against
DOP853, and the ledger errors with the stepper's promise. About 1.5 minutes cold
(two kernel compiles), 10 s warm.
"""
import sys, math
sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1] / "tests"))
import numpy as np
import test_events_dissipation as T
from granular_chain import restitution as R
from granular_chain.two_granules import collide
from granular_chain.simulate import simulate
for tens in (False, True):
    for b in (0.3, 1.0, 3.0):
        c = b * T.C_CRIT
        ref = R.linear_dashpot(c, 1.0, T.M_EFF, tens)
        col = collide(2, stepper="event", damping={"model": "linear", "coefficient": c}, tensile=tens)
        dt = (col.t_separation / ref.contact_time - 1) if ref.ended and ref.contact_time < 100 else float("nan")
        print(f"linear tensile={tens} b={b}: e={T._e(col):.17g} ref={ref.e:.17g} err={T._e(col)-ref.e:.2g} t_c relerr={dt:.2g} ledger={col.result.energy.balance_error:.2g}")
    col = collide(2, stepper="event", damping={"model": "restitution", "value": 0.8}, tensile=tens)
    print(f"restitution 0.8 tensile={tens}: err={T._e(col)-0.8:.2g}")
for tens in (False, True):
    for v, A in ((1.0, 0.1), (1.0, 0.5), (1e-3, 0.1)):
        e, r = T._hertz_pair(v, A, tens)
        ref = float(R.restitution_reference(v, 1.0, T.M_EFF, 2.5, "viscoelastic", A, tens, dps=25).e)
        print(f"visco tensile={tens} v={v} A={A}: err={e-ref:.2g} ledger={r.energy.balance_error:.2g} tol={r.info['event_stepper']['ledger_tolerance']:.2g}")
A = 0.01
for v in (1e-6, 1e-8):
    e, _ = T._hertz_pair(v, A, False)
    G = float(R.viscoelastic_group(v, 1.0, A, T.M_EFF))
    print(f"small v={v} G={G:.3g}: e - series2 = {e - float(R.viscoelastic_series(v, 1.0, A, T.M_EFF, terms=2)):.2g}, G^2.5={G**2.5:.2g}, (1-e)/G={(1-e)/G:.8f}")
print("C1", float(R.viscoelastic_c1_exact()))
for n, te in ((2.0, 300.0), (2.5, 3000.0)):
    r = simulate(T._column(n, te), progress=False)
    u = r.x_final - r.x[0]
    ov = np.concatenate([[-u[0]], u[:-1] - u[1:]])[::-1]
    ref = R.column_overlaps(10, 1.0, 0.01, 1.0, n)
    print(f"column n={n}: max rel err {np.max(np.abs(ov/ref-1)):.2g} ledger {r.energy.balance_error:.2g}")
for n, damp in ((2.0, {"model": "restitution", "value": 0.8}), (2.5, {"model": "linear", "coefficient": 0.2})):
    for kind in sorted(T.MOTIONS):
        sc = T._driven(n, T.MOTIONS[kind], damp)
        r = simulate(sc, progress=False)
        x, v = T._reference_end(sc, 40.0)
        print(f"driven n={n} {kind}: |x-ref|={np.max(np.abs(r.x_final-x)):.2g} |v-ref|={np.max(np.abs(r.v_final-v)):.2g} ledger={r.energy.balance_error:.2g} tol={r.info['event_stepper']['ledger_tolerance']:.2g}")
sc = T._driven(2.5, T.MOTIONS["sine"], {"model": "viscoelastic", "coefficient": 0.2})
r = simulate(sc, progress=False)
print(f"driven visco sine: ledger={r.energy.balance_error:.2g} tol={r.info['event_stepper']['ledger_tolerance']:.2g}")
