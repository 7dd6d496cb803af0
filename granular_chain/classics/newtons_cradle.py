"""Experiment ``newtons_cradle``: a row of touching Hertz balls struck by one of them.

Scene ``scenarios/classics/newtons_cradle.yaml`` run for 2..10 balls (scaled units,
ball 0 at v0 = 1 into the others). With linear or hard-sphere contacts the cradle
would send the last ball off at v0 and leave the others at rest; with Hertz
contacts the pulse disperses on a short row and it does not: the last ball leaves
slower, the ones before it with small velocities, the first ones backwards
(Herrmann & Schmaelzle, Am. J. Phys. 49, 761 (1981); Herrmann & Seitz, Am. J.
Phys. 50, 977 (1982); Hutzler, Delaney, Weaire & MacLeod, Am. J. Phys. 72, 1065
(2004)). Those papers give these velocities as figures and to a few digits;
the reference here is computed: the same equations integrated independently by
scipy's DOP853, restarted at every contact opening and closing (:mod:`.chain_ode`),
the median of five runs at rtol = atol = 2.5e-14 .. 5e-14, whose own error (the
spread of the three runs nearest the median) is recorded.

Measured for every row length: the final velocity of every ball from the event
stepper (to 1e-10 of the reference) and from Verlet at dt = 0.01, whose error
is estimated by halving dt (Richardson: ``(4/3) |v(dt) - v(dt/2)|``), and the
momentum and energy after the collision against their values before.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..simulate import simulate
from .chain_ode import integrate_chain
from .experiment import Experiment, Outcome, figure_file, final_energy, scene_of
from .table import Row

__all__ = ["EXPERIMENT", "COUNTS", "VERLET_DT", "REFERENCE_RTOLS", "final_velocities",
           "reference_velocities", "compute", "figure", "SCENE"]

SCENE = "newtons_cradle.yaml"
#: Row lengths (balls, the striker included).
COUNTS = tuple(range(2, 11))
#: Verlet's step (its error is measured at half of it).
VERLET_DT = 0.01
#: The reference's tolerances (DOP853, relative and absolute): it is the median of the
#: runs at each. At tolerances this close to roundoff a single DOP853 run can land
#: 1e-11 off the others at 10 balls (scipy 1.17: 3e-14 and 5e-14 do, 2.5e-14, 3.5e-14,
#: 4e-14 agree with each other and with the event stepper within 2e-12), so one run
#: at one tolerance is not a reference to 1e-11.
REFERENCE_RTOLS = (2.5e-14, 3e-14, 3.5e-14, 4e-14, 5e-14)
REFERENCE = "DOP853 rtol=atol=2.5e-14..5e-14, median of 5 (scipy, computed)"


def final_velocities(folder: Path, count: int, stepper: str, dt: float = VERLET_DT) -> dict:
    """Run the cradle of ``count`` balls with ``stepper`` to the scene's t_end.

    Parameters
    ----------
    folder : Path
        The scenes' folder.
    count : int
        Balls in the row, the striker included.
    stepper : str
        ``event`` or ``verlet``.
    dt : float
        Verlet's step (scaled time units).

    Returns
    -------
    dict
        ``v`` (final velocities, units of v0, list), ``momentum`` and ``energy``
        (final, kinetic plus contact), ``energy_error`` (the run's ledger),
        ``separated`` (every contact open and every ball slower than the next: no
        collision is left).
    """
    over = [f"granules.count={count}"]
    if stepper == "verlet":
        over += ["run.stepper=verlet", f"run.dt={dt!r}", "output.dt=null",
                 "output.every=1000000"]
    result = simulate(scene_of(folder, SCENE, over), progress=False)
    v, x = result.v_final, result.x_final
    gaps = np.diff(x) - 2.0  # radius 1
    return {"v": v.tolist(), "momentum": float(v.sum()), "energy": final_energy(result),
            "energy_error": float(result.energy.balance_error),
            "separated": bool(np.all(gaps > 0.0) and np.all(np.diff(v) >= 0.0))}


def reference_velocities(count: int, t_end: float = 60.0) -> dict:
    """The cradle of ``count`` balls by DOP853 (:func:`.chain_ode.integrate_chain`).

    Parameters
    ----------
    count : int
        Balls in the row.
    t_end : float
        End time (scaled units; the scene's).

    Returns
    -------
    dict
        ``v`` (final velocities, list: each the median of the runs at
        :data:`REFERENCE_RTOLS`) and ``error`` (the largest distance from ``v`` of
        the three runs nearest to it, a majority: two runs off by roundoff do not
        move the median and are not counted).
    """
    args = (np.ones(count), 2.0 * np.arange(count), np.r_[1.0, np.zeros(count - 1)],
            2.0 * np.ones(count - 1))
    runs = np.array([integrate_chain(*args, t_end=t_end, rtol=r).v for r in REFERENCE_RTOLS])
    v = np.median(runs, axis=0)
    distance = np.sort(np.max(np.abs(runs - v), axis=1))
    return {"v": v.tolist(), "error": float(distance[len(runs) // 2])}


def _rows(count: int, d: dict) -> list:
    """The table's rows for the row of ``count`` balls."""
    ref, ev, vv = d["reference"]["v"], d["event"]["v"], d["verlet"]["v"]
    source = REFERENCE
    if count == 2:  # equal elastic balls exchange their velocities exactly
        ref, source = [0.0, 1.0], "exact exchange (equal masses, elastic)"
    rows = [Row(f"N={count} v[{i}]/v0, event", ev[i], ref[i], source)
            for i in range(count)]
    rows += [Row(f"N={count} v[{i}]/v0, Verlet dt={VERLET_DT}", vv[i], ref[i], source)
             for i in (0, count - 1)]
    rows += [Row(f"N={count} momentum after / before, {s}", d[s]["momentum"], 1.0,
                 "conservation") for s in ("event", "verlet")]
    rows += [Row(f"N={count} energy after / before, {s}", d[s]["energy"] / 0.5, 1.0,
                 "conservation") for s in ("event", "verlet")]
    return rows


def compute(folder: Path) -> Outcome:
    """Run the experiment for every row length of :data:`COUNTS`.

    Parameters
    ----------
    folder : Path
        The scenes' folder.

    Returns
    -------
    Outcome
        Its table and (``data``, keyed by the row length) every velocity behind it,
        with Verlet's error estimate ``verlet_error`` (per ball).
    """
    rows, data = [], {}
    t_end = float(scene_of(folder, SCENE).run.t_end)
    for count in COUNTS:
        d = {"reference": reference_velocities(count, t_end),
             "event": final_velocities(folder, count, "event"),
             "verlet": final_velocities(folder, count, "verlet"),
             "verlet_half": final_velocities(folder, count, "verlet", VERLET_DT / 2)}
        d["verlet_error"] = (4.0 / 3.0 * np.abs(np.subtract(d["verlet"]["v"],
                                                            d["verlet_half"]["v"]))).tolist()
        bad = [s for s in ("event", "verlet", "verlet_half") if not d[s]["separated"]]
        if bad:
            raise RuntimeError(f"newtons_cradle: N={count}: a collision is left at t_end "
                               f"({', '.join(bad)}): raise run.t_end in {SCENE}")
        rows += _rows(count, d)
        data[str(count)] = d
    return Outcome(rows=rows, data=data)


def figure(outcome: Outcome, path: Path) -> None:
    """Final velocity of every ball against its place in the row, one line per row
    length (event stepper), on a symmetric-log axis that shows the small ones.

    Parameters
    ----------
    outcome : Outcome
        What :func:`compute` returned.
    path : Path
        The PNG written.
    """
    with figure_file(path, 1, (7, 4.2)) as (fig, ax):
        for key, d in outcome.data.items():
            v = np.asarray(d["event"]["v"])
            ax.plot(np.arange(v.size) - v.size + 1, v, "o-", ms=3, label=f"N = {key}")
        ax.set_yscale("symlog", linthresh=1e-3)
        ax.set_xlabel("ball, counted from the last (0 = last)")
        ax.set_ylabel(r"final velocity / $v_0$")
        ax.set_title("Newton's cradle, Hertz contacts (event stepper)", fontsize=10)
        ax.legend(fontsize=7, ncol=3)
        ax.grid(alpha=0.3)


EXPERIMENT = Experiment(
    name="newtons_cradle",
    title="Newton's cradle with Hertz contacts, 2..10 balls: final velocities, momentum, "
          "energy",
    scenes=(SCENE,), compute=compute, figure=figure)
