"""Experiment ``backscatter_friction``: the paper's two-granule backscattering against
the first granule of a longer chain, over the friction eta.

Scene ``scenarios/classics/backscatter_friction.yaml``: equal spheres, just touching,
scaled units (m = 1, force coefficient 1), granule 0 striking the others at v0 = 1;
the run stops when granule 0 leaves granule 1 (``stop: separation`` at contact 0),
its velocity then being the backscatter velocity ``v1^(s)`` of Rosas, Buceta &
Lindenberg, "Dynamics of two granules" (the paper, ``../shared/seed``). Two places
for the Coulomb friction eta, the paper's two sections:

* ``struck`` (Sec. II A): eta on every struck granule, none on the striker. For two
  granules and n = 2 the striker leaves at ``v1^(s) = -eta pi / (2 sqrt 2)`` exactly
  (for eta < 0.669), the paper's "friction on the second granule causes the first
  granule to move backward".
* ``striker`` (Sec. II B): eta on the striker only. Two granules with n = 2
  backscatter while eta < 0.2195624104 (the root of t_stop = t1, exact); beyond it the
  striker is held before the contact opens.

For N = 2, 3, 20 and n = 2, 5/2 the engine's event stepper gives the striker's
velocity at separation, and where backscattering ends under striker friction
(bisection on eta). The references: the paper's closed forms (two granules, n = 2,
:mod:`granular_chain.paper`, 30 digits) and, for every case, the same equations
with the same friction integrated independently by DOP853 at rtol = 3e-14,
restarted at every contact and friction event (:mod:`.chain_ode`), its own error
measured against rtol 1e-13. Verlet at dt = 0.02, 0.01, 0.005 against DOP853 (its
error is not smooth in dt here: stick, slip and the separation fall within a step).
As the paper's outlook says, a chain throws its striker back where two
granules do not: without friction (0.0711 v0 for n = 5/2) and, under striker
friction, beyond the two-granule edge.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..paper.coulomb_on_granule1 import iib_backscatter_threshold_eta_exact, iib_collision_exact
from ..paper.coulomb_on_granule2 import iia_v1s
from ..simulate import simulate
from .chain_ode import integrate_chain
from .experiment import Experiment, Outcome, figure_file, scene_of
from .table import Row

__all__ = ["EXPERIMENT", "SCENE", "CASES", "COUNTS", "EXPONENTS", "ETAS", "VERLET_DT",
           "REFERENCE_RTOL", "EDGE_TOL", "frictions", "engine_backscatter",
           "reference_backscatter", "backscatter_edge", "compute", "figure"]

SCENE = "backscatter_friction.yaml"
#: Where the friction acts: the paper's section for each.
CASES = {"struck": "Sec. II A, eta on the struck granules",
         "striker": "Sec. II B, eta on the striker"}
#: Granules in the chain, the striker included.
COUNTS = (2, 3, 20)
#: Potential exponents (force delta^(n-1)).
EXPONENTS = (2.0, 2.5)
#: Friction values of each case (Sec. II A's closed form holds for eta < 0.669).
ETAS = {"struck": (0.0, 0.05, 0.1, 0.2, 0.3, 0.5, 0.6),
        "striker": (0.025, 0.05, 0.1, 0.15, 0.2)}
#: Verlet's step (its error is measured at half of it).
VERLET_DT = 0.01
#: The DOP853 reference's tolerance; its error is measured against a run at 1e-13.
REFERENCE_RTOL = 3e-14
#: Width to which the edge of backscattering is bisected (eta, absolute).
EDGE_TOL = 1e-10
DOP853 = "DOP853 rtol=atol=3e-14 with friction (scipy, computed)"


def frictions(case: str, count: int, eta: float) -> list:
    """Each granule's Coulomb friction force for ``case``.

    Parameters
    ----------
    case : str
        A key of :data:`CASES`.
    count : int
        Granules in the chain.
    eta : float
        Friction force, scaled units (m v0^2 / length).

    Returns
    -------
    list of float, length ``count``
    """
    if case == "struck":
        return [0.0] + [eta] * (count - 1)
    return [eta] + [0.0] * (count - 1)


def engine_backscatter(folder: Path, case: str, n: float, count: int, eta: float,
                       stepper: str = "event", dt: float = VERLET_DT) -> dict:
    """The striker's velocity when it leaves granule 1, by the engine.

    Parameters
    ----------
    folder : Path
        The scenes' folder.
    case : str
        A key of :data:`CASES`.
    n : float
        Potential exponent.
    count : int
        Granules in the chain.
    eta : float
        Friction force (scaled).
    stepper : str
        ``event`` or ``verlet``.
    dt : float
        Verlet's step (scaled time units).

    Returns
    -------
    dict
        ``v`` (striker velocity at separation, units of v0), ``t`` (separation time).

    Raises
    ------
    RuntimeError
        The run did not end at the separation.
    """
    friction = ",".join(repr(float(e)) for e in frictions(case, count, eta))
    over = [f"granules.count={count}", f"contacts.exponent={n!r}",
            f"granules.friction.kinetic=[{friction}]", "output.dt=null", "output.every=1000000"]
    if stepper == "verlet":
        over += ["run.stepper=verlet", f"run.dt={dt!r}"]
    result = simulate(scene_of(folder, SCENE, over), progress=False)
    if str(result.status) != "separated":
        raise RuntimeError(f"backscatter_friction: {case} n={n} N={count} eta={eta}: the run "
                           f"ended {result.status} at t={result.t_final}, not at the separation")
    return {"v": float(result.v_final[0]), "t": float(result.t_final)}


def reference_backscatter(case: str, n: float, count: int, eta: float,
                          rtol: float = REFERENCE_RTOL) -> float:
    """The striker's velocity at separation by DOP853 (:func:`.chain_ode.integrate_chain`).

    Parameters
    ----------
    case, n, count, eta
        As :func:`engine_backscatter`.
    rtol : float
        DOP853's tolerance.

    Returns
    -------
    float
        Units of v0.
    """
    solution = integrate_chain(np.ones(count), 2.0 * np.arange(count),
                               np.r_[1.0, np.zeros(count - 1)], 2.0 * np.ones(count - 1),
                               n=n, t_end=50.0, rtol=rtol,
                               eta=frictions(case, count, eta), stop_contact=0)
    return float(solution.v[0])


def backscatter_edge(velocity, lo: float = 0.1, hi: float = 0.4, tol: float = EDGE_TOL) -> float:
    """Where backscattering under striker friction ends: bisection on eta.

    Parameters
    ----------
    velocity : callable(float) -> float
        The striker's velocity at separation for a friction eta (negative below the
        edge, zero above: the striker is held before the contact opens).
    lo, hi : float
        A bracket: backscattering at ``lo``, none at ``hi``.
    tol : float
        Width of the final bracket.

    Returns
    -------
    float
        The bracket's middle (within ``tol / 2`` of the edge).
    """
    if not (velocity(lo) < 0.0 <= velocity(hi)):
        raise RuntimeError(f"backscatter_friction: [{lo}, {hi}] does not bracket the edge")
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if velocity(mid) < 0.0 else (lo, mid)
    return 0.5 * (lo + hi)


def _paper(case: str, eta: float) -> float:
    """The paper's closed form of the two-granule backscatter velocity (n = 2)."""
    if case == "struck":
        return float(iia_v1s(eta))
    return float(iib_collision_exact(eta)["v1s"])


