"""Event stepper: exact contact, separation, stop, stick and slip events for N granules.

Modules, in the order data flows through them:

* :mod:`.options` - what the stepper reads from a scene (:func:`event_options`);
* :mod:`.pack` - the Model and options packed into the kernel's records (:mod:`.records`);
* :mod:`.kernel` - the compiled loop (:func:`~.kernel.run_events`), built from
  :mod:`.series` (Taylor series of a mode), :mod:`.roots` (roots of the event
  conditions), :mod:`.modes` (contact and friction modes), :mod:`.modal_step`
  and :mod:`.modal_n2` (two granules, n = 2, in closed form) and :mod:`.output`
  (recorded frames);
* :mod:`.driver` - the Python side: units, kernel calls in chunks, streamed
  frames, checkpoints (:func:`simulate_events`, :class:`EventRun`);
* :mod:`.report` - the Result; :mod:`.batch` - many runs differing in friction
  (:class:`EventBatch`, for collision maps).

The method and its error control are described in :mod:`.kernel` and docs/events.md.
"""

from .batch import POINT_BUDGET, BatchOutput, EventBatch
from .driver import (CHECKPOINT_FORMAT, FIRST_BUDGET, MAX_EXPONENT, MIN_EXPONENT, EventRun,
                     check_exponents, checkpoint_state, next_budget, simulate_events)
from .options import EventOptions, event_options, series_order
from .report import EXACT_LEDGER_ULPS, ledger_tolerance

__all__ = ["simulate_events", "series_order", "checkpoint_state", "EventRun", "EventBatch",
           "BatchOutput", "check_exponents", "MIN_EXPONENT", "MAX_EXPONENT", "EventOptions",
           "event_options",
           "ledger_tolerance", "EXACT_LEDGER_ULPS", "POINT_BUDGET",
           "FIRST_BUDGET", "CHECKPOINT_FORMAT", "next_budget"]
