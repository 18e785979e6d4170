"""Particle sampling of scene geometry: fluid blocks, box containers and triangle meshes.

This is scene set-up code (run once before a simulation), written with NumPy, SciPy and trimesh.

Conventions shared by every sampler here:

- Particles of radius ``r`` sit on a lattice of spacing ``2r`` (one particle diameter).
- A fluid block ``[start, end]`` holds the lattice points ``start + r + 2r k`` (k = 0, 1, ...)
  that lie at or below ``end - r`` (tolerance ``1e-9 r``): the block is exactly filled by the
  particles' cubes of side ``2r`` when ``end - start`` is a multiple of ``2r``.
- The walls of a box container with interior ``[lo, hi]`` continue that lattice outwards: wall
  layer ``k`` (0-based) lies at ``lo - r - 2r k`` and ``hi + r + 2r k`` on each axis, so a fluid
  block filling the container is ``2r`` away from the first wall layer.
- Mesh surfaces are sampled with one layer of particles (Akinci et al. 2012) about ``2r`` apart.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from sphkit.geometry.rotations import rotation_matrix
from sphkit.scene.schema import SceneError

ArrayLike = Sequence[float] | np.ndarray

# Lattice tolerance, relative to r: a lattice point this close beyond end - r still counts.
_LATTICE_TOL = 1e-9
# Mesh sampling: interior points keep this distance (in units of the spacing 2r) from the
# edges of their face, and no two samples are closer than it (1.5 r).
_MIN_SPACING = 0.75
# Polylines (2D sections) are split at corners that turn more than this angle.
_CORNER_ANGLE = np.deg2rad(20.0)


# ----------------------------------------------------------------------------------------------
# lattices
# ----------------------------------------------------------------------------------------------


def _as_vector(x: ArrayLike, name: str) -> np.ndarray:
    v = np.asarray(x, dtype=np.float64).ravel()
    if v.size not in (1, 2, 3):
        raise ValueError(f"{name} must have 1 to 3 components, got {v.size}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite, got {v.tolist()}")
    return v


def _check_radius(r: float) -> float:
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
    r = _check_radius(r)
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
    r = _check_radius(r)
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
    r = _check_radius(r)
    a = _as_vector(lo, "lo")
    b = _as_vector(hi, "hi")
    if a.shape != b.shape:
        raise ValueError(f"lo {a.tolist()} and hi {b.tolist()} differ in length")
    if int(layers) < 1:
        raise ValueError(f"layers must be >= 1, got {layers}")
    layers = int(layers)
    dim = a.size
    if open_top_axis is not None and not 0 <= int(open_top_axis) < dim:
        raise ValueError(f"open_top_axis must be in [0, {dim}), got {open_top_axis}")

    k = np.arange(layers, dtype=np.float64)
    # wall coordinates along a face: evenly spaced between the first wall layers lo - r and
    # hi + r, at most 2r apart; the fluid lattice when hi - lo is a multiple of 2r. (The fluid
    # lattice itself would leave a gap of up to 4r before the upper walls, through which fluid
    # leaked at the upper edges of a 3D box.)
    interior = []
    for d in range(dim):
        m = max(1, int(np.ceil((b[d] - a[d] + 2.0 * r) / (2.0 * r) - 1e-9)))
        interior.append(np.linspace(a[d] - r, b[d] + r, m + 1)[1:-1])
    low = [a[d] - r - 2.0 * r * k[::-1] for d in range(dim)]
    high = [b[d] + r + 2.0 * r * k for d in range(dim)]

    def high_side(d: int) -> list[np.ndarray]:
        return [] if open_top_axis is not None and d == int(open_top_axis) else [high[d]]

    # The shell is a disjoint union over axes d of the points whose first wall coordinate is on
    # axis d: axes before d take interior coordinates, axis d wall coordinates, later axes all.
    parts = []
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
    return np.concatenate(parts, axis=0)


# ----------------------------------------------------------------------------------------------
# meshes
# ----------------------------------------------------------------------------------------------


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


def _read_triangles(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of a mesh file, without materials or textures.

    ``trimesh.load(..., force="mesh")`` copies the visuals, which needs Pillow for textured OBJ
    files; reading the geometry (and a scene's node transforms) directly does not.
    """
    loaded = trimesh.load(path)
    if isinstance(loaded, trimesh.Trimesh):
        return np.array(loaded.vertices, dtype=np.float64), np.array(loaded.faces, dtype=np.int64)
    vertices, faces, offset = [], [], 0
    if isinstance(loaded, trimesh.Scene):
        for node in loaded.graph.nodes_geometry:
            transform, name = loaded.graph[node]
            geom = loaded.geometry[name]
            if not isinstance(geom, trimesh.Trimesh) or len(geom.faces) == 0:
                continue
            v = np.asarray(geom.vertices, dtype=np.float64)
            vertices.append(v @ transform[:3, :3].T + transform[:3, 3])
            faces.append(np.asarray(geom.faces, dtype=np.int64) + offset)
            offset += len(v)
    if not faces:
        return np.empty((0, 3)), np.empty((0, 3), dtype=np.int64)
    return np.concatenate(vertices), np.concatenate(faces)


