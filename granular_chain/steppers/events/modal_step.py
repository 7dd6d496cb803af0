"""The kernel's closed-form path for two granules with a closed linear contact.

N = 2, n = 2, contact closed: each mode is evaluated in closed form from its
start (:mod:`.modal_n2`), exact near critical damping, where a stepper's
rounding grows like s (t0 - s). A step runs from the mode's start to its
first event (or t_end); the viscous work is the energy lost minus the Coulomb
work (both exact in the mode), so the ledger closes by the energy theorem.
"""

import math

import numba

from ..._compile import callee, run_time
from ...codes import EventKind, Pause, Status
from ...laws.contact import LAW_LINEAR, contact_energy
from ...laws.friction import phi1
from . import modal_n2
from .output import record_frame
from .records import GOING
from .roots import CENTRES_MEET

#: Samples per search window of the closed-form path.
WINDOW = 3


@callee(error_model="numpy", _nrt=False)
def modal_energy(coulomb, model, state, d, v0, v1, du0, du1):
    """Mechanical energy of the pair at overlap d, velocities v0, v1, and the
    Coulomb work of displacements du0, du1 in the current friction modes.

    Parameters
    ----------
    coulomb : int
        Feature code: nonzero when some granule has Coulomb friction (a literal in
        the step, a run-time value where frames are made).
    model : ChainArrays
        The two-granule chain's constants (N = 2), kernel units.
    state : MotionState
        Its state; only the friction modes ``slide`` (2,) are read.
    d : float
        Overlap of the contact between the granules, kernel length units.
    v0, v1 : float
        Velocities of granules 0 and 1, kernel units (length / time).
    du0, du1 : float
        Displacements of granules 0 and 1 since the step's start, kernel length units.

    Returns
    -------
    energy, coulomb_work : float
        Kinetic plus elastic energy, and the Coulomb work of the displacements;
        energy in kernel units.
    """
    mass, slide, eta = model.mass, state.slide, model.eta
    e = 0.5 * mass[0] * v0 * v0 + 0.5 * mass[1] * v1 * v1
    if d > 0.0:
        e += contact_energy(LAW_LINEAR, d, model.stiffness[1], 2.0)
    wc = 0.0
    if coulomb:
        if slide[0] == 1 or slide[0] == -1:
            wc += eta[0] * slide[0] * du0
        if slide[1] == 1 or slide[1] == -1:
            wc += eta[1] * slide[1] * du1
    return e, wc


