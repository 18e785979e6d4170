"""Surface tension and adhesion of Akinci, Akinci & Teschner 2013 (survey Sec. 5.4,
SPlisHSPlasH ``surfaceTensionMethod`` 2).

Akinci, Akinci, Teschner 2013, "Versatile surface tension and adhesion for SPH fluids", ACM TOG
32(6):182, as SPlisHSPlasH implements it (``SPlisHSPlasH/SurfaceTension/
SurfaceTension_Akinci2013.cpp``, kernels in ``SPHKernels.h``). With ``x_ij = x_i - x_j``,
``r = |x_ij|`` and support radius h:

* surface normals (Eq. 5): ``n_i = h sum_j (m_j / rho_j) grad W_ij`` (dimensionless; zero in a
  full neighbourhood, pointing into the fluid at a surface; :func:`core.operators.
  surface_normals`);
* cohesion kernel (Eq. 2): ``C(r) = 32/(pi h^9) (h - r)^3 r^3`` for ``h/2 < r <= h``,
  ``32/(pi h^9) (2 (h - r)^3 r^3 - h^6/64)`` for ``0 < r <= h/2`` (attraction beyond h/2,
  repulsion below);
* cohesion (Eq. 1) and curvature (Eq. 6) forces with the symmetrization factor
  ``K_ij = 2 rho0 / (rho_i + rho_j)`` (Eq. 7), per unit mass::

      a_i += sum_j K_ij [ -gamma m_j C(r) x_ij / r  -  gamma (n_i - n_j) ]

* adhesion to boundary particles (Eqs. 8-9) with the adhesion kernel
  ``A(r) = 0.007 / h^3.25 (-4 r^2 / h + 6 r - 2 h)^(1/4)`` for ``h/2 < r <= h`` (else 0)::

      a_i -= beta sum_b rho0 V_b A(|x_ib|) x_ib / |x_ib|

Both fluid terms are equal and opposite for a pair (``K_ij = K_ji``), so linear momentum is
conserved to round-off; the curvature term is not central, so angular momentum is not. As in
SPlisHSPlasH the cohesion kernel keeps its 3D normalization in 2D (the paper defines it in 3D
only), and the pair cohesion term is skipped for coincident particles (``r <= 1e-9`` m).

Units: the two fluid terms give ``gamma`` different units (cohesion: ``gamma m_j C`` with C in
1/m^3 is an acceleration, so gamma is in m^4/(kg s^2); curvature: n is dimensionless, so gamma
is in m/s^2); the paper and SPlisHSPlasH use one plain number for both, as here. ``gamma`` is
therefore a model coefficient, not the physical surface tension sigma [N/m]: for a uniform fluid
with a sharp planar surface, the cohesion term alone has the Kirkwood-Buff tension and internal
pressure that :meth:`Akinci2013.cohesion_sigma` evaluates (formulas in
:mod:`sphkit.surface_tension.becker2007`); the curvature term is not a central pair force and
adds a force that depends on the normals only. validation/surface_tension.py measures the
Laplace pressure of drops and reports it against gamma. The adhesion kernel is in 1/m^3
(``0.007 h^-3.25`` times a length^(1/4)), so ``beta`` is in m^4/(kg s^2) like gamma's cohesion
part.

Defaults (SPlisHSPlasH): gamma (``surfaceTension``) 0.05, beta (``surfaceTensionBoundary``) 0.01.
"""

from __future__ import annotations

import math

import numba

from sphkit.backend import launch
from sphkit.core.operators import kirkwood_buff, surface_normals
from sphkit.core.pairs import delta, dot, pair_slots, point
from sphkit.core.state import SimState
from sphkit.surface_tension.base import CohesionAdhesion

_PI = math.pi


@numba.njit(cache=True, fastmath=True)
def cohesion_kernel(r: float, h: float) -> float:
    """Akinci et al. 2013 cohesion kernel C(r) [1/m^3] (Eq. 2; 3D normalization)."""
    if r > h:
        return 0.0
    k = 32.0 / (_PI * h**9)
    t = h - r
    v = t * t * t * r * r * r
    if r > 0.5 * h:
        return k * v
    return k * (2.0 * v - h**6 / 64.0)


