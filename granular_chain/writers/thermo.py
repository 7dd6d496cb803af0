"""The thermo log (LAMMPS' ``thermo N``): a line of run-wide numbers every few steps.

Each line holds the step, the time, the kinetic and elastic energy, the energy
dissipated so far (Coulomb, viscous and the contacts' dashpots), the energy ledger's relative error,
the number of closed contacts (walls included) and the number of granules
sliding (moving granules that feel Coulomb friction). The lines go to
``thermo.csv`` as the run goes and, when asked, to the terminal: a table with
a header (rich) on a terminal, plain aligned lines otherwise.
"""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path
from typing import Optional

import numpy as np
from rich.console import Console

from ..progress import echo
from .tables import keep_lines

__all__ = ["ThermoLog", "COLUMNS"]

COLUMNS = ("step", "t", "kinetic", "potential", "dissipated", "ledger_error",
           "contacts_closed", "sliding")


class ThermoLog:
    """Thermo lines of one run, written to ``thermo.csv`` and optionally printed.

    Parameters
    ----------
    model : Model
        For the radii, walls and friction of the granules.
    every : int
        Steps between lines (the Verlet driver calls :meth:`write_frame` on this
        cadence; frames handed on by the event stepper are thinned to ``dt``).
    path : Path, optional
        ``thermo.csv`` (None: not saved).
    echo : bool
        Print each line to standard output.
    dt : float, optional
        Simulated time between lines for frames handed on as they come (event
        stepper): a frame is written when at least ``dt`` after the last one.
    resume_lines : int, optional
        Lines kept from an existing ``thermo.csv`` (a restart); None starts a new file.
    """

    def __init__(self, model, every: int, path: Optional[Path] = None, echo: bool = False,
                 dt: Optional[float] = None, resume_lines: Optional[int] = None):
        self.every, self.dt = every, dt
        self._model = model
        self._contact_reach = model.radius[:-1] + model.radius[1:]
        self._coulomb = model.eta_static > 0
        self._last_t = -math.inf
        self.lines = 0
        self.last_step = None
        self._fh = self._csv = None
        if path is not None and resume_lines is not None:  # a run restarted from a checkpoint
            keep_lines(path, 1 + resume_lines)
            self._fh = open(path, "a", newline="")
            self._csv = csv.writer(self._fh)
            self.lines = resume_lines
        elif path is not None:
            self._fh = open(path, "w", newline="")
            self._csv = csv.writer(self._fh)
            self._csv.writerow(COLUMNS)
        self._echo = _Echo() if echo else None

    def row(self, frame) -> tuple:
        """The thermo values of one frame, in the order of :data:`COLUMNS`.

        Parameters
        ----------
        frame : Frame
            One output frame (time, positions, velocities, ledger; scene units).

        Returns
        -------
        tuple
            One value per column of :data:`COLUMNS`, in scene units.
        """
        x = frame.x
        closed = int(np.count_nonzero(self._contact_reach - np.diff(x) > 0.0))
        m = self._model
        if m.features.left_wall or m.features.right_wall:
            u = x - m.x0
            d0 = m.contacts.d0  # the walls are the table's rows 0 and N
            closed += int(m.features.left_wall and d0[0] - u[0] > 0.0)
            closed += int(m.features.right_wall and d0[-1] + u[-1] > 0.0)
        sliding = int(np.count_nonzero(self._coulomb & (frame.v != 0.0)))
        return (frame.step, frame.t, frame.kinetic, frame.potential,
                frame.coulomb + frame.viscous + frame.contact_dissipated, frame.balance_error,
                closed, sliding)

    def write_frame(self, frame) -> None:
        """Write (and maybe print) the line of one frame, on the log's cadence.

        Parameters
        ----------
        frame : Frame
            One output frame (time, positions, velocities, ledger; scene units).
        """
        if self.dt is not None and frame.t < self._last_t + self.dt:
            return
        self._last_t = frame.t
        self.last_step = frame.step
        self.lines += 1
        row = self.row(frame)
        if self._csv is not None:
            self._csv.writerow([repr(float(v)) if isinstance(v, float) else v for v in row])
            self._fh.flush()
        if self._echo is not None:
            self._echo.line(row)

    def close(self, result=None) -> None:
        """Close ``thermo.csv``.

        Parameters
        ----------
        result : Result, optional
            The finished run (unused: every row came with the frames).
        """
        if self._fh is not None:
            self._fh.close()
            self._fh = None


class _Echo:
    """Thermo lines on standard output: a rich table row on a terminal, else plain.

    A line is 79 characters: it fits an 80-column terminal without wrapping (the
    time and the energies in 10 characters at most, see :func:`_g`).
    """

    _WIDTHS = (10, 11, 11, 11, 11, 9, 8, 8)

    def __init__(self):
        self._rich = None
        if sys.stdout.isatty():
            self._rich = Console(highlight=False)
        header = "".join(f"{name:>{w}}" for name, w in zip(
            ("step", "t", "kinetic", "potential", "dissipated", "ledger", "closed", "sliding"),
            self._WIDTHS))
        if self._rich is not None:
            echo(lambda: self._rich.print(f"[bold]{header}[/bold]"))
        else:
            echo(lambda: print(header, flush=True))

    def line(self, row) -> None:
        step, t, ke, pe, diss, err, closed, sliding = row
        values = (str(step), _g(t), _g(ke), _g(pe), _g(diss), f"{err:.2e}", str(closed),
                  str(sliding))
        text = "".join(value.rjust(w) for value, w in zip(values, self._WIDTHS))
        # a progress bar on the terminal is cleared for the line and drawn again below it
        if self._rich is not None:
            echo(lambda: self._rich.print(text))
        else:
            echo(lambda: print(text, flush=True))


def _g(value: float) -> str:
    """``value`` in 10 characters at most: 5 significant digits, fewer when that is
    too wide (a three-digit exponent, or a minus sign with a long exponent)."""
    for digits in (5, 4, 3):
        text = f"{value:.{digits}g}"
        if len(text) <= 10:
            break
    return text
