"""Frames the kernel records: positions, velocities, net contact forces, the energy ledger."""

import numba

from ..._compile import callee, kernel
from ...laws.contact import contact_energy, contact_force
from ...laws.damping import damped_contact_force
from .modes import _rate


@callee(error_model="numpy", _nrt=False)
def record_frame(law, t, clock, model, state, frames, work_coulomb, work_viscous):
    """Append the frame of the current state at time ``t`` to ``frames`` (nothing when
    the last frame recorded is at ``t``: frame times increase strictly).

    Parameters
    ----------
    law : int
        Contact-law code (``laws.contact``), a compile-time constant.
    t : float
        Time of the frame, kernel units (units of the time scale B).
    clock : record of CLOCK_DTYPE
        The run's clock; its work totals are read and ``n_frames`` advanced.
    model : ChainArrays
        The chain's constants, kernel units, contacts (N + 1,), granules (N,).
    state : MotionState
        The state recorded (``u``, ``v``: (N,); ``overlap``: (N + 1,), kernel units).
    frames : FrameBuffers
        Buffers with room for row ``clock.n_frames``; ``x``, ``v``, ``f``
        (F, N), ``e`` (F, 7).
    work_coulomb, work_viscous : float
        Friction work (energy, kernel units) since the clock's totals -- a frame
        inside a step, before the step's work is added -- else 0.

    Notes
    -----
    Columns of ``frames.e``: kinetic, elastic, Coulomb, viscous, dashpot work,
    wall work, body work (sum_i f_i u_i).
    """
    k = clock.n_frames
    if k > 0 and frames.t[k - 1] == t:
        # One frame a time (the time is the frames' index: xarray selects by it). A
        # second batch of events at the same instant, or the end falling on a frame,
        # changes the state by roundoff at most (a stop sets a velocity of ~1e-38 to 0).
        return
    N = state.u.size
    u, v, overlap = state.u, state.v, state.overlap
    frames.t[k] = t
    ke = 0.0
    pe = 0.0
    for i in range(N):
        frames.x[k, i] = model.x0[i] + u[i]
        frames.v[k, i] = v[i]
        ke += 0.5 * model.mass[i] * v[i] * v[i]
        frames.f[k, i] = 0.0
    for j in range(N + 1):
        if model.present[j] == 0:
            continue
        if model.damping[j] != 0.0:
            # with a dashpot the elastic energy is that of closed contacts (a
            # non-tensile one opens at overlap > 0) and the force the total one
            if state.closed[j] == 0:
                continue
            c = damped_contact_force(law, model.dashpot[0], model.dashpot[1], overlap[j],
                                     _rate(state, j), model.stiffness[j], model.exponent[j],
                                     model.damping[j])
        else:
            c = contact_force(law, overlap[j], model.stiffness[j], model.exponent[j])
        pe += contact_energy(law, overlap[j], model.stiffness[j], model.exponent[j])
        if j >= 1:
            frames.f[k, j - 1] -= c
        if j < N:
            frames.f[k, j] += c
    frames.e[k, 0] = ke
    frames.e[k, 1] = pe
    frames.e[k, 2] = clock.work_coulomb + work_coulomb
    frames.e[k, 3] = clock.work_viscous + work_viscous
    frames.e[k, 4] = clock.work_contact
    frames.e[k, 5] = clock.work_wall
    body = 0.0
    for i in range(N):
        if model.body[i] != 0.0:
            body += model.body[i] * u[i]
    frames.e[k, 6] = body
    clock.n_frames = k + 1


@kernel(error_model="numpy", _nrt=False)
def record_final_frame(law, clock_array, model, state, frames):
    """A frame at the clock's time (driver: an interrupted run's last state); compiled
    for the run's law (its code a compile-time constant, as in the kernel)."""
    law = numba.literally(law)
    clock = clock_array[0]
    record_frame(law, clock.time, clock, model, state, frames, 0.0, 0.0)