@numba.njit(cache=True, fastmath=True)
def adhesion_kernel(r: float, h: float) -> float:
    """Akinci et al. 2013 adhesion kernel A(r) [1/m^3] (Eq. 9); zero for r <= h/2 and r > h."""
    if r > h or r <= 0.5 * h:
        return 0.0
    arg = -4.0 * r * r / h + 6.0 * r - 2.0 * h
    if arg <= 0.0:
        return 0.0
    return 0.007 / h**3.25 * arg**0.25


@numba.njit(inline="always", cache=True, fastmath=True)
def akinci_body(i, x, m, rho, nrm, off, idx, bx, bV, boff, bidx, gamma, beta, rho0, h, dim, a, L):
    """Add the cohesion, curvature and adhesion acceleration of fluid particle i to ``a[:, i]``
    (a kernel body, :func:`sphkit.backend.launch`)."""
    xi0, xi1, xi2 = point(x, i, dim)
    ni0, ni1, ni2 = point(nrm, i, dim)
    rhoi = rho[i]
    a0 = a1 = a2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2 = delta(xi0, xi1, xi2, x, j, dim, L)
        r2 = dot(d0, d1, d2, d0, d1, d2)
        kij = 2.0 * rho0 / (rhoi + rho[j])
        c0 = c1 = c2 = 0.0
        if r2 > 1.0e-18:
            r = math.sqrt(r2)
            s = -gamma * m[j] * cohesion_kernel(r, h) / r
            c0 = s * d0
            c1 = s * d1
            c2 = s * d2
        c0 -= gamma * (ni0 - nrm[0, j])
        c1 -= gamma * (ni1 - nrm[1, j])
        if dim == 3:
            c2 -= gamma * (ni2 - nrm[2, j])
        a0 += kij * c0
        a1 += kij * c1
        a2 += kij * c2
    for k in pair_slots(boff, i):
        b = bidx[k]
        d0, d1, d2 = delta(xi0, xi1, xi2, bx, b, dim, L)
        r2 = dot(d0, d1, d2, d0, d1, d2)
        if r2 > 1.0e-18:
            r = math.sqrt(r2)
            s = beta * rho0 * bV[b] * adhesion_kernel(r, h) / r
            a0 -= s * d0
            a1 -= s * d1
            a2 -= s * d2
    a[0, i] += a0
    a[1, i] += a1
    if dim == 3:
        a[2, i] += a2


class Akinci2013(CohesionAdhesion):
    """Surface tension (cohesion + curvature) and boundary adhesion of Akinci et al. 2013.

    ``coefficient``: gamma (cohesion and curvature, model units, see the module docstring);
    ``boundary_coefficient``: beta (adhesion to boundary particles). Registers the fluid field
    ``normal`` (dimensionless, 'vector').
    """

    name = "akinci2013"
    repeatable = True  #: apply adds to a (the normals it writes are made from x)

    def init(self, state: SimState) -> None:
        """Register ``normal`` on the fluid and the boundary volumes the adhesion term reads."""
        super().init(state)
        state.fluid.register("normal", "vector")

    def apply(self, state: SimState, dt: float) -> None:
        """Compute the normals, then add the surface tension and adhesion accelerations."""
        f, b = state.fluid, state.boundary
        if f.n == 0:
            return
        if "normal" not in f or "V" not in b:
            self.init(state)
        nl = state.nl_ff
        surface_normals(f["x"], f["m"], f["rho"], nl.offsets, nl.indices, state.h, state.h,
                        state.kid, state.dim, f["normal"], state.period)
        launch(akinci_body, f.n, f["x"], f["m"], f["rho"], f["normal"], nl.offsets, nl.indices,
               b["x"], b["V"], state.nl_fb.offsets, state.nl_fb.indices, self.coefficient,
               self.boundary_coefficient, state.rho0, state.h, state.dim, f["a"], state.period)

    def cohesion_sigma(self, rho0: float, mass: float, h: float, dim: int) -> tuple[float, float]:
        """(sigma, p_int) of the cohesion term alone for a uniform continuum of particles of
        mass ``mass`` at density ``rho0`` with a sharp planar surface (Kirkwood-Buff, as in
        :meth:`sphkit.surface_tension.becker2007.BeckerTeschner2007.equivalent_sigma`); the
        attractive pair force is ``gamma m^2 C(r)``."""
        n = rho0 / mass

        def f(s: float) -> float:
            return self.coefficient * mass * mass * float(cohesion_kernel(s, h))

        brk = [0.5 * h]
        return kirkwood_buff(f, n, h, brk, dim)


__all__ = ["Akinci2013", "adhesion_kernel", "akinci_body", "cohesion_kernel"]
