"""Shared machinery of implicit boundary maps (density maps, Koschier & Bender 2017; volume maps,
Bender et al. 2019): map construction and caching, the per-step assembly of one virtual boundary
neighbour per fluid particle, and the body frames of moving maps.

Grid: a map is a cubic serendipity grid (:mod:`sphkit.geometry.grids`, as Discregrid's
``CubicLagrangeDiscreteGrid``, used by SPlisHSPlasH) with two fields on the lattice of spacing
``cell / 3``. The signed distance field (field 0) is computed exactly at every lattice point
(:mod:`sphkit.geometry.sdf`), so it can also be read trilinearly between the nodes, which the map
quadrature does; the map field (field 1) is computed at the serendipity nodes only.

Domain and distance, as SPlisHSPlasH's ``SimulatorBase::initDensityMap`` / ``initVolumeMap``:
the bounding box of the geometry grown by ``4 h + thickness`` on every side, and the map distance
``phi = s d - thickness`` with ``s = -1`` for ``invert`` (containers: the fluid is inside the
geometry). ``phi`` is positive in the fluid, and zero on the geometry's surface where the
thickness is zero (every shipped SPlisHSPlasH scene). SPlisHSPlasH writes ``s (d - thickness)``,
which for inverted maps moves the surface *away* from the fluid; sphkit adds a wall's thickness
on the fluid side in both cases. (SPlisHSPlasH's volume maps subtracted a further 0.5 r until
2021, ``s (d - thickness - 0.5 r)``; sphkit moved its volume maps' surface 0.5 r into the fluid
until 2026-12, which made every container claim 0.5 r of the fluid's room:
validation/README.md, "Volume maps on the geometry's surface".)

Resolution: ``res`` cells per axis (SPlisHSPlasH's ``mapResolution``), or automatic: cells of
about one support radius h (SPlisHSPlasH's shipped scenes use about that), reduced uniformly if
the lattice would exceed 8 million points per field.

Per step, a method's query kernel writes, for each fluid particle i and map m, a virtual boundary
particle ``(x_b, V_b)`` (V_b = 0: none); :meth:`MapBoundaryModel.update` packs them into
``state.boundary`` (fields ``x``, ``V``, ``v`` = 0, ``id`` = the fluid particle's id) and the CSR
lists ``state.nl_fb`` (at most one entry per map and fluid particle), so every pressure solver
uses them through its usual boundary terms ``rho0 V_b W(x_i - x_b)`` and ``V_b grad W(x_i - x_b)``.
Solvers that evaluate the density at predicted positions x* (PBF, PCISPH) get the virtual
particles of x* in every iteration (:meth:`MapBoundaryModel.boundary_at`, through
``state.coupling.boundary_at``), leaving the step's own as they are -- density maps; volume
maps keep the step's (``Bender2019.boundary_at``).

Hydrostatic boundary pressure (scene ``configuration.boundary.pressure: "hydrostatic"``, static
maps only): the virtual neighbour mirrors the pressure and the walls add the kernel moment of the
extrapolated pressure of Adami et al. 2012, from one more map field per geometry
(:mod:`sphkit.boundary.maps_hydrostatic`).

Moving rigid bodies (Bender et al. 2019, Sec. 5, "dynamic rigid bodies"; SPlisHSPlasH's
``BoundaryModel_Bender2019``/``_Koschier2017`` with a dynamic ``RigidBodyObject``): a body's map
is computed once, for its geometry as placed at t = 0, and the body's pose ``x = c + R (x_0 -
c_0)`` (centre c, rotation R; ``c_0`` its centre at t = 0, where R = I) moves it. Each step a
fluid particle is taken into the body frame, ``x_l = c_0 + R^T (x_i - c)``, with its velocity
relative to the body, ``u_l = R^T (v_i - v_c - omega x (x_i - c))``; the method's query runs
there unchanged (distances, volumes and kernel values do not change under a rigid motion), and
the virtual particle goes back to the world, ``x_b = c + R (x_b,l - c_0)``, with the velocity of
the body's surface at it, ``v_b = v_c + omega x (x_b - c)``, which the solvers' divergence terms
and the viscosities read (boundary field ``v``). The packed virtual particle carries the body's
number in the boundary field ``rigid_body``, so that the reaction of the fluid's boundary force
on it, ``-m_i a_i<-b``, is summed into the body's force and torque about c exactly as for
boundary particles (:mod:`sphkit.boundary.rigid`; the two-way coupling of the paper's Sec. 5).
A fluid particle found inside a moving solid is pushed out in the body frame and its relative
velocity treated as the method does for static walls (this fallback is not a pair force: the
body does not feel it, so momentum is not conserved in the steps where it happens).
"""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

