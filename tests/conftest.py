"""Test-session settings.

The suite runs on two pytest-xdist workers (``-n 2`` in pyproject's addopts): most of its time is
Numba's single-threaded compilation and small scenes, which two processes overlap on two cores.
Each worker runs its Numba loops on one thread so that two workers do not oversubscribe the
cores; the thread count is set at run time (not through NUMBA_NUM_THREADS, which would key a
second on-disk cache for the command-line subprocesses the tests start).

The CUDA-simulator test (:data:`LATE`) runs after the others: its subprocess steps every solver
on the CPU as the reference, and with a cold cache it compiled those passes itself (124-132 s in
CI against 42-46 s with them cached); run late, it loads what the other tests compiled.
"""

from __future__ import annotations

import os


def pytest_configure(config) -> None:  # noqa: ANN001 - pytest's hook signature
    """Give each xdist worker one Numba thread."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        import numba

        numba.set_num_threads(1)


#: test files moved to the end of the run (module docstring)
LATE = ("test_cuda_simulator.py",)


def pytest_collection_modifyitems(config, items) -> None:  # noqa: ANN001 - pytest's hook
    """Move the tests of :data:`LATE` to the end of the collection (xdist hands the tests out in
    this order)."""
    late = [item for item in items if item.path.name in LATE]
    if late:
        items[:] = [item for item in items if item.path.name not in LATE] + late
