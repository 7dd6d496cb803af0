"""The velocity-Verlet stepper with exact friction kicks.

- :mod:`.records`: the named tuples the compiled kernels take (features, chain,
  timestep, state, call, event buffers);
- :mod:`.kernel`: the compiled step loops (the sweep; the blocked passes);
- :mod:`.forced`: the step loop of scenes with contact dashpots, body forces or
  driven walls (:func:`.forced.forced_chunk`), and :mod:`.forced_setup`, its
  records, step limits and energies on the driver's side;
- :mod:`.event_log`: the event log (``output.events``);
- :mod:`.timestep`: the default step, its stability limit and accuracy bound;
- :mod:`.driver`: :class:`VerletRun`: chunking, cadences, checkpoints (the step plan is
  :mod:`granular_chain.steppers.schedule`'s).
"""

from ...codes import EVENT_KINDS, EventKind, Pause
from .driver import VerletRun
from .event_log import EventLog, log_capacity, new_event_log
from .kernel import BLOCK, BLOCK_LONG, LONG_CHAIN, chunk_kernel, passes_chunk, sweep_chunk, synchronise
from .records import (PER_GRANULE, STOP_ON_REST, STOP_ON_SEPARATION, UNIFORM, UNIT, Call, Chain,
                      EventBuffers, Features, State, Timestep)
from .timestep import check_dt, default_dt

# Event-kind indices under the names the event stepper imports from here
# (granular_chain.codes.EventKind is their one definition).
EV_CLOSE, EV_OPEN, EV_STOP, EV_SLIP = (int(k) for k in EventKind)
LOG_FULL = Pause.LOG_FULL  # what a kernel call returns when the event log is full

__all__ = ["VerletRun", "default_dt", "check_dt", "EventLog",
           "new_event_log", "log_capacity", "sweep_chunk", "passes_chunk", "chunk_kernel",
           "synchronise", "Features", "Chain", "Timestep", "State", "Call", "EventBuffers",
           "PER_GRANULE", "UNIFORM", "UNIT", "STOP_ON_SEPARATION", "STOP_ON_REST", "BLOCK",
           "BLOCK_LONG", "LONG_CHAIN", "EVENT_KINDS", "EV_CLOSE", "EV_OPEN", "EV_STOP", "EV_SLIP",
           "LOG_FULL"]