from sphkit.backend import device_of, exclusive_scan, launch, launch_reduce, to_device
from sphkit.boundary.maps_hydrostatic import (
    WallMomentForce,
    gamma_table,
    moment_nodes,
    wall_moment_body,
)
from sphkit.core import arrays
from sphkit.core.methods import BoundaryModel
from sphkit.core.neighbors import INDEX, NeighborList
from sphkit.core.particles import ParticleSet
from sphkit.core.state import SimState
from sphkit.geometry.cache import cache_folder, cached_arrays
from sphkit.geometry.grids import (
    _eval_many,
    ball_quadrature,
    grid_eval,
    map_query_point,
    serendipity_mask,
)
from sphkit.geometry.rotations import rotate, rotate_t, rotation_exp
from sphkit.geometry.sdf import SignedDistance, sdf_lattice_cached

_JIT = dict(cache=True, fastmath=True)
#: lattice points per field above which the automatic resolution is reduced
MAX_AUTO_POINTS = 8_000_000


# ---------------------------------------------------------------------------------------------
# maps


@dataclass
class MapGeometry:
    """A static boundary described by a signed distance (negative inside the solid geometry).

    ``invert``: the fluid is inside the geometry (containers, SPlisHSPlasH ``mapInvert``);
    ``thickness``: moves the surface this far into the fluid [m] (``mapThickness``);
    ``resolution``: cells per axis (``mapResolution``), None: automatic;
    ``extend_axis``: for a box open along +axis, queries above the grid are clamped into it (the
    geometry does not change along that axis there);
    ``body``: 1-based number of the moving rigid body the geometry belongs to (0: static). Its
    map is built once, for the geometry as placed at t = 0, and queried in the body's frame
    (:meth:`MapBoundaryModel.bind_bodies`).
    """

    name: str
    sdf: SignedDistance
    invert: bool = False
    thickness: float = 0.0
    resolution: tuple[int, ...] | None = None
    extend_axis: int = -1
    body: int = 0


class BoundaryMap:
    """One geometry's grid: map distance ``phi`` (positive in the fluid) and map values."""

    def __init__(self, geom: MapGeometry, lo: np.ndarray, res: np.ndarray, cell: np.ndarray,
                 phi: np.ndarray, values: np.ndarray) -> None:
        dim = geom.sdf.dim
        self.geometry = geom
        self.dim = dim
        self.lo = np.zeros(3)
        self.lo[:dim] = lo
        self.res = np.ones(3, np.int64)
        self.res[:dim] = res
        self.cell = np.ones(3)
        self.cell[:dim] = cell
        self.spacing = self.cell / 3.0
        self.shape = np.ones(3, np.int64)
        self.shape[:dim] = 3 * self.res[:dim] + 1
        self.phi = np.ascontiguousarray(phi, dtype=np.float64).ravel()
        self.values = np.ascontiguousarray(values, dtype=np.float64).ravel()
        self.hi = self.lo + self.cell * self.res

    def on(self, like: object) -> tuple:
        """``(phi, values, lo, cell, res, spacing, shape)`` on the device of ``like`` (the
        arrays themselves on the CPU; copied to a device once and kept there)."""
        dev = device_of(like)
        fields = (self.phi, self.values, self.lo, self.cell, self.res, self.spacing, self.shape)
        if dev == "cpu":
            return fields
        cache = self.__dict__.setdefault("_on", {})
        if dev not in cache:
            cache[dev] = tuple(to_device(np.ascontiguousarray(a), dev) for a in fields)
        return cache[dev]

    def eval_phi(self, p: np.ndarray) -> np.ndarray:
        """Interpolated map distance at points p (dim, M) (tests and diagnostics)."""
        out = np.empty(p.shape[1])
        _eval_many(self.phi, self.lo, self.cell, self.res, self.dim, _pad3(p), out)
        return out

    def eval_values(self, p: np.ndarray) -> np.ndarray:
        """Interpolated map values at points p (dim, M)."""
        out = np.empty(p.shape[1])
        _eval_many(self.values, self.lo, self.cell, self.res, self.dim, _pad3(p), out)
        return out


