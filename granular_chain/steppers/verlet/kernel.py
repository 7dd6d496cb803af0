"""Velocity-Verlet with exact friction kicks: one compiled step loop for every scene.

A step is kick(dt/2) - drift(dt) - kick(dt/2) (velocity Verlet written as
Strang splitting). Contact forces are recomputed once per step by the
neighbour loop of :mod:`granular_chain.forces`; each kick integrates the
spring force (frozen) and Coulomb stick/slip exactly, and each drift the
viscous drag exactly (:mod:`granular_chain.laws.friction`). Without friction
this is the classic second-order velocity Verlet; with friction the exact
sub-steps keep the order at two (measured: docs/verlet_convergence.md).

Scenes with drag but no Coulomb friction use the exponential form of velocity
Verlet instead (exact for drag, second order for the springs, c = gamma/m)::

    u+ = u + v phi1(c, dt) + a phi2(c, dt)
    v+ = v exp(-c dt) + a (phi1 - phi2/dt) + a+ phi2/dt

which is the classic scheme as c -> 0 and the overdamped limit u+ = u + F dt/gamma,
v+ = F/gamma as c dt -> infinity: both positions and velocities stay right
when the drag relaxes a velocity within one step. (With Coulomb friction the
drag is split off into the drift: stable and exact for positions, but the
velocity carries an O(F dt / m) splitting error when c dt >> 1.)

The compiled driver :func:`verlet_chunk` advances a whole chunk of steps
(between two output frames) with no Python and no allocation inside. The
feature codes are compile-time literals, so each feature set compiles (and is
cached on disk) once and code for absent features is not generated.

Two shapes of the same step, chosen at compile time by the ``coulomb`` code:

*Scenes without Coulomb friction* (frictionless, drag only) take **one sweep**
per step: granule i+1 gets its first half kick and drift, contact i its force,
granule i its second half kick, so u, v and f stream from memory once per step.
Granule i+1's new u, v travel to the next iteration in registers; LLVM
vectorises the sweep as a first-order recurrence (vsqrtpd in its code). When
every granule has the same parameters and every contact the same (d0, k, n)
(feature code ``uniform``), the parameters are read once as scalars and the
sweep streams only u, v, f: 48 B per grain-step, against 72 B with per-granule
parameters. The paper's scaled chain, m = 1 and k = 1 on touching granules
(d0 = 0; feature code ``UNIT``), compiles them in as constants: the multiply by
k, the add of d0 and the mass factors are left out (1.10-1.17x in cache, measured),
and since x * 1 and x + 0 are exact the results are bit-identical to ``UNIFORM``.

*Scenes with Coulomb friction* take **three cache-blocked passes**: (1) kick +
drift, (2) contact forces and contact events, (3) net force (the kick that
ends a step is merged into the next step's pass 1; see *Merged kicks* below).
Their kick loops vectorise (8 granules per AVX-512 instruction) where the
sweep's branch-free Coulomb kick carried from one iteration to the next does not
(the sweep measured 4x slower with Coulomb friction). The chain is walked in
blocks of ``BLOCK`` granules (``BLOCK_LONG`` on long chains), and for each
block [a, b) the three passes run back to back, software-pipelined by one
granule:

* pass 1 on granules a .. b-1;
* pass 2 on the contacts whose two granules are now drifted, max(a-1, 0) .. b-2
  (the left wall with the first block, the right wall with the last);
* pass 3 on the granules whose two contacts are now known, a-1 .. b-2 (to N-1
  on the last block).

A block's arrays stay in L1/L2 between the passes, so u, v, f and the
parameters come from memory once per step. The contact forces live in a
block-local buffer (the last one carried to the next block), never written to
memory. Every pass stays a simple loop over a block with no loop-carried value
except reductions, so each vectorises.

*Merged kicks* (every Coulomb scene). The second half
kick of step s and the first half kick of step s+1 act under the same frozen
force f(t_(s+1)), and a kick is the exact flow of m dv/dt = F - eta sign(v)
with stick at v = 0 (autonomous while F is frozen), so the two are one kick of
dt: the same velocity, friction work and stop and slip counts (a kick stops at
most once, and after slipping from rest it never stops), up to roundoff. The
blocked passes therefore step the leapfrog form: pass 1 kicks by dt (by dt/2 on the
run's first step, ``opening``) and drifts, pass 3 only forms the net force, so
a step costs one Coulomb kick instead of two (1.4x faster in cache, measured).
Between chunks (at time t) v then holds the half-step velocity v(t - dt/2) of the
granules' last kick; :func:`synchronise` kicks a copy by the remaining dt/2 for
the output frame, so the trajectory does not depend on the output cadence.
The separation stop reads positions only, and the state it stops in is
synchronised in the same way. The rest stop is read off the merged kick: the
granule was at rest at the step's start time t when its kick ends at rest and
it had stopped within the first dt/2 (:func:`granular_chain.laws.friction.at_rest_by`).
When every granule was, the step just taken changed nothing (each drifted by
zero) and the kernel returns at t, the step before it; simulate() tests the
synchronised velocities at the chunk's end, which the next chunk's first step
would otherwise report.

A contact counts as closed when its overlap delta > 0 (the same test in both
shapes, written so that the same displacements always give the same answer).
The sweep derives each contact's state before and after the step from the
displacements it has at hand; the blocked passes keep it in the ``active``
array. The separation watch reads its contact before the step starts; the
overlap check (centres met) runs every step but costs only an integer count
unless some contact force reaches ``fcap``.

*Event log* (feature code ``log_events``, ``output.events``). Without it the
kernel only counts events and no logging code is compiled. With it each event
goes into buffers (step, kind, index) with a fill counter; a step starts only
when the buffers have room for its worst case (:func:`log_capacity`), else the
call returns LOG_FULL and :class:`EventLog` drains them and calls again (the
state lives in the arrays, so the resumed run is bit-identical). Nothing is
logged inside a loop with a floating-point sum: the Coulomb kick codes go into a
block buffer scanned after pass 1, the sweep's contacts are read before the step
and after its sums are stored, the walls at both ends of the step; so the run,
its ledger included, is bit-identical to the one without the log.
"""

