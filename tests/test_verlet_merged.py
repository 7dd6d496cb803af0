"""Merged kicks: Coulomb scenes step the leapfrog form (one kick of dt per step
instead of two of dt/2; granular_chain/steppers/verlet/kernel.py).

A kick is the exact flow of m dv/dt = F - eta sign(v) (with stick) under a frozen
force, so two half kicks and one whole kick are the same map up to roundoff. The
reference is a plain numpy velocity Verlet written from the scheme with two half
kicks per step (kick, exact drag drift, force, kick; the kick transcribed from
the law in granular_chain/laws/friction.py), so that the engine's merging, its
synchronisation of the frames, its rest detection read off the merged kick and
its separation backtrack are all checked against the unmerged scheme.
"""

import importlib

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.laws.friction import drift_tables
from granular_chain.model import build_model

sim = importlib.import_module("granular_chain.simulate")  # the package exports the function


def _chain(N, viscous, stop, every, seed=7, t_end=8.0, speed=0.05):
    rng = np.random.default_rng(seed)
    friction = {"kinetic": rng.uniform(0.0, 4e-3, N).tolist(),
                "static": rng.uniform(4e-3, 6e-3, N).tolist()}
    if viscous:
        friction["viscous"] = rng.uniform(0.0, 0.05, N).tolist()
    granules = {"count": N, "mass": rng.uniform(0.5, 2.0, N).tolist(), "radius": 0.5,
                "gap": rng.uniform(-0.01, 0.01, N - 1).tolist(),
                # random velocities: granules stick, slip and reverse
                "velocity": rng.uniform(-speed, speed, N).tolist(), "friction": friction}
    return gc.scene_from_dict({
        "name": "merged", "granules": granules,
        "contacts": {"exponent": 2.5, "stiffness": rng.uniform(0.5, 2.0, N - 1).tolist()},
        "walls": {"left": {"gap": 0.0, "exponent": 2.5, "stiffness": 1.0},
                  "right": {"gap": 0.0, "exponent": 2.5, "stiffness": 1.0}},
        "run": {"stepper": "verlet", "dt": 0.01, "t_end": t_end, "stop": stop},
        "output": {"every": every, "trajectory": False}})


def _half_kick(v, F, eta, eta_s, inv_m, h):
    """Exact Coulomb stick/slip kick of duration h under frozen F, vectorised:
    (v_new, work <= 0, stops, slips)."""
    s = np.sign(v)
    a = (F - eta * s) * inv_m
    v1 = v + a * h
    through = v1 * s > 0.0
    t_stop = np.minimum(np.abs(v) / np.maximum(np.abs(a), 1e-300), h)
    rem = h - t_stop
    slip = np.abs(F) > eta_s
    a2 = (F - eta * np.where(F > 0.0, 1.0, -1.0)) * inv_m
    d1 = np.where(through, (v + 0.5 * a * h) * h * s, 0.5 * np.abs(v) * t_stop)
    d2 = np.where(slip & ~through, 0.5 * np.abs(a2) * rem * rem, 0.0)
    v_new = np.where(through, v1, np.where(slip, a2 * rem, 0.0))
    stops = int(np.sum(~through & (s != 0.0)))
    slips = int(np.sum(slip & ~through))
    return v_new, -float(np.sum(eta * (d1 + d2))), stops, slips


class _Reference:
    """Two half kicks per step, numpy, whole chain at once."""

    def __init__(self, model, dt):
        self.model, self.dt = model, dt
        N = model.count
        self.E, self.P1, P2 = np.empty(N), np.empty(N), np.empty(N)
        drift_tables(model.gamma / model.mass, dt, self.E, self.P1, P2)
        self.u = np.zeros(N)
        self.v = model.v0.copy()
        self.F, self.closed = self.forces(self.u)
        self.coulomb = self.viscous = 0.0
        self.counts = dict(contact_close=0, contact_open=0, stop=0, slip=0)

    def forces(self, u):
        m = self.model
        F = np.zeros(m.count)
        delta = m.d0 + u[:-1] - u[1:]
        fc = m.k * np.maximum(delta, 0.0) ** (m.n - 1.0)
        F[:-1] -= fc
        F[1:] += fc
        w = m.walls
        if m.features.left_wall:
            F[0] += w[1] * max(w[0] - u[0], 0.0) ** (w[2] - 1.0)
        if m.features.right_wall:
            F[-1] -= w[4] * max(w[3] + u[-1], 0.0) ** (w[5] - 1.0)
        return F, delta > 0.0

    def kick(self):
        m = self.model
        self.v, w, stops, slips = _half_kick(self.v, self.F, m.eta, m.eta_static, m.inv_mass,
                                             0.5 * self.dt)
        self.coulomb -= w
        self.counts["stop"] += stops
        self.counts["slip"] += slips

    def step(self):
        m = self.model
        self.kick()
        self.u += self.v * self.P1
        self.viscous += float(np.sum(0.5 * m.mass * self.v ** 2 * (1.0 - self.E ** 2)))
        self.v = self.v * self.E
        self.F, now = self.forces(self.u)
        self.counts["contact_close"] += int(np.sum(now & ~self.closed))
        self.counts["contact_open"] += int(np.sum(self.closed & ~now))
        self.closed = now
        self.kick()


