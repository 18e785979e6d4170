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

Where the matrix has a narrow profile (the quasi-one-dimensional bodies such as Beam.json's bar),
the envelope method of George & Liu (1981, "Computer Solution of Large Sparse Positive Definite
Systems", ch. 4) is used instead: the reverse Cuthill-McKee ordering (:func:`scipy.sparse.csgraph.
reverse_cuthill_mckee`) gives each row i of ``P A P^T`` a first nonzero column ``f_i``; the
Cholesky factor ``L L^T`` has no fill outside that envelope, so row i of L is stored densely from
``f_i`` to the diagonal, without indices. The factorisation is the bordering (row) method,
``L_ij = (A_ij - sum_k L_ik L_jk) / L_jj``, and a solve is, per right-hand side (in parallel),
contiguous dot products (forward) and contiguous updates (backward) that vectorise, where the
indexed L D L^T scatters (timings in benchmarks/README.md). The envelope is taken when it is small
against the matrix (:data:`ENVELOPE_RATIO`), so wide bodies keep L D L^T.
"""

from __future__ import annotations

import numba
import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee
from scipy.sparse.linalg import splu

from sphkit.core.pairs import pair_slots

#: U is taken as ``D L^T`` when ``max |U - D L^T| <= SYMMETRY_TOLERANCE * max |U|``
SYMMETRY_TOLERANCE = 1e-12

#: ``method="auto"`` factorises in the envelope when it holds at most this many entries per
#: nonzero of the matrix. An envelope entry costs about a sixth of an indexed factor entry in a
#: solve (8 B streamed in vectorised loops, against 12 B and a scattered update), and the sparse
#: factors of the elastic solids' matrices hold 0.75-3.6 entries per matrix nonzero, so up to
#: this ratio the envelope's solve is not slower; wider bodies, whose envelope grows faster
#: than a fill-reducing factor (as n^(5/3) against n^(4/3) for a compact 3D body), keep the
#: sparse L D L^T. Deciding on A alone spares the sparse factorisation (seconds for the larger
#: bodies) where the envelope is taken.
ENVELOPE_RATIO = 6.0


@numba.njit(cache=True, fastmath=True)
def _envelope_factor(first, start, val):
    """In place, ``L L^T`` of the matrix whose lower envelope is ``val`` (row i: columns
    ``first[i]..i`` at ``val[start[i]:start[i + 1]]``), by rows (the bordering method); false
    when a pivot is not positive (the matrix is not positive definite)."""
    n = first.shape[0]
    for i in range(n):
        fi = first[i]
        row = val[start[i]:start[i + 1]]
        for j in range(fi, i):
            fj = first[j]
            rowj = val[start[j]:start[j + 1]]
            lo = max(fi, fj)
            a = row[lo - fi:j - fi]
            b = rowj[lo - fj:j - fj]
            acc = 0.0
            for k in range(j - lo):
                acc += a[k] * b[k]
            row[j - fi] = (row[j - fi] - acc) / rowj[j - fj]
        acc = 0.0
        for k in range(i - fi):
            acc += row[k] * row[k]
        d = row[i - fi] - acc
        if not d > 0.0:
            return False
        row[i - fi] = np.sqrt(d)
    return True


@numba.njit(cache=True, fastmath=True)
def _envelope_forward(first, start, val, z):
    """``z <- L^-1 z`` (one right-hand side): a dot product over each row's envelope."""
    for i in range(first.shape[0]):
        fi = first[i]
        row = val[start[i]:start[i + 1]]
        seg = z[fi:i]
        acc = 0.0
        for k in range(i - fi):
            acc += row[k] * seg[k]
        z[i] = (z[i] - acc) / row[i - fi]


@numba.njit(cache=True, fastmath=True)
def _envelope_backward(first, start, val, z):
    """``z <- L^-T z`` (one right-hand side): row i of L, scaled by the solved ``x_i``, taken
    off the entries before it."""
    for i in range(first.shape[0] - 1, -1, -1):
        fi = first[i]
        row = val[start[i]:start[i + 1]]
        xi = z[i] / row[i - fi]
        z[i] = xi
        seg = z[fi:i]
        for k in range(i - fi):
            seg[k] -= row[k] * xi


@numba.njit(cache=True, parallel=True)
def _envelope_solve(first, start, val, perm, b, x, z):
    """``x = A^-1 b`` for ``P A P^T = L L^T`` in the envelope (``perm[k]``: the unknown at
    position k of the ordering); b, x: (n, m), z: (m, n) scratch; the m right-hand sides in
    parallel."""
    n, m = b.shape
    for c in numba.prange(m):
        zc = z[c]
        for k in range(n):
            zc[k] = b[perm[k], c]
        _envelope_forward(first, start, val, zc)
        _envelope_backward(first, start, val, zc)
        for k in range(n):
            x[perm[k], c] = zc[k]


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
        for k in pair_slots(indptr, j):
            r = indices[k]
            v = data[k]
            z[r, 0] -= v * z0
            z[r, 1] -= v * z1
            z[r, 2] -= v * z2
    for j in range(n - 1, -1, -1):  # D^-1, then L^T x = z (rows of L^T: the columns of L)
        inv = 1.0 / d[j]
        s0, s1, s2 = z[j, 0] * inv, z[j, 1] * inv, z[j, 2] * inv
        for k in pair_slots(indptr, j):
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
        for k in pair_slots(indptr, j):
            r = indices[k]
            v = data[k]
            for c in range(m):
                z[r, c] -= v * z[j, c]
    for j in range(n):
        inv = 1.0 / d[j]
        for c in range(m):
            z[j, c] *= inv
    for j in range(n - 1, -1, -1):  # L^T x = z (rows of L^T are the columns of L)
        for k in pair_slots(indptr, j):
            r = indices[k]
            v = data[k]
            for c in range(m):
                z[j, c] -= v * z[r, c]
    for i in range(n):
        for c in range(m):
            x[i, c] = z[perm[i], c]


class LDLT:
    """``A = P^T L D L^T P`` of a sparse symmetric positive definite matrix (module
    docstring; ``ordering``: SuperLU's ``permc_spec``), or ``A = P^T L L^T P`` in the envelope of
    the reverse Cuthill-McKee ordering. ``method``: ``"auto"`` (the envelope when it holds at
    most :data:`ENVELOPE_RATIO` entries per nonzero of A, else the sparse factor), ``"envelope"``
    (whenever A is positive definite) or ``"sparse"``; :attr:`kind` says which was taken
    (``"envelope"``, ``"ldlt"``, or ``"lu"`` when SuperLU pivoted). ``solve(b)`` for b of shape
    (n,) or (n, m)."""

    def __init__(self, A: sp.spmatrix, ordering: str = "COLAMD", method: str = "auto") -> None:
        if method not in ("auto", "envelope", "sparse"):
            raise ValueError(f"LDLT: method {method!r}: expected 'auto', 'envelope' or 'sparse'")
        A = sp.csc_matrix(A)
        self.n = A.shape[0]
        self._lu: object = None
        if method == "sparse" or self.n == 0 or not self._envelope(A, method == "envelope"):
            self._sparse(A, ordering)

    def _envelope(self, A: sp.csc_matrix, always: bool) -> bool:
        """Factorise in the reverse Cuthill-McKee envelope when it is small enough (or
        ``always``) and A symmetric positive definite; false (nothing kept) otherwise."""
        n = self.n
        Ar = sp.csr_matrix(A)
        asym = abs(Ar - Ar.T)
        if asym.nnz and asym.max() > SYMMETRY_TOLERANCE * abs(Ar).max():
            return False  # the envelope reads the lower triangle only: A must be symmetric
        perm = reverse_cuthill_mckee(Ar, symmetric_mode=True).astype(np.int64)
        P = sp.tril(Ar[perm][:, perm]).tocsr()
        P.sort_indices()
        counts = np.diff(P.indptr)
        if np.any(counts == 0):
            return False  # a row without its diagonal: not positive definite
        first = P.indices[P.indptr[:-1]].astype(np.int64)
        start = np.zeros(n + 1, np.int64)
        start[1:] = np.cumsum(np.arange(n) - first + 1)
        size = int(start[-1])
        if not always and size > ENVELOPE_RATIO * A.nnz:
            return False
        val = np.zeros(size)
        rows = np.repeat(np.arange(n), counts)
        val[start[rows] + P.indices - first[rows]] = P.data
        if not _envelope_factor(first, start, val):
            return False
        self.kind = "envelope"
        self.symmetric = True
        self._first, self._start, self._val, self._perm = first, start, val, perm
        #: entries of the kept factor (the envelope's; for L D L^T the strict lower part of L
        #: and the diagonal; for L U both factors')
        self.nnz = size
        #: memory of the kept factor [B] (values, indices, pointers, permutation)
        self.bytes = int(size * 8 + 8 * (n + 1) + 16 * n)
        return True

    def _sparse(self, A: sp.csc_matrix, ordering: str) -> None:
        """SuperLU's factor in its symmetric mode, kept as L D L^T (module docstring)."""
        n = self.n
        lu = splu(A, permc_spec=ordering, diag_pivot_thresh=0.0,
                  options={"SymmetricMode": True})
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
            self.kind = "ldlt"  # L D L^T is all a solve needs
            self.nnz = int(L.nnz + n)
        else:
            self.kind = "lu"
            self._lu = lu
            self.nnz = int(lu.L.nnz + lu.U.nnz)
        self.bytes = int(self.nnz * 12 + 8 * (n + 1) + 8 * n)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``A^-1 b`` (a new array of b's shape)."""
        b = np.asarray(b, dtype=np.float64)
        if self.kind == "lu":
            return self._lu.solve(b)
        b2 = np.ascontiguousarray(b.reshape(self.n, -1))
        x = np.empty_like(b2)
        if self.kind == "envelope":
            _envelope_solve(self._first, self._start, self._val, self._perm, b2, x,
                            np.empty((b2.shape[1], self.n)))
        else:
            solve = _ldlt_solve3 if b2.shape[1] == 3 else _ldlt_solve
            solve(self._indptr, self._indices, self._data, self._d, self._perm, b2, x,
                  np.empty_like(b2))
        return x.reshape(b.shape)
