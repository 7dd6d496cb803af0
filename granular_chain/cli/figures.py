"""``granular-chain figures``: the figures of the two-granule paper, redrawn from the
engine (:mod:`granular_chain.paper.figures`)."""

from __future__ import annotations

import argparse
import time

from ..extras import check
from ..paper import figures
from ..rundir import OutputError, claim_folder
from .exit_codes import fail


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``granular-chain figures`` to the CLI's subparsers.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The CLI's subparsers (``parser.add_subparsers()``).

    Returns
    -------
    argparse.ArgumentParser
        The ``figures`` subparser.
    """
    p = subparsers.add_parser(
        "figures", help="redraw every figure of the two-granule paper from the engine",
        description="Redraw the figures of Rosas, Buceta and Lindenberg, 'Dynamics of Two "
                    "Granules', from the event stepper, closed forms overlaid; writes "
                    "OUT/paper_<name>.png and prints the time each figure takes.")
    p.add_argument("--out", required=True,
                   help="a new folder (created and marked), or one an earlier figures "
                   "command wrote")
    p.add_argument("--only", default=None,
                   help=f"comma-separated subset of: {','.join(figures.FIGURES)}")
    p.add_argument("--grid", type=int, default=100,
                   help="points per axis of the (eta1, eta2) maps (default 100)")
    p.add_argument("--processes", type=int, default=2,
                   help="worker processes for the (eta1, eta2) maps (default 2)")
    return p


def run(args, announce=None) -> int:
    """Run ``granular-chain figures`` (refuses without matplotlib, before anything is
    written); returns the exit status.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed ``--out``, ``--only``, ``--grid``, ``--processes``.
    announce : callable, optional
        Called once the arguments and ``--out`` are accepted, before any figure.

    Returns
    -------
    int
        0 on success, 2 on a bad argument.
    """
    check("matplotlib", "granular-chain figures")
    only = [s.strip() for s in args.only.split(",") if s.strip()] if args.only else None
    if args.grid < 2 or args.processes < 1:
        return fail("--grid must be >= 2 and --processes >= 1")
    unknown = [n for n in only or () if n not in figures.FIGURES]
    if unknown:
        return fail(f"--only: unknown figure(s) {unknown}; "
                    f"choose from {list(figures.FIGURES)}")
    try:  # decided before any figure is drawn
        claim = claim_folder(args.out, "figures",
                             [f"paper_{n}.png" for n in only or figures.FIGURES])
    except OutputError as exc:
        return fail(str(exc))
    if announce is not None:
        announce()
    t = time.perf_counter()
    try:
        with claim:
            figures.make_figures(claim.folder, only=only, grid=args.grid,
                                 processes=args.processes)
    except OutputError as exc:
        return fail(str(exc))
    print(f"total {time.perf_counter() - t:.2f} s")
    return 0
