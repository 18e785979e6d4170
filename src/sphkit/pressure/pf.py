"""Projective fluids (PF): projective dynamics with density constraints.

Weiler, Koschier, Bender 2016, "Projective fluids", Proc. Motion in Games (MIG), as
SPlisHSPlasH's ``TimeStepPF`` implements it (``simulationMethod`` 5). Each fluid particle i owns
one density constraint over itself and its fluid neighbours,
``C_i = max(rho_hat_i - 1, 0)``, ``rho_hat_i = V_i W(0) + sum_j V_j W_ij + sum_b V_b W_ib``
(rest volumes ``V = m / rho0``, the field ``V0``: the solver reads rho0 only through them;
clamped: no attraction at the free surface). Per step, with
``a_ext`` = gravity and the non-pressure accelerations already in ``state.fluid["a"]``:

1. inertial prediction ``s = x + dt v + dt^2 a_ext`` (the start of the iteration, ``X = s``);
2. local/global iterations (paper Sec. 3-4), at least ``min_iterations``, at most
   ``max_iterations``:

   * **local step** (:func:`_local_step`): every constraint i projects its own copy of the
     positions of i and its fluid neighbours, starting from X, onto ``C_i = 0`` by Newton steps
     ``p_k += nfn_k c grad_k C_i`` with ``c = -C_i / (sum_k |grad_k C_i|^2 + 1e-6)`` until
     ``|C_i| <= 1e-14`` (at most 100 steps; SPlisHSPlasH's projection), where
     ``grad_j C_i = -V_j grad W_ij``, ``grad_i C_i = sum_j V_j grad W_ij + sum_b V_b grad W_ib``
     (boundary particles are not moved) and ``nfn_k`` is the number of fluid neighbours of k
     plus one (SPlisHSPlasH's relaxation: each particle's projections are averaged over its
     ``nfn`` constraints in the global step, so each is scaled up by that many);
   * **global step**: the projective-dynamics system
     ``(M + dt^2 k S) X = M s + dt^2 k sum_c p^c`` with the masses M, the stiffness k
     [N/m] (SPlisHSPlasH ``stiffness``) and ``S = diag(nfn)`` (every particle is in ``nfn``
     constraints: its own and each neighbour's), solved by the shared matrix-free
     preconditioned CG (:func:`sphkit.core.krylov.cg`, Jacobi preconditioner) from the last X,
     as SPlisHSPlasH solves it with Eigen's CG and its diagonal preconditioner (the matrix is
     diagonal, so one CG iteration solves it);
   * the loop ends, after at least ``min_iterations`` (:class:`sphkit.core.solver.
     IterationControl`), at the first iteration whose global solve reaches the relative
     residual ``|b - A X| / |b| <= tolerance`` (SPlisHSPlasH: 1e-10) in at most one CG
     iteration. That is SPlisHSPlasH's test ``m_solver.iterations() == 0``: Eigen's CG counts an
     iteration only when it does *not* converge in it, so a solve that converges in its first
     iteration reports 0. The system being diagonal, every solve converges in one iteration,
     and SPlisHSPlasH's PF does ``minIterations + 1`` local/global iterations per step (its
     counter reports ``minIterations``; sphkit reports the iterations it did, one more);
3. velocity ``v = (X - x_old) / dt`` and ``x = X``.

PF is a soft-constraint method: the density error it keeps is set by the stiffness (larger k,
smaller compression), not by a tolerance on the density. SPlisHSPlasH's PF does not read
``maxError`` (its scenes set one); sphkit reports the density error ``mean(C_i)`` / ``max C_i``
at the final positions, but does not stop on it.

**As an acceleration.** Like :mod:`sphkit.pressure.pbf`, ``solve`` writes the effective
acceleration ``a = (X - x_old - dt v_old) / dt^2`` into ``state.fluid["a"]`` (replacing it: the
prediction already holds a_ext), so the step's ``v += dt a``, ``x += dt v`` lands on X.

**Differences from SPlisHSPlasH.** The neighbour lists are those of the step start (SPlisHSPlasH
searches again at the predicted positions s), as in sphkit's PBF; the non-pressure forces are
evaluated at the step start before the solve (SPlisHSPlasH adds them after the velocity
update); PF moves positions only, so it has no boundary pressure, and no dynamic bodies
(SPlisHSPlasH's PF does not couple them either: the registry refuses such scenes). PF has no
pressure variable: the field ``p`` stays 0.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from sphkit.core.kernels import kernel_dw, kernel_w
from sphkit.core.krylov import JacobiPreconditioner, cg
from sphkit.core.methods import PressureSolver
from sphkit.core.pairs import pair_slots, separation
from sphkit.core.projection import constraint_lambda
from sphkit.core.solver import IterationControl, SolverStats
from sphkit.core.state import SimState

_JIT = dict(cache=True, fastmath=True)

#: SPlisHSPlasH's projection of one constraint: its goal |C| and its Newton steps
_C_GOAL = 1e-14
_MAX_STEPS = 100
#: SPlisHSPlasH's regularization of sum |grad C|^2 [1/m^2]
_EPS = 1e-6


@numba.njit(parallel=True, **_JIT)
def reverse_pairs(off, idx, rev):
    """``rev[k]`` = the position of i in j's row for the pair k = (i, j) of the CSR lists
    (symmetric lists); -1 when j does not list i."""
    for i in numba.prange(off.shape[0] - 1):
        for k in pair_slots(off, i):
            j = idx[k]
            rev[k] = -1
            for kk in pair_slots(off, j):
                if idx[kk] == i:
                    rev[k] = kk
                    break


@numba.njit(parallel=True, **_JIT)
def _local_step(X, V, nfn, off, idx, bx, bV, boff, bidx, h, kid, dim, d_self, d_pair):
    """Project every constraint i (module docstring): ``d_self[:, i]`` is the displacement of
    particle i and ``d_pair[:, k]`` that of the neighbour ``idx[k]`` in constraint i's copy
    of the positions X. Returns (mean, max) of the constraints C_i at X."""
    n = X.shape[1]
    w0 = kernel_w(kid, 0.0, h, dim)
    tot = 0.0
    mx = 0.0
    for i in numba.prange(n):
        for d in range(dim):
            d_self[d, i] = 0.0
        for k in pair_slots(off, i):
            for d in range(dim):
                d_pair[d, k] = 0.0
        c0 = 0.0
        for it in range(_MAX_STEPS):
            # positions of the constraint's copy: p_i = X_i + d_self_i, p_j = X_j + d_pair_k
            pi0 = X[0, i] + d_self[0, i]
            pi1 = X[1, i] + d_self[1, i] if dim > 1 else 0.0
            pi2 = X[2, i] + d_self[2, i] if dim > 2 else 0.0
            rho = V[i] * w0
            g0 = g1 = g2 = 0.0
            sq = 0.0
            for k in pair_slots(off, i):
                j = idx[k]
                e0 = pi0 - X[0, j] - d_pair[0, k]
                e1 = pi1 - X[1, j] - d_pair[1, k] if dim > 1 else 0.0
                e2 = pi2 - X[2, j] - d_pair[2, k] if dim > 2 else 0.0
                r2 = e0 * e0 + e1 * e1 + e2 * e2
                rr = math.sqrt(r2)
                rho += V[j] * kernel_w(kid, rr, h, dim)
                f = V[j] * kernel_dw(kid, rr, h, dim)
                g0 += f * e0
                g1 += f * e1
                g2 += f * e2
                sq += f * f * r2
            for k in pair_slots(boff, i):
                b = bidx[k]
                e0, e1, e2, rr = separation(pi0, pi1, pi2, bx, b, dim, 0.0)
                rho += bV[b] * kernel_w(kid, rr, h, dim)
                f = bV[b] * kernel_dw(kid, rr, h, dim)
                g0 += f * e0
                g1 += f * e1
                g2 += f * e2
            c = max(rho - 1.0, 0.0)
            if it == 0:
                c0 = c
            if abs(c) <= _C_GOAL:
                break
            dg = g0 * g0 + g1 * g1 + g2 * g2 + sq
            if dg == 0.0:
                break
            lam = -c / (dg + _EPS)
            si = lam * nfn[i]
            d_self[0, i] += si * g0
            if dim > 1:
                d_self[1, i] += si * g1
            if dim > 2:
                d_self[2, i] += si * g2
            for k in pair_slots(off, i):
                j = idx[k]
                pj0 = X[0, j] + d_pair[0, k]
                pj1 = X[1, j] + d_pair[1, k] if dim > 1 else 0.0
                pj2 = X[2, j] + d_pair[2, k] if dim > 2 else 0.0
                e0 = pi0 - pj0
                e1 = pi1 - pj1
                e2 = pi2 - pj2
                rr = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
                # grad_j C_i = -V_j grad W(p_i - p_j)
                f = -lam * nfn[j] * V[j] * kernel_dw(kid, rr, h, dim)
                d_pair[0, k] += f * e0
                if dim > 1:
                    d_pair[1, k] += f * e1
                if dim > 2:
                    d_pair[2, k] += f * e2
        tot += c0
        mx = max(mx, c0)
    return tot / max(n, 1), mx


@numba.njit(parallel=True, **_JIT)
def _gather(X, nfn, off, rev, d_self, d_pair, acc):
    """``acc_i = sum_c p_i^c`` over the nfn_i constraints that hold particle i: its own and
    each neighbour j's (where i is the pair ``rev[k]`` of j's row)."""
    dim = X.shape[0]
    for i in numba.prange(X.shape[1]):
        for d in range(dim):
            s = nfn[i] * X[d, i] + d_self[d, i]
            for k in pair_slots(off, i):
                kk = rev[k]
                if kk >= 0:
                    s += d_pair[d, kk]
            acc[d, i] = s


class PF(PressureSolver):
    """Projective fluids: local density-constraint projections, global CG solve."""

    name = "pf"
    uses_boundary_pressure = False  #: constraints on positions: no boundary pressure

    @classmethod
    def from_config(cls, p: Any) -> PF:
        """The PF of a scene's ``configuration.pressure`` (scene model)."""
        return cls(stiffness=p.pf_stiffness, min_iterations=p.min_iterations,
                   max_iterations=p.max_iterations, tolerance=p.pf_tolerance)

    def __init__(self, stiffness: float = 50000.0, min_iterations: int | None = None,
                 max_iterations: int = 100, tolerance: float = 1e-10) -> None:
        """``stiffness`` k [N/m] of the density constraints (SPlisHSPlasH ``stiffness``);
        ``tolerance``: the relative residual of the global step that ends the iterations."""
        if not stiffness > 0:
            raise ValueError(f"pressure.pf_stiffness: {stiffness!r}; expected a stiffness "
                             "> 0 [N/m]")
        if not tolerance > 0:
            raise ValueError(f"pressure.pf_tolerance: {tolerance!r}; expected > 0")
        if min_iterations is None:
            min_iterations = min(2, max_iterations)
        self.control = IterationControl("PF (global-step relative residual)", min_iterations,
                                        max_iterations, float(tolerance))
        self.stiffness = float(stiffness)
        self.tolerance = float(tolerance)

    def init(self, state: SimState) -> None:
        """Register p (PF has no pressure: it stays 0, for output)."""
        state.fluid.register("p")

    def solve(self, state: SimState, dt: float) -> SolverStats:
        """Local/global solve; writes the effective acceleration into ``a`` (module doc)."""
        f, b = state.fluid, state.boundary
        nl, nb = state.nl_ff, state.nl_fb
        x, v, a, V, m = f["x"], f["v"], f["a"], f["V0"], f["m"]
        n, dim = f.n, state.dim
        s = x + dt * v + dt * dt * a  # inertial prediction
        X = s.copy()
        nfn = (np.diff(nl.offsets) + 1).astype(f.dtype)
        rev = np.empty(nl.indices.shape[0], dtype=np.int64)
        reverse_pairs(nl.offsets, nl.indices, rev)
        d_self = np.empty_like(x)
        d_pair = np.empty((dim, nl.indices.shape[0]), dtype=f.dtype)
        acc = np.empty_like(x)
        w = dt * dt * self.stiffness  # [kg]
        diag = np.ascontiguousarray(np.broadcast_to(w * nfn + m, (dim, n)), dtype=np.float64)
        precond = JacobiPreconditioner(diag.ravel())
        flat_diag = diag.ravel()
        ms = (m * s).ravel()

        def matvec(u: np.ndarray, out: np.ndarray) -> None:
            np.multiply(flat_diag, u, out=out)

        residual = np.empty(dim * n)

        def sweep(k: int) -> tuple[float, float]:
            _local_step(X, V, nfn, nl.offsets, nl.indices, b["x"], b["V"], nb.offsets,
                        nb.indices, state.h, state.kid, dim, d_self, d_pair)
            _gather(X, nfn, nl.offsets, rev, d_self, d_pair, acc)
            rhs = w * acc.ravel() + ms
            matvec(X.ravel(), residual)
            bb = float(np.dot(rhs, rhs))
            r0 = float(np.linalg.norm(rhs - residual) / math.sqrt(bb)) if bb > 0 else 0.0
            xs, st = cg(matvec, rhs, X.ravel(), precond=precond, tol=self.tolerance,
                        max_iter=self.control.max_iterations, name="PF global step",
                        step=state.step)
            X[...] = xs.reshape(dim, n)
            # SPlisHSPlasH's end: the solve converged within its first CG iteration (module doc)
            done = k >= self.control.min_iterations and st.converged and st.iterations <= 1
            return (0.0, 0.0) if done else (r0, r0)

        its, _r, _rm, ok = self.control.run(sweep, state.step) if n else (0, 0.0, 0.0, True)
        # the density error at the final positions
        lam = np.empty(n, dtype=f.dtype)
        rho_hat = np.empty(n, dtype=f.dtype)
        avg, mx = constraint_lambda(X, V, np.ones(n, dtype=f.dtype), nl.offsets,
                                    nl.indices, b["x"], b["V"], nb.offsets, nb.indices,
                                    state.h, state.kid, dim, 0.0, _EPS, 0.0, lam, rho_hat)
        a[...] = (X - x - dt * v) / (dt * dt)
        f["p"] = 0.0
        return SolverStats(iterations=its, density_error_avg=avg, density_error_max=mx,
                           converged=ok)
