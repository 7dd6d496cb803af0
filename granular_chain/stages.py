"""Staged runs (``run.stages``): stages run one after another, in one run.

A scene with ``run.stages`` is run as a chain of ordinary runs, one a stage. The
first runs the scene as written from t = 0 to its ``t_end``; each later stage
starts from the positions and velocities the stage before ended with (its
``x_final``, ``v_final``, exactly), changes the velocities its fields name
(``velocity`` sets, ``velocity_add`` adds) and runs on to its own ``t_end``. The
walls stay where they are in space: each stage's wall gaps are those of the
stage's starting positions. A stage is therefore, bit for bit, the run a user
would make by hand from the stage before's final state (``granules.state``) with
the velocities changed and the wall gaps measured from that state.

The stages' frames go to one frame log, the run's, as one continuous run:

- times are the run's clock (a stage's own clock starts at 0 at its start: its
  frame time plus the stage's start time; its last frame at its ``t_end``
  exactly); frame steps go on counting from the stage before's last frame;
- a stage's first frame, at the same time as the stage before's last, is not
  recorded: the frame at a stage boundary holds the state before the change;
- the energy ledger is continuous: the energies dissipated and the work done
  by walls and body forces go on from the stage before's last frame, the
  reference energy is the first stage's, and the kinetic energy the change of
  velocities puts in enters as ``stage_work`` (eq. (L) below), so that the
  balance error of the run is the sum of the stages' own, at the integrator's
  level;
- each frame carries its stage index (``Frame.stage``; trajectory.h5's
  ``stage`` variable), and ``Result.info["stages"]`` (summary.json's
  ``stages``) lists each stage's start and end, changes and energy put in.

The ledger of stage k's frames, from the stage's own ledger (primed):

    coulomb = C_(k-1) + coulomb', ... (each dissipated or work term likewise),
    stage_work = S_(k-1) + K'_0 - K_(k-1)                                   (L)

with C_(k-1), S_(k-1) the terms at stage k-1's last frame, K_(k-1) its kinetic
energy and K'_0 stage k's kinetic energy at its start, after the change.

What carries no state across a boundary is refused by the scene (stop
conditions, moving walls) or not offered (checkpoints, ``--restart``).
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence

import numpy as np

from .frames import Frame, FrameLog
from .interrupts import stop_signals
from .result import TERMS_ADDED, EnergyLedger, Event, Result, Status
from .scene import InitialState, Scene

__all__ = ["run_stages", "stage_scene", "StageFrames"]

#: The ledger terms that go on from the stage before's last frame.
_CARRIED = ("coulomb", "viscous", "contact_dissipated", "wall_work", "body_work")


def stage_scene(scene: Scene, k: int, x: Optional[np.ndarray] = None,
                v: Optional[np.ndarray] = None, first=None) -> Scene:
    """The scene stage ``k`` of a staged scene runs, on its own clock.

    Parameters
    ----------
    scene : Scene
        A scene with ``run.stages``.
    k : int
        Stage index, 0 first.
    x, v : ndarray, shape (N,), optional
        Positions and velocities the stage before ended with (scene units); not
        used for stage 0, which runs the scene as written.
    first : Model, optional
        The first stage's model: where the walls are (:func:`wall_positions`) and
        the radii (drawn ones included); needed for k > 0.

    Returns
    -------
    Scene
        The scene with ``run.t_end`` the stage's length of time and no stages;
        for k > 0 starting from ``x`` and ``v`` changed as the stage says, with
        each wall's gap measured from ``x``.
    """
    stages = scene.run.stages
    t0 = stages[k - 1].t_end if k else 0.0
    run = scene.run.model_copy(update={"t_end": stages[k].t_end - t0, "stages": None})
    if k == 0:
        return scene.model_copy(update={"run": run})
    stage = stages[k]
    v = np.array(v, dtype=np.float64)
    for i, value in stage.velocity.items():
        v[i] = value
    for i, change in stage.velocity_add.items():
        v[i] += change
    # (the record names where the state comes from; the arrays are given, not read)
    state = InitialState(file=f"<end of stage {k - 1}>", frame=-1)
    granules = scene.granules.model_copy(update={"state": state})
    granules._x0, granules._v0 = np.array(x, dtype=np.float64), v
    radius = first.radius
    update = {}
    for side, at in zip(("left", "right"), wall_positions(first)):
        wall = getattr(scene.walls, side)
        if wall is None:
            continue
        gap = (x[0] - radius[0]) - at if side == "left" else at - (x[-1] + radius[-1])
        update[side] = wall.model_copy(update={"gap": float(gap)})
    return scene.model_copy(update={"run": run, "granules": granules,
                                    "walls": scene.walls.model_copy(update=update)})


def wall_positions(model) -> tuple:
    """Positions of the wall contact surfaces of a model at t = 0 (None: no wall).

    Parameters
    ----------
    model : Model
        The first stage's model (scene units).

    Returns
    -------
    (float or None, float or None)
        Left wall at x_0 - r_0 - gap_left; right wall at x_(N-1) + r_(N-1) + gap_right
        (the model stores the initial overlaps, -gap).
    """
    t, x0, r = model.contacts, model.x0, model.radius
    has_left, has_right = t.has_walls
    left = float(x0[0] - r[0] + t.d0[0]) if has_left else None
    right = float(x0[-1] + r[-1] - t.d0[-1]) if has_right else None
    return left, right


class StageFrames:
    """A frame writer that hands one stage's frames on to the run's frame log, on the
    run's clock and with the run's ledger (eq. (L) of the module docstring).

    Parameters
    ----------
    log : FrameLog
        The run's frame log (its writers get every stage's frames).
    k : int
        Stage index.
    t0, t_end : float
        The stage's start and end on the run's clock (scene units of time).
    before : Frame or None
        The run's last recorded frame before this stage (None for stage 0).
    """

    def __init__(self, log: FrameLog, k: int, t0: float, t_end: float,
                 before: Optional[Frame]):
        self.log, self.k, self.t0, self.t_end = log, k, t0, t_end
        self.before = before
        self.kinetic_start: Optional[float] = None  #: the stage's kinetic energy at its start
        self.last: Optional[Frame] = before  #: the run's latest frame

    def write_frame(self, frame: Frame) -> None:
        """Map one of the stage's frames onto the run and record it (the stage's first
        frame only sets the offsets, after stage 0).

        Parameters
        ----------
        frame : Frame
            One of the stage's frames, on its own clock and ledger (scene units).
        """
        if self.kinetic_start is None:
            self.kinetic_start = float(frame.kinetic)
            self.duration = self.t_end - self.t0
            if self.before is not None:
                return  # the frame before the change is the stage before's last
        mapped = self.mapped(frame)
        self.log.record(mapped)
        # (the arrays are the stage log's, reused after this call: the numbers only)
        self.last = mapped._replace(x=None, v=None, f=None)

    def mapped(self, frame: Frame) -> Frame:
        """``frame`` (on the stage's clock and ledger) on the run's.

        Parameters
        ----------
        frame : Frame
            One of the stage's frames (scene units).

        Returns
        -------
        Frame
            The same state at the run's time, step count and ledger (eq. (L)), with
            the stage's index.
        """
        b = self.before
        t = self.t_end if frame.t == self.duration else self.t0 + frame.t
        if b is None:
            return frame._replace(t=t)
        carried = {name: getattr(b, name) + getattr(frame, name) for name in _CARRIED}
        put_in = b.stage_work + (self.kinetic_start - b.kinetic)
        return frame._replace(step=b.step + frame.step, t=t, initial=b.initial,
                              stage_work=put_in, stage=self.k, **carried)

    def close(self, result) -> None:
        """Nothing to close: the run's log is closed once, after the last stage.

        Parameters
        ----------
        result : Result
            The stage's Result (unused).
        """


@dataclass
class _Progress:
    """What the stages run so far add up to."""

    results: list = field(default_factory=list)
    lasts: list = field(default_factory=list)  #: each stage's last frame on the run's terms
    records: list = field(default_factory=list)
    events: list = field(default_factory=list)
    counts: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    steps: int = 0


def run_stages(scene: Scene, run_one: Callable, writers: Sequence = (),
               keep_frames: bool = True) -> Result:
    """Run a staged scene: each stage with ``run_one``, its frames to one log.

    Parameters
    ----------
    scene : Scene
        A scene with ``run.stages``.
    run_one : callable(Scene, writers) -> Result
        Runs one unstaged scene with the given frame writers attached, frames not
        kept (``granular_chain.simulate`` passes its own single run); the Result
        carries its ``model``.
    writers : sequence of FrameWriter
        The run's writers: they get the frames of every stage, on the run's clock.
    keep_frames : bool
        Keep every frame in the Result (else the first and the last).

    Returns
    -------
    Result
        One run: frames, ledger and events of all stages on the run's clock;
        ``info["stages"]`` describes each stage run. The status is the last
        stage's; a stage that does not reach its t_end ends the run there.
    """
    log = FrameLog(list(writers), keep=keep_frames, background=bool(writers))
    done, first, x, v = _Progress(), None, None, None
    start = _time.perf_counter()
    # (one stop request for every stage, shared by their runs: a signal between two
    # stages ends the next one at its start, with status interrupted)
    try:
        with stop_signals():
            for k, stage in enumerate(scene.run.stages):
                t0 = scene.run.stages[k - 1].t_end if k else 0.0
                adapter = StageFrames(log, k, t0, stage.t_end, done.lasts[-1] if k else None)
                r = run_one(stage_scene(scene, k, x, v, first), [adapter])
                if k == 0:
                    first = r.model
                _add(done, k, stage, t0, r, adapter)
                x, v = r.x_final, r.v_final
                if r.status != Status.T_END:
                    break
    finally:
        log.finish()
    result = _combine(scene, log, done, _time.perf_counter() - start)
    log.close(result)
    return result


def _add(done: _Progress, k: int, stage, t0: float, r: Result, adapter: StageFrames) -> None:
    """Add stage ``k``'s Result ``r`` to what the run has so far."""
    offset = done.steps
    done.events.extend(Event(t0 + e.t, e.kind, e.index, e.step + offset if e.step >= 0
                                   else e.step) for e in r.events)
    for kind, n in r.event_counts.items():
        done.counts[kind] = done.counts.get(kind, 0) + int(n)
    done.warnings.extend(f"stage {k}: {w}" for w in r.info.get("warnings", []))
    done.steps += int(r.steps)
    last = adapter.last
    kinetic_before = float(done.lasts[-1].kinetic) if k else None
    done.records.append({
        "index": k, "name": stage.name or f"stage{k}", "t_start": t0,
        "t_end": float(last.t) if r.status == Status.T_END else t0 + float(r.t_final),
        "status": str(r.status), "steps": int(r.steps), "dt": r.dt,
        "velocity": {str(i): v for i, v in stage.velocity.items()},
        "velocity_add": {str(i): v for i, v in stage.velocity_add.items()},
        "kinetic_before": kinetic_before, "kinetic_after": adapter.kinetic_start,
        "stage_work": float(last.stage_work)})
    done.results.append(r)
    done.lasts.append(last)


def _combine(scene: Scene, log: FrameLog, done: _Progress, wall: float) -> Result:
    """The staged run's Result from its log and the stages' Results."""
    last = done.results[-1]
    k = len(done.results) - 1
    stage = done.records[-1]
    energy = EnergyLedger(
        kinetic=log.array("kinetic"), potential=log.array("potential"),
        coulomb=log.array("coulomb"), viscous=log.array("viscous"),
        initial=float(done.lasts[0].initial),
        streamed_error=None if log.keep else log.max_balance_error,
        **{name: log.array(name) for name in TERMS_ADDED})
    if last.status == Status.T_END:
        message = (f"reached t_end = {stage['t_end']:.12g} after {done.steps} steps in "
                   f"{len(done.results)} stages")
    else:
        message = (f"stage {k} ({stage['name']}, from t = {stage['t_start']:.12g}; its times "
                   f"counted from its start): {last.message}")
    info = {**last.info, "stages": done.records}
    for name in ("warnings", "frames", "frames_kept"):  # (the last stage's own)
        info.pop(name, None)
    if done.warnings:
        info["warnings"] = done.warnings
    if not log.keep:
        info["frames"] = log.count
        info["frames_kept"] = "first and last (the others were streamed to the writers)"
    t = log.array("t")
    return Result(t=t, x=log.array("x"), v=log.array("v"), f=log.array("f"), energy=energy,
                  status=last.status, message=message, steps=done.steps, wall_time=wall,
                  stepper=last.stepper, dt=last.dt, t_final=float(stage["t_end"]),
                  x_final=last.x_final.copy(), v_final=last.v_final.copy(),
                  events=done.events, event_counts=done.counts, info=info)
