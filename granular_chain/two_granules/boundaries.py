"""Outcome boundaries of the two-granule collision, found with the exact event stepper.

Along a 1-D path in one parameter (``eta1``, ``eta2``, ``eta``, ``gamma1``,
``gamma2``, ``gamma`` or ``n``) every value where the outcome that
:func:`~granular_chain.two_granules.collide` reports changes is located to a
relative tolerance (default 1e-12):

1. **Scan.** The outcome at ``grid`` (default 128) equally spaced points of
   ``[lo, hi]``, ends included. An outcome interval narrower than the grid
   spacing ``(hi - lo)/(grid - 1)`` can fall between two points of the same
   outcome and be missed; a wider one cannot.
2. **Refine** each change between neighbours. Bisection on the outcome alone
   needs about ``log2(spacing/(tol x))`` ~ 35-40 collisions. Where the two
   outcomes differ by one velocity that is zero on one side (the granule that
   stops: ``v1`` across backscatter_and_propagation | propagation_only, ``v2``
   across backscatter_and_propagation | backscatter_only, ...), that velocity
   vanishes smoothly (linearly) as the boundary is approached from the other
   side; a secant extrapolation of it (or of its square, where it vanishes
   like a square root) to zero predicts the boundary and two probes straddling
   the prediction confirm it, so the bracket shrinks superlinearly (13-22
   collisions instead of ~34). Across the onset of
   ``no_separation`` the indicator is the separation speed ``v2 - v1``
   (``n != 2``) or ``1/t_sep^2`` (``n = 2``, where the separation time
   diverges like ``pi/omega`` with ``omega^2`` linear in the parameter).
   Every bracket end is an engine result: the reported bracket is always
   one the engine confirms; the indicator only chooses where to probe.
3. **Accuracy** (``n != 2``): the adaptive Taylor stepper's error moves the
   boundary; it is refound with ``rtol/10`` and the difference reported as
   ``error``. For ``n = 2`` the modes are exact and the bracket is the error.

The ``no_separation`` outcome means "not separated by ``t_max``". For ``n = 2``
with equal viscous friction the separation time ``pi/omega`` diverges at
``gamma^2 = 8`` and the speeds at separation, ``~ exp(-gamma t/2)``, underflow
for ``t > ~500``; the engine's outcome boundary then lies where ``t_sep``
reaches ``t_max`` (or the underflow), 2.5e-6 to 1e-5 relative below ``sqrt(8)``.
:func:`separation_limit` extrapolates ``1/t_sep^2`` to zero from the
separated side and recovers the ``t_max -> infinity`` limit.

2-D: :func:`~granular_chain.two_granules.curves.trace_curves` follows boundary
curves in a plane (module ``curves``).
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass
from typing import Optional

import numpy as np

from ..interrupts import Stopped, stop_signals
from .outcomes import SEPARATION_SIGNS
from .problem import collide

__all__ = ["PARAMS", "Boundary", "Boundaries", "find_boundaries", "separation_limit"]

#: Parameters a path may vary; ``eta``/``gamma`` set both granules' values.
PARAMS = ("eta1", "eta2", "eta", "gamma1", "gamma2", "gamma", "n")
_DEFAULTS = {"n": 2.0, "eta1": 0.0, "eta2": 0.0, "gamma1": 0.0, "gamma2": 0.0}

# Signs of (v1, v2) at separation for each separated outcome, by name: the
# indicator of a boundary is the velocity whose sign pattern differs (see _indicator).
_SIGNS = {outcome.name: signs for outcome, signs in SEPARATION_SIGNS.items()}


@dataclass(frozen=True)
class Boundary:
    """One value of the parameter where the collision's outcome changes.

    Attributes
    ----------
    param : str
        The parameter varied (eta1, eta2, eta, gamma1, gamma2, gamma or n).
    value : float
        The boundary: midpoint of ``bracket``.
    bracket : (float, float)
        Parameter values, ``bracket[1] - bracket[0] <= tol * |value|`` (or two
        neighbouring floats), at which the engine reports ``below`` and ``above``.
    below, above : str
        Outcome names (:class:`~granular_chain.two_granules.Outcome` ``.name``)
        at ``bracket[0]`` and ``bracket[1]``.
    collisions : int
        Collisions run to refine this boundary from its scan bracket (the scan
        itself is counted in :attr:`Boundaries.scan_collisions`).
    seconds : float
        Wall time of that refinement.
    method : str
        ``"bisection"`` or ``"secant:<indicator>"`` (indicator-guided probes).
    error : float or None
        Estimated absolute error of ``value`` from the stepper (``n != 2``: the
        change when refound with ``rtol/10``); None where not estimated.
    events_below, events_above : tuple of str
        Event kinds of the collisions at the bracket ends.
    """

    param: str
    value: float
    bracket: tuple
    below: str
    above: str
    collisions: int
    seconds: float
    method: str = "bisection"
    error: Optional[float] = None
    events_below: tuple = ()
    events_above: tuple = ()

    def to_dict(self) -> dict:
        """The fields as a JSON-ready dict (tuples as lists).

        Returns
        -------
        dict
        """
        d = asdict(self)
        d["bracket"] = list(self.bracket)
        d["events_below"], d["events_above"] = list(self.events_below), list(self.events_above)
        return d


class Boundaries(list):
    """The list of :class:`Boundary` found on a path, with the scan's cost.

    Attributes
    ----------
    scan_collisions : int
    scan_seconds : float
    grid : int
    fixed : dict
        The value of every parameter not on the path (of n, eta1, eta2, gamma1, gamma2).
    """

    scan_collisions: int = 0
    scan_seconds: float = 0.0
    grid: int = 0
    fixed: dict = {}

    def to_dict(self) -> dict:
        """The boundaries and the scan's counts as a JSON-ready dict.

        Returns
        -------
        dict
        """
        return {"boundaries": [b.to_dict() for b in self], "grid": self.grid,
                "scan_collisions": self.scan_collisions, "scan_seconds": self.scan_seconds,
                "fixed": dict(self.fixed)}


class _Problem:
    """The two-granule problem along one parameter; counts the collisions it runs."""

    def __init__(self, param, fixed, by="outcome", rtol=None, t_max=1000.0):
        if param not in PARAMS:
            raise ValueError(f"param must be one of {', '.join(PARAMS)}; got {param!r}")
        fixed = dict(fixed or {})
        unknown = set(fixed) - set(_DEFAULTS) - {"eta", "gamma"}
        if unknown:
            raise ValueError(f"fixed: unknown parameter(s) {', '.join(sorted(unknown))} "
                             f"(known: n, eta1, eta2, eta, gamma1, gamma2, gamma)")
        for both in ("eta", "gamma"):
            if both in fixed:
                v = fixed.pop(both)
                fixed.setdefault(both + "1", v)
                fixed.setdefault(both + "2", v)
        self.values = {**_DEFAULTS, **{k: float(v) for k, v in fixed.items()}}
        if by not in ("outcome", "events"):
            raise ValueError(f"by must be 'outcome' or 'events'; got {by!r}")
        self.param, self.by, self.rtol, self.t_max = param, by, rtol, float(t_max)
        self.count = 0
        self.stop = None  # the StopRequest of the scan (find_boundaries sets it)
        self.floor = 0.0  # absolute floor of the bracket width (find_boundaries sets it)
        self.secant = True  # indicator-guided probes where an indicator exists

    def point(self, x: float) -> dict:
        v = dict(self.values)
        if self.param in ("eta", "gamma"):
            v[self.param + "1"] = v[self.param + "2"] = x
        else:
            v[self.param] = x
        return v

    def collide(self, x: float, rtol=None):
        """The collision at ``x``; raises :class:`Stopped` once a stop is asked for (a
        collision cut short by it is not an outcome)."""
        v = self.point(x)
        self.count += 1
        self._check_stop()
        c = collide(v["n"], eta=(v["eta1"], v["eta2"]), gamma=(v["gamma1"], v["gamma2"]),
                    stepper="event", t_max=self.t_max,
                    rtol=rtol if rtol is not None else self.rtol)
        self._check_stop()
        return c

    def _check_stop(self) -> None:
        if self.stop is not None and self.stop.requested:
            raise Stopped(self.stop.signum)

    def label(self, c):
        """What must differ across a boundary: the outcome (and, by='events', the
        sequence of event kinds)."""
        if self.by == "events":
            return (c.outcome.name, _kinds(c))
        return c.outcome.name


def _kinds(c) -> tuple:
    return tuple(e.kind for e in c.result.events)


def _indicator(label_a: str, label_b: str, n: float):
    """A function Collision -> float that vanishes smoothly at the boundary between
    outcomes ``label_a`` and ``label_b`` (zero on one side, or changing sign), and its name;
    None where the outcomes differ in more than one way."""
    if "no_separation" in (label_a, label_b):
        if float(n) == 2.0:
            return (lambda c: 0.0 if not math.isfinite(c.t_separation)
                    else c.t_separation ** -2.0), "1/t_sep^2"
        return (lambda c: 0.0 if not math.isfinite(c.t_separation) else c.v2 - c.v1), "v2-v1"
    sa, sb = _SIGNS.get(label_a), _SIGNS.get(label_b)
    if sa is None or sb is None:
        return None
    diff = [i for i in (0, 1) if sa[i] != sb[i]]
    if len(diff) != 1:
        return None
    i = diff[0]
    return (lambda c: (c.v1, c.v2)[i]), f"v{i + 1}"


def _secant_guess(pts, power=1.0):
    """Zero of the line through the two points nearest the zero of the indicator
    (smallest |f|), in ``sign(f) |f|^power`` (power 2 for an indicator vanishing
    like a square root), or None. ``pts``: list of (x, f) with f != 0."""
    if len(pts) < 2:
        return None
    (x0, f0), (x1, f1) = sorted(pts, key=lambda p: abs(p[1]))[:2]
    f0, f1 = math.copysign(abs(f0) ** power, f0), math.copysign(abs(f1) ** power, f1)
    if f0 == f1:
        return None
    return x1 - f1 * (x1 - x0) / (f1 - f0)


def _narrow(a: float, b: float, tol: float, floor: float) -> bool:
    """Is [a, b] within the relative tolerance or the absolute floor, or are a and b
    neighbouring floats?"""
    mid = a + (b - a) / 2
    return b - a <= max(tol * max(abs(a), abs(b)), floor) or not a < mid < b


def _refine(prob: _Problem, a, coll_a, b, coll_b, tol: float) -> list:
    """The boundaries between a (collision coll_a) and b (coll_b), whose labels differ.

    Probes only inside (a, b), keeps the bracket's ends as engine results, and
    recurses when a probe finds a third label (two boundaries inside).

    Not scipy's brentq: the function bracketed is the outcome, a label without
    a sign; the indicator (a velocity) only proposes probes, and it vanishes
    identically on one side, so every bracket end must be an engine result
    whose label is checked, and a probe may find a third outcome."""
    start, t0 = prob.count, time.perf_counter()
    label_a, label_b = prob.label(coll_a), prob.label(coll_b)
    outcome_a, outcome_b = coll_a.outcome.name, coll_b.outcome.name
    n = prob.point(a)["n"]
    ind = _indicator(outcome_a, outcome_b, n) if outcome_a != outcome_b and prob.secant else None
    indicator_of, method = ind if ind is not None else (None, "bisection")
    if indicator_of is not None:
        method = "secant:" + method
    pts = [(x, f) for x, c in ((a, coll_a), (b, coll_b))
           for f in ([indicator_of(c)] if indicator_of else [])
           if f != 0.0 and math.isfinite(f)]
    g_prev, bisect, power, failures = None, indicator_of is None, 1.0, 0
    while not _narrow(a, b, tol, prob.floor):
        width = b - a
        probes = []
        g = None if bisect else _secant_guess(pts, power)
        if g is not None and a < g < b:
            # straddle the prediction by twice the last change of prediction
            e = 2 * abs(g - g_prev) if g_prev is not None else width / 16
            e = max(e, tol * max(abs(a), abs(b)) / 4)
            probes = [g - e, g + e]
            g_prev = g
        else:
            probes = [a + width / 2]
        for x in probes:
            if not a < x < b:
                continue
            c = prob.collide(x)
            lab = prob.label(c)
            if lab == label_a:
                a, coll_a = x, c
            elif lab == label_b:
                b, coll_b = x, c
            else:  # a third outcome inside: two (or more) boundaries
                return _refine(prob, a, coll_a, x, c, tol) + _refine(prob, x, c, b, coll_b, tol)
            if indicator_of is not None:
                f = indicator_of(c)
                if f != 0.0 and math.isfinite(f):
                    pts.append((x, f))
        # a secant round that did not halve the bracket: bisect once and switch
        # between the indicator and its square (square-root vanishing); after four
        # such rounds, bisection only
        bisect = indicator_of is None or (not bisect and b - a > width / 2)
        if bisect and indicator_of is not None and g is not None:
            g_prev, failures = None, failures + 1
            power = 3.0 - power  # 1 <-> 2
            if failures >= 4:
                indicator_of, method = None, method + "+bisection"
    return [Boundary(param=prob.param, value=a + (b - a) / 2, bracket=(a, b), below=outcome_a,
                     above=outcome_b,
                     collisions=prob.count - start, seconds=time.perf_counter() - t0,
                     method=method, events_below=_kinds(coll_a), events_above=_kinds(coll_b))]


def _stepper_error(prob: _Problem, boundary: Boundary, tol: float) -> Boundary:
    """``boundary`` with ``error`` = its change when refound with rtol/10 (n != 2): the
    stepper's contribution. Counts those collisions and seconds into ``boundary``."""
    t0, start = time.perf_counter(), prob.count
    tight = _Problem(prob.param, prob.values, prob.by, (prob.rtol or 1e-12) / 10, prob.t_max)
    tight.floor, tight.secant, tight.stop = prob.floor, prob.secant, prob.stop
    x, h = boundary.value, max(1e-7 * abs(boundary.value), 1e-12)
    coll_a, coll_b = tight.collide(x - h), tight.collide(x + h)
    found = []
    if (coll_a.outcome.name, coll_b.outcome.name) == (boundary.below, boundary.above):
        found = [b for b in _refine(tight, x - h, coll_a, x + h, coll_b, tol)
                 if (b.below, b.above) == (boundary.below, boundary.above)]
    err = abs(found[0].value - x) if len(found) == 1 else None
    return Boundary(**{**asdict(boundary), "bracket": boundary.bracket, "error": err,
                       "collisions": boundary.collisions + tight.count + prob.count - start,
                       "seconds": boundary.seconds + time.perf_counter() - t0})


