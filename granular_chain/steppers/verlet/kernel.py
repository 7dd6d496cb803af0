"""Velocity-Verlet with exact friction kicks: the compiled step loops.

A step is kick(dt/2) - drift(dt) - kick(dt/2) (velocity Verlet as Strang
splitting). Each kick integrates the frozen spring force and Coulomb stick/slip
exactly, each drift the viscous drag exactly (:mod:`granular_chain.laws.friction`);
without friction this is classic velocity Verlet. Scenes with drag but no
Coulomb friction take the exponential form instead (c = gamma/m)::

    u+ = u + v phi1(c, dt) + a phi2(c, dt)
    v+ = v exp(-c dt) + a (phi1 - phi2/dt) + a+ phi2/dt

exact for the drag and second order for the springs, so a velocity relaxed
within one step (c dt >> 1) still comes out right.

Two algorithms, each a kernel of its own, so that a scene compiles only the one
it runs (:class:`~.records.Features` fields are compile-time constants):

* :func:`sweep_chunk`, scenes without Coulomb friction: one sweep per step
  (granule i+1's first half, contact i, granule i's second half), so u, v, f
  stream from memory once per step; the branch-free sweep vectorises as a
  first-order recurrence.
* :func:`passes_chunk`, scenes with Coulomb friction: the chain in blocks of
  ``BLOCK`` granules, three passes per block (kick + drift, contacts, net
  force), each a loop that vectorises, while the block stays in cache. A step's
  closing half kick and the next step's opening one act under the same frozen
  force and a kick is the exact flow of an autonomous equation, so they are
  merged into one kick of dt; between calls v holds the half-step velocities,
  which :func:`synchronise` completes for output.

A contact is closed when its overlap delta > 0 (:func:`.event_log.closed`, the
same test in both algorithms). Overlaps and forces come from
:mod:`granular_chain.forces` and :mod:`granular_chain.laws.contact`.
"""

import numba
import numpy as np

from ..._compile import kernel
from ...codes import Pause, Status
from ...forces import (contact_overlap, left_wall_force, left_wall_overlap, net_force,
                       right_wall_force, right_wall_overlap)
from ...laws.contact import contact_force
from ...laws.friction import at_rest_by, coulomb_kick, free_kick, viscous_drift
from .event_log import (CLOSE, OPEN, SLIP, STOP, closed, log_capacity, log_event, log_walls,
                        sweep_contact_log, walls_closed)
from .records import STOP_ON_REST, STOP_ON_SEPARATION, UNIT

__all__ = ["sweep_chunk", "passes_chunk", "synchronise", "chunk_kernel",
           "BLOCK", "BLOCK_LONG", "LONG_CHAIN"]

# Granules per block of the passes: smaller blocks for chains that stream from
# memory (faster from about N = 3e5 on, slower below; benchmarks/results/
# verlet_sweep_blocks.jsonl).
BLOCK = 1024
BLOCK_LONG = 256
LONG_CHAIN = 300_000

# Reassociation lets the reductions (friction work, event counts) vectorise.
FASTMATH = {"reassoc", "contract", "nsz"}

ONE = np.uint64(1)
TWO = np.uint64(2)

# The kernels return (steps taken, code): a Status when the run ends, a Pause otherwise.
CHUNK_DONE = int(Pause.CHUNK_DONE)
LOG_FULL = int(Pause.LOG_FULL)
SEPARATED = int(Status.SEPARATED)
AT_REST = int(Status.AT_REST)
OVERLAP = int(Status.OVERLAP)


def chunk_kernel(features):
    """The kernel that runs a scene of these features: the passes with Coulomb
    friction, the sweep otherwise.

    Parameters
    ----------
    features : Features
        The kernel's compile-time codes (:class:`.records.Features`); ``coulomb``
        picks the kernel.

    Returns
    -------
    numba dispatcher
        :func:`passes_chunk` or :func:`sweep_chunk`.
    """
    return passes_chunk if features.coulomb else sweep_chunk


# ---------------------------------------------------------------- the sweep
# Written without compound tests on the feature codes (``viscous and not
# coulomb``): those are not pruned at compile time, and they stopped loops
# vectorising.

@numba.njit(inline="always", cache=True)
def param(uniform, a, a0, i):
    """a[i], or a0 = a[0] read once before the loop when every a[i] is equal (uniform):
    the sweep then streams only u, v, f."""
    if uniform:
        return a0
    return a[i]


