"""Seeded distributions for per-granule values: the exact draw, reproducible from the scene."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

import granular_chain as gc
from granular_chain.model import build_model

ROOT = Path(__file__).resolve().parents[1]


def _scene(count=50, **granules):
    return gc.scene_from_dict({"name": "d", "granules": {"count": count, **granules}},
                              source="d.yaml")


def test_each_distribution_is_numpys_documented_draw():
    n = 50
    m = build_model(_scene(
        n, mass={"distribution": "lognormal", "median": 2.0, "sigma": 0.1, "seed": 7},
        radius={"distribution": "uniform", "low": 0.4, "high": 0.6, "seed": 8},
        velocity={"distribution": "normal", "mean": 0.5, "std": 0.01, "seed": 9},
        gap={"distribution": "uniform", "low": 0.0, "high": 0.01, "seed": 10},
        friction={"kinetic": {"distribution": "uniform", "low": 0.0, "high": 0.1, "seed": 11},
                  "viscous": {"distribution": "lognormal", "median": 0.01, "sigma": 1.0,
                              "seed": 12}}))
    rng = np.random.default_rng
    assert np.array_equal(m.mass, rng(7).lognormal(np.log(2.0), 0.1, n))
    z = rng(7).standard_normal(n)  # NumPy's lognormal calls the C library's exp
    assert np.array_equal(m.mass, [math.exp(math.log(2.0) + 0.1 * zi) for zi in z])
    assert np.array_equal(m.radius, rng(8).uniform(0.4, 0.6, n))
    assert np.array_equal(m.radius, 0.4 + (0.6 - 0.4) * rng(8).random(n))
    assert np.array_equal(m.v0, 0.5 + 0.01 * rng(9).standard_normal(n))
    assert np.array_equal(m.d0, -rng(10).uniform(0.0, 0.01, n - 1))  # one gap per contact
    assert np.array_equal(m.eta, rng(11).uniform(0.0, 0.1, n))
    assert np.array_equal(m.eta_static, m.eta)
    assert np.array_equal(m.gamma, rng(12).lognormal(np.log(0.01), 1.0, n))


def test_same_seed_same_values_on_any_machine():
    """The first draws, pinned bit for bit: recorded with NumPy 2.4 on x86-64 Linux, they
    fail where a machine or NumPy version would draw other values from the same recipe."""
    spec = {"distribution": "normal", "mean": 1.0, "std": 0.1, "seed": 7}
    a, b = build_model(_scene(mass=spec)).mass, build_model(_scene(mass=dict(spec))).mass
    assert np.array_equal(a, b)
    assert [x.hex() for x in a[:3]] == ["0x1.00080fdad80cdp+0", "0x1.07a5dbd757acep+0",
                                       "0x1.f1f6d1ff53222p-1"]
    u = build_model(_scene(radius={"distribution": "uniform", "low": 1.0, "high": 2.0,
                                   "seed": 0})).radius
    assert [x.hex() for x in u[:2]] == ["0x1.a30febcfd9c28p+0", "0x1.4510bdf882d9dp+0"]
    other = build_model(_scene(mass={**spec, "seed": 8})).mass
    assert not np.array_equal(a, other)


def test_the_stored_scene_keeps_the_recipe_and_redraws_the_values(tmp_path):
    from granular_chain.cli import main

    out = tmp_path / "run"
    recipe = "{distribution: lognormal, median: 1.0, sigma: 0.2, seed: 3}"
    assert main(["run", str(ROOT / "scenarios" / "two_granules.yaml"), "--out", str(out),
                 "--quiet", "--set", f"granules.mass={recipe}"]) == 0
    stored = json.loads((out / "summary.json").read_text())["scene"]["granules"]["mass"]
    assert stored == {"distribution": "lognormal", "median": 1.0, "sigma": 0.2, "seed": 3}
    back = gc.read_run(out)
    drawn = np.random.default_rng(3).lognormal(0.0, 0.2, 2)
    assert np.array_equal(build_model(back.scene).mass, drawn)
    import h5py
    with h5py.File(out / "trajectory.h5") as h5:
        assert np.array_equal(h5["mass"][...], drawn)
        assert yaml.safe_load(h5.attrs["scene"])["granules"]["mass"] == stored
    assert back.status == gc.Status.SEPARATED


@pytest.mark.parametrize("granules, field, words", [
    ({"mass": {"distribution": "normal", "mean": 1.0, "std": 1.0, "seed": 7}},
     "granules.mass", "gives -"),
    ({"friction": {"kinetic": {"distribution": "normal", "mean": 0.0, "std": 0.2, "seed": 4}}},
     "granules.friction.kinetic", "values must be >= 0"),
    ({"mass": {"distribution": "normal", "mean": 1.0, "std": 0.1}}, "granules.mass.seed",
     "required"),
    ({"radius": {"distribution": "gauss", "mean": 1.0, "std": 0.1, "seed": 1}},
     "granules.radius.distribution", "uniform, normal or lognormal"),
    ({"gap": {"distribution": "uniform", "low": 0.1, "high": 0.0, "seed": 1}}, "granules.gap",
     "greater than low"),
    ({"velocity": {"distribution": "lognormal", "median": 1.0, "sigma": -1, "seed": 1}},
     "granules.velocity.sigma", "greater than 0"),
])
def test_bad_recipes_and_draws_name_the_field(granules, field, words):
    with pytest.raises(gc.SceneError) as err:
        _scene(count=50, **granules)
    assert err.value.field == field and words in err.value.problem


def test_drawn_values_meet_the_scene_checks():
    """Checks across fields see the drawn values: static below a drawn kinetic is refused."""
    with pytest.raises(gc.SceneError, match="granules.friction.static: static threshold"):
        _scene(friction={"kinetic": {"distribution": "uniform", "low": 0.1, "high": 0.2,
                                     "seed": 4}, "static": 0.15})


def test_taper_and_repeat_are_their_formulas():
    """taper: first * ratio**i; repeat: values[i % len(values)]; per granule and per contact."""
    scene = _scene(count=7, radius={"distribution": "taper", "first": 0.5, "ratio": 0.97},
                   mass={"distribution": "repeat", "values": [1.0, 0.25]},
                   gap={"distribution": "repeat", "values": [0.0, 0.1, 0.2]},
                   velocity={"distribution": "taper", "first": -2.0, "ratio": 0.5})
    model = build_model(scene)
    for i in range(7):
        assert model.radius[i] == pytest.approx(0.5 * 0.97 ** i, rel=1e-15)
        assert model.mass[i] == (1.0 if i % 2 == 0 else 0.25)
        assert model.v0[i] == -2.0 / 2 ** i  # exact: powers of two
    assert np.array_equal(-model.d0, [0.0, 0.1, 0.2, 0.0, 0.1, 0.2])
    # mass tapering as radius**3 (one density): ratio 0.97**3
    tapered = _scene(count=50, mass={"distribution": "taper", "first": 1.0, "ratio": 0.97 ** 3})
    assert build_model(tapered).mass[-1] == pytest.approx(0.97 ** 147, rel=1e-13)


@pytest.mark.parametrize("granules, field, words", [
    ({"radius": {"distribution": "taper", "first": 0.5, "ratio": 0.0}}, "granules.radius.ratio",
     "greater than 0"),
    ({"radius": {"distribution": "taper", "first": 0.5, "ratio": -0.9}}, "granules.radius.ratio",
     "greater than 0"),
    ({"mass": {"distribution": "repeat", "values": []}}, "granules.mass.values", "at least 1"),
    ({"mass": {"distribution": "repeat", "values": [1.0, -0.5]}}, "granules.mass",
     "repeat values give -0.5 for granule 1"),
    ({"mass": {"distribution": "taper", "first": -1.0, "ratio": 0.9}}, "granules.mass",
     "values must be > 0"),
    ({"radius": {"distribution": "taper", "first": 1.0, "ratio": 1e-20}}, "granules.radius",
     "change first or ratio"),
    ({"mass": {"distribution": "taper", "first": 1.0, "ratio": 1e20}}, "granules.mass",
     "not finite"),
    ({"mass": {"distribution": "taper", "first": 1.0, "ratio": 1e4}}, "granules.mass",
     "values must be within 1.49e-154 .. 6.7e+153"),
    ({"friction": {"kinetic": {"distribution": "repeat", "values": [0.1, -0.1]}}},
     "granules.friction.kinetic", "values must be >= 0"),
    ({"radius": {"distribution": "geometric", "first": 1.0, "ratio": 0.9}},
     "granules.radius.distribution", "must be taper, repeat, uniform, normal or lognormal"),
    ({"radius": {"distribution": "taper", "first": 1.0}}, "granules.radius.ratio", "required"),
])
def test_bad_taper_and_repeat_name_the_field(granules, field, words):
    """ratio <= 0, an empty pattern, values out of the field's bounds after tapering
    (including the representable range 2^-511 .. 2^511 of masses and radii)."""
    with pytest.raises(gc.SceneError) as err:
        _scene(count=50, **granules)
    assert err.value.field == field and words in err.value.problem, (err.value.field,
                                                                     err.value.problem)


def test_taper_refusal_is_one_line_exit_2(tmp_path, capsys):
    from granular_chain.cli import main
    path = tmp_path / "t.yaml"
    path.write_text("name: t\ngranules: {count: 5, radius: {distribution: taper, first: 0.5, "
                    "ratio: 0}}\n")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "t.yaml" in err[0] and "granules.radius.ratio" in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.yaml"]
