"""The state that methods read and write during a time step.

A :class:`SimState` bundles the particle sets, the neighbour lists of the current step and the
constants every method needs. Methods (pressure solvers, non-pressure forces, boundary models)
receive it, read and write fields of its particle sets, and never call each other.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numba
import numpy as np

from sphkit.backend import launch_reduce, to_host
from sphkit.core import arrays
from sphkit.core.coupling import BoundaryCoupling
from sphkit.core.neighbors import Grid, NeighborList
from sphkit.core.particles import ParticleSet

if TYPE_CHECKING:
    from sphkit.core.solver import PairGradients


@dataclass(frozen=True)
class RestArrays:
    """Per-particle rest density of the fluid in the forms the compiled passes read
    (Solenthaler & Pajarola 2008 number densities, as SPlisHSPlasH implements them).

    With ``c_i = rho0_i / rho0_ref`` (``rho0_ref`` = :attr:`SimState.rho0`):

    * density ``rho_i = rho0_i sum_j V0_j W_ij = c_i sum_j mu_j W_ij`` with ``mu_j = m_j /
      c_j = rho0_ref V0_j`` (the mass in reference units), boundary ``+ c_i rho0_ref V_b W_ib``;
    * pressure sums weigh the neighbour by ``rho0_j / rho0_i``: passes that evaluate the kernel
      take the ratio per pair, ``c_j * inv_c[i]`` (or ``c_i * inv_c[j]``); the passes over cached
      pair gradients take the field ``k c`` and multiply the particle's sum by ``inv_c[i]``
      (:func:`sphkit.core.ppe.kappa_accel_cached`), one gather per pair as before.

    For a single fluid ``c = 1`` exactly, so every product with c or inv_c is exact and the
    results are those of the single-density formulas to the last bit.
    """

    c: np.ndarray  #: rho0_i / rho0_ref (N,)
    inv_c: np.ndarray  #: rho0_ref / rho0_i (N,)
    mu: np.ndarray  #: m_i / c_i = rho0_ref V0_i [kg] (N,)
    rho0: np.ndarray  #: the field rho0 [kg/m^3] (N,)
    m: np.ndarray  #: the field m [kg] (N,)
    uniform: bool  #: True when every particle has the reference rest density (c == 1)
    V: np.ndarray  #: ``m_i * (1 / rho0_i)``: the rest volume [m^dim] (N,)
    inv_rho0: np.ndarray  #: ``1 / rho0_i`` [m^3/kg] (N,)

    @property
    def sums_factor(self) -> np.ndarray | None:
        """``inv_c`` for the passes that multiply a particle's sums by it, None for one rest
        density (the factor 1 then not read a particle)."""
        return None if self.uniform else self.inv_c

    @cached_property
    def one_mass(self) -> bool:
        """Whether every particle's ``mu`` is the same value (on the CPU; False on a device,
        where the test would read a value back): the passes may then take ``mu[0]`` for all."""
        mu = self.mu
        on_host = isinstance(mu, np.ndarray)
        return bool(on_host and mu.shape[0] > 0 and not arrays.any_differs(mu, float(mu[0])))

    @cached_property
    def groups(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The particles' classes of equal rest density for the solvers' convergence test
        (:func:`sphkit.core.solver.group_error`): (class of each particle (N,), particles per
        class), on the host; None for one rest density. Classes, not materials: two materials
        of one rest density solve as one (as one material would)."""
        if self.uniform:
            return None
        values, index = np.unique(to_host(self.rho0), return_inverse=True)
        return index, np.bincount(index, minlength=values.shape[0]).astype(np.float64)

    @staticmethod
    def of(fluid: ParticleSet, rho0_ref: float) -> RestArrays:
        """The arrays of a fluid set (fields ``rho0`` and ``m``), on the set's device: c,
        1 / rho0 and V in one pass (:func:`rest_body`, which also tells whether every rest
        density is the reference), 1 / c and mu only where they differ from c and m."""
        rho0, m = fluid["rho0"], fluid["m"]
        c, V, inv_rho0 = (arrays.empty(fluid.n, fluid.dtype, like=rho0) for _ in range(3))
        ref = fluid.dtype.type(rho0_ref)
        uniform = not fluid.n or launch_reduce(rest_body, fluid.n, rho0, m, ref, c, V,
                                               inv_rho0)[1] == 0.0
        mu = m if uniform else arrays.divided_by(m, c)
        inv_c = c if uniform else arrays.reciprocal(c)
        return RestArrays(c=c, inv_c=inv_c, mu=mu, rho0=rho0, m=m, uniform=uniform, V=V,
                          inv_rho0=inv_rho0)