@numba.njit(inline="always", cache=True)
def uniform_values(uniform, chain, timestep):
    """The chain's one value of each parameter (m, 1/m, E, P1, P2, d0, k, n), read
    once; constants on the UNIT chain, so that the compiler drops the operations
    they make exact (x * 1, x + 0: the results are those of UNIFORM)."""
    m0, im0 = chain.mass[0], chain.inv_mass[0]
    E0, P10, P20 = timestep.E[0], timestep.P1[0], timestep.P2[0]
    d00, k0, n0 = (chain.d0[1], chain.k[1], chain.n[1]) if chain.d0.size > 2 else (0.0, 0.0, 0.0)
    if uniform == UNIT:
        m0, im0, d00, k0 = 1.0, 1.0, 0.0, 1.0
    return m0, im0, E0, P10, P20, d00, k0, n0


@numba.njit(inline="always", cache=True)
def sweep_first_half(viscous, u, v, F, m, inv_m, E, P1, P2, times):
    """First half kick and drift of one granule (state u, v, net force F, its
    parameters; ``times`` = (dt, 1/dt, dt/2)), without stores: the sweep
    carries the result to the next iteration.

    Returns (u_new, v_new, du, w_viscous): du, the displacement of the step, is
    what the drag-only second half needs."""
    dt, inv_dt, h = times
    if viscous:
        a = F * inv_m
        du = v * P1 + a * P2
        return u + du, v * E + a * (P1 - P2 * inv_dt), du, -(0.5 * m * v * v + 0.5 * F * du)
    else:
        v1, w1, w2, code = free_kick(v, F, inv_m, h)
        return u + dt * v1, v1, 0.0, 0.0


@numba.njit(inline="always", cache=True)
def sweep_second_half(viscous, v, F, du, m, inv_m, P2, times):
    """Second half kick of one granule under net force F: (v_new, w_viscous)."""
    dt, inv_dt, h = times
    if viscous:
        v1 = v + F * inv_m * P2 * inv_dt
        # viscous work = change of kinetic energy - trapezoidal spring work
        return v1, 0.5 * m * v1 * v1 - 0.5 * F * du
    else:
        v1, w1, w2, code = free_kick(v, F, inv_m, h)
        return v1, 0.0


@numba.njit(inline="always", cache=True)
def store_granule(state, i, u, v, F, stop_mode):
    """Store granule i's new u, v and net force; 1 if it moves and the run stops at rest."""
    state.u[i] = u
    state.v[i] = v
    state.f[i] = F
    if stop_mode & STOP_ON_REST:
        return 1 if v != 0.0 else 0
    return 0


@numba.njit(inline="always", cache=True)
def sweep_contact_closed(chain, u, j):
    """1 if contact j (between granules j and j+1: table row j+1) is closed, from the
    displacements (the sweep keeps no state array)."""
    if u.size < 2:
        return 0
    return closed(chain.d0[j + 1], u[j], u[j + 1])


@numba.njit(inline="always", cache=True)
def overlap_reached(features, chain, u, n_hard):
    """Whether some overlap reached olim (the centres met): checked every step,
    since granules passing through each other can come out again between frames;
    contacts only when some force reached fcap (n_hard > 0)."""
    N = u.size
    if n_hard > 0:
        for i in range(N - 1):
            if contact_overlap(chain.d0[i + 1], u[i], u[i + 1]) >= chain.olim[i + 1]:
                return True
    if features.left_wall:
        if left_wall_overlap(chain.d0[0], u[0]) >= chain.olim[0]:
            return True
    if features.right_wall:
        if right_wall_overlap(chain.d0[N], u[N - 1]) >= chain.olim[N]:
            return True
    return False


