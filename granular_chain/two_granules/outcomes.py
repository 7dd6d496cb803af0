"""How a two-granule collision ends: the outcome names, defined once.

:class:`Outcome` is the one list of outcome names (the engine's
:func:`~granular_chain.two_granules.collide`, its maps and boundaries, and the
paper's exact reference :func:`~granular_chain.paper.reference_collision_n2`
all name outcomes with it), and :data:`SEPARATION_SIGNS` the one rule that
names a collision ending in separation from the signs of the two velocities.
"""

from __future__ import annotations

import enum

import numpy as np

from .._compile import kernel
from ..codes import Status

__all__ = ["Outcome", "OUTCOMES", "SEPARATION_SIGNS", "outcome_of_signs", "outcome_code",
           "outcome_codes"]


class Outcome(enum.Enum):
    """How a two-granule collision ends (``.name`` is the public contract)."""

    backscatter_and_propagation = "granule 1 moves back and granule 2 forward"
    propagation_only = "granule 1 at rest, granule 2 moves forward"
    backscatter_only = "granule 1 moves back, granule 2 at rest"
    both_forward = "both granules move forward"
    stuck = "both granules held by static friction while still compressed: the collision never ends"
    no_separation = "overdamped: the overlap decays without ever reaching zero"


#: Outcome codes of :class:`~granular_chain.two_granules.CollisionMap`: code i is
#: ``OUTCOMES[i]`` (= ``list(Outcome)[i]``), -1 a failed run (see its status).
OUTCOMES = tuple(Outcome)

#: Signs (-1 backwards, 0 at rest, +1 forwards) of (v1, v2) when the contact opens,
#: for each outcome named at separation. Other sign pairs (a granule pushed
#: backwards by the spring cannot happen) are named ``stuck``.
SEPARATION_SIGNS = {
    Outcome.backscatter_and_propagation: (-1, 1),
    Outcome.propagation_only: (0, 1),
    Outcome.backscatter_only: (-1, 0),
    Outcome.both_forward: (1, 1),
    Outcome.stuck: (0, 0),
}
_OUTCOME_OF_SIGNS = {signs: outcome for outcome, signs in SEPARATION_SIGNS.items()}


def outcome_of_signs(sign1: int, sign2: int) -> Outcome:
    """The outcome of a collision that separated with velocities of these signs.

    Parameters
    ----------
    sign1, sign2 : int
        Signs (-1, 0, 1) of the velocities of granules 1 and 2 at separation.

    Returns
    -------
    Outcome
        ``stuck`` for a pair no separated outcome has.
    """
    return _OUTCOME_OF_SIGNS.get((sign1, sign2), Outcome.stuck)


# The same rule for compiled code: _CODE_OF_SIGNS[sign1 + 1, sign2 + 1] is the
# outcome's index into OUTCOMES.
_CODE_OF_SIGNS = np.full((3, 3), OUTCOMES.index(Outcome.stuck), dtype=np.int64)
for _outcome, (_s1, _s2) in SEPARATION_SIGNS.items():
    _CODE_OF_SIGNS[_s1 + 1, _s2 + 1] = OUTCOMES.index(_outcome)
_STUCK = OUTCOMES.index(Outcome.stuck)
_NO_SEPARATION = OUTCOMES.index(Outcome.no_separation)
_SEPARATED, _T_END, _AT_REST = int(Status.SEPARATED), int(Status.T_END), int(Status.AT_REST)


@kernel()
def _sign(v):
    return 1 if v > 0.0 else (-1 if v < 0.0 else 0)


@kernel()
def outcome_code(status, v1, v2, rest_tol):
    """Index into :data:`OUTCOMES` of a run that ended with ``status`` (a
    :class:`~granular_chain.codes.Status` value) and velocities ``v1``, ``v2``
    (scaled); -1 for a failed run. A granule is at rest when
    ``|v| <= rest_tol * max(|v1|, |v2|)``.

    Parameters
    ----------
    status : int
        :class:`~granular_chain.codes.Status` value of the run.
    v1, v2 : float
        Final velocities, units of ``v0``.
    rest_tol : float
        A granule is at rest when ``|v| <= rest_tol * max(|v1|, |v2|)`` (dimensionless).

    Returns
    -------
    int
        Index into :data:`OUTCOMES`, -1 for a failed run.
    """
    scale = max(abs(v1), abs(v2))
    r1 = 0.0 if abs(v1) <= rest_tol * scale else v1
    r2 = 0.0 if abs(v2) <= rest_tol * scale else v2
    if status == _SEPARATED:
        return _CODE_OF_SIGNS[_sign(r1) + 1, _sign(r2) + 1]
    if status == _T_END or status == _AT_REST:
        if r1 == 0.0 and r2 == 0.0 and status == _AT_REST:
            return _STUCK
        return _NO_SEPARATION
    return -1


@kernel()
def outcome_codes(status, velocities, rest_tol, out):
    """:func:`outcome_code` of M runs: ``status`` (M,), ``velocities`` (M, 2); into ``out`` (M,).

    Parameters
    ----------
    status : ndarray of int, shape (M,)
        Status values of the runs.
    velocities : ndarray, shape (M, 2)
        Final velocities, units of ``v0``.
    rest_tol : float
        A granule is at rest when ``|v| <= rest_tol * max(|v1|, |v2|)`` (dimensionless).
    out : ndarray of int8, shape (M,)
        Filled with the outcome codes.
    """
    for p in range(status.size):
        out[p] = outcome_code(status[p], velocities[p, 0], velocities[p, 1], rest_tol)
