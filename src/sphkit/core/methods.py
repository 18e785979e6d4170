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

from sphkit.backend import device_of
from sphkit.core import arrays

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
    mirrored: float  #: 1: the solver adds the mirrored share ``m_b``; 0: it does not
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


def checked_number(what: str, value: Any, lo: float = 0.0, hi: float = math.inf,
                   expected: str = "a finite number >= 0") -> float:
    """``value`` as a float when it is a finite number in ``[lo, hi]``; otherwise a
    ``ValueError`` that names the parameter ``what`` (e.g. ``"surface tension (he2014):
    coefficient"``), the value and ``expected``. The one check of the methods' numeric
    parameters (a NaN, an infinity, a string or a negative coefficient given through the API)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not (math.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"{what}: {value!r}; expected {expected}")
    return v


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

    def boundary_at(self, state: SimState, dx: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, NeighborList, np.ndarray] | None:
        """The boundary neighbours ``(x_b, V_b, lists, body)`` of :meth:`update` for the fluid
        at the positions ``x + dx`` (dim, N) instead of ``x = state.fluid["x"]`` (a solve's
        predicted positions), leaving the state as it is; ``body``: each neighbour's 1-based
        moving rigid body (0: static), as the boundary field ``rigid_body``. None: they do not
        depend on the fluid positions beyond the step-start lists (boundary particles); maps
        place their virtual particles anew."""
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

    def init(self, state: SimState) -> None:
        """Set the boundary fields (e.g. stop mirroring where the model replaces it)."""
        return None

    @abstractmethod
    def diagonal_mirror(self) -> np.ndarray:
        """The mirror share (N_boundary,) the Jacobi diagonals count for its samples."""

    @abstractmethod
    def prepare(self, state: SimState) -> None:
        """Once per step, after the densities: what the extrapolation needs of this step."""

    @abstractmethod
    def extrapolate(self, k: np.ndarray, out: np.ndarray) -> None:
        """``out[b] = p_b / rho0`` for the solver field k of the fluid (kappa units)."""

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
    def yielding(self, state: SimState) -> np.ndarray:
        """Which boundary particles yield (N_boundary,) bool."""

    @abstractmethod
    def response(self, k: np.ndarray, gwb: np.ndarray) -> np.ndarray:
        """The accelerations (dim, N_boundary) of the boundary particles under the pressure
        field k of a solver sweep (``gwb``: the cached ``V_b grad W_ib``); 0 where the boundary
        does not yield."""

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


#: ``solved: "density"``: a wall particle holds its start value only where every fluid
#: neighbour had a filled kernel then, ``rho / rho0 >= 1 - COVERED_TOLERANCE``
#: (:meth:`BoundaryCoupling.wall_rest`). The start-up's masses make filled kernels exact to
#: 1e-6 (:data:`sphkit.world.startup.MASS_TOLERANCE`); a free surface's top row lacks 10-20 %.
COVERED_TOLERANCE = 1e-3


class BoundaryCoupling:
    """How every pressure solver meets the boundary, the same way for all of them.

    * **mirror weights** (:meth:`mirror`): the boundary field ``pressure_mirror`` ``m_b``, the
      share of mirrored boundary pressure in the boundary term
      ``-sum_b V_b ((1 + m_b) k_i + k_b) grad W_ib`` (:func:`sphkit.core.ppe.
      kappa_accel_cached`; 0 where a boundary model does not set it);
    * **boundary pressure** (:meth:`boundary_kappa`, :meth:`prepare`, :meth:`correct_mirrored`):
      the extrapolated ``k_b = p_b / rho0`` of a :class:`BoundaryPressure` model, or nothing
      (mirrored pressure, the default);
    * **moving boundaries** (:meth:`predict`, :meth:`response`, :meth:`take_impulse`,
      :meth:`displacement`): how boundary particles of bodies that yield to the pressure move
      inside the solves (strong coupling, Gissler et al. 2019); static walls by default;
    * **the boundary at predicted positions** (:meth:`boundary_at`): the boundary model's
      neighbours for fluid positions inside a solve (maps' virtual particles).
    """

    def __init__(self, pressure: BoundaryPressure | None = None,
                 moving: MovingBoundary | None = None,
                 model: BoundaryModel | None = None, symmetric: bool = False,
                 solved: bool | str = False) -> None:
        """``solved``: the scene's ``configuration.boundary.solved`` (False; True or
        ``"velocity"``; ``"density"``: see :meth:`solved_walls` and :meth:`wall_rest`)."""
        self.pressure = pressure
        #: the symmetric boundary term ``V_b k_i`` in the PPE solvers (see :meth:`mirror`)
        self.symmetric = symmetric
        #: the static walls' pressures are unknowns of the PPE (:meth:`solved_walls`)
        self.solved = bool(solved)
        #: ``solved: "density"``: the density solves hold the fluid's density at each wall
        #: particle at its rest value (:meth:`wall_rest`), not only its rate
        self.density_walls = solved == "density"
        self._wall_k: dict[str, np.ndarray] = {}
        self.moving = moving
        self.model = model
        self._still = np.zeros((0, 0))

    def boundary_at(self, state: SimState, dx: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, NeighborList, np.ndarray]:
        """The boundary neighbours ``(x_b, V_b, lists, body)`` for the fluid displaced by
        ``dx`` (the boundary model's :meth:`BoundaryModel.boundary_at`; the step's own where
        they do not depend on the fluid positions; ``body``: the boundary field
        ``rigid_body``, zeros where a state has none)."""
        at = self.model.boundary_at(state, dx) if self.model is not None else None
        if at is None:
            b = state.boundary
            if "rigid_body" in b.specs and b["rigid_body"].shape[0] == b.n:
                body = b["rigid_body"]
            else:
                body = arrays.zeros(b.n, np.int64, like=b["x"])
            return b["x"], b["V"], state.nl_fb, body
        return at

    @property
    def reacts(self) -> bool:
        """Whether moving bodies take the fluid's reaction (:meth:`pair_reaction`)."""
        return self.moving is not None and self.moving.reacts

    def pair_reaction(self, state: SimState, k: np.ndarray, x: np.ndarray, bx: np.ndarray,
                      bV: np.ndarray, lists: NeighborList, body: np.ndarray
                      ) -> np.ndarray | None:
        """The bodies' reaction (bodies, 6) to the boundary share ``-k_i V_b grad W(x_i -
        x_b)`` (:meth:`MovingBoundary.pair_reaction`); None without moving bodies."""
        if self.moving is None:
            return None
        return self.moving.pair_reaction(state, k, x, bx, bV, lists, body)

    def following(self, state: SimState, dx: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, NeighborList]:
        """The step's boundary neighbours moved with the fluid's displacement ``dx``
        (:meth:`BoundaryModel.following`; the step's own where a model keeps them fixed)."""
        at = self.model.following(state, dx) if self.model is not None else None
        if at is None:
            return state.boundary["x"], state.boundary["V"], state.nl_fb
        return at

    # -- boundary pressure ----------------------------------------------------------------------
    def mirror(self, state: SimState, diagonal: bool = False) -> np.ndarray:
        """The mirror weights ``m_b`` (N_boundary,); ``diagonal``: the weights the Jacobi
        diagonals use, which count extrapolated boundary pressures as mirrored.

        ``symmetric`` (scene ``configuration.boundary.symmetric``): ``m_b = 0`` and no
        extrapolated ``k_b`` (:meth:`boundary_kappa`), SPlisHSPlasH's boundary term ``V_b k_i``.
        Only that term keeps the PPE operator symmetric positive (semi)definite in p (the
        divergence of the boundary pairs has the same ``V_b grad W_ib`` once); with full
        mirroring or the MLS value the wall pushes a particle harder than the divergence
        accounts for, which a single fluid tolerates but which turns the smallest eigenvalue
        negative once a light phase lies between walls and a heavy one (measured, 2D column
        1000 over 100 kg/m^3, r = 2 cm: eigenvalues of the diagonal-scaled operator from
        -0.0025 (MLS) / -0.0018 (mirror) to +0.0077 (this), the mode being the light layer's
        pressure; Jacobi then diverges along it and DFSPH, IISPH blew up at 1.1-1.6 s;
        validation/README.md, "Several fluids"). Not the default: on lattice walls it lets a
        resting light-over-heavy column move at 0.3 m/s and steepens the hydrostatic slopes
        by 5-10 %."""
        b = state.boundary
        if self.symmetric:  # the symmetric term (see below)
            return arrays.zeros(b.n, b.dtype, like=b["x"])
        m = self._mirror_field(state)
        if self.solved:  # the static walls' own pressure k_b instead (solved_walls)
            return np.where(self.solved_walls(state), 0.0, m).astype(b.dtype)
        if diagonal and self.pressure is not None:
            m = m + self.pressure.diagonal_mirror()
        return m

    @staticmethod
    def _mirror_field(state: SimState) -> np.ndarray:
        b = state.boundary
        if "pressure_mirror" in b.specs and b["pressure_mirror"].shape[0] == b.n:
            return b["pressure_mirror"]
        return arrays.zeros(b.n, b.dtype, like=b["x"])

    def boundary_kappa(self, state: SimState) -> BoundaryKappa:
        """The extrapolation ``k -> k_b`` of this step's pressure fields (see
        :class:`BoundaryKappa`)."""
        return BoundaryKappa(None if self.symmetric or self.solved else self.pressure, state)

    def symmetric_walls(self, state: SimState) -> np.ndarray:
        """Which boundary particles take the symmetric term ``V_b k_i`` (no mirrored share, no
        extrapolated ``k_b``): all with ``symmetric``; with ``solved`` the static walls
        (:meth:`solved_walls`), not rigid bodies; none otherwise. The mask of :meth:`mirror`'s
        zeros for WCSPH, whose boundary term mirrors every boundary particle otherwise."""
        if self.symmetric:
            return np.ones(state.boundary.n, dtype=np.bool_)
        return self.solved_walls(state)

    def solved_walls(self, state: SimState) -> np.ndarray:
        """Which boundary particles carry a pressure of their own that the PPE solvers solve
        for (scene ``configuration.boundary.solved``; static walls, not rigid bodies; all
        False when off). Their boundary term is ``-sum_b V_b (k_i + k_b) grad W_ib`` with
        ``k_b >= 0`` chosen in the same Jacobi iteration as the fluid's so that the fluid's
        normalized density at the wall particle, ``sum_f V_f W_fb``, does not change in the
        step (:func:`sphkit.core.solver.jacobi_ppe`). The force is then the transpose of
        that constraint (a Lagrange multiplier's): it does no work on a flow that keeps it,
        unlike the mirrored or extrapolated ``k_b``, whose share beyond ``V_b k_i`` made a
        closed box of fluid at rest gain energy (``validation/wall_energy.py``). After Band
        et al. 2018, "Pressure boundaries for implicit incompressible SPH" (ACM TOG 37(2)),
        whose extended PPE gives boundary samples a pressure of their own; the paper itself
        could not be read here: the constraint (the fluid density at the wall held, velocity
        level) and its Jacobi update are sphkit's. ``solved: "density"`` holds the density
        itself at its rest value in the density solves (:meth:`wall_rest`); it does not make
        the split of the support between ``k_b`` and the fluid's pressure unique
        (validation/README.md, "Solved walls at density level")."""
        b = state.boundary
        if not self.solved:
            return np.zeros(b.n, dtype=np.bool_)
        if "rigid_body" in b.specs and b["rigid_body"].shape[0] == b.n:
            return b["rigid_body"] == 0
        return np.ones(b.n, dtype=np.bool_)

    def wall_rest(self, state: SimState) -> np.ndarray:
        """The rest value of the fluid's normalized density ``rho_hat_b = sum_f V_f W_fb`` at
        each solved wall particle (``solved: "density"``): its value at the first density
        solve that sees it (the run's start, after :mod:`sphkit.world.startup`) where the
        wall particle is *covered* then -- it has fluid neighbours and every one of them has
        a filled kernel (``rho / rho0 >= 1 -`` :data:`COVERED_TOLERANCE`) --, else -2 (the
        wall particle keeps the velocity-level constraint, that of ``solved: true``); -1 where
        not yet computed. Kept in the boundary field ``wall_rest`` (so checkpoints keep it).

        Why the start value: the start-up sets every fluid mass so that its density is exactly
        its start density (rest density for the incompressible solvers) with the walls as
        they stand, so the start configuration satisfies every fluid row and every wall row
        at once, whatever the walls' shape (faces, edges, corners, meshes) and wherever the
        start-up's relaxation moved the first fluid row. A value from the wall geometry (the
        box's interior sampling lattice) was measured against it at the 2D column's walls: the
        start values were 0.76-0.78 of it along the side walls (the relaxation moves the first
        row away from Akinci walls), so the walls' rows would be slack at rest. Why only
        covered wall particles: at a free surface or where no fluid is at the start, the start
        value is a partial one; holding it would push fluid that arrives later (sloshing, a
        dam break's far wall) away from the wall, so those particles hold the rate only."""
        b = state.boundary
        if "wall_rest" not in b.specs:
            b.register("wall_rest", fill=-1.0)
        rest = b["wall_rest"]
        use = self.solved_walls(state)
        new = use & (rest == -1.0)
        if new.any():
            f = state.fluid
            rho_b = self.wall_density(state, new)
            boff, bidx = state.nl_fb.offsets, state.nl_fb.indices
            rows = np.repeat(np.arange(f.n), np.diff(boff))
            filled = (f["rho"] / f["rho0"] >= 1.0 - COVERED_TOLERANCE)[rows]
            seen = np.bincount(bidx, minlength=b.n) > 0
            thin = np.bincount(bidx, weights=(~filled).astype(np.float64), minlength=b.n) > 0
            covered = seen & ~thin
            rest[new] = np.where(covered[new], rho_b[new], -2.0)
        return rest

    def wall_density(self, state: SimState, use: np.ndarray) -> np.ndarray:
        """The fluid's normalized density ``sum_f V_f W_fb`` at the boundary particles with
        ``use`` (0 elsewhere; :func:`sphkit.core.ppe.wall_density`)."""
        from sphkit.core.pairs import period_arg
        from sphkit.core.ppe import wall_density

        f, b = state.fluid, state.boundary
        rest = state.rest()
        Vf = f["V0"] if rest.uniform else rest.V
        out = np.empty(b.n, dtype=f.dtype)
        wall_density(f["x"], Vf, b["x"], state.nl_fb.offsets, state.nl_fb.indices, state.h,
                     state.kid, state.dim, period_arg(state.pair_period), use, out)
        return out

    def wall_kappa(self, state: SimState, key: str) -> np.ndarray:
        """The solved walls' ``k_b`` of the solve named ``key`` (its warm start: the last
        step's values; zeros when the boundary changed size). Not checkpointed: a run resumed
        from a checkpoint starts its walls from zero."""
        n = state.boundary.n
        kb = self._wall_k.get(key)
        if kb is None or kb.shape[0] != n:
            kb = np.zeros(n, dtype=state.fluid.dtype)
            self._wall_k[key] = kb
        return kb

    def prepare(self, state: SimState) -> None:
        """Once per step after the densities (the MLS coefficients of this step's pairs)."""
        if self.pressure is not None:
            self.pressure.prepare(state)

    def correct_mirrored(self, state: SimState, a: np.ndarray) -> None:
        """A state-equation solver's correction from mirrored to the model's ``p_b``."""
        if self.pressure is not None:
            self.pressure.correct_mirrored(state, a)

    # -- moving boundaries ----------------------------------------------------------------------
    @property
    def yields(self) -> bool:
        """Whether some boundary yields to the pressure (strong coupling is on)."""
        return self.moving is not None and self.moving.yields

    def predict(self, state: SimState, dt: float) -> None:
        """Before the pressure solve: the yielding boundary's non-pressure velocity change."""
        if self.yields:
            self.moving.predict(state, dt)

    def response(self, state: SimState, k: np.ndarray, gwb: np.ndarray) -> np.ndarray:
        """Boundary accelerations (dim, N_boundary) under the solver field k (zeros when no
        boundary yields: then the pressure does not accelerate the boundary)."""
        if self.yields:
            return self.moving.response(k, gwb)
        x = state.boundary["x"]
        if (self._still.shape != x.shape or self._still.dtype != x.dtype
                or device_of(self._still) != device_of(x)):
            self._still = arrays.zeros(x.shape, x.dtype, like=x)
        return self._still

    def take_impulse(self, state: SimState, k: np.ndarray, gwb: np.ndarray, dt: float) -> None:
        """The yielding boundary takes the velocity change ``dt a_b(k)`` of a solve that
        applied the pressure impulse of k to the fluid (DFSPH's divergence solve), so that a
        later solve sees the boundary as the fluid does."""
        if self.yields:
            state.boundary["v"] += dt * self.moving.response(k, gwb)

    def displacement(self, state: SimState, k: np.ndarray, gwb: np.ndarray,
                     dt: float) -> np.ndarray:
        """Predicted displacement of the yielding boundary particles under the field k,
        ``dt (v_b + dt a_b(k))`` where the boundary yields and 0 elsewhere (PCISPH's predicted
        positions); an empty array when nothing yields (the static boundary stays put)."""
        if not self.yields:  # where the boundary is (a device array on the device)
            return arrays.empty((state.dim, 0), state.boundary.dtype, like=state.boundary["x"])
        ab = self.moving.response(k, gwb)
        return np.where(self.moving.yielding(state), dt * (state.boundary["v"] + dt * ab), 0.0)


class BoundaryKappa:
    """The boundary values ``k_b = p_b / rho0`` that :func:`sphkit.core.ppe.kappa_accel_cached`
    adds to its boundary term: extrapolated from the fluid field k by a
    :class:`BoundaryPressure` model when the scene has one, else none (an empty array, which the
    pass reads as 0: mirroring only)."""

    def __init__(self, model: BoundaryPressure | None, state: SimState) -> None:
        self.model = model
        n = state.boundary.n if model is not None else 0
        self.kb = arrays.zeros(n, state.fluid.dtype, like=state.fluid["x"])

    def __call__(self, k: np.ndarray) -> np.ndarray:
        """``k_b`` for the fluid field k."""
        if self.model is not None:
            self.model.extrapolate(k, self.kb)
        return self.kb
