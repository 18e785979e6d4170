"""The shared matrix-free Krylov solvers (core.krylov) against SciPy on small systems."""

from __future__ import annotations

import logging

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from sphkit.core.krylov import (
    BlockJacobiPreconditioner,
    JacobiPreconditioner,
    bicgstab,
    cg,
)
from sphkit.core.ldlt import LDLT


def _spd(n: int = 12, seed: int = 0) -> sp.csr_matrix:
    """A 2D Laplacian (n x n grid, Dirichlet) plus a random positive diagonal: SPD and
    badly scaled, so that Jacobi preconditioning matters."""
    lap1 = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    eye = sp.identity(n)
    lap = sp.kron(lap1, eye) + sp.kron(eye, lap1)
    d = np.random.default_rng(seed).uniform(0.1, 50.0, n * n)
    return (sp.diags(d) @ lap @ sp.diags(d) + sp.diags(d)).tocsr()


def _mv(A: sp.csr_matrix):
    def matvec(x: np.ndarray, out: np.ndarray) -> None:
        out[:] = A @ x
    return matvec


def test_cg_matches_direct_solve_and_scipy_iterations() -> None:
    """CG solves an SPD system to the requested relative residual (1e-10), the solution equals
    SciPy's direct solve to 1e-8 relative (the residual bound times the condition number is
    about that size), and Jacobi-preconditioned CG takes the same number of iterations as
    scipy.sparse.linalg.cg with the same preconditioner (same algorithm; +-1 for where the
    tolerance test falls)."""
    A = _spd()
    b = np.random.default_rng(1).normal(size=A.shape[0])
    ref = spla.spsolve(A.tocsc(), b)
    M = JacobiPreconditioner(A.diagonal())
    x, st = cg(_mv(A), b, precond=M, tol=1e-10, max_iter=1000)
    assert st.converged and st.residual <= 1e-10
    assert np.linalg.norm(A @ x - b) <= 1e-10 * np.linalg.norm(b) * 1.0001
    assert np.linalg.norm(x - ref) <= 1e-8 * np.linalg.norm(ref)
    count = [0]

    def cb(_xk: np.ndarray) -> None:
        count[0] += 1

    Minv = spla.LinearOperator(A.shape, matvec=lambda r: r / A.diagonal())
    _x, info = spla.cg(A, b, M=Minv, rtol=1e-10, atol=0.0, maxiter=1000, callback=cb)
    assert info == 0
    assert abs(st.iterations - count[0]) <= 1
    # preconditioning pays off on this badly scaled matrix
    _x2, plain = cg(_mv(A), b, tol=1e-10, max_iter=1000)
    assert plain.converged and plain.iterations > st.iterations


def test_cg_warm_start_and_zero_rhs() -> None:
    """An exact initial guess needs 0 iterations; b = 0 gives x = 0 without iterating."""
    A = _spd(6)
    b = np.random.default_rng(2).normal(size=A.shape[0])
    ref = spla.spsolve(A.tocsc(), b)
    x, st = cg(_mv(A), b, x0=ref, tol=1e-8)
    assert st.iterations == 0 and st.converged
    np.testing.assert_array_equal(x, ref)
    x, st = cg(_mv(A), np.zeros_like(b), x0=ref)
    assert st.iterations == 0 and not x.any()


def test_bicgstab_solves_nonsymmetric_system() -> None:
    """A convection-diffusion matrix (nonsymmetric): BiCGSTAB with Jacobi preconditioning
    reaches a relative residual of 1e-10; the solution matches the direct solve to 1e-8."""
    n = 100
    A = (sp.diags([-1.3, 2.5, -0.7], [-1, 0, 1], shape=(n, n))
         + sp.diags(np.linspace(0.1, 3.0, n))).tocsr()
    b = np.random.default_rng(3).normal(size=n)
    ref = spla.spsolve(A.tocsc(), b)
    x, st = bicgstab(_mv(A), b, precond=JacobiPreconditioner(A.diagonal()), tol=1e-10,
                     max_iter=500)
    assert st.converged
    assert np.linalg.norm(A @ x - b) <= 1.0001e-10 * np.linalg.norm(b)
    assert np.linalg.norm(x - ref) <= 1e-8 * np.linalg.norm(ref)


