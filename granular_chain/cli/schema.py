"""``granular-chain schema``: the JSON Schema of scene files."""

from __future__ import annotations

import json

from ..scene import scene_json_schema
from .exit_codes import EXIT_OK


def add_parser(subparsers) -> None:
    """Register ``granular-chain schema`` on the CLI's subparsers.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The CLI's subparsers (``parser.add_subparsers()``).
    """
    subparsers.add_parser("schema", help="print the JSON Schema of scene files")


def run(args) -> int:
    """Entry point of ``granular-chain schema``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of ``granular-chain schema``.

    Returns
    -------
    int
        0: the schema is printed on stdout.
    """
    print(json.dumps(scene_json_schema(), indent=2))
    return EXIT_OK
