"""The kernel's records for a run of a Model (already in the units the kernel runs in)."""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple, Optional

import numpy as np

from ..._compile import kernel, specialised
from ...laws.contact import law_of_code
from ...laws.damping import DAMPING_VISCOELASTIC
from ...model import LAW_LINEAR, Model
from .kernel import run_events
from .modes import initial_friction_modes
from ..schedule import FRAMES_AT_EVENTS_MAX_N
from .options import (LINEAR_ORDER, LINEAR_RTOL, LINEAR_STEP, EventOptions, frame_interval,
                      series_order)
from .records import (CLOCK_DTYPE, MODE_DTYPE, SETTINGS_DTYPE, ChainArrays, EventLog,
                      EventRecords, FrameBuffers, MotionState, Workspace)

#: Rows of the frame buffers of a run whose frames are streamed (handed to a
#: FrameLog between kernel calls): at most STREAM_FRAMES, at most about
#: STREAM_VALUES values per array (x, v, f) for long chains, at least 16.
STREAM_FRAMES = 256
STREAM_VALUES = 1 << 16


#: Snapshots of the settings and clock records as Python values (one C call to
#: read; numpy's record attribute access costs a microsecond per field).
SettingsValues = NamedTuple("SettingsValues", [(n, object) for n in SETTINGS_DTYPE.names])
ClockValues = NamedTuple("ClockValues", [(n, object) for n in CLOCK_DTYPE.names])


@dataclasses.dataclass
class Packed:
    """The kernel's records for one run, and what the result is built from.

    Attributes
    ----------
    records : EventRecords
        The kernel's arrays (settings, clock, chain, state, workspace, frames,
        log), kernel units (times in units of the time scale the run uses).
    kernel : object
        The compiled entry point (:func:`~.kernel.run_events` specialised to them).
    law : int
        Contact-law code (``laws.contact``).
    coulomb, viscous : int
        Feature codes: 1 when some granule has Coulomb (viscous) friction, else 0.
    dissip : int
        1: dashpots, body forces or driven walls compiled in (:func:`dissipative`), else 0.
    options : EventOptions
        The run's options, times in kernel units.
    ke0 : float
        Initial kinetic energy, kernel units.
    projection : tuple of (float, float)
        (steps still needed at the pace reached, that pace as a mean step in
        kernel time units) when the run stopped because ``run.max_steps`` could
        not reach t_end; (0.0, 0.0) otherwise.
    out_of_steps : bool
        Stopped by that projection (Status.MAX_STEPS).
    roundoff : tuple of (float, float) or None
        (kernel time, relative speed over its roundoff floor) of the first opening of
        the watched contact that was only its overlap decaying through roundoff (the
        run went on), else None.
    """

    records: EventRecords
    kernel: object  #: compiled entry point for them
    law: int
    coulomb: int
    viscous: int
    dissip: int  #: 1: dashpots, body forces or driven walls compiled in (:func:`dissipative`)
    options: EventOptions  #: kernel units
    ke0: float  #: initial kinetic energy
    #: (steps still needed at the pace reached, that pace) when the run stopped
    #: because run.max_steps could not reach t_end
    projection: tuple = (0.0, 0.0)
    out_of_steps: bool = False  #: stopped by that projection (Status.MAX_STEPS)
    #: (time, relative speed over its roundoff floor) of the watched contact's first
    #: opening below roundoff (:func:`~..opening.resolved_opening`), or None
    roundoff: Optional[tuple] = None

    @property
    def settings(self) -> "SettingsValues":
        """The settings record's values now (a snapshot: write through ``records.settings``)."""
        return SettingsValues(*self.records.settings[0].item())

    @property
    def clock(self) -> "ClockValues":
        """The clock record's values now (a snapshot: write through ``records.clock``)."""
        return ClockValues(*self.records.clock[0].item())

    @property
    def linear(self) -> bool:
        """True for the linear contact law (n = 2), which the kernel solves exactly."""
        return self.law == LAW_LINEAR

    def with_records(self, records: EventRecords) -> "Packed":
        """A copy holding other records (another run of the same packing)."""
        return Packed(records, self.kernel, self.law, self.coulomb, self.viscous, self.dissip,
                      self.options, self.ke0, self.projection, self.out_of_steps)

    def call(self) -> int:
        """Run the kernel on the records (until it returns a Status or a Pause)."""
        return self.kernel(self.law, self.coulomb, self.viscous, dissipative_arg(self.dissip),
                           *self.records)