import numba
import numpy as np
from numba import literally

from ..codes import EVENT_KINDS, EventKind  # noqa: F401  (EVENT_KINDS re-exported)
from ..forces import wall_forces
from ..laws.contact import contact_force
from ..laws.friction import at_rest_by, coulomb_kick, free_kick, viscous_drift

# Granules per block of the tiled step (see the module docstring). Chains that
# stream from memory take smaller blocks: BLOCK_LONG was 1.14-1.18x faster than
# 1024 at N = 1e6, equal at 1e7, but 0.94-0.97x at N <= 1e5 (benchmarks/results/
# verlet_sweep_blocks.jsonl), so it is used from LONG_CHAIN granules on.
BLOCK = 1024
BLOCK_LONG = 256
LONG_CHAIN = 300_000

ONE = np.uint64(1)
TWO = np.uint64(2)

# Stop codes returned by the driver.
RAN_CHUNK = 0
SEPARATED = 1
AT_REST = 2
OVERLAPPED = 3  # an overlap reached the sum of the radii (the centres met)
LOG_FULL = 4  # the event log has no room for another step: drain it and call again

# Values of the ``uniform`` feature code.
PER_GRANULE = 0
UNIFORM = 1  # one value of each parameter, read once as a scalar
UNIT = 2  # uniform with m = 1, k = 1, d0 = 0 (the scaled touching chain): constants

# Stop-mode bits.
STOP_ON_SEPARATION = 1
STOP_ON_REST = 2

# Indices into the event-count array.
EV_CLOSE, EV_OPEN, EV_STOP, EV_SLIP = (int(k) for k in EventKind)



@numba.njit(cache=True)
def log_capacity(N, coulomb):
    """Entries an event log needs for one step of a chain of N granules: every
    contact (walls included) may close or open, and with Coulomb friction every
    granule may stop and slip in its kick. The kernel starts a step only with
    this much room left."""
    return N + 1 + (2 * N if coulomb else 0)


