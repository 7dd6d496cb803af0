"""Velocity Verlet with contact dashpots, body forces and driven walls.

One kernel, :func:`forced_chunk`, runs every scene with any of these features;
scenes with none of them run the elastic kernels of :mod:`.kernel`, which know
nothing of this one. A step is kick(dt/2) - drift(dt) - kick(dt/2)
as in :mod:`.kernel` (Coulomb kicks and viscous drifts exact,
:mod:`granular_chain.laws.friction`), with the net force of a granule made of
its contacts' forces (spring + dashpot, :mod:`granular_chain.laws.damping`),
its body force and the walls' contacts.

Contacts and walls are numbered together, c = 0 .. N: c = 0 is the left wall,
c = i + 1 the contact between granules i and i + 1, c = N the right wall;
contact c lies between granule c - 1 and granule c, a wall being a granule of
prescribed displacement s(t) (:mod:`granular_chain.laws.wall_motion`)::

    delta_c = d0_c + u_(c-1) - u_c,   u_(-1) = s_L(t),  u_N = s_R(t)

Why the dashpot is integrated through its impulse
-------------------------------------------------
The dashpot force depends on the velocities, so the closing half kick of a
step would need the velocities it produces. Both dashpots are time derivatives
of a function of the overlap alone, D = d Phi(delta)/dt
(:func:`~granular_chain.laws.damping.dashpot_primitive`), so the impulse a
contact gives over the step is taken as::

    J = (dt/2) (S_old + S_new) + Phi(delta_new) - Phi(delta_old)

the spring's trapezoid (what velocity Verlet does) and the dashpot's impulse
exactly: no velocity at the end of the step is needed, and the jump of a
linear dashpot's force from 0 to c w when a contact closes (or back, tensile,
when it opens), which a force evaluated at the step's ends would miss by
O(dt) per collision, costs nothing. The opening half kick applies
(dt/2) F_old (F_old with the synchronised velocities, so positions advance by
dt v + dt^2 a_old / 2 as in Verlet); the closing one the rest, J - (dt/2)
F_old. Where a non-tensile contact's force is clipped at zero at either end of
the step, the clipped force is no derivative: J is then the trapezoid of the
clipped forces, the one at the end with the velocities predicted by a half
kick under the old force (error O(dt^2) in them, O(dt^3) in J). Both forms are
second order; the force-zero end, a kink, costs O(dt^2) once per contact.
Positions still advance with the dashpot force of the step's start: the
dashpot is explicit there, stable while c dt / m_eff < 2
(:func:`~.driver.check_dt` refuses a larger step; the default takes 1/40).

Ledger
------
The impulse above the spring's, J_D = J - (dt/2)(S_old + S_new), moves the two
sides of the contact by d(delta) over the step; the energy it takes is
``J_D d(delta) / dt`` (for the linear dashpot c d(delta)^2/dt >= 0), summed into
``contact_dissipated``. A moving wall does the work ``J d(s) / dt`` (left) and
``-J d(s) / dt`` (right), d(s) the wall's exact displacement over the step,
summed into ``wall_work``. Both match the kicks' work to O(dt^2) over a run,
as the spring's trapezoid matches the elastic energy; the body forces' work is
``sum_i f_i u_i``, read off the state by the driver.

Rest
----
With ``run.stop: rest`` the run ends after a step that leaves every granule at
rest: held by static friction (v = 0 and |f| <= eta_static), or still to
roundoff: its velocity moves it by at most :data:`REST_ULPS` units in the last
place of its displacement plus overlaps within a step, and its springs and body
force balance to what its closed contacts give when displaced by as much (their
stiffness (n-1) S/delta times that). A column settled under gravity never
reaches v = 0 exactly: the forces balance only to roundoff.

Not here: the event log (``output.events``), which the driver refuses for these
scenes.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from ..._compile import kernel
from ...codes import Pause, Status
from ...forces import net_contact_force, net_force
from ...laws.contact import LAW_LINEAR, contact_force
from ...laws.damping import (DAMPING_LINEAR, DAMPING_NONE, DAMPING_VISCOELASTIC,
                             damped_contact_force, dashpot_force, dashpot_primitive)
from ...laws.friction import coulomb_kick, free_kick, viscous_drift
from ...laws.wall_motion import wall_displacement, wall_speed
from .event_log import CLOSE, OPEN, SLIP, STOP
from .records import STOP_ON_REST, STOP_ON_SEPARATION

__all__ = ["ForcedFeatures", "Forcing", "ForcedState", "forced_chunk", "forced_start",
           "REST_ULPS"]

#: A granule still to within this many units in the last place (of its displacement
#: plus its overlaps) over a step is at rest (``run.stop: rest``).
REST_ULPS = 64.0
_EPS = float(np.finfo(np.float64).eps)

CHUNK_DONE = int(Pause.CHUNK_DONE)
SEPARATED = int(Status.SEPARATED)
AT_REST = int(Status.AT_REST)
OVERLAP = int(Status.OVERLAP)


class ForcedFeatures(NamedTuple):
    """Compile-time codes of :func:`forced_chunk` (integers). Walls, body forces,
    wall motion, ``tensile`` and the stop mode are runtime values (:class:`Forcing`),
    so that scenes differing only in them share one compiled kernel.

    Attributes
    ----------
    law : int
        Contact law (:mod:`granular_chain.laws.contact`).
    coulomb, viscous : int
        1 where the scene has that friction.
    damping : int
        Dashpot law (:mod:`granular_chain.laws.damping`), DAMPING_NONE included.
    """

    law: int
    coulomb: int
    viscous: int
    damping: int


class Forcing(NamedTuple):
    """The runtime constants of a forced scene.

    Attributes
    ----------
    d0, k, n, coefficient : ndarray, shape (N + 1,)
        Initial overlap, force coefficient, exponent and dashpot coefficient (c or
        A) of contact c (c = 0 the left wall, c = N the right wall), units of the
        model (length, force / length^(n-1), dimensionless, mass/time or time).
    body : ndarray, shape (N,)
        Body force on each granule along +x, units of force of the model.
    motion : ndarray, shape (2, 3)
        (kind, p1, p2) of the left and right wall (:mod:`granular_chain.laws.wall_motion`),
        units of the model.
    ends : ndarray of int64, shape (2,)
        First and last contact index present: 0 or 1, N or N - 1 (walls or not).
    tensile : int
        1: a damped contact may pull (it ends at overlap 0).
    stop_mode : int
        STOP_ON_SEPARATION | STOP_ON_REST.
    """

    d0: np.ndarray
    k: np.ndarray
    n: np.ndarray
    coefficient: np.ndarray
    body: np.ndarray
    motion: np.ndarray
    ends: np.ndarray
    tensile: int
    stop_mode: int


class ForcedState(NamedTuple):
    """What :func:`forced_chunk` carries from step to step besides :class:`.records.State`.

    Attributes
    ----------
    delta, spring, dashpot, phi, force : ndarray, shape (N + 1,)
        Per contact at the current time: overlap, spring force k delta^(n-1),
        dashpot force D (synchronised velocities), its primitive Phi and the
        total force (clipped unless tensile); zeros for an absent wall. Units of
        the model (length, force, force, impulse = force x time, force).
    closing : ndarray, shape (N + 1,)
        Work array: each contact's force in the closing half kick (force).
    v_pred : ndarray, shape (N,)
        Work array: velocities predicted at the end of the step (speed).
    work : ndarray, shape (2,)
        Energy dissipated so far by the dashpots; work done so far by the walls
        (units of energy of the model).
    clock : ndarray, shape (2,)
        (t_base, steps since t_base): a step starts at t_base + steps dt
        (t_base in units of time of the model; the count a float).
    after_jump : ndarray, shape (N + 1,)
        Work array: for a contact that closed in this step with a jump of its
        dashpot's force (Coulomb scenes only), the fraction of the step after
        the closing (linear interpolation of the overlap); 0 otherwise.
    """

    delta: np.ndarray
    spring: np.ndarray
    dashpot: np.ndarray
    phi: np.ndarray
    force: np.ndarray
    closing: np.ndarray
    v_pred: np.ndarray
    work: np.ndarray
    clock: np.ndarray
    after_jump: np.ndarray


@numba.njit(inline="always", cache=True)
def wall_positions(forcing, t):
    """(s_L, s_R): the walls' displacements at time t."""
    m = forcing.motion
    return (wall_displacement(int(m[0, 0]), m[0, 1], m[0, 2], t),
            wall_displacement(int(m[1, 0]), m[1, 1], m[1, 2], t))


