"""What every pressure solver reports per step."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class SolverStats:
    """Statistics of one pressure solve.

    ``density_error_avg``/``_max``: mean / max of ``max(rho - rho0, 0) / rho0`` (compression) over
    fluid particles, as fractions (0.001 = 0.1 %). ``divergence_error``: for divergence-free
    solvers, else 0. ``converged`` is False when the iteration limit stopped the solver.
    """

    iterations: int = 0
    density_error_avg: float = 0.0
    density_error_max: float = 0.0
    divergence_error: float = 0.0
    converged: bool = True
