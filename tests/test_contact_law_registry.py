"""Contact laws registered by name (``laws/contact.py``): a law written in one file
reaches every kernel through ``contacts.law``, and what cannot take it says so."""

import json
import subprocess
import sys
from importlib import metadata

import numba
import numpy as np
import pytest

import granular_chain as gc
from granular_chain.cli import main
from granular_chain.laws import contact
from granular_chain.model import build_model
from granular_chain.writers.vtk import contact_overlap_force


@numba.njit(inline="always", cache=True)
def quadratic_force(d, k, n):
    """F = k d^2 written as d*d (the n = 3 power law without pow)."""
    return k * d * d


@numba.njit(inline="always", cache=True)
def quadratic_energy(d, k, n):
    """V = k d^3 / 3."""
    return k * d * d * d / 3.0


@numba.njit(inline="always", cache=True)
def stiffening_force(d, k, n):
    """A law that is not a power: F = k d (1 + d / 2)."""
    return k * d * (1.0 + 0.5 * d)


@numba.njit(inline="always", cache=True)
def stiffening_energy(d, k, n):
    """V = k (d^2 / 2 + d^3 / 6)."""
    return k * d * d * (0.5 + d / 6.0)


@pytest.fixture
def laws(monkeypatch):
    """The registry as it is, restored after the test."""
    monkeypatch.setattr(contact, "_BY_NAME", dict(contact._BY_NAME))
    monkeypatch.setattr(contact, "_BY_CODE", dict(contact._BY_CODE))
    quadratic = gc.register_contact_law("quadratic", quadratic_force, quadratic_energy,
                                        exponent=3.0, words="quadratic (n=3)")
    stiffening = gc.register_contact_law("stiffening", stiffening_force, stiffening_energy)
    return quadratic, stiffening


def chain(law, exponent=3.0, **extra):
    """A struck chain of 12 granules between two walls, with Coulomb friction on some."""
    data = {"name": f"chain_{law}",
            "granules": {"count": 12, "velocity": {0: 0.5},
                         "friction": {"kinetic": [0.0] * 6 + [0.02] * 6}},
            "contacts": {"law": law, "exponent": exponent, "stiffness": 20.0},
            "walls": {"left": {"gap": 0.05, "exponent": exponent, "stiffness": 20.0},
                      "right": {"gap": 0.05, "exponent": exponent, "stiffness": 20.0}},
            "run": {"dt": 0.002, "t_end": 30.0}, "output": {"every": 250}}
    for path, value in extra.items():
        group, name = path.split("__")
        data.setdefault(group, {})[name] = value
    return gc.scene_from_dict(data)


def test_registered_law_runs_as_the_power_law_it_rewrites(laws):
    quadratic, _ = laws
    a, b = gc.simulate(chain("quadratic")), gc.simulate(chain("auto"))
    assert a.model.features.law == quadratic.code and b.model.features.law == contact.LAW_POWER
    assert a.success and b.success and a.status == b.status
    assert np.abs(a.x_final - b.x_final).max() < 1e-12
    assert np.abs(a.v_final - b.v_final).max() < 1e-12
    assert a.energy.balance_error < 1e-4 and a.energy.coulomb[-1] > 0


def test_registered_law_in_the_forced_kernel_gravity_and_a_dashpot(laws):
    """Dashpots and body forces take the Verlet kernel that composes them: the law
    goes through it too, and the driven wall's contact as well."""
    extra = {"contacts__damping": {"model": "linear", "coefficient": 0.05},
             "body_force__g": 0.01}
    a, b = gc.simulate(chain("quadratic", **extra)), gc.simulate(chain("auto", **extra))
    assert a.success and np.abs(a.x_final - b.x_final).max() < 1e-12
    assert a.energy.balance_error < 1e-4


def test_law_not_a_power_closes_its_ledger(laws):
    _, stiffening = laws
    r = gc.simulate(chain("stiffening", exponent=2.0))
    assert r.model.features.law == stiffening.code and r.success
    assert r.energy.balance_error < 1e-4
    # F = dV/dd at the overlaps the run reached (central differences)
    d = np.linspace(1e-3, 0.2, 50)
    h = 1e-6
    dv = (np.array([stiffening_energy(x + h, 1.3, 2.0) - stiffening_energy(x - h, 1.3, 2.0)
                    for x in d]) / (2 * h))
    f = np.array([stiffening_force(x, 1.3, 2.0) for x in d])
    assert np.abs(dv - f).max() < 1e-8


