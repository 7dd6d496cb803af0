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
import signal
import threading
from dataclasses import dataclass

__all__ = ["CHUNK_SECONDS", "STOP_SIGNALS", "StopRequest", "Stopped", "stop_signals"]

#: The signals that stop a run cleanly (SIGHUP: the terminal was closed; absent on
#: Windows).
STOP_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP")
                     if hasattr(signal, name))

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
    if threading.current_thread() is not threading.main_thread():
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