@numba.njit(inline="always", cache=True)
def wall_speeds(forcing, t):
    """(s_L', s_R'): the walls' velocities at time t."""
    m = forcing.motion
    return (wall_speed(int(m[0, 0]), m[0, 1], m[0, 2], t),
            wall_speed(int(m[1, 0]), m[1, 1], m[1, 2], t))


@numba.njit(inline="always", cache=True)
def sides(x, c, left, right):
    """(value left of contact c, value right of it): x[c-1] and x[c], the walls'
    ``left`` and ``right`` beyond the ends."""
    a = x[c - 1] if c > 0 else left
    b = x[c] if c < x.size else right
    return a, b


# The helpers bind every array of a record to a local before their loops: an
# array read through a record inside a loop costs a reference count (an atomic
# increment and decrement), about 70 ns a granule.

@numba.njit(inline="always", cache=True)
def kick(coulomb, v, F, eta, eta_s, inv_m, h):
    """Kick from v under the frozen force F for h: (v_new, w_coulomb, code)."""
    if coulomb:
        v1, w1, w2, code = coulomb_kick(v, F, eta, eta_s, inv_m, h)
        return v1, w1, code
    v1, w1, w2, code = free_kick(v, F, inv_m, h)
    return v1, 0.0, 0


@numba.njit(inline="always", cache=True)
def jumps(features):
    """Whether a contact's force can jump when it closes in a Coulomb scene: a
    linear dashpot (c w), or a viscoelastic one at n = 2 (A k w)."""
    return features.coulomb != 0 and (features.damping == DAMPING_LINEAR or (
        features.damping == DAMPING_VISCOELASTIC and features.law == LAW_LINEAR))


