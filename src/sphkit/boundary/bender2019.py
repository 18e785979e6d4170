"""Volume maps of Bender, Kugelstadt, Weiler and Koschier 2019, "Volume maps: an implicit
boundary representation for SPH", Motion, Interaction and Games (MIG '19); as SPlisHSPlasH
implements them (``BoundaryModel_Bender2019``, ``SimulatorBase::initVolumeMap``,
``TimeStep::computeVolumeAndBoundaryX``; its ``boundaryHandlingMethod`` 2, the default).

Precomputation, per static body (:mod:`sphkit.boundary.maps`): the map distance ``phi``
(positive in the fluid, zero on the geometry's surface, as SPlisHSPlasH since 2021) and the
boundary volume inside the support sphere of a point x (paper, Eq. 7-8),

    V_B(x) = 0.8 * integral_{|xi| <= h} gamma(phi(x + xi)) dxi,
    gamma(d) = 1 - 0.1 d / h                for d <= 0    (inside the solid),
             = W(f d) / W(0)                for 0 < d < h / f,
             = 0                            otherwise,

with the cubic spline W, ``f = 1`` in 3D and 1.75 in 2D, and ``V_B = 0`` where ``phi > 2h``
(SPlisHSPlasH's constants of 2019; the paper's gamma is the plain indicator, the smooth extension
and the factor 0.8 are SPlisHSPlasH's tuning; since 2020 SPlisHSPlasH takes ``gamma = 1`` inside
and ``f = 1`` in 2D as well, which sphkit does not: with ``f = 1`` one of twenty 2D drops onto
a volume-map floor blew up and the jets reached 93 m/s, with 1.75 none did (both with the impact
rule's earlier threshold), validation/README.md, "Volume maps on the geometry's surface").
V_B is stored on the map grid and interpolated with the cubic serendipity scheme, as is phi,
whose gradient gives the normal n.

Per step, for a fluid particle at map distance ``0 < phi < h`` (paper, Sec. 4: the boundary acts
as one particle at the closest surface point, carrying the volume V_B): one virtual boundary
neighbour with

    V_b = V_B(x_i),   x_b = x_i - max(phi + 0.5 r, 2 r) n,

("at least one particle diameter away ... to avoid strong pressure forces", SPlisHSPlasH), used
in every solver exactly as an Akinci particle: density ``rho0 V_b W(x_i - x_b)``, pressure and
gradient terms ``V_b grad W(x_i - x_b)``. A particle found inside (``phi <= 0``, which happens
only after too large steps) is moved ``min(2r - phi, 0.1 r)`` along n and stopped, as in
SPlisHSPlasH; :attr:`pushed` counts these events.

Hydrostatic boundary pressure (scene ``configuration.boundary.pressure: "hydrostatic"``, the
default for maps; not in the paper nor in SPlisHSPlasH, see
:mod:`sphkit.boundary.maps_hydrostatic`): the virtual neighbour
mirrors the pressure (``-2 k_i V_b grad W_ib``) and the wall adds the kernel moment of Adami et
al.'s (2012, Eq. 27) extrapolated pressure ``p_b = p_i + rho_i g . (x_b - x_i)``: along the wall
the virtual neighbour's density ``V_b W_ib``, across it the normal moment integrated with the
volume map's own weight ``0.8 gamma(d)`` (:meth:`Bender2019._solid_weight`). Measured in
validation/maps.py's 2D tank, the fluid next to the side walls carries +16 % of rho0 g H above
hydrostatic with SPlisHSPlasH's term (SPlisHSPlasH 2.19: +11 %) and -3 % with this option.
The mirrored share ``m_b`` of each virtual particle follows how much of an approach the map
registers: with ``q = (phi(x_i + r n) - phi(x_i - r n)) / (2 r)``, the map distance's change
across one particle diameter along the normal (1 at a plane wall), the map's density
``V_B W(phi + 0.5 r)`` changes about q times as fast along n as the virtual particle's
``V_b grad W`` says, so the continuum push ``-2 k_i grad rho_B`` is ``-2 q k_i V_b grad W``; the
base term (SPlisHSPlasH's, one ``k_i V_b grad W``) stays, and the mirror supplies the rest,
``m_b = max(2 q - 1, 0)`` (:func:`mirror_share_body`; 1 at a plane wall). q < 1 where an edge or a
corner is within reach: the interpolated distance smooths the kink (cells of about h), q about
0.5-0.6 where fluid rests at the 3D tank's vertical edges. With the full mirror there, the
doubled push through a gradient the density does not have drove a circulation in the edge
columns that kept 3D columns from coming to rest (validation/README.md, "Volume maps: the
mirrored share at edges"). In 2D it acts at the tank's floor corners: with the full mirror
there (where the map's gradient magnitude is 0.3-0.5) converged solves reached 10-20 times the
hydrostatic pressure in corner clusters and threw them out, so that 2D columns at r = 1 cm
boiled or diverged at some tank widths with every solver (validation/README.md, "2D PCISPH with
volume maps: what diverges at step 519, and main's corners across widths"); with the share all
of them rest. (A coarse 2D column, r = 2 cm, 10 rows, settles more slowly with it: 0.97 over
1-2 s, within 0.5 % of 1 from 3 s on.)

Symmetric walls (scene ``configuration.boundary.symmetric``; WCSPH's default for nearly inviscid
fluids): the wall force is then the symmetric term ``-rho0 V_b (p_i / rho_i^2) grad W_ib`` alone,
which is the derivative of the fluid's elastic energy only where ``V_b grad W_ib`` is the gradient
of the density ``rho_B(x) = V_B(x) W(s(x))``, ``s = max(phi + 0.5 r, 2 r)``, that the virtual
particle gives. It is not: it leaves out ``W(s) grad V_B`` (the volume grows towards the wall)
and, within ``phi < 1.5 r``, where s is held at 2 r, claims ``V_B W'(2 r) n`` that the density
does not have. With the placement above, an inviscid WCSPH dam break in a closed box gained 12-22
times its energy in 3-4 s (validation/energy.py). So with ``symmetric`` the virtual particle is
placed as a density map's is (:func:`sphkit.boundary.virtual.place_virtual`): the same density,
``V_b W = rho_B``, and the exact gradient of the interpolated maps, ``V_b grad W = W(s) grad V_B +
V_B W'(s) grad s`` (``grad s = grad phi`` beyond 1.5 r, 0 within). The wall force is then an
energy derivative, and the dam break keeps its energy with a fixed step (validation/README.md,
"Volume maps' symmetric term"). sphkit's, not the paper's nor SPlisHSPlasH's.

Moving rigid bodies (paper, Sec. 5): the map of a kinematic or dynamic body is computed once in
the body's frame and queried there, and the virtual particle goes back to the world with the
body's surface velocity (:mod:`sphkit.boundary.maps`, "Moving rigid bodies"); the map of a
moving body is built for its mesh moved :data:`MOVING_INSET` r inward.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sphkit.backend import launch, launch_reduce
from sphkit.boundary.maps import BoundaryMap, MapBoundaryModel
from sphkit.boundary.virtual import place_virtual
from sphkit.core import arrays
from sphkit.core.kernels import kernel_dr, kernel_w
from sphkit.core.pairs import pair_slots
from sphkit.core.state import SimState
from sphkit.geometry.grids import (
    ball_quadrature,
    grid_eval,
    lattice_lookup,
    lattice_lower_bound,
    map_query_point,
)

#: depth [particle radii] by which the map surface of a *moving* body is moved into its mesh.
#: Measured (3D, cubic kernel, r = 12.5 mm, DFSPH, a 0.2 m deep tank at rest, with the map
#: surface then 0.5 r off the mesh): fluid rested 2.8 r above a volume-map floor (bottom layer
#: mean; 2.5 r at the side walls), against 1.2 r on Akinci walls and 1.1 r on density maps, i.e.
#: the volume map kept the fluid about 1.7 r further off its mesh than the lattice does. A
#: floating body would displace a shell that thick too many and float too high (submerged
#: fraction 0.22 instead of 0.5 for a cube of density 500, side 16 r), so its map is built for
#: the mesh shrunk by 1.7 r less the 0.5 r the map surface then stood off it -- this 1.2 r,
#: the same map distance as before the static maps' surface moved onto the mesh -- and the fluid
#: rests about r outside the mesh, as at Akinci bodies (:data:`sphkit.boundary.rigid.INSET`).
MOVING_INSET = 1.2
#: SPlisHSPlasH's constants: volume scale, integration cut-off (in h), 2D ramp factor
SCALE = 0.8
CUTOFF = 2.0
FACTOR_2D = 1.75


@numba.njit(cache=True, fastmath=True)
def gamma(d: float, h: float, f: float) -> float:
    """The smoothed solid indicator of SPlisHSPlasH's volume map (see the module docstring)."""
    if d <= 0.0:
        return 1.0 - 0.1 * d / h
    q = f * d / h
    if q >= 1.0:
        return 0.0
    if q <= 0.5:
        return 6.0 * (q * q * q - q * q) + 1.0
    t = 1.0 - q
    return 2.0 * t * t * t


