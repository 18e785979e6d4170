"""Implicit surface tension of Jeske, Westhofen, Löschner, Fernández-Fernández, Bender 2023
(survey Sec. 5.4, SPlisHSPlasH ``surfaceTensionMethod`` 4).

Jeske et al. 2023, "Implicit Surface Tension for SPH Fluid Simulation", ACM TOG 42(6), as
SPlisHSPlasH implements it (``SPlisHSPlasH/SurfaceTension/SurfaceTension_Jeske2023.cpp`` since
its official version of 2023-11-24, both code paths, with the adhesion fix of 2024-03-06; read,
re-derived and written anew here). The surface tension is a
pair cohesion evaluated at the end of the step and linearized in the new velocity u, solved
together with an optional viscosity as one linear system per step. With ``x_ij = x_i - x_j``,
``r = |x_ij|``, the particle diameter ``2r_p`` and the simulation kernel W:

* the cohesion kernel ``W_c = s min(W(r), W(2 r_p))`` (constant below one diameter) and its
  gradient ``grad W_c = s grad W_ij`` for ``r > 2 r_p`` (0 below), with the fixed factor
  ``s = 10/7`` (:data:`COHESION_SCALE`) between fluid particles (SPlisHSPlasH's plain and AVX
  builds alike, in 2D and 3D; the adhesion's kernel is unscaled);
* the density rate ``D_i = sum_j m_j (v_i - v_j) . grad W_ij`` (current velocities v);
* the first-order weight (constant during the solve, symmetric in i and j), with
  ``rho_ij = rho_i + rho_j``::

      F_ij = 2 [ W_c / rho_ij + dt grad W_c . (v_i - v_j) / rho_ij - dt W_c (D_i + D_j) / rho_ij^2 ]

  i.e. ``2 W_c / rho_ij`` at the end of the step to first order in dt;
* the accelerations, u the unknown new velocity::

      a_i = - gamma sum_j F_ij (x_ij + dt (u_i - u_j))                           (cohesion)
            - beta sum_b F_ib (x_ib + dt (u_i - v_b))                             (adhesion)
            + (1/rho_i) 2 (d + 2) mu sum_j (m_j/rho_j) ((u_i - u_j) . x_ij)
                / (r^2 + 0.01 h^2) grad W_ij                                      (viscosity)
            + (1/rho_i) 2 (d + 2) mu_b sum_b (rho0 V_b/rho_i) ((u_i - v_b) . x_ib)
                / (r^2 + 0.01 h^2) grad W_ib                                      (wall viscosity)
            - (c_x / dt) sum_j (m_j/rho_j) W_ij (u_i - u_j)                       (XSPH)

  with ``mu = nu rho0`` (``surfaceTensionViscosity`` nu [m^2/s]), ``mu_b`` likewise, the
  adhesion weight ``F_ib = ((m_i + m_b)/m_i) [W_c/rho_ib + dt grad W_c . (v_i - v_b)/rho_ib - dt
  W_c D_i / rho_ib^2]`` (s = 1) of a boundary particle of mass ``m_b = rho0 V_b``, density rho0
  and velocity v_b (its end-of-step position ``x_b + dt v_b``), and
  the XSPH factor c_x (``surfaceTensionXSPH``; SPlisHSPlasH's cubic kernel). Backward Euler,
  ``u = v + dt a(u)``, gives the linear system ``A u = b``::

      (A u)_i = u_i + dt^2 gamma sum_j F_ij (u_i - u_j) + dt^2 beta sum_b F_ib u_i
                - (dt / rho_i) (viscosity and XSPH terms in u)
      b_i = v_i - dt gamma sum_j F_ij x_ij - dt beta sum_b F_ib (x_ib - dt v_b)
            + (wall viscosity in v_b)

  solved matrix-free by the shared conjugate gradient (:func:`sphkit.core.krylov.cg`, block
  Jacobi preconditioner of the per-particle diagonal blocks) to the relative residual
  ``maxError`` (default 1e-3) in at most ``maxIter`` (100) iterations, warm-started with
  ``v + du_prev`` (the previous step's velocity change, field ``jeske_dv``); the result is
  applied as ``a_i += (u_i - v_i) / dt``.

At rest (v = 0, rho = rho0) the cohesion is the pair force ``gamma m (W_c(r) / rho0) x_ij``,
i.e. Becker & Teschner 2007's cohesion with ``kappa = s gamma / rho0`` (the same clamp of the
kernel at one diameter): its Kirkwood-Buff tension and internal pressure are
:meth:`sphkit.surface_tension.becker2007.BeckerTeschner2007.equivalent_sigma` of that kappa
(:meth:`Jeske2023.equivalent_sigma`). The cohesion pair forces are equal and opposite (F_ij =
F_ji) for equal masses, so momentum is conserved up to the CG tolerance.

Units: gamma in kg/s^2 = N/m in 3D (``F x`` is in m/kg), kg/(m s^2) in 2D with sphkit's
per-depth masses; beta likewise; nu, nu_b in m^2/s.

Differences from SPlisHSPlasH (documented, none changes a default run):

* boundaries: sphkit's boundaries all reach the force as boundary particles (Akinci 2012
  particles, or the virtual particles of density/volume maps), and the adhesion and wall
  viscosity act on them. SPlisHSPlasH applies the adhesion only with volume maps (Bender 2019;
  its Akinci 2012 and density-map loops add nothing) and its wall viscosity on volume and
  density maps samples four tangential points per map neighbour.

Defaults (SPlisHSPlasH, ``reference/methods.md`` K5): gamma (``surfaceTension``) 0.05, beta
(``surfaceTensionBoundary``) 0.01, nu (``surfaceTensionViscosity``) 0, nu_b 0, maxIter 100,
maxError 0.001, XSPH 0.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from sphkit.core.kernels import CUBIC, kernel_dw, kernel_w
from sphkit.core.krylov import BlockJacobiPreconditioner, KrylovStats, cg
from sphkit.core.methods import NonPressureForce
from sphkit.core.operators import kirkwood_buff
from sphkit.core.pairs import delta, delta2, delta2_r, dot, pair_slots, point
from sphkit.core.params import checked_number
from sphkit.core.state import SimState
from sphkit.core.viscous import (
    add_velocity_change,
    laplacian_diagonal_pair,
    laplacian_factor,
    laplacian_pair,
    outer_add,
    write_blocks,
)

_JIT = dict(cache=True, fastmath=True)
EPS = 0.01  #: the Laplacian's regularisation, times h^2
#: s: the factor of the cohesion kernel and its gradient between fluid particles (module
#: docstring; SPlisHSPlasH's code applies it in every dimension, the adhesion excluded)
COHESION_SCALE = 10.0 / 7.0


@numba.njit(parallel=True, **_JIT)
def _density_rate(x, v, m, off, idx, h, kid, dim, L, out):
    """``D_i = sum_j m_j (v_i - v_j) . grad W_ij``."""
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        vi0, vi1, vi2 = point(v, i, dim)
        s = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2, w0, w1, w2, r = delta2_r(xi0, xi1, xi2, x, vi0, vi1, vi2, v, j, dim, L)
            s += m[j] * dot(w0, w1, w2, d0, d1, d2) * kernel_dw(kid, r, h, dim)
        out[i] = s


@numba.njit(**_JIT)
def _weight(W, dW, r, w0, w1, w2, d0, d1, d2, rho_ij, drate, wmin, diam, dt):
    """``W_c / rho_ij + dt grad W_c . (v_i - v_j) / rho_ij - dt W_c D / rho_ij^2`` (without
    the factor 2, resp. (m_i + m_b)/m_i) from the pair's kernel value ``W`` and ``dW = W'(r) /
    r``; ``w`` = v_i - v_j, ``d`` = x_ij, ``D`` the summed density rates."""
    wc = min(W, wmin)
    g = 0.0
    if r > diam:
        g = dW * dot(w0, w1, w2, d0, d1, d2)
    return wc / rho_ij + dt * g / rho_ij - dt * wc * drate / (rho_ij * rho_ij)


@numba.njit(parallel=True, **_JIT)
def _weights(x, v, m, rho, drate, off, idx, bx, bv, boff, bidx, rho0, wmin, diam, dt, h, kid,
             dim, L, cf, xsph, F, Fb, Fsum, Fbsum, Sv, Sx):
    """The per-pair weights ``F_ij`` (in neighbour-list order) and ``F_ib``, and their sums per
    particle (the diagonal of the cohesion and adhesion terms); with them the velocity-free
    factors of the viscosity and XSPH pair terms, constant during the solve: ``Sv[k] = cf m_j /
    rho_j W'(r) / (r (r^2 + eps))`` (the projected Laplacian's,
    :func:`sphkit.core.viscous.laplacian_diagonal_pair`) and ``Sx[k] = xsph m_j / rho_j
    W_cubic(r) rho_i / dt`` (an empty Sv or Sx is not written: the term is off)."""
    eps = EPS * h * h
    visc = Sv.shape[0] > 0
    xs = Sx.shape[0] > 0
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        vi0, vi1, vi2 = point(v, i, dim)
        s = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2, w0, w1, w2, r = delta2_r(xi0, xi1, xi2, x, vi0, vi1, vi2, v, j, dim, L)
            dW = kernel_dw(kid, r, h, dim)  # W'(r) / r, for the weight and the viscosity
            F[k] = 2.0 * COHESION_SCALE * _weight(kernel_w(kid, r, h, dim), dW, r, w0, w1, w2,
                                                  d0, d1, d2, rho[i] + rho[j],
                                                  drate[i] + drate[j], wmin, diam, dt)
            s += F[k]
            if visc:
                Sv[k] = laplacian_factor(cf * m[j] / rho[j], r * r, eps, dW)
            if xs:
                Sx[k] = xsph * m[j] / rho[j] * kernel_w(CUBIC, r, h, dim) * rho[i] / dt
        Fsum[i] = s
        sb = 0.0
        for k in pair_slots(boff, i):
            b = bidx[k]
            d0, d1, d2, w0, w1, w2, r = delta2_r(xi0, xi1, xi2, bx, vi0, vi1, vi2, bv, b, dim,
                                                 L)
            # times (m_i + m_b) / m_i in _scale_boundary (needs V_b)
            Fb[k] = _weight(kernel_w(kid, r, h, dim), kernel_dw(kid, r, h, dim), r, w0, w1,
                            w2, d0, d1, d2, rho[i] + rho0, drate[i], wmin, diam, dt)
            sb += Fb[k]
        Fbsum[i] = sb


@numba.njit(parallel=True, **_JIT)
def _scale_boundary(m, bV, boff, bidx, rho0, Fb, Fbsum):
    """``F_ib *= (m_i + rho0 V_b) / m_i`` and the sums again."""
    for i in numba.prange(m.shape[0]):
        s = 0.0
        for k in pair_slots(boff, i):
            Fb[k] *= (m[i] + rho0 * bV[bidx[k]]) / m[i]
            s += Fb[k]
        Fbsum[i] = s


@numba.njit(parallel=True, **_JIT)
def _matvec(x, rho, off, idx, bx, bV, boff, bidx, F, Fsum, Fbsum, Sv, Sx, u, gamma, beta, cb,
            rho0, dt, h, kid, dim, L, out):
    """``out = A u`` (module docstring) for (dim, N) views u, out; the viscosity and XSPH pair
    terms through their factors Sv, Sx of :func:`_weights` (empty: the term is off)."""
    eps = EPS * h * h
    visc = Sv.shape[0] > 0
    xs = Sx.shape[0] > 0
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        ui0, ui1, ui2 = point(u, i, dim)
        c = dt * dt * (gamma * Fsum[i] + beta * Fbsum[i])
        o0 = ui0 * (1.0 + c)
        o1 = ui1 * (1.0 + c)
        o2 = ui2 * (1.0 + c)
        a0 = a1 = a2 = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            g = dt * dt * gamma * F[k]
            o0 -= g * u[0, j]
            o1 -= g * u[1, j]
            if dim == 3:
                o2 -= g * u[2, j]
            if visc or xs:
                d0, d1, d2, w0, w1, w2 = delta2(xi0, xi1, xi2, x, ui0, ui1, ui2, u, j, dim, L)
                if visc:
                    s = Sv[k] * dot(w0, w1, w2, d0, d1, d2)
                    a0 += s * d0
                    a1 += s * d1
                    a2 += s * d2
                if xs:
                    t = Sx[k]
                    a0 -= t * w0
                    a1 -= t * w1
                    a2 -= t * w2
        if cb > 0.0:
            for k in pair_slots(boff, i):
                b = bidx[k]
                d0, d1, d2 = delta(xi0, xi1, xi2, bx, b, dim, L)
                r2 = dot(d0, d1, d2, d0, d1, d2)
                s = cb * rho0 * bV[b] / rho[i] * laplacian_pair(kid, ui0, ui1, ui2, d0, d1, d2,
                                                                r2, eps, h, dim, 1.0)
                a0 += s * d0
                a1 += s * d1
                a2 += s * d2
        f = dt / rho[i]
        out[0, i] = o0 - f * a0
        out[1, i] = o1 - f * a1
        if dim == 3:
            out[2, i] = o2 - f * a2


@numba.njit(parallel=True, **_JIT)
def _rhs_blocks(x, v, rho, off, idx, bx, bv, bV, boff, bidx, F, Fb, Fsum, Fbsum, Sv, Sx, gamma,
                beta, cb, rho0, dt, h, kid, dim, L, rhs, blocks):
    """``rhs = b`` and the diagonal blocks of A (module docstring); the viscosity and XSPH
    diagonals from the pair factors Sv, Sx of :func:`_weights` (empty: the term is off)."""
    eps = EPS * h * h
    visc = Sv.shape[0] > 0
    xsph = Sx.shape[0] > 0
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        g00 = g01 = g02 = g11 = g12 = g22 = 0.0
        b0 = b1 = b2 = 0.0
        xs = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2 = delta(xi0, xi1, xi2, x, j, dim, L)
            b0 += gamma * F[k] * d0
            b1 += gamma * F[k] * d1
            b2 += gamma * F[k] * d2
            if visc:
                g00, g01, g02, g11, g12, g22 = outer_add(Sv[k], d0, d1, d2, g00, g01, g02, g11,
                                                         g12, g22)
            if xsph:
                xs += Sx[k]
        c0 = c1 = c2 = 0.0
        for k in pair_slots(boff, i):
            b = bidx[k]
            d0, d1, d2 = delta(xi0, xi1, xi2, bx, b, dim, L)
            vb0, vb1, vb2 = point(bv, b, dim)
            # the boundary particle's end-of-step position: x_ib - dt v_b
            b0 += beta * Fb[k] * (d0 - dt * vb0)
            b1 += beta * Fb[k] * (d1 - dt * vb1)
            b2 += beta * Fb[k] * (d2 - dt * vb2)
            if cb > 0.0:
                r2 = dot(d0, d1, d2, d0, d1, d2)
                s = laplacian_diagonal_pair(cb * rho0 * bV[b] / rho[i], r2, eps, kid, h, dim)
                g00, g01, g02, g11, g12, g22 = outer_add(s, d0, d1, d2, g00, g01, g02, g11,
                                                         g12, g22)
                t = s * dot(vb0, vb1, vb2, d0, d1, d2)
                c0 += t * d0
                c1 += t * d1
                c2 += t * d2
        f = dt / rho[i]
        diag = 1.0 + dt * dt * (gamma * Fsum[i] + beta * Fbsum[i]) + f * xs
        rhs[0, i] = v[0, i] - dt * b0 - f * c0
        rhs[1, i] = v[1, i] - dt * b1 - f * c1
        if dim == 3:
            rhs[2, i] = v[2, i] - dt * b2 - f * c2
        write_blocks(blocks, i, diag, f, g00, g01, g02, g11, g12, g22, dim)


def _nonneg(what: str, value: Any, unit: str) -> float:
    return checked_number(f"surface tension (jeske2023): {what}", value,
                          expected=f"a finite number >= 0 {unit}")


class Jeske2023(NonPressureForce):
    """Implicit surface tension (cohesion, adhesion, viscosity) of Jeske et al. 2023.

    ``coefficient``: gamma (SPlisHSPlasH ``surfaceTension``); ``boundary_coefficient``: beta
    (``surfaceTensionBoundary``); ``viscosity``, ``boundary_viscosity``: nu, nu_b [m^2/s]
    (``surfaceTensionViscosity``, ``...Boundary``); ``xsph`` (``surfaceTensionXSPH``);
    ``max_iterations``, ``max_error`` (``surfaceTensionMaxIter``, ``surfaceTensionMaxError``).
    After :meth:`apply`, ``stats`` holds the CG iterations and residual of the step.
    """

    name = "jeske2023"

    @classmethod
    def from_config(cls, p: Any) -> Jeske2023:
        """The Jeske2023 of a material's ``surface_tension`` (scene model)."""
        j = p.jeske2023
        return cls(p.coefficient, p.boundary_coefficient, viscosity=j.viscosity,
                   boundary_viscosity=j.boundary_viscosity, xsph=j.xsph,
                   max_iterations=j.max_iterations, max_error=j.max_error)

    def __init__(self, coefficient: float = 0.05, boundary_coefficient: float = 0.01, *,
                 viscosity: float = 0.0, boundary_viscosity: float = 0.0, xsph: float = 0.0,
                 max_iterations: int = 100, max_error: float = 1e-3) -> None:
        self.coefficient = _nonneg("coefficient", coefficient, "(gamma)")
        self.boundary_coefficient = _nonneg("boundary_coefficient", boundary_coefficient,
                                            "(beta)")
        self.viscosity = _nonneg("viscosity", viscosity, "[m^2/s]")
        self.boundary_viscosity = _nonneg("boundary_viscosity", boundary_viscosity, "[m^2/s]")
        self.xsph = _nonneg("xsph", xsph, "(dimensionless)")
        if int(max_iterations) != max_iterations or max_iterations < 1:
            raise ValueError(f"surface tension (jeske2023): max_iterations: {max_iterations!r};"
                             " expected an integer >= 1")
        self.max_iterations = int(max_iterations)
        if not (math.isfinite(float(max_error)) and float(max_error) > 0.0):
            raise ValueError(f"surface tension (jeske2023): max_error: {max_error!r}; expected "
                             "a relative residual > 0")
        self.max_error = float(max_error)
        self.stats = KrylovStats()

    def equivalent_sigma(self, rho0: float, mass: float, r: float, h: float, kid: int,
                         dim: int) -> tuple[float, float]:
        """(sigma, p_int) of the cohesion at rest: Becker & Teschner 2007's Kirkwood-Buff
        values for ``kappa = COHESION_SCALE gamma / rho0`` (module docstring)."""

        n = rho0 / mass
        diam = 2.0 * r
        wmin = float(kernel_w(kid, diam, h, dim))

        def f(s: float) -> float:  # attractive pair force magnitude [N]: m gamma W_c s / rho0
            return (COHESION_SCALE * self.coefficient / rho0 * mass
                    * min(float(kernel_w(kid, s, h, dim)), wmin) * s)

        brk = [diam, 0.5 * h]
        return kirkwood_buff(f, n, h, brk, dim)

    def init(self, state: SimState) -> None:
        """Register the warm-start field ``jeske_dv`` and the boundary fields read."""
        if state.dim not in (2, 3):
            raise ValueError(
                f"surface tension (jeske2023): dimension {state.dim}; expected 2 or 3")
        state.fluid.register("jeske_dv", "vector")
        for name, kind in (("V", "scalar"), ("v", "vector")):
            if name not in state.boundary:
                state.boundary.register(name, kind)

    def apply(self, state: SimState, dt: float) -> None:
        """Build and solve the implicit system, add ``(u - v) / dt`` to ``a``."""
        f, b = state.fluid, state.boundary
        n, dim = f.n, state.dim
        if n == 0:
            self.stats = KrylovStats()
            return
        if "jeske_dv" not in f:
            self.init(state)
        x, v, m, rho = f["x"], f["v"], f["m"], f["rho"]
        nl, nb = state.nl_ff, state.nl_fb
        h, kid, L, rho0 = state.h, state.kid, state.period, state.rho0
        diam = 2.0 * state.r
        wmin = float(kernel_w(kid, diam, h, dim))
        grads = state.pair_grads
        if grads is not None and state.rest().uniform:
            # this step's cached V_j grad W_ij (m_j = rho0 V_j): one multiply-add a pair
            drate = np.asarray(grads.velocity_divergence(v, fluid_only=True), np.float64)
            drate *= rho0  # float64 as the model's own pass (one compiled signature)
        else:
            drate = np.empty(n)
            _density_rate(x, v, m, nl.offsets, nl.indices, h, kid, dim, L, drate)
        c = 2.0 * (dim + 2)
        cf, cb = c * self.viscosity * rho0, c * self.boundary_viscosity * rho0
        npairs = nl.indices.shape[0]
        F = np.empty(npairs)
        Fb = np.empty(nb.indices.shape[0])
        Fsum, Fbsum = np.empty(n), np.empty(n)
        Sv = np.empty(npairs if cf > 0.0 else 0)
        Sx = np.empty(npairs if self.xsph > 0.0 else 0)
        _weights(x, v, m, rho, drate, nl.offsets, nl.indices, b["x"], b["v"], nb.offsets,
                 nb.indices, rho0, wmin, diam, dt, h, kid, dim, L, cf, self.xsph, F, Fb, Fsum,
                 Fbsum, Sv, Sx)
        _scale_boundary(m, b["V"], nb.offsets, nb.indices, rho0, Fb, Fbsum)
        gamma, beta = self.coefficient, self.boundary_coefficient
        rhs = np.empty((dim, n))
        blocks = np.empty((dim, dim, n))
        _rhs_blocks(x, v, rho, nl.offsets, nl.indices, b["x"], b["v"], b["V"], nb.offsets,
                    nb.indices, F, Fb, Fsum, Fbsum, Sv, Sx, gamma, beta, cb, rho0, dt, h, kid,
                    dim, L, rhs, blocks)

        def matvec(u: np.ndarray, out: np.ndarray) -> None:
            _matvec(x, rho, nl.offsets, nl.indices, b["x"], b["V"], nb.offsets, nb.indices, F,
                    Fsum, Fbsum, Sv, Sx, u.reshape(dim, n), gamma, beta, cb, rho0, dt, h, kid,
                    dim, L, out.reshape(dim, n))

        dv = f["jeske_dv"]
        x0 = (v + dv).ravel()
        sol, self.stats = cg(matvec, rhs.ravel(), x0, precond=BlockJacobiPreconditioner(blocks),
                             tol=self.max_error, max_iter=self.max_iterations,
                             name="Jeske 2023 surface tension", step=state.step)
        add_velocity_change(v, sol.reshape(dim, n), 1.0 / dt, f["a"], dv, True)


__all__ = ["COHESION_SCALE", "Jeske2023"]
