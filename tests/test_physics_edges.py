"""Physics edges: no wrong answer reported as success, and each stepper's valid range.

Each test names the input that was reported as a success with a wrong answer, and
what the engine says about it instead (docs/robustness.md, "Valid range of each
stepper").
"""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.cli import main
from granular_chain.two_granules import collide

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "scenarios"


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


# --- the default energy tolerance ---------------------------------------------

NEAR_ONE = ["contacts.exponent=1.001", "walls.left.exponent=1.001",
            "walls.right.exponent=1.001"]


def test_exponents_near_one_are_refused_or_inaccurate(tmp_path, capsys):
    """chain_walls.yaml with every exponent 1.001. At its dt = 0.01: above the accuracy
    bound (T/50 = 0.00643), so refused, exit 2, nothing on disk. At the engine's default
    step (T/800 = 4.0e-4) the run reaches t_end with a ledger error of 0.046 (0.51 at
    T/200), above the default run.energy_tolerance: inaccurate, exit 1, and
    summary.json says so."""
    scene = str(SCENES / "chain_walls.yaml")
    sets = [a for item in NEAR_ONE for a in ("--set", item)]
    refused = tmp_path / "refused"
    assert main(["run", scene, "--out", str(refused), *sets]) == 2
    err = _one_line(capsys)
    assert "run.dt: 0.01 is above the accuracy bound 0.00643" in err
    assert not refused.exists()
    out = tmp_path / "run"
    assert main(["run", scene, "--out", str(out), "--quiet", "--no-trajectory", *sets,
                 "--set", "run.dt=null"]) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "inaccurate"
    error = float(re.search(r"energy ledger's error (\S+) ", summary["message"]).group(1))
    assert 0.01 < error < 0.1  # (the largest over the run; summary's is the last frame's)
    assert "exceeds run.energy_tolerance 0.01" in summary["message"]


def test_default_energy_tolerance_is_the_schema_default():
    from granular_chain.scene import DEFAULT_ENERGY_TOLERANCE, RunEvent, RunVerlet

    for run in (RunVerlet, RunEvent):
        assert run().energy_tolerance == DEFAULT_ENERGY_TOLERANCE == 0.01
        assert "0.01" in run.model_fields["energy_tolerance"].description


# --- run.dt against the accuracy bound ----------------------------------------

def test_dt_above_the_accuracy_bound_is_refused_with_the_bound(tmp_path, capsys):
    """two_granules.yaml at dt 0.5 (bound 0.0889): one line, exit 2, nothing on disk."""
    out = tmp_path / "run"
    scene = SCENES / "two_granules.yaml"
    assert main(["run", str(scene), "--out", str(out), "--set", "run.dt=0.5"]) == 2
    err = _one_line(capsys)
    assert err.startswith("granular-chain: ") and str(scene) in err
    assert "run.dt: 0.5 is above the accuracy bound 0.0889" in err
    assert "run.accept_inaccurate_dt: true" in err
    assert list(tmp_path.iterdir()) == []


def test_accepted_inaccurate_dt_runs_and_its_ledger_judges_it(tmp_path, capsys):
    """With run.accept_inaccurate_dt the run goes; its energy ledger misses the
    default tolerance: inaccurate, exit 1."""
    out = tmp_path / "run"
    assert main(["run", str(SCENES / "two_granules.yaml"), "--out", str(out), "--quiet",
                 "--set", "run.dt=0.5", "--set", "run.accept_inaccurate_dt=true"]) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "inaccurate", summary["message"]
    assert "exceeds run.energy_tolerance 0.01" in summary["message"]


def test_dt_at_the_accuracy_bound_runs():
    from granular_chain.model import build_model
    from granular_chain.steppers.verlet.timestep import accuracy_bound

    scene = gc.load_scene(SCENES / "two_granules.yaml")
    bound, why = accuracy_bound(build_model(scene))
    assert bound == pytest.approx(0.0889, rel=1e-3) and "1/50" in why
    r = gc.simulate(gc.load_scene(SCENES / "two_granules.yaml", [f"run.dt={bound!r}"]),
                    progress=False)
    assert r.status == gc.Status.SEPARATED and r.energy.balance_error < 0.01


def test_accept_inaccurate_dt_belongs_to_verlet():
    with pytest.raises(gc.SceneError, match="run.accept_inaccurate_dt"):
        gc.scene_from_dict({"granules": {"count": 2, "velocity": [1, 0]},
                            "run": {"stepper": "event", "accept_inaccurate_dt": True}})


# --- tensile dashpot at damping ratio >= 1 -----------------------------------

