"""``granular-chain boundaries``: outcome boundaries of the two-granule collision (the
command is defined with them, in :mod:`granular_chain.two_granules.boundaries`)."""

from __future__ import annotations

from ..extras import check


def add_parser(subparsers) -> None:
    """Register ``granular-chain boundaries`` on the CLI's subparsers.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The CLI's subparsers (``parser.add_subparsers()``).
    """
    from ..two_granules.boundaries import add_boundaries_parser
    add_boundaries_parser(subparsers)


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
    from ..two_granules.boundaries import run_boundaries_command

    if args.y_param is not None:  # a plane: its curves are drawn as a PNG
        check("matplotlib", "granular-chain boundaries --y-param")
    if args.dask:
        check("distributed", "granular-chain boundaries --dask")
    return run_boundaries_command(args)
