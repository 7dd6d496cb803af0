"""``granular-chain boundaries``: outcome boundaries of the two-granule collision (the
command is defined with them, in :mod:`granular_chain.two_granules.boundaries`)."""

from __future__ import annotations


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
    """Entry point of ``granular-chain boundaries`` (announces a first compilation
    once its arguments and --out are accepted).

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
    from ..warmup import announce_compilation
    # the collisions run on the event stepper; said once the arguments are accepted
    return run_boundaries_command(args, announce=lambda: announce_compilation("event"))
