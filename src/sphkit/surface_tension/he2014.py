"""Colour-field surface tension of He et al. 2014 (survey Sec. 5.4, SPlisHSPlasH
``surfaceTensionMethod`` 3).

He, Wang, Zhang, Wang, Wang, Zhou 2014, "Robust simulation of sparsely sampled thin features in
SPH-based free surface flows", ACM TOG 34(1):7, Sec. 4 (surface energy ``E = kappa/2 int
|grad c|^2 dV`` of the smoothed colour field; the force is its negative gradient, Eqs. 5-8), as
SPlisHSPlasH implements it (``SPlisHSPlasH/SurfaceTension/SurfaceTension_He2014.cpp``):

* colour field ``c_i = sum_j (m_j/rho_j) W_ij`` (self included) ``+ sum_b V_b W_ib``
  (:func:`core.operators.color_field_cpu`);
* its gradient, normalized by the particle's own colour (thin features get a full-size
  gradient): ``grad c_i = (1/c_i) sum_j (m_j/rho_j) c_j grad W_ij`` (fluid neighbours);
* ``G_i = |grad c_i|^2`` and the force per unit mass::

      a_i += kappa / (4 rho_i) sum_j (m_j/rho_j) (G_i + G_j) grad W_ij
           + kappa_b / (4 rho_i) sum_b V_b G_i grad W_ib

The fluid pair forces ``m_i a_i = kappa/4 V_i V_j (G_i + G_j) grad W_ij`` are equal, opposite and
central (``V = m/rho``), so linear and angular momentum are conserved; inside the fluid
``G = 0`` and the force vanishes, so, unlike pure cohesion, the model holds no internal pressure
in a flat-surfaced fluid. The boundary term is SPlisHSPlasH's (boundary particles of volume V_b,
without rho0; its reaction on the static boundary is not applied).

Units: ``G`` is in 1/m^2 and ``kappa/2 G`` is an energy density, so ``kappa`` is in N in 3D
(J/m) and in J in 2D (sphkit's 2D masses are per unit depth); ``kappa_b`` likewise. ``kappa``
is a surface *energy* coefficient, not the surface tension sigma (N/m in 3D, N in 2D): for a
planar surface ``sigma = kappa/2 int (dc/dz)^2 dz``, which grows like 1/h as the colour field
sharpens. validation/surface_tension.py reports the measured Laplace pressure of drops against
kappa.

Defaults (SPlisHSPlasH): kappa (``surfaceTension``) 0.05, kappa_b (``surfaceTensionBoundary``)
0.01.
"""

from __future__ import annotations

import numba

from sphkit.core.kernels import kernel_dw
from sphkit.core.operators import color_field_cpu, color_gradient_sum
from sphkit.core.pairs import pair_slots, point, separation
from sphkit.core.state import SimState
from sphkit.surface_tension.base import CohesionAdhesion


@numba.njit(parallel=True, cache=True, fastmath=True)
def _grad_c2_cpu(x, m, rho, c, off, idx, h, kid, dim, g2, L=0.0):
    """``g2[i] = |(1/c_i) sum_j (m_j/rho_j) c_j grad W_ij|^2``
    (:func:`sphkit.core.operators.color_gradient_sum` weighted with the colour)."""
    for i in numba.prange(x.shape[1]):
        s0, s1, s2 = color_gradient_sum(i, x, m, rho, c, off, idx, h, kid, dim, L)
        inv = 1.0 / c[i]
        g2[i] = (s0 * s0 + s1 * s1 + s2 * s2) * inv * inv


@numba.njit(inline="always", cache=True, fastmath=True)
def he_body(i, x, m, rho, g2, off, idx, bx, bV, boff, bidx, kappa, kappa_b, h, kid, dim, a,
            L=0.0):
    """Add the colour-field surface tension acceleration of fluid particle i to ``a[:, i]``."""
    xi0, xi1, xi2 = point(x, i, dim)
    gi = g2[i]
    s0 = s1 = s2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
        w = m[j] / rho[j] * (gi + g2[j]) * kernel_dw(kid, r, h, dim)
        s0 += w * d0
        s1 += w * d1
        s2 += w * d2
    b0 = b1 = b2 = 0.0
    for k in pair_slots(boff, i):
        b = bidx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, bx, b, dim, L)
        w = bV[b] * gi * kernel_dw(kid, r, h, dim)
        b0 += w * d0
        b1 += w * d1
        b2 += w * d2
    c = 0.25 / rho[i]
    a[0, i] += c * (kappa * s0 + kappa_b * b0)
    a[1, i] += c * (kappa * s1 + kappa_b * b1)
    if dim == 3:
        a[2, i] += c * (kappa * s2 + kappa_b * b2)


@numba.njit(parallel=True, cache=True, fastmath=True)
def _he_cpu(x, m, rho, g2, off, idx, bx, bV, boff, bidx, kappa, kappa_b, h, kid, dim, a, L=0.0):
    for i in numba.prange(x.shape[1]):
        he_body(i, x, m, rho, g2, off, idx, bx, bV, boff, bidx, kappa, kappa_b, h, kid, dim, a, L)


class He2014(CohesionAdhesion):
    """Colour-field surface tension of He et al. 2014 (SPlisHSPlasH "He et al. 2014").

    ``coefficient``: kappa (surface energy coefficient, see the module docstring);
    ``boundary_coefficient``: kappa_b. Registers the fluid fields ``color`` (dimensionless) and
    ``grad_c2`` (``|grad c|^2`` [1/m^2]).
    """

    name = "he2014"
    repeatable = True  #: apply adds to a (the colour fields it writes are made from x, m, rho)

    def init(self, state: SimState) -> None:
        """Register ``color`` and ``grad_c2`` on the fluid, ``V`` on the boundary."""
        super().init(state)
        state.fluid.register("color")
        state.fluid.register("grad_c2")

    def apply(self, state: SimState, dt: float) -> None:
        """Colour field, its squared gradient, then the surface tension acceleration."""
        f, b = state.fluid, state.boundary
        if f.n == 0:
            return
        if "color" not in f or "V" not in b:
            self.init(state)
        nl, nb = state.nl_ff, state.nl_fb
        color_field_cpu(f["x"], f["m"], f["rho"], nl.offsets, nl.indices, b["x"], b["V"],
                        nb.offsets, nb.indices, state.h, state.kid, state.dim, f["color"],
                        state.period)
        _grad_c2_cpu(f["x"], f["m"], f["rho"], f["color"], nl.offsets, nl.indices, state.h,
                     state.kid, state.dim, f["grad_c2"], state.period)
        _he_cpu(f["x"], f["m"], f["rho"], f["grad_c2"], nl.offsets, nl.indices, b["x"], b["V"],
                nb.offsets, nb.indices, self.coefficient, self.boundary_coefficient, state.h,
                state.kid, state.dim, f["a"], state.period)


__all__ = ["He2014", "he_body"]
