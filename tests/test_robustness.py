"""Hard cases: a correct result or a clear error, never a silent NaN or an endless loop.

Each case states the outcome it must reach; docs/robustness.md tabulates them.
"""

import math

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.simulate import SimulationError
from granular_chain.two_granules import collide


def scene(**parts):
    base = {"name": "hard", "granules": {"count": 2, "velocity": [1.0, 0.0]}}
    base.update(parts)
    return gc.scene_from_dict(base)


@pytest.mark.parametrize("ratio", [1e-6, 1e6])
def test_mass_ratio_between_neighbours(ratio):
    # Linear contact: the collision is exactly elastic, outcome by momentum and
    # energy: v1' = (m1-m2)/(m1+m2), v2' = 2 m1/(m1+m2). The default dt follows
    # the reduced mass. The largest overlap is v sqrt(mu/k) ~ 1: radius 1 keeps
    # it at half the sum of the radii (with radius 0.5 it would just reach it).
    s = scene(granules={"count": 2, "mass": [1.0, ratio], "velocity": [1.0, 0.0], "radius": 1.0},
              run={"stop": "separation", "t_end": 1e4})
    r = gc.simulate(s)
    assert r.status == gc.Status.SEPARATED
    m1, m2 = 1.0, ratio
    np.testing.assert_allclose(r.v_final, [(m1 - m2) / (m1 + m2), 2 * m1 / (m1 + m2)],
                               rtol=1e-3, atol=1e-9)
    assert r.energy.balance_error < 1e-3


def test_stiffness_ratio_between_contacts():
    s = scene(granules={"count": 3, "velocity": {0: 1.0}},
              contacts={"stiffness": [1.0, 1e6]}, run={"t_end": 20.0})
    r = gc.simulate(s)
    assert r.success and r.dt <= 2 * math.pi * math.sqrt(0.5 / 1e6) / 100
    assert r.energy.balance_error < 1e-4


@pytest.mark.parametrize("eta,outcome", [
    (0.0, "propagation_only"), (1e-12, "propagation_only"), (1e-3, "backscatter_and_propagation"),
    (1e6, "stuck")])
def test_friction_zero_tiny_huge(eta, outcome):
    # Verlet resolves velocities to ~dt^2 = 1e-6 here: a backscatter of ~1e-12
    # is below that and is named propagation_only (the event stepper, exact,
    # names it backscatter_and_propagation: tests/test_events.py).
    c = collide(2, (eta, eta), dt=1e-3)
    assert c.outcome.name == outcome
    if eta == 1e6:
        assert c.t_separation == math.inf and c.v1 == 0.0 and c.v2 == 0.0


def test_huge_viscous_damping_is_stable_and_accurate():
    # gamma dt = 10 >> 2: explicit damping would explode. The exponential
    # Verlet is exact for the drag, so even the velocity, which relaxes within
    # one step, is right: the event stepper (exact) gives -9.980020587e-9 at
    # t = 10 (scipy Radau at rtol 1e-12 agrees); Verlet at dt = 1e-3 is off by
    # 1.6e-7 relative (second order in dt).
    c = collide(2, gamma=(1e4, 1e4), dt=1e-3, t_max=10.0)
    assert c.outcome.name == "no_separation"
    exact = collide(2, gamma=(1e4, 1e4), stepper="event", t_max=10.0)
    assert exact.v1 == pytest.approx(-9.980020587e-9, rel=1e-9)
    assert abs(c.v1 / exact.v1 - 1) < 1e-6
    assert c.result.energy.balance_error < 1e-12


@pytest.mark.parametrize("g", [math.sqrt(8.0), 3.0, 10.0])
def test_overdamped_collision_never_separates_and_ends(g):
    c = collide(2, gamma=(g, g), dt=1e-2, t_max=200.0)
    assert c.outcome.name == "no_separation" and c.t_separation == math.inf
    assert c.result.t_final == pytest.approx(200.0)


def test_dt_too_large_is_refused_with_the_limit():
    with pytest.raises(SimulationError, match=r"run.dt: 2 is too large .* unstable above 1.414"):
        gc.simulate(scene(run={"dt": 2.0}))


def test_unchecked_large_dt_stops_with_a_status_not_nan():
    r = gc.simulate(scene(granules={"count": 5, "velocity": {0: 1.0}},
                          run={"dt": 3.0, "t_end": 1000.0, "check_dt": False}))
    assert r.status in (gc.Status.UNSTABLE, gc.Status.NONFINITE, gc.Status.OVERLAP)
    assert not r.success
    assert "reduce run.dt" in r.message
    assert np.all(np.isfinite(r.x_final)) and np.all(np.isfinite(r.v))


def test_precompressed_chain_with_large_overlaps():
    # Overlaps of 0.4 radii: the default dt uses the local stiffness of the
    # precompressed contacts; energy balances, granules stay ordered.
    s = scene(granules={"count": 10, "gap": -0.2, "velocity": {0: 0.1}},
              contacts={"exponent": 2.5}, walls={"left": {"gap": -0.2, "exponent": 2.5},
                                                 "right": {"gap": -0.2, "exponent": 2.5}},
              run={"t_end": 50.0})
    r = gc.simulate(s)
    assert r.success and r.energy.balance_error < 1e-5
    assert np.all(np.diff(r.x, axis=1) > 0)


