"""The first run of a scene compiles its kernels; say so, and compile them up front.

numba compiles each kernel specialisation on its first use (10-60 s) and
caches the machine code on disk (``__pycache__``, or ``NUMBA_CACHE_DIR``), so
later runs load it in about a second. :func:`prepare_kernels` compiles (or
loads) what a scene needs by stepping a copy of it for two steps, and, when
the stepper's kernels are not yet cached, says so on stderr: a ``rich``
spinner on a terminal, one plain line otherwise.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import time
from pathlib import Path

__all__ = ["kernels_cached", "prepare_kernels", "compile_notice", "announce_compilation", "NOTICE"]

NOTICE = "compiling kernels, first run only (later runs reuse them) ..."
_KERNEL_FILES = {"verlet": "kernel.*_chunk-*.nbi", "event": "kernel.run_events-*.nbi"}


def kernels_cached(stepper: str) -> bool:
    """Whether numba's cache holds an index for the stepper's main kernel.

    An index is written with the first compiled specialisation and removed
    when the package's sources change (see ``granular_chain._drop_stale_kernels``);
    a scene with a new feature set still compiles once more without notice.

    Parameters
    ----------
    stepper : {'verlet', 'event'}
        The stepper whose kernels are meant.

    Returns
    -------
    bool
        True when the index exists.
    """
    pattern = _KERNEL_FILES.get(stepper, _KERNEL_FILES["verlet"])
    custom = os.environ.get("NUMBA_CACHE_DIR")
    root = Path(custom) if custom else Path(__file__).resolve().parent / "steppers"
    return root.is_dir() and next(root.rglob(pattern), None) is not None


@contextlib.contextmanager
def compile_notice(stepper: str, stream=None, quiet: bool = False):
    """Around the code that compiles: spinner or one line when the kernels are not cached.

    Parameters
    ----------
    stepper : {'verlet', 'event'}
        The stepper whose kernels are meant.
    stream : file, optional
        Where the notice goes (default ``sys.stderr``).
    quiet : bool
        No notice.

    Yields
    ------
    None
    """
    stream = sys.stderr if stream is None else stream
    if quiet or kernels_cached(stepper):
        yield
        return
    if not stream.isatty():
        print(f"granular-chain: {NOTICE}", file=stream, flush=True)
        yield
        return
    from rich.console import Console

    console = Console(file=stream)
    start = time.perf_counter()
    with console.status(NOTICE, spinner="dots"):
        yield
    console.print(f"kernels compiled in {time.perf_counter() - start:.1f} s; "
                  f"later runs load them from the cache", highlight=False)


def announce_compilation(stepper: str, stream=None) -> None:
    """One line on stderr when ``stepper``'s kernels are not cached yet: for commands
    (figures, boundaries) whose first minute would otherwise pass in silence.

    Parameters
    ----------
    stepper : {'verlet', 'event'}
        The stepper whose kernels are meant.
    stream : file, optional
        Where the notice goes (default ``sys.stderr``).
    """
    if not kernels_cached(stepper):
        print(f"granular-chain: {NOTICE}", file=sys.stderr if stream is None else stream,
              flush=True)


def _two_step_copy(scene):
    """The scene cut to two steps (same features, same kernels, nothing worth writing)."""
    from .model import build_model
    from .simulate import default_dt

    tiny = scene.model_copy(deep=True)
    tiny.run.stages = None  # (the first stage's kernels are every stage's)
    model = build_model(scene)
    if scene.run.stepper == "verlet":
        dt = scene.run.dt if scene.run.dt is not None else default_dt(model, scene.run.t_end)
        tiny.run.dt = dt
        tiny.run.t_end = min(2 * dt, scene.run.t_end)
    else:
        period = model.shortest_period()
        span = 1e-3 * period if math.isfinite(period) else 1e-6 * scene.run.t_end
        tiny.run.t_end = min(span, scene.run.t_end)
    tiny.output.dt = None
    tiny.output.every = 1 if scene.run.stepper == "verlet" else None
    return tiny


def prepare_kernels(scene, *, quiet: bool = False, stream=None) -> float:
    """Compile or load the kernels ``scene`` needs; returns the seconds it took.

    Called before a run so that the compilation is announced (and the progress
    bar of the run then measures stepping only).

    Parameters
    ----------
    scene : Scene
        The validated scene about to run.
    quiet : bool
        No notice.
    stream : file, optional
        Where the notice goes (default ``sys.stderr``).

    Returns
    -------
    float
        Seconds of compiling or loading.
    """
    from .simulate import simulate

    start = time.perf_counter()
    with compile_notice(scene.run.stepper, stream=stream, quiet=quiet):
        simulate(_two_step_copy(scene), progress=False)
    return time.perf_counter() - start
