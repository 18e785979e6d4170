"""Morton (z-order) ordering of particles by their grid cells.

The simulation permutes every particle field along this curve every few steps and the world
builder orders the boundary samples the same way, so that particles close in space lie close in
memory and the pair loops' gathers of neighbour values hit the caches (Ihmsen et al. 2011,
"A parallel SPH implementation on multi-core CPUs").
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def _spread(v, dim):
    # interleave the bits of v with (dim - 1) zero bits between them
    out = np.int64(0)
    for b in range(63 // dim):
        out |= ((v >> b) & 1) << (b * dim)
    return out


@numba.njit(cache=True, parallel=True)
def _morton(x, dim, inv_h, lo, codes):
    for i in numba.prange(x.shape[1]):
        code = np.int64(0)
        for d in range(dim):
            c = np.int64(np.floor(x[d, i] * inv_h)) - lo[d]
            code |= _spread(c, dim) << d
        codes[i] = code


def zorder_permutation(x: np.ndarray, h: float) -> np.ndarray:
    """Permutation that orders points (dim, N) along a z-order curve of their grid cells."""
    n = x.shape[1]
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    dim = x.shape[0]
    lo = np.floor(x.min(axis=1) / h).astype(np.int64)
    codes = np.empty(n, dtype=np.int64)
    _morton(np.ascontiguousarray(x), dim, 1.0 / h, lo, codes)
    return np.argsort(codes, kind="stable")
