"""Experiment ``dimers``: transmission of a struck granular dimer chain against its
mass ratio, with its resonances and anti-resonances.

Scene ``scenarios/classics/dimers.yaml``: 60 Hertz spheres (n = 5/2) alternating
heavy (mass 1) and light (mass ``epsilon``), scaled units, just touching; heavy
granule 0 strikes the others at v0 = 1. Every contact joins a heavy and a light
granule and has the same force coefficient (1), as in the rescaled equations of
Jayaprakash, Starosvetsky & Vakakis, Phys. Rev. E 83, 036606 (2011). That paper
finds that at a discrete sequence of mass ratios (resonances) the uncompressed
dimer carries solitary waves that leave no tail behind, and that in between
(anti-resonances) the leading pulse radiates into the chain behind it and decays
fastest. The paper gives those mass ratios in its tables and figures, whose
digits are not quoted here: the reference is computed.

Measured, on the leading pulse's peak velocity ``v_p(j)`` at heavy granule
``2 j`` (cell ``j``; the peak read from the frames, every 0.02, by the quartic
through the largest frame and two either side):

- the decay rate per cell ``(ln v_p(15) - ln v_p(27)) / 12`` (cells where the
  struck chain's transient has settled, before the free end) and the transmission
  ``T = v_p(27)^2`` (heavy granule 54's peak kinetic energy over the striker's);
- scanned over 15 mass ratios from 0.133 to 1 (event stepper); the first two
  local minima of the decay (resonances) and its first maximum (anti-resonance)
  refined by :func:`scipy.optimize.minimize_scalar` (bounded Brent, xatol 1e-4)
  on the bracket the scan gives;
- the reference: the same chain integrated by scipy's DOP853 (:mod:`.chain_ode`,
  rtol 1e-11, velocities sampled on the same frame times), the same peak
  reading; an extremum's mass ratio is the vertex of the parabola through the
  reference's decay at ``epsilon* - h, epsilon*, epsilon* + h`` (h = 2e-4), the
  parabola's own error measured on the engine's decay (its vertex against
  Brent's optimum); the reference's own error by running it again at rtol 1e-12;
- Verlet at dt = 0.01 at the first resonance and anti-resonance, its error by
  halving dt (Richardson ``(4/3) |q(dt) - q(dt/2)|``);
- momentum and energy after the run against before.

The located mass ratios are those of this chain and this reading of the decay:
the struck chain starts with a transient, so a longer chain and later cells move
them slightly towards those of the exact solitary waves. Near the first
resonance the heavy granules' velocity has two humps of nearly equal height; the
reading takes the larger, which changes hump at epsilon = 0.3429, a kink of the
decay curve 3e-4 below the resonance (so the parabola's h stays below that).
"""

from __future__ import annotations

import math
from functools import lru_cache, partial
from pathlib import Path

import numpy as np

from ..simulate import simulate
from .chain_ode import integrate_chain
from .experiment import Experiment, Outcome, figure_file, final_energy, scene_of
from .table import Row

__all__ = ["EXPERIMENT", "SCENE", "EPSILONS", "FIRST_CELL", "LAST_CELL", "VERLET_DT",
           "REFERENCE_RTOL", "PARABOLA_STEP", "XATOL", "peak_heights", "pulse_decay",
           "engine_run", "reference_run", "scan", "extrema", "refine", "compute", "figure"]

SCENE = "dimers.yaml"
#: The scan's mass ratios: geometric, ratio 10^(1/16), from 0.133 to 1 (denser where
#: the extrema crowd, at small epsilon).
EPSILONS = tuple(float(10.0 ** (-k / 16.0)) for k in range(14, -1, -1))
#: The cells (heavy granules 2 j) between which the decay is read: from where the
#: struck chain's transient has settled to before the free end.
FIRST_CELL, LAST_CELL = 15, 27
#: Verlet's step (its error is measured at half of it).
VERLET_DT = 0.01
#: The reference's tolerance (DOP853, relative and absolute); its own error is
#: measured against a run at :data:`TIGHTER_RTOL`.
REFERENCE_RTOL, TIGHTER_RTOL = 1e-11, 1e-12
#: Half-width of the three mass ratios the reference's parabola passes through.
PARABOLA_STEP = 2e-4
#: Brent's tolerance on the mass ratio.
XATOL = 1e-4
REFERENCE = "DOP853 rtol=1e-11 (scipy), same chain and frames (computed)"
NO_DECAY = "no decay at a resonance (Jayaprakash, Starosvetsky & Vakakis 2011)"