@callee(error_model="numpy", _nrt=False)
def try_jump(law, settings, clock, model, state):
    """N = 2, n = 2, viscous only, gamma/m equal: decide from the exact modal
    solution whether the closed contact can ever open; if not, move the state
    to t_end (``clock.jumped = 1``).

    delta'' + c delta' + K delta = 0 (c = gamma/m, K = k (1/m1 + 1/m2)) with
    c^2 >= 4K: delta is a sum of two decaying exponentials (or (a + b t) e^(-ct/2)
    at critical damping), whose only zero is found in closed form.

    Parameters
    ----------
    law : int
        Contact-law code (``laws.contact``; LAW_LINEAR for n = 2), a compile-time constant.
    settings : record of SETTINGS_DTYPE
        What the kernel is asked to do (end time, tolerances, stops), kernel units.
    clock : record of CLOCK_DTYPE
        The run's clock and work totals (kernel units), advanced in place.
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).

    Returns
    -------
    bool
        True when the state was moved to ``settings.t_end`` (the viscous work of
        the jumped tail added to ``clock.work_viscous``), False when nothing changed.
    """
    u, v, overlap, mass = state.u, state.v, state.overlap, model.mass
    gamma, stiffness = model.gamma, model.stiffness
    N = u.size
    if (N != 2 or law != LAW_LINEAR or model.present[0] == 1 or model.present[2] == 1
            or state.closed[1] == 0):
        return False
    if model.has_coulomb[0] == 1 or model.has_coulomb[1] == 1:
        return False
    c = gamma[0] / mass[0]
    if c <= 0.0 or gamma[1] / mass[1] != c:
        return False
    K = stiffness[1] * (1.0 / mass[0] + 1.0 / mass[1])
    disc = c * c - 4.0 * K
    if disc < 0.0:
        return False
    d0 = overlap[1]
    w0 = v[0] - v[1]
    T = (settings.t_end - clock.time) - clock.time_lo
    if disc > 0.0:
        sq = math.sqrt(disc)
        lp = -modal_n2.slow_rate(K, 0.5 * c, 0.5 * sq)  # sq = 2 kap
        lm = 0.5 * (-c - sq)
        A = (w0 - lm * d0) / (lp - lm)
        B = d0 - A
        if A != 0.0 and -B / A > 1.0:
            return False  # opens at t = ln(-B/A)/(lp - lm) > 0: let the stepper find it
        ep = math.exp(lp * T)
        em = math.exp(lm * T)
        dT = A * ep + B * em
        wT = A * lp * ep + B * lm * em
    else:
        q = w0 + 0.5 * c * d0
        if q != 0.0 and -d0 / q > 0.0:
            return False
        e = math.exp(-0.5 * c * T)
        dT = (d0 + q * T) * e
        wT = (q - 0.5 * c * (d0 + q * T)) * e
    M = mass[0] + mass[1]
    V0 = (mass[0] * v[0] + mass[1] * v[1]) / M
    U0 = (mass[0] * u[0] + mass[1] * u[1]) / M
    VT = V0 * math.exp(-c * T)
    UT = U0 + V0 * phi1(c, T)
    r = (u[0] - u[1]) + (dT - d0)
    e_before = (0.5 * mass[0] * v[0] ** 2 + 0.5 * mass[1] * v[1] ** 2
                + contact_energy(LAW_LINEAR, d0, stiffness[1], 2.0))
    u[0] = UT + mass[1] / M * r
    u[1] = UT - mass[0] / M * r
    v[0] = VT + mass[1] / M * wT
    v[1] = VT - mass[0] / M * wT
    overlap[1] = dT
    e_after = (0.5 * mass[0] * v[0] ** 2 + 0.5 * mass[1] * v[1] ** 2
               + contact_energy(LAW_LINEAR, dT, stiffness[1], 2.0))
    # The viscous work of the jumped tail, by the energy theorem (closed form).
    clock.work_viscous += e_before - e_after
    clock.jumped_from = clock.time
    clock.time = settings.t_end
    clock.time_lo = 0.0
    clock.jumped = 1
    return True


@numba.njit(inline="always", cache=True, error_model="numpy", _nrt=False)
def _candidate(work, ncand, kind, index, rh, rl, bh, bl):
    """Write a candidate root (rh + rl) and return the count and the earliest root."""
    work.cand_kind[ncand] = kind
    work.cand_index[ncand] = index
    work.cand_root[ncand] = rh + rl
    if rh < bh or (rh == bh and rl < bl):
        bh, bl = rh, rl
    return ncand + 1, bh, bl


@callee(error_model="numpy", _nrt=False)
def _window_roots(coulomb, p, lo, hi, nsamp, deep, open_root, state, work):
    """First roots in [lo, hi] of the mode's event functions (``nsamp`` samples):
    opening (``open_root`` (th, tl) when known in closed form, else searched),
    stops of sliding granules, the stuck granule's slip, the centres meeting
    (``deep``). Returns the earliest as (th, tl) and the candidates written."""
    s0, s1 = state.slide[0], state.slide[1]
    sl0 = coulomb and (s0 == 1 or s0 == -1)
    sl1 = coulomb and (s1 == 1 or s1 == -1)
    case = p.case
    slipc = case != 0.0
    bh = math.inf
    bl = 0.0
    if p.drive == 0.0:
        rh, rl = open_root
    else:
        rh, rl = modal_n2.first_root(p, 0, lo, hi, nsamp)
    ncand, bh, bl = _candidate(work, 0, EventKind.CONTACT_OPEN, 1, rh, rl, bh, bl)
    for q in range(3):
        if q == 0 and not sl0:
            continue
        if q == 1 and not sl1:
            continue
        if q == 2 and not slipc:
            continue
        rh, rl = modal_n2.first_root(p, q + 1, lo, hi, nsamp)
        kind = EventKind.SLIP if q == 2 else EventKind.STOP
        index = q if q < 2 else (1 if case == 1.0 else 0)
        ncand, bh, bl = _candidate(work, ncand, kind, index, rh, rl, bh, bl)
    if deep:
        rh, rl = modal_n2.first_root(p, 4, lo, hi, nsamp)
        ncand, bh, bl = _candidate(work, ncand, CENTRES_MEET, 1, rh, rl, bh, bl)
    return bh, bl, ncand


