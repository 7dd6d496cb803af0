"""``granular-chain boundaries``: outcome boundaries of the two-granule collision along a
parameter (:func:`~granular_chain.two_granules.boundaries.find_boundaries`), or the
boundary curves of a plane of two frictions
(:func:`~granular_chain.two_granules.curves.trace_curves`)."""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Optional

import numpy as np

from .. import budget
from ..extras import check
from ..interrupts import Stopped
from ..rundir import OutputError, claim_folder
from ..scene import SceneError, load_scene
from ..two_granules import curves
from ..two_granules.boundaries import _DEFAULTS, PARAMS, Boundaries, find_boundaries


def add_parser(subparsers) -> None:
    """Register ``granular-chain boundaries`` on the CLI's subparsers.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The CLI's subparsers (``parser.add_subparsers()``).
    """
    _add_arguments(subparsers)


def run(args) -> int:
    """Entry point of ``granular-chain boundaries`` (refuses a plane without matplotlib
    and --dask without dask.distributed, before anything is written).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of ``granular-chain boundaries``.

    Returns
    -------
    int
        Exit status: 0 ok, 2 bad input, 128 + N stopped by signal N.
    """
    if args.y_param is not None:  # a plane: its curves are drawn as a PNG
        check("matplotlib", "granular-chain boundaries --y-param")
    if args.dask:
        check("distributed", "granular-chain boundaries --dask")
    return _run_command(args)


class _BadInput(Exception):
    pass


#: Bytes one scan point keeps until the refinement (its Collision and Result; measured
#: 16 kB with tracemalloc over 2000 points) and seconds it takes (measured 5 to 50 ms,
#: loaded 2-core machine; the estimate takes the low end).
SCAN_POINT_BYTES = 16_000
SCAN_POINT_SECONDS = 0.005


def check_grid(grid: int, available: Optional[int] = None) -> None:
    """Refuse a ``--grid`` whose scan would not fit in memory, before any collision.

    Parameters
    ----------
    grid : int
        Scan points.
    available : int, optional
        Bytes of memory to plan with (default :func:`~granular_chain.budget.available_memory`).

    Raises
    ------
    _BadInput
        One line with the estimate (memory, and time at SCAN_POINT_SECONDS a point).
    """
    need = grid * SCAN_POINT_BYTES
    available = budget.available_memory() if available is None else available
    if need > available:
        hours = grid * SCAN_POINT_SECONDS / 3600
        raise _BadInput(f"--grid {grid}: the scan keeps every point until it is refined, "
                        f"about {budget._gb(need)} ({SCAN_POINT_BYTES // 1000} kB a point; and at "
                        f"least {hours:.3g} hours), but {budget._gb(available)} of memory is "
                        f"available; use at most --grid {max(2, available // SCAN_POINT_BYTES)}")


def _add_arguments(subparsers) -> argparse.ArgumentParser:
    """Register ``granular-chain boundaries``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The CLI's subparsers (``parser.add_subparsers()``).

    Returns
    -------
    argparse.ArgumentParser
        The ``boundaries`` subparser.
    """
    p = subparsers.add_parser(
        "boundaries", help="find where the two-granule outcome changes along a parameter",
        description="Outcome boundaries of the two-granule collision (event stepper): every "
        "value of --param in --range where the outcome changes, to --tol relative. With "
        "--y-param, trace the boundary curves of the plane instead (CSV, JSON, PNG in --out).")
    p.add_argument("problem", nargs="?", default=None, metavar="SCENE_OR_PROBLEM",
                   help="a two-granule scene YAML (n, eta, gamma taken from it) or "
                   "'two_granules' (default: the paper's problem, n = 2, no friction)")
    p.add_argument("--param", required=True, help=f"one of {', '.join(PARAMS)}")
    p.add_argument("--range", nargs=2, type=float, required=True, metavar=("LO", "HI"))
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="NAME=VALUE",
                   help="fix another parameter (n, eta1, eta2, eta, gamma1, gamma2, gamma), "
                   "or rtol, t_max (repeatable)")
    p.add_argument("--tol", type=float, default=1e-12, help="relative tolerance (1e-12)")
    p.add_argument("--grid", type=int, default=128, help="scan points (128)")
    p.add_argument("--by", choices=("outcome", "events"), default="outcome",
                   help="what must change: the outcome, or also the sequence of events")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--y-param", default=None, help="2-D: the y parameter of the plane")
    p.add_argument("--y-range", nargs=2, type=float, default=None, metavar=("LO", "HI"))
    p.add_argument("--out", default=None, help="2-D: folder for boundaries_curves.csv/.json/.png")
    p.add_argument("--dask", action="store_true", help="2-D: seed lines on a dask LocalCluster")
    return p


