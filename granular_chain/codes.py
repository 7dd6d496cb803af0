"""How a run ends and what happens in it: the one numbering, shared by both
steppers, their compiled kernels, the result and the writers.

Compiled kernels return these integers (numba reads ``IntEnum`` members as
constants): a :class:`Status` when the run has ended, a :class:`Pause` when the
kernel returns only so that Python can act (drain a log, check for Ctrl-C,
write a frame) and will be called again.
"""

from __future__ import annotations

import enum

__all__ = ["Status", "Pause", "EventKind", "EVENT_KINDS"]


class Status(enum.IntEnum):
    """How a run ended. Non-negative values are successes."""

    T_END = 0  #: reached t_end
    SEPARATED = 1  #: the watched contact opened (stop: separation)
    AT_REST = 2  #: every granule at rest (stop: rest)
    MAX_STEPS = -1  #: refused to take more than run.max_steps steps
    NONFINITE = -2  #: NaN or Inf appeared in the state
    MAX_EVENTS = -3  #: event stepper: more than run.max_events events
    ZENO = -4  #: event stepper: events accumulate at a finite time
    UNSTABLE = -5  #: the energy ledger stopped balancing (error above the initial energy)
    OVERLAP = -6  #: an overlap grew beyond a granule's radius: the contact model no longer applies
    INTERRUPTED = -7  #: stopped by SIGINT (Ctrl-C) or SIGTERM; the result holds what was computed
    INACCURATE = -8  #: the run ended, but its energy ledger missed the stepper's promised tolerance

    @property
    def success(self) -> bool:
        """True for a run that ended normally (a non-negative status)."""
        return self.value >= 0

    def __str__(self) -> str:
        """The lower-case name (``t_end``, ``separated``...), as summary.json writes it."""
        return self.name.lower()

    def __format__(self, spec: str) -> str:
        # Integer presentation types keep the number ({s:d}); anything else the name.
        if spec and spec[-1] in "bdnoxX":
            return format(int(self), spec)
        return format(str(self), spec)


class Pause(enum.IntEnum):
    """A compiled call returned without ending the run: call it again.

    Values lie above every :class:`Status`, so one integer says both.
    """

    CHUNK_DONE = 10  #: the call's share of steps or work is done (time to check signals, write)
    LOG_FULL = 11  #: the event log has no room for another step: drain it and call again


class EventKind(enum.IntEnum):
    """Kinds of events in an event log (index of the event-count arrays)."""

    CONTACT_CLOSE = 0
    CONTACT_OPEN = 1
    STOP = 2  #: a sliding granule stuck (Coulomb friction)
    SLIP = 3  #: a stuck granule started to slide

    def __str__(self) -> str:
        return self.name.lower()


#: Names of the event kinds in order, as events.csv and Result.events write them.
EVENT_KINDS = tuple(str(k) for k in EventKind)
