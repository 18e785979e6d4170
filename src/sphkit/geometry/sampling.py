"""Points on lattices: fluid blocks and the walls of box containers.

Set-up code (run once before a simulation), written with NumPy. Conventions shared by every
sampler here and in :mod:`sphkit.geometry.mesh_sampling`:

- Particles of radius ``r`` sit on a lattice of spacing ``2r`` (one particle diameter).
- A fluid block ``[start, end]`` holds the lattice points ``start + r + 2r k`` (k = 0, 1, ...)
  that lie at or below ``end - r`` (tolerance ``1e-9 r``): the block is exactly filled by the
  particles' cubes of side ``2r`` when ``end - start`` is a multiple of ``2r``.
- The walls of a box container with interior ``[lo, hi]`` continue that lattice outwards: wall
  layer ``k`` (0-based) lies at ``lo - r - 2r k`` and ``hi + r + 2r k`` on each axis, so a fluid
  block filling the container is ``2r`` away from the first wall layer.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

ArrayLike = Sequence[float] | np.ndarray

# Lattice tolerance, relative to r: a lattice point this close beyond end - r still counts.
_LATTICE_TOL = 1e-9


def _as_vector(x: ArrayLike, name: str) -> np.ndarray:
    v = np.asarray(x, dtype=np.float64).ravel()
    if v.size not in (1, 2, 3):
        raise ValueError(f"{name} must have 1 to 3 components, got {v.size}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite, got {v.tolist()}")
    return v


def check_radius(r: float) -> float:
    """``r`` as a float; a ValueError unless it is a positive finite number."""
    r = float(r)
    if not (r > 0.0 and np.isfinite(r)):
        raise ValueError(f"particle radius must be a positive number, got {r}")
    return r


def lattice_count(a: float, b: float, r: float) -> int:
    """Number of lattice points ``a + r + 2r k`` at or below ``b - r`` (tolerance ``1e-9 r``)."""
    span = (b - a) - 2.0 * r + _LATTICE_TOL * r
    if span < 0.0:
        return 0
    return int(np.floor(span / (2.0 * r))) + 1


def _axis_lattice(a: float, b: float, r: float) -> np.ndarray:
    return a + r + 2.0 * r * np.arange(lattice_count(a, b, r), dtype=np.float64)


def _product(axes: Sequence[np.ndarray]) -> np.ndarray:
    dim = len(axes)
    if any(len(ax) == 0 for ax in axes):
        return np.empty((0, dim), dtype=np.float64)
    grids = np.meshgrid(*axes, indexing="ij")
    return np.stack([g.ravel() for g in grids], axis=1)


def lattice_block(start: ArrayLike, end: ArrayLike, r: float) -> np.ndarray:
    """Fluid particles filling the block ``[start, end]`` on a lattice of spacing ``2r``.

    Args:
        start: lower corner [m], 1 to 3 components.
        end: upper corner [m], same length as ``start``.
        r: particle radius [m].

    Returns:
        ``(M, dim)`` float64 positions: the first particle at ``start + r``, the last at or below
        ``end - r`` on every axis (``floor((end - start) / 2r)`` particles per axis, up to a
        tolerance of ``1e-9 r``). ``M`` is 0 when the block is thinner than ``2r``.
    """
    r = check_radius(r)
    a = _as_vector(start, "start")
    b = _as_vector(end, "end")
    if a.shape != b.shape:
        raise ValueError(f"start {a.tolist()} and end {b.tolist()} differ in length")
    return _product([_axis_lattice(lo, hi, r) for lo, hi in zip(a, b, strict=True)])


def hexagonal_block(start: ArrayLike, end: ArrayLike, r: float) -> np.ndarray:
    """2D fluid particles filling ``[start, end]`` on a hexagonal lattice of spacing ``2r``.

    The hexagonal (triangular) lattice of touching discs of radius r, rows along x: the packing
    a 2D SPH fluid at rest settles into. The square lattice of :func:`lattice_block` is not
    stable under pressure in 2D; a column sampled on it shears into hexagonal grains with
    frozen-in defects while it settles (see validation/README.md, "2D hydrostatic columns").
    Rows ``sqrt(3) r`` apart start at ``start + r`` and stay at or below ``end - r``; every
    second row is shifted by ``r`` along x and holds the points that still fit. The particles'
    volume is :func:`sphkit.core.kernels.hexagonal_volume` of this lattice (0.8696 (2r)^2 for
    the cubic spline), so that the block is at rest density.

    Args:
        start: lower corner [m], 2 components.
        end: upper corner [m], 2 components.
        r: particle radius [m].

    Returns:
        ``(M, 2)`` float64 positions (``M`` = 0 when the block is thinner than ``2r``).
    """
    r = check_radius(r)
    a = _as_vector(start, "start")
    b = _as_vector(end, "end")
    if a.shape != (2,) or b.shape != (2,):
        raise ValueError(f"hexagonal_block: start {a.tolist()} and end {b.tolist()}; expected "
                         "2 components each (the hexagonal lattice is 2D)")
    spacing = 2.0 * r
    tol = _LATTICE_TOL * r
    dy = spacing * np.sqrt(3.0) / 2.0
    height = b[1] - a[1] - 2.0 * r + tol
    rows = []
    for j in range(int(np.floor(height / dy)) + 1 if height >= 0.0 else 0):
        x0 = a[0] + r + (0.5 * spacing if j % 2 else 0.0)
        span = b[0] - r - x0 + tol
        if span < 0.0:
            continue
        xs = x0 + spacing * np.arange(int(np.floor(span / spacing)) + 1)
        rows.append(np.stack([xs, np.full(len(xs), a[1] + r + j * dy)], axis=1))
    if not rows:
        return np.empty((0, 2), dtype=np.float64)
    return np.concatenate(rows)


#: sphkit's names of SPlisHSPlasH's ``denseMode`` 1 and 2 of fluid blocks
DENSE_LATTICES = {"layered": 1, "close_packed": 2}


def dense_block(start: ArrayLike, end: ArrayLike, r: float, lattice: str) -> np.ndarray:
    """Fluid particles of the block ``[start, end]`` on SPlisHSPlasH's denser lattices
    (``SimulatorBase::createFluidBlocks``, ``denseMode`` 1 ``"layered"`` and 2
    ``"close_packed"``), 2D or 3D, for SPlisHSPlasH's box ``[start - r, end + r]`` (so that, as
    for :func:`lattice_block`, the first particle is at ``start + r`` on x and y):

    * layered (1): layers ``sqrt(3) r`` apart along y, particles ``2r`` apart along x and z;
      even layers shifted by r along z, odd ones by r along x;
    * close_packed (2): ``sqrt(6) 2r / 3`` apart along x, layers ``sqrt(3) r`` apart along y,
      ``2r`` along z, everything shifted by r along z, even layers by half the x spacing along
      x, and in 3D odd columns by +r (even layers) or -r (odd layers) along z.

    Per axis ``round(d / s) - 1`` particles for the box's extent d (less one diameter along x
    and z in mode 1, less the x spacing along x and one diameter along z in mode 2) and the
    spacing s, from ``start + r`` on, as SPlisHSPlasH counts them; in 2D one layer at z = 0
    (the z shifts are dropped). Returns ``(M, dim)`` float64 positions.
    """
    r = check_radius(r)
    a = _as_vector(start, "start")
    b = _as_vector(end, "end")
    dim = a.shape[0]
    if a.shape != b.shape or dim not in (2, 3):
        raise ValueError(f"dense_block: start {a.tolist()} and end {b.tolist()}; expected 2 "
                         "or 3 components each")
    mode = DENSE_LATTICES.get(lattice)
    if mode is None:
        raise ValueError(f"dense_block: lattice {lattice!r}; expected one of "
                         f"{', '.join(DENSE_LATTICES)}")
    eps = 1e-9  # SPlisHSPlasH's, in metres
    diam = 2.0 * r
    xs = np.sqrt(6.0) * diam / 3.0 + eps if mode == 2 else diam
    ys = np.sqrt(3.0) * r + eps
    lo = np.zeros(3)
    hi = np.zeros(3)
    lo[:dim], hi[:dim] = a - r, b + r
    diff = hi - lo
    diff[0] -= diam if mode == 1 else xs
    diff[2] -= diam
    nx = int(np.floor(diff[0] / xs + 0.5)) - 1
    ny = int(np.floor(diff[1] / ys + 0.5)) - 1
    nz = int(np.floor(diff[2] / diam + 0.5)) - 1 if dim == 3 else 1
    if min(nx, ny, nz) < 1:
        return np.empty((0, dim), dtype=np.float64)
    j, k, m = (g.ravel() for g in np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz),
                                              indexing="ij"))
    p = np.stack([lo[0] + diam + j * xs, lo[1] + diam + k * ys,
                  (lo[2] + diam if dim == 3 else 0.0) + m * diam], axis=1)
    even = k % 2 == 0
    if mode == 1:
        p[:, 2] += np.where(even, r, 0.0)
        p[:, 0] += np.where(even, 0.0, r)
    else:
        p[:, 2] += r
        if dim == 3:
            p[:, 2] += np.where(j % 2 == 1, np.where(even, r, -r), 0.0)
        p[:, 0] += np.where(even, 0.5 * xs, 0.0)
    return np.ascontiguousarray(p[:, :dim])


def box_walls(
    lo: ArrayLike,
    hi: ArrayLike,
    r: float,
    layers: int = 1,
    open_top_axis: int | None = None,
) -> np.ndarray:
    """Boundary particles of a box container whose interior (fluid space) is ``[lo, hi]``.

    The walls are the lattice points of the box enlarged by ``layers`` particle layers minus the
    interior lattice of :func:`lattice_block` ``(lo, hi, r)``: layer ``k`` (0-based) lies at
    ``lo - r - 2r k`` and ``hi + r + 2r k`` on each axis, edges and corners included. Between the
    walls the points follow the interior lattice, so a fluid block filling the container is
    exactly ``2r`` from the first wall layer. When ``hi - lo`` is not a multiple of ``2r`` the
    upper walls stay at ``hi + r``, a little more than ``2r`` from the last fluid particle, and
    the points along each face are spaced evenly at a little less than ``2r`` (no gap wider
    than ``2r`` anywhere in the walls).

    Args:
        lo: inner lower corner [m], 1 to 3 components.
        hi: inner upper corner [m].
        r: particle radius [m].
        layers: number of wall layers (>= 1).
        open_top_axis: if given, leave out the wall on the ``hi`` side of this axis (an open
            container, e.g. 1 when gravity points along -y).

    Returns:
        ``(M, dim)`` float64 wall particle positions, without duplicates.
    """
    return box_shell(lo, hi, r, layers, open_top_axis)[0]


def box_shell(lo: ArrayLike, hi: ArrayLike, r: float, layers: int = 1,
              open_top_axis: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The wall particles of :func:`box_walls` (same arguments) and the cell of each: the
    product over the axes of the spacing of its coordinate there, 2r across a wall layer and
    the face's even spacing (``2r`` when ``hi - lo`` is a multiple of 2r, a little less
    otherwise) along the face [m^dim]. The walls are a lattice that continues the fluid's, so
    their particles stand for the fluid's missing neighbours with these cells
    (:func:`sphkit.world.walls.add_wall_particles` scales the fluid's lattice volume by
    ``cell / (2r)^dim``).

    Returns:
        ``(M, dim)`` float64 positions and ``(M,)`` float64 cells, ``(2r)^dim`` where the walls
        follow the fluid lattice.
    """
    r = check_radius(r)
    a = _as_vector(lo, "lo")
    b = _as_vector(hi, "hi")
    if a.shape != b.shape:
        raise ValueError(f"lo {a.tolist()} and hi {b.tolist()} differ in length")
    if int(layers) < 1:
        raise ValueError(f"layers must be >= 1, got {layers}")
    dim = a.size
    if open_top_axis is not None and not 0 <= int(open_top_axis) < dim:
        raise ValueError(f"open_top_axis must be in [0, {dim}), got {open_top_axis}")
    k = np.arange(int(layers), dtype=np.float64)
    # wall coordinates along a face: evenly spaced between the first wall layers lo - r and
    # hi + r, at most 2r apart; the fluid lattice when hi - lo is a multiple of 2r. (The fluid
    # lattice itself would leave a gap of up to 4r before the upper walls, through which fluid
    # leaked at the upper edges of a 3D box.)
    interior, spacing = [], []
    for d in range(dim):
        m = max(1, int(np.ceil((b[d] - a[d] + 2.0 * r) / (2.0 * r) - 1e-9)))
        interior.append(np.linspace(a[d] - r, b[d] + r, m + 1)[1:-1])
        spacing.append((b[d] - a[d] + 2.0 * r) / m)
    low = [a[d] - r - 2.0 * r * k[::-1] for d in range(dim)]
    high = [b[d] + r + 2.0 * r * k for d in range(dim)]

    def high_side(d: int) -> list[np.ndarray]:
        return [] if open_top_axis is not None and d == int(open_top_axis) else [high[d]]

    def widths(d: int, coords: np.ndarray) -> np.ndarray:
        """The spacing at each coordinate of axis d: 2r in the wall layers, the face's inside."""
        eps = 1e-6 * r
        inside = (coords > a[d] - r + eps) & (coords < b[d] + r - eps)
        return np.where(inside, spacing[d], 2.0 * r)

    # The shell is a disjoint union over axes d of the points whose first wall coordinate is on
    # axis d: axes before d take interior coordinates, axis d wall coordinates, later axes all.
    parts, cells = [], []
    for d in range(dim):
        axes = []
        for e in range(dim):
            if e < d:
                axes.append(interior[e])
            elif e == d:
                axes.append(np.concatenate([low[e], *high_side(e)]))
            else:
                axes.append(np.concatenate([low[e], interior[e], *high_side(e)]))
        parts.append(_product(axes))
        cells.append(np.prod(_product([widths(e, ax) for e, ax in enumerate(axes)]), axis=1)
                     if all(len(ax) for ax in axes) else np.empty(0))
    return np.concatenate(parts, axis=0), np.concatenate(cells)