def _fixed_from(args) -> tuple:
    """(fixed values, options) from SCENE_OR_PROBLEM and --set."""
    fixed, opts = {}, {}
    if args.problem not in (None, "two_granules"):
        try:
            scene = load_scene(args.problem)
        except SceneError as exc:
            raise _BadInput(str(exc)) from None
        g = scene.granules
        if g.count != 2:
            raise _BadInput(f"{args.problem}: boundaries need a two-granule scene, this one has "
                            f"{g.count} granules")
        pair = lambda a: [float(a)] * 2 if np.isscalar(a) else [float(b) for b in a]  # noqa: E731
        n = scene.contacts.exponent
        fixed["n"] = float(n if np.isscalar(n) else n[0])
        fixed["eta1"], fixed["eta2"] = pair(g.friction.kinetic)
        fixed["gamma1"], fixed["gamma2"] = pair(g.friction.viscous)
    for item in args.sets:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or name not in set(_DEFAULTS) | {"eta", "gamma", "rtol", "t_max"}:
            raise _BadInput(f"--set {item!r}: expected NAME=VALUE with NAME one of n, eta1, "
                            f"eta2, eta, gamma1, gamma2, gamma, rtol, t_max")
        try:
            x = float(value)
        except ValueError:
            raise _BadInput(f"--set {item!r}: {value!r} is not a number") from None
        if not math.isfinite(x) or x < 0 or (name in ("n", "rtol", "t_max") and x <= 0):
            raise _BadInput(f"--set {item!r}: must be finite and "
                            f"{'positive' if name in ('n', 'rtol', 't_max') else '>= 0'}")
        if name in ("rtol", "t_max"):
            opts[name] = x
        elif name in ("eta", "gamma"):
            fixed[name + "1"] = fixed[name + "2"] = x
        else:
            fixed[name] = x
    if fixed.get("n", 2.0) <= 1:
        raise _BadInput(f"n must be > 1; got {fixed['n']}")
    return fixed, opts


def _table(res: Boundaries) -> str:
    rows = [f"{'value':>22}  {'bracket width':>13}  {'below':<27} {'above':<27} "
            f"{'collisions':>10} {'ms':>8}  error"]
    for b in res:
        err = "-" if b.error is None else f"{b.error:.1e}"
        rows.append(f"{b.value:22.16g}  {b.bracket[1] - b.bracket[0]:13.2e}  {b.below:<27} "
                    f"{b.above:<27} {b.collisions:>10d} {1e3 * b.seconds:8.2f}  {err}")
    rows.append(f"scan: {res.grid} points, {res.scan_collisions} collisions, "
                f"{res.scan_seconds:.3f} s; fixed: "
                + ", ".join(f"{k} = {v:g}" for k, v in res.fixed.items()))
    return "\n".join(rows)


