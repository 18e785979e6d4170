"""Signed distance fields of boundary geometry on regular lattices, and their disk cache.

Convention: the signed distance ``d`` is negative inside the solid (inside a closed mesh, inside
a 2D polygon, inside a box) and positive outside; ``|grad d| = 1``. Boundary models that keep
fluid *inside* a geometry (containers, SPlisHSPlasH's ``mapInvert``) negate it.

Three sources, one interface (:class:`SignedDistance`: ``lattice(origin, spacing, shape)`` gives
``d`` at the lattice points ``origin + spacing * index``):

* :class:`MeshDistance` -- a closed triangle mesh (3D), computed by compiled kernels, never by a
  Python loop over triangles (in the manner of Bridson's ``makelevelset3``):

  1. *narrow band*: every triangle writes its exact point-triangle distance (Ericson,
     "Real-Time Collision Detection" 5.1.5) to the lattice points of its bounding box grown by
     ``band`` lattice spacings, keeping the smallest and the triangle it came from. Points whose
     true distance is at most ``band`` times the smallest spacing are exact. The loop runs in
     parallel over x-planes of the lattice (each plane owned by one thread: no races).
  2. *far field*: the closest-triangle index is propagated along lattice lines (forward and
     backward on every axis, twice; lines in parallel), each point keeping the exact distance to
     the best triangle offered by its line neighbour (a fast-sweeping closest-point transform).
     Away from the band the distance is the exact distance to a nearly closest triangle.
  3. *sign*: ray parity along each axis, with the point-in-triangle test made exact for rays
     through edges and vertices by a symbolic perturbation of the ray (each crossing of a closed
     surface counts once); a point is inside when at least two of the three axes say so, which
     tolerates small holes and rays grazing a face.

* :class:`PolygonDistance` -- closed polylines (segments) in 2D, e.g. the section of a mesh with
  the plane z = 0: exact distance to the nearest segment and crossing parity (majority of three
  rays), in a compiled loop over lattice points (sections hold few segments).
* :class:`BoxDistance` -- an axis-aligned box (closed, or open along one axis), analytic.

:func:`sdf_lattice_cached` keeps computed lattices in the disk cache of
:mod:`sphkit.geometry.cache` (keyed by the vertices and faces as placed in the scene, so the
transform is included, and the lattice).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Sequence
from pathlib import Path

import numba
import numpy as np

from sphkit.geometry.cache import cached_arrays

_JIT = dict(cache=True)  # no fastmath: the distance and sign code compares infinities and zeros


# ---------------------------------------------------------------------------------------------
# point-triangle and point-segment distances


@numba.njit(**_JIT)
def _seg3_dist2(px, py, pz, ax, ay, az, bx, by, bz):
    """Squared distance from p to the segment ab (3D; a point when a = b)."""
    ex, ey, ez = bx - ax, by - ay, bz - az
    l2 = ex * ex + ey * ey + ez * ez
    t = min(max(((px - ax) * ex + (py - ay) * ey + (pz - az) * ez) / max(l2, 1e-300), 0.), 1.)
    return (px - ax - t * ex) ** 2 + (py - ay - t * ey) ** 2 + (pz - az - t * ez) ** 2


@numba.njit(**_JIT)
def tri_dist2(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Squared distance from p to the triangle abc (Ericson 2005, Sec. 5.1.5); with an edge of
    zero length (its square underflows) that of the segment left (the regions divide by it)."""
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    if not (abx * abx + aby * aby + abz * abz > 0.0):
        return _seg3_dist2(px, py, pz, ax, ay, az, cx, cy, cz)
    if not (acx * acx + acy * acy + acz * acz > 0.0
            and (cx - bx) ** 2 + (cy - by) ** 2 + (cz - bz) ** 2 > 0.0):
        return _seg3_dist2(px, py, pz, ax, ay, az, bx, by, bz)
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return apx * apx + apy * apy + apz * apz
    bpx, bpy, bpz = px - bx, py - by, pz - bz
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return bpx * bpx + bpy * bpy + bpz * bpz
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        qx, qy, qz = apx - v * abx, apy - v * aby, apz - v * abz
        return qx * qx + qy * qy + qz * qz
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return cpx * cpx + cpy * cpy + cpz * cpz
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        qx, qy, qz = apx - w * acx, apy - w * acy, apz - w * acz
        return qx * qx + qy * qy + qz * qz
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        qx = bpx - w * (cx - bx)
        qy = bpy - w * (cy - by)
        qz = bpz - w * (cz - bz)
        return qx * qx + qy * qy + qz * qz
    den = va + vb + vc
    if den <= 0.0:  # degenerate (zero-area) triangle: the regions above cover all but this
        return min(apx * apx + apy * apy + apz * apz, bpx * bpx + bpy * bpy + bpz * bpz)
    v = vb / den
    w = vc / den
    qx = apx - abx * v - acx * w
    qy = apy - aby * v - acy * w
    qz = apz - abz * v - acz * w
    return qx * qx + qy * qy + qz * qz


