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
cached on disk) once and code for absent features is not generated. A step
makes three passes over the chain: kick + drift, contact forces, then net
force + kick + contact events; the middle one vectorises.
"""

import numba
from numba import literally

from ..forces import contact_forces, wall_forces
from ..laws.friction import coulomb_kick, free_kick, viscous_drift

# Stop codes returned by the driver.
RAN_CHUNK = 0
SEPARATED = 1
AT_REST = 2

# Stop-mode bits.
STOP_ON_SEPARATION = 1
STOP_ON_REST = 2

# Indices into the event-count array.
EV_CLOSE, EV_OPEN, EV_STOP, EV_SLIP = 0, 1, 2, 3
EVENT_KINDS = ("contact_close", "contact_open", "stop", "slip")


@numba.njit(inline="always", cache=True)
def kick(coulomb, i, v, F, inv_m, eta, eta_s, h):
    """Kick of granule i: (v_new, w_coulomb, 0, code), the law chosen at compile time."""
    if coulomb:
        return coulomb_kick(v, F, eta[i], eta_s[i], inv_m[i], h)
    else:
        return free_kick(v, F, inv_m[i], h)


@numba.njit(cache=True, fastmath={"reassoc", "contract", "nsz"})
def verlet_chunk(law, coulomb, viscous, left_wall, right_wall, stop_mode,
                 u, v, f, c, active, d0, k, n, walls, m, inv_m, eta, eta_s, E, P1, P2, du,
                 dt, n_steps, stop_contact, ledger, counts):
    """Advance the state by up to ``n_steps`` velocity-Verlet steps, in place.

    Parameters
    ----------
    law, coulomb, viscous, left_wall, right_wall, stop_mode : int
        Compile-time feature codes (``stop_mode``: bit 1 = stop at the opening
        of ``stop_contact``, bit 2 = stop when every granule is at rest).
    u, v, f : ndarray, shape (N,)
        Displacements, velocities and net spring forces (f consistent with u on entry).
    c : ndarray, shape (max(N-1, 1),)
        Contact forces (work array).
    active : ndarray of uint8, shape (max(N-1, 1),)
        1 where the contact is closed (delta > 0); updated, for event counting.
    d0, k, n, walls, m, inv_m, eta, eta_s, E, P1, P2 : ndarray
        Packed parameters (see :class:`granular_chain.model.Model`); E, P1, P2
        the per-granule drag coefficients exp(-c dt), phi1(c, dt), phi2(c, dt),
        c = gamma/m.
    du : ndarray, shape (N,)
        Work array (displacements of the step, viscous scenes).
    dt : float
        Time step.
    n_steps : int
        Steps to take at most.
    stop_contact : int
        Contact watched by ``stop_mode`` bit 1.
    ledger : ndarray, shape (2,)
        Accumulated energy dissipated by Coulomb and by viscous friction (>= 0).
    counts : ndarray of int64, shape (4,)
        Accumulated event counts (close, open, stop, slip).

    Returns
    -------
    steps : int
        Steps taken.
    code : int
        RAN_CHUNK, SEPARATED or AT_REST.
    """
    law = literally(law)
    coulomb = literally(coulomb)
    viscous = literally(viscous)
    left_wall = literally(left_wall)
    right_wall = literally(right_wall)
    stop_mode = literally(stop_mode)
    h = 0.5 * dt
    inv_dt = 1.0 / dt
    N = u.size
    for step in range(n_steps):
        wc = 0.0
        wv = 0.0
        n_stop = 0
        n_slip = 0
        # Pass 1: first half kick and drift.
        for i in range(N):
            if viscous and not coulomb:
                # Exponential Verlet: exact for drag, second order for springs.
                vv = v[i]
                a = f[i] * inv_m[i]
                dui = vv * P1[i] + a * P2[i]
                u[i] += dui
                du[i] = dui
                v[i] = vv * E[i] + a * (P1[i] - P2[i] * inv_dt)
                wv -= 0.5 * m[i] * vv * vv + 0.5 * f[i] * dui
                continue
            v1, a, b, code = kick(coulomb, i, v[i], f[i], inv_m, eta, eta_s, h)
            wc += a
            n_stop += code & 1
            n_slip += (code >> 1) & 1
            if viscous:
                dui, v1, b = viscous_drift(v1, m[i], E[i], P1[i])
                u[i] += dui
                wv += b
            else:
                u[i] += dt * v1
            v[i] = v1
        # Pass 2: contact forces at the new positions (vectorised).
        contact_forces(law, u, d0, k, n, c)
        fl, fr = wall_forces(law, left_wall, right_wall, u, walls)
        if stop_mode & STOP_ON_SEPARATION:
            watched_was = active[stop_contact]
        # Pass 3: net force, second half kick, contact events.
        n_close = 0
        n_open = 0
        for i in range(N):
            left = c[i - 1] if i > 0 else fl
            right = c[i] if i < N - 1 else fr
            F = left - right
            f[i] = F
            if viscous and not coulomb:
                v1 = v[i] + F * inv_m[i] * P2[i] * inv_dt
                v[i] = v1
                # viscous work = change of kinetic energy - trapezoidal spring work
                wv += 0.5 * m[i] * v1 * v1 - 0.5 * F * du[i]
            else:
                v1, a, b, code = kick(coulomb, i, v[i], F, inv_m, eta, eta_s, h)
                v[i] = v1
                wc += a
                n_stop += code & 1
                n_slip += (code >> 1) & 1
            if i < N - 1:
                now = 1 if right > 0.0 else 0
                was = active[i]
                n_close += now & (1 - was)
                n_open += was & (1 - now)
                active[i] = now
        if coulomb:
            ledger[0] -= wc
            counts[EV_STOP] += n_stop
            counts[EV_SLIP] += n_slip
        if viscous:
            ledger[1] -= wv
        counts[EV_CLOSE] += n_close
        counts[EV_OPEN] += n_open
        if stop_mode & STOP_ON_SEPARATION:
            if watched_was == 1 and active[stop_contact] == 0:
                return step + 1, SEPARATED
        if stop_mode & STOP_ON_REST:
            rest = True
            for i in range(N):
                if v[i] != 0.0:
                    rest = False
                    break
            if rest:
                return step + 1, AT_REST
    return n_steps, RAN_CHUNK
