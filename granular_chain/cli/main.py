"""The ``granular-chain`` parser and dispatch: one module of this package per subcommand,
each with ``add_parser(subparsers)`` and ``run(args) -> exit status``."""

from __future__ import annotations

import argparse
import importlib

from .exit_codes import EXIT_BAD_INPUT, fail

__all__ = ["main", "build_parser", "COMMANDS"]

#: The subcommands, in the order ``--help`` lists them (each a module of this package).
COMMANDS = ("run", "validate", "schema", "plot", "sweep", "diagnose", "figures", "boundaries",
            "export")


class _Parser(argparse.ArgumentParser):
    """argparse with bad usage said in one line (the rule of every refusal here),
    exit status 2; ``--help`` still prints the whole usage."""

    def error(self, message: str):
        self.exit(EXIT_BAD_INPUT, f"granular-chain: {self.prog}: {message} "
                                  f"(see {self.prog} --help)\n")


def _command(name: str):
    """The module of subcommand ``name``."""
    return importlib.import_module(f"{__package__}.{name}")


def build_parser() -> argparse.ArgumentParser:
    """The ``granular-chain`` argument parser with every subcommand.

    Returns
    -------
    argparse.ArgumentParser
        The parser.
    """
    from .. import __version__
    from . import __doc__ as description

    # (the docstring's first paragraph: what the command is and its subcommands)
    parser = _Parser(prog="granular-chain", description=" ".join(
        description.split("\n\n")[0].replace("``", "").split()))
    parser.add_argument("--version", action="version", version=f"granular-chain {__version__}")
    subparsers = parser.add_subparsers(dest="command", required=True)
    for name in COMMANDS:
        _command(name).add_parser(subparsers)
    return parser


def main(argv=None) -> int:
    """Run ``granular-chain`` with ``argv`` (default ``sys.argv[1:]``); the exit status.

    Parameters
    ----------
    argv : list of str, optional
        Arguments after the program name.

    Returns
    -------
    int
        Exit status (see :mod:`granular_chain.cli.exit_codes`).
    """
    args = build_parser().parse_args(argv)
    if args.command not in COMMANDS:
        return EXIT_BAD_INPUT  # argparse already refused unknown commands
    if getattr(args, "out", None) is not None and not str(args.out).strip():
        # an empty --out would fall back to a default place: say so instead
        return fail("--out: is empty; name a new folder (or file, for diagnose)")
    return _command(args.command).run(args)
