"""The event kernel's records: what it reads, the state it advances, what it writes.

The kernel takes NamedTuples of arrays (numba passes them as plain structs
whose members are the arrays themselves, so ``model.mass[i]`` costs what
``mass[i]`` did) and two one-element structured arrays for its scalars. A
structured record read as ``clock = clock_array[0]`` is a reference into the
array: ``clock.time = t`` writes through, so the driver sees the state between
calls and a call resumes exactly where the last one returned. Scalars in
arrays (not in an immutable NamedTuple) are what makes that possible.

The kernel's functions are compiled without numba's reference counting
(``_nrt=False``): they allocate nothing, and with it every call increfs and
decrefs each array of the NamedTuples it is given, which made a two-granule
run four times slower than the same loop on positional arrays. The phases
called once per step are inlined into the loop (``inline="always"``) so that
the records are not copied into a call frame at each step.

Contacts are numbered for the kernel 0..N (0 = left wall, j = between
granules j-1 and j, N = right wall; ``ChainArrays.present`` marks which
exist); granules 0..N-1. Series arrays have P + 1 columns (Taylor order P).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .modal_n2 import MODE_DTYPE

#: Returned by a phase of the kernel that finished without ending the run or
#: pausing it: the main loop goes on. Not a code the kernel returns (those are
#: :class:`~granular_chain.codes.Status` and :class:`~granular_chain.codes.Pause`).
GOING = -100

__all__ = ["GOING", "SETTINGS_DTYPE", "CLOCK_DTYPE", "MODE_DTYPE", "ChainArrays", "MotionState",
           "Workspace", "FrameBuffers", "EventLog", "EventRecords"]

#: What the kernel is asked to do (one element; set by the driver, read by the kernel).
SETTINGS_DTYPE = np.dtype([
    ("t_end", np.float64),           # end time (kernel units)
    ("frame_interval", np.float64),  # output cadence in time (0: none)
    ("step_cap", np.float64),        # n = 2: largest step, 0.5 / (eigenvalue bound); 0: none
    ("rtol", np.float64),            # relative tolerance of the step control
    ("atol", np.float64),            # absolute tolerance (0 for n = 2)
    ("order", np.int64),             # Taylor order P
    ("watch", np.int64),             # kernel contact whose opening is "separation" (-10: none)
    ("stop_separation", np.int64),   # 1: end the run when the watched contact opens
    ("stop_rest", np.int64),         # 1: end the run when every granule is at rest
    ("max_events", np.int64),        # end the run with Status.MAX_EVENTS after this many
    ("max_steps", np.int64),         # end the run with Status.MAX_STEPS after this many steps
    ("frames_at_events", np.int64),  # 1: a frame at every event batch
    ("every", np.int64),             # a frame every this many steps (0: none)
    ("budget", np.int64),            # main-loop passes per call before Pause.CHUNK_DONE (0: none)
], align=True)

#: Where the run is (one element; advanced by the kernel).
CLOCK_DTYPE = np.dtype([
    ("time", np.float64),          # t, high part of a double-double (see time_lo)
    ("time_lo", np.float64),       # low part: t += h rounds with a bias over thousands of steps
    ("work_coulomb", np.float64),  # energy dissipated by Coulomb friction so far
    ("work_viscous", np.float64),  # energy dissipated by viscous friction so far
    ("work_contact", np.float64),  # energy dissipated by the contacts' dashpots so far
    ("work_wall", np.float64),     # work done on the chain by moving walls so far
    ("last_event", np.float64),    # time of the last event batch (Zeno test)
    ("jumped_from", np.float64),   # time from which the state was moved to t_end in closed form
    ("steps", np.int64),           # steps taken (Taylor or closed-form)
    ("n_events", np.int64),        # events in the log
    ("n_frames", np.int64),        # frames in the buffers
    ("started", np.int64),         # 1 once the first call has settled the modes
    ("watched", np.int64),         # 1 once the watched contact has closed
    ("zeno", np.int64),            # consecutive event batches without time advancing
    ("next_frame", np.int64),      # index k of the next cadence frame (at k * frame_interval)
    ("batches", np.int64),         # event batches so far
    ("n_moving", np.int64),        # size of the moving set (MotionState.moving)
    ("overlap_contact", np.int64),  # contact whose overlap reached its limit (Status.OVERLAP)
    ("jumped", np.int64),          # 1: overdamped jump to t_end; 2: nothing moves any more
], align=True)


class ChainArrays(NamedTuple):
    """The chain's constants in kernel numbering (kernel units)."""

    x0: np.ndarray             #: (N,) initial centre positions
    present: np.ndarray        #: (N + 1,) int8, 1 where the contact exists
    stiffness: np.ndarray      #: (N + 1,) force coefficient k of each contact
    exponent: np.ndarray       #: (N + 1,) potential exponent n of each contact
    mass: np.ndarray           #: (N,)
    eta: np.ndarray            #: (N,) kinetic (Coulomb) friction force
    eta_static: np.ndarray     #: (N,) static threshold
    gamma: np.ndarray          #: (N,) viscous coefficient
    overlap_limit: np.ndarray  #: (N + 1,) overlap at which the centres meet
    has_coulomb: np.ndarray    #: (N,) int8, 1 where the granule has a static threshold
    damping: np.ndarray        #: (N + 1,) dashpot coefficient of each contact (c, or A); 0: none
    dashpot: np.ndarray        #: (2,) int64: dashpot law (laws.damping code), tensile (0/1)
    body: np.ndarray           #: (N,) body force on each granule (force)
    wall_motion: np.ndarray    #: (2, 3) (kind, p1, p2) of the left and right wall (laws.wall_motion)


