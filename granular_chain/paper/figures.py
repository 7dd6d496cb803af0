"""Every figure of the two-granule paper, redrawn from the engine.

Rosas, Buceta and Lindenberg, *Dynamics of Two Granules*
(``shared/seed/two_granules_paper.tex``).  One function per figure of the paper;
each runs the engine's event stepper (``collide(..., stepper="event")``: exact to
roundoff for ``n = 2``, adaptive Taylor for ``n = 5/2``), overlays the paper's
closed forms from :mod:`granular_chain.paper` where they exist, and writes one
PNG with labelled axes.  Everything is in the paper's scaled units (Appendix A:
masses 1, contact force ``delta^(n-1)``, granule 1 arriving at ``v0 = 1``): a
velocity is in units of ``v0``, a time in units of ``B = A/v0``, a friction force
``eta`` in units of ``m v0^2/A`` and a viscous coefficient ``gamma`` in units of
``m/B``.

===================  ====================================================
function             paper figure
===================  ====================================================
``fig_velocity``     Fig. ``velocity``: v1 at separation vs eta2 (eta1 = 0)
``fig_energy``       Fig. ``energy``: E/E0 at separation vs eta2 (eta1 = 0)
``fig_timecompare2`` Fig. ``timecompare2``: stopping time t0 of granule 1
``fig_timecompare3`` Fig. ``timecompare3``: back-sliding time t1 (Sec. II B)
``fig_finalv1``      Fig. ``finalv1``: v1 at separation vs eta1 (eta2 = 0)
``fig_hertz``        Fig. ``hertz``: -v1, v2, E/E0 over (eta1, eta2), n = 5/2
``fig_finalv1m5``    Fig. ``finalv1m5``: v1 vs gamma, delta = -0.1, 0, 0.1
===================  ====================================================

Cost.  The collisions of every figure run through
:func:`~granular_chain.two_granules.collision_map`: the scene is validated and
packed once per friction feature set and the points run in a compiled loop, so
a collision costs what the event kernel costs (20-40 us where at most one
granule has friction, ~100-200 us with Coulomb friction on both, a few ms at a
point whose modes chatter).  The (eta1, eta2) map is split into row blocks over
a ``fork`` process pool (default 2 processes; children inherit the compiled
kernels, so nothing is recompiled).

Command line (wired in :mod:`granular_chain.cli`)::

    granular-chain figures --out docs/figures [--only hertz,energy] [--grid 100] [--processes 2]
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np

from .. import paper
from ..codes import Status
from ..extras import require
from ..plotting import label_contours, signed
from ..rundir import write_atomic
from ..two_granules import OUTCOMES, Outcome, collide, collision_map

__all__ = [
    "collision_values", "collision_grid", "hertz_maps",
    "fig_velocity", "fig_energy", "fig_timecompare2", "fig_timecompare3",
    "fig_finalv1", "fig_hertz", "fig_finalv1m5", "FIGURES", "make_figures",
]

SQRT2 = math.sqrt(2.0)

_BOTH = OUTCOMES.index(Outcome.backscatter_and_propagation)


# ----------------------------------------------------------------------------
# running many collisions
# ----------------------------------------------------------------------------
def collision_values(n: float, points: Sequence[tuple], processes: int = 1) -> dict:
    """Collide two granules (event stepper) at each point and collect the results.

    Parameters
    ----------
    n : float
        Potential exponent (2 or 5/2).
    points : sequence of (eta1, eta2, gamma1, gamma2)
        Scaled friction parameters, P points.
    processes : int
        Worker processes (``fork``, over blocks of 2000 points or more); 1 runs in
        this process.

    Returns
    -------
    dict of ndarray, shape (P,)
        ``v1``, ``v2`` (velocities at separation, units of v0), ``energy`` (E/E0),
        ``t_sep`` (separation time, units of B; inf if never), ``outcome``
        (index into :data:`~granular_chain.two_granules.OUTCOMES`), ``t_stop1`` (first
        stop of granule 1, NaN if it never stops).

    Raises
    ------
    RuntimeError
        A run failed (as :func:`collide` would raise).
    """
    pts = np.array([tuple(float(a) for a in p) for p in points], dtype=float).reshape(-1, 4)
    m = collision_map(pts[:, 0], pts[:, 1], n, gamma=(pts[:, 2], pts[:, 3]), workers=processes)
    if m.failed.any():
        i = int(np.flatnonzero(m.failed)[0])
        raise RuntimeError(f"the collision run failed at (eta1, eta2, gamma1, gamma2) = "
                           f"{tuple(pts[i])}: status {Status(int(m.status[i])).name}")
    return {"v1": m.v1, "v2": m.v2, "energy": m.energy_ratio, "t_sep": m.t_separation,
            "outcome": m.outcome.astype(int), "t_stop1": m.t_stop1}


def collision_grid(n: float, eta1: np.ndarray, eta2: np.ndarray, processes: int = 2) -> dict:
    """:func:`collision_values` over the grid ``eta1 x eta2`` (no viscous friction).

    Parameters
    ----------
    n : float
        Potential exponent (2 or 5/2).
    eta1, eta2 : ndarray, shape (M,) and (K,)
        Kinetic friction forces on granules 1 and 2, scaled (units of ``m v0^2/A``).
    processes : int
        Worker processes (``fork``); 1 runs in this process.

    Returns
    -------
    dict of ndarray, shape (len(eta2), len(eta1))
        As :func:`collision_values`, row ``j`` at ``eta2[j]``, column ``i`` at ``eta1[i]``.
    """
    E1, E2 = np.meshgrid(np.asarray(eta1, float), np.asarray(eta2, float))
    pts = [(a, b, 0.0, 0.0) for a, b in zip(E1.ravel(), E2.ravel())]
    out = collision_values(n, pts, processes)
    return {k: v.reshape(E1.shape) for k, v in out.items()}


def hertz_maps(grid: int = 100, processes: int = 2, n: float = 2.5,
               eta1_max: float = 0.3, eta2_max: float = 0.7) -> dict:
    """The data of Fig. ``hertz``: a ``grid x grid`` map over (eta1, eta2).

    Parameters
    ----------
    grid : int
        Points per axis.
    processes : int
        Worker processes (``fork``); 1 runs in this process.
    n : float
        Potential exponent (5/2: Hertz spheres).
    eta1_max, eta2_max : float
        Upper ends of the axes, scaled friction forces (units of ``m v0^2/A``); both start at 0.

    Returns
    -------
    dict
        ``eta1`` (grid,), ``eta2`` (grid,) and the arrays of :func:`collision_grid`.
    """
    e1 = np.linspace(0.0, eta1_max, grid)
    e2 = np.linspace(0.0, eta2_max, grid)
    out = collision_grid(n, e1, e2, processes)
    out.update(eta1=e1, eta2=e2)
    return out


# ----------------------------------------------------------------------------
# plotting helpers
# ----------------------------------------------------------------------------
def _plt():
    require("matplotlib", "granular_chain paper figures").use("Agg")
    return require("matplotlib.pyplot", "granular_chain paper figures")


def _save(fig, out: Path, name: str) -> Path:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = write_atomic(out / f"paper_{name}.png",
                        lambda tmp: fig.savefig(tmp, dpi=130, bbox_inches="tight"))
    _plt().close(fig)
    return path


def _eta_axis(lo, hi, m):
    return np.linspace(lo, hi, m)


# ----------------------------------------------------------------------------
# Sec. II A: friction on granule 2 only
# ----------------------------------------------------------------------------
def _iia_curves(m: int, eta_hi: float):
    eta = _eta_axis(0.0, eta_hi, m)
    return eta, {n: collision_values(n, [(0.0, e, 0.0, 0.0) for e in eta]) for n in (2.0, 2.5)}


def fig_velocity(out: Path, m: int = 301) -> Path:
    """Fig. ``velocity``: v1 at the end of the collision vs eta (= eta2; eta1 = 0).

    Engine for ``n = 2`` (dashed, as in the paper) and ``n = 5/2`` (solid); the
    closed form ``v1 = -eta pi/(2 sqrt2)`` (Sec. II A) overlaid for ``n = 2`` on
    its range ``eta < (1 + pi^2/8)^(-1/2)``; beyond, granule 2 stops first and
    granule 1 is pushed back by the released spring (``v1 -> -1`` for eta >= 1).

    Parameters
    ----------
    out : str or Path
        Folder written into (created); the file is ``out/paper_<name>.png``.
    m : int
        Points along the horizontal axis (values of eta2).

    Returns
    -------
    Path
        The PNG written.
    """
    plt = _plt()
    eta, r = _iia_curves(m, 1.2)
    emax = paper.iia_eta_max()
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.plot(eta, r[2.5]["v1"], "k-", lw=1.8, label="engine, $n = 5/2$ (Hertz spheres)")
    ax.plot(eta, r[2.0]["v1"], "k--", lw=1.8, label="engine, $n = 2$")
    ec = eta[eta <= emax]
    ax.plot(ec, paper.iia_v1s(ec), color="tab:red", ls=":", lw=2.5,
            label=r"closed form $-\eta_2\pi/(2\sqrt{2})$, $n = 2$")
    ax.axvline(emax, color="0.6", lw=0.8)
    ax.text(emax + 0.01, -0.05, r"$(1+\pi^2/8)^{-1/2}$" + f" = {emax:.4f}", fontsize=8)
    ax.set_xlabel(r"friction on granule 2, $\eta_2$ (scaled: $m v_0^2/A$)")
    ax.set_ylabel(r"$v_1^{(s)}$ at end of collision (units of $v_0$)")
    ax.set_title(r"Fig. velocity: frictionless granule 1 ($\eta_1 = 0$)")
    ax.set_xlim(0, 1.2)
    ax.legend(fontsize=8, loc="lower left")
    ax.grid(alpha=0.3)
    return _save(fig, out, "velocity")


def fig_energy(out: Path, m: int = 301) -> Path:
    """Fig. ``energy``: E/E0 at the end of the collision vs eta (= eta2; eta1 = 0).

    Closed form ``1 - eta (1-eta^2)^(1/2) pi/sqrt2 + (pi^2/4 - 1) eta^2`` (Sec. II A)
    overlaid for ``n = 2`` on its range; its minimum (eta = 0.4737) marked.

    Parameters
    ----------
    out : str or Path
        Folder written into (created); the file is ``out/paper_<name>.png``.
    m : int
        Points along the horizontal axis (values of eta2).

    Returns
    -------
    Path
        The PNG written.
    """
    plt = _plt()
    eta, r = _iia_curves(m, 1.2)
    emax = paper.iia_eta_max()
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.plot(eta, r[2.5]["energy"], "k-", lw=1.8, label="engine, $n = 5/2$ (Hertz spheres)")
    ax.plot(eta, r[2.0]["energy"], "k--", lw=1.8, label="engine, $n = 2$")
    ec = eta[eta <= emax]
    ax.plot(ec, paper.iia_energy_ratio(ec), color="tab:red", ls=":", lw=2.5,
            label="closed form $E^{(s)}/E_0$, $n = 2$")
    e_min, r_min = (float(v) for v in paper.iia_energy_minimum())
    ax.plot([e_min], [r_min], "o", color="tab:red", ms=4)
    ax.annotate(f"minimum {r_min:.4f} at $\\eta_2 = {e_min:.4f}$", (e_min, r_min),
                (e_min - 0.25, r_min - 0.12), fontsize=8,
                arrowprops={"arrowstyle": "->", "lw": 0.6})
    ax.axvline(emax, color="0.6", lw=0.8)
    ax.set_xlabel(r"friction on granule 2, $\eta_2$ (scaled: $m v_0^2/A$)")
    ax.set_ylabel(r"$E^{(s)}/E_0$ at end of collision")
    ax.set_title(r"Fig. energy: frictionless granule 1 ($\eta_1 = 0$)")
    ax.set_xlim(0, 1.2)
    ax.set_ylim(0, 1.02)
    ax.legend(fontsize=8, loc="lower left")
    ax.grid(alpha=0.3)
    return _save(fig, out, "energy")


# ----------------------------------------------------------------------------
# Sec. II B: friction on granule 1 only
# ----------------------------------------------------------------------------
def iib_back_sliding_times(eta: np.ndarray, u0: np.ndarray, v20: np.ndarray):
    """Times after the stop of granule 1 in Sec. II B, from the state at that stop.

    With granule 1 sliding back (Eqs. ``motionx1``, ``motionx2``, ``t' = t - t0``)
    the overlap and v1 are :func:`~granular_chain.paper.iib_back_sliding_overlap` and
    :func:`~granular_chain.paper.iib_back_sliding_v1`; their roots are found with brentq.

    Parameters
    ----------
    eta, u0, v20 : ndarray, shape (M,)
        Friction, overlap ``x1 - x2`` and velocity of granule 2 at the stop
        (``u0 > eta``: granule 1 slides back).

    Returns
    -------
    (t1, t_stop) : ndarray, shape (M,)
        First root of ``u`` (separation if granule 1 kept sliding) and first
        positive root of ``v1`` (the dashed curve of Fig. ``timecompare3``).
    """
    from scipy.optimize import brentq
    t1 = np.full(len(eta), np.nan)
    ts = np.full(len(eta), np.nan)
    for i, (e, u_0, w) in enumerate(zip(eta, u0, v20)):
        def u(tp):
            return paper.iib_back_sliding_overlap(tp, e, u_0, w)

        def v1(tp):
            return paper.iib_back_sliding_v1(tp, e, u_0, w)
        # u falls from u0 to its minimum at theta = pi - psi; v1 < 0 just after 0 and
        # v1(theta = 2 pi) = eta pi > 0, so both roots are bracketed
        psi = math.atan2(w / SQRT2, u_0 - e / 2)
        t1[i] = brentq(u, 0.0, (math.pi - psi) / SQRT2, xtol=1e-15, rtol=1e-15)
        grid = np.linspace(0.0, 2 * math.pi / SQRT2, 257)[1:]
        vals = np.array([v1(t) for t in grid])
        j = int(np.argmax(vals > 0))
        lo = grid[j - 1] if j > 0 else 1e-300
        ts[i] = brentq(v1, lo, grid[j], xtol=1e-15, rtol=1e-15)
    return t1, ts


def _iib_state_at_stop(eta: np.ndarray):
    """Overlap and v2 at the first stop of granule 1, from the engine's event frame."""
    u0 = np.full(len(eta), np.nan)
    v20 = np.full(len(eta), np.nan)
    for i, e in enumerate(eta):
        c = collide(2, eta=(float(e), 0.0), stepper="event")
        r = c.result
        k = int(np.searchsorted(r.t, [ev.t for ev in r.events if ev.kind == "stop" and ev.index == 0][0]))
        u0[i] = r.x[k, 0] - r.x[k, 1] + 2.0  # radius 1 each: overlap = 2 - (X2 - X1)
        v20[i] = r.v[k, 1]
    return u0, v20


def fig_timecompare2(out: Path, m: int = 300) -> Path:
    """Fig. ``timecompare2``: stopping time t0 of granule 1 vs eta1 (eta2 = 0).

    Engine (stop event of granule 1, solid), the small-eta form
    ``pi/sqrt2 - (pi eta/sqrt2)^(1/2)`` (Eq. ``t0model2``, dotted) and ``t0'`` , the
    separation time if Eqs. (x1model2, x2model2) stayed valid, ``sqrt2 atan(sqrt2/eta)``
    (dashed).  Log eta axis to show both limits (t0 ~ 1/eta, t0' ~ 2/eta).

    Parameters
    ----------
    out : str or Path
        Folder written into (created); the file is ``out/paper_<name>.png``.
    m : int
        Points along the horizontal axis (values of eta1, log-spaced).

    Returns
    -------
    Path
        The PNG written.
    """
    plt = _plt()
    eta = np.geomspace(1e-3, 10.0, m)
    r = collision_values(2.0, [(e, 0.0, 0.0, 0.0) for e in eta])
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.plot(eta, r["t_stop1"], "k-", lw=1.8, label="engine: stop of granule 1, $t_0$")
    small = paper.iib_t0_small_eta(eta)
    ok = small > 0
    ax.plot(eta[ok], small[ok], "k:", lw=2.0,
            label=r"small $\eta$: $\pi/\sqrt{2} - (\pi\eta/\sqrt{2})^{1/2}$")
    ax.plot(eta, SQRT2 * np.arctan(SQRT2 / eta), "k--", lw=1.4,
            label=r"$t_0'$: $x_1 = x_2$ if Eqs. (x1model2, x2model2) held")
    ax.plot(eta, 1 / eta, color="0.6", lw=0.8, ls="-.", label=r"$1/\eta$, $2/\eta$")
    ax.plot(eta, 2 / eta, color="0.6", lw=0.8, ls="-.")
    ax.set_xscale("log")
    ax.set_ylim(0, 2.5)
    ax.set_xlim(eta[0], eta[-1])
    ax.set_xlabel(r"friction on granule 1, $\eta_1$ (scaled; $\eta_2 = 0$)")
    ax.set_ylabel(r"time (units of $B = A/v_0$)")
    ax.set_title("Fig. timecompare2: stopping time of granule 1, $n = 2$")
    ax.legend(fontsize=8, loc="lower left")
    ax.grid(alpha=0.3, which="both")
    return _save(fig, out, "timecompare2")


def fig_timecompare3(out: Path, m: int = 220) -> Path:
    """Fig. ``timecompare3``: back-sliding phase of granule 1 (Sec. II B, n = 2).

    Solid: engine, separation time minus the stop time of granule 1, ``t1``.
    Dotted: ``(pi eta/sqrt2)^(1/2) - eta`` (Eq. ``omega1``).  Dashed: time after
    ``t0`` at which granule 1 would stop again if Eq. (``motionx1``) held, from the
    engine's state at its first stop.  Where dashed < solid (eta > 0.2196) granule
    1 stops before separation: no backscattering.  Only ``eta < 0.44402`` (granule 1
    slides back) is meaningful.

    Parameters
    ----------
    out : str or Path
        Folder written into (created); the file is ``out/paper_<name>.png``.
    m : int
        Points along the horizontal axis (values of eta1).

    Returns
    -------
    Path
        The PNG written.
    """
    plt = _plt()
    eta_c = float(paper.iib_slip_critical_eta_exact())
    eta_b = float(paper.iib_backscatter_threshold_eta_exact())
    eta = np.linspace(1e-3, eta_c * (1 - 1e-3), m)
    r = collision_values(2.0, [(e, 0.0, 0.0, 0.0) for e in eta])
    u0, v20 = _iib_state_at_stop(eta)
    _, ts = iib_back_sliding_times(eta, u0, v20)
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.plot(eta, r["t_sep"] - r["t_stop1"], "k-", lw=1.8,
            label="engine: separation $-$ stop of granule 1")
    ax.plot(eta, paper.iib_t1_small_eta(eta), "k:", lw=2.0,
            label=r"small $\eta$: $(\pi\eta/\sqrt{2})^{1/2} - \eta$")
    ax.plot(eta, ts, "k--", lw=1.4, label="granule 1 stops again (Eq. motionx1)")
    ax.axvline(eta_b, color="tab:red", lw=0.8)
    ax.text(eta_b + 0.005, 0.15, f"$\\eta_1 = {eta_b:.4f}$\n(printed ~0.22)", fontsize=8,
            color="tab:red")
    ax.axvline(eta_c, color="0.5", lw=0.8, ls="--")
    ax.text(eta_c - 0.115, 0.9, f"slip limit {eta_c:.4f}\n(printed 0.439)", fontsize=8,
            color="0.3")
    ax.set_xlim(0, 0.45)
    ax.set_ylim(0, 1.0)
    ax.set_xlabel(r"friction on granule 1, $\eta_1$ (scaled; $\eta_2 = 0$)")
    ax.set_ylabel(r"time after $t_0$ (units of $B = A/v_0$)")
    ax.set_title("Fig. timecompare3: end of the collision, $n = 2$")
    ax.legend(fontsize=8, loc="upper left")
    ax.grid(alpha=0.3)
    return _save(fig, out, "timecompare3")


def fig_finalv1(out: Path, m: int = 401) -> Path:
    """Fig. ``finalv1``: v1 at the end of the collision vs eta1 (eta2 = 0).

    Engine for ``n = 2`` and ``n = 5/2``; the exact ``n = 2`` maximum of the
    backscattering (3.119 % at eta = 0.0940) and its end (eta = 0.2196) marked.

    Parameters
    ----------
    out : str or Path
        Folder written into (created); the file is ``out/paper_<name>.png``.
    m : int
        Points along the horizontal axis (values of eta1).

    Returns
    -------
    Path
        The PNG written.
    """
    plt = _plt()
    eta = _eta_axis(0.0, 0.35, m)
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for n, ls, lab in ((2.0, "--", "engine, $n = 2$"), (2.5, "-", "engine, $n = 5/2$")):
        r = collision_values(n, [(e, 0.0, 0.0, 0.0) for e in eta])
        ax.plot(eta, r["v1"], color="k", ls=ls, lw=1.8, label=lab)
    e_star, v_star = (float(v) for v in paper.iib_max_backscatter_exact(dps=12))
    ax.plot([e_star], [-v_star], "o", color="tab:red", ms=4)
    ax.annotate(f"max backscattering {100 * v_star:.3f} %\nat $\\eta_1 = {e_star:.4f}$ ($n = 2$)",
                (e_star, -v_star), (e_star + 0.05, -v_star + 0.004), fontsize=8,
                arrowprops={"arrowstyle": "->", "lw": 0.6})
    eta_b = float(paper.iib_backscatter_threshold_eta_exact())
    ax.axvline(eta_b, color="tab:red", lw=0.8)
    ax.text(eta_b + 0.004, -0.005, f"{eta_b:.4f}", fontsize=8, color="tab:red")
    ax.axhline(0, color="0.6", lw=0.6)
    ax.set_xlabel(r"friction on granule 1, $\eta_1$ (scaled; $\eta_2 = 0$)")
    ax.set_ylabel(r"$v_1^{(s)}$ at end of collision (units of $v_0$)")
    ax.set_title("Fig. finalv1: frictionless granule 2")
    ax.set_xlim(0, 0.35)
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3)
    return _save(fig, out, "finalv1")