@pytest.mark.parametrize("stepper", ["event", "verlet"])
def test_tensile_overdamped_dashpot_never_separates(stepper):
    """c = 2 (damping ratio 1.41): restitution.linear_dashpot says the overlap never
    returns to 0; both steppers name the outcome no_separation."""
    c = collide(2, damping={"model": "linear", "coefficient": 2.0}, tensile=True,
                stepper=stepper, t_max=200)
    assert c.outcome.name == "no_separation" and c.t_separation == math.inf
    assert "never opens" in c.message
    assert c.v1 == pytest.approx(0.5, abs=1e-6) and c.v2 == pytest.approx(0.5, abs=1e-6)


def test_tensile_underdamped_dashpot_still_separates():
    from granular_chain.restitution import linear_dashpot

    c = collide(2, damping={"model": "linear", "coefficient": 1.2}, tensile=True,
                stepper="event", t_max=200)
    exact = linear_dashpot(1.2, 1.0, 0.5, tensile=True)
    assert c.outcome.name == "both_forward"  # v = 1/2 -+ e/2, e = 0.0065
    assert c.v2 - c.v1 == pytest.approx(exact.e, rel=1e-12)
    assert c.t_separation == pytest.approx(exact.contact_time, rel=1e-12)


#: a plain scene of the two-granule collision with a tensile linear dashpot
DASHPOT_SCENE = """\
name: dashpot
granules: {count: 2, mass: 1.0, radius: 1.0, gap: 0.0, velocity: [1.0, 0.0]}
contacts:
  exponent: 2.0
  stiffness: 1.0
  damping: {model: linear, coefficient: COEFFICIENT}
  tensile: true
run: {stepper: STEPPER, t_end: 200.0, stop: separation}
output: {every: 100}
"""


def _dashpot_run(tmp_path, capsys, stepper, coefficient):
    scene = tmp_path / f"{stepper}_{coefficient}.yaml"
    scene.write_text(DASHPOT_SCENE.replace("STEPPER", stepper)
                     .replace("COEFFICIENT", repr(coefficient)))
    out = tmp_path / f"out_{stepper}_{coefficient}"
    code = main(["run", str(scene), "--out", str(out)])
    return code, capsys.readouterr().out, json.loads((out / "summary.json").read_text())


@pytest.mark.parametrize("stepper", ["event", "verlet"])
def test_plain_run_of_a_tensile_overdamped_dashpot_reaches_t_end(tmp_path, capsys, stepper):
    """granular-chain run of the two-granule scene with contacts.damping linear c = 2
    (damping ratio 1.41), tensile, stop: separation. The closed form never opens; the
    steppers' overlap crosses zero only once it has decayed to roundoff (event stepper
    t = 58.09, relative speed 4.4e-16; Verlet t = 64, 3.1e-13), which is not a separation:
    the run goes on to t_end and says why."""
    from granular_chain.restitution import linear_dashpot

    assert not linear_dashpot(2.0, 1.0, 0.5, tensile=True).ended
    code, said, summary = _dashpot_run(tmp_path, capsys, stepper, 2.0)
    assert code == 0 and summary["status"] == "t_end"
    assert "separated:" not in said and "\nt_end: reached t_end = 200 after" in said
    assert "contact 0 never opened: its overlap decayed through roundoff" in said


@pytest.mark.parametrize("stepper", ["event", "verlet"])
def test_plain_run_of_a_tensile_underdamped_dashpot_separates_on_time(tmp_path, capsys, stepper):
    """Control: c = 1.2 (damping ratio 0.85) opens at the closed form's contact time 4.19:
    exactly for the event stepper (1.6e-15), to the Verlet step's second order at its
    default dt = m_eff/(40 c) = 0.0104 (measured 2.4e-5 relative)."""
    from granular_chain.restitution import linear_dashpot

    exact = linear_dashpot(1.2, 1.0, 0.5, tensile=True)
    code, said, summary = _dashpot_run(tmp_path, capsys, stepper, 1.2)
    assert code == 0 and summary["status"] == "separated"
    rel = 1e-12 if stepper == "event" else 1e-4
    assert summary["t_final"] == pytest.approx(exact.contact_time, rel=rel)


def test_verlet_collide_of_a_tensile_overdamped_dashpot_ends_at_t_max():
    """collide(..., stepper="verlet", t_max=200): the engine itself goes on to t_max
    (collide no longer overrides the run's stop), and the message names the reason."""
    c = collide(2, damping={"model": "linear", "coefficient": 2.0}, tensile=True,
                stepper="verlet", t_max=200)
    assert c.result.status == gc.Status.T_END and c.result.t_final == 200.0
    assert "decayed through roundoff" in c.message and "never opens" in c.message


