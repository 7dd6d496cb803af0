"""Prescribed wall motion: a wall displaced by ``s(t)`` from its initial place.

Kinds (``motion[0]`` of a wall; parameters ``p1 = motion[1]``, ``p2 = motion[2]``)::

    WALL_FIXED      s = 0
    WALL_VELOCITY   s = p1 t                          constant velocity p1
    WALL_SINE       s = p1 sin(2 pi p2 t)             amplitude p1, frequency p2
    WALL_PULSE      s = p1 min(t, p2)                 a piston at velocity p1 for a time p2, then still

Displacements are along +x for both walls. The wall's contact overlaps are
``delta_L = d0_L + s_L - u_0`` and ``delta_R = d0_R + u_(N-1) - s_R``; the power
a wall gives the chain is ``F_L s_L'`` (left) and ``-F_R s_R'`` (right) with
``F >= 0`` the contact's push, and its time integral is the ledger's
``wall_work``.
"""

import math

import numba

WALL_FIXED = 0
WALL_VELOCITY = 1
WALL_SINE = 2
WALL_PULSE = 3

__all__ = ["WALL_FIXED", "WALL_VELOCITY", "WALL_SINE", "WALL_PULSE", "wall_displacement",
           "wall_speed"]


@numba.njit(inline="always", cache=True)
def wall_displacement(kind, p1, p2, t):
    """Displacement s(t) of a wall (length) at time t.

    Parameters
    ----------
    kind : int
        WALL_FIXED, WALL_VELOCITY, WALL_SINE or WALL_PULSE.
    p1, p2 : float
        The kind's parameters (see the module docstring).
    t : float
        Time since the run's start (time units).

    Returns
    -------
    float
        s(t), scene units of length.
    """
    if kind == WALL_VELOCITY:
        return p1 * t
    if kind == WALL_SINE:
        return p1 * math.sin(2.0 * math.pi * p2 * t)
    if kind == WALL_PULSE:
        return p1 * min(t, p2)
    return 0.0


@numba.njit(inline="always", cache=True)
def wall_speed(kind, p1, p2, t):
    """Velocity s'(t) of a wall (length/time); a pulse's velocity is p1 for t < p2, else 0.

    Parameters
    ----------
    kind : int
        WALL_FIXED, WALL_VELOCITY, WALL_SINE or WALL_PULSE.
    p1, p2 : float
        The kind's parameters (see the module docstring), scene units.
    t : float
        Time since the run's start, scene units of time.

    Returns
    -------
    float
        s'(t), scene units of speed.
    """
    if kind == WALL_VELOCITY:
        return p1
    if kind == WALL_SINE:
        w = 2.0 * math.pi * p2
        return p1 * w * math.cos(w * t)
    if kind == WALL_PULSE:
        return p1 if t < p2 else 0.0
    return 0.0
