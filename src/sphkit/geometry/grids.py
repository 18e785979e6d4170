"""Interpolation on lattices: the cubic serendipity grid of boundary maps, multilinear lookups,
and a quadrature rule over the ball.

Grid. As Discregrid's ``CubicLagrangeDiscreteGrid`` (used by SPlisHSPlasH), a grid covers a box
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
axis of length 1), of which :func:`grid_eval` reads the nodes only (:func:`serendipity_mask`).
A field known at every lattice point can also be read multilinearly (:func:`lattice_lookup`).

Ball quadrature (:func:`ball_quadrature`): a product rule in polar / spherical coordinates for
integrals over ``|xi| <= h``, which the boundary maps use to integrate over the kernel support.
"""

from __future__ import annotations

import math

import numba
import numpy as np

_JIT = dict(cache=True, fastmath=True)

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


@numba.njit(inline="always", **_JIT)
def map_query_point(x, i, dim, extend_axis, top):
    """The lookup point of point i of x (dim, N), e.g. a fluid particle's in a boundary map: its
    position, clamped to ``top`` along ``extend_axis`` (a grid open along +axis, e.g. an open
    box: queries above the grid see its top layer; -1: none)."""
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


@numba.njit(parallel=True, **_JIT)
def _eval_many(f, lo, cell, res, dim, p, out):
    """``out[i]`` = :func:`grid_eval` of f at the points p (3, M); NaN outside the grid."""
    for i in numba.prange(p.shape[1]):
        v, _a, _b, _c, ok = grid_eval(f, lo, cell, res, dim, p[0, i], p[1, i], p[2, i])
        out[i] = v if ok else np.nan


def serendipity_mask(shape: np.ndarray) -> np.ndarray:
    """Lattice points that are serendipity nodes: at most one index not a multiple of 3."""
    grids = np.meshgrid(*[np.arange(n) % 3 != 0 for n in shape], indexing="ij")
    return sum(g.astype(np.int8) for g in grids) <= 1


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
