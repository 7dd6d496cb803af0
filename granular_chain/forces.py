"""The one neighbour loop: net spring force on every granule from the laws present.

Contacts are only between neighbours i, i+1 (granules never pass each other),
and optionally between the end granules and fixed walls. The loop is written
once; the contact law and the wall branches are compile-time constants of the
caller's specialisation, so a scene without walls compiles no wall code and
n = 5/2 compiles ``d*sqrt(d)``.

Every function here reads the contacts as the columns ``d0, k, n`` of the
contact table (:class:`granular_chain.contact_table.ContactTable`), shape
(N+1,): row 0 the left wall, row j (1 <= j <= N-1) the contact between
granules j-1 and j, row N the right wall. Overlaps are formed from
displacements (see :mod:`granular_chain.model`)::

    delta_j = d0_j + u_(j-1) - u_j          contact j, between j-1 and j
    delta_L = d0_0 - u_0                    left wall (row 0)
    delta_R = d0_N + u_(N-1)                right wall (row N)
"""

import numba

from ._compile import kernel
from .laws.contact import contact_energy, contact_force


@numba.njit(inline="always", cache=True)
def contact_overlap(d0, u_left, u_right):
    """delta = d0 + u_i - u_(i+1) of a contact of initial overlap d0 between
    granules displaced by u_left and u_right (evaluated left to right)."""
    return d0 + u_left - u_right


@numba.njit(inline="always", cache=True)
def contact_forces(law, u, d0, k, n, c):
    """Fill rows 1..N-1 of ``c`` (N+1,) with the compressive force of every contact
    between granules (>= 0; row j between granules j-1 and j).

    A loop with no loop-carried value: it vectorises.
    """
    for i in range(u.size - 1):
        c[i + 1] = contact_force(law, contact_overlap(d0[i + 1], u[i], u[i + 1]), k[i + 1],
                                 n[i + 1])


@numba.njit(inline="always", cache=True)
def net_force(left, right):
    """Net force of its two contacts on a granule, positive to the right: the push
    ``left`` of the contact on its left less the push ``right`` of the one on its right
    (force units; 0 for a wall that is absent). Every Verlet kernel forms the net force
    here: the sweep from the two forces it keeps in registers, the others through
    :func:`net_contact_force`."""
    return left - right


@numba.njit(inline="always", cache=True)
def net_contact_force(c, i):
    """Net force of the contacts on granule i from the contact forces ``c`` (N+1,) in the
    table's rows: :func:`net_force` of row i (its left contact) and row i+1 (its right)."""
    return net_force(c[i], c[i + 1])


@numba.njit(inline="always", cache=True)
def left_wall_overlap(d0_left, u_first):
    """delta_L = d0_L - u_0 of the left wall's contact (d0_L: table row 0's d0)."""
    return d0_left - u_first


@numba.njit(inline="always", cache=True)
def right_wall_overlap(d0_right, u_last):
    """delta_R = d0_R + u_(N-1) of the right wall's contact (d0_R: table row N's d0)."""
    return d0_right + u_last


@numba.njit(inline="always", cache=True)
def left_wall_force(law, d0, k, n, u_first):
    """Force of the left wall (table row 0) on granule 0 (to the right, >= 0), granule 0
    displaced by u_first; ``d0, k, n`` the table's columns (N+1,)."""
    return contact_force(law, left_wall_overlap(d0[0], u_first), k[0], n[0])


@numba.njit(inline="always", cache=True)
def right_wall_force(law, d0, k, n, u_last):
    """Force of the right wall (table row N) on granule N-1 (to the left, >= 0),
    displaced by u_last; ``d0, k, n`` the table's columns (N+1,)."""
    N = d0.size - 1
    return contact_force(law, right_wall_overlap(d0[N], u_last), k[N], n[N])


@numba.njit(inline="always", cache=True)
def wall_forces(law, left_wall, right_wall, u, d0, k, n):
    """Forces of the walls on granule 0 (to the right) and granule N-1 (to the left, >= 0).

    Parameters
    ----------
    law, left_wall, right_wall : int
        Compile-time feature codes (contact law; 1 when that wall is present).
    u : numpy.ndarray
        Shape (N,): displacements from the initial positions, scene units of length.
    d0, k, n : numpy.ndarray
        Shape (N+1,) each: the contact table's columns (rows 0 and N the walls).

    Returns
    -------
    tuple of float
        ``(fl, fr)``: push of the left wall on granule 0 and of the right wall on
        granule N-1 (each >= 0, 0 without that wall), scene units of force.
    """
    fl = 0.0
    fr = 0.0
    if left_wall:
        fl = left_wall_force(law, d0, k, n, u[0])
    if right_wall:
        fr = right_wall_force(law, d0, k, n, u[u.size - 1])
    return fl, fr


