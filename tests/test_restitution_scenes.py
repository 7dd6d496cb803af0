"""contacts.damping {model: restitution, value, speed} for any exponent; Hertz walls.

The float64 e(g) of :func:`granular_chain.restitution.scaled_restitution` against the
mpmath reference, its inverse, the engine's two-granule collision against both, the
Hertz wall stiffness against the textbook sphere-on-flat formula, and the refusals.
"""

import math

import numpy as np
import pytest
import yaml

import granular_chain as gc
from granular_chain import restitution as R
from granular_chain.cli import main
from granular_chain.model import build_model, hertz_wall_stiffness
from granular_chain.simulate import simulate
from granular_chain.two_granules.problem import two_granule_scene

M_EFF = 0.5  # two unit masses
TARGET = {"model": "restitution", "value": 0.9, "speed": 1.0}


@pytest.mark.parametrize("n, tensile", [(2.5, False), (3.0, False), (7 / 3, False),
                                        (1.5, False), (2.5, True), (3.0, True)])
def test_float64_e_matches_the_mpmath_reference(n, tensile):
    """scaled_restitution(g, n) agrees with restitution_reference (25 digits) to 1e-12
    over g = 0.01 .. 2 (e from 0.98 to 0.02)."""
    worst = 0.0
    for g in (0.01, 0.07, 0.5, 2.0):
        e = R.scaled_restitution(g, n, tensile)
        ref = float(R.restitution_reference(1.0, 1.0, 1.0, n, "viscoelastic", g, tensile,
                                            dps=25).e)
        worst = max(worst, abs(e - ref))
    assert worst < 1e-12


def test_damping_group_is_the_only_group():
    """Eq. (R1): two contacts with the same g = A (k/m)^(1/n) v^((n-2)/n) have the same e
    (reference), and at n = 2 scaled_restitution is the linear-dashpot closed form."""
    n, A, v, k, m = 3.0, 0.3, 0.7, 2.0, 0.4
    g = R.damping_group(A, v, n, k, m)
    assert g == pytest.approx(A * (k / m) ** (1 / n) * v ** ((n - 2) / n), rel=1e-15)
    ref = float(R.restitution_reference(v, k, m, n, "viscoelastic", A, False, dps=25).e)
    assert abs(R.scaled_restitution(g, n) - ref) < 1e-12
    b = 0.3
    assert R.scaled_restitution(2 * b, 2.0) == R.linear_dashpot(2 * b, 1.0, 1.0).e


@pytest.mark.parametrize("n", [2.0, 2.5, 3.0])
@pytest.mark.parametrize("e", [0.9, 0.5, 0.2])
def test_solve_damping_round_trip(n, e):
    """A = solve_damping(e, v, n, k, m) gives e back at speed v (float64 and mpmath)."""
    v, k, m = 0.3, 1.7, 0.6
    A = R.solve_damping(e, v, n, k, m)
    assert isinstance(A, float) and A > 0
    assert abs(R.scaled_restitution(R.damping_group(A, v, n, k, m), n) - e) < 1e-14
    ref = float(R.restitution_reference(v, k, m, n, "viscoelastic", A, False, dps=25).e)
    assert abs(ref - e) < 1e-12
    assert R.scaled_damping(1.0, n) == 0.0


def test_solve_damping_at_n2_is_the_linear_dashpot_and_needs_no_speed():
    assert R.solve_damping(0.8, None, 2.0, 3.0, 0.5) == R.choose_damping(0.8, 3.0, 0.5) / 3.0
    with pytest.raises(ValueError, match="speed"):
        R.solve_damping(0.8, None, 2.5, 3.0, 0.5)


def _pair(v, stepper, **run):
    """Two unit Hertz grains, e = 0.9 at speed 1, impact speed v: (e, A, Result)."""
    spec = two_granule_scene(2.5, stepper=stepper, **run)
    spec["granules"]["velocity"] = [v, 0.0]
    spec["contacts"]["damping"] = dict(TARGET)
    r = simulate(gc.scene_from_dict(spec), progress=False)
    assert r.status == gc.Status.SEPARATED, r.message
    return (r.v_final[1] - r.v_final[0]) / v, float(r.model.damping[0]), r


