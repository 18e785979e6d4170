"""The hashed neighbour grid as kernel bodies, for the CPU or the GPU.

:class:`HashGrid` builds and queries the hashed layout of :class:`sphkit.core.neighbors.Grid`
with per-particle kernel bodies (:mod:`sphkit.backend.launch`), so the same search runs on the
GPU with its arrays resident there (DESIGN.md, "Compute backend"). The scan of one query point is
the CPU grid's :func:`sphkit.core.neighbors._scan`, and the cell keys and buckets are its
:func:`~sphkit.core.neighbors._cell`, :func:`~sphkit.core.neighbors._pack` and
:func:`~sphkit.core.neighbors._bucket`: one source for both devices.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sphkit.backend import (
    empty,
    exclusive_scan,
    histogram,
    launch,
    launch_reduce,
    to_device,
    to_host,
)
from sphkit.core.neighbors import _BITS, INDEX, NeighborList, _bucket, _cell, _pack, _scan
from sphkit.core.zorder import _spread


@numba.njit(cache=True, inline="always")
def cell_key_body(i, x, dim, inv_h, origin, mask, keys, buckets):
    """Packed cell key and hash bucket of point i (the pass :func:`_cells` makes on the CPU)."""
    ix = _cell(x, i, 0, dim, inv_h, origin)
    iy = _cell(x, i, 1, dim, inv_h, origin)
    iz = _cell(x, i, 2, dim, inv_h, origin)
    keys[i] = _pack(ix, iy, iz)
    buckets[i] = _bucket(ix, iy, iz, mask)


@numba.njit(cache=True, inline="always")
def place_body(i, buckets, keys, x, dim, bucket_start, rank, sorted_index, sorted_key, sorted_x):
    """Point i to its sorted slot ``bucket_start[b] + rank[i]`` (slots are distinct: the body
    writes entries that no other point writes)."""
    s = bucket_start[buckets[i]] + rank[i]
    sorted_index[s] = i
    sorted_key[s] = keys[i]
    for d in range(3):
        sorted_x[d, s] = x[d, i] if d < dim else 0.0


@numba.njit(cache=True, inline="always", fastmath=True)
def rows_body(i, xq, dim, h2, inv_h, origin, mask, bucket_start, sorted_index, sorted_key,
              sorted_x, exclude_self, rows, cap, counts):
    """The neighbours of query point i into its row ``rows[i cap:(i + 1) cap]`` and their count
    (:func:`_scan`; a count of ``cap`` or more means the row overflowed)."""
    counts[i] = _scan(i, xq, dim, h2, inv_h, origin, mask, bucket_start, sorted_index,
                      sorted_key, sorted_x, exclude_self, rows, i * cap, cap)


@numba.njit(cache=True, inline="always")
def count_body(i, counts):
    """``counts[i]`` as the value :func:`sphkit.backend.launch_reduce` maximizes."""
    return float(counts[i])


@numba.njit(cache=True, inline="always")
def compact_body(i, rows, cap, offsets, indices):
    """Row i of the fixed-stride rows into its CSR range ``offsets[i]:offsets[i + 1]``."""
    o = offsets[i]
    for k in range(offsets[i + 1] - o):
        indices[o + k] = rows[i * cap + k]


@numba.njit(cache=True, inline="always")
def extent_body(i, x, d, center):
    """``|x[d, i] - center|``, whose largest value is the points' half extent about ``center``
    along axis d."""
    return abs(x[d, i] - center)


@numba.njit(cache=True, inline="always")
def morton_key_body(i, x, dim, inv_c, origin, bits, keys):
    """The z-order key of point i: the Morton code of its cell of size ``1 / inv_c``, cell
    coordinates relative to ``origin`` (dim,) wrapped to ``bits`` bits each."""
    m = (np.int64(1) << bits) - 1
    code = np.int64(0)
    for d in range(dim):
        c = (np.int64(math.floor(x[d, i] * inv_c)) - origin[d]) & m
        code |= _spread(c, dim) << d
    keys[i] = code


@numba.njit(cache=True, inline="always")
def order_body(i, keys, start, rank, perm):
    """Point i to its place ``start[key_i] + rank_i`` of the z-order permutation."""
    perm[start[keys[i]] + rank[i]] = i


#: the most bits per axis of :func:`zorder_on_device`'s keys, in 1D, 2D and 3D (2^21 bins)
ZORDER_MAX_BITS = (21, 10, 7)


def zorder_on_device(x, h: float, center: np.ndarray, device: str = "cpu"):  # noqa: ANN201
    """A permutation (N,) int64, on ``device``, that orders the points ``x`` (dim, N) there along
    a z-order curve, without copying them to the host (where :func:`sphkit.core.zorder.
    zorder_permutation` sorts the Morton codes of the cells of size h): a counting sort
    (:func:`sphkit.backend.histogram`, :func:`sphkit.backend.exclusive_scan`) by the Morton code
    of cells of size ``h 2^s``, with ``b`` bits per axis (about as many bins as points, at most
    2^21) and s the least that makes the points' extent about ``center`` (dim,) (three
    reductions, three scalars read back) fit ``2^b`` cells. Within a cell the order is the
    index order on the CPU and that of the atomic increments on the GPU."""
    dim, n = x.shape
    perm = empty(n, np.int64, device)
    if n == 0:
        return perm
    ext = max(launch_reduce(extent_body, n, x, d, float(center[d]), device=device)[1]
              for d in range(dim))
    bits = min(ZORDER_MAX_BITS[dim - 1], max(1, math.ceil(math.log2(max(n, 2)) / dim)))
    s = 0
    while h * 2.0 ** (s + bits) < 2.0 * ext + 2.0 * h:
        s += 1
    cell = h * 2.0 ** s
    origin = np.floor((np.asarray(center[:dim], np.float64) - ext - h) / cell).astype(np.int64)
    keys, rank = empty(n, np.int64, device), empty(n, np.int64, device)
    size = 1 << (dim * bits)
    counts, start = empty(size, np.int64, device), empty(size + 1, np.int64, device)
    launch(morton_key_body, n, x, dim, 1.0 / cell, to_device(origin, device), bits, keys,
           device=device)
    histogram(keys, counts, rank, device=device)
    exclusive_scan(counts, start, device=device)
    launch(order_body, n, keys, start, rank, perm, device=device)
    return perm


def hash_origin(center: np.ndarray, h: float) -> np.ndarray:
    """The integer cell origin (3,) of a :class:`HashGrid` around ``center`` (dim,): cell
    coordinates stay in the packed keys' range for points within about 10^6 h of it."""
    origin = np.zeros(3, dtype=np.int64)
    c = np.asarray(center, dtype=np.float64)
    origin[: c.shape[0]] = np.floor(c / h).astype(np.int64) - (1 << (_BITS - 1))
    return origin


