"""The Verlet event log (output.events): every contact opening/closing (walls
included) and every stop/slip, with the step at whose end it was seen.

Checked: the trajectory, ledger and counts with the log are bit-identical to the
run without it (the sweep and the Coulomb passes, walls included); the logged
events of each kind add up to the counts; the contact events are exactly the
sign changes of the overlaps read off a frame at every step (an independent
reference); a log too small for the run drains and resumes without changing
anything; the half kicks the driver adds at the end (and before a shortened last
step) are logged too; events.csv is written from them.
"""

import csv
import importlib
from collections import Counter

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.model import build_model
from granular_chain.steppers import verlet
from granular_chain.writers.tables import write_events_csv

sim = importlib.import_module("granular_chain.simulate")

DT = 0.01
FRICTION = {"frictionless": {}, "coulomb+viscous": {"kinetic": 1e-3, "static": 2e-3,
                                                    "viscous": 1e-2},
            "coulomb": {"kinetic": 1e-3, "static": 2e-3}, "viscous": {"viscous": 1e-2}}


def _scene(feat, events, N=40, steps=2500, every=500, walls=True, t_end=None, stop="t_end"):
    d = {"name": "ev", "granules": {"count": N, "mass": 1.0, "radius": 0.5, "gap": 0.01,
                                    "velocity": {0: 1.0}, "friction": FRICTION[feat]},
         "contacts": {"exponent": 2.5, "stiffness": 1.0},
         "run": {"stepper": "verlet", "dt": DT, "t_end": t_end or steps * DT, "stop": stop},
         "output": {"every": every, "trajectory": False, "events": events}}
    if walls:
        d["walls"] = {"left": {"gap": 0.01, "exponent": 2.5, "stiffness": 1.0},
                      "right": {"gap": 0.01, "exponent": 2.5, "stiffness": 1.0}}
    return gc.scene_from_dict(d)


def _run(scene, seed=3, speed=0.1):
    model = build_model(scene)
    # random velocities: contacts open and close, granules stick, slip and reverse
    model.v0[:] = np.random.default_rng(seed).uniform(-speed, speed, model.count)
    return sim._simulate_verlet(scene, model, False)


def _same_run(a, b):
    for q in ("t", "x", "v", "f"):
        assert np.array_equal(getattr(a, q), getattr(b, q)), q
    assert np.array_equal(a.energy.coulomb, b.energy.coulomb)
    assert np.array_equal(a.energy.viscous, b.energy.viscous)
    assert (a.status, a.steps, a.event_counts) == (b.status, b.steps, b.event_counts)


def _interior(result, N):
    """Logged events per kind without the wall contacts (which the counts leave out)."""
    walls = (-1, N - 1)
    return Counter(e.kind for e in result.events
                   if not (e.kind.startswith("contact") and e.index in walls))


@pytest.mark.parametrize("feat", ["frictionless", "viscous", "coulomb+viscous"])
def test_log_is_bit_identical_and_adds_up_to_the_counts(feat):
    """Sweep path (frictionless, viscous) and Coulomb passes, all with walls."""
    N = 40
    off, on = _run(_scene(feat, False)), _run(_scene(feat, True))
    _same_run(off, on)
    assert off.events == []
    counted = {k: n for k, n in on.event_counts.items() if n}
    assert counted and dict(_interior(on, N)) == counted
    assert on.event_counts["contact_close"] > 20
    if feat.startswith("coulomb"):
        assert on.event_counts["stop"] > 20 and on.event_counts["slip"] > 20
    walls = Counter((e.kind, e.index) for e in on.events if e.index in (-1, N - 1)
                    and e.kind.startswith("contact"))
    assert walls[("contact_close", -1)] >= 1 and walls[("contact_close", N - 1)] >= 1
    t = np.array([e.t for e in on.events])
    assert np.all(np.diff(t) >= 0) and t[0] > 0 and t[-1] <= on.t_final


