"""Verlet neighbour lists: the lists of a search with a skin, reused across steps.

Opt-in through ``configuration.neighbor_skin`` (a fraction of h; 0, the default, searches every
step). Lists built with the radius ``h (1 + skin)`` stay a superset of the true neighbours while
no particle has moved more than half the skin since (two particles then approach by less than
the skin); every step :func:`within` cuts them to the pairs closer than h, a distance test over
the candidates instead of a grid search (Verlet 1967; the "skin" of molecular dynamics codes).
The cut lists hold the same pairs as a search (up to a pair whose distance rounds across h), in
another order, so results agree with a search every step to round-off, not bit for bit.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sphkit.core.neighbors import (
    INDEX,
    NeighborList,
    Period,
    csr_offsets,
    neighbor_lists,
    pair_period,
)
from sphkit.core.pairs import delta, pair_slots, point


@numba.njit(cache=True, parallel=True, fastmath=True)
def _within(x, off, idx, h, dim, L):
    """CSR lists of the pairs of (off, idx) closer than h (``L`` > 0: minimum image along x)."""
    n = off.shape[0] - 1
    h2 = h * h
    counts = np.empty(n, dtype=np.int64)
    for i in numba.prange(n):
        xi0, xi1, xi2 = point(x, i, dim)
        c = 0
        for k in pair_slots(off, i):
            d0, d1, d2 = delta(xi0, xi1, xi2, x, idx[k], dim, L)
            c += np.int64(d0 * d0 + d1 * d1 + d2 * d2 < h2)
        counts[i] = c
    offsets = csr_offsets(counts)
    indices = np.empty(offsets[n], dtype=INDEX)
    for i in numba.prange(n):
        xi0, xi1, xi2 = point(x, i, dim)
        o = offsets[i]
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2 = delta(xi0, xi1, xi2, x, j, dim, L)
            if d0 * d0 + d1 * d1 + d2 * d2 < h2:
                indices[o] = j
                o += 1
    return offsets, indices


def within(x: np.ndarray, lists: NeighborList, h: float,
           period: float | tuple[float, float] = 0.0) -> NeighborList:
    """The pairs of ``lists`` (of the point set x (dim, N) with itself) closer than ``h``, in
    the order of ``lists`` (``period``: the pair loops' period, minimum-image distances along
    its periodic axes, :func:`sphkit.core.pairs.axis_period`)."""
    if x.shape[1] == 0:
        return NeighborList.empty(0)
    L = period if isinstance(period, tuple) else float(period)
    off, idx = _within(x, lists.offsets, lists.indices, float(h), x.shape[0], L)
    return NeighborList(off, idx)


class VerletLists:
    """Fluid-fluid neighbour lists reused across steps (Verlet lists with a skin).

    The candidate lists are searched with the radius ``h (1 + skin)`` and kept with the positions
    they were built from. A step reuses them while every particle has moved less than half the
    skin ``skin h / 2`` since (two particles then approach by less than ``skin h``, so every pair
    closer than h is a candidate) and cuts them to the pairs closer than h (:func:`within`): the
    same pairs as a search (up to a pair whose distance rounds across h), in another order, so
    results agree to round-off. Rebuilt when the particle count changes or the caller says so
    (a reordering of the particles)."""

    def __init__(self, skin: float) -> None:
        if not 0.0 < skin:
            raise ValueError(f"neighbor_skin: {skin!r}; expected a positive fraction of h")
        self.skin = float(skin)
        self.candidates: NeighborList | None = None
        self.x0: np.ndarray | None = None
        self.builds = 0  #: searches so far

    def lists(self, x: np.ndarray, h: float, period: Period,
              rebuild: bool = False) -> NeighborList:
        """This step's lists (pairs closer than h) of the point set x (dim, N)."""
        x0 = self.x0
        if (rebuild or self.candidates is None or x0 is None or x0.shape != x.shape
                or _largest_move(x, x0) > 0.5 * self.skin * h):
            self.candidates = None  # the old candidates go before the search
            self.candidates = neighbor_lists(x, h * (1.0 + self.skin), period)
            self.x0 = x.copy()
            self.builds += 1
        return within(x, self.candidates, h, pair_period(period))


@numba.njit(cache=True, parallel=True, fastmath=True)
def _largest_move2(x, x0):
    m = 0.0
    for i in numba.prange(x.shape[1]):
        s = 0.0
        for d in range(x.shape[0]):
            t = x[d, i] - x0[d, i]
            s += t * t
        m = max(m, s)
    return m


def _largest_move(x: np.ndarray, x0: np.ndarray) -> float:
    """The largest distance between x and x0 (dim, N) [m] (a periodic wrap counts as a move)."""
    return math.sqrt(_largest_move2(x, x0)) if x.shape[1] else 0.0
