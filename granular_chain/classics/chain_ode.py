"""An independent integration of a frictionless chain: scipy's DOP853 at tight tolerance.

The reference the engine's steppers are checked against where the literature
gives no number to the digits needed. Granule ``i`` (mass ``m_i``) at ``x_i``
with velocity ``v_i``; contact ``i`` joins granules ``i`` and ``i+1`` with overlap
``delta_i = (r_i + r_{i+1}) - (x_{i+1} - x_i)`` and force ``k_i max(delta_i, 0)^(n-1)``::

    m_i x_i'' = F_{i-1} - F_i,    F_i = k_i max(delta_i, 0)^(n-1)           (1)

written here once more, in numpy, apart from the engine's laws and kernels, and
integrated by :func:`scipy.integrate.solve_ivp` (``DOP853``, an explicit
Runge-Kutta method of order 8 with error control). The force has a kink of
order ``n - 1`` where a contact opens or closes; the step-size control resolves
it, and the reference's own error is measured by running it again at a
tolerance ten times tighter (:func:`reference_error`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

__all__ = ["ChainSolution", "integrate_chain", "integrate_chain_at", "reference_error"]

#: DOP853's first step of each smooth piece, scene time units: a contact that has
#: just closed pushes as t^(n-1), which the starting-step guess (from the first
#: derivatives, zero there) overestimates.
FIRST_STEP = 1e-6


@dataclass(frozen=True)
class ChainSolution:
    """The state of a chain at ``t_end`` by eq. (1), integrated by DOP853.

    Attributes
    ----------
    t_end : float
        Time reached, scene units.
    x, v : ndarray, shape (N,)
        Positions and velocities at ``t_end``.
    overlaps : ndarray, shape (N-1,)
        Contact overlaps at ``t_end`` (positive: in contact).
    evaluations : int
        Right-hand-side evaluations DOP853 took.
    rtol : float
        The tolerance it ran at (relative and absolute).
    """

    t_end: float
    x: np.ndarray
    v: np.ndarray
    overlaps: np.ndarray
    evaluations: int
    rtol: float


def integrate_chain(mass, x0, v0, reach, k=1.0, n=2.5, t_end=10.0,
                    rtol=1e-13) -> ChainSolution:
    """Integrate eq. (1) from ``(x0, v0)`` to ``t_end`` with DOP853.

    Parameters
    ----------
    mass : array_like, shape (N,)
        Masses.
    x0, v0 : array_like, shape (N,)
        Initial centres and velocities.
    reach : array_like, shape (N-1,)
        ``r_i + r_{i+1}``: the centre distance at which contact ``i`` closes.
    k : float or array_like, shape (N-1,)
        Force coefficients.
    n : float
        Potential exponent (force ``k delta^(n-1)``).
    t_end : float
        End time.
    rtol : float
        DOP853's relative and absolute tolerance.

    Returns
    -------
    ChainSolution

    Raises
    ------
    RuntimeError
        DOP853 failed (its message).
    """
    m = np.asarray(mass, float)
    reach, k = np.asarray(reach, float), np.broadcast_to(np.asarray(k, float), m.size - 1)
    count = m.size

    def rhs(_t, y):
        delta = reach - np.diff(y[:count])
        force = k * np.maximum(delta, 0.0) ** (n - 1.0)
        acc = np.zeros(count)
        acc[:-1] -= force
        acc[1:] += force
        return np.concatenate([y[count:], acc / m])

    y = np.concatenate([np.asarray(x0, float), np.asarray(v0, float)])
    t, evaluations, fired = 0.0, 0, set()
    while t < t_end:
        # restarted at every contact's opening and closing: each piece is smooth
        # inside, so the error control never steps across a kink of the force
        sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=rtol, atol=rtol, first_step=FIRST_STEP,
                        events=[_contact_event(i, reach[i], count, t, y, i in fired)
                                for i in range(count - 1)])
        if not sol.success:
            raise RuntimeError(f"DOP853: {sol.message}")
        evaluations += int(sol.nfev)
        t, y = float(sol.t[-1]), sol.y[:, -1]
        fired = {i for i, hit in enumerate(sol.t_events) if hit.size}
    return ChainSolution(t_end=t, x=y[:count], v=y[count:],
                         overlaps=reach - np.diff(y[:count]), evaluations=evaluations,
                         rtol=rtol)


def _contact_event(i: int, reach: float, count: int, t0: float, y0: np.ndarray,
                   fired: bool):
    """solve_ivp's terminal event: contact ``i``'s overlap crosses zero. At the piece's
    start ``t0``, when this contact's event ended the piece before (``fired``: its
    overlap is zero there to roundoff), it reports the sign the overlap takes next,
    so that zero is not found again."""
    rate = y0[count + i] - y0[count + i + 1]  # d(delta_i)/dt at t0

    def event(t, y):
        if fired and t == t0:
            return rate if rate != 0.0 else 1.0
        delta = reach - (y[i + 1] - y[i])
        # touching granules not yet reached by the pulse keep an overlap of exactly
        # zero: counted as closed, the zero is no crossing
        return delta if delta != 0.0 else 1e-300

    event.terminal = True
    return event


def reference_error(solution: ChainSolution, tighter: ChainSolution) -> float:
    """The reference's own error: its largest velocity difference from a run at a
    tighter tolerance, relative to the largest speed.

    Parameters
    ----------
    solution, tighter : ChainSolution
        The same chain at ``rtol`` and at a tighter one.

    Returns
    -------
    float
        ``max |v - v_tight| / max |v_tight|`` (dimensionless).
    """
    return float(np.max(np.abs(solution.v - tighter.v)) / np.max(np.abs(tighter.v)))


def integrate_chain_at(mass, x0, v0, reach, times, k=1.0, n=2.5,
                       rtol=1e-13) -> list:
    """Integrate eq. (1) from ``(x0, v0)`` and return the state at each of ``times``.

    The integration is carried on from each time to the next (the equations are
    autonomous), so the states cost one run to the last time.

    Parameters
    ----------
    mass, x0, v0, reach, k, n, rtol
        As :func:`integrate_chain`.
    times : sequence of float
        Increasing times (scene units), the first >= 0.

    Returns
    -------
    list of ChainSolution
        One per time, ``t_end`` the time itself, ``evaluations`` counted from 0.
    """
    x, v = np.asarray(x0, float), np.asarray(v0, float)
    now, evaluations, out = 0.0, 0, []
    for t in times:
        if t > now:
            sol = integrate_chain(mass, x, v, reach, k=k, n=n, t_end=t - now, rtol=rtol)
            x, v, now = sol.x, sol.v, float(t)
            evaluations += sol.evaluations
        out.append(ChainSolution(t_end=float(t), x=x, v=v,
                                 overlaps=np.asarray(reach, float) - np.diff(x),
                                 evaluations=evaluations, rtol=rtol))
    return out
