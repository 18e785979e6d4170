"""Points on the surface and in the volume of triangle meshes (and of their 2D sections).

Set-up code (run once before a simulation), written with NumPy, SciPy and trimesh, following the
lattice conventions of :mod:`sphkit.geometry.sampling`. Mesh surfaces are sampled with one layer
of particles (Akinci et al. 2012) about ``2r`` apart; volumes on the lattice ``lo + r + 2r k`` of
the mesh's bounding box, keeping the points inside (signed distance, :mod:`sphkit.geometry.sdf`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from sphkit.geometry import GeometryError
from sphkit.geometry.meshes import section_segments
from sphkit.geometry.sampling import check_radius, lattice_count

if TYPE_CHECKING:
    import trimesh

# Mesh sampling: interior points keep this distance (in units of the spacing 2r) from the
# edges of their face, and no two samples are closer than it (1.5 r).
_MIN_SPACING = 0.75
# Polylines (2D sections) are split at corners that turn more than this angle.
_CORNER_ANGLE = np.deg2rad(20.0)


def _greedy_thin(points: np.ndarray, dmin: float) -> np.ndarray:
    """Keep points in order, dropping each point closer than ``dmin`` to an earlier kept one."""
    from scipy.spatial import cKDTree

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
        raise GeometryError(
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
        mesh: the mesh, already placed in the scene
            (:func:`sphkit.geometry.meshes.load_mesh`).
        r: particle radius [m].
        dim: 3, or 2 for the section with z = 0.

    Returns:
        ``(M, dim)`` float64 positions on the surface (or on the 2D section).
    """
    r = check_radius(r)
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
    from scipy.spatial import cKDTree

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


Lattice = tuple[np.ndarray, np.ndarray, np.ndarray]  # origin, spacing, points per axis


def volume_lattices(lo: np.ndarray, hi: np.ndarray, r: float, lattice: str = "square"
                    ) -> list[Lattice]:
    """The candidate points of SPlisHSPlasH's ``VolumeSampling::sampleMesh`` over the box
    ``[lo, hi]`` (2D or 3D), as rectangular lattices ``(origin, spacing, shape)``.

    * ``square`` (mode 0): ``lo + r + 2r k`` at or below ``hi - r`` (as
      :func:`sphkit.geometry.sampling.lattice_block`);
    * ``layered`` (mode 1): columns ``2r`` apart along x and z, rows ``sqrt(3) r`` apart along y
      from ``lo``; a point ``(x, y + r, z + r)`` in even rows, ``(x + r, y + r, z)`` in odd ones;
    * ``close_packed`` (mode 2): columns ``sqrt(3) r`` apart along x, rows ``2 sqrt(6) r / 3``
      along y, ``2r`` along z; ``(x, y + r, z + r)``, odd columns shifted by ``+r`` along z in
      even rows and ``-r`` in odd ones, odd rows by half a column along x and ``+r`` along z.

    SPlisHSPlasH's loops run from ``lo`` while the coordinate is at most ``hi``, so the dense
    lattices are split by the parity of row (and, in 3D mode 2, column) into lattices of twice
    the spacing. In 2D the z offsets are dropped (the section z = 0 is sampled).
    """
    dim = len(lo)
    if lattice == "square":
        n = np.array([lattice_count(a, b, r) for a, b in zip(lo, hi, strict=True)], np.int64)
        return [(lo + r, np.full(dim, 2.0 * r), n)]
    if lattice not in ("layered", "close_packed"):
        raise ValueError(f"lattice {lattice!r}; expected square, layered or close_packed")
    d = 2.0 * r
    layered = lattice == "layered"
    steps = [d if layered else np.sqrt(3.0) * r,
             np.sqrt(3.0) * r if layered else np.sqrt(6.0) * d / 3.0, d][:dim]
    count = [int(np.floor((b - a) / s + 1e-9)) + 1 if b >= a else 0
             for a, b, s in zip(lo, hi, steps, strict=True)]
    xs, ys = steps[0], steps[1]
    out = []
    for row in (0, 1):
        ny = (count[1] - row + 1) // 2
        if layered:  # even rows (x, y + r, z + r), odd rows (x + r, y + r, z)
            cols = [(row * r, count[0], d, (1 - row) * r)]
        elif dim == 2:  # the z shifts dropped: every column, odd rows half a column along x
            cols = [(row * xs / 2.0, count[0], xs, 0.0)]
        else:  # mode 2 in 3D: even and odd columns apart
            cols = [(c * xs + row * xs / 2.0, (count[0] - c + 1) // 2, 2.0 * xs,
                     r + (r if c and not row else 0.0) + (r if row and not c else 0.0))
                    for c in (0, 1)]
        for x0, nx, sx, z0 in cols:
            origin = [lo[0] + x0, lo[1] + row * ys + r]
            spacing = [sx, 2.0 * ys]
            shape = [nx, ny]
            if dim == 3:
                origin.append(lo[2] + z0)
                spacing.append(d)
                shape.append(count[2])
            out.append((np.array(origin), np.array(spacing), np.array(shape, np.int64)))
    return out