@kernel(error_model="numpy", _nrt=False)
def linear_step_cap(model):
    """n = 2: largest step, LINEAR_STEP / L with L a bound on the eigenvalues of
    any linear mode.

    L is the drag rate plus twice the fastest contact frequency (a chain's
    highest mode is 2 sqrt(k/m)) plus four times the fastest dashpot rate c/m
    (a dashpot between two granules pulls both: rate 2c/m each side). A bound
    on every mode, read from the kernel's records, so it is at least the
    relaxation rate :func:`granular_chain.laws.damping.dashpot_rate` (c/m_eff).

    Parameters
    ----------
    model : ChainArrays
        The chain's constants, kernel units: ``stiffness``, ``present``,
        ``damping`` (N + 1,), ``mass``, ``gamma`` (N,).

    Returns
    -------
    float
        The step cap, kernel time units; 0.0 (no cap) when L = 0.
    """
    kmax = 0.0
    first = True
    for j in range(model.present.size):
        if model.present[j] == 1:
            if first or model.stiffness[j] > kmax:
                kmax = model.stiffness[j]
            first = False
    drag = 0.0
    imax = 0.0
    for i in range(model.mass.size):
        im = 1.0 / model.mass[i]
        g = model.gamma[i] * im
        if i == 0 or g > drag:
            drag = g
        if i == 0 or im > imax:
            imax = im
    L = drag + 2.0 * math.sqrt(kmax * imax)
    cmax = 0.0
    for j in range(model.present.size):
        if model.present[j] == 1 and model.damping[j] > cmax:
            cmax = model.damping[j]
    if cmax > 0.0:
        # (viscoelastic n = 2: the dashpot is A k, a rate A k / m)
        c_eff = cmax * kmax if model.dashpot[0] == DAMPING_VISCOELASTIC else cmax
        L += 4.0 * c_eff * imax
    return LINEAR_STEP / L if L > 0 else 0.0


def _contacts(model: Model):
    """present, overlap, stiffness, exponent of the kernel's contacts 0..N: the contact
    table's, with a unit linear law in the rows of absent walls (never read there, but
    finite in every formula the kernel forms)."""
    t = model.contacts
    absent = t.present == 0
    return (t.present.copy(), t.d0.copy(), np.where(absent, 1.0, t.k),
            np.where(absent, 2.0, t.n))


def dissipative(model: Model) -> int:
    """1 when the scene has dashpots, body forces or a driven wall, else 0.

    With 1 their code is compiled in (their kinds, tensile and the wall motion
    are runtime values); with 0, an elastic chain between fixed walls, the code
    is left out and the kernels compute what the frictionless and friction
    cases did, bit for bit. The kernel receives it as :func:`dissipative_arg`.

    Parameters
    ----------
    model : Model
        The run's model (any units).

    Returns
    -------
    int
        0 or 1.
    """
    return 0 if model.features.elastic_and_fixed else 1


def dissipative_arg(dissip: int):
    """The kernel's ``dissip`` argument: None (elastic, fixed walls) or 1.

    Parameters
    ----------
    dissip : int
        :func:`dissipative`'s code, 0 or 1.

    Returns
    -------
    None or int
        None for 0, else 1.
    """
    return 1 if dissip else None


def _dissipation_arrays(model: Model):
    """damping (N + 1,), dashpot (2,), body (N,), wall_motion (2, 3) of ChainArrays."""
    feat = model.features
    damping = model.contacts.damping.copy()  # (zeros without dashpots)
    dashpot = np.array([int(feat.damping), int(bool(feat.tensile))], dtype=np.int64)
    return (damping, dashpot, np.ascontiguousarray(model.body_force, dtype=np.float64),
            model.contacts.wall_motion.copy())


def _overlap_limits(model: Model) -> np.ndarray:
    """Overlap of each kernel contact at which the centres meet (N + 1,):
    r_(j-1) + r_j between granules, the granule's radius at a wall."""
    r = model.radius
    lim = np.empty(model.count + 1)
    lim[1:-1] = r[:-1] + r[1:]
    lim[0] = r[0]
    lim[-1] = r[-1]
    return lim


def _settings(options: EventOptions, N: int, linear: bool):
    settings = np.zeros(1, SETTINGS_DTYPE)
    s = settings.view(np.recarray)[0]
    if linear:
        s.order, s.rtol, s.atol = LINEAR_ORDER, LINEAR_RTOL, 0.0
    else:
        s.order, s.rtol, s.atol = series_order(options.rtol), options.rtol, options.atol
    s.t_end = options.t_end
    s.frame_interval = frame_interval(options)
    s.watch = options.stop_contact + 1 if N > 1 else -10
    s.stop_separation = int(options.stop_separation)
    s.stop_rest = int(options.stop_rest)
    s.max_events = options.max_events
    s.max_steps = options.max_steps
    s.frames_at_events = int(N <= FRAMES_AT_EVENTS_MAX_N)
    s.every = options.output_every or 0
    return settings