def new_event_log(N: int, coulomb: bool, log_events: int):
    """The kernel's ``events`` argument: (step int64, kind int8, index int64, fill
    int64 (1,)). Room for at least 65536 entries and one step when logging;
    empty buffers otherwise (the kernel compiled without the log never touches them)."""
    size = max(1 << 16, log_capacity(N, coulomb)) if log_events else 0
    return (np.zeros(size, dtype=np.int64), np.zeros(size, dtype=np.int8),
            np.zeros(size, dtype=np.int64), np.zeros(1, dtype=np.int64))


@numba.njit(inline="always", cache=True)
def log_event(events, fill, step, kind, index):
    """Append (step, kind, index) at entry ``fill`` of the event log; the new fill."""
    events[0][fill] = step
    events[1][fill] = kind
    events[2][fill] = index
    return fill + 1


@numba.njit(inline="always", cache=True)
def walls_closed(left_wall, right_wall, u, walls):
    """(left, right): 1 where that wall's contact is closed (delta > 0), as
    :func:`granular_chain.forces.wall_forces` measures delta; 0 without the wall."""
    lc = 0
    rc = 0
    if left_wall:
        lc = 1 if walls[0] - u[0] > 0.0 else 0
    if right_wall:
        rc = 1 if walls[3] + u[u.size - 1] > 0.0 else 0
    return lc, rc


@numba.njit(inline="always", cache=True)
def log_walls(events, fill, step, left_wall, right_wall, u, walls, lc, rc):
    """Log the wall contacts that changed since they were (lc, rc); the new fill."""
    lc1, rc1 = walls_closed(left_wall, right_wall, u, walls)
    if lc1 != lc:
        fill = log_event(events, fill, step, EV_CLOSE if lc1 else EV_OPEN, -1)
    if rc1 != rc:
        fill = log_event(events, fill, step, EV_CLOSE if rc1 else EV_OPEN, u.size - 1)
    return fill


@numba.njit(cache=True)
def sweep_contact_log(uniform, d0, u, seen, after, events, fill, step):
    """The sweep's contact events, read off the displacements before (``after`` 0:
    the states into ``seen``) and after the step (1: a log entry where a state
    changed); the new fill. Kept out of the sweep and called, not inlined: code
    around the sweep changes how its sums are reassociated (the drag's work in the
    ledger then differs in the last bits from the run without the log)."""
    for i in range(u.size - 1):
        # d0 is 0 on the UNIT chain, where the sweep adds the constant 0.0: the same test
        now = closed(d0[i], u[i], u[i + 1])
        if not after:
            seen[i] = now
        elif now != seen[i]:
            fill = log_event(events, fill, step, EV_CLOSE if now else EV_OPEN, i)
    return fill


@numba.njit(cache=True)
def kick_codes(v, f, eta, eta_s, inv_m, h, codes):
    """Stop/slip codes (bit 1 stop, bit 2 slip) of the half kick :func:`synchronise`
    takes, per granule, into ``codes`` (int8, shape (N,)): the events behind the
    stop and slip counts it returns."""
    for i in range(v.size):
        v1, w1, w2, code = coulomb_kick(v[i], f[i], eta[i], eta_s[i], inv_m[i], h)
        codes[i] = code


# The sweep's two halves of a step for one granule (scenes without Coulomb
# friction). Written without a compound test on the feature codes: a test like
# ``viscous and not coulomb`` inside an inlined function is not pruned at
# compile time, and in the blocked passes it stopped the kick loop vectorising
# (Coulomb + viscous 2.2x slower, measured).

@numba.njit(inline="always", cache=True)
def param(uniform, a, a0, i):
    """a[i], or a0 = a[0] read once before the loop when every a[i] is equal (uniform):
    the sweep then streams only u, v, f."""
    if uniform:
        return a0
    return a[i]


