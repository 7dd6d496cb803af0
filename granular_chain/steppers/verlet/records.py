"""The records the Verlet kernels take: features, chain, step, state, call, event log.

Each is a ``NamedTuple`` of numpy arrays and numbers, which numba passes to a
compiled function as one argument with named fields. :class:`Features` holds
the compile-time codes: the driver compiles each kernel with those fields as
literal constants (:func:`granular_chain._compile.specialised`), so the code
of absent features is never generated.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["Features", "Chain", "Timestep", "State", "Call", "EventBuffers",
           "PER_GRANULE", "UNIFORM", "UNIT", "STOP_ON_SEPARATION", "STOP_ON_REST"]

# Values of Features.uniform.
PER_GRANULE = 0
UNIFORM = 1  #: one value of each parameter, read once as a scalar
UNIT = 2  #: uniform with m = 1, k = 1, d0 = 0 (the scaled touching chain): constants

# Bits of Features.stop_mode.
STOP_ON_SEPARATION = 1
STOP_ON_REST = 2


class Features(NamedTuple):
    """Compile-time codes of a kernel specialisation (integers).

    Attributes
    ----------
    law : int
        Contact law (:mod:`granular_chain.laws.contact`: LAW_LINEAR, LAW_HERTZ, LAW_POWER).
    coulomb, viscous, left_wall, right_wall : int
        1 where the scene has that friction or wall.
    stop_mode : int
        STOP_ON_SEPARATION (the opening of ``Call.stop_contact``) | STOP_ON_REST.
    uniform : int
        PER_GRANULE, UNIFORM (every granule the same m, E, P1, P2 and every
        contact the same d0, k, n: the sweep reads granule 0's values and the
        table's row 1 once) or UNIT
        (moreover m = k = 1, d0 = 0, compiled in as constants). The blocked
        passes ignore it.
    log_events : int
        1 to log every event into :class:`EventBuffers`; 0 compiles no log code.
    """

    law: int
    coulomb: int
    viscous: int
    left_wall: int
    right_wall: int
    stop_mode: int
    uniform: int
    log_events: int


class Chain(NamedTuple):
    """The chain's constants (see :class:`granular_chain.model.Model`), read only.

    Attributes
    ----------
    d0, k, n : ndarray, shape (N+1,)
        Initial overlap (length), force coefficient (force / length^(n-1)) and
        exponent (dimensionless) of each contact: the columns of the contact table
        (:class:`granular_chain.contact_table.ContactTable`), row 0 the left wall,
        row j the contact between granules j-1 and j, row N the right wall (zeros
        where absent), units of the model.
    mass, inv_mass, eta, eta_static : ndarray, shape (N,)
        Mass, 1/mass, kinetic friction force, static friction threshold (force),
        units of the model.
    olim : ndarray, shape (N + 1,)
        Overlaps at which centres meet: the left wall's granule radius,
        r_i + r_(i+1) for each contact, the right wall's granule radius (length).
    fcap : float
        The smallest contact force at which some contact reaches its olim: only
        a step with a contact force reaching it checks the overlaps themselves
        (units of force of the model).
    """

    d0: np.ndarray
    k: np.ndarray
    n: np.ndarray
    mass: np.ndarray
    inv_mass: np.ndarray
    eta: np.ndarray
    eta_static: np.ndarray
    olim: np.ndarray
    fcap: float


class Timestep(NamedTuple):
    """The step and its drag tables (c = gamma/m per granule).

    Attributes
    ----------
    dt : float
        Step (time unit of the model).
    E, P1, P2 : ndarray, shape (N,)
        exp(-c dt) (dimensionless), phi1(c, dt) (time), phi2(c, dt) (time^2)
        (:func:`granular_chain.laws.friction.drift_tables`).
    """

    dt: float
    E: np.ndarray
    P1: np.ndarray
    P2: np.ndarray


class State(NamedTuple):
    """What the kernels advance, in place.

    Attributes
    ----------
    u, v, f : ndarray, shape (N,)
        Displacements, velocities, net spring forces (f consistent with u), units
        of the model. With
        Coulomb friction (merged kicks) v holds between calls the half-step
        velocities of the last kick (:func:`.kernel.synchronise`).
    active : ndarray of uint8, shape (max(N-1, 1),)
        1 where a contact is closed (delta > 0); kept by the blocked passes only.
    ledger : ndarray, shape (2,)
        Energy dissipated so far by Coulomb and by viscous friction (>= 0), units
        of energy of the model.
    counts : ndarray of int64, shape (4,)
        Events so far, indexed by :class:`granular_chain.codes.EventKind`.
    """

    u: np.ndarray
    v: np.ndarray
    f: np.ndarray
    active: np.ndarray
    ledger: np.ndarray
    counts: np.ndarray


class Call(NamedTuple):
    """What one kernel call is asked to do.

    Attributes
    ----------
    n_steps : int
        Steps to take at most.
    opening : int
        1 on the run's first call (and after the short last step's restart): v
        holds synchronised velocities, so a Coulomb run opens with a kick of dt/2.
    stop_contact : int
        The contact whose opening ends the run (STOP_ON_SEPARATION).
    """

    n_steps: int
    opening: int
    stop_contact: int


class EventBuffers(NamedTuple):
    """The kernel's event log: entry j is (step[j], kind[j], index[j]) for j < fill[0].

    ``step`` counts the steps of the call (1 = its first) at whose end the change
    was seen, ``kind`` is a :class:`granular_chain.codes.EventKind`, ``index`` the
    contact (-1 left wall, N-1 right wall) or the granule.
    """

    step: np.ndarray
    kind: np.ndarray
    index: np.ndarray
    fill: np.ndarray
