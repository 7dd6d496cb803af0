"""Boundary curves of the two-granule outcome in a plane of two frictions.

:func:`trace_curves` follows every curve across which the outcome changes,
point by point with the 1-D bracketing of :mod:`~granular_chain.two_granules.boundaries`
(each point an engine-confirmed bracket, ``tol`` relative, across the curve);
:func:`write_curves` and :func:`plot_curves` write them.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

from .._compile import share_compiling
from ..extras import require
from ..plotting import tex_name
from ..rundir import write_atomic, write_text_atomic
from . import maps
from .boundaries import PARAMS, _Problem, _refine
from .outcomes import OUTCOMES

__all__ = ["BoundaryCurve", "trace_curves", "write_curves", "plot_curves"]


class _LineProblem(_Problem):
    """The problem along the straight line ``base + s * direction`` of a plane of
    two parameters (the path parameter is s)."""

    def __init__(self, plane, base, direction, values, t_max, rtol=None):
        super().__init__(plane[0], values, rtol=rtol, t_max=t_max)
        self.plane, self.base, self.dir = plane, base, direction

    def point(self, s: float) -> dict:
        v = dict(self.values)
        for name, b, d in zip(self.plane, self.base, self.dir):
            x = float(b + s * d)
            for key in ((name + "1", name + "2") if name in ("eta", "gamma") else (name,)):
                v[key] = x
        return v


@dataclass
class BoundaryCurve:
    """A boundary curve traced in a plane of two parameters.

    Attributes
    ----------
    plane : (str, str)
        The parameters on the x and y axes.
    below, above : str
        Outcomes at ``points - d * normals`` and ``points + d * normals`` (d > 0 small).
    points : ndarray, shape (M, 2)
        Boundary points in order along the curve (bracket midpoints, bracket width
        <= tol * |point| across the curve).
    normals : ndarray, shape (M, 2)
        Unit normals pointing from ``below`` to ``above``.
    closed : bool
        The curve closes on itself (a loop).
    ends : (str, str)
        Why each end stopped: 'edge' (left the box), 'corner' (a third outcome
        appears: three outcomes meet within the final step), 'lost' (the step fell
        below its minimum without a clear third outcome), 'max_points', 'closed'.
    corners : list of (point, normal, width, labels, tangent)
        Where a third outcome was met: the probe point (ndarray, shape (2,)), within
        ``min_step`` of the last curve point, the segment probed there (point -+
        width * normal, whose ends showed ``labels``) and the curve's direction.
    collisions : int
        Collisions run to trace the curve.
    seconds : float
        Wall time of the tracing, seconds.
    """

    plane: tuple
    below: str
    above: str
    points: np.ndarray
    normals: np.ndarray
    closed: bool = False
    ends: tuple = ("", "")
    corners: list = field(default_factory=list)
    collisions: int = 0
    seconds: float = 0.0

    def to_dict(self) -> dict:
        """The fields as a JSON-ready dict (tuples as lists).

        Returns
        -------
        dict
        """
        return {"plane": list(self.plane), "below": self.below, "above": self.above,
                "closed": self.closed, "ends": list(self.ends),
                "corners": [[float(c[0][0]), float(c[0][1])] for c in self.corners],
                "collisions": self.collisions, "seconds": self.seconds,
                "points": self.points.tolist(), "normals": self.normals.tolist()}


class _Plane:
    """What the tracer needs: the plane, the box, the fixed values, the options."""

    def __init__(self, plane, box, fixed, tol, t_max, rtol):
        for p in plane:
            if p not in PARAMS or p == "n":
                raise ValueError(f"plane parameters must be frictions ({', '.join(PARAMS[:-1])});"
                                 f" got {p!r}")
        self.plane, self.box = tuple(plane), np.asarray(box, dtype=float)  # [[x0, x1], [y0, y1]]
        self.values = _Problem(plane[0], fixed).values
        self.tol, self.t_max, self.rtol = tol, t_max, rtol
        self.scale = float(np.max(np.abs(self.box)))
        self.count = 0

    def inside(self, p) -> bool:
        b = self.box
        return bool(b[0, 0] <= p[0] <= b[0, 1] and b[1, 0] <= p[1] <= b[1, 1])

    def line(self, base, direction) -> _LineProblem:
        line_problem = _LineProblem(self.plane, np.asarray(base, float),
                                    np.asarray(direction, float), self.values, self.t_max,
                                    self.rtol)
        line_problem.floor = self.tol * max(float(np.hypot(*base)), 1e-3 * self.scale)
        return line_problem

    def cross(self, q, nrm, w, pair):
        """Find the boundary ``pair`` = (below, above) across the segment q -+ w nrm.
        Returns (point, normal, labels at the two ends); point None if the ends do
        not show exactly the pair."""
        line_problem = self.line(q - w * nrm, nrm)
        ends = (q - w * nrm, q + w * nrm)
        if not (self.inside(ends[0]) and self.inside(ends[1])):
            return None, None, ("outside",)
        coll_a, coll_b = line_problem.collide(0.0), line_problem.collide(2 * w)
        labs = (coll_a.outcome.name, coll_b.outcome.name)
        found = []
        if labs == pair:
            found = _refine(line_problem, 0.0, coll_a, 2 * w, coll_b, 1e-300)
        self.count += line_problem.count
        if len(found) != 1:
            return None, None, labs + tuple(x for b in found for x in (b.below, b.above))
        return q + (found[0].value - w) * nrm, nrm, labs

    def first_normal(self, p, d, pair, h):
        """Unit normal (below -> above) at the boundary point p found across the unit
        direction d, from a second crossing a small step h along the curve (searched
        over +-8 h, since d may cross the curve at a shallow angle); None if none."""
        perp = np.array([-d[1], d[0]])
        for s in (1.0, -1.0):
            q, _, _ = self.cross(p + s * h * perp, d, 8 * h, pair)
            if q is not None:
                t = s * (q - p) / np.hypot(*(q - p))
                nrm = np.array([t[1], -t[0]])
                return nrm if nrm @ d > 0 else -nrm
        return None


def _seed_line(plane, box, values, tol, t_max, rtol, base, direction, length, grid):
    """Boundary points on one straight line of the plane (a dask task): a list of
    (point, direction, below, above, collisions)."""
    tracer = _Plane(plane, box, values, tol, t_max, rtol)
    line_problem = tracer.line(np.asarray(base, float), np.asarray(direction, float))
    ss = np.linspace(0.0, length, grid)
    cs = [line_problem.collide(float(s)) for s in ss]
    out = []
    for i in range(grid - 1):
        if cs[i].outcome.name != cs[i + 1].outcome.name:
            for b in _refine(line_problem, float(ss[i]), cs[i], float(ss[i + 1]), cs[i + 1],
                             1e-300):
                p = np.asarray(base, float) + b.value * np.asarray(direction, float)
                out.append((p, np.asarray(direction, float), b.below, b.above, b.collisions))
    return out


def _trace_dir(tracer: _Plane, p0, n0, pair, steps, sign, max_points):
    """Follow the curve from p0 along sign * (n0 turned by +90 degrees)."""
    h, hmin, hmax = steps
    p, nrm = p0, n0
    pts, nrms, corners = [], [], []
    third, reason = None, "max_points"
    while len(pts) < max_points:
        tan = sign * np.array([-nrm[1], nrm[0]])
        q, w, saw = None, h, None
        while True:
            q, _, labs = tracer.cross(p + h * tan, nrm, w, pair)
            # a third outcome across the segment: the pair's band may be a wedge
            # thinner than w; narrow the segment before shortening the step
            if q is None and set(labs) - set(pair) - {"outside"}:
                saw = (p + h * tan, nrm, w, labs, tan)
                if w > 1e-9 * tracer.scale:
                    w /= 8
                    continue
            break
        if q is not None:
            t = (q - p) / np.hypot(*(q - p))
            turn = math.acos(max(-1.0, min(1.0, float(t @ tan))))
        if q is None or turn > 0.3:
            if q is None and saw is not None:
                third = saw
            if h / 2 < hmin:
                reason = ("corner" if third is not None else
                          "edge" if q is None and "outside" in labs else "lost")
                if third is not None:
                    corners.append(third)
                break
            h /= 2
            continue
        third = None
        nrm = sign * np.array([t[1], -t[0]])
        pts.append(q)
        nrms.append(nrm)
        p = q
        if len(pts) > 3 and np.hypot(*(q - p0)) < 0.75 * h:
            reason = "closed"
            break
        if turn < 0.05:
            h = min(hmax, 1.5 * h)
    return pts, nrms, reason, corners


def trace_curves(plane=("eta1", "eta2"), box=((0.0, 1.0), (0.0, 1.0)), fixed=None,
                 tol: float = 1e-12, *, seeds: int = 8, grid: int = 64, step: float = 0.01,
                 min_step: float = 1e-4, max_points: int = 2000, t_max: float = 1000.0,
                 rtol=None, executor: str = "serial", client=None, workers: int = 2):
    """Trace every boundary curve between outcomes in a plane of two frictions.

    Seeds: :func:`find_boundaries`-style searches (scan of ``grid`` points, then
    refinement) along ``seeds`` horizontal and ``seeds`` vertical lines across the
    box; these run as dask tasks with ``executor="dask"``. From each seed not
    already on a traced curve, the curve is continued both ways: predict one step
    along the tangent, correct by locating the boundary across a segment along the
    last normal (the same bracketing as in 1-D, to ``tol`` relative), accept if the
    curve turned by less than 0.3 rad (else halve the step), grow the step by 1.5
    when it turned by less than 0.05 rad. A curve ends at the box's edge, on
    closing a loop, or where a third outcome appears within ``min_step`` (a
    corner where three outcomes meet, recorded in ``corners``).

    Parameters
    ----------
    plane : (str, str)
        x and y parameters (frictions: eta1, eta2, eta, gamma1, gamma2, gamma).
    box : ((x0, x1), (y0, y1))
        Ranges of the x and y parameters, in their scaled units.
    fixed : dict, optional
        The other parameters (as :func:`find_boundaries`).
    tol : float
        Relative width of each point's bracket across the curve.
    seeds, grid : int
        Seed lines per axis; scan points per seed line.
    step, min_step : float
        Largest and smallest continuation step, relative to the box's size.
    max_points : int
        Per direction of each curve.
    t_max : float
        Give up waiting for separation after this time (units of ``B``).
    rtol : float, optional
        Event-stepper tolerance (n != 2).
    executor : {'serial', 'dask'}
        Where the seed lines run; ``client`` an existing distributed.Client
        (default a LocalCluster of ``workers`` processes). The result does not
        depend on it.
    client : distributed.Client, optional
        An existing dask client (``executor='dask'``).
    workers : int
        Processes of the LocalCluster started when no ``client`` is given.

    Returns
    -------
    list of BoundaryCurve
        In the order of the seeds that started them (deterministic). The seed
        searches' collisions are added to the first curve's ``collisions``.
    """
    tracer = _Plane(plane, box, fixed, tol, t_max, rtol)
    size = float(max(tracer.box[:, 1] - tracer.box[:, 0]))
    steps = (0.5 * step * size, min_step * size, step * size)
    lines = []
    for k in range(seeds):
        f = (k + 0.5) / seeds
        y = tracer.box[1, 0] + f * (tracer.box[1, 1] - tracer.box[1, 0])
        x = tracer.box[0, 0] + f * (tracer.box[0, 1] - tracer.box[0, 0])
        lines.append(((tracer.box[0, 0], y), (1.0, 0.0), tracer.box[0, 1] - tracer.box[0, 0]))
        lines.append(((x, tracer.box[1, 0]), (0.0, 1.0), tracer.box[1, 1] - tracer.box[1, 0]))
    args = [(tracer.plane, tracer.box, tracer.values, tol, t_max, rtol, b, d, ln, grid)
            for b, d, ln in lines]
    found = _run_tasks(_seed_line, args, executor, client, workers)
    seed_cost = sum(c for res in found for *_, c in res) + len(lines) * grid
    curves = []
    queue = [(p, d, (below, above)) for res in found for p, d, below, above, _ in res]
    while queue:
        p, d, pair = queue.pop(0)
        if any(set(pair) == {c.below, c.above} and
               np.min(np.hypot(*(c.points - p).T)) < steps[2] for c in curves):
            continue
        c = _trace_from(tracer, p, d, pair, steps, max_points)
        if c is None:
            continue
        curves.append(c)
        queue.extend(_corner_seeds(tracer, c))
    if curves:
        curves[0].collisions += seed_cost  # the seed searches, counted once
    return curves


def _corner_seeds(tracer: _Plane, curve: BoundaryCurve) -> list:
    """Seeds of the curves that start where ``curve`` ended at a third outcome:
    segments across the continued tangent, 1, 2, 4, 8 and 16 final steps beyond the
    corner, cross them (a curve ending at a corner usually lies in a narrow wedge
    whose tip is the corner, so the nearest segment may show only its own pair)."""
    out = []
    for q, nrm, w, labs, tan in curve.corners:
        for k in (1, 2, 4, 8, 16):
            c = q + k * w * tan
            line_problem = tracer.line(c - (k + 1) * w * nrm, nrm)
            if not (tracer.inside(c - (k + 1) * w * nrm) and tracer.inside(c + (k + 1) * w * nrm)):
                break
            coll_a, coll_b = line_problem.collide(0.0), line_problem.collide(2 * (k + 1) * w)
            if coll_a.outcome != coll_b.outcome:
                for b in _refine(line_problem, 0.0, coll_a, 2 * (k + 1) * w, coll_b, 1e-300):
                    out.append((c + (b.value - (k + 1) * w) * nrm, nrm, (b.below, b.above)))
            tracer.count += line_problem.count
    return out


def _trace_from(tracer: _Plane, p, d, pair, steps, max_points) -> Optional[BoundaryCurve]:
    """The curve through the seed p (found across direction d), or None if no
    second point can be found near it."""
    t0, start = time.perf_counter(), tracer.count
    n0 = tracer.first_normal(p, d, pair, steps[1] * 4)
    if n0 is None:
        return None
    fwd, nf, r1, c1 = _trace_dir(tracer, p, n0, pair, steps, 1.0, max_points)
    if r1 == "closed":
        bwd, nb, r0, c0 = [], [], "closed", []
    else:
        bwd, nb, r0, c0 = _trace_dir(tracer, p, n0, pair, steps, -1.0, max_points)
    pts = np.array(bwd[::-1] + [p] + fwd)
    nrms = np.array(nb[::-1] + [n0] + nf)
    return BoundaryCurve(plane=tracer.plane, below=pair[0], above=pair[1], points=pts, normals=nrms,
                         closed=r1 == "closed", ends=(r0, r1), corners=c0 + c1,
                         collisions=tracer.count - start, seconds=time.perf_counter() - t0)


def _run_tasks(fn, args, executor, client, workers):
    """[fn(*a) for a in args], in order, here or on dask.distributed."""
    if executor == "serial":
        return [fn(*a) for a in args]
    if executor != "dask":
        raise ValueError(f"executor must be 'serial' or 'dask'; got {executor!r}")
    distributed = require("distributed", "granular_chain boundary curves on dask")
    Client, LocalCluster = distributed.Client, distributed.LocalCluster
    own = cluster = None
    if client is None:
        share_compiling()
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = own = Client(cluster)
    try:
        futures = [client.submit(fn, *a, pure=False) for a in args]
        return client.gather(futures)
    finally:
        if own is not None:
            own.close()
        if cluster is not None:
            cluster.close()


# ----------------------------------------------------------------------------
# Output: CSV / JSON of curves, the figure over the collision map
# ----------------------------------------------------------------------------
def write_curves(curves, folder, stem: str = "boundaries") -> list:
    """``folder/<stem>_curves.csv`` (curve, x, y, nx, ny, below, above) and
    ``folder/<stem>_curves.json`` (every :class:`BoundaryCurve` as a dict).

    Parameters
    ----------
    curves : list of BoundaryCurve
        The traced curves.
    folder : str or Path
        Output folder (created).
    stem : str
        File name prefix.

    Returns
    -------
    list of Path
        The CSV and JSON written.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    csv_path, json_path = folder / f"{stem}_curves.csv", folder / f"{stem}_curves.json"
    xn, yn = curves[0].plane if curves else ("x", "y")
    lines = [f"curve,{xn},{yn},n_{xn},n_{yn},below,above"]
    for i, c in enumerate(curves):
        for p, nv in zip(c.points, c.normals):
            lines.append(f"{i},{p[0]!r},{p[1]!r},{nv[0]!r},{nv[1]!r},{c.below},{c.above}")
    write_text_atomic(csv_path, "\n".join(lines) + "\n")
    write_text_atomic(json_path, json.dumps({"curves": [c.to_dict() for c in curves]},
                                            indent=1) + "\n")
    return [csv_path, json_path]