@numba.njit(parallel=True, cache=True, fastmath=True)
def _volumes(nodes, phi, o, s, shape, dim, qp, qw, h, f, out):
    for m in numba.prange(nodes.shape[1]):
        x0, x1, x2 = nodes[0, m], nodes[1, m], nodes[2, m]
        d0 = lattice_lookup(phi, o, s, shape, dim, x0, x1, x2)
        if d0 > CUTOFF * h:
            out[m] = 0.0
            continue
        acc = 0.0
        for q in range(qw.shape[0]):
            d = lattice_lookup(phi, o, s, shape, dim, x0 + qp[0, q], x1 + qp[1, q],
                               x2 + qp[2, q])
            acc += qw[q] * gamma(d, h, f)
        out[m] = SCALE * acc


@numba.njit(cache=True, fastmath=True, inline="always")
def query_body(i, x, v, phi, vol, lo, cell, res, spacing, shape, dim, extend_axis, top, h, r,
               kid, exact, xb, Vb):
    """Fluid particle i's virtual particle of one volume map (``xb[:, i]``, ``Vb[i]``), or its
    push out of the solid (x and v changed; returns 1, else 0); with ``exact`` placed so that
    its gradient is that of the density it gives (module docstring, "Symmetric walls")."""
    p0, p1, p2 = map_query_point(x, i, dim, extend_axis, top)
    if lattice_lower_bound(phi, lo, spacing, shape, dim, p0, p1, p2) > 1.5 * h:
        return 0.0  # far from the surface (phi is 1-Lipschitz)
    d, n0, n1, n2, ok = grid_eval(phi, lo, cell, res, dim, p0, p1, p2)
    if not ok:
        return 0.0
    nl = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if d > 0.0 and d < h:
        V, v0, v1, v2, _ok = grid_eval(vol, lo, cell, res, dim, p0, p1, p2)
        s = max(d + 0.5 * r, 2.0 * r)  # the virtual particle's distance
        if V > 0.0 and nl > 1e-9 and exact:
            # rho_B(x) = V_B(x) W(s(x)): its value and gradient
            w = kernel_w(kid, s, h, dim)
            if V * w > 1e-6:  # as a density map's (koschier2017.query_body)
                ds = kernel_dr(kid, s, h, dim) if d + 0.5 * r > 2.0 * r else 0.0
                place_virtual(i, x, V * w, w * v0 + V * ds * n0, w * v1 + V * ds * n1,
                              w * v2 + V * ds * n2 if dim == 3 else 0.0, h, kid, dim, xb, Vb)
        elif V > 0.0 and nl > 1e-9:
            t = s / nl
            xb[0, i] = x[0, i] - t * n0
            xb[1, i] = x[1, i] - t * n1
            if dim == 3:
                xb[2, i] = x[2, i] - t * n2
            Vb[i] = V
    elif d <= 0.0 and nl > 1e-5:
        delta = min(2.0 * r - d, 0.1 * r) / nl
        x[0, i] += delta * n0
        x[1, i] += delta * n1
        if dim == 3:
            x[2, i] += delta * n2
        for k in range(dim):
            v[k, i] = 0.0
        return 1.0
    return 0.0