def peak_heights(t: np.ndarray, v: np.ndarray, granules) -> tuple:
    """Largest velocity of each granule and its time, refined by the quartic through
    the largest frame and two frames either side (error of order dt^5).

    Parameters
    ----------
    t : ndarray, shape (F,)
        Frame times, uniformly spaced.
    v : ndarray, shape (F, N)
        Velocities.
    granules : sequence of int
        Which granules.

    Returns
    -------
    t_peak, v_peak : ndarray, shape (len(granules),)
        ``nan`` where the largest frame is within two frames of either end.
    """
    tp = np.full(len(granules), np.nan)
    vp = np.full(len(granules), np.nan)
    s = np.arange(-2.0, 3.0)
    for out, i in enumerate(granules):
        j = int(np.argmax(v[:, i]))
        if j < 2 or j > v.shape[0] - 3:
            continue
        quartic = np.polynomial.Polynomial.fit(s, v[j - 2:j + 3, i], 4, domain=[-1, 1],
                                               window=[-1, 1])
        roots = quartic.deriv().roots()
        roots = np.r_[0.0, roots.real[(abs(roots.imag) < 1e-12) & (abs(roots.real) <= 1.0)]]
        best = roots[int(np.argmax(quartic(roots)))]
        tp[out] = t[j] + best * (t[j + 1] - t[j])
        vp[out] = quartic(best)
    return tp, vp


def pulse_decay(t: np.ndarray, v: np.ndarray) -> dict:
    """The leading pulse's peaks along the heavy granules, its decay and transmission.

    Parameters
    ----------
    t : ndarray, shape (F,)
        Frame times (uniform).
    v : ndarray, shape (F, N)
        Velocities; granule ``2 j`` is heavy cell ``j``.

    Returns
    -------
    dict
        ``rate`` (decay of ln v_p per cell between :data:`FIRST_CELL` and
        :data:`LAST_CELL`), ``transmission`` (``v_p(LAST_CELL)^2``: peak kinetic
        energy over the striker's), ``peaks`` and ``times`` (per cell, lists),
        ``ordered`` (peak times increase along the cells up to LAST_CELL: the
        peaks are the leading pulse's).
    """
    cells = np.arange(0, v.shape[1], 2)
    tp, vp = peak_heights(t, v, cells)
    a, b = vp[FIRST_CELL], vp[LAST_CELL]
    return {"rate": float(math.log(a / b) / (LAST_CELL - FIRST_CELL)),
            "transmission": float(b * b), "peaks": vp.tolist(), "times": tp.tolist(),
            "ordered": bool(np.all(np.diff(tp[1:LAST_CELL + 1]) > 0.0))}


def _overrides(eps: float, stepper: str, dt: float, frame_dt: float) -> list:
    """The ``--set`` items of a run at mass ratio ``eps`` with ``stepper``: frames on
    the scene's cadence (Verlet: every ``frame_dt / dt`` steps)."""
    over = [f"granules.mass.values=[1.0, {float(eps)!r}]"]
    if stepper == "verlet":
        over += ["run.stepper=verlet", f"run.dt={dt!r}", "output.dt=null",
                 f"output.every={round(frame_dt / dt)}"]
    return over


def _on_cadence(t: np.ndarray, v: np.ndarray, frame_dt: float) -> tuple:
    """The frames at multiples of ``frame_dt`` (the event stepper adds frames at events)."""
    on = np.abs(t / frame_dt - np.round(t / frame_dt)) < 1e-6
    return t[on], v[on]


def engine_run(folder: Path, eps: float, stepper: str = "event", dt: float = VERLET_DT) -> dict:
    """The scene at mass ratio ``eps`` with ``stepper``.

    Parameters
    ----------
    folder : Path
        The scenes' folder.
    eps : float
        Light mass over heavy mass.
    stepper : str
        ``event`` or ``verlet``.
    dt : float
        Verlet's step (scaled time units).

    Returns
    -------
    dict
        :func:`pulse_decay`'s entries, and ``momentum`` and ``energy`` at the end
        (units of the striker's), ``energy_error`` (the run's ledger).
    """
    base = scene_of(folder, SCENE)
    frame_dt = float(base.output.dt)
    scene = scene_of(folder, SCENE, _overrides(eps, stepper, dt, frame_dt))
    result = simulate(scene, progress=False)
    t, v = _on_cadence(np.asarray(result.t), np.asarray(result.v), frame_dt)
    out = pulse_decay(t, v)
    m = np.where(np.arange(v.shape[1]) % 2 == 0, 1.0, eps)
    e0 = 0.5 * float(m[0] * v[0, 0] ** 2)
    out.update(momentum=float(np.sum(m * result.v_final) / (m[0] * v[0, 0])),
               energy=final_energy(result) / e0,
               energy_error=float(result.energy.balance_error))
    return out