def find_boundaries(param: str, lo: float, hi: float, fixed: Optional[dict] = None,
                    tol: float = 1e-12, *, grid: int = 128, by: str = "outcome",
                    rtol: Optional[float] = None, t_max: float = 1000.0,
                    error: Optional[bool] = None, secant: bool = True) -> Boundaries:
    """Every value of ``param`` in [lo, hi] where the two-granule outcome changes.

    Parameters
    ----------
    param : {'eta1', 'eta2', 'eta', 'gamma1', 'gamma2', 'gamma', 'n'}
        The parameter varied (``eta``/``gamma``: both granules equal).
    lo, hi : float
        The path, lo < hi (scaled units; frictions >= 0, n > 1).
    fixed : dict, optional
        Values of the other parameters (keys as ``param``); defaults n = 2 and
        every friction 0.
    tol : float
        Relative width of the final brackets (default 1e-12).
    grid : int
        Points of the initial scan (>= 2). Outcome intervals narrower than
        ``(hi - lo)/(grid - 1)`` may be missed.
    by : {'outcome', 'events'}
        What must change across a boundary: the outcome name, or also the
        sequence of event kinds (finds e.g. the onset of back-sliding of
        granule 1, eta1 = 0.4440, which leaves the outcome unchanged).
    rtol : float, optional
        Event-stepper tolerance for n != 2 (default the scene's 1e-12).
    t_max : float
        Collisions not separated by then are ``no_separation``.
    error : bool, optional
        Estimate each boundary's stepper error (refind with rtol/10); default:
        when n != 2 somewhere on the path.
    secant : bool
        Use the smooth indicators where they exist (False: bisection on the
        outcome only; for comparison).

    Returns
    -------
    Boundaries
        A list of :class:`Boundary`, in increasing ``value``.

    Raises
    ------
    granular_chain.interrupts.Stopped
        SIGINT, SIGTERM or SIGHUP arrived (in the main thread): the search stops
        within a compiled chunk of the collision it was running.
    """
    lo, hi, grid = float(lo), float(hi), int(grid)
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"the range must be finite with lo < hi; got [{lo}, {hi}]")
    if grid < 2:
        raise ValueError(f"grid must be at least 2; got {grid}")
    if not 0 < tol < 1:
        raise ValueError(f"tol must be in (0, 1); got {tol}")
    prob = _Problem(param, fixed, by=by, rtol=rtol, t_max=t_max)
    # a relative width cannot be reached at a boundary at 0: floor it
    prob.floor = tol * tol * (hi - lo)
    prob.secant = bool(secant)
    # one stop request for every collision: SIGINT, SIGTERM or SIGHUP ends the one
    # running within a compiled chunk and the search with Stopped
    with stop_signals() as stop:
        prob.stop = stop
        return _scan_and_refine(prob, lo, hi, grid, tol, error)