@callee(error_model="numpy", _nrt=False)
def _first_event(coulomb, p, h, state, work):
    """Search the candidates window by window (WINDOW samples each) and stop at
    the first window holding a root: most modes end within a period, so
    sampling all of h (up to 256 samples per event function) cost 4-5x the rest
    of a collision; roots beyond the window are not needed, the step ends at
    the earliest root. Returns (th, tl, ncand, h): the earliest root, the
    candidates written and the step's span (cut for sampled modes)."""
    s0, s1 = state.slide[0], state.slide[1]
    sliding = coulomb and (s0 == 1 or s0 == -1 or s1 == 1 or s1 == -1)
    deep = modal_n2.overlap_bound(p) >= p.limit
    sampled = p.drive != 0.0 or sliding or p.case != 0.0 or deep
    dts = h
    dts_max = h
    if sampled:
        dts = modal_n2.sample_step(p)
        # Overdamped (D <= 0): after the fast transient the mode creeps at the
        # slow rate ~K/c, so the windows double their sampling interval up to
        # a quarter of the slow time scale (a sum of real exponentials has at
        # most two extrema, so coarse samples miss nothing the transient's fine
        # ones do not catch). With the fast scale alone, gamma = 1e6 needed
        # ~1e10 steps to reach t_end: an apparent hang.
        dts_max = modal_n2.slow_sample_step(p)
        h = min(h, 256.0 * dts_max)
    open_root = (math.inf, 0.0)
    if p.drive == 0.0:
        open_root = modal_n2.open_root_analytic(p, h)
    lo = 0.0
    while True:
        hi = min(h, lo + WINDOW * dts) if sampled else h
        nsamp = max(1, int(math.ceil((hi - lo) / dts))) if sampled else 0
        bh, bl, ncand = _window_roots(coulomb, p, lo, hi, nsamp, deep, open_root, state, work)
        if bh + bl <= hi or hi >= h:
            break
        lo = hi
        dts = min(2.0 * dts, dts_max)
    return bh, bl, ncand, h


@callee(error_model="numpy", _nrt=False)
def _frames_in_mode(coulomb, viscous, t_new, settings, clock, model, state, work, frames):
    """Frames at the output cadence up to t_new, from the mode's closed form.
    Returns Pause.LOG_FULL when the buffers are full (state untouched), else GOING."""
    p = work.modal[0]
    u, v, overlap = state.u, state.v, state.overlap
    t, tlo, t_end, out_dt = clock.time, clock.time_lo, settings.t_end, settings.frame_interval
    e0, _ = modal_energy(coulomb, model, state, overlap[1], v[0], v[1], 0.0, 0.0)
    while True:
        tf = clock.next_frame * out_dt
        if tf > t_new or tf > t_end:
            break
        if clock.n_frames >= frames.t.size - 3:
            return Pause.LOG_FULL.value
        x = (tf - t) - tlo
        d, w, v0, v1, du0, du1 = modal_n2.state(p, x, 0.0)
        ex, wc = modal_energy(coulomb, model, state, d, v0, v1, du0, du1)
        wv = (e0 - ex - wc) if viscous else 0.0
        su0, su1, sv0, sv1, sd = u[0], u[1], v[0], v[1], overlap[1]
        u[0] += du0
        u[1] += du1
        v[0] = v0
        v[1] = v1
        overlap[1] = d
        record_frame(LAW_LINEAR, tf, clock, model, state, frames, wc, wv)
        u[0], u[1], v[0], v[1], overlap[1] = su0, su1, sv0, sv1, sd
        clock.next_frame += 1
    return GOING


