"""Stopping a run cleanly: SIGINT (Ctrl-C), SIGTERM and SIGHUP (the terminal closed)
become a request the drivers read between compiled chunks.

Compiled kernels cannot be interrupted from inside; a Python signal handler
only runs once the kernel has returned. So the drivers (Verlet and event
stepper) size their compiled chunks to return within about
:data:`CHUNK_SECONDS` of wall time, and between chunks they look at the
:class:`StopRequest` that :func:`stop_signals` hands them. A run that sees a
request ends with ``Status.INTERRUPTED`` and everything computed so far; the
command line writes that and exits with 128 + the signal number.

A second signal while the first is being honoured raises
:class:`KeyboardInterrupt` at once, so a user is never left without a way out.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from dataclasses import dataclass

__all__ = ["CHUNK_SECONDS", "STOP_SIGNALS", "StopRequest", "Stopped", "stop_signals",
           "raise_on_signals", "held_signals", "pool_worker_signals"]

#: The signals that stop a run cleanly (SIGHUP: the terminal was closed; absent on
#: Windows).
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP")
                     if hasattr(signal, name))

#: True in a pool's worker process (:func:`pool_worker_signals`): the signals are its
#: parent's to handle, and none of this module's blocks changes a handler there.
_POOL_WORKER = False

#: Target wall time of one compiled chunk (seconds): small enough that a stop
#: request is honoured well within one second, large enough that the Python
#: work between chunks costs well under 1 % of the run.
CHUNK_SECONDS = 0.1


@dataclass
class StopRequest:
    """What the signal handler saw: ``signum`` is 0 until a stop is asked for.

    Attributes
    ----------
    signum : int
        Number of the signal received (0: none).
    """

    signum: int = 0

    @property
    def requested(self) -> bool:
        """True once SIGINT, SIGTERM or SIGHUP arrived."""
        return self.signum != 0

    @property
    def name(self) -> str:
        """``SIGINT``, ``SIGTERM`` or ``SIGHUP`` (empty when no stop was asked for)."""
        return signal.Signals(self.signum).name if self.signum else ""

    @property
    def exit_code(self) -> int:
        """The conventional exit status of a process ended by this signal (128 + N)."""
        return 128 + self.signum if self.signum else 0


class Stopped(KeyboardInterrupt):
    """Raised by a loop of many runs (the scan of ``boundaries``) between two runs once
    a stop is asked for: its results so far are incomplete and are not used.

    Parameters
    ----------
    signum : int
        The signal that asked for the stop.
    """

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


@contextlib.contextmanager
def stop_signals():
    """While the block runs, SIGINT, SIGTERM and SIGHUP set the yielded :class:`StopRequest`.

    Outside the main thread (dask workers, threads) signals cannot be caught;
    the request then never fires and the default behaviour is kept. Handlers
    are restored on exit, so nesting (the CLI around ``simulate``) is safe: the
    inner block shares the outer request.

    Yields
    ------
    StopRequest
        Shared by nested blocks.
    """
    if not _main_thread():
        yield StopRequest()
        return
    current = signal.getsignal(signal.SIGINT)
    outer = getattr(current, "stop_request", None)
    if outer is not None:  # already inside stop_signals: share its request
        yield outer
        return
    request = StopRequest()

    def handler(signum, frame):
        if request.requested:  # asked twice: stop now, whatever is running
            raise KeyboardInterrupt
        request.signum = signum

    handler.stop_request = request
    previous = {s: signal.signal(s, handler) for s in STOP_SIGNALS}
    try:
        yield request
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


def _main_thread() -> bool:
    """The thread that may handle signals: the main thread, outside a pool's worker."""
    return threading.current_thread() is threading.main_thread() and not _POOL_WORKER


def pool_worker_signals() -> None:
    """Initializer of a process pool's workers (``Pool(initializer=...)``): the parent
    command owns the signals.

    SIGINT is ignored (a terminal's Ctrl-C reaches the whole process group: the parent
    stops and ends the pool); SIGTERM and SIGHUP end the worker at once, which is how
    ``Pool.terminate`` ends it. A worker forked while a run's :func:`stop_signals` or
    a command's :func:`raise_on_signals` was active would otherwise keep that handler:
    a SIGTERM taken as a stop request for the worker's own run left it alive, blocked
    on a result queue its parent no longer read, and the parent waiting for it for
    ever. Inside the worker, those blocks then change no handler.
    """
    global _POOL_WORKER
    _POOL_WORKER = True
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for s in STOP_SIGNALS:
        if s != signal.SIGINT:
            signal.signal(s, signal.SIG_DFL)


@contextlib.contextmanager
def raise_on_signals():
    """While the block runs, SIGINT, SIGTERM and SIGHUP raise :class:`Stopped`.

    The command line's frame around a whole command: a signal that arrives before
    a run's loop takes over (:func:`stop_signals`, which replaces these handlers
    for its block) or after it (scene loading, kernel compilation, claiming and
    writing output) unwinds the command at once through its cleanup, and the
    command exits with 128 + the signal number instead of the signal's default
    (SIGTERM, SIGHUP: the process dies on the spot, its files as they were).
    Outside the main thread nothing is changed; in a process forked meanwhile (a
    pool's worker) the signals keep their default action.

    Yields
    ------
    None
    """
    if not _main_thread():
        yield
        return

    pid = os.getpid()

    def handler(signum, frame):
        if os.getpid() != pid:  # a forked worker (a pool's): the signal's default action
            if signum == signal.SIGINT:
                raise KeyboardInterrupt
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)
            return
        if _in_callback(frame):  # an exception there would be printed and dropped:
            # the signal comes again a moment later, to whichever handler is current
            # then (this one, a run's stop request, a held block's), so none is lost
            resend = threading.Timer(0.02, os.kill, (pid, signum))
            resend.daemon = True
            resend.start()
            return
        raise Stopped(signum)

    previous = {s: signal.signal(s, handler) for s in STOP_SIGNALS}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


def _in_callback(frame) -> bool:
    """Whether ``frame`` runs inside llvmlite's callbacks (ctypes drops exceptions there)."""
    while frame is not None:
        if "llvmlite" in frame.f_code.co_filename:
            return True
        frame = frame.f_back
    return False


@contextlib.contextmanager
def held_signals():
    """Hold SIGINT, SIGTERM and SIGHUP back while the block runs; one that arrives
    meanwhile is handed, when the block ends, to the handler it would have met.

    For the few file-system steps that must not be cut in two (a folder created and
    marked, a temporary folder removed, a run renamed into place): a signal then acts
    before or after them, never between. Blocks last milliseconds. The signals are
    held by a recording handler, not by the thread's signal mask, which another
    thread of the process (a writer's, a progress bar's) would not share; swapping
    handlers runs the pending ones first (``signal.signal``), so none slips past.
    Outside the main thread nothing is held.

    Yields
    ------
    None
    """
    if not _main_thread():
        yield
        return
    pending = []
    previous = {s: signal.signal(s, lambda signum, frame: pending.append(signum))
                for s in STOP_SIGNALS}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)  # (runs the recording handler for any signal still pending)
        for signum in pending:
            _deliver(signum, previous[signum])


def _deliver(signum: int, handler) -> None:
    """Act on a held signal as ``handler`` (a Python handler, SIG_DFL or SIG_IGN) would."""
    if callable(handler):
        handler(signum, None)
    elif handler == signal.SIG_DFL:
        if signum == signal.SIGINT:
            raise KeyboardInterrupt
        os.kill(os.getpid(), signum)  # (its default action: the process ends by it)
