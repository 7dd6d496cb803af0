"""``granular-chain sweep SCENE --grid ... | --list ...``: a grid of scene overrides run
on dask.distributed, resumable (see :mod:`granular_chain.sweep`)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..extras import check
from ..rundir import OutputError, claim_folder
from ..sweep import PointOptions, SweepError, parse_grid, parse_list, plot_heatmap, run_sweep
from ..sweep.heatmap import slug


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Register ``granular-chain sweep`` on an argparse subparsers object.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The CLI's subparsers (``parser.add_subparsers()``).

    Returns
    -------
    argparse.ArgumentParser
        The ``sweep`` subparser.
    """
    p = subparsers.add_parser(
        "sweep", help="run a grid of scene overrides on dask.distributed (resumable)",
        description="Run every point of a grid (or list) of scene overrides in parallel on "
        "dask.distributed; results.csv grows as points finish and a rerun resumes.")
    p.add_argument("scene", help="scene YAML file")
    p.add_argument("--grid", action="append", default=[], metavar="dotted.path=start:stop:num",
                   help="an axis of evenly spaced values (inclusive; add ':log' for geometric). "
                   "Lists can be indexed: granules.friction.kinetic[1]=0:0.8:41")
    p.add_argument("--list", dest="lists", action="append", default=[],
                   metavar="dotted.path=a,b,c", help="an axis of explicit values (YAML)")
    p.add_argument("--set", dest="fixed", action="append", default=[],
                   metavar="dotted.path=value", help="override applied to every point")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="address of a running dask scheduler (default: a LocalCluster)")
    p.add_argument("--workers", type=int, default=2, help="LocalCluster worker processes")
    p.add_argument("--serial", action="store_true", help="no dask: run in this process")
    p.add_argument("--batch-size", type=int, default=None, help="points per dask task")
    p.add_argument("--out", default=None,
                   help="a new folder, or one an earlier sweep wrote, to resume it "
                   "(default outputs/sweeps/<scene stem>)")
    p.add_argument("--quantity", action="append", default=[], metavar="NAME",
                   help="heat map of this column (2-D sweeps; repeatable)")
    p.add_argument("--mask", action="append", default=[], metavar="COLUMN=VALUE",
                   help="heat maps colour only points with this value (repeatable)")
    p.add_argument("--granules", default="0,1,-1", metavar="I,J,...",
                   help="granules whose final velocity is a column (default 0,1,-1)")
    p.add_argument("--frames", action="store_true",
                   help="keep the scene's output cadence (pulse speed, pulse death time)")
    p.add_argument("--restart", action="store_true", help="discard earlier results in --out")
    p.add_argument("--quiet", action="store_true", help="no progress bar, no report")
    return p


def run(args) -> int:
    """Entry point of ``granular-chain sweep``: 0 done, 1 every point failed, 2 bad input,
    130 interrupted (129, 143: SIGHUP, SIGTERM in a --serial sweep).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of ``granular-chain sweep``.

    Returns
    -------
    int
        The exit status.
    """
    if not args.serial:  # decided before the scene is read or a folder made
        check("distributed", "granular-chain sweep")
    if args.quantity:
        check("matplotlib", "granular-chain sweep --quantity")
    try:
        axes = [parse_grid(s) for s in args.grid] + [parse_list(s) for s in args.lists]
        if not axes:
            raise SweepError("give at least one --grid or --list axis")
        granules = tuple(int(g) for g in args.granules.split(",") if g.strip())
        mask = {}
        for item in args.mask:
            k, sep, v = item.partition("=")
            if not sep:
                raise SweepError(f"--mask {item!r}: expected COLUMN=VALUE")
            mask[k] = v
        out = Path(args.out) if args.out else Path("outputs") / "sweeps" / Path(args.scene).stem
        stats = run_sweep(args.scene, axes, out_dir=out, fixed=args.fixed,
                          options=PointOptions(frames=args.frames, granules=granules),
                          executor="serial" if args.serial else "dask",
                          scheduler=args.scheduler, workers=args.workers,
                          batch_size=args.batch_size, progress=False if args.quiet else None,
                          restart=args.restart)
    except (SweepError, ValueError) as exc:
        print(f"granular-chain: {exc}", file=sys.stderr)
        return 2
    if not args.quiet:
        print(json.dumps(stats.as_dict(), indent=2))
    if stats.interrupted:
        print(f"granular-chain: interrupted after {stats.skipped + stats.computed} of "
              f"{stats.points} points; rerun the same command to resume", file=sys.stderr)
        return 128 + stats.signal if stats.signal else 130
    if stats.computed and stats.failed == stats.computed:
        print(f"granular-chain: every point of the sweep failed ({stats.failed} of "
              f"{stats.points}; results in {stats.results}); the first: {stats.first_error}",
              file=sys.stderr)
        return 1
    if args.quantity:
        if len(axes) != 2:
            print("granular-chain: heat maps need exactly two axes", file=sys.stderr)
            return 2
        try:  # the sweep's own folder, claimed like its results
            with claim_folder(out, "sweep", [f"heatmap_{slug(q)}.png" for q in args.quantity]):
                for q in args.quantity:
                    png = plot_heatmap(stats.results, axes[0].path, axes[1].path, q,
                                       out / f"heatmap_{slug(q)}.png", mask=mask or None)
                    if not args.quiet:
                        print(png)
        except (SweepError, OutputError) as exc:
            print(f"granular-chain: {exc}", file=sys.stderr)
            return 2
    return 0
