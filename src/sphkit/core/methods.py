"""The roles a method plays in a time step, and how boundaries reach the pressure solvers.

DESIGN.md, "Methods: roles, not types": a method is a small class with one entry point per
role, written against one of these Protocols. A method class inherits its Protocol explicitly
and so gets the no-op defaults, which is why the time step (:meth:`sphkit.simulation.
Simulation.step`) calls every entry point of every method without asking ``hasattr``:

* :class:`PressureSolver` -- ``init``, ``max_time_step``, ``pre_forces`` (DFSPH's factors and
  divergence-free solve), ``solve -> SolverStats``, ``boundary_reaction`` (the boundary share
  of its pressure acceleration, which moving bodies feel as the fluid force);
* :class:`NonPressureForce` -- ``init``, ``apply`` (adds to ``state.fluid["a"]``), ``stats``
  (an implicit solver's last solve);
* :class:`BoundaryModel` -- ``init``, ``update`` (this step's fluid-boundary neighbours),
  ``rebuild`` (after boundary particles moved), ``bind_bodies``, ``forces``;
* :class:`Elasticity` -- ``init``, ``apply``, for the elastic solids to come.

Each method builds itself from its part of the scene with ``from_config`` (the scene model's
``PressureConfig``, ``ViscosityConfig``, ... read by attribute; core does not import the
scene). The registry (:mod:`sphkit.registry`) names the classes.

:class:`BoundaryCoupling` is the one typed object through which every solver meets the
boundary: the mirror weights of the boundary pressure, the boundary pressure a boundary
pressure model extrapolates (:class:`BoundaryPressure`), and the response of boundaries that
yield to the pressure (:class:`MovingBoundary`: dynamic rigid bodies, strong coupling). Its
defaults do nothing: mirrored pressure, static walls.
"""

from __future__ import annotations

import math
from abc import abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Protocol, runtime_checkable

import numpy as np

if TYPE_CHECKING:
    from sphkit.core.krylov import KrylovStats
    from sphkit.core.solver import SolverStats
    from sphkit.core.state import SimState


@dataclass
class BoundaryReaction:
    """The boundary share of a pressure solver's acceleration of fluid particle i,
    ``a_i<-b = -k_i (1 + mirrored m_b) V_b grad W_ib`` (``m_b``: the boundary field
    ``pressure_mirror``), from which moving bodies take the fluid's force ``-m_i a_i<-b``."""

    k: np.ndarray  #: per fluid particle, ``p_i / rho`` in the solver's normalisation [m^2/s^2]
    mirrored: float  #: 1: the solver adds the mirrored share ``m_b``; 0: it does not


@runtime_checkable
class PressureSolver(Protocol):
    """A pressure solver (survey Sec. 4): WCSPH, PCISPH, PBF, IISPH, DFSPH."""

    name: ClassVar[str] = ""
    #: the step computes the cached pair gradients ``V_j grad W_ij`` in the density pass
    #: (:class:`sphkit.core.solver.PairGradients`) for this solver
    uses_pair_gradients: ClassVar[bool] = False

    @classmethod
    def from_config(cls, config: Any) -> PressureSolver:
        """The solver with the parameters of a scene's ``configuration.pressure``."""
        return cls()

    def init(self, state: SimState) -> None:
        """Register fields; derive what the solver needs from the fluid (called again when
        fluid first appears, and after a checkpoint restore)."""
        return None

    def max_time_step(self, state: SimState) -> float:
        """The solver's own bound on the time step [s] (inf: only the CFL step)."""
        return math.inf

    def pre_forces(self, state: SimState, dt: float) -> None:
        """Work before the non-pressure forces (DFSPH: factors, divergence-free solve)."""
        return None

    @abstractmethod
    def solve(self, state: SimState, dt: float) -> SolverStats:
        """Add the pressure acceleration of this step to ``state.fluid["a"]``."""

    def boundary_reaction(self, state: SimState) -> BoundaryReaction | None:
        """The boundary share of the last solve's pressure acceleration (see
        :class:`BoundaryReaction`); None: the solver's pressure does not act on boundaries
        that could take a force (PBF moves positions)."""
        return None


@runtime_checkable
class NonPressureForce(Protocol):
    """A non-pressure force (survey Sec. 5): viscosity, vorticity, surface tension, drag."""

    name: ClassVar[str] = ""
    #: an implicit solver's last solve (iterations, residual, converged); None for explicit ones
    stats: KrylovStats | None = None

    @classmethod
    def from_config(cls, config: Any) -> NonPressureForce:
        """The force with the parameters of its part of a material (``materials[k].viscosity``,
        ``.vorticity``, ``.surface_tension``, ``.drag``)."""
        return cls()

    def init(self, state: SimState) -> None:
        """Register fields (called once the world is built)."""
        return None

    @abstractmethod
    def apply(self, state: SimState, dt: float) -> None:
        """Add this force's acceleration to ``state.fluid["a"]``."""


@runtime_checkable
class BoundaryModel(Protocol):
    """A boundary model (survey Sec. 6): boundary particles or density / volume maps."""

    name: ClassVar[str] = ""
    #: depth [r] by which a moving body's map surface lies inside its mesh (maps only)
    moving_inset_in_radii: ClassVar[float] = 0.0

    def init(self, state: SimState) -> None:
        """Register boundary fields and build the model's structures."""
        return None

    @abstractmethod
    def update(self, state: SimState) -> None:
        """This step's fluid-boundary neighbour lists ``state.nl_fb`` (and, for maps, the
        virtual boundary particles)."""

    def rebuild(self, state: SimState) -> None:
        """Rebuild what depends on the boundary positions after boundary particles moved."""
        return None

    def bind_bodies(self, bodies: list) -> None:
        """The moving rigid bodies whose geometry this model queries in their own frames."""
        return None

    def forces(self) -> list[NonPressureForce]:
        """Non-pressure forces the model adds to the fluid (the walls' hydrostatic moment)."""
        return []


@runtime_checkable
class Elasticity(Protocol):
    """An elasticity model of a solid material (survey, "Material models")."""

    name: ClassVar[str] = ""

    def init(self, state: SimState) -> None:
        """Reference configuration and fields of the solid."""
        return None

    @abstractmethod
    def apply(self, state: SimState, dt: float) -> None:
        """Add the elastic acceleration of the solid's particles."""
