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


def test_exponents_near_one_at_the_scene_step_are_inaccurate_exit_1(tmp_path, capsys):
    """chain_walls.yaml with every exponent 1.001: the ledger misses the default
    run.energy_tolerance (error 0.68), so the run is inaccurate, exit 1, and says so
    in summary.json."""
    out = tmp_path / "run"
    args = ["run", str(SCENES / "chain_walls.yaml"), "--out", str(out), "--quiet",
            "--no-trajectory"]
    for item in NEAR_ONE:
        args += ["--set", item]
    assert main(args) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "inaccurate"
    assert summary["energy"]["balance_error"] > 0.5
    assert "run.energy_tolerance 0.01" in summary["message"]


def test_default_energy_tolerance_is_the_schema_default():
    from granular_chain.scene import DEFAULT_ENERGY_TOLERANCE, Run

    assert Run().energy_tolerance == DEFAULT_ENERGY_TOLERANCE == 0.01
    assert "0.01" in Run.model_fields["energy_tolerance"].description


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
    """With run.accept_inaccurate_dt the run goes; its 6.4 % energy error misses the
    default tolerance: inaccurate, exit 1."""
    out = tmp_path / "run"
    assert main(["run", str(SCENES / "two_granules.yaml"), "--out", str(out), "--quiet",
                 "--set", "run.dt=0.5", "--set", "run.accept_inaccurate_dt=true"]) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "inaccurate"
    assert 0.05 < summary["energy"]["balance_error"] < 0.08


def test_dt_at_the_accuracy_bound_runs():
    from granular_chain.model import build_model
    from granular_chain.steppers.verlet.driver import accuracy_bound

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
    assert c.outcome.name == "backscatter_and_propagation" or c.v1 < 0
    assert c.t_separation == pytest.approx(exact.contact_time, rel=1e-12)


# --- the event stepper's valid range of n -------------------------------------

def test_event_stepper_refuses_exponents_above_its_range(tmp_path, capsys):
    from granular_chain.steppers.events import MAX_EXPONENT

    n = 20.0
    assert n > MAX_EXPONENT
    with pytest.raises(gc.SimulationError, match=r"contacts.exponent: .* n <= "):
        collide(n, stepper="event")
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
    from granular_chain.steppers.verlet.driver import NEAR_ONE_STEPS_PER_PERIOD

    c = collide(1.01, stepper="verlet")
    assert c.outcome.name == "propagation_only"
    T = c.result.model.shortest_period()
    assert c.result.dt == pytest.approx(T / NEAR_ONE_STEPS_PER_PERIOD, rel=1e-9)
    assert abs(c.v1) < 2e-3 and c.result.energy.balance_error < 5e-3


# --- VTK per-contact forces ---------------------------------------------------

def test_vtk_contact_forces_add_up_to_the_net_force_damped_and_driven(tmp_path):
    """Dashpots and a sine-driven wall, under gravity: on every granule of every
    frame, force_(i-1) - force_i (walls at the ends) == net_force - body force."""
    import pyvista as pv

    from granular_chain.writers.vtk import write_vtk

    scene = gc.scene_from_dict({
        "name": "driven",
        "granules": {"count": 6, "radius": 0.5, "gap": 0.0, "velocity": {0: 0.3}},
        "contacts": {"exponent": 2.5, "damping": {"model": "linear", "coefficient": 0.3}},
        "walls": {"left": {"gap": 0.0, "exponent": 2.5,
                           "motion": {"sine": {"amplitude": 0.05, "frequency": 0.3}}},
                  "right": {"gap": 0.0, "exponent": 2.5}},
        "body_force": {"g": 0.05, "direction": -1},
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
