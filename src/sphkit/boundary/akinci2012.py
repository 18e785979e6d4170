"""Boundary particles of Akinci et al. 2012, "Versatile rigid-fluid coupling for incompressible
SPH", ACM TOG 31(4).

The boundary is sampled by particles b (one layer suffices). Because their sampling is irregular,
each gets the volume of Eq. (4) of the paper,

    V_b = 1 / sum_k W_bk        (k over boundary particles, self included),

except the lattice walls of scene boxes, which continue the fluid's lattice and keep its
lattice volume (:func:`static_volumes`). Each boundary particle contributes ``psi_b = rho0 V_b``
to fluid density (Eq. 6): ``rho_i += sum_b psi_b W_ib``, and to
the pressure force with pressure mirroring (Eq. 10; p_b = p_i, rho_b = rho0 as in SPlisHSPlasH),
see :func:`sphkit.core.operators.pressure_accel_body`. Boundary particles reach the solvers only
as neighbours (``state.nl_fb``) and fields (``V``, ``v``) of ``state.boundary``.
"""

from __future__ import annotations

import numba
import numpy as np

from sphkit.backend import on_device, to_device, to_host
from sphkit.core.hashgrid import HashGrid, hash_origin
from sphkit.core.kernels import kernel_w
from sphkit.core.methods import BoundaryModel
from sphkit.core.neighbors import Grid, NeighborList, Period, neighbor_lists, pair_period
from sphkit.core.pairs import distance, pair_slots, point
from sphkit.core.state import SimState


@numba.njit(parallel=True, cache=True, fastmath=True)
def _volumes(x, off, idx, h, kid, dim, L, V):
    for b in numba.prange(x.shape[1]):
        xb0, xb1, xb2 = point(x, b, dim)
        s = kernel_w(kid, 0.0, h, dim)
        for k in pair_slots(off, b):
            s += kernel_w(kid, distance(xb0, xb1, xb2, x, idx[k], dim, L), h, dim)
        V[b] = 1.0 / s


@numba.njit(parallel=True, cache=True, fastmath=True)
def _nearest(x, off, idx, bx, dim, L, dist, near):
    """Distance to the nearest boundary neighbour of each fluid particle (inf: none) and its
    index (-1: none)."""
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        best = np.inf
        b_best = -1
        for k in pair_slots(off, i):
            b = idx[k]
            d = distance(xi0, xi1, xi2, bx, b, dim, L)
            if d < best:
                best = d
                b_best = b
        dist[i] = best
        near[i] = b_best


def boundary_volumes(x: np.ndarray, h: float, kid: int, dim: int,
                     period: Period = None,
                     out: np.ndarray | None = None) -> np.ndarray:
    """The volumes of Eq. (4), ``V_b = 1 / sum_k W_bk``, of the boundary particles x (dim, N)
    among themselves (k over x, self included).

    Args:
        x: boundary particle positions (dim, N) [m].
        h: kernel support radius [m].
        kid: kernel id (:func:`sphkit.core.kernels.kernel_id`).
        dim: 2 or 3.
        period: the periodic axes (:meth:`sphkit.core.neighbors.Grid.query`: ``(lo, L)`` of
            x, or one ``(lo, L)`` per axis; minimum-image distances), or None.
        out: (N,) array to write the volumes to; by default a new one of x's dtype.

    Returns:
        The volumes (N,) [m^dim] (``out`` when given).
    """
    nl = neighbor_lists(x, h, period)
    V = np.empty(x.shape[1], dtype=x.dtype) if out is None else out
    _volumes(x, nl.offsets, nl.indices, h, kid, dim, pair_period(period), V)
    return V


def static_volumes(state: SimState, sel: np.ndarray | None = None) -> None:
    """Set the volumes ``V`` of the static boundary particles ``sel`` (indices; all by default):
    Eq. (4) among themselves (:func:`boundary_volumes`), except where the boundary field
    ``cell_volume`` is positive: scene boxes, whose lattice walls continue the fluid's lattice
    (:func:`sphkit.geometry.sampling.box_walls`), so that each wall particle stands for exactly
    the fluid particle missing there and keeps the fluid's lattice volume for its cell
    (:func:`sphkit.world.walls.add_wall_particles`). Eq. (4) is made for surface samples of
    irregular spacing; on a lattice wall one layer thick it gives 1.42-1.47 (2D) and 1.36-1.65
    (3D) lattice volumes, so fluid filling the box started 13-15 % too dense at the walls and the
    wall pressure terms did work on fluid at rest (validation/README.md, "Box walls: the
    lattice's volume")."""
    bd = state.boundary
    x = bd["x"] if sel is None else np.ascontiguousarray(bd["x"][:, sel])
    V = boundary_volumes(x, state.h, state.kid, state.dim, state.periodic)
    if "cell_volume" in bd.specs:
        cell = bd["cell_volume"] if sel is None else bd["cell_volume"][sel]
        V = np.where(cell > 0.0, cell, V)
    if sel is None:
        bd["V"][:] = V
    else:
        bd["V"][sel] = V