def reference_run(folder: Path, eps: float, rtol: float = REFERENCE_RTOL,
                  t_stop: float = math.inf) -> dict:
    """The scene's chain at mass ratio ``eps`` by DOP853 (:func:`.chain_ode.integrate_chain`),
    sampled on the scene's frame times.

    Parameters
    ----------
    folder : Path
        The scenes' folder.
    eps : float
        Light mass over heavy mass.
    rtol : float
        DOP853's tolerance.
    t_stop : float
        Stop here if before the scene's t_end (scaled time units): once the peaks
        read are past, the rest of the run changes nothing.

    Returns
    -------
    dict
        :func:`pulse_decay`'s entries.
    """
    scene = scene_of(folder, SCENE)
    count, radius = int(scene.granules.count), float(scene.granules.radius)
    frame_dt, t_end = float(scene.output.dt), min(float(scene.run.t_end), t_stop)
    samples = frame_dt * np.arange(round(t_end / frame_dt) + 1)
    mass = np.where(np.arange(count) % 2 == 0, 1.0, eps)
    sol = integrate_chain(mass, 2.0 * radius * np.arange(count), np.r_[1.0, np.zeros(count - 1)],
                          np.full(count - 1, 2.0 * radius), k=float(scene.contacts.stiffness),
                          n=float(scene.contacts.exponent), t_end=t_end, rtol=rtol,
                          t_eval=samples)
    return pulse_decay(sol.t_samples, sol.v_samples)


def scan(run) -> dict:
    """The decay and transmission at every mass ratio of :data:`EPSILONS`.

    Parameters
    ----------
    run : callable(float) -> dict
        :func:`engine_run` at a mass ratio (the event stepper's, memoised).

    Returns
    -------
    dict
        ``eps``, ``rate``, ``transmission`` (lists), ``ordered`` (every run's peaks
        are the leading pulse's).
    """
    runs = [run(e) for e in EPSILONS]
    return {"eps": list(EPSILONS), "rate": [r["rate"] for r in runs],
            "transmission": [r["transmission"] for r in runs],
            "ordered": all(r["ordered"] for r in runs)}


def extrema(scanned: dict) -> dict:
    """The scan's interior local extrema of the decay, from the largest mass ratio down.

    Parameters
    ----------
    scanned : dict
        What :func:`scan` returned.

    Returns
    -------
    dict
        ``resonances`` (local minima) and ``anti_resonances`` (local maxima): lists of
        brackets ``(eps_below, eps_above)`` (the neighbouring scan points), the
        largest mass ratio first.
    """
    eps, rate = scanned["eps"], scanned["rate"]
    found = {"resonances": [], "anti_resonances": []}
    for i in range(len(eps) - 2, 0, -1):
        if rate[i] < rate[i - 1] and rate[i] < rate[i + 1]:
            found["resonances"].append((eps[i - 1], eps[i + 1]))
        elif rate[i] > rate[i - 1] and rate[i] > rate[i + 1]:
            found["anti_resonances"].append((eps[i - 1], eps[i + 1]))
    return found


def refine(run, bracket: tuple, sign: float) -> dict:
    """The extremum of the decay inside ``bracket`` by bounded Brent.

    Parameters
    ----------
    run : callable(float) -> dict
        :func:`engine_run` at a mass ratio (the event stepper's, memoised).
    bracket : tuple of float
        ``(eps_below, eps_above)``.
    sign : float
        +1 for a minimum (resonance), -1 for a maximum (anti-resonance).

    Returns
    -------
    dict
        ``eps`` (the optimum), ``evaluations`` (runs Brent took).
    """
    from scipy.optimize import minimize_scalar
    found = minimize_scalar(lambda e: sign * run(e)["rate"], bounds=bracket,
                            method="bounded", options={"xatol": XATOL})
    return {"eps": float(found.x), "evaluations": int(found.nfev)}