class HashGrid:
    """A hashed uniform grid of cell size ``h`` (:class:`Grid`'s hashed layout) whose build and
    queries are kernel bodies launched on ``device`` ("cpu" or "cuda"): positions, the sorted
    points and the lists stay where they are, and each build or query reads back only a total
    and a largest row length.

    Build: cell keys and buckets per point (:func:`cell_key_body`), a counting sort by bucket
    (:func:`sphkit.backend.histogram` and :func:`sphkit.backend.exclusive_scan`, then
    :func:`place_body`). Query: each point's neighbours into a row of ``capacity`` slots
    (:func:`rows_body`, :func:`_scan` as on the CPU), the rows compacted into CSR
    (:func:`compact_body`); a row that overflowed grows the capacity and the query is redone.

    ``origin`` (:func:`hash_origin`) fixes the cell coordinates instead of the points' bounding
    box, which would cost a reduction per build; points farther than about 10^6 h from it are
    not found. On the GPU the order of the points within a bucket, and so of the neighbours in
    a row, is that of the atomic increments: the lists are the same sets run to run, their
    order is not.
    """

    #: slots per query point of the one-pass search (grown on demand, see :meth:`query`)
    capacity: int = 64

    def __init__(self, dim: int, h: float, origin: np.ndarray, device: str = "cpu") -> None:
        if dim not in (1, 2, 3):
            raise ValueError(f"dim: {dim!r}; expected 1, 2 or 3")
        if not h > 0:
            raise ValueError(f"h: {h!r} is not a cell size; expected a positive number")
        self.dim, self.h, self.device = dim, float(h), device
        self.origin = np.ascontiguousarray(origin, dtype=np.int64)
        self._origin = to_device(self.origin, device)
        self._rows = None
        self.n = -1
        self.sorted_x = None

    def build(self, x) -> None:
        """Sort the points ``x`` (dim, N), an array on the grid's device, into the grid."""
        n = x.shape[1]
        dev = self.device
        if n != self.n or self.sorted_x.dtype != x.dtype:
            size = 1
            while size < 2 * max(n, 1):
                size *= 2
            self.n, self.table_size, self.mask = n, size, size - 1
            self.keys = empty(n, np.int64, dev)
            self.buckets = empty(n, np.int64, dev)
            self.rank = empty(n, np.int64, dev)
            self.counts = empty(size, np.int64, dev)
            self.bucket_start = empty(size + 1, np.int64, dev)
            self.sorted_index = empty(n, INDEX, dev)
            self.sorted_key = empty(n, np.int64, dev)
            self.sorted_x = empty((3, n), x.dtype, dev)  # the positions' precision (as Grid)
        launch(cell_key_body, n, x, self.dim, 1.0 / self.h, self._origin, self.mask, self.keys,
               self.buckets, device=dev)
        histogram(self.buckets, self.counts, self.rank, device=dev)
        exclusive_scan(self.counts, self.bucket_start, device=dev)
        launch(place_body, n, self.buckets, self.keys, x, self.dim, self.bucket_start, self.rank,
               self.sorted_index, self.sorted_key, self.sorted_x, device=dev)

    def query(self, xq, exclude_self: bool = False) -> NeighborList:
        """Neighbours (distance < h) in the grid's points of every column of ``xq`` (dim, M), an
        array on the grid's device; CSR lists there (offsets int64, indices uint32).
        ``exclude_self``: as :meth:`Grid.query`."""
        if self.n < 0:
            raise RuntimeError("HashGrid.query before build")
        dev = self.device
        m = xq.shape[1]
        counts = empty(m, np.int64, dev)
        offsets = empty(m + 1, np.int64, dev)
        cap = self.capacity
        while True:
            if self._rows is None or self._rows.shape[0] < m * cap:
                self._rows = empty(max(m * cap, 1), INDEX, dev)
            rows = self._rows
            launch(rows_body, m, xq, self.dim, self.h * self.h, 1.0 / self.h, self._origin,
                   self.mask, self.bucket_start, self.sorted_index, self.sorted_key,
                   self.sorted_x, bool(exclude_self), rows, cap, counts, device=dev)
            largest = int(launch_reduce(count_body, m, counts, device=dev)[1])
            if largest < cap:
                break
            cap = largest + 8  # rare: a denser neighbourhood than ever seen; redo
            self.capacity = cap
        total = exclusive_scan(counts, offsets, device=dev)
        indices = empty(max(total, 1), INDEX, dev)[:total]
        launch(compact_body, m, rows, cap, offsets, indices, device=dev)
        return NeighborList(offsets, indices)


class DeviceSearch:
    """The fluid's neighbour search of a time step on a device: a :class:`HashGrid` centred on
    the first positions it is given (read back once; later positions stay on the device) and
    the z-order permutation found there (:func:`zorder_on_device`)."""

    def __init__(self, dim: int, h: float, device: str = "cuda") -> None:
        self.dim, self.h, self.device = dim, float(h), device
        self.center: np.ndarray | None = None  #: the grid's centre [m] (dim,)
        self.grid: HashGrid | None = None

    def _start(self, x) -> None:  # noqa: ANN001 - a device array
        if self.grid is None:
            self.center = to_host(x).mean(1)
            self.grid = HashGrid(self.dim, self.h, hash_origin(self.center, self.h), self.device)

    def zorder(self, x):  # noqa: ANN001, ANN201 - device arrays
        """The z-order permutation of the points ``x`` (dim, N), on the device."""
        self._start(x)
        return zorder_on_device(x, self.h, self.center, self.device)

    def lists(self, x) -> NeighborList:  # noqa: ANN001 - a device array
        """The points' neighbour lists among themselves (self excluded), on the device."""
        self._start(x)
        self.grid.build(x)
        return self.grid.query(x, exclude_self=True)