@numba.njit(inline="always", cache=True)
def sweep_first_half(viscous, u, v, F, m, inv_m, E, P1, P2, dt, inv_dt, h):
    """First half kick and drift of one granule (state u, v, net force F, its
    parameters), without stores: the sweep carries the result to the next iteration.

    Returns (u_new, v_new, du, w_viscous): du, the displacement of the step, is
    what the drag-only second half needs."""
    if viscous:
        # Exponential Verlet: exact for drag, second order for springs.
        a = F * inv_m
        du = v * P1 + a * P2
        return u + du, v * E + a * (P1 - P2 * inv_dt), du, -(0.5 * m * v * v + 0.5 * F * du)
    else:
        v1, w1, w2, code = free_kick(v, F, inv_m, h)
        return u + dt * v1, v1, 0.0, 0.0


@numba.njit(inline="always", cache=True)
def sweep_second_half(viscous, v, F, du, m, inv_m, P2, inv_dt, h):
    """Second half kick of one granule under net force F: (v_new, w_viscous)."""
    if viscous:
        v1 = v + F * inv_m * P2 * inv_dt
        # viscous work = change of kinetic energy - trapezoidal spring work
        return v1, 0.5 * m * v1 * v1 - 0.5 * F * du
    else:
        v1, w1, w2, code = free_kick(v, F, inv_m, h)
        return v1, 0.0


@numba.njit(inline="always", cache=True)
def sweep_finish(viscous, stop_mode, i, ui, vi, F, dui, u, v, f, m, inv_m, P2, inv_dt, h):
    """Second half of granule i's step under net force F, stored: u[i], v[i], f[i].
    Returns (w_viscous, 1 if it moves and the run stops at rest else 0); the same
    for the sweep's loop and its peeled last granule."""
    v1, w = sweep_second_half(viscous, vi, F, dui, m, inv_m, P2, inv_dt, h)
    u[i] = ui
    v[i] = v1
    f[i] = F
    moving = 0
    if stop_mode & STOP_ON_REST:
        moving = 1 if v1 != 0.0 else 0
    return w, moving


@numba.njit(inline="always", cache=True)
def contact_state(coulomb, active, j, d0, u):
    """1 if contact j is closed: the events array of the blocked passes (Coulomb
    scenes), or the overlap's sign (the sweep keeps no events array)."""
    if coulomb:
        return np.int64(active[j])
    if u.size < 2:
        return 0
    return closed(d0[j], u[j], u[j + 1])


@numba.njit(inline="always", cache=True)
def closed(d0, ua, ub):
    """Whether a contact of initial overlap d0 between displacements ua, ub is
    closed (delta > 0), written so that the same two displacements always give
    the same answer (one subtraction and a comparison: nothing to reassociate)."""
    return 1 if ua - ub > -d0 else 0


@numba.njit(cache=True)
def synchronise(v, f, eta, eta_s, inv_m, h, vs):
    """The synchronised velocities of a Coulomb (merged-kick) run: ``vs = v`` kicked by h
    (dt/2) under the frozen forces f, v left as it is.

    Parameters
    ----------
    v, f : ndarray, shape (N,)
        Half-step velocities v(t - dt/2) after the last kick and net spring forces at t.
    eta, eta_s, inv_m : ndarray, shape (N,)
        Kinetic friction force, static threshold, 1/mass.
    h : float
        dt/2.
    vs : ndarray, shape (N,)
        Out: velocities at t.

    Returns
    -------
    (work, stops, slips) : (float, int, int)
        Coulomb work of the half kick (<= 0) and its stop and slip counts: what the
        ledger and the counts lack at t.
    """
    w = 0.0
    n_stop = 0
    n_slip = 0
    for i in range(v.size):
        v1, w1, w2, code = coulomb_kick(v[i], f[i], eta[i], eta_s[i], inv_m[i], h)
        vs[i] = v1
        w += w1
        n_stop += code & 1
        n_slip += (code >> 1) & 1
    return w, n_stop, n_slip


