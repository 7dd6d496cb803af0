"""One checkpoint schema: both steppers write the same frame (format, stepper, the frame
log's part), checkpoints of the layouts before it are read in its terms, and a stepper
refuses the other's checkpoint."""

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.checkpoint import (CHECKPOINT_FORMAT, check_checkpoint, load_checkpoint,
                                       save_checkpoint, upgrade)

SCENE = {
    "granules": {"count": 12, "radius": 2.0, "velocity": {0: 1.0},
                 "friction": {"kinetic": 2e-3, "static": 3e-3}},
    "contacts": {"exponent": 2.5}, "walls": {"right": {"gap": 0.0, "exponent": 2.5}},
    "output": {"every": 40}}


def _scene(stepper):
    run = {"t_end": 40.0, "stepper": stepper}
    run.update({"dt": 0.013} if stepper == "verlet" else {})
    every = 400 if stepper == "verlet" else 40
    return gc.scene_from_dict({**SCENE, "run": run,
                               "output": {**SCENE["output"], "checkpoint_every": every}})


def _states(stepper):
    """The run's Result and the checkpoints it gave on its way."""
    states = []
    result = gc.simulate(_scene(stepper), checkpoint=states.append)
    assert len(states) >= 2, stepper
    return result, states


def _log_keys(state):
    return {key for key in state if key.startswith("log_")}


def _resumed(stepper, state):
    """The run continued from ``state``, its log keeping the first and the latest
    frame (as ``granular-chain run`` does; Verlet always does so on a resume)."""
    return gc.simulate(_scene(stepper), resume=state, keep_frames=False)


def _same_end(a, b):
    """``a`` (resumed) ends as ``b`` (the whole run): its first and last frames are the
    whole run's, and the ledger's largest error over every frame is the same."""
    assert a.status == b.status and a.t_final == b.t_final
    assert np.array_equal(a.x_final, b.x_final) and np.array_equal(a.v_final, b.v_final)
    assert np.array_equal(a.t[[0, -1]], b.t[[0, -1]]) and a.t.size == 2
    assert np.array_equal(a.x[[0, -1]], b.x[[0, -1]])
    assert a.energy.balance_error == b.energy.balance_error


@pytest.fixture(scope="module")
def runs():
    return {stepper: _states(stepper) for stepper in ("verlet", "event")}


def test_both_steppers_write_the_same_frame(runs):
    verlet, event = runs["verlet"][1][-1], runs["event"][1][-1]
    assert (verlet["format"], verlet["stepper"]) == (CHECKPOINT_FORMAT, "verlet")
    assert (event["format"], event["stepper"]) == (CHECKPOINT_FORMAT, "event")
    assert _log_keys(verlet) == _log_keys(event)
    assert {"log_count", "log_max_balance_error", "log_keep", "log_first_t",
            "log_last_t", "log_first_x", "log_last_x"} <= _log_keys(verlet)
    for state in (verlet, event):
        assert state["log_count"] >= 2 and state["log_first_t"] == 0.0
        assert 0.0 < state["log_last_t"] < 40.0
        assert upgrade(state) is state  # already in the schema's terms


@pytest.mark.parametrize("stepper", ["verlet", "event"])
def test_a_run_resumed_through_the_file_ends_as_the_whole_run(runs, stepper, tmp_path):
    whole, states = runs[stepper]
    save_checkpoint(tmp_path, states[0], _scene(stepper))
    state, scene = load_checkpoint(tmp_path)
    assert scene["run"]["stepper"] == stepper
    _same_end(_resumed(stepper, state), whole)


def _as_before(state):
    """A format-4 Verlet state in the layout Verlet checkpoints had before: no format
    or stepper, the frame log as frames, max_error and first_<field>, no latest."""
    old = {}
    for key, value in state.items():
        if key in ("format", "stepper", "log_keep") or key.startswith("log_last_"):
            continue
        if key == "log_count":
            old["frames"] = value
        elif key == "log_max_balance_error":
            old["max_error"] = value
        elif key.startswith("log_first_"):
            old[key[len("log_"):]] = value
        else:
            old[key] = value
    return old


def test_a_verlet_checkpoint_of_the_layout_before_is_continued(runs, tmp_path):
    whole, states = runs["verlet"]
    old = _as_before(states[1])
    assert "frames" in old and "format" not in old and "log_count" not in old
    save_checkpoint(tmp_path, old, _scene("verlet"))
    state, _ = load_checkpoint(tmp_path)
    assert state["stepper"] == "verlet" and state["format"] == CHECKPOINT_FORMAT
    assert int(state["log_count"]) == int(states[1]["log_count"])
    _same_end(_resumed("verlet", state), whole)


def test_an_event_checkpoint_of_format_3_is_continued(runs, tmp_path):
    whole, states = runs["event"]
    old = {key: value for key, value in states[1].items() if key != "stepper"}
    old["format"] = 3
    save_checkpoint(tmp_path, old, _scene("event"))
    state, _ = load_checkpoint(tmp_path)
    assert state["stepper"] == "event" and state["format"] == CHECKPOINT_FORMAT
    _same_end(_resumed("event", state), whole)


def test_a_stepper_refuses_the_other_steppers_checkpoint(runs):
    verlet, event = runs["verlet"][1][0], runs["event"][1][0]
    with pytest.raises(ValueError, match="verlet stepper .* stepper event"):
        gc.simulate(_scene("verlet"), resume=event)
    with pytest.raises(ValueError, match="event stepper .* stepper verlet"):
        gc.simulate(_scene("event"), resume=verlet)
    with pytest.raises(ValueError, match="format 3"):
        check_checkpoint({**verlet, "format": 3}, "verlet")


def test_a_state_of_no_layout_known_is_refused_and_an_old_one_in_memory_is_read(runs):
    whole, states = runs["event"]
    older = {key: value for key, value in states[1].items() if key != "stepper"}
    with pytest.raises(ValueError, match="format 2"):  # (an event format before 3)
        gc.simulate(_scene("event"), resume={**older, "format": 2})
    # a format-3 state held in memory, never written to a file, continues as well
    _same_end(_resumed("event", {**older, "format": 3}), whole)
    verlet_whole, verlet_states = runs["verlet"]
    _same_end(_resumed("verlet", _as_before(verlet_states[1])), verlet_whole)