@numba.njit(inline="always", cache=True)
def kick_after_jump(i, G, body, after, eta, eta_s, inv_m, dt):
    """Closing kick of a granule at rest (held through the opening half) next to a
    contact that closed in this step with a jump of its force.

    The opening half kick decided stick or slip from the force at the step's
    start, before the jump; a slip from the closing on is then a kick of the
    remaining time r = (fraction after the jump) dt, not dt/2, under the jumping
    contacts' impulse (dt/2) G spread over it and the other forces. Without
    this the granule lost a friction impulse eta (dt/2 - r) at each closing:
    Verlet with Coulomb friction and a linear dashpot was first order.

    Parameters
    ----------
    i : int
        The granule's index.
    G : ndarray, shape (N + 1,)
        Contacts' forces of the closing half kick (force).
    body : float
        The granule's body force (force).
    after : ndarray, shape (N + 1,)
        Fraction of the step after each contact's closing with a jump (0: none).
    eta, eta_s, inv_m : float
        Kinetic friction, static threshold (force), 1/mass.
    dt : float
        Step (time).

    Returns
    -------
    (v_new, w_coulomb, code)
        As :func:`kick`.
    """
    h = 0.5 * dt
    r = dt * max(after[i], after[i + 1])
    left = G[i] * (h / r) if after[i] > 0.0 else G[i]
    right = G[i + 1] * (h / r) if after[i + 1] > 0.0 else G[i + 1]
    v1, w1, w2, code = coulomb_kick(0.0, net_force(left, right) + body, eta, eta_s, inv_m, r)
    return v1, w1, code