def test_the_vtk_contact_forces_use_the_law(laws):
    quadratic, stiffening = laws
    x = np.array([0.0, 1.9, 3.7])
    radius = np.ones(3)
    k, n = np.array([1.5, 2.0]), np.array([3.0, 3.0])
    overlap, force = contact_overlap_force(x, radius, k, n, law=stiffening.code)[:2]
    assert np.allclose(overlap, [0.1, 0.2])
    assert force.tolist() == [stiffening_force(o, kk, 3.0) for o, kk in zip(overlap, k)]
    force_q = contact_overlap_force(x, radius, k, n, law=quadratic.code)[1]
    assert np.allclose(force_q, k * overlap ** 2, rtol=1e-15)


def test_features_name_the_law(laws, capsys, tmp_path):
    assert build_model(chain("quadratic")).features.describe()["law"] == "quadratic (n=3)"
    assert build_model(chain("hertz", exponent=2.5)).features.law == contact.LAW_HERTZ
    assert build_model(chain("auto", exponent=2.5)).features.law == contact.LAW_HERTZ


@pytest.mark.parametrize("extra, field, words", [
    ({"contacts": {"law": "nonesuch"}}, "contacts.law", "no contact law 'nonesuch'"),
    ({"contacts": {"law": "quadratic", "exponent": 2.5}}, "contacts.exponent", "n = 3 law"),
    ({"contacts": {"law": "linear", "exponent": 2.5}}, "contacts.exponent", "n = 2 law"),
    ({"contacts": {"law": "quadratic", "exponent": 3},
      "walls": {"left": {"gap": 0.0}}}, "walls.left.exponent", "n = 3 law"),
    ({"contacts": {"law": "quadratic", "exponent": 3}, "run": {"stepper": "event"}},
     "contacts.law", "use run.stepper: verlet"),
    ({"contacts": {"law": "stiffening", "damping": {"model": "viscoelastic",
                                                      "coefficient": 0.1}}},
     "contacts.damping.model", "use model: linear"),
])
def test_what_a_law_cannot_take_is_refused_by_field(laws, extra, field, words):
    data = {"name": "refused", "granules": {"count": 4, "velocity": {0: 1.0}},
            "run": {"dt": 0.01, "t_end": 1.0}, **extra}
    with pytest.raises(gc.SceneError) as err:
        gc.scene_from_dict(data)
    assert err.value.field == field and words in str(err.value)
    assert str(err.value).count("\n") == 0


