"""``granular-chain schema``: the JSON Schema of scene files."""

from __future__ import annotations

import json

from .exit_codes import EXIT_OK


def add_parser(subparsers) -> None:
    subparsers.add_parser("schema", help="print the JSON Schema of scene files")


def run(args) -> int:
    from ..scene import scene_json_schema

    print(json.dumps(scene_json_schema(), indent=2))
    return EXIT_OK
