"""The contact table: contacts 0..N with the walls as contacts 0 and N, built once in the
Model and read by the steppers' records, the scaling and the writers."""

import numpy as np
import pytest

from granular_chain.model import build_model, hertz_wall_stiffness
from granular_chain.scene import scene_from_dict
from granular_chain.steppers.events.pack import _contacts, _dissipation_arrays
from granular_chain.units import internal_scales, scaled_model
from granular_chain.writers.vtk import dissipation_of, wall_contacts

WALLS = {"left": {"gap": 0.1, "stiffness": 2.0, "exponent": 2.5},
         "right": {"gap": 0.2, "stiffness": 3.0, "exponent": 3.0}}


def _model(walls=WALLS, count=4, **extra):
    return build_model(scene_from_dict({
        "granules": {"count": count, "mass": [1.0, 2.0, 0.5, 1.5][:count], "radius": 0.5,
                     "velocity": {0: 1.0}, "gap": 0.05},
        "contacts": {"exponent": 2.5, "stiffness": [1.0, 2.0, 4.0][:count - 1], **extra},
        "walls": walls}))


@pytest.mark.parametrize("sides", [("left", "right"), ("left",), ("right",), ()])
def test_walls_are_contacts_0_and_n(sides):
    model = _model({s: WALLS[s] for s in sides})
    t, N = model.contacts, model.count
    assert t.present.tolist() == [int("left" in sides), 1, 1, 1, int("right" in sides)]
    assert t.has_walls == ("left" in sides, "right" in sides)
    assert t.rows().tolist() == [1, 2, 3] + [j for j, s in ((0, "left"), (N, "right")) if s in sides]
    assert t.k[1:N].tolist() == [1.0, 2.0, 4.0] and t.n[1:N].tolist() == [2.5] * 3
    assert t.d0[1:N].tolist() == [-0.05] * 3
    for j, side in ((0, "left"), (N, "right")):
        expect = (-WALLS[side]["gap"], WALLS[side]["stiffness"], WALLS[side]["exponent"])
        assert (t.d0[j], t.k[j], t.n[j]) == (expect if side in sides else (0.0, 0.0, 0.0))
    # the views the plain Verlet kernels take are the table's own rows
    for name in ("d0", "k", "n", "damping"):
        assert np.shares_memory(getattr(model, name), getattr(t, name))
    assert model.walls.tolist() == [t.d0[0], t.k[0], t.n[0], t.d0[N], t.k[N], t.n[N]]


def test_one_granule_between_two_walls():
    model = _model(count=1)
    t = model.contacts
    assert t.count == 1 and t.present.tolist() == [1, 1] and t.rows().tolist() == [0, 1]
    assert model.k.size == 0 and t.reduced_mass(model.mass).tolist() == [1.0, 1.0]
    assert [t.field_of(j) for j in (0, 1)] == ["walls.left.stiffness", "walls.right.stiffness"]


def test_reduced_mass_of_every_contact():
    model = _model()
    m = model.mass
    mu = model.contacts.reduced_mass(m)
    assert mu[0] == m[0] and mu[-1] == m[-1]
    assert np.array_equal(mu[1:-1], m[:-1] * m[1:] / (m[:-1] + m[1:]))


def test_hertz_wall_row_from_the_materials():
    walls = {"left": {"gap": 0.0, "stiffness": "hertz", "material": {"young": 2.0, "poisson": 0.2}}}
    model = build_model(scene_from_dict({
        "granules": {"count": 3, "radius": 0.01, "velocity": {0: 1.0},
                     "material": {"young": 1.0, "poisson": 0.3}},
        "contacts": {"stiffness": "hertz"}, "walls": walls}))
    assert model.contacts.k[0] == hertz_wall_stiffness(1.0, 0.3, 2.0, 0.2, 0.01)
    assert model.contacts.n[0] == 2.5 and model.contacts.present[0] == 1


def test_restitution_sets_the_dashpot_of_every_contact_present():
    model = _model({"left": WALLS["left"]}, damping={"model": "restitution", "value": 0.8,
                                                     "speed": 1.0})
    c = model.contacts.damping
    assert np.all(c[:4] > 0) and c[4] == 0.0  # no right wall: no dashpot there
    assert model.wall_damping.tolist() == [c[0], c[4]]


def test_event_records_are_the_table():
    model = _model({"right": WALLS["right"]}, damping={"model": "linear", "coefficient": 0.3})
    t = model.contacts
    present, overlap, stiffness, exponent = _contacts(model)
    assert np.array_equal(present, t.present) and np.array_equal(overlap, t.d0)
    # an absent wall's row gets a unit linear law (never read: present is 0)
    assert (stiffness[0], exponent[0]) == (1.0, 2.0)
    assert np.array_equal(stiffness[1:], t.k[1:]) and np.array_equal(exponent[1:], t.n[1:])
    damping, dashpot, body, motion = _dissipation_arrays(model)
    assert np.array_equal(damping, t.damping) and np.all(damping == 0.3)
    d = dissipation_of(model)
    assert np.array_equal(d.coefficient, t.damping) and d.motion.shape == (2, 3)


def test_writers_read_the_wall_rows():
    model = _model()
    left, right = wall_contacts(model)
    t = model.contacts
    assert (left.d0, left.k, left.n) == (t.d0[0], t.k[0], t.n[0])
    assert (right.d0, right.k, right.n) == (t.d0[4], t.k[4], t.n[4])
    assert wall_contacts(_model({}))[0] is None


def test_scaling_divides_each_row_by_its_scale():
    """Internal units: overlaps by A, k by F A^(1-n) = M A^(2-n) / B^2 row by row (the
    walls' rows with their own exponents), the dashpots by their unit."""
    model = build_model(scene_from_dict({
        "units": "physical",
        "granules": {"count": 3, "mass": 0.01, "radius": 0.005, "velocity": {0: 0.3}},
        "contacts": {"exponent": 2.5, "stiffness": 1e7,
                     "damping": {"model": "linear", "coefficient": 0.02}},
        "walls": {"right": {"gap": 0.001, "stiffness": 2e7, "exponent": 3.0}}}))
    M, A, B = internal_scales(model)
    s, t = scaled_model(model, M, A, B).contacts, model.contacts
    assert np.array_equal(s.present, t.present) and np.array_equal(s.n, t.n)
    assert np.array_equal(s.d0, t.d0 / A)
    assert s.k == pytest.approx(t.k * A ** (t.n - 2.0) * B * B / M, rel=1e-15)
    assert s.k[3] == pytest.approx(2e7 * A * B * B / M, rel=1e-15)  # n = 3 at the wall
    assert np.array_equal(s.damping, t.damping * (B / M))
