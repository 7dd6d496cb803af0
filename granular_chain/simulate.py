"""simulate(scene) -> Result: checks a scene, runs it with its stepper, attaches writers.

The steppers' drivers live in :mod:`.steppers.verlet` and
:mod:`.steppers.events`; this module picks one, runs the checks every run makes
before it computes anything (:func:`preflight`) and hands the frames to the
writers attached to the run as they come.
"""

from __future__ import annotations

from typing import NamedTuple, Optional, Sequence, Union

import numpy as np

from ._compile import compile_scope, kernel
from .budget import check_budget
from .errors import SimulationError
from .frames import Frame, FrameLog
from .ledger import ledger_verdict
from .model import Model
from .notices import OverlapWarning, TimeStepWarning, warn
from .result import Result
from .scene import Scene
from .stages import run_stages
from .steppers.events import check_exponents, event_options, simulate_events
from .steppers.schedule import Schedule, plan_run
from .steppers.verlet.driver import (  # noqa: F401  (re-exported: benchmarks and tests)
    VerletRun,
    _backtrack_to_separation,
    _drift_coefficients,
    _net_forces,
    _overlap_caps,
    _uniform_code,
)
from .steppers.verlet.timestep import check_accuracy, check_dt, default_dt, step_plan, verlet_dt

__all__ = ["simulate", "preflight", "prepare_run", "Preflight", "SimulationError", "default_dt",
           "check_dt", "step_plan"]


class Preflight(NamedTuple):
    """What :func:`prepare_run` decided before a run: its Model and its Schedule."""

    model: Model        #: the scene compiled to arrays (scene units)
    schedule: Schedule  #: steps, frames and thermo lines (:mod:`.steppers.schedule`)


def prepare_run(scene: Scene) -> Preflight:
    """Every check a run makes before it computes anything; the scene's Model and the
    run's Schedule, each worked out once and handed to :func:`simulate`.

    ``granular-chain run`` calls this before it creates any folder, so that a
    refused run changes nothing on disk.

    Parameters
    ----------
    scene : Scene
        The validated scene (scene units).

    Returns
    -------
    Preflight
        The Model (:func:`granular_chain.model.build_model`) and the Schedule.

    Raises
    ------
    SimulationError
        Naming the field to change and the limit (for example run.dt).
    """
    budget = check_budget(scene)  # refuses, before allocating, what cannot run
    model = budget.model
    if scene.run.stepper == "event":
        check_exponents(model)
    if scene.run.stepper == "verlet" and scene.run.check_dt:
        dt = verlet_dt(scene, model)
        check_dt(model, dt)
        if scene.run.dt is not None and not scene.run.accept_inaccurate_dt:
            check_accuracy(model, dt)
    return Preflight(model, budget.schedule)


def preflight(scene: Scene) -> Model:
    """:func:`prepare_run`'s checks; the scene's Model.

    Parameters
    ----------
    scene : Scene
        The validated scene (scene units).

    Returns
    -------
    Model
        The scene compiled to arrays (:func:`granular_chain.model.build_model`).

    Raises
    ------
    SimulationError
        Naming the field to change and the limit (for example run.dt).
    """
    return prepare_run(scene).model


