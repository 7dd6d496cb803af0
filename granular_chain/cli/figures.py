"""``granular-chain figures``: the paper's figures (the command is defined with them,
in :mod:`granular_chain.paper.figures`)."""

from __future__ import annotations

from ..extras import check


def add_parser(subparsers) -> None:
    """Register ``granular-chain figures`` on the CLI's subparsers.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The CLI's subparsers (``parser.add_subparsers()``).
    """
    from ..paper.figures import add_figures_parser
    add_figures_parser(subparsers)


def run(args) -> int:
    """Entry point of ``granular-chain figures`` (refuses without matplotlib, before
    anything is written).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of ``granular-chain figures``.

    Returns
    -------
    int
        Exit status: 0 ok, 2 bad input.
    """
    from ..paper.figures import run_figures_command

    check("matplotlib", "granular-chain figures")
    return run_figures_command(args)
