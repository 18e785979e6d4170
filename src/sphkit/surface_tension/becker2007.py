"""Cohesion surface tension of Becker & Teschner 2007 (survey Sec. 5.4, SPlisHSPlasH
``surfaceTensionMethod`` 1).

Becker & Teschner 2007, "Weakly compressible SPH for free surface flows", SCA 2007, Sec. 5
("Surface tension"), Eq. 11, as SPlisHSPlasH implements it
(``SPlisHSPlasH/SurfaceTension/SurfaceTension_Becker2007.cpp``). Cohesion between molecules is
modelled by kernel-weighted attraction between particle pairs:

    a_i = -(kappa / m_i) [ sum_j m_j x_ij W(max(|x_ij|, 2r))
                           + (kappa_b / kappa) sum_b rho0 V_b x_ib W(max(|x_ib|, 2r)) ]

with ``x_ij = x_i - x_j``, the simulation kernel W (support h) and the particle radius r. As in
SPlisHSPlasH the kernel argument is clamped at one particle diameter 2r, so pairs closer than 2r
attract no more strongly than pairs at 2r (the pressure solver keeps them apart). The fluid
pair forces ``m_i a_i = -kappa m_j x_ij W`` are equal and opposite (linear and angular momentum
are conserved); the boundary term is the adhesion of the fluid to Akinci et al. 2012 boundary
particles (psi_b = rho0 V_b), its reaction on the (static) boundary is not applied.

Units: ``kappa`` [m^d/s^2] in d dimensions (``kappa m_j W |x|`` is an acceleration), and the
same for ``kappa_b``. ``kappa`` is not the physical surface tension sigma [N/m]; for a uniform
fluid of particles of mass m at rest density rho0 (number density n = rho0/m) with a sharp
planar surface, the attractive pair force ``f(r) = kappa m r W(max(r, 2r_p))`` [N] gives the
Kirkwood-Buff tension (the energy per area of the two surfaces made by cutting the fluid)

    sigma = (pi n^2 / 8) int_0^h f r^4 dr  (3D),      sigma = (n^2 / 3) int_0^h f r^3 dr  (2D)

and, because the pairs attract across every plane inside the fluid too, an internal pressure
(minus the virial of the pair forces) ``p_int = (2 pi n^2 / 3) int f r^3 dr`` (3D),
``(pi n^2 / 2) int f r^2 dr`` (2D), which the pressure solver carries everywhere inside the
fluid (flat surfaces included). A drop of radius R at rest therefore holds ``p = p_int +
sigma/R`` (2D) or ``p_int + 2 sigma/R`` (3D) in the continuum limit;
:meth:`BeckerTeschner2007.equivalent_sigma` evaluates both integrals and validation/
surface_tension.py compares them with simulated drops.

Defaults (SPlisHSPlasH): kappa = 0.05, kappa_b = 0.01.
"""

from __future__ import annotations

import numba

from sphkit.core.kernels import kernel_w
from sphkit.core.operators import kirkwood_buff
from sphkit.core.pairs import pair_slots, point, separation
from sphkit.core.state import SimState
from sphkit.surface_tension.base import CohesionAdhesion


@numba.njit(inline="always", cache=True, fastmath=True)
def becker_body(i, x, m, off, idx, bx, bV, boff, bidx, kappa, kappa_b, diam, rho0, h, kid, dim,
                a, L=0.0):
    """Add the cohesion and boundary adhesion acceleration of fluid particle i to ``a[:, i]``."""
    xi0, xi1, xi2 = point(x, i, dim)
    w_diam = kernel_w(kid, diam, h, dim)
    s0 = s1 = s2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
        w = kernel_w(kid, r, h, dim) if r > diam else w_diam
        c = m[j] * w
        s0 += c * d0
        s1 += c * d1
        s2 += c * d2
    b0 = b1 = b2 = 0.0
    for k in pair_slots(boff, i):
        b = bidx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, bx, b, dim, L)
        w = kernel_w(kid, r, h, dim) if r > diam else w_diam
        c = rho0 * bV[b] * w
        b0 += c * d0
        b1 += c * d1
        b2 += c * d2
    inv_m = 1.0 / m[i]
    a[0, i] -= inv_m * (kappa * s0 + kappa_b * b0)
    a[1, i] -= inv_m * (kappa * s1 + kappa_b * b1)
    if dim == 3:
        a[2, i] -= inv_m * (kappa * s2 + kappa_b * b2)


@numba.njit(parallel=True, cache=True, fastmath=True)
def _becker_cpu(x, m, off, idx, bx, bV, boff, bidx, kappa, kappa_b, diam, rho0, h, kid, dim, a,
                L=0.0):
    for i in numba.prange(x.shape[1]):
        becker_body(i, x, m, off, idx, bx, bV, boff, bidx, kappa, kappa_b, diam, rho0, h, kid,
                    dim, a, L)


class BeckerTeschner2007(CohesionAdhesion):
    """Cohesion forces of Becker & Teschner 2007 (SPlisHSPlasH "Becker & Teschner 2007").

    ``coefficient``: kappa [m^d/s^2]; ``boundary_coefficient``: kappa_b [m^d/s^2] (adhesion to
    boundary particles). See the module docstring for the equivalent surface tension.
    """

    name = "becker2007"
    repeatable = True  #: apply adds to a only

    def apply(self, state: SimState, dt: float) -> None:
        """Add the cohesion (and boundary adhesion) acceleration to ``state.fluid['a']``."""
        f, b = state.fluid, state.boundary
        if f.n == 0:
            return
        if "V" not in b:
            self.init(state)
        _becker_cpu(f["x"], f["m"], state.nl_ff.offsets, state.nl_ff.indices, b["x"], b["V"],
                    state.nl_fb.offsets, state.nl_fb.indices, self.coefficient,
                    self.boundary_coefficient, 2.0 * state.r, state.rho0, state.h, state.kid,
                    state.dim, f["a"], state.period)

    def equivalent_sigma(self, rho0: float, mass: float, r: float, h: float, kid: int,
                         dim: int) -> tuple[float, float]:
        """(sigma [N/m or N], p_int [Pa]) of a uniform continuum of particles of mass ``mass``
        at density ``rho0`` with a sharp planar surface (Kirkwood-Buff; module docstring)."""
        n = rho0 / mass
        diam = 2.0 * r

        def f(s: float) -> float:  # attractive pair force magnitude [N]
            return self.coefficient * mass * s * float(kernel_w(kid, max(s, diam), h, dim))

        brk = [diam, 0.5 * h]
        return kirkwood_buff(f, n, h, brk, dim)


__all__ = ["BeckerTeschner2007", "becker_body"]