@pytest.mark.parametrize("viscous", [False, True], ids=["coulomb", "coulomb+viscous"])
def test_merged_kicks_equal_two_half_kicks(viscous):
    scene = _chain(60, viscous, "t_end", 100)
    merged = gc.simulate(scene, progress=False)
    ref = _Reference(build_model(scene), 0.01)
    for _ in range(800):
        ref.step()
    assert merged.status == gc.Status.T_END and merged.steps == 800
    # the run exercised what the merge has to get right
    assert merged.event_counts["stop"] > 50 and merged.event_counts["slip"] > 50
    assert merged.event_counts == ref.counts
    # same map up to roundoff (O(1e-16) per step, grown over 800 steps)
    assert np.max(np.abs(merged.x_final - (ref.model.x0 + ref.u))) < 1e-12
    assert np.max(np.abs(merged.v_final - ref.v)) < 1e-12
    assert abs(merged.energy.coulomb[-1] - ref.coulomb) < 1e-14
    assert abs(merged.energy.viscous[-1] - ref.viscous) < 1e-14
    # the synchronised frames close the ledger as the unmerged scheme does: the
    # O(dt^2) error of Verlet (about 2e-6 of the initial energy), not the
    # O(eta v dt) a missing half kick would leave
    e = merged.energy
    balance = abs(e.kinetic[-1] + e.potential[-1] + e.coulomb[-1] + e.viscous[-1] - e.initial)
    ke = 0.5 * float(np.sum(ref.model.mass * ref.v ** 2))
    pe = ref.model.energies(ref.u, ref.v)[1]
    ref_balance = abs(ke + pe + ref.coulomb + ref.viscous - e.initial)
    assert balance < 3e-6 * e.initial and e.coulomb[-1] > 0.3 * e.initial
    assert abs(balance - ref_balance) < 1e-12 * e.initial


def test_merged_trajectory_does_not_depend_on_the_output_cadence():
    every_step = gc.simulate(_chain(30, True, "t_end", 1, t_end=2.0), progress=False)
    rare = gc.simulate(_chain(30, True, "t_end", 37, t_end=2.0), progress=False)
    assert every_step.steps == rare.steps == 200
    # frames of the rare run are every 37th frame of the other, bit for bit
    idx = np.searchsorted(every_step.t, rare.t)
    assert np.array_equal(every_step.t[idx], rare.t)
    for name in ("x", "v", "f"):
        assert np.array_equal(getattr(every_step, name)[idx], getattr(rare, name)), name
    assert np.array_equal(every_step.energy.coulomb[idx], rare.energy.coulomb)
    assert every_step.event_counts == rare.event_counts


def _rest_reference(scene, max_steps):
    ref = _Reference(build_model(scene), 0.01)
    for step in range(1, max_steps + 1):
        ref.step()
        if not ref.v.any():
            return ref, step
    raise AssertionError("the reference chain did not come to rest")


def test_rest_stop_read_off_the_merged_kick():
    # A chain that comes to rest: the engine reads rest off the next step's merged
    # kick (mid-chunk) or off the synchronised velocities (at a chunk's end). Every
    # output cadence must stop at the reference's first all-at-rest step, with the
    # reference's state, counts and ledger.
    scene = _chain(40, False, "rest", 1, t_end=200.0, speed=0.02)
    ref, rest_step = _rest_reference(scene, 20000)
    assert ref.counts["stop"] > 40
    for every in (1, 7, rest_step, rest_step - 1, 1000):
        scene = _chain(40, False, "rest", every, t_end=200.0, speed=0.02)
        r = gc.simulate(scene, progress=False)
        assert r.status == gc.Status.AT_REST, every
        assert r.steps == rest_step, every
        assert abs(r.t_final - rest_step * 0.01) < 1e-12
        assert not r.v_final.any()
        assert np.max(np.abs(r.x_final - (ref.model.x0 + ref.u))) < 1e-12
        assert r.event_counts == ref.counts, every
        assert abs(r.energy.coulomb[-1] - ref.coulomb) < 1e-14