# ----------------------------------------------------------------------------
# Sec. II C: (eta1, eta2) maps for Hertz spheres
# ----------------------------------------------------------------------------
def fig_hertz(out: Path, grid: int = 100, processes: int = 2, data: Optional[dict] = None) -> Path:
    """Fig. ``hertz``: -v1, v2 and E/E0 over (eta1, eta2) for ``n = 5/2``.

    Gray scale (darker = faster / more energy) with iso-lines, shown only where
    both granules move at the end of the collision (outcome
    ``backscatter_and_propagation``); the rest is white.  The outline of that
    region is drawn in red.

    Parameters
    ----------
    out : str or Path
        Folder written into (created); the file is ``out/paper_<name>.png``.
    grid : int
        Points per axis of the map (ignored with ``data``).
    processes : int
        Worker processes (``fork``); 1 runs in this process.
    data : dict, optional
        The output of :func:`hertz_maps` (``eta1``, ``eta2``, ``outcome``, ``v1``, ``v2``,
        ``energy``) to draw instead of computing it.

    Returns
    -------
    Path
        The PNG written.
    """
    plt = _plt()
    d = data if data is not None else hertz_maps(grid, processes)
    e1, e2 = d["eta1"], d["eta2"]
    both = d["outcome"] == _BOTH
    fields = ((-d["v1"], r"backscattering $-v_1^{(s)}$ (units of $v_0$)"),
              (d["v2"], r"propagation $v_2^{(s)}$ (units of $v_0$)"),
              (d["energy"], r"energy $E^{(s)}/E_0$"))
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), constrained_layout=True)
    ext = (e1[0], e1[-1], e2[0], e2[-1])
    # -v1 peaks at ~0.02 along eta2 = 0: fine levels there show the bending iso-lines
    # (the nonmonotonic Fig. finalv1), coarse ones elsewhere
    level_sets = (np.r_[0.005, 0.01, 0.015, 0.02, np.arange(0.05, 0.66, 0.05)],
                  np.arange(0.1, 1.0, 0.1), np.r_[0.3, 0.35, np.arange(0.4, 1.0, 0.1)])
    lines = []
    for ax, (f, lab), levels in zip(axes, fields, level_sets):
        z = np.where(both, f, np.nan)
        im = ax.imshow(z, origin="lower", extent=ext, aspect="auto", cmap="Greys",
                       interpolation="nearest")
        lines.append(ax.contour(e1, e2, z, levels=levels, colors="tab:blue", linewidths=0.8))
        ax.contour(e1, e2, both.astype(float), levels=[0.5], colors="tab:red", linewidths=1.0)
        fig.colorbar(im, ax=ax, label=lab, shrink=0.9)
        ax.set_xlabel(r"friction on granule 1, $\eta_1$ (scaled)")
        ax.set_ylabel(r"friction on granule 2, $\eta_2$ (scaled)")
        ax.set_title(lab.split(" (")[0], fontsize=10)
    fig.suptitle(f"Fig. hertz: $n = 5/2$, end of collision where both granules move "
                 f"(${len(e1)} \\times {len(e2)}$ event-stepper collisions)", fontsize=11)
    # labelled once every panel and colour bar is in place: the labels are kept
    # apart in pixels, which the layout fixes
    for ax, cs in zip(axes, lines):
        label_contours(ax, cs)
    return _save(fig, out, "hertz")


