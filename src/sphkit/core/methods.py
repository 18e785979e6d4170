"""The roles a method plays in a time step, and how boundaries reach the pressure solvers.

DESIGN.md, "Methods: roles, not types": a method is a small class with one entry point per
role, written against one of these Protocols. A method class inherits its Protocol explicitly
and so gets the no-op defaults, which is why the time step (:meth:`sphkit.simulation.
Simulation.step`) calls every entry point of every method without asking ``hasattr``:

* :class:`PressureSolver` -- ``init``, ``max_time_step``, ``pre_forces`` (DFSPH's factors and
  divergence-free solve), ``solve -> SolverStats``, ``boundary_reaction`` (the boundary share
  of its pressure acceleration, which moving bodies feel as the fluid force), and for the
  hydrostatic start ``compressed_density`` (the density that carries a pressure);
* :class:`NonPressureForce` -- ``init``, ``apply`` (adds to ``state.fluid["a"]``), ``stats``
  (an implicit solver's last solve), ``advect`` (moves the fluid after the integration: the
  transport velocity of :mod:`sphkit.transport`);
* :class:`BoundaryModel` -- ``init``, ``update`` (this step's fluid-boundary neighbours),
  ``rebuild`` (after boundary particles moved), ``bind_bodies``, ``forces``, ``inside`` (the
  fluid that starts inside the model's solid);
* :class:`Elasticity` -- ``init``, ``max_time_step``, ``apply`` (adds to ``state.fluid["a"]``
  for the particles of its solid), ``constrain`` (pinned particles, after the integration).

Each method builds itself from its part of the scene with ``from_config`` (the scene model's
``PressureConfig``, ``ViscosityConfig``, ... read by attribute; core does not import the
scene). The registry (:mod:`sphkit.registry`) names the classes.

:class:`sphkit.core.coupling.BoundaryCoupling` (its own module) is the one typed object through
which every solver meets the boundary, combining the last two roles here: the boundary pressure
a :class:`BoundaryPressure` model extrapolates and the response of boundaries that yield to the
pressure (:class:`MovingBoundary`: dynamic rigid bodies).
"""

from __future__ import annotations

import math
from abc import abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Protocol, runtime_checkable

import numpy as np

if TYPE_CHECKING:
    from sphkit.core.krylov import KrylovStats
    from sphkit.core.neighbors import NeighborList
    from sphkit.core.solver import SolverStats
    from sphkit.core.state import SimState


@dataclass
class BoundaryReaction:
    """The boundary share of a pressure solver's acceleration of fluid particle i,
    ``a_i<-b = -k_i (1 + mirrored m_b) V_b grad W_ib`` (``m_b``: the boundary field
    ``pressure_mirror``), from which moving bodies take the fluid's force ``-m_i a_i<-b``."""

    k: np.ndarray  #: per fluid particle, ``p_i / rho`` in the solver's normalisation [m^2/s^2]
    #: the factor of ``m_b``: 1: the solver adds the mirrored share ``m_b``; 0: it does not; an
    #: array (N_fluid,): per fluid particle (WCSPH, whose mirrored share is ``p_i / rho0_i``,
    #: ``rho_i^2 / rho0_i^2`` times its ``k_i``)
    mirrored: float | np.ndarray
    #: force (0:3) and torque (3:6) [N, N m] on each body (bodies, 6), about its centre, that
    #: the solver summed pair by pair inside its solve (:meth:`MovingBoundary.pair_reaction`),
    #: where its boundary share is not a field times the step's gradients (PBF: corrections at
    #: the predicted positions of every sweep); when set, the bodies take it instead of
    #: reacting to ``k``
    forces: np.ndarray | None = None


