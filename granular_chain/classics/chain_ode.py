"""An independent integration of a chain: scipy's DOP853 at tight tolerance.

The reference the engine's steppers are checked against where the literature
gives no number to the digits needed. Granule ``i`` (mass ``m_i``) at ``x_i``
with velocity ``v_i``; contact ``i`` joins granules ``i`` and ``i+1`` with overlap
``delta_i = (r_i + r_{i+1}) - (x_{i+1} - x_i)`` and force ``k_i max(delta_i, 0)^(n-1)``::

    m_i x_i'' = F_{i-1} - F_i,    F_i = k_i max(delta_i, 0)^(n-1)           (1)

and, on a granule with Coulomb friction ``eta_i`` (kinetic and static alike),

    m_i x_i'' = F_{i-1} - F_i - eta_i sign(v_i)        while it slides,       (2)

held at rest while ``|F_{i-1} - F_i| <= eta_i``; written here once more, in numpy,
apart from the engine's laws and kernels, and integrated by :func:`scipy.integrate.solve_ivp` (``DOP853``, an explicit
Runge-Kutta method of order 8 with error control). The force has a kink of
order ``n - 1`` where a contact opens or closes and friction jumps where a granule
stops or starts to slide; every piece between two such events is integrated
apart, and the reference's own error is measured by running it again at a
tolerance ten times tighter (:func:`reference_error`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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
    t_samples : ndarray, shape (S,), optional
        The sample times asked for (``t_eval``), those reached.
    v_samples : ndarray, shape (S, N), optional
        Velocities at them (DOP853's dense output, of the method's order).
    """

    t_end: float
    x: np.ndarray
    v: np.ndarray
    overlaps: np.ndarray
    evaluations: int
    rtol: float
    t_samples: np.ndarray | None = None
    v_samples: np.ndarray | None = None


def integrate_chain(mass, x0, v0, reach, k=1.0, n=2.5, t_end=10.0,
                    rtol=1e-13, eta=0.0, stop_contact=None, t_eval=None) -> ChainSolution:
    """Integrate eq. (1), with eq. (2) where ``eta`` is set, from ``(x0, v0)`` with DOP853.

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
    eta : float or array_like, shape (N,)
        Coulomb friction force on each granule, eq. (2), kinetic and static alike.
    stop_contact : int, optional
        End at the first opening of this contact instead of at ``t_end``.
    t_eval : array_like, shape (S,), optional
        Increasing times at which to sample the velocities (as frames).

    Returns
    -------
    ChainSolution

    Raises
    ------
    RuntimeError
        DOP853 failed (its message).
    """
    from scipy.integrate import solve_ivp
    chain = _Chain(np.asarray(mass, float), np.asarray(reach, float),
                   np.broadcast_to(np.asarray(k, float), len(mass) - 1), float(n),
                   np.broadcast_to(np.asarray(eta, float), len(mass)))
    y = np.concatenate([np.asarray(x0, float), np.asarray(v0, float)])
    t, evaluations, fired, released = 0.0, 0, set(), set()
    samples = _Samples(t_eval, t_end, chain.count)
    while t < t_end:
        # restarted at every contact's opening and closing and every change of a
        # granule's sliding: each piece is smooth inside, so the error control never
        # steps across a kink of the force
        slide = chain.sliding(y, released)
        events = chain.events(t, y, slide, fired)
        ahead = samples.ahead(t)
        sol = solve_ivp(chain.rhs(slide), (t, t_end), y, method="DOP853", rtol=rtol,
                        atol=rtol, first_step=FIRST_STEP, events=events,
                        dense_output=ahead is not None)
        if not sol.success:
            raise RuntimeError(f"DOP853: {sol.message}")
        evaluations += int(sol.nfev)
        t, y = float(sol.t[-1]), sol.y[:, -1].copy()
        samples.take(sol, ahead, t)
        fired = {i for i, hit in enumerate(sol.t_events) if hit.size}
        if stop_contact is not None and stop_contact in fired \
                and y[chain.count + stop_contact] < y[chain.count + stop_contact + 1]:
            break  # the watched contact opened (its overlap falls through zero)
        released = set()
        for g in (chain.granule_of(i) for i in fired - set(range(chain.count - 1))):
            if slide[g] == 0.0:
                released.add(g)  # a held granule's force reached the friction: it slips
            else:
                y[chain.count + g] = 0.0  # a sliding granule came to rest
    return ChainSolution(t_end=t, x=y[:chain.count], v=y[chain.count:],
                         overlaps=chain.reach - np.diff(y[:chain.count]),
                         evaluations=evaluations, rtol=rtol, **samples.result())


