"""The single-sweep Verlet kernel (scenes without Coulomb friction) against a plain
numpy velocity Verlet written from the formulas, on chains that exercise each of
its paths: per-granule parameters and the ``uniform`` specialisation, both walls,
drag (exponential Verlet), contact events, and N = 1.

The reference is a direct transcription of the scheme in
granular_chain/steppers/verlet/kernel.py (its docstring) (three whole-chain passes, no
blocking, no fused sweep, the Hertz force as delta ** 1.5); it agrees with the
kernel to roundoff, and a contact counts as closed when its overlap is positive.
"""

import importlib

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.laws.friction import drift_tables
from granular_chain.model import build_model
from granular_chain.simulate import _simulate_verlet


def _reference(model, dt, steps):
    """Final (x, v), (closings, openings) and steps taken of the plain numpy Verlet,
    which stops after the first step where two centres (or a centre and a wall) met."""
    feat = model.features
    N = model.count
    m, d0, k, n, w = model.mass, model.d0, model.k, model.n, model.walls
    c = model.gamma / m
    E, P1, P2 = np.empty(N), np.empty(N), np.empty(N)
    drift_tables(c, dt, E, P1, P2)

    def forces(u):
        F = np.zeros(N)
        delta = d0 + u[:-1] - u[1:]
        fc = k * np.maximum(delta, 0.0) ** (n - 1.0)
        F[:-1] -= fc
        F[1:] += fc
        if feat.left_wall:
            F[0] += w[1] * max(w[0] - u[0], 0.0) ** (w[2] - 1.0)
        if feat.right_wall:
            F[-1] -= w[4] * max(w[3] + u[-1], 0.0) ** (w[5] - 1.0)
        return F, delta > 0

    r = model.radius
    lim = r[:-1] + r[1:]

    def overlapped(u):
        delta = d0 + u[:-1] - u[1:]
        return (np.any(delta >= lim) or (feat.left_wall and w[0] - u[0] >= r[0])
                or (feat.right_wall and w[3] + u[-1] >= r[-1]))

    u = np.zeros(N)
    v = model.v0.copy()
    F, was = forces(u)
    closings = openings = 0
    for step in range(steps):
        a = F / m
        if feat.viscous:
            du = v * P1 + a * P2
            u += du
            v = v * E + a * (P1 - P2 / dt)
        else:
            v = v + 0.5 * dt * a
            u += dt * v
        F, now = forces(u)
        a = F / m
        v = v + (a * P2 / dt if feat.viscous else 0.5 * dt * a)
        closings += int(np.sum(now & ~was))
        openings += int(np.sum(was & ~now))
        was = now
        if overlapped(u):
            return model.x0 + u, v, (closings, openings), step + 1
    return model.x0 + u, v, (closings, openings), steps


def _chain(N, uniform, viscous, walls, seed=3, wall_stiffness=100.0, v=1.0):
    rng = np.random.default_rng(seed)
    granules = {"count": N, "mass": 1.0, "radius": 0.5, "gap": 0.0}
    contacts = {"exponent": 2.5, "stiffness": 1.0}
    if uniform:
        granules["velocity"] = {0: v}  # the struck chain
        if viscous:
            granules["friction"] = {"viscous": 0.05}
    else:
        granules["mass"] = rng.uniform(0.5, 2.0, N).tolist()
        granules["velocity"] = rng.uniform(-0.3, 0.3, N).tolist()
        if N > 1:
            granules["gap"] = rng.uniform(-0.01, 0.01, N - 1).tolist()
            contacts["stiffness"] = rng.uniform(0.5, 2.0, N - 1).tolist()
        if viscous:
            granules["friction"] = {"viscous": rng.uniform(0.0, 0.2, N).tolist()}
    scene = {"name": "sweep", "granules": granules, "contacts": contacts,
             "run": {"stepper": "verlet", "dt": 0.01, "t_end": 6.0},
             "output": {"every": 200, "trajectory": False}}
    if walls:
        scene["walls"] = {"left": {"gap": 0.005, "exponent": 2.5, "stiffness": wall_stiffness},
                          "right": {"gap": 0.005, "exponent": 2.5, "stiffness": wall_stiffness}}
    return gc.scene_from_dict(scene)


@pytest.mark.parametrize("viscous", [False, True], ids=["frictionless", "viscous"])
@pytest.mark.parametrize("uniform,walls,N", [(True, False, 300), (False, True, 300),
                                             (False, True, 1), (True, True, 2)],
                         ids=["uniform", "per-granule+walls", "N=1 walls", "N=2 uniform walls"])
