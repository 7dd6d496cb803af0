"""The chain's contacts in one table, the walls included: contacts 0..N.

A chain of N granules has N + 1 places where a contact can act::

    wall | g_0 | g_1 | ... | g_(N-1) | wall
       0     1     2   ...   N-1       N        <- contact index j

Contact j (1 <= j <= N-1) joins granules j-1 and j; contact 0 is the left wall
on granule 0 and contact N the right wall on granule N-1, present only when the
scene has that wall. One row per contact holds what the contact laws read
(:mod:`granular_chain.laws.contact`, :mod:`granular_chain.laws.damping`): the
initial overlap, the force coefficient, the exponent and the dashpot
coefficient; the walls' prescribed motion sits beside them. The Model holds one
table (``model.contacts``); the steppers' records, the scaling to internal units
and the writers read it, so that a wall is a contact everywhere and no code
gathers the walls back out of a separate array.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["ContactTable", "LEFT_WALL"]

#: Index of the left wall's contact (the right wall's is N, the granule count).
LEFT_WALL = 0


@dataclass(frozen=True, eq=False)
class ContactTable:
    """Contacts 0..N of a chain of N granules (walls at 0 and N), scene units.

    Rows of absent walls hold zeros, but for ``damping`` when the scene gives the
    coefficient itself (not a restitution): every row holds it there, unused where
    no contact is.

    Attributes
    ----------
    present : ndarray of int8, shape (N+1,)
        1 where a contact exists: every neighbour contact 1..N-1, and 0 or N when
        the scene has that wall.
    d0 : ndarray, shape (N+1,)
        Initial overlap (negative: an open gap; a wall's is minus its gap), length.
    k : ndarray, shape (N+1,)
        Force coefficient of F = k delta^(n-1), force / length^(n-1).
    n : ndarray, shape (N+1,)
        Potential exponent, dimensionless.
    damping : ndarray, shape (N+1,)
        Dashpot coefficient: c (force / speed) or A (time) by the Model's
        ``features.damping``; zeros when undamped.
    wall_motion : ndarray, shape (2, 3)
        (kind, p1, p2) of the left and right wall
        (:mod:`granular_chain.laws.wall_motion`; zeros: fixed).
    """

    present: np.ndarray
    d0: np.ndarray
    k: np.ndarray
    n: np.ndarray
    damping: np.ndarray
    wall_motion: np.ndarray

    @property
    def count(self) -> int:
        """Number of granules N (the table has N + 1 rows)."""
        return self.present.size - 1

    @property
    def has_walls(self) -> tuple[bool, bool]:
        """Whether the left and the right wall are present."""
        return bool(self.present[LEFT_WALL]), bool(self.present[self.count])

    def between_granules(self, column: np.ndarray) -> np.ndarray:
        """The rows of the neighbour contacts 1..N-1 of a column.

        Parameters
        ----------
        column : numpy.ndarray
            Shape (N+1,): one of the table's columns.

        Returns
        -------
        numpy.ndarray
            Shape (N-1,): a view of rows 1..N-1.
        """
        return column[1:self.count]

    def wall_triples(self) -> np.ndarray:
        """The walls' rows in the layout the Verlet kernels and
        :mod:`granular_chain.forces` take.

        Returns
        -------
        numpy.ndarray
            Shape (6,): (d0, k, n) of the left then the right wall, zeros where absent.
        """
        N = self.count
        return np.array([self.d0[0], self.k[0], self.n[0], self.d0[N], self.k[N], self.n[N]])

    def rows(self) -> np.ndarray:
        """The contacts present, in the order of the scene's fields.

        Returns
        -------
        numpy.ndarray of int64
            Their indices: the neighbour contacts 1..N-1, then the left wall (0),
            then the right wall (N), each wall if present.
        """
        N = self.count
        order = [*range(1, N), *(j for j in (LEFT_WALL, N) if self.present[j])]
        return np.array(order, dtype=np.int64)

    def reduced_mass(self, mass: np.ndarray) -> np.ndarray:
        """Reduced mass of each contact, shape (N+1,): m_(j-1) m_j / (m_(j-1) + m_j)
        between granules, the end granule's mass at a wall (a wall is an infinite mass).

        Parameters
        ----------
        mass : numpy.ndarray
            Shape (N,): the granules' masses.

        Returns
        -------
        numpy.ndarray
            Shape (N+1,), units of mass.
        """
        mu = np.empty(self.count + 1)
        mu[1:self.count] = mass[:-1] * mass[1:] / (mass[:-1] + mass[1:])
        mu[0], mu[self.count] = mass[0], mass[-1]
        return mu

    def field_of(self, j: int) -> str:
        """The scene field that sets a contact's stiffness (for messages).

        Parameters
        ----------
        j : int
            Contact index, 0..N.

        Returns
        -------
        str
            ``walls.left.stiffness``, ``walls.right.stiffness`` or ``contacts.stiffness``.
        """
        if j == LEFT_WALL:
            return "walls.left.stiffness"
        return "walls.right.stiffness" if j == self.count else "contacts.stiffness"


def contact_table(d0, k, n, walls: np.ndarray, left: bool, right: bool,
                  wall_motion=None) -> ContactTable:
    """The table of a chain from its neighbour contacts and its walls, undamped (the
    Model's builder sets ``damping``, solved from these rows, with
    ``dataclasses.replace``).

    Parameters
    ----------
    d0, k, n : numpy.ndarray
        Shape (N-1,): initial overlap, force coefficient and exponent of the
        neighbour contacts.
    walls : numpy.ndarray
        Shape (6,): (d0, k, n) of the left then the right wall (zeros if absent).
    left, right : bool
        Walls present.
    wall_motion : numpy.ndarray, optional
        Shape (2, 3): (kind, p1, p2) of the walls (zeros: fixed).

    Returns
    -------
    ContactTable
    """
    N = np.asarray(d0).size + 1
    present = np.zeros(N + 1, dtype=np.int8)
    present[1:N] = 1
    present[0], present[N] = int(left), int(right)
    columns = []
    for inner, wall in ((d0, walls[0::3]), (k, walls[1::3]), (n, walls[2::3])):
        col = np.zeros(N + 1)
        col[1:N] = inner
        col[0], col[N] = wall[0], wall[1]
        columns.append(col)
    motion = np.zeros((2, 3)) if wall_motion is None else np.ascontiguousarray(
        wall_motion, dtype=np.float64).reshape(2, 3)
    return ContactTable(present, *columns, damping=np.zeros(N + 1), wall_motion=motion)