@pytest.mark.parametrize("feat", ["frictionless", "coulomb+viscous"])
def test_contact_events_are_the_overlap_sign_changes_frame_by_frame(feat):
    """Reference: a frame at every step; contact i closed where r_i + r_(i+1) >
    x_(i+1) - x_i, a wall closed where the granule overlaps it. (The gap of 0.01
    keeps every overlap far from 0 relative to roundoff at the step it changes sign.)"""
    N, steps = 30, 1500
    scene = _scene(feat, True, N=N, steps=steps, every=1)
    r = _run(scene)
    model = build_model(scene)
    x, rad = r.x, model.radius
    delta = (rad[:-1] + rad[1:]) - (x[:, 1:] - x[:, :-1])
    w = model.walls
    left = w[0] - (x[:, 0] - model.x0[0])
    right = w[3] + (x[:, -1] - model.x0[-1])
    closed = np.column_stack([left, delta, right]) > 0  # columns: contacts -1 .. N-1
    step, col = np.nonzero(closed[1:] != closed[:-1])
    ref = sorted((int(s) + 1, "contact_close" if closed[s + 1, c] else "contact_open", int(c) - 1)
                 for s, c in zip(step, col))
    logged = sorted((int(round(e.t / DT)), e.kind, e.index) for e in r.events
                    if e.kind.startswith("contact"))
    assert len(ref) > 50
    assert logged == ref
    assert all(abs(e.t - round(e.t / DT) * DT) <= 1e-12 * e.t for e in r.events)


def test_a_full_log_drains_and_resumes_bit_identically(monkeypatch):
    """A log with room for little more than one step's worst case makes the kernel
    return LOG_FULL often; the run and the log are the same as with a large one."""
    N = 40
    big = _run(_scene("coulomb", True, N=N))
    calls = []
    real = verlet.new_event_log

    def small(n, coulomb, log_events):
        bufs = real(n, coulomb, log_events)
        size = verlet.log_capacity(n, coulomb) + 7
        calls.append(size)
        return tuple(b[:size].copy() for b in bufs[:3]) + (bufs[3],)

    monkeypatch.setattr(verlet.event_log, "new_event_log", small)
    full = []
    real_call = verlet.EventLog.call

    def counting_call(self, call, *a):
        def wrapped(args):
            taken, code = call(args)
            full.append(code == verlet.LOG_FULL)
            return taken, code
        return real_call(self, wrapped, *a)

    monkeypatch.setattr(verlet.EventLog, "call", counting_call)
    tiny = _run(_scene("coulomb", True, N=N))
    assert calls and sum(full) > 10  # it did fill up, many times
    _same_run(big, tiny)
    assert tiny.events == big.events


def test_half_kicks_at_the_end_and_before_a_short_last_step_are_logged():
    """t_end not a whole number of steps: the driver synchronises before the short
    last step and at the end; their stops and slips are in the counts and the log."""
    N = 40
    scene = _scene("coulomb", True, N=N, t_end=2500 * DT + 0.37 * DT, walls=False)
    off, on = _run(scene.model_copy(update={"output": scene.output.model_copy(
        update={"events": False})})), _run(scene)
    _same_run(off, on)
    assert on.t_final == pytest.approx(2500.37 * DT, rel=1e-14)
    counted = {k: n for k, n in on.event_counts.items() if n}
    assert dict(_interior(on, N)) == counted
    assert max(e.t for e in on.events) <= on.t_final


def test_rest_stop_log_adds_up():
    """stop: rest (Coulomb): the step that found the chain at rest is not taken; its
    events (if any) are dated at the run's end."""
    N = 20
    scene = _scene("coulomb", True, N=N, steps=400_000, every=100_000, walls=False, stop="rest")
    on = _run(scene, speed=0.02)
    assert on.status == gc.Status.AT_REST
    assert dict(_interior(on, N)) == {k: n for k, n in on.event_counts.items() if n}
    assert max(e.t for e in on.events) <= on.t_final


def test_events_csv_from_the_log(tmp_path):
    N = 20
    r = _run(_scene("coulomb", True, N=N, steps=800, every=400))
    path = write_events_csv(r, tmp_path)
    rows = list(csv.DictReader(path.open()))
    assert len(rows) == len(r.events) > 0
    assert list(rows[0]) == ["step", "t", "kind", "index"]
    assert [(int(q["step"]), float(q["t"]), q["kind"], int(q["index"])) for q in rows] == \
        [(e.step, e.t, e.kind, e.index) for e in r.events]


def test_event_steps_give_their_times():
    """An event's step is the step whose end is its time (t = step dt), including
    the stops and slips of the half kicks at the frames (logged with the frame's step)."""
    N = 20
    r = _run(_scene("coulomb", True, N=N, steps=800, every=400))
    kinds = {e.kind for e in r.events}
    assert {"contact_close", "stop", "slip"} <= kinds, kinds
    steps = np.array([e.step for e in r.events])
    assert steps.min() >= 1 and steps.max() <= r.steps
    assert np.all(np.diff(steps) >= 0)  # in the order they happened
    assert [e.t for e in r.events] == [s * r.dt for s in steps.tolist()]