@runtime_checkable
class PressureSolver(Protocol):
    """A pressure solver (survey Sec. 4): WCSPH, PCISPH, PBF, IISPH, DFSPH."""

    name: ClassVar[str] = ""
    #: the step computes the cached pair gradients ``V_j grad W_ij`` in the density pass
    #: (:class:`sphkit.core.solver.PairGradients`) for this solver
    uses_pair_gradients: ClassVar[bool] = False
    #: the solver's pressure terms read a boundary pressure model (:class:`BoundaryPressure`,
    #: MLS); False (PBF, which has no boundary pressure): the world builds none for it
    uses_boundary_pressure: ClassVar[bool] = True

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

    def rejects(self, stats: SolverStats) -> bool:
        """Whether the step of the solve that gave ``stats`` is to be computed again with a
        smaller time step (``configuration.time.retries``): the solve failed. Only a solver
        whose solve changes nothing but its outputs (the acceleration, the pressure field) may
        answer True; False by default."""
        return False

    def boundary_reaction(self, state: SimState) -> BoundaryReaction | None:
        """The boundary share of the last solve's pressure acceleration (see
        :class:`BoundaryReaction`); None: the solver's pressure does not act on boundaries
        that could take a force (PBF moves positions)."""
        return None

    def checkpoint_state(self) -> dict:
        """The solver's own state across steps, for checkpoints (JSON-ready; PCISPH's adaptive
        step bound); empty for solvers whose state lives in particle fields."""
        return {}

    def restore_checkpoint_state(self, state: dict) -> None:
        """Take back what :meth:`checkpoint_state` wrote (``{}`` for checkpoints without it)."""
        return None

    def acoustic_speed(self, state: SimState) -> float:
        """The speed of sound of the solver's state equation at rest [m/s] (the start-up's
        settling, :mod:`sphkit.world.settle`); inf for the incompressible solvers, which have
        no acoustic modes to settle."""
        return math.inf

    def compressed_density(self, p: np.ndarray, rho0: np.ndarray) -> np.ndarray:
        """The density [kg/m^3] at which the fluid carries the pressure p [Pa] at rest (the
        hydrostatic start, :mod:`sphkit.world.startup`): rho0 for the incompressible solvers,
        the inverse of the state equation for WCSPH."""
        return np.broadcast_to(np.asarray(rho0, dtype=float), np.shape(p)).copy()


@runtime_checkable
class NonPressureForce(Protocol):
    """A non-pressure force (survey Sec. 5): viscosity, vorticity, surface tension, drag."""

    name: ClassVar[str] = ""
    #: an implicit solver's last solve (iterations, residual, converged); None for explicit ones
    stats: KrylovStats | None = None
    #: :meth:`apply` only adds to ``a`` what it computes from the state, so a step can be
    #: computed again with another time step (a rejected step, ``configuration.time.retries``);
    #: False for a force that keeps or changes other state in the step
    repeatable: ClassVar[bool] = False

    @classmethod
    def from_config(cls, config: Any) -> NonPressureForce:
        """The force with the parameters of its part of a material (``materials[k].viscosity``,
        ``.vorticity``, ``.surface_tension``, ``.drag``)."""
        return cls()

    def init(self, state: SimState) -> None:
        """Register fields (called once the world is built)."""
        return None

    def max_time_step(self, state: SimState) -> float:
        """The force's own bound on the time step [s] (an explicit viscosity's diffusion
        limit); inf: none."""
        return math.inf

    @abstractmethod
    def apply(self, state: SimState, dt: float) -> None:
        """Add this force's acceleration to ``state.fluid["a"]``."""

    def advect(self, state: SimState, dt: float) -> None:
        """Move the fluid after the step's ``x += dt v`` (a transport velocity's share of the
        displacement, :mod:`sphkit.transport`); none by default."""
        return None


