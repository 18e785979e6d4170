"""Implicit viscosity of Takahashi et al. 2015, in SPlisHSPlasH's improved form (survey Sec. 5.2).

Takahashi, Dobashi, Fujishiro, Nishita, Lin 2015, "Implicit formulation for SPH-based viscous
fluids", Computer Graphics Forum 34(2), as SPlisHSPlasH's ``Viscosity_Takahashi2015`` (2.19,
"Takahashi et al. 2015 (improved)", viscosityMethod 5) implements it. The paper's equation numbers
could not be checked here; the formulas are those of ``reference/methods.md`` (I4) and of
SPlisHSPlasH's source, written out in full.

The viscous acceleration is the divergence of the full viscous stress (no separate Laplacian, so
that variable viscosity and free surfaces are handled by the stress form),

    a_i(v) = sum_j m_j (sigma_i / rho_i^2 + sigma_j / rho_j^2) grad W_ij,
    sigma_i = mu (grad v_i + grad v_i^T),
    grad v_i = sum_j (m_j / rho_j) (v_j - v_i) (x) grad W_ij,

with ``mu = nu rho0`` (``nu`` kinematic [m^2/s]). Backward Euler gives ``(I - dt a) v_new = v*``.
The paper assembles this matrix, which needs the neighbours' neighbours (two rings); SPlisHSPlasH's
improvement, followed here, never forms it: a matrix-vector product is two passes over the
one-ring lists (first the stress of every particle, then the acceleration), and the system is
solved by the shared matrix-free conjugate gradient (:func:`sphkit.core.krylov.cg`). The pair
terms are symmetric in i and j, so the matrix is symmetric for equal masses and uniform density
(the weights ``m_j / rho_j`` and ``1 / rho_i^2`` differ slightly where the density varies) and
positive definite (``-a`` is the SPH form of ``-div(mu (grad v + grad v^T))``).

Differences from SPlisHSPlasH, each documented:

* The unknown is the velocity change ``dv = v_new - v*``: ``(I - dt a) dv = dt a(v*)``, the same
  system, warm-started with the previous step's change (field ``takahashi_dv``, as the Weiler 2018
  solver does). The tolerance ``max_error`` (``viscoMaxError``, default 0.01) therefore bounds the
  residual relative to the viscous change ``dt |a(v*)|``. SPlisHSPlasH starts from zero with the
  right-hand side ``v*``, so its tolerance is relative to ``|v*|``: it lets errors of up to 1 % of
  the velocity itself through, and how accurate the viscous change is depends on the frame of
  reference (adding a uniform velocity loosens the test).
* Preconditioner: the dim x dim block-Jacobi preconditioner of the system's diagonal blocks
  (SPlisHSPlasH uses none). Differentiating ``a_i`` by ``v_i`` through ``sigma_i`` and through the
  neighbours' ``sigma_j`` gives (``g = grad W_ij``, ``V_i = m_i / rho_i``)

      D_i = I + dt mu [ ((c_i . s_i) I + sym(c_i s_i^T)) / rho_i^2
                        + V_i sum_j (m_j / rho_j^2) (|g|^2 I + g g^T) ],
      c_i = sum_j (m_j / rho_j) g,   s_i = sum_j m_j g

  (``sym`` keeps the preconditioner symmetric; at uniform density ``c_i`` and ``s_i`` are
  parallel and D_i is exact, which the tests check against the matrix's columns).

Walls (Akinci 2012 boundary particles) add SPlisHSPlasH's XSPH-type friction with the velocities
the step starts from, ``a_i -= (0.1 / dt) sum_b (rho0 V_b / rho_i) (v_i - v_b) W_ib``: a fixed
factor 0.1, not scaled by the viscosity (SPlisHSPlasH's form; there is no separate wall
viscosity). The result is applied as ``a_i += dv_i / dt``.

Properties (tested): momentum is conserved up to the solver tolerance (antisymmetric pair
forces); a uniform velocity gives ``a(v*) = 0`` and stays exactly unchanged; a rigid rotation has
zero stress where the neighbourhood is full (the lattice interior), so it is damped only through
the free-surface particles; a shear wave decays like backward Euler of ``dv/dt = nu lap v``.
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

from sphkit.core.kernels import kernel_dw
from sphkit.core.krylov import BlockJacobiPreconditioner, KrylovStats, cg
from sphkit.core.methods import NonPressureForce
from sphkit.core.pairs import grad_w, pair_slots, point, separation
from sphkit.core.state import SimState
from sphkit.core.viscous import add_velocity_change, forget_lone, wall_friction

_JIT = dict(cache=True, fastmath=True)


@numba.njit(parallel=True, **_JIT)
def _stress(x, u, m, rho, off, idx, h, kid, dim, L, mu, S):
    """S_i = mu (grad u_i + grad u_i^T), symmetric, stored row-major (dim * dim, N)."""
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        ui0, ui1, ui2 = point(u, i, dim)
        g00 = g01 = g02 = 0.0
        g10 = g11 = g12 = 0.0
        g20 = g21 = g22 = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
            f = m[j] / rho[j] * kernel_dw(kid, r, h, dim)
            w0 = u[0, j] - ui0
            w1 = u[1, j] - ui1 if dim > 1 else 0.0
            w2 = u[2, j] - ui2 if dim > 2 else 0.0
            e0 = f * d0
            e1 = f * d1
            e2 = f * d2
            g00 += w0 * e0
            g01 += w0 * e1
            g02 += w0 * e2
            g10 += w1 * e0
            g11 += w1 * e1
            g12 += w1 * e2
            g20 += w2 * e0
            g21 += w2 * e1
            g22 += w2 * e2
        S[0, i] = 2.0 * mu * g00
        if dim == 2:
            S[1, i] = mu * (g01 + g10)
            S[2, i] = S[1, i]
            S[3, i] = 2.0 * mu * g11
        elif dim == 3:
            S[1, i] = mu * (g01 + g10)
            S[2, i] = mu * (g02 + g20)
            S[3, i] = S[1, i]
            S[4, i] = 2.0 * mu * g11
            S[5, i] = mu * (g12 + g21)
            S[6, i] = S[2, i]
            S[7, i] = S[5, i]
            S[8, i] = 2.0 * mu * g22


@numba.njit(parallel=True, **_JIT)
def _operator(x, u, m, rho, off, idx, h, kid, dim, L, S, dt, out):
    """out_i = u_i - dt sum_j m_j (S_i / rho_i^2 + S_j / rho_j^2) grad W_ij."""
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        ri2 = 1.0 / (rho[i] * rho[i])
        a0 = a1 = a2 = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
            f = m[j] * kernel_dw(kid, r, h, dim)
            ci = f * ri2
            cj = f / (rho[j] * rho[j])
            d = (d0, d1, d2)
            for a in range(dim):
                s = 0.0
                for b in range(dim):
                    s += (ci * S[a * dim + b, i] + cj * S[a * dim + b, j]) * d[b]
                if a == 0:
                    a0 += s
                elif a == 1:
                    a1 += s
                else:
                    a2 += s
        out[0, i] = u[0, i] - dt * a0
        if dim > 1:
            out[1, i] = u[1, i] - dt * a1
        if dim > 2:
            out[2, i] = u[2, i] - dt * a2


@numba.njit(parallel=True, **_JIT)
def _diagonal_blocks(x, m, rho, off, idx, h, kid, dim, L, mu, dt, blocks):
    """The dim x dim diagonal blocks D_i of I - dt a (see the module), (dim, dim, N)."""
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        c0 = c1 = c2 = 0.0
        s0 = s1 = s2 = 0.0
        q = q00 = q01 = 0.0
        q02 = q11 = q12 = 0.0
        q22 = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
            g0, g1, g2 = grad_w(kid, d0, d1, d2, r, h, dim)
            vj = m[j] / rho[j]
            c0 += vj * g0
            c1 += vj * g1
            c2 += vj * g2
            s0 += m[j] * g0
            s1 += m[j] * g1
            s2 += m[j] * g2
            w = m[j] / (rho[j] * rho[j])
            q += w * (g0 * g0 + g1 * g1 + g2 * g2)
            q00 += w * g0 * g0
            q01 += w * g0 * g1
            q02 += w * g0 * g2
            q11 += w * g1 * g1
            q12 += w * g1 * g2
            q22 += w * g2 * g2
        ri2 = 1.0 / (rho[i] * rho[i])
        vi = m[i] / rho[i]
        cs = c0 * s0 + c1 * s1 + c2 * s2
        t = dt * mu
        blocks[0, 0, i] = 1.0 + t * ((cs + c0 * s0) * ri2 + vi * (q + q00))
        if dim > 1:
            blocks[1, 1, i] = 1.0 + t * ((cs + c1 * s1) * ri2 + vi * (q + q11))
            o = t * (0.5 * (c0 * s1 + c1 * s0) * ri2 + vi * q01)
            blocks[0, 1, i] = o
            blocks[1, 0, i] = o
        if dim > 2:
            blocks[2, 2, i] = 1.0 + t * ((cs + c2 * s2) * ri2 + vi * (q + q22))
            o = t * (0.5 * (c0 * s2 + c2 * s0) * ri2 + vi * q02)
            blocks[0, 2, i] = o
            blocks[2, 0, i] = o
            o = t * (0.5 * (c1 * s2 + c2 * s1) * ri2 + vi * q12)
            blocks[1, 2, i] = o
            blocks[2, 1, i] = o


class Takahashi2015(NonPressureForce):
    """Implicit stress-divergence viscosity; ``nu`` kinematic [m^2/s].

    After :meth:`apply`, ``stats`` holds the CG iterations and relative residual of the step.
    """

    name = "takahashi2015"
    #: SPlisHSPlasH's XSPH-type wall friction factor (fixed, not scaled by the viscosity)
    BOUNDARY_FRICTION = 0.1

    @classmethod
    def from_config(cls, p: Any) -> Takahashi2015:
        """The Takahashi2015 of a material's ``viscosity`` (scene model)."""
        return cls(p.coefficient, p.max_iterations or 100, p.max_error)

    def __init__(self, nu: float, max_iterations: int = 100, max_error: float = 0.01) -> None:
        if not nu >= 0:
            raise ValueError(f"viscosity: {nu!r}; expected a non-negative kinematic viscosity")
        if max_iterations < 1 or not 0 < max_error < 1:
            raise ValueError(f"viscosity: max_iterations {max_iterations!r}, max_error "
                             f"{max_error!r}; expected >= 1 and in (0, 1)")
        self.nu = float(nu)
        self.max_iterations = int(max_iterations)
        self.max_error = float(max_error)
        self.stats = KrylovStats()

    def init(self, state: SimState) -> None:
        """Register the warm-start field ``takahashi_dv`` (last step's velocity change)."""
        state.fluid.register("takahashi_dv", "vector")

    def operator(self, state: SimState, dt: float):
        """The matrix-free ``matvec(u, out)``: ``out = (I - dt a) u`` for flat (dim * N) u."""
        f = state.fluid
        n, dim = f.n, state.dim
        x, m, rho = f["x"], f["m"], f["rho"]
        nl = state.nl_ff
        mu = self.nu * state.rho0
        S = np.empty((dim * dim, n))

        def matvec(u: np.ndarray, out: np.ndarray) -> None:
            uu = u.reshape(dim, n)
            _stress(x, uu, m, rho, nl.offsets, nl.indices, state.h, state.kid, dim, state.period,
                    mu, S)
            _operator(x, uu, m, rho, nl.offsets, nl.indices, state.h, state.kid, dim,
                      state.period, S, dt, out.reshape(dim, n))

        return matvec

    def diagonal_blocks(self, state: SimState, dt: float) -> np.ndarray:
        """The diagonal blocks D_i of the system matrix, (dim, dim, N)."""
        f = state.fluid
        blocks = np.empty((state.dim, state.dim, f.n))
        _diagonal_blocks(f["x"], f["m"], f["rho"], state.nl_ff.offsets, state.nl_ff.indices,
                         state.h, state.kid, state.dim, state.period, self.nu * state.rho0, dt,
                         blocks)
        return blocks

    def apply(self, state: SimState, dt: float) -> None:
        """Solve the implicit viscosity system and add its acceleration (and wall friction)."""
        f, b = state.fluid, state.boundary
        n, dim = f.n, state.dim
        if n == 0:
            self.stats = KrylovStats()
            return
        x, v, rho, a = f["x"], f["v"], f["rho"], f["a"]
        dv = f["takahashi_dv"]
        if self.nu > 0.0:
            forget_lone(state, dv, False)  # the system is the fluid's alone (walls: friction)
            matvec = self.operator(state, dt)
            v64 = np.ascontiguousarray(v, dtype=np.float64).ravel()
            rhs = np.empty_like(v64)
            matvec(v64, rhs)
            rhs = v64 - rhs  # dt a(v*)
            sol, self.stats = cg(matvec, rhs, dv.ravel(),
                                 precond=BlockJacobiPreconditioner(self.diagonal_blocks(state, dt)),
                                 tol=self.max_error, max_iter=self.max_iterations,
                                 name="Takahashi 2015 viscosity", step=state.step)
            vnew = v + sol.reshape(dim, n)
            add_velocity_change(v, vnew, 1.0 / dt, a, dv, True)
        else:
            self.stats = KrylovStats()
        nb = state.nl_fb
        wall_friction(x, v, rho, b["x"], b["v"], b["V"], nb.offsets, nb.indices,
                      self.BOUNDARY_FRICTION, state.rho0, state.h, state.kid, dim, state.period,
                      1.0 / dt, a)
