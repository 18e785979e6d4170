"""The radius graph of a particle set, built with sphkit's neighbour search.

Edges connect every pair closer than the connectivity radius R (strictly, as
:func:`sphkit.core.neighbors.neighbor_lists`), both directions, no self edges. Only particles
whose type is predicted (the fluid) receive messages: walls are inputs, their nodes keep their
encoded features (an edge into a static wall would only feed a node whose output is discarded;
leaving those edges out saves about a third of the edges of the dam break). A periodic axis x
(the only periodic axis sphkit's search knows) uses the minimum image.

Several graphs are batched by concatenating their nodes (offsets added to the indices); nothing
is padded.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sphkit.core.neighbors import neighbor_lists


def radius_graph(x: np.ndarray, radius: float, receivers_mask: np.ndarray | None = None,
                 periodic: Sequence[bool] | None = None,
                 bounds: Sequence[Sequence[float]] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Senders and receivers (int64 arrays of the same length) of the radius graph of positions
    ``x`` (N, dim): pairs with ``|x_s - x_r| < radius``, s != r, and ``receivers_mask[r]``.

    ``periodic``: per axis; only x may be periodic (then ``bounds[0]`` is the period's
    [lo, hi])."""
    x = np.asarray(x, dtype=np.float64)
    n, dim = x.shape
    period = None
    if periodic is not None and any(periodic):
        if any(periodic[1:]):
            raise ValueError("periodic_boundary_conditions: sphkit's neighbour search is periodic "
                             "along x only")
        if bounds is None:
            raise ValueError("a periodic graph needs the bounds")
        lo, hi = float(bounds[0][0]), float(bounds[0][1])
        period = (lo, hi - lo)
        x = x.copy()
        x[:, 0] = lo + np.mod(x[:, 0] - lo, hi - lo)
    nl = neighbor_lists(np.ascontiguousarray(x.T), float(radius), period)
    counts = np.diff(nl.offsets)
    receivers = np.repeat(np.arange(n, dtype=np.int64), counts)
    senders = nl.indices.astype(np.int64)
    if receivers_mask is not None:
        keep = np.asarray(receivers_mask, dtype=bool)[receivers]
        senders, receivers = senders[keep], receivers[keep]
    return senders, receivers


def displacement(x: np.ndarray, senders: np.ndarray, receivers: np.ndarray,
                 periodic: Sequence[bool] | None = None,
                 bounds: Sequence[Sequence[float]] | None = None) -> np.ndarray:
    """``x_s - x_r`` per edge (E, dim), the minimum image along periodic axes."""
    d = x[senders] - x[receivers]
    if periodic is not None and bounds is not None:
        for k, p in enumerate(periodic):
            if p:
                L = float(bounds[k][1]) - float(bounds[k][0])
                d[:, k] -= L * np.round(d[:, k] / L)
    return d


def brute_force_graph(x: np.ndarray, radius: float,
                      receivers_mask: np.ndarray | None = None) -> set[tuple[int, int]]:
    """The edge set (sender, receiver) by the O(N^2) search (tests)."""
    d = np.linalg.norm(x[:, None, :] - x[None, :, :], axis=-1)
    s, r = np.nonzero((d < radius) & ~np.eye(len(x), dtype=bool))
    mask = np.ones(len(x), bool) if receivers_mask is None else np.asarray(receivers_mask, bool)
    return {(int(a), int(b)) for a, b in zip(s, r, strict=True) if mask[b]}
