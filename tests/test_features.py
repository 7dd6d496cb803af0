"""Walls, materials, physical units, stop conditions, N = 1."""

import math

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.model import build_model, hertz_stiffness


def _scene(**kw):
    # radius 2: the largest wall overlap (1, for m = k = v = 1) stays below it
    base = {"name": "t", "granules": {"count": 1, "velocity": -1.0, "radius": 2.0},
            "walls": {"left": {"gap": 0.0, "stiffness": 1.0, "exponent": 2.0}},
            "run": {"dt": 1e-3, "t_end": 5.0}}
    for key, value in kw.items():
        base[key] = value
    return gc.scene_from_dict(base)


def test_single_granule_bounces_elastically_off_a_linear_wall():
    # m = k = 1: in contact for half a period, pi, then leaves at +1.
    r = gc.simulate(_scene())
    assert r.v_final[0] == pytest.approx(1.0, abs=1e-6)
    x_exact = 2.0 + (5.0 - math.pi) * 1.0
    assert r.x_final[0] == pytest.approx(x_exact, abs=1e-5)
    assert r.event_counts == {"contact_close": 0, "contact_open": 0, "stop": 0, "slip": 0}


def test_chain_between_two_walls_keeps_its_energy():
    s = gc.scene_from_dict({
        "granules": {"count": 5, "velocity": {2: 1.0}, "gap": 0.1},
        "contacts": {"exponent": 2.5, "stiffness": 100.0},
        "walls": {"left": {"gap": 0.1, "exponent": 2.5, "stiffness": 100.0},
                  "right": {"gap": 0.1, "exponent": 2.5, "stiffness": 100.0}},
        "run": {"dt": 5e-4, "t_end": 40.0}})
    r = gc.simulate(s)
    assert r.energy.balance_error < 1e-5
    x = r.x
    assert np.all(np.diff(x, axis=1) > 0)  # granules never pass each other
    # No wall overlap can exceed the one that stores all the energy: 40 d^(5/2) = 1/2.
    dmax = (0.5 / 40) ** 0.4
    left_wall, right_wall = -0.1, x[0, -1] + 0.5 + 0.1
    assert np.all(left_wall + 0.5 - x[:, 0] < dmax)
    assert np.all(x[:, -1] + 0.5 - right_wall < dmax)
    assert np.max(left_wall + 0.5 - x[:, 0]) > 0  # the wall was hit


def test_hertz_stiffness_from_materials():
    E, nu, R = 2.0e11, 0.3, 0.01
    k = hertz_stiffness(E, nu, E, nu, R, R)
    # identical spheres: (4/3) E/(2(1-nu^2)) sqrt(R/2)
    assert k == pytest.approx(4 / 3 * E / (2 * (1 - nu ** 2)) * math.sqrt(R / 2), rel=1e-15)
    s = gc.scene_from_dict({
        "units": "physical",
        "granules": {"count": 2, "mass": 0.033, "radius": R, "velocity": [0.5, 0.0],
                     "material": {"young": E, "poisson": nu},
                     "friction": {"kinetic": [0.0, 0.05], "viscous": [0.0, 0.2]}},
        "contacts": {"stiffness": "hertz", "exponent": 2.5},
        "run": {"t_end": 1e-3, "stop": "separation"}})
    model = build_model(s)
    assert model.k[0] == pytest.approx(k, rel=1e-15)
    r = gc.simulate(s)
    sc = r.info["scaled"]
    A = (0.033 * 0.25 / k) ** 0.4
    assert sc["length_scale_A"] == pytest.approx(A, rel=1e-14)
    assert sc["time_scale_B"] == pytest.approx(A / 0.5, rel=1e-14)
    assert sc["eta_scaled"][1] == pytest.approx(0.05 * A / (0.033 * 0.25), rel=1e-14)
    assert sc["gamma_scaled"][1] == pytest.approx(0.2 * A / (0.033 * 0.5), rel=1e-14)
    assert r.status == gc.Status.SEPARATED


def test_scaled_and_physical_runs_agree_after_scaling():
    # The physical run, expressed in A, B units, is the scaled run.
    E, nu, R, m, v0 = 2.0e11, 0.3, 0.01, 0.033, 0.5
    k = hertz_stiffness(E, nu, E, nu, R, R)
    A = (m * v0 * v0 / k) ** 0.4
    B = A / v0
    eta_s = 0.2
    phys = gc.scene_from_dict({
        "units": "physical",
        "granules": {"count": 2, "mass": m, "radius": R, "velocity": [v0, 0.0],
                     "friction": {"kinetic": [0.0, eta_s * m * v0 * v0 / A]}},
        "contacts": {"stiffness": k, "exponent": 2.5},
        "run": {"dt": B * 1e-3, "t_end": 10 * B, "stop": "separation"}})
    scaled = gc.scene_from_dict({
        "granules": {"count": 2, "radius": R / A, "velocity": [1.0, 0.0],
                     "friction": {"kinetic": [0.0, eta_s]}},
        "contacts": {"exponent": 2.5},
        "run": {"dt": 1e-3, "t_end": 10.0, "stop": "separation"}})
    rp, rs = gc.simulate(phys), gc.simulate(scaled)
    assert rp.steps == rs.steps
    assert rp.t_final / B == pytest.approx(rs.t_final, rel=1e-10)
    np.testing.assert_allclose(rp.v_final / v0, rs.v_final, rtol=1e-10, atol=1e-13)


def test_stop_at_rest_with_coulomb_friction():
    s = gc.scene_from_dict({
        "granules": {"count": 3, "velocity": {0: 1.0}, "friction": {"kinetic": 0.2}},
        "run": {"dt": 1e-3, "t_end": 100.0, "stop": "rest"}})
    r = gc.simulate(s)
    assert r.status == gc.Status.AT_REST and np.all(r.v_final == 0.0)
    assert r.t_final < 20.0
    assert r.energy.balance_error < 1e-6


def test_max_steps_is_reported():
    # With a stop condition the run may end before t_end, so run.max_steps is a cap
    # (without one, t_end/dt > max_steps is refused up front: tests/test_bad_input.py).
    s = gc.scene_from_dict({"granules": {"count": 2, "velocity": [1.0, 0.0]},
                            "run": {"dt": 1e-3, "t_end": 10.0, "max_steps": 500,
                                    "stop": "separation"}})
    r = gc.simulate(s)
    assert r.status == gc.Status.MAX_STEPS and not r.success
    assert "run.max_steps" in r.message and r.steps == 500
