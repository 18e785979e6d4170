"""Sparse operators of a solid's rest configuration, shared by the models that assemble
matrices (:mod:`sphkit.solids.kugelstadt2021`, :mod:`sphkit.solids.kee2023`, and
:mod:`sphkit.solids.peer2018` for its implicit zero-energy-mode stiffness); not a method.

* :func:`gradient_operators`: the components ``D_c`` of the gradient with the weights of
  :mod:`sphkit.solids.gradients`, ``(D_c phi)_i = sum_j (phi_j - phi_i) G_ij[c]``; the
  deformation gradient of positions x is ``F_i[a, c] = (D_c x_a)_i``;
* :func:`zero_energy_operator`: ``Z^T W Z`` of the zero-energy-mode energy
  ``1/2 sum_(i,j) w_ij |x_ij - F_i x0_ij|^2``, ``w_ij = V0_i V0_j W(x0_ij) / |x0_ij|^2``
  (Ganzenmüller 2015's error vector over the rest pairs, made implicit by Kugelstadt et al.
  2021, Sec. 5; Kee et al. 2023 use the same term), a constant scalar n x n matrix applied to
  each coordinate.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from sphkit.core.kernels import Kernel


def gradient_operators(offsets: np.ndarray, indices: np.ndarray, G: np.ndarray,
                       dim: int) -> list[sp.csr_matrix]:
    """The sparse operators ``D_c`` (n x n) with ``(D_c phi)_i = sum_j (phi_j - phi_i) G_ij[c]``
    (vectorised over the rest pairs)."""
    n = offsets.shape[0] - 1
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(offsets))
    cols = indices.astype(np.int64)
    out = []
    for c in range(dim):
        diag = np.bincount(rows, weights=G[:, c], minlength=n)
        Dc = sp.csr_matrix((np.concatenate([G[:, c], -diag]),
                            (np.concatenate([rows, np.arange(n)]),
                             np.concatenate([cols, np.arange(n)]))), shape=(n, n))
        out.append(Dc)
    return out


def gradient_laplacian(D: list[sp.csr_matrix], V0: np.ndarray) -> sp.csr_matrix:
    """``K = sum_c D_c^T diag(V0) D_c`` (n x n): the stiffness of the squared gradient,
    ``phi^T K phi = sum_i V0_i |grad phi|_i^2`` (kugelstadt2021's and kee2023's constant
    matrix)."""
    V = sp.diags(V0)
    n = len(V0)
    return sum((Dc.T @ V @ Dc for Dc in D), sp.csr_matrix((n, n))).tocsr()


def zero_energy_operator(x0: np.ndarray, V0: np.ndarray, offsets: np.ndarray,
                         indices: np.ndarray, D: list[sp.csr_matrix], h: float, kid: int,
                         dim: int) -> sp.csr_matrix:
    """``Z^T W Z`` (n x n) of the zero-energy-mode energy (module docstring): ``(Z phi)_k =
    phi_j - phi_i - sum_c x0_ij[c] (D_c phi)_i`` per rest pair k = (i, j), weights
    ``V0_i V0_j W(x0_ij) / |x0_ij|^2``."""
    n = offsets.shape[0] - 1
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(offsets))
    cols = indices.astype(np.int64)
    npair = rows.size
    d = (x0[:dim, cols] - x0[:dim, rows]).T
    r2 = np.einsum("ij,ij->i", d, d)
    k = np.arange(npair)
    Z = sp.csr_matrix((np.concatenate([np.ones(npair), -np.ones(npair)]),
                       (np.concatenate([k, k]), np.concatenate([cols, rows]))),
                      shape=(npair, n))
    for c in range(dim):
        Z = Z - sp.diags(d[:, c]) @ D[c][rows]
    w = V0[rows] * V0[cols] * Kernel(kid, h, dim).w(np.sqrt(r2)) / np.maximum(r2, 1e-300)
    return (Z.T @ sp.diags(w) @ Z).tocsr()