@pytest.mark.parametrize("dim", [2, 3])
def test_block_jacobi_is_exact_for_block_diagonal_systems(dim: int) -> None:
    """For a matrix made only of per-particle dim x dim SPD blocks (in the (dim, N) flattened
    layout), the block-Jacobi preconditioner is A^-1 itself: CG converges in one iteration."""
    rng = np.random.default_rng(dim)
    n = 50
    blocks = np.empty((dim, dim, n))
    rows, cols, vals = [], [], []
    for i in range(n):
        g = rng.normal(size=(dim, dim))
        B = g @ g.T + dim * np.eye(dim)
        blocks[:, :, i] = B
        for d in range(dim):
            for e in range(dim):
                rows.append(d * n + i)
                cols.append(e * n + i)
                vals.append(B[d, e])
    A = sp.csr_matrix((vals, (rows, cols)), shape=(dim * n, dim * n))
    b = rng.normal(size=dim * n)
    x, st = cg(_mv(A), b, precond=BlockJacobiPreconditioner(blocks), tol=1e-12)
    assert st.iterations == 1 and st.converged
    assert np.linalg.norm(A @ x - b) <= 1e-10 * np.linalg.norm(b)


def test_iteration_limit_warns(caplog: pytest.LogCaptureFixture) -> None:
    """Stopping at max_iter without reaching the tolerance logs a warning naming the solve."""
    A = _spd()
    b = np.ones(A.shape[0])
    with caplog.at_level(logging.WARNING, logger="sphkit"):
        _x, st = cg(_mv(A), b, tol=1e-12, max_iter=3, name="test solve", step=7)
    assert not st.converged and st.iterations == 3 and st.residual > 1e-12
    assert any("test solve" in r.message and "step 7" in r.message for r in caplog.records)


def test_ldlt_matches_scipy_on_spd_matrix() -> None:
    """core.ldlt's factorisations (SuperLU's L D L^T and the envelope's L L^T) and compiled
    solves against scipy's direct solve on a small SPD matrix (the 2D Laplacian's pattern,
    random symmetric weights, strictly diagonally dominant), one, two and three right-hand
    sides. Tolerance 1e-12 relative: both are direct solves of a well-conditioned system
    (condition number below 1e2), so they differ by round-off only."""
    rng = np.random.default_rng(3)
    k = 12
    lap = sp.kronsum(sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(k, k)),
                     sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(k, k)))
    W = sp.triu(lap, 1).multiply(rng.uniform(0.5, 1.5, lap.shape))
    A = (W + W.T - sp.diags(np.asarray(abs(W + W.T).sum(axis=1)).ravel() + 1.0)) * -1.0
    A = sp.csc_matrix(A)
    for method, kind in (("sparse", "ldlt"), ("envelope", "envelope"), ("auto", "envelope")):
        fac = LDLT(A, method=method)
        assert fac.symmetric and fac.kind == kind  # the grid's envelope: 2 entries per nonzero
        for b in (rng.normal(size=k * k), rng.normal(size=(k * k, 3)),
                  rng.normal(size=(k * k, 2))):
            x = fac.solve(b)
            ref = spla.spsolve(A, b)
            assert x.shape == b.shape
            assert np.max(np.abs(x - ref)) <= 1e-12 * np.max(np.abs(ref))
    # indefinite (a negative pivot): the envelope is refused and SuperLU's factor solves it;
    # the shifted matrix's condition number is below 1e2 as well (measured: 11)
    B = sp.csc_matrix(A - 10.0 * sp.eye(k * k))
    fac = LDLT(B, method="envelope")
    assert fac.kind in ("ldlt", "lu")
    b = rng.normal(size=k * k)
    ref = spla.spsolve(B, b)
    assert np.max(np.abs(fac.solve(b) - ref)) <= 1e-12 * np.max(np.abs(ref))
    # not symmetric: refused too (the envelope reads the lower triangle only)
    N = sp.csc_matrix(A + sp.triu(W, 1) * 0.1)
    assert LDLT(N, method="envelope").kind != "envelope"
