"""Viscosity between unlike phases (scene ``interfaces[].viscosity``, method ``morris1997``).

Morris, Fox & Zhu 1997, "Modeling low Reynolds number incompressible flows using SPH", J.
Comput. Phys. 136, Eq. (8), the SPH Laplacian of a fluid of variable viscosity, restricted to
the pairs of particles of *different* phases:

    a_i += sum_{j: phase_j != phase_i} m_j 2 mu_ij (x_ij . grad_i W_ij)
                                       / (rho_i rho_j (|x_ij|^2 + eps h^2)) v_ij

with ``v_ij = v_i - v_j``, the current densities rho (number densities of the phase model),
``eps`` = ``laplacian_eps`` (Morris' 0.01) and the pair's dynamic viscosity ``mu_ij`` the
harmonic mean of the two sides' dynamic viscosities ``mu_a = rho0_a nu_ab``, ``mu_b = rho0_b
nu_ab`` (the inter-phase form of Cleary 1998 and Hu & Adams 2006, J. Comput. Phys. 213, Eq.
(9): it keeps the shear stress continuous across the interface)::

    mu_ij = 2 mu_a mu_b / (mu_a + mu_b) = 2 nu_ab rho0_a rho0_b / (rho0_a + rho0_b)

where ``nu_ab`` [m^2/s] is the interface's ``coefficient`` (for equal rest densities mu_ij =
rho0 nu_ab, Morris' ``(mu_i + mu_j) / 2``). Morris writes ``(mu_i + mu_j)`` where this is
``2 mu_ij``.

Properties: the pair coefficient ``m_i m_j 2 mu_ij (x_ij . grad W_ij) / (rho_i rho_j (...))``
is symmetric in i and j and multiplies ``v_ij``, so the pair forces are antisymmetric and
linear momentum is conserved to round-off; ``x_ij . grad_i W_ij = r W'(r) <= 0``, so each pair
only damps its relative velocity (the kinetic energy of the pair decreases); it vanishes for
uniform motion (Galilean invariant). Pairs within one phase are left to each material's own
viscosity (:class:`sphkit.multiphase.PhaseForce`), walls to the materials' boundary viscosity:
this force only couples the phases. Explicit: stable for about ``dt < 0.125 dx^2 rho / mu``
(Morris 1997, Eq. 23, his smoothing length ~ the spacing dx = 2r; ``rho / mu = 1 / nu_ab`` for
equal densities), and the time step is bounded by it for the largest ``nu_ab``
(:meth:`Morris1997.max_time_step`; without the bound two materials with nu = 0.01 m^2/s at
r = 5 mm, whose bound is 1.25 ms, grew velocities of 2 m/s from rest within 0.1 s at 2 ms).

Several interfaces: one force holds the ``(P, P)`` table of ``nu_ab`` over the materials of the
scene (0: no viscosity between those two), indexed by the particle field ``phase``.
"""

from __future__ import annotations

import math
from typing import Any

import numba

from sphkit.backend import launch
from sphkit.core.kernels import kernel_dw
from sphkit.core.methods import NonPressureForce
from sphkit.core.pairs import add_vector, delta2, dot, pair_slots, point
from sphkit.core.state import SimState
from sphkit.core.viscous import viscous_time_step
from sphkit.multiphase.phases import pair_table


@numba.njit(cache=True, fastmath=True, inline="always")
def interface_viscosity_body(i, x, v, m, rho, rho0, phase, off, idx, nu, eps, h, kid, dim, L,
                             a):
    """Particle i's viscous acceleration from its neighbours of other phases (module
    docstring); ``nu`` (P, P) kinematic viscosities [m^2/s] by phase."""
    xi0, xi1, xi2 = point(x, i, dim)
    vi0, vi1, vi2 = point(v, i, dim)
    pi = phase[i]
    ri = rho[i]
    r0i = rho0[i]
    e = eps * h * h
    acc0 = acc1 = acc2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        pj = phase[j]
        if pj == pi:
            continue
        nuij = nu[pi, pj]
        if nuij == 0.0:
            continue
        d0, d1, d2, w0, w1, w2 = delta2(xi0, xi1, xi2, x, vi0, vi1, vi2, v, j, dim, L)
        r2 = dot(d0, d1, d2, d0, d1, d2)
        mu = 2.0 * nuij * r0i * rho0[j] / (r0i + rho0[j])  # harmonic mean of rho0 nu
        # x_ij . grad_i W_ij = r^2 W'(r) / r
        s = (2.0 * mu * m[j] / (ri * rho[j]) * r2 * kernel_dw(kid, math.sqrt(r2), h, dim)
             / (r2 + e))
        acc0 += s * w0
        acc1 += s * w1
        acc2 += s * w2
    add_vector(a, i, dim, acc0, acc1, acc2)


class Morris1997(NonPressureForce):
    """Viscosity between particles of unlike phases (module docstring).

    ``nu``: (P, P) table of kinematic viscosities [m^2/s] between the materials of the scene
    (symmetric, the diagonal unused), indexed by the fluid field ``phase``; ``eps`` the
    regularisation of ``|x_ij|^2 + eps h^2`` (dimensionless)."""

    name = "morris1997"

    @classmethod
    def from_config(cls, config: Any) -> Morris1997:
        """The force of ``(nu table, options)`` that the world builds from the scene's
        ``interfaces`` (:func:`sphkit.world.build_world`; options: an ``interfaces[].viscosity``
        with ``laplacian_eps``)."""
        nu, options = config
        return cls(nu, options.laplacian_eps)

    def __init__(self, nu: Any, eps: float = 0.01) -> None:
        self.nu = pair_table(nu, "interfaces[].viscosity.coefficient")
        if not eps > 0.0:
            raise ValueError(f"interfaces[].viscosity.laplacian_eps: {eps!r}; expected > 0")
        self.eps = float(eps)

    def max_time_step(self, state: SimState) -> float:
        """The explicit diffusion bound of Morris et al. 1997 for the largest viscosity
        between two phases."""
        return viscous_time_step(float(self.nu.max()) if self.nu.size else 0.0, state.r)

    def apply(self, state: SimState, dt: float) -> None:
        """Add the inter-phase viscous acceleration to ``state.fluid['a']``."""
        f = state.fluid
        if f.n == 0:
            return
        launch(interface_viscosity_body, f.n, f["x"], f["v"], f["m"], f["rho"], f["rho0"],
               f["phase"], state.nl_ff.offsets, state.nl_ff.indices, self.nu, self.eps,
               float(state.h), int(state.kid), int(state.dim), float(state.period), f["a"])