@pytest.mark.parametrize("v0", [1e-8, 1e3])
def test_extreme_impact_speeds(v0):
    # Hertz: the contact time scales as v^(-1/5); velocities are exchanged.
    # The largest overlap is (5/8 v0^2)^(2/5) = 208 at v0 = 1e3 (k = 1, m = 1):
    # granules of radius 500 keep it physical (radius 0.5: see the next test).
    s = scene(granules={"count": 2, "velocity": [v0, 0.0], "radius": 500.0 if v0 > 1 else 0.5},
              contacts={"exponent": 2.5}, run={"stop": "separation", "t_end": 1e6})
    r = gc.simulate(s)
    assert r.status == gc.Status.SEPARATED
    # default dt = 1/200 of the collision time: velocity errors ~ 6e-8 (O(dt^2))
    np.testing.assert_allclose(r.v_final / v0, [0.0, 1.0], atol=2e-7)
    from scipy.special import gamma as G
    tc1 = 2 * (5 / 8) ** 0.4 * math.sqrt(math.pi) * G(1.4) / G(0.9)
    assert r.t_final == pytest.approx(tc1 * v0 ** -0.2, rel=1e-4)


@pytest.mark.parametrize("stepper", ["verlet", "event"])
def test_impact_too_fast_for_the_radius_is_refused(stepper):
    # v0 = 1e3 on radius-0.5 granules: the overlap would reach 208, far past
    # the sum of the radii. Verlet checks every step in its kernel (a frame
    # check alone would miss it: the granules come out again within 200 steps).
    s = scene(granules={"count": 2, "velocity": [1e3, 0.0]}, contacts={"exponent": 2.5},
              run={"stop": "separation", "t_end": 1e6, "stepper": stepper})
    r = gc.simulate(s)
    assert r.status == gc.Status.OVERLAP and "raise contacts.stiffness" in r.message
    if stepper == "event":
        # located exactly: the overlap first equals 1 at t ~ 1/v0 (delta ~ v0 t early on)
        assert r.t_final == pytest.approx(1e-3, rel=1e-2)
    else:
        # Verlet stops at the end of the first step that reaches it (default dt
        # ~ 4e-3 here, so the first); its result ends at the last good frame.
        assert "contact 0 overlaps by" in r.message and r.t_final == 0.0


def test_long_run_has_no_energy_drift():
    # 1e8 steps (about 6e4 closings of each contact) of two granules rattling
    # between walls (about 3.5 s). Each contact opening or closing adds a small
    # non-cancelling energy error (the Hertz force is not smooth there), so the
    # error grows about linearly with the number of contact events: 1.7e-6
    # after 1e6 steps, 6.7e-6 after 1e7, 5.2e-5 after 1e8 (measured, relative
    # to E0; the largest in the last tenth is 11x the largest in the first).
    # No blow-up.
    s = scene(granules={"count": 2, "velocity": [1.0, -0.5], "gap": 0.3},
              contacts={"exponent": 2.5, "stiffness": 100.0},
              walls={"left": {"gap": 0.2, "exponent": 2.5, "stiffness": 100.0},
                     "right": {"gap": 0.2, "exponent": 2.5, "stiffness": 100.0}},
              run={"dt": 1e-3, "t_end": 1e5}, output={"every": 1_000_000})
    r = gc.simulate(s)
    assert r.steps == 100_000_000 and r.success
    assert r.energy.balance_error < 5e-4
    b = np.abs(r.energy.balance)
    assert b[-10:].max() < 20 * b[1:11].max()


def test_single_granule_and_a_million_granules():
    r = gc.simulate(gc.scene_from_dict({"granules": {"count": 1, "velocity": 2.0},
                                        "run": {"t_end": 1.0, "dt": 0.1}}))
    assert r.x_final[0] == pytest.approx(0.5 + 2.0) and r.v_final[0] == 2.0
    big = gc.scene_from_dict({"granules": {"count": 1_000_000, "velocity": {0: 1.0}},
                              "contacts": {"exponent": 2.5},
                              "run": {"dt": 1e-2, "t_end": 0.5}})
    r = gc.simulate(big)
    assert r.steps == 50 and r.success and np.isfinite(r.energy.balance_error)


def test_soft_contact_pushed_through_is_refused_not_crossed():
    # Found by the property tests: a linear contact of k = 1 hit at relative
    # speed 2 by masses 2 would need an overlap of 2, more than both radii.
    s = scene(granules={"count": 2, "mass": 2.0, "radius": [0.5, 0.375], "velocity": [2.0, 0.0]},
              run={"t_end": 8.0})
    r = gc.simulate(s)
    assert r.status == gc.Status.OVERLAP and not r.success
    assert "contact 0 overlaps by" in r.message and "sum of the radii 0.875" in r.message
    assert "raise contacts.stiffness" in r.message
    assert np.all(np.diff(r.x, axis=1) > 0)


