"""``granular-chain validate SCENE``: check a scene file and report what it contains."""

from __future__ import annotations

import json

from ..errors import SimulationError
from ..scene import SceneError, load_scene
from ..simulate import preflight, step_plan
from .exit_codes import EXIT_OK, fail


def add_parser(subparsers) -> None:
    """Register ``granular-chain validate`` on the CLI's subparsers.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The CLI's subparsers (``parser.add_subparsers()``).
    """
    val = subparsers.add_parser("validate", help="check a scene file and report what it contains")
    val.add_argument("scene")
    val.add_argument("--set", dest="overrides", action="append", default=[],
                     metavar="dotted.path=value")


def run(args) -> int:
    """Entry point of ``granular-chain validate``.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of ``granular-chain validate``.

    Returns
    -------
    int
        Exit status: 0 valid (a JSON report on stdout), 2 invalid.
    """
    try:
        scene = load_scene(args.scene, args.overrides)
        model = preflight(scene)
    except SceneError as exc:
        return fail(str(exc))
    except SimulationError as exc:
        return fail(f"{args.scene}: {exc}")
    dt = step_plan(model, scene).dt if scene.run.stepper == "verlet" else None
    print(json.dumps({
        "scene": args.scene, "valid": True, "granules": model.count,
        "features": model.features.describe(), "stepper": scene.run.stepper,
        "dt": dt, "shortest_contact_time": model.shortest_period(),
    }, indent=2))
    return EXIT_OK
