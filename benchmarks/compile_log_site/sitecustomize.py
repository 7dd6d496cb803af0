"""Logs numba's compiles in every Python process started with this folder on
``PYTHONPATH`` and ``SUITE_COMPILE_LOG`` set (``benchmarks/suite_compile_log.py``)."""

import suite_compile_log

suite_compile_log.install_on_numba_import()
