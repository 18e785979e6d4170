"""The state that methods read and write during a time step.

A :class:`SimState` bundles the particle sets, the neighbour lists of the current step and the
constants every method needs. Methods (pressure solvers, non-pressure forces, boundary models)
receive it, read and write fields of its particle sets, and never call each other.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sphkit.core.neighbors import NeighborList
from sphkit.core.particles import ParticleSet


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
    #: this step's cached pair gradients (:class:`sphkit.core.solver.PairGradients`), made with
    #: the densities for solvers that set ``uses_pair_gradients``; None outside that window
    pair_grads: Any = None
