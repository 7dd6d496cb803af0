"""The driver's side of :mod:`.forced`: records, time step limits, energies.

A scene is *forced* when it has a dashpot, a body force or a moving wall
(``not model.features.elastic_and_fixed``); it then runs
:func:`.forced.forced_chunk`, and everything here applies. Elastic scenes never
reach this module.
"""

from __future__ import annotations

import math

import numpy as np

from ..._compile import specialised
from ...laws.damping import dashpot_rate
from ...laws.wall_motion import WALL_SINE, wall_displacement
from ...model import Model
from .forced import ForcedFeatures, ForcedState, Forcing, forced_start

__all__ = ["is_forced", "forced_records", "forced_dt_limit", "wall_positions",
           "walls_at", "body_work", "FORCED_STATE_ARRAYS"]

#: Steps per damping time m_eff/c of the fastest dashpot (default dt), and per
#: period of a sine-driven wall.
STEPS_PER_DAMPING_TIME = 40
STEPS_PER_WALL_PERIOD = 200

#: The ForcedState arrays a checkpoint keeps (the work arrays are rebuilt each step).
FORCED_STATE_ARRAYS = ("delta", "spring", "dashpot", "phi", "force", "work", "clock")


def is_forced(model: Model) -> bool:
    """Whether the scene needs the forced kernel (dashpot, body force or moving wall).

    Parameters
    ----------
    model : Model
        The compiled scene.

    Returns
    -------
    bool
        True unless the scene is elastic with fixed walls and no body force.
    """
    return not model.features.elastic_and_fixed


def forced_records(model: Model, state, stop_mode: int):
    """(ForcedFeatures, Forcing, ForcedState) of a model, the contact state set for
    (state.u, state.v) at t = 0 and state.f the net force (compiles the kernel's
    start function for these features).

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.
    state : State
        The kernel's state (:class:`.records.State`); ``state.f`` is set here.
    stop_mode : int
        The run's stop condition (the bits of :class:`.records.Features`' ``stop_mode``).

    Returns
    -------
    tuple
        ``(ForcedFeatures, Forcing, ForcedState)`` (:mod:`.forced`); arrays of
        the contacts with the walls are shape (N+1,), left wall first.
    """
    feat, N, t = model.features, model.count, model.contacts
    features = ForcedFeatures(law=int(feat.law), coulomb=int(feat.coulomb),
                              viscous=int(feat.viscous), damping=int(feat.damping))
    forcing = Forcing(
        d0=t.d0.copy(), k=t.k.copy(), n=t.n.copy(), coefficient=t.damping.copy(),
        body=np.ascontiguousarray(model.body_force, dtype=np.float64),
        motion=t.wall_motion.copy(),
        ends=np.array([0 if feat.left_wall else 1, N if feat.right_wall else N - 1],
                      dtype=np.int64),
        tensile=int(feat.tensile), stop_mode=int(stop_mode))
    fstate = ForcedState(*(np.zeros(N + 1) for _ in range(6)), np.zeros(N), np.zeros(2),
                         np.zeros(2), np.zeros(N + 1))
    args = (features, state, forcing, fstate, 0.0)
    specialised(forced_start, args, (0,))(*args)
    return features, forcing, fstate


def forced_dt_limit(model: Model) -> float:
    """Largest default step the forced features allow (inf when none limits it):
    1/40 of the fastest dashpot's time 1/:func:`dashpot_rate` (the dashpot's
    explicit part is unstable at 2 of them; at 1/40 the ledger's error from it is
    about 3e-4 of the energy a collision loses), and 200 steps per period of a
    sine-driven wall.

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.

    Returns
    -------
    float
        Largest step, scene units of time (``inf`` when nothing limits it).
    """
    limit = math.inf
    rate = dashpot_rate(model)
    if rate > 0:
        limit = 1.0 / (STEPS_PER_DAMPING_TIME * rate)
    for kind, _, frequency in model.wall_motion:
        if int(kind) == WALL_SINE:
            limit = min(limit, 1.0 / (STEPS_PER_WALL_PERIOD * frequency))
    return limit


def wall_positions(model: Model, t: float) -> tuple[float, float]:
    """(s_L, s_R): the walls' displacements at time t.

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.
    t : float
        Time since the run's start, scene units of time.

    Returns
    -------
    tuple of float
        ``(s_L, s_R)``, scene units of length.
    """
    return tuple(float(wall_displacement(int(k), p1, p2, t)) for k, p1, p2 in model.wall_motion)


def walls_at(model: Model, t: float, out: np.ndarray) -> np.ndarray:
    """The contact table's d0 column with the walls where they are at t: a driven
    wall's displacement enters its d0 (the table's own column when no wall is driven).

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.
    t : float
        Time, scene units of time.
    out : numpy.ndarray
        Shape (N+1,): a copy of ``model.contacts.d0``, whose wall rows (0 and N) are
        written here when a wall is driven (no array is made per frame).

    Returns
    -------
    numpy.ndarray
        Shape (N+1,): initial overlaps of the contacts, rows 0 and N the walls at t,
        scene units of length.
    """
    table = model.contacts
    if not model.features.driven:
        return table.d0
    s_left, s_right = wall_positions(model, t)
    out[0] = table.d0[0] + s_left  # delta_L = d0_L + s_L - u_0
    out[-1] = table.d0[-1] - s_right  # delta_R = d0_R + u_(N-1) - s_R
    return out


def body_work(model: Model, u) -> float:
    """Work done by the body forces since t = 0: sum_i f_i u_i (exact: they are constant).

    Parameters
    ----------
    model : Model
        The compiled scene, scene units.
    u : numpy.ndarray
        Shape (N,): displacements since t = 0, scene units of length.

    Returns
    -------
    float
        Work, scene units of energy.
    """
    return float(np.dot(model.body_force, u))