class Akinci2012(BoundaryModel):
    """Static boundary particles with Akinci volumes; rebuilds fluid-boundary neighbour lists."""

    name = "akinci2012"
    #: a static mesh's samples lie on its surface, 2r apart, each standing for the volume r
    #: around it: a fluid particle sampled r from the surface (a block written flush against
    #: the mesh in sphkit's own format) overlaps them by half a particle. Kept, the start-up's
    #: relaxation had to squeeze that layer into the block: next to an obstacle on the floor of
    #: a full tank (2D, r = 5 mm) it pressed particles to 0.5 r above the floor and PCISPH
    #: diverged at step 6 (542 m/s); in the floor corners of a mesh container it pushed the
    #: corner particles out. SPlisHSPlasH's blocks start 2r from the surface (1.8 r on a
    #: block's far side), which 1.5 r keeps (validation/README.md, "Own-format pools against
    #: mesh walls")
    start_reach = 1.5

    def __init__(self) -> None:
        self.grid: Grid | None = None
        self._hashed: HashGrid | None = None  # the walls' grid on a device (static walls)

    def init(self, state: SimState) -> None:
        """Compute the static walls' volumes V_b and the boundary grid. The walls' volumes come
        from the static particles alone (a body that starts close to a wall must not shrink the
        wall's volumes for the rest of the run); a moving body's particles (boundary field
        ``rigid_body`` > 0) get theirs from their own body (:mod:`sphkit.boundary.rigid`)."""
        bd = state.boundary
        bd.register("V")
        bd.register("v", "vector")
        if bd.n:
            moving = bd["rigid_body"] > 0 if "rigid_body" in bd.specs else None
            if moving is None or not moving.any():
                static_volumes(state)
            elif not moving.all():
                static_volumes(state, np.flatnonzero(~moving))
            self.grid = Grid(bd["x"], state.h).mark_near()

    def rebuild(self, state: SimState) -> None:
        """Rebuild the boundary grid after boundary particles moved (rigid bodies)."""
        bd = state.boundary
        self.grid = Grid(bd["x"], state.h) if bd.n else None
        self._hashed = None

    def inside(self, state: SimState) -> tuple[np.ndarray, list[str]]:
        """Fluid particles closer than r to a boundary particle (their discs or spheres of
        radius r overlap by more than a radius: the particle sits in the wall), indexed by the
        boundary particle's object (``boxes[k]``, ``meshes[k]``, ``emitters[k].housing``)."""
        f, bd = state.fluid, state.boundary
        out = np.full(f.n, -1, dtype=np.int64)
        if self.grid is None or f.n == 0:
            return out, []
        nl = self.grid.query(f["x"], period=state.periodic)
        dist = np.empty(f.n, dtype=f.dtype)
        near = np.empty(f.n, dtype=np.int64)
        _nearest(f["x"], nl.offsets, nl.indices, bd["x"], state.dim, state.pair_period, dist, near)
        hit = dist < state.r
        names = [o.name for o in bd.objects]
        if hit.any() and names:
            out[hit] = np.maximum(bd.object_index(bd["id"][near[hit]]), 0)
        return out, names

    def update(self, state: SimState) -> None:
        """Fluid-boundary neighbour lists for the current fluid positions (on a device: the
        hashed grid's kernel bodies, :class:`sphkit.core.hashgrid.HashGrid`, of the walls
        built there once; the lists hold the same pairs in another order)."""
        x = state.fluid["x"]
        if self.grid is None:
            state.nl_fb = NeighborList.empty(state.fluid.n)
            if on_device(x):
                state.nl_fb = NeighborList(*(to_device(a, "cuda") for a in (
                    state.nl_fb.offsets, state.nl_fb.indices)))
        elif on_device(x):
            if self._hashed is None:  # once: the walls are static (a copy back for the centre)
                bx = to_host(state.boundary["x"])
                origin = hash_origin(0.5 * (bx.min(axis=1) + bx.max(axis=1)), state.h)
                self._hashed = HashGrid(state.dim, state.h, origin, "cuda")
                self._hashed.build(state.boundary["x"])
            state.nl_fb = self._hashed.query(x)
        elif state.fluid_grid is not None:  # cell by cell of the fluid's grid (same lists)
            state.nl_fb = self.grid.query_grid(state.fluid_grid, x, period=state.periodic,
                                               scratch=state.scratch, slot="boundary")
        else:  # the rows of the search in the step's scratch block (its cache is gone)
            state.nl_fb = self.grid.query(x, period=state.periodic, scratch=state.scratch,
                                          slot="boundary")