@numba.njit(cache=True, fastmath=True, inline="always")
def mirror_share_body(i, x, phi, lo, cell, res, dim, extend_axis, top, r, Vb, out):
    """``out[i]``: the mirrored share of fluid particle i's virtual particle (V_b = Vb[i] > 0),
    ``max(2 q - 1, 0)`` with q the map distance's change across one particle diameter along the
    unit normal n, ``q = (phi(x_i + r n) - phi(x_i - r n)) / (2 r)`` (module docstring,
    "Hydrostatic boundary pressure"); 1 where q is within 1e-9 of 1 or above (a plane wall, where
    the interpolated distance is linear) and where it cannot be evaluated."""
    out[i] = 1.0
    if Vb[i] <= 0.0:
        return
    p0, p1, p2 = map_query_point(x, i, dim, extend_axis, top)
    _d, n0, n1, n2, ok = grid_eval(phi, lo, cell, res, dim, p0, p1, p2)
    nl = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if not ok or nl < 1e-9:
        return
    e = r / nl
    up, _a, _b, _c, ok1 = grid_eval(phi, lo, cell, res, dim, p0 + e * n0, p1 + e * n1,
                                    p2 + e * n2)
    down, _a, _b, _c, ok2 = grid_eval(phi, lo, cell, res, dim, p0 - e * n0, p1 - e * n1,
                                      p2 - e * n2)
    if not (ok1 and ok2):
        return
    q = (up - down) / (2.0 * r)
    if q < 1.0 - 1e-9:
        out[i] = max(2.0 * q - 1.0, 0.0)


