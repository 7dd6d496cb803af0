"""The energy ledger as the judge of a run's status.

A run that reports success must have an energy ledger within the tolerance its
stepper promises; otherwise its numbers are not what the stepper says they are,
and the status becomes :attr:`~granular_chain.result.Status.INACCURATE`. Each
stepper states and derives its own tolerance; this module only compares.
"""

from __future__ import annotations

import math

from .result import Result, Status

__all__ = ["ledger_verdict"]


def ledger_verdict(result: Result, tolerance: float, what: str = "") -> tuple[Status, str]:
    """Status and message of ``result`` once its energy ledger is checked.

    Parameters
    ----------
    result : Result
        A finished run; its ``status`` and ``message`` are not modified.
    tolerance : float
        Largest ``result.energy.balance_error`` (relative to the initial energy,
        dimensionless) the stepper promises for this run.
    what : str, optional
        What set the tolerance, for the message (default: the stepper's promise).

    Returns
    -------
    (Status, str)
        ``(result.status, result.message)`` unless the run would report success
        while its ledger error exceeds ``tolerance`` (or is not a number): then
        ``Status.INACCURATE`` and a message giving both numbers.
    """
    if not result.status.success:
        return result.status, result.message
    err = result.energy.balance_error
    if err <= tolerance:  # (False for NaN)
        return result.status, result.message
    shown = "nan" if math.isnan(err) else f"{err:.3g}"
    what = what or f"the {result.stepper} stepper's promised tolerance"
    return Status.INACCURATE, (
        f"{result.message}; but the energy ledger's error {shown} (relative to the initial "
        f"energy) exceeds {what} {tolerance:.3g} for this run, so the numbers are not "
        f"trusted")
