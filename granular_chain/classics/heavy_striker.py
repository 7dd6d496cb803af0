"""Experiment ``heavy_striker``: the train of solitary waves a heavy striker sheds.

Scene ``scenarios/classics/heavy_striker.yaml``: a striker of mass ``M`` (granule 0)
hits 99 equal Hertz spheres (mass ``m = 1``, force coefficient 1, scaled units) at
rest and just touching, at ``v0 = 1``; run for the mass ratios ``M/m`` of
:data:`RATIOS`. With ``M = m`` the striker stops (it rebounds at -0.0711 v0) and
one solitary wave leaves; with ``M > m`` the striker keeps pushing the chain and
sheds a train of solitary waves of decreasing amplitude, more and larger ones the
heavier it is (Job, Melo, Sokolow & Sen, Granular Matter 9, 159 (2007); Sen,
Hong, Bang, Avalos & Doney, Phys. Rep. 462, 21 (2008)). The literature gives the
trains as figures; the references here are computed:

1. The same equations integrated independently by scipy's DOP853 at
   rtol = atol = 3e-14 (:func:`.chain_ode.integrate_chain_at`) on a shorter
   chain (:data:`REF_COUNT` granules to :data:`REF_T`, before the leading wave
   reaches its end; on the full chain its contact events make it minutes long):
   the velocity of granule :data:`REF_PROBE` at the time the engine finds the
   leading wave's peak there, and every granule's and the striker's velocity at
   :data:`REF_T`, against the engine on that chain. Its own error is its change
   against a run at rtol 1e-13.
2. The physics: each separated wave is the exact discrete Hertz wave at its
   amplitude, so its speed (a straight-line fit of its peak times over granules
   :data:`FIT`) over ``v_max^(1/5)`` is the exact constant ``W_max^(-1/5)`` of
   :mod:`.hertz_wave`, 0.907470078412.
3. Momentum ``M v0`` and energy ``M v0^2 / 2`` at t_end.

Measured for every mass ratio (both steppers; Verlet's error by halving dt,
Richardson ``(4/3) |a(dt) - a(dt/2)|``): the amplitudes (peak velocity, units of
v0) of the leading waves at granule :data:`PROBE` and their ratios, the number of
waves above :data:`THRESHOLD` that have passed it by t_end, the speed constant of
each, and the striker's velocity at t_end (it has not left: a striker heavier than
the grains keeps shedding ever smaller waves, its velocity falling towards 0).
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

from .. import diagnostics as dg
from ..scene import read_scene_data, scene_from_dict
from ..simulate import simulate
from .chain_ode import integrate_chain_at
from .experiment import Experiment, Outcome, figure_file, final_energy
from .hertz_wave import solve_travelling_wave
from .table import Row, conservation_rows

__all__ = ["EXPERIMENT", "SCENE", "RATIOS", "PROBE", "FIT", "WAVES", "THRESHOLD",
           "VERLET_DT", "REF_COUNT", "REF_T", "REF_PROBE", "REFERENCE_RTOL", "run_train",
           "short_chain", "reference_train", "compute", "figure"]

SCENE = "heavy_striker.yaml"
#: Striker / grain mass ratios.
RATIOS = (1.0, 2.0, 3.0, 5.0, 10.0)
#: The granule whose velocity the amplitudes are read at.
PROBE = 70
#: The granules whose peak times give each wave's speed (inclusive).
FIT = (55, 70)
#: The leading waves measured (fewer where fewer have passed :data:`PROBE`).
WAVES = 3
#: Waves counted: peaks above this (units of v0) at :data:`PROBE` by t_end.
THRESHOLD = 0.05
#: Verlet's step (its error is measured at half of it).
VERLET_DT = 0.01
#: The reference's chain: granules, end time, the granule whose peak is compared.
REF_COUNT, REF_T, REF_PROBE = 40, 32.0, 20
#: The reference's tolerance (DOP853); its error is measured against rtol 1e-13.
REFERENCE_RTOL = 3e-14
REFERENCE = "DOP853 rtol=atol=3e-14, chain of 40 to t=32 (scipy, computed)"
EXACT = "exact discrete wave W_max^(-1/5) (Petviashvili, computed)"
STEPPERS = {"event": ("event", None), "verlet": ("verlet", VERLET_DT),
            "verlet_half": ("verlet", VERLET_DT / 2)}


def _scene(folder: Path, ratio: float, stepper: str, dt, count=None, t_end=None):
    """The scene with striker mass ``ratio`` and ``stepper`` (Verlet: frames every
    0.01 time units), optionally shortened to ``count`` granules and ``t_end``."""
    data = read_scene_data(Path(folder) / SCENE)
    count = int(count or data["granules"]["count"])
    data["granules"].update(count=count, mass=[float(ratio)] + [1.0] * (count - 1))
    if t_end is not None:
        data["run"]["t_end"] = float(t_end)
    if stepper == "verlet":
        data["run"].update(stepper="verlet", dt=dt)
        data["output"] = {"every": int(round(VERLET_DT / dt))}
    return scene_from_dict(data, source=f"{SCENE} (M/m = {ratio:g}, {stepper})")


def _humps(t: np.ndarray, v: np.ndarray, floor: float) -> list:
    """The velocity humps of one granule above ``floor``, in time order.

    Each hump's peak is its largest frame, refined by
    :func:`granular_chain.diagnostics.peak_times` (a parabola through it and its
    two neighbours); its valley is the least velocity before the next hump.

    Returns
    -------
    list of (t_peak, v_peak, v_valley_after)
    """
    inner = np.flatnonzero((v[1:-1] > v[:-2]) & (v[1:-1] >= v[2:]) & (v[1:-1] > floor)) + 1
    out = []
    for j, i in enumerate(inner):
        tp, vp = dg.peak_times(SimpleNamespace(t=t[i - 1:i + 2], v=v[i - 1:i + 2, None]), [0])
        hi = inner[j + 1] if j + 1 < inner.size else v.size
        out.append((float(tp[0]), float(vp[0]), float(np.min(v[i:hi]))))
    return out


def run_train(folder: Path, ratio: float, stepper: str, dt: float = VERLET_DT) -> dict:
    """Run the scene at mass ratio ``ratio`` and read its wave train.

    Parameters
    ----------
    folder : Path
        The scenes' folder.
    ratio : float
        Striker mass over grain mass.
    stepper : str
        ``event`` or ``verlet``.
    dt : float
        Verlet's step (scaled time units).

    Returns
    -------
    dict
        ``amplitude`` (peak velocity of each leading wave at :data:`PROBE`, units
        of v0, at most :data:`WAVES`), ``valley`` (the least velocity between a
        wave and the next at :data:`PROBE`, over the next's amplitude: near 0 once
        they have separated), ``drift`` (relative change of each amplitude from
        granule ``FIT[0]`` to :data:`PROBE`), ``speed`` (granules per unit time,
        fit over :data:`FIT`), ``waves`` (peaks above :data:`THRESHOLD` at
        :data:`PROBE`), ``train`` (every peak there, in order), ``striker`` (its
        velocity at t_end), ``momentum`` and ``energy`` at t_end over their
        initial values, ``energy_error`` (the run's ledger).
    """
    result = simulate(_scene(folder, ratio, stepper, dt), progress=False)
    t, v = np.asarray(result.t), np.asarray(result.v)
    trains = {g: _humps(t, v[:, g], 0.1 * THRESHOLD) for g in range(FIT[0], FIT[1] + 1)}
    probe, first = trains[PROBE], trains[FIT[0]]
    waves = min(WAVES, len(probe))
    speeds = [float(np.polyfit([trains[g][k][0] for g in trains], list(trains), 1)[0])
              for k in range(waves)]
    mass = np.r_[ratio, np.ones(v.shape[1] - 1)]
    return {"amplitude": [p[1] for p in probe[:waves]],
            "valley": [probe[k][2] / probe[k + 1][1] for k in range(waves - 1)],
            "drift": [probe[k][1] / first[k][1] - 1.0 for k in range(waves)],
            "speed": speeds, "waves": int(sum(p[1] > THRESHOLD for p in probe)),
            "train": [p[1] for p in probe], "striker": float(result.v_final[0]),
            "momentum": float(mass @ result.v_final) / ratio,
            "energy": final_energy(result) / (0.5 * ratio),
            "energy_error": float(result.energy.balance_error)}


def short_chain(folder: Path, ratio: float, stepper: str, dt: float = VERLET_DT) -> dict:
    """The engine on the reference's chain (:data:`REF_COUNT` granules to :data:`REF_T`).

    Parameters
    ----------
    folder : Path
        The scenes' folder.
    ratio : float
        Striker mass over grain mass.
    stepper : str
        ``event`` or ``verlet``.
    dt : float
        Verlet's step.

    Returns
    -------
    dict
        ``peak_time`` and ``amplitude`` (the leading wave's peak at
        :data:`REF_PROBE`), ``v_final`` (ndarray, at :data:`REF_T`).
    """
    scene = _scene(folder, ratio, stepper, dt, count=REF_COUNT, t_end=REF_T)
    result = simulate(scene, progress=False)
    tp, vp = _humps(np.asarray(result.t), np.asarray(result.v)[:, REF_PROBE], 0.01)[0][:2]
    return {"peak_time": tp, "amplitude": vp, "v_final": np.asarray(result.v_final)}


def reference_train(ratio: float, peak_time: float, rtol: float = REFERENCE_RTOL) -> dict:
    """The reference's chain by DOP853 (:func:`.chain_ode.integrate_chain_at`).

    Parameters
    ----------
    ratio : float
        Striker mass over grain mass.
    peak_time : float
        The engine's time of the leading wave's peak at :data:`REF_PROBE`.
    rtol : float
        DOP853's tolerance.

    Returns
    -------
    dict
        ``amplitude`` (velocity of :data:`REF_PROBE` at ``peak_time``),
        ``v_final`` (ndarray, at :data:`REF_T`).
    """
    count = REF_COUNT
    states = integrate_chain_at(np.r_[ratio, np.ones(count - 1)], 4.0 * np.arange(count),
                                np.r_[1.0, np.zeros(count - 1)], 4.0 * np.ones(count - 1),
                                [peak_time, REF_T], rtol=rtol)
    return {"amplitude": float(states[0].v[REF_PROBE]), "v_final": states[1].v}


def _measure(folder: Path, ratio: float) -> dict:
    """Every run at one mass ratio: the trains, the short chains, the reference."""
    d = {key: run_train(folder, ratio, s, dt or VERLET_DT) for key, (s, dt) in STEPPERS.items()}
    short = {key: short_chain(folder, ratio, s, dt or VERLET_DT)
             for key, (s, dt) in STEPPERS.items()}
    t_peak = short["event"]["peak_time"]
    ref, loose = reference_train(ratio, t_peak), reference_train(ratio, t_peak, 1e-13)
    d["reference"] = {"amplitude": ref["amplitude"], "striker": float(ref["v_final"][0]),
                      "error": float(max(abs(ref["amplitude"] - loose["amplitude"]),
                                         np.max(np.abs(ref["v_final"] - loose["v_final"]))))}
    d["short"] = {k: {"amplitude": s["amplitude"], "striker": float(s["v_final"][0]),
                      "state_diff": float(np.max(np.abs(s["v_final"] - ref["v_final"])))}
                  for k, s in short.items()}
    d["verlet_error"] = {
        "amplitude": [4.0 / 3.0 * abs(a - b) for a, b in
                      zip(d["verlet"]["amplitude"], d["verlet_half"]["amplitude"])],
        "striker": 4.0 / 3.0 * abs(d["verlet"]["striker"] - d["verlet_half"]["striker"]),
        "short_amplitude": 4.0 / 3.0 * abs(short["verlet"]["amplitude"]
                                           - short["verlet_half"]["amplitude"])}
    return d


def _rows(ratio: float, d: dict, constant: float) -> list:
    """The table's rows for one mass ratio."""
    tag, ev, vv = f"M/m={ratio:g}", d["event"], d["verlet"]
    rows = []
    for s, name in (("event", "event"), ("verlet", f"Verlet dt={VERLET_DT}")):
        rows.append(Row(f"{tag} wave 1 peak v/v0 at granule {REF_PROBE} (chain of "
                        f"{REF_COUNT}), {name}", d["short"][s]["amplitude"],
                        d["reference"]["amplitude"], REFERENCE))
        rows.append(Row(f"{tag} striker v/v0 at t={REF_T:g} (chain of {REF_COUNT}), {name}",
                        d["short"][s]["striker"], d["reference"]["striker"], REFERENCE))
    for k, (a, c) in enumerate(zip(ev["amplitude"], ev["speed"])):
        rows.append(Row(f"{tag} wave {k + 1} peak v/v0 at granule {PROBE}, Verlet dt={VERLET_DT}",
                        vv["amplitude"][k], a, "engine, event stepper"))
        rows.append(Row(f"{tag} wave {k + 1}: c/v_max^(1/5) (granules {FIT[0]}..{FIT[1]}), "
                        f"event (v_max={a:.6g})", c / a ** 0.2, constant, EXACT))
    rows += [Row(f"{tag} wave {k + 2}/wave {k + 1} amplitude ratio, Verlet dt={VERLET_DT}",
                 vv["amplitude"][k + 1] / vv["amplitude"][k],
                 ev["amplitude"][k + 1] / ev["amplitude"][k], "engine, event stepper")
             for k in range(len(ev["amplitude"]) - 1)]
    rows.append(Row(f"{tag} striker v/v0 at t_end, Verlet dt={VERLET_DT}", vv["striker"],
                    ev["striker"], "engine, event stepper"))
    return rows + conservation_rows(tag, d, "M v0", "(M v0^2/2)")


def compute(folder: Path) -> Outcome:
    """Run the experiment for every mass ratio of :data:`RATIOS`.

    Parameters
    ----------
    folder : Path
        The scenes' folder.

    Returns
    -------
    Outcome
        Its table and (``data``, keyed by the mass ratio) every number behind it:
        per stepper the train (:func:`run_train`), the short chain and the
        reference, Verlet's error estimates.
    """
    constant = solve_travelling_wave().speed_constant
    rows, data = [], {"exact_constant": constant}
    for ratio in RATIOS:
        d = _measure(folder, ratio)
        rows += _rows(ratio, d, constant)
        data[f"{ratio:g}"] = d
    return Outcome(rows=rows, data=data)


def figure(outcome: Outcome, path: Path) -> None:
    """Two panels: the peaks of the train at granule :data:`PROBE` for each mass
    ratio (event stepper), and each measured wave's speed against its amplitude
    with the exact ``c = W_max^(-1/5) v_max^(1/5)``.

    Parameters
    ----------
    outcome : Outcome
        What :func:`compute` returned.
    path : Path
        The PNG written.
    """
    d = outcome.data
    with figure_file(path, 2, (11, 4)) as (fig, (a, b)):
        amps, speeds = [], []
        for ratio in RATIOS:
            ev = d[f"{ratio:g}"]["event"]
            train = np.asarray(ev["train"])
            a.semilogy(np.arange(1, train.size + 1), train, "o-", ms=3, label=f"M/m = {ratio:g}")
            amps += ev["amplitude"]
            speeds += ev["speed"]
        a.axhline(THRESHOLD, color="k", lw=0.5, ls=":")
        a.set_xlabel(f"wave (in the order it passes granule {PROBE})")
        a.set_ylabel(r"peak velocity / $v_0$")
        a.legend(fontsize=8)
        line = np.geomspace(min(amps) * 0.8, max(amps) * 1.2, 50)
        b.loglog(line, d["exact_constant"] * line ** 0.2, "k-", lw=1,
                 label=r"exact wave $W_{max}^{-1/5} v_{max}^{1/5}$")
        b.loglog(amps, speeds, "o", color="tab:red", ms=4, label="engine (event): waves 1-3")
        b.set_xlabel(r"wave amplitude $v_{max}/v_0$")
        b.set_ylabel("wave speed (granules per unit time)")
        b.legend(fontsize=8)
        fig.suptitle("Heavy striker: trains of solitary waves "
                     "(scenarios/classics/heavy_striker.yaml)", fontsize=10)


EXPERIMENT = Experiment(
    name="heavy_striker",
    title="Heavy striker, M/m = 1..10: the train of solitary waves, amplitudes, speeds, "
          "striker, momentum, energy",
    scenes=(SCENE,), compute=compute, figure=figure)
