"""Calling compiled kernels specialised on compile-time feature codes.

Kernels take their feature codes (contact law, friction present, walls, stop
mode) as integer arguments passed through ``numba.literally``, or as one named
tuple of integers compiled with each field a literal, so numba compiles one
specialisation per feature set, prunes the absent features'
branches and caches each specialisation on disk (``cache=True``); closures
over law functions, the other common way to specialise, are not cacheable.

Dispatching a literal argument from Python re-runs type inference on every
call (tens of milliseconds for a large kernel), so :func:`specialised` looks
the compiled specialisation up once and returns its entry point, which then
costs a fraction of a microsecond per call.
"""

from __future__ import annotations

import atexit
import contextlib
import contextvars
import fcntl
import hashlib
import os
import shutil
import tempfile
import time

import numba
from numba import types
from numba.core import event

from ._literal_folding import FeatureCompiler
from .notices import COMPILE_NOTICE, CompileNotice, logger, warn

_ENTRIES: dict = {}


def callee(**options):
    """``numba.njit`` for a function that only compiled code calls: cached, and without
    the CPython and C wrappers numba otherwise generates with every specialisation for
    calls from Python (numba's own ``@overload`` implementations are compiled so). The
    wrappers of a callee taking the event stepper's records cost about a sixth of the
    kernel's compile. Python must not call such a function (it has no entry point:
    ``tests/test_callees.py`` checks that no Python code does).

    Parameters
    ----------
    **options
        Further ``numba.njit`` options (``error_model``, ``_nrt``, ...).

    Returns
    -------
    callable
        The decorator.
    """
    return numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True,
                      pipeline_class=FeatureCompiler, **options)


def kernel(**options):
    """``numba.njit`` for a function Python calls (an entry point; compiled code may
    call it too): cached, and without the C wrapper (for ``cfunc`` and first-class
    function values, which the engine does not use).

    Parameters
    ----------
    **options
        Further ``numba.njit`` options.

    Returns
    -------
    callable
        The decorator.
    """
    return numba.njit(cache=True, no_cfunc_wrapper=True, pipeline_class=FeatureCompiler,
                      **options)


@numba.njit(inline="always", cache=True)
def run_time(code):
    """A literal feature code as a plain integer: a callee given it is compiled once
    for all its values and branches on it as it runs. For code that works only at
    output times, where a compile per value buys no speed.

    Parameters
    ----------
    code : int
        A compile-time feature code (``numba.literally``).

    Returns
    -------
    int
        The same value, typed int64.
    """
    return code + 0


#: A folder shared by processes that may compile the same kernels at the same time
#: (the test suite's workers, a sweep's workers): when set, a process compiling a
#: specialisation holds a lock on it there, and another asking for it meanwhile
#: waits and then loads it from numba's on-disk cache instead of compiling it too.
LOCK_DIR_ENV = "GRANULAR_CHAIN_COMPILE_LOCKS"


def specialised(dispatcher, args: tuple, literal: tuple[int, ...]):
    """The compiled entry point of ``dispatcher`` for these arguments.

    Parameters
    ----------
    dispatcher : numba Dispatcher
        An ``@njit`` function that calls ``numba.literally`` on the arguments at
        positions ``literal``.
    args : tuple
        A representative argument tuple (only its types and the literal values
        matter; the kernel is not run).
    literal : tuple of int
        Positions of the feature codes: integers, or named tuples of integers
        (each field then a compile-time constant, read as ``features.law``).

    Returns
    -------
    numba compiled overload
        The entry point (callable with ``args``' types).
    """
    # A cheap key (numba.typeof on every argument costs more than a small run):
    # the literal values, and each argument's type, dtype, rank, layout and
    # writability (what numba.typeof puts in an array's type).
    if not hasattr(dispatcher, "compile"):
        return dispatcher  # NUMBA_DISABLE_JIT=1 (debugging): the plain Python function
    key = (dispatcher,) + tuple(a if i in literal else _type_key(a) for i, a in enumerate(args))
    entry = _ENTRIES.get(key)
    if entry is None:
        sig = tuple(_literal_type(a) if i in literal else numba.typeof(a)
                    for i, a in enumerate(args))
        with _compile_lock(dispatcher, sig), _CompileWatch(dispatcher):
            dispatcher.compile(sig)  # compile, or load from the on-disk cache
        entry = dispatcher.overloads[sig].entry_point
        _ENTRIES[key] = entry
    return entry