def lattice_volume_points(r: float, lattice: str, dim: int, side: float) -> np.ndarray:
    """The points of :func:`volume_lattices` in the cube ``[0, side]^dim`` (M, dim): a sample
    of the lattice from which the particle volume is computed."""
    from sphkit.geometry.sdf import lattice_points

    pts = [lattice_points(o, s, n).reshape(dim, -1).T
           for o, s, n in volume_lattices(np.zeros(dim), np.full(dim, side), r, lattice)
           if np.all(n > 0)]
    return np.concatenate(pts)


def sample_mesh_volume(mesh: trimesh.Trimesh, r: float, dim: int = 3,
                       invert: bool = False, lattice: str = "square") -> np.ndarray:
    """Fluid particles filling a closed mesh (SPlisHSPlasH's ``VolumeSampling``).

    The candidates are the points of :func:`volume_lattices` in the mesh's bounding box
    ``[lo, hi]`` (``square``: the lattice points ``lo + r + 2r k`` at or below ``hi - r``, as
    :func:`sphkit.geometry.sampling.lattice_block`); a point is kept when its signed distance to
    the mesh (:mod:`sphkit.geometry.sdf`, exact at the points) is negative (inside), or positive
    with ``invert`` (the box around the mesh is filled instead). A block-shaped mesh thus gives
    the same particles as the fluid block of the same extent on the square lattice.

    Args:
        mesh: closed mesh, already placed in the scene.
        r: particle radius [m].
        dim: 3, or 2 for the section with z = 0 (sampled in the xy-plane).
        invert: keep the points outside the mesh.
        lattice: ``square``, ``layered`` or ``close_packed`` (SPlisHSPlasH's modes 0, 1, 2).

    Returns:
        ``(M, dim)`` float64 positions.
    """
    from sphkit.geometry.sdf import mesh_sdf_lattice, polygon_sdf_lattice

    r = check_radius(r)
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
    lattices = [la for la in volume_lattices(lo, hi, r, lattice) if np.all(la[2] > 0)]
    if sum(np.prod(n.astype(float)) for _, _, n in lattices) > 2e8:
        raise GeometryError(f"mesh of extent {(hi - lo).tolist()} m holds more than 2e8 "
                            f"lattice points of radius {r} m")
    out = [np.empty((0, dim))]
    for origin, spacing, n in lattices:
        if dim == 3:
            d = mesh_sdf_lattice(mesh.vertices, mesh.faces, origin, spacing, n)
        else:
            d = polygon_sdf_lattice(a, b, origin, spacing, n)
        tol = 1e-9 * r  # a point on the surface (a dense lattice's face row) stays out
        keep = d > tol if invert else d < -tol
        out.append(origin[None] + np.argwhere(keep) * spacing[None])
    return np.concatenate(out)


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
