"""The classic experiments (granular_chain.classics, ``granular-chain classics``).

Tolerances come from the methods, not from the answers: the event stepper's
series tolerance (rtol 1e-12, so 1e-10 after the error has grown over a run),
Verlet's error measured by halving dt (Richardson, order 2), the Petviashvili
solve's own change between two grids, DOP853's own change between two
tolerances.
"""

import json

import numpy as np
import pytest

from granular_chain.classics import EXPERIMENTS, SCENES, Row, format_table, table_csv
from granular_chain.classics import newtons_cradle as nc
from granular_chain.classics import solitary_wave as sw
from granular_chain.classics.chain_ode import integrate_chain
from granular_chain.classics.hertz_wave import solve_travelling_wave
from granular_chain.cli import main
from granular_chain.rundir import read_marker

#: What the event stepper promises over one of these runs (its series at rtol 1e-12).
EVENT_TOLERANCE = 1e-10


@pytest.fixture(scope="module")
def wave():
    return solve_travelling_wave()


# ----------------------------------------------------------------------------
# the references, checked on their own
# ----------------------------------------------------------------------------
def test_travelling_wave_solves_its_equation_on_two_grids(wave):
    """S = Lambda * S^p to roundoff, and the speed constant the same on a grid of
    half the spacing and a longer period (the solve's error is below 1e-14)."""
    finer = solve_travelling_wave(length=60.0, spacing=1.0 / 128.0)
    assert wave.residual < 1e-14 and finer.residual < 1e-14
    assert abs(wave.speed_constant / finer.speed_constant - 1) < 1e-14
    assert abs(wave.fwhm() / finer.fwhm() - 1) < 1e-12


def test_travelling_wave_obeys_the_lattice_equation(wave):
    """The wave's strain R = c^4 S obeys c^2 R'' = f(R(x+1)) - 2 f(R(x)) + f(R(x-1))
    at sample points (R'' by the spectral derivative), and the velocity W is
    (1/c) times the integral of f(R) over one granule ahead (eq. 4), by quadrature."""
    x = np.linspace(-3.0, 3.0, 13)
    second = wave._series(-wave.xi ** 2 * wave.spectrum, x)
    f = lambda y: np.maximum(wave.profile(y), 0.0) ** 1.5  # noqa: E731
    assert np.max(np.abs(second - (f(x + 1) - 2 * f(x) + f(x - 1)))) < 1e-12
    s = np.linspace(0.3, 1.3, 2001)
    quad = np.trapezoid(f(s), s)
    assert abs(wave.scaled_velocity(0.3)[0] - quad) < 1e-6  # trapezoid's own error


def test_travelling_wave_is_slower_than_the_long_wave_limit(wave):
    """At the same peak velocity the discrete wave is 0.8 % slower than Nesterenko's
    continuum wave."""
    assert 0.99 < wave.speed_constant / sw.NESTERENKO_CONSTANT < 0.995


def test_reference_chain_exchanges_velocities_of_two_equal_balls():
    """Two equal elastic balls swap velocities exactly; DOP853 to its tolerance."""
    sol = integrate_chain(np.ones(2), [0.0, 2.0], [1.0, 0.0], [2.0], t_end=20.0, rtol=3e-14)
    assert np.max(np.abs(sol.v - [0.0, 1.0])) < 1e-12
    assert sol.overlaps[0] < 0


# ----------------------------------------------------------------------------
# solitary_wave
# ----------------------------------------------------------------------------
def test_exact_wave_seeded_event_stepper_keeps_it_to_1e10(wave):
    """The chain seeded with the exact wave: after 20 granules the event stepper's
    state is the shifted wave and its speed the exact constant, to 1e-10."""
    got = sw.seeded_speed(SCENES, wave, "event")
    assert abs(got["constant"] / wave.speed_constant - 1) < EVENT_TOLERANCE
    assert got["misfit"] < EVENT_TOLERANCE


