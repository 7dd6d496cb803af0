"""Exit statuses of the ``granular-chain`` command and its one-line refusal."""

from __future__ import annotations

import sys

__all__ = ["EXIT_OK", "EXIT_RUN_FAILED", "EXIT_BAD_INPUT", "EXIT_INTERRUPTED",
           "EXIT_TERMINATED", "EXIT_HANGUP", "fail"]

EXIT_OK, EXIT_RUN_FAILED, EXIT_BAD_INPUT = 0, 1, 2
EXIT_INTERRUPTED, EXIT_TERMINATED = 130, 143  # 128 + signal number, as shells report
EXIT_HANGUP = 129  # SIGHUP: the terminal was closed


def fail(message: str) -> int:
    """Say ``message`` in one line on stderr; the bad-input exit status.

    Parameters
    ----------
    message : str
        The refusal, one line.

    Returns
    -------
    int
        :data:`EXIT_BAD_INPUT` (2).
    """
    print(f"granular-chain: {message}", file=sys.stderr)
    return EXIT_BAD_INPUT