def _pad3(p: np.ndarray) -> np.ndarray:
    q = np.zeros((3, p.shape[1]))
    q[: p.shape[0]] = p
    return q


def map_domain(geom: MapGeometry, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lower corner, cells per axis and cell size of a geometry's map grid."""
    lo, hi = geom.sdf.bounds()
    pad = 4.0 * h + max(geom.thickness, 0.0)
    lo = np.asarray(lo, float) - pad
    hi = np.asarray(hi, float) + pad
    ext = hi - lo
    dim = geom.sdf.dim
    if geom.resolution is not None:
        res = np.asarray(geom.resolution, dtype=np.int64)[:dim]
        if res.size != dim or np.any(res < 1):
            raise ValueError(f"{geom.name}: map resolution {list(geom.resolution)}; expected "
                             f"{dim} positive cell counts")
    else:
        res = np.maximum(np.ceil(ext / h), 2)
        while np.prod(3 * res + 1) > MAX_AUTO_POINTS:  # (in floats: a huge box's product
            res = np.maximum(np.floor(res * 0.9), 2)  # overflowed int64 and stopped the loop)
        res = res.astype(np.int64)
    return lo, res, ext / res


def build_map(geom: MapGeometry, h: float, method: str, params: list,
              integrate: Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                                  np.ndarray],
              folder: Path | None) -> tuple[BoundaryMap, bool]:
    """Compute (or read from the cache) one geometry's map.

    ``integrate(nodes (3, M), phi_flat, origin (3,), spacing (3,), shape (3,))`` returns the map
    values at the serendipity nodes ``nodes``; ``params`` lists everything else it depends on
    (kernel, h, r, quadrature, method constants) for the cache key. Returns (map, cache hit).
    """
    dim = geom.sdf.dim
    lo, res, cell = map_domain(geom, h)
    spacing = cell / 3.0
    shape = 3 * res + 1

    def compute() -> dict[str, np.ndarray]:
        d, _ = sdf_lattice_cached(geom.sdf, lo, spacing, shape, folder)
        sign = -1.0 if geom.invert else 1.0
        phi = sign * d - geom.thickness
        mask = serendipity_mask(shape)
        idx = np.argwhere(mask)
        nodes = np.zeros((3, len(idx)))
        nodes[:dim] = (lo[None] + idx * spacing[None]).T
        o3, s3, n3 = np.zeros(3), np.ones(3), np.ones(3, np.int64)
        o3[:dim], s3[:dim], n3[:dim] = lo, spacing, shape
        vals = np.zeros(shape)
        vals[mask] = integrate(nodes, np.ascontiguousarray(phi).ravel(), o3, s3, n3)
        return {"phi": phi, "values": vals}

    key = [geom.sdf.key(), geom.invert, float(geom.thickness), lo, res, float(h), params]
    arrays, hit = cached_arrays(f"{method}-map", key, compute, folder)
    return BoundaryMap(geom, lo, res, cell, arrays["phi"], arrays["values"]), hit


# ---------------------------------------------------------------------------------------------
# per-step assembly and the shared model


