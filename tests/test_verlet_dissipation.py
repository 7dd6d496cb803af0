"""Verlet with contact dashpots, body forces and driven walls (steppers/verlet/forced.py),
measured against closed forms (restitution.linear_dashpot, column_overlaps), the
independent mpmath reference (restitution.restitution_reference) and its own energy
ledger, whose error must fall as dt^2.

Every scene here runs one of three compiled kernels (linear law with a linear
dashpot; Hertz with a viscoelastic one; linear with a dashpot, Coulomb and viscous
friction): walls, wall motion, body forces and ``tensile`` are runtime values, and
a wall or body-force test without dissipation uses a dashpot of coefficient 0.
"""

import math

import numpy as np
import pytest

import granular_chain as gc
from conftest import fitted_order
from granular_chain.model import build_model
from granular_chain.restitution import (column_overlaps, linear_dashpot, restitution_reference)
from granular_chain.steppers.verlet.timestep import default_dt

M_EFF = 0.5  # two unit masses
FINE = (50, 100, 200)  # steps per contact time


def scene(granules, t_end, dt, **extra):
    # convergence studies: steps of a fixed fraction of the contact time, some of them
    # above the accuracy bound of a strong dashpot on purpose
    spec = {"granules": granules, "run": {"t_end": t_end, "dt": dt, "accept_inaccurate_dt": True},
            "output": {"every": 1_000_000}}
    spec.update(extra)
    return gc.scene_from_dict(spec)


def collide(contacts, t_end, dt, v=1.0, n=2.0):
    """Two touching unit granules, the left one at v: (restitution e, Result)."""
    r = gc.simulate(scene({"count": 2, "velocity": [v, 0.0], "gap": 0.0}, t_end, dt,
                          contacts={"exponent": n, **contacts}), progress=False)
    return (r.v_final[1] - r.v_final[0]) / v, r


def linear_c(b):
    """Dashpot c of damping ratio b for k = 1, m_eff = 1/2."""
    return 2.0 * b * math.sqrt(M_EFF)


@pytest.mark.parametrize("tensile, b", [(True, 0.1), (False, 0.1), (False, 2.0)])
def test_two_grain_restitution_converges_to_closed_form_as_dt2(tensile, b):
    """e of a linear dashpot (n = 2): tensile (e = exp(-beta pi/w)) and force-zero
    (Schwager-Poeschel), under- and overdamped; dt = t_c/M puts the end of the
    contact near a step for every M, so the error is the integrator's alone."""
    ref = linear_dashpot(linear_c(b), 1.0, M_EFF, tensile)
    damping = {"damping": {"model": "linear", "coefficient": linear_c(b)}, "tensile": tensile}
    errors = []
    for M in FINE:
        e, r = collide(damping, 2.0 * ref.contact_time, ref.contact_time / M)
        errors.append(e - ref.e)
        assert r.status == gc.Status.T_END and r.energy.contact_dissipated[-1] > 0
    assert fitted_order([1 / M for M in FINE], errors) == pytest.approx(2.0, abs=0.3), errors
    assert abs(errors[-1]) < 2e-5, errors  # 200 steps per contact


def test_overdamped_tensile_contact_never_ends():
    """b = 2, tensile: the overlap decays without reaching zero, the relative speed
    follows xi'(t) of the overdamped oscillator, converging as dt^2."""
    c = linear_c(2.0)
    beta, w0 = c / (2 * M_EFF), math.sqrt(1 / M_EFF)
    W = math.sqrt(beta * beta - w0 * w0)
    T = 6.0
    rate = (-(beta - W) * math.exp(-(beta - W) * T) + (beta + W) * math.exp(-(beta + W) * T)) \
        / (2 * W)
    errors = []
    for dt in (0.02, 0.01, 0.005):
        e, r = collide({"damping": {"model": "linear", "coefficient": c}, "tensile": True},
                       T, dt)
        assert r.event_counts["contact_open"] == 0
        errors.append(-e - rate)  # xi' = v_0 - v_1 = -e v
    assert fitted_order([0.02, 0.01, 0.005], errors) == pytest.approx(2.0, abs=0.3), errors


