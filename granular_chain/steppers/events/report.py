"""The Result of an event run: frames, ledger, event log, status and its message."""

from __future__ import annotations

import math

import numpy as np

from ...codes import EVENT_KINDS, Status
from ...ledger import ledger_verdict
from ...model import Model
from ...result import OVERLAP_ADVICE, EnergyLedger, Event, Result
from ...units import scaled_parameters
from ..opening import roundoff_note
from .kernel import ZENO_BATCHES
from .pack import Packed

__all__ = ["build_result", "ledger_tolerance", "EXACT_LEDGER_ULPS"]


def build_result(packed: Packed, code, wall, model: Model, tscale: float, run=None) -> Result:
    """The Result of a finished kernel run (frames, ledger, event log, status).

    Without ``run`` every frame is in the kernel's buffers (kernel units); with
    it the frames are those its log kept (the scene's units) and the buffers
    hold the last one (its final state, kernel units, as without it).

    Parameters
    ----------
    packed : Packed
        The run's records after the last kernel call.
    code : int
        The code the driver ended with (a :class:`~granular_chain.codes.Status`).
    wall : float
        Wall-clock time of the run, seconds.
    model : Model
        The model the kernel ran (kernel units).
    tscale : float
        Scene time units per kernel time unit (1.0 when the run was not scaled);
        used for times in messages.
    run : EventRun, optional
        The streamed run whose log kept the frames (None: not streamed).

    Returns
    -------
    Result
        Times, positions, velocities and forces in kernel units unless streamed
        (then scene units); ``status`` and ``message`` include the ledger verdict.
    """
    clock = packed.clock
    fr_t, fr_x, fr_v, fr_f, fr_e = packed.records.frames
    ev_t, ev_k, ev_i, counts = packed.records.log
    feat = model.features
    nfr = int(clock.n_frames)
    nev = int(clock.n_events)
    settings = packed.settings
    pe0 = float(fr_e[0, 1]) if run is None else run.pe0
    e0 = packed.ke0 + pe0
    t_final = float(clock.time)
    if packed.out_of_steps:
        status, message = Status.MAX_STEPS, _out_of_steps_message(packed, t_final, tscale)
    else:
        status, message = _status(code, packed, clock, model, t_final * tscale, nev, tscale)
    work = float(fr_e[nfr - 1, 2] + fr_e[nfr - 1, 3] + fr_e[nfr - 1, 4]
                 + abs(fr_e[nfr - 1, 5]) + abs(fr_e[nfr - 1, 6]))
    tol = ledger_tolerance(packed, e0, work, clock, settings)
    events = [Event(float(ev_t[q]), EVENT_KINDS[int(ev_k[q])], int(ev_i[q])) for q in range(nev)]
    info = {"features": feat.describe(), "granules": model.count, "units": model.units,
            "event_stepper": {"taylor_order": int(settings.order),
                              "rtol": float(settings.rtol), "atol": float(settings.atol),
                              "exact_modes": bool(packed.linear),
                              "event_batches": int(clock.batches),
                              "ledger_tolerance": tol}}
    if model.units == "physical":
        info["scaled"] = scaled_parameters(model)
    if run is None:
        energy = EnergyLedger(kinetic=fr_e[:nfr, 0].copy(), potential=fr_e[:nfr, 1].copy(),
                              coulomb=fr_e[:nfr, 2].copy(), viscous=fr_e[:nfr, 3].copy(),
                              initial=e0, contact_dissipated=fr_e[:nfr, 4].copy(),
                              wall_work=fr_e[:nfr, 5].copy(), body_work=fr_e[:nfr, 6].copy())
        t, x, vv, f = fr_t[:nfr].copy(), fr_x[:nfr].copy(), fr_v[:nfr].copy(), fr_f[:nfr].copy()
        judged = energy
    else:
        t, x, vv, f, energy = _logged_frames(run, info)
        # judged in kernel units first, as the frames of an unstreamed run are
        scale = e0 if e0 > 0 else 1.0
        judged = EnergyLedger(kinetic=np.zeros(0), potential=np.zeros(0), coulomb=np.zeros(0),
                              viscous=np.zeros(0), initial=e0,
                              streamed_error=run.balance / scale)
    r = Result(
        t=t, x=x, v=vv, f=f, energy=judged, status=status,
        message=message, steps=int(clock.steps), wall_time=wall, stepper="event", dt=None,
        t_final=t_final, x_final=fr_x[nfr - 1].copy(), v_final=fr_v[nfr - 1].copy(),
        events=events, event_counts={k: int(n) for k, n in zip(EVENT_KINDS, counts)},
        info=info)
    r.status, r.message = ledger_verdict(r, tol)
    r.energy = energy
    return r


