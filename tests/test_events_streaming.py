"""The event stepper hands its frames on while it runs, and continues bit for bit
from a checkpoint (taken on a cadence or when a signal stops the run)."""

import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import granular_chain as gc
from granular_chain.frames import FrameLog
from granular_chain.model import build_model
from granular_chain.steppers.events import simulate_events

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _two_granules():  # exact modes (n = 2), viscous friction, many frames a step
    return {"name": "two", "granules": {"count": 2, "velocity": {0: 1.0},
                                        "friction": {"viscous": 0.1}},
            "contacts": {"exponent": 2.0}, "run": {"stepper": "event", "t_end": 5.0},
            "output": {"dt": 0.01}}


def _hertz_chain():  # frames at event batches and on a cadence, both frictions, a wall
    return {"name": "chain", "granules": {"count": 30, "velocity": {0: 0.1},
                                          "friction": {"kinetic": [0.0] * 15 + [2e-5] * 15,
                                                       "viscous": 1e-4}},
            "contacts": {"exponent": 2.5}, "walls": {"right": {"gap": 0.0, "exponent": 2.5}},
            "run": {"stepper": "event", "t_end": 60.0}, "output": {"dt": 0.5}}


def _physical():  # run in internal scaled units, frames scaled back
    return {"name": "si", "units": "physical",
            "granules": {"count": 4, "mass": 0.033, "radius": 0.01,
                         "velocity": [0.5, 0.0, 0.0, 0.0],
                         "material": {"young": 2e11, "poisson": 0.3},
                         "friction": {"kinetic": [0.0, 0.05, 0.0, 0.0],
                                      "viscous": [0.0, 0.2, 0.0, 0.0]}},
            "contacts": {"stiffness": "hertz", "exponent": 2.5},
            "run": {"stepper": "event", "t_end": 1e-3}, "output": {"dt": 1e-5}}


def _long_chain(N=300, t_end=30.0):  # long chain: small stream buffers, many flushes
    return {"name": "long", "granules": {"count": N, "velocity": {0: 1.0},
                                         "friction": {"viscous": 1e-3}},
            "contacts": {"exponent": 2.5}, "run": {"stepper": "event", "t_end": t_end},
            "output": {"dt": 0.01}}


SCENES = {"two": _two_granules, "chain": _hertz_chain, "physical": _physical,
          "long": _long_chain}


class Collect:
    """A writer keeping a copy of every frame."""

    def __init__(self):
        self.frames, self.closed = [], None

    def write_frame(self, f):
        self.frames.append(f._replace(x=f.x.copy(), v=f.v.copy(), f=f.f.copy()))

    def close(self, result):
        self.closed = result