def test_verlet_tensile_underdamped_dashpot_separates_on_time():
    from granular_chain.restitution import linear_dashpot

    c = collide(2, damping={"model": "linear", "coefficient": 1.2}, tensile=True,
                stepper="verlet", t_max=200)
    exact = linear_dashpot(1.2, 1.0, 0.5, tensile=True)
    assert c.result.status == gc.Status.SEPARATED  # (2.4e-5 at dt = 0.0104)
    assert c.t_separation == pytest.approx(exact.contact_time, rel=1e-4)


def test_opening_below_roundoff_is_not_resolved():
    from granular_chain.steppers.opening import ROUNDOFF_FACTOR, opening_floor, resolved_opening

    event = opening_floor((0.5, 0.5))
    assert event == 0.5 * 2.0 ** -52 and not resolved_opening(4.4e-16, event)
    assert resolved_opening(0.0065, event)
    verlet = opening_floor((0.5, 0.5), (0.0, 33.0, 35.0), 1 / 160)
    assert verlet == pytest.approx(0.5 * 2.0 ** -52 + math.ulp(35.0) * 160)
    assert not resolved_opening(3.1e-13, verlet)
    assert resolved_opening(1.01 * ROUNDOFF_FACTOR * verlet, verlet)


# --- the event stepper's valid range of n -------------------------------------

@pytest.mark.parametrize("n", [20.0, 80.0])
def test_event_stepper_refuses_exponents_above_its_range(tmp_path, capsys, n):
    with pytest.raises(gc.SimulationError, match=r"contacts.exponent: .* n <= "):
        collide(n, stepper="event")
    from granular_chain.steppers.events import MAX_EXPONENT

    assert n > MAX_EXPONENT
    scene = tmp_path / "high.yaml"
    scene.write_text(f"granules: {{count: 2, velocity: [1, 0]}}\ncontacts: {{exponent: {n}}}\n"
                     "run: {stepper: event, t_end: 5}\n")
    out = tmp_path / "run"
    assert main(["run", str(scene), "--out", str(out)]) == 2
    err = _one_line(capsys)
    assert "contacts.exponent" in err and f"n <= {MAX_EXPONENT:g}" in err
    assert not out.exists()


def test_event_stepper_accurate_at_the_top_of_its_range():
    from granular_chain.steppers.events import MAX_EXPONENT

    c = collide(MAX_EXPONENT, stepper="event")
    r = c.result
    assert r.status == gc.Status.SEPARATED
    assert r.energy.balance_error <= r.info["event_stepper"]["ledger_tolerance"]
    assert abs(c.v1) < 1e-9 and abs(c.v2 - 1) < 1e-9


def test_verlet_takes_large_exponents():
    c = collide(40, stepper="verlet")
    assert c.outcome.name == "propagation_only" and c.result.energy.balance_error < 1e-3


# --- Verlet near n = 1 --------------------------------------------------------

def test_verlet_near_one_gives_the_exact_outcome_at_its_default_step():
    """Equal masses, elastic: the exact answer is v1 = 0, v2 = 1 (propagation only)."""
    c = collide(1.01, stepper="verlet")
    assert c.outcome.name == "propagation_only"
    from granular_chain.steppers.verlet.timestep import NEAR_ONE_STEPS_PER_PERIOD

    T = c.result.model.shortest_period()
    # (shortened by at most one step in t_max / dt = 4.97e5, to end exactly at t_max)
    assert c.result.dt == pytest.approx(T / NEAR_ONE_STEPS_PER_PERIOD, rel=1e-5)
    assert abs(c.v1) < 2e-3 and c.result.energy.balance_error < 5e-3


# --- VTK per-contact forces ---------------------------------------------------