def test_exact_wave_seeded_verlet_within_its_measured_error(wave):
    """Verlet's speed misses the exact constant by its own error, measured by
    halving dt: within 1.5 times the Richardson estimate, and of that size
    (second order: not far below it either)."""
    coarse = sw.seeded_speed(SCENES, wave, "verlet", sw.VERLET_DT)["constant"]
    fine = sw.seeded_speed(SCENES, wave, "verlet", sw.VERLET_DT / 2)["constant"]
    estimate = 4.0 / 3.0 * abs(coarse - fine)
    error = abs(coarse - wave.speed_constant)
    assert 0.5 * estimate < error < 1.5 * estimate


@pytest.mark.slow
def test_solitary_wave_experiment(wave):
    """The whole experiment: the struck wave settles onto the exact one, the v0^(1/5)
    scaling holds to the event stepper's tolerance over four decades, the rebound
    matches DOP853 to 1e-10."""
    out = sw.compute(SCENES)
    rows = {r.quantity + " | " + r.source: r for r in out.rows}
    for r in out.rows:
        if r.quantity.startswith("c/v0^(1/5) at") or r.quantity.startswith("log-log"):
            assert abs(r.rel_diff) < EVENT_TOLERANCE, r
    rebound = rows["striker's rebound v/v0, event | " + sw.REBOUND_SOURCE]
    assert abs(rebound.engine - rebound.reference) < EVENT_TOLERANCE
    assert out.data["rebound_reference_error"] < 1e-11
    struck = out.data["struck"]["event"]
    # the struck wave is the exact wave at its amplitude, to the relaxation left
    assert abs(struck["constant"] / wave.speed_constant - 1) < 1e-6
    assert abs(struck["share"] / struck["share_exact"] - 1) < 1e-5
    assert struck["energy_error"] < 1e-10


# ----------------------------------------------------------------------------
# newtons_cradle
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("count", [3, 5, 10])
def test_cradle_event_stepper_matches_the_independent_solve(count):
    """Every ball's final velocity from the event stepper within 1e-10 v0 of DOP853
    (the median of five runs, whose own error, their spread, is far below that)."""
    ref = nc.reference_velocities(count)
    assert ref["error"] < 0.1 * EVENT_TOLERANCE
    got = nc.final_velocities(SCENES, count, "event")
    assert got["separated"]
    assert np.max(np.abs(np.subtract(got["v"], ref["v"]))) < EVENT_TOLERANCE
    assert abs(got["momentum"] - 1.0) < 1e-14 * count
    assert abs(got["energy"] / 0.5 - 1.0) < EVENT_TOLERANCE


def test_cradle_is_not_one_in_one_out():
    """Hertz contacts: the last ball leaves below v0, the first ones go backwards,
    momentum and energy are kept (the point of Herrmann & Seitz and Hutzler et al.)."""
    v = np.asarray(nc.reference_velocities(5)["v"])
    assert 0.98 < v[-1] < 0.99 and v[0] < -0.07 and v[3] > 0.1
    assert abs(v.sum() - 1.0) < 1e-12 and abs(0.5 * np.sum(v ** 2) - 0.5) < 1e-12


def test_cradle_verlet_within_its_measured_error():
    """Verlet's final velocities (5 balls) miss the reference by its own error,
    measured by halving dt: each within 1.5 times the Richardson estimate plus the
    reference's and the half step's roundoff."""
    ref = np.asarray(nc.reference_velocities(5)["v"])
    coarse = np.asarray(nc.final_velocities(SCENES, 5, "verlet")["v"])
    fine = np.asarray(nc.final_velocities(SCENES, 5, "verlet", nc.VERLET_DT / 2)["v"])
    estimate = 4.0 / 3.0 * np.abs(coarse - fine)
    assert np.all(np.abs(coarse - ref) < 1.5 * estimate + 1e-12)
    assert np.max(np.abs(coarse - ref)) > 0.5 * np.max(estimate)


# ----------------------------------------------------------------------------
# the table and the command
# ----------------------------------------------------------------------------
def test_row_and_table():
    rows = [Row("a", 1.5, 1.0, "closed form"), Row("b", 1e-13, 0.0, "exact")]
    assert rows[0].rel_diff == 0.5 and rows[1].rel_diff == 1e-13
    text = format_table(rows, "title")
    assert text.splitlines()[1].split()[:4] == ["quantity", "engine", "reference", "rel."]
    assert table_csv(rows).splitlines()[0] == "quantity,engine,reference,rel_diff,source"


