"""Event stepper against closed forms, with bounds justified by the method.

n = 2 modes are propagated exactly (Taylor series of the matrix exponential
truncated below 1e-17, time carried as a double-double), so the paper's closed
forms must hold to a few hundred ulps: the bound 1e-13 leaves a factor ~50 over
the worst error measured on these sweeps (docs/events.md). Near-critical
damping is ill-conditioned (secular (a + b t) e^(-g t/2) growth of rounding),
so gamma stops at 2.8, where the measured error is below 1e-14.
"""

import math

import numpy as np
import pytest
from scipy.special import gamma as Gamma

from granular_chain import scene_from_dict
from granular_chain.result import Status
from granular_chain.simulate import simulate
from granular_chain.two_granules import collide

from conftest import paper_sec2a


@pytest.mark.parametrize("eta", np.linspace(0.02, 0.6, 12))
def test_sec2a_kinetic_friction_on_second_granule_exact(eta):
    v1, v2, ratio = paper_sec2a(eta)
    t_sep = math.asin(eta) + math.pi / math.sqrt(2)  # stuck until F = eta, then pi/sqrt2
    c = collide(2, (0.0, eta), stepper="event")
    assert c.outcome.name == "backscatter_and_propagation"
    assert c.result.stepper == "event" and c.result.dt is None
    for got, want in ((c.v1, v1), (c.v2, v2), (c.energy_ratio, ratio), (c.t_separation, t_sep)):
        assert abs(got / want - 1) <= 1e-13
    assert c.result.event_counts == {"contact_close": 1, "contact_open": 1, "stop": 0, "slip": 1}
    slip = [e for e in c.result.events if e.kind == "slip"][0]
    assert abs(slip.t - math.asin(eta)) <= 1e-15 and slip.index == 1


@pytest.mark.parametrize("g", np.linspace(0.05, 2.8, 12))
def test_sec3_equal_viscous_friction_exact(g):
    w = math.sqrt(8 - g * g) / 2
    t0 = math.pi / w
    v1 = (1 - math.exp(g * math.pi / (2 * w))) * math.exp(-g * math.pi / w) / 2
    v2 = (1 + math.exp(g * math.pi / (2 * w))) * math.exp(-g * math.pi / w) / 2
    c = collide(2, gamma=(g, g), stepper="event")
    assert c.result.status == Status.SEPARATED
    # The reference itself is evaluated in double: its own error is about
    # (g pi / w) * eps * 8 / (8 - g^2) < 2e-14 here.
    for got, want in ((c.v1, v1), (c.v2, v2), (c.t_separation, t0)):
        assert abs(got / want - 1) <= 1e-13
    # Energy ledger closes to roundoff (viscous work integrated from the series).
    assert c.result.energy.balance_error <= 1e-14


def test_frictionless_linear_exchange_exact():
    c = collide(2, stepper="event")
    assert abs(c.t_separation - math.pi / math.sqrt(2)) <= 4e-16 * math.pi
    assert abs(c.v2 - 1.0) <= 2e-16 and abs(c.v1) <= 2e-16


def test_hertz_contact_time_falls_with_tolerance():
    dmax = (5.0 / 8.0) ** 0.4
    tc = 2 * dmax * math.sqrt(math.pi) * Gamma(1.4) / Gamma(0.9)
    errs = []
    for rtol in (1e-6, 1e-8, 1e-10, 1e-12, 1e-13):
        c = collide(2.5, stepper="event", rtol=rtol, atol=rtol * 1e-2)
        errs.append(abs(c.t_separation / tc - 1))
        # The error is controlled by the tolerance (measured ratio err/rtol < 0.1).
        assert errs[-1] <= 0.1 * rtol + 4e-16
        assert abs(c.v2 - 1) <= rtol
    assert errs[-1] <= 1e-11
    assert errs[0] > errs[2] > errs[3]


def test_stuck_outcome_is_reached_at_rest():
    c = collide(2, (0.9, 0.9), stepper="event")
    assert c.outcome.name == "stuck" and c.result.status == Status.AT_REST
    assert c.v1 == 0.0 and c.v2 == 0.0
    assert c.result.t_final < 1.0
    # Compressed at rest: the held force is within both static thresholds.
    assert c.result.energy.potential[-1] > 0
    assert abs(c.result.f[-1][0]) <= 0.9


@pytest.mark.parametrize("g", [math.sqrt(8.0), 3.0, 10.0])
def test_overdamped_no_separation_jumps_to_t_end(g):
    c = collide(2, gamma=(g, g), stepper="event", t_max=1000.0)
    assert c.outcome.name == "no_separation" and c.result.status == Status.T_END
    assert c.result.t_final == 1000.0
    assert "never opens" in c.result.message
    assert c.result.steps == 0


def test_max_events_status():
    d = _chain(6, 2.0, eta=0.05)
    d["run"]["max_events"] = 3
    r = simulate(scene_from_dict(d))
    assert r.status == Status.MAX_EVENTS and "run.max_events" in r.message
    assert len(r.events) >= 3


def _chain(N, n, eta=0.0, gamma=0.0, t_end=20.0):
    return {"granules": {"count": N, "velocity": [1.0] + [0.0] * (N - 1),
                         "friction": {"kinetic": eta, "viscous": gamma}},
            "contacts": {"exponent": n},
            "run": {"stepper": "event", "t_end": t_end},
            "output": {"trajectory": False}}


def test_chain_agrees_with_verlet_at_order_two():
    # n = 2: Verlet's error against the exact event answer falls by 4 per
    # halving of dt (measured 4.5e-7, 1.1e-7, 3.0e-8 at dt = 2e-3, 1e-3, 5e-4).
    # n = 5/2 chains with friction agree only to ~3e-7 (an open issue, see
    # docs/events.md), so they are not asserted here.
    d = _chain(8, 2.0, eta=0.02, t_end=6.0)
    ev = simulate(scene_from_dict(d))
    assert ev.status == Status.T_END
    errs = []
    H = [2e-3, 1e-3, 5e-4]
    for h in H:
        dv = dict(d, run={"stepper": "verlet", "t_end": 6.0, "dt": h})
        r = simulate(scene_from_dict(dv))
        errs.append(float(np.max(np.abs(r.v_final - ev.v_final))))
    assert errs[1] < errs[0] / 3.5 and errs[2] < errs[1] / 3.5
    assert all(e <= 0.15 * h * h for e, h in zip(errs, H))


@pytest.mark.parametrize("n, bound", [
    (2.0, 1e-13),  # exact modes: roundoff
    pytest.param(2.5, 1e-10, marks=pytest.mark.xfail(
        reason="open issue: n != 2 chains with friction close only to ~3e-9 "
               "(docs/events.md, 'Known gaps')", strict=False)),
])
def test_chain_energy_ledger_closes(n, bound):
    d = _chain(12, n, eta=0.02, gamma=0.05)
    r = simulate(scene_from_dict(d))
    assert r.energy.balance_error <= bound
    kinds = {e.kind for e in r.events}
    assert kinds <= {"contact_close", "contact_open", "stop", "slip"}
    assert sum(r.event_counts.values()) == len(r.events)
    assert all(b.t >= a.t for a, b in zip(r.events, r.events[1:]))