def plot_curves(curves, path, box, fixed=None, m: int = 200, title: Optional[str] = None):
    """The curves drawn over the outcome map (``m`` x ``m`` collisions, event
    stepper) of the plane; corners marked. Returns the path written.

    Parameters
    ----------
    curves : list of BoundaryCurve
        The traced curves (at least one; their ``plane`` names the axes).
    path : str or Path
        PNG written.
    box : ((x0, x1), (y0, y1))
        Ranges of the x and y parameters, scaled units.
    fixed : dict, optional
        The other parameters (as :func:`trace_curves`).
    m : int
        Points per axis of the outcome map drawn under the curves.
    title : str, optional
        Figure title (default names ``n``).

    Returns
    -------
    str or Path
        ``path``.
    """
    require("matplotlib", "granular_chain boundary curves").use("Agg")
    plt = require("matplotlib.pyplot", "granular_chain boundary curves")
    ListedColormap = require("matplotlib.colors", "granular_chain boundary curves").ListedColormap

    xn, yn = curves[0].plane
    v = _Problem(xn, fixed).values
    x = np.linspace(box[0][0], box[0][1], m)
    y = np.linspace(box[1][0], box[1][1], m)
    X, Y = np.meshgrid(x, y)
    args = {"eta1": v["eta1"], "eta2": v["eta2"], "gamma1": v["gamma1"], "gamma2": v["gamma2"]}
    for name, grid in ((xn, X), (yn, Y)):
        for key in ((name + "1", name + "2") if name in ("eta", "gamma") else (name,)):
            args[key] = grid
    cm = maps.collision_map(args["eta1"], args["eta2"], n=v["n"],
                            gamma=(args["gamma1"], args["gamma2"]))
    colours = ["#9ecae1", "#a1d99b", "#fdae6b", "#dadaeb", "#d9d9d9", "#fcbba1"]
    fig, ax = plt.subplots(figsize=(6.4, 5.6))
    ax.pcolormesh(x, y, cm.outcome, cmap=ListedColormap(colours), vmin=-0.5, vmax=5.5,
                  shading="nearest")
    for c in curves:
        ax.plot(c.points[:, 0], c.points[:, 1], "k-", lw=1.2)
        for corner in c.corners:
            ax.plot(*corner[0], "ro", ms=4)
    handles = [plt.Rectangle((0, 0), 1, 1, color=colours[i]) for i in range(len(OUTCOMES))]
    present = sorted(set(int(k) for k in np.unique(cm.outcome)) - {-1})
    ax.legend([handles[i] for i in present], [OUTCOMES[i].name.replace("_", " ") for i in present],
              loc="upper right", fontsize=7)
    ax.set_xlabel(tex_name(xn))
    ax.set_ylabel(tex_name(yn))
    ax.set_title(title or f"outcome boundaries, $n = {v['n']:g}$")
    fig.tight_layout()
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=120))
    plt.close(fig)
    return path