def _workspace(N: int, P: int) -> Workspace:
    ncand = 5 * N + 16
    i8, i64 = np.int8, np.int64
    return Workspace(
        u_series=np.zeros((N, P + 1)), v_series=np.zeros((N, P + 1)),
        d_series=np.zeros((N + 1, P + 2)), f_series=np.zeros((N + 1, P + 1)),
        s_series=np.zeros((N + 1, P + 2)), g_series=np.zeros((N + 1, P + 1)),
        wall_series=np.zeros((2, P + 2)),
        row=np.zeros(max(P + 1, N + 1)), force_on=np.zeros(N + 1), saved_u=np.zeros(N),
        saved_v=np.zeros(N), saved_overlap=np.zeros(N + 1), active=np.zeros(N + 1, i64),
        stuck=np.zeros(N, i64), contact_flag=np.zeros(N + 1, i8), granule_flag=np.zeros(N, i8),
        old_closed=np.zeros(N + 1, i8), old_slide=np.zeros(N, i8),
        cand_kind=np.zeros(ncand, i64), cand_index=np.zeros(ncand, i64),
        cand_root=np.zeros(ncand), modal=np.zeros(1, MODE_DTYPE), window=np.zeros(2, i64))


def frame_buffers(rows: int, N: int) -> FrameBuffers:
    """Empty frame buffers of ``rows`` frames.

    Parameters
    ----------
    rows : int
        Frames the buffers hold, F.
    N : int
        Number of granules.

    Returns
    -------
    FrameBuffers
        Zeroed ``t`` (F,), ``x``, ``v``, ``f`` (F, N), ``e`` (F, 7).
    """
    return FrameBuffers(t=np.zeros(rows), x=np.zeros((rows, N)), v=np.zeros((rows, N)),
                        f=np.zeros((rows, N)), e=np.zeros((rows, 7)))


def pack_run(model: Model, options: EventOptions, stream: bool = False) -> Packed:
    """The kernel's records for a run of ``model`` with ``options`` (kernel units):
    the state, the settings and the work buffers.

    Parameters
    ----------
    model : Model
        The run's model, already in the units the kernel runs in.
    options : EventOptions
        Its run and output options, times in those units.
    stream : bool, optional
        With True the frame buffers get a size set by N alone (STREAM_FRAMES
        rows, fewer for long chains: the driver empties them between kernel
        calls) instead of room for the run's whole cadence.

    Returns
    -------
    Packed
        The records, the compiled kernel for the run's features and the
        initial kinetic energy (kernel units).
    """
    feat = model.features
    N = model.count
    law = int(feat.law)
    if not law_of_code(law).builtin:
        raise ValueError(f"the event stepper has Taylor series only for the built-in contact "
                         f"laws, not {law_of_code(law).name}: use the Verlet stepper")
    linear = law == LAW_LINEAR
    settings = _settings(options, N, linear)
    present, overlap, stiffness, exponent = _contacts(model)
    damping, dashpot, body, wall_motion = _dissipation_arrays(model)
    chain = ChainArrays(x0=model.x0, present=present, stiffness=stiffness, exponent=exponent,
                        mass=model.mass, eta=model.eta, eta_static=model.eta_static,
                        gamma=model.gamma, overlap_limit=_overlap_limits(model),
                        has_coulomb=np.zeros(N, dtype=np.int8), damping=damping,
                        dashpot=dashpot, body=body, wall_motion=wall_motion)
    v = model.v0.copy()
    state = MotionState(u=np.zeros(N), v=v, overlap=overlap,
                        closed=((overlap > 0) & (present == 1)).astype(np.int8),
                        slide=np.zeros(N, dtype=np.int8), moving=np.zeros(N, dtype=np.int64),
                        is_moving=np.zeros(N, dtype=np.int8),
                        moving_pos=np.zeros(N, dtype=np.int64), wall_rate=np.zeros(2))
    initial_friction_modes(chain, state)
    clock = np.zeros(1, CLOCK_DTYPE)
    clock["last_event"] = -math.inf
    if linear:
        settings["step_cap"] = linear_step_cap(chain)
    fcap = 64
    out_dt = float(settings["frame_interval"][0])
    if out_dt > 0.0:
        fcap = min(int(options.t_end / out_dt) + 16, 1 << 20)
    if stream:  # rows set by N only: memory does not depend on the number of frames
        fcap = max(16, min(STREAM_FRAMES, STREAM_VALUES // max(N, 1)))
    ecap = 4 * N + 64
    log = EventLog(t=np.zeros(ecap), kind=np.zeros(ecap, dtype=np.int64),
                   index=np.zeros(ecap, dtype=np.int64), counts=np.zeros(4, dtype=np.int64))
    records = EventRecords(settings, clock, chain, state,
                           _workspace(N, int(settings["order"][0])), frame_buffers(fcap, N), log)
    dissip = dissipative(model)
    kernel = specialised(run_events, (law, int(feat.coulomb), int(feat.viscous),
                                      dissipative_arg(dissip)) + records, (0, 1, 2))
    ke0 = 0.5 * float(np.dot(model.mass, v * v))
    return Packed(records=records, kernel=kernel, law=law, coulomb=int(feat.coulomb),
                  viscous=int(feat.viscous), dissip=dissip, options=options, ke0=ke0)
