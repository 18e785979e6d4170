"""Neighbourhood search: uniform grid, counting sort by cell, CSR neighbour lists.

The grid has cell size equal to the kernel support radius ``h``, so all neighbours of a particle
lie in the 3^d cells around it (survey Sec. 3; Ihmsen et al. 2011, "A parallel SPH implementation
on multi-core CPUs"). Two layouts give the same lists:

* **dense** (the default whenever the point set's bounding box holds at most 32 cells per point,
  which is the case for a fluid in a tank and for static boundaries): every cell of the box has
  a slot, particles are counting-sorted by the row-major cell index, so a row of cells along the
  last axis is one contiguous run of the sorted points. A query visits, for each of the 3^(d-1)
  rows around it, only the run of cells that the ball of radius h touches (fewer candidates and
  no hashing; a fluid-fluid query of the DFSPH benchmark scene took 3.5 instead of 4.8 ms, a
  fluid-boundary query 0.7 instead of 2.1 ms). A set queried against itself (the fluid's lists,
  :meth:`Grid.query_own`), and the fluid against the walls (:meth:`Grid.query_grid`), are
  searched cell by cell of the fluid's grid, the points of a cell testing their common
  candidates 64 at a time (:mod:`sphkit.core.densegrid`).
* **hashed** (sparse sets, e.g. splashes far from the bulk): every particle's integer cell
  coordinates are packed into a 63-bit key and hashed into a table of ``2^k >= 2N`` buckets; a
  counting sort over buckets groups the particles (Hoetzlein 2014, as in cuNSearch). A query
  visits the buckets of the 3^d neighbour cells and accepts a particle only if its packed key
  equals the visited cell's key, so hash collisions cost a comparison and never a duplicate.
  Memory is O(N) whatever the extent of the domain (up to 2^21 cells per axis).

Neighbour lists are compressed sparse rows: the neighbours of query point ``i`` are
``indices[offsets[i]:offsets[i + 1]]`` (indices into the searched set, self excluded when a set is
queried against itself). The scan writes into rows of a fixed capacity (grown and redone on
overflow) in parallel over query points, then the rows are compacted.

:class:`sphkit.core.hashgrid.HashGrid` builds and queries the hashed layout with per-particle
kernel bodies, so the same search runs on the GPU; the scan of one query point is :func:`_scan`.

Verlet lists reused across steps (``configuration.neighbor_skin``): :mod:`sphkit.core.verlet`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numba
import numpy as np

from sphkit.core.densegrid import (
    _dense_cell_query,
    _dense_cells,
    _dense_query,
    _dilated_occupancy,
)
from sphkit.core.pairs import pair_slots, unsigned_range

if TYPE_CHECKING:
    from sphkit.core.arrays import Scratch

#: neighbour (and sorted point) indices: unsigned, which Numba indexes with without its
#: negative-index fix-up (:func:`sphkit.core.pairs.unsigned_range`); 32 bits, half of 64
INDEX = np.uint32
_START = np.int32  # first sorted slot of every cell (dense) or bucket (hashed)
_BITS = 21
_LIMIT = (1 << _BITS) - 2  # largest relative cell coordinate (one cell kept free on each side)

#: the periodic axes of a search (:meth:`Grid.query`): None, ``(lo, L)`` of x, or ``(lo, L)``
#: per axis from x on
Period = tuple[float, float] | tuple[tuple[float, float], ...] | None


@numba.njit(cache=True, inline="always")
def _pack(ix, iy, iz):
    return (ix << 42) | (iy << 21) | iz


@numba.njit(cache=True, inline="always")
def _bucket(ix, iy, iz, mask):
    return ((ix * 73856093) ^ (iy * 19349663) ^ (iz * 83492791)) & mask


@numba.njit(cache=True, inline="always")
def _cell(x, i, d, dim, inv_h, origin):
    if d >= dim:
        return 1
    return np.int64(math.floor(x[d, i] * inv_h)) - origin[d] + 1


@numba.njit(cache=True, parallel=True)
def _cells(x, dim, inv_h, origin, mask, keys, buckets):
    n = x.shape[1]
    for i in numba.prange(n):
        ix = _cell(x, i, 0, dim, inv_h, origin)
        iy = _cell(x, i, 1, dim, inv_h, origin)
        iz = _cell(x, i, 2, dim, inv_h, origin)
        keys[i] = _pack(ix, iy, iz)
        buckets[i] = _bucket(ix, iy, iz, mask)


@numba.njit(cache=True)
def _dense_box(x, inv_a):
    """The box of cells of size ``1 / inv_a`` around the points x (dim, N), in one pass over
    them: ``(finite, count, lo, shape, cells)``, whether every coordinate is finite, the box's
    number of cells in floating point (``prod(floor(max inv_a) - floor(min inv_a) + 1)``, before
    any conversion to integers: far-flung points would overflow them), its first cell and
    cells per axis ((3,) int64, the data's axes last, 0 and 1 before them) and their product,
    the last three meaningful only where ``count`` is within the int64 range. The floors are
    those of :func:`sphkit.core.densegrid._dense_cells` (``x * inv_a`` in float64)."""
    dim, n = x.shape
    lo = np.zeros(3, dtype=np.int64)
    shape = np.ones(3, dtype=np.int64)
    finite = True
    count = 1.0
    cells = 1
    for d in range(dim):
        a = np.inf
        b = -np.inf
        bad = False
        for i in range(n):
            v = x[d, i] * 1.0
            bad = bad | (v - v != 0.0)  # inf and NaN
            if v < a:
                a = v
            if v > b:
                b = v
        finite = finite and not bad
        if n == 0 or bad:
            continue
        flo = np.floor(a * inv_a)
        fhi = np.floor(b * inv_a)
        count *= fhi - flo + 1.0
        if count < 2.0**62:
            k = d + 3 - dim
            lo[k] = np.int64(flo)
            shape[k] = np.int64(fhi) - lo[k] + 1
            cells *= shape[k]
    return finite, count, lo, shape, cells


@numba.njit(cache=True)
def _counting_sort(buckets, keys, x, table_size, bucket_start, sorted_index, sorted_key, sorted_x):
    n = buckets.shape[0]
    for b in range(table_size + 1):
        bucket_start[b] = 0
    for i in range(n):
        bucket_start[buckets[i] + 1] += 1
    for b in range(table_size):
        bucket_start[b + 1] += bucket_start[b]
    fill = bucket_start[:table_size].copy()
    dim = x.shape[0]
    with_keys = sorted_key.shape[0] > 0  # the dense grid needs no keys
    for i in range(n):
        b = buckets[i]
        s = fill[b]
        fill[b] = s + 1
        sorted_index[s] = i
        if with_keys:
            sorted_key[s] = keys[i]
        for d in range(3):
            sorted_x[d, s] = x[d, i] if d < dim else 0.0


@numba.njit(cache=True, inline="always")
def _scan(i, xq, dim, h2, inv_h, origin, mask, bucket_start, sorted_index, sorted_key, sorted_x,
          exclude_self, out, pos, cap):
    """Write up to ``cap - 1`` neighbours of query point i to ``out[pos:]``; returns their count.

    The append is branch-free (every candidate is written to the next free slot, which only a
    hit keeps), which saved a quarter of the search time over the accept branch, whose outcome
    (about 1 in 6 candidates) the processor cannot predict. Counts of ``cap`` or more mean the
    row overflowed."""
    cx = _cell(xq, i, 0, dim, inv_h, origin)
    cy = _cell(xq, i, 1, dim, inv_h, origin)
    cz = _cell(xq, i, 2, dim, inv_h, origin)
    ry = 1 if dim >= 2 else 0
    rz = 1 if dim >= 3 else 0
    qx = xq[0, i]
    qy = xq[1, i] if dim >= 2 else 0.0
    qz = xq[2, i] if dim >= 3 else 0.0
    # distance from the query point to the lower / upper face of its cell, per axis: a
    # neighbour cell whose nearest point is h or farther away is skipped (about a quarter of
    # the 27 cells in 3D)
    fx = qx * inv_h - math.floor(qx * inv_h)
    fy = qy * inv_h - math.floor(qy * inv_h)
    fz = qz * inv_h - math.floor(qz * inv_h)
    count = 0
    last = cap - 1
    notself = not exclude_self
    for dx in range(-1, 2):
        ix = cx + dx
        if ix < 0 or ix > _LIMIT + 1:
            continue
        ex = 0.0 if dx == 0 else (fx if dx < 0 else 1.0 - fx)
        for dy in range(-ry, ry + 1):
            iy = cy + dy
            if iy < 0 or iy > _LIMIT + 1:
                continue
            ey = 0.0 if dy == 0 else (fy if dy < 0 else 1.0 - fy)
            for dz in range(-rz, rz + 1):
                iz = cz + dz
                if iz < 0 or iz > _LIMIT + 1:
                    continue
                ez = 0.0 if dz == 0 else (fz if dz < 0 else 1.0 - fz)
                if ex * ex + ey * ey + ez * ez >= 1.0:
                    continue
                key = _pack(ix, iy, iz)
                b = _bucket(ix, iy, iz, mask)
                for s in unsigned_range(bucket_start[b], bucket_start[b + 1]):
                    if sorted_key[s] != key:  # another cell hashed to this bucket
                        continue
                    j = sorted_index[s]
                    tx = qx - sorted_x[0, s]
                    ty = qy - sorted_x[1, s]
                    tz = qz - sorted_x[2, s]
                    # branch-free append: always write, advance only on a hit
                    out[np.uint64(pos + min(count, last))] = j
                    count += (tx * tx + ty * ty + tz * tz < h2) & ((j != i) | notself)
    return count


@numba.njit(cache=True)
def _row_offsets(counts, cap):
    """CSR offsets of rows of ``counts`` entries (at most ``cap``) and the largest count."""
    n = counts.shape[0]
    offsets = np.zeros(n + 1, dtype=np.int64)
    largest = 0
    for i in range(n):
        offsets[i + 1] = offsets[i] + min(counts[i], cap)
        largest = max(largest, counts[i])
    return offsets, largest


@numba.njit(cache=True, parallel=True)
def _compact(buf, offsets, cap, indices):
    """The CSR ``indices`` of rows of ``cap`` slots (``buf``) at the rows' ``offsets``."""
    for i in numba.prange(offsets.shape[0] - 1):
        o, b = np.uint64(offsets[i]), np.uint64(i * cap)
        for k in unsigned_range(0, offsets[i + 1] - offsets[i]):
            indices[o + k] = buf[b + k]


@numba.njit(cache=True, parallel=True, fastmath=True)
def _query(xq, dim, h, origin, mask, bucket_start, sorted_index, sorted_key, sorted_x,
           exclude_self, cap, buf, counts):
    """One pass into fixed-stride rows of ``cap`` slots, ``buf`` (N cap,) with the row lengths
    in ``counts`` (N,) (compacted into CSR by :func:`_compact`). When a count reaches ``cap``
    that row may be incomplete (the branch-free append of :func:`_scan` reuses the last slot)
    and the caller repeats with a larger ``cap``.
    """
    n = xq.shape[1]
    inv_h = 1.0 / h
    h2 = h * h
    for i in numba.prange(n):
        counts[i] = _scan(i, xq, dim, h2, inv_h, origin, mask, bucket_start, sorted_index,
                          sorted_key, sorted_x, exclude_self, buf, i * cap, cap)


@dataclass
class NeighborList:
    """CSR neighbour lists: neighbours of point i are ``indices[offsets[i]:offsets[i+1]]``."""

    offsets: np.ndarray
    indices: np.ndarray

    def __len__(self) -> int:
        return self.offsets.shape[0] - 1

    def neighbors(self, i: int) -> np.ndarray:
        """Indices of the neighbours of point ``i`` (a view)."""
        return self.indices[self.offsets[i]:self.offsets[i + 1]]

    def counts(self) -> np.ndarray:
        """Number of neighbours of every point."""
        return np.diff(self.offsets)

    def rows(self, index: np.ndarray) -> NeighborList:
        """The lists of the points ``index`` only (row k = point ``index[k]``; the neighbour
        indices unchanged)."""
        counts = np.diff(self.offsets)[index]
        off = np.zeros(index.shape[0] + 1, dtype=self.offsets.dtype)
        np.cumsum(counts, out=off[1:])
        pos = np.repeat(self.offsets[index] - off[:-1], counts) + np.arange(int(off[-1]))
        return NeighborList(off, self.indices[pos])

    @staticmethod
    def empty(n: int) -> NeighborList:
        """Lists with no neighbours for ``n`` points."""
        return NeighborList(np.zeros(n + 1, np.int64), np.zeros(0, INDEX))


class Grid:
    """A uniform grid over a point set (positions of shape (dim, N)), for radius-``h`` queries.

    Dense when the point set's bounding box holds at most :attr:`dense_cells_per_point` cells
    of size ``h / SUB`` per point (every cell stored; rows of cells along the last axis are
    contiguous runs of the sorted points, so a query visits one run per row of the ball's
    shadow, :mod:`sphkit.core.densegrid`); hashed otherwise (sparse scenes, e.g. a few
    splashes far from the bulk; :func:`_scan`). Both give the same lists.
    """

    #: cells per h along an axis of the dense grid. Finer cells cover the ball more tightly
    #: but cost more rows: on the DFSPH benchmark scene (27 neighbours, 120 candidates per
    #: particle with cells of size h) a fluid-fluid query took 3.6 / 4.6 / 6.5 ms with 1 / 2 / 3
    #: cells per h, against 4.8 ms for the hashed grid (one thread).
    SUB: int = 1
    #: largest ratio of dense cells to points before the grid is hashed instead (small sets
    #: may always have :attr:`dense_min_cells`)
    dense_cells_per_point: int = 32
    dense_min_cells: int = 1 << 16

    def __init__(self, x: np.ndarray, h: float) -> None:
        if x.ndim != 2 or x.shape[0] not in (1, 2, 3):
            raise ValueError(f"positions: shape {x.shape} is not (dim, N) with dim in 1, 2, 3")
        if not h > 0:
            raise ValueError(f"h: {h!r} is not a cell size; expected a positive number")
        self.dim = x.shape[0]
        self.h = float(h)
        n = x.shape[1]
        self.n = n
        xc = np.ascontiguousarray(x)
        finite, count, lo, shape, cells = _dense_box(xc, self.SUB / self.h)
        if not finite:
            raise ValueError("positions: contain NaN or inf; cannot build a neighbour grid")
        self.sorted_index = np.empty(n, dtype=INDEX)
        #: the packed cell key of each sorted point (hashed grid only: the dense grid has none)
        self.sorted_key = np.empty(0, dtype=np.int64)
        self.sorted_x = np.empty((3, n), dtype=x.dtype)  # zero-padded to 3 rows
        #: per dense cell, whether a point lies within reach (:meth:`mark_near`; empty: not kept)
        self.near = np.zeros(0, dtype=np.uint8)
        # the cell count in floating point first: far-flung points (or coordinates beyond the
        # int64 range) go to the hashed grid, which names the extent it cannot hold
        self.dense = n > 0 and count <= max(self.dense_cells_per_point * n,
                                            self.dense_min_cells)
        if self.dense:
            self._build_dense(xc, lo, shape, cells)
        else:
            self.sorted_key = np.empty(n, dtype=np.int64)
            self._build_hashed(xc)

    def _build_dense(self, xc: np.ndarray, lo: np.ndarray, shape: np.ndarray,
                     cells: int) -> None:
        """Set up the dense grid of :func:`_dense_box`'s box (first cell ``lo``, ``shape``
        cells per axis, ``cells`` in all)."""
        n, dim = self.n, self.dim
        self.lo, self.shape = lo, shape
        cell = np.empty(n, dtype=np.int64)
        _dense_cells(xc, dim, self.SUB / self.h, lo, shape, cell)
        self.cell_start = np.empty(cells + 1, dtype=_START)
        _counting_sort(cell, cell, xc, cells, self.cell_start, self.sorted_index,
                       self.sorted_key, self.sorted_x)

    def mark_near(self) -> Grid:
        """Keep, per cell of a dense grid, whether any point lies in the cells a query from
        there scans, so that queries far from every point return at once; for a grid queried
        at every step (static walls: most fluid particles are far from them). Returns self."""
        if self.dense:
            self.near = _dilated_occupancy(self.cell_start, self.shape, self.SUB)
        return self

    def _build_hashed(self, xc: np.ndarray) -> None:
        n, h = self.n, self.h
        origin = np.zeros(3, dtype=np.int64)
        if n:
            flo = np.floor(xc.min(axis=1) / h)
            ext = np.floor(xc.max(axis=1) / h) - flo  # in floating point: no int64 overflow
            if np.any(ext > _LIMIT - 2):
                raise ValueError(
                    f"positions: extent of {float(ext.max()):.4g} cells of size {h} exceeds the "
                    f"grid's limit of {_LIMIT - 2} cells per axis"
                )
            origin[: self.dim] = flo.astype(np.int64)
        self.origin = origin
        size = 1
        while size < 2 * max(n, 1):
            size *= 2
        self.table_size = size
        self.mask = size - 1
        keys = np.empty(n, dtype=np.int64)
        buckets = np.empty(n, dtype=np.int64)
        _cells(xc, self.dim, 1.0 / h, origin, self.mask, keys, buckets)
        self.bucket_start = np.empty(size + 1, dtype=_START)
        _counting_sort(buckets, keys, xc, size, self.bucket_start, self.sorted_index,
                       self.sorted_key, self.sorted_x)

    def query(self, xq: np.ndarray, exclude_self: bool = False,
              period: Period = None, scratch: Scratch | None = None,
              slot: str | None = None) -> NeighborList:
        """Neighbours (distance < h) in this grid's set of every column of ``xq`` (dim, M).

        ``exclude_self`` drops ``j == i``; use it when ``xq`` is the set the grid was built on.
        ``period = (lo, L)``: the domain is periodic along x with period L > 2h, all points
        (grid and queries) lying in ``[lo, lo + L)``; ``period = ((lo_x, L_x), (lo_y, L_y))``:
        periodic along x and y the same way (L = 0: that axis is not). Neighbours are found by
        the minimum-image distance (see :func:`_periodic_query`). ``scratch``: the block the
        one-pass search writes its fixed-stride rows into (:class:`sphkit.core.arrays.Scratch`,
        invalidating what was taken from it before; None, and periodic queries: fresh arrays);
        the lists returned are arrays of their own, or with ``slot`` their indices lie in the
        scratch's memory kept for that slot, valid until its next query
        (:meth:`sphkit.core.arrays.Scratch.kept`).
        """
        if xq.shape[0] != self.dim:
            raise ValueError(f"query positions: dim {xq.shape[0]} != grid dim {self.dim}")
        m = xq.shape[1]
        if m == 0 or self.n == 0:
            return NeighborList.empty(m)
        xq = np.ascontiguousarray(xq, dtype=self.sorted_x.dtype)
        axes = periodic_axes(period)
        if axes:
            return _periodic_query(self, xq, exclude_self, axes)
        if self.dense:
            def fill(cap: int, rows: np.ndarray, counts: np.ndarray) -> None:
                _dense_query(xq, self.dim, self.h, self.SUB, self.lo, self.shape, self.cell_start,
                             self.sorted_index, self.sorted_x, exclude_self, cap, rows, counts,
                             self.near)
        else:
            def fill(cap: int, rows: np.ndarray, counts: np.ndarray) -> None:
                _query(xq, self.dim, self.h, self.origin, self.mask, self.bucket_start,
                       self.sorted_index, self.sorted_key, self.sorted_x, exclude_self, cap,
                       rows, counts)
        return self._lists(m, scratch, fill, slot)

    def query_own(self, x: np.ndarray, period: Period = None,
                  scratch: Scratch | None = None, slot: str | None = None) -> NeighborList:
        """:meth:`query` of the point set x (dim, N) the grid was built on, self excluded: the
        same lists, on a dense grid without period found cell by cell
        (:func:`sphkit.core.densegrid._dense_cell_query`, about twice as fast)."""
        return self.query_grid(self, x, period, scratch, slot)

    def query_grid(self, queries: Grid, xq: np.ndarray, period: Period = None,
                   scratch: Scratch | None = None, slot: str | None = None) -> NeighborList:
        """:meth:`query` of the points xq (dim, M) that the grid ``queries`` was built on (self
        excluded where ``queries`` is this grid): the same lists, found cell by cell of
        ``queries`` (:func:`sphkit.core.densegrid._dense_cell_query`) where both grids are
        dense with the same cell size and there is no period; else by :meth:`query`."""
        if xq.shape != (queries.dim, queries.n) or queries.dim != self.dim:
            raise ValueError(f"query positions: shape {xq.shape}; the query grid holds "
                             f"{(queries.dim, queries.n)} in {self.dim} dimensions")
        own = queries is self
        if (not (self.dense and queries.dense) or self.n == 0 or queries.n == 0
                or queries.h != self.h or periodic_axes(period)):
            return self.query(xq, exclude_self=own, period=period, scratch=scratch, slot=slot)
        xq = np.ascontiguousarray(xq, dtype=self.sorted_x.dtype)

        def fill(cap: int, rows: np.ndarray, counts: np.ndarray) -> None:
            _dense_cell_query(xq, self.h, self.SUB, self.lo, self.shape, self.cell_start,
                              self.sorted_index, self.sorted_x, self.near, queries.lo,
                              queries.shape, queries.cell_start, queries.sorted_index,
                              queries.sorted_x, own, cap, rows, counts,
                              min(queries.n, 16 * numba.config.NUMBA_NUM_THREADS))
        return self._lists(queries.n, scratch, fill, slot)

    def _lists(self, m: int, scratch: Scratch | None, fill: Callable, slot: str | None
               ) -> NeighborList:
        """CSR lists of m query points from ``fill(cap, rows, counts)``, which writes them into
        rows of ``cap`` slots (repeated with a larger ``cap`` when a row overflows); their
        indices in ``scratch``'s memory kept for ``slot`` (:meth:`sphkit.core.arrays.Scratch.
        kept`) where both are given, else in an array of their own. The row width a slot's
        search grew to is kept there too (:attr:`sphkit.core.arrays.Scratch.widths`): a scene
        with more neighbours than :attr:`capacity` (a compressed start, dense wall samples)
        searches once a step, not twice."""
        remember = scratch is not None and slot is not None
        cap = max(self.capacity, scratch.widths.get(slot, 0)) if remember else self.capacity
        while True:
            if scratch is None:
                rows, counts = np.empty(m * cap, dtype=INDEX), np.empty(m, dtype=np.int64)
            else:
                rows, counts = scratch.take(((m * cap,), INDEX), ((m,), np.int64))
            fill(cap, rows, counts)
            offsets, largest = _row_offsets(counts, cap)
            if largest < cap:
                size = int(offsets[m])
                indices = (np.empty(size, dtype=INDEX) if scratch is None or slot is None
                           else scratch.kept(slot, size, INDEX))
                _compact(rows, offsets, cap, indices)
                return NeighborList(offsets, indices)
            cap = int(largest) + 8  # rare: a denser neighbourhood than ever seen; redo
            if remember:
                scratch.widths[slot] = cap

    #: slots per query point of the one-pass search (grown on demand, see :meth:`query`)
    capacity: int = 64


def neighbor_lists(x: np.ndarray, h: float, period: Period = None,
                   scratch: Scratch | None = None) -> NeighborList:
    """Neighbour lists of a point set (dim, N) with itself, self excluded (``period``,
    ``scratch``: see :meth:`Grid.query`)."""
    return Grid(x, h).query_own(x, period=period, scratch=scratch)


@numba.njit(cache=True, inline="always")
def csr_offsets(counts):
    """The CSR row offsets (N + 1,) int64 of the row lengths ``counts`` (N,): a prefix sum."""
    n = counts.shape[0]
    offsets = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        offsets[i + 1] = offsets[i] + counts[i]
    return offsets


@numba.njit(cache=True, parallel=True)
def _merge_rows(off_a, idx_a, off_b, idx_b, row_b):
    """CSR lists whose row i is row i of (off_a, idx_a) followed by row row_b[i] of
    (off_b, idx_b) when row_b[i] >= 0."""
    n = off_a.shape[0] - 1
    counts = np.empty(n, dtype=np.int64)
    for i in numba.prange(n):
        c = off_a[i + 1] - off_a[i]
        k = row_b[i]
        if k >= 0:
            c += off_b[k + 1] - off_b[k]
        counts[i] = c
    offsets = csr_offsets(counts)
    indices = np.empty(offsets[n], dtype=INDEX)
    for i in numba.prange(n):
        o = offsets[i]
        for t in pair_slots(off_a, i):
            indices[o] = idx_a[t]
            o += 1
        k = row_b[i]
        if k >= 0:
            for t in pair_slots(off_b, k):
                indices[o] = idx_b[t]
                o += 1
    return offsets, indices


def periodic_axes(period: Period) -> list[tuple[int, float, float]]:
    """``(axis, lo, L)`` of each periodic axis of a search's ``period`` (:meth:`Grid.query`)."""
    if period is None:
        return []
    pairs = period if isinstance(period[0], tuple) else (period,)
    return [(a, float(lo), float(L)) for a, (lo, L) in enumerate(pairs) if L > 0.0]


def pair_period(period: Period) -> float | tuple[float, float]:
    """The pair loops' period argument (:func:`sphkit.core.pairs.axis_period`) of a search's
    ``period``: the float L_x when at most x is periodic, else ``(L_x, L_y)``."""
    if period is None:
        return 0.0
    if isinstance(period[0], tuple):
        return tuple(float(L) for _lo, L in period)
    return float(period[1])


def _periodic_query(grid: Grid, xq: np.ndarray, exclude_self: bool,
                    axes: list[tuple[int, float, float]]) -> NeighborList:
    """Neighbour lists of ``xq`` in ``grid`` with periods L along the ``(axis, lo, L)`` of
    ``axes`` (all points in [lo, lo+L) along each).

    The query cells wrap around: a query point closer than h to the lower end of a period also
    scans the cells around its image ``x + L``, one closer than h to the upper end those around
    ``x - L``; near a corner of two periodic axes, also the image shifted along both. The hits
    of these scans are appended to its row (x, then y, then both). With ``L > 2h`` a point sees
    each neighbour through exactly one image (the minimum image, whose distance the pair loops
    then use), so no pair is listed twice. Away from the seams the search is the plain one.
    """
    h = grid.h
    shifts = []
    for a, lo, L in axes:
        if not L > 2.0 * h:
            raise ValueError(f"period: {L!r} m along {'xyz'[a]}; expected more than 2h = "
                             f"{2.0 * h!r} m")
        xa = xq[a]
        shifts.append((a, np.where(xa < lo + h, L, np.where(xa >= lo + L - h, -L, 0.0))))
    images = [[s] for s in shifts]
    if len(shifts) == 2:  # the corners: shifted along both axes
        images.append(shifts)
    out = grid.query(xq, exclude_self)
    for image in images:
        moved = np.ones(xq.shape[1], dtype=bool)
        for _a, s in image:
            moved &= s != 0.0
        sel = np.flatnonzero(moved)
        if sel.size == 0:
            continue
        xs = np.ascontiguousarray(xq[:, sel])
        for a, s in image:
            xs[a] += s[sel]
        # the image of a point is never its own neighbour (L > 2h): no self exclusion needed
        seam = grid.query(xs, False)
        row_b = np.full(xq.shape[1], -1, dtype=np.int64)
        row_b[sel] = np.arange(sel.size)
        off, idx = _merge_rows(out.offsets, out.indices, seam.offsets, seam.indices, row_b)
        out = NeighborList(off, idx)
    return out