@pytest.mark.parametrize("n, model", [(2.0, "linear"), (2.5, "viscoelastic")])
def test_vtk_contact_forces_add_up_to_the_net_force_damped_and_driven(tmp_path, n, model):
    """Dashpots (linear at n = 2, whose force jumps as a contact closes; viscoelastic at
    n = 5/2) and a sine-driven wall, under gravity: on every granule of every frame,
    force_(i-1) - force_i (walls at the ends) == net_force - body force."""
    import pyvista as pv

    from granular_chain.writers.vtk import write_vtk

    scene = gc.scene_from_dict({
        "name": "driven",
        "granules": {"count": 6, "radius": 1.0, "gap": 0.0, "velocity": {0: 0.3}},
        "contacts": {"exponent": n, "damping": {"model": model, "coefficient": 0.3}},
        "walls": {"left": {"gap": 0.0, "exponent": n,
                           "motion": {"sine": {"amplitude": 0.05, "frequency": 0.3}}},
                  "right": {"gap": 0.0, "exponent": n}},
        "body_force": {"g": 0.01, "direction": -1},
        "run": {"t_end": 12.0}, "output": {"dt": 0.5}})
    r = gc.simulate(scene, progress=False)
    assert r.success
    write_vtk(r, tmp_path, scene)
    body = np.asarray(r.model.body_force, dtype=float)
    worst = 0.0
    for q, path in enumerate(sorted((tmp_path / "vtk").glob("frame_*.vtp"))):
        m = pv.read(path)
        F = np.concatenate(([m.field_data["wall_force"][0]], m.cell_data["force"],
                            [m.field_data["wall_force"][1]]))
        net = np.asarray(m.point_data["net_force"])
        scale = max(np.abs(F).max(), 1e-300)
        worst = max(worst, np.abs(F[:-1] - F[1:] - (net - body)).max() / scale)
    assert q == r.t.size - 1
    assert worst < 1e-12


# --- Newton's cradle: what holds today ----------------------------------------

@pytest.mark.parametrize("count", [2, 5, 10])
@pytest.mark.parametrize("n", [2.0, 2.5])
def test_newtons_cradle_agrees_between_steppers(count, n):
    """count touching equal balls, the first struck at v = 1: the event stepper and
    Verlet at its default step end with the same velocities, both ledgers tight."""
    def run(stepper):
        return gc.simulate(gc.scene_from_dict({
            "name": "cradle", "granules": {"count": count, "radius": 0.5, "gap": 0.0,
                                           "velocity": {0: 1.0}},
            "contacts": {"exponent": n},
            "run": {"stepper": stepper, "t_end": 4.0 + 2.0 * count},
            "output": {"trajectory": False}}), progress=False)

    event, verlet = run("event"), run("verlet")
    assert event.status == verlet.status == gc.Status.T_END
    assert event.energy.balance_error <= 1e-12  # (measured up to 5.6e-13)
    assert verlet.energy.balance_error <= 2e-4  # O(dt^2) at T/200 (measured up to 1.23e-4)
    assert np.abs(event.v_final - verlet.v_final).max() < 1e-3
    assert event.v_final.sum() == pytest.approx(1.0, abs=1e-13)  # momentum


# --- docs/robustness.md tables against the code -------------------------------

def _table_after(text: str, title: str) -> list[list[str]]:
    """Rows (cells stripped) of the markdown table that follows the line ``title``."""
    lines = text.split(title, 1)[1].strip().splitlines()
    rows = []
    for line in lines:
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in line.strip().strip("|").split("|")])
    return rows[2:]  # (header and rule)


def test_robustness_tables_match_the_code():
    from granular_chain.scene import DEFAULT_ENERGY_TOLERANCE
    from granular_chain.steppers.events import MAX_EXPONENT, MIN_EXPONENT
    from granular_chain.steppers.verlet import timestep as driver

    text = (ROOT / "docs" / "robustness.md").read_text()
    section = text.split("## Valid range of each stepper", 1)[1].split("\n## ", 1)[0]
    ranges = {row[0]: row for row in _table_after(section, "Valid range of each stepper:")}
    assert set(ranges) == {"verlet", "event"}
    verlet, event = ranges["verlet"], ranges["event"]
    assert verlet[1].startswith("n > 1") and f"n = {driver.NEAR_ONE_EXPONENT:g}" in verlet[1]
    assert f"T/{driver.ACCURACY_STEPS_PER_PERIOD}" in verlet[2]
    assert f"m_eff/({driver.ACCURACY_STEPS_PER_RELAXATION} c)" in verlet[2]
    assert "T/pi" in verlet[2] and math.isclose(driver.STABILITY_FRACTION, 1 / math.pi)
    assert re.fullmatch(
        rf"T/{driver._DEFAULT_STEPS_PER_PERIOD}; T/{driver.NEAR_ONE_STEPS_PER_PERIOD} when an "
        rf"exponent is below {driver.NEAR_ONE_EXPONENT:g}; at most t_end/100", verlet[3])
    assert event[1] == f"{MIN_EXPONENT:g} <= n <= {MAX_EXPONENT:g}"
    refusals = _table_after(section, "Refused or judged:")
    joined = "\n".join(" | ".join(r) for r in refusals)
    assert f"above {MAX_EXPONENT:g} or below {MIN_EXPONENT:g}" in joined
    assert f"`run.energy_tolerance` (default {DEFAULT_ENERGY_TOLERANCE:g})" in joined
    assert {r[-1] for r in refusals} == {"2", "1", "none"}