@kernel(nogil=True, fastmath=FASTMATH)
def sweep_chunk(features, chain, timestep, state, call, log):
    """Advance a scene without Coulomb friction by up to ``call.n_steps`` steps, in place.

    Each step is one sweep: granule i+1's first half, contact i, granule i's
    second half. Granule i+1's new u, v travel to the next iteration in
    registers and the last granule is peeled off; contact events are read off
    the overlap's sign before and after the step (no state array streamed). The
    sweep stays in this function: moved into a helper, the compiler regroups
    some products differently (last-bit changes).

    Parameters
    ----------
    features : Features
        Compile-time codes (``coulomb`` 0).
    chain, timestep, state, call : Chain, Timestep, State, Call
        See :mod:`.records`.
    log : EventBuffers
        Read only with ``features.log_events``; a step starts only with room for
        :func:`.event_log.log_capacity` entries, else the call returns LOG_FULL.

    Returns
    -------
    (steps, code) : (int, int)
        Steps taken; Pause.CHUNK_DONE, Pause.LOG_FULL, Status.SEPARATED,
        Status.AT_REST or Status.OVERLAP.
    """
    law, viscous, uniform, stop_mode = features.law, features.viscous, features.uniform, \
        features.stop_mode
    u, v, f, counts = state.u, state.v, state.f, state.counts
    d0, k, n, m, inv_m = chain.d0, chain.k, chain.n, chain.mass, chain.inv_mass
    dt, E, P1, P2 = timestep
    times = (dt, 1.0 / dt, 0.5 * dt)
    last = np.uint64(max(u.size - 1, 0))
    m0, im0, E0, P10, P20, d00, k0, n0 = uniform_values(uniform, chain, timestep)
    if features.log_events:
        fill = log.fill[0]
        room = log.step.size - log_capacity(u.size, 0)
        seen = np.zeros(max(u.size - 1, 1), dtype=np.int8)
    for step in range(call.n_steps):
        if features.log_events:
            if fill > room:
                return step, LOG_FULL
            walls_was = walls_closed(features, u, d0)
            fill = sweep_contact_log(d0, u, seen, 0, log, fill, step)
        wv = 0.0
        n_moving = 0
        n_hard = 0
        if stop_mode & STOP_ON_SEPARATION:
            watched_was = sweep_contact_closed(chain, u, call.stop_contact)
        # contact events counted as changes and net change (2 integer operations a contact)
        n_change = 0
        n_net = 0
        u_was = u[0]
        ui, vi, dui, w = sweep_first_half(viscous, u_was, v[0], f[0], m[0], inv_m[0], E[0], P1[0],
                                          P2[0], times)
        wv += w
        left = 0.0
        if features.left_wall:
            left = left_wall_force(law, d0, k, n, ui)
        for i in range(np.uint64(0), last):
            j = i + ONE
            u_next_was = u[j]
            un, vn, dun, w = sweep_first_half(
                viscous, u_next_was, v[j], f[j], param(uniform, m, m0, j),
                param(uniform, inv_m, im0, j), param(uniform, E, E0, j),
                param(uniform, P1, P10, j), param(uniform, P2, P20, j), times)
            wv += w
            d0i = param(uniform, d0, d00, j)  # contact i: table row j = i + 1
            ci = contact_force(law, contact_overlap(d0i, ui, un), param(uniform, k, k0, j),
                               param(uniform, n, n0, j))
            n_hard += 1 if ci >= chain.fcap else 0
            was = closed(d0i, u_was, u_next_was)
            now = closed(d0i, ui, un)
            n_change += now ^ was
            n_net += now - was
            F = net_force(left, ci)
            v1, w = sweep_second_half(viscous, vi, F, dui, param(uniform, m, m0, i),
                                      param(uniform, inv_m, im0, i), param(uniform, P2, P20, i),
                                      times)
            n_moving += store_granule(state, i, ui, v1, F, stop_mode)
            wv += w
            left = ci
            u_was = u_next_was
            ui = un
            vi = vn
            dui = dun
        right = 0.0
        if features.right_wall:
            right = right_wall_force(law, d0, k, n, ui)
        F = net_force(left, right)
        v1, w = sweep_second_half(viscous, vi, F, dui, m[last], inv_m[last], P2[last], times)
        n_moving += store_granule(state, last, ui, v1, F, stop_mode)
        wv += w
        if viscous:
            state.ledger[1] -= wv
        counts[CLOSE] += (n_change + n_net) >> 1
        counts[OPEN] += (n_change - n_net) >> 1
        if features.log_events:  # read after the sums are stored: their bits stay
            fill = sweep_contact_log(d0, u, seen, 1, log, fill, step + 1)
            fill = log_walls(features, log, fill, step + 1, u, d0, walls_was)
            log.fill[0] = fill
        if overlap_reached(features, chain, u, n_hard):
            return step + 1, OVERLAP
        if stop_mode & STOP_ON_SEPARATION:
            if watched_was == 1 and sweep_contact_closed(chain, u, call.stop_contact) == 0:
                return step + 1, SEPARATED
        if stop_mode & STOP_ON_REST:
            if n_moving == 0:
                return step + 1, AT_REST
    return call.n_steps, CHUNK_DONE


# ---------------------------------------------------------------- the passes