def _run_command(args, announce=None) -> int:
    """Entry point of ``granular-chain boundaries``: 0 ok, 2 bad input, 128 + N stopped
    by signal N.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of ``granular-chain boundaries``.
    announce : callable, optional
        Called once the arguments (and a 2-D ``--out``) are accepted, before any
        collision.

    Returns
    -------
    int
        Exit status: 0 ok, 2 bad input (also a --grid too large for memory), 130 (129,
        143) stopped by SIGINT (SIGHUP, SIGTERM).
    """
    try:
        fixed, opts = _fixed_from(args)
        if args.param not in PARAMS:
            raise _BadInput(f"--param {args.param!r}: expected one of {', '.join(PARAMS)}")
        fixed.pop(args.param, None)
        if args.param in ("eta", "gamma"):
            fixed.pop(args.param + "1", None), fixed.pop(args.param + "2", None)
        lo, hi = args.range
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise _BadInput(f"--range {lo:g} {hi:g}: expected finite LO < HI")
        if args.param != "n" and lo < 0:
            raise _BadInput(f"--range: {args.param} must be >= 0")
        if args.param == "n" and lo <= 1:
            raise _BadInput("--range: n must be > 1")
        if args.grid < 2 or not 0 < args.tol < 1:
            raise _BadInput("--grid must be >= 2 and --tol in (0, 1)")
        check_grid(args.grid)
        if args.y_param is not None:
            return _run_plane(args, fixed, opts, announce)
        if announce is not None:
            announce()
        res = find_boundaries(args.param, lo, hi, fixed, args.tol, grid=args.grid, by=args.by,
                              rtol=opts.get("rtol"), t_max=opts.get("t_max", 1000.0))
    except (_BadInput, ValueError) as exc:
        print(f"granular-chain: {exc}", file=sys.stderr)
        return 2
    except Stopped as stop:
        print(f"granular-chain: boundaries: interrupted by {stop}; nothing written",
              file=sys.stderr)
        return 128 + stop.signum
    print(json.dumps(res.to_dict(), indent=2) if args.json else _table(res))
    return 0


def _run_plane(args, fixed, opts, announce=None) -> int:
    if args.y_range is None or args.out is None:
        raise _BadInput("--y-param needs --y-range LO HI and --out FOLDER")
    if args.y_param not in PARAMS or "n" in (args.param, args.y_param):
        raise _BadInput(f"--y-param {args.y_param!r}: the plane's parameters must be frictions")
    box = (tuple(args.range), tuple(args.y_range))
    if not (box[1][0] < box[1][1]) or box[1][0] < 0:
        raise _BadInput("--y-range: expected 0 <= LO < HI")
    for k in (args.y_param,) + ((args.y_param + "1", args.y_param + "2")
                                if args.y_param in ("eta", "gamma") else ()):
        fixed.pop(k, None)
    try:  # decided before any collision is run
        claim = claim_folder(args.out, "boundaries", [f"boundaries_curves.{ext}"
                                                      for ext in ("csv", "json", "png")])
    except OutputError as exc:
        raise _BadInput(str(exc)) from None
    if announce is not None:
        announce()
    found = curves.trace_curves((args.param, args.y_param), box, fixed, args.tol,
                          t_max=opts.get("t_max", 1000.0), rtol=opts.get("rtol"),
                          executor="dask" if args.dask else "serial")
    try:
        with claim:
            paths = curves.write_curves(found, claim.folder) if found else []
            if found:
                paths.append(curves.plot_curves(found, claim.folder / "boundaries_curves.png",
                                                box, fixed))
    except Stopped as stop:  # (the claim is undone, or its folder marked incomplete)
        left = (f"{claim.folder} marked incomplete, {len(claim.written)} of its files "
                f"written" if claim.written else "nothing written")
        print(f"granular-chain: boundaries: interrupted by {stop}; {left}", file=sys.stderr)
        return 128 + stop.signum
    summary = {"curves": [{k: v for k, v in c.to_dict().items() if k not in ("points", "normals")}
                          | {"points": len(c.points)} for c in found],
               "files": [str(p) for p in paths]}
    print(json.dumps(summary, indent=2) if args.json else
          "\n".join(f"{c.below} | {c.above}: {len(c.points)} points, ends {c.ends}, "
                    f"{c.collisions} collisions" for c in found)
          + "".join(f"\nwrote {p}" for p in paths))
    return 0