def _vertex(rates: tuple, centre: float, h: float) -> float:
    """Abscissa of the parabola's vertex through ``(centre + (i - 1) h, rates[i])``."""
    low, mid, high = rates
    return float(centre - 0.5 * h * (high - low) / (high - 2.0 * mid + low))


def _locate(folder: Path, run, kind: str, bracket: tuple) -> dict:
    """One extremum: the engine's (Brent), the parabolas through the engine's and the
    reference's decay at ``eps* - h, eps*, eps* + h``, the reference at ``eps*`` and its
    own error there (against :data:`TIGHTER_RTOL`)."""
    found = refine(run, bracket, 1.0 if kind == "resonance" else -1.0)
    centre, h = found["eps"], PARABOLA_STEP
    points = (centre - h, centre, centre + h)
    engine = [run(e) for e in points]
    # DOP853 stops five frames after the engine's last peak read (the reading needs two)
    stop = max(r["times"][LAST_CELL] for r in engine) + 5 * _frame_dt(folder)
    reference = [reference_run(folder, e, t_stop=stop) for e in points]
    tight = reference_run(folder, centre, TIGHTER_RTOL, stop)
    return {"kind": kind, "bracket": list(bracket), **found,
            "engine": engine[1], "reference": reference[1],
            "second_difference": engine[0]["rate"] - 2 * engine[1]["rate"] + engine[2]["rate"],
            "engine_vertex": _vertex(tuple(r["rate"] for r in engine), centre, h),
            "reference_vertex": _vertex(tuple(r["rate"] for r in reference), centre, h),
            "reference_error": {q: abs(tight[q] - reference[1][q])
                                for q in ("rate", "transmission")}}


def _frame_dt(folder: Path) -> float:
    """The scene's frame interval (scaled time units)."""
    return float(scene_of(folder, SCENE).output.dt)


def _verlet(folder: Path, eps: float) -> dict:
    """Verlet at :data:`VERLET_DT` and half of it, with Richardson's error estimate."""
    coarse = engine_run(folder, eps, "verlet")
    fine = engine_run(folder, eps, "verlet", VERLET_DT / 2)
    return {"dt": coarse, "half": fine,
            "error": {q: 4.0 / 3.0 * abs(coarse[q] - fine[q]) for q in ("rate", "transmission")}}


def compute(folder: Path) -> Outcome:
    """Run the experiment: the scan, the extrema, the reference, Verlet.

    Parameters
    ----------
    folder : Path
        The scenes' folder.

    Returns
    -------
    Outcome
        Its table and (``data``) the scan, every extremum (engine, reference, both
        parabolas), Verlet's runs and error estimates.

    Raises
    ------
    RuntimeError
        The scan found fewer than two resonances or no anti-resonance, or a run's
        peaks are not the leading pulse's.
    """
    run = lru_cache(maxsize=None)(partial(engine_run, folder))
    scanned = scan(run)
    found = extrema(scanned)
    if len(found["resonances"]) < 2 or not found["anti_resonances"] or not scanned["ordered"]:
        raise RuntimeError(f"dimers: the scan over {SCENE} did not show two resonances and an "
                           f"anti-resonance with the leading pulse's peaks: {found}")
    located = {"resonance 1": _locate(folder, run, "resonance", found["resonances"][0]),
               "resonance 2": _locate(folder, run, "resonance", found["resonances"][1]),
               "anti-resonance 1": _locate(folder, run, "anti-resonance",
                                           found["anti_resonances"][0])}
    verlet = {name: _verlet(folder, located[name]["eps"])
              for name in ("resonance 1", "anti-resonance 1")}
    rows = [row for name, d in located.items() for row in _rows(name, d)]
    rows += [row for name, d in verlet.items() for row in _verlet_rows(name, d, located[name])]
    data = {"scan": scanned, "extrema": found, "located": located, "verlet": verlet,
            "cells": [FIRST_CELL, LAST_CELL], "parabola_step": PARABOLA_STEP, "xatol": XATOL}
    return Outcome(rows=rows, data=data)