def test_the_command_line_refuses_an_unknown_law(tmp_path, capsys):
    scene = tmp_path / "s.yaml"
    scene.write_text("granules: {count: 3, velocity: {0: 1.0}}\ncontacts: {law: nonesuch}\n"
                     "run: {dt: 0.01, t_end: 1.0}\n")
    assert main(["run", str(scene), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "contacts.law" in err and "linear, hertz, power" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.yaml"]


def test_the_event_stepper_refuses_a_model_with_another_law(laws):
    from granular_chain.steppers.events.options import event_options
    from granular_chain.steppers.events.pack import pack_run
    event_scene = gc.scene_from_dict({"granules": {"count": 3, "velocity": {0: 0.5}},
                                      "run": {"stepper": "event", "t_end": 1.0}})
    with pytest.raises(ValueError, match="only for the built-in contact laws, not quadratic"):
        pack_run(build_model(chain("quadratic")), event_options(event_scene))


def test_installed_packages_offer_laws_by_entry_point(laws, monkeypatch, tmp_path):
    """``contacts.law: NAME`` loads the entry point of that name (group
    granular_chain.contact_laws), whose module registers the law when imported."""
    module = tmp_path / "gc_plugin_cubic.py"
    module.write_text(
        "import numba\nimport granular_chain as gc\n\n"
        "@numba.njit(inline='always')\ndef f(d, k, n):\n    return k * d * d * d\n\n"
        "@numba.njit(inline='always')\ndef v(d, k, n):\n    return 0.25 * k * d * d * d * d\n\n"
        "gc.register_contact_law('cubic', f, v, exponent=4.0)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    offered = [metadata.EntryPoint("cubic", "gc_plugin_cubic", contact.ENTRY_POINT_GROUP)]
    monkeypatch.setattr(contact.metadata, "entry_points",
                        lambda group: offered if group == contact.ENTRY_POINT_GROUP else [])
    assert "cubic" not in contact.known_laws()
    scene = chain("cubic", exponent=4.0)
    assert contact.contact_law("cubic").exponent == 4.0 and "cubic" in contact.known_laws()
    assert gc.simulate(scene).success
    monkeypatch.delitem(sys.modules, "gc_plugin_cubic")


def test_codes_follow_the_law_not_the_process(laws):
    """Registered again unchanged, a law keeps its code (a kernel cached on disk is
    its own); changed, it gets another; the built-in names cannot be taken."""
    quadratic, stiffening = laws
    again = gc.register_contact_law("quadratic", quadratic_force, quadratic_energy,
                                    exponent=3.0)
    assert again.code == quadratic.code
    other = gc.register_contact_law("quadratic", stiffening_force, stiffening_energy,
                                    exponent=3.0)
    assert other.code not in (quadratic.code, stiffening.code)
    assert contact.law_of_code(other.code) is other
    with pytest.raises(KeyError):
        contact.law_of_code(quadratic.code)   # replaced
    with pytest.raises(ValueError, match="built in"):
        gc.register_contact_law("hertz", quadratic_force, quadratic_energy)
    # in a fresh process, the same file gives the same code
    code = subprocess.run(
        [sys.executable, "-c", "import sys; sys.path.insert(0, sys.argv[1]); "
         "import test_contact_law_registry as t, granular_chain as gc; "
         "print(gc.register_contact_law('quadratic', t.quadratic_force, t.quadratic_energy, "
         "exponent=3.0).code)", str(__import__('pathlib').Path(__file__).parent)],
        capture_output=True, text=True, check=True).stdout
    assert int(code) == quadratic.code


def test_validate_names_the_law(laws, tmp_path, capsys):
    scene = tmp_path / "s.yaml"
    scene.write_text("granules: {count: 3, velocity: {0: 1.0}}\n"
                     "contacts: {law: quadratic, exponent: 3}\nrun: {dt: 0.01, t_end: 1.0}\n")
    assert main(["validate", str(scene)]) == 0
    assert json.loads(capsys.readouterr().out)["features"]["law"] == "quadratic (n=3)"


LAW_SOURCE = """\
import math
import numba

ALPHA = {alpha}


@numba.njit
def helper(d):
    return {helper}


@numba.njit
def force(d, k, n):
    return k * ALPHA * helper(d) * math.{fn}(1.0) * (lambda x: x)(1.0)
"""


def _code_of(**edit):
    namespace = {}
    exec(LAW_SOURCE.format(**{"alpha": 1.0, "helper": "d * d", "fn": "sin", **edit}), namespace)
    return contact._law_code("edited", namespace["force"], namespace["force"], None)


def test_a_changed_law_gets_another_code():
    """What the law computes with is in its code: a kernel cached on disk for one
    version is never loaded for another (the constant it reads, a helper it calls, a
    function it names), and the same source gives the same code again."""
    base = _code_of()
    assert _code_of() == base
    edited = [_code_of(alpha=2.0), _code_of(helper="d * d * d"), _code_of(fn="cos")]
    assert len({base, *edited}) == 4


def test_a_stored_scene_is_read_as_written(laws):
    """A finished run's scene names a law a script registered: reading the run back
    in a process without it needs no registration (its Model does)."""
    data = {"granules": {"count": 3, "velocity": {0: 1.0}},
            "contacts": {"law": "from_a_script", "exponent": 3}, "run": {"t_end": 1.0}}
    assert gc.scene_from_dict(data, stored=True).contacts.law == "from_a_script"
    with pytest.raises(gc.SceneError):
        gc.scene_from_dict(data)


def test_a_run_stored_before_contacts_law_continues():
    """The scene of a run folder written before contacts.law existed has no such key:
    --restart compares it as the default ('auto'), not as a different scene."""
    from granular_chain import restart
    scene = chain("auto")
    stored = scene.model_dump(mode="json")
    del stored["contacts"]["law"]
    restart._check_scene(restart.Path("old_run"), stored, scene, complete=False)
    stored["contacts"]["exponent"] = 2.5
    with pytest.raises(restart.OutputError, match="contacts.exponent"):
        restart._check_scene(restart.Path("old_run"), stored, scene, complete=False)
