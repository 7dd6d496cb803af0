"""What the engine tells its user besides results: warning classes and the logger.

Every warning goes through :mod:`warnings` with a class of this module, so a
program or a notebook can filter, record or raise them as it likes
(``warnings.simplefilter("ignore", granular_chain.GranularChainWarning)``
silences them all); ``granular-chain`` prints each as one line on stderr.
Progress that is not a warning goes to the :mod:`logging` logger
``"granular_chain"``.

Classes: :class:`GranularChainWarning` and, under it, :class:`OverlapWarning`
(granules i and i+2 overlapped: the model's nearest-neighbour contacts miss
that contact), :class:`TimeStepWarning` (run.dt changed to fit the frames),
:class:`PlotSkippedWarning` (a plot that could not be drawn while the others
were) and :class:`CompileNotice` (kernels are being compiled: the first run of
a feature set takes 10-60 s, later runs load them from numba's cache).
"""

from __future__ import annotations

import logging
import warnings

__all__ = ["GranularChainWarning", "OverlapWarning", "TimeStepWarning", "PlotSkippedWarning",
           "CompileNotice", "COMPILE_NOTICE", "logger", "warn"]

#: The logger of the package (progress: kernels compiled).
logger = logging.getLogger("granular_chain")

#: The start of every compile notice.
COMPILE_NOTICE = "compiling kernels, first run only (later runs reuse them)"


class GranularChainWarning(UserWarning):
    """Base class of the package's warnings."""


class OverlapWarning(GranularChainWarning):
    """Granules i and i+2 overlapped at a frame: the model ignores that contact."""


class TimeStepWarning(GranularChainWarning):
    """The Verlet step was changed from the scene's run.dt (frames fall on steps)."""


class PlotSkippedWarning(GranularChainWarning):
    """One plot was skipped (no pyvista, no off-screen OpenGL); the others are written."""


class CompileNotice(GranularChainWarning):
    """numba is compiling kernels for a feature set not in its cache (10-60 s, once)."""


def warn(message: str, category: type = GranularChainWarning, stacklevel: int = 2) -> None:
    """Issue ``message`` as a warning of ``category`` (``warnings.warn``), attributed
    ``stacklevel`` frames above the caller of this function.

    Parameters
    ----------
    message : str
        One line.
    category : type
        A subclass of :class:`GranularChainWarning`.
    stacklevel : int
        As ``warnings.warn``'s, counted from the function calling this one.
    """
    warnings.warn(message, category, stacklevel=stacklevel + 1)