@numba.njit(inline="always", cache=True)
def kick_drift_pass(features, chain, timestep, state, block, kick, seen, tally):
    """Pass 1 on granules [a, b) = ``block``: Coulomb kick by ``kick`` (the first
    half of this step merged with the second half of the last) and drift.

    ``tally`` = (w_coulomb, w_viscous, stops, slips, moving) so far; returned
    updated. With the log, each granule's kick code goes into ``seen``.
    """
    u, v, f, eta, eta_s = state.u, state.v, state.f, chain.eta, chain.eta_static
    m, inv_m, E, P1 = chain.mass, chain.inv_mass, timestep.E, timestep.P1
    dt = timestep.dt
    h = 0.5 * dt
    wc, wv, n_stop, n_slip, n_moving = tally
    # Unsigned loop indices: a signed index from a non-zero start gets numba's
    # negative-index wraparound test, which stops vectorisation. Block-local
    # offsets are written (i + j) - a >= 0.
    ua = np.uint64(block[0])
    for i in range(ua, np.uint64(block[1])):
        vi = v[i]
        v1, w1, w2, code = coulomb_kick(vi, f[i], eta[i], eta_s[i], inv_m[i], kick)
        wc += w1
        n_stop += code & 1
        n_slip += (code >> 1) & 1
        if features.log_events:
            seen[i - ua] = code
        if features.stop_mode & STOP_ON_REST:
            n_moving += 1 - at_rest_by(vi, v1, f[i], eta[i], inv_m[i], h)
        if features.viscous:
            dui, v1, w2 = viscous_drift(v1, m[i], E[i], P1[i])
            u[i] += dui
            wv += w2
        else:
            u[i] += dt * v1
        v[i] = v1
    return wc, wv, n_stop, n_slip, n_moving


@numba.njit(inline="always", cache=True)
def log_kicks(log, fill, step, block, seen):
    """Log the stops and slips pass 1 saw in ``block`` (scanned after it, so that
    the pass's sums vectorise as without the log); the new fill."""
    a, b = block
    for j in range(b - a):
        if seen[j] & 1:
            fill = log_event(log, fill, step, STOP, a + j)
        if seen[j] & 2:
            fill = log_event(log, fill, step, SLIP, a + j)
    return fill


@numba.njit(inline="always", cache=True)
def contact_pass(features, chain, state, block, buffer, log, fill, step, tally):
    """Pass 2: forces of the contacts whose two granules are drifted,
    max(a-1, 0) .. b-2, into ``buffer`` (buffer[j] = contact a - 2 + j), and their
    events (``active`` updated). ``tally`` = (closed, opened, n_hard); returns
    it updated and the log's fill."""
    u, active, d0, k, n = state.u, state.active, chain.d0, chain.k, chain.n
    n_close, n_open, n_hard = tally
    ua = np.uint64(block[0])
    for i in range(np.uint64(max(block[0] - 1, 0)), np.uint64(block[1]) - ONE):
        j = i + ONE  # contact i: table row i + 1
        ci = contact_force(features.law, contact_overlap(d0[j], u[i], u[i + ONE]), k[j], n[j])
        buffer[i + TWO - ua] = ci
        n_hard += 1 if ci >= chain.fcap else 0  # an integer reduction: vectorises
        # closed = delta > 0, as in the sweep (not ci > 0, which differs where
        # the force underflows: delta < ~1e-216 for Hertz)
        now = closed(d0[j], u[i], u[i + ONE])
        was = active[i]
        n_close += now & (1 - was)
        n_open += was & (1 - now)
        if features.log_events:
            if now != was:
                fill = log_event(log, fill, step, CLOSE if now else OPEN, i)
        active[i] = now
    return (n_close, n_open, n_hard), fill


