"""Density maps of Koschier and Bender 2017, "Density maps for improved SPH boundary handling",
ACM SIGGRAPH / Eurographics Symposium on Computer Animation (SCA '17); as SPlisHSPlasH implements
them (``BoundaryModel_Koschier2017``, ``SimulatorBase::initDensityMap``,
``TimeStep::computeDensityAndGradient``; its ``boundaryHandlingMethod`` 1).

Precomputation, per static body (:mod:`sphkit.boundary.maps`): the map distance ``phi``
(positive in the fluid, moved into the fluid by the wall thickness) and the boundary's normalized
density contribution at a point x (paper, Eq. 11-13: the kernel-weighted volume of the solid,
with a density that grows linearly into the solid to make up for the missing fluid neighbours),

    rho_B(x) = 0.8 * integral_{|xi| <= h} gamma(phi(x + xi)) W(xi) dxi,
    gamma(d) = 1 - f d / h   for d <= h / f,   0 otherwise,

with the simulation's kernel W, ``f = 5`` in 3D and 1.75 in 2D, and ``rho_B = 0`` where
``phi > (1 + 1/f) h`` (SPlisHSPlasH's constants and its factor 0.8). rho_B is stored on the map
grid and interpolated with the cubic serendipity scheme, whose analytic gradient gives
``grad rho_B`` (paper, Sec. 5: the density gradient replaces the boundary particles' kernel
gradients in the pressure terms).

Per step, for a fluid particle with ``phi > 0`` where the interpolated map is positive (up to
:meth:`Koschier2017.reach`, ``(1 + 1/f) h`` plus a cell diagonal): the boundary adds
``rho0 rho_B(x_i)`` to the density and ``grad rho_B(x_i)`` wherever the solvers sum
``V_b grad W(x_i - x_b)``. To reach the solvers as an ordinary boundary neighbour (DESIGN.md), the
pair is written as one virtual particle ``(x_b, V_b)`` that reproduces both exactly at x_i:

    V_b W(|x_i - x_b|) = rho_B,   V_b grad_i W(x_i - x_b) = grad rho_B,

i.e. ``x_b = x_i + s g / |g|`` (``g = grad rho_B``, pointing into the wall) with the distance s
solving ``|W'(s)| / W(s) = |g| / rho_B`` (increasing in s from 0 to infinity for the cubic,
Wendland and poly6 kernels, solved by bisection), and ``V_b = rho_B / W(s)``. The density and
gradient terms of every solver are then exactly the paper's; PCISPH and PBF, which evaluate the
density at predicted positions, query the map there in every iteration
(:meth:`~sphkit.boundary.maps.MapBoundaryModel.boundary_at`, as SPlisHSPlasH's PBF; the
step-start virtual particle, extrapolated to the predicted position, let a particle in a
corner of a 2D tank pass through the wall with PBF at 0.5 s of a dam break). A particle
found inside (``phi < 0``) is moved ``min(-phi, 0.1 r)`` along the normal and its inward normal
velocity is replaced by 0.05 m/s outwards (SPlisHSPlasH; its step cap ``50 r dt`` is replaced by
``0.1 r`` because the boundary model does not see dt); :attr:`pushed` counts these events.

Hydrostatic boundary pressure (scene ``configuration.boundary.pressure: "hydrostatic"``, the
default for maps; not in the paper nor in SPlisHSPlasH, see
:mod:`sphkit.boundary.maps_hydrostatic`): the virtual neighbour
mirrors the pressure (``-2 k_i grad rho_B`` instead of ``-k_i grad rho_B``) and the wall adds
the kernel moment of Adami et al.'s (2012, Eq. 27) extrapolated pressure ``p_b = p_i + rho_i g .
(x_b - x_i)``: along the wall the density rho_B itself (the plane-wall identity), across it the
normal moment integrated with the same solid weight as rho_B, ``0.8 gamma(d)``
(:meth:`Koschier2017._solid_weight`). Measured in validation/maps.py's 2D tank, the fluid next to
the side walls carries +62 % of rho0 g H above hydrostatic with SPlisHSPlasH's term (SPlisHSPlasH
2.19 itself: +67 %) and +8 % with this option; the pressure slope goes from 1.078 to 1.022 rho0 g.

Moving rigid bodies (paper, Sec. 6; :mod:`sphkit.boundary.maps`, "Moving rigid bodies"): the
map of a kinematic or dynamic body lives in the body's frame, built for the mesh moved
:data:`MOVING_INSET_2D` r (2D) or :data:`MOVING_INSET_3D` r (3D) inward, so that a floating body
displaces its own volume: the map's density exceeds what the fluid misses next to a wall (3D, at
r off a plane: rho_B = 0.35 against the kernel's missing share 0.18), so fluid held at rest
density is kept out of a shell along every wet face, which a body displaces in addition to its
mesh, and whose weight reaches the body through the vertical density gradient at its bottom
edges (validation/README.md, "Density maps: why a floating body rides high").

Deviations from SPlisHSPlasH: it uses the map only for ``0.1 r < phi < h`` and gives particles
closer to the surface no boundary density (it resets their normal velocity instead). sphkit keeps
the map down to ``phi > 0``: in validation/maps.py's 3D dam break against a sphere, the 0.1 r
gap let particles into the sphere (282 push-outs, one particle 0.6 % of R inside at a frame);
with the map down to the surface, none. At the far end, the map's density reaches
``(1 + 1/f) h`` into the fluid (the ramp's ``h / f`` plus the kernel's h), and sphkit reads it
wherever the interpolated map is positive instead of cutting it at ``phi = h``: in 2D
(``f = 1.75``) the map's density at h is 1 % of rho0, and a particle crossing ``phi = h``
changed its density by 100 times the solvers' 0.01 % tolerance in one step, which made the
pressure of a 2D column at rest swing from 0 to 2.4 rho0 g per step (validation/README.md,
"2D density maps: the cut at h"). The interpolated map is continuous (zero in every cell whose
nodes are all beyond the map's reach), so the boundary density is too. In 3D (``f = 5``) the
exact density at h is 6e-5 of rho0, but a coarse 3D map's interpolation can hold 0.009 there (a
plane wall on cells of h), so the same rule applies. Read beyond h, the 2D map's tail must be
resolved: on SPlisHSPlasH's default cells (1.15-1.6 h in its scenes) the cubic interpolation
overshoots there by 0.5 % of rho0, so 2D maps are built on cells of at most
:data:`MAX_CELL_2D` h, finer than the scene's resolution where that is coarser (cheap in 2D).
"""