class _Samples:
    """Velocities sampled at times asked for (``t_eval``), piece by piece, from DOP853's
    dense output."""

    def __init__(self, t_eval, t_end: float, count: int):
        self.wanted = None if t_eval is None else np.asarray(t_eval, float)
        self.t_end, self.count, self.t, self.v = t_end, count, [], []

    def ahead(self, t: float):
        """The sample times of a piece starting at ``t`` (those up to its end, at most
        ``t_end``), or None when no samples are asked for."""
        if self.wanted is None:
            return None
        after = (self.wanted >= t) if t == 0.0 else (self.wanted > t)
        return self.wanted[after & (self.wanted <= self.t_end)]

    def take(self, sol, ahead, t: float) -> None:
        """Keep the samples of the piece ``sol`` that ended at ``t``."""
        if ahead is None:
            return
        ahead = ahead[ahead <= t]
        self.t.append(ahead)
        self.v.append(sol.sol(ahead)[self.count:].T if ahead.size else
                      np.empty((0, self.count)))

    def result(self) -> dict:
        """``t_samples`` and ``v_samples`` for ChainSolution (empty without samples)."""
        if self.wanted is None:
            return {}
        return {"t_samples": np.concatenate(self.t), "v_samples": np.concatenate(self.v)}


@dataclass(frozen=True)
class _Chain:
    """The chain's constants, and the right-hand side and events of one smooth piece."""

    m: np.ndarray
    reach: np.ndarray
    k: np.ndarray
    n: float
    eta: np.ndarray

    @property
    def count(self) -> int:
        """Granules in the chain."""
        return self.m.size

    @property
    def frictional(self) -> np.ndarray:
        """Indices of the granules with friction (each has one event, after the contacts')."""
        return np.flatnonzero(self.eta > 0.0)

    def granule_of(self, event: int) -> int:
        """The granule whose friction event has index ``event`` in the event list."""
        return int(self.frictional[event - (self.count - 1)])

    def contact_force(self, y: np.ndarray) -> np.ndarray:
        """Net contact force on each granule, eq. (1), shape (N,)."""
        force = self.k * np.maximum(self.reach - np.diff(y[:self.count]), 0.0) ** (self.n - 1.0)
        net = np.zeros(self.count)
        net[:-1] -= force
        net[1:] += force
        return net

    def sliding(self, y: np.ndarray, released=()) -> np.ndarray:
        """Each granule's sliding direction for the next piece (eq. (2)): the sign of
        its velocity; at rest, the sign of the net force if that exceeds the friction
        (or the granule is in ``released``, whose force has just reached it), else 0
        (held). Frictionless granules: 2 (free)."""
        v, net = y[self.count:], self.contact_force(y)
        pushed = np.where(np.abs(net) > self.eta, np.sign(net), 0.0)
        pushed[list(released)] = np.sign(net[list(released)])
        return np.where(self.eta > 0.0, np.where(v != 0.0, np.sign(v), pushed), 2.0)

    def rhs(self, slide: np.ndarray):
        """The piece's right-hand side: contact forces, friction against ``slide``,
        held granules kept at rest."""
        friction = np.where(np.abs(slide) == 1.0, -self.eta * slide, 0.0)
        held = slide == 0.0

        def rhs(_t, y):
            acc = (self.contact_force(y) + friction) / self.m
            acc[held] = 0.0
            return np.concatenate([y[self.count:], acc])

        return rhs

    def events(self, t0: float, y0: np.ndarray, slide: np.ndarray, fired: set) -> list:
        """The piece's terminal events: every contact's opening or closing, then, for
        each granule with friction, the end of its sliding (velocity through zero) or
        of its holding (net force reaching the friction)."""
        contacts = [_contact_event(i, self.reach[i], self.count, t0, y0, i in fired)
                    for i in range(self.count - 1)]
        return contacts + [self._friction_event(int(g), slide[g], t0) for g in self.frictional]

    def _friction_event(self, g: int, slide: float, t0: float):
        """Granule ``g``'s friction event for a piece starting at ``t0``."""
        def moving(t, y):
            # a granule that starts to slip from rest has v = 0 at t0: no crossing there
            return slide if t == t0 and y[self.count + g] == 0.0 else y[self.count + g]

        def held(_t, y):
            return abs(self.contact_force(y)[g]) - self.eta[g]

        event = held if slide == 0.0 else moving
        event.terminal = True
        return event


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