# ----------------------------------------------------------------------------
# Sec. III: hydrodynamic friction
# ----------------------------------------------------------------------------
def fig_finalv1m5(out: Path, m: int = 281) -> Path:
    """Fig. ``finalv1m5``: v1 at separation vs gamma, ``gamma_i = gamma(1 + delta_i)``.

    ``delta_1 = -delta_2 = delta`` = 0.1 (gamma1 > gamma2, dashed), 0 (dotted),
    -0.1 (gamma1 < gamma2, solid), as in the caption.  Engine (black) and the
    first-order-in-delta closed forms of Sec. III (red, thin).  For gamma^2 >= 8
    the collision never ends (no point plotted).

    Parameters
    ----------
    out : str or Path
        Folder written into (created); the file is ``out/paper_<name>.png``.
    m : int
        Points along the horizontal axis (values of gamma).

    Returns
    -------
    Path
        The PNG written.
    """
    plt = _plt()
    gam = np.linspace(0.01, 2.8, m)
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for delta, ls in ((0.1, "--"), (0.0, ":"), (-0.1, "-")):
        g1, g2 = paper.iii_gammas(gam, delta)
        r = collision_values(2.0, [(0.0, 0.0, a, b) for a, b in zip(g1, g2)])
        order = (r" ($\gamma_1 > \gamma_2$)" if delta > 0
                 else r" ($\gamma_1 < \gamma_2$)" if delta < 0 else "")
        ax.plot(gam, r["v1"], color="k", ls=ls, lw=1.8,
                label=f"engine, $\\delta = {signed(delta)}$" + order)
        if delta != 0.0:
            ax.plot(gam, paper.iii_v1s_first_order(gam, delta), color="tab:red", ls=ls, lw=0.9,
                    label=f"first order in $\\delta$, $\\delta = {signed(delta)}$")
    g_star = float(paper.iii_optimal_gamma_zeroth()[0])
    ax.plot([g_star], [-0.125], "o", color="tab:red", ms=4)
    ax.annotate(f"$\\delta = 0$ optimum: $\\gamma = {g_star:.4f}$, $v_1 = -1/8$", (g_star, -0.125),
                (g_star - 0.1, -0.03), fontsize=8, arrowprops={"arrowstyle": "->", "lw": 0.6})
    ax.set_xlabel(r"mean hydrodynamic friction $\gamma$ (scaled: $m/B$)")
    ax.set_ylabel(r"$v_1^{(s)}$ at end of collision (units of $v_0$)")
    ax.set_title(r"Fig. finalv1m5: $\gamma_{1,2} = \gamma(1 \pm \delta)$, $n = 2$")
    ax.set_xlim(0, 2.85)
    ax.legend(fontsize=7, loc="lower right")
    ax.grid(alpha=0.3)
    return _save(fig, out, "finalv1m5")


