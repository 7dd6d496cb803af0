"""The exact collision of two granules for ``n = 2``: the paper's independent reference.

For ``n = 2`` the contact force is linear, so within each stick/slip mode the
motion is linear with constant coefficients and the state is propagated with
the matrix exponential (mpmath, 30+ digits); mode switches (contact opening, a
sliding granule stopping, a stuck granule slipping) are located by sign change
and :func:`~granular_chain.paper.roots.bracket_root`. The engine is measured
against it. It shares nothing with the engine's code but the outcome names
(:class:`~granular_chain.two_granules.Outcome`).
"""
from __future__ import annotations

import math

import mpmath

from ..two_granules.outcomes import Outcome, outcome_of_signs
from .roots import bracket_root

__all__ = ["OUTCOMES", "reference_collision_n2", "reference_state_n2"]

#: Outcome names of :func:`reference_collision_n2` (``Outcome`` member names, in order).
OUTCOMES = tuple(outcome.name for outcome in Outcome)

_FREE, _STICK = "free", "stick"  # a sliding granule is represented by its direction +1 / -1


def _mode_matrix(modes, eta, gamma):
    """Generator of ``z' = M z`` for ``z = [u, s, v1, v2, 1]`` (u = x1-x2 > 0, s = x1+x2)."""
    M = mpmath.zeros(5, 5)
    M[0, 2], M[0, 3] = 1, -1
    M[1, 2], M[1, 3] = 1, 1
    for i, sign in ((0, -1), (1, 1)):  # spring force on granule i is sign * u
        row = 2 + i
        if modes[i] == _STICK:
            continue
        M[row, 0] = sign
        M[row, row] = -gamma[i]
        if modes[i] != _FREE:
            M[row, 4] = -eta[i] * modes[i]
    return M


def _events(modes, eta):
    """Event functionals ``g = c . z``; an event fires when g goes from > 0 to <= 0."""
    ev = [("separation", None, (1, 0, 0, 0, 0))]
    for i in (0, 1):
        if modes[i] == _STICK:
            ev.append(("slip", i, (-1, 0, 0, 0, eta[i])))  # |spring force| = u exceeds eta_i
        elif modes[i] != _FREE:
            c = [0, 0, 0, 0, 0]
            c[2 + i] = modes[i]
            ev.append(("stop", i, tuple(c)))  # velocity along the slide direction reaches 0
    return ev


def _dot(c, z):
    return sum(ci * z[k] for k, ci in enumerate(c) if ci)


def _homogeneous_horizon(modes, gamma, z):
    """For a mode without Coulomb sliding: time after which no event can occur.

    Returns ``mpmath.inf`` when separation is certain (march until found),
    a finite horizon otherwise, or the string ``"monotone"`` for the one-granule
    case in which separation is impossible and the caller stops once ``u' < 0``.
    """
    u, v1, v2 = z[0], z[2], z[3]
    free = [i for i in (0, 1) if modes[i] == _FREE]
    if len(free) == 1:
        # the other granule is stuck: u'' + g u' + u = 0 for the free granule's g
        g = gamma[free[0]]
        if g < 2:
            return mpmath.inf
        r_fast = (-g - mpmath.sqrt(g * g - 4)) / 2
        du = v1 - v2
        # u = A e^{r_slow t} + B e^{r_fast t}: crosses 0 for t > 0 iff A < 0 iff u' < r_fast u
        return mpmath.inf if du < r_fast * u else "monotone"
    # both granules free (eta1 = eta2 = 0): reduced system on (u, v1, v2)
    g1, g2 = gamma
    if g1 == g2:
        # x_- decouples: u'' + g u' + 2u = 0, u(0)=0, u'(0)=1 (mode starts at t = 0)
        return mpmath.inf if g1 * g1 < 8 else mpmath.mpf(0)
    A = mpmath.matrix([[0, 1, -1], [-1, -g1, 0], [1, 0, -g2]])
    lam, V = mpmath.eig(A)
    gaps = [abs(lam[i] - lam[j]) for i in range(3) for j in range(i)]
    if min(gaps) < mpmath.mpf(10) ** (-12):
        raise NotImplementedError("nearly repeated eigenvalues in the viscous mode")
    coef = mpmath.lu_solve(V, mpmath.matrix([u, v1, v2]))
    c = [V[0, k] * coef[k] for k in range(3)]  # u(t) = sum c_k exp(lam_k t)
    scale = max(abs(ck) for ck in c)
    keep = [k for k in range(3) if abs(c[k]) > scale * mpmath.mpf(10) ** (-(mpmath.mp.dps - 8))]
    k_lead = max(keep, key=lambda k: mpmath.re(lam[k]))
    lead = mpmath.re(lam[k_lead])
    tiny = mpmath.mpf(10) ** (-(mpmath.mp.dps - 8))
    # mpmath.eig returns real eigenvalues with ~1e-40 imaginary noise
    if abs(mpmath.im(lam[k_lead])) > tiny * (1 + abs(lam[k_lead])) or mpmath.re(c[k_lead]) < 0:
        return mpmath.inf  # oscillating or negative tail: separation is certain
    others = [k for k in keep if mpmath.re(lam[k]) < lead - mpmath.mpf(10) ** (-20)]
    if not others:
        return mpmath.mpf(0)
    rest = sum(abs(c[k]) for k in others)
    gap = lead - max(mpmath.re(lam[k]) for k in others)
    # beyond T the leading positive term dominates all others: u > 0
    return max(mpmath.mpf(0), mpmath.log(rest / mpmath.re(c[k_lead])) / gap) + 1


