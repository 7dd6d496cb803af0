"""Staged runs (run.stages): one run equals the runs made by hand, stage by stage.

scenarios/settle_strike.yaml: a column of 8 Hertz spheres settles on a wall under
gravity (stage 0, t = 0 .. 400), then its top granule is struck (stage 1: v_7 set to
-0.3) and the run goes on to t = 460. Both steppers (the event stepper with frames
every 2 time units).
"""

import copy
import json
import signal
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml

from granular_chain import Status, scene_from_dict, simulate
from granular_chain.cli.main import main
from granular_chain.scene import read_scene_data

from conftest import patch_everywhere

SCENE = Path(__file__).resolve().parents[1] / "scenarios" / "settle_strike.yaml"
STRIKE = -0.3  # the strike stage's velocity of granule 7


def _data(stepper="verlet"):
    data = read_scene_data(SCENE)
    if stepper == "event":
        data["run"]["stepper"] = "event"
        del data["run"]["dt"]
        data["output"] = {"dt": 2.0}
    return data


def _unstaged(data, t_end):
    """The scene's data without stages, run to ``t_end``."""
    data = copy.deepcopy(data)
    del data["run"]["stages"]
    data["run"]["t_end"] = t_end
    return data


@pytest.fixture(scope="module", params=["verlet", pytest.param("event", marks=pytest.mark.slow)])
def stepper(request):
    return request.param


@pytest.fixture(scope="module")
def staged(stepper):
    return simulate(scene_from_dict(_data(stepper), str(SCENE)), progress=False)


@pytest.fixture(scope="module")
def by_hand(stepper, tmp_path_factory):
    """The two runs a user makes without stages: settle to t = 400; then from its
    final state (an .npz written by hand, granule 7's velocity set), the wall gap
    measured from that state (the wall stays at x = 0), run for 60."""
    first = simulate(scene_from_dict(_unstaged(_data(stepper), 400.0)), progress=False)
    v = first.v_final.copy()
    v[7] = STRIKE
    npz = tmp_path_factory.mktemp("by_hand") / "settled.npz"
    np.savez(npz, x=first.x_final, v=v)
    data = _unstaged(_data(stepper), 60.0)
    g = data["granules"]
    del g["gap"], g["velocity"]
    g["state"] = {"file": str(npz)}
    data["walls"]["left"]["gap"] = float(first.x_final[0] - 1.0)  # radius 1, wall at 0
    second = simulate(scene_from_dict(data), progress=False)
    return first, second


def test_staged_run_equals_the_two_runs_by_hand_bit_for_bit(stepper, staged, by_hand):
    first, second = by_hand
    assert staged.status == Status.T_END and first.status == second.status == Status.T_END
    assert staged.t_final == 460.0 and staged.steps == first.steps + second.steps
    assert staged.stepper == stepper and (stepper == "event" or staged.steps == 46000)
    boundary = int(np.flatnonzero(staged.t == 400.0)[0])
    assert np.array_equal(staged.x[boundary], first.x_final)
    assert np.array_equal(staged.v[boundary], first.v_final)  # the frame before the strike
    assert np.array_equal(staged.x_final, second.x_final)
    assert np.array_equal(staged.v_final, second.v_final)
    # the second stage's frames are the second run's, on the run's clock
    assert np.array_equal(staged.x[boundary + 1:], second.x[1:])
    assert np.array_equal(staged.t[boundary + 1:], 400.0 + second.t[1:])
    assert staged.x_final[7] < first.x_final[7]  # (the strike moved the top granule)


def test_ledger_runs_on_across_the_strike(stepper, staged, by_hand):
    """The strike's kinetic energy enters as stage_work; the run's balance after it is
    the second run's own plus the balance at the strike, to roundoff."""
    first, second = by_hand
    led = staged.energy
    boundary = int(np.flatnonzero(staged.t == 400.0)[0])
    put_in = 0.5 * (STRIKE ** 2 - first.v_final[7] ** 2)  # m = 1
    assert led.stage_work[boundary] == 0.0
    assert led.stage_work[-1] == pytest.approx(put_in, rel=1e-12)
    assert put_in > 1000 * led.kinetic[boundary]  # (settled: the strike dominates)
    assert np.array_equal(led.body_work[:boundary + 1], first.energy.body_work)
    after = led.balance[boundary + 1:]
    expected = second.energy.balance[1:] + led.balance[boundary]
    roundoff = np.max(np.abs(after - expected)) / led.scale
    assert roundoff < 1e-14, roundoff
    # the run's own error: Verlet's of the two stages (dt = 0.01), the event stepper's
    # to roundoff
    assert led.balance_error < (1e-5 if stepper == "verlet" else 1e-13), led.balance_error
    assert abs(led.balance[boundary]) / led.scale < (1e-6 if stepper == "verlet" else 1e-14)
    stages = staged.info["stages"]
    assert [(s["name"], s["t_start"], s["t_end"]) for s in stages] == [
        ("settle", 0.0, 400.0), ("strike", 400.0, 460.0)]
    assert stages[1]["kinetic_after"] - stages[1]["kinetic_before"] == led.stage_work[-1]