@numba.njit(cache=True, fastmath=True, inline="always")
def follow_body(i, x, dx, bx, off, idx, dim, out):
    """out[:, b] = bx[:, b] + (I - n n) dx[:, i] for the virtual particles b of fluid particle
    i, n = (x_i - x_b) / |x_i - x_b|."""
    for k in pair_slots(off, i):
        b = idx[k]
        nn = 0.0
        for d in range(dim):
            nn += (x[d, i] - bx[d, b]) ** 2
        nn = math.sqrt(nn)
        if nn <= 0.0:
            continue
        dn = 0.0
        for d in range(dim):
            dn += dx[d, i] * (x[d, i] - bx[d, b]) / nn
        for d in range(dim):
            out[d, b] = bx[d, b] + dx[d, i] - dn * (x[d, i] - bx[d, b]) / nn


class Bender2019(MapBoundaryModel):
    """Volume maps: one virtual boundary particle per fluid particle near each static body."""

    name = "bender2019"
    #: the volume map claims more room than boundary particles: fluid sampled r from the
    #: wall (a block written flush against a box or mesh in sphkit's own format) starts more
    #: than twice as dense there in 3D, and the start-up's relaxation had to squeeze that layer
    #: into the block (a 3D pool 0.12 m deep rose to 0.18 m, particles moved up to 7 r, pairs
    #: were left 0.98 r apart); from that packing the floor's edge particles were thrown up at
    #: 60-75 m/s^2 in the second step with every solver, and PCISPH's solve diverged at step
    #: 4 next to an obstacle. Removed (within 1.5 r of a static mesh's surface or a box's
    #: face, measured on the geometry: the coarse maps of SPlisHSPlasH's scenes interpolate
    #: the distance at a concave edge up to half a particle short), every solver rests
    #: (validation/README.md, "Own-format pools against mesh walls"); SPlisHSPlasH's blocks,
    #: 2r off the surface (1.8 r on a far side), keep every particle
    start_reach = 1.5
    reach_at_boxes = True

    @classmethod
    def moving_inset(cls, dim: int) -> float:
        """:data:`MOVING_INSET`, in 2D and 3D."""
        return MOVING_INSET

    def boundary_at(self, state: SimState, dx: np.ndarray,
                    motion: np.ndarray | None = None) -> None:
        """None: the solvers keep the step's virtual particles at predicted positions. A
        volume-map particle placed anew at x* moves with the fluid particle (at least 2r off,
        along the normal) and carries V_b(x*), so the density it gives changes by grad V_b
        terms that ``V_b grad W`` -- the gradient PCISPH's step-start forces use -- leaves out:
        queried anew, PCISPH's first solve in the 3D dam break diverged (100 iterations,
        97.9 % max density error, unstable at 0.005 s; at 0.33 s with the step's particles).
        Density maps are queried anew (their virtual particle gives rho_B and grad rho_B
        exactly at x*); SPlisHSPlasH's PBF queries both."""
        return None

    def following(self, state: SimState, dx: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, object]:
        """The step's virtual particles moved with their fluid particle's displacement ``dx``
        along the wall (the part of dx normal to ``x_i - x_b`` left out): ``(x_b*, V_b,
        lists)`` for a PCISPH prediction (:mod:`sphkit.pressure.pcisph`, step 2) and PBF's
        predicted positions (:mod:`sphkit.pressure.pbf`). The map's
        volume and distance barely change along a wall, so the virtual particle that the query
        would place for ``x_i + dx`` sits about there; across the wall the fixed particle lets
        the predicted density respond to the approach with the gradient ``V_b grad W`` that the
        step's forces use."""
        nb = state.nl_fb
        bx = state.boundary["x"]
        out = arrays.copied(bx)
        if bx.shape[1]:
            launch(follow_body, state.fluid.n, state.fluid["x"], dx, bx, nb.offsets,
                   nb.indices, state.dim, out)
        return out, state.boundary["V"], nb

    def _integrate(self, state: SimState):
        qp, qw = ball_quadrature(state.h, state.dim)
        f = 1.0 if state.dim == 3 else FACTOR_2D
        h = state.h

        def integrate(nodes, phi, o, s, shape):
            out = np.empty(nodes.shape[1])
            _volumes(nodes, phi, o, s, shape, state.dim, qp, qw, h, f, out)
            return out

        return integrate, ["volume map", SCALE, CUTOFF, f, qw.size, float(state.r)]

    def _solid_weight(self, state: SimState):
        """The volume map's weight: SPlisHSPlasH's smoothed indicator gamma, times 0.8."""
        f = 1.0 if state.dim == 3 else FACTOR_2D
        h = state.h
        return (lambda d: gamma(d, h, f)), -3.0 * h, h / f, SCALE

    def _mirror_shares(self, state: SimState, x: np.ndarray, Vb: np.ndarray) -> np.ndarray:
        """The mirrored share of each static map's virtual particles (:func:`mirror_share_body`;
        moving maps' rows are not read: their virtual particles are not mirrored)."""
        out = arrays.full(Vb.shape, 1.0, Vb.dtype, like=Vb)
        for m, bmap in enumerate(self.maps):
            if bmap.geometry.body != 0:
                continue
            ax = bmap.geometry.extend_axis
            top = bmap.hi[ax] - 1e-6 * bmap.cell[ax] if ax >= 0 else 0.0
            phi, _v, lo, cell, res, _s, _n = bmap.on(x)
            launch(mirror_share_body, x.shape[1], x, phi, lo, cell, res, state.dim, ax, top,
                   state.r, Vb[m], out[m])
        return out

    def _query(self, bmap: BoundaryMap, state: SimState, x: np.ndarray, v: np.ndarray,
               xb: np.ndarray, Vb: np.ndarray) -> int:
        ax = bmap.geometry.extend_axis
        top = bmap.hi[ax] - 1e-6 * bmap.cell[ax] if ax >= 0 else 0.0
        phi, vol, lo, cell, res, spacing, shape = bmap.on(x)
        return int(launch_reduce(query_body, x.shape[1], x, v, phi, vol, lo, cell, res, spacing,
                                 shape, state.dim, ax, top, state.h, state.r, state.kid,
                                 self.symmetric, xb, Vb)[0])
