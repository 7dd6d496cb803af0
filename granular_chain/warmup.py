"""The first run of a scene compiles its kernels; compile them up front.

numba compiles each kernel specialisation (one per feature set: contact law,
friction, walls, ...) on its first use (10-60 s) and caches the machine code on
disk (``__pycache__``, or ``NUMBA_CACHE_DIR``), so later runs load it in about a
second. Whenever it compiles, :mod:`granular_chain._compile` issues a
:class:`~granular_chain.notices.CompileNotice` (``compiling kernels, first run
only (later runs reuse them): <feature set>``; the command line prints it as
one line on stderr) and logs on the ``granular_chain`` logger.
:func:`prepare_kernels` compiles (or loads) what a scene needs by stepping a
copy of it for two steps, so that a run's progress bar then measures stepping
only.
"""

from __future__ import annotations

import math
import time
import warnings

from .codes import Status
from .interrupts import Stopped
from .model import build_model
from .notices import COMPILE_NOTICE, CompileNotice, OverlapWarning, TimeStepWarning
from .simulate import simulate
from .steppers.verlet.timestep import verlet_dt

__all__ = ["prepare_kernels", "NOTICE"]

#: The compile notice (each adds the feature set it compiles).
NOTICE = COMPILE_NOTICE


def _two_step_copy(scene, model=None):
    """The scene cut to two steps (same features, same kernels, nothing worth writing);
    ``model``: the scene's, if built already."""
    tiny = scene.model_copy(deep=True)
    tiny.run.stages = None  # (the first stage's kernels are every stage's)
    model = model if model is not None else build_model(scene)
    if scene.run.stepper == "verlet":
        dt = verlet_dt(scene, model)
        tiny.run.dt = dt
        tiny.run.t_end = min(2 * dt, scene.run.t_end)
    else:
        period = model.shortest_period()
        span = 1e-3 * period if math.isfinite(period) else 1e-6 * scene.run.t_end
        tiny.run.t_end = min(span, scene.run.t_end)
    tiny.output.dt = None
    tiny.output.every = 1 if scene.run.stepper == "verlet" else None
    return tiny


def prepare_kernels(scene, *, quiet: bool = False, model=None) -> float:
    """Compile or load the kernels ``scene`` needs; returns the seconds it took.

    Called before a run so that the compilation is announced (and the progress
    bar of the run then measures stepping only).

    Parameters
    ----------
    scene : Scene
        The validated scene about to run.
    quiet : bool
        No compile notice (the :class:`~granular_chain.notices.CompileNotice` is
        ignored; the ``granular_chain`` logger still has it).
    model : Model, optional
        The scene's Model, if built already (it is not built again for the copy's
        step and span).

    Returns
    -------
    float
        Seconds of compiling or loading.
    """
    start = time.perf_counter()
    with warnings.catch_warnings():
        # what the two-step copy could warn about is the copy's (the run says its own)
        warnings.simplefilter("ignore", OverlapWarning)
        warnings.simplefilter("ignore", TimeStepWarning)
        if quiet:
            warnings.simplefilter("ignore", CompileNotice)
        copy = simulate(_two_step_copy(scene, model), progress=False)
    if copy.status == Status.INTERRUPTED:  # a stop meant for the command (also one that
        # came while numba compiled, which the copy's run took over): the command stops
        raise Stopped(int(copy.info.get("signal") or 2))
    return time.perf_counter() - start