@pytest.mark.slow
def test_event_stepper_gives_e_at_the_target_speed_and_e_of_g_elsewhere():
    """Event stepper (rtol 1e-12): e = 0.9 to 1e-9 at the target speed 1; at 1e-3, 1e-2,
    0.1 and 0.5 the engine's e is scaled_restitution(g(v)) to 1e-9 (e depends on v)."""
    e, A, r = _pair(1.0, "event", rtol=1e-12)
    assert abs(e - 0.9) < 1e-9
    assert A == pytest.approx(R.solve_damping(0.9, 1.0, 2.5, 1.0, M_EFF), rel=1e-15)
    assert r.energy.balance_error <= r.info["event_stepper"]["ledger_tolerance"]
    seen = []
    for v in (1e-3, 1e-2, 0.1, 0.5):
        e, _, _ = _pair(v, "event", rtol=1e-12)
        expected = R.scaled_restitution(R.damping_group(A, v, 2.5, 1.0, M_EFF), 2.5)
        assert abs(e - expected) < 1e-9
        seen.append(e)
    assert np.all(np.diff(seen) < -1e-3)  # slower impacts bounce more


@pytest.mark.slow
def test_verlet_gives_e_within_its_error_estimate():
    """Verlet at its default dt and at dt/2: e converges to 0.9, and the error at dt/2
    is within the difference |e(dt) - e(dt/2)|, the error estimate of a method of
    order >= 1 (the contact's end between steps makes the order below 2: the error
    falls by 2.4 when dt halves; 5.2e-6 then 2.1e-6)."""
    e1, _, r = _pair(1.0, "verlet")
    e2, _, _ = _pair(1.0, "verlet", dt=r.dt / 2)
    assert abs(e2 - 0.9) < abs(e1 - 0.9) < 1e-5
    assert abs(e2 - 0.9) <= abs(e1 - e2)


def _scene_file(tmp_path, damping, exponent=2.5, walls=None):
    data = {"name": "s", "granules": {"count": 2, "velocity": [1.0, 0.0]},
            "contacts": {"exponent": exponent, "damping": damping},
            "run": {"t_end": 1.0}}
    if walls:
        data["walls"] = walls
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize("damping, exponent, walls, field", [
    ({"model": "restitution", "value": 0.9}, 2.5, None, "contacts.damping.speed"),
    ({"model": "restitution", "value": 0.9}, 2.0, {"right": {"exponent": 3.0}},
     "contacts.damping.speed"),
    ({"model": "restitution", "value": 0.9, "speed": 0.0}, 2.5, None, "contacts.damping.speed"),
    ({"model": "restitution", "value": 0.9, "speed": ".inf"}, 2.5, None, "contacts.damping.speed"),
    ({"model": "restitution", "value": 1.5, "speed": 1.0}, 2.5, None, "contacts.damping.value"),
    ({"model": "restitution", "value": 0.0, "speed": 1.0}, 2.5, None, "contacts.damping.value"),
    ({"model": "viscoelastic", "coefficient": 0.1, "speed": 1.0}, 2.5, None,
     "contacts.damping.speed"),
])
def test_bad_restitution_is_refused_in_one_line(tmp_path, capsys, damping, exponent, walls, field):
    path = _scene_file(tmp_path, damping, exponent, walls)
    text = path.read_text().replace("'.inf'", ".inf")
    path.write_text(text)
    before = sorted(p.name for p in tmp_path.iterdir())
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "s.yaml" in err[0] and field in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_restitution_at_n2_ignores_speed_and_keeps_the_linear_dashpot():
    """n = 2: the same linear dashpot c (bit for bit) with or without speed."""
    base = {"name": "s", "granules": {"count": 3, "mass": [1.0, 2.0, 0.5]},
            "contacts": {"damping": {"model": "restitution", "value": 0.7}},
            "walls": {"right": {}}}
    a = build_model(gc.scene_from_dict(base))
    base["contacts"]["damping"]["speed"] = 5.0
    b = build_model(gc.scene_from_dict(base))
    assert a.features.damping == b.features.damping == 1  # DAMPING_LINEAR
    assert np.array_equal(a.damping, b.damping) and np.array_equal(a.wall_damping, b.wall_damping)
    assert a.damping[0] == R.choose_damping(0.7, 1.0, 2.0 / 3.0)


