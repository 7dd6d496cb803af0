"""Numba's look-ups keyed by compile flags, at the cost of a dictionary look-up.

While numba types a call to an ``@overload`` function (numpy's and math's functions,
``min``, ``literally``, the engine's ``@overload`` helpers), it looks the
implementation up in a cache keyed by the call's types and the compile's flags, a
``numba.core.targetconfig.TargetConfig`` (``_OverloadFunctionTemplate._get_impl``).
Every compile has flags objects of its own, so the look-up compares the new flags
with those of earlier compiles, and numba 0.68 makes both steps slow:

- ``TargetConfig.__hash__`` hashes the sorted names of the options (the keys of
  ``values()``), which are the same for every flags object of a class: it builds the
  dictionary of every option's value (22 property reads for numba's ``Flags``) to
  return a constant of the class.
- ``TargetConfig.__eq__`` builds that dictionary for both sides, although only the
  options either side has set can differ.

In the event kernel's compile these took about a tenth of the CPU time. While one of
the engine's kernels compiles, :func:`quick_flag_lookups` puts in place a hash that
is that constant, computed once per class, and an equality that compares the options
either side has set (numba's own for flags of two classes): the same answers
(``tests/test_flag_lookups.py``), so every look-up finds the entry it found before
and the machine code is the same. If the installed numba's methods are not the text
this module knows, numba's own are used unchanged.
"""

from __future__ import annotations

import inspect
import textwrap

from numba.core.targetconfig import TargetConfig

from ._method_swap import methods_swapped

#: Numba's methods as this module knows them: a faster version is used only for these.
_KNOWN = {
    "__hash__": ("def __hash__(self):\n"
                 "    return hash(tuple(sorted(self.values())))\n"),
    "__eq__": ("def __eq__(self, other):\n"
               "    if isinstance(other, TargetConfig):\n"
               "        return self.values() == other.values()\n"
               "    else:\n"
               "        return NotImplemented\n"),
}
_ORIGINAL = {name: TargetConfig.__dict__[name] for name in _KNOWN}

#: The hash of each TargetConfig class (numba's, a constant of the class).
_HASHES: dict = {}


def _hash(self) -> int:
    """Numba's hash, ``hash(tuple(sorted(self.values())))``: the sorted option names."""
    cls = type(self)
    value = _HASHES.get(cls)
    if value is None:
        value = _HASHES[cls] = hash(tuple(sorted(cls.options)))
    return value


#: The default of every option of each TargetConfig class.
_DEFAULTS: dict = {}


def _eq(self, other):
    """Numba's equality, ``self.values() == other.values()`` (every option's value, set
    or default), decided for two flags of one class from the options either has set:
    every other option reads its default on both sides."""
    if self is other:
        return True
    cls = type(self)
    if cls is not type(other):
        return _ORIGINAL["__eq__"](self, other)
    mine, theirs = self._values, other._values
    defaults = _DEFAULTS.get(cls)
    if defaults is None:
        defaults = _DEFAULTS[cls] = {k: option.default for k, option in cls.options.items()}
    for name in mine.keys() | theirs.keys():
        if name in defaults:
            a, b = mine.get(name, defaults[name]), theirs.get(name, defaults[name])
            if a is not b and not a == b:  # (a dict's comparison of values)
                return False
    return True


def _numba_is_known() -> bool:
    """Whether the installed numba's ``TargetConfig`` methods are the text above."""
    for name, text in _KNOWN.items():
        try:
            source = textwrap.dedent(inspect.getsource(_ORIGINAL[name]))
        except (OSError, TypeError):
            return False
        if source != text:
            return False
    return True


#: What quick_flag_lookups puts in place: nothing when numba is not the one known.
_FASTER = {"__hash__": _hash, "__eq__": _eq} if _numba_is_known() else {}


def applies() -> bool:
    """Whether the installed numba's flags are the ones this module speeds up."""
    return bool(_FASTER)


def quick_flag_lookups():
    """Compile with the faster flags hash and equality inside the block, numba's own
    outside it.

    Returns
    -------
    context manager
        Within it ``TargetConfig`` has this module's ``__hash__`` and ``__eq__`` (not
        when numba is not the one this module knows); a block inside another leaves
        them to the outer.
    """
    return methods_swapped(TargetConfig, _FASTER, _ORIGINAL)