from __future__ import annotations

import dataclasses
import math

import numba
import numpy as np

from sphkit.backend import launch_reduce
from sphkit.boundary.maps import (
    MAX_AUTO_POINTS,
    BoundaryMap,
    MapBoundaryModel,
    MapGeometry,
    map_domain,
)
from sphkit.boundary.virtual import place_virtual
from sphkit.core.kernels import kernel_w
from sphkit.core.state import SimState
from sphkit.geometry.grids import (
    ball_quadrature,
    grid_eval,
    lattice_lookup,
    lattice_lower_bound,
    map_query_point,
)

#: depth [particle radii] by which the map surface of a *moving* body is moved into its mesh in
#: 2D (as :data:`sphkit.boundary.bender2019.MOVING_INSET`). Measured (DFSPH, cubic kernel, 2D
#: tank 0.4 m wide, 0.2 m deep, r = 1 cm, at rest after 1.5 s): the bottom layer of the fluid
#: rests 2.10 r above a density-map floor (2.16 r off the side walls), against 2.36 r on Akinci
#: walls and 2.58 r on volume maps: the 2D ramp ``1 - 1.75 d / h`` reaches 2.3 r into the fluid
#: (0.8 r in 3D, where the fluid rests 1.1 r off the map). For static walls sphkit keeps
#: SPlisHSPlasH's geometry; a floating square of density 500 and side 12 r displaced a shell
#: 1.1 r too thick and sat 30 % submerged instead of 50 %, so its map is built for the mesh
#: shrunk by this depth and the fluid rests about r outside the mesh.
MOVING_INSET_2D = 1.1
#: depth [particle radii] by which the map surface of a moving body is moved into its mesh in
#: 3D: the thickness of the shell the map keeps fluid out of at a plane wall,
#: ``delta = integral_0^inf (rho_B(d) - F(d)) dd`` with ``F(d)`` the share of the kernel beyond
#: the wall (what fluid filling the half-space up to the wall would miss), computed for the
#: cubic kernel, h = 4 r, f = 5: 0.844 r - 0.440 r = 0.40 r (not fitted to a float; the same
#: integral gives 0.68 r in 2D, where the measured 1.1 r is kept).
MOVING_INSET_3D = 0.4
#: largest cell of a 2D density map [kernel supports h]: a 2D map's density reaches 0.57 h beyond
#: h (ramp factor 1.75) and is read there (:meth:`Koschier2017.reach`); on cells of about h its
#: cubic interpolation overshoots beyond h (0.005 of rho0 on SPlisHSPlasH's 20 cells across a
#: 0.6 m tank at r = 1 cm), which put a dam break's particles at 80 m/s; 2D maps are built at
#: least this fine whatever the scene's resolution (validation/README.md, "2D density maps: the
#: cut at h")
MAX_CELL_2D = 0.5
#: SPlisHSPlasH's constants: density scale, ramp factor in 3D and 2D
SCALE = 0.8
FACTOR_3D = 5.0
FACTOR_2D = 1.75


