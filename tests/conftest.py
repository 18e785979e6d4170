"""Test-session settings.

The suite runs on two pytest-xdist workers (``-n 2`` in pyproject's addopts): most of its time is
Numba's single-threaded compilation and small scenes, which two processes overlap on two cores.
Each worker runs its Numba loops on one thread so that two workers do not oversubscribe the
cores; the thread count is set at run time (not through NUMBA_NUM_THREADS, which would key a
second on-disk cache for the command-line subprocesses the tests start).

The CUDA simulator test runs its script in a subprocess whose CPU side steps every solver and
boundary model: collected in file order it starts while the cache is cold and compiles those
passes a second time beside the workers (118 s in a fresh clone against 38 s with a warm cache),
so it is moved to 70 % of the order, after the tests that compile the same passes.
"""

from __future__ import annotations

import os


def pytest_configure(config) -> None:  # noqa: ANN001 - pytest's hook signature
    """Give each xdist worker one Numba thread."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        import numba

        numba.set_num_threads(1)


LATE = ("tests/test_cuda_simulator.py",)  #: subprocess tests that reuse the workers' cache


def pytest_collection_modifyitems(config, items) -> None:  # noqa: ANN001 - pytest's hook
    """Move the tests of :data:`LATE` to 70 % of the order (the same on every worker)."""
    late = [it for it in items if it.nodeid.split("::")[0] in LATE]
    if not late:
        return
    rest = [it for it in items if it.nodeid.split("::")[0] not in LATE]
    at = int(0.7 * len(rest))
    items[:] = rest[:at] + late + rest[at:]
