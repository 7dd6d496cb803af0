"""One schedule a run: the budget's steps and frames are the ones the steppers take and
record, and a command-line run works its Schedule out once (steppers/schedule.py)."""

import numpy as np
import pytest

import granular_chain as gc
from conftest import patch_everywhere
from granular_chain.cli import main
from granular_chain.simulate import prepare_run
from granular_chain.steppers import schedule as schedule_module

CHAIN = {"name": "s", "granules": {"count": 6, "velocity": {0: 1.0}},
         "contacts": {"exponent": 2.5}, "run": {"t_end": 2.0}}


def _scene(**changes):
    data = {k: dict(v) if isinstance(v, dict) else v for k, v in CHAIN.items()}
    for path, value in changes.items():
        section, field = path.split(".")
        data.setdefault(section, {})[field] = value
    return gc.scene_from_dict(data)


@pytest.mark.parametrize("changes", [
    {},                                        # about 1000 frames, the default step
    {"run.dt": 0.003},                         # a last shorter step to t_end
    {"run.dt": 0.01, "output.every": 7},
    {"run.dt": 0.01, "output.dt": 0.035},      # the step shortened to fall on frames
    {"output.thermo": 13},
])
def test_verlet_budget_is_what_the_run_takes(changes):
    scene = _scene(**changes)
    ready = prepare_run(scene)
    plan = ready.schedule.plan
    result = gc.simulate(scene, progress=False, model=ready.model, schedule=ready.schedule)
    assert result.status == gc.Status.T_END
    assert result.steps == ready.schedule.steps == plan.total_steps
    assert result.dt == plan.dt
    # the first frame, one every plan.every steps, the last at t_end (the budget counts
    # one more, for a frame at a stop between two of the cadence's)
    assert len(result.t) == ready.schedule.frames - 1
    assert ready.schedule.thermo_every == changes.get(
        "output.thermo", max(1, -(-plan.steps // schedule_module.THERMO_LINES)))


def test_event_default_cadence_of_a_long_chain():
    scene = gc.scene_from_dict({"name": "long", "granules": {"count": 100, "velocity": {0: 1.0}},
                                "contacts": {"exponent": 2.5},
                                "run": {"stepper": "event", "t_end": 3.0}})
    ready = prepare_run(scene)
    assert not ready.schedule.frames_at_events
    assert ready.schedule.cadence_frames == schedule_module.DEFAULT_FRAMES
    result = gc.simulate(scene, progress=False, model=ready.model, schedule=ready.schedule)
    step = 3.0 / schedule_module.DEFAULT_FRAMES  # a frame at every multiple of t_end / 1000
    cadence = step * np.arange(1, schedule_module.DEFAULT_FRAMES)
    assert np.abs(result.t[:, None] - cadence[None, :]).min(axis=0).max() < 1e-12
    assert ready.schedule.frames >= len(result.t)


def test_a_cli_run_plans_once(tmp_path, monkeypatch):
    (tmp_path / "s.yaml").write_text("name: once\ngranules: {count: 6, velocity: {0: 1.0}}\n"
                                     "contacts: {exponent: 2.5}\nrun: {dt: 0.01, t_end: 2.0}\n")
    planned, stepped = [], []
    real_run, real_steps = schedule_module.plan_run, schedule_module.plan_steps

    def counting_run(scene, model, asked):
        planned.append(scene.run.t_end)
        return real_run(scene, model, asked)

    def counting_steps(scene, asked, count):
        stepped.append(scene.run.t_end)
        return real_steps(scene, asked, count)

    patch_everywhere(monkeypatch, "steppers.schedule", "plan_run", counting_run)
    patch_everywhere(monkeypatch, "steppers.schedule", "plan_steps", counting_steps)
    assert main(["run", str(tmp_path / "s.yaml"), "--quiet", "--out",
                 str(tmp_path / "out")]) == 0
    # the scene's, once (the warm-up's two-step copy is a scene of its own: t_end 0.02)
    assert planned.count(2.0) == 1 and stepped.count(2.0) == 1, (planned, stepped)
