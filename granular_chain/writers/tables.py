"""CSV tables: the energy ledger per frame and the event log.

``energy.csv`` (one row per output frame)::

    t,kinetic,potential,coulomb,viscous,contact_dissipated,wall_work,body_work,balance

``kinetic`` = sum m v^2/2, ``potential`` = elastic energy of the contacts, ``coulomb`` and
``viscous`` = energy dissipated so far by kinetic and hydrodynamic friction (>= 0),
``contact_dissipated`` = energy dissipated so far by the contacts' dashpots (>= 0),
``wall_work`` and ``body_work`` = work done on the chain so far by moving walls and by
body forces, and ``balance`` = kinetic + potential + coulomb + viscous +
contact_dissipated - wall_work - body_work - initial, the integrator's
energy error (0 for an exact integrator). Numbers are written with 17 significant
digits, so reading them back gives the same doubles.

``events.csv`` (only when the stepper logged events: the event stepper, or Verlet with
``output.events``)::

    step,t,kind,index

``step`` is the Verlet step at whose end the event was seen (``t`` its end time; -1
with the event stepper, whose event times are exact); ``kind`` is ``contact_close``,
``contact_open``, ``stop`` or ``slip``; ``index`` is the contact (-1 left wall, N-1
right wall) or the granule.

Read with ``numpy.genfromtxt(path, delimiter=",", names=True)`` or ``pandas.read_csv``.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path
from typing import Optional

import numpy as np

from ..result import TERMS_ADDED

__all__ = ["write_energy_csv", "write_events_csv", "write_tables", "ENERGY_COLUMNS",
           "EnergyTable"]

ENERGY_COLUMNS = ("t", "kinetic", "potential", "coulomb", "viscous", *TERMS_ADDED, "balance")


def write_energy_csv(result, folder) -> Path:
    """Write ``folder/energy.csv`` from ``result.t`` and ``result.energy``.

    Parameters
    ----------
    result : Result
        The finished run.
    folder : str or Path
        Run folder written into.

    Returns
    -------
    Path
        ``folder/energy.csv``.
    """
    led = result.energy
    table = np.column_stack([result.t, led.kinetic, led.potential, led.coulomb, led.viscous,
                             *(getattr(led, name) for name in TERMS_ADDED), led.balance])
    path = Path(folder) / "energy.csv"
    np.savetxt(path, table, delimiter=",", fmt="%.17g", header=",".join(ENERGY_COLUMNS),
               comments="")
    return path


def keep_lines(path: Path, lines: int) -> None:
    """Cut a text file the engine wrote to its first ``lines`` lines (a run restarted
    from a checkpoint drops what came after it); written beside and renamed."""
    path = Path(path)
    with path.open("rb") as fh:  # bytes: the line ends stay as written (csv writes \r\n)
        kept = [line for _, line in zip(range(lines), fh)]
    if len(kept) < lines:
        raise ValueError(f"{path} has {len(kept)} lines, fewer than the checkpoint's {lines}")
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(b"".join(kept))
    os.replace(tmp, path)


class EnergyTable:
    """``energy.csv`` written frame by frame as the run goes (a frame writer).

    The rows are those :func:`write_energy_csv` writes from a finished Result,
    to the last bit. ``resume_rows``: continue a file after its first rows (a
    run restarted from a checkpoint).

    Parameters
    ----------
    folder : str or Path
        Run folder; the file is ``folder/energy.csv``.
    resume_rows : int, optional
        Rows kept from an existing file (a restart); None starts a new file.
    """

    def __init__(self, folder, resume_rows: Optional[int] = None):
        self.path = Path(folder) / "energy.csv"
        if resume_rows is not None:
            keep_lines(self.path, 1 + resume_rows)
            self._fh = self.path.open("a")
            return
        self._fh = self.path.open("w")
        self._fh.write(",".join(ENERGY_COLUMNS) + "\n")

    def flush(self) -> None:
        """Push the rows written so far to disk (before a checkpoint)."""
        self._fh.flush()

    def write_frame(self, frame) -> None:
        """Write the row of one frame.

        Parameters
        ----------
        frame : Frame
            One output frame (time, positions, velocities, ledger; scene units).
        """
        values = (frame.t, frame.kinetic, frame.potential, frame.coulomb, frame.viscous,
                  *(getattr(frame, name) for name in TERMS_ADDED), frame.balance)
        self._fh.write(",".join("%.17g" % v for v in values) + "\n")

    def close(self, result=None) -> None:
        """Close the file (its rows are flushed).

        Parameters
        ----------
        result : Result, optional
            The finished run (unused: every row came with the frames).
        """
        if not self._fh.closed:
            self._fh.close()


def write_events_csv(result, folder) -> Optional[Path]:
    """Write ``folder/events.csv`` if ``result.events`` is non-empty; return its path or None.

    Parameters
    ----------
    result : Result
        The finished run.
    folder : str or Path
        Run folder written into.

    Returns
    -------
    Path or None
        ``folder/events.csv``, or None when there are no events.
    """
    if not result.events:
        return None
    path = Path(folder) / "events.csv"
    with path.open("w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(("step", "t", "kind", "index"))
        for ev in result.events:
            out.writerow((int(ev.step), repr(float(ev.t)), ev.kind, int(ev.index)))
    return path


def write_tables(result, folder, scene=None) -> list[Path]:
    """Write energy.csv and (when there are events) events.csv; return the paths written.

    Parameters
    ----------
    result : Result
        The finished run.
    folder : str or Path
        Run folder written into.
    scene : Scene, optional
        The run's scene (recorded for reference).

    Returns
    -------
    list of Path
        The CSV files written.
    """
    paths = [write_energy_csv(result, folder)]
    ev = write_events_csv(result, folder)
    if ev is not None:
        paths.append(ev)
    return paths