@runtime_checkable
class BoundaryModel(Protocol):
    """A boundary model (survey Sec. 6): boundary particles or density / volume maps."""

    name: ClassVar[str] = ""
    #: its boundary neighbours are virtual particles, each standing for the whole wall near a
    #: fluid particle (density and volume maps), not samples of the wall (boundary particles)
    virtual: ClassVar[bool] = False
    #: distance [r] from a static mesh's surface within which the model's walls claim the
    #: fluid's place: fluid sampled closer starts inside the wall (:mod:`sphkit.world.startup`)
    start_reach: ClassVar[float] = 0.0
    #: whether :attr:`start_reach` also holds at a box's wall faces: the model's walls stand
    #: on the face (a map's surface), where boundary particles' box walls are sampled outside
    #: it, r off
    reach_at_boxes: ClassVar[bool] = False

    @classmethod
    def moving_inset(cls, dim: int) -> float:
        """Depth [r] by which a moving body's map surface lies inside its mesh in ``dim``
        dimensions (maps only), so that the fluid rests about r outside the mesh."""
        return 0.0

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

    def boundary_at(self, state: SimState, dx: np.ndarray, motion: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray, NeighborList, np.ndarray] | None:
        """The boundary neighbours ``(x_b, V_b, lists, body)`` of :meth:`update` for the fluid
        at the positions ``x + dx`` (dim, N) instead of ``x = state.fluid["x"]`` (a solve's
        predicted positions), leaving the state as it is; ``body``: each neighbour's 1-based
        moving rigid body (0: static), as the boundary field ``rigid_body``. ``motion``: the
        moving bodies' rigid displacement in the solve (:meth:`MovingBoundary.motion`; None:
        the bodies at their step-start poses). None: they do not depend on the fluid positions
        beyond the step-start lists (boundary particles); maps place their virtual particles
        anew."""
        return None

    def following(self, state: SimState, dx: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, NeighborList] | None:
        """The step's boundary neighbours ``(x_b, V_b, lists)`` moved along with the fluid's
        displacement ``dx`` where a model's virtual particles should slide with their fluid
        particle inside a prediction (volume maps); None: the step's own."""
        return None

    def bind_bodies(self, bodies: list) -> None:
        """The moving rigid bodies whose geometry this model queries in their own frames."""
        return None

    def forces(self) -> list[NonPressureForce]:
        """Non-pressure forces the model adds to the fluid (the walls' hydrostatic moment)."""
        return []

    def inside(self, state: SimState) -> tuple[np.ndarray, list[str]]:
        """Which fluid particles start inside the model's own solid (called once the world is
        built, before the first step; :mod:`sphkit.world.startup` removes them): an index
        (N,) into the returned geometry names, -1 where the particle is free. By default no
        particle is inside."""
        return np.full(state.fluid.n, -1, dtype=np.int64), []


@runtime_checkable
class Elasticity(Protocol):
    """An elasticity model of a solid material (survey, "Material models").

    A solid is a material of the fluid particle set: its particles (the scene objects named in
    :attr:`objects`, set by the world builder before :meth:`init`) go through the density and
    the pressure solve like the fluid, and the elasticity adds its acceleration in the
    non-pressure stage (:meth:`apply`). After the integration :meth:`constrain` holds the
    pinned particles (fixed boxes) where the model prescribes them: at their rest positions
    with zero velocity, or (kee2023, as SPlisHSPlasH's Kee et al. 2023) moved by their own
    velocity, which animation fields may set.
    """

    name: ClassVar[str] = ""
    #: the names of the particle-set objects (``fluid_blocks[0]``, ...) that form this solid
    objects: tuple[str, ...] = ()
    #: an implicit model's last solve (iterations, residual, converged); None when explicit
    stats: KrylovStats | None = None

    @classmethod
    def from_config(cls, config: Any) -> Elasticity:
        """The model with the parameters of a material's ``elasticity``."""
        return cls()

    def init(self, state: SimState) -> None:
        """Reference configuration and fields of the solid (called once the world is built,
        and again after a checkpoint restore: the stored rest positions are kept)."""
        return None

    def max_time_step(self, state: SimState) -> float:
        """The model's own bound on the time step [s] (inf: none)."""
        return math.inf

    @abstractmethod
    def apply(self, state: SimState, dt: float) -> None:
        """Add the elastic acceleration of the solid's particles to ``state.fluid["a"]``."""

    def constrain(self, state: SimState) -> None:
        """After the integration: pinned particles where the model prescribes them (at rest,
        or moved by their own velocity)."""
        return None


# ---------------------------------------------------------------------------------------------
# how boundaries reach the pressure solvers