def box_wall_distance(points: np.ndarray, lo: ArrayLike, hi: ArrayLike
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Distance of wall particles to the surface of the box ``[lo, hi]`` and the unit wall normal.

    For a point outside the box the nearest surface point is the point clamped into the box, so
    the distance is ``|p - clamp(p)|`` and the normal ``(p - clamp(p)) / distance`` points from
    the fluid into the wall (at edges and corners diagonally). Points on or inside the box get
    distance 0 and normal 0 (no wall distance known). Used by the no-slip wall velocity of Morris
    et al. 1997 (:func:`sphkit.core.viscous.morris_beta`).

    Args:
        points: ``(M, dim)`` wall particle positions [m].
        lo: inner lower corner of the box [m] (at least ``dim`` components).
        hi: inner upper corner [m].

    Returns:
        ``(M,)`` distances [m] and ``(M, dim)`` unit normals.
    """
    p = np.asarray(points, dtype=np.float64)
    dim = p.shape[1]
    a = _as_vector(lo, "lo")[:dim]
    b = _as_vector(hi, "hi")[:dim]
    off = p - np.clip(p, a, b)
    dist = np.linalg.norm(off, axis=1)
    normal = np.zeros_like(p)
    out = dist > 0.0
    normal[out] = off[out] / dist[out, None]
    return dist, normal


def box_face_factors(points: np.ndarray, lo: ArrayLike, hi: ArrayLike,
                     factors: ArrayLike) -> np.ndarray:
    """A value per wall particle of the box ``[lo, hi]`` from one value per face.

    ``factors`` holds 2 dim values in the order -x, +x, -y, +y (, -z, +z); a particle lying
    beyond the face at ``lo[e]`` (``p[e] < lo[e]``) or at ``hi[e]`` takes that face's value, one
    beyond several faces (an edge or a corner) the largest of theirs, one beyond none (on or
    inside the box) 1. Used for ``boxes[].viscosity_factors``.

    Returns:
        ``(M,)`` values.
    """
    p = np.asarray(points, dtype=np.float64)
    dim = p.shape[1]
    a = _as_vector(lo, "lo")[:dim]
    b = _as_vector(hi, "hi")[:dim]
    f = np.asarray(factors, dtype=np.float64)
    if f.shape != (2 * dim,):
        raise ValueError(f"factors {factors!r}: expected {2 * dim} values, one per face")
    out = np.full(len(p), -np.inf)
    for e in range(dim):
        out = np.where(p[:, e] < a[e], np.maximum(out, f[2 * e]), out)
        out = np.where(p[:, e] > b[e], np.maximum(out, f[2 * e + 1]), out)
    return np.where(np.isinf(out), 1.0, out)
