"""The dense layout of :class:`sphkit.core.neighbors.Grid`: every cell of the point set's
bounding box has a slot, the points are counting-sorted by the row-major cell index, so a row of
cells along the last axis is one contiguous run of the sorted points.

Two queries:

* :func:`_dense_query` (any query points, e.g. fluid particles against the walls' samples):
  for each query point, each of the rows of cells within reach, only the run of cells that the
  ball of radius h touches, the distance test appending the hits branch-free
  (:func:`_dense_scan`).
* :func:`_dense_cell_query` (query points sorted into a grid of their own on the same lattice:
  the fluid against itself, self excluded, and against the walls, every step): cell by cell of
  the queries' grid. The points of a cell share their candidates -- the runs of the 3^d cells
  around it -- which are copied once into a contiguous block; each point of the cell then tests
  the block 64 candidates at a time into a bit mask (a loop the compiler vectorises, with no
  branch) and appends only the hits, found by counting trailing zeros. The lists are those of
  :func:`_dense_query`, in the same order (the block holds the runs in the order the per-point
  scan visits them and only more candidates, the cells' corners); the candidates per point are
  about 1.8 times as many, but the per-point scan's cost was its branch-free append of every
  candidate and its loop bookkeeping per run, which the block removes (measured in
  benchmarks/README.md).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba.cpython.unsafe.numbers import trailing_zeros

from sphkit.core.pairs import unsigned_range

#: candidates a cell's block holds (a cell with more takes the per-point scan)
BLOCK = 2048
#: where the block's padding lies: a coordinate no point is near, in m
_FAR = 1e18


@numba.njit(cache=True, inline="always")
def _u(x, i, k, dim, inv_a):
    """Coordinate along internal axis k (0, 1, 2; the data's axes are the last ``dim`` of them)
    in cell units."""
    d = k - (3 - dim)
    if d < 0:
        return 0.0
    return x[d, i] * inv_a


@numba.njit(cache=True, parallel=True)
def _dense_cells(x, dim, inv_a, lo, shape, cells):
    for i in numba.prange(x.shape[1]):
        c = np.int64(0)
        for k in range(3):
            c = c * shape[k] + (np.int64(np.floor(_u(x, i, k, dim, inv_a))) - lo[k])
        cells[i] = c


@numba.njit(cache=True, inline="always")
def _gap(u, cu, c):
    """Distance (cell units) from coordinate u, which lies in cell cu, to the cell c along one
    axis (0 inside)."""
    if c < cu:
        return u - (c + 1.0)
    if c > cu:
        return c - u
    return 0.0


@numba.njit(cache=True)
def _dilated_occupancy(cell_start, shape, reach):
    """Per cell of a dense grid (row-major, ``shape`` (3,)): 1 where a point lies in the block
    of cells within ``reach`` along every axis (the cells a query from there scans), else 0."""
    n0, n1, n2 = shape[0], shape[1], shape[2]
    a = np.empty(n0 * n1 * n2, dtype=np.uint8)
    for c in range(a.shape[0]):
        a[c] = cell_start[c + 1] > cell_start[c]
    b = np.empty_like(a)
    strides = (n1 * n2, n2, 1)
    for axis in range(3):  # separable: a maximum over the reach along one axis at a time
        st, n = strides[axis], shape[axis]
        for c in range(a.shape[0]):
            p = (c // st) % n
            m = 0
            for q in range(max(p - reach, 0), min(p + reach, n - 1) + 1):
                m = max(m, a[c + (q - p) * st])
            b[c] = m
        a, b = b, a
    return a


@numba.njit(cache=True, inline="always")
def _dense_scan(i, xq, dim, h2, inv_a, sub, lo, shape, cell_start, sorted_index, sorted_x,
                exclude_self, out, pos, cap, near):
    """Like :func:`_scan` on a dense grid of cells ``h / sub`` wide: for every row of cells
    along the last axis within reach, only the cells that the ball of radius h around the
    query point touches are visited, and they are one contiguous run of the sorted points.

    Two stages: the distance test over the runs appends sorted slots branch-free (it reads
    only the sorted coordinates), then the hits' slots are mapped to point indices and the
    query point itself is dropped (about 10 % faster than reading the index of every
    candidate)."""
    u0 = _u(xq, i, 0, dim, inv_a) - lo[0]
    u1 = _u(xq, i, 1, dim, inv_a) - lo[1]
    u2 = _u(xq, i, 2, dim, inv_a) - lo[2]
    qx = xq[0, i]
    qy = xq[1, i] if dim >= 2 else 0.0
    qz = xq[2, i] if dim >= 3 else 0.0
    c0 = np.int64(np.floor(u0))
    c1 = np.int64(np.floor(u1))
    c2 = np.int64(np.floor(u2))
    if (near.shape[0] > 0 and 0 <= c0 < shape[0] and 0 <= c1 < shape[1] and 0 <= c2 < shape[2]
            and near[(c0 * shape[1] + c1) * shape[2] + c2] == 0):
        return 0  # no point in any cell within reach (Grid.mark_near)
    reach2 = sub * sub * (1.0 + 1e-9)  # slack: rounding never drops a cell
    count = 0
    last = cap - 1
    for a0 in range(max(c0 - sub, 0), min(c0 + sub, shape[0] - 1) + 1):
        e0 = _gap(u0, c0, a0)
        for a1 in range(max(c1 - sub, 0), min(c1 + sub, shape[1] - 1) + 1):
            e1 = _gap(u1, c1, a1)
            rem = reach2 - e0 * e0 - e1 * e1
            if rem <= 0.0:
                continue
            w = math.sqrt(rem)
            z0 = max(np.int64(np.floor(u2 - w)), 0)
            z1 = min(np.int64(np.floor(u2 + w)), shape[2] - 1)
            if z0 > z1:
                continue
            base = (a0 * shape[1] + a1) * shape[2]
            for s in unsigned_range(cell_start[base + z0], cell_start[base + z1 + 1]):
                tx = qx - sorted_x[0, s]
                ty = qy - sorted_x[1, s]
                tz = qz - sorted_x[2, s]
                out[np.uint64(pos + min(count, last))] = s  # always written, kept on a hit
                count += np.int64(tx * tx + ty * ty + tz * tz < h2)
    if count >= cap:  # the row overflowed (its last slot was overwritten): redo, wider
        return count
    k = 0
    for t in unsigned_range(pos, pos + count):
        j = sorted_index[np.uint64(out[t])]
        out[np.uint64(pos + k)] = j
        k += np.int64((j != i) or not exclude_self)
    return k


@numba.njit(cache=True, parallel=True, fastmath=True)
def _dense_query(xq, dim, h, sub, lo, shape, cell_start, sorted_index, sorted_x, exclude_self,
                 cap, buf, counts, near):
    """:func:`_query` on the dense grid."""
    n = xq.shape[1]
    inv_a = sub / h
    h2 = h * h
    for i in numba.prange(n):
        counts[i] = _dense_scan(i, xq, dim, h2, inv_a, sub, lo, shape, cell_start, sorted_index,
                                sorted_x, exclude_self, buf, i * cap, cap, near)


@numba.njit(cache=True, parallel=True, fastmath=True)
def _dense_cell_query(xq, h, sub, lo, shape, cell_start, sorted_index, sorted_x, near, qlo,
                      qshape, qcell_start, qsorted_index, qsorted_x, own, cap, buf, counts,
                      parts):
    """The lists of the query points xq (dim, M) in this grid (``lo`` ... ``near``), cell by cell
    of the queries' own dense grid (``qlo`` ... ``qsorted_x``, the same cell size: the cells
    of both lie on one lattice), into the fixed-stride rows of :func:`_dense_query` (``buf``,
    ``counts``; a count reaching ``cap`` asks the caller to repeat with a larger ``cap``).
    ``own``: the query grid is this grid (the point itself is dropped from its list). A query
    cell whose cells within reach hold no point (``near``, :meth:`Grid.mark_near`; or beyond
    the grid) has empty lists. The query cells are split into ``parts`` contiguous ranges of
    about the same number of points, one task each (module docstring)."""
    n0, n1, n2 = shape[0], shape[1], shape[2]
    m1, m2 = qshape[1], qshape[2]
    ncell = qshape[0] * m1 * m2
    n = qsorted_index.shape[0]
    h2 = h * h
    inv_a = sub / h
    last = cap - 1
    for c in numba.prange(parts):
        bx = np.empty(BLOCK + 64, dtype=sorted_x.dtype)
        by = np.empty(BLOCK + 64, dtype=sorted_x.dtype)
        bz = np.empty(BLOCK + 64, dtype=sorted_x.dtype)
        bs = np.empty(BLOCK + 64, dtype=np.uint32)
        # the query cells whose first slot lies in this task's share of the points
        first = np.searchsorted(qcell_start[:ncell], c * n // parts)
        end = ncell if c == parts - 1 else np.searchsorted(qcell_start[:ncell],
                                                             (c + 1) * n // parts)
        for cell in range(first, end):
            s0, s1 = qcell_start[cell], qcell_start[cell + 1]
            if s0 == s1:
                continue
            # the cell in this grid's coordinates
            a0 = cell // (m1 * m2) + qlo[0] - lo[0]
            a1 = (cell // m2) % m1 + qlo[1] - lo[1]
            a2 = cell % m2 + qlo[2] - lo[2]
            inside = 0 <= a0 < n0 and 0 <= a1 < n1 and 0 <= a2 < n2
            if (not (-sub <= a0 < n0 + sub and -sub <= a1 < n1 + sub and -sub <= a2 < n2 + sub)
                    or (inside and near.shape[0] > 0 and near[(a0 * n1 + a1) * n2 + a2] == 0)):
                for q in range(s0, s1):
                    counts[qsorted_index[q]] = 0
                continue
            z0, z1 = max(a2 - sub, 0), min(a2 + sub, n2 - 1)
            k = 0  # the block: the runs of the cells within reach, in the per-point scan's order
            for b0 in range(max(a0 - sub, 0), min(a0 + sub, n0 - 1) + 1):
                for b1 in range(max(a1 - sub, 0), min(a1 + sub, n1 - 1) + 1):
                    base = (b0 * n1 + b1) * n2
                    r0, r1 = cell_start[base + z0], cell_start[base + z1 + 1]
                    if k + (r1 - r0) > BLOCK:
                        k = BLOCK + 1
                        break
                    for s in unsigned_range(r0, r1):
                        bx[k] = sorted_x[0, s]
                        by[k] = sorted_x[1, s]
                        bz[k] = sorted_x[2, s]
                        bs[k] = s
                        k += 1
                if k > BLOCK:
                    break
            if k > BLOCK:  # a crowded neighbourhood: the per-point scan
                for q in range(s0, s1):
                    i = qsorted_index[q]
                    counts[i] = _dense_scan(i, xq, xq.shape[0], h2, inv_a, sub, lo, shape,
                                            cell_start, sorted_index, sorted_x, own, buf,
                                            i * cap, cap, near)
                continue
            words = (k + 63) // 64
            for t in range(k, words * 64):  # padding far from every point
                bx[t] = by[t] = bz[t] = _FAR
            for q in range(s0, s1):
                qx, qy, qz = qsorted_x[0, q], qsorted_x[1, q], qsorted_x[2, q]
                i = qsorted_index[q]
                pos = np.uint64(i) * np.uint64(cap)
                count = 0
                for wi in unsigned_range(0, words):
                    w = wi * np.uint64(64)
                    mask = np.uint64(0)
                    for t in unsigned_range(0, 64):
                        tx = qx - bx[w + t]
                        ty = qy - by[w + t]
                        tz = qz - bz[w + t]
                        mask |= np.uint64(tx * tx + ty * ty + tz * tz < h2) << t
                    while mask != 0:
                        s = bs[w + trailing_zeros(mask)]
                        buf[pos + np.uint64(min(count, last))] = sorted_index[s]
                        count += np.int64((s != q) or not own)  # own: the point is dropped
                        mask &= mask - np.uint64(1)
                counts[i] = count
