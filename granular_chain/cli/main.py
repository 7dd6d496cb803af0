"""The ``granular-chain`` parser and dispatch: one module of this package per subcommand,
each with ``add_parser(subparsers)`` and ``run(args) -> exit status``."""

from __future__ import annotations

import argparse
import atexit
import importlib
import os
import signal
import sys
import threading
import warnings

from ..extras import MissingExtraError
from ..interrupts import STOP_SIGNALS, raise_on_signals
from ..notices import CompileNotice, GranularChainWarning, PlotSkippedWarning
from ..version import __version__
from .exit_codes import EXIT_BAD_INPUT, fail

__all__ = ["main", "build_parser", "show_warning", "COMMANDS"]

#: The subcommands, in the order ``--help`` lists them (each a module of this package).
COMMANDS = ("run", "validate", "schema", "plot", "sweep", "diagnose", "figures", "boundaries",
            "export", "classics")


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
    parser = _Parser(prog="granular-chain",
                     description=f"The granular-chain command: {' | '.join(COMMANDS)}.")
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
        Exit status (see :mod:`granular_chain.cli.exit_codes`). With ``argv`` None
        (the process's own command) the process ends with it instead, once the command
        is done (:func:`_exit_now`); argparse's own exits (``--help``, ``--version``,
        bad usage) end it with SystemExit before the command starts.
    """
    _drop_output_to_closed_pipes()
    try:
        with warnings.catch_warnings():  # (restores the hook and filters on return)
            warnings.simplefilter("always", GranularChainWarning)
            # a feature set's notice once (the run after prepare_kernels may compile
            # more of the same feature set's kernels)
            warnings.simplefilter("default", CompileNotice)
            warnings.showwarning = show_warning
            status = _main(argv)
    except KeyboardInterrupt as exc:  # a signal in the instant after the command's own
        # handlers were restored: its files are whole or cleaned up by then
        status = 128 + getattr(exc, "signum", signal.SIGINT)
    if argv is None:  # the process's own command: it ends the process
        _exit_now(status)
    return status


def _exit_now(status: int) -> None:
    """End the process once its command is done: its threads joined, its exit functions
    run, its output flushed, without the interpreter's teardown.

    The teardown (unloading the compiled kernels) takes about a second, more on a
    loaded machine, and runs with the signals' default actions, under which a Ctrl-C
    would kill a process whose result is already published and a user who asked a
    command to stop would wait for it. A signal that arrives here ends the process at
    once with 128 + its number (its files are whole or cleaned up by now).
    """
    for signum in STOP_SIGNALS:
        signal.signal(signum, _exit_on_signal)
    shutdown = getattr(threading, "_shutdown", None)  # what the interpreter's exit
    if shutdown is not None:  # does first: join the threads that are not daemons
        shutdown()
    atexit._run_exitfuncs()
    _flush_output()
    os._exit(status)


def _exit_on_signal(signum, frame) -> None:
    """The handler while the process ends: end it now, with 128 + ``signum``."""
    try:
        _flush_output()
    except Exception:  # (a flush cut into by the signal: "reentrant call")
        pass
    os._exit(128 + signum)


def _flush_output() -> None:
    """Flush stdout and stderr (either may be None, closed or a closed pipe)."""
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):
            pass


def _main(argv) -> int:
    """Parse and dispatch; a stray signal or a MemoryError said in one line."""
    try:
        args = build_parser().parse_args(argv)
        if args.command not in COMMANDS:
            return EXIT_BAD_INPUT  # argparse already refused unknown commands
        if getattr(args, "out", None) is not None and not str(args.out).strip():
            # an empty --out would fall back to a default place: say so instead
            return fail("--out: is empty; name a new folder (or file, for diagnose)")
        with raise_on_signals():  # a signal before (or after) a run's loop unwinds at once
            return _command(args.command).run(args)
    except MissingExtraError as exc:  # an optional library the command needs is absent
        said = str(exc)
        print(said if said.startswith("granular-chain") else f"granular-chain: {said}",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt as exc:  # a signal outside a run's own handling (start-up,
        # compilation, a second Ctrl-C): one line, no traceback; what was being written
        # is cleaned up
        signum = getattr(exc, "signum", signal.SIGINT)
        print(f"granular-chain: interrupted by {signal.Signals(signum).name}", file=sys.stderr)
        return 128 + signum
    except MemoryError:  # a cap the up-front estimate cannot see (ulimit -v, cgroups)
        print("granular-chain: out of memory: the process could not allocate what the run "
              "needs (a limit such as ulimit -v or a container's may be below the machine's "
              "memory); nothing written", file=sys.stderr)
        return EXIT_BAD_INPUT


def show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """``warnings.showwarning`` of the command: each warning one line on stderr,
    ``granular-chain: warning: ...`` (a skipped plot or a compile notice, which are
    not warnings about the results, without ``warning:``).

    Parameters
    ----------
    message : Warning or str
        The warning.
    category : type
        Its class.
    filename, lineno, file, line
        As ``warnings.showwarning``'s (where it was issued; unused: one line says it).
    """
    text = " ".join(str(message).split())
    if issubclass(category, (CompileNotice, PlotSkippedWarning)):
        said = f"granular-chain: {text}"
    elif issubclass(category, GranularChainWarning):
        said = f"granular-chain: warning: {text}"
    else:  # a library's warning, named by its class
        said = f"granular-chain: warning: {category.__name__}: {text}"
    print(said, file=sys.stderr, flush=True)


class _ClosedPipeSafe:
    """A text stream whose output is dropped once its reader has gone (``| head``):
    the command goes on and ends as it would have, without a BrokenPipeError."""

    def __init__(self, stream):
        self._stream = stream

    def _drop(self) -> None:
        # later writes, and the flush at exit, go to /dev/null
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, self._stream.fileno())
        finally:
            os.close(null)

    def write(self, text):
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            self._drop()
            return len(text)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._drop()

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _drop_output_to_closed_pipes() -> None:
    """Wrap stdout and stderr (once) in :class:`_ClosedPipeSafe`."""
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        if stream is None or isinstance(stream, _ClosedPipeSafe):
            continue
        try:
            stream.fileno()
        except (AttributeError, OSError, ValueError):  # not a file (pytest's capture)
            continue
        setattr(sys, name, _ClosedPipeSafe(stream))
