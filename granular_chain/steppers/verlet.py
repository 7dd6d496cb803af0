"""Velocity-Verlet with exact friction kicks: one compiled step loop for every scene.

A step is kick(dt/2) - drift(dt) - kick(dt/2) (velocity Verlet written as
Strang splitting). The spring force is recomputed once per step by the one
neighbour loop of :mod:`granular_chain.forces`; each kick integrates the
granule's friction law exactly with that force frozen
(:mod:`granular_chain.laws.friction`). Without friction this is the classic
second-order velocity Verlet; with Coulomb friction a granule that stops
inside a drift is resolved only to O(dt) at that instant (the convergence
tests measure the resulting order rather than assume it).

The compiled driver :func:`verlet_chunk` advances a whole chunk of steps
(between two output frames) with no Python and no allocation inside; the
feature codes are compile-time literals, so each feature set compiles (and is
cached on disk) once, and code for absent features is not generated.
"""

import numba
from numba import literally

from ..forces import spring_forces
from ..laws.friction import coulomb_kick, viscous_kick

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
def kick_all(coulomb, viscous, v, f, m, inv_m, eta, eta_s, cv, E, P1, P2, h, ledger, counts):
    """Advance every velocity by a friction kick of duration h under frozen forces f."""
    N = v.size
    if coulomb:
        wc = 0.0
        wv = 0.0
        for i in range(N):
            v1, a, b, code = coulomb_kick(viscous, v[i], f[i], eta[i], eta_s[i], m[i],
                                          inv_m[i], cv[i], E[i], P1[i], P2[i], h)
            v[i] = v1
            wc += a
            wv += b
            counts[EV_STOP] += code & 1
            counts[EV_SLIP] += (code >> 1) & 1
        ledger[0] -= wc
        ledger[1] -= wv
    elif viscous:
        wv = 0.0
        for i in range(N):
            v1, a, b, code = viscous_kick(v[i], f[i], m[i], inv_m[i], E[i], P1[i], P2[i])
            v[i] = v1
            wv += b
        ledger[1] -= wv
    else:
        for i in range(N):
            v[i] += h * f[i] * inv_m[i]


@numba.njit(cache=True)
def verlet_chunk(law, coulomb, viscous, left_wall, right_wall, stop_mode,
                 u, v, f, c, active, d0, k, n, walls, m, inv_m, eta, eta_s, cv, E, P1, P2,
                 dt, n_steps, stop_contact, ledger, counts):
    """Advance the state by up to ``n_steps`` velocity-Verlet steps, in place.

    Parameters
    ----------
    law, coulomb, viscous, left_wall, right_wall, stop_mode : int
        Compile-time feature codes (``stop_mode``: bit 1 = stop at the opening
        of ``stop_contact``, bit 2 = stop when every granule is at rest).
    u, v, f : ndarray, shape (N,)
        Displacements, velocities and net spring forces (f consistent with u on entry).
    c : ndarray, shape (N-1,)
        Contact forces (work array).
    active : ndarray of uint8, shape (N-1,)
        1 where the contact is closed (delta > 0); updated, for event counting.
    d0, k, n, walls, m, inv_m, eta, eta_s, cv, E, P1, P2 : ndarray
        Packed parameters (see :class:`granular_chain.model.Model`); cv = gamma/m,
        E, P1, P2 the per-granule kick coefficients for h = dt/2.
    dt : float
        Time step.
    n_steps : int
        Steps to take at most.
    stop_contact : int
        Contact watched by ``stop_mode`` 1.
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
    N = u.size
    for step in range(n_steps):
        kick_all(coulomb, viscous, v, f, m, inv_m, eta, eta_s, cv, E, P1, P2, h, ledger, counts)
        for i in range(N):
            u[i] += dt * v[i]
        spring_forces(law, left_wall, right_wall, u, d0, k, n, walls, c, f)
        kick_all(coulomb, viscous, v, f, m, inv_m, eta, eta_s, cv, E, P1, P2, h, ledger, counts)
        if stop_mode & STOP_ON_SEPARATION:
            watched_was = active[stop_contact]
        for i in range(N - 1):
            now = 1 if c[i] > 0.0 else 0
            was = active[i]
            counts[EV_CLOSE] += now & (1 - was)
            counts[EV_OPEN] += was & (1 - now)
            active[i] = now
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
