"""One-sided power-law contacts: small compiled scalar laws.

Force of a contact with overlap ``delta`` (positive when the granules
interpenetrate), force coefficient ``k`` and potential exponent ``n``::

    F(delta) = k * max(delta, 0)**(n - 1)          (repulsive, never attractive)
    V(delta) = k * max(delta, 0)**n / n            (F = dV/d(delta))

This is the paper's eq. (1) with ``V = a delta^n`` read on the overlap side
(the paper prints ``delta <= 0`` with ``delta`` defined positive on overlap: a
sign slip) and with ``k`` a *force* coefficient, ``k = n a``: the scaled
equations of Sec. II and Appendix A set the force coefficient to one.

Each law takes ``(delta, k, n)`` with ``delta >= 0`` already clipped, so the
kernels stay branch-free. ``n`` is ignored by the fixed-exponent laws; it is
passed so that every law has one signature and the kernels compose them.

The laws are registered by name (:func:`register_contact_law`): the three built
in here and any other, written in a file of its own (``docs/architecture.md``,
"Adding a contact law", is a worked example). A scene picks one with
``contacts.law``; by default the exponents choose among the built-in three. A
kernel is compiled for one law: its code is a compile-time constant, and
:func:`contact_force` and :func:`contact_energy` call that law's functions, looked up in
the registry while the kernel compiles (only the law's own code is typed and inlined).
"""

from __future__ import annotations

import inspect
import math
import zlib
from dataclasses import dataclass
from importlib import metadata
from types import CodeType, ModuleType
from typing import Callable, Optional

import numba
import numpy as np
from numba.core.errors import TypingError
from numba.extending import overload, sentry_literal_args

LAW_LINEAR = 0
LAW_HERTZ = 1
LAW_POWER = 2

#: The entry-point group through which an installed package offers contact laws to
#: scenes by name (each entry point a module that calls :func:`register_contact_law`).
ENTRY_POINT_GROUP = "granular_chain.contact_laws"


@numba.njit(inline="always", cache=True)
def linear_force(d, k, n):
    """n = 2: F = k d."""
    return k * d


@numba.njit(inline="always", cache=True)
def linear_energy(d, k, n):
    """n = 2: V = k d^2 / 2."""
    return 0.5 * k * d * d


@numba.njit(inline="always", cache=True)
def hertz_force(d, k, n):
    """n = 5/2: F = k d^(3/2), as d*sqrt(d) (a pow costs about three times more)."""
    return k * d * math.sqrt(d)


@numba.njit(inline="always", cache=True)
def hertz_energy(d, k, n):
    """n = 5/2: V = (2/5) k d^(5/2)."""
    return 0.4 * k * d * d * math.sqrt(d)


@numba.njit(inline="always", cache=True)
def power_force(d, k, n):
    """Any n > 1: F = k d^(n-1)."""
    return k * d ** (n - 1.0)


@numba.njit(inline="always", cache=True)
def power_energy(d, k, n):
    """Any n > 1: V = k d^n / n."""
    return k * d ** n / n


@dataclass(frozen=True)
class ContactLaw:
    """A contact law the kernels can be compiled for.

    Attributes
    ----------
    name : str
        The name a scene gives in ``contacts.law``.
    code : int
        The compile-time code the kernels are specialised on: 0, 1, 2 for the built-in
        laws; for another, a number made from its name, exponent and the compiled form
        of its two functions, so a kernel cached on disk for an earlier version of the
        law is never taken for it.
    force, energy : numba dispatcher
        ``F(d, k, n)`` and ``V(d, k, n)`` with ``F = dV/dd``, for ``d >= 0`` (already
        clipped): scene units of force and energy.
    exponent : float or None
        The exponent n the law stands for (every contact and wall of a scene that uses
        it must have it); None: any, the law reads each contact's n.
    words : str
        The law in the compile notice and ``validate`` (``"hertz (n=5/2)"``).
    builtin : bool
        One of the three laws the event stepper has Taylor series and closed forms for.
    """

    name: str
    code: int
    force: Callable
    energy: Callable
    exponent: Optional[float]
    words: str
    builtin: bool = False


_BY_NAME: dict[str, ContactLaw] = {}
_BY_CODE: dict[int, ContactLaw] = {}


def _law_code(name: str, force, energy, exponent) -> int:
    """A code for a law that is not built in: above the built-in ones, and different
    whenever what the law computes may differ (:func:`_fingerprint`), so that a kernel
    numba cached on disk for one version of a law is never loaded for another."""
    digest, seen = zlib.crc32(f"{name}|{exponent!r}".encode()), set()
    for fn in (force, energy):
        digest = _fingerprint(fn, digest, seen)
    return 16 + digest


