"""Implicit viscosity of Peer & Teschner 2016, with vorticity diffusion (survey Sec. 5.2).

Peer, Teschner 2016, "Prescribed velocity gradients for highly viscous SPH fluids with vorticity
diffusion", IEEE TVCG 23(12), as SPlisHSPlasH's ``Viscosity_Peer2016`` (2.19, viscosityMethod 4)
implements it. The paper's equation numbers could not be checked here; the formulas are those of
``reference/methods.md`` (I6) and of SPlisHSPlasH's source, written out in full.

It extends Peer et al. 2015 (see :mod:`sphkit.viscosity.peer2015` for the velocity gradient
``G_i = (1 / rho_i) sum_j m_j (v_j - v_i) (x) grad W_ij``, its decomposition ``G = R + V + S``
and the velocity reconstruction), whose target keeps the spin R unchanged, so that vorticity is
never diffused. Here the spin is replaced by a diffused one:

1. vorticity ``omega_i = curl v_i`` from ``G_i`` (``2 R_i``; one component in 2D, three in 3D);
2. vorticity diffusion: per component the sparse system

       d_i w_i - sum_j m_j W_ij w_j = xi sum_j m_j (omega_i - omega_j) W_ij,
       d_i = sum_j m_j W_ij   (fluid neighbours only),

   with ``xi = 1 - nu``, solved by the shared conjugate gradient (:func:`sphkit.core.krylov.cg`)
   with the Jacobi preconditioner ``d_i``, warm-started with ``omega``, at most
   ``max_iterations_omega`` (``viscoMaxIterOmega``, default 50) iterations, tolerance
   ``max_error_omega`` (``viscoMaxErrorOmega``, default 0.01). The matrix is a graph Laplacian
   (constants are its null space) and the right-hand side is ``xi`` times it applied to omega,
   so the solutions are ``xi omega + c``; CG keeps the d-weighted mean of its start, which sets
   ``c`` to ``(1 - xi)`` times the d-weighted mean vorticity: within the tolerance and the
   iterations CG makes, the vorticity relaxes towards its (neighbourhood) mean by ``nu``. A
   component whose solve needs no iteration keeps omega (SPlisHSPlasH's rule; it also applies
   at ``nu = 1``, where the right-hand side vanishes);
3. target ``T_i = R(w_i) + V_i + xi S_i`` (V left out where ``rho_i < rho0`` and
   ``div v_i <= 0``), ``R(w)`` the spin tensor of the vorticity w (``R(w) u = w x u / 2``);
4. velocity reconstruction from T exactly as in Peer et al. 2015 (walls in its diagonal, Jacobi
   CG, ``max_iterations`` = ``viscoMaxIter`` default 50, ``max_error`` = ``viscoMaxError`` 0.01),
   applied as ``a_i += (v_new - v_i) / dt``.

``nu`` is a dimensionless factor in [0, 1] as in Peer 2015. After :meth:`Peer2016.apply`,
``stats`` holds the velocity solve (reported per step) and ``stats_omega`` the vorticity solve.

Properties (tested): a uniform velocity is unchanged; a rigid rotation (uniform omega, zero
right-hand side of step 2) keeps its vorticity, and is preserved where the SPH gradient of the
rotation is exact; shear is removed at the rate ``nu`` per step. As in Peer 2015, linear momentum
is kept only up to the d-weighted mean of the velocity reconstruction, and ``V`` uses 1/d
(SPlisHSPlasH: 1/3 in 2D too).
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

from sphkit.core.krylov import KrylovStats
from sphkit.core.methods import NonPressureForce
from sphkit.core.state import SimState
from sphkit.core.viscous import (
    add_velocity_change,
    kernel_sum_diagonal,
    kernel_sum_matvec,
    kernel_sum_solve,
    reconstruct_velocity,
    target_gradients,
)

_JIT = dict(cache=True, fastmath=True)


@numba.njit(parallel=True, **_JIT)
def _vorticity(G, dim, omega):
    """omega_i = curl v_i from the row-major gradients G (dim * dim, N); (1 or 3, N)."""
    for i in numba.prange(G.shape[1]):
        if dim == 2:
            omega[0, i] = G[2, i] - G[1, i]
        else:
            omega[0, i] = G[7, i] - G[5, i]
            omega[1, i] = G[2, i] - G[6, i]
            omega[2, i] = G[3, i] - G[1, i]


@numba.njit(parallel=True, **_JIT)
def _add_spin(w, dim, T):
    """T_i += R(w_i), the spin tensor with R u = w x u / 2."""
    for i in numba.prange(T.shape[1]):
        if dim == 2:
            T[1, i] -= 0.5 * w[0, i]
            T[2, i] += 0.5 * w[0, i]
        else:
            T[1, i] -= 0.5 * w[2, i]
            T[2, i] += 0.5 * w[1, i]
            T[3, i] += 0.5 * w[2, i]
            T[5, i] -= 0.5 * w[0, i]
            T[6, i] -= 0.5 * w[1, i]
            T[7, i] += 0.5 * w[0, i]


class Peer2016(NonPressureForce):
    """Peer 2015's velocity reconstruction with diffused vorticity; ``nu`` dimensionless in
    [0, 1]."""

    name = "peer2016"

    @classmethod
    def from_config(cls, p: Any) -> Peer2016:
        """The Peer2016 of a material's ``viscosity`` (scene model)."""
        return cls(p.coefficient, p.max_iterations or 50, p.max_error,
                   p.max_iterations_omega or 50, p.max_error_omega)

    def __init__(self, nu: float, max_iterations: int = 50, max_error: float = 0.01,
                 max_iterations_omega: int = 50, max_error_omega: float = 0.01) -> None:
        if not 0.0 <= nu <= 1.0:
            raise ValueError(f"viscosity: {nu!r}; expected a dimensionless factor in [0, 1]")
        for its, err in ((max_iterations, max_error), (max_iterations_omega, max_error_omega)):
            if its < 1 or not 0 < err < 1:
                raise ValueError(f"viscosity: max_iterations {its!r}, max_error {err!r}; "
                                 "expected >= 1 and in (0, 1)")
        self.nu = float(nu)
        self.max_iterations = int(max_iterations)
        self.max_error = float(max_error)
        self.max_iterations_omega = int(max_iterations_omega)
        self.max_error_omega = float(max_error_omega)
        self.stats = KrylovStats()
        self.stats_omega = KrylovStats()

    def apply(self, state: SimState, dt: float) -> None:
        """Diffuse the vorticity, reconstruct the velocities and add the change to ``a``."""
        f = state.fluid
        n, dim = f.n, state.dim
        if n == 0:
            self.stats = self.stats_omega = KrylovStats()
            return
        xi = 1.0 - self.nu
        G, T = target_gradients(state, xi, spin=False)
        omega = np.empty((1 if dim == 2 else 3, n))
        _vorticity(G, dim, omega)
        x, m, nl = f["x"], f["m"], state.nl_ff
        diag = np.empty(n)
        kernel_sum_diagonal(x, m, nl.offsets, nl.indices, x, m, nl.offsets, nl.indices,
                            state.rho0, False, state.h, state.kid, dim, state.period, diag)
        rhs = np.empty_like(omega)
        for c in range(omega.shape[0]):
            kernel_sum_matvec(x, m, nl.offsets, nl.indices, diag, state.h, state.kid, dim,
                              state.period, omega[c], rhs[c])
        rhs *= xi
        w, self.stats_omega = kernel_sum_solve(state, diag, rhs, omega, self.max_error_omega,
                                               self.max_iterations_omega,
                                               "Peer 2016 vorticity diffusion")
        _add_spin(w, dim, T)
        vnew, self.stats = reconstruct_velocity(state, T, self.max_error, self.max_iterations,
                                                "Peer 2016 viscosity")
        add_velocity_change(f["v"], vnew, 1.0 / dt, f["a"], vnew, False)