@pytest.mark.parametrize("law", [2.0, 2.5])
@pytest.mark.parametrize("friction", [None, {"viscous": [0.1, 0.0]}, {"kinetic": [0.1, 0.1]}])
def test_event_stepper_stops_where_the_centres_meet(law, friction):
    # The same soft collision with the event stepper: reaching r_0 + r_1 is an
    # event located like the others (the closed-form two-granule path can
    # otherwise span the whole contact in one step and never look at it).
    g = {"count": 2, "mass": 2.0, "radius": [0.5, 0.375], "velocity": [2.0, 0.0]}
    if friction:
        g["friction"] = friction
    s = scene(granules=g, contacts={"exponent": law},
              run={"t_end": 8.0, "stepper": "event"}, output={"every": 10**9})
    r = gc.simulate(s)
    assert r.status == gc.Status.OVERLAP and not r.success
    assert "contact 0 reached an overlap equal to the sum of the radii" in r.message
    assert "raise contacts.stiffness" in r.message
    overlap = 0.875 - (r.x_final[1] - r.x_final[0])
    assert overlap == pytest.approx(0.875, abs=1e-12)
    if law == 2.0 and friction is None:
        # relative motion delta = 2 sin t (reduced mass 1, k = 1): delta = 0.875 at asin(0.4375)
        assert r.t_final == pytest.approx(math.asin(0.4375), rel=1e-14)


def test_event_stepper_overlap_in_a_chain_and_at_a_wall():
    chain = scene(granules={"count": 5, "mass": 2.0, "velocity": {0: 2.0}},
                  contacts={"exponent": 2.5}, run={"t_end": 8.0, "stepper": "event"})
    r = gc.simulate(chain)
    assert r.status == gc.Status.OVERLAP and "contact 0 reached" in r.message
    wall = scene(granules={"count": 1, "mass": 2.0, "velocity": 3.0},
                 walls={"right": {"gap": 0.0}}, run={"t_end": 8.0, "stepper": "event"})
    r = gc.simulate(wall)
    assert r.status == gc.Status.OVERLAP and "right wall" in r.message
    stiff = scene(granules={"count": 5, "velocity": {0: 1.0}}, contacts={"exponent": 2.5},
                  run={"t_end": 20.0, "stepper": "event"})
    assert gc.simulate(stiff).status == gc.Status.T_END  # no false alarm


def _struck_chain(v, stepper, every=1):
    run = {"stepper": stepper, "t_end": 5.0}
    if stepper == "verlet":
        run["dt"] = 0.01
    return gc.scene_from_dict({
        "name": "struck", "granules": {"count": 8, "mass": 1.0, "radius": 0.5, "gap": 0.0,
                                       "velocity": {0: v}},
        "contacts": {"exponent": 2.5, "stiffness": 1.0}, "run": run,
        "output": {"every": every, "trajectory": False}})


@pytest.mark.parametrize("stepper", ["verlet", "event"])
def test_next_neighbour_overlap_is_warned(stepper):
    """The benchmark chain struck at v = 1 (k = 1, radius 0.5) compresses contacts 0 and 1
    by more than granule 1's diameter: spheres 0 and 2 overlap (LAMMPS counts that
    contact, benchmarks/results/lammps.md: 0 and 2 overlap from step 118 at dt = 0.01).
    The run succeeds with a warning naming the pair and the first frame; at v = 0.01 no
    warning."""
    r = gc.simulate(_struck_chain(1.0, stepper), progress=False)
    assert r.success
    (w,) = r.info["warnings"]
    assert w.startswith("granules 0 and 2 overlap at t = ")
    # the first frame where x2 - x0 < r0 + r2, recomputed here
    q = int(np.flatnonzero(r.x[:, 2] - r.x[:, 0] < 1.0)[0])
    assert f"t = {r.t[q]:.6g} " in w
    if stepper == "verlet":
        assert abs(r.t[q] - 1.18) < 0.015  # step 118 in LAMMPS
    r = gc.simulate(_struck_chain(0.01, stepper), progress=False)
    assert "warnings" not in r.info


def test_neighbour_overlap_check_counts_as_numpy_does():
    """The compiled check behind the warning finds the same first pair and count as
    x[i+2] - x[i] < r_i + r_(i+2) in numpy, NaN counting as no overlap."""
    from granular_chain.simulate import _neighbour_overlaps

    rng = np.random.default_rng(3)
    for n in (3, 4, 50, 1001):
        radius = rng.uniform(0.2, 0.6, n)
        reach = radius[:-2] + radius[2:]
        for spread in (0.3, 1.0, 3.0):
            x = np.cumsum(rng.uniform(0.0, spread, n))
            x[rng.integers(n)] = np.nan
            bad = np.flatnonzero(x[2:] - x[:-2] < reach)
            expected = (int(bad[0]), bad.size) if bad.size else (-1, 0)
            assert _neighbour_overlaps(x, reach) == expected