def _points(folder: Path) -> list:
    """Every (case, n, N, eta) with the engine's, DOP853's and the paper's velocities."""
    points = []
    for case, etas in ETAS.items():
        for n in EXPONENTS:
            for count in COUNTS:
                for eta in etas:
                    ref = reference_backscatter(case, n, count, eta)
                    loose = reference_backscatter(case, n, count, eta, 1e-13)
                    paper = _paper(case, eta) if (n == 2.0 and count == 2) else None
                    points.append({"case": case, "n": n, "N": count, "eta": eta,
                                   "event": engine_backscatter(folder, case, n, count, eta)["v"],
                                   "reference": ref, "reference_error": abs(ref - loose),
                                   "paper": paper})
    return points


def _edges(folder: Path) -> list:
    """Where backscattering under striker friction ends, for each n and N, by the event
    stepper and by DOP853 (rtol 1e-12; the paper's exact value for n = 2, N = 2)."""
    edges = []
    for n in EXPONENTS:
        for count in COUNTS:
            engine = backscatter_edge(
                lambda e: engine_backscatter(folder, "striker", n, count, e)["v"])
            if n == 2.0 and count == 2:
                ref, source = float(iib_backscatter_threshold_eta_exact()), "paper, exact"
            else:
                ref = backscatter_edge(
                    lambda e: reference_backscatter("striker", n, count, e, 1e-12), tol=1e-9)
                source = "DOP853 rtol=1e-12, bisected to 1e-9"
            edges.append({"n": n, "N": count, "event": engine, "reference": ref,
                          "source": source})
    return edges