def test_sweep_matches_plain_verlet(uniform, walls, N, viscous):
    # v = 0.2 between walls: slow enough that no overlap reaches the radii
    scene = _chain(N, uniform, viscous, walls, v=0.2 if walls else 1.0)
    model = build_model(scene)
    r = _simulate_verlet(scene, model, False)
    x, v, (closings, openings), steps = _reference(model, 0.01, 600)
    assert (r.status, r.steps) == (gc.Status.T_END, 600) and steps == 600
    assert np.max(np.abs(r.x_final - x)) < 1e-11
    assert np.max(np.abs(r.v_final - v)) < 1e-11
    assert (r.event_counts["contact_close"], r.event_counts["contact_open"]) == (closings, openings)
    if N > 2:
        assert closings > 0 and (uniform or openings > 0)  # the events path was exercised


@pytest.mark.parametrize("viscous", [False, True], ids=["frictionless", "viscous"])
def test_sweep_stops_when_a_granule_goes_through_a_soft_wall(viscous):
    # The struck granule of two hits a wall of k = 1 at v = 1: the overlap reaches
    # its radius (0.5) before the wall turns it back; the every-step check stops
    # the run at that step.
    scene = _chain(2, True, viscous, True, wall_stiffness=1.0)
    model = build_model(scene)
    r = _simulate_verlet(scene, model, False)
    x, v, _, steps = _reference(model, 0.01, 600)
    assert r.status == gc.Status.OVERLAP and "right wall" in r.message
    assert r.steps == steps < 600


def test_uniform_code_is_set_only_where_the_sweep_can_use_it():
    from granular_chain.simulate import _drift_coefficients, _uniform_code
    from granular_chain.steppers.verlet import PER_GRANULE, UNIFORM, UNIT

    def code(scene):
        model = build_model(scene)
        E, P1, P2 = _drift_coefficients(model, 0.01)
        return _uniform_code(model, model.features, E, P1, P2)

    # _chain's uniform chains are the scaled touching chain: m = k = 1, d0 = 0
    for uniform, viscous, expected in ((True, False, UNIT), (True, True, UNIT),
                                       (False, False, PER_GRANULE), (False, True, PER_GRANULE)):
        assert code(_chain(50, uniform, viscous, False)) == expected
    base = {"count": 5, "velocity": {0: 1.0}}
    assert code(gc.scene_from_dict({"granules": base})) == UNIT
    # one value of each parameter, but not the unit ones: scalars read at run time
    for granules, contacts in (({"mass": 2.0}, {}), ({"gap": -0.01}, {}),
                               ({}, {"stiffness": 3.0})):
        scene = gc.scene_from_dict({"granules": {**base, **granules}, "contacts": contacts})
        assert code(scene) == UNIFORM
    coulomb = gc.scene_from_dict({"granules": {**base, "friction": {"kinetic": 0.01}}})
    assert code(coulomb) == PER_GRANULE  # the blocked passes ignore it


@pytest.mark.parametrize("viscous,walls", [(False, False), (True, True)],
                         ids=["frictionless", "viscous+walls"])
def test_unit_constants_are_bit_identical_to_uniform_scalars(monkeypatch, viscous, walls):
    # UNIT compiles m = k = 1, d0 = 0 in; x * 1 and x + 0 are exact, so the run
    # must equal the UNIFORM kernel (the same values read as scalars) bit for bit.
    sim = importlib.import_module("granular_chain.steppers.verlet.driver")  # the Verlet driver
    from granular_chain.steppers.verlet import UNIFORM, UNIT

    scene = _chain(300, True, viscous, walls, v=0.2 if walls else 1.0)
    model = build_model(scene)
    unit = _simulate_verlet(scene, model, False)
    original = sim._uniform_code
    seen = []

    def as_uniform(*args):
        seen.append(original(*args))
        return UNIFORM

    monkeypatch.setattr(sim, "_uniform_code", as_uniform)
    scalars = _simulate_verlet(scene, model, False)
    assert seen == [UNIT]
    assert unit.steps == scalars.steps == 600 and unit.event_counts == scalars.event_counts
    assert unit.event_counts["contact_close"] > 0
    for name in ("x", "v", "f"):
        assert np.array_equal(getattr(unit, name), getattr(scalars, name)), name
    # the viscous work sums 1.8e5 terms 0.5 m v^2 in a reassociated, fused
    # reduction: with m = 1 folded in, the compiler fuses differently, so the sum
    # rounds differently (measured 3.8e-15 of the total; the states are equal)
    assert np.max(np.abs(unit.energy.viscous - scalars.energy.viscous)) <= (
        1e-13 * np.max(np.abs(scalars.energy.viscous)))