def _classify(v1, v2, dps):
    """Outcome name from the velocities at separation.

    A velocity counts as rest when ``|v| <= 1e-(dps-5) * max(|v1|, |v2|)`` (roundoff
    of an exactly zero velocity, e.g. granule 1 in the frictionless exchange);
    the scale is relative because viscous collisions may end with tiny velocities.
    """
    scale = max(abs(v1), abs(v2))
    if scale == 0:
        return Outcome.stuck.name  # pragma: no cover - both at rest exactly at separation
    tol = mpmath.mpf(10) ** (-(dps - 5)) * scale
    sign1 = 0 if abs(v1) <= tol else (1 if v1 > 0 else -1)
    sign2 = 0 if abs(v2) <= tol else (1 if v2 > 0 else -1)
    return outcome_of_signs(sign1, sign2).name


class _ReferenceRun:
    """The state of one reference collision while it runs from mode to mode.

    ``z = [x1-x2, x1+x2, v1, v2, 1]`` (mpmath column), ``modes[i]`` the mode of
    granule i (``_FREE``, ``_STICK`` or the direction +1/-1 it slides in),
    ``events`` and ``segments`` as :func:`reference_collision_n2` returns them.
    """

    def __init__(self, eta, gamma, dps, t_cap):
        self.eta, self.gamma, self.dps, self.t_cap = eta, gamma, dps, t_cap
        # marching step of the propagator: sign changes of the event functions
        # are looked for on this grid
        self.step = min(mpmath.mpf(1) / 32, mpmath.mpf(1) / (2 * (1 + gamma[0] + gamma[1])))
        self.modes = [1 if eta[0] > 0 else _FREE, _STICK if eta[1] > 0 else _FREE]
        self.z = mpmath.matrix([0, 0, 1, 0, 1])
        self.t = mpmath.mpf(0)
        self.events, self.segments = [], []

    def record(self, kind, granule, t, z):
        self.events.append({"t": t, "kind": kind, "granule": granule,
                            "x1": (z[1] + z[0]) / 2, "x2": (z[1] - z[0]) / 2,
                            "v1": z[2], "v2": z[3]})

    def finish(self, outcome, t_sep, z):
        """The result dict; ``z`` None when the granules never separate."""
        if z is None:
            v1 = v2 = mpmath.mpf(0)
            x1 = x2 = None
        else:
            v1, v2 = z[2], z[3]
            x1, x2 = (z[1] + z[0]) / 2, (z[1] - z[0]) / 2
        return {"v1": +v1, "v2": +v2, "energy_ratio": +(v1**2 + v2**2),
                "t_separation": t_sep if t_sep == math.inf else +t_sep,
                "x1": x1, "x2": x2, "outcome": outcome,
                "events": self.events, "segments": self.segments, "dps": self.dps}

    def next_mode(self):
        """Run the current mode to its end: the result dict if the collision ended,
        else None (the state, time and modes then hold the next mode's start)."""
        modes, eta, gamma = self.modes, self.eta, self.gamma
        if modes[0] == _STICK and modes[1] == _STICK:
            self.segments.append((self.t, mpmath.inf, _mode_matrix(modes, eta, gamma),
                                  self.z.copy()))
            return self.finish(Outcome.stuck.name, math.inf, None)
        M = _mode_matrix(modes, eta, gamma)
        event_fns = _events(modes, eta)
        sliding = any(m not in (_FREE, _STICK) for m in modes)
        horizon = mpmath.mpf(self.t_cap) if sliding else _homogeneous_horizon(modes, gamma, self.z)
        if (not sliding and modes == [_FREE, _FREE] and gamma[0] == gamma[1]
                and horizon == mpmath.inf):
            ended = self.symmetric_viscous_end(M)
            if ended is not None:
                return ended
        hit = self.march(M, event_fns, sliding, horizon)
        if isinstance(hit, dict):
            return hit
        return self.switch_mode(M, event_fns, *hit)

    def symmetric_viscous_end(self, M):
        """Closed-form end of the symmetric viscous case when the contact lasts longer
        than t_cap (gamma just below sqrt 8, w -> 0), where marching is pointless:
        u = e^{-g t/2} sin(w t)/w, v1 + v2 = e^{-g t}. None when it ends earlier."""
        g = self.gamma[0]
        w = mpmath.sqrt(8 - g ** 2) / 2
        t_sep = mpmath.pi / w
        if not t_sep > self.t_cap:
            return None
        vp = mpmath.exp(-g * t_sep)
        vm = -mpmath.exp(-g * t_sep / 2)
        z = mpmath.matrix([0, (1 - vp) / g, (vp + vm) / 2, (vp - vm) / 2, 1])
        self.segments.append((self.t, t_sep, M, self.z.copy()))
        self.record("separation", None, t_sep, z)
        return self.finish(_classify(z[2], z[3], self.dps), t_sep, z)

    def march(self, M, event_fns, sliding, horizon):
        """March ``z`` with the exact propagator over steps ``self.step`` until an event
        function changes sign; locate the first root. Returns ``(t_event, tau, j,
        z_before, t_start, z_start)`` (event j at ``tau`` after the state
        ``z_before``), or the result dict when the granules never separate."""
        h = self.step
        propagator = mpmath.expm(M * h)
        t_start, z_start = self.t, self.z.copy()
        z = self.z
        k = 0
        while True:
            if horizon == "monotone":
                if z[2] - z[3] < 0:
                    self.segments.append((t_start, mpmath.inf, M, z_start))
                    return self.finish(Outcome.no_separation.name, math.inf, None)
            elif k * h > horizon or t_start + k * h > self.t_cap:
                if sliding or horizon == mpmath.inf:
                    raise RuntimeError("no event before t_cap = %s" % self.t_cap)
                self.segments.append((t_start, mpmath.inf, M, z_start))
                return self.finish(Outcome.no_separation.name, math.inf, None)
            z_next = propagator * z
            g_now = [_dot(c, z) for _, _, c in event_fns]
            g_next = [_dot(c, z_next) for _, _, c in event_fns]
            fired = [j for j in range(len(event_fns)) if g_now[j] > 0 and g_next[j] <= 0]
            if fired:
                z_before = z.copy()
                roots = []
                for j in fired:
                    c = event_fns[j][2]
                    roots.append((bracket_root(
                        lambda tau: _dot(c, mpmath.expm(M * tau) * z_before), mpmath.mpf(0), h), j))
                tau, j = min(roots)
                return t_start + k * h + tau, tau, j, z_before, t_start, z_start
            z = z_next
            k += 1

    def switch_mode(self, M, event_fns, t_event, tau, j, z_before, t_start, z_start):
        """Apply event j at ``t_event``: the result dict at separation, else None with
        the modes switched (stop: stick or reverse; slip)."""
        z = mpmath.expm(M * tau) * z_before
        self.segments.append((t_start, t_event, M, z_start))
        self.t = t_event
        kind, i, _ = event_fns[j]
        if kind == "separation":
            z[0] = mpmath.mpf(0)
            self.record("separation", None, t_event, z)
            return self.finish(_classify(z[2], z[3], self.dps), t_event, z)
        if kind == "stop":
            z[2 + i] = mpmath.mpf(0)
            if z[0] > self.eta[i]:
                self.modes[i] = -1 if i == 0 else 1  # slide along the spring force
                self.record("reverse", i, t_event, z)
            else:
                self.modes[i] = _STICK
                self.record("stick", i, t_event, z)
        else:  # slip
            self.modes[i] = -1 if i == 0 else 1
            self.record("slip", i, t_event, z)
        self.z = z
        return None