def test_every_experiment_has_its_scenes():
    assert set(EXPERIMENTS) >= {"solitary_wave", "newtons_cradle"}
    for e in EXPERIMENTS.values():
        assert e.scenes and all((SCENES / s).is_file() for s in e.scenes)


def test_command_lists_the_experiments(capsys):
    assert main(["classics"]) == 0
    out = capsys.readouterr().out
    assert "solitary_wave" in out and "newtons_cradle" in out


@pytest.mark.parametrize("argv, says", [
    (["classics", "nope"], "unknown experiment 'nope'"),
    (["classics", "--out", "x"], "--out needs an experiment"),
    (["classics", "newtons_cradle", "--scenes", "nowhere"], "no such scene file"),
])
def test_command_refuses_bad_input_in_one_line(capsys, tmp_path, monkeypatch, argv, says):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and says in err[0]
    assert not any(tmp_path.iterdir())


def test_command_refuses_a_bad_scene_before_any_work(capsys, tmp_path, monkeypatch):
    """A scene of --scenes that does not validate: one line naming the file and the
    field, exit 2, no folder made."""
    (tmp_path / "scenes").mkdir()
    text = (SCENES / nc.SCENE).read_text().replace("count: 5", "count: -5")
    (tmp_path / "scenes" / nc.SCENE).write_text(text)
    monkeypatch.chdir(tmp_path)
    assert main(["classics", "newtons_cradle", "--scenes", "scenes", "--out", "out"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and nc.SCENE in err[0] and "granules.count" in err[0]
    assert not (tmp_path / "out").exists()


def test_command_writes_through_the_output_claim(capsys, tmp_path, monkeypatch):
    """--out: a new folder, marked as the command's; again into it replaces its own
    files; a file the user put there makes it refuse, changing nothing."""
    pytest.importorskip("matplotlib")
    monkeypatch.chdir(tmp_path)
    assert main(["classics", "newtons_cradle", "--out", "out"]) == 0
    names = {f"classics_newtons_cradle.{e}" for e in ("csv", "json", "png")}
    marker = read_marker(tmp_path / "out")
    assert marker["command"] == "classics" and set(marker["files"]) == names
    assert marker["complete"]
    table = json.loads((tmp_path / "out" / "classics_newtons_cradle.json").read_text())
    assert len(table["rows"]) == sum(n + 6 for n in nc.COUNTS)
    assert main(["classics", "newtons_cradle", "--out", "out"]) == 0
    (tmp_path / "out" / "mine.txt").write_text("the user's")
    capsys.readouterr()
    assert main(["classics", "newtons_cradle", "--out", "out"]) == 2
    assert "mine.txt was not written by the engine" in capsys.readouterr().err


def test_a_failed_experiment_leaves_its_folder_marked_incomplete(tmp_path, monkeypatch, capsys):
    """Two experiments into one --out folder, the second failing: the first's files stay,
    the folder is marked incomplete with the reason, exit status 1."""
    import json

    from granular_chain import classics
    from granular_chain.classics import Experiment, Outcome, Row
    from granular_chain.cli import main

    def fine(scenes):
        return Outcome([Row("x", 1.0, 1.0, "itself")])

    def broken(scenes):
        raise RuntimeError("no answer")

    def figure(outcome, path):
        path.write_bytes(b"png")

    real = dict(classics.EXPERIMENTS)
    first, second = list(real)[:2]
    monkeypatch.setitem(classics.EXPERIMENTS, first,
                        Experiment(first, "fine", (), fine, figure))
    monkeypatch.setitem(classics.EXPERIMENTS, second,
                        Experiment(second, "broken", (), broken, figure))
    out = tmp_path / "out"
    assert main(["classics", first, second, "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert f"classics {second}: no answer" in err
    marker = json.loads((out / "run.json").read_text())
    assert marker["complete"] is False and "no answer" in marker["reason"]
    assert (out / f"classics_{first}.csv").is_file()
    assert not (out / f"classics_{second}.csv").exists()
