"""Implicit strain-rate viscosity of Bender & Koschier 2017 (survey Sec. 5.2).

Bender, Koschier 2017, "Divergence-free SPH for incompressible and viscous fluids", IEEE TVCG
23(3), the viscosity solver of its Sec. 5, as SPlisHSPlasH's ``Viscosity_Bender2017`` (2.19)
implements it (viscosityMethod 2). The paper's equation numbers could not be checked here; the
formulas below are the ones of ``reference/methods.md`` (I7) and of SPlisHSPlasH's source, written
out in full.

The strain rate (symmetric velocity gradient) of particle i, stored as the vector of its
independent components (3D: xx, yy, zz, xy, xz, yz; 2D: xx, yy, xy), is

    E_i(v) = 1 / (2 rho_i) sum_j m_j (v_ji (x) grad W_ij + grad W_ij (x) v_ji),   v_ji = v_j - v_i.

The viscosity prescribes the target ``E_i* = (1 - nu) E_i(v*)`` of the velocities ``v*`` the step
starts from, with a **dimensionless** factor ``nu`` in [0, 1] (0: no viscosity; 1: remove all
strain rate), and enforces the constraints ``C_i(v) = E_i(v) - E_i* = 0`` with DFSPH-style Jacobi
iterations on Lagrange multipliers (one dim(E)-vector per particle):

    lambda_i = -K_i^-1 C_i(v),
    K_i = (1 / rho_i) (sum_j B_ij B_ij^T + B_ii B_ii^T),
    B_ij = dE_i/dv_j = m_j / (2 rho_i) G(grad W_ij),   B_ii = dE_i/dv_i = -sum_j B_ij,
    v_i <- v_i - sum_j (m_j / 2) G(grad W_ij)^T ((m_j / rho_i^2) lambda_i
                                                  + (m_j / rho_j^2) lambda_j),

where ``G(g)`` is the linear map ``v -> (g (x) v + v (x) g)`` in the component order above (3D rows
``(2 g_x, 0, 0), (0, 2 g_y, 0), (0, 0, 2 g_z), (g_y, g_x, 0), (g_z, 0, g_x), (0, g_z, g_y)``). The
matrix K_i is precomputed once per step and inverted as SPlisHSPlasH does: scaled by the inverse of
its diagonal (entries below 1e-6 in magnitude count as 1), and set to zero when the determinant of
the scaled matrix is below 1e-6 (too few neighbours). Each iteration evaluates C, then applies the
impulses; the loop stops after the first iteration whose average ``|C|`` over particles and
components was below ``max_error`` (SPlisHSPlasH ``viscoMaxError``, an absolute strain rate in
1/s, default 0.01) or after ``max_iterations`` (``viscoMaxIter``, default 50). The velocity change
is applied as the acceleration ``a_i += (v_i - v*_i) / dt``. Walls (Akinci 2012 boundary
particles) only add SPlisHSPlasH's XSPH-type friction with the velocities after the iterations,

    a_i -= (0.1 nu / dt) sum_b (rho0 V_b / rho_i) (v_i - v_b) W_ib.

Properties (tested): the impulses are pairwise opposite for equal masses, so linear momentum is
conserved to round-off; a uniform velocity has ``E = 0`` and is untouched; a rigid rotation has
``E = 0`` where the neighbourhood is full (the lattice interior), so only the free surface, where
the SPH strain rate of a rotation is not zero, is affected.

Notes on the implementation as shipped by SPlisHSPlasH, kept here so that its scenes mean the same:

* ``K_i`` uses ``1 / rho_i`` where the impulses use the masses: for equal masses one iteration
  changes a particle's own constraint by ``-m C_i`` instead of ``-C_i``, i.e. the iteration is a
  Jacobi iteration relaxed by ``omega = m`` (the particle mass as a number of kg; 0.1 at
  SPlisHSPlasH's default r = 0.025 m). The damping per step therefore depends on the resolution,
  on ``dt`` and on ``max_error``/``max_iterations``: ``nu`` is a per-step strain-rate reduction
  target, not a physical viscosity (the survey notes this resolution dependence).
* The constraints outnumber the velocity unknowns (6 per particle against 3; 3 against 2 in 2D),
  and the Jacobi iteration diverges for large relaxations: measured on a lattice block, it
  converges for omega <= 0.25 and diverges from 0.3 on in 3D (in 2D from about 0.5 on). With
  SPlisHSPlasH's omega = m that is every particle heavier than about 0.25 kg (r above about
  0.034 m at rho0 = 1000 kg/m^3). sphkit therefore bounds the relaxation, ``omega = min(m_i, 0.2)``
  (:attr:`Bender2017.MAX_RELAXATION`): the same as SPlisHSPlasH's for particles up to 0.2 kg,
  stable beyond. (At equal particle radius sphkit's lattice masses are 1/0.8 of SPlisHSPlasH's,
  see the README, so its relaxation is 25 % larger there.)
* 2D: SPlisHSPlasH evaluates its 6x6 form with z = 0, where K_i is singular (its zz row is zero),
  K_i^-1 is set to zero and the viscosity does nothing; sphkit uses the three in-plane components
  (xx, yy, xy), the exact reduction of the 3D constraint to a plane flow, with the same
  ``omega = min(m_i, 0.2)`` (m_i then being a mass per unit length, so 0.2 for every particle
  radius above about 0.007 m).
"""

