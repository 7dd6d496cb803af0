"""Event stepper: exact contact, separation, stop, stick and slip events for N granules.

``simulate_events(scene, model) -> Result`` is what :func:`granular_chain.simulate`
calls for ``run.stepper: event``. The compiled core is
:mod:`granular_chain.steppers.events_kernel` (method and error control are
described there and in docs/events.md); this module packs the model into the
kernel's arrays, grows the frame and event buffers between kernel calls, and
builds the :class:`~granular_chain.result.Result` exactly like the Verlet path.

Contacts are numbered for the kernel 0..N (0 = left wall, j = between granules
j-1 and j, N = right wall); the event log uses the model's numbering (contact
i between granules i and i+1, -1 the left wall, N-1 the right wall).
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from .._compile import specialised
from ..model import LAW_LINEAR, Model
from ..result import OVERLAP_ADVICE, EnergyLedger, Event, Result, Status
from . import events_kernel as K
from .verlet import EVENT_KINDS

__all__ = ["simulate_events", "series_order"]

# n = 2: order and relative size of the first neglected terms (below roundoff).
LINEAR_ORDER = 24
LINEAR_RTOL = 2e-17
# n = 2: largest step times the eigenvalue bound L (see events_kernel, S_HCAP).
LINEAR_STEP = 0.5


def series_order(rtol: float) -> int:
    """Taylor order for a relative tolerance (Jorba & Zou: about -ln(tol)/2, at least 8)."""
    return int(min(30, max(8, math.ceil(-0.5 * math.log(rtol)) + 2)))


def _pack(model: Model):
    N = model.count
    present = np.zeros(N + 1, dtype=np.int8)
    dl = np.zeros(N + 1)
    kc = np.ones(N + 1)
    nexp = np.full(N + 1, 2.0)
    present[1:N] = 1
    dl[1:N] = model.d0
    kc[1:N] = model.k
    nexp[1:N] = model.n
    w = model.walls
    if model.features.left_wall:
        present[0] = 1
        dl[0], kc[0], nexp[0] = w[0], w[1], w[2]
    if model.features.right_wall:
        present[N] = 1
        dl[N], kc[N], nexp[N] = w[3], w[4], w[5]
    return present, dl, kc, nexp


def _scales(model: Model):
    """Mass, length, time scales (M, A, B) of Appendix A for this scene.

    The kernel's step control and tolerances (atol) are absolute, tuned for
    scaled units (m ~ 1, force coefficient ~ 1, speeds ~ 1). A scene in SI, or
    with an impact speed of 1e-8, is run in its own scaled units and the result
    converted back, so that the answer does not depend on the units.
    Returns None when the scene is already scaled (or nothing sets a scale).
    """
    M = float(model.mass[0])
    present_k = [float(k) for k in model.k]
    present_n = [float(n) for n in model.n]
    w = model.walls
    if model.features.left_wall:
        present_k.append(float(w[1]))
        present_n.append(float(w[2]))
    if model.features.right_wall:
        present_k.append(float(w[4]))
        present_n.append(float(w[5]))
    if not present_k:
        return None
    K0, n0 = present_k[0], present_n[0]
    # Speed scale: the larger of the speed a granule of mass M would have with
    # the most energetic granule's kinetic energy and the one it would have
    # with the initial elastic energy, so that a precompressed scene starting
    # at rest or at a tiny speed is scaled by the motion it will have.
    V = float(np.max(np.abs(model.v0) * np.sqrt(model.mass / M)))
    pe0 = model.energies(np.zeros(model.count), model.v0)[1]
    V = max(V, math.sqrt(2.0 * pe0 / M))
    if V == 0.0:
        return None
    # (M V^2/K0)^(1/n0) without forming V^2, which underflows below 1e-154
    A = (M / K0) ** (1.0 / n0) * V ** (2.0 / n0)
    B = (M / K0) ** (1.0 / n0) * V ** (2.0 / n0 - 1.0)
    # A drag, or a kinetic friction, stopping the motion far faster than the
    # collision (tiny speeds make B huge) sets the time scale instead: its
    # series would overflow in units of B.
    rate = max(float(np.max(model.gamma * model.inv_mass)) * B,
               float(np.max(model.eta * model.inv_mass)) * B / V)
    if rate > 1e3:
        B /= rate
        A /= rate
    if M == 1.0 and A == 1.0 and B == 1.0:
        return None
    if not all(1e-100 < x < 1e100 for x in (A, B, A / B)):
        # Speeds near the underflow threshold (1e-300 and below): the scales
        # themselves would lose their digits; such a scene hardly moves and
        # is run as given.
        return None
    return M, A, B


def _scaled_model(model: Model, M: float, A: float, B: float) -> Model:
    # Force coefficients k A^n / (F A) with F = M A / B^2 the force scale,
    # written as k A^(n-2) B^2 / M and 1/F as (B/M)(B/A), so that no factor
    # underflows for tiny speeds (A ~ 1e-300 at v = 1e-300).
    w = model.walls.copy()
    w[0] /= A
    w[3] /= A
    w[1] = w[1] * A ** (w[2] - 2.0) * B * B / M
    w[4] = w[4] * A ** (w[5] - 2.0) * B * B / M
    inv_F = (B / M) * (B / A)
    return dataclasses.replace(
        model, mass=model.mass / M, inv_mass=model.inv_mass * M, radius=model.radius / A,
        x0=model.x0 / A, v0=model.v0 * (B / A), d0=model.d0 / A,
        k=model.k * A ** (model.n - 2.0) * (B * B / M), walls=w, eta=model.eta * inv_F,
        eta_static=model.eta_static * inv_F, gamma=model.gamma * (B / M))


def simulate_events(scene, model: Model) -> Result:
    """Run the scene with the event stepper in its own scaled units (see :func:`_scales`)."""
    scales = _scales(model)
    if scales is None:
        return _simulate_events(scene, model, 1.0)
    M, A, B = scales
    run = scene.run.model_copy(update={"t_end": scene.run.t_end / B})
    out = scene.output.model_copy(
        update={"dt": scene.output.dt / B if scene.output.dt is not None else None})
    r = _simulate_events(scene.model_copy(update={"run": run, "output": out}),
                         _scaled_model(model, M, A, B), B)
    V, F, E = A / B, M * A / (B * B), M * A * A / (B * B)
    led = r.energy
    r.energy = EnergyLedger(kinetic=led.kinetic * E, potential=led.potential * E,
                            coulomb=led.coulomb * E, viscous=led.viscous * E,
                            initial=led.initial * E)
    r.t, r.x, r.v, r.f = r.t * B, r.x * A, r.v * V, r.f * F
    r.t_final, r.x_final, r.v_final = r.t_final * B, r.x_final * A, r.v_final * V
    r.events = [Event(e.t * B, e.kind, e.index) for e in r.events]
    r.info["event_stepper"]["internal_scales"] = {"mass": M, "length": A, "time": B}
    if model.units == "physical":
        from ..units import scaled_parameters
        r.info["scaled"] = scaled_parameters(model)
    return r


def _simulate_events(scene, model: Model, tscale: float) -> Result:
    """Run the scene with the event stepper (see module docstring); times in
    messages are multiplied by ``tscale`` (the scene's own time unit).

    Returns
    -------
    Result
        ``stepper='event'``, ``dt=None``; frames at t = 0, at every event batch
        (unless ``output.dt`` is given and N > 64, where frames are at the
        cadence only, to bound memory), at the ``output.dt`` cadence, and at the
        end; ``events`` the full event log; ``steps`` the Taylor steps taken.
    """
    settings = scene.run
    feat = model.features
    N = model.count
    law = int(feat.law)
    linear = law == LAW_LINEAR
    if linear:
        P, rtol, atol = LINEAR_ORDER, LINEAR_RTOL, 0.0
    else:
        P, rtol, atol = series_order(settings.rtol), float(settings.rtol), float(settings.atol)
    present, dl, kc, nexp = _pack(model)
    coulomb = int(feat.coulomb)
    viscous = int(feat.viscous)
    csl = (model.eta_static > 0).astype(np.int8)
    v = model.v0.copy()
    u = np.zeros(N)
    slide = np.where(csl == 1, np.sign(v), 2).astype(np.int8)
    closed = ((dl > 0) & (present == 1)).astype(np.int8)

    stops = settings.stop_conditions
    st = np.zeros(9)
    st[K.S_TEND] = settings.t_end
    st[K.S_OUTDT] = scene.output.dt or 0.0
    st[K.S_LASTEV] = -math.inf
    if linear:
        # Bound on the eigenvalues of any linear mode: drag rate plus twice the
        # fastest contact frequency (a chain's highest mode is 2 sqrt(k/m)).
        kmax = float(np.max(kc[present == 1])) if np.any(present == 1) else 0.0
        L = float(np.max(model.gamma * model.inv_mass)) + 2.0 * math.sqrt(
            kmax * float(np.max(model.inv_mass)))
        st[K.S_HCAP] = LINEAR_STEP / L if L > 0 else 0.0
    ist = np.zeros(20, dtype=np.int64)
    ist[K.I_WATCH] = settings.stop_contact + 1 if N > 1 else -10
    ist[K.I_STOPSEP] = int("separation" in stops)
    ist[K.I_STOPREST] = int("rest" in stops)
    ist[K.I_MAXEV] = settings.max_events
    ist[K.I_MAXSTEPS] = settings.max_steps
    ist[K.I_FRAMEEV] = int(scene.output.dt is None or N <= 64)
    ist[K.I_EVERY] = scene.output.every or 0

    R = max(P + 1, N + 1)
    U = np.zeros((N, P + 1))
    V = np.zeros((N, P + 1))
    D = np.zeros((N + 1, P + 1))
    Fc = np.zeros((N + 1, P + 1))
    Q = np.zeros((2, R))
    wrk = np.zeros(3 * N + 1)
    mov = np.zeros(N, dtype=np.int64)
    act = np.zeros(N + 1, dtype=np.int64)
    cand = np.zeros(N, dtype=np.int64)
    cflag = np.zeros(N + 1, dtype=np.int8)
    gflag = np.zeros(N, dtype=np.int8)
    old_c = np.zeros(N + 1, dtype=np.int8)
    old_s = np.zeros(N, dtype=np.int8)
    ctype = np.zeros(5 * N + 16, dtype=np.int64)
    cidx = np.zeros(5 * N + 16, dtype=np.int64)
    croot = np.zeros(5 * N + 16)
    fcap = 64
    if scene.output.dt is not None:
        fcap = min(int(settings.t_end / scene.output.dt) + 16, 1 << 20)
    fr_t = np.zeros(fcap)
    fr_x = np.zeros((fcap, N))
    fr_v = np.zeros((fcap, N))
    fr_f = np.zeros((fcap, N))
    fr_e = np.zeros((fcap, 4))
    ecap = 4 * N + 64
    ev_t = np.zeros(ecap)
    ev_k = np.zeros(ecap, dtype=np.int64)
    ev_i = np.zeros(ecap, dtype=np.int64)
    counts = np.zeros(4, dtype=np.int64)

    ke0 = 0.5 * float(np.dot(model.mass, v * v))
    mass = model.mass
    args = [law, coulomb, viscous, P, rtol, atol, st, ist, model.x0, u, v, dl, closed, present,
            slide, csl, kc, nexp, mass, model.eta, model.eta_static, model.gamma, U, V, D, Fc,
            Q, wrk, mov, act, cand, cflag, gflag, old_c, old_s, ctype, cidx, croot,
            fr_t, fr_x, fr_v, fr_f, fr_e, ev_t, ev_k, ev_i, counts,
            np.zeros(K.EM.NPAR), np.zeros(2, dtype=np.int64), np.zeros(N, dtype=np.int8),
            np.zeros(N, dtype=np.int64), _overlap_limits(model)]
    kernel = specialised(K.run_events, tuple(args), (0, 1, 2))
    start = time.perf_counter()
    while True:
        code = kernel(*args)
        if code != K.C_BUFFER:
            break
        # Grow whichever buffer is short (doubling) and call again: the state
        # lives in the arrays, so the kernel resumes where it stopped.
        if fr_t.size - ist[K.I_NFR] < 8:
            n2 = 2 * fr_t.size
            fr_t = _grow(fr_t, n2)
            fr_x = _grow(fr_x, n2)
            fr_v = _grow(fr_v, n2)
            fr_f = _grow(fr_f, n2)
            fr_e = _grow(fr_e, n2)
            args[38:43] = [fr_t, fr_x, fr_v, fr_f, fr_e]
        if ev_t.size - ist[K.I_NEV] < 2 * N + 8:
            n2 = 2 * ev_t.size
            ev_t = _grow(ev_t, n2)
            ev_k = _grow(ev_k, n2)
            ev_i = _grow(ev_i, n2)
            args[43:46] = [ev_t, ev_k, ev_i]
    wall = time.perf_counter() - start

    nfr = int(ist[K.I_NFR])
    nev = int(ist[K.I_NEV])
    pe0 = float(fr_e[0, 1])
    e0 = ke0 + pe0
    t_final = float(st[K.S_T])
    status, message = _status(code, scene, model, st * _time_fields(tscale), ist,
                              t_final * tscale, nev)
    energy = EnergyLedger(kinetic=fr_e[:nfr, 0].copy(), potential=fr_e[:nfr, 1].copy(),
                          coulomb=fr_e[:nfr, 2].copy(), viscous=fr_e[:nfr, 3].copy(),
                          initial=e0)
    events = [Event(float(ev_t[q]), EVENT_KINDS[int(ev_k[q])], int(ev_i[q])) for q in range(nev)]
    info = {"features": feat.describe(), "granules": N, "units": model.units,
            "event_stepper": {"taylor_order": P, "rtol": rtol, "atol": atol,
                              "exact_modes": bool(linear), "event_batches": int(ist[K.I_BATCHES])}}
    if model.units == "physical":
        from ..units import scaled_parameters
        info["scaled"] = scaled_parameters(model)
    x = fr_x[:nfr].copy()
    vv = fr_v[:nfr].copy()
    return Result(
        t=fr_t[:nfr].copy(), x=x, v=vv, f=fr_f[:nfr].copy(), energy=energy, status=status,
        message=message, steps=int(ist[K.I_STEPS]), wall_time=wall, stepper="event", dt=None,
        t_final=t_final, x_final=x[-1].copy(), v_final=vv[-1].copy(), events=events,
        event_counts={k: int(n) for k, n in zip(EVENT_KINDS, counts)}, info=info)


def _overlap_limits(model: Model) -> np.ndarray:
    """Overlap of each kernel contact at which the centres meet (N + 1,):
    r_(j-1) + r_j between granules, the granule's radius at a wall."""
    r = model.radius
    lim = np.empty(model.count + 1)
    lim[1:-1] = r[:-1] + r[1:]
    lim[0] = r[0]
    lim[-1] = r[-1]
    return lim


def _time_fields(tscale: float) -> np.ndarray:
    """Factors that put the kernel's time-valued state entries in the scene's unit."""
    f = np.ones(9)
    f[K.S_T] = f[K.S_TEND] = f[K.S_JUMPFROM] = tscale
    return f


def _grow(a: np.ndarray, n: int) -> np.ndarray:
    b = np.zeros((n,) + a.shape[1:], dtype=a.dtype)
    b[: a.shape[0]] = a
    return b


def _status(code, scene, model, st, ist, t, nev):
    settings = scene.run
    steps = int(ist[K.I_STEPS])
    if code == K.C_T_END:
        msg = f"reached t_end = {t:.12g} after {nev} events and {steps} Taylor steps"
        if ist[K.I_JUMPED] == 1:
            msg += (f"; from t = {st[K.S_JUMPFROM]:.12g} the exact modal solution shows the "
                    f"contact never opens again (overdamped), so the state was moved to t_end "
                    f"in closed form")
        elif ist[K.I_JUMPED] == 2:
            msg += (f"; nothing moves after t = {st[K.S_JUMPFROM]:.12g} (every granule held "
                    f"or at rest), so the state is final")
        return Status.T_END, msg
    if code == K.C_SEPARATED:
        return Status.SEPARATED, (f"contact {settings.stop_contact} opened at t = {t:.17g} "
                                  f"(exact event time, {nev} events)")
    if code == K.C_AT_REST:
        return Status.AT_REST, (f"every granule at rest (held by static friction) at "
                                f"t = {t:.17g} after {nev} events")
    if code == K.C_MAX_EVENTS:
        return Status.MAX_EVENTS, (f"stopped after run.max_events = {settings.max_events} "
                                   f"events at t = {t:.12g} before t_end = {settings.t_end:g}; "
                                   f"raise run.max_events")
    if code == K.C_ZENO:
        return Status.ZENO, (f"events accumulate at t = {t:.15g}: {K.ZENO_BATCHES} consecutive "
                             f"event batches without time advancing by more than 1e-12 "
                             f"(relative); the modes chatter (Zeno), so the run stopped")
    if code == K.C_OVERLAP:
        j = int(ist[K.I_OVERLAP])
        N = model.count
        if j == 0:
            where = "granule 0 reached the left wall's position with its centre"
        elif j == N:
            where = f"granule {N - 1} reached the right wall's position with its centre"
        else:
            where = (f"contact {j - 1} reached an overlap equal to the sum of the radii of "
                     f"granules {j - 1} and {j} (their centres meet)")
        return Status.OVERLAP, f"{where} at t = {t:.12g} (exact event time); " + OVERLAP_ADVICE
    if code == K.C_MAX_STEPS:
        return Status.MAX_STEPS, (f"stopped after run.max_steps = {settings.max_steps} Taylor "
                                  f"steps at t = {t:.12g}; raise run.max_steps or loosen run.rtol")
    return Status.NONFINITE, (f"non-finite state or step size at t = {t:.12g}: the Taylor "
                              f"series diverged (a time scale of the scene is too short to "
                              f"resolve: look for extreme ratios of speeds, overlaps and "
                              f"friction, e.g. speeds near 1e-300); the Verlet stepper or "
                              f"rescaled parameters may run it")