def simulate(scene: Union[Scene, Model], *, progress: Optional[bool] = None,
             writers: Sequence = (), keep_frames: bool = True, thermo=None,
             checkpoint=None, resume: Optional[dict] = None,
             end_checkpoint: bool = False, model: Optional[Model] = None,
             schedule: Optional[Schedule] = None) -> Result:
    """Run a scene and return its :class:`Result`.

    Parameters
    ----------
    scene : Scene
        A validated scene (see :func:`granular_chain.load_scene`).
    progress : bool, optional
        A progress bar of simulated time t / t_end with an ETA, for both steppers:
        True shows it (on standard error; a widget in a Jupyter notebook), False
        never; None (default) shows it in a Jupyter notebook only
        (:func:`granular_chain.progress.progress_bar`).
    writers : sequence of FrameWriter, optional
        Attached to the run: each output frame is handed to them as the run
        goes (:class:`granular_chain.frames.FrameWriter`); every frame is
        written when this returns, and the caller closes them with the Result
        (``close(result)``), as ``granular-chain run`` does.
    keep_frames : bool
        Keep every frame in the Result (default). False keeps the first and the
        last only, so memory does not grow with the number of frames: for runs
        whose frames go to writers.
    thermo : ThermoLog, optional
        A thermo log (:mod:`granular_chain.writers.thermo`) on its own cadence.
    checkpoint : callable(dict), optional
        Given the run's state every ``output.checkpoint_every`` steps and when the run
        is interrupted (Verlet; :mod:`granular_chain.checkpoint` saves it).
    resume : dict, optional
        A state given to ``checkpoint`` by a run of the same scene: this run goes
        on from it, bit for bit as if it had never stopped; a Verlet state may come
        from a run of the same scene with an earlier ``run.t_end`` whose step plan
        is this one's (:func:`granular_chain.restart.extension_problem`).
    end_checkpoint : bool
        Verlet: also give ``checkpoint`` the state at the last frame of the cadence
        before the last whole step, which a run to a later t_end passes through
        (the event stepper ignores it).
    model : Model, optional
        The scene's Model as :func:`prepare_run` (or :func:`preflight`) returned it,
        for a caller that has checked the scene already (the command line): it is not
        built, nor checked, again. Its scene must be ``scene``.
    schedule : Schedule, optional
        With ``model``: the run's Schedule as :func:`prepare_run` returned it.

    Returns
    -------
    Result
        Never contains NaN: a run whose state turns non-finite stops with
        ``Status.NONFINITE`` at its last finite frame.

    Raises
    ------
    SimulationError
        The run cannot start (for example dt too large for the stiffest contact).

    Warns
    -----
    OverlapWarning
        Granules i and i+2 overlapped at a frame (the model ignores that contact).
    TimeStepWarning
        run.dt was shortened so that the frames fall on steps.
    CompileNotice
        Kernels are being compiled for a feature set numba has not cached
        (:mod:`granular_chain.notices`; also logged on the ``granular_chain`` logger).

    Notes
    -----
    SIGINT (Ctrl-C) and SIGTERM during the run end it within about
    :data:`granular_chain.interrupts.CHUNK_SECONDS` with ``Status.INTERRUPTED``
    and the frames computed so far (in the main thread; elsewhere signals keep
    their default effect).

    A scene with ``run.stages`` runs its stages one after another
    (:mod:`granular_chain.stages`); ``thermo`` and ``checkpoint`` are not used
    then, and ``resume`` is refused.
    """
    if isinstance(scene, Scene) and scene.run.stages:
        return _simulate_stages(scene, progress, writers, keep_frames, resume, model)
    return _simulate_one(scene, progress, writers, keep_frames, thermo, checkpoint, resume,
                         end_checkpoint, model, schedule)


def _simulate_stages(scene: Scene, progress, writers, keep_frames, resume,
                     model=None) -> Result:
    """:func:`simulate` of a scene with ``run.stages``: each stage one run, judged on
    its own ledger, then the whole run on the continuous ledger."""
    if resume is not None:
        raise SimulationError("run.stages: a staged run cannot be continued from a "
                              "checkpoint; run it again")
    if model is None:  # the first stage's checks; each stage's run makes its own
        model = preflight(scene)

    def run_one(stage: Scene, stage_writers) -> Result:
        return _simulate_one(stage, progress, stage_writers, False, None, None, None, False)

    result = run_stages(scene, run_one, writers, keep_frames)
    if scene.run.energy_tolerance is not None:
        result.status, result.message = ledger_verdict(result, scene.run.energy_tolerance,
                                                       "run.energy_tolerance")
    result.scene = scene
    result.model = model  # the first stage's: its walls and x0 are the run's (fixed in space)
    return result


def _simulate_one(scene, progress, writers, keep_frames, thermo, checkpoint,
                  resume, end_checkpoint, model=None, schedule=None) -> Result:
    """:func:`simulate` of one unstaged run (its parameters)."""
    if model is None:
        model, schedule = prepare_run(scene)
    elif schedule is None:
        asked = verlet_dt(scene, model) if scene.run.stepper == "verlet" else None
        schedule = plan_run(scene, model, asked)
    with compile_scope(f"{scene.run.stepper} stepper: {model.features.in_words()}"):
        return _run(scene, model, schedule, progress, writers, keep_frames, thermo, checkpoint,
                    resume, end_checkpoint)


