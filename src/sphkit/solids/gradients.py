"""Gradient weights of a solid's rest configuration: ``grad phi_i = sum_j (phi_j - phi_i) G_ij``.

The corotated models measure the displacement gradient of particle i from its rest neighbours
j with one weight vector ``G_ij`` per pair of the rest lists, computed once, at the start
(NumPy, vectorised over the pairs), in one of three orders of consistency:

* ``none``: the SPH gradient ``G_ij = -V0_j grad W(x0_j - x0_i)`` (SPlisHSPlasH's Becker 2009),
  exact for linear fields only where the kernel is complete;
* ``linear``: the corrected gradient ``G_ij = -V0_j L_i grad W(x0_j - x0_i)`` with
  ``L_i = (-sum_j V0_j grad W(x0_ji) x0_ji^T)^-1`` (Bonet & Lok 1999; Peer et al. 2018 Eq. 18),
  exact for linear fields everywhere;
* ``quadratic``: a second-order moving-least-squares gradient: the coefficients ``beta`` of the
  weighted (``V0_j W_ij``) least-squares fit of ``phi_j - phi_i`` by the monomials of degree 1
  and 2 of ``x0_ji`` (dim + dim (dim + 1) / 2 of them), ``grad phi_i = beta[:dim]``, so
  ``G_ij = V0_j W_ij [M_i^-1 p(x0_ji)][:dim]`` with ``M_i = sum_j V0_j W_ij p p^T``: exact
  for quadratic fields. A bent beam's displacement is quadratic, and the linear correction
  measures the strain of its surface particles at the centroid of their one-sided
  neighbourhood, inside the beam, which makes a beam 4 particles thick about 40 % too soft in
  bending (validation/solids.py); the quadratic fit removes that first-order error. Where
  ``M_i`` is singular or ill-conditioned (fewer neighbours than monomials: corners; condition
  number above :data:`MAX_CONDITION`) the particle keeps the linear weights.

The elastic force that follows from these weights (:mod:`sphkit.solids.corotation`) needs the
weight of the reverse pair, ``G_ji``; :func:`reverse_pairs` finds it in the symmetric lists.
"""

from __future__ import annotations

import numpy as np

from sphkit.core.kernels import Kernel

#: the largest condition number of the (scaled) moment matrix of the quadratic fit
MAX_CONDITION = 1e6


def reverse_pairs(offsets: np.ndarray, indices: np.ndarray) -> np.ndarray:
    """For each pair k = (i, j) of symmetric CSR lists, the index of the pair (j, i)."""
    n = offsets.shape[0] - 1
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(offsets))
    cols = indices.astype(np.int64)
    key = rows * n + cols
    order = np.argsort(key, kind="stable")
    pos = np.searchsorted(key[order], cols * n + rows)
    rev = order[np.minimum(pos, key.size - 1)]
    if key.size and not np.array_equal(key[rev], cols * n + rows):
        raise ValueError("solid rest lists are not symmetric")
    return rev


def _monomials(d: np.ndarray, dim: int) -> np.ndarray:
    """(pairs, nb): the monomials of degree 1 and 2 of the rows of ``d`` (pairs, dim)."""
    cols = [d[:, a] for a in range(dim)]
    cols += [d[:, a] * d[:, b] for a in range(dim) for b in range(a, dim)]
    return np.stack(cols, axis=1)


def gradient_weights(x0: np.ndarray, V0: np.ndarray, offsets: np.ndarray, indices: np.ndarray,
                     h: float, kid: int, dim: int, order: str,
                     min_samples: float = 1.0, pair_d: np.ndarray | None = None,
                     rigid: np.ndarray | None = None) -> np.ndarray:
    """The weights ``G`` (pairs, 3) of the rest lists (module docstring); ``x0`` (3, n) rest
    positions padded with zero rows, ``V0`` rest volumes, ``order`` one of ``none``,
    ``linear``, ``quadratic``; a particle keeps the linear weights unless it has at least
    ``min_samples`` times as many neighbours as the quadratic fit has monomials (capped lists:
    a fit barely determined by its nearest neighbours is noisy). ``pair_d`` (pairs, dim), if
    given, replaces the rest vectors ``x0_ji`` as the fit's sample positions (the face clamp
    of :meth:`sphkit.solids.rest.RestConfiguration.clamp_vectors`; the weights stay those of
    the rest distances); the rows of the particles marked in ``rigid`` (bool per particle)
    are zero (no strain)."""
    if order not in ("none", "linear", "quadratic"):
        raise ValueError(f"elasticity.gradient_correction: {order!r}; expected 'none', "
                         "'linear' or 'quadratic'")
    n = offsets.shape[0] - 1
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(offsets))
    cols = indices.astype(np.int64)
    d = (x0[:dim, cols] - x0[:dim, rows]).T  # x0_ji, (pairs, dim)
    dist = np.linalg.norm(d, axis=1)  # the pairs' weights: their rest distances
    if pair_d is not None:  # the face clamp's samples: moved, with their pairs' weights
        d = pair_d
    kern = Kernel(kid, h, dim)
    g = kern.dw_over_r(dist)[:, None] * d  # grad W(x0_ji)
    G = np.zeros((rows.size, 3))
    G[:, :dim] = -V0[cols, None] * g
    if order == "none" or rows.size == 0:
        return _zero_rows(G, rows, rigid)
    # linear: L_i = (sum_j -V0_j grad W(x0_ji) x0_ji^T)^-1 ... as rows: B_i = sum_j d (-V g)^T
    B = np.zeros((n, dim, dim))
    np.add.at(B, rows, d[:, :, None] * G[:, None, :dim])
    det = np.linalg.det(B)
    scale = np.abs(np.einsum("nii->n", B)) ** dim
    good = np.abs(det) > 1e-6 * scale
    Linv = np.broadcast_to(np.eye(dim), B.shape).copy()
    Linv[good] = np.linalg.inv(B[good])
    # grad phi = sum_j (phi_j - phi_i) G_ij with sum_j d_j G_ij^T = I: G_ij = B^-T ... applied
    # to the SPH weights: G_lin_ij = L_i^T? solve sum_j d (L g)^T = I  ->  L = B^-T
    G_lin = np.einsum("nba,nb->na", Linv[rows], G[:, :dim])
    G[:, :dim] = G_lin
    if order == "linear":
        return _zero_rows(G, rows, rigid)
    p = _monomials(d / h, dim)
    nb = p.shape[1]
    w = V0[cols] * kern.w(dist)
    M = np.zeros((n, nb, nb))
    np.add.at(M, rows, w[:, None, None] * p[:, :, None] * p[:, None, :])
    counts = np.diff(offsets)
    ok = counts >= max(1.0, min_samples) * nb
    cond = np.full(n, np.inf)
    if ok.any():
        cond[ok] = np.linalg.cond(M[ok])
    ok &= cond < MAX_CONDITION
    Minv = np.zeros_like(M)
    Minv[ok] = np.linalg.inv(M[ok])
    quad = ok[rows]
    coef = np.einsum("kab,kb->ka", Minv[rows[quad]], p[quad])[:, :dim]
    G[quad, :dim] = w[quad, None] * coef / h
    return _zero_rows(G, rows, rigid)


def _zero_rows(G: np.ndarray, rows: np.ndarray, rigid: np.ndarray | None) -> np.ndarray:
    """``G`` with the pairs of the particles marked in ``rigid`` zeroed."""
    if rigid is not None:
        G[rigid[rows]] = 0.0
    return G
