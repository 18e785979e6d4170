"""A sparse LDL^T factorisation of a symmetric positive definite matrix, with compiled
triangular solves, for the constant matrices that implicit methods factorise once and solve
with every step (:mod:`sphkit.solids.kugelstadt2021`).

The factorisation is SuperLU's (:func:`scipy.sparse.linalg.splu`) in its symmetric mode: a
fill-reducing column ordering applied to rows and columns alike (``ordering``: SuperLU's
``permc_spec``, default ``"COLAMD"``; ``"MMD_AT_PLUS_A"``, the minimum degree of ``A + A^T``, is
the textbook choice for symmetric matrices, but on kugelstadt2021's Beam.json matrix it left 38 %
more nonzeros in L: 1.99 against 1.44 million) with ``SymmetricMode`` and no pivoting off the
diagonal (``diag_pivot_thresh=0``), so ``P A P^T = L U`` with ``U = D L^T`` for a symmetric
positive definite A. Only the strictly lower part of L and the diagonal D are kept (half the
factor's memory), and a solve is a forward substitution with L, a division by D and a back
substitution with L^T, all compiled, over the (n, m) right-hand sides at once (each entry of L read
once for all m). When SuperLU did pivot anyway (a matrix that is not positive definite, or not
symmetric), the rows and columns are not permuted alike or U is not ``D L^T``; then
:attr:`LDLT.symmetric` is false and :meth:`LDLT.solve` uses SuperLU's own solve.
"""

from __future__ import annotations

import numba
import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

#: U is taken as ``D L^T`` when ``max |U - D L^T| <= SYMMETRY_TOLERANCE * max |U|``
SYMMETRY_TOLERANCE = 1e-12


@numba.njit(cache=True, fastmath=True)
def _ldlt_solve3(indptr, indices, data, d, perm, b, x, z):
    """:func:`_ldlt_solve` for three right-hand sides, unrolled (the positions' coordinates)."""
    n = b.shape[0]
    for i in range(n):
        p = perm[i]
        z[p, 0] = b[i, 0]
        z[p, 1] = b[i, 1]
        z[p, 2] = b[i, 2]
    for j in range(n):  # L z = b (column-oriented)
        z0, z1, z2 = z[j, 0], z[j, 1], z[j, 2]
        for k in range(indptr[j], indptr[j + 1]):
            r = indices[k]
            v = data[k]
            z[r, 0] -= v * z0
            z[r, 1] -= v * z1
            z[r, 2] -= v * z2
    for j in range(n - 1, -1, -1):  # D^-1, then L^T x = z (rows of L^T: the columns of L)
        inv = 1.0 / d[j]
        s0, s1, s2 = z[j, 0] * inv, z[j, 1] * inv, z[j, 2] * inv
        for k in range(indptr[j], indptr[j + 1]):
            r = indices[k]
            v = data[k]
            s0 -= v * z[r, 0]
            s1 -= v * z[r, 1]
            s2 -= v * z[r, 2]
        z[j, 0] = s0
        z[j, 1] = s1
        z[j, 2] = s2
    for i in range(n):
        p = perm[i]
        x[i, 0] = z[p, 0]
        x[i, 1] = z[p, 1]
        x[i, 2] = z[p, 2]


@numba.njit(cache=True, fastmath=True)
def _ldlt_solve(indptr, indices, data, d, perm, b, x, z):
    """``x = A^-1 b`` for ``P A P^T = L D L^T`` (``L``: the strictly lower part, CSC; ``perm[i]``:
    the permuted index of unknown i); b, x, z: (n, m), z scratch."""
    n, m = b.shape
    for i in range(n):
        for c in range(m):
            z[perm[i], c] = b[i, c]
    for j in range(n):  # L z = b (column-oriented)
        for k in range(indptr[j], indptr[j + 1]):
            r = indices[k]
            v = data[k]
            for c in range(m):
                z[r, c] -= v * z[j, c]
    for j in range(n):
        inv = 1.0 / d[j]
        for c in range(m):
            z[j, c] *= inv
    for j in range(n - 1, -1, -1):  # L^T x = z (rows of L^T are the columns of L)
        for k in range(indptr[j], indptr[j + 1]):
            r = indices[k]
            v = data[k]
            for c in range(m):
                z[j, c] -= v * z[r, c]
    for i in range(n):
        for c in range(m):
            x[i, c] = z[perm[i], c]


class LDLT:
    """``A = P^T L D L^T P`` of a sparse symmetric positive definite matrix (module
    docstring; ``ordering``: SuperLU's ``permc_spec``). ``solve(b)`` for b of shape (n,) or
    (n, m)."""

    def __init__(self, A: sp.spmatrix, ordering: str = "COLAMD") -> None:
        A = sp.csc_matrix(A)
        n = A.shape[0]
        self.n = n
        self._lu = splu(A, permc_spec=ordering, diag_pivot_thresh=0.0,
                        options={"SymmetricMode": True})
        lu = self._lu
        L = sp.tril(lu.L, -1).tocsc()
        L.sort_indices()
        d = lu.U.diagonal()
        self.symmetric = bool(np.array_equal(lu.perm_r, lu.perm_c) and np.all(d > 0))
        if self.symmetric:
            diff = abs(sp.triu(lu.U, 1) - sp.diags(d) @ L.T)
            scale = abs(lu.U).max()
            self.symmetric = bool(diff.nnz == 0 or diff.max() <= SYMMETRY_TOLERANCE * scale)
        self._indptr = L.indptr.astype(np.int64)
        self._indices = L.indices.astype(np.int32)
        self._data = L.data
        self._d = d
        self._perm = lu.perm_c.astype(np.int64)
        if self.symmetric:
            self._lu = None  # L D L^T is all a solve needs
            #: nonzeros of the kept factor (strict lower part of L and the diagonal)
            self.nnz = int(L.nnz + n)
        else:
            self.nnz = int(lu.L.nnz + lu.U.nnz)
        #: memory of the kept factor [B] (8 B values, 4 B indices, column pointers, permutation)
        self.bytes = int(self.nnz * 12 + 8 * (n + 1) + 8 * n)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``A^-1 b`` (a new array of b's shape)."""
        b = np.asarray(b, dtype=np.float64)
        if not self.symmetric:
            return self._lu.solve(b)
        b2 = np.ascontiguousarray(b.reshape(self.n, -1))
        x = np.empty_like(b2)
        solve = _ldlt_solve3 if b2.shape[1] == 3 else _ldlt_solve
        solve(self._indptr, self._indices, self._data, self._d, self._perm, b2, x,
              np.empty_like(b2))
        return x.reshape(b.shape)