@numba.njit(**_JIT)
def seg_dist2(px, py, ax, ay, bx, by):
    """Squared distance from p to the segment ab (2D)."""
    ex, ey = bx - ax, by - ay
    l2 = ex * ex + ey * ey
    t = 0.0
    if l2 > 0.0:
        t = ((px - ax) * ex + (py - ay) * ey) / l2
        t = min(max(t, 0.0), 1.0)
    qx = px - ax - t * ex
    qy = py - ay - t * ey
    return qx * qx + qy * qy


# ---------------------------------------------------------------------------------------------
# 3D mesh: band, sweeps, sign


@numba.njit(**_JIT)
def _node_range(lo, hi, o, s, n, band):
    i0 = int(math.ceil((lo - o) / s)) - band
    i1 = int(math.floor((hi - o) / s)) + band
    return max(i0, 0), min(i1, n - 1)


@numba.njit(**_JIT)
def _plane_buckets(V, F, o, s, shape, band):
    """CSR lists of the triangles whose grown bounding box meets each x-plane of the lattice."""
    nx = shape[0]
    counts = np.zeros(nx + 1, np.int64)
    nt = F.shape[0]
    ranges = np.empty((nt, 2), np.int64)
    for t in range(nt):
        a, b, c = F[t, 0], F[t, 1], F[t, 2]
        lo = min(V[a, 0], V[b, 0], V[c, 0])
        hi = max(V[a, 0], V[b, 0], V[c, 0])
        i0, i1 = _node_range(lo, hi, o[0], s[0], nx, band)
        ranges[t, 0] = i0
        ranges[t, 1] = i1
        for i in range(i0, i1 + 1):
            counts[i + 1] += 1
    for i in range(nx):
        counts[i + 1] += counts[i]
    fill = counts[:-1].copy()
    tri = np.empty(counts[nx], np.int64)
    for t in range(nt):
        for i in range(ranges[t, 0], ranges[t, 1] + 1):
            tri[fill[i]] = t
            fill[i] += 1
    return counts, tri


@numba.njit(parallel=True, **_JIT)
def _band(V, F, o, s, shape, band, off, tri, dist2, owner):
    nx, ny, nz = shape[0], shape[1], shape[2]
    for i in numba.prange(nx):
        px = o[0] + i * s[0]
        for q in range(off[i], off[i + 1]):
            t = tri[q]
            a, b, c = F[t, 0], F[t, 1], F[t, 2]
            j0, j1 = _node_range(min(V[a, 1], V[b, 1], V[c, 1]), max(V[a, 1], V[b, 1], V[c, 1]),
                                 o[1], s[1], ny, band)
            k0, k1 = _node_range(min(V[a, 2], V[b, 2], V[c, 2]), max(V[a, 2], V[b, 2], V[c, 2]),
                                 o[2], s[2], nz, band)
            for j in range(j0, j1 + 1):
                py = o[1] + j * s[1]
                for k in range(k0, k1 + 1):
                    pz = o[2] + k * s[2]
                    d2 = tri_dist2(px, py, pz, V[a, 0], V[a, 1], V[a, 2], V[b, 0], V[b, 1],
                                   V[b, 2], V[c, 0], V[c, 1], V[c, 2])
                    if d2 < dist2[i, j, k]:
                        dist2[i, j, k] = d2
                        owner[i, j, k] = t


