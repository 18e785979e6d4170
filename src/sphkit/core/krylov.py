"""Matrix-free Krylov solvers shared by the implicit non-pressure methods.

DESIGN.md: "one matrix-free (preconditioned) conjugate gradient for the implicit viscosity,
surface tension and elasticity solves. Iteration control and statistics live there." This module
is that solver. The system matrix is never stored: a method passes ``matvec(x, out)``, a
compiled pass over the step's neighbour lists that writes ``A x`` into ``out``.

* :func:`cg` -- preconditioned conjugate gradient (Hestenes & Stiefel 1952; Saad 2003,
  "Iterative Methods for Sparse Linear Systems", Alg. 9.1) for symmetric positive definite A;
* :func:`bicgstab` -- preconditioned BiCGSTAB (van der Vorst 1992, SIAM J. Sci. Stat. Comput.
  13(2); right preconditioning as in Saad 2003, Alg. 9.x and Eigen's ``BiCGSTAB``) for general A;
* :class:`JacobiPreconditioner` -- ``M = diag(A)``;
* :class:`BlockJacobiPreconditioner` -- ``M`` = the dim x dim diagonal blocks of A (one per
  particle), as SPlisHSPlasH's ``BlockJacobiPreconditioner3D`` for the implicit viscosity.

Devices: the vector operations and the block-Jacobi preconditioner are kernel bodies
(:func:`sphkit.backend.launch`; dot products :func:`sphkit.backend.launch_sum`), so :func:`cg`
with :class:`BlockJacobiPreconditioner` runs where ``b`` is (a CUDA device array: on the GPU,
reading back only the dot products, float64 there too); each has the fast-math flags of the
``prange`` loop it replaced, so the CPU's results are unchanged to the last bit.
:class:`JacobiPreconditioner` and :func:`bicgstab` still allocate with NumPy (CPU only).

Vector unknowns are (dim, N) fields flattened row-major (``x.reshape(dim, N)`` gives them back
without a copy), so particle i's components are ``x[d * N + i]``.

Stopping test (the convention of Eigen, which SPlisHSPlasH's solvers use, so that its
``maxError`` values mean the same here): the relative residual ``|b - A x| / |b|`` at most
``tol``, checked before every iteration (0 iterations when the initial guess is good enough).
Each solve returns :class:`KrylovStats`; hitting ``max_iter`` logs a warning on the ``sphkit``
logger naming the solve, the step and the residual.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np

from sphkit.backend import launch, launch_sum
from sphkit.core import arrays

log = logging.getLogger("sphkit")

_JIT = dict(cache=True, fastmath=True)

MatVec = Callable[[np.ndarray, np.ndarray], None]
Preconditioner = Callable[[np.ndarray, np.ndarray], None]


@dataclass
class KrylovStats:
    """Result of one Krylov solve: iterations, final relative residual ``|b - A x| / |b|``
    (as tracked by the recurrence), and whether it reached the tolerance."""

    iterations: int = 0
    residual: float = 0.0
    converged: bool = True


# ---------------------------------------------------------------------------------------------
# vector operations: kernel bodies (:func:`sphkit.backend.launch`, where the vectors are), with
# the fast-math flags of the prange loops they replace


@numba.njit(inline="always", **_JIT)
def dot_body(i, a, b):
    """``a[i] * b[i]`` (summed by :func:`sphkit.backend.launch_sum`)."""
    return a[i] * b[i]


@numba.njit(inline="always", **_JIT)
def axpy_body(i, alpha, x, y):
    """``y[i] += alpha x[i]``."""
    y[i] += alpha * x[i]


@numba.njit(inline="always", **_JIT)
def xpby_body(i, x, beta, y):
    """``y[i] = x[i] + beta y[i]``."""
    y[i] = x[i] + beta * y[i]


@numba.njit(inline="always", **_JIT)
def sub_body(i, a, b, out):
    """``out[i] = a[i] - b[i]``."""
    out[i] = a[i] - b[i]


@numba.njit(inline="always", **_JIT)
def bicg_p_body(i, r, beta, omega, v, p):
    """``p[i] = r[i] + beta (p[i] - omega v[i])``."""
    p[i] = r[i] + beta * (p[i] - omega * v[i])


def _dot(a, b) -> float:
    return launch_sum(dot_body, a.shape[0], a, b)


def _axpy(alpha: float, x, y) -> None:
    """y += alpha x"""
    launch(axpy_body, x.shape[0], alpha, x, y)


def _xpby(x, beta: float, y) -> None:
    """y = x + beta y"""
    launch(xpby_body, x.shape[0], x, beta, y)


def _sub(a, b, out) -> None:
    """out = a - b"""
    launch(sub_body, a.shape[0], a, b, out)


def _bicg_p(r, beta: float, omega: float, v, p) -> None:
    """p = r + beta (p - omega v)"""
    launch(bicg_p_body, r.shape[0], r, beta, omega, v, p)


# ---------------------------------------------------------------------------------------------
# preconditioners


class JacobiPreconditioner:
    """``z = r / diag(A)``; zero or non-finite diagonal entries act as 1."""

    def __init__(self, diagonal: np.ndarray) -> None:
        d = np.asarray(diagonal, dtype=np.float64).ravel()
        ok = np.isfinite(d) & (d != 0.0)
        self.inv = np.where(ok, 1.0 / np.where(ok, d, 1.0), 1.0)

    def __call__(self, r: np.ndarray, z: np.ndarray) -> None:
        arrays.multiplied(self.inv, r, out=z)  # z = inv * r, element-wise


@numba.njit(inline="always", **_JIT)
def invert_blocks_body(i, B, out, dim):
    """out[:, :, i] = B[:, :, i]^-1 for dim x dim blocks (dim <= 3), closed form; a block whose
    determinant is tiny relative to its scale falls back to the inverse of its diagonal (a
    kernel body)."""
    for d in range(dim):
        for e in range(dim):
            out[d, e, i] = 0.0
    if dim == 1:
        det = B[0, 0, i]
        scale = abs(B[0, 0, i])
    elif dim == 2:
        det = B[0, 0, i] * B[1, 1, i] - B[0, 1, i] * B[1, 0, i]
        scale = abs(B[0, 0, i] * B[1, 1, i]) + abs(B[0, 1, i] * B[1, 0, i])
    else:
        c00 = B[1, 1, i] * B[2, 2, i] - B[1, 2, i] * B[2, 1, i]
        c01 = B[1, 2, i] * B[2, 0, i] - B[1, 0, i] * B[2, 2, i]
        c02 = B[1, 0, i] * B[2, 1, i] - B[1, 1, i] * B[2, 0, i]
        det = B[0, 0, i] * c00 + B[0, 1, i] * c01 + B[0, 2, i] * c02
        scale = abs(B[0, 0, i] * B[1, 1, i] * B[2, 2, i]) + abs(B[0, 0, i] * c00) + 1e-300
    if abs(det) <= 1e-12 * scale or not math.isfinite(det):
        for d in range(dim):
            out[d, d, i] = 1.0 / B[d, d, i] if B[d, d, i] != 0.0 else 1.0
        return
    inv = 1.0 / det
    if dim == 1:
        out[0, 0, i] = inv
    elif dim == 2:
        out[0, 0, i] = B[1, 1, i] * inv
        out[0, 1, i] = -B[0, 1, i] * inv
        out[1, 0, i] = -B[1, 0, i] * inv
        out[1, 1, i] = B[0, 0, i] * inv
    else:
        out[0, 0, i] = c00 * inv
        out[1, 0, i] = c01 * inv
        out[2, 0, i] = c02 * inv
        out[0, 1, i] = (B[0, 2, i] * B[2, 1, i] - B[0, 1, i] * B[2, 2, i]) * inv
        out[1, 1, i] = (B[0, 0, i] * B[2, 2, i] - B[0, 2, i] * B[2, 0, i]) * inv
        out[2, 1, i] = (B[0, 1, i] * B[2, 0, i] - B[0, 0, i] * B[2, 1, i]) * inv
        out[0, 2, i] = (B[0, 1, i] * B[1, 2, i] - B[0, 2, i] * B[1, 1, i]) * inv
        out[1, 2, i] = (B[0, 2, i] * B[1, 0, i] - B[0, 0, i] * B[1, 2, i]) * inv
        out[2, 2, i] = (B[0, 0, i] * B[1, 1, i] - B[0, 1, i] * B[1, 0, i]) * inv


@numba.njit(inline="always", **_JIT)
def apply_blocks_body(i, Binv, r, z, dim):
    """``z[:, i] = Binv[:, :, i] r[:, i]`` for (dim, N) views r, z of the flat vectors."""
    r0 = r[0, i]
    r1 = r[1, i] if dim > 1 else 0.0
    r2 = r[2, i] if dim > 2 else 0.0
    for d in range(dim):
        s = Binv[d, 0, i] * r0
        if dim > 1:
            s += Binv[d, 1, i] * r1
        if dim > 2:
            s += Binv[d, 2, i] * r2
        z[d, i] = s


class BlockJacobiPreconditioner:
    """``z_i = B_i^-1 r_i`` with the dim x dim diagonal block B_i of particle i.

    ``blocks`` has shape (dim, dim, N): ``blocks[d, e, i]`` is the coefficient of unknown
    ``x[e, i]`` in row ``(d, i)`` of A (the (dim, N) layout, one contiguous row per entry).
    """

    def __init__(self, blocks: np.ndarray) -> None:
        if blocks.ndim != 3 or blocks.shape[0] != blocks.shape[1] or blocks.shape[0] > 3:
            raise ValueError(f"blocks: shape {blocks.shape}; expected (dim, dim, N), dim <= 3")
        self.dim = blocks.shape[0]
        self.n = blocks.shape[2]
        if not arrays.on_device(blocks):  # on a device: float64 and contiguous already
            blocks = np.ascontiguousarray(blocks, dtype=np.float64)
        self.inv = arrays.empty(blocks.shape, np.float64, like=blocks)
        launch(invert_blocks_body, self.n, blocks, self.inv, self.dim)

    def __call__(self, r: np.ndarray, z: np.ndarray) -> None:
        launch(apply_blocks_body, self.n, self.inv, r.reshape(self.dim, self.n),
               z.reshape(self.dim, self.n), self.dim)


# ---------------------------------------------------------------------------------------------
# solvers


def _start(matvec: MatVec, b: np.ndarray, x0: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    if not arrays.on_device(b):  # on a device: float64 and contiguous already (as the method
        b = np.ascontiguousarray(b, dtype=np.float64).ravel()  # allocates it)
    b = b.ravel()
    x = (arrays.zeros(b.shape, np.float64, like=b) if x0 is None
         else arrays.copied(x0, np.float64).ravel())
    if x.shape != b.shape:
        raise ValueError(f"x0: {x.shape[0]} unknowns, b has {b.shape[0]}")
    r = arrays.empty_like(b)
    if x0 is None:
        arrays.copy_into(r, b)
    else:
        matvec(x, r)
        _sub(b, r, r)
    return x, r


def _report(name: str, stats: KrylovStats, max_iter: int, tol: float, step: int) -> KrylovStats:
    if not stats.converged:
        log.warning("%s: no convergence in %d iterations at step %d: relative residual %.4g "
                    "(tolerance %.4g)", name, max_iter, step, stats.residual, tol)
    return stats


def cg(matvec: MatVec, b: np.ndarray, x0: np.ndarray | None = None, *,
       precond: Preconditioner | None = None, tol: float = 1e-2, max_iter: int = 100,
       name: str = "CG", step: int = -1, warn: bool = True) -> tuple[np.ndarray, KrylovStats]:
    """Solve ``A x = b`` (A symmetric positive definite) by preconditioned CG.

    ``matvec(x, out)`` writes ``A x``; ``precond(r, z)`` writes ``M^-1 r`` (identity if None).
    Stops when ``|r| <= tol |b|`` or after ``max_iter`` iterations (then warns, unless ``warn``
    is false: an inexact Newton method's inner solve, whose caller reports its own
    convergence). Returns the solution (a new flat array) and :class:`KrylovStats`.
    """
    if not tol > 0 or max_iter < 1:
        raise ValueError(f"tol {tol!r}, max_iter {max_iter!r}: expected tol > 0, max_iter >= 1")
    x, r = _start(matvec, b, x0)
    bb = _dot(b.ravel(), b.ravel()) if b.size else 0.0
    if bb == 0.0:  # the solution of A x = 0 is 0
        return arrays.zeros(x.shape, x.dtype, like=x), KrylovStats(0, 0.0, True)
    thresh = tol * tol * bb
    rr = _dot(r, r)
    if rr <= thresh:
        return x, KrylovStats(0, math.sqrt(rr / bb), True)
    z = arrays.empty_like(r)
    if precond is None:
        arrays.copy_into(z, r)
    else:
        precond(r, z)
    p = arrays.copied(z)
    q = arrays.empty_like(r)
    rz = _dot(r, z)
    it = 0
    while it < max_iter:
        matvec(p, q)
        pq = _dot(p, q)
        if pq <= 0.0:  # A not positive definite along p (or p = 0): stop
            break
        alpha = rz / pq
        _axpy(alpha, p, x)
        _axpy(-alpha, q, r)
        it += 1
        rr = _dot(r, r)
        if rr <= thresh:
            break
        if precond is None:
            arrays.copy_into(z, r)
        else:
            precond(r, z)
        rz_new = _dot(r, z)
        _xpby(z, rz_new / rz, p)
        rz = rz_new
    stats = KrylovStats(it, math.sqrt(rr / bb), rr <= thresh)
    return x, (_report(name, stats, max_iter, tol, step) if warn else stats)


def bicgstab(matvec: MatVec, b: np.ndarray, x0: np.ndarray | None = None, *,
             precond: Preconditioner | None = None, tol: float = 1e-2, max_iter: int = 100,
             name: str = "BiCGSTAB", step: int = -1) -> tuple[np.ndarray, KrylovStats]:
    """Solve ``A x = b`` (A general, non-singular) by right-preconditioned BiCGSTAB.

    Same arguments, stopping test and results as :func:`cg`; one iteration costs two matvecs.
    When the shadow residual becomes orthogonal to the residual (breakdown) the iteration
    restarts from the current x.
    """
    if not tol > 0 or max_iter < 1:
        raise ValueError(f"tol {tol!r}, max_iter {max_iter!r}: expected tol > 0, max_iter >= 1")
    x, r = _start(matvec, b, x0)
    bb = _dot(b.ravel(), b.ravel()) if b.size else 0.0
    if bb == 0.0:
        return np.zeros_like(x), KrylovStats(0, 0.0, True)
    thresh = tol * tol * bb
    rr = _dot(r, r)
    if rr <= thresh:
        return x, KrylovStats(0, math.sqrt(rr / bb), True)
    r0 = r.copy()
    r0r0 = rr
    rho = alpha = omega = 1.0
    v = np.zeros_like(r)
    p = np.zeros_like(r)
    y = np.empty_like(r)
    s = np.empty_like(r)
    zz = np.empty_like(r)
    t = np.empty_like(r)
    it = 0
    eps2 = np.finfo(np.float64).eps ** 2
    while it < max_iter:
        rho_new = _dot(r0, r)
        if abs(rho_new) < eps2 * r0r0:  # breakdown: restart with the current residual
            matvec(x, r)
            _sub(b.ravel(), r, r)
            r0[:] = r
            r0r0 = rho_new = _dot(r, r)
            rho = alpha = omega = 1.0
            v[:] = 0.0
            p[:] = 0.0
        beta = (rho_new / rho) * (alpha / omega)
        rho = rho_new
        _bicg_p(r, beta, omega, v, p)
        if precond is None:
            y[:] = p
        else:
            precond(p, y)
        matvec(y, v)
        r0v = _dot(r0, v)
        if r0v == 0.0:
            break
        alpha = rho / r0v
        s[:] = r
        _axpy(-alpha, v, s)
        if precond is None:
            zz[:] = s
        else:
            precond(s, zz)
        matvec(zz, t)
        tt = _dot(t, t)
        omega = _dot(t, s) / tt if tt > 0.0 else 0.0
        _axpy(alpha, y, x)
        _axpy(omega, zz, x)
        r[:] = s
        _axpy(-omega, t, r)
        it += 1
        rr = _dot(r, r)
        if rr <= thresh or omega == 0.0:
            break
    stats = KrylovStats(it, math.sqrt(rr / bb), rr <= thresh)
    return x, _report(name, stats, max_iter, tol, step)