#: The notice scope of the code running (:func:`compile_scope`): the feature set being
#: run, in words.
_SCOPE: contextvars.ContextVar = contextvars.ContextVar("granular_chain_compile_scope",
                                                        default=None)

#: The feature sets announced in this process: a later compile for one of them (the
#: run after :func:`~granular_chain.warmup.prepare_kernels`, a writer's kernel) goes to
#: the logger only. Python's own once-per-place rule of warnings cannot be relied on for
#: that: every ``warnings.catch_warnings`` resets it.
_ANNOUNCED: set = set()


@contextlib.contextmanager
def compile_scope(what: str):
    """Within: the kernels compiled are announced once, as for ``what`` (a run compiles
    several kernels of one feature set; one notice says so), and only the first time in
    the process that ``what`` compiles anything (also when a warnings filter hid that
    notice, as ``prepare_kernels(quiet=True)`` does). Nested scopes join the outermost.

    Parameters
    ----------
    what : str
        The feature set in words (``"verlet stepper: hertz (n=5/2)"``).

    Yields
    ------
    None
    """
    if _SCOPE.get() is not None:
        yield
        return
    token = _SCOPE.set(what)
    try:
        yield
    finally:
        _SCOPE.reset(token)


class _CompileWatch(event.Listener):
    """Around one ``dispatcher.compile``: numba signals "numba:compile" only when it
    compiles (a kernel loaded from its cache does not), so the first signal is the
    moment to announce it: :class:`~granular_chain.notices.CompileNotice` (a warning:
    notebooks and the command line show it) and the ``granular_chain`` logger."""

    def __init__(self, dispatcher):
        self.name = getattr(dispatcher, "__name__", "kernel")
        self.start = None
        self._installed = None

    def on_start(self, ev) -> None:
        if self.start is not None:
            return  # the kernel's callees compile inside it: one notice
        self.start = time.perf_counter()
        what = _SCOPE.get()
        if what is None:
            message = f"{COMPILE_NOTICE}: {self.name}"
        elif what not in _ANNOUNCED:
            _ANNOUNCED.add(what)
            message = f"{COMPILE_NOTICE}: {what}"
        else:
            message = ""
        logger.info("compiling %s", self.name)
        if message:
            warn(message, CompileNotice, stacklevel=1)

    def on_end(self, ev) -> None:
        pass

    def __enter__(self):
        self._installed = event.install_listener("numba:compile", self)
        self._installed.__enter__()
        return self

    def __exit__(self, *exc):
        self._installed.__exit__(*exc)
        if self.start is not None:
            logger.info("compiled %s in %.1f s", self.name,
                        time.perf_counter() - self.start)


def _literal_type(a):
    """The numba type of a feature code: a literal integer, or a named tuple of them."""
    if isinstance(a, tuple):
        return types.NamedTuple([types.literal(int(x)) for x in a], type(a))
    return types.literal(a)


def _type_key(a):
    """What numba.typeof puts in an argument's type: type, dtype, rank, layout and
    writability of an array; the same for each member of a tuple."""
    if isinstance(a, tuple):
        return tuple(_type_key(b) for b in a)
    if hasattr(a, "flags"):
        return (type(a), a.dtype, a.ndim, a.flags.c_contiguous, a.flags.writeable)
    return type(a)


@contextlib.contextmanager
def _compile_lock(dispatcher, sig):
    """Hold an exclusive lock on this specialisation in the folder named by
    :data:`LOCK_DIR_ENV` (nothing when it is unset or cannot be used); released
    when the process ends, whatever the way."""
    folder = os.environ.get(LOCK_DIR_ENV)
    if not folder:
        yield
        return
    name = f"{dispatcher.py_func.__module__}.{dispatcher.py_func.__qualname__}{sig}"
    path = os.path.join(folder, hashlib.sha1(name.encode()).hexdigest() + ".lock")
    try:
        fd = os.open(path, os.O_CREAT | os.O_RDWR, 0o600)
    except OSError:
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # (closing releases the lock)


def share_compiling() -> None:
    """Before starting worker processes on this machine (a LocalCluster): give them a
    lock folder (:data:`LOCK_DIR_ENV`, a temporary one removed at exit, unless one is
    set already), so that a kernel they all need first is compiled by one of them."""
    if os.environ.get(LOCK_DIR_ENV):
        return
    folder = tempfile.mkdtemp(prefix="granular-chain-compile-locks-")
    os.environ[LOCK_DIR_ENV] = folder
    atexit.register(shutil.rmtree, folder, True)