@pytest.mark.parametrize("v", [1.0, 0.01])
def test_viscoelastic_hertz_restitution_against_reference(v):
    """n = 5/2 viscoelastic (force-zero end): e(v) against the mpmath reference, O(dt^2)."""
    A = 0.1
    ref = restitution_reference(v, 1.0, M_EFF, 2.5, "viscoelastic", A, tensile=False, dps=30)
    tc = float(ref.contact_time)
    damping = {"damping": {"model": "viscoelastic", "coefficient": A}}
    errors = [collide(damping, 2.0 * tc, tc / M, v=v, n=2.5)[0] - float(ref.e) for M in FINE]
    assert fitted_order([1 / M for M in FINE], errors) == pytest.approx(2.0, abs=0.4), errors
    assert abs(errors[-1]) < 1e-4, errors


def ledger(spec, dts):
    """Largest relative ledger error of a scene (dict without run.dt) at each dt, and
    the last run's Result."""
    errors = []
    for dt in dts:
        spec["run"]["dt"] = dt
        r = gc.simulate(gc.scene_from_dict(spec), progress=False)
        assert r.status == gc.Status.T_END, r.message
        errors.append(r.energy.balance_error)
    return errors, r


DTS = (0.04, 0.02, 0.01)
DTS_WALL = (0.02, 0.01, 0.005, 0.0025)  # a pulse's stop needs the finer steps to be asymptotic
ELASTIC = {"damping": {"model": "linear", "coefficient": 0.0}}  # forced kernel, no dissipation


def test_ledger_closes_as_dt2_with_contact_dissipation():
    spec = {"granules": {"count": 5, "velocity": {0: 1.0}, "gap": 0.0, "radius": 2.0},
            "contacts": {"damping": {"model": "linear", "coefficient": 0.3}},
            "walls": {"right": {"gap": 0.1}}, "run": {"t_end": 30.0},
            "output": {"every": 10}}
    errors, r = ledger(spec, DTS)
    led = r.energy
    assert led.contact_dissipated[-1] > 0.3 * led.initial
    assert not led.wall_work.any() and not led.body_work.any()
    assert fitted_order(DTS, errors) == pytest.approx(2.0, abs=0.3), errors


@pytest.mark.parametrize("motion", [{"velocity": 0.05}, {"sine": {"amplitude": 0.2,
                                                                  "frequency": 0.1}},
                                    {"pulse": {"velocity": 0.4, "duration": 3.3}}])
def test_ledger_closes_as_dt2_with_wall_work(motion):
    """A wall driven into a chain at rest: the ledger holds only the wall's work."""
    spec = {"granules": {"count": 4, "velocity": 0.0, "gap": 0.0, "radius": 2.0},
            "contacts": ELASTIC,
            "walls": {"left": {"gap": 0.0, "motion": motion}, "right": {"gap": 0.5}},
            "run": {"t_end": 20.0}, "output": {"every": 10}}
    errors, r = ledger(spec, DTS_WALL)
    led = r.energy
    assert led.initial == 0 and abs(led.wall_work[-1]) > 1e-3
    assert not led.contact_dissipated.any() and not led.body_work.any()
    assert fitted_order(DTS_WALL, errors) == pytest.approx(2.0, abs=0.35), errors


def test_ledger_closes_as_dt2_with_body_work():
    """Granules falling onto a wall under gravity and bouncing (elastic)."""
    spec = {"granules": {"count": 3, "velocity": 0.0, "gap": 0.3, "radius": 2.0},
            "contacts": ELASTIC, "walls": {"left": {"gap": 0.2}},
            "body_force": {"g": 0.2, "direction": -1},
            "run": {"t_end": 15.0}, "output": {"every": 10}}
    errors, r = ledger(spec, DTS)
    led = r.energy
    assert led.body_work[-1] > 0.05 and not led.contact_dissipated.any()
    assert fitted_order(DTS, errors) == pytest.approx(2.0, abs=0.3), errors


