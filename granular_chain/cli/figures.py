"""``granular-chain figures``: the paper's figures (the command is defined with them,
in :mod:`granular_chain.paper.figures`)."""

from __future__ import annotations


def add_parser(subparsers) -> None:
    from ..paper.figures import add_figures_parser
    add_figures_parser(subparsers)


def run(args) -> int:
    from ..paper.figures import run_figures_command
    from ..warmup import announce_compilation
    announce_compilation("event")  # the collisions run on the event stepper
    return run_figures_command(args)