@numba.njit(**_JIT)
def _offer(V, F, o, s, dist2, owner, i, j, k, t):
    """Offer triangle t to lattice point (i, j, k); keep it if it is closer."""
    if t < 0 or t == owner[i, j, k]:
        return
    a, b, c = F[t, 0], F[t, 1], F[t, 2]
    d2 = tri_dist2(o[0] + i * s[0], o[1] + j * s[1], o[2] + k * s[2], V[a, 0], V[a, 1], V[a, 2],
                   V[b, 0], V[b, 1], V[b, 2], V[c, 0], V[c, 1], V[c, 2])
    if d2 < dist2[i, j, k]:
        dist2[i, j, k] = d2
        owner[i, j, k] = t


@numba.njit(parallel=True, **_JIT)
def _sweep(V, F, o, s, dist2, owner, axis, step):
    """Propagate closest triangles along lattice lines of ``axis`` in direction ``step``."""
    nx, ny, nz = dist2.shape
    if axis == 0:
        for j in numba.prange(ny):
            for q in range(1, nx):
                i = q if step > 0 else nx - 1 - q
                for k in range(nz):
                    _offer(V, F, o, s, dist2, owner, i, j, k, owner[i - step, j, k])
    elif axis == 1:
        for i in numba.prange(nx):
            for q in range(1, ny):
                j = q if step > 0 else ny - 1 - q
                for k in range(nz):
                    _offer(V, F, o, s, dist2, owner, i, j, k, owner[i, j - step, k])
    else:
        for i in numba.prange(nx):
            for j in range(ny):
                for q in range(1, nz):
                    k = q if step > 0 else nz - 1 - q
                    _offer(V, F, o, s, dist2, owner, i, j, k, owner[i, j, k - step])


@numba.njit(parallel=True, **_JIT)
def _descend(V, F, voff, vtri, o, s, dist2, owner, max_steps):
    """Walk each point's closest triangle over the triangles around its vertices while that gets
    closer.

    The sweeps hand a point the best triangle of its line neighbour, which drifts away from the
    true closest one with distance; a greedy walk over the vertex one-rings of the triangle
    removes the drift (exact where the distance has no local minimum over the mesh other than
    the global one, e.g. outside a convex mesh).
    """
    nx, ny, nz = dist2.shape
    for i in numba.prange(nx):
        px = o[0] + i * s[0]
        for j in range(ny):
            py = o[1] + j * s[1]
            for k in range(nz):
                pz = o[2] + k * s[2]
                t = owner[i, j, k]
                if t < 0:
                    continue
                best = dist2[i, j, k]
                for _ in range(max_steps):
                    nxt = -1
                    for e in range(3):
                        v = F[t, e]
                        for q in range(voff[v], voff[v + 1]):
                            u = vtri[q]
                            if u == t:
                                continue
                            a, b, c = F[u, 0], F[u, 1], F[u, 2]
                            d2 = tri_dist2(px, py, pz, V[a, 0], V[a, 1], V[a, 2], V[b, 0],
                                           V[b, 1], V[b, 2], V[c, 0], V[c, 1], V[c, 2])
                            if d2 < best:
                                best = d2
                                nxt = u
                    if nxt < 0:
                        break
                    t = nxt
                dist2[i, j, k] = best
                owner[i, j, k] = t