def _logged_frames(run, info: dict):
    """t, x, v, f and the EnergyLedger (scene units) of a streamed run's kept frames."""
    log = run.log
    e0 = run.packed.ke0 + run.pe0
    if run.units is not None:
        e0 = e0 * run.units.e
    whole = log.keep and not run.resumed  # else frames were handed on without being kept
    energy = EnergyLedger(
        kinetic=log.array("kinetic"), potential=log.array("potential"),
        coulomb=log.array("coulomb"), viscous=log.array("viscous"), initial=e0,
        streamed_error=None if whole else log.max_balance_error,
        contact_dissipated=log.array("contact_dissipated"), wall_work=log.array("wall_work"),
        body_work=log.array("body_work"))
    if not log.keep:
        info["frames"] = log.count
        info["frames_kept"] = "first and last (the others were streamed to the writers)"
    return log.array("t"), log.array("x"), log.array("v"), log.array("f"), energy


#: n = 2 (exact modes): ledger error promised per unit of work, in units of eps.
#: A step sums series whose terms stay below ~3 times the result (L h <= 1/2), so
#: it rounds each state entry by a few ulps; the energy is quadratic in the state
#: (2x the relative error); an event batch sets and re-rounds the same entries;
#: the ledger's own sums over N granules round by ~N ulps. Errors add at worst
#: linearly: 8 eps per step, batch and granule.
EXACT_LEDGER_ULPS = 8.0


def ledger_tolerance(packed: Packed, e0: float, work: float, clock=None, settings=None) -> float:
    """The largest energy-ledger error (relative to the initial energy ``e0``) the
    event stepper promises for the run held in ``packed`` (kernel units).

    * n = 2 (exact modes): ``EXACT_LEDGER_ULPS * eps * (steps + batches + N + 1)``.
    * other n: each step keeps the last two terms of every velocity's and
      overlap's series below ``tol = rtol * |x| + atol``; with terms falling at
      least by half, the truncation error is below ``2 tol``. That changes the
      energy by at most ``max(2, n) rtol`` of it plus ``atol`` times the momenta
      and forces, ``2 atol / V`` relative (V = sqrt(2 e0 / total mass), the speed
      scale); an opening or closing leaves out an impulse below ``tol / 10``
      (the contact switching rule) and its root is located to a few ulps,
      counted as two steps; the friction work, integrated from the series of v,
      is off by at most ``2 rtol`` of itself. At worst linearly accumulated:
      ``2 [(steps + 2 batches + 1) (max(2, n) rtol + 2 atol / V) + 2 rtol work / e0]``.

    Parameters
    ----------
    packed : Packed
        The run's records.
    e0 : float
        Initial mechanical energy, kernel units.
    work : float
        Energy dissipated by friction (and dashpots, walls, body forces) over the
        run, kernel units.
    clock : ClockValues, optional
        Snapshot of the clock record already read (read here if None).
    settings : SettingsValues, optional
        Snapshot of the settings record already read (read here if None).

    Returns
    -------
    float
        The promised error, dimensionless (relative to ``e0``).
    """
    clock = packed.clock if clock is None else clock
    settings = packed.settings if settings is None else settings
    chain = packed.records.model
    steps = int(clock.steps)
    batches = int(clock.batches)
    N = chain.mass.size
    if packed.linear:
        return EXACT_LEDGER_ULPS * np.finfo(float).eps * (steps + batches + N + 1)
    present = chain.present == 1
    n_max = float(np.max(chain.exponent[present])) if present.any() else 2.0
    m_tot = float(np.sum(chain.mass))
    V = math.sqrt(2.0 * e0 / m_tot) if e0 > 0.0 else math.inf
    rtol, atol = float(settings.rtol), float(settings.atol)
    per_step = max(2.0, n_max) * rtol + 2.0 * atol / V
    friction = 2.0 * rtol * abs(work) / e0 if e0 > 0.0 else 0.0
    return 2.0 * ((steps + 2 * batches + 1) * per_step + friction)