from __future__ import annotations

import logging
from typing import Any

import numba
import numpy as np

from sphkit.core.kernels import kernel_dw
from sphkit.core.krylov import KrylovStats
from sphkit.core.methods import NonPressureForce
from sphkit.core.pairs import add_vector, pair_slots, point, separation
from sphkit.core.state import SimState
from sphkit.core.viscous import add_velocity_change, wall_friction

log = logging.getLogger("sphkit")

_JIT = dict(cache=True, fastmath=True)

#: components of the strain-rate vector that are stored, as indices into (xx, yy, zz, xy, xz, yz)
COMPONENTS = {2: (0, 1, 3), 3: (0, 1, 2, 3, 4, 5)}


@numba.njit(inline="always", **_JIT)
def _pair_strain(w0, w1, w2, g0, g1, g2):
    """``v (x) g + g (x) v`` as (xx, yy, zz, xy, xz, yz)."""
    return (2.0 * w0 * g0, 2.0 * w1 * g1, 2.0 * w2 * g2, w0 * g1 + w1 * g0, w0 * g2 + w2 * g0,
            w1 * g2 + w2 * g1)


@numba.njit(inline="always", **_JIT)
def _g_rows(g0, g1, g2):
    """The six rows of G(g) (3D component order)."""
    return ((2.0 * g0, 0.0, 0.0), (0.0, 2.0 * g1, 0.0), (0.0, 0.0, 2.0 * g2), (g1, g0, 0.0),
            (g2, 0.0, g0), (0.0, g2, g1))


@numba.njit(inline="always", **_JIT)
def _load6(a, i, dim):
    """A stored strain-type vector of particle i as the six (xx, yy, zz, xy, xz, yz)."""
    if dim == 3:
        return a[0, i], a[1, i], a[2, i], a[3, i], a[4, i], a[5, i]
    return a[0, i], a[1, i], 0.0, a[2, i], 0.0, 0.0