@numba.njit(parallel=True, cache=True, fastmath=True)
def _densities(nodes, phi, o, s, shape, dim, qp, qw, h, f, kid, out):
    for m in numba.prange(nodes.shape[1]):
        x0, x1, x2 = nodes[0, m], nodes[1, m], nodes[2, m]
        d0 = lattice_lookup(phi, o, s, shape, dim, x0, x1, x2)
        if d0 > (1.0 + 1.0 / f) * h:
            out[m] = 0.0
            continue
        acc = 0.0
        for q in range(qw.shape[0]):
            d = lattice_lookup(phi, o, s, shape, dim, x0 + qp[0, q], x1 + qp[1, q],
                               x2 + qp[2, q])
            if d < h / f:
                r = math.sqrt(qp[0, q] ** 2 + qp[1, q] ** 2 + qp[2, q] ** 2)
                acc += qw[q] * (1.0 - f * d / h) * kernel_w(kid, r, h, dim)
        out[m] = SCALE * acc


@numba.njit(cache=True, fastmath=True, inline="always")
def query_body(i, x, v, phi, rho_b, lo, cell, res, spacing, shape, dim, extend_axis, top, h, r,
               kid, reach, xb, Vb):
    """Fluid particle i's virtual particle of one density map (``xb[:, i]``, ``Vb[i]``), or
    its push out of the solid (x and v changed; returns 1, else 0)."""
    p0, p1, p2 = map_query_point(x, i, dim, extend_axis, top)
    if lattice_lower_bound(phi, lo, spacing, shape, dim, p0, p1, p2) > reach + 0.5 * h:
        return 0.0
    d, n0, n1, n2, ok = grid_eval(phi, lo, cell, res, dim, p0, p1, p2)
    if not ok:
        return 0.0
    if d > 0.0 and d < reach:
        rho, g0, g1, g2, _ok = grid_eval(rho_b, lo, cell, res, dim, p0, p1, p2)
        if rho > 1e-6:
            place_virtual(i, x, rho, g0, g1, g2, h, kid, dim, xb, Vb)
    elif d < 0.0:
        nl = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if nl > 1e-5:
            n0 /= nl
            n1 /= nl
            n2 /= nl
            delta = min(-d, 0.1 * r)
            x[0, i] += delta * n0
            x[1, i] += delta * n1
            vn = v[0, i] * n0 + v[1, i] * n1
            if dim == 3:
                x[2, i] += delta * n2
                vn += v[2, i] * n2
            c = 0.05 - vn
            v[0, i] += c * n0
            v[1, i] += c * n1
            if dim == 3:
                v[2, i] += c * n2
            return 1.0
    return 0.0