def test_cli_writes_one_trajectory_with_the_stage_of_each_frame(tmp_path):
    out = tmp_path / "run"
    assert main(["run", str(SCENE), "--out", str(out), "--quiet", "--csv"]) == 0
    with h5py.File(out / "trajectory.h5") as h5:
        t, stage, work = h5["time"][...], h5["stage"][...], h5["stage_work"][...]
    assert np.all(np.diff(t) > 0) and t[-1] == 460.0
    assert np.array_equal(stage, (t > 400.0).astype(stage.dtype))
    assert np.all(work[t <= 400.0] == 0.0) and np.all(work[t > 400.0] > 0.0)
    summary = json.loads((out / "summary.json").read_text())
    assert [s["t_end"] for s in summary["stages"]] == [400.0, 460.0]
    assert summary["energy"]["stage_work"] == work[-1]
    assert "stage_work" in (out / "energy.csv").read_text().splitlines()[0].split(",")


def _stage(data, k, **fields):
    data["run"]["stages"][k].update(fields)
    return data


def _set(data, section, **fields):
    data[section].update(fields)
    return data


@pytest.mark.parametrize("change, field, words", [
    (lambda d: _stage(d, 1, t_end=400), "run.stages[1].t_end", "increase strictly"),
    (lambda d: _set(d, "run", t_end=500), "run.t_end", "last stage ends at 460"),
    (lambda d: _stage(d, 1, velocity={8: 1.0}), "run.stages[1].velocity[8]", "out of range"),
    (lambda d: _stage(d, 1, velocity_add={-1: 1.0}), "run.stages[1].velocity_add[-1]",
     "out of range"),
    (lambda d: _stage(d, 1, body_force={"g": 0.02}), "run.stages[1].body_force",
     "known fields: t_end, name, velocity, velocity_add"),
    (lambda d: _stage(d, 0, velocity={7: 1.0}), "run.stages[0].velocity",
     "granules.velocity"),
    (lambda d: _set(d, "run", stop="rest"), "run.stop", "not available with run.stages"),
    (lambda d: _set(d, "output", checkpoint_every=100), "output.checkpoint_every",
     "not available with run.stages"),
])
def test_bad_stages_are_refused_in_one_line(tmp_path, capsys, change, field, words):
    scene = tmp_path / "bad.yaml"
    scene.write_text(yaml.safe_dump(change(_data())))
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"bad.yaml: {field}: " in err and words in err, err
    assert not out.exists()


def test_run_t_end_may_be_given_equal_to_the_last_stage():
    data = _data()
    data["run"]["t_end"] = 460
    assert scene_from_dict(data).run.t_end == 460.0
    assert scene_from_dict(_data()).run.t_end == 460.0  # left out: the last stage's


def test_restart_of_a_staged_scene_is_refused(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    assert main(["run", str(SCENE), "--restart", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "run.stages" in err and "not continued" in err


class _InterruptAt:
    """A frame writer that raises SIGINT at the first frame past time ``t``."""

    def __init__(self, t):
        self.t, self.sent = t, False

    def write_frame(self, frame):
        if frame.t > self.t and not self.sent:
            self.sent = True
            signal.raise_signal(signal.SIGINT)

    def close(self, result):
        pass


def test_a_signal_in_the_second_stage_ends_the_run_there(monkeypatch):
    # The writer raises the signal on the stepping thread (writers inline, no thread of
    # their own): a writers' thread may reach the frame only after the last stage has
    # ended on a loaded machine, when the run's signal handlers are gone (the signal
    # then ends the test process). The staged run makes its log in granular_chain.stages:
    # every module's binding is replaced.
    from granular_chain.frames import FrameLog

    inline = []  # the writers of each log made inline

    class InlineLog(FrameLog):
        def __init__(self, writers=(), keep=True, background=False):
            inline.append(list(writers))
            super().__init__(writers, keep=keep, background=False)

    patch_everywhere(monkeypatch, "frames", "FrameLog", InlineLog)
    scene = scene_from_dict(_data(), str(SCENE))
    interrupter = _InterruptAt(402.0)
    r = simulate(scene, progress=False, writers=[interrupter], keep_frames=False)
    # the log that calls the interrupting writer (the staged run's own) was made inline
    assert any(w is interrupter for writers in inline for w in writers)
    assert r.status == Status.INTERRUPTED
    assert 402.0 < r.t_final < 460.0 and r.t[-1] == r.t_final
    stages = r.info["stages"]
    assert [s["status"] for s in stages] == ["t_end", "interrupted"]
    assert stages[1]["t_end"] == r.t_final and "stage 1 (strike" in r.message