@numba.njit(inline="always", **_JIT)
def _strain_sums(i, x, v, m, off, idx, h, kid, dim, L):
    """The six sums ``sum_j m_j sym((v_j - v_i) grad W_ij)`` of particle i (before the factor
    ``0.5 / rho_i``), shared by :func:`strain_rate` and :func:`_constraint`."""
    xi0, xi1, xi2 = point(x, i, dim)
    vi0, vi1, vi2 = point(v, i, dim)
    e0 = e1 = e2 = 0.0
    e3 = e4 = e5 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
        f = m[j] * kernel_dw(kid, r, h, dim)
        w0 = v[0, j] - vi0
        w1 = v[1, j] - vi1 if dim > 1 else 0.0
        w2 = v[2, j] - vi2 if dim > 2 else 0.0
        p = _pair_strain(w0, w1, w2, f * d0, f * d1, f * d2)
        e0 += p[0]
        e1 += p[1]
        e2 += p[2]
        e3 += p[3]
        e4 += p[4]
        e5 += p[5]
    return e0, e1, e2, e3, e4, e5


@numba.njit(parallel=True, **_JIT)
def strain_rate(x, v, m, rho, off, idx, h, kid, dim, L, scale, out):
    """``out_i = scale * E_i(v)`` ((nc, N), components :data:`COMPONENTS`)."""
    for i in numba.prange(x.shape[1]):
        e0, e1, e2, e3, e4, e5 = _strain_sums(i, x, v, m, off, idx, h, kid, dim, L)
        s = scale * 0.5 / rho[i]
        out[0, i] = s * e0
        out[1, i] = s * e1
        if dim == 3:
            out[2, i] = s * e2
            out[3, i] = s * e3
            out[4, i] = s * e4
            out[5, i] = s * e5
        else:
            out[2, i] = s * e3


@numba.njit(inline="always", **_JIT)
def _invert(P, Pinv, i, n):
    """Gauss-Jordan inverse of the n x n matrix P[:, :, i] into Pinv[:, :, i] (P is destroyed);
    returns the determinant (0 when a pivot vanishes)."""
    for a in range(n):
        for b in range(n):
            Pinv[a, b, i] = 1.0 if a == b else 0.0
    det = 1.0
    for c in range(n):
        piv = c
        best = abs(P[c, c, i])
        for r in range(c + 1, n):
            if abs(P[r, c, i]) > best:
                best = abs(P[r, c, i])
                piv = r
        if best == 0.0:
            return 0.0
        if piv != c:
            det = -det
            for b in range(n):
                t = P[c, b, i]
                P[c, b, i] = P[piv, b, i]
                P[piv, b, i] = t
                t = Pinv[c, b, i]
                Pinv[c, b, i] = Pinv[piv, b, i]
                Pinv[piv, b, i] = t
        p = P[c, c, i]
        det *= p
        inv = 1.0 / p
        for b in range(n):
            P[c, b, i] *= inv
            Pinv[c, b, i] *= inv
        for r in range(n):
            if r != c:
                f = P[r, c, i]
                if f != 0.0:
                    for b in range(n):
                        P[r, b, i] -= f * P[c, b, i]
                        Pinv[r, b, i] -= f * Pinv[c, b, i]
    return det