@runtime_checkable
class BoundaryPressure(Protocol):
    """A boundary pressure model: the pressure ``p_b`` the boundary terms of the pressure
    solvers use, where it is not the mirrored ``p_b = p_i`` (Band et al. 2018's MLS
    extrapolation, :mod:`sphkit.boundary.band2018`)."""

    name: ClassVar[str] = ""
    #: the fluid's phase indices (N,) where the model gives each phase a boundary value of its
    #: own (several rest densities); :meth:`extrapolate` then fills (:attr:`phases`,
    #: N_boundary). None: one value per sample
    phase: np.ndarray | None = None

    def init(self, state: SimState) -> None:
        """Set the boundary fields (e.g. stop mirroring where the model replaces it)."""
        return None

    @property
    def phases(self) -> int:
        """Rows of :meth:`extrapolate`'s output: the phases where :attr:`phase` is set, else 1."""
        return 1

    @abstractmethod
    def diagonal_mirror(self) -> np.ndarray:
        """The mirror share (N_boundary,) the Jacobi diagonals count for its samples."""

    @abstractmethod
    def prepare(self, state: SimState) -> None:
        """Once per step, after the densities: what the extrapolation needs of this step."""

    @abstractmethod
    def extrapolate(self, k: np.ndarray, out: np.ndarray) -> None:
        """``out[b] = p_b / rho0`` for the solver field k of the fluid (kappa units);
        ``out[q, b]`` per phase q where :attr:`phase` is set; at the samples it extrapolates
        (every such sample with fluid neighbours in this step), the others left as they are
        (the coupling's array holds 0 there: :meth:`sphkit.core.coupling.BoundaryCoupling.
        boundary_kappa`)."""

    @abstractmethod
    def correct_mirrored(self, state: SimState, a: np.ndarray) -> None:
        """For a state-equation solver whose boundary term mirrored ``p_b = p_i``: add to the
        accelerations a the change to the model's ``p_b``."""


@runtime_checkable
class MovingBoundary(Protocol):
    """Boundaries that move with bodies and may yield to the pressure of the fluid (rigid
    bodies, :mod:`sphkit.boundary.rigid`)."""

    @property
    def yields(self) -> bool:
        """Whether any of it is pushed by the fluid's pressure (dynamic bodies)."""
        return False

    @property
    def reacts(self) -> bool:
        """Whether any of it takes the fluid's reaction (kinematic or dynamic bodies): whether
        :meth:`pair_reaction` has bodies to sum for."""
        return False

    def predict(self, state: SimState, dt: float) -> None:
        """Before the pressure solve: advance the yielding boundary's velocities by its
        non-pressure accelerations, as the fluid's are."""
        return None

    @abstractmethod
    def yielding(self, state: SimState, body: np.ndarray | None = None) -> np.ndarray:
        """Which boundary particles yield (N_boundary,) bool; ``body``: which of the samples
        with these 1-based body numbers (0: static) yield instead."""

    @abstractmethod
    def response(self, k: np.ndarray, gwb: np.ndarray) -> np.ndarray:
        """The accelerations (dim, N_boundary) of the boundary particles under the pressure
        field k of a solver sweep (``gwb``: the cached ``V_b grad W_ib``); 0 where the boundary
        does not yield."""

    @abstractmethod
    def motion(self, forces: np.ndarray | None, dt: float) -> np.ndarray:
        """The rigid displacement (bodies, 6: translation, rotation vector) each yielding body
        takes in the step under the forces and torques ``forces`` (bodies, 6, about the step's
        centres; None: none), its predicted velocity included; 0 where a body does not yield
        (a positional solve's strong coupling, PBF)."""

    @abstractmethod
    def displaced(self, motion: np.ndarray, bx: np.ndarray, body: np.ndarray) -> np.ndarray:
        """Points ``bx`` (dim, N) of the bodies ``body`` (N,; 1-based, 0: static) moved with
        their body's ``motion`` (:meth:`motion`)."""

    def pair_reaction(self, state: SimState, k: np.ndarray, x: np.ndarray, bx: np.ndarray,
                      bV: np.ndarray, lists: NeighborList, body: np.ndarray
                      ) -> np.ndarray | None:
        """The reaction on the bodies of a boundary share ``a_i<-b = -k_i V_b grad W(x_i -
        x_b)`` evaluated at the fluid positions x (dim, N) and the boundary neighbours ``(bx,
        bV, lists, body)`` of :meth:`BoundaryModel.boundary_at`: per body (bodies, 6) the force
        ``sum m_i k_i V_b grad W`` (0:3, minus the share's momentum, pair by pair) and its
        torque about the body's centre at ``x_b`` (3:6), for kinematic and dynamic bodies
        alike. For a solver that sums its boundary share inside the solve (PBF) into
        :attr:`BoundaryReaction.forces`; None: no bodies."""
        return None
