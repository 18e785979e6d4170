"""Implicit viscosity of Weiler, Koschier, Brand & Bender 2018 (survey Sec. 5.2).

Weiler, Koschier, Brand, Bender 2018, "A physically consistent implicit viscosity solver for SPH
fluids", Computer Graphics Forum 37(2), as SPlisHSPlasH's ``Viscosity_Weiler2018`` implements it
(viscosityMethod 6). The equation numbers of the paper could not be checked here; the formulas
below follow ``reference/methods.md`` (I8) and SPlisHSPlasH's source, and are written out in full.

The viscous acceleration is the velocity Laplacian discretized directly (the survey's
recommendation for implicit viscosity: no strain-rate artefacts at the free surface), in the
Monaghan 2005 projected form of :mod:`sphkit.viscosity.standard` with ``mu = nu rho0``:

    a_i = (1 / rho_i) (L v)_i,
    (L v)_i = 2 (d + 2) mu sum_j (m_j / rho_j) (v_ij . x_ij) / (|x_ij|^2 + 0.01 h^2) grad W_ij
            + 2 (d + 2) mu_b sum_b (rho0 V_b / rho_i) ((v_i - v_b) . x_ib) / (|x_ib|^2 + 0.01 h^2)
              grad W_ib

(the second line is the fluid-boundary viscosity with Akinci 2012 boundary particles, wall
velocity v_b, ``mu_b = nu_b rho0``; ``0.01 h^2`` is the option ``eps`` times h^2). With density
or volume maps the boundary neighbour is one virtual particle along the wall normal standing
for the wall's whole volume V_b; as SPlisHSPlasH does (``m_tangentialDistanceFactor`` 0.5), the
wall term then takes its volume at samples 0.5 h beside it in the wall's tangent plane (four in
3D, a quarter of V_b each: ``x_b -+ 0.5 h t_1``, ``x_b -+ 0.5 h t_2``; two in 2D, half each),
so that the wall resists the fluid's sliding along it and not only its normal motion
(:func:`sphkit.core.viscous.wall_samples`; a virtual particle closer than 1e-4 h adds nothing). With
``boundary_velocity = "morris1997"`` the wall term's ``v_i - v_b`` becomes
``beta_ib (v_i - v_b)``, the no-slip wall of Morris, Fox & Zhu 1997 (J. Comput. Phys. 136,
214-226: the wall particle takes the fluid velocity extrapolated antisymmetrically across the
wall surface, ``beta = min(beta_max, 1 + d_b / d_i)``, see
:func:`sphkit.core.viscous.morris_beta`); beta depends on positions only, so the system stays
linear in v (and symmetric: beta scales the diagonal blocks). Backward Euler gives the linear
system for the new velocity

    (I - (dt / rho_i) L) v^{t+dt} = v^t - (dt / rho_i) B v_b,

where ``B v_b`` is the boundary term's v_b part moved to the right-hand side. Its matrix is
symmetric for equal particle masses (the (i, j) block is proportional to m_j / (rho_i rho_j)
times the symmetric ``grad W_ij x_ij^T``) and positive definite (``grad W_ij = W'(r)/r x_ij``
with ``W' <= 0``), so it is solved matrix-free by the shared preconditioned conjugate gradient
(:func:`sphkit.core.krylov.cg`) with the 3x3 (2x2 in 2D) block-Jacobi preconditioner of the
per-particle diagonal blocks ``I - (dt / rho_i) sum_j c_ij grad W_ij x_ij^T``. The tolerance is
SPlisHSPlasH's ``viscoMaxError`` on the relative residual ``|b - A v| / |b|`` (default 0.01), at
most ``viscoMaxIter`` iterations (100). As in SPlisHSPlasH the solve is warm-started with
``v + dv_prev``, the velocity change of the previous step (kept in the field ``weiler_dv`` so
that it follows particle reordering), and the result is applied as the acceleration
``a_i += (v^{t+dt}_i - v_i) / dt``.

The pair forces ``m_i a_i`` are antisymmetric (coefficient ``m_i m_j / (rho_i rho_j)``), so the
converged solve conserves linear momentum up to the CG tolerance. With ``configuration.periodic_x``
x differences take the minimum image. Units: ``nu`` and ``nu_boundary`` are kinematic viscosities
[m^2/s] (dynamic viscosity = nu * rho0 [Pa s]).
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

from sphkit.backend import launch
from sphkit.core import arrays
from sphkit.core.krylov import BlockJacobiPreconditioner, KrylovStats, cg
from sphkit.core.methods import NonPressureForce
from sphkit.core.pairs import delta, delta2, dot, pair_slots, point
from sphkit.core.state import SimState
from sphkit.core.viscous import (
    LAPLACIAN_EPS,
    MORRIS_BETA_MAX,
    TANGENTIAL_DISTANCE,
    add_velocity_change,
    check_wall_options,
    forget_lone,
    laplacian_diagonal_pair,
    laplacian_pair,
    outer_add,
    register_wall_fields,
    wall_pair,
    wall_samples,
    write_blocks,
)

_JIT = dict(cache=True, fastmath=True)


@numba.njit(inline="always", **_JIT)
def matvec_body(i, x, m, rho, off, idx, bx, bV, bn, bd, boff, bidx, u, cf, cb, beta_max, epsf,
                rho0, h, kid, dim, L, dt, spread, out):
    """``out[:, i] = ((I - dt/rho L) u)_i`` for (dim, N) views u, out of the flat CG vectors (a
    kernel body, :func:`sphkit.backend.launch`); ``spread`` > 0: the wall's tangential samples
    (:func:`sphkit.core.viscous.wall_samples`)."""
    eps = epsf * h * h
    xi0, xi1, xi2 = point(x, i, dim)
    ui0, ui1, ui2 = point(u, i, dim)
    a0 = a1 = a2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, w0, w1, w2 = delta2(xi0, xi1, xi2, x, ui0, ui1, ui2, u, j, dim, L)
        r2 = dot(d0, d1, d2, d0, d1, d2)
        s = cf * m[j] * laplacian_pair(kid, w0, w1, w2, d0, d1, d2, r2, eps, h, dim, rho[j])
        a0 += s * d0
        a1 += s * d1
        a2 += s * d2
    if cb > 0.0:
        for k in pair_slots(boff, i):
            b = bidx[k]
            d0, d1, d2, r2, beta = wall_pair(xi0, xi1, xi2, bx, b, bn, bd, beta_max, dim, L)
            if spread > 0.0:
                g, cd, ct = wall_samples(beta * cb * rho0 * bV[b] / rho[i], r2, spread, eps,
                                         kid, h, dim)
                s = g * cd * dot(ui0, ui1, ui2, d0, d1, d2)
                a0 += s * d0 + g * ct * ui0
                a1 += s * d1 + g * ct * ui1
                a2 += s * d2 + g * ct * ui2
                continue
            s = (beta * cb * rho0 * bV[b] / rho[i]
                 * laplacian_pair(kid, ui0, ui1, ui2, d0, d1, d2, r2, eps, h, dim, 1.0))
            a0 += s * d0
            a1 += s * d1
            a2 += s * d2
    f = dt / rho[i]
    out[0, i] = ui0 - f * a0
    if dim > 1:
        out[1, i] = ui1 - f * a1
    if dim > 2:
        out[2, i] = ui2 - f * a2


@numba.njit(inline="always", **_JIT)
def rhs_blocks_body(i, x, v, m, rho, off, idx, bx, bv, bV, bn, bd, boff, bidx, cf, cb, beta_max,
                    epsf, rho0, h, kid, dim, L, dt, spread, rhs, blocks):
    """``rhs_i = v_i - dt/rho_i B_i v_b`` and the diagonal block of the system matrix of
    particle i (a kernel body)."""
    eps = epsf * h * h
    xi0, xi1, xi2 = point(x, i, dim)
    g00 = g01 = g02 = 0.0
    g11 = g12 = g22 = 0.0
    b0 = b1 = b2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2 = delta(xi0, xi1, xi2, x, j, dim, L)
        r2 = dot(d0, d1, d2, d0, d1, d2)
        s = laplacian_diagonal_pair(cf * m[j] / rho[j], r2, eps, kid, h, dim)
        g00, g01, g02, g11, g12, g22 = outer_add(s, d0, d1, d2, g00, g01, g02, g11, g12,
                                                 g22)
    if cb > 0.0:
        for k in pair_slots(boff, i):
            b = bidx[k]
            d0, d1, d2, r2, beta = wall_pair(xi0, xi1, xi2, bx, b, bn, bd, beta_max, dim, L)
            vb0, vb1, vb2 = point(bv, b, dim)
            if spread > 0.0:
                g, cd, ct = wall_samples(beta * cb * rho0 * bV[b] / rho[i], r2, spread, eps,
                                         kid, h, dim)
                g00, g01, g02, g11, g12, g22 = outer_add(g * cd, d0, d1, d2, g00 + g * ct, g01,
                                                         g02, g11 + g * ct, g12, g22 + g * ct)
                t = g * cd * dot(vb0, vb1, vb2, d0, d1, d2)
                b0 += t * d0 + g * ct * vb0
                b1 += t * d1 + g * ct * vb1
                b2 += t * d2 + g * ct * vb2
                continue
            s = laplacian_diagonal_pair(beta * cb * rho0 * bV[b] / rho[i], r2, eps, kid, h,
                                        dim)
            g00, g01, g02, g11, g12, g22 = outer_add(s, d0, d1, d2, g00, g01, g02, g11,
                                                     g12, g22)
            t = s * dot(vb0, vb1, vb2, d0, d1, d2)
            b0 += t * d0
            b1 += t * d1
            b2 += t * d2
    f = dt / rho[i]
    rhs[0, i] = v[0, i] - f * b0
    if dim > 1:
        rhs[1, i] = v[1, i] - f * b1
    if dim > 2:
        rhs[2, i] = v[2, i] - f * b2
    write_blocks(blocks, i, 1.0, f, g00, g01, g02, g11, g12, g22, dim)


class Weiler2018(NonPressureForce):
    """Implicit Laplacian viscosity; ``nu``, ``nu_boundary`` kinematic [m^2/s].

    After :meth:`apply`, ``stats`` holds the CG iterations and relative residual of the step
    (the simulation reports them).
    """

    name = "weiler2018"

    @classmethod
    def from_config(cls, p: Any) -> Weiler2018:
        """The Weiler2018 of a material's ``viscosity`` (scene model)."""
        return cls(p.coefficient, p.boundary_coefficient, p.max_iterations or 100, p.max_error,
                   p.boundary_velocity, p.morris_beta_max, p.laplacian_eps)

    def __init__(self, nu: float, nu_boundary: float = 0.0, max_iterations: int = 100,
                 max_error: float = 0.01, boundary_velocity: str = "zero",
                 beta_max: float = MORRIS_BETA_MAX, eps: float = LAPLACIAN_EPS) -> None:
        if not (nu >= 0 and nu_boundary >= 0):
            raise ValueError(f"viscosity: {nu!r}/{nu_boundary!r}; expected non-negative values")
        if max_iterations < 1 or not max_error > 0:
            raise ValueError(f"viscosity: max_iterations {max_iterations!r}, max_error "
                             f"{max_error!r}; expected >= 1 and > 0")
        check_wall_options(boundary_velocity, beta_max, eps)
        self.eps = float(eps)
        self.nu = float(nu)
        self.nu_boundary = float(nu_boundary)
        self.boundary_velocity = boundary_velocity
        self.beta_max = float(beta_max) if boundary_velocity == "morris1997" else 0.0
        self.max_iterations = int(max_iterations)
        self.max_error = float(max_error)
        self.stats = KrylovStats()

    def init(self, state: SimState) -> None:
        """Register the warm-start field ``weiler_dv`` (last step's velocity change) and the
        boundary's wall fields (Morris wall velocity)."""
        state.fluid.register("weiler_dv", "vector")
        register_wall_fields(state.boundary)

    def apply(self, state: SimState, dt: float) -> None:
        """Solve the implicit viscosity system and add its acceleration to ``a``."""
        f, b = state.fluid, state.boundary
        n, dim = f.n, state.dim
        if n == 0 or self.nu == 0.0 and self.nu_boundary == 0.0:
            self.stats = KrylovStats()
            return
        c = 2.0 * (dim + 2)
        cf = c * self.nu * state.rho0
        cb = c * self.nu_boundary * state.rho0
        x, v, m, rho = f["x"], f["v"], f["m"], f["rho"]
        nl, nb = state.nl_ff, state.nl_fb
        register_wall_fields(b)
        bn, bd, bm = b["wall_normal"], b["wall_distance"], self.beta_max
        model = state.coupling.model
        spread = (TANGENTIAL_DISTANCE * state.h) ** 2 if (
            model is not None and model.virtual and dim > 1) else 0.0
        rhs = arrays.empty((dim, n), np.float64, like=v)
        blocks = arrays.empty((dim, dim, n), np.float64, like=v)
        launch(rhs_blocks_body, n, x, v, m, rho, nl.offsets, nl.indices, b["x"], b["v"], b["V"],
               bn, bd, nb.offsets, nb.indices, cf, cb, bm, self.eps, state.rho0, state.h,
               state.kid, dim, state.pair_period, dt, spread, rhs, blocks)

        def matvec(u: np.ndarray, out: np.ndarray) -> None:
            launch(matvec_body, n, x, m, rho, nl.offsets, nl.indices, b["x"], b["V"], bn, bd,
                   nb.offsets, nb.indices, u.reshape(dim, n), cf, cb, bm, self.eps, state.rho0,
                   state.h, state.kid, dim, state.pair_period, dt, spread,
                   out.reshape(dim, n))

        dv = f["weiler_dv"]
        forget_lone(state, dv, cb > 0.0)  # a lone particle's row: no change (its docstring)
        x0 = arrays.axpy_into(v, 1.0, dv).ravel()  # v + dv: the warm start
        sol, self.stats = cg(matvec, rhs.ravel(), x0, precond=BlockJacobiPreconditioner(blocks),
                             tol=self.max_error, max_iter=self.max_iterations,
                             name="Weiler 2018 viscosity", step=state.step)
        vnew = sol.reshape(dim, n)
        if vnew.dtype != v.dtype:
            vnew = arrays.copied(vnew, v.dtype)
        add_velocity_change(v, vnew, 1.0 / dt, f["a"], dv, True)