@numba.njit(parallel=True, **_JIT)
def viscosity_factor(x, m, rho, off, idx, h, kid, dim, L, comp, max_relax, K, dinv, Kinv):
    """``Kinv_i = min(1, max_relax / m_i) K_i^-1`` (zero where the diagonally scaled K_i is near
    singular); K (nc, nc, N) and dinv (nc, N) are work arrays."""
    nc = comp.shape[0]
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        for a in range(nc):
            for b in range(nc):
                K[a, b, i] = 0.0
        c = 0.5 / rho[i]
        inv_rho = 1.0 / rho[i]
        s0 = s1 = s2 = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
            f = c * m[j] * kernel_dw(kid, r, h, dim)
            g0 = f * d0  # B_ij = G(g), g = m_j / (2 rho_i) grad W_ij
            g1 = f * d1
            g2 = f * d2
            s0 += g0
            s1 += g1
            s2 += g2
            rows = _g_rows(g0, g1, g2)
            for a in range(nc):
                ra = rows[comp[a]]
                for b in range(a, nc):
                    rb = rows[comp[b]]
                    K[a, b, i] += inv_rho * (ra[0] * rb[0] + ra[1] * rb[1] + ra[2] * rb[2])
        rows = _g_rows(s0, s1, s2)  # B_ii = -G(sum g): the sign cancels in B_ii B_ii^T
        for a in range(nc):
            ra = rows[comp[a]]
            for b in range(a, nc):
                rb = rows[comp[b]]
                K[a, b, i] += inv_rho * (ra[0] * rb[0] + ra[1] * rb[1] + ra[2] * rb[2])
                K[b, a, i] = K[a, b, i]
        # SPlisHSPlasH: invert D K with D = diag(1 / K_ll) (1 where |K_ll| < 1e-6), zero if its
        # determinant is below 1e-6, then K^-1 = (D K)^-1 D
        for a in range(nc):
            dinv[a, i] = 1.0 / K[a, a, i] if abs(K[a, a, i]) >= 1e-6 else 1.0
            for b in range(nc):
                K[a, b, i] *= dinv[a, i]
        det = _invert(K, Kinv, i, nc)
        if not abs(det) >= 1e-6:
            for a in range(nc):
                for b in range(nc):
                    Kinv[a, b, i] = 0.0
        else:
            cap = min(1.0, max_relax / m[i])
            for a in range(nc):
                for b in range(nc):
                    Kinv[a, b, i] *= cap * dinv[b, i]


@numba.njit(parallel=True, **_JIT)
def _constraint(x, v, m, rho, off, idx, h, kid, dim, L, target, Kinv, lam):
    """lam_i = -Kinv_i C_i(v) with C_i = E_i(v) - target_i; returns sum_i sum_c |C_i,c|."""
    nc = target.shape[0]
    err = 0.0
    for i in numba.prange(x.shape[1]):
        e0, e1, e2, e3, e4, e5 = _strain_sums(i, x, v, m, off, idx, h, kid, dim, L)
        s = 0.5 / rho[i]
        if dim == 3:
            c = (s * e0 - target[0, i], s * e1 - target[1, i], s * e2 - target[2, i],
                 s * e3 - target[3, i], s * e4 - target[4, i], s * e5 - target[5, i])
        else:
            c = (s * e0 - target[0, i], s * e1 - target[1, i], s * e3 - target[2, i],
                 0.0, 0.0, 0.0)
        ei = 0.0
        for a in range(nc):
            ei += abs(c[a])
            t = 0.0
            for b in range(nc):
                t += Kinv[a, b, i] * c[b]
            lam[a, i] = -t
        err += ei
    return err


@numba.njit(parallel=True, **_JIT)
def _impulse(x, m, rho, off, idx, h, kid, dim, L, lam, v):
    """v_i -= sum_j (m_j / 2) G(grad W_ij)^T ((m_j / rho_i^2) lam_i + (m_j / rho_j^2) lam_j)."""
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        li = _load6(lam, i, dim)
        ri2 = 1.0 / (rho[i] * rho[i])
        dv0 = dv1 = dv2 = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
            f = 0.5 * m[j] * kernel_dw(kid, r, h, dim)
            g0 = f * d0
            g1 = f * d1
            g2 = f * d2
            lj = _load6(lam, j, dim)
            ci = m[j] * ri2
            cj = m[j] / (rho[j] * rho[j])
            u0 = ci * li[0] + cj * lj[0]
            u1 = ci * li[1] + cj * lj[1]
            u2 = ci * li[2] + cj * lj[2]
            u3 = ci * li[3] + cj * lj[3]
            u4 = ci * li[4] + cj * lj[4]
            u5 = ci * li[5] + cj * lj[5]
            dv0 += 2.0 * g0 * u0 + g1 * u3 + g2 * u4
            dv1 += 2.0 * g1 * u1 + g0 * u3 + g2 * u5
            dv2 += 2.0 * g2 * u2 + g0 * u4 + g1 * u5
        add_vector(v, i, dim, -dv0, -dv1, -dv2)


