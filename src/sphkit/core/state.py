"""The state that methods read and write during a time step.

A :class:`SimState` bundles the particle sets, the neighbour lists of the current step and the
constants every method needs. Methods (pressure solvers, non-pressure forces, boundary models)
receive it, read and write fields of its particle sets, and never call each other.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from sphkit.core.methods import BoundaryCoupling
from sphkit.core.neighbors import NeighborList
from sphkit.core.particles import ParticleSet

if TYPE_CHECKING:
    from sphkit.core.solver import PairGradients


@dataclass
class SimState:
    """Particles, neighbourhoods and constants of one simulation.

    Fluid fields used by every method: ``x``, ``v``, ``a`` (acceleration, (dim, N)), ``m`` (mass
    [kg]), ``rho`` (density [kg/m^3]), ``p`` (pressure [Pa]). Boundary fields: ``x``, ``V`` (the
    boundary particle's volume [m^dim], so that ``rho0 * V`` is its contribution psi to density),
    ``v`` (velocity of the boundary surface).
    """

    fluid: ParticleSet
    boundary: ParticleSet
    dim: int
    h: float  #: kernel support radius [m]
    kid: int  #: kernel id (see core.kernels)
    r: float  #: particle radius [m]
    rho0: float  #: rest density [kg/m^3]
    gravity: np.ndarray  #: gravitational acceleration (dim,) [m/s^2]
    nl_ff: NeighborList = field(default_factory=lambda: NeighborList.empty(0))
    nl_fb: NeighborList = field(default_factory=lambda: NeighborList.empty(0))
    time: float = 0.0
    step: int = 0
    #: this step's cached pair gradients ``V_j grad W_ij``, made with the densities for solvers
    #: that set ``uses_pair_gradients``; None outside that window
    pair_grads: PairGradients | None = None
    #: periodic along x: particles live in ``[period_lo, period_lo + period)``; period = 0: not
    #: periodic. Pair loops take minimum-image x differences ``d - L round(d / L)`` [m]
    period_lo: float = 0.0
    period: float = 0.0
    #: how the boundary reaches the pressure solvers: mirror weights, the boundary pressure of
    #: a boundary pressure model (MLS), the response of moving bodies (strong coupling)
    coupling: BoundaryCoupling = field(default_factory=BoundaryCoupling)

    @property
    def periodic(self) -> tuple[float, float] | None:
        """``(lo, L)`` of the periodic x axis for the neighbour search, or None."""
        return (self.period_lo, self.period) if self.period > 0.0 else None
