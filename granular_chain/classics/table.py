"""The table every classic experiment prints: quantity, engine, reference, relative
difference, source (plain text, CSV, JSON)."""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import asdict, dataclass, field
from typing import Sequence

__all__ = ["Row", "COLUMNS", "conservation_rows", "format_table", "table_csv", "table_json"]

#: The columns, in order.
COLUMNS = ("quantity", "engine", "reference", "rel_diff", "source")


@dataclass(frozen=True)
class Row:
    """One compared number.

    Attributes
    ----------
    quantity : str
        What is compared, with its units.
    engine : float
        The engine's number.
    reference : float
        The reference's number.
    source : str
        Where the reference comes from (a paper, a closed form, an independent solve).
    rel_diff : float
        ``(engine - reference) / |reference|`` (``engine - reference`` when the
        reference is 0); filled in from the two.
    """

    quantity: str
    engine: float
    reference: float
    source: str
    rel_diff: float = field(default=math.nan)

    def __post_init__(self):
        scale = abs(self.reference) if self.reference != 0.0 else 1.0
        object.__setattr__(self, "engine", float(self.engine))
        object.__setattr__(self, "reference", float(self.reference))
        object.__setattr__(self, "rel_diff", (self.engine - self.reference) / scale)

    def as_dict(self) -> dict:
        """The row as a dict keyed by :data:`COLUMNS`.

        Returns
        -------
        dict
            Column -> value.
        """
        d = asdict(self)
        return {c: d[c] for c in COLUMNS}


def _cells(row: Row) -> list[str]:
    return [row.quantity, f"{row.engine:.13g}", f"{row.reference:.13g}",
            f"{row.rel_diff:.2e}", row.source]


def format_table(rows: Sequence[Row], title: str = "") -> str:
    """The rows as an aligned plain-text table (numbers to 13 significant digits).

    Parameters
    ----------
    rows : sequence of Row
        The table's rows.
    title : str
        A line printed above it.

    Returns
    -------
    str
        The table, lines joined by newlines (no final newline).
    """
    head = ["quantity", "engine", "reference", "rel. diff.", "source"]
    body = [_cells(r) for r in rows]
    widths = [max(len(line[i]) for line in [head, *body]) for i in range(len(head))]
    lines = [title] if title else []
    for k, line in enumerate([head, *body]):
        lines.append("  ".join(c.ljust(w) for c, w in zip(line, widths)).rstrip())
        if k == 0:
            lines.append("  ".join("-" * w for w in widths))
    return "\n".join(lines)


def table_csv(rows: Sequence[Row]) -> str:
    """The rows as CSV with the header :data:`COLUMNS` (numbers in full, ``repr``).

    Parameters
    ----------
    rows : sequence of Row
        The table's rows.

    Returns
    -------
    str
        The CSV text.
    """
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(COLUMNS)
    for r in rows:
        writer.writerow([r.quantity, repr(r.engine), repr(r.reference), repr(r.rel_diff),
                         r.source])
    return out.getvalue()


def table_json(name: str, title: str, rows: Sequence[Row], extra: dict) -> str:
    """An experiment's table and its other numbers as JSON.

    Parameters
    ----------
    name, title : str
        The experiment's name and title.
    rows : sequence of Row
        The table's rows.
    extra : dict
        Further numbers (JSON-ready) the experiment records.

    Returns
    -------
    str
        The JSON text (indented).
    """
    return json.dumps({"experiment": name, "title": title,
                       "rows": [r.as_dict() for r in rows], "data": extra}, indent=2) + "\n"


def conservation_rows(prefix: str, runs: dict, momentum_unit: str, energy_unit: str,
                      steppers=("event", "verlet")) -> list:
    """Momentum and energy at the run's end over their initial values, each stepper's.

    Parameters
    ----------
    prefix : str
        What the rows are of (``"q=0.1"``, ``"M/m=5"``).
    runs : dict
        stepper -> a run's numbers with ``momentum`` and ``energy`` (ratios to the
        initial values, dimensionless).
    momentum_unit, energy_unit : str
        The initial values' names, for the quantity column.
    steppers : sequence of str
        The keys of ``runs`` to report, in order.

    Returns
    -------
    list of Row
        Two rows per stepper, against 1 (source "conservation").
    """
    rows = []
    for s in steppers:
        rows.append(Row(f"{prefix} momentum at t_end / {momentum_unit}, {s}",
                        runs[s]["momentum"], 1.0, "conservation"))
        rows.append(Row(f"{prefix} energy at t_end / {energy_unit}, {s}", runs[s]["energy"],
                        1.0, "conservation"))
    return rows

