"""Standard explicit viscosity (survey Sec. 5.1).

Morris, Fox & Zhu 1997, "Modeling low Reynolds number incompressible flows using SPH", J. Comput.
Phys. 136, with the vector Laplacian of Monaghan 2005 (Rep. Prog. Phys. 68, Eq. 6.xx) that
SPlisHSPlasH's ``Viscosity_Standard`` uses:

    a_i += 2 (d + 2) nu sum_j (m_j / rho_ij) (v_ij . x_ij) / (|x_ij|^2 + 0.01 h^2) grad W_ij

with kinematic viscosity nu [m^2/s] and ``rho_ij = (rho_i + rho_j) / 2``. SPlisHSPlasH uses
``m_j / rho_j``; the pair-averaged density makes the pair forces exactly antisymmetric, so linear
momentum is conserved to round-off (tested), and it equals ``m_j / rho_j`` at uniform density.
It is Galilean invariant, vanishes for rigid rotation and
conserves linear and angular momentum. Boundary particles (static or moving with velocity v_b)
contribute the same term with ``m_j / rho_j -> rho0 V_b / rho_i`` and their own ``nu_b``.
"""

from __future__ import annotations

import numba

from sphkit.core.kernels import kernel_dw
from sphkit.core.state import SimState


@numba.njit(parallel=True, cache=True, fastmath=True)
def _standard(x, v, m, rho, off, idx, bx, bv, bV, boff, bidx, nu, nub, rho0, h, kid, dim, a):
    eps = 0.01 * h * h
    c = 2.0 * (dim + 2)
    for i in numba.prange(x.shape[1]):
        acc0 = 0.0
        acc1 = 0.0
        acc2 = 0.0
        for k in range(off[i], off[i + 1]):
            j = idx[k]
            r2 = 0.0
            vx = 0.0
            for d in range(dim):
                t = x[d, i] - x[d, j]
                r2 += t * t
                vx += (v[d, i] - v[d, j]) * t
            f = kernel_dw(kid, r2 ** 0.5, h, dim)
            s = c * nu * (2.0 * m[j] / (rho[i] + rho[j])) * vx / (r2 + eps) * f
            acc0 += s * (x[0, i] - x[0, j])
            acc1 += s * (x[1, i] - x[1, j]) if dim > 1 else 0.0
            acc2 += s * (x[2, i] - x[2, j]) if dim > 2 else 0.0
        if nub > 0.0:
            for k in range(boff[i], boff[i + 1]):
                b = bidx[k]
                r2 = 0.0
                vx = 0.0
                for d in range(dim):
                    t = x[d, i] - bx[d, b]
                    r2 += t * t
                    vx += (v[d, i] - bv[d, b]) * t
                f = kernel_dw(kid, r2 ** 0.5, h, dim)
                s = c * nub * (rho0 * bV[b] / rho[i]) * vx / (r2 + eps) * f
                acc0 += s * (x[0, i] - bx[0, b])
                acc1 += s * (x[1, i] - bx[1, b]) if dim > 1 else 0.0
                acc2 += s * (x[2, i] - bx[2, b]) if dim > 2 else 0.0
        a[0, i] += acc0
        if dim > 1:
            a[1, i] += acc1
        if dim > 2:
            a[2, i] += acc2


class StandardViscosity:
    """Explicit Morris/Monaghan viscosity; ``nu`` and ``nu_boundary`` are kinematic [m^2/s]."""

    name = "standard"

    def __init__(self, nu: float, nu_boundary: float = 0.0) -> None:
        if nu < 0 or nu_boundary < 0:
            raise ValueError(f"viscosity: {nu!r}/{nu_boundary!r}; expected non-negative values")
        self.nu = float(nu)
        self.nu_boundary = float(nu_boundary)

    def apply(self, state: SimState, dt: float) -> None:
        """Add the viscous acceleration to ``state.fluid['a']``."""
        f, b = state.fluid, state.boundary
        _standard(f["x"], f["v"], f["m"], f["rho"], state.nl_ff.offsets, state.nl_ff.indices,
                  b["x"], b["v"], b["V"], state.nl_fb.offsets, state.nl_fb.indices, self.nu,
                  self.nu_boundary, state.rho0, state.h, state.kid, state.dim, f["a"])