@callee(error_model="numpy", _nrt=False)
def modal_step(coulomb, viscous, settings, clock, model, state, work, frames):
    """One step of the exact modal solution from the mode's start (record
    ``work.modal``, filled by :func:`modal_n2.setup`).

    A step can span a whole contact, so the centres meeting is a root like the
    others (searched only when the mode's energy bound does not exclude it).

    Parameters
    ----------
    coulomb : int
        Compile-time feature code: nonzero when some granule has Coulomb friction.
    viscous : int
        Compile-time feature code: nonzero when some granule has viscous friction.
    settings : record of SETTINGS_DTYPE
        What the kernel is asked to do (end time, tolerances, stops), kernel units.
    clock : record of CLOCK_DTYPE
        The run's clock and work totals (kernel units), advanced in place.
    model : ChainArrays
        The chain's constants in kernel numbering and units: granules (N,),
        contacts (N + 1,).
    state : MotionState
        The state advanced in place: ``u``, ``v`` (N,), ``overlap`` (N + 1,),
        kernel units; modes ``closed`` (N + 1,), ``slide`` (N,).
    work : Workspace
        Scratch of the step: series (rows, P + 1 or P + 2), candidate lists, flags.
    frames : FrameBuffers
        Frame buffers (F rows; ``x``, ``v``, ``f`` (F, N), ``e`` (F, 7)), kernel units.

    Returns
    -------
    code : int
        A Status (the run ended), a Pause, or GOING.
    event : int
        1 when the step ended at the earliest candidate root, else 0.
    tau_e : float
        That root, kernel time units from the step's start (0.0 without an event).
    ncand : int
        Candidates written to ``work.cand_*`` (0 without an event).
    """
    p = work.modal[0]
    u, v, overlap = state.u, state.v, state.overlap
    t, tlo, t_end = clock.time, clock.time_lo, settings.t_end
    rem = (t_end - t) - tlo
    p.limit = model.overlap_limit[1]
    bh, bl, ncand, h = _first_event(coulomb, p, rem, state, work)
    event = bh + bl <= h
    if event:
        th, tl = bh, bl
    else:
        th, tl = h, 0.0
    s_, e_ = modal_n2.two_sum(t, th)
    t_new, t_lo_new = modal_n2.two_sum(s_, e_ + tlo + tl)
    if not event and h == rem:
        t_new = t_end
        t_lo_new = 0.0
    if settings.frame_interval > 0.0:
        # (the friction codes at run time: frames are made at output times only)
        code = _frames_in_mode(run_time(coulomb), run_time(viscous), t_new, settings, clock,
                               model, state, work, frames)
        if code != GOING:
            return code, 0, 0.0, 0
    e0, _ = modal_energy(coulomb, model, state, overlap[1], v[0], v[1], 0.0, 0.0)
    d, w, v0, v1, du0, du1 = modal_n2.state(p, th, tl)
    ex, wc = modal_energy(coulomb, model, state, d, v0, v1, du0, du1)
    clock.work_coulomb += wc
    if viscous:
        clock.work_viscous += e0 - ex - wc
    u[0] += du0
    u[1] += du1
    v[0] = v0
    v[1] = v1
    overlap[1] = d
    clock.time = t_new
    clock.time_lo = t_lo_new
    clock.steps += 1
    if not (math.isfinite(u[0]) and math.isfinite(u[1]) and math.isfinite(v[0])
            and math.isfinite(v[1]) and math.isfinite(d)):
        return Status.NONFINITE.value, 0, 0.0, 0
    if not event:
        if t_new >= t_end:
            record_frame(LAW_LINEAR, t_end, clock, model, state, frames, 0.0, 0.0)
            return Status.T_END.value, 0, 0.0, 0
        return GOING, 0, 0.0, 0
    return GOING, 1, bh + bl, ncand