def load_mesh(
    path: str | Path,
    translation: ArrayLike = (0.0, 0.0, 0.0),
    rotation_axis: ArrayLike = (1.0, 0.0, 0.0),
    rotation_angle: float = 0.0,
    scale: ArrayLike | float = (1.0, 1.0, 1.0),
) -> trimesh.Trimesh:
    """Load a triangle mesh (OBJ, PLY, STL, ...) and place it in the scene.

    The transformation follows SPlisHSPlasH (``StaticBoundarySimulator``): the vertices are
    scaled when the file is read, then rotated by ``rotation_angle`` radians about
    ``rotation_axis``, then translated: ``x = R (s * x0) + t``.

    Args:
        path: mesh file.
        translation: translation t [m].
        rotation_axis: rotation axis (any length > 0; normalized here).
        rotation_angle: rotation angle [rad].
        scale: per-axis scale factors s (a number scales uniformly); none may be zero.

    Returns:
        A new :class:`trimesh.Trimesh` without visuals, duplicate vertices merged.

    Raises:
        SceneError: naming the file: missing, unreadable, without triangles, or a bad transform.
    """
    p = Path(path)
    if not p.is_file():
        raise SceneError(f"mesh file {str(p)!r}: not found")
    try:
        vertices, faces = _read_triangles(p)
    except Exception as err:  # trimesh raises many exception types for bad files
        raise SceneError(
            f"mesh file {str(p)!r}: cannot be read as a triangle mesh ({err})"
        ) from err
    if len(faces) == 0:
        raise SceneError(f"mesh file {str(p)!r}: contains no triangles (not a triangle mesh)")
    s = np.broadcast_to(np.asarray(scale, dtype=np.float64).ravel(), (3,)).copy()
    if not np.all(np.isfinite(s)) or np.any(s == 0.0):
        raise SceneError(f"mesh file {str(p)!r}: scale {s.tolist()} must be finite and non-zero")
    t = np.asarray(translation, dtype=np.float64).ravel()
    if t.size != 3 or not np.all(np.isfinite(t)):
        raise SceneError(f"mesh file {str(p)!r}: translation {t.tolist()} must be 3 finite numbers")
    ax = np.asarray(rotation_axis, dtype=np.float64).ravel()
    if ax.size != 3:
        raise SceneError(f"mesh file {str(p)!r}: rotation axis must have 3 components, got "
                         f"{ax.tolist()}")
    angle = float(rotation_angle)
    if angle != 0.0 and not np.linalg.norm(ax) > 0.0:
        raise SceneError(f"mesh file {str(p)!r}: rotation axis {ax.tolist()} has zero length")
    rot = rotation_matrix(ax, angle)
    # without visuals (texture seams split vertices); duplicate vertices merged
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces)
    transform = np.eye(4)
    transform[:3, :3] = rot @ np.diag(s)
    transform[:3, 3] = t
    mesh.apply_transform(transform)
    return mesh