def _fingerprint(fn, digest: int, seen: set) -> int:
    """crc32 ``digest`` carried over what a compiled function's result depends on: its
    bytecode, the names it reads, its constants (nested functions by their code), the
    values of the globals and closure cells it reads (numbers, strings, arrays by value;
    functions, compiled or not, by their own fingerprint, recursively; modules by
    name; other objects by type only: a law reading an object's attributes is
    registered under a new name when they change)."""
    fn = getattr(fn, "py_func", fn)
    if id(fn) in seen or not hasattr(fn, "__code__"):
        return zlib.crc32(repr(getattr(fn, "__name__", type(fn).__name__)).encode(), digest)
    seen.add(id(fn))
    code = fn.__code__
    digest = _code_digest(code, digest)
    for name in sorted(_names_read(code)):
        if name in fn.__globals__:
            digest = _value_digest(fn.__globals__[name], digest, seen)
    for cell in fn.__closure__ or ():
        digest = _value_digest(cell.cell_contents, digest, seen)
    return digest


def _code_digest(code, digest: int) -> int:
    """crc32 of a code object: bytecode, names, constants (nested code recursively)."""
    digest = zlib.crc32(code.co_code + repr(code.co_names).encode(), digest)
    for const in code.co_consts:
        if isinstance(const, CodeType):
            digest = _code_digest(const, digest)
        else:
            digest = zlib.crc32(repr(const).encode(), digest)
    return digest