def test_restitution_builds_each_contact_and_wall_from_its_own_masses():
    """n = 5/2: A_i of each contact from its reduced mass, the wall's from the end mass."""
    scene = gc.scene_from_dict({
        "name": "s", "granules": {"count": 3, "mass": [1.0, 2.0, 0.5]},
        "contacts": {"exponent": 2.5, "stiffness": [1.0, 3.0], "damping": TARGET},
        "walls": {"right": {"exponent": 2.5, "stiffness": 2.0}}})
    model = build_model(scene)
    assert model.features.damping == 2  # DAMPING_VISCOELASTIC
    for A, k, m in zip(model.damping, (1.0, 3.0), (2 / 3, 0.4)):
        assert A == pytest.approx(R.solve_damping(0.9, 1.0, 2.5, k, m), rel=1e-14)
    assert model.wall_damping[1] == pytest.approx(R.solve_damping(0.9, 1.0, 2.5, 2.0, 0.5),
                                                  rel=1e-14)


def _hertz_scene(walls, contacts=None):
    return {"name": "s", "units": "physical",
            "granules": {"count": 3, "mass": 1e-3, "radius": [0.01, 0.02, 0.005],
                         "material": {"young": [70e9, 70e9, 100e9], "poisson": [0.22, 0.22, 0.3]}},
            "contacts": contacts or {"stiffness": "hertz"}, "walls": walls}


def test_hertz_wall_is_the_textbook_sphere_on_flat():
    """walls.*.stiffness: hertz is k = (4/3) E* sqrt(r), 1/E* = (1-nu_g^2)/E_g + (1-nu_w^2)/E_w,
    with the end granule's material and radius; the exponent defaults to 2.5."""
    steel = {"young": 200e9, "poisson": 0.3}
    model = build_model(gc.scene_from_dict(_hertz_scene(
        {"left": {"stiffness": "hertz", "material": steel},
         "right": {"stiffness": "hertz", "material": {"young": 3e9, "poisson": 0.4}}})))
    e_left = 1.0 / ((1 - 0.22 ** 2) / 70e9 + (1 - 0.3 ** 2) / 200e9)
    e_right = 1.0 / ((1 - 0.3 ** 2) / 100e9 + (1 - 0.4 ** 2) / 3e9)
    assert model.walls[1] == pytest.approx(4 / 3 * e_left * math.sqrt(0.01), rel=1e-15)
    assert model.walls[4] == pytest.approx(4 / 3 * e_right * math.sqrt(0.005), rel=1e-15)
    assert model.walls[2] == model.walls[5] == 2.5
    assert np.all(model.n == 2.5) and model.features.law == gc.model.LAW_HERTZ
    # a flat is the limit of a sphere of infinite radius in the two-sphere formula
    far = gc.model.hertz_stiffness(70e9, 0.22, 200e9, 0.3, 0.01, 1e30)
    assert hertz_wall_stiffness(70e9, 0.22, 200e9, 0.3, 0.01) == pytest.approx(far, rel=1e-14)


def test_hertz_contacts_default_to_the_hertz_exponent():
    """contacts.stiffness: hertz without contacts.exponent is n = 5/2 (an explicit 2.0
    is still refused)."""
    scene = gc.scene_from_dict(_hertz_scene({}))
    assert scene.contacts.exponent == 2.5
    with pytest.raises(gc.SceneError, match="contacts.exponent"):
        gc.scene_from_dict(_hertz_scene({}, {"stiffness": "hertz", "exponent": 2.0}))


@pytest.mark.parametrize("wall, field", [
    ({"stiffness": "hertz"}, "walls.right.stiffness"),
    ({"stiffness": "hertz", "exponent": 2.0, "material": {"young": 1e9, "poisson": 0.3}},
     "walls.right.exponent"),
    ({"stiffness": 5.0, "material": {"young": 1e9, "poisson": 0.3}}, "walls.right.material"),
    ({"stiffness": "hertz", "material": {"young": 1e9, "poisson": 0.7}},
     "walls.right.material.poisson"),
])
def test_bad_hertz_wall_is_refused(tmp_path, capsys, wall, field):
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(_hertz_scene({"right": wall})))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and field in err[0], err


def test_hertz_wall_needs_granule_material(tmp_path, capsys):
    data = _hertz_scene({"right": {"stiffness": "hertz",
                                   "material": {"young": 1e9, "poisson": 0.3}}},
                        {"stiffness": 1.0})
    del data["granules"]["material"]
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "walls.right.stiffness" in err[0] and "granules.material" in err[0]