def _bits(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


def _same_end(a, b):
    """The end of two runs is the same bit for bit (time, state, events, counts,
    steps, status, the ledger at the last frame)."""
    assert a.t_final == b.t_final and a.steps == b.steps
    assert _bits(a.x_final, b.x_final) and _bits(a.v_final, b.v_final)
    assert a.events == b.events and a.event_counts == b.event_counts
    assert a.status == b.status and a.message == b.message
    for name in ("kinetic", "potential", "coulomb", "viscous"):
        assert getattr(a.energy, name)[-1] == getattr(b.energy, name)[-1]
    assert a.energy.initial == b.energy.initial
    assert a.energy.balance_error == b.energy.balance_error


def _same_frames(frames, result, start=0):
    """frames[q] is row start + q of the result (time, state, ledger), numbered so."""
    e = result.energy
    assert len(frames) == result.t.size - start
    for q, f in enumerate(frames, start):
        assert f.step == q and f.t == result.t[q] and f.initial == e.initial
        assert _bits(f.x, result.x[q]) and _bits(f.v, result.v[q]) and _bits(f.f, result.f[q])
        assert (f.kinetic, f.potential, f.coulomb, f.viscous) == (
            e.kinetic[q], e.potential[q], e.coulomb[q], e.viscous[q])


@pytest.mark.parametrize("name", list(SCENES))
def test_streamed_run_equals_the_run_keeping_its_frames(name):
    # log=None: the frames stay in the kernel's buffers (no streaming); with a
    # log they are handed on between kernel calls: the same Result bit for bit
    scene = gc.scene_from_dict(SCENES[name]())
    kept = simulate_events(scene, build_model(scene))
    sink = Collect()
    streamed = gc.simulate(scene, progress=False, writers=[sink])
    assert sink.closed is streamed and len(sink.frames) > 100
    for field in ("t", "x", "v", "f"):
        assert _bits(getattr(streamed, field), getattr(kept, field))
    for field in ("kinetic", "potential", "coulomb", "viscous"):
        assert _bits(getattr(streamed.energy, field), getattr(kept.energy, field))
    assert streamed.energy.streamed_error is None
    _same_end(streamed, kept)
    assert streamed.info["event_stepper"] == kept.info["event_stepper"]
    _same_frames(sink.frames, kept)


def test_frames_not_kept_leave_first_last_and_the_ledger_error():
    scene = gc.scene_from_dict(_hertz_chain())
    kept = simulate_events(scene, build_model(scene))
    sink = Collect()
    r = gc.simulate(scene, progress=False, writers=[sink], keep_frames=False)
    _same_frames(sink.frames, kept)
    assert r.t.size == 2 and r.x.shape == (2, 30) and r.info["frames"] == kept.t.size
    assert r.t[0] == kept.t[0] and r.t[1] == kept.t[-1] and _bits(r.x[1], kept.x[-1])
    assert r.energy.streamed_error == kept.energy.balance_error > 0
    _same_end(r, kept)


MEMORY = textwrap.dedent("""
    import sys, tracemalloc
    import granular_chain as gc
    frames, keep = int(sys.argv[1]), sys.argv[2] == "1"
    scene = gc.scene_from_dict({"name": "m", "granules": {"count": 200, "velocity": {0: 1.0}},
        "contacts": {"exponent": 2.5}, "run": {"stepper": "event", "t_end": 20.0},
        "output": {"dt": 20.0 / frames}})
    class Count:
        n = 0
        def write_frame(self, f): self.n += 1
        def close(self, r): pass
    gc.simulate(scene, progress=False, writers=[Count()], keep_frames=keep)  # compiled
    w = Count()
    tracemalloc.start()
    r = gc.simulate(scene, progress=False, writers=[w], keep_frames=keep)
    print(w.n, tracemalloc.get_traced_memory()[1])
""")


def _peak(frames: int, keep: bool):
    env = dict(os.environ, PYTHONPATH=ROOT)
    out = subprocess.run([sys.executable, "-c", MEMORY, str(frames), str(int(keep))], env=env,
                         capture_output=True, text=True, check=True).stdout.split()
    return int(out[0]), int(out[1])


def test_memory_of_a_streamed_run_does_not_grow_with_its_frames():
    n_few, few = _peak(200, keep=False)
    n_many, many = _peak(5000, keep=False)
    # t = 0, the cadence (the last at t_end) and the frame at contact 0's opening
    assert (n_few, n_many) == (202, 5002)
    assert abs(many - few) <= 0.10 * few, (few, many)
    # the measurement sees frames kept: 5000 frames of 3 x 200 doubles = 24 MB
    _, kept = _peak(5000, keep=True)
    assert kept > few + 5000 * 3 * 200 * 8


def _checkpointed(scene, model, every):
    states = []
    log = FrameLog([Collect()])
    r = simulate_events(scene, model, log, checkpoint=states.append, checkpoint_every=every)
    return r, log.writers[0], states


def _npz(state, path):
    """The state through numpy.savez / numpy.load, as a run folder keeps it."""
    np.savez(path, **state)
    with np.load(path) as data:
        return {k: data[k] for k in data.files}


@pytest.mark.parametrize("name", ["two", "chain", "physical", "long"])
def test_resumed_run_is_bit_identical_to_the_uninterrupted_one(name, tmp_path):
    scene = gc.scene_from_dict(SCENES[name]())
    model = build_model(scene)
    a_sink = Collect()
    a = simulate_events(scene, model, FrameLog([a_sink]))
    b, b_sink, states = _checkpointed(scene, model, max(a.steps // 4, 1))
    _same_end(b, a)
    _same_frames(b_sink.frames, a)
    steps = [int(s["steps"]) for s in states]
    assert len(states) >= 3 and steps == sorted(steps) and not any(s["interrupted"] for s in states)
    state = _npz(states[len(states) // 2], tmp_path / "state.npz")
    k0 = int(state["frames"])
    assert 0 < k0 < a.t.size - 1
    for keep in (True, False):
        sink = Collect()
        c = simulate_events(scene, model, FrameLog([sink], keep=keep), resume=state)
        _same_end(c, a)
        _same_frames(sink.frames, a, start=k0)
        if keep:  # the frames computed after the resume
            assert _bits(c.t, a.t[k0:]) and _bits(c.x, a.x[k0:])
        else:  # first and last of the whole run, counted over the whole run
            assert c.t[0] == a.t[0] and _bits(c.x[0], a.x[0]) and _bits(c.x[1], a.x[-1])
            assert c.info["frames"] == a.t.size


def test_a_checkpoint_of_another_scene_is_refused():
    two, chain = (gc.scene_from_dict(f()) for f in (_two_granules, _hertz_chain))
    _, _, states = _checkpointed(two, build_model(two), 2)
    with pytest.raises(ValueError, match="another scene"):
        simulate_events(chain, build_model(chain), FrameLog(), resume=states[0])


CHILD = textwrap.dedent("""
    import os, sys, time
    import numpy as np
    import granular_chain as gc
    from granular_chain.frames import FrameLog
    from granular_chain.model import build_model
    from granular_chain.steppers.events import simulate_events
    folder, scene = sys.argv[1], gc.scene_from_dict(eval(sys.argv[2]))
    def save(state):
        if state["interrupted"]:
            np.savez(os.path.join(folder, "interrupted.npz"), **state)
            return
        if not os.path.exists(os.path.join(folder, "running")):
            open(os.path.join(folder, "running"), "w").close()
            for _ in range(3000):  # the parent sends SIGINT meanwhile
                if os.path.exists(os.path.join(folder, "sent")):
                    break
                time.sleep(0.01)
    r = simulate_events(scene, build_model(scene), FrameLog(), checkpoint=save,
                        checkpoint_every=50)
    print(r.status.name, r.t_final)
""")


def test_run_stopped_by_sigint_resumes_from_its_checkpoint(tmp_path):
    spec = _long_chain(N=300, t_end=30.0)
    scene = gc.scene_from_dict(spec)
    model = build_model(scene)
    env = dict(os.environ, PYTHONPATH=ROOT)
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(tmp_path), repr(spec)], env=env,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while not (tmp_path / "running").exists():
        assert child.poll() is None and time.time() < deadline, child.communicate()
        time.sleep(0.02)
    child.send_signal(signal.SIGINT)
    (tmp_path / "sent").touch()
    out, err = child.communicate(timeout=60)
    assert child.returncode == 0, err
    status, t_stop = out.split()
    assert status == "INTERRUPTED" and float(t_stop) < 30.0
    with np.load(tmp_path / "interrupted.npz") as data:
        state = {k: data[k] for k in data.files}
    assert state["interrupted"] and int(state["steps"]) >= 50
    a_sink = Collect()
    a = simulate_events(scene, model, FrameLog([a_sink]))
    sink = Collect()
    c = simulate_events(scene, model, FrameLog([sink]), resume=state)
    _same_end(c, a)
    _same_frames(sink.frames, a, start=int(state["frames"]))
    assert len(sink.frames) > 100