def _rows(name: str, d: dict) -> list:
    """The table's rows of one located extremum (event stepper against DOP853)."""
    ev, ref = d["engine"], d["reference"]
    where = f"at eps*={d['eps']:.5f}"
    parabola = f"vertex of the parabola through eps*, eps*+-{PARABOLA_STEP:g}"
    vertex, source = d["reference_vertex"], f"DOP853 rtol=1e-11, {parabola} (computed)"
    rows = [Row(f"{name}: mass ratio eps* ({'most' if 'anti' in name else 'least'} decay), "
                f"event + Brent", d["eps"], vertex, source),
            Row(f"{name}: decay rate per cell {where}, event", ev["rate"], ref["rate"], REFERENCE),
            Row(f"{name}: transmission v_p(cell {LAST_CELL})^2 {where}, event", ev["transmission"],
                ref["transmission"], REFERENCE)]
    if "anti" not in name:
        rows.append(Row(f"{name}: decay rate per cell {where}, event", ev["rate"], 0.0, NO_DECAY))
    rows += [Row(f"{name}: momentum after / before, event", ev["momentum"], 1.0, "conservation"),
             Row(f"{name}: energy after / before, event", ev["energy"], 1.0, "conservation")]
    return rows


def _verlet_rows(name: str, d: dict, located: dict) -> list:
    """The table's rows of Verlet at one located extremum."""
    ref, vv = located["reference"], d["dt"]
    where = f"at eps*={located['eps']:.5f}"
    return [Row(f"{name}: decay rate per cell {where}, Verlet dt={VERLET_DT}", vv["rate"],
                ref["rate"], REFERENCE),
            Row(f"{name}: transmission {where}, Verlet dt={VERLET_DT}", vv["transmission"],
                ref["transmission"], REFERENCE),
            Row(f"{name}: momentum after / before, Verlet dt={VERLET_DT}", vv["momentum"], 1.0,
                "conservation"),
            Row(f"{name}: energy after / before, Verlet dt={VERLET_DT}", vv["energy"], 1.0,
                "conservation")]


def figure(outcome: Outcome, path: Path) -> None:
    """Two panels: the decay rate per cell against the mass ratio (scan and located
    extrema, engine and reference), and the transmission against it.

    Parameters
    ----------
    outcome : Outcome
        What :func:`compute` returned.
    path : Path
        The PNG written.
    """
    s, located = outcome.data["scan"], outcome.data["located"]
    with figure_file(path, 2, (11, 4)) as (fig, (a, b)):
        a.plot(s["eps"], s["rate"], "o-", ms=3, color="tab:red", label="engine (event), scan")
        b.plot(s["eps"], s["transmission"], "o-", ms=3, color="tab:red",
               label="engine (event), scan")
        for name, d in located.items():
            style = "v" if d["kind"] == "resonance" else "^"
            a.plot(d["eps"], d["engine"]["rate"], style, color="k", ms=7)
            a.plot(d["reference_vertex"], d["reference"]["rate"], "x", color="tab:blue", ms=9)
            a.annotate(name, (d["eps"], d["engine"]["rate"]), textcoords="offset points",
                       xytext=(4, 6), fontsize=7)
            b.plot(d["eps"], d["engine"]["transmission"], style, color="k", ms=7)
        a.plot([], [], "kv", label="located by Brent (engine)")
        a.plot([], [], "x", color="tab:blue", label="DOP853 reference (parabola's vertex)")
        a.axhline(0.0, color="0.6", lw=0.8)
        a.set_yscale("symlog", linthresh=1e-5)  # the resonances' decay is 1e-7 .. 1e-5
        ticks = [0.15, 0.2, 0.3, 0.4, 0.6, 1.0]
        a.set_xscale("log")
        a.set_xticks(ticks, [f"{x:g}" for x in ticks])
        a.set_xlabel(r"mass ratio $\varepsilon$ (light / heavy)")
        a.set_ylabel(f"decay of ln v_p per cell (cells {FIRST_CELL}..{LAST_CELL})")
        a.legend(fontsize=8)
        b.set_xscale("log")
        b.set_xticks(ticks, [f"{x:g}" for x in ticks])
        b.set_xlabel(r"mass ratio $\varepsilon$ (light / heavy)")
        b.set_ylabel(f"transmission $v_p^2$ at cell {LAST_CELL}")
        b.legend(fontsize=8)
        fig.suptitle("Dimer chain struck by a heavy granule (scenarios/classics/dimers.yaml)",
                     fontsize=10)


EXPERIMENT = Experiment(
    name="dimers",
    title="Dimer chains: decay and transmission of the struck pulse against the mass ratio, "
          "resonances and anti-resonances located",
    scenes=(SCENE,), compute=compute, figure=figure)