@pytest.mark.parametrize("n, damping", [(2.0, {"model": "linear", "coefficient": 5.0}),
                                        (2.5, {"model": "viscoelastic", "coefficient": 2.0})])
def test_column_settles_to_static_overlaps(n, damping):
    """N = 10 granules fall onto a left wall under gravity; the run stops at rest with
    delta_i = (i m g / k)^(1/(n-1)) (i from the top) to 1e-10."""
    g = 0.01
    s = scene({"count": 10, "velocity": 0.0, "gap": 0.0}, 5000.0, 0.01 if n == 2.5 else None,
              contacts={"exponent": n, "damping": damping},
              walls={"left": {"gap": 0.0, "exponent": n}},
              body_force={"g": g, "direction": -1})
    s.run.stop = "rest"
    r = gc.simulate(s, progress=False)
    assert r.status == gc.Status.AT_REST, r.message
    m = r.model
    u = r.x_final - m.x0
    delta = np.concatenate(([m.walls[0] - u[0]], m.d0 + u[:-1] - u[1:]))[::-1]
    err = np.max(np.abs(delta / column_overlaps(10, 1.0, g, 1.0, n) - 1))
    assert err < 1e-10, err


def test_damped_chain_with_coulomb_and_viscous_friction():
    """Dashpots, Coulomb and viscous friction and a left wall: every dissipation term
    grows, the ledger closes as dt^2, and the chain ends held by static friction."""
    spec = {"granules": {"count": 6, "velocity": {5: -1.0}, "gap": 0.0, "radius": 2.0,
                         "friction": {"kinetic": 0.02, "static": 0.03, "viscous": 0.05}},
            "contacts": {"damping": {"model": "linear", "coefficient": 0.2}},
            "walls": {"left": {"gap": 0.0}}, "run": {"t_end": 12.0}, "output": {"every": 10}}
    errors, r = ledger(spec, DTS)
    led = r.energy
    assert min(led.coulomb[-1], led.viscous[-1], led.contact_dissipated[-1]) > 0.02
    assert fitted_order(DTS, errors) == pytest.approx(2.0, abs=0.35), errors
    spec["run"].update(t_end=500.0, stop="rest")
    rest = gc.simulate(gc.scene_from_dict(spec), progress=False)
    assert rest.status == gc.Status.AT_REST and not rest.v_final.any()


def test_default_dt_respects_the_dashpot_and_a_sine_wall():
    """dt <= m_eff/(40 c) for the stiffest dashpot, <= 1/(200 f) for a sine wall."""
    s = gc.scene_from_dict({"granules": {"count": 3, "velocity": {0: 1.0}},
                            "contacts": {"damping": {"model": "linear", "coefficient": 50.0}},
                            "run": {"t_end": 10.0}})
    assert default_dt(build_model(s), 10.0) <= M_EFF / (40 * 50.0)
    s = gc.scene_from_dict({"granules": {"count": 3, "velocity": 0.0},
                            "walls": {"left": {"motion": {"sine": {"amplitude": 0.1,
                                                                   "frequency": 3.0}}}},
                            "run": {"t_end": 10.0}})
    assert default_dt(build_model(s), 10.0) <= 1 / 600.0


def test_a_step_the_dashpot_cannot_take_is_refused():
    """The dashpot's explicit part is unstable from c dt / m_eff = 2 on (measured:
    1.9 runs, 2.1 blows up): such a run.dt is refused before the run starts."""
    s = gc.scene_from_dict({"granules": {"count": 2, "velocity": [1.0, 0.0]},
                            "contacts": {"damping": {"model": "linear", "coefficient": 20.0}},
                            "run": {"t_end": 1.0, "dt": 2.0 * M_EFF / 20.0}})
    with pytest.raises(gc.SimulationError, match="run.dt.*dashpot"):
        gc.simulate(s, progress=False)
    # (stable but far above the accuracy bound m_eff/(40 c): accepted, not judged)
    s.run.dt, s.run.accept_inaccurate_dt, s.run.energy_tolerance = 1.9 * M_EFF / 20.0, True, None
    assert gc.simulate(s, progress=False).status == gc.Status.T_END