def _scan_and_refine(prob: _Problem, lo: float, hi: float, grid: int, tol: float,
                     error: Optional[bool]) -> Boundaries:
    """The scan of ``grid`` points, then each change of outcome refined to ``tol``."""
    param = prob.param
    t0 = time.perf_counter()
    xs = np.linspace(lo, hi, grid)
    cs = [prob.collide(float(x)) for x in xs]
    out = Boundaries()
    out.scan_collisions, out.scan_seconds = prob.count, time.perf_counter() - t0
    varied = {param + "1", param + "2"} if param in ("eta", "gamma") else {param}
    out.grid, out.fixed = grid, {k: v for k, v in prob.values.items() if k not in varied}
    if error is None:
        error = param == "n" or prob.values["n"] != 2.0
    for i in range(grid - 1):
        if prob.label(cs[i]) != prob.label(cs[i + 1]):
            found = _refine(prob, float(xs[i]), cs[i], float(xs[i + 1]), cs[i + 1], tol)
            out.extend(_stepper_error(prob, b, tol) if error else b for b in found)
    return out


def separation_limit(param: str, x_sep: float, x_nosep: float, fixed: Optional[dict] = None,
                     points: int = 6, span: float = 1e-2, t_max: float = 1000.0):
    """The t_max -> infinity limit of a no_separation boundary where t_sep diverges.

    For n = 2 the separation time of a collision that barely separates is
    ``~ pi/omega`` with ``omega^2`` a smooth function of the parameter that
    vanishes at the true boundary, so ``F = 1/t_sep^2`` vanishes linearly there.
    F is measured at ``points`` parameter values on the separated side, at
    distances ``span |x| 2^-k`` (k = 0 .. points-1) from the engine's boundary,
    and ``x(F)`` is extrapolated to F = 0 by polynomial (Neville) interpolation.

    Parameters
    ----------
    param, fixed, t_max
        As :func:`find_boundaries`.
    x_sep, x_nosep : float
        The engine's boundary bracket: separates at x_sep, not at x_nosep.
    points : int
        Samples (polynomial degree + 1).
    span : float
        Relative distance of the farthest sample.

    Returns
    -------
    value : float
        The extrapolated boundary.
    error : float
        |value - the extrapolation with one sample fewer|.
    collisions : int
    """
    prob = _Problem(param, fixed, t_max=t_max)
    x0 = x_sep
    s = 1.0 if x_nosep > x_sep else -1.0
    hs = [span * abs(x0) * 2.0 ** -k for k in range(points)]
    xs, fs = [], []
    for h in hs:
        c = prob.collide(x0 - s * h)
        if not math.isfinite(c.t_separation) or c.t_separation > t_max / 4:
            raise ValueError(f"separation_limit: no separation well before t_max at "
                             f"{param} = {x0 - s * h!r}")
        xs.append(x0 - s * h)
        fs.append(c.t_separation ** -2.0)
    value = float(_neville(fs, xs, 0.0))
    return value, abs(value - float(_neville(fs[1:], xs[1:], 0.0))), prob.count


def _neville(ts, ys, t0):
    """Value at t0 of the polynomial through (ts[i], ys[i])."""
    p = list(ys)
    m = len(ts)
    for k in range(1, m):
        for i in range(m - k):
            p[i] = ((t0 - ts[i + k]) * p[i] + (ts[i] - t0) * p[i + 1]) / (ts[i] - ts[i + k])
    return p[0]