def _out_of_steps_message(packed: Packed, t: float, tscale: float) -> str:
    need, pace = packed.projection
    options, chain = packed.options, packed.records.model
    msg = (f"stopped at t = {t * tscale:.6g} after {int(packed.clock.steps)} Taylor steps: at "
           f"the pace reached (mean step {pace * tscale:.3g}) t_end = "
           f"{options.t_end * tscale:g} needs ~{need:.3g} more steps, more than "
           f"run.max_steps = {options.max_steps} allows")
    # in kernel units: the fastest drag rate against the fastest contact rate
    drag = float(np.max(chain.gamma / chain.mass))
    present = chain.present == 1
    kmax = float(np.max(chain.stiffness[present])) if present.any() else 0.0
    contact = math.sqrt(kmax / float(np.min(chain.mass)))
    if drag > 10.0 * contact:
        msg += (f"; the scene is overdamped (drag time m/gamma = {tscale / drag:.3g}, far "
                f"shorter than the contact time): the steps cannot exceed the drag time while "
                f"the granules creep on a far slower time scale; the Verlet stepper integrates "
                f"drag exactly, or shorten t_end")
    else:
        msg += "; raise run.max_steps or shorten t_end"
    return msg


def _status(code: int, packed: Packed, clock, model: Model, t: float, nev: int, tscale: float):
    """Status and message of a run the kernel ended with ``code`` at time t (scene units)."""
    options = packed.options
    steps = int(clock.steps)
    if code == Status.T_END:
        msg = f"reached t_end = {t:.12g} after {nev} events and {steps} Taylor steps"
        jumped_from = float(clock.jumped_from) * tscale
        if clock.jumped == 1:
            msg += (f"; from t = {jumped_from:.12g} the exact modal solution shows the "
                    f"contact never opens again (overdamped), so the state was moved to t_end "
                    f"in closed form")
        elif clock.jumped == 2:
            msg += (f"; nothing moves after t = {jumped_from:.12g} (every granule held "
                    f"or at rest), so the state is final")
        if packed.roundoff is not None:
            msg += roundoff_note(options.stop_contact, packed.roundoff[0] * tscale,
                                 packed.roundoff[1])
        return Status.T_END, msg
    if code == Status.SEPARATED:
        return Status.SEPARATED, (f"contact {options.stop_contact} opened at t = {t:.17g} "
                                  f"(exact event time, {nev} events)")
    if code == Status.AT_REST:
        return Status.AT_REST, (f"every granule at rest (held by static friction) at "
                                f"t = {t:.17g} after {nev} events")
    if code == Status.MAX_EVENTS:
        return Status.MAX_EVENTS, (f"stopped after run.max_events = {options.max_events} "
                                   f"events at t = {t:.12g} before t_end = {options.t_end:g}; "
                                   f"raise run.max_events")
    if code == Status.ZENO:
        return Status.ZENO, (f"events accumulate at t = {t:.15g}: {ZENO_BATCHES} consecutive "
                             f"event batches without time advancing by more than 1e-12 "
                             f"(relative); the modes chatter (Zeno), so the run stopped")
    if code == Status.OVERLAP:
        return Status.OVERLAP, _overlap_message(int(clock.overlap_contact), model.count, t)
    if code == Status.INTERRUPTED:  # the message is set by the caller, who knows the signal
        return Status.INTERRUPTED, "stopped by a signal"
    if code == Status.MAX_STEPS:
        return Status.MAX_STEPS, (f"stopped after run.max_steps = {options.max_steps} Taylor "
                                  f"steps at t = {t:.12g}; raise run.max_steps or loosen run.rtol")
    return Status.NONFINITE, (f"non-finite state or step size at t = {t:.12g}: the Taylor "
                              f"series diverged (a time scale of the scene is too short to "
                              f"resolve: look for extreme ratios of speeds, overlaps and "
                              f"friction, e.g. speeds near 1e-300); the Verlet stepper or "
                              f"rescaled parameters may run it")


def _overlap_message(j: int, N: int, t: float) -> str:
    """Which contact reached its overlap limit (kernel contact j of N granules)."""
    if j == 0:
        where = "granule 0 reached the left wall's position with its centre"
    elif j == N:
        where = f"granule {N - 1} reached the right wall's position with its centre"
    else:
        where = (f"contact {j - 1} reached an overlap equal to the sum of the radii of "
                 f"granules {j - 1} and {j} (their centres meet)")
    return f"{where} at t = {t:.12g} (exact event time); " + OVERLAP_ADVICE
