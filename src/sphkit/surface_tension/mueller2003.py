"""Continuum surface force (CSF) surface tension of Müller, Charypar & Gross 2003 (survey
Sec. 5.4; no SPlisHSPlasH ``surfaceTensionMethod`` number).

Müller, Charypar, Gross 2003, "Particle-based fluid simulation for interactive applications",
SCA 2003, Sec. 4.4 ("Surface Tension"). The paper's equations (numbers as we read them; the
PDF was not at hand in this session to re-check them):

* (15) colour field ``c_S(x) = sum_j (m_j/rho_j) W(x - x_j)``, 1 inside the fluid;
* (16) its gradient, the (unnormalized, inward) surface normal ``n = grad c_S``;
* (17) the curvature ``kappa = -lap c_S / |n|``;
* (18) the surface traction ``t = sigma kappa n/|n|`` and
* (19) the force density ``f = sigma kappa n = -sigma lap(c_S) n/|n|``, evaluated only where
  ``|n| >= l`` (a threshold that keeps the division by |n| away from the noise of the bulk).

``sigma`` is the physical surface tension [N/m in 3D; N in 2D, where masses are per unit
depth], so a drop at rest holds the Laplace pressure ``sigma/R`` (2D) or ``2 sigma/R`` (3D).

What is implemented, and why it departs from Eqs. (17) and (19) at a free surface. Eq. (19) is
the CSF of Brackbill et al. 1992: across a *two-phase* interface ``int |n| dz = 1`` (the colour
jump) and ``int lap c dz = [dc/dz] = 0``, so integrating f across the interface gives the jump
``sigma kappa``. A free surface has no particles on the air side; the colour field is truncated
(in the continuum limit it falls from 1 to 1/2 at the fluid's edge, by the kernel's symmetry,
and the other half of its fall lies in the empty air), and two things break:

1. ``int_fluid -lap c dz = dc/dz|_edge = |n|_edge`` no longer vanishes: Eqs. (17)/(19) put a
   normal force ``sigma |n|_edge ~ sigma/h`` per area on every *flat* surface (in the continuum
   limit an inward one, an internal pressure ~ sigma/h, 5-10 times the Laplace pressure of the
   drops we validate), and the curvature ``-lap c/|n|`` of a surface particle is dominated by
   it: with the Brookshaw Laplacian of the particles' colours, tests/
   test_surface_tension_mueller.py measures ``-lap c/|n| d`` = -0.95 and -2.17 on the outer
   ring of sampled circles of R = 0.1 and 0.2 m (exact: 1), wrong in sign and growing with R.
2. ``int_fluid |n| dz = c(inside) - c(edge) = 1/2``: only half of the surface delta is carried by
   particles.

We therefore keep Eqs. (15), (16) and the force ``f = sigma kappa n`` of Eq. (19) with Müller's
``V_j = m_j/rho_j``, and change how kappa is obtained and how much of the delta is applied:

* **curvature on the surface layer.** With sphkit's support h = 4r (two particle spacings) the
  colour gradient of a free surface lives on two or three particle layers, and on the second
  layer it often points *outwards* (the surface particles' volumes m/rho are larger), so a
  per-particle ``-div(n/|n|)`` is ill-defined there. kappa is measured only on the surface layer
  proper, ``|n| h >= SURFACE`` (1.0-1.3 there, at most ~0.5 deeper), as the divergence of the
  unit normal (the geometric definition that Eq. (17) approximates when |n| is constant along
  n). Since ``n/|n|`` has unit length, its divergence is its *tangential* divergence, estimated
  by weighted least squares over the neighbours j with ``|n_j| h >= THRESHOLD`` whose normals
  are within 60 degrees of n_i (tangent basis t_k of n_i, weights ``V_j |W'_ij| / r_ij``)::

      kappa_i = -tr(M^-1 B),  M_kl = sum_j w_ij s_k s_l,  B_kl = sum_j w_ij s_k e_l,
      s_k = t_k . (x_j - x_i),  e_l = t_l . (n_j/|n_j| - n_i/|n_i|)

  clamped to ``|kappa| <= (dim - 1) KAPPA_MAX / h``. On a relaxed 2D drop this gives
  ``kappa d = 1.00 +- 0.14`` (d: the particle's distance from the centre; test and validation).
* **curvature carried into the band.** kappa is then interpolated (Shepard, two passes, i.e. up
  to 2h deep) from the surface layer to the particles below it, so that every particle of the
  band gets the curvature of *its* surface, with the surface's orientation.
* **signed delta, doubled.** The force is ``f_i = 2 sigma kappa_i n_i`` on every particle with
  ``|n_i| h >= THRESHOLD`` and a curvature. Outward-pointing n on the second layer then
  subtract, as they must: the signed sum of ``V_i n_i`` across the band is the colour drop from
  the interior to the edge, 1/2 (measured 0.50-0.51 on 2D drops), and the factor 2 restores the
  half of the surface delta that lies in the air (``int_fluid 2 |n| dz = 1`` for a flat surface
  in the continuum limit).

Acceleration ``a_i = f_i / rho_i``. The force is not a pair force: linear momentum is conserved
only as far as the discrete normals and curvatures are symmetric (a closed drop: to a small
fraction of the total surface force). There is no adhesion term (``boundary_coefficient`` must be
0); walls do not enter the colour field.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sphkit.core.kernels import kernel_dw, kernel_w
from sphkit.core.operators import surface_normals_cpu
from sphkit.core.state import SimState

#: Müller's threshold l, made dimensionless: a particle carries a force where
#: ``|n| h >= THRESHOLD`` (deep in a relaxed 2D drop ``|n| h`` is 0.13-0.25 of disorder noise
#: with random directions; those particles get no curvature unless they are within 2h of the
#: surface layer)
THRESHOLD = 0.1
#: the surface layer proper, where the curvature is measured: ``|n| h >= SURFACE`` (outermost
#: layer of a relaxed 2D drop: 0.9-1.2; second layer up to 0.5, with outward normals)
SURFACE = 0.7
#: neighbours enter a curvature only if their normal is within 60 degrees of the particle's
COS_MAX = 0.5
#: the fluid side of a free surface carries half of the colour jump (see the module docstring)
HALF_SPACE_FACTOR = 2.0
#: curvatures are clamped to ``|kappa| <= (dim - 1) KAPPA_MAX / h``: no radius of curvature
#: below h (two particle spacings) is resolved, and without the clamp single particles at the
#: corners of a sampled lattice get forces that eject them (3D drop, sigma = 5 N/m, r = 2.5 mm)
KAPPA_MAX = 1.0


@numba.njit(cache=True, fastmath=True)
def curvature_body(i, x, m, rho, n, off, idx, thr_i, thr, h, kid, dim, L=0.0):
    """``kappa_i = -div(n/|n|)`` at fluid particle i from the tangential derivatives of the unit
    normal over the neighbours with ``|n_j| >= thr`` (0 where ``|n_i| < thr`` or the neighbours
    do not span the tangent plane); see the module docstring."""
    ni0 = n[0, i]
    ni1 = n[1, i]
    ni2 = n[2, i] if dim == 3 else 0.0
    li = math.sqrt(ni0 * ni0 + ni1 * ni1 + ni2 * ni2)
    if li < thr_i:
        return 0.0
    u0 = ni0 / li
    u1 = ni1 / li
    u2 = ni2 / li
    # orthonormal tangents t (and q in 3D)
    if dim == 2:
        t0 = -u1
        t1 = u0
        t2 = 0.0
    else:
        if abs(u0) < 0.9:  # t = e_x - (e_x . u) u, normalized
            t0 = 1.0 - u0 * u0
            t1 = -u0 * u1
            t2 = -u0 * u2
        else:  # t = e_y - (e_y . u) u
            t0 = -u1 * u0
            t1 = 1.0 - u1 * u1
            t2 = -u1 * u2
        lt = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        t0 /= lt
        t1 /= lt
        t2 /= lt
    q0 = u1 * t2 - u2 * t1  # q = u x t
    q1 = u2 * t0 - u0 * t2
    q2 = u0 * t1 - u1 * t0
    xi0 = x[0, i]
    xi1 = x[1, i]
    xi2 = x[2, i] if dim == 3 else 0.0
    # weighted least squares of the tangential unit-normal components over the tangential
    # offsets: M = sum w s s^T, B = sum w s e^T (s = (t, q) . (x_j - x_i), e = (t, q) . (u_j - u_i))
    mtt = mtq = mqq = 0.0
    btt = btq = bqt = bqq = 0.0
    for k in range(off[i], off[i + 1]):
        j = idx[k]
        nj0 = n[0, j]
        nj1 = n[1, j]
        nj2 = n[2, j] if dim == 3 else 0.0
        lj = math.sqrt(nj0 * nj0 + nj1 * nj1 + nj2 * nj2)
        if lj < thr or nj0 * u0 + nj1 * u1 + nj2 * u2 < COS_MAX * lj:
            continue
        d0 = x[0, j] - xi0
        if L > 0.0:  # periodic along x: minimum image
            d0 -= L * math.floor(d0 / L + 0.5)
        d1 = x[1, j] - xi1
        d2 = x[2, j] - xi2 if dim == 3 else 0.0
        w = -m[j] / rho[j] * kernel_dw(kid, math.sqrt(d0 * d0 + d1 * d1 + d2 * d2), h, dim)
        e0 = nj0 / lj - u0
        e1 = nj1 / lj - u1
        e2 = nj2 / lj - u2
        st = t0 * d0 + t1 * d1 + t2 * d2
        et = t0 * e0 + t1 * e1 + t2 * e2
        mtt += w * st * st
        btt += w * st * et
        if dim == 3:
            sq = q0 * d0 + q1 * d1 + q2 * d2
            eq = q0 * e0 + q1 * e1 + q2 * e2
            mtq += w * st * sq
            mqq += w * sq * sq
            btq += w * st * eq
            bqt += w * sq * et
            bqq += w * sq * eq
    if dim == 2:
        if mtt <= 0.0:
            return 0.0
        kap = -btt / mtt
    else:
        det = mtt * mqq - mtq * mtq
        if det <= 1e-6 * (mtt * mtt + mqq * mqq) or det <= 0.0:
            return 0.0
        # div = tr(M^-1 B)
        kap = -(mqq * btt - mtq * bqt - mtq * btq + mtt * bqq) / det
    kmax = (dim - 1) * KAPPA_MAX / h
    return min(max(kap, -kmax), kmax)


@numba.njit(parallel=True, cache=True, fastmath=True)
def curvature_cpu(x, m, rho, n, off, idx, thr_i, thr, h, kid, dim, kappa, L=0.0):
    """``kappa[i] = -div(n/|n|)`` for all fluid particles (:func:`curvature_body`)."""
    for i in numba.prange(x.shape[1]):
        kappa[i] = curvature_body(i, x, m, rho, n, off, idx, thr_i, thr, h, kid, dim, L)


@numba.njit(parallel=True, cache=True, fastmath=True)
def extend_curvature_cpu(x, m, rho, k_src, w_src, off, idx, h, kid, dim, k_out, w_out, L=0.0):
    """Shepard interpolation ``k_out_i = sum_j V_j W_ij w_j k_j / sum_j V_j W_ij w_j`` (self
    included) of the curvatures ``k_src`` known where ``w_src`` = 1; ``w_out`` = 1 where the sum
    has a term (one pass reaches one support radius further into the fluid)."""
    for i in numba.prange(x.shape[1]):
        xi0 = x[0, i]
        xi1 = x[1, i]
        xi2 = x[2, i] if dim == 3 else 0.0
        w = w_src[i] * m[i] / rho[i] * kernel_w(kid, 0.0, h, dim)
        num = w * k_src[i]
        den = w
        for k in range(off[i], off[i + 1]):
            j = idx[k]
            if w_src[j] == 0.0:
                continue
            d0 = xi0 - x[0, j]
            if L > 0.0:  # periodic along x: minimum image
                d0 -= L * math.floor(d0 / L + 0.5)
            d1 = xi1 - x[1, j]
            d2 = xi2 - x[2, j] if dim == 3 else 0.0
            w = m[j] / rho[j] * kernel_w(kid, math.sqrt(d0 * d0 + d1 * d1 + d2 * d2), h, dim)
            num += w * k_src[j]
            den += w
        if den > 0.0:
            k_out[i] = num / den
            w_out[i] = 1.0
        else:
            k_out[i] = 0.0
            w_out[i] = 0.0


@numba.njit(parallel=True, cache=True, fastmath=True)
def _csf_cpu(rho, n, kappa, sigma, factor, thr, dim, a):
    """``a_i += factor sigma kappa_i n_i / rho_i`` where ``|n_i| >= thr``."""
    for i in numba.prange(rho.shape[0]):
        n0 = n[0, i]
        n1 = n[1, i]
        n2 = n[2, i] if dim == 3 else 0.0
        if n0 * n0 + n1 * n1 + n2 * n2 < thr * thr:
            continue
        s = factor * sigma * kappa[i] / rho[i]
        a[0, i] += s * n0
        a[1, i] += s * n1
        if dim == 3:
            a[2, i] += s * n2


class Mueller2003:
    """Continuum surface force of Müller et al. 2003 with the free-surface corrections of the
    module docstring.

    ``coefficient``: the surface tension sigma [N/m in 3D, N in 2D]; ``boundary_coefficient``:
    must be 0 (the model has no adhesion). Registers the fluid fields ``normal`` (colour
    gradient [1/m], 'vector'), ``curvature_raw`` (kappa measured on the surface layer, 0
    elsewhere) and ``curvature`` (carried into the band; the one the force uses) [1/m]. The
    time step must resolve capillary waves, ``dt < sqrt(rho dx^3 / (2 pi sigma))``; the solvers'
    CFL/acoustic steps do not check it.
    """

    name = "mueller2003"

    def __init__(self, coefficient: float = 0.05, boundary_coefficient: float = 0.0) -> None:
        sigma = float(coefficient)
        if not (math.isfinite(sigma) and sigma >= 0.0):
            raise ValueError(f"surface tension (mueller2003): coefficient: {coefficient!r}; "
                             "expected a finite surface tension sigma >= 0 [N/m]")
        if float(boundary_coefficient) != 0.0:
            raise ValueError(
                f"surface tension (mueller2003): boundary_coefficient: {boundary_coefficient!r};"
                " expected 0 (Müller et al. 2003 has no adhesion term)")
        self.coefficient = sigma
        self.boundary_coefficient = 0.0

    def init(self, state: SimState) -> None:
        """Register the ``normal``, ``curvature`` and ``curvature_raw`` fluid fields."""
        if state.dim not in (2, 3):
            raise ValueError(
                f"surface tension (mueller2003): dimension {state.dim}; expected 2 or 3")
        state.fluid.register("normal", "vector")
        state.fluid.register("curvature")
        state.fluid.register("curvature_raw")

    def apply(self, state: SimState, dt: float) -> None:
        """Colour-field normals, curvature, then ``a += 2 sigma kappa n / rho``."""
        f = state.fluid
        if f.n == 0:
            return
        if "normal" not in f or "curvature_raw" not in f:
            self.init(state)
        nl = state.nl_ff
        h = state.h
        thr = THRESHOLD / h
        surface_normals_cpu(f["x"], f["m"], f["rho"], nl.offsets, nl.indices, 1.0, h, state.kid,
                            state.dim, f["normal"], state.period)
        curvature_cpu(f["x"], f["m"], f["rho"], f["normal"], nl.offsets, nl.indices,
                      SURFACE / h, thr, h, state.kid, state.dim, f["curvature_raw"], state.period)
        n_len = np.sqrt((f["normal"] ** 2).sum(axis=0))
        w0 = (n_len >= SURFACE / h).astype(np.float64)
        w1 = np.empty_like(w0)
        k1 = np.empty_like(w0)
        extend_curvature_cpu(f["x"], f["m"], f["rho"], f["curvature_raw"], w0, nl.offsets,
                             nl.indices, h, state.kid, state.dim, k1, w1, state.period)
        extend_curvature_cpu(f["x"], f["m"], f["rho"], k1, w1, nl.offsets, nl.indices, h,
                             state.kid, state.dim, f["curvature"], w0, state.period)
        _csf_cpu(f["rho"], f["normal"], f["curvature"], self.coefficient, HALF_SPACE_FACTOR,
                 thr, state.dim, f["a"])


__all__ = ["HALF_SPACE_FACTOR", "KAPPA_MAX", "SURFACE", "THRESHOLD", "Mueller2003",
           "curvature_body", "curvature_cpu", "extend_curvature_cpu"]