@numba.njit(cache=True, inline="always")
def count_body(i, Vb, counts):
    """``counts[i]``: how many maps give fluid particle i a virtual particle (``Vb[m, i] > 0``)."""
    c = 0
    for m in range(Vb.shape[0]):
        if Vb[m, i] > 0.0:
            c += 1
    counts[i] = c


@numba.njit(cache=True, inline="always")
def pack_body(i, xb, Vb, vb, mbody, fid, off, bx, bV, bv, bbody, bid, idx):
    """Fluid particle i's virtual particles (``Vb[m, i] > 0``, map order) into the packed
    boundary arrays from ``off[i]`` on, each listed as its own neighbour ``idx[q] = q``."""
    q = off[i]
    for m in range(xb.shape[0]):
        if Vb[m, i] > 0.0:
            for d in range(xb.shape[1]):
                bx[d, q] = xb[m, d, i]
                bv[d, q] = vb[m, d, i]
            bV[q] = Vb[m, i]
            bbody[q] = mbody[m]
            bid[q] = fid[i]
            idx[q] = q
            q += 1


@numba.njit(cache=True, inline="always")
def mirror_pack_body(i, Vb, share, with_share, mbody, off, out):
    """The mirrored share of fluid particle i's virtual particles packed as :func:`pack_body`
    packs them: ``share[m, i]`` (1 without ``with_share``) for static maps, 0 for moving bodies'
    maps."""
    q = off[i]
    for m in range(Vb.shape[0]):
        if Vb[m, i] > 0.0:
            if mbody[m] != 0:
                out[q] = 0.0
            else:
                out[q] = share[m, i] if with_share else 1.0
            q += 1


@numba.njit(parallel=True, **_JIT)
def _inside(x, phi, lo, cell, res, dim, extend_axis, top, m, out):
    """``out[i] = m`` where point i of x lies on the grid with map distance ``phi <= 0``."""
    for i in numba.prange(x.shape[1]):
        p0, p1, p2 = map_query_point(x, i, dim, extend_axis, top)
        d, _g0, _g1, _g2, ok = grid_eval(phi, lo, cell, res, dim, p0, p1, p2)
        if ok and d <= 0.0 and out[i] < 0:
            out[i] = m


@numba.njit(parallel=True, **_JIT)
def to_body_frame(x, v, c, R, vc, w, c0, xl, ul):
    """Fluid positions and velocities in a body's frame (module docstring):
    ``x_l = c_0 + R^T (x - c)``, ``u_l = R^T (v - v_c - omega x (x - c))``. Vectors are 3D
    (c, vc, w, c0 of length 3, R 3x3); in 2D the body turns about z (third rows ignored)."""
    dim = x.shape[0]
    for i in numba.prange(x.shape[1]):
        q0 = x[0, i] - c[0]
        q1 = x[1, i] - c[1]
        q2 = x[2, i] - c[2] if dim == 3 else 0.0
        u0 = v[0, i] - vc[0] - (w[1] * q2 - w[2] * q1)
        u1 = v[1, i] - vc[1] - (w[2] * q0 - w[0] * q2)
        u2 = (v[2, i] if dim == 3 else 0.0) - vc[2] - (w[0] * q1 - w[1] * q0)
        a0, a1, a2 = rotate_t(R, q0, q1, q2)
        b0, b1, b2 = rotate_t(R, u0, u1, u2)
        xl[0, i] = c0[0] + a0
        xl[1, i] = c0[1] + a1
        ul[0, i] = b0
        ul[1, i] = b1
        if dim == 3:
            xl[2, i] = c0[2] + a2
            ul[2, i] = b2


