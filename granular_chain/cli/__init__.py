"""The ``granular-chain`` command: run | validate | schema | plot | export | sweep | diagnose |
figures | boundaries | classics.

Exit status: 0 success, 1 a run that ended without success (its outputs say
why), 2 bad input (one line on stderr naming the file, the field and the
problem; nothing written), 130 interrupted by Ctrl-C (SIGINT), 143 terminated
(SIGTERM), 129 hung up (SIGHUP): an interrupted run is written as far as it went,
marked incomplete.

What ``run`` writes, and where, is described in :mod:`.run`.

One module per subcommand (:mod:`.run`, :mod:`.validate`, :mod:`.schema`,
:mod:`.plot`, :mod:`.sweep`, :mod:`.diagnose`, :mod:`.figures`,
:mod:`.boundaries`, :mod:`.export`, :mod:`.classics`), each with ``add_parser`` and ``run``;
:mod:`.main` builds the parser and dispatches, :mod:`.exit_codes` holds the
exit statuses.
"""

from .exit_codes import (  # noqa: F401  (re-exported)
    EXIT_BAD_INPUT,
    EXIT_HANGUP,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_RUN_FAILED,
    EXIT_TERMINATED,
)
from .main import main

__all__ = ["main"]