class Bender2017(NonPressureForce):
    """Strain-rate viscosity; ``nu`` is a dimensionless factor in [0, 1] (see the module).

    After :meth:`apply`, ``stats`` holds the Jacobi iterations of the step and, as ``residual``,
    the average strain-rate error ``|C|`` [1/s] of the last iteration.
    """

    name = "bender2017"
    #: SPlisHSPlasH's XSPH-type wall friction factor (times nu)
    BOUNDARY_FRICTION = 0.1
    #: bound of the Jacobi relaxation, which SPlisHSPlasH's form makes m_i [kg] (see the module)
    MAX_RELAXATION = 0.2

    @classmethod
    def from_config(cls, p: Any) -> Bender2017:
        """The Bender2017 of a material's ``viscosity`` (scene model)."""
        return cls(p.coefficient, p.max_iterations or 50, p.max_error)

    def __init__(self, nu: float, max_iterations: int = 50, max_error: float = 0.01) -> None:
        if not 0.0 <= nu <= 1.0:
            raise ValueError(f"viscosity: {nu!r}; expected a dimensionless factor in [0, 1]")
        if max_iterations < 1 or not max_error > 0:
            raise ValueError(f"viscosity: max_iterations {max_iterations!r}, max_error "
                             f"{max_error!r}; expected >= 1 and > 0")
        self.nu = float(nu)
        self.max_iterations = int(max_iterations)
        self.max_error = float(max_error)
        self.stats = KrylovStats()

    def apply(self, state: SimState, dt: float) -> None:
        """Run the strain-rate iterations and add the velocity change (and wall friction) to
        ``a``."""
        f, b = state.fluid, state.boundary
        n, dim = f.n, state.dim
        if n == 0:
            self.stats = KrylovStats()
            return
        comp = np.array(COMPONENTS[dim], dtype=np.int64)
        nc = comp.shape[0]
        x, v0, m, rho = f["x"], f["v"], f["m"], f["rho"]
        nl, nb = state.nl_ff, state.nl_fb
        h, kid, L = state.h, state.kid, state.period
        v = np.array(v0, dtype=np.float64)
        K = np.empty((nc, nc, n))
        Kinv = np.empty((nc, nc, n))
        viscosity_factor(x, m, rho, nl.offsets, nl.indices, h, kid, dim, L, comp,
                         self.MAX_RELAXATION, K, np.empty((nc, n)), Kinv)
        target = np.empty((nc, n))
        strain_rate(x, v, m, rho, nl.offsets, nl.indices, h, kid, dim, L, 1.0 - self.nu, target)
        lam = np.empty((nc, n))
        it, err = 0, 0.0
        while it < self.max_iterations:
            err = _constraint(x, v, m, rho, nl.offsets, nl.indices, h, kid, dim, L, target,
                              Kinv, lam) / (nc * n)
            _impulse(x, m, rho, nl.offsets, nl.indices, h, kid, dim, L, lam, v)
            it += 1
            if err < self.max_error:
                break
        converged = err < self.max_error
        if not converged:
            log.warning("Bender 2017 viscosity: no convergence in %d iterations at step %d: "
                        "average strain-rate error %.4g 1/s (tolerance %.4g 1/s)",
                        self.max_iterations, state.step, err, self.max_error)
        self.stats = KrylovStats(it, err, converged)
        a = f["a"]
        add_velocity_change(v0, v, 1.0 / dt, a, v, False)
        if self.nu > 0.0:  # friction with the velocities after the iterations, as SPlisHSPlasH
            wall_friction(x, v, rho, b["x"], b["v"], b["V"], nb.offsets, nb.indices,
                          self.BOUNDARY_FRICTION * self.nu, state.rho0, h, kid, dim, L, 1.0 / dt,
                          a)