@numba.njit(inline="always", cache=True)
def opening_half(features, chain, timestep, state, fstate, predict, counts):
    """Opening half kick and drift of every granule; with ``predict``, the velocity
    a second half kick under the same force would give (into v_pred). Returns the
    (Coulomb, viscous) work."""
    u, v, f, v_pred = state.u, state.v, state.f, fstate.v_pred
    eta, eta_s, inv_m, mass = chain.eta, chain.eta_static, chain.inv_mass, chain.mass
    E, P1 = timestep.E, timestep.P1
    dt = timestep.dt
    h = 0.5 * dt
    wc = 0.0
    wv = 0.0
    n_stop = 0
    n_slip = 0
    for i in range(u.size):
        v1, w1, code = kick(features.coulomb, v[i], f[i], eta[i], eta_s[i], inv_m[i], h)
        wc += w1
        n_stop += code & 1
        n_slip += (code >> 1) & 1
        if features.viscous:
            du, v1, w2 = viscous_drift(v1, mass[i], E[i], P1[i])
            wv += w2
        else:
            du = dt * v1
        u[i] += du
        v[i] = v1
        if predict:
            v_pred[i] = kick(features.coulomb, v1, f[i], eta[i], eta_s[i], inv_m[i], h)[0]
    counts[STOP] += n_stop
    counts[SLIP] += n_slip
    return wc, wv


@numba.njit(inline="always", cache=True)
def closing_force(features, tensile, old, d, S, phi, h, rate, params):
    """Force of a contact in the closing half kick, the rest of its impulse over the
    step (module docstring): ``old`` = (spring, dashpot, primitive) at the step's
    start, (d, S, phi) at its end, ``rate`` the predicted overlap rate there,
    ``params`` = (k, n, coefficient)."""
    S0, D0, phi0 = old
    G = S + ((phi - phi0) / h - D0)
    if features.damping != DAMPING_NONE and not tensile:
        raw = S + dashpot_force(features.law, features.damping, d, rate, params[0], params[1],
                                params[2])
        if S0 + D0 < 0.0 or raw < 0.0:  # clipped at an end: trapezoid of the clipped force
            G = max(raw, 0.0)
    return G


@numba.njit(inline="always", cache=True)
def contacts_after_drift(features, chain, timestep, state, forcing, fstate, times, counts):
    """Overlaps, springs and primitives at the step's end (stored), the closing
    kick's contact forces (into ``closing``), the dashpots' and walls' work.

    ``times`` = (t0, t1). Returns n_hard, the contacts whose spring force reached
    chain.fcap."""
    u, N, law = state.u, state.u.size, features.law
    d0, k, n, coef = forcing.d0, forcing.k, forcing.n, forcing.coefficient
    delta, spring, dashpot, phis = fstate.delta, fstate.spring, fstate.dashpot, fstate.phi
    force, closing, v_pred = fstate.force, fstate.closing, fstate.v_pred
    tensile, fcap = forcing.tensile, chain.fcap
    dt = timestep.dt
    h = 0.5 * dt
    s0 = wall_positions(forcing, times[0])
    s1 = wall_positions(forcing, times[1])
    sp = wall_speeds(forcing, times[1])
    closing[0] = 0.0
    closing[N] = 0.0
    diss = 0.0
    wall = 0.0
    n_hard = 0
    n_close = 0
    n_open = 0
    for c in range(forcing.ends[0], forcing.ends[1] + 1):
        a, b = sides(u, c, s1[0], s1[1])
        d = d0[c] + a - b
        S = contact_force(law, d, k[c], n[c])
        phi = dashpot_primitive(law, features.damping, d, k[c], n[c], coef[c])
        pa, pb = sides(v_pred, c, sp[0], sp[1])
        G = closing_force(features, tensile, (spring[c], dashpot[c], phis[c]), d, S, phi, h,
                          pa - pb, (k[c], n[c], coef[c]))
        J = h * (force[c] + G)
        if features.damping != DAMPING_NONE:
            diss += h * ((force[c] - spring[c]) + (G - S)) * (d - delta[c]) / dt
        if jumps(features):  # (the record read only in kernels that use it: ~70 ns a step)
            fstate.after_jump[c] = d / (d - delta[c]) if (delta[c] <= 0.0 < d) else 0.0
        if 0 < c < N:
            n_hard += 1 if S >= fcap else 0
            was = 1 if delta[c] > 0.0 else 0
            now = 1 if d > 0.0 else 0
            n_close += now & (1 - was)
            n_open += was & (1 - now)
        elif c == 0:
            wall += J * (s1[0] - s0[0]) / dt
        else:
            wall -= J * (s1[1] - s0[1]) / dt
        delta[c] = d
        spring[c] = S
        phis[c] = phi
        closing[c] = G
    counts[CLOSE] += n_close
    counts[OPEN] += n_open
    fstate.work[0] += diss
    fstate.work[1] += wall
    return n_hard


