"""Velocity-Verlet against closed forms: errors measured, orders fitted.

The bounds are the measured error constants of a second-order method
(error <= C h^2 with C read off the tables in docs/verlet_convergence.md,
times about 3): a first-order regression or a wrong formula fails them by
orders of magnitude.
"""

import math

import numpy as np
import pytest
from scipy.special import gamma as Gamma

import granular_chain as gc
from granular_chain.two_granules import collide

from conftest import fitted_order, paper_sec2a

H = [1e-2, 3e-3, 1e-3, 3e-4, 1e-4]


def test_sec2a_kinetic_friction_on_second_granule_converges_at_order_two():
    eta = 0.3
    v1c, v2c, ec = paper_sec2a(eta)
    e1, e2, ee = [], [], []
    for h in H:
        c = collide(2, (0.0, eta), dt=h)
        assert c.outcome.name == "backscatter_and_propagation"
        e1.append(c.v1 - v1c)
        e2.append(c.v2 - v2c)
        ee.append(c.energy_ratio - ec)
    assert fitted_order(H, e2) == pytest.approx(2.0, abs=0.3)
    assert fitted_order(H, ee) == pytest.approx(2.0, abs=0.3)
    for h, a, b, c in zip(H, e1, e2, ee):
        assert abs(a) <= 0.3 * h * h and abs(b) <= 0.5 * h * h and abs(c) <= 1.0 * h * h


def test_first_granule_friction_stop_and_reversal_keeps_order_two():
    # Reference: the same collision at h = 2e-7, whose error (C h^2 with
    # C < 0.25 from the table) is below 1e-14; checked against the exact
    # event stepper in tests/test_events.py.
    ref = collide(2, (0.1, 0.0), dt=2e-7)
    errs = []
    for h in H:
        c = collide(2, (0.1, 0.0), dt=h)
        assert c.result.event_counts["stop"] >= 1 and c.result.event_counts["slip"] >= 1
        errs.append(max(abs(c.v1 - ref.v1), abs(c.v2 - ref.v2)))
    assert fitted_order(H, errs) == pytest.approx(2.0, abs=0.35)
    assert all(e <= 0.2 * h * h for e, h in zip(errs, H))


def test_hertz_contact_time_and_velocity_exchange():
    # Two equal frictionless spheres, relative speed 1, reduced mass 1/2:
    # delta_max = (5/8)^(2/5), t_c = 2 delta_max integral_0^1 dx/sqrt(1-x^(5/2))
    # and the integral is sqrt(pi) Gamma(7/5)/Gamma(9/10).
    dmax = (5.0 / 8.0) ** 0.4
    tc = 2 * dmax * math.sqrt(math.pi) * Gamma(1.4) / Gamma(0.9)
    et, ev = [], []
    for h in H:
        c = collide(2.5, (0.0, 0.0), dt=h)
        assert c.outcome.name == "propagation_only"
        et.append(c.t_separation - tc)
        ev.append(max(abs(c.v1), abs(c.v2 - 1.0)))
    assert fitted_order(H, et) == pytest.approx(2.0, abs=0.2)
    assert all(abs(e) <= 0.5 * h * h for e, h in zip(et, H))
    assert all(e <= 0.01 * h * h for e, h in zip(ev, H))


def _chain_scene(friction=None, n=2.5, count=20, dt=1e-2, t_end=30.0):
    return gc.scene_from_dict({
        "name": "chain",
        "granules": {"count": count, "mass": [1.0 + 0.1 * (i % 3) for i in range(count)],
                     "radius": 0.5, "gap": 0.0, "velocity": [1.0] + [0.0] * (count - 1),
                     "friction": friction or {}},
        "contacts": {"exponent": n, "stiffness": 1.0},
        "run": {"dt": dt, "t_end": t_end},
        "output": {"every": 50},
    })


def test_frictionless_chain_conserves_momentum_to_roundoff():
    r = gc.simulate(_chain_scene())
    m = np.array([1.0 + 0.1 * (i % 3) for i in range(20)])
    p = r.v @ m
    # Each step adds contact forces in equal and opposite pairs: momentum
    # changes only by rounding, ~ eps per step and granule.
    assert np.max(np.abs(p - p[0])) <= 1e-13
    assert 0 < r.energy.balance_error <= 1e-4


@pytest.mark.parametrize("friction", [
    {"kinetic": 0.02},
    {"viscous": 0.05},
    {"kinetic": [0.0, 0.03] * 10, "static": 0.04, "viscous": 0.02},
])
def test_energy_ledger_closes_to_order_two(friction):
    errs = []
    hs = [2e-2, 1e-2, 5e-3, 2.5e-3]
    for h in hs:
        r = gc.simulate(_chain_scene(friction, dt=h, t_end=20.0))
        assert r.energy.coulomb[-1] + r.energy.viscous[-1] > 1e-3  # friction did work
        errs.append(r.energy.balance_error)
    order = fitted_order(hs, errs)
    assert order == pytest.approx(2.0, abs=0.3)
    assert errs[-1] <= 1e-5


def test_runs_are_deterministic():
    s = _chain_scene({"kinetic": 0.02, "viscous": 0.01})
    a, b = gc.simulate(s), gc.simulate(s)
    assert np.array_equal(a.x, b.x) and np.array_equal(a.v, b.v)


def test_stuck_granules_stay_exactly_at_rest():
    # Huge friction: nothing beyond the struck granule can move; it stops, sticks.
    r = gc.simulate(_chain_scene({"kinetic": 10.0}, t_end=5.0))
    assert np.all(r.v_final == 0.0)
    assert np.all(r.x[:, 2:] == r.x[0, 2:])