@numba.njit(cache=True, inline="always")
def rest_body(i, rho0, m, ref, c, V, inv_rho0):
    """Particle i's ``c_i = rho0_i / rho0_ref`` (exactly 1 where they are equal), ``1 / rho0_i``
    and rest volume ``V_i = m_i * (1 / rho0_i)``, each operation rounded to the fields' type as
    NumPy's element-wise form rounds it (no fast math; ``ref`` in the fields' type); 1 where
    ``rho0_i`` differs from the reference, else 0 (reduced: are the rest densities uniform)."""
    c[i] = rho0[i] / ref
    inv_rho0[i] = 1.0 / rho0[i]
    V[i] = m[i] * inv_rho0[i]
    return 1.0 if rho0[i] != ref else 0.0


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
    #: the reference rest density [kg/m^3]: the first fluid material's. Every fluid particle
    #: carries its own in the field ``rho0``; the passes read it through :meth:`rest`
    rho0: float
    gravity: np.ndarray  #: gravitational acceleration (dim,) [m/s^2]
    nl_ff: NeighborList = field(default_factory=lambda: NeighborList.empty(0))
    nl_fb: NeighborList = field(default_factory=lambda: NeighborList.empty(0))
    time: float = 0.0
    step: int = 0
    #: this step's cached pair gradients ``V_j grad W_ij``, made with the densities for solvers
    #: that set ``uses_pair_gradients``; None outside that window
    pair_grads: PairGradients | None = None
    #: their floating-point type on the CPU (``configuration.pair_cache``: "auto", "float64",
    #: "float32"; :func:`sphkit.core.solver.pair_cache_dtype`)
    pair_cache: str = "auto"
    #: periodic along x: particles live in ``[period_lo, period_lo + period)``; period = 0: not
    #: periodic. Pair loops take minimum-image x differences ``d - L round(d / L)`` [m]
    period_lo: float = 0.0
    period: float = 0.0
    #: periodic along y too (``configuration.periodic_y``): ``[period_lo_y, period_lo_y +
    #: period_y)``; 0: not periodic along y. Pair loops then take :attr:`pair_period`
    period_lo_y: float = 0.0
    period_y: float = 0.0
    #: how the boundary reaches the pressure solvers: mirror weights, the boundary pressure of
    #: a boundary pressure model (MLS), the response of moving bodies (strong coupling)
    coupling: BoundaryCoupling = field(default_factory=BoundaryCoupling)
    #: the block of memory the step's neighbour searches write their rows into and the
    #: simulation's pair-gradient cache lives in (:class:`sphkit.core.arrays.Scratch`, CPU
    #: only; None: fresh arrays). A search invalidates the cache taken from it before, so only
    #: the step's own search and cache use it (:class:`sphkit.simulation.Simulation`)
    scratch: arrays.Scratch | None = field(default=None, repr=False)
    #: the grid of the fluid's search in this step's neighbour search, for the boundary's
    #: search against the fluid's cells (:meth:`sphkit.core.neighbors.Grid.query_grid`); None
    #: outside that window and where the fluid's lists come another way (device, Verlet lists)
    fluid_grid: Grid | None = field(default=None, repr=False)
    #: fluid particles the step moves by prescription (an emitter's region,
    #: :meth:`sphkit.world.emitters.FluidEmitter.mark`): int8 (N,), 1 where animated, from the
    #: step-start positions; None where no emitter animates. PCISPH, IISPH and DFSPH leave
    #: them out of their solves (:func:`sphkit.core.ppe.held`)
    animated: Any = field(default=None, repr=False)
    #: how often a failed solve's step may be computed again (``configuration.time.retries``
    #: where the world is repeatable, :attr:`sphkit.world.World.repeatable`; else 0): PCISPH
    #: leaves thrown particles out of a solve only where it cannot (:mod:`sphkit.core.impacts`)
    retries: int = 0
    _rest: tuple | None = field(default=None, repr=False)  # this step's RestArrays on a device
    _held: RestArrays | None = field(default=None, repr=False)  # see hold_rest

    def rest(self) -> RestArrays:
        """The fluid's rest quantities per particle (:class:`RestArrays`) from its fields
        ``rho0`` and ``m``, relative to the reference :attr:`rho0`. On a device they are made
        once per step (and set of fields): the test of uniformity reads a scalar back."""
        if self._held is not None:
            return self._held
        f = self.fluid
        if f.device == "cpu":
            return RestArrays.of(f, self.rho0)
        key = (self.step, f.n, id(f["rho0"]), id(f["m"]))
        if self._rest is None or self._rest[0] != key:
            self._rest = (key, RestArrays.of(f, self.rho0))
        return self._rest[1]

    def hold_rest(self, hold: bool = True) -> None:
        """Keep :meth:`rest` as it is now until ``hold_rest(False)``: the step's window in
        which the fields ``rho0`` and ``m`` do not change (the simulation holds them from its
        densities to the end of the pressure solve; about 11 us a call otherwise, six calls a
        DFSPH step)."""
        self._held = None
        if hold:
            self._held = self.rest()

    @property
    def device(self) -> str:
        """Where the fluid's fields are ("cpu" or "cuda"): the step's passes run there."""
        return self.fluid.device

    @property
    def periodic(self) -> tuple[float, float] | tuple[tuple[float, float], ...] | None:
        """The periodic axes for the neighbour search (:meth:`sphkit.core.neighbors.Grid.query`):
        ``(lo, L)`` of x when only x is periodic, ``((lo_x, L_x), (lo_y, L_y))`` when y is
        (L = 0: that axis is not periodic), None when no axis is."""
        if self.period_y > 0.0:
            return ((self.period_lo, self.period), (self.period_lo_y, self.period_y))
        return (self.period_lo, self.period) if self.period > 0.0 else None

    @property
    def pair_period(self) -> float | tuple[float, float]:
        """The period argument ``L`` of the pair loops (:mod:`sphkit.core.pairs`): the period
        along x [m] (0: none) when y is not periodic (every scene before ``periodic_y``, so
        their compiled loops are unchanged), else the tuple ``(L_x, L_y)`` [m]."""
        if self.period_y > 0.0:
            return (float(self.period), float(self.period_y))
        return self.period

    @property
    def periodic_axes(self) -> list[tuple[int, float, float]]:
        """``(axis, lo, L)`` of every periodic axis (NumPy code outside the pair loops)."""
        out = [(0, self.period_lo, self.period)] if self.period > 0.0 else []
        if self.period_y > 0.0:
            out.append((1, self.period_lo_y, self.period_y))
        return out

    @property
    def gravity_along_period(self) -> bool:
        """Whether gravity has a component along a periodic axis: the fluid is a flow that
        gravity drives, not a column at rest (no hydrostatic start, no fall to a floor)."""
        return any(self.gravity[a] != 0.0 for a, _lo, _length in self.periodic_axes)

    def standing_gravity(self) -> np.ndarray:
        """Gravity (dim,) without its components along periodic axes, which drive a flow and
        load no column."""
        g = np.array(self.gravity, float)[: self.dim]
        for axis, _lo, _length in self.periodic_axes:
            g[axis] = 0.0
        return g