#: name -> figure function, in the paper's order.
FIGURES: dict[str, Callable[..., Path]] = {
    "velocity": fig_velocity,
    "energy": fig_energy,
    "timecompare2": fig_timecompare2,
    "timecompare3": fig_timecompare3,
    "finalv1": fig_finalv1,
    "hertz": fig_hertz,
    "finalv1m5": fig_finalv1m5,
}


def make_figures(out: Path, only: Optional[Sequence[str]] = None, grid: int = 100,
                 processes: int = 2, log=print) -> dict:
    """Draw the paper's figures into ``out`` and time each.

    Parameters
    ----------
    out : str or Path
        Folder written into (created); the file is ``out/paper_<name>.png``.
    only : sequence of str, optional
        Names from :data:`FIGURES` (default: all of them).
    grid : int
        Points per axis of the (eta1, eta2) map of Fig. ``hertz``.
    processes : int
        Worker processes (``fork``); 1 runs in this process.
    log : callable or None
        Called with one line per figure (name, seconds, path); None is silent.

    Returns
    -------
    dict
        name -> (path, wall seconds).
    """
    names = list(FIGURES) if not only else list(only)
    unknown = [n for n in names if n not in FIGURES]
    if unknown:
        raise ValueError(f"unknown figure(s) {unknown}; choose from {list(FIGURES)}")
    done = {}
    for name in names:
        t = time.perf_counter()
        if name == "hertz":
            path = fig_hertz(out, grid=grid, processes=processes)
        else:
            path = FIGURES[name](out)
        dt = time.perf_counter() - t
        done[name] = (path, dt)
        if log is not None:
            log(f"{name:13s} {dt:7.2f} s  {path}")
    return done