class MotionState(NamedTuple):
    """The state the kernel advances (besides the clock)."""

    u: np.ndarray           #: (N,) displacement from x0
    v: np.ndarray           #: (N,) velocity
    overlap: np.ndarray     #: (N + 1,) overlap of each contact (a state variable of its own)
    closed: np.ndarray      #: (N + 1,) int8 contact mode, 1 closed
    slide: np.ndarray       #: (N,) int8 friction mode: +-1 sliding, 0 stuck, 2 frictionless
    moving: np.ndarray      #: (N,) int64, moving[:clock.n_moving] the moving set
    is_moving: np.ndarray   #: (N,) int8 membership of the moving set
    moving_pos: np.ndarray  #: (N,) int64 place of a member in ``moving``
    wall_rate: np.ndarray   #: (2,) the walls' velocities s_L', s_R' now (0: fixed walls)


class Workspace(NamedTuple):
    """Scratch of a step and an event batch (no meaning between kernel calls but
    the flags, kept zero)."""

    u_series: np.ndarray        #: (N, P + 1) Taylor coefficients of u
    v_series: np.ndarray        #: (N, P + 1) of v
    d_series: np.ndarray        #: (N + 1, P + 2) of the overlaps (column P + 1: dashpots only)
    f_series: np.ndarray        #: (N + 1, P + 1) of the contact forces (applied)
    s_series: np.ndarray        #: (N + 1, P + 2) of the springs' forces (dashpots only)
    g_series: np.ndarray        #: (N + 1, P + 1) of spring + dashpot, applied or not (dashpots only)
    wall_series: np.ndarray     #: (2, P + 2) of the walls' displacements s_L, s_R (driven walls)
    row: np.ndarray             #: (max(P + 1, N + 1),) one series (stop/slip functions)
    force_on: np.ndarray        #: (N + 1,) 1.0 where a closed contact's force is switched on
    saved_u: np.ndarray         #: (N,) state kept while a frame inside the step is recorded
    saved_v: np.ndarray         #: (N,)
    saved_overlap: np.ndarray   #: (N + 1,)
    active: np.ndarray          #: (N + 1,) int64 contacts of the step
    stuck: np.ndarray           #: (N,) int64 stuck granules next to the step's contacts
    contact_flag: np.ndarray    #: (N + 1,) int8 listing flag, then event mark
    granule_flag: np.ndarray    #: (N,) int8 listing flag, then event mark
    old_closed: np.ndarray      #: (N + 1,) int8 contact modes before an event batch
    old_slide: np.ndarray       #: (N,) int8 friction modes before an event batch
    cand_kind: np.ndarray       #: (5 N + 16,) int64 kind of each root candidate
    cand_index: np.ndarray      #: (5 N + 16,) int64 its contact or granule
    cand_root: np.ndarray       #: (5 N + 16,) its root (time from the step's start)
    modal: np.ndarray           #: (1,) MODE_DTYPE: the closed-form n = 2 mode
    window: np.ndarray          #: (2,) int64 granules [lo, hi] an event batch settles


class FrameBuffers(NamedTuple):
    """Recorded frames (rows 0..clock.n_frames-1); grown or drained by the driver."""

    t: np.ndarray  #: (F,)
    x: np.ndarray  #: (F, N) centre positions
    v: np.ndarray  #: (F, N)
    f: np.ndarray  #: (F, N) net contact force on each granule
    e: np.ndarray  #: (F, 7) kinetic, elastic, Coulomb work, viscous work, dashpot work,
                   #: wall work, body work


class EventLog(NamedTuple):
    """Events (rows 0..clock.n_events-1), kernel numbering; grown by the driver."""

    t: np.ndarray       #: (E,)
    kind: np.ndarray    #: (E,) int64, a codes.EventKind
    index: np.ndarray   #: (E,) int64, model numbering (contact i between granules i, i+1)
    counts: np.ndarray  #: (4,) int64 events of each kind


class EventRecords(NamedTuple):
    """Everything the kernel takes, in the order :func:`~.kernel.run_events` takes it
    after its four compile-time feature codes."""

    settings: np.ndarray  #: (1,) SETTINGS_DTYPE
    clock: np.ndarray     #: (1,) CLOCK_DTYPE
    model: ChainArrays
    state: MotionState
    work: Workspace
    frames: FrameBuffers
    log: EventLog
