"""Shared machinery of implicit boundary maps (density maps, Koschier & Bender 2017; volume maps,
Bender et al. 2019): the grid and its cubic interpolation, the ball quadrature, map construction
and caching, and the per-step assembly of one virtual boundary neighbour per fluid particle.

Grid. As Discregrid's ``CubicLagrangeDiscreteGrid`` (used by SPlisHSPlasH), a map covers a box
divided into ``res`` cells per axis and interpolates with the cubic *serendipity* element in
every cell: 32 nodes in 3D (8 corners and 2 nodes on each of the 12 edges, at 1/3 and 2/3) and 12
in 2D. In local coordinates ``xi in [-1, 1]^d`` with a node at ``xi_n``:

* corner (3D) ``N = (1 + xi xi_n)(1 + eta eta_n)(1 + zeta zeta_n)(9 (xi^2 + eta^2 + zeta^2) - 19)
  / 64``, edge along xi (``xi_n = +-1/3``) ``N = 9/64 (1 - xi^2)(1 + 9 xi xi_n)(1 + eta eta_n)
  (1 + zeta zeta_n)``, and likewise for the other axes;
* corner (2D) ``N = (1 + xi xi_n)(1 + eta eta_n)(9 (xi^2 + eta^2) - 10) / 32``, edge along xi
  ``N = 9/32 (1 - xi^2)(1 + 9 xi xi_n)(1 + eta eta_n)``.

These reproduce every polynomial of total degree 3 exactly, and their gradients are analytic
(SPlisHSPlasH's normals come from the shape-function gradients too). All nodes lie on the lattice
of spacing ``cell / 3``; a field is stored on that whole lattice (flat, C order, 2D with a third
axis of length 1). The signed distance field (field 0) is computed exactly at every lattice point
(:mod:`sphkit.geometry.sdf`), so it can also be read trilinearly between the nodes, which the map
quadrature does; the map field (field 1) is computed at the serendipity nodes only.

Domain and distance, as SPlisHSPlasH's ``SimulatorBase::initDensityMap`` / ``initVolumeMap``:
the bounding box of the geometry grown by ``4 h + thickness`` on every side, and the map distance
``phi = s d - thickness - offset`` with ``s = -1`` for ``invert`` (containers: the fluid is inside
the geometry) and ``offset`` chosen by the method (volume maps: 0.5 r). ``phi`` is positive in the
fluid. SPlisHSPlasH writes ``s (d - thickness - offset)``, which for inverted maps moves the
surface *away* from the fluid; sphkit moves it into the fluid in both cases (the thickness of a
wall is added on the fluid side, and so is the volume map's margin against penetration).

Resolution: ``res`` cells per axis (SPlisHSPlasH's ``mapResolution``), or automatic: cells of
about one support radius h (SPlisHSPlasH's shipped scenes use about that), reduced uniformly if
the lattice would exceed 8 million points per field.

Per step, a method's query kernel writes, for each fluid particle i and map m, a virtual boundary
particle ``(x_b, V_b)`` (V_b = 0: none); :meth:`MapBoundaryModel.update` packs them into
``state.boundary`` (fields ``x``, ``V``, ``v`` = 0, ``id`` = the fluid particle's id) and the CSR
lists ``state.nl_fb`` (at most one entry per map and fluid particle), so every pressure solver
uses them through its usual boundary terms ``rho0 V_b W(x_i - x_b)`` and ``V_b grad W(x_i - x_b)``.

Hydrostatic boundary pressure (scene ``configuration.boundary.pressure: "hydrostatic"``, static
maps only). SPlisHSPlasH's boundary term for maps, ``-k_i grad rho_B`` (``pressure_mirror`` 0,
see :mod:`sphkit.core.ppe`), is half of the mirrored pressure, and it acts along the map normal
only. Measured in validation/maps.py's 2D tank (and in SPlisHSPlasH 2.19 run on the same
column), the fluid next to a side wall then carries 61 % (SPlisHSPlasH 67 %) of rho0 g H more
pressure than the interior with density maps, 15 % (SPlisHSPlasH 9-21 %) with volume maps: the
wall pushes with k_i, not 2 k_i, so the wall column needs about twice the pressure to keep the
interior fluid off the wall, and nothing on the wall side carries the column's weight. With this
option the boundary of a fluid particle i is given the pressure that Adami, Hu and Adams 2012
("A generalized wall boundary condition for smoothed particle hydrodynamics", JCP 231, Eq. 27)
extrapolate into a static wall, ``p_b(x) = p_i + rho_i g . (x - x_i)``. In the symmetric pressure
term integrated over the solid (the continuum form of the map),

    a_i = -integral_solid (k_i + k_b(x)) grad_i W(x_i - x) dx
        = -2 k_i grad rho_B - M grad k_b,     grad k_b = g / rho_hat_i,

the first part is the virtual neighbour with the mirrored pressure (``pressure_mirror`` 1) and
the second the kernel moment of the solid, ``M = -integral_solid x' (x) x' W'(|x'|)/|x'| dx'``
(``x' = x - x_i``), which gives the wall side of the kernel the hydrostatic pressure gradient
along the wall too. For a plane wall ``M = T (I - n n) + N n n``, and integrating by parts along
the wall (``-integral t^2 W'/|x'| dt = integral W dt``) shows that the tangential part equals the
wall's density contribution, ``T = rho_B``, for any solid weight that varies only across the
wall. The fluid's own tangential moment obeys the same identity in the continuum, so with
``T = rho_B`` the wall completes the kernel's tangential moment exactly where it completes the
density, which the pressure solvers hold at rest; sphkit takes T as the virtual neighbour's
density contribution ``V_b W(|x_i - x_b|)`` (both map types; for volume maps this is the
point-particle density of Bender et al., not the integral). The normal part ``N = n.M.n`` is
precomputed on one more map field with the method's own solid weight (:func:`moment_nodes`), and
``-(T (I - n n) + N n n) g / rho_hat_i`` is added with the non-pressure forces
(:class:`WallMomentForce`), before the pressure solve. Measured (2D, same tank): the wall
column's excess drops to about +8 % (density maps) and -4 % (volume maps). Moving bodies' maps
keep SPlisHSPlasH's term (their wall acceleration would enter ``p_b``).

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

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

from sphkit.core.kernels import kernel_dw, kernel_w
from sphkit.core.neighbors import NeighborList
from sphkit.core.state import SimState
from sphkit.geometry.cache import cache_folder, cached_arrays
from sphkit.geometry.rotations import rotate, rotate_t
from sphkit.geometry.sdf import SignedDistance, sdf_lattice_cached

_JIT = dict(cache=True, fastmath=True)
#: lattice points per field above which the automatic resolution is reduced
MAX_AUTO_POINTS = 8_000_000

# serendipity nodes: offsets on the cell's 4^d lattice (0..3) and type (0 corner, 1+a edge along
# axis a)
_N3 = []
for _a in (0, 3):
    for _b in (0, 3):
        for _c in (0, 3):
            _N3.append((_a, _b, _c, 0))
for _axis in range(3):
    for _m in (1, 2):
        for _b in (0, 3):
            for _c in (0, 3):
                _o = [0, 0, 0]
                _o[_axis] = _m
                _o[(_axis + 1) % 3] = _b
                _o[(_axis + 2) % 3] = _c
                _N3.append((_o[0], _o[1], _o[2], 1 + _axis))
NODES3 = np.array(_N3, dtype=np.int64)
_N2 = [(a, b, 0, 0) for a in (0, 3) for b in (0, 3)]
for _axis in range(2):
    for _m in (1, 2):
        for _b in (0, 3):
            _o = [0, 0, 0]
            _o[_axis] = _m
            _o[1 - _axis] = _b
            _N2.append((_o[0], _o[1], 0, 1 + _axis))
NODES2 = np.array(_N2, dtype=np.int64)


# ---------------------------------------------------------------------------------------------
# interpolation


@numba.njit(**_JIT)
def _locate(p, lo, cell, res):
    """Cell index and local coordinate in [-1, 1] of p on one axis; -1 when outside."""
    u = (p - lo) / cell
    if u < -1e-9 or u > res + 1e-9:
        return -1, 0.0
    c = int(math.floor(u))
    c = min(max(c, 0), res - 1)
    return c, 2.0 * (u - c) - 1.0


@numba.njit(**_JIT)
def grid_eval(f, lo, cell, res, dim, p0, p1, p2):
    """Cubic serendipity interpolation of the flat lattice field f at p.

    Returns (value, d/dx0, d/dx1, d/dx2, inside); outside the grid (value 0, inside False).
    """
    c0, a = _locate(p0, lo[0], cell[0], res[0])
    c1, b = _locate(p1, lo[1], cell[1], res[1])
    c2 = 0
    c = 0.0
    if dim == 3:
        c2, c = _locate(p2, lo[2], cell[2], res[2])
    if c0 < 0 or c1 < 0 or c2 < 0:
        return 0.0, 0.0, 0.0, 0.0, False
    n1 = 3 * res[1] + 1
    n2 = 3 * res[2] + 1 if dim == 3 else 1
    base0, base1, base2 = 3 * c0, 3 * c1, 3 * c2
    val = 0.0
    g0 = 0.0
    g1 = 0.0
    g2 = 0.0
    if dim == 3:
        s2 = 9.0 * (a * a + b * b + c * c) - 19.0
        for n in range(32):
            oa, ob, oc, typ = NODES3[n, 0], NODES3[n, 1], NODES3[n, 2], NODES3[n, 3]
            na = -1.0 + 2.0 * oa / 3.0
            nb = -1.0 + 2.0 * ob / 3.0
            nc = -1.0 + 2.0 * oc / 3.0
            fa = 1.0 + a * na
            fb = 1.0 + b * nb
            fc = 1.0 + c * nc
            if typ == 0:
                N = fa * fb * fc * s2 / 64.0
                da = (na * fb * fc * s2 + fa * fb * fc * 18.0 * a) / 64.0
                db = (fa * nb * fc * s2 + fa * fb * fc * 18.0 * b) / 64.0
                dc = (fa * fb * nc * s2 + fa * fb * fc * 18.0 * c) / 64.0
            elif typ == 1:
                e = (1.0 - a * a) * (1.0 + 9.0 * a * na)
                de = -2.0 * a * (1.0 + 9.0 * a * na) + 9.0 * na * (1.0 - a * a)
                N = 9.0 / 64.0 * e * fb * fc
                da = 9.0 / 64.0 * de * fb * fc
                db = 9.0 / 64.0 * e * nb * fc
                dc = 9.0 / 64.0 * e * fb * nc
            elif typ == 2:
                e = (1.0 - b * b) * (1.0 + 9.0 * b * nb)
                de = -2.0 * b * (1.0 + 9.0 * b * nb) + 9.0 * nb * (1.0 - b * b)
                N = 9.0 / 64.0 * e * fa * fc
                da = 9.0 / 64.0 * e * na * fc
                db = 9.0 / 64.0 * de * fa * fc
                dc = 9.0 / 64.0 * e * fa * nc
            else:
                e = (1.0 - c * c) * (1.0 + 9.0 * c * nc)
                de = -2.0 * c * (1.0 + 9.0 * c * nc) + 9.0 * nc * (1.0 - c * c)
                N = 9.0 / 64.0 * e * fa * fb
                da = 9.0 / 64.0 * e * na * fb
                db = 9.0 / 64.0 * e * fa * nb
                dc = 9.0 / 64.0 * de * fa * fb
            v = f[((base0 + oa) * n1 + base1 + ob) * n2 + base2 + oc]
            val += N * v
            g0 += da * v
            g1 += db * v
            g2 += dc * v
        g2 *= 2.0 / cell[2]
    else:
        s2 = 9.0 * (a * a + b * b) - 10.0
        for n in range(12):
            oa, ob, typ = NODES2[n, 0], NODES2[n, 1], NODES2[n, 3]
            na = -1.0 + 2.0 * oa / 3.0
            nb = -1.0 + 2.0 * ob / 3.0
            fa = 1.0 + a * na
            fb = 1.0 + b * nb
            if typ == 0:
                N = fa * fb * s2 / 32.0
                da = (na * fb * s2 + fa * fb * 18.0 * a) / 32.0
                db = (fa * nb * s2 + fa * fb * 18.0 * b) / 32.0
            elif typ == 1:
                e = (1.0 - a * a) * (1.0 + 9.0 * a * na)
                de = -2.0 * a * (1.0 + 9.0 * a * na) + 9.0 * na * (1.0 - a * a)
                N = 9.0 / 32.0 * e * fb
                da = 9.0 / 32.0 * de * fb
                db = 9.0 / 32.0 * e * nb
            else:
                e = (1.0 - b * b) * (1.0 + 9.0 * b * nb)
                de = -2.0 * b * (1.0 + 9.0 * b * nb) + 9.0 * nb * (1.0 - b * b)
                N = 9.0 / 32.0 * e * fa
                da = 9.0 / 32.0 * e * na
                db = 9.0 / 32.0 * de * fa
            v = f[(base0 + oa) * n1 + base1 + ob]
            val += N * v
            g0 += da * v
            g1 += db * v
    return val, g0 * 2.0 / cell[0], g1 * 2.0 / cell[1], g2, True


@numba.njit(**_JIT)
def lattice_lookup(f, origin, spacing, shape, dim, p0, p1, p2):
    """Multilinear interpolation of the flat lattice field f at p (clamped to the lattice)."""
    u0 = min(max((p0 - origin[0]) / spacing[0], 0.0), shape[0] - 1.0)
    u1 = min(max((p1 - origin[1]) / spacing[1], 0.0), shape[1] - 1.0)
    i0 = min(int(u0), shape[0] - 2)
    i1 = min(int(u1), shape[1] - 2)
    t0 = u0 - i0
    t1 = u1 - i1
    n1 = shape[1]
    if dim == 2:
        b = i0 * n1 + i1
        return ((1 - t0) * ((1 - t1) * f[b] + t1 * f[b + 1])
                + t0 * ((1 - t1) * f[b + n1] + t1 * f[b + n1 + 1]))
    u2 = min(max((p2 - origin[2]) / spacing[2], 0.0), shape[2] - 1.0)
    i2 = min(int(u2), shape[2] - 2)
    t2 = u2 - i2
    n2 = shape[2]
    b = (i0 * n1 + i1) * n2 + i2
    s1 = n2
    s0 = n1 * n2
    c00 = (1 - t2) * f[b] + t2 * f[b + 1]
    c01 = (1 - t2) * f[b + s1] + t2 * f[b + s1 + 1]
    c10 = (1 - t2) * f[b + s0] + t2 * f[b + s0 + 1]
    c11 = (1 - t2) * f[b + s0 + s1] + t2 * f[b + s0 + s1 + 1]
    return (1 - t0) * ((1 - t1) * c00 + t1 * c01) + t0 * ((1 - t1) * c10 + t1 * c11)


@numba.njit(**_JIT)
def lattice_lower_bound(f, origin, spacing, shape, dim, p0, p1, p2):
    """A lower bound of a distance field at p from its nearest lattice point (1-Lipschitz):
    ``f(q) - |p - q|``; -inf outside the lattice."""
    u0 = (p0 - origin[0]) / spacing[0]
    u1 = (p1 - origin[1]) / spacing[1]
    u2 = (p2 - origin[2]) / spacing[2] if dim == 3 else 0.0
    if u0 < 0 or u1 < 0 or u2 < 0 or u0 > shape[0] - 1 or u1 > shape[1] - 1 \
            or u2 > shape[2] - 1:
        return -np.inf
    i0 = int(u0 + 0.5)
    i1 = int(u1 + 0.5)
    i2 = int(u2 + 0.5)
    d0 = (u0 - i0) * spacing[0]
    d1 = (u1 - i1) * spacing[1]
    d2 = (u2 - i2) * spacing[2] if dim == 3 else 0.0
    return f[(i0 * shape[1] + i1) * shape[2] + i2] - math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@numba.njit(**_JIT)
def map_query_point(x, i, dim, extend_axis, top):
    """Fluid particle i's map lookup point: its position, clamped to ``top`` along
    ``extend_axis`` (an open box: queries above the grid see its top layer; -1: none)."""
    p0 = x[0, i]
    p1 = x[1, i]
    p2 = x[2, i] if dim == 3 else 0.0
    if extend_axis == 1:
        p1 = min(p1, top)
    elif extend_axis == 0:
        p0 = min(p0, top)
    elif extend_axis == 2:
        p2 = min(p2, top)
    return p0, p1, p2


# ---------------------------------------------------------------------------------------------
# quadrature over the ball of radius h


def ball_quadrature(h: float, dim: int, n_r: int | None = None,
                    n_a: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Points (3, Q) (third row 0 in 2D) and weights (Q,) integrating over ``|xi| <= h``.

    Product rule in polar / spherical coordinates: Gauss-Legendre in the radius (``n_r``, weight
    r^(dim-1)), Gauss-Legendre in cos(theta) (``n_a``, 3D) and ``2 n_a`` equal steps in the
    azimuth. Defaults: 3D 10 x 10 x 20 = 2000 points, 2D 16 x 48 = 768 points.
    """
    if dim == 3:
        n_r = 10 if n_r is None else n_r
        n_a = 10 if n_a is None else n_a
        xr, wr = np.polynomial.legendre.leggauss(n_r)
        r = 0.5 * h * (xr + 1.0)
        wr = 0.5 * h * wr * r * r
        mu, wm = np.polynomial.legendre.leggauss(n_a)
        n_p = 2 * n_a
        ph = (np.arange(n_p) + 0.5) * 2.0 * np.pi / n_p
        R, M, P = np.meshgrid(r, mu, ph, indexing="ij")
        W = (wr[:, None, None] * wm[None, :, None] * np.full(n_p, 2.0 * np.pi / n_p)[None, None])
        st = np.sqrt(1.0 - M * M)
        pts = np.stack([R * st * np.cos(P), R * st * np.sin(P), R * M])
        return pts.reshape(3, -1).copy(), W.ravel().copy()
    n_r = 16 if n_r is None else n_r
    n_a = 24 if n_a is None else n_a
    xr, wr = np.polynomial.legendre.leggauss(n_r)
    r = 0.5 * h * (xr + 1.0)
    wr = 0.5 * h * wr * r
    n_p = 2 * n_a
    ph = (np.arange(n_p) + 0.5) * 2.0 * np.pi / n_p
    R, P = np.meshgrid(r, ph, indexing="ij")
    W = wr[:, None] * np.full(n_p, 2.0 * np.pi / n_p)[None]
    pts = np.stack([R * np.cos(P), R * np.sin(P), np.zeros_like(R)])
    return pts.reshape(3, -1).copy(), W.ravel().copy()


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


