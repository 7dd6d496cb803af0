"""The run's progress bar: simulated time t / t_end with an ETA, for both steppers.

The drivers (Verlet and event stepper) update it between compiled chunks, which
return about every :data:`~granular_chain.interrupts.CHUNK_SECONDS` of wall time,
so the bar moves several times a second and no Python runs inside a chunk. The
bar measures simulated time, not steps: the event stepper's steps have no fixed
count, and a Verlet run's ETA is the same either way.

Whether a bar is shown (:func:`progress_bar`): ``progress=True`` always (on
standard error; in a Jupyter notebook a widget, via ``tqdm.auto``),
``progress=False`` never, ``progress=None`` only in a Jupyter notebook. The
command line asks for one when standard error is a terminal and ``--quiet``
is not given. Lines printed while a bar is shown (the thermo lines) go through
:func:`echo`, which clears the bar, prints and redraws it.
"""

from __future__ import annotations

import sys
from typing import Optional

from tqdm import tqdm
from tqdm.auto import tqdm as auto_tqdm

__all__ = ["ProgressBar", "progress_bar", "in_notebook", "echo"]

_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| t = {n:.4g}/{total:.4g} [{elapsed}<{remaining}]"


def in_notebook() -> bool:
    """True inside a Jupyter kernel (IPython's ZMQ shell); IPython is not imported here.

    Returns
    -------
    bool
        The code runs in a notebook (or another Jupyter front end).
    """
    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None else None
    return shell is not None and type(shell).__name__ == "ZMQInteractiveShell"


class ProgressBar:
    """A tqdm bar of simulated time, started at the run's first time and updated
    with the time reached.

    Parameters
    ----------
    t_end : float
        The run's end time, in the unit of the times given to :meth:`update`.
    scale : float
        Factor from those times to the time shown (the scene's unit; the event
        stepper runs in its own scaled time).
    notebook : bool
        Draw a notebook widget (``tqdm.auto``) instead of a text bar on standard error.
    """

    def __init__(self, t_end: float, scale: float = 1.0, notebook: bool = False):
        self.t_end, self.scale, self.notebook = float(t_end), float(scale), notebook
        self.bar = None

    def start(self, t: float) -> None:
        """Show the bar at time ``t`` (a continued run starts where it stopped, so
        the ETA is measured from there).

        Parameters
        ----------
        t : float
            Simulated time reached (unit of ``t_end``).
        """
        if self.bar is not None:
            return
        total, initial = self.t_end * self.scale, min(t, self.t_end) * self.scale
        kind = auto_tqdm if self.notebook else tqdm
        extra = {} if self.notebook else {"file": sys.stderr, "leave": False}
        # mininterval: the chunks return every ~0.1 s; redraw at most ~4 times a second
        self.bar = kind(total=total, initial=initial, desc="simulating", bar_format=_FORMAT,
                        mininterval=0.25, smoothing=0.1, dynamic_ncols=True, **extra)

    def update(self, t: float) -> None:
        """Move the bar to time ``t`` (starting it if it is not shown yet).

        Parameters
        ----------
        t : float
            Simulated time reached (unit of ``t_end``); clipped to ``t_end``.
        """
        if self.bar is None:
            self.start(t)
            return
        shown = min(t, self.t_end) * self.scale
        if shown > self.bar.n:
            self.bar.update(shown - self.bar.n)

    def close(self) -> None:
        """Remove the bar (a text bar leaves no line behind; the run's report follows)."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def progress_bar(progress: Optional[bool], t_end: float, scale: float = 1.0):
    """The run's bar, or None when none is to be shown.

    Parameters
    ----------
    progress : bool or None
        True: a bar (a widget in a notebook, else text on standard error);
        False: none; None: a bar in a Jupyter notebook only.
    t_end : float
        The run's end time (unit of the times the driver gives).
    scale : float
        Factor from the driver's times to the scene's.

    Returns
    -------
    ProgressBar or None
    """
    notebook = in_notebook()
    if progress is False or (progress is None and not notebook):
        return None
    return ProgressBar(t_end, scale, notebook=notebook)


def echo(print_line) -> None:
    """Call ``print_line()`` with any text bar on the terminal cleared and redrawn
    after, so a printed line never lands in the middle of a bar.

    Parameters
    ----------
    print_line : callable
        Prints one line (to standard output or standard error).
    """
    with tqdm.external_write_mode():
        print_line()