@numba.njit(cache=True, nogil=True, fastmath={"reassoc", "contract", "nsz"})
def verlet_chunk(law, coulomb, viscous, left_wall, right_wall, stop_mode, uniform, log_events,
                 u, v, f, active, d0, k, n, walls, m, inv_m, eta, eta_s, E, P1, P2,
                 dt, n_steps, opening, stop_contact, ledger, counts, olim, fcap, events):
    """Advance the state by up to ``n_steps`` velocity-Verlet steps, in place.

    Parameters
    ----------
    law, coulomb, viscous, left_wall, right_wall, stop_mode, uniform, log_events : int
        Compile-time feature codes (``stop_mode``: bit 1 = stop at the opening
        of ``stop_contact``, bit 2 = stop when every granule is at rest;
        ``uniform``: UNIFORM when every granule has the same m, inv_m, E, P1, P2
        and every contact the same d0, k, n, so that the sweep reads element 0
        once; UNIT when moreover m = k = 1 and d0 = 0, compiled in as constants;
        the blocked passes ignore it; ``log_events``: 1 to log every event in
        ``events``, 0 to compile no log code at all).
    u, v, f : ndarray, shape (N,)
        Displacements, velocities and net spring forces (f consistent with u on
        entry). With Coulomb friction (merged kicks) v holds, between chunks,
        the half-step velocities of the last kick (see :func:`synchronise`).
    active : ndarray of uint8, shape (max(N-1, 1),)
        1 where the contact is closed (delta > 0); updated by the blocked passes
        (Coulomb scenes) for event counting; the sweep neither reads nor updates it.
    d0, k, n, walls, m, inv_m, eta, eta_s, E, P1, P2 : ndarray
        Packed parameters (see :class:`granular_chain.model.Model`); E, P1, P2
        the per-granule drag coefficients exp(-c dt), phi1(c, dt), phi2(c, dt),
        c = gamma/m.
    dt : float
        Time step.
    n_steps : int
        Steps to take at most.
    opening : int
        1 on the run's first chunk: v holds the initial (synchronised)
        velocities, so a Coulomb (merged-kick) run opens with a kick of dt/2.
        Ignored without Coulomb friction.
    stop_contact : int
        Contact watched by ``stop_mode`` bit 1.
    ledger : ndarray, shape (2,)
        Accumulated energy dissipated by Coulomb and by viscous friction (>= 0).
    counts : ndarray of int64, shape (4,)
        Accumulated event counts (close, open, stop, slip).
    olim : ndarray, shape (N + 1,)
        Overlaps at which the centres meet: the left wall's granule radius,
        r_i + r_(i+1) for each contact, the right wall's granule radius.
    fcap : float
        The smallest contact force at which some contact reaches its olim:
        only a step with a contact force reaching it checks the overlaps
        themselves (a count in the contact loop is all the check costs otherwise).
    events : tuple (step, kind, index, fill)
        The event log (:func:`new_event_log`; read only with ``log_events``):
        entries from fill[0] on get (step, kind, index) of each event, ``step`` the
        step of this call (1 = its first) at whose end the change was seen,
        ``kind`` an index into EVENT_KINDS, ``index`` the contact (-1 left wall,
        N-1 right wall) or the granule. A step starts only with room for
        :func:`log_capacity` entries; otherwise the call returns LOG_FULL with
        the steps taken so far (the state is that of a call of as many steps).

    Returns
    -------
    steps : int
        Steps taken; with AT_REST in a Coulomb scene, the steps up to the time
        every granule was at rest (the step that found it moved nothing).
    code : int
        RAN_CHUNK, SEPARATED, AT_REST, OVERLAPPED or LOG_FULL.
    """
    law = literally(law)
    coulomb = literally(coulomb)
    viscous = literally(viscous)
    left_wall = literally(left_wall)
    right_wall = literally(right_wall)
    stop_mode = literally(stop_mode)
    uniform = literally(uniform)
    log_events = literally(log_events)
    h = 0.5 * dt
    inv_dt = 1.0 / dt
    N = u.size
    # Block-local buffer of the blocked passes (Coulomb scenes; allocated once
    # per chunk, stays in L1): cb[j] = force of contact a - 2 + j for the block
    # [a, b) (cb[1] = left wall force on the first block, cb[b - a + 1] = right
    # wall force on the last).
    B = BLOCK_LONG if N >= LONG_CHAIN else BLOCK
    cb = np.zeros((B if coulomb else 1) + 2)
    ulast = np.uint64(max(N - 1, 0))
    # The chain's one value of each parameter (used when uniform; d0, k, n are
    # empty for a single granule).
    m0, im0, E0, P10, P20 = m[0], inv_m[0], E[0], P1[0], P2[0]
    d00, k0, n0 = (d0[0], k[0], n[0]) if N > 1 else (0.0, 0.0, 0.0)
    if uniform == UNIT:
        # Constants, so that the compiler drops the operations they make exact.
        m0, im0, d00, k0 = 1.0, 1.0, 0.0, 1.0
    if log_events:
        nfill = events[3][0]
        room = events[0].size - log_capacity(N, coulomb)
        # Changes seen by the loops, logged by a scan after them: a branch inside a
        # loop with a floating-point reduction changes how it vectorises, hence the
        # order of the sum and the ledger's last bits. One code per granule of a
        # block (Coulomb passes: bit 1 stop, bit 2 slip); the sweep is left as it
        # is: its contacts' states are read (into seen) before the step starts and
        # compared after its ledger sums are stored (anywhere between, the scans
        # changed the drag work's last bits).
        seen = np.zeros(B if coulomb else max(N - 1, 1), dtype=np.int8)
    for step in range(n_steps):
        if log_events:
            if nfill > room:
                return step, LOG_FULL
            wl, wr = walls_closed(left_wall, right_wall, u, walls)
            if not coulomb:  # the contacts' states before the step
                nfill = sweep_contact_log(uniform, d0, u, seen, 0, events, nfill, step)
        wc = 0.0
        wv = 0.0
        n_stop = 0
        n_slip = 0
        n_close = 0
        n_open = 0
        n_moving = 0
        n_hard = 0
        if stop_mode & STOP_ON_SEPARATION:
            watched_was = contact_state(coulomb, active, stop_contact, d0, u)
        if not coulomb:
            # One sweep: granule i+1's first half, contact i, granule i's second
            # half, so u, v, f stream from memory once per step. Granule i+1's new
            # u, v travel to the next iteration in registers (storing and
            # reloading them measured 3x slower), and the last granule is peeled
            # off (a test on i inside the loop cost as much).
            n_change = 0
            n_net = 0
            uo = u[0]
            ui, vi, dui, w = sweep_first_half(viscous, uo, v[0], f[0], m[0], inv_m[0], E[0], P1[0],
                                              P2[0], dt, inv_dt, h)
            wv += w
            left = 0.0
            if left_wall:
                left = contact_force(law, walls[0] - ui, walls[1], walls[2])
            for i in range(np.uint64(0), ulast):
                j = i + ONE
                uon = u[j]
                un, vn, dun, w = sweep_first_half(
                    viscous, uon, v[j], f[j], param(uniform, m, m0, j), param(uniform, inv_m, im0, j),
                    param(uniform, E, E0, j), param(uniform, P1, P10, j), param(uniform, P2, P20, j),
                    dt, inv_dt, h)
                wv += w
                d0i = param(uniform, d0, d00, i)
                ci = contact_force(law, d0i + ui - un, param(uniform, k, k0, i),
                                   param(uniform, n, n0, i))
                n_hard += 1 if ci >= fcap else 0
                # Contact events from the overlap's sign before and after the step:
                # both displacements are at hand, so no state array is streamed
                # (the events array cost 10-25 %, measured on hand kernels).
                # Counted as changes and net change (2 integer operations a contact
                # instead of 4; 2-3 % in cache, measured on hand kernels).
                was = closed(d0i, uo, uon)
                now = closed(d0i, ui, un)
                n_change += now ^ was
                n_net += now - was
                w, mv = sweep_finish(viscous, stop_mode, i, ui, vi, left - ci, dui, u, v, f,
                                     param(uniform, m, m0, i), param(uniform, inv_m, im0, i),
                                     param(uniform, P2, P20, i), inv_dt, h)
                wv += w
                n_moving += mv
                left = ci
                uo = uon
                ui = un
                vi = vn
                dui = dun
            right = 0.0
            if right_wall:
                right = contact_force(law, walls[3] + ui, walls[4], walls[5])
            w, mv = sweep_finish(viscous, stop_mode, ulast, ui, vi, left - right, dui, u, v, f,
                                 m[ulast], inv_m[ulast], P2[ulast], inv_dt, h)
            wv += w
            n_moving += mv
            n_close = (n_change + n_net) >> 1
            n_open = (n_change - n_net) >> 1
        else:
            # Pass 1's kick: the first half of this step and the second half of
            # the last one, except on the run's first step.
            kd = h if opening and step == 0 else dt
            for a in range(0, N, B):
                b = min(a + B, N)
                # Unsigned loop indices: a signed index from a non-zero start gets
                # numba's negative-index wraparound test, which stops vectorisation
                # (3x slower). Block-local offsets are written (i + j) - ua >= 0.
                ua = np.uint64(a)
                ub = np.uint64(b)
                ulo = np.uint64(max(a - 1, 0))
                ue = np.uint64(N if b == N else b - 1)
                # Pass 1: kick (by kd) and drift of granules [a, b).
                for i in range(ua, ub):
                    # (the blocked passes run only with Coulomb friction: the sweep takes the rest)
                    vi = v[i]
                    v1, w1, w2, code = coulomb_kick(vi, f[i], eta[i], eta_s[i], inv_m[i], kd)
                    wc += w1
                    n_stop += code & 1
                    n_slip += (code >> 1) & 1
                    if log_events:
                        seen[i - ua] = code
                    if stop_mode & STOP_ON_REST:
                        n_moving += 1 - at_rest_by(vi, v1, f[i], eta[i], inv_m[i], h)
                    if viscous:
                        dui, v1, w2 = viscous_drift(v1, m[i], E[i], P1[i])
                        u[i] += dui
                        wv += w2
                    else:
                        u[i] += dt * v1
                    v[i] = v1
                if log_events:
                    for j in range(b - a):
                        if seen[j] & 1:
                            nfill = log_event(events, nfill, step + 1, EV_STOP, a + j)
                        if seen[j] & 2:
                            nfill = log_event(events, nfill, step + 1, EV_SLIP, a + j)
                # Walls: the left one acts on granule 0 (first block), the right
                # one on granule N-1 (last block).
                if a == 0:
                    fl, fr = wall_forces(law, left_wall, 0, u, walls)
                    cb[1] = fl
                if b == N:
                    fl, fr = wall_forces(law, 0, right_wall, u, walls)
                    cb[b - a + 1] = fr
                # Pass 2: contacts whose two granules are drifted, max(a-1, 0) .. b-2
                # (vectorised; the event counts are reductions).
                for i in range(ulo, ub - ONE):
                    ci = contact_force(law, d0[i] + u[i] - u[i + ONE], k[i], n[i])
                    cb[i + TWO - ua] = ci
                    n_hard += 1 if ci >= fcap else 0  # an integer reduction: vectorises
                    # closed = delta > 0, as in the sweep (not ci > 0, which differs
                    # where the force underflows: delta < ~1e-216 for Hertz)
                    now = closed(d0[i], u[i], u[i + ONE])
                    was = active[i]
                    n_close += now & (1 - was)
                    n_open += was & (1 - now)
                    if log_events:
                        if now != was:
                            nfill = log_event(events, nfill, step + 1,
                                              EV_CLOSE if now else EV_OPEN, i)
                    active[i] = now
                # Pass 3: net force on the granules whose two contacts are known:
                # a-1 .. b-2, or to N-1 on the last block (the kick that ends the
                # step is the next step's pass 1).
                for i in range(ulo, ue):
                    f[i] = cb[i + ONE - ua] - cb[i + TWO - ua]
                # Carry the block's last contact to the next block.
                cb[0] = cb[b - a]
        if coulomb:
            ledger[0] -= wc
            counts[EV_STOP] += n_stop
            counts[EV_SLIP] += n_slip
        if viscous:
            ledger[1] -= wv
        counts[EV_CLOSE] += n_close
        counts[EV_OPEN] += n_open
        if log_events:
            if not coulomb:  # the sweep's contact events
                nfill = sweep_contact_log(uniform, d0, u, seen, 1, events, nfill, step + 1)
            nfill = log_walls(events, nfill, step + 1, left_wall, right_wall, u, walls, wl, wr)
            events[3][0] = nfill
        # Granules passing through each other (a contact too soft for the
        # impact) can come out again between two output frames: checked every step.
        if n_hard > 0:
            for i in range(N - 1):
                if d0[i] + u[i] - u[i + 1] >= olim[i + 1]:
                    return step + 1, OVERLAPPED
        if left_wall:
            if walls[0] - u[0] >= olim[0]:
                return step + 1, OVERLAPPED
        if right_wall:
            if walls[3] + u[N - 1] >= olim[N]:
                return step + 1, OVERLAPPED
        if stop_mode & STOP_ON_SEPARATION:
            if watched_was == 1 and contact_state(coulomb, active, stop_contact, d0, u) == 0:
                return step + 1, SEPARATED
        if stop_mode & STOP_ON_REST:
            if coulomb:
                # Every granule was at rest when this step started (its pass-1 kick
                # tells): the step changed nothing, so the run stops before it. On
                # a chunk's first step simulate() has already tested that time.
                if n_moving == 0 and step > 0:
                    return step, AT_REST
            elif n_moving == 0:
                return step + 1, AT_REST
    return n_steps, RAN_CHUNK


