"""Event stepper: exact contact, separation, stop, stick and slip events for N granules.

``simulate_events(scene, model) -> Result`` is what :func:`granular_chain.simulate`
calls for ``run.stepper: event``. The compiled core is
:mod:`granular_chain.steppers.events_kernel` (method and error control are
described there and in docs/events.md); this module packs the model into the
kernel's arrays, grows the frame and event buffers between kernel calls, and
builds the :class:`~granular_chain.result.Result` exactly like the Verlet path.

Contacts are numbered for the kernel 0..N (0 = left wall, j = between granules
j-1 and j, N = right wall); the event log uses the model's numbering (contact
i between granules i and i+1, -1 the left wall, N-1 the right wall).
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import NamedTuple

import numba
from numba import literally
import numpy as np

from .._compile import specialised
from ..frames import Frame, FrameLog
from ..interrupts import CHUNK_SECONDS, StopRequest, stop_signals
from ..ledger import ledger_verdict
from ..model import LAW_LINEAR, Model
from ..result import OVERLAP_ADVICE, EnergyLedger, Event, Result, Status
from . import events_kernel as K
from .verlet import EVENT_KINDS

__all__ = ["simulate_events", "series_order", "checkpoint_state", "EventRun"]

# n = 2: order and relative size of the first neglected terms (below roundoff).
LINEAR_ORDER = 24
LINEAR_RTOL = 2e-17
# n = 2: largest step times the eigenvalue bound L (see events_kernel, S_HCAP).
LINEAR_STEP = 0.5


def series_order(rtol: float) -> int:
    """Taylor order for a relative tolerance (Jorba & Zou: about -ln(tol)/2, at least 8)."""
    return int(min(30, max(8, math.ceil(-0.5 * math.log(rtol)) + 2)))


def _pack(model: Model):
    N = model.count
    present = np.zeros(N + 1, dtype=np.int8)
    dl = np.zeros(N + 1)
    kc = np.ones(N + 1)
    nexp = np.full(N + 1, 2.0)
    present[1:N] = 1
    dl[1:N] = model.d0
    kc[1:N] = model.k
    nexp[1:N] = model.n
    w = model.walls
    if model.features.left_wall:
        present[0] = 1
        dl[0], kc[0], nexp[0] = w[0], w[1], w[2]
    if model.features.right_wall:
        present[N] = 1
        dl[N], kc[N], nexp[N] = w[3], w[4], w[5]
    return present, dl, kc, nexp


def _speed_scale(model: Model) -> float:
    """Speed scale of the scene: the larger of the speed a granule of mass m_0 would
    have with the most energetic granule's kinetic energy and the one it would have
    with the initial elastic energy (a precompressed scene starting at rest or at a
    tiny speed is scaled by the motion it will have)."""
    M = float(model.mass[0])
    V = float(np.max(np.abs(model.v0) * np.sqrt(model.mass / M)))
    pe0 = model.energies(np.zeros(model.count), model.v0)[1]
    return max(V, math.sqrt(2.0 * pe0 / M))


def _unscaled_atol(model: Model, atol: float) -> float:
    """atol for a scene run in its own units (:func:`_scales` returned None).

    atol is absolute, meant for scaled units (speeds ~ 1). A scene whose scales are
    too extreme to apply (speeds of 1e-94 against a friction stopping them at once)
    runs as given, where an atol of 1e-14 exceeded every velocity and overlap: the
    step control saw nothing, took whole-run steps, and the series of a decaying
    velocity grew its energy 2.5e5-fold (found by hypothesis). It is scaled by the
    speed scale when that is below 1."""
    V = _speed_scale(model)
    return atol * V if 0.0 < V < 1.0 else atol


def _scales(model: Model):
    """Mass, length, time scales (M, A, B) of Appendix A for this scene.

    The kernel's step control and tolerances (atol) are absolute, tuned for
    scaled units (m ~ 1, force coefficient ~ 1, speeds ~ 1). A scene in SI, or
    with an impact speed of 1e-8, is run in its own scaled units and the result
    converted back, so that the answer does not depend on the units.
    Returns None when the scene is already scaled (or nothing sets a scale).
    """
    M = float(model.mass[0])
    present_k = [float(k) for k in model.k]
    present_n = [float(n) for n in model.n]
    w = model.walls
    if model.features.left_wall:
        present_k.append(float(w[1]))
        present_n.append(float(w[2]))
    if model.features.right_wall:
        present_k.append(float(w[4]))
        present_n.append(float(w[5]))
    if not present_k:
        return None
    K0, n0 = present_k[0], present_n[0]
    # Speed scale: the larger of the speed a granule of mass M would have with
    # the most energetic granule's kinetic energy and the one it would have
    # with the initial elastic energy, so that a precompressed scene starting
    # at rest or at a tiny speed is scaled by the motion it will have.
    V = _speed_scale(model)
    if V == 0.0:
        return None
    # (M V^2/K0)^(1/n0) without forming V^2, which underflows below 1e-154
    A = (M / K0) ** (1.0 / n0) * V ** (2.0 / n0)
    B = (M / K0) ** (1.0 / n0) * V ** (2.0 / n0 - 1.0)
    # A drag, or a kinetic friction, stopping the motion far faster than the
    # collision (tiny speeds make B huge) sets the time scale instead: its
    # series would overflow in units of B.
    rate = max(float(np.max(model.gamma * model.inv_mass)) * B,
               float(np.max(model.eta * model.inv_mass)) * B / V)
    if rate > 1e3:
        B /= rate
        A /= rate
    if M == 1.0 and A == 1.0 and B == 1.0:
        return None
    # (short-circuit: a rate that overflowed to inf leaves B = 0, and A / B must not be formed)
    if not (1e-100 < A < 1e100 and 1e-100 < B < 1e100 and 1e-100 < A / B < 1e100):
        # Speeds near the underflow threshold (1e-300 and below): the scales
        # themselves would lose their digits; such a scene hardly moves and
        # is run as given.
        return None
    return M, A, B


def _scaled_model(model: Model, M: float, A: float, B: float) -> Model:
    # Force coefficients k A^n / (F A) with F = M A / B^2 the force scale,
    # written as k A^(n-2) B^2 / M and 1/F as (B/M)(B/A), so that no factor
    # underflows for tiny speeds (A ~ 1e-300 at v = 1e-300).
    w = model.walls.copy()
    w[0] /= A
    w[3] /= A
    w[1] = w[1] * A ** (w[2] - 2.0) * B * B / M
    w[4] = w[4] * A ** (w[5] - 2.0) * B * B / M
    inv_F = (B / M) * (B / A)
    return dataclasses.replace(
        model, mass=model.mass / M, inv_mass=model.inv_mass * M, radius=model.radius / A,
        x0=model.x0 / A, v0=model.v0 * (B / A), d0=model.d0 / A,
        k=model.k * A ** (model.n - 2.0) * (B * B / M), walls=w, eta=model.eta * inv_F,
        eta_static=model.eta_static * inv_F, gamma=model.gamma * (B / M))


#: Smallest contact exponent the event stepper accepts. Below it the contact force
#: k delta^(n-1) has a derivative growing fast as delta -> 0 and the ledger error
#: grows far beyond the rtol-based promise (measured, two spheres, ledger error /
#: promise at rtol 1e-12: n = 1.01: 2.4e-3 / 3.2e-10; 1.5: 3.5e-10 / 3.1e-10;
#: 1.6: 0.1 of it; 1.75: 0.001 of it; docs/events.md). Verlet takes every n > 1.
MIN_EXPONENT = 1.75


def check_exponents(model: Model) -> None:
    """Refuse a scene whose contacts (walls included) have an exponent below
    MIN_EXPONENT (SimulationError naming contacts.exponent)."""
    n = [float(x) for x in model.n]
    w = model.walls
    if model.features.left_wall:
        n.append(float(w[2]))
    if model.features.right_wall:
        n.append(float(w[5]))
    low = [x for x in n if x < MIN_EXPONENT]
    if low:
        from ..simulate import SimulationError
        raise SimulationError(
            f"contacts.exponent: the event stepper accepts exponents n >= {MIN_EXPONENT} "
            f"(n = 2 exactly, others to run.rtol); got n = {min(low):g}, for which its energy "
            f"ledger misses the promised tolerance (docs/events.md); use run.stepper: verlet")


def simulate_events(scene, model: Model, log: FrameLog | None = None, *, resume=None,
                    checkpoint=None, checkpoint_every: int = 0) -> Result:
    """Run the scene with the event stepper in its own scaled units (see :func:`_scales`).

    Parameters
    ----------
    scene, model
        The scene and its Model (:func:`granular_chain.simulate.preflight`).
    log : FrameLog, optional
        Where the frames go as the run goes (the scene's units; ``Frame.step`` is
        the frame's number): handed on between kernel calls, so memory does not
        grow with the number of frames when ``log.keep`` is false. Closed with the
        Result at the end. Without it (and without ``resume`` and ``checkpoint``)
        the frames stay in the kernel's buffers and the Result holds them all.
    resume : dict, optional
        A :func:`checkpoint_state` of a run of the same scene: the run continues
        from it; the frames handed on and the end state are those the run would
        have had without the interruption, bit for bit. The Result's frames are
        those handed on after the resume (with ``log.keep`` false: the first and
        latest of the whole run, the checkpoint holds the first).
    checkpoint : callable, optional
        ``checkpoint(state)`` with a :func:`checkpoint_state` dictionary, every
        ``checkpoint_every`` Taylor steps (at the kernel's next return after
        them) and when a signal interrupts the run (before its final frame).
    checkpoint_every : int
        Taylor steps between checkpoints (0: only at an interruption).
    """
    check_exponents(model)
    scales = _scales(model)
    streamed = log is not None or resume is not None or checkpoint is not None
    if streamed and log is None:
        log = FrameLog()
    kw = dict(log=log, resume=resume, checkpoint=checkpoint, checkpoint_every=checkpoint_every)
    if scales is None:
        atol = _unscaled_atol(model, scene.run.atol)
        if atol != scene.run.atol:
            scene = scene.model_copy(update={"run": scene.run.model_copy(update={"atol": atol})})
        r = _simulate_events(scene, model, None, **kw)
        if log is not None:
            log.close(r)
        return r
    M, A, B = scales
    run = scene.run.model_copy(update={"t_end": scene.run.t_end / B})
    out = scene.output.model_copy(
        update={"dt": scene.output.dt / B if scene.output.dt is not None else None})
    V, F, E = A / B, M * A / (B * B), M * A * A / (B * B)
    r = _simulate_events(scene.model_copy(update={"run": run, "output": out}),
                         _scaled_model(model, M, A, B), _Units(B, A, V, F, E), **kw)
    if not streamed:  # (a streamed run's frames and ledger are in the scene's units)
        led = r.energy
        r.energy = EnergyLedger(kinetic=led.kinetic * E, potential=led.potential * E,
                                coulomb=led.coulomb * E, viscous=led.viscous * E,
                                initial=led.initial * E)
        r.t, r.x, r.v, r.f = r.t * B, r.x * A, r.v * V, r.f * F
    r.t_final, r.x_final, r.v_final = r.t_final * B, r.x_final * A, r.v_final * V
    r.events = [Event(e.t * B, e.kind, e.index) for e in r.events]
    r.info["event_stepper"]["internal_scales"] = {"mass": M, "length": A, "time": B}
    # the ledger in the scene's units (rounded again by the scaling): judged again
    r.status, r.message = ledger_verdict(r, r.info["event_stepper"]["ledger_tolerance"])
    if model.units == "physical":
        from ..units import scaled_parameters
        r.info["scaled"] = scaled_parameters(model)
    if log is not None:
        log.close(r)
    return r


def _simulate_events(scene, model: Model, units, log=None, resume=None, checkpoint=None,
                     checkpoint_every=0) -> Result:
    """Run the scene with the event stepper (see module docstring); ``units`` the
    factors to the scene's own units (:class:`_Units`, None: the same), used for
    the streamed frames and for times in messages. With a ``log`` (or ``resume``
    or ``checkpoint``) the frames are streamed (:class:`EventRun`).

    Returns
    -------
    Result
        ``stepper='event'``, ``dt=None``; frames at t = 0, at every event batch
        for N <= 64 (longer chains: at the cadence only, to bound memory), at the
        ``output.dt`` cadence (see :func:`_frame_interval`), and at the end; ``events`` the full event log; ``steps`` the Taylor steps taken.
    """
    tscale = units.t if units is not None else 1.0
    packed = _pack_run(scene, model, stream=log is not None)
    run = None
    if log is not None:
        run = EventRun(packed, log, units, checkpoint, checkpoint_every)
        if resume is not None:
            run.restore(resume)
    with stop_signals() as stop:
        code, wall = _drive(packed, stop, run)
    if run is not None:
        run.flush()
        wall += run.wall
    result = _build_result(packed, code, wall, scene, model, tscale, run)
    if code == C_INTERRUPTED:
        result.info["signal"] = stop.signum
        result.message = (f"stopped by {stop.name} at t = {result.t_final * tscale:.12g} "
                          f"(t_end = {scene.run.t_end * tscale:g}); the result holds the "
                          f"frames computed until then")
    return result


# Argument positions of the kernel (run_events), by name.
_RUN_PY = getattr(K.run_events, "py_func", K.run_events)  # NUMBA_DISABLE_JIT=1 (debugging)
_KARGS = _RUN_PY.__code__.co_varnames[:_RUN_PY.__code__.co_argcount]
_A = {name: i for i, name in enumerate(_KARGS)}


@dataclasses.dataclass
class _Packed:
    """The kernel's arguments for one run, and what the result is built from."""

    args: list  #: positional arguments of run_events
    kernel: object  #: compiled entry point for them
    P: int
    rtol: float
    atol: float
    linear: bool
    ke0: float  #: initial kinetic energy
    #: (steps still needed at the pace reached, that pace) when the run stopped
    #: because run.max_steps could not reach t_end (C_OUT_OF_STEPS)
    projection: tuple = (0.0, 0.0)

    def __getitem__(self, name):
        return self.args[_A[name]]


@numba.njit(cache=True, error_model="numpy")
def _friction_modes(v, eta_s, csl, slide):
    """Initial friction modes: csl[i] = 1 where a static threshold exists
    (Coulomb friction), slide[i] the sign of v[i] there, 2 (no friction) elsewhere."""
    for i in range(v.size):
        if eta_s[i] > 0.0:
            csl[i] = 1
            slide[i] = 1 if v[i] > 0.0 else (-1 if v[i] < 0.0 else 0)
        else:
            csl[i] = 0
            slide[i] = 2


@numba.njit(cache=True, error_model="numpy")
def _linear_step_cap(kc, present, gamma, mass):
    """n = 2: largest step, LINEAR_STEP / L with L a bound on the eigenvalues of
    any linear mode: drag rate plus twice the fastest contact frequency (a
    chain's highest mode is 2 sqrt(k/m)). 0 (no cap) when L = 0."""
    kmax = 0.0
    first = True
    for j in range(present.size):
        if present[j] == 1:
            if first or kc[j] > kmax:
                kmax = kc[j]
            first = False
    drag = 0.0
    imax = 0.0
    for i in range(mass.size):
        im = 1.0 / mass[i]
        g = gamma[i] * im
        if i == 0 or g > drag:
            drag = g
        if i == 0 or im > imax:
            imax = im
    L = drag + 2.0 * math.sqrt(kmax * imax)
    return LINEAR_STEP / L if L > 0 else 0.0


def _pack_run(scene, model: Model, stream: bool = False) -> _Packed:
    """Every argument of the kernel for a run of ``scene`` (already in the units
    the kernel runs in): the state, the settings and the work buffers. With
    ``stream`` the frame buffers get a size set by N alone (STREAM_FRAMES rows,
    fewer for long chains: the driver empties them between kernel calls) instead
    of room for the run's whole cadence."""
    settings = scene.run
    feat = model.features
    N = model.count
    law = int(feat.law)
    linear = law == LAW_LINEAR
    if linear:
        P, rtol, atol = LINEAR_ORDER, LINEAR_RTOL, 0.0
    else:
        P, rtol, atol = series_order(settings.rtol), float(settings.rtol), float(settings.atol)
    present, dl, kc, nexp = _pack(model)
    coulomb = int(feat.coulomb)
    viscous = int(feat.viscous)
    v = model.v0.copy()
    u = np.zeros(N)
    csl = np.zeros(N, dtype=np.int8)
    slide = np.zeros(N, dtype=np.int8)
    _friction_modes(v, model.eta_static, csl, slide)
    closed = ((dl > 0) & (present == 1)).astype(np.int8)

    stops = settings.stop_conditions
    st = np.zeros(9)
    st[K.S_TEND] = settings.t_end
    st[K.S_OUTDT] = _frame_interval(scene, N)
    st[K.S_LASTEV] = -math.inf
    if linear:
        st[K.S_HCAP] = _linear_step_cap(kc, present, model.gamma, model.mass)
    ist = np.zeros(20, dtype=np.int64)
    ist[K.I_WATCH] = settings.stop_contact + 1 if N > 1 else -10
    ist[K.I_STOPSEP] = int("separation" in stops)
    ist[K.I_STOPREST] = int("rest" in stops)
    ist[K.I_MAXEV] = settings.max_events
    ist[K.I_MAXSTEPS] = settings.max_steps
    ist[K.I_FRAMEEV] = int(N <= FRAMES_AT_EVENTS_MAX_N)
    ist[K.I_EVERY] = scene.output.every or 0

    R = max(P + 1, N + 1)
    U = np.zeros((N, P + 1))
    V = np.zeros((N, P + 1))
    D = np.zeros((N + 1, P + 1))
    Fc = np.zeros((N + 1, P + 1))
    Q = np.zeros((2, R))
    wrk = np.zeros(3 * N + 1)
    mov = np.zeros(N, dtype=np.int64)
    act = np.zeros(N + 1, dtype=np.int64)
    cand = np.zeros(N, dtype=np.int64)
    cflag = np.zeros(N + 1, dtype=np.int8)
    gflag = np.zeros(N, dtype=np.int8)
    old_c = np.zeros(N + 1, dtype=np.int8)
    old_s = np.zeros(N, dtype=np.int8)
    ctype = np.zeros(5 * N + 16, dtype=np.int64)
    cidx = np.zeros(5 * N + 16, dtype=np.int64)
    croot = np.zeros(5 * N + 16)
    fcap = 64
    if st[K.S_OUTDT] > 0.0:
        fcap = min(int(settings.t_end / st[K.S_OUTDT]) + 16, 1 << 20)
    if stream:  # rows set by N only: memory does not depend on the number of frames
        fcap = max(16, min(STREAM_FRAMES, STREAM_VALUES // max(N, 1)))
    fr_t = np.zeros(fcap)
    fr_x = np.zeros((fcap, N))
    fr_v = np.zeros((fcap, N))
    fr_f = np.zeros((fcap, N))
    fr_e = np.zeros((fcap, 4))
    ecap = 4 * N + 64
    ev_t = np.zeros(ecap)
    ev_k = np.zeros(ecap, dtype=np.int64)
    ev_i = np.zeros(ecap, dtype=np.int64)
    counts = np.zeros(4, dtype=np.int64)

    ke0 = 0.5 * float(np.dot(model.mass, v * v))
    mass = model.mass
    args = [law, coulomb, viscous, P, rtol, atol, st, ist, model.x0, u, v, dl, closed, present,
            slide, csl, kc, nexp, mass, model.eta, model.eta_static, model.gamma, U, V, D, Fc,
            Q, wrk, mov, act, cand, cflag, gflag, old_c, old_s, ctype, cidx, croot,
            fr_t, fr_x, fr_v, fr_f, fr_e, ev_t, ev_k, ev_i, counts,
            np.zeros(K.EM.NPAR), np.zeros(2, dtype=np.int64), np.zeros(N, dtype=np.int8),
            np.zeros(N, dtype=np.int64), _overlap_limits(model)]
    kernel = specialised(K.run_events, tuple(args), (0, 1, 2))
    return _Packed(args=args, kernel=kernel, P=P, rtol=rtol, atol=atol, linear=linear, ke0=ke0)


#: Chains up to this many granules get a frame at every event batch; longer ones
#: at the output.dt cadence only (a frame holds 3 N values; a long chain has
#: thousands of event batches).
FRAMES_AT_EVENTS_MAX_N = 64
_DEFAULT_FRAMES = 1000
_DEFAULT_FRAME_VALUES = 10_000_000  # per recorded array (x, v, f), as the Verlet default


def _frame_interval(scene, N: int) -> float:
    """Output cadence in time (0: none). ``output.dt`` if given; for a chain longer than
    FRAMES_AT_EVENTS_MAX_N without it (and without ``output.every``) about 1000 frames,
    fewer for long chains (at most 1e7 values per recorded array), as Verlet's default."""
    out = scene.output
    if out.dt is not None:
        return float(out.dt)
    if N <= FRAMES_AT_EVENTS_MAX_N or out.every is not None:
        return 0.0
    frames = max(2, min(_DEFAULT_FRAMES, _DEFAULT_FRAME_VALUES // N))
    return float(scene.run.t_end) / frames


#: Code of a run stopped by SIGINT/SIGTERM between kernel calls (the driver's, not
#: the kernel's: a kernel call never sees the signal).
C_INTERRUPTED = 100
#: Code of a run stopped because, at the pace its steps have reached, t_end lies
#: beyond run.max_steps (see :func:`_out_of_steps`).
C_OUT_OF_STEPS = 101
#: Taylor steps before the pace of a run is judged (its start and first events
#: can take short steps that later ones do not).
PACE_MIN_STEPS = 10_000
#: Main-loop passes one point of an :class:`EventBatch` may make in the compiled
#: loop before it is resumed from Python (a two-granule collision makes 5-100).
POINT_BUDGET = 1 << 14
#: Main-loop passes of the first kernel call; later calls are sized from the
#: measured wall time (:func:`next_budget`).
FIRST_BUDGET = 64


def next_budget(budget: int, seconds: float) -> int:
    """Passes for the next kernel call so that it lasts about CHUNK_SECONDS: scaled
    by the time the last ``budget`` passes took, by at most 4x up and 8x down (one
    slow pass, e.g. a page fault, must not shrink the budget to nothing)."""
    if seconds <= 0.0:
        return 4 * budget
    scaled = budget * (0.5 * CHUNK_SECONDS / seconds)  # aim at half: passes vary
    return int(min(max(scaled, budget / 8.0, 1.0), 4.0 * budget, 1 << 40))


def _drive(packed: _Packed, stop=None, run=None):
    """Call the kernel until it stops for another reason than a full buffer or a
    spent work budget.

    With a :class:`~granular_chain.interrupts.StopRequest` ``stop``, each call
    makes a bounded number of main-loop passes (sized to return within about
    CHUNK_SECONDS) and a requested stop ends the run with C_INTERRUPTED between
    calls; the kernel resumes from its arrays, so the trajectory is the same
    bit for bit as in one call. With an :class:`EventRun` ``run``, the frames
    recorded by each call are handed on between calls and checkpoints are taken
    (:meth:`EventRun.between`), and the pace counters start from the run's.
    Returns the code and the wall time (seconds).
    """
    args = packed.args
    kernel = packed.kernel
    ist, st = packed["ist"], packed["st"]
    budget = FIRST_BUDGET if run is None else run.budget
    start = time.perf_counter()
    mark = (float(st[K.S_T]), int(ist[K.I_STEPS])) if run is None else run.mark
    while True:
        if stop is None:
            ist[K.I_BUDGET] = 0
        else:
            ist[K.I_BUDGET] = budget if run is None else run.passes(budget)
        t0 = time.perf_counter()
        code = kernel(*args)
        if code == K.C_BUFFER:
            if run is not None:
                run.flush()  # (the kernel resumes a step cut short by a full buffer)
            _grow_buffers(args)
            ist = args[_A["ist"]]
        elif code == K.C_YIELD:
            budget = next_budget(budget, time.perf_counter() - t0)
            if _out_of_steps(packed, mark):
                code = C_OUT_OF_STEPS
                _final_frame(packed)
                break
            mark = (float(st[K.S_T]), int(ist[K.I_STEPS]))
        else:
            break
        interrupted = stop is not None and stop.requested
        if run is not None:
            run.between(budget, mark, time.perf_counter() - start, interrupted)
        if interrupted:
            code = C_INTERRUPTED
            _final_frame(packed)
            break
    ist[K.I_BUDGET] = 0
    return code, time.perf_counter() - start


#: Rows of the frame buffers of a run whose frames are streamed (handed to a
#: FrameLog between kernel calls): at most STREAM_FRAMES, at most about
#: STREAM_VALUES values per array (x, v, f) for long chains, at least 16.
STREAM_FRAMES = 256
STREAM_VALUES = 1 << 16
_FRAME_BUFS = ("fr_t", "fr_x", "fr_v", "fr_f", "fr_e")
_EVENT_BUFS = ("ev_t", "ev_k", "ev_i")
#: Version of the checkpoint dictionary (:func:`checkpoint_state`).
CHECKPOINT_FORMAT = 1


class _Units(NamedTuple):
    """Factors from the kernel's units to the scene's (time, length, speed, force,
    energy); None: the kernel runs in the scene's units."""

    t: float
    x: float
    v: float
    f: float
    e: float


class EventRun:
    """The driver's side of an event run whose frames are streamed.

    Between kernel calls the frames the kernel recorded since the last call are
    handed to ``log`` (in the scene's units: exactly the numbers the Result of
    an unstreamed run holds) and the frame buffers are emptied but for their
    last frame, whose time the kernel reads; the event log stays in memory (a
    few numbers an event, not frames). Checkpoints (:func:`checkpoint_state`)
    go to ``checkpoint`` every ``checkpoint_every`` Taylor steps and when the
    run is interrupted.
    """

    def __init__(self, packed: _Packed, log: FrameLog, units, checkpoint=None,
                 checkpoint_every: int = 0):
        self.packed, self.log, self.units = packed, log, units
        self.checkpoint = checkpoint
        self.every = int(checkpoint_every) if checkpoint is not None else 0
        self.handed = 0  #: rows of the frame buffers already handed on
        self.frames = 0  #: frames handed on over the whole run (Frame.step)
        self.pe0 = math.nan  #: elastic energy of the first frame (kernel units)
        self.balance = 0.0  #: largest |ledger balance| over the frames (kernel units)
        self.budget, self.mark = FIRST_BUDGET, (float(packed["st"][K.S_T]), 0)
        self.next_checkpoint = self.every
        self.wall = 0.0  #: wall time of the kernel calls before a resume
        self.resumed = False

    def passes(self, budget: int) -> int:
        """The work budget of the next call: ``budget``, cut so that the call returns
        at the next checkpoint (the trajectory does not depend on where calls end)."""
        if self.every <= 0:
            return budget
        left = self.next_checkpoint - int(self.packed["ist"][K.I_STEPS])
        return int(min(budget, max(left, 1)))

    def between(self, budget: int, mark, wall: float, interrupted: bool) -> None:
        """After a kernel call: hand on its frames, checkpoint when due or interrupted."""
        self.budget, self.mark = budget, mark
        self.flush()
        steps = int(self.packed["ist"][K.I_STEPS])
        due = self.every > 0 and steps >= self.next_checkpoint
        if due:
            self.next_checkpoint = steps + self.every
        if self.checkpoint is not None and (due or interrupted):
            self.checkpoint(checkpoint_state(self, self.wall + wall, interrupted))

    def flush(self) -> None:
        """Hand on the frames recorded since the last flush; keep the last one in row 0."""
        pk = self.packed
        nfr = int(pk["ist"][K.I_NFR])
        if nfr == 0:
            return
        fr_e = pk["fr_e"]
        if self.frames == 0 and self.handed == 0:
            self.pe0 = float(fr_e[0, 1])
        e0 = pk.ke0 + self.pe0
        if nfr > self.handed:
            block = fr_e[self.handed:nfr]
            # the ledger error in kernel units, as EnergyLedger.balance_error forms it
            worst = float(np.max(np.abs(block[:, 0] + block[:, 1] + block[:, 2]
                                        + block[:, 3] - e0)))
            if not math.isnan(self.balance) and not worst <= self.balance:
                self.balance = worst
        self._hand_on(self.handed, nfr, e0)
        if nfr > 1:
            for name in _FRAME_BUFS:
                pk[name][0] = pk[name][nfr - 1]
            pk["ist"][K.I_NFR] = 1
        self.handed = 1

    def _hand_on(self, lo: int, hi: int, e0: float) -> None:
        """Rows lo..hi-1 of the frame buffers to the log, in the scene's units."""
        pk, u, record = self.packed, self.units, self.log.record
        xs, vs, fs = pk["fr_x"], pk["fr_v"], pk["fr_f"]
        ts, es = pk["fr_t"][lo:hi].tolist(), pk["fr_e"][lo:hi].tolist()  # exact floats
        if u is not None:
            e0 = e0 * u.e
        for q in range(lo, hi):
            t, (ke, pe, wc, wv) = ts[q - lo], es[q - lo]
            x, v, f = xs[q], vs[q], fs[q]
            if u is not None:
                t, x, v, f = t * u.t, x * u.x, v * u.v, f * u.f
                ke, pe, wc, wv = ke * u.e, pe * u.e, wc * u.e, wv * u.e
            record(Frame(self.frames, t, x, v, f, ke, pe, wc, wv, e0))
            self.frames += 1

    def restore(self, state: dict) -> None:
        """Continue from ``state`` (:func:`checkpoint_state` of a run of the same scene)."""
        if int(state.get("format", -1)) != CHECKPOINT_FORMAT:
            raise ValueError(f"not an event-stepper checkpoint of format {CHECKPOINT_FORMAT}")
        args = self.packed.args
        for name in _KARGS[_NSCALAR:]:
            key = "k_" + name
            if key in state:
                old = args[_A[name]]
                new = np.ascontiguousarray(state[key], dtype=old.dtype)
                if new.shape != old.shape:
                    raise ValueError(f"checkpoint: {name} has shape {new.shape}, the scene "
                                     f"gives {old.shape} (another scene?)")
                args[_A[name]] = new.copy()
        for names, count in ((_FRAME_BUFS, K.I_NFR), (_EVENT_BUFS, K.I_NEV)):
            live = int(self.packed["ist"][count])
            for name in names:
                i = _A[name]
                rows = max(args[i].shape[0], 2 * live + 16)
                buf = np.zeros((rows,) + args[i].shape[1:], dtype=args[i].dtype)
                buf[:live] = state[name]
                args[i] = buf
        self.handed, self.frames = int(state["handed"]), int(state["frames"])
        self.pe0, self.balance = float(state["pe0"]), float(state["kernel_balance"])
        self.budget = int(state["budget"])
        self.mark = (float(state["mark_t"]), int(state["mark_steps"]))
        steps = int(self.packed["ist"][K.I_STEPS])
        self.next_checkpoint = steps + self.every if self.every > 0 else 0
        self.wall = float(state["wall_time"])
        self.resumed = True
        _restore_log(self.log, state)


def checkpoint_state(run: EventRun, wall: float = 0.0, interrupted: bool = False) -> dict:
    """Everything an event run needs to continue exactly (plain numpy arrays and
    Python scalars, for ``numpy.savez``).

    Keys: ``format``; ``k_<name>`` every array argument of the kernel but the
    buffers (its state: ``k_st``, ``k_ist`` with the step, event and frame
    counts and the cadence position, the positions ``k_u``, velocities ``k_v``,
    overlaps ``k_dl``, contact and friction modes, the kept moving set, ...);
    the live rows of the frame buffers ``fr_t, fr_x, fr_v, fr_f, fr_e`` (the
    last frame, already handed on) and the event log so far ``ev_t, ev_k,
    ev_i`` (kernel numbering and units); the driver's counters ``handed``,
    ``frames`` (frames handed on so far), ``pe0``, ``kernel_balance``,
    ``budget``, ``mark_t``, ``mark_steps``, ``wall_time`` (seconds of kernel
    calls so far), ``interrupted`` (taken because a signal stops the run); and the
    FrameLog's ``log_count``, ``log_max_balance_error``, ``log_keep`` and its
    first and latest frames ``log_first_<field>``, ``log_last_<field>`` (fields
    of :class:`~granular_chain.frames.Frame`), for a resumed log that keeps
    only those two.
    """
    pk = run.packed
    state = {"format": CHECKPOINT_FORMAT}
    for name in _KARGS[_NSCALAR:]:
        if name not in _FRAME_BUFS and name not in _EVENT_BUFS:
            state["k_" + name] = np.array(pk[name])
    nfr, nev = int(pk["ist"][K.I_NFR]), int(pk["ist"][K.I_NEV])
    for name in _FRAME_BUFS:
        state[name] = np.array(pk[name][:nfr])
    for name in _EVENT_BUFS:
        state[name] = np.array(pk[name][:nev])
    state.update(handed=run.handed, frames=run.frames, pe0=run.pe0,
                 kernel_balance=run.balance, budget=int(run.budget),
                 mark_t=float(run.mark[0]), mark_steps=int(run.mark[1]), wall_time=float(wall),
                 interrupted=bool(interrupted))
    log = run.log
    state.update(log_count=log.count, log_max_balance_error=float(log.max_balance_error),
                 log_keep=bool(log.keep))
    if log.count:
        for which, k in (("first", 0), ("last", -1)):
            for name in log._FIELDS:
                value = log.kept[name][k]
                state[f"log_{which}_{name}"] = np.array(value) if isinstance(
                    value, np.ndarray) else value
    return state


def _restore_log(log: FrameLog, state: dict) -> None:
    """Put a FrameLog's counters (and, keeping first and latest only, those two
    frames) back as the checkpointed run's log had them."""
    log.count = int(state["log_count"])
    log.max_balance_error = float(state["log_max_balance_error"])
    if log.keep or log.count == 0:
        return
    kept = {}
    for name in log._FIELDS:
        first, last = state[f"log_first_{name}"], state[f"log_last_{name}"]
        if np.ndim(first) == 0:  # (numpy.savez turns scalars into 0-d arrays)
            first, last = np.asarray(first).item(), np.asarray(last).item()
        kept[name] = [first, last] if log.count >= 2 else [first]
    log.kept = kept


def _out_of_steps(packed: _Packed, mark) -> bool:
    """True when t_end cannot be reached within run.max_steps even at the faster of
    two paces: the mean step over the run so far and over the last kernel call
    (``mark`` = (t, steps) at its start). Judged only after PACE_MIN_STEPS steps.

    The event stepper's steps are bounded by the fastest time scale of the mode
    (n = 2: a quarter of 1/(drag rate + contact rate); other n: the series'
    radius): an overdamped scene, drag rate gamma/m far above every contact
    rate, creeps on the slow time scale gamma/k and would need t_end gamma/m
    steps. Such a run ends at once with Status.MAX_STEPS and the numbers, not
    after hours. Sets ``packed.projection``.
    """
    ist, st = packed["ist"], packed["st"]
    steps = int(ist[K.I_STEPS])
    if steps < PACE_MIN_STEPS or steps <= mark[1]:
        return False
    t = float(st[K.S_T])
    pace = max(t / steps, (t - mark[0]) / (steps - mark[1]))
    left = int(ist[K.I_MAXSTEPS]) - steps
    need = (float(st[K.S_TEND]) - t) / pace if pace > 0.0 else math.inf
    if need <= left:
        return False
    packed.projection = (need, pace)
    return True


def _final_frame(packed: _Packed) -> None:
    """Record a frame at the state an interrupted run reached (kernel state is
    consistent between calls), unless the last frame is already there."""
    a = packed
    ist, st = a["ist"], a["st"]
    nfr = int(ist[K.I_NFR])
    if a["fr_t"][nfr - 1] == st[K.S_T]:
        return
    if a["fr_t"].size - nfr < 1:
        _grow_buffers(a.args)
    K._record(a.args[0], st[K.S_T], a["x0"], a["u"], a["v"], a["dl"], a["closed"],
              a["present"], a["kc"], a["nexp"], a["mass"], st, ist, a["fr_t"], a["fr_x"],
              a["fr_v"], a["fr_f"], a["fr_e"], 0.0, 0.0)


def _grow_buffers(args: list) -> None:
    """Grow whichever buffer is short (doubling), replacing it in ``args``: the
    state lives in the arrays, so the kernel called again resumes where it stopped."""
    ist = args[_A["ist"]]
    N = args[_A["u"]].size
    ifr, iev = _A["fr_t"], _A["ev_t"]
    if args[ifr].size - ist[K.I_NFR] < 8:
        n2 = 2 * args[ifr].size
        args[ifr:ifr + 5] = [_grow(a, n2) for a in args[ifr:ifr + 5]]
    if args[iev].size - ist[K.I_NEV] < 2 * N + 8:
        n2 = 2 * args[iev].size
        args[iev:iev + 3] = [_grow(a, n2) for a in args[iev:iev + 3]]


def _build_result(packed: _Packed, code, wall, scene, model: Model, tscale: float,
                  run: EventRun | None = None) -> Result:
    """The Result of a finished kernel run (frames, ledger, event log, status).

    Without ``run`` every frame is in the kernel's buffers (kernel units); with
    it the frames are those its log kept (the scene's units) and the buffers
    hold the last one (its final state, kernel units, as without it).
    """
    ist, st = packed["ist"], packed["st"]
    fr_t, fr_x, fr_v, fr_f, fr_e = (packed[k] for k in _FRAME_BUFS)
    ev_t, ev_k, ev_i = (packed[k] for k in _EVENT_BUFS)
    counts = packed["counts"]
    feat = model.features
    nfr = int(ist[K.I_NFR])
    nev = int(ist[K.I_NEV])
    pe0 = float(fr_e[0, 1]) if run is None else run.pe0
    e0 = packed.ke0 + pe0
    t_final = float(st[K.S_T])
    if tscale != 1.0:  # (times 1.0 is exact: skip the arrays for the common case)
        st = st * _time_fields(tscale)
    status, message = _status(code, scene, model, st, ist, t_final * tscale, nev)
    if code == C_OUT_OF_STEPS:
        message = _out_of_steps_message(packed, model, scene, t_final, tscale)
    tol = ledger_tolerance(packed, e0, float(fr_e[nfr - 1, 2] + fr_e[nfr - 1, 3]))
    events = [Event(float(ev_t[q]), EVENT_KINDS[int(ev_k[q])], int(ev_i[q])) for q in range(nev)]
    info = {"features": feat.describe(), "granules": model.count, "units": model.units,
            "event_stepper": {"taylor_order": packed.P, "rtol": packed.rtol,
                              "atol": packed.atol, "exact_modes": bool(packed.linear),
                              "event_batches": int(ist[K.I_BATCHES]),
                              "ledger_tolerance": tol}}
    if model.units == "physical":
        from ..units import scaled_parameters
        info["scaled"] = scaled_parameters(model)
    if run is None:
        energy = EnergyLedger(kinetic=fr_e[:nfr, 0].copy(), potential=fr_e[:nfr, 1].copy(),
                              coulomb=fr_e[:nfr, 2].copy(), viscous=fr_e[:nfr, 3].copy(),
                              initial=e0)
        t, x, vv, f = fr_t[:nfr].copy(), fr_x[:nfr].copy(), fr_v[:nfr].copy(), fr_f[:nfr].copy()
        judged = energy
    else:
        t, x, vv, f, energy = _logged_frames(run, info)
        # judged in kernel units first, as the frames of an unstreamed run are
        scale = e0 if e0 > 0 else 1.0
        judged = EnergyLedger(kinetic=np.zeros(0), potential=np.zeros(0), coulomb=np.zeros(0),
                              viscous=np.zeros(0), initial=e0,
                              streamed_error=run.balance / scale)
    r = Result(
        t=t, x=x, v=vv, f=f, energy=judged, status=status,
        message=message, steps=int(ist[K.I_STEPS]), wall_time=wall, stepper="event", dt=None,
        t_final=t_final, x_final=fr_x[nfr - 1].copy(), v_final=fr_v[nfr - 1].copy(),
        events=events, event_counts={k: int(n) for k, n in zip(EVENT_KINDS, counts)},
        info=info)
    r.status, r.message = ledger_verdict(r, tol)
    r.energy = energy
    return r


def _logged_frames(run: EventRun, info: dict):
    """t, x, v, f and the EnergyLedger (scene units) of a streamed run's kept frames."""
    log = run.log
    e0 = run.packed.ke0 + run.pe0
    if run.units is not None:
        e0 = e0 * run.units.e
    whole = log.keep and not run.resumed  # else frames were handed on without being kept
    energy = EnergyLedger(
        kinetic=log.array("kinetic"), potential=log.array("potential"),
        coulomb=log.array("coulomb"), viscous=log.array("viscous"), initial=e0,
        streamed_error=None if whole else log.max_balance_error)
    if not log.keep:
        info["frames"] = log.count
        info["frames_kept"] = "first and last (the others were streamed to the writers)"
    return log.array("t"), log.array("x"), log.array("v"), log.array("f"), energy


#: n = 2 (exact modes): ledger error promised per unit of work, in units of eps.
#: A step sums series whose terms stay below ~3 times the result (L h <= 1/2), so
#: it rounds each state entry by a few ulps; the energy is quadratic in the state
#: (2x the relative error); an event batch sets and re-rounds the same entries;
#: the ledger's own sums over N granules round by ~N ulps. Errors add at worst
#: linearly: 8 eps per step, batch and granule.
EXACT_LEDGER_ULPS = 8.0


def ledger_tolerance(packed: _Packed, e0: float, work: float) -> float:
    """The largest energy-ledger error (relative to the initial energy ``e0``) the
    event stepper promises for the run held in ``packed`` (kernel units);
    ``work`` is the energy dissipated by friction over the run.

    * n = 2 (exact modes): ``EXACT_LEDGER_ULPS * eps * (steps + batches + N + 1)``.
    * other n: each step keeps the last two terms of every velocity's and
      overlap's series below ``tol = rtol * |x| + atol``; with terms falling at
      least by half, the truncation error is below ``2 tol``. That changes the
      energy by at most ``max(2, n) rtol`` of it plus ``atol`` times the momenta
      and forces, ``2 atol / V`` relative (V = sqrt(2 e0 / total mass), the speed
      scale); an opening or closing leaves out an impulse below ``tol / 10``
      (the contact switching rule) and its root is located to a few ulps,
      counted as two steps; the friction work, integrated from the series of v,
      is off by at most ``2 rtol`` of itself. At worst linearly accumulated:
      ``2 [(steps + 2 batches + 1) (max(2, n) rtol + 2 atol / V) + 2 rtol work / e0]``.
    """
    ist = packed["ist"]
    steps = int(ist[K.I_STEPS])
    batches = int(ist[K.I_BATCHES])
    N = packed["u"].size
    if packed.linear:
        return EXACT_LEDGER_ULPS * np.finfo(float).eps * (steps + batches + N + 1)
    present = packed["present"] == 1
    n_max = float(np.max(packed["nexp"][present])) if present.any() else 2.0
    m_tot = float(np.sum(packed["mass"]))
    V = math.sqrt(2.0 * e0 / m_tot) if e0 > 0.0 else math.inf
    per_step = max(2.0, n_max) * packed.rtol + 2.0 * packed.atol / V
    friction = 2.0 * packed.rtol * abs(work) / e0 if e0 > 0.0 else 0.0
    return 2.0 * ((steps + 2 * batches + 1) * per_step + friction)


def _overlap_limits(model: Model) -> np.ndarray:
    """Overlap of each kernel contact at which the centres meet (N + 1,):
    r_(j-1) + r_j between granules, the granule's radius at a wall."""
    r = model.radius
    lim = np.empty(model.count + 1)
    lim[1:-1] = r[:-1] + r[1:]
    lim[0] = r[0]
    lim[-1] = r[-1]
    return lim


def _time_fields(tscale: float) -> np.ndarray:
    """Factors that put the kernel's time-valued state entries in the scene's unit."""
    f = np.ones(9)
    f[K.S_T] = f[K.S_TEND] = f[K.S_JUMPFROM] = tscale
    return f


def _grow(a: np.ndarray, n: int) -> np.ndarray:
    b = np.zeros((n,) + a.shape[1:], dtype=a.dtype)
    b[: a.shape[0]] = a
    return b


def _out_of_steps_message(packed, model, scene, t, tscale) -> str:
    need, pace = packed.projection
    ist = packed["ist"]
    msg = (f"stopped at t = {t * tscale:.6g} after {int(ist[K.I_STEPS])} Taylor steps: at the "
           f"pace reached (mean step {pace * tscale:.3g}) t_end = {scene.run.t_end * tscale:g} needs "
           f"~{need:.3g} more steps, more than run.max_steps = {scene.run.max_steps} allows")
    # in kernel units: the fastest drag rate against the fastest contact rate
    drag = float(np.max(packed["gamma"] / packed["mass"]))
    present = packed["present"] == 1
    kmax = float(np.max(packed["kc"][present])) if present.any() else 0.0
    contact = math.sqrt(kmax / float(np.min(packed["mass"])))
    if drag > 10.0 * contact:
        msg += (f"; the scene is overdamped (drag time m/gamma = {tscale / drag:.3g}, far "
                f"shorter than the contact time): the steps cannot exceed the drag time while "
                f"the granules creep on a far slower time scale; the Verlet stepper integrates "
                f"drag exactly, or shorten t_end")
    else:
        msg += "; raise run.max_steps or shorten t_end"
    return msg


def _status(code, scene, model, st, ist, t, nev):
    settings = scene.run
    steps = int(ist[K.I_STEPS])
    if code == K.C_T_END:
        msg = f"reached t_end = {t:.12g} after {nev} events and {steps} Taylor steps"
        if ist[K.I_JUMPED] == 1:
            msg += (f"; from t = {st[K.S_JUMPFROM]:.12g} the exact modal solution shows the "
                    f"contact never opens again (overdamped), so the state was moved to t_end "
                    f"in closed form")
        elif ist[K.I_JUMPED] == 2:
            msg += (f"; nothing moves after t = {st[K.S_JUMPFROM]:.12g} (every granule held "
                    f"or at rest), so the state is final")
        return Status.T_END, msg
    if code == K.C_SEPARATED:
        return Status.SEPARATED, (f"contact {settings.stop_contact} opened at t = {t:.17g} "
                                  f"(exact event time, {nev} events)")
    if code == K.C_AT_REST:
        return Status.AT_REST, (f"every granule at rest (held by static friction) at "
                                f"t = {t:.17g} after {nev} events")
    if code == K.C_MAX_EVENTS:
        return Status.MAX_EVENTS, (f"stopped after run.max_events = {settings.max_events} "
                                   f"events at t = {t:.12g} before t_end = {settings.t_end:g}; "
                                   f"raise run.max_events")
    if code == K.C_ZENO:
        return Status.ZENO, (f"events accumulate at t = {t:.15g}: {K.ZENO_BATCHES} consecutive "
                             f"event batches without time advancing by more than 1e-12 "
                             f"(relative); the modes chatter (Zeno), so the run stopped")
    if code == K.C_OVERLAP:
        j = int(ist[K.I_OVERLAP])
        N = model.count
        if j == 0:
            where = "granule 0 reached the left wall's position with its centre"
        elif j == N:
            where = f"granule {N - 1} reached the right wall's position with its centre"
        else:
            where = (f"contact {j - 1} reached an overlap equal to the sum of the radii of "
                     f"granules {j - 1} and {j} (their centres meet)")
        return Status.OVERLAP, f"{where} at t = {t:.12g} (exact event time); " + OVERLAP_ADVICE
    if code == C_OUT_OF_STEPS:  # the message is set by the caller (_out_of_steps_message)
        return Status.MAX_STEPS, "t_end out of reach within run.max_steps"
    if code == C_INTERRUPTED:  # the message is set by the caller, who knows the signal
        return Status.INTERRUPTED, "stopped by a signal"
    if code == K.C_MAX_STEPS:
        return Status.MAX_STEPS, (f"stopped after run.max_steps = {settings.max_steps} Taylor "
                                  f"steps at t = {t:.12g}; raise run.max_steps or loosen run.rtol")
    return Status.NONFINITE, (f"non-finite state or step size at t = {t:.12g}: the Taylor "
                              f"series diverged (a time scale of the scene is too short to "
                              f"resolve: look for extreme ratios of speeds, overlaps and "
                              f"friction, e.g. speeds near 1e-300); the Verlet stepper or "
                              f"rescaled parameters may run it")


# ----------------------------------------------------------------------------
# Many runs of one scene differing only in friction (two-granule maps)
# ----------------------------------------------------------------------------
#: Status of a run from the kernel's return code (C_BUFFER excluded: not an end).
CODE_STATUS = {K.C_T_END: Status.T_END, K.C_SEPARATED: Status.SEPARATED,
               K.C_AT_REST: Status.AT_REST, K.C_MAX_EVENTS: Status.MAX_EVENTS,
               K.C_ZENO: Status.ZENO, K.C_MAX_STEPS: Status.MAX_STEPS,
               K.C_NONFINITE: Status.NONFINITE, K.C_OVERLAP: Status.OVERLAP,
               C_INTERRUPTED: Status.INTERRUPTED}

# The kernel's leading scalar arguments; the rest are arrays, passed to
# _run_points as one tuple ``a`` (position in it: _A[name] - _NSCALAR).
_NSCALAR = 6
(_ST, _IST, _V, _SLIDE, _CSL, _KC, _PRESENT, _MASS, _ETA, _ETAS, _GAMMA, _FRV, _FRE, _EVT,
 _EVK, _EVI) = (_A[k] - _NSCALAR for k in (
     "st", "ist", "v", "slide", "csl", "kc", "present", "mass", "eta", "eta_s", "gamma",
     "fr_v", "fr_e", "ev_t", "ev_k", "ev_i"))
assert len(_KARGS) == _NSCALAR + 46, "run_events changed: update the call in _run_points"


@numba.njit(cache=True, error_model="numpy")
def _extract(p, code, st, ist, fr_v, fr_e, ev_t, ev_k, ev_i, o_code, o_t, o_v, o_e, o_stop):
    """Store point p's end state: the kernel's code, final time, final velocities,
    (kinetic, elastic energy at the end, elastic energy at t = 0), and the time
    of each granule's first stop event (NaN if it never stops)."""
    o_code[p] = code
    o_t[p] = st[K.S_T]
    nfr = ist[K.I_NFR]
    for i in range(o_v.shape[1]):
        o_v[p, i] = fr_v[nfr - 1, i]
        o_stop[p, i] = math.nan
    o_e[p, 0] = fr_e[nfr - 1, 0]
    o_e[p, 1] = fr_e[nfr - 1, 1]
    o_e[p, 2] = fr_e[0, 1]
    for q in range(ist[K.I_NEV]):
        if ev_k[q] == K.EV_STOP:
            i = ev_i[q]
            if math.isnan(o_stop[p, i]):
                o_stop[p, i] = ev_t[q]


@numba.njit(cache=True, error_model="numpy")
def _run_points(law, coulomb, viscous, P, rtol, atol, a, fbuf, ftmp, ibuf, itmp, bbuf, btmp,
                eta, eta_s, gamma, start, end, budget, o_code, o_t, o_v, o_e, o_stop):
    """Run the packed scene once per row start <= p < end of eta, eta_s, gamma
    (each (M, N)), each run with the kernel's work budget ``budget`` (0: none).

    ``a`` holds the kernel's array arguments, all views into the three flat
    buffers (float64, int64, int8), whose initial contents are ``*tmp``: each
    run starts from exactly the state the packing produced, with the point's
    friction and the friction-dependent entries (csl, slide, the n = 2 step
    cap) set by the same functions the packing uses. Results go to the o_
    arrays (:func:`_extract`). Returns ``end``, or the first point whose run
    filled a buffer (C_BUFFER) or spent its budget (C_YIELD): its state is left
    in the arrays for the caller to resume, and the loop continues from the
    next point.
    """
    law = literally(law)
    coulomb = literally(coulomb)
    viscous = literally(viscous)
    for p in range(start, end):
        fbuf[:] = ftmp
        ibuf[:] = itmp
        bbuf[:] = btmp
        a[_IST][K.I_BUDGET] = budget
        a[_ETA][:] = eta[p]
        a[_ETAS][:] = eta_s[p]
        a[_GAMMA][:] = gamma[p]
        _friction_modes(a[_V], a[_ETAS], a[_CSL], a[_SLIDE])
        if law == LAW_LINEAR:
            a[_ST][K.S_HCAP] = _linear_step_cap(a[_KC], a[_PRESENT], a[_GAMMA], a[_MASS])
        code = K.run_events(
            law, coulomb, viscous, P, rtol, atol, a[0], a[1], a[2], a[3], a[4], a[5], a[6],
            a[7], a[8], a[9], a[10], a[11], a[12], a[13], a[14], a[15], a[16], a[17], a[18],
            a[19], a[20], a[21], a[22], a[23], a[24], a[25], a[26], a[27], a[28], a[29],
            a[30], a[31], a[32], a[33], a[34], a[35], a[36], a[37], a[38], a[39], a[40],
            a[41], a[42], a[43], a[44], a[45])
        if code == K.C_BUFFER or code == K.C_YIELD:
            return p
        _extract(p, code, a[_ST], a[_IST], a[_FRV], a[_FRE], a[_EVT], a[_EVK], a[_EVI],
                 o_code, o_t, o_v, o_e, o_stop)
    return end


@dataclasses.dataclass
class BatchOutput:
    """Per-point end state of :meth:`EventBatch.run` (M points, N granules)."""

    code: np.ndarray  #: (M,) kernel return code (a key of CODE_STATUS)
    t_final: np.ndarray  #: (M,)
    v_final: np.ndarray  #: (M, N)
    kinetic: np.ndarray  #: (M,) kinetic energy at the end
    potential: np.ndarray  #: (M,) elastic energy at the end
    initial: np.ndarray  #: (M,) kinetic + elastic energy at t = 0 (EnergyLedger.initial)
    t_stop: np.ndarray  #: (M, N) time of each granule's first stop event, NaN if none
    wall_time: float  #: seconds in the kernel (compiled loop and resumed runs)
    last_args: list  #: the kernel's arguments holding the last point's run
    signal: int = 0  #: SIGINT/SIGTERM number if a stop request ended the batch early


class EventBatch:
    """One scene run many times with different friction, the event stepper's packing reused.

    The scene is validated and packed once (:func:`_pack_run`, the same packing
    :func:`simulate_events` uses); the kernel's arrays are moved into three flat
    buffers, so each run restores the packed state with three copies, sets the
    point's friction, and calls the kernel from a compiled loop
    (:func:`_run_points`): no per-run Python, no Result objects. A run that
    fills a buffer is resumed with grown buffers exactly as
    :func:`_simulate_events` does. Every run gives bitwise the numbers
    :func:`simulate_events` gives for the scene with that friction.

    Only for scenes that are already in scaled units (the kernel's units, see
    :func:`_scales`), and only for points whose friction has the scene's
    features (Coulomb friction present or not, viscous friction present or
    not): :func:`granular_chain.model.friction_features` tells.
    """

    def __init__(self, scene, model: Model):
        if model.units != "scaled" or _scales(model) is not None:
            raise ValueError("EventBatch needs a scene in the kernel's scaled units "
                             "(mass 1, force coefficient 1, largest speed 1)")
        self.scene, self.model = scene, model
        self.packed = pk = _pack_run(scene, model)
        args = pk.args
        if not all(isinstance(x, np.ndarray) for x in args[_NSCALAR:]):
            raise TypeError("run_events changed: its arguments after atol must be arrays")
        flat = []
        for dtype in (np.float64, np.int64, np.int8):
            idx = [i for i in range(_NSCALAR, len(args)) if args[i].dtype == dtype]
            buf = np.empty(sum(args[i].size for i in idx), dtype=dtype)
            off = 0
            for i in idx:
                view = buf[off:off + args[i].size].reshape(args[i].shape)
                view[...] = args[i]
                args[i] = view
                off += view.size
            flat += [buf, buf.copy()]
        if sum(b.size for b in flat[::2]) != sum(x.size for x in args[_NSCALAR:]):
            raise TypeError("run_events changed: an array argument of another dtype")
        self._flat = tuple(flat)
        self._head = tuple(args[:_NSCALAR])
        self._arrays = tuple(args[_NSCALAR:])
        N = model.count
        probe = self._call_args(*(np.zeros((1, N)),) * 3)
        self._entry = specialised(_run_points, probe, (0, 1, 2))

    def _call_args(self, eta, eta_s, gamma):
        M, N = eta.shape
        return [*self._head, self._arrays, *self._flat, eta, eta_s, gamma, 0, M, 0,
                np.zeros(M, dtype=np.int64), np.zeros(M), np.zeros((M, N)), np.zeros((M, 3)),
                np.zeros((M, N))]

    def run(self, eta, eta_static, gamma) -> BatchOutput:
        """Run every point: eta, eta_static, gamma of shape (M, N), float64.

        The returned ``last_args`` hold the last point's run, from which
        :meth:`result` makes its full Result.
        """
        shape = (len(eta), self.model.count)
        arrs = [np.ascontiguousarray(x, dtype=np.float64) for x in (eta, eta_static, gamma)]
        if not arrs[0].shape == arrs[1].shape == arrs[2].shape == shape:
            raise ValueError(f"eta, eta_static and gamma must all have shape {shape}")
        call = self._call_args(*arrs)
        M = shape[0]
        i_start = _NSCALAR + 10  # positions of start, end, budget in the call
        code, t, v, e, t_stop = call[-5:]
        call[i_start + 2] = POINT_BUDGET
        # The first call (16 points of at most POINT_BUDGET passes) runs without
        # the signal handlers: a single collide() costs ~130 us, and installing
        # and restoring them would add ~50 % to it. Chunks then last ~CHUNK_SECONDS.
        p, chunk, wall, last, stop = self._chunk(call, 0, 16, None, self.packed.args)
        if p < M and not stop.requested:
            with stop_signals() as stop:
                while p < M and not stop.requested:
                    p, chunk, w, last, _ = self._chunk(call, p, chunk, stop, last)
                    wall += w
        if p < M:  # stopped by a signal: the points not run are marked so
            code[p:] = C_INTERRUPTED
            t[p:] = math.nan
        return BatchOutput(code=code, t_final=t, v_final=v, kinetic=e[:, 0], potential=e[:, 1],
                           initial=self.packed.ke0 + e[:, 2], t_stop=t_stop, wall_time=wall,
                           last_args=last, signal=stop.signum)

    def _chunk(self, call, p, chunk, stop, last):
        """Run points p .. p + chunk - 1 in the compiled loop, resuming from Python
        a point that filled a buffer or spent its budget. Returns the next point,
        the next chunk size, the wall time, the arguments of the last point and the
        stop request (``stop``, or, when None, a request whose handlers were
        installed only while a point was resumed)."""
        M = len(call[-5])
        i_start = _NSCALAR + 10  # positions of start, end, budget in the call
        code, t, v, e, t_stop = call[-5:]
        end = min(M, p + chunk)
        call[i_start:i_start + 2] = [p, end]
        t0 = time.perf_counter()
        q = self._entry(*call)
        wall = time.perf_counter() - t0
        chunk = next_budget(chunk, wall * chunk / max(q - p, 1))
        if q >= end:
            return end, chunk, wall, last, stop or StopRequest()
        # Point q filled a buffer or spent its budget: resume it the ordinary way
        # (_drive), on a copy of the argument list (grown buffers replace the
        # flat buffers' views there only).
        grown = list(self.packed.args)
        _grow_buffers(grown)
        pk = dataclasses.replace(self.packed, args=grown)
        if stop is None:
            with stop_signals() as stop:
                c, w = _drive(pk, stop)
        else:
            c, w = _drive(pk, stop)
        _extract(q, c, pk["st"], pk["ist"], pk["fr_v"], pk["fr_e"], pk["ev_t"], pk["ev_k"],
                 pk["ev_i"], code, t, v, e, t_stop)
        # the last point's run: in the grown buffers if it was this one, else
        # (later points ran in the loop) in the flat buffers' views
        return q + 1, chunk, wall + w, (grown if q == M - 1 else self.packed.args), stop

    def result(self, out: BatchOutput) -> Result:
        """The full Result of the last point of ``out`` (as simulate_events returns it)."""
        pk = dataclasses.replace(self.packed, args=out.last_args)
        return _build_result(pk, int(out.code[-1]), out.wall_time, self.scene, self.model, 1.0)