def vertex_triangles(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists (offsets, triangles) of the triangles around each vertex."""
    F = np.asarray(faces, dtype=np.int64)
    v = F.ravel()
    order = np.argsort(v, kind="stable")
    offsets = np.zeros(n_vertices + 1, np.int64)
    np.cumsum(np.bincount(v, minlength=n_vertices), out=offsets[1:])
    return offsets, (order // 3).astype(np.int64)


@numba.njit(**_JIT)
def _orient(xa, ya, xb, yb):
    """Sign of cross(a - q, b - q) for the query point q at the origin moved to (eps, eps^2).

    The perturbation (simulation of simplicity) makes the sign exact and never zero unless
    a == b: a ray through an edge or vertex is claimed by exactly one of the triangles there,
    because neighbours traverse their shared edge in opposite directions.
    """
    c = xa * yb - ya * xb
    if c > 0.0:
        return 1
    if c < 0.0:
        return -1
    if ya > yb:
        return 1
    if ya < yb:
        return -1
    if xb > xa:
        return 1
    if xb < xa:
        return -1
    return 0


@numba.njit(**_JIT)
def _parity_axis(V, F, o, s, shape, axis, cnt):
    """cnt[p] += 1 for the first lattice point p above each crossing of a ray along ``axis``."""
    b = (axis + 1) % 3
    c = (axis + 2) % 3
    n_a, n_b, n_c = shape[axis], shape[b], shape[c]
    idx = np.zeros(3, np.int64)
    for t in range(F.shape[0]):
        v0, v1, v2 = F[t, 0], F[t, 1], F[t, 2]
        j0, j1 = _node_range(min(V[v0, b], V[v1, b], V[v2, b]), max(V[v0, b], V[v1, b], V[v2, b]),
                             o[b], s[b], n_b, 0)
        k0, k1 = _node_range(min(V[v0, c], V[v1, c], V[v2, c]), max(V[v0, c], V[v1, c], V[v2, c]),
                             o[c], s[c], n_c, 0)
        for j in range(j0, j1 + 1):
            qb = o[b] + j * s[b]
            for k in range(k0, k1 + 1):
                qc = o[c] + k * s[c]
                x0, y0 = V[v0, b] - qb, V[v0, c] - qc
                x1, y1 = V[v1, b] - qb, V[v1, c] - qc
                x2, y2 = V[v2, b] - qb, V[v2, c] - qc
                s0 = _orient(x1, y1, x2, y2)
                s1 = _orient(x2, y2, x0, y0)
                s2 = _orient(x0, y0, x1, y1)
                if s0 == 0 or s0 != s1 or s0 != s2:
                    continue
                w0 = x1 * y2 - y1 * x2
                w1 = x2 * y0 - y2 * x0
                w2 = x0 * y1 - y0 * x1
                wsum = w0 + w1 + w2
                if wsum != 0.0:
                    za = (w0 * V[v0, axis] + w1 * V[v1, axis] + w2 * V[v2, axis]) / wsum
                else:
                    za = (V[v0, axis] + V[v1, axis] + V[v2, axis]) / 3.0
                m = int(math.ceil((za - o[axis]) / s[axis]))
                if m < 0:
                    m = 0
                if m < n_a:
                    idx[axis] = m
                    idx[b] = j
                    idx[c] = k
                    cnt[idx[0], idx[1], idx[2]] += 1


@numba.njit(parallel=True, **_JIT)
def _parity_vote(cnt, axis, votes):
    """Prefix sums of crossings along ``axis``: an odd count below a point votes 'inside'."""
    nx, ny, nz = cnt.shape
    if axis == 0:
        for j in numba.prange(ny):
            for k in range(nz):
                acc = 0
                for i in range(nx):
                    acc += cnt[i, j, k]
                    votes[i, j, k] += acc & 1
    elif axis == 1:
        for i in numba.prange(nx):
            for k in range(nz):
                acc = 0
                for j in range(ny):
                    acc += cnt[i, j, k]
                    votes[i, j, k] += acc & 1
    else:
        for i in numba.prange(nx):
            for j in range(ny):
                acc = 0
                for k in range(nz):
                    acc += cnt[i, j, k]
                    votes[i, j, k] += acc & 1


@numba.njit(parallel=True, **_JIT)
def _finish(dist2, votes, out):
    nx, ny, nz = dist2.shape
    for i in numba.prange(nx):
        for j in range(ny):
            for k in range(nz):
                d = math.sqrt(dist2[i, j, k])
                out[i, j, k] = -d if votes[i, j, k] >= 2 else d


def mesh_sdf_lattice(vertices: np.ndarray, faces: np.ndarray, origin: Sequence[float],
                     spacing: Sequence[float], shape: Sequence[int], band: int = 2) -> np.ndarray:
    """Signed distance of a closed triangle mesh at the points of a 3D lattice.

    Args:
        vertices: (V, 3) vertex positions [m].
        faces: (F, 3) vertex indices of the triangles (any orientation).
        origin: lattice point (0, 0, 0) [m].
        spacing: lattice spacing per axis [m].
        shape: number of lattice points per axis.
        band: half-width of the exact band, in lattice spacings (see the module docstring).

    Returns:
        ``(nx, ny, nz)`` float64 signed distances, negative inside the mesh.
    """
    V = np.ascontiguousarray(vertices, dtype=np.float64)
    F = np.ascontiguousarray(faces, dtype=np.int64)
    o = np.asarray(origin, dtype=np.float64)
    s = np.asarray(spacing, dtype=np.float64)
    shp = np.asarray(shape, dtype=np.int64)
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3 or len(F) == 0:
        raise ValueError(f"mesh: vertices {V.shape} and faces {F.shape}; expected (V, 3), (F>0, 3)")
    if o.shape != (3,) or s.shape != (3,) or shp.shape != (3,) or np.any(s <= 0) or np.any(shp < 1):
        raise ValueError(f"lattice: origin {o}, spacing {s}, shape {shp}; expected 3 values each, "
                         "positive spacing and shape")
    if F.min() < 0 or F.max() >= len(V):
        raise ValueError(f"mesh: face indices in [{F.min()}, {F.max()}] outside [0, {len(V)})")
    nx, ny, nz = (int(v) for v in shp)
    dist2 = np.full((nx, ny, nz), np.inf)
    owner = np.full((nx, ny, nz), -1, np.int64)
    off, tri = _plane_buckets(V, F, o, s, shp, int(band))
    _band(V, F, o, s, shp, int(band), off, tri, dist2, owner)
    for _ in range(2):
        for axis in range(3):
            _sweep(V, F, o, s, dist2, owner, axis, 1)
            _sweep(V, F, o, s, dist2, owner, axis, -1)
    voff, vtri = vertex_triangles(F, len(V))
    _descend(V, F, voff, vtri, o, s, dist2, owner, 256)
    votes = np.zeros((nx, ny, nz), np.int8)
    cnt = np.zeros((nx, ny, nz), np.int32)
    for axis in range(3):
        cnt[...] = 0
        _parity_axis(V, F, o, s, shp, axis, cnt)
        _parity_vote(cnt, axis, votes)
    out = np.empty((nx, ny, nz))
    _finish(dist2, votes, out)
    return out


# ---------------------------------------------------------------------------------------------
# 2D polygon


@numba.njit(**_JIT)
def _crossings(px, py, A, B, axis, direction):
    """Parity of the crossings of the ray from p along +/- ``axis`` with the segments AB."""
    n = 0
    for e in range(A.shape[0]):
        if axis == 0:
            ua, va, ub, vb, pu, pv = A[e, 0], A[e, 1], B[e, 0], B[e, 1], px, py
        else:
            ua, va, ub, vb, pu, pv = A[e, 1], A[e, 0], B[e, 1], B[e, 0], py, px
        if (va > pv) != (vb > pv):  # half-open in v: a vertex on the ray counts once
            u = ua + (pv - va) * (ub - ua) / (vb - va)
            if (u - pu) * direction > 0.0:
                n += 1
    return n & 1


@numba.njit(parallel=True, **_JIT)
def _polygon_lattice(A, B, o, s, nx, ny, out):
    for i in numba.prange(nx):
        px = o[0] + i * s[0]
        for j in range(ny):
            py = o[1] + j * s[1]
            best = np.inf
            for e in range(A.shape[0]):
                d2 = seg_dist2(px, py, A[e, 0], A[e, 1], B[e, 0], B[e, 1])
                if d2 < best:
                    best = d2
            votes = (_crossings(px, py, A, B, 0, 1.0) + _crossings(px, py, A, B, 0, -1.0)
                     + _crossings(px, py, A, B, 1, 1.0))
            d = math.sqrt(best)
            out[i, j] = -d if votes >= 2 else d


def polygon_sdf_lattice(a: np.ndarray, b: np.ndarray, origin: Sequence[float],
                        spacing: Sequence[float], shape: Sequence[int]) -> np.ndarray:
    """Signed distance of closed 2D polylines (segments a[e] -> b[e]) at a 2D lattice.

    Returns ``(nx, ny)`` float64 distances, negative inside (odd crossing parity).
    """
    A = np.ascontiguousarray(a, dtype=np.float64)
    B = np.ascontiguousarray(b, dtype=np.float64)
    if A.ndim != 2 or A.shape[1] != 2 or A.shape != B.shape or len(A) == 0:
        raise ValueError(f"segments: {A.shape} / {B.shape}; expected two (E>0, 2) arrays")
    o = np.asarray(origin, dtype=np.float64)
    s = np.asarray(spacing, dtype=np.float64)
    nx, ny = (int(v) for v in shape)
    out = np.empty((nx, ny))
    _polygon_lattice(A, B, o, s, nx, ny, out)
    return out


# ---------------------------------------------------------------------------------------------
# sources


def lattice_points(origin: np.ndarray, spacing: np.ndarray, shape: Sequence[int]) -> np.ndarray:
    """Positions (dim, n1, ..., nd) of the lattice points ``origin + spacing * index``."""
    axes = [origin[d] + spacing[d] * np.arange(shape[d]) for d in range(len(shape))]
    return np.stack(np.meshgrid(*axes, indexing="ij"))


class SignedDistance(ABC):
    """A geometry whose signed distance can be sampled on lattices (negative inside)."""

    dim: int

    @abstractmethod
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper corner of the geometry's bounding box [m]."""

    @abstractmethod
    def lattice(self, origin: Sequence[float], spacing: Sequence[float],
                shape: Sequence[int]) -> np.ndarray:
        """Signed distances at ``origin + spacing * index``, array of the given shape."""

    @abstractmethod
    def key(self) -> list:
        """Everything that determines the distances (for cache keys)."""


class MeshDistance(SignedDistance):
    """A closed triangle mesh (3D), already placed in the scene."""

    dim = 3

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self.vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        self.faces = np.ascontiguousarray(faces, dtype=np.int64)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.vertices.min(axis=0), self.vertices.max(axis=0)

    def lattice(self, origin, spacing, shape) -> np.ndarray:
        return mesh_sdf_lattice(self.vertices, self.faces, origin, spacing, shape)

    def key(self) -> list:
        return ["mesh", self.vertices, self.faces]


class PolygonDistance(SignedDistance):
    """Closed polylines in 2D given as segments a[e] -> b[e]."""

    dim = 2

    def __init__(self, a: np.ndarray, b: np.ndarray) -> None:
        self.a = np.ascontiguousarray(a, dtype=np.float64)
        self.b = np.ascontiguousarray(b, dtype=np.float64)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        p = np.concatenate([self.a, self.b])
        return p.min(axis=0), p.max(axis=0)

    def lattice(self, origin, spacing, shape) -> np.ndarray:
        return polygon_sdf_lattice(self.a, self.b, origin, spacing, shape)

    def key(self) -> list:
        return ["polygon", self.a, self.b]


class BoxDistance(SignedDistance):
    """The axis-aligned box [lo, hi] (2D or 3D); ``open_axis`` extends it to +infinity there."""

    def __init__(self, lo: Sequence[float], hi: Sequence[float], open_axis: int | None = None):
        self.lo = np.asarray(lo, dtype=np.float64)
        self.hi = np.asarray(hi, dtype=np.float64)
        self.dim = self.lo.size
        self.open_axis = open_axis

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.lo.copy(), self.hi.copy()

    def distance(self, p: np.ndarray) -> np.ndarray:
        """Signed distance at points p of shape (dim, ...)."""
        hi = self.hi.copy()
        if self.open_axis is not None:
            hi[self.open_axis] = np.inf
        shape = (self.dim,) + (1,) * (p.ndim - 1)
        q = np.maximum(self.lo.reshape(shape) - p, p - hi.reshape(shape))
        outside = np.sqrt((np.maximum(q, 0.0) ** 2).sum(axis=0))
        return outside + np.minimum(q.max(axis=0), 0.0)

    def lattice(self, origin, spacing, shape) -> np.ndarray:
        o = np.asarray(origin, dtype=np.float64)
        s = np.asarray(spacing, dtype=np.float64)
        return self.distance(lattice_points(o, s, shape))

    def key(self) -> list:
        return ["box", self.lo, self.hi, self.open_axis]


def sdf_lattice_cached(src: SignedDistance, origin: Sequence[float], spacing: Sequence[float],
                      shape: Sequence[int], folder: Path | None) -> tuple[np.ndarray, bool]:
    """:meth:`SignedDistance.lattice` through :func:`sphkit.geometry.cache.cached_arrays`;
    returns (values, hit)."""
    o = np.asarray(origin, dtype=np.float64)
    s = np.asarray(spacing, dtype=np.float64)
    shp = np.asarray(shape, dtype=np.int64)
    arrays, hit = cached_arrays("sdf", [src.key(), o, s, shp],
                                lambda: {"d": src.lattice(o, s, shp)}, folder)
    return arrays["d"], hit