class EventLog:
    """The driver's side of the event log (``output.events``): drains the kernel's
    buffers into a list of :class:`granular_chain.result.Event` after each call.

    An event's time is the end of the step that saw it, ``step * dt`` (t_end for
    the run's shortened last step), clamped to the time the call reached. The
    list grows by one Event (about 160 B, measured; not capped) per event;
    the kernel's buffers stay at their size (:func:`new_event_log`).

    Parameters
    ----------
    N : int
        Granules.
    coulomb : bool
        Whether the kernel runs the Coulomb (merged-kick) passes.
    dt : float
        Step.
    steps : int
        Whole steps of dt in the plan; later steps end at ``t_end``.
    t_end : float
        End of the run.
    """

    def __init__(self, N: int, coulomb: bool, dt: float, steps: int, t_end: float):
        self.buffers = new_event_log(N, coulomb, 1)
        self.events: list = []
        self.dt, self.steps, self.t_end = dt, steps, t_end
        self._codes = np.zeros(N, dtype=np.int8)
        self._pending: list = []

    def call(self, call, args: list, done: int, n_steps_at: int, opening_at: int):
        """``call(args)`` (one kernel call), draining the log after it and calling
        again while the kernel reports LOG_FULL; ``done`` = steps of the run before.
        Returns (steps taken, code) as one call would."""
        n_steps = args[n_steps_at]
        taken, code = call(args)
        self._drain(done, taken)
        while code == LOG_FULL:
            args[opening_at] = 0
            args[n_steps_at] = n_steps - taken
            more, code = call(args)
            self._drain(done + taken, more)
            taken += more
        args[n_steps_at] = n_steps
        return taken, code

    def _drain(self, done: int, taken: int) -> None:
        from ..result import Event

        step, kind, index, fill = self.buffers
        q = int(fill[0])
        s = np.minimum(step[:q], taken) + done
        t = np.where(s <= self.steps, s * self.dt, self.t_end)
        self.events.extend(Event(ti, EVENT_KINDS[k], i)
                           for ti, k, i in zip(t.tolist(), kind[:q].tolist(), index[:q].tolist()))
        fill[0] = 0

    def half_kick(self, v, f, model, h: float, t: float) -> None:
        """Hold the stop and slip events of the half kick :func:`synchronise` takes
        at time t (v, f and h as given to it); :meth:`commit` adds them."""
        kick_codes(v, f, model.eta, model.eta_static, model.inv_mass, h, self._codes)
        self._pending = [(t, kind, int(i)) for bit, kind in ((1, "stop"), (2, "slip"))
                         for i in np.flatnonzero(self._codes & bit)]

    def commit(self) -> list:
        """Add the held half-kick events (those the run's counts take in); the list."""
        from ..result import Event

        self.events.extend(Event(t, kind, i) for t, kind, i in sorted(
            self._pending, key=lambda e: e[2]))
        self._pending = []
        return self.events
