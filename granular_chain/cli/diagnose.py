"""``granular-chain diagnose RUN_DIR_or_SCENE``: pulse, backscatter and energy ledger
of a run, as JSON (:mod:`granular_chain.diagnostics`)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..diagnostics import summarize
from ..errors import SimulationError
from ..readback import read_trajectory
from ..rundir import OutputError, claim_file, write_text_atomic
from ..scene import SceneError, load_scene
from ..simulate import simulate


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Register ``granular-chain diagnose RUN_DIR_or_SCENE`` on an argparse subparsers object.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The CLI's subparsers (``parser.add_subparsers()``).

    Returns
    -------
    argparse.ArgumentParser
        The ``diagnose`` subparser.
    """
    p = subparsers.add_parser(
        "diagnose", help="pulse speed/width, backscatter, energy ledger of a run or a scene",
        description="Diagnostics of a finished run (RUN_DIR with trajectory.h5) or of a "
        "scene file (simulated first). Prints JSON. Pulse speeds need fine frames: "
        "output.every of a few steps.")
    p.add_argument("target", metavar="RUN_DIR_or_SCENE")
    p.add_argument("--set", dest="overrides", action="append", default=[],
                   metavar="dotted.path=value", help="override a scene field (scene only)")
    p.add_argument("--first", type=int, default=3,
                   help="backscatter: the first this many granules (default 3)")
    p.add_argument("--out", default=None,
                   help="also write the JSON to this file: a new one, or one diagnose wrote "
                   "inside RUN_DIR (it joins the run's run.json)")
    return p


def run(args) -> int:
    """Entry point of ``granular-chain diagnose``: 0 ok, 1 run failed, 2 bad input.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of ``granular-chain diagnose``.

    Returns
    -------
    int
        The exit status.
    """
    target = Path(args.target)
    claim = None
    try:
        if args.out is not None:  # a new file, or one diagnose wrote in the run it reads
            claim = claim_file(args.out, "diagnose", home=target if target.is_dir() else None)
        if target.is_dir():
            if not (target / "trajectory.h5").is_file():
                print(f"granular-chain: {target}: no trajectory.h5 (run with trajectory on)",
                      file=sys.stderr)
                return 2
            try:
                result, scene = read_trajectory(target)
            except (OSError, ValueError) as exc:
                print(f"granular-chain: {target}/trajectory.h5: cannot be read ({exc})",
                      file=sys.stderr)
                return 2
            if args.overrides:
                print("granular-chain: --set applies to scene files, not run folders",
                      file=sys.stderr)
                return 2
        else:
            scene = load_scene(target, args.overrides)
            try:
                result = simulate(scene)
            except SimulationError as exc:
                print(f"granular-chain: {target}: {exc}", file=sys.stderr)
                return 2
    except (SceneError, OutputError) as exc:
        print(f"granular-chain: {exc}", file=sys.stderr)
        return 2
    summary = summarize(result, scene, first=args.first)
    text = json.dumps(summary, indent=2)
    print(text)
    for warning in summary["warnings"]:  # also in the JSON; said where a reader looks
        print(f"granular-chain: warning: {warning}", file=sys.stderr)
    if claim is not None:
        try:
            with claim:
                write_text_atomic(claim.paths[0], text + "\n")
        except OutputError as exc:
            print(f"granular-chain: {exc}", file=sys.stderr)
            return 2
    return 0 if result.success else 1