def reference_collision_n2(eta1, eta2, gamma1=0, gamma2=0, dps=30, t_cap=1000):
    """Exact collision of two granules for ``n = 2`` with Coulomb and viscous friction.

    Scaled model (Sec. II, III, Appendix A): masses 1, spring force ``u = x1 - x2``
    while ``u > 0``; granule ``i`` feels ``-eta_i sign(v_i) - gamma_i v_i``; a granule
    at rest stays at rest while ``|spring force| <= eta_i`` (stick) and slides in the
    direction of the spring force once it exceeds ``eta_i`` (slip).  Initially
    ``x1 = x2 = 0``, ``v1 = 1``, ``v2 = 0``.

    Within a mode (each granule free, sticking, or sliding in a fixed direction) the
    dynamics is linear with constant coefficients, ``z' = M z`` for
    ``z = [x1-x2, x1+x2, v1, v2, 1]``, so ``z(t) = expm(M t) z(0)`` exactly.  The
    solver marches with the exact propagator on a grid (step <= 1/32), detects sign
    changes of the event functions (contact opening ``u -> 0``, a sliding granule
    stopping, a stuck granule's spring force exceeding ``eta_i``) and refines each
    root with ``expm`` at ``dps + 10`` digits.  Results are accurate to about
    ``10**-(dps-5)``.

    Parameters
    ----------
    eta1, eta2 : float or mpf, >= 0
        Scaled kinetic friction forces.
    gamma1, gamma2 : float or mpf, >= 0
        Scaled hydrodynamic friction coefficients.
    dps : int
        Decimal digits of the mpmath arithmetic.
    t_cap : float
        Give up (``RuntimeError``) if a Coulomb-sliding mode lasts longer.

    Returns
    -------
    dict
        ``v1``, ``v2`` : mpf, velocities at separation (0 for ``stuck`` and
        ``no_separation``, their limits as ``t -> inf``);
        ``energy_ratio`` : mpf, ``(v1**2 + v2**2) / 2 / E0`` with ``E0 = 1/2``
        (kinetic energy only);
        ``t_separation`` : mpf, or ``math.inf`` if contact never ends;
        ``x1``, ``x2`` : mpf displacements at separation (``None`` if never);
        ``outcome`` : one of :data:`OUTCOMES`;
        ``events`` : list of dicts ``{t, kind, granule, x1, x2, v1, v2}``
        (``kind`` in ``stop``, ``slip``, ``stick``, ``reverse``, ``separation``);
        ``segments`` : list of ``(t_start, t_end, M, z_start)`` for
        :func:`reference_state_n2`.

    Notes
    -----
    Viscous-only modes that never reach ``u = 0`` are recognised analytically
    (eigen-decomposition of the mode, or the closed form for one moving granule);
    exactly repeated eigenvalues are supported only in the symmetric case
    ``gamma1 == gamma2`` and for one moving granule.
    """
    with mpmath.workdps(dps + 10):
        eta = (mpmath.mpf(eta1), mpmath.mpf(eta2))
        gamma = (mpmath.mpf(gamma1), mpmath.mpf(gamma2))
        if min(eta) < 0 or min(gamma) < 0:
            raise ValueError("friction parameters must be non-negative")
        run = _ReferenceRun(eta, gamma, dps, t_cap)
        while True:
            result = run.next_mode()
            if result is not None:
                return result


def reference_state_n2(result, t):
    """State ``(x1, x2, v1, v2)`` at time ``t`` of a :func:`reference_collision_n2` result.

    Parameters
    ----------
    result : dict
        Output of :func:`reference_collision_n2`.
    t : float or mpf
        Scaled time, ``0 <= t <= t_separation``.

    Returns
    -------
    tuple of mpf
    """
    with mpmath.workdps(result["dps"] + 10):
        t = mpmath.mpf(t)
        for t0, t1, M, z0 in result["segments"]:
            if t0 <= t <= t1:
                z = mpmath.expm(M * (t - t0)) * z0
                return (+(z[1] + z[0]) / 2, +(z[1] - z[0]) / 2, +z[2], +z[3])
    raise ValueError("t outside the computed contact interval")
