"""What the Verlet driver reads off the state at an output frame, in one compiled call
(:func:`scan_frame`), or in two when the frame is made on the writers' thread
(:func:`stash_state` on the stepping thread, then :func:`settle_frame`).

At a frame the driver needs the frame's arrays (x = x0 + u, v, f), whether the
state is finite, whether two centres have met or a granule has passed a wall
(the one-sided contact model then no longer describes the scene; the kernels
check it after every step, so the scan looks only when a call ended early), and
the kinetic and elastic energies of the ledger. Written with numpy these are about
a dozen passes over the N granules and as many temporary arrays, which on a
long chain cost as much as tens of steps. :func:`scan_frame` reads each array
once or twice in one compiled call, writes into arrays the frame log lends
(:meth:`granular_chain.frames.FrameLog.lend`) and allocates nothing. It keeps
the GIL: it lasts tens of microseconds, and letting the writers' thread take
the GIL meanwhile makes the stepping thread wait for it back at the end
(measured: streaming to trajectory.h5 about 2 % slower on a chain of 10^4
granules).

The energies are bit for bit those of :meth:`granular_chain.model.Model.energies`:
the same BLAS dot product for sum(m v^2)/2 and the same ordered sum of
:func:`granular_chain.forces.potential_energy`.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from ..._compile import kernel
from ...forces import contact_overlap, left_wall_overlap, potential_energy, right_wall_overlap

__all__ = ["ScanCodes", "FrameArrays", "Scan", "scan_frame", "stash_state", "settle_frame",
           "NO_PROBLEM", "CONTACT_PASSED",
           "LEFT_WALL_PASSED", "RIGHT_WALL_PASSED"]

# Values of Scan.problem.
NO_PROBLEM = 0
CONTACT_PASSED = 1  #: contact ``index``'s overlap reached r_i + r_(i+1): the centres met
LEFT_WALL_PASSED = 2  #: granule 0 overlaps the left wall by its radius or more
RIGHT_WALL_PASSED = 3  #: granule N-1 overlaps the right wall by its radius or more

# The exponent bits of a double: all set for infinities and NaN only.
_EXPONENT = np.int64(0x7FF0000000000000)


class ScanCodes(NamedTuple):
    """Compile-time codes of a scan: the contact law and the walls present (1/0)."""

    law: int
    left_wall: int
    right_wall: int


class FrameArrays(NamedTuple):
    """Where a scan writes the frame, each of shape (N,), units of the model.

    Attributes
    ----------
    x, v, f : ndarray
        Centre positions x0 + u, velocities, net spring forces.
    v2 : ndarray
        Work array: v^2, for the dot product with the masses.
    """

    x: np.ndarray
    v: np.ndarray
    f: np.ndarray
    v2: np.ndarray


class Scan(NamedTuple):
    """What a scan found (see :func:`scan_frame`).

    Attributes
    ----------
    nonfinite : int
        First granule whose u or v is NaN or infinite, -1 when none is.
    problem : int
        NO_PROBLEM, CONTACT_PASSED, LEFT_WALL_PASSED or RIGHT_WALL_PASSED (the first
        found, in that order of the chain: contacts left to right, then walls).
    index : int
        The contact (CONTACT_PASSED), else 0 or N-1 for a wall, -1 without a problem.
    overlap : float
        The overlap found at ``index`` (length).
    kinetic, potential : float
        sum(m v^2)/2 and the elastic energy of the contacts and walls (energy).
    """

    nonfinite: int
    problem: int
    index: int
    overlap: float
    kinetic: float
    potential: float


@kernel()
def scan_frame(codes, chain, d0, u, v, f, x0, out, reach):
    """Fill the frame's arrays from the state and check it, in one compiled call.

    Parameters
    ----------
    codes : ScanCodes
        Compile-time codes (literal fields).
    chain : granular_chain.steppers.verlet.records.Chain
        The chain's constants: k, n (N+1,, the contact table's columns), mass (N,),
        olim (N+1,) (the overlaps at which centres meet: left wall, contacts, right
        wall).
    d0 : ndarray, shape (N+1,)
        The contact table's initial overlaps with the walls (rows 0 and N) where
        they are now (a driven wall's displacement added to its d0).
    u, v, f : ndarray, shape (N,)
        Displacements, synchronised velocities and net spring forces.
    x0 : ndarray, shape (N,)
        Initial centre positions.
    out : FrameArrays
        Written: x = x0 + u, v, f, and v^2.
    reach : int
        1: look for centres that met and granules past a wall; 0: skip it (a
        kernel call that ended with Pause.CHUNK_DONE found none after any of its
        steps: every kernel checks after each step and pauses with Status.OVERLAP).

    Returns
    -------
    tuple
        The fields of :class:`Scan`.
    """
    law = numba.literally(codes.law)
    left_wall = numba.literally(codes.left_wall)
    right_wall = numba.literally(codes.right_wall)
    N = u.size
    ubits, vbits = u.view(np.int64), v.view(np.int64)
    nonfinite = 0
    # No branch: the loops vectorise. Three loops of two or three arrays each take
    # two thirds of the time of one loop over all eight (measured at N = 10^4).
    for i in range(N):
        out.x[i] = x0[i] + u[i]
        nonfinite |= (ubits[i] & _EXPONENT) == _EXPONENT
    for i in range(N):
        vi = v[i]
        out.v[i] = vi
        out.v2[i] = vi * vi
        nonfinite |= (vbits[i] & _EXPONENT) == _EXPONENT
    for i in range(N):
        out.f[i] = f[i]
    first = _first_nonfinite(u, v) if nonfinite else -1
    problem, index, overlap = NO_PROBLEM, -1, 0.0
    if reach:
        problem, index, overlap = _passed(left_wall, right_wall, chain, d0, u)
    kinetic, potential = _energies(law, left_wall, right_wall, chain, d0, u, out.v2)
    return first, problem, index, overlap, kinetic, potential


@kernel()
def stash_state(u, v, f, out):
    """Copy the state into a frame's arrays as it is: the part of a frame the
    stepping thread must make before it steps on (the rest is
    :func:`settle_frame`'s, on the writers' thread). Keeps the GIL: it lasts
    a few microseconds at N = 10^4, and a hand-over of the GIL would cost as much.

    Parameters
    ----------
    u, v, f : ndarray, shape (N,)
        Displacements, synchronised velocities and net spring forces.
    out : FrameArrays
        Written: x = u (not yet x0 + u), v and f; v2 is not used.
    """
    for i in range(u.size):
        out.x[i] = u[i]
    for i in range(u.size):
        out.v[i] = v[i]
    for i in range(u.size):
        out.f[i] = f[i]


@kernel(nogil=True)
def settle_frame(codes, chain, d0, x0, out):
    """Make a frame of a state :func:`stash_state` copied into ``out``: the first
    non-finite granule and the energies, as :func:`scan_frame` finds them, then
    x = x0 + u in place. Without the GIL (it runs on the writers' thread).

    Parameters
    ----------
    codes : ScanCodes
        Compile-time codes (literal fields).
    chain : granular_chain.steppers.verlet.records.Chain
        The chain's constants (k, n, mass).
    d0 : ndarray, shape (N+1,)
        The contact table's initial overlaps, rows 0 and N the walls (fixed: a
        scene with a driven wall has no writers' thread of this kind).
    x0 : ndarray, shape (N,)
        Initial centre positions.
    out : FrameArrays
        On entry x holds the displacements u, v and f the state's; on return x
        holds x0 + u, and v2 the squared velocities.

    Returns
    -------
    tuple
        (first non-finite granule or -1, kinetic, potential): the fields
        ``nonfinite``, ``kinetic`` and ``potential`` of :class:`Scan` (the
        kernel that stopped at this state found no other problem).
    """
    law = numba.literally(codes.law)
    left_wall = numba.literally(codes.left_wall)
    right_wall = numba.literally(codes.right_wall)
    u, v = out.x, out.v
    ubits, vbits = u.view(np.int64), v.view(np.int64)
    nonfinite = 0
    for i in range(u.size):
        nonfinite |= (ubits[i] & _EXPONENT) == _EXPONENT
    for i in range(u.size):
        vi = v[i]
        out.v2[i] = vi * vi
        nonfinite |= (vbits[i] & _EXPONENT) == _EXPONENT
    first = _first_nonfinite(u, v) if nonfinite else -1
    kinetic, potential = _energies(law, left_wall, right_wall, chain, d0, u, out.v2)
    for i in range(u.size):  # (u is out.x: each value read before it is replaced)
        out.x[i] = x0[i] + u[i]
    return first, kinetic, potential


@numba.njit(inline="always", cache=True)
def _first_nonfinite(u, v):
    """The first granule whose u or v is NaN or infinite, -1 when none is (the scans'
    branch-free loops only tell whether one is)."""
    for i in range(u.size):
        if not (np.isfinite(u[i]) and np.isfinite(v[i])):
            return i
    return -1


@numba.njit(inline="always", cache=True)
def _energies(law, left_wall, right_wall, chain, d0, u, v2):
    """(kinetic, potential): 0.5 m . v2 by the BLAS dot product and the ordered sum
    of the contacts' and walls' elastic energies, as Model.energies makes them
    (``d0``: the table's column with the walls where they are now)."""
    kinetic = 0.5 * np.dot(chain.mass, v2)
    potential = potential_energy(law, left_wall, right_wall, u, d0, chain.k, chain.n)
    return kinetic, potential


@numba.njit(inline="always", cache=True)
def _passed(left_wall, right_wall, chain, d0, u):
    """(problem, index, overlap): the first contact whose centres met, else a wall
    its granule has passed, else (NO_PROBLEM, -1, 0). ``d0``: the table's column
    with the walls where they are now (contact i, between granules i and i+1, is its
    row i+1, as olim's)."""
    N = u.size
    olim = chain.olim
    met = False
    for i in range(N - 1):  # whether any has, with no early exit: the loop vectorises
        met |= contact_overlap(d0[i + 1], u[i], u[i + 1]) >= olim[i + 1]
    if met:
        for i in range(N - 1):
            d = contact_overlap(d0[i + 1], u[i], u[i + 1])
            if d >= olim[i + 1]:
                return CONTACT_PASSED, i, d
    if left_wall:
        d = left_wall_overlap(d0[0], u[0])
        if d >= olim[0]:
            return LEFT_WALL_PASSED, 0, d
    if right_wall:
        d = right_wall_overlap(d0[N], u[N - 1])
        if d >= olim[N]:
            return RIGHT_WALL_PASSED, N - 1, d
    return NO_PROBLEM, -1, 0.0
