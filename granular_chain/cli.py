"""The ``granular-chain`` command: run | validate | schema.

Exit status: 0 success, 1 a run that ended without success (its outputs say
why), 2 bad input (one line on stderr naming the file, the field and the
problem; nothing written).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

from .scene import SceneError, load_scene, scene_json_schema

EXIT_OK, EXIT_RUN_FAILED, EXIT_BAD_INPUT = 0, 1, 2


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="granular-chain", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run a scene and write its outputs")
    run.add_argument("scene", help="scene YAML file")
    run.add_argument("--set", dest="overrides", action="append", default=[],
                     metavar="dotted.path=value", help="override a scene field (repeatable)")
    run.add_argument("--out", default=None,
                     help="output folder (default outputs/<scene name>); replaced atomically")
    run.add_argument("--quiet", action="store_true", help="no progress bar, no report")

    val = sub.add_parser("validate", help="check a scene file and report what it contains")
    val.add_argument("scene")
    val.add_argument("--set", dest="overrides", action="append", default=[],
                     metavar="dotted.path=value")

    sub.add_parser("schema", help="print the JSON Schema of scene files")
    return p


def _fail(message: str) -> int:
    print(f"granular-chain: {message}", file=sys.stderr)
    return EXIT_BAD_INPUT


def _prepare_output(out: Path) -> Path:
    """A fresh temporary folder beside ``out`` (renamed onto it when the run is complete)."""
    parent = out.parent if str(out.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        return Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-", dir=parent))
    except OSError as exc:
        raise SceneError("--out", str(out), f"cannot be written ({exc.strerror or exc})") from None


def _publish(tmp: Path, out: Path) -> None:
    """Move the finished temporary folder onto ``out`` (replacing an older run)."""
    if out.exists():
        old = out.with_name(f".{out.name}.old-{os.getpid()}")
        out.rename(old)
        tmp.rename(out)
        shutil.rmtree(old, ignore_errors=True)
    else:
        tmp.rename(out)


def cmd_run(args) -> int:
    from .simulate import SimulationError, simulate
    from .writers.summary import write_summary
    from .writers.trajectory import write_trajectory

    try:
        scene = load_scene(args.scene, args.overrides)
    except SceneError as exc:
        return _fail(str(exc))
    out = Path(args.out) if args.out else Path("outputs") / scene.name
    if out.exists() and not out.is_dir():
        return _fail(f"--out: {out} exists and is not a folder")
    try:
        tmp = _prepare_output(out)
    except SceneError as exc:
        return _fail(str(exc))
    try:
        try:
            result = simulate(scene, progress=None if not args.quiet else False)
        except SimulationError as exc:
            shutil.rmtree(tmp, ignore_errors=True)
            return _fail(f"{args.scene}: {exc}")
        write_summary(result, tmp, scene)
        if scene.output.trajectory:
            write_trajectory(result, tmp, scene)
        _publish(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if not args.quiet:
        print(f"{result.status.name.lower()}: {result.message}")
        print(f"t_final = {result.t_final:.12g}, steps = {result.steps}, "
              f"energy balance error = {result.energy.balance_error:.3g} (relative)")
        print(f"wrote {out}/")
    return EXIT_OK if result.success else EXIT_RUN_FAILED


def cmd_validate(args) -> int:
    from .model import build_model
    from .simulate import SimulationError, check_dt, default_dt

    try:
        scene = load_scene(args.scene, args.overrides)
    except SceneError as exc:
        return _fail(str(exc))
    model = build_model(scene)
    dt = scene.run.dt if scene.run.dt is not None else default_dt(model)
    if scene.run.stepper == "verlet":
        try:
            check_dt(model, dt)
        except SimulationError as exc:
            return _fail(f"{args.scene}: {exc}")
    print(json.dumps({
        "scene": args.scene, "valid": True, "granules": model.count,
        "features": model.features.describe(), "stepper": scene.run.stepper,
        "dt": dt, "shortest_contact_time": model.shortest_period(),
    }, indent=2))
    return EXIT_OK


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "run":
        return cmd_run(args)
    if args.command == "validate":
        return cmd_validate(args)
    if args.command == "schema":
        print(json.dumps(scene_json_schema(), indent=2))
        return EXIT_OK
    return EXIT_BAD_INPUT  # argparse already refused unknown commands


if __name__ == "__main__":
    sys.exit(main())