@kernel(nogil=True, fastmath=FASTMATH)
def passes_chunk(features, chain, timestep, state, call, log):
    """Advance a scene with Coulomb friction by up to ``call.n_steps`` steps, in place.

    The chain is walked in blocks [a, b) of ``BLOCK`` granules (``BLOCK_LONG``
    on long chains); for each block, pass 1 (:func:`kick_drift_pass`) on
    granules a .. b-1, pass 2 (:func:`contact_pass`) on contacts max(a-1, 0) ..
    b-2 (the walls with the first and the last block), pass 3 (net force) on
    granules a-1 .. b-2 (to N-1 on the last block); the block's last contact
    force is carried in ``buffer`` to the next block. The kick that ends a step
    is the next step's pass 1. The passes are written here rather than in a
    step helper: an inlined helper holding inlined helpers costs a second of
    compilation.

    Parameters and returns as :func:`sweep_chunk`. ``call.opening`` 1: v holds
    synchronised velocities and the first kick is dt/2. With Status.AT_REST the
    steps are those up to the time every granule was at rest (the step that
    found it moved nothing); the driver tests the synchronised velocities at a
    call's end, which the next call's first step would otherwise report.

    Parameters
    ----------
    features : Features
        Compile-time codes (``coulomb`` 1).
    chain, timestep, state, call : Chain, Timestep, State, Call
        See :mod:`.records`; arrays of shape (N,), the contact table's columns
        (N+1,), units of the model.
    log : EventBuffers
        Read only with ``features.log_events``; a step starts only with room for
        :func:`.event_log.log_capacity` entries, else the call returns LOG_FULL.

    Returns
    -------
    (steps, code) : (int, int)
        Steps taken; Pause.CHUNK_DONE, Pause.LOG_FULL, Status.SEPARATED,
        Status.AT_REST or Status.OVERLAP.
    """
    u, f, N, ledger, counts = state.u, state.f, state.u.size, state.ledger, state.counts
    size = BLOCK_LONG if u.size >= LONG_CHAIN else BLOCK
    buffer = np.zeros(size + 2)  # block-local contact forces: stays in L1
    seen = np.zeros(size if features.log_events else 1, dtype=np.int8)
    fill = 0
    if features.log_events:
        fill = log.fill[0]
        room = log.step.size - log_capacity(u.size, 1)
    h = 0.5 * timestep.dt
    for step in range(call.n_steps):
        if features.log_events:
            if fill > room:
                return step, LOG_FULL
            walls_was = walls_closed(features, u, chain.d0)
        if features.stop_mode & STOP_ON_SEPARATION:
            watched_was = np.int64(state.active[call.stop_contact])
        kick = h if call.opening and step == 0 else timestep.dt
        kicks = (0.0, 0.0, 0, 0, 0)
        contacts = (0, 0, 0)
        for a in range(0, N, size):
            b = min(a + size, N)
            kicks = kick_drift_pass(features, chain, timestep, state, (a, b), kick, seen, kicks)
            if features.log_events:
                fill = log_kicks(log, fill, step + 1, (a, b), seen)
            if a == 0:
                buffer[1] = left_wall_force(features.law, chain.d0, chain.k, chain.n, u[0]) \
                    if features.left_wall else 0.0
            if b == N:
                buffer[b - a + 1] = right_wall_force(features.law, chain.d0, chain.k, chain.n,
                                                     u[N - 1]) \
                    if features.right_wall else 0.0
            contacts, fill = contact_pass(features, chain, state, (a, b), buffer, log, fill,
                                          step + 1, contacts)
            # Pass 3: net force (the kick that ends the step is the next step's pass 1),
            # from the block's buffer (net_contact_force's rows at unsigned offsets: a
            # signed 1 added to them would make a float index).
            ua = np.uint64(a)
            for i in range(np.uint64(max(a - 1, 0)), np.uint64(N if b == N else b - 1)):
                f[i] = net_force(buffer[i + ONE - ua], buffer[i + TWO - ua])
            buffer[0] = buffer[b - a]
        wc, wv, n_stop, n_slip, n_moving = kicks
        n_close, n_open, n_hard = contacts
        ledger[0] -= wc
        counts[STOP] += n_stop
        counts[SLIP] += n_slip
        if features.viscous:
            ledger[1] -= wv
        counts[CLOSE] += n_close
        counts[OPEN] += n_open
        if features.log_events:
            fill = log_walls(features, log, fill, step + 1, u, chain.d0, walls_was)
            log.fill[0] = fill
        if overlap_reached(features, chain, u, n_hard):
            return step + 1, OVERLAP
        if features.stop_mode & STOP_ON_SEPARATION:
            if watched_was == 1 and state.active[call.stop_contact] == 0:
                return step + 1, SEPARATED
        # Every granule was at rest when this step started (its kick tells): the
        # step changed nothing, so the run stops before it.
        if features.stop_mode & STOP_ON_REST:
            if n_moving == 0 and step > 0:
                return step, AT_REST
    return call.n_steps, CHUNK_DONE


@kernel()
def synchronise(v, f, eta, eta_s, inv_m, h, vs):
    """The synchronised velocities of a Coulomb (merged-kick) run: ``vs = v`` kicked by h
    (dt/2) under the frozen forces f, v left as it is.

    Parameters
    ----------
    v, f : ndarray, shape (N,)
        Half-step velocities v(t - dt/2) after the last kick and net spring forces at t,
        units of the model.
    eta, eta_s, inv_m : ndarray, shape (N,)
        Kinetic friction force, static threshold (force), 1/mass, units of the model.
    h : float
        dt/2, units of time of the model.
    vs : ndarray, shape (N,)
        Out: velocities at t, units of speed of the model.

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