@numba.njit(inline="always", cache=True)
def closing_half(features, chain, timestep, state, forcing, fstate, counts):
    """Closing half kick of every granule under its contacts' closing forces and its
    body force; the Coulomb work."""
    v, G, body = state.v, fstate.closing, forcing.body
    eta, eta_s, inv_m = chain.eta, chain.eta_static, chain.inv_mass
    h = 0.5 * timestep.dt
    wc = 0.0
    n_stop = 0
    n_slip = 0
    for i in range(v.size):
        if jumps(features) and v[i] == 0.0 and (fstate.after_jump[i] > 0.0
                                                 or fstate.after_jump[i + 1] > 0.0):
            v1, w1, code = kick_after_jump(i, G, body[i], fstate.after_jump, eta[i],
                                           eta_s[i], inv_m[i], timestep.dt)
        else:
            v1, w1, code = kick(features.coulomb, v[i], net_contact_force(G, i) + body[i],
                                eta[i], eta_s[i], inv_m[i], h)
        wc += w1
        n_stop += code & 1
        n_slip += (code >> 1) & 1
        v[i] = v1
    counts[STOP] += n_stop
    counts[SLIP] += n_slip
    return wc


@numba.njit(inline="always", cache=True)
def end_forces(features, state, forcing, fstate, t):
    """Dashpot and total force of every contact with the synchronised velocities at
    time t (overlaps as stored), and the net force f on every granule."""
    v, f, N = state.v, state.f, state.v.size
    k, n, coef, body, tensile = forcing.k, forcing.n, forcing.coefficient, forcing.body, \
        forcing.tensile
    delta, dashpot, force = fstate.delta, fstate.dashpot, fstate.force
    law, damping = features.law, features.damping
    sp = wall_speeds(forcing, t)
    for c in range(forcing.ends[0], forcing.ends[1] + 1):
        a, b = sides(v, c, sp[0], sp[1])
        dashpot[c] = dashpot_force(law, damping, delta[c], a - b, k[c], n[c], coef[c])
        force[c] = damped_contact_force(law, damping, tensile, delta[c], a - b, k[c], n[c],
                                        coef[c])
    for i in range(N):
        f[i] = net_contact_force(force, i) + body[i]


@numba.njit(inline="always", cache=True)
def at_rest(features, chain, timestep, state, forcing, fstate):
    """1 if every granule is at rest after the step (module docstring, Rest)."""
    u, v, f, dt, eta_s = state.u, state.v, state.f, timestep.dt, chain.eta_static
    delta, spring, n, body = fstate.delta, fstate.spring, forcing.n, forcing.body
    for i in range(u.size):
        if features.coulomb and v[i] == 0.0 and abs(f[i]) <= eta_s[i]:
            continue
        scale = abs(u[i])
        stiffness = 0.0  # d(force)/d(delta) of the closed contacts: force per displacement
        for c in (i, i + 1):
            if delta[c] > 0.0:
                scale += delta[c]
                stiffness += (n[c] - 1.0) * spring[c] / delta[c]
        tol = REST_ULPS * _EPS * scale
        # the springs' and body force's balance: the dashpots' share of f is the
        # residual velocities' (checked on their own), not a displacement
        static = spring[i] - spring[i + 1] + body[i]
        if abs(v[i]) * dt > tol or abs(static) > stiffness * tol:
            return 0
    return 1


@numba.njit(inline="always", cache=True)
def overlap_reached(chain, forcing, fstate, n_hard):
    """Whether some overlap reached olim (the centres met); contacts between granules
    only when some spring force reached fcap (n_hard > 0), the walls always."""
    lo, hi, delta, olim = forcing.ends[0], forcing.ends[1], fstate.delta, chain.olim
    N = delta.size - 1
    for c in range(lo, hi + 1):
        if (n_hard > 0 or c == 0 or c == N) and delta[c] >= olim[c]:
            return True
    return False