def _run(scene: Scene, model: Model, schedule: Schedule, progress, writers, keep_frames,
         thermo, checkpoint, resume, end_checkpoint) -> Result:
    """:func:`simulate` once the scene is checked and packed into ``model``."""
    watch = NeighbourWatch(model.radius)
    log = FrameLog([watch, *writers], keep=keep_frames, background=bool(writers))
    every = scene.output.checkpoint_every
    try:
        if scene.run.stepper == "event":
            result = simulate_events(event_options(scene, schedule), model, log=log,
                                     resume=resume, checkpoint=checkpoint,
                                     checkpoint_every=every or 0, progress=progress)
        else:
            run = VerletRun(scene, model, progress, log=log, thermo=thermo, checkpoint=checkpoint,
                            checkpoint_every=every, end_checkpoint=end_checkpoint,
                            schedule=schedule)
            result = run.run(resume=resume)
    finally:
        log.finish()  # (the writers' thread is done before anyone closes their files)
    warning = watch.warning
    if warning:
        result.info.setdefault("warnings", []).append(warning)
    for text in result.info.get("warnings", []):  # kept in info too (summary.json)
        # (stacklevel 4: said at the line that called simulate, through _simulate_one)
        warn(text, OverlapWarning if text == warning else TimeStepWarning, stacklevel=4)
    if scene.run.energy_tolerance is not None:
        result.status, result.message = ledger_verdict(result, scene.run.energy_tolerance,
                                                       "run.energy_tolerance")
    result.scene = scene
    result.model = model  # the chain constants writers, diagnostics and plots read
    return result


class NeighbourWatch:
    """A frame writer that remembers the first frame where granules i and i+2
    overlap (:func:`_overlap_warning`): one compiled pass over the
    frame's positions, about 2 µs for 10^4 granules."""

    def __init__(self, radius: np.ndarray):
        self.reach = _reach(radius)
        self.warning = ""

    def write_frame(self, frame: Frame) -> None:
        if not self.warning:
            self.warning = _overlap_warning(frame.x, self.reach, frame.t)

    def close(self, result) -> None:
        pass


@kernel(nogil=True)
def _neighbour_overlaps(x, reach):
    """(first i, count) of the pairs (i, i+2) whose spheres overlap, x[i+2] - x[i] <
    reach[i] = r_i + r_(i+2); (-1, 0) when none do.

    Parameters
    ----------
    x : ndarray, shape (N,)
        Centre positions (length).
    reach : ndarray, shape (N-2,)
        r_i + r_(i+2) (length).
    """
    count = 0
    for i in range(reach.size):  # no early exit: the loop vectorises
        count += x[i + 2] - x[i] < reach[i]
    if count == 0:
        return -1, 0
    for i in range(reach.size):
        if x[i + 2] - x[i] < reach[i]:
            return i, count
    return -1, 0


def _reach(radius: np.ndarray) -> np.ndarray:
    """r_i + r_(i+2), shape (N-2,) (empty below 3 granules)."""
    return np.ascontiguousarray(radius[:-2] + radius[2:], dtype=np.float64)


def _overlap_warning(x: np.ndarray, reach: np.ndarray, t: float) -> str:
    """The warning for a frame at time ``t`` with positions ``x``, or ''."""
    i, count = _neighbour_overlaps(np.ascontiguousarray(x, dtype=np.float64), reach)
    if not count:
        return ""
    return (f"granules {i} and {i + 2} overlap at t = {t:.6g} (first recorded frame; "
            f"{count} such pairs): the overlaps of contacts {i} and {i + 1} exceed "
            f"granule {i + 1}'s diameter. The model has nearest-neighbour contacts "
            f"only, so it ignores that contact (a 3D DEM code would not): raise "
            f"contacts.stiffness or lower the velocities if it matters")


def _simulate_verlet(scene: Scene, model: Model, progress: Optional[bool],
                     log: Optional[FrameLog] = None, thermo=None) -> Result:
    """Run a scene with the Verlet stepper (see :class:`~.steppers.verlet.VerletRun`)."""
    return VerletRun(scene, model, progress, log=log, thermo=thermo).run()
