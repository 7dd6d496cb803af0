"""``python -m granular_chain.cli ...`` is the ``granular-chain`` command."""

import sys

from .main import main

if __name__ == "__main__":
    sys.exit(main())