@kernel(nogil=True)
def forced_chunk(features, chain, timestep, state, call, forcing, fstate):
    """Advance a scene with dashpots, body forces or driven walls by up to
    ``call.n_steps`` steps, in place (see the module docstring).

    Parameters
    ----------
    features : ForcedFeatures
        Compile-time codes.
    chain, timestep, state, call : Chain, Timestep, State, Call
        See :mod:`.records`; v holds synchronised velocities between calls
        (``call.opening`` is not read) and f the net force (contacts with their
        dashpots, walls, body force); state.ledger gets the Coulomb and viscous work.
    forcing : Forcing
        Runtime constants.
    fstate : ForcedState
        Contact state at the current time (consistent with state.u, state.v);
        its ``work`` gets the dashpots' and the walls' work.

    Returns
    -------
    (steps, code) : (int, int)
        Steps taken; Pause.CHUNK_DONE, Status.SEPARATED, Status.AT_REST or Status.OVERLAP.
    """
    dt = timestep.dt
    counts = state.counts
    predict = features.damping != DAMPING_NONE and not forcing.tensile
    watched = call.stop_contact + 1
    for step in range(call.n_steps):
        t0 = fstate.clock[0] + fstate.clock[1] * dt
        t1 = fstate.clock[0] + (fstate.clock[1] + 1.0) * dt
        was = False
        if forcing.stop_mode & STOP_ON_SEPARATION:
            was = _touching(predict, watched, fstate)
        wc, wv = opening_half(features, chain, timestep, state, fstate, predict, counts)
        n_hard = contacts_after_drift(features, chain, timestep, state, forcing, fstate,
                                      (t0, t1), counts)
        wc += closing_half(features, chain, timestep, state, forcing, fstate, counts)
        end_forces(features, state, forcing, fstate, t1)
        fstate.clock[1] += 1.0
        state.ledger[0] -= wc
        if features.viscous:
            state.ledger[1] -= wv
        if overlap_reached(chain, forcing, fstate, n_hard):
            return step + 1, OVERLAP
        if forcing.stop_mode & STOP_ON_SEPARATION:
            if was and not _touching(predict, watched, fstate):
                return step + 1, SEPARATED
        if forcing.stop_mode & STOP_ON_REST:
            if at_rest(features, chain, timestep, state, forcing, fstate):
                return step + 1, AT_REST
    return call.n_steps, CHUNK_DONE


@numba.njit(inline="always", cache=True)
def _touching(predict, j, fstate):
    """Whether contact j (a granule pair) still acts: overlap > 0, and for a
    non-tensile dashpot (``predict``) total force > 0 too, the contact's end the
    event stepper locates. (Between the force's zero and the overlap's, friction
    still slows the granules: reporting at the overlap's zero gave velocities
    0.03 away from the event stepper's.)"""
    if j >= fstate.delta.size - 1:
        return False
    if predict:
        return fstate.delta[j] > 0.0 and fstate.force[j] > 0.0
    return fstate.delta[j] > 0.0


@kernel()
def forced_start(features, state, forcing, fstate, t):
    """The contact state (into fstate) and net forces (into state.f) of
    (state.u, state.v) at time t.

    Parameters
    ----------
    features : ForcedFeatures
        Compile-time codes.
    state : State
        The kernel's state (:mod:`.records`); ``state.f`` (shape (N,), units of
        force of the model) is written.
    forcing : Forcing
        Runtime constants; per-contact arrays of shape (N+1,), left wall first.
    fstate : ForcedState
        Contact state, written: overlaps, spring forces and dashpot primitives of
        the contacts, units of the model.
    t : float
        Time of the state, units of time of the model (sets the walls' places).
    """
    u, law = state.u, features.law
    s = wall_positions(forcing, t)
    for c in range(forcing.ends[0], forcing.ends[1] + 1):
        a, b = sides(u, c, s[0], s[1])
        d = forcing.d0[c] + a - b
        fstate.delta[c] = d
        fstate.spring[c] = contact_force(law, d, forcing.k[c], forcing.n[c])
        fstate.phi[c] = dashpot_primitive(law, features.damping, d, forcing.k[c], forcing.n[c],
                                          forcing.coefficient[c])
    end_forces(features, state, forcing, fstate, t)