def _verlet(folder: Path) -> list:
    """Verlet at 2 dt, dt and dt / 2 (:data:`VERLET_DT`), eta = 0.1, both cases, N = 20.

    Stick, slip and the separation are resolved to a step, so Verlet's error is not a
    smooth function of dt here and halving dt does not estimate it: its error is
    measured against DOP853 (exact to 1e-10) at each step.
    """
    out = []
    for case in CASES:
        for n in EXPONENTS:
            ref = reference_backscatter(case, n, 20, 0.1)
            v = {dt: engine_backscatter(folder, case, n, 20, 0.1, "verlet", dt)["v"]
                 for dt in (2 * VERLET_DT, VERLET_DT, VERLET_DT / 2)}
            out.append({"case": case, "n": n, "N": 20, "eta": 0.1, "verlet": v[VERLET_DT],
                        "reference": ref,
                        "errors": {repr(dt): value - ref for dt, value in v.items()}})
    return out


def _rows(points: list, edges: list, verlet: list) -> list:
    """The table: every point against DOP853, the two-granule ones against the paper,
    the edges, Verlet."""
    rows = []
    for p in points:
        label = f"{p['case']} n={p['n']:g} N={p['N']} eta={p['eta']:g}: v_striker/v0"
        if p["N"] == 2 and p["eta"] == 0.0:  # equal elastic granules exchange velocities
            rows.append(Row(f"{label}, event", p["event"], 0.0, "exact exchange"))
            continue
        rows.append(Row(f"{label}, event", p["event"], p["reference"], DOP853))
        if p["paper"] is not None:
            rows.append(Row(f"{label}, event", p["event"], p["paper"],
                            f"paper {CASES[p['case']][:9]}, closed form"))
    for e in edges:
        rows.append(Row(f"striker n={e['n']:g} N={e['N']}: eta where backscattering ends, "
                        f"event", e["event"], e["reference"], e["source"]))
    for v in verlet:
        rows.append(Row(f"{v['case']} n={v['n']:g} N=20 eta=0.1: v_striker/v0, Verlet "
                        f"dt={VERLET_DT}", v["verlet"], v["reference"], DOP853))
    return rows


def compute(folder: Path) -> Outcome:
    """Run the experiment.

    Parameters
    ----------
    folder : Path
        The scenes' folder.

    Returns
    -------
    Outcome
        Its table; ``data``: ``points`` (every case, n, N, eta with the event stepper's,
        DOP853's and, for two granules at n = 2, the paper's velocity, and DOP853's own
        error), ``edges`` (where backscattering ends under striker friction), ``verlet``
        (Verlet's velocities and their errors at three steps).
    """
    points, edges, verlet = _points(folder), _edges(folder), _verlet(folder)
    return Outcome(rows=_rows(points, edges, verlet),
                   data={"points": points, "edges": edges, "verlet": verlet})


def figure(outcome: Outcome, path: Path) -> None:
    """Backscatter speed against eta, one panel per case, one line per N and n; the
    paper's two-granule closed forms (n = 2) drawn through.

    Parameters
    ----------
    outcome : Outcome
        What :func:`compute` returned.
    path : Path
        The PNG written.
    """
    with figure_file(path, 2, (9, 3.8)) as (fig, axes):
        for ax, case in zip(axes, CASES):
            for n, style in zip(EXPONENTS, ("-", "--")):
                for count, colour in zip(COUNTS, ("C0", "C1", "C2")):
                    pts = [p for p in outcome.data["points"]
                           if p["case"] == case and p["n"] == n and p["N"] == count]
                    ax.plot([p["eta"] for p in pts], [-p["event"] for p in pts], style + "o",
                            color=colour, ms=3, label=f"N = {count}, n = {n:g}")
            grid = np.linspace(0.0, max(ETAS[case]), 41)[1:]
            ax.plot(grid, [-_paper(case, e) for e in grid], ":", color="k", lw=1,
                    label="paper, N = 2, n = 2")
            if case == "striker":  # where the striker is held before it leaves
                edges = outcome.data["edges"]
                ax.plot([e["event"] for e in edges], np.zeros(len(edges)), "kx", ms=5,
                        label="edge of backscattering")
            ax.set_xlabel(r"friction $\eta$")
            ax.set_title(CASES[case], fontsize=9)
            ax.grid(alpha=0.3)
        axes[0].set_ylabel(r"backscatter speed $-v_\mathrm{striker}/v_0$ at separation")
        axes[1].legend(fontsize=6)


EXPERIMENT = Experiment(
    name="backscatter_friction",
    title="Backscattering with Coulomb friction: the paper's two granules against a chain's "
          "first granule, over eta",
    scenes=(SCENE,), compute=compute, figure=figure)
