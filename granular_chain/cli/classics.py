"""``granular-chain classics [NAME ...]``: the classic experiments of granular-chain
physics (:mod:`granular_chain.classics`), each a table of the engine against its
reference; ``--out DIR`` also writes ``classics_<name>.csv``, ``.json`` and ``.png``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..classics import EXPERIMENTS, SCENES, format_table, table_csv, table_json
from ..classics.experiment import scene_of
from ..extras import check
from ..rundir import OutputError, claim_folder, write_atomic, write_text_atomic
from ..scene import SceneError
from .exit_codes import EXIT_OK, EXIT_RUN_FAILED, fail


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Register ``granular-chain classics`` on the CLI's subparsers.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The CLI's subparsers (``parser.add_subparsers()``).

    Returns
    -------
    argparse.ArgumentParser
        The ``classics`` subparser.
    """
    p = subparsers.add_parser(
        "classics", help="the classic experiments of granular chains, engine against reference",
        description="Without NAME: list the experiments. With NAME (or all): run it and print "
        "its table (quantity, engine, reference, relative difference, source).")
    p.add_argument("names", nargs="*", metavar="NAME", help="experiment(s) to run, or all")
    p.add_argument("--out", default=None,
                   help="also write classics_<name>.csv, .json and .png into this folder: a "
                   "new one (created and marked), or one an earlier classics command wrote")
    p.add_argument("--scenes", default=None,
                   help="folder holding the experiments' scenes (default: scenarios/classics "
                   "of the source tree)")
    return p


def _chosen(names) -> list:
    """The experiments named (``all``: every one), in order, each once."""
    if "all" in names:
        return list(EXPERIMENTS.values())
    return [EXPERIMENTS[n] for n in dict.fromkeys(names)]


def _listing() -> int:
    """Print the experiments, one line each."""
    width = max(len(n) for n in EXPERIMENTS)
    for name, e in EXPERIMENTS.items():
        print(f"{name.ljust(width)}  {e.title}")
    print("run one: granular-chain classics NAME [--out DIR]; every one: granular-chain "
          "classics all")
    return EXIT_OK


def run(args) -> int:
    """Entry point of ``granular-chain classics``: 0 ok, 1 an experiment failed, 2 bad input.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments of ``granular-chain classics``.

    Returns
    -------
    int
        The exit status.
    """
    if not args.names:
        if args.out is not None:
            return fail("classics: --out needs an experiment NAME (or all)")
        return _listing()
    unknown = [n for n in args.names if n != "all" and n not in EXPERIMENTS]
    if unknown:
        return fail(f"classics: unknown experiment {unknown[0]!r}; choose from "
                    f"{', '.join(EXPERIMENTS)} or all")
    chosen = _chosen(args.names)
    scenes = Path(args.scenes) if args.scenes is not None else SCENES
    for e in chosen:  # decided before any work: each scene there and valid
        for s in e.scenes:
            if not (scenes / s).is_file():
                return fail(f"classics: {scenes / s}: no such scene file (--scenes names the "
                            f"folder holding {', '.join(e.scenes)})")
            try:
                scene_of(scenes, s)
            except SceneError as exc:
                return fail(str(exc))
    claim = None
    if args.out is not None:
        check("matplotlib", "granular-chain classics --out")
        names = [f"classics_{e.name}.{ext}" for e in chosen for ext in ("csv", "json", "png")]
        try:
            claim = claim_folder(args.out, "classics", names)
        except OutputError as exc:
            return fail(str(exc))
    try:
        if claim is None:
            return _run_all(chosen, scenes, None)
        with claim:  # (a failed experiment leaves the folder marked incomplete, with why)
            return _run_all(chosen, scenes, claim.folder)
    except (SceneError, OutputError) as exc:
        return fail(str(exc))
    except _ExperimentFailed as exc:
        print(f"granular-chain: {exc}", file=sys.stderr)
        return EXIT_RUN_FAILED


class _ExperimentFailed(RuntimeError):
    """An experiment's runs did not give its answer (the message says why)."""


def _run_all(chosen, scenes: Path, out) -> int:
    """Run each experiment, print its table, write its files into ``out`` (claimed)."""
    for k, e in enumerate(chosen):
        try:
            outcome = e.run(scenes)
        except RuntimeError as exc:
            raise _ExperimentFailed(f"classics {e.name}: {exc}") from None
        print(("\n" if k else "") + format_table(outcome.rows, f"{e.name}: {e.title}"),
              flush=True)
        if out is not None:
            base = Path(out) / f"classics_{e.name}"
            write_text_atomic(base.with_suffix(".csv"), table_csv(outcome.rows))
            write_text_atomic(base.with_suffix(".json"),
                              table_json(e.name, e.title, outcome.rows, outcome.data))
            write_atomic(base.with_suffix(".png"), lambda tmp: e.figure(outcome, Path(tmp)))
    return EXIT_OK