@numba.njit(inline="always", cache=True)
def spring_forces(law, left_wall, right_wall, u, d0, k, n, c, f):
    """Fill the contact forces ``c`` (N+1,, the table's rows) and the net spring forces
    ``f`` (N,).

    Parameters
    ----------
    law, left_wall, right_wall : int
        Compile-time feature codes.
    u : ndarray, shape (N,)
        Displacements from the initial positions, scene units of length.
    d0, k, n : numpy.ndarray
        Shape (N+1,) each: initial overlaps (length), force coefficients
        (force / length^(n-1)) and exponents (dimensionless) of the contacts, the
        contact table's columns (rows 0 and N the walls), scene units.
    c : ndarray, shape (N+1,)
        Output: compressive force of each contact (>= 0) in the table's rows, the
        walls' in rows 0 and N (0 without that wall), scene units of force.
    f : ndarray, shape (N,)
        Output: net spring force on each granule (positive to the right),
        scene units of force.
    """
    N = u.size
    contact_forces(law, u, d0, k, n, c)
    c[0], c[N] = wall_forces(law, left_wall, right_wall, u, d0, k, n)
    for i in range(N):
        f[i] = net_contact_force(c, i)


@numba.njit(inline="always", cache=True)
def potential_energy(law, left_wall, right_wall, u, d0, k, n):
    """Total elastic energy stored in the contacts and walls (sum of V(delta)).

    Parameters
    ----------
    law, left_wall, right_wall : int
        Compile-time feature codes (contact law; 1 when that wall is present).
    u : numpy.ndarray
        Shape (N,): displacements from the initial positions, scene units of length.
    d0, k, n : numpy.ndarray
        Shape (N+1,) each: initial overlaps (length), force coefficients
        (force / length^(n-1)) and exponents (dimensionless) of the contacts, the
        contact table's columns (rows 0 and N the walls), scene units.

    Returns
    -------
    float
        Sum of V(delta) over contacts and walls, scene units of energy.
    """
    N = u.size
    e = 0.0
    for i in range(N - 1):
        d = contact_overlap(d0[i + 1], u[i], u[i + 1])
        if d > 0.0:  # an open contact stores nothing (adding its +0.0 would change no bit)
            e += contact_energy(law, d, k[i + 1], n[i + 1])
    if left_wall:
        e += contact_energy(law, left_wall_overlap(d0[0], u[0]), k[0], n[0])
    if right_wall:
        e += contact_energy(law, right_wall_overlap(d0[N], u[N - 1]), k[N], n[N])
    return e


@kernel()
def total_potential(law, left_wall, right_wall, u, d0, k, n):
    """Compiled entry point for :func:`potential_energy` (called at output frames).

    Parameters
    ----------
    law, left_wall, right_wall : int
        Compile-time feature codes (contact law; 1 when that wall is present).
    u : numpy.ndarray
        Shape (N,): displacements from the initial positions, scene units of length.
    d0, k, n : numpy.ndarray
        Shape (N+1,) each: initial overlaps (length), force coefficients
        (force / length^(n-1)) and exponents (dimensionless) of the contacts, the
        contact table's columns (rows 0 and N the walls), scene units.

    Returns
    -------
    float
        Sum of V(delta) over contacts and walls, scene units of energy.
    """
    law = numba.literally(law)
    left_wall = numba.literally(left_wall)
    right_wall = numba.literally(right_wall)
    return potential_energy(law, left_wall, right_wall, u, d0, k, n)


@kernel()
def net_forces(law, left_wall, right_wall, u, d0, k, n, c, f):
    """Compiled entry point for :func:`spring_forces` (initial forces, writers).

    Parameters
    ----------
    law, left_wall, right_wall : int
        Compile-time feature codes (contact law; 1 when that wall is present).
    u : numpy.ndarray
        Shape (N,): displacements from the initial positions, scene units of length.
    d0, k, n : numpy.ndarray
        Shape (N+1,) each: initial overlaps (length), force coefficients
        (force / length^(n-1)) and exponents (dimensionless) of the contacts, the
        contact table's columns (rows 0 and N the walls), scene units.
    c : numpy.ndarray
        Shape (N+1,), output: compressive force of each contact (>= 0) in the table's
        rows (0 for a wall that is absent), scene units.
    f : numpy.ndarray
        Shape (N,), output: net spring force on each granule (positive to the
        right), scene units of force.
    """
    law = numba.literally(law)
    left_wall = numba.literally(left_wall)
    right_wall = numba.literally(right_wall)
    spring_forces(law, left_wall, right_wall, u, d0, k, n, c, f)