@numba.njit(parallel=True, **_JIT)
def from_body_frame(xl, xl0, ul, c, R, vc, w, c0, Vb, xb, vb, x, v):
    """Back to the world after a query in a body's frame (module docstring): the virtual
    particles ``x_b = c + R (x_b,l - c_0)`` (xb in place) with the surface velocity
    ``v_b = v_c + omega x (x_b - c)``; the fluid particles the query pushed (``xl != xl0``) get
    ``x = c + R (x_l - c_0)`` and ``v = R u_l + v_c + omega x (x - c)``."""
    dim = x.shape[0]
    for i in numba.prange(x.shape[1]):
        if Vb[i] > 0.0:
            q0, q1, q2 = rotate(R, xb[0, i] - c0[0], xb[1, i] - c0[1],
                              xb[2, i] - c0[2] if dim == 3 else 0.0)
            xb[0, i] = c[0] + q0
            xb[1, i] = c[1] + q1
            vb[0, i] = vc[0] + w[1] * q2 - w[2] * q1
            vb[1, i] = vc[1] + w[2] * q0 - w[0] * q2
            if dim == 3:
                xb[2, i] = c[2] + q2
                vb[2, i] = vc[2] + w[0] * q1 - w[1] * q0
        moved = False
        for d in range(dim):
            if xl[d, i] != xl0[d, i]:
                moved = True
        if moved:
            q0, q1, q2 = rotate(R, xl[0, i] - c0[0], xl[1, i] - c0[1],
                              xl[2, i] - c0[2] if dim == 3 else 0.0)
            u0, u1, u2 = rotate(R, ul[0, i], ul[1, i], ul[2, i] if dim == 3 else 0.0)
            x[0, i] = c[0] + q0
            x[1, i] = c[1] + q1
            v[0, i] = u0 + vc[0] + w[1] * q2 - w[2] * q1
            v[1, i] = u1 + vc[1] + w[2] * q0 - w[0] * q2
            if dim == 3:
                x[2, i] = c[2] + q2
                v[2, i] = u2 + vc[2] + w[0] * q1 - w[1] * q0


