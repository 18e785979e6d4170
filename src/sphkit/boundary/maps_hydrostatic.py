"""Hydrostatic boundary pressure for density and volume maps (scene
``configuration.boundary.pressure: "hydrostatic"``, the maps' default; static maps only): the
wall's share of the tangential pressure gradient.

SPlisHSPlasH's boundary term for maps, ``-k_i grad rho_B`` (``pressure_mirror`` 0,
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
keep SPlisHSPlasH's term (their wall acceleration would enter ``p_b``). The mirrored share may
be less than 1 where a method's virtual particle overstates the map's own density gradient
(volume maps at edges and corners, ``MapBoundaryModel._mirror_shares``). With
``configuration.boundary.symmetric`` (SPlisHSPlasH's ``V_b k_i`` alone; WCSPH's default for
nearly inviscid fluids) neither the mirrored share nor the moment acts: both are work the
state equation's energy does not account for (validation/README.md, "WCSPH's walls by
default: the energy they pump").

:class:`sphkit.boundary.maps.MapBoundaryModel` builds the normal moment map of each static
geometry with :func:`moment_nodes` (``init``) and adds the moment term with
:func:`wall_moment_body` (``wall_moment``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numba
import numpy as np

from sphkit.backend import specialize
from sphkit.core.kernels import kernel_dw, kernel_w
from sphkit.core.methods import NonPressureForce
from sphkit.core.pairs import point, separation
from sphkit.core.state import SimState
from sphkit.geometry.grids import grid_eval, lattice_lookup, map_query_point

if TYPE_CHECKING:
    from sphkit.boundary.maps import MapBoundaryModel

_JIT = dict(cache=True, fastmath=True)


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


@numba.njit(inline="always", **_JIT)
def wall_moment_body(i, x, rho, rho0, phi, N, lo, cell, res, dim, extend_axis, top, h, kid, g0,
                     g1, g2, xb, Vb, a):
    """Add ``-(T (I - n n) + N n n) g / rho_hat_i`` to ``a[:, i]`` if fluid particle i has a
    virtual neighbour (xb, Vb) of this map: the moment term ``-M grad k_b`` of the hydrostatic
    boundary pressure ``p_b(x) = p_i + rho_i g . (x - x_i)`` (Adami et al. 2012, Eq. 27, static
    wall), ``grad k_b = g / rho_hat_i`` in the kappa units of :mod:`sphkit.core.ppe`, with the
    tangential part T the neighbour's density contribution ``V_b W(|x_i - x_b|)`` and the normal
    part N from the map (module docstring); ``rho0`` (N,): each particle's rest density.
    Returns 1 where it acted, else 0 (summed: the particles it acted on)."""
    if Vb[i] <= 0.0:
        return 0.0
    p0, p1, p2 = map_query_point(x, i, dim, extend_axis, top)
    d, n0, n1, n2, ok = grid_eval(phi, lo, cell, res, dim, p0, p1, p2)
    nl = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if not ok or nl < 1e-9:
        return 0.0
    n0 /= nl
    n1 /= nl
    n2 /= nl
    xi0, xi1, xi2 = point(x, i, dim)
    _e0, _e1, _e2, r = separation(xi0, xi1, xi2, xb, i, dim, 0.0)
    t = Vb[i] * kernel_w(kid, r, h, dim)
    nn = grid_eval(N, lo, cell, res, dim, p0, p1, p2)[0]
    gn = g0 * n0 + g1 * n1 + g2 * n2
    c = rho0[i] / rho[i]
    a[0, i] -= c * (t * (g0 - gn * n0) + nn * gn * n0)
    a[1, i] -= c * (t * (g1 - gn * n1) + nn * gn * n1)
    if dim == 3:
        a[2, i] -= c * (t * (g2 - gn * n2) + nn * gn * n2)
    return 1.0


#: no constants (sphkit.backend.launch.specialize): the kernel id as one made it 1.1x slower
specialize(wall_moment_body)


class WallMomentForce(NonPressureForce):
    """The non-pressure-force interface (``apply(state, dt)``) to
    :meth:`sphkit.boundary.maps.MapBoundaryModel.wall_moment`, run with the other forces before
    the pressure solve."""

    #: not declared repeatable, although apply only adds to a from the step start's state:
    #: with map walls PCISPH's retries of thrown particles made the 3D density-map dam break of
    #: validation/energy.py unstable (validation/README.md, "PCISPH's thrown particles"), and
    #: those of failed solves alone gave mixed pools
    repeatable = False

    def __init__(self, model: MapBoundaryModel) -> None:
        self.model = model
        self.count = 0  #: particle-map pairs it acted on in the last step

    def apply(self, state: SimState, dt: float) -> None:
        """Add the walls' tangential pressure-gradient share to ``state.fluid['a']``."""
        self.count = self.model.wall_moment(state)