def test_separation_stop_with_merged_kicks():
    # Two granules with kinetic friction (n = 2, the paper's problem): the engine
    # stops at the step where the contact opens and backtracks from the
    # synchronised state; the same backtrack applied to the reference's state at
    # that step gives the same time, state and ledger.
    scene = gc.scene_from_dict({
        "granules": {"count": 2, "velocity": [1.0, 0.0],
                     "friction": {"kinetic": [0.3, 0.1], "static": [0.35, 0.12]}},
        "contacts": {"exponent": 2.0, "stiffness": 1.0},
        "run": {"stepper": "verlet", "dt": 1e-3, "t_end": 50.0, "stop": "separation"}})
    r = gc.simulate(scene, progress=False)
    model = build_model(scene)
    ref = _Reference(model, 1e-3)
    was_closed = False
    for steps in range(1, 50_001):
        ref.step()
        if was_closed and not ref.closed[0]:
            break
        was_closed = bool(ref.closed[0])
    ledger = np.array([ref.coulomb, ref.viscous])
    t = sim._backtrack_to_separation(model, ref.u, ref.v, ref.F, ledger, 0, 1e-3, steps * 1e-3)
    assert r.status == gc.Status.SEPARATED and r.steps == steps
    assert r.event_counts["stop"] >= 1 and r.event_counts["slip"] >= 1
    assert r.event_counts == ref.counts
    assert abs(r.t_final - t) < 1e-13
    assert np.max(np.abs(r.x_final - (model.x0 + ref.u))) < 1e-13
    assert np.max(np.abs(r.v_final - ref.v)) < 1e-13
    assert abs(r.energy.coulomb[-1] - ledger[0]) < 1e-13


def _reference_run(scene, dt, steps, last_dt):
    ref = _Reference(build_model(scene), dt)
    for _ in range(steps):
        ref.step()
    ref.dt = last_dt
    N = ref.model.count
    ref.E, ref.P1, P2 = np.empty(N), np.empty(N), np.empty(N)
    drift_tables(ref.model.gamma / ref.model.mass, last_dt, ref.E, ref.P1, P2)
    ref.step()
    return ref


@pytest.mark.parametrize("friction", ["coulomb", "coulomb+viscous", "frictionless"])
def test_last_step_is_shortened_to_end_exactly_at_t_end(friction):
    """t_end = 8.005 with dt = 0.01: 800 steps, then one of 0.005 (not a step to 8.01)."""
    scene = _chain(40, friction == "coulomb+viscous", "t_end", 37, t_end=8.005)
    if friction == "frictionless":
        scene.granules.friction.kinetic = 0.0
        scene.granules.friction.static = None
    run = gc.simulate(scene, progress=False)
    assert run.status == gc.Status.T_END and run.steps == 801
    assert run.t_final == 8.005 and run.t[-1] == 8.005 and run.dt == 0.01
    ref = _reference_run(scene, 0.01, 800, 8.005 - 800 * 0.01)
    assert np.max(np.abs(run.x_final - (ref.model.x0 + ref.u))) < 1e-12
    assert np.max(np.abs(run.v_final - ref.v)) < 1e-12
    assert abs(run.energy.coulomb[-1] - ref.coulomb) < 1e-14
    # (the numpy kick counts any velocity reversal as a stop; without Coulomb
    # friction the engine counts none: compare contact events only there)
    kinds = ["contact_close", "contact_open"] + (["stop", "slip"] if friction != "frictionless"
                                                 else [])
    assert {k: run.event_counts[k] for k in kinds} == {k: ref.counts[k] for k in kinds}


def test_output_dt_is_honoured_exactly():
    """Frames at multiples of output.dt even when it is not a multiple of run.dt:
    the step is shortened to the largest that divides it, and the run says so."""
    scene = _chain(10, False, "t_end", 1, t_end=1.0)
    scene.output.every = None
    scene.output.dt = 0.1
    scene.run.dt = 0.0097
    run = gc.simulate(scene, progress=False)
    assert np.allclose(run.t, np.arange(11) * 0.1, rtol=0, atol=1e-14)
    assert run.dt == pytest.approx(0.1 / 11) and run.t_final == pytest.approx(1.0, rel=1e-15)
    assert any("run.dt shortened" in w for w in run.info["warnings"])


@pytest.mark.parametrize("viscous", [False, True])
def test_no_frame_off_the_cadence_before_a_shortened_last_step(viscous):
    """t_end = 1.055 with dt = 0.01: frames at the multiples of output.dt = 0.1, then
    one at t_end after the shortened last step, none at 1.05 (its last whole step);
    the state at t_end is the one of the run with a frame at every step."""
    def run(every):
        scene = _chain(10, viscous, "t_end", 1, t_end=1.055)
        scene.run.dt = 0.01
        scene.output.every = every
        return gc.simulate(scene, progress=False)

    sparse, dense = run(10), run(1)
    assert np.allclose(sparse.t, [*(np.arange(11) * 0.1), 1.055], rtol=0, atol=1e-14)
    assert sparse.t[-1] == 1.055 and dense.t[-2] == pytest.approx(1.05, abs=1e-14)
    assert np.array_equal(sparse.x_final, dense.x_final)
    assert np.array_equal(sparse.v_final, dense.v_final)
    assert sparse.event_counts == dense.event_counts
    assert sparse.energy.coulomb[-1] == dense.energy.coulomb[-1]