class MapBoundaryModel(BoundaryModel):
    """Base of the map boundary models: builds one map per geometry, assembles virtual particles.

    Subclasses set ``name``, implement
    ``_integrate(state)`` (returning the node-integration callable and its cache parameters) and
    ``_query(bmap, state, x, v, xb, Vb) -> int`` (fills one map's virtual particles for the
    fluid positions x and velocities v (dim, N) given in the map's frame, pushes particles found
    in the solid out by changing x and v, returns how many it pushed).
    """

    name = "map"
    virtual = True
    #: the wall's share of the tangential pressure gradient with a hydrostatic boundary
    #: pressure (configuration.boundary.pressure "hydrostatic"; see
    #: :mod:`sphkit.boundary.maps_hydrostatic`); set before :meth:`init`
    hydrostatic = False
    #: configuration.boundary.symmetric (set before :meth:`init`): ``V_b grad W`` is the gradient
    #: of the density ``V_b W`` (:mod:`sphkit.boundary.virtual`; density maps: always)
    symmetric = False

    def __init__(self, geometries: list[MapGeometry] | None = None,
                 cache_dir: str | Path | None = None, cache: bool = True) -> None:
        self.geometries = list(geometries or [])
        self.folder = cache_folder(cache_dir) if cache else None
        self.maps: list[BoundaryMap] = []
        self.cache_hits = 0
        self.pushed = 0  #: fluid particles pushed out of a solid so far (fallback)

    def init(self, state: SimState) -> None:
        """Build (or load) every geometry's map; register the boundary fields. Called again
        (a checkpoint restore whose walls differ), it rebuilds the maps instead of adding a
        second copy of each."""
        bd = state.boundary
        bd.register("V")
        bd.register("v", "vector")
        integrate, params = self._integrate(state)
        self.maps = []
        for g in self.geometries:
            if g.sdf.dim != state.dim:
                raise ValueError(f"{g.name}: a {g.sdf.dim}D geometry in a {state.dim}D scene")
            bmap, hit = build_map(g, state.h, self.name, params, integrate, self.folder)
            self.maps.append(bmap)
            self.cache_hits += int(hit)
        #: per geometry, with :attr:`hydrostatic`: its normal moment map N
        #: (:func:`sphkit.boundary.maps_hydrostatic.moment_nodes`); None for a moving body's
        #: geometry, whose map gets no wall moment (:meth:`wall_moment`)
        self.moment_maps: list[BoundaryMap | None] = []
        if self.hydrostatic:
            qp, qw = ball_quadrature(state.h, state.dim)
            gamma, d_lo, d_hi, scale = self._solid_weight(state)
            t_lo, t_step, table = gamma_table(gamma, d_lo, d_hi)
            h, kid, dim = state.h, state.kid, state.dim

            def moments(nodes, phi, o, s, shape):
                out = np.empty(nodes.shape[1])
                moment_nodes(nodes, phi, o, s, shape, dim, qp, qw, h, kid, t_lo, t_step, table,
                             scale, h + d_hi, out)
                return out

            mparams = params + ["normal moment", t_lo, t_step, table.size, float(table.sum()),
                                scale]
            for g in self.geometries:
                if g.body != 0:
                    self.moment_maps.append(None)
                    continue
                bmap, hit = build_map(g, state.h, f"{self.name}-normal-moment", mparams, moments,
                                      self.folder)
                self.moment_maps.append(bmap)
                self.cache_hits += int(hit)

    def bind_bodies(self, bodies: list) -> None:
        """The moving rigid bodies whose maps this model queries in their frames (geometries
        with ``body`` > 0): objects with ``c``, ``R`` (3x3), ``v``, ``omega`` (world, 3D, SI),
        e.g. :class:`sphkit.boundary.rigid.RigidBody`, numbered from 1 in this order and posed
        at t = 0 now (``R`` = I): their present centres are the maps' frame origins ``c_0``."""
        self.bodies = list(bodies)
        for g in self.geometries:
            if g.body > len(self.bodies):
                raise ValueError(f"{g.name}: rigid body {g.body} of {len(self.bodies)}")
        for b in self.bodies:
            if not np.allclose(b.R, np.eye(3), atol=1e-12):
                raise ValueError("bind_bodies: the bodies must be at their t = 0 pose (R = I)")
        self._c0 = [np.array(b.c, dtype=np.float64) for b in self.bodies]

    def forces(self) -> list:
        """With :attr:`hydrostatic`: the walls' share of the tangential pressure gradient
        (:class:`~sphkit.boundary.maps_hydrostatic.WallMomentForce`), run with the other
        non-pressure forces."""
        return [WallMomentForce(self)] if self.hydrostatic else []

    def inside(self, state: SimState) -> tuple[np.ndarray, list[str]]:
        """Fluid particles inside a map's solid at t = 0: map distance ``phi <= 0``, i.e.
        behind the geometry's surface moved into the fluid by the wall's thickness (the
        particles the query would push out). Moving bodies' maps are read
        directly: at t = 0 their frames are the world's."""
        f = state.fluid
        out = np.full(f.n, -1, dtype=np.int64)
        for m, bmap in enumerate(self.maps):
            ax = bmap.geometry.extend_axis
            top = bmap.hi[ax] - 1e-6 * bmap.cell[ax] if ax >= 0 else 0.0
            _inside(f["x"], bmap.phi, bmap.lo, bmap.cell, bmap.res, state.dim, ax, top, m, out)
        return out, [bmap.geometry.name for bmap in self.maps]

    def rebuild(self, state: SimState) -> None:
        """After the rigid bodies moved: nothing to rebuild, :meth:`update` reads their poses
        (the interface of the particle models, whose grid follows the bodies)."""
        return None

    def update(self, state: SimState) -> None:
        """Virtual boundary particles and fluid-boundary lists for the current fluid positions
        (fluid found inside a solid is pushed out, :attr:`pushed`), packed into
        ``state.boundary``'s fields where they are (on a device: there)."""
        f = state.fluid
        xb, Vb, vb, mbody, pushed = self._virtual_particles(state, f["x"], f["v"])
        self.pushed += pushed
        if self.hydrostatic:  # the wall moment reads this step's virtual particles
            self._virtual = (xb, Vb)
        bd = state.boundary
        nl, _bx, bV, _bv, _bbody, _bid = self._packed(state, xb, Vb, vb, mbody, into=bd)
        if bV.shape[0] and self.hydrostatic and "pressure_mirror" in bd.fields:
            # at edges (3D) and corners (2D and 3D): bender2019's docstring
            share = self._mirror_shares(state, f["x"], Vb)
            launch(mirror_pack_body, f.n, Vb, Vb if share is None else share, share is not None,
                   mbody, nl.offsets, bd.fields["pressure_mirror"])
        state.nl_fb = nl

    def boundary_at(self, state: SimState, dx: np.ndarray, motion: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray, NeighborList, np.ndarray] | None:
        """The virtual particles ``(x_b, V_b)``, their lists and their bodies' numbers for the
        fluid at ``x + dx`` (a solve's predicted positions; SPlisHSPlasH's PBF queries its maps
        there in every iteration), with the bodies at their poses moved by ``motion`` (bodies,
        6; None: the step's), leaving the state as it is and pushing nothing: a predicted
        position inside a solid gets no virtual particle."""
        f = state.fluid
        xb, Vb, vb, mbody, _ = self._virtual_particles(state, arrays.axpy_into(f["x"], 1.0, dx),
                                                       arrays.copied(f["v"]), motion)
        nl, bx, bV, _, bbody, _ = self._packed(state, xb, Vb, vb, mbody)
        return bx, bV, nl, bbody

    def _virtual_particles(self, state: SimState, x: np.ndarray, v: np.ndarray,
                           motion: np.ndarray | None = None
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
        """Per map and fluid particle the virtual particle (xb (k, dim, N), Vb (k, N), its
        surface velocity vb (k, dim, N)), each map's body number and the pushed count, for
        fluid positions and velocities x, v (dim, N), which the queries' push-out changes.
        Where x is (a device, :func:`sphkit.backend.launch`) the queries run and the arrays
        are; moving bodies' maps only on the CPU (``scene.checks.device_features``)."""
        n, dim = state.fluid.n, state.dim
        pushed = 0
        k = len(self.maps)
        xb = arrays.zeros((k, dim, n), np.float64, like=x)
        Vb = arrays.zeros((k, n), np.float64, like=x)
        vb = arrays.zeros((k, dim, n), np.float64, like=x)
        mbody = np.zeros(k, np.int64)
        for m, bmap in enumerate(self.maps):
            kb = bmap.geometry.body
            if kb == 0:
                pushed += int(self._query(bmap, state, x, v, xb[m], Vb[m]))
                continue
            body = getattr(self, "bodies", [])
            if kb > len(body):
                raise RuntimeError(f"{bmap.geometry.name}: moving map without its body; call "
                                   "bind_bodies first")
            b, c0 = body[kb - 1], self._c0[kb - 1]
            c, R = np.asarray(b.c, np.float64), np.asarray(b.R, np.float64)
            if motion is not None:  # the pose the body takes in the solve (boundary_at)
                c, R = c + motion[kb - 1, :3], rotation_exp(motion[kb - 1, 3:], 1.0) @ R
            vc, w = np.asarray(b.v, np.float64), np.asarray(b.omega, np.float64)
            xl = np.empty((dim, n))
            ul = np.empty((dim, n))
            to_body_frame(x, v, c, R, vc, w, c0, xl, ul)
            xl0 = xl.copy()
            pushed += int(self._query(bmap, state, xl, ul, xb[m], Vb[m]))
            from_body_frame(xl, xl0, ul, c, R, vc, w, c0, Vb[m], xb[m], vb[m], x, v)
            mbody[m] = kb
        return xb, Vb, vb, to_device(mbody, device_of(x)), pushed

    @staticmethod
    def _packed(state: SimState, xb: np.ndarray, Vb: np.ndarray, vb: np.ndarray,
                mbody: np.ndarray, into: ParticleSet | None = None
                ) -> tuple[NeighborList, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                           np.ndarray]:
        """The virtual particles with V_b > 0 packed per fluid particle: the lists and the
        boundary arrays x, V, v, rigid_body, id (the fluid particle's id), on the device of
        ``Vb``; ``into``: a boundary particle set resized to them and packed into (its fields
        x, V, v, id, and rigid_body where registered), else new arrays."""
        n, dim = state.fluid.n, state.dim
        counts = arrays.empty(n, np.int64, like=Vb)
        off = arrays.empty(n + 1, np.int64, like=Vb)
        launch(count_body, n, Vb, counts)
        total = exclusive_scan(counts, off, device=device_of(Vb))
        idx = arrays.empty(total, INDEX, like=Vb)
        if into is None:
            bx = arrays.empty((dim, total), np.float64, like=Vb)
            bv = arrays.empty((dim, total), np.float64, like=Vb)
            bV = arrays.empty(total, np.float64, like=Vb)
            bid = arrays.empty(total, np.int64, like=Vb)
        else:
            into.resize(total)
            bx, bV, bv, bid = (into.fields[k] for k in ("x", "V", "v", "id"))
        bbody = (into.fields["rigid_body"] if into is not None and "rigid_body" in into.fields
                 else arrays.empty(total, np.int64, like=Vb))
        if total:
            launch(pack_body, n, xb, Vb, vb, mbody, state.fluid["id"], off, bx, bV, bv, bbody,
                   bid, idx)
        return NeighborList(off, idx), bx, bV, bv, bbody, bid

    def wall_moment(self, state: SimState) -> int:
        """Add the static maps' share of the tangential pressure gradient (hydrostatic
        boundary pressure) to ``state.fluid['a']``; returns the number of particle-map pairs it
        acted on (0 unless :attr:`hydrostatic`). Moving bodies' maps are left out."""
        if not self.moment_maps:
            return 0
        f = state.fluid
        g = np.zeros(3)
        g[: state.dim] = state.gravity
        n = 0
        xb, Vb = self._virtual
        for m, (bmap, nmap) in enumerate(zip(self.maps, self.moment_maps, strict=True)):
            if bmap.geometry.body != 0:
                continue
            ax = bmap.geometry.extend_axis
            top = bmap.hi[ax] - 1e-6 * bmap.cell[ax] if ax >= 0 else 0.0
            phi, _v, lo, cell, res, _s, _n = bmap.on(f["x"])
            n += int(launch_reduce(wall_moment_body, f.n, f["x"], f["rho"], f["rho0"], phi,
                                   nmap.on(f["x"])[1], lo, cell, res, state.dim, ax, top,
                                   state.h, state.kid, float(g[0]), float(g[1]), float(g[2]),
                                   xb[m], Vb[m], f["a"])[0])
        return n

    def _mirror_shares(self, state: SimState, x: np.ndarray, Vb: np.ndarray
                       ) -> np.ndarray | None:
        """With :attr:`hydrostatic`: the mirrored share ``m_b`` in [0, 1] of each static map's
        virtual particle (k, N) for the fluid at x (dim, N), or None for 1 everywhere (density
        maps: their virtual particle gives the map's own density gradient)."""
        return None

    def _solid_weight(self, state: SimState) -> tuple[Callable[[float], float], float, float,
                                                       float]:
        """The method's solid weight of its map integral, for the normal moment map: (gamma(d),
        d_lo, d_hi, scale) with gamma = 0 for d >= d_hi and the table clamped below d_lo (only
        with :attr:`hydrostatic`)."""
        raise NotImplementedError(f"{self.name}: no hydrostatic boundary pressure")

    # -- provided by the method ----------------------------------------------------------------
    @abstractmethod
    def _integrate(self, state: SimState) -> tuple[Callable, list]:
        """The node-integration callable of :func:`build_map` and its cache parameters."""

    @abstractmethod
    def _query(self, bmap: BoundaryMap, state: SimState, x: np.ndarray, v: np.ndarray,
               xb: np.ndarray, Vb: np.ndarray) -> int:
        """Fill one map's virtual particles (xb (dim, N), Vb (N,)) for the fluid positions x and
        velocities v (dim, N) in the map's frame; return the pushed count."""
