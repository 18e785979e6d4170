"""Test-session settings.

The suite runs on two pytest-xdist workers (``-n 2`` in pyproject's addopts): most of its time is
Numba's single-threaded compilation and small scenes, which two processes overlap on two cores.
Each worker runs its Numba loops on one thread so that two workers do not oversubscribe the
cores; the thread count is set at run time (not through NUMBA_NUM_THREADS, which would key a
second on-disk cache for the command-line subprocesses the tests start).
"""

from __future__ import annotations

import os


def pytest_configure(config) -> None:  # noqa: ANN001 - pytest's hook signature
    """Give each xdist worker one Numba thread."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        import numba

        numba.set_num_threads(1)