@numba.njit(parallel=True, **_JIT)
def _eval_many(f, lo, cell, res, dim, p, out):
    for i in numba.prange(p.shape[1]):
        v, _a, _b, _c, ok = grid_eval(f, lo, cell, res, dim, p[0, i], p[1, i], p[2, i])
        out[i] = v if ok else np.nan


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
        res = np.maximum(np.ceil(ext / h), 2).astype(np.int64)
        while np.prod(3 * res + 1) > MAX_AUTO_POINTS:
            res = np.maximum((res * 0.9).astype(np.int64), 2)
    return lo, res, ext / res


def build_map(geom: MapGeometry, h: float, offset: float, method: str, params: list,
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
        phi = sign * d - geom.thickness - offset
        mask = serendipity_mask(shape)
        idx = np.argwhere(mask)
        nodes = np.zeros((3, len(idx)))
        nodes[:dim] = (lo[None] + idx * spacing[None]).T
        o3, s3, n3 = np.zeros(3), np.ones(3), np.ones(3, np.int64)
        o3[:dim], s3[:dim], n3[:dim] = lo, spacing, shape
        vals = np.zeros(shape)
        vals[mask] = integrate(nodes, np.ascontiguousarray(phi).ravel(), o3, s3, n3)
        return {"phi": phi, "values": vals}

    key = [geom.sdf.key(), geom.invert, float(geom.thickness), lo, res, float(h), float(offset),
           params]
    arrays, hit = cached_arrays(f"{method}-map", key, compute, folder)
    return BoundaryMap(geom, lo, res, cell, arrays["phi"], arrays["values"]), hit


def serendipity_mask(shape: np.ndarray) -> np.ndarray:
    """Lattice points that are serendipity nodes: at most one index not a multiple of 3."""
    grids = np.meshgrid(*[np.arange(n) % 3 != 0 for n in shape], indexing="ij")
    return sum(g.astype(np.int8) for g in grids) <= 1


# ---------------------------------------------------------------------------------------------
# per-step assembly and the shared model


@numba.njit(parallel=True, **_JIT)
def _count(Vb, counts):
    k, n = Vb.shape
    for i in numba.prange(n):
        c = 0
        for m in range(k):
            if Vb[m, i] > 0.0:
                c += 1
        counts[i + 1] = c


@numba.njit(parallel=True, **_JIT)
def _pack(xb, Vb, vb, mbody, fid, off, bx, bV, bv, bbody, bid, idx):
    k, dim, n = xb.shape
    for i in numba.prange(n):
        q = off[i]
        for m in range(k):
            if Vb[m, i] > 0.0:
                for d in range(dim):
                    bx[d, q] = xb[m, d, i]
                    bv[d, q] = vb[m, d, i]
                bV[q] = Vb[m, i]
                bbody[q] = mbody[m]
                bid[q] = fid[i]
                idx[q] = q
                q += 1


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


class MapBoundaryModel(ABC):
    """Base of the map boundary models: builds one map per geometry, assembles virtual particles.

    Subclasses set ``name``, ``offset`` (added to the map distance's shift), implement
    ``_integrate(state)`` (returning the node-integration callable and its cache parameters) and
    ``_query(bmap, state, x, v, xb, Vb) -> int`` (fills one map's virtual particles for the
    fluid positions x and velocities v (dim, N) given in the map's frame, pushes particles found
    in the solid out by changing x and v, returns how many it pushed).
    """

    name = "map"
    offset_in_radii = 0.0
    #: depth [r] by which a moving body's map surface is moved into its mesh (a negative
    #: ``MapGeometry.thickness``), so that the fluid rests about r outside the mesh
    moving_inset_in_radii = 0.0
    uses_maps = True
    #: the wall's share of the tangential pressure gradient with a hydrostatic boundary
    #: pressure (configuration.boundary.pressure "hydrostatic"; see "Hydrostatic boundary
    #: pressure" in the module docstring); set before :meth:`init`
    hydrostatic = False

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
            bmap, hit = build_map(g, state.h, self.offset_in_radii * state.r, self.name, params,
                                  integrate, self.folder)
            self.maps.append(bmap)
            self.cache_hits += int(hit)
        #: per geometry, with :attr:`hydrostatic`: its normal moment map N (:func:`moment_nodes`)
        self.moment_maps: list[BoundaryMap] = []
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
                bmap, hit = build_map(g, state.h, self.offset_in_radii * state.r,
                                      f"{self.name}-normal-moment", mparams, moments, self.folder)
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

    def rebuild(self, state: SimState) -> None:
        """After the rigid bodies moved: nothing to rebuild, :meth:`update` reads their poses
        (the interface of the particle models, whose grid follows the bodies)."""
        return None

    def update(self, state: SimState) -> None:
        """Virtual boundary particles and fluid-boundary lists for the current fluid positions."""
        f = state.fluid
        n, dim = f.n, state.dim
        k = len(self.maps)
        xb = np.zeros((k, dim, n))
        Vb = np.zeros((k, n))
        vb = np.zeros((k, dim, n))
        mbody = np.zeros(k, np.int64)
        for m, bmap in enumerate(self.maps):
            kb = bmap.geometry.body
            if kb == 0:
                self.pushed += int(self._query(bmap, state, f["x"], f["v"], xb[m], Vb[m]))
                continue
            body = getattr(self, "bodies", [])
            if kb > len(body):
                raise RuntimeError(f"{bmap.geometry.name}: moving map without its body; call "
                                   "bind_bodies first")
            b, c0 = body[kb - 1], self._c0[kb - 1]
            c, R = np.asarray(b.c, np.float64), np.asarray(b.R, np.float64)
            vc, w = np.asarray(b.v, np.float64), np.asarray(b.omega, np.float64)
            xl = np.empty((dim, n))
            ul = np.empty((dim, n))
            to_body_frame(f["x"], f["v"], c, R, vc, w, c0, xl, ul)
            xl0 = xl.copy()
            self.pushed += int(self._query(bmap, state, xl, ul, xb[m], Vb[m]))
            from_body_frame(xl, xl0, ul, c, R, vc, w, c0, Vb[m], xb[m], vb[m], f["x"], f["v"])
            mbody[m] = kb
        if self.hydrostatic:  # the wall moment reads this step's virtual particles
            self._virtual = (xb, Vb)
        counts = np.zeros(n + 1, np.int64)
        if k:
            _count(Vb, counts)
        off = np.cumsum(counts)
        total = int(off[-1])
        bd = state.boundary
        bd.resize(total)
        idx = np.empty(total, np.int32)
        if total:
            bid = np.empty(total, np.int64)
            bx = np.empty((dim, total))
            bV = np.empty(total)
            bv = np.empty((dim, total))
            bbody = np.empty(total, np.int64)
            _pack(xb, Vb, vb, mbody, f["id"], off, bx, bV, bv, bbody, bid, idx)
            bd.fields["x"][...] = bx
            bd.fields["V"][...] = bV
            bd.fields["id"][...] = bid
            bd.fields["v"][...] = bv
            if "rigid_body" in bd.fields:
                bd.fields["rigid_body"][...] = bbody
            if self.hydrostatic and "pressure_mirror" in bd.fields:
                bd.fields["pressure_mirror"][...] = np.where(bbody == 0, 1.0, 0.0)
        state.nl_fb = NeighborList(off, idx)

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
            n += int(wall_moment_accel(f["x"], f["rho"], state.rho0, bmap.phi, nmap.values,
                                       bmap.lo, bmap.cell, bmap.res, bmap.spacing, bmap.shape,
                                       state.dim, ax, top, state.h, state.kid, g[0], g[1], g[2],
                                       xb[m], Vb[m], f["a"]))
        return n

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


# ---------------------------------------------------------------------------------------------
# the wall's share of the tangential pressure gradient (hydrostatic boundary pressure)


def gamma_table(gamma: Callable[[float], float], lo: float, hi: float,
                n: int = 4001) -> tuple[float, float, np.ndarray]:
    """A method's solid weight ``gamma(d)`` sampled on ``n`` points of [lo, hi] (for
    :func:`moment_nodes`, read linearly and clamped): (lo, step, values)."""
    d = np.linspace(lo, hi, n)
    return float(lo), float(d[1] - d[0]), np.array([gamma(float(v)) for v in d])


@numba.njit(**_JIT)
def _table(t_lo, t_step, table, d):
    u = min(max((d - t_lo) / t_step, 0.0), table.shape[0] - 1.0)
    i = min(int(u), table.shape[0] - 2)
    s = u - i
    return (1.0 - s) * table[i] + s * table[i + 1]


@numba.njit(parallel=True, **_JIT)
def moment_nodes(nodes, phi, o, s, shape, dim, qp, qw, h, kid, t_lo, t_step, table, scale,
                 cutoff, out):
    """The normal part ``N = n.M.n`` of the kernel moment of the boundary at the map nodes,

        M(x) = scale * integral_{|xi| <= h} gamma(phi(x + xi)) xi (x) xi (-W'(|xi|) / |xi|) dxi

    (the boundary's share of the identity ``-integral xi (x) xi W'/|xi| dxi = I`` of the full
    kernel), n the map normal (grad phi, central differences on the lattice). ``gamma`` is the
    method's solid weight, given as a table; 0 where ``phi > cutoff``."""
    for m in numba.prange(nodes.shape[1]):
        x0, x1, x2 = nodes[0, m], nodes[1, m], nodes[2, m]
        d0 = lattice_lookup(phi, o, s, shape, dim, x0, x1, x2)
        if d0 > cutoff:
            out[m] = 0.0
            continue
        m00 = 0.0
        m01 = 0.0
        m02 = 0.0
        m11 = 0.0
        m12 = 0.0
        m22 = 0.0
        for q in range(qw.shape[0]):
            a0, a1, a2 = qp[0, q], qp[1, q], qp[2, q]
            d = lattice_lookup(phi, o, s, shape, dim, x0 + a0, x1 + a1, x2 + a2)
            w = _table(t_lo, t_step, table, d)
            if w == 0.0:
                continue
            rr = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
            c = -qw[q] * w * kernel_dw(kid, rr, h, dim)  # kernel_dw: W'(r) / r
            m00 += c * a0 * a0
            m01 += c * a0 * a1
            m02 += c * a0 * a2
            m11 += c * a1 * a1
            m12 += c * a1 * a2
            m22 += c * a2 * a2
        e0, e1, e2 = s[0], s[1], s[2] if dim == 3 else 1.0
        n0 = (lattice_lookup(phi, o, s, shape, dim, x0 + e0, x1, x2)
              - lattice_lookup(phi, o, s, shape, dim, x0 - e0, x1, x2)) / (2.0 * e0)
        n1 = (lattice_lookup(phi, o, s, shape, dim, x0, x1 + e1, x2)
              - lattice_lookup(phi, o, s, shape, dim, x0, x1 - e1, x2)) / (2.0 * e1)
        n2 = 0.0
        if dim == 3:
            n2 = (lattice_lookup(phi, o, s, shape, dim, x0, x1, x2 + e2)
                  - lattice_lookup(phi, o, s, shape, dim, x0, x1, x2 - e2)) / (2.0 * e2)
        nl = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        mnn = 0.0
        if nl > 1e-9:
            n0 /= nl
            n1 /= nl
            n2 /= nl
            mnn = (n0 * n0 * m00 + n1 * n1 * m11 + n2 * n2 * m22
                   + 2.0 * (n0 * n1 * m01 + n0 * n2 * m02 + n1 * n2 * m12))
        out[m] = scale * mnn


@numba.njit(parallel=True, **_JIT)
def wall_moment_accel(x, rho, rho0, phi, N, lo, cell, res, spacing, shape, dim, extend_axis, top,
                      h, kid, g0, g1, g2, xb, Vb, a):
    """Add ``-(T (I - n n) + N n n) g / rho_hat_i`` to a for the fluid particles with a virtual
    neighbour (xb, Vb) of this map: the moment term ``-M grad k_b`` of the hydrostatic boundary
    pressure ``p_b(x) = p_i + rho_i g . (x - x_i)`` (Adami et al. 2012, Eq. 27, static wall),
    ``grad k_b = g / rho_hat_i`` in the kappa units of :mod:`sphkit.core.ppe`, with the
    tangential part T the neighbour's density contribution ``V_b W(|x_i - x_b|)`` and the normal
    part N from the map (see "Hydrostatic boundary pressure" in the module docstring). Returns
    how many particles it acted on."""
    count = 0
    for i in numba.prange(x.shape[1]):
        if Vb[i] <= 0.0:
            continue
        p0, p1, p2 = map_query_point(x, i, dim, extend_axis, top)
        d, n0, n1, n2, ok = grid_eval(phi, lo, cell, res, dim, p0, p1, p2)
        nl = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if not ok or nl < 1e-9:
            continue
        n0 /= nl
        n1 /= nl
        n2 /= nl
        e0 = x[0, i] - xb[0, i]
        e1 = x[1, i] - xb[1, i]
        e2 = x[2, i] - xb[2, i] if dim == 3 else 0.0
        t = Vb[i] * kernel_w(kid, math.sqrt(e0 * e0 + e1 * e1 + e2 * e2), h, dim)
        nn = grid_eval(N, lo, cell, res, dim, p0, p1, p2)[0]
        gn = g0 * n0 + g1 * n1 + g2 * n2
        c = rho0 / rho[i]
        a[0, i] -= c * (t * (g0 - gn * n0) + nn * gn * n0)
        a[1, i] -= c * (t * (g1 - gn * n1) + nn * gn * n1)
        if dim == 3:
            a[2, i] -= c * (t * (g2 - gn * n2) + nn * gn * n2)
        count += 1
    return count


class WallMomentForce:
    """The non-pressure-force interface (``apply(state, dt)``) to
    :meth:`MapBoundaryModel.wall_moment`, run with the other forces before the pressure solve."""

    def __init__(self, model: MapBoundaryModel) -> None:
        self.model = model
        self.count = 0  #: particle-map pairs it acted on in the last step

    def apply(self, state: SimState, dt: float) -> None:
        """Add the walls' tangential pressure-gradient share to ``state.fluid['a']``."""
        self.count = self.model.wall_moment(state)