class Koschier2017(MapBoundaryModel):
    """Density maps: the boundary's density and its gradient as one virtual particle per fluid
    particle near each static body."""

    name = "koschier2017"

    def init(self, state: SimState) -> None:
        """Build the maps; in 2D on cells of at most :data:`MAX_CELL_2D` h (the scene's
        resolution raised where it is coarser)."""
        if state.dim == 2:
            self.geometries = [_fine_2d(g, state.h) for g in self.geometries]
        super().init(state)

    @classmethod
    def moving_inset(cls, dim: int) -> float:
        """:data:`MOVING_INSET_2D` in 2D, :data:`MOVING_INSET_3D` in 3D."""
        return MOVING_INSET_2D if dim == 2 else MOVING_INSET_3D

    def _integrate(self, state: SimState):
        qp, qw = ball_quadrature(state.h, state.dim)
        f = FACTOR_3D if state.dim == 3 else FACTOR_2D
        h, kid, dim = state.h, state.kid, state.dim

        def integrate(nodes, phi, o, s, shape):
            out = np.empty(nodes.shape[1])
            _densities(nodes, phi, o, s, shape, dim, qp, qw, h, f, kid, out)
            return out

        return integrate, ["density map", SCALE, f, kid, qw.size]

    def _solid_weight(self, state: SimState):
        """The density map's weight ``gamma(d) = 1 - f d / h`` (d < h / f), times 0.8."""
        f = FACTOR_3D if state.dim == 3 else FACTOR_2D
        h = state.h
        return (lambda d: 1.0 - f * d / h if d < h / f else 0.0), -3.0 * h, h / f, SCALE

    def _query(self, bmap: BoundaryMap, state: SimState, x: np.ndarray, v: np.ndarray,
               xb: np.ndarray, Vb: np.ndarray) -> int:
        ax = bmap.geometry.extend_axis
        top = bmap.hi[ax] - 1e-6 * bmap.cell[ax] if ax >= 0 else 0.0
        phi, rho_b, lo, cell, res, spacing, shape = bmap.on(x)
        return int(launch_reduce(query_body, x.shape[1], x, v, phi, rho_b, lo, cell, res,
                                 spacing, shape, state.dim, ax, top, state.h, state.r,
                                 state.kid, self.reach(state, bmap), xb, Vb)[0])

    @staticmethod
    def reach(state: SimState, bmap: BoundaryMap) -> float:
        """Map distance [m] beyond which a map's interpolated density is zero: its nodes are 0
        beyond ``(1 + 1/f) h`` (the ramp's reach into the fluid plus the kernel's), and every
        node of the cell around a point lies within one cell diagonal of it."""
        f = FACTOR_3D if state.dim == 3 else FACTOR_2D
        return (1.0 + 1.0 / f) * state.h + float(np.linalg.norm(bmap.cell[: state.dim]))


def _fine_2d(geom: MapGeometry, h: float) -> MapGeometry:
    """``geom`` with a resolution whose cells are at most :data:`MAX_CELL_2D` h per axis (never
    coarser than its own, at most :data:`sphkit.boundary.maps.MAX_AUTO_POINTS` lattice points)."""
    lo, res, cell = map_domain(geom, h)
    # in floats: the cell counts of a huge box overflowed int64's product, which stopped the
    # loop at 1e18 cells (fuzz seed 105: a box 5.6e16 m high, "array is too big")
    need = np.maximum(np.ceil(cell * res / (MAX_CELL_2D * h)), res.astype(float))
    while np.prod(3.0 * need + 1.0) > MAX_AUTO_POINTS and np.any(need > res):
        need = np.maximum(np.floor(need * 0.9), res)
    need = need.astype(np.int64)
    if np.all(need == res):
        return geom
    return dataclasses.replace(geom, resolution=tuple(int(v) for v in need))
