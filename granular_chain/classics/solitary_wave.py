"""Experiment ``solitary_wave``: the Hertz solitary wave after an equal-mass striker.

Scene ``scenarios/classics/solitary_wave.yaml`` (100 Hertz spheres, scaled units,
granule 0 at v0 = 1). Three measurements, each against a reference computed
apart from the engine:

1. The exact wave. The chain is seeded with the exact discrete travelling wave
   of :mod:`.hertz_wave` (peak velocity 1) and run for 20 granules' travel;
   the engine's speed is the shift that best maps its final state onto the
   wave, over ``v_max^(1/5)``: against ``W_max^(-1/5) = 0.907470078412``. The
   event stepper holds it to roundoff; Verlet to its error, measured by
   halving dt (Richardson: ``(4/3) |c(dt) - c(dt/2)|``).
2. The struck chain (both steppers): speed over ``v_max^(1/5)`` from per-granule
   peak times (:func:`granular_chain.diagnostics.pulse_speed`), against the exact
   constant and Nesterenko's long-wave ``(16/25)^(1/5)``; the width at half
   maximum; the share of the striker's energy in the wave, against the exact
   wave's energy at the engine's peak velocity; the striker's rebound, against
   the independent DOP853 integration (:mod:`.chain_ode`).
3. The ``v0^(1/5)`` scaling over four decades (v0 = 1e-3 .. 10, event stepper;
   radii scaled as ``v0^(4/5)``, which the dynamics never sees but the overlap
   check does).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import diagnostics as dg
from ..scene import read_scene_data, scene_from_dict
from ..simulate import simulate
from .chain_ode import integrate_chain
from .experiment import Experiment, Outcome, figure_file, scene_of
from .hertz_wave import NESTERENKO_CONSTANT, TravellingWave, solve_travelling_wave
from .table import Row

__all__ = ["EXPERIMENT", "seeded_speed", "struck_chain", "scaling", "compute", "figure",
           "SCENE", "V0S", "VERLET_DT", "NESTERENKO_CONSTANT", "REBOUND_SOURCE"]

SCENE = "solitary_wave.yaml"
#: Striker speeds of the scaling measurement (scaled units).
V0S = (1e-3, 1e-2, 1e-1, 1.0, 10.0)
#: Verlet's step for the struck and seeded chains (its error is measured at half of it).
VERLET_DT = 0.01
EXACT = "exact discrete wave (Petviashvili, computed)"
REBOUND_SOURCE = "DOP853 rtol=atol=3e-14 (scipy, computed)"
_SEED_COUNT, _SEED_CENTRE, _SEED_TRAVEL = 50, 12.0, 20


def _seed(wave: TravellingWave, c: float):
    """Overlaps (per contact) and velocities of the chain seeded with the wave of
    speed ``c`` centred at granule :data:`_SEED_CENTRE`, at ``x``-offset ``shift``."""
    def state(shift: float):
        i = np.arange(_SEED_COUNT) - _SEED_CENTRE - shift
        inside = np.abs(i) < 15.0  # the grid's period is 40: no image of the wave
        r = np.where(inside[1:], c ** 4 * np.maximum(wave.profile(i[1:]), 0.0), 0.0)
        v = np.where(inside, c ** 5 * wave.scaled_velocity(i), 0.0)
        return r, v
    return state


def seeded_speed(folder: Path, wave: TravellingWave, stepper: str,
                 dt: float = VERLET_DT) -> dict:
    """Run the chain seeded with the exact wave (peak velocity 1) for
    :data:`_SEED_TRAVEL` granules and measure its speed.

    Parameters
    ----------
    folder : Path
        The scenes' folder.
    wave : TravellingWave
        The exact wave.
    stepper : str
        ``event`` or ``verlet``.
    dt : float
        Verlet's step (scaled time units).

    Returns
    -------
    dict
        ``constant`` (measured speed / v_max^(1/5), granules per unit time),
        ``misfit`` (largest state difference from the shifted wave after the fit,
        units of v_max), ``energy_error`` (the run's ledger).
    """
    c = wave.speed(1.0)
    state = _seed(wave, c)
    r0, v0 = state(0.0)
    t_end = _SEED_TRAVEL / c
    data = read_scene_data(Path(folder) / SCENE)
    data["granules"].update(count=_SEED_COUNT, radius=2.0, gap=[float(-g) for g in r0],
                            velocity=[float(v) for v in v0])
    data["run"] = ({"stepper": "event", "t_end": t_end} if stepper == "event" else
                   {"stepper": "verlet", "t_end": t_end, "dt": dt})
    # the first and last frames only (a Verlet output.dt would shorten dt to fit it)
    data["output"] = {"dt": t_end} if stepper == "event" else {"every": 1_000_000}
    result = simulate(scene_from_dict(data, source=f"{SCENE} (seeded)"), progress=False)
    r_end = 4.0 - np.diff(result.x_final)
    r_ref, v_ref = state(_SEED_TRAVEL)
    h = 1e-4  # derivative of the state along the shift (central difference)
    (rp, vp), (rm, vm) = state(_SEED_TRAVEL + h), state(_SEED_TRAVEL - h)
    slope = np.concatenate([(rp - rm), (vp - vm)]) / (2 * h)
    miss = np.concatenate([r_end - r_ref, result.v_final - v_ref])
    ds = float(slope @ miss / (slope @ slope))  # least-squares extra shift
    return {"constant": (_SEED_TRAVEL + ds) / t_end,
            "misfit": float(np.max(np.abs(miss - ds * slope))),
            "energy_error": float(result.energy.balance_error)}


def _half_max_duration(t: np.ndarray, v: np.ndarray) -> float:
    """Time a velocity pulse stays above half its largest sample (linear crossings)."""
    j = int(np.argmax(v))
    half = 0.5 * v[j]
    a = j - int(np.argmax(v[j::-1] < half))  # last sample below half, before the peak
    b = j + int(np.argmax(v[j:] < half))  # first sample below half, after it
    ta = t[a] + (half - v[a]) * (t[a + 1] - t[a]) / (v[a + 1] - v[a])
    tb = t[b - 1] + (half - v[b - 1]) * (t[b] - t[b - 1]) / (v[b] - v[b - 1])
    return float(tb - ta)


def struck_chain(folder: Path, wave: TravellingWave, stepper: str) -> dict:
    """The scene as written (granule 0 strikes at v0 = 1) with ``stepper``.

    Parameters
    ----------
    folder : Path
        The scenes' folder.
    wave : TravellingWave
        The exact wave (for its energy constant).
    stepper : str
        ``event`` or ``verlet`` (at :data:`VERLET_DT`, frames every step).

    Returns
    -------
    dict
        ``constant`` (speed / v_max^(1/5)), ``speed`` (granules per unit time),
        ``v_max`` (units of v0), ``fwhm`` (granules, at granule 80), ``share``
        (energy ahead of the wave's tail / E0), ``share_exact`` (the exact wave's
        energy at ``v_max`` / E0), ``rebound`` (striker's final velocity / v0),
        ``energy_error``, ``profile`` (granule 80's velocity against the distance
        to its peak, granules).
    """
    over = [] if stepper == "event" else [
        "run.stepper=verlet", f"run.dt={VERLET_DT}", "output.dt=null", "output.every=1"]
    scene = scene_of(folder, SCENE, over)
    result = simulate(scene, progress=False)
    fit = dg.pulse_speed(result, 20, 90)
    v = np.asarray(result.v)
    tp, _ = dg.peak_times(result, [80])
    x = fit.speed * (tp[0] - result.t)  # distance behind (-) and ahead (+) of the peak
    v_end, x_end = result.v_final, result.x_final
    front = int(np.argmax(v_end)) - 6  # the wave and what is ahead of it
    overlap = np.maximum(2.0 * float(scene.granules.radius) - np.diff(x_end[front:]), 0.0)
    e0 = 0.5 * float(v[0, 0]) ** 2
    share = (0.5 * np.sum(v_end[front:] ** 2) + 0.4 * np.sum(overlap ** 2.5)) / e0
    near = np.abs(x) < 4.0
    return {"constant": fit.speed / fit.v_peak ** 0.2, "speed": fit.speed,
            "v_max": fit.v_peak, "fwhm": fit.speed * _half_max_duration(result.t, v[:, 80]),
            "share": float(share), "share_exact": wave.energy_constant() * fit.v_peak ** 2 / e0,
            "rebound": float(v_end[0]), "energy_error": float(result.energy.balance_error),
            "profile": {"x": x[near].tolist(), "v": (v[near, 80] / fit.v_peak).tolist()}}


def scaling(folder: Path) -> dict:
    """Speed over ``v0^(1/5)`` of the struck chain (40 granules, event stepper) at
    each striker speed of :data:`V0S`.

    Parameters
    ----------
    folder : Path
        The scenes' folder.

    Returns
    -------
    dict
        ``v0`` (list), ``constant`` (speed / v0^(1/5), granules per unit time, list),
        ``slope`` (of log speed against log v0).
    """
    speeds = []
    for v0 in V0S:
        s = v0 ** -0.2  # the time scale
        scene = scene_of(folder, SCENE, [
            "granules.count=40", f"granules.velocity={{0: {v0!r}}}",
            f"granules.radius={v0 ** 0.8!r}", f"run.t_end={45 * s!r}", f"output.dt={0.01 * s!r}"])
        speeds.append(dg.pulse_speed(simulate(scene, progress=False), 10, 34).speed)
    slope = float(np.polyfit(np.log(V0S), np.log(speeds), 1)[0])
    return {"v0": list(V0S), "constant": [c / v ** 0.2 for c, v in zip(speeds, V0S)],
            "slope": slope}


def _rebound_reference() -> tuple:
    """The striker's rebound by DOP853 (20 granules to t = 60; the striker leaves
    within the first granules, so a longer chain does not change it), and that
    reference's own error (against a run at rtol 1e-13)."""
    count = 20
    args = (np.ones(count), 2.0 * np.arange(count), np.r_[1.0, np.zeros(count - 1)],
            2.0 * np.ones(count - 1))
    ref = integrate_chain(*args, t_end=60.0, rtol=3e-14)
    loose = integrate_chain(*args, t_end=60.0, rtol=1e-13)
    return float(ref.v[0]), abs(float(loose.v[0] - ref.v[0]))


def compute(folder: Path) -> Outcome:
    """Run the experiment: the exact wave, the struck chain, the scaling.

    Parameters
    ----------
    folder : Path
        The scenes' folder.

    Returns
    -------
    Outcome
        Its table and (``data``) every number and curve behind it.
    """
    wave = solve_travelling_wave()
    exact = wave.speed_constant
    seeded = {"event": seeded_speed(folder, wave, "event"),
              "verlet": seeded_speed(folder, wave, "verlet"),
              "verlet_half": seeded_speed(folder, wave, "verlet", VERLET_DT / 2)}
    verlet_error = 4.0 / 3.0 * abs(seeded["verlet"]["constant"] - seeded["verlet_half"]["constant"])
    struck = {s: struck_chain(folder, wave, s) for s in ("event", "verlet")}
    scale = scaling(folder)
    rebound, rebound_error = _rebound_reference()
    ev = struck["event"]
    rows = [
        Row("c/v_max^(1/5), exact wave seeded, event", seeded["event"]["constant"], exact, EXACT),
        Row(f"c/v_max^(1/5), exact wave seeded, Verlet dt={VERLET_DT}",
            seeded["verlet"]["constant"], exact, EXACT),
        Row("c/v_max^(1/5), struck chain, event", ev["constant"], exact, EXACT),
        Row(f"c/v_max^(1/5), struck chain, Verlet dt={VERLET_DT}", struck["verlet"]["constant"],
            exact, EXACT),
        Row("c/v_max^(1/5), struck chain, event", ev["constant"], NESTERENKO_CONSTANT,
            "Nesterenko 1983, long-wave limit (16/25)^(1/5)"),
        Row("FWHM of the velocity pulse (granules), event", ev["fwhm"], wave.fwhm(), EXACT),
        Row("energy share of the wave E_w/E0, event", ev["share"], ev["share_exact"],
            "exact wave's energy 1.0693 v_max^2 at the engine's v_max"),
        Row("striker's rebound v/v0, event", ev["rebound"], rebound, REBOUND_SOURCE),
        Row(f"striker's rebound v/v0, Verlet dt={VERLET_DT}", struck["verlet"]["rebound"],
            rebound, REBOUND_SOURCE),
    ]
    base = scale["constant"][V0S.index(1.0)]
    rows += [Row(f"c/v0^(1/5) at v0={v0:g} (struck, event)", c, base,
                 "v0^(1/5) scaling: the value at v0=1") for v0, c in zip(V0S, scale["constant"])
             if v0 != 1.0]
    rows.append(Row("log-log slope of c against v0", scale["slope"], 0.2,
                    "v0^(1/5) scaling (Nesterenko)"))
    data = {"exact_constant": exact, "nesterenko_constant": NESTERENKO_CONSTANT,
            "exact_fwhm": wave.fwhm(), "exact_energy_constant": wave.energy_constant(),
            "petviashvili": {"iterations": wave.iterations, "residual": wave.residual},
            "seeded": seeded, "verlet_error_estimate": verlet_error, "struck": struck,
            "scaling": scale, "rebound_reference_error": rebound_error,
            "exact_profile": _exact_profile(wave)}
    return Outcome(rows=rows, data=data)


def _exact_profile(wave: TravellingWave) -> dict:
    """The exact wave's velocity ``v/v_max`` against the distance to its peak (granules)."""
    x = np.linspace(-4.0, 4.0, 321)
    return {"x": x.tolist(), "v": (wave.scaled_velocity(x - 0.5) / wave.w_max).tolist()}


def figure(outcome: Outcome, path: Path) -> None:
    """Two panels: the struck wave's velocity profile against the exact wave's, and
    speed over ``v0^(1/5)`` across four decades of v0.

    Parameters
    ----------
    outcome : Outcome
        What :func:`compute` returned.
    path : Path
        The PNG written.
    """
    d = outcome.data
    with figure_file(path, 2, (11, 4)) as (fig, (a, b)):
        a.plot(d["exact_profile"]["x"], d["exact_profile"]["v"], "k-", lw=1.5,
               label="exact discrete wave")
        p = d["struck"]["event"]["profile"]
        a.plot(p["x"][::20], p["v"][::20], "o", ms=3, color="tab:red",
               label="engine: granule 80 after the striker (event)")
        a.set_xlabel("distance to the peak (granules)")
        a.set_ylabel(r"$v / v_{max}$")
        a.legend(fontsize=8, loc="upper left")
        s = d["scaling"]
        v0 = np.asarray(s["v0"])
        b.loglog(v0, np.asarray(s["constant"]) * v0 ** 0.2, "o", color="tab:red",
                 label="engine (event), struck chain of 40")
        line = np.geomspace(v0[0], v0[-1], 50)
        b.loglog(line, s["constant"][list(V0S).index(1.0)] * line ** 0.2, "k-", lw=1,
                 label=r"$c(v_0 = 1)\,v_0^{1/5}$ (slope %.10f)" % s["slope"])
        b.set_xlabel(r"striker speed $v_0$")
        b.set_ylabel("wave speed (granules per unit time)")
        b.legend(fontsize=8)
        fig.suptitle("Hertz solitary wave (scenarios/classics/solitary_wave.yaml)", fontsize=10)


EXPERIMENT = Experiment(
    name="solitary_wave",
    title="Hertz solitary wave after an equal-mass striker: speed, width, energy, rebound, "
          "v0^(1/5) scaling",
    scenes=(SCENE,), compute=compute, figure=figure)