def _names_read(code) -> set:
    """Global names a code object and the code nested in it read."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, CodeType):
            names |= _names_read(const)
    return names


def _value_digest(value, digest: int, seen: set) -> int:
    """crc32 carried over one value a law reads (see :func:`_fingerprint`)."""
    if isinstance(value, (bool, int, float, complex, str, bytes, tuple, type(None))):
        return zlib.crc32(repr(value).encode(), digest)
    if isinstance(value, np.ndarray):
        return zlib.crc32(value.tobytes() + repr((value.dtype, value.shape)).encode(), digest)
    if isinstance(value, ModuleType):
        return zlib.crc32(value.__name__.encode(), digest)
    if callable(value):
        return _fingerprint(value, digest, seen)
    return zlib.crc32(type(value).__name__.encode(), digest)


def register_contact_law(name: str, force, energy, *, exponent: Optional[float] = None,
                         words: Optional[str] = None) -> ContactLaw:
    """Make a contact law available to scenes (``contacts.law: NAME``) and kernels.

    Parameters
    ----------
    name : str
        The scene's name for it.
    force, energy : numba dispatcher
        ``@numba.njit`` functions ``(d, k, n) -> float``: the force ``F`` and the
        potential energy ``V`` of a contact of overlap ``d >= 0``, with ``F = dV/dd``
        (the energy ledger closes only then). Marked ``inline="always"`` they are
        inlined into the kernels as the built-in laws are.
    exponent : float, optional
        The power n the law stands for: the default time step, the scaling checks and
        the dashpots are worked out for ``k d^(n-1)``, and a scene choosing the law must
        give this exponent. None: the law takes each contact's n as given.
    words : str, optional
        The law in one line for notices; the name by default.

    Returns
    -------
    ContactLaw
        The registered law. Registering a name again replaces its law (a new code when
        the functions changed).
    """
    if not name.isidentifier():
        raise ValueError(f"contact law name {name!r} must be a plain identifier")
    if name in _BY_NAME and _BY_NAME[name].builtin:
        raise ValueError(f"contact law {name!r} is built in; give the new law another name")
    law = ContactLaw(name, _law_code(name, force, energy, exponent), force, energy,
                     None if exponent is None else float(exponent), words or name)
    return _add(law)


def _add(law: ContactLaw) -> ContactLaw:
    """Enter ``law`` in both tables."""
    old = _BY_NAME.get(law.name)
    if old is not None:
        _BY_CODE.pop(old.code, None)
    _BY_NAME[law.name] = law
    _BY_CODE[law.code] = law
    return law


def contact_law(name: str) -> ContactLaw:
    """The law registered as ``name``, looked for among the installed packages' entry
    points (group :data:`ENTRY_POINT_GROUP`) when no module has registered it yet.

    Parameters
    ----------
    name : str
        The law's name (``contacts.law``).

    Returns
    -------
    ContactLaw
        The registered law.

    Raises
    ------
    KeyError
        No law of that name; the message lists the known ones.
    """
    if name not in _BY_NAME:
        for entry in metadata.entry_points(group=ENTRY_POINT_GROUP):
            if entry.name == name:
                entry.load()   # the module registers its law when imported
    if name not in _BY_NAME:
        raise KeyError(f"no contact law {name!r} (known: {', '.join(known_laws())}; a law is "
                       f"registered with granular_chain.register_contact_law)")
    return _BY_NAME[name]


def law_of_code(code: int) -> ContactLaw:
    """The registered law compiled under ``code``.

    Parameters
    ----------
    code : int
        A law's code (:attr:`ContactLaw.code`, ``Features.law``).

    Returns
    -------
    ContactLaw
        The law.

    Raises
    ------
    KeyError
        No law of that code is registered in this process.
    """
    try:
        return _BY_CODE[int(code)]
    except KeyError:
        raise KeyError(f"no contact law of code {code} in this process (register the law "
                       f"before building or loading a run that uses it)") from None


def known_laws() -> list[str]:
    """Names of the registered laws, the built-in ones first."""
    return list(_BY_NAME)


def registered_force(law, d, k, n):
    """Force of the law of code ``law`` (built in or registered) at overlap ``d >= 0``
    (compiled: the law's own function, chosen while the kernel compiles)."""
    return law_of_code(law).force(d, k, n)


def registered_energy(law, d, k, n):
    """Energy of the law of code ``law`` (built in or registered) at overlap ``d >= 0``."""
    return law_of_code(law).energy(d, k, n)


def _compiled_law(which: str):
    """The typing of :func:`registered_force` / :func:`registered_energy`: the law is
    looked up by its code, which must be a compile-time constant."""
    def typer(law, d, k, n):
        # A code not yet a compile-time constant (a call from Python with a plain int):
        # numba compiles the caller again with it as one, as numba.literally does.
        sentry_literal_args(_SIGNATURE, ("law",), (law, d, k, n), {})
        try:
            fn = getattr(law_of_code(law.literal_value), which)
        except KeyError as exc:
            raise TypingError(str(exc.args[0])) from None

        def impl(law, d, k, n):
            return fn(d, k, n)
        return impl
    return typer


_SIGNATURE = inspect.signature(registered_force)
overload(registered_force, inline="always")(_compiled_law("force"))
overload(registered_energy, inline="always")(_compiled_law("energy"))


@numba.njit(inline="always", cache=True)
def contact_force(law, d, k, n):
    """Force of a contact of overlap ``d`` (any sign): zero unless ``d > 0``.

    ``law`` is a compile-time constant in the kernels: only that law's force is typed
    and compiled into each specialisation (:func:`registered_force`).

    Parameters
    ----------
    law : int
        The law's code (LAW_LINEAR, LAW_HERTZ, LAW_POWER or a registered law's),
        a compile-time constant.
    d : float
        Overlap, scene units of length (any sign).
    k : float
        Force coefficient, scene units of force / length^(n-1).
    n : float
        Potential exponent, dimensionless (ignored by the fixed-exponent laws).

    Returns
    -------
    float
        Repulsive force ``k max(d, 0)^(n-1)``, scene units of force.
    """
    d = max(d, 0.0)
    return registered_force(law, d, k, n)


@numba.njit(inline="always", cache=True)
def contact_energy(law, d, k, n):
    """Potential energy stored in a contact of overlap ``d`` (any sign).

    Parameters
    ----------
    law : int
        The law's code (LAW_LINEAR, LAW_HERTZ, LAW_POWER or a registered law's),
        a compile-time constant.
    d : float
        Overlap, scene units of length (any sign).
    k : float
        Force coefficient, scene units of force / length^(n-1).
    n : float
        Potential exponent, dimensionless (ignored by the fixed-exponent laws).

    Returns
    -------
    float
        ``k max(d, 0)^n / n``, scene units of energy.
    """
    d = max(d, 0.0)
    return registered_energy(law, d, k, n)


for _law in (ContactLaw("linear", LAW_LINEAR, linear_force, linear_energy, 2.0, "linear (n=2)", True),
             ContactLaw("hertz", LAW_HERTZ, hertz_force, hertz_energy, 2.5, "hertz (n=5/2)", True),
             ContactLaw("power", LAW_POWER, power_force, power_energy, None, "power", True)):
    _add(_law)