def _greedy_thin(points: np.ndarray, dmin: float) -> np.ndarray:
    """Keep points in order, dropping each point closer than ``dmin`` to an earlier kept one."""
    if len(points) < 2:
        return points
    pairs = cKDTree(points).query_pairs(dmin, output_type="ndarray")
    if len(pairs) == 0:
        return points
    pairs = np.sort(pairs, axis=1)
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    first, offsets = np.unique(pairs[:, 0], return_index=True)
    ends = np.append(offsets[1:], len(pairs))
    keep = np.ones(len(points), dtype=bool)
    for i, lo, hi in zip(first.tolist(), offsets.tolist(), ends.tolist(), strict=True):
        if keep[i]:
            keep[pairs[lo:hi, 1]] = False
    return points[keep]


def _sample_segments(a: np.ndarray, b: np.ndarray, spacing: float) -> np.ndarray:
    """Interior points (no end points) of segments a->b, ``round(L / spacing)`` pieces each."""
    length = np.linalg.norm(b - a, axis=1)
    n = np.maximum(1, np.rint(length / spacing)).astype(np.int64)
    counts = n - 1
    if counts.sum() == 0:
        return np.empty((0, a.shape[1]))
    seg = np.repeat(np.arange(len(a)), counts)
    starts = np.cumsum(counts) - counts
    k = np.arange(counts.sum()) - np.repeat(starts, counts) + 1
    t = (k / n[seg])[:, None]
    return a[seg] + t * (b[seg] - a[seg])


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of each 2D point to the nearest of the segments a->b; shape (len(p),)."""
    best = np.full(len(p), np.inf)
    ab = b - a
    ab2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    chunk = max(1, 2_000_000 // max(1, len(a)))
    for s0 in range(0, len(p), chunk):
        q = p[s0 : s0 + chunk, None, :]  # (K, 1, 2)
        t = np.clip(np.einsum("kej,ej->ke", q - a[None], ab) / ab2[None], 0.0, 1.0)
        d = q - (a[None] + t[..., None] * ab[None])
        best[s0 : s0 + chunk] = np.sqrt(np.einsum("kej,kej->ke", d, d).min(axis=1))
    return best


def _inside_triangles(p: np.ndarray, tri: np.ndarray, eps: float) -> np.ndarray:
    """Whether each 2D point lies in any of the 2D triangles ``tri`` (T, 3, 2)."""
    inside = np.zeros(len(p), dtype=bool)
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1 = b - a, c - a
    den = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    ok = np.abs(den) > 0.0
    a, v0, v1, den = a[ok], v0[ok], v1[ok], den[ok]
    chunk = max(1, 2_000_000 // max(1, len(a)))
    for s0 in range(0, len(p), chunk):
        q = p[s0 : s0 + chunk, None, :] - a[None]  # (K, T, 2)
        u = (q[..., 0] * v1[None, :, 1] - q[..., 1] * v1[None, :, 0]) / den[None]
        w = (v0[None, :, 0] * q[..., 1] - v0[None, :, 1] * q[..., 0]) / den[None]
        inside[s0 : s0 + chunk] = np.any((u >= -eps) & (w >= -eps) & (u + w <= 1.0 + eps), axis=1)
    return inside


def _facet_interior(
    vertices: np.ndarray, faces: np.ndarray, normal: np.ndarray, spacing: float
) -> np.ndarray:
    """Grid points inside a planar patch (faces), at least ``0.75 spacing`` from its border."""
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    uniq, counts = np.unique(edges, axis=0, return_counts=True)
    border = uniq[counts == 1]
    if len(border) == 0:
        return np.empty((0, 3))
    lengths = np.linalg.norm(vertices[border[:, 1]] - vertices[border[:, 0]], axis=1)
    e0 = border[np.argmax(lengths)]
    origin = vertices[e0[0]]
    u = vertices[e0[1]] - origin
    u /= np.linalg.norm(u)
    nrm = normal / np.linalg.norm(normal)
    v = np.cross(nrm, u)
    v /= np.linalg.norm(v)
    basis = np.stack([u, v])  # (2, 3)
    used = np.unique(faces)
    p2 = np.zeros((len(vertices), 2))
    p2[used] = (vertices[used] - origin) @ basis.T
    umin, vmin = p2[used].min(axis=0)
    umax, vmax = p2[used].max(axis=0)
    lu = float(lengths.max())
    hv = max(abs(vmin), abs(vmax))
    su = lu / max(1.0, np.rint(lu / spacing))
    sv = hv / max(1.0, np.rint(hv / spacing)) if hv > 0 else spacing
    iu = np.arange(np.floor(umin / su), np.ceil(umax / su) + 1)
    iv = np.arange(np.floor(vmin / sv), np.ceil(vmax / sv) + 1)
    if len(iu) * len(iv) > 50_000_000:
        raise SceneError(
            f"mesh face of {umax - umin:.3g} x {vmax - vmin:.3g} m is too large to sample "
            f"at spacing {spacing:.3g} m"
        )
    gu, gv = np.meshgrid(iu * su, iv * sv, indexing="ij")
    cand = np.stack([gu.ravel(), gv.ravel()], axis=1)
    clearance = _MIN_SPACING * spacing * (1.0 - 1e-6)
    cand = cand[_inside_triangles(cand, p2[faces], 1e-9)]
    if len(cand) == 0:
        return np.empty((0, 3))
    cand = cand[_point_segment_distance(cand, p2[border[:, 0]], p2[border[:, 1]]) >= clearance]
    return origin + cand @ basis


def sample_mesh_surface(mesh: trimesh.Trimesh, r: float, dim: int = 3) -> np.ndarray:
    """Boundary particles on the surface of a mesh, one layer about ``2r`` apart.

    3D: the mesh is split into planar patches (trimesh facets; other triangles on their own).
    The border edges of the patches are sampled first (every mesh vertex on a border, then
    ``round(L / 2r)`` pieces per edge, each edge once), then the inside of each patch with a grid
    of spacing about ``2r`` aligned to its longest border edge, keeping ``1.5r`` from the
    border. A final greedy pass (vertices first, then edge points, then interior points) removes
    any sample closer than ``1.5r`` to a kept one, e.g. where patches meet at sharp angles or
    where the mesh is finer than the particles. Flat faces thus get a regular grid; nearest
    neighbours are ``1.5r`` to ``2.5r`` apart except on edges shorter than ``2r``.

    2D: the mesh is intersected with the plane z = 0; the section's polylines are split at
    corners (turns over 20 degrees) and each piece is sampled with ``round(L / 2r)`` equal steps,
    corners included.

    Args:
        mesh: the mesh, already placed in the scene (see :func:`load_mesh`).
        r: particle radius [m].
        dim: 3, or 2 for the section with z = 0.

    Returns:
        ``(M, dim)`` float64 positions on the surface (or on the 2D section).
    """
    r = _check_radius(r)
    spacing = 2.0 * r
    if dim == 2:
        return _sample_section_2d(mesh, spacing)
    if dim != 3:
        raise ValueError(f"dim must be 2 or 3, got {dim}")
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    areas = np.asarray(mesh.area_faces)
    scale = max(float(np.ptp(vertices, axis=0).max()), 1e-300)
    good = areas > 1e-14 * scale * scale
    normals = np.asarray(mesh.face_normals)

    groups: list[np.ndarray] = [f for f in mesh.facets if np.all(good[f])]
    in_group = np.zeros(len(faces), dtype=bool)
    for g in groups:
        in_group[g] = True
    singles = np.flatnonzero(good & ~in_group)

    # border edges of every patch: edges that are not shared by two faces of the same patch
    patch = np.full(len(faces), -1, dtype=np.int64)
    for k, g in enumerate(groups):
        patch[g] = k
    patch[singles] = len(groups) + np.arange(len(singles))
    valid = np.flatnonzero(patch >= 0)
    e = np.sort(faces[valid][:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    epatch = np.repeat(patch[valid], 3)
    key = np.concatenate([e, epatch[:, None]], axis=1)
    uk, kc = np.unique(key, axis=0, return_counts=True)
    border = np.unique(uk[kc == 1][:, :2], axis=0)

    corner_pts = vertices[np.unique(border)]
    edge_pts = _sample_segments(vertices[border[:, 0]], vertices[border[:, 1]], spacing)

    interior = []
    for g in groups:
        interior.append(_facet_interior(vertices, faces[g], normals[g[0]], spacing))
    if len(singles):
        # a triangle holds interior points only if its inradius exceeds the clearance
        tri = vertices[faces[singles]]
        perim = sum(np.linalg.norm(tri[:, i] - tri[:, (i + 1) % 3], axis=1) for i in range(3))
        inradius = 2.0 * areas[singles] / perim
        for f in singles[inradius >= _MIN_SPACING * spacing * (1.0 - 1e-6)]:
            interior.append(_facet_interior(vertices, faces[[f]], normals[f], spacing))
    pts = np.concatenate([corner_pts, edge_pts, *interior], axis=0)
    return _greedy_thin(pts, _MIN_SPACING * spacing * (1.0 - 1e-6))


# ----------------------------------------------------------------------------------------------
# 2D sections
# ----------------------------------------------------------------------------------------------


def _merge_points(p: np.ndarray, tol: float) -> np.ndarray:
    """Label points so that points closer than ``tol`` share a label (first index wins)."""
    labels = np.arange(len(p))
    for i, j in sorted(cKDTree(p).query_pairs(tol)):
        root_i, root_j = labels[i], labels[j]
        while labels[root_i] != root_i:
            root_i = labels[root_i]
        while labels[root_j] != root_j:
            root_j = labels[root_j]
        if root_i != root_j:
            labels[max(root_i, root_j)] = min(root_i, root_j)
    for i in range(len(p)):
        root = labels[i]
        while labels[root] != root:
            root = labels[root]
        labels[i] = root
    return labels


def _chains(edges: np.ndarray) -> list[list[int]]:
    """Split an undirected graph into maximal chains (open, or closed with first == last)."""
    adj: dict[int, list[int]] = {}
    for a, b in edges.tolist():
        adj.setdefault(a, []).append(b)
        adj.setdefault(b, []).append(a)
    used: set[tuple[int, int]] = set()
    chains = []

    def walk(start: int, nxt: int) -> list[int]:
        chain = [start]
        prev, cur = start, nxt
        used.add((min(prev, cur), max(prev, cur)))
        while True:
            chain.append(cur)
            if cur == start or len(adj[cur]) != 2:
                return chain
            a, b = adj[cur]
            step = b if a == prev else a
            key = (min(cur, step), max(cur, step))
            if key in used:
                return chain
            used.add(key)
            prev, cur = cur, step

    starts = [v for v, n in adj.items() if len(n) != 2] + [v for v, n in adj.items() if len(n) == 2]
    for v in starts:
        for w in adj[v]:
            if (min(v, w), max(v, w)) not in used:
                chains.append(walk(v, w))
    return chains


def _sample_polyline(p: np.ndarray, spacing: float, closed: bool) -> np.ndarray:
    """Points along a polyline, corners kept, ``round(L / spacing)`` equal steps per piece."""
    if closed:
        p = p[:-1]
        n = len(p)
        d_in = p - np.roll(p, 1, axis=0)
        d_out = np.roll(p, -1, axis=0) - p
    else:
        n = len(p)
        d_in = np.diff(p, axis=0, prepend=p[:1])
        d_out = np.diff(p, axis=0, append=p[-1:])
    cosang = np.einsum("ij,ij->i", d_in, d_out) / np.maximum(
        np.linalg.norm(d_in, axis=1) * np.linalg.norm(d_out, axis=1), 1e-300
    )
    corner = cosang < np.cos(_CORNER_ANGLE)
    if not closed:
        corner[0] = corner[-1] = True
    cidx = np.flatnonzero(corner)
    if closed:
        if len(cidx) == 0:
            cidx = np.array([0])
        p = np.roll(p, -cidx[0], axis=0)
        cidx = np.append(cidx - cidx[0], n)
        p = np.concatenate([p, p[:1]], axis=0)
    out = []
    for c0, c1 in zip(cidx[:-1], cidx[1:], strict=True):
        piece = p[c0 : c1 + 1]
        seg = np.linalg.norm(np.diff(piece, axis=0), axis=1)
        s = np.concatenate([[0.0], np.cumsum(seg)])
        if s[-1] <= 0.0:
            continue
        m = max(1, int(np.rint(s[-1] / spacing)))
        t = np.linspace(0.0, s[-1], m + 1)[:-1]
        out.append(np.stack([np.interp(t, s, piece[:, 0]), np.interp(t, s, piece[:, 1])], axis=1))
    if not closed:
        out.append(p[-1:])
    return np.concatenate(out, axis=0) if out else np.empty((0, 2))


def section_segments(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    """The section of a mesh with the plane z = 0 as 2D segments a[e] -> b[e], each (E, 2)."""
    segs = trimesh.intersections.mesh_plane(mesh, plane_normal=[0.0, 0.0, 1.0],
                                            plane_origin=[0.0, 0.0, 0.0])
    if len(segs) == 0:
        return np.empty((0, 2)), np.empty((0, 2))
    s = np.asarray(segs, dtype=np.float64)[:, :, :2]
    return s[:, 0].copy(), s[:, 1].copy()


def sample_mesh_volume(mesh: trimesh.Trimesh, r: float, dim: int = 3,
                       invert: bool = False) -> np.ndarray:
    """Fluid particles filling a closed mesh (SPlisHSPlasH's ``VolumeSampling``, mode 0).

    The candidates are the lattice points ``lo + r + 2r k`` at or below ``hi - r`` (as
    :func:`lattice_block`) in the mesh's bounding box ``[lo, hi]``; a point is kept when its
    signed distance
    to the mesh (:mod:`sphkit.geometry.sdf`, exact at the points) is negative (inside), or positive
    with ``invert`` (the box around the mesh is filled instead). A block-shaped mesh thus gives
    the same particles as the fluid block of the same extent.

    Args:
        mesh: closed mesh, already placed in the scene.
        r: particle radius [m].
        dim: 3, or 2 for the section with z = 0 (sampled in the xy-plane).
        invert: keep the points outside the mesh.

    Returns:
        ``(M, dim)`` float64 positions.
    """
    from sphkit.geometry.sdf import mesh_sdf_lattice, polygon_sdf_lattice

    r = _check_radius(r)
    if dim == 3:
        v = np.asarray(mesh.vertices, dtype=np.float64)
        lo, hi = v.min(axis=0), v.max(axis=0)
    elif dim == 2:
        a, b = section_segments(mesh)
        if len(a) == 0:
            return np.empty((0, 2))
        p = np.concatenate([a, b])
        lo, hi = p.min(axis=0), p.max(axis=0)
    else:
        raise ValueError(f"dim must be 2 or 3, got {dim}")
    n = np.array([lattice_count(a, b, r) for a, b in zip(lo, hi, strict=True)], dtype=np.int64)
    if np.any(n == 0):
        return np.empty((0, dim))
    if np.prod(n.astype(float)) > 2e8:
        raise SceneError(f"mesh of extent {(hi - lo).tolist()} m holds more than 2e8 lattice "
                         f"points of radius {r} m")
    origin = lo + r
    spacing = np.full(dim, 2.0 * r)
    if dim == 3:
        d = mesh_sdf_lattice(mesh.vertices, mesh.faces, origin, spacing, n)
    else:
        d = polygon_sdf_lattice(a, b, origin, spacing, n)
    keep = d > 0.0 if invert else d < 0.0
    idx = np.argwhere(keep)
    return origin[None] + idx * spacing[None]


def _sample_section_2d(mesh: trimesh.Trimesh, spacing: float) -> np.ndarray:
    a, b = section_segments(mesh)
    if len(a) == 0:
        return np.empty((0, 2))
    pts = np.stack([a, b], axis=1).reshape(-1, 2)
    scale = max(float(np.ptp(pts, axis=0).max()), 1e-300)
    labels = _merge_points(pts, 1e-9 * scale)
    edges = labels.reshape(-1, 2)
    edges = edges[edges[:, 0] != edges[:, 1]]
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    out = []
    for chain in _chains(edges):
        closed = chain[0] == chain[-1] and len(chain) > 2
        out.append(_sample_polyline(pts[chain], spacing, closed))
    samples = np.concatenate(out, axis=0) if out else np.empty((0, 2))
    return _greedy_thin(samples, _MIN_SPACING * spacing * (1.0 - 1e-6))
