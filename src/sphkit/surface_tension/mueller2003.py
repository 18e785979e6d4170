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
  by weighted least squares over the neighbours j with ``|n_j| h >= NEIGHBOUR`` (the surface
  layer and the particles just under it) whose normals are within 60 degrees of n_i (tangent
  basis t_k of n_i, weights ``V_j |W'_ij| / r_ij``)::

      kappa_i = -tr(M^-1 B),  M_kl = sum_j w_ij s_k s_l,  B_kl = sum_j w_ij s_k e_l,
      s_k = t_k . (x_j - x_i),  e_l = t_l . (u_j - u_i)

  clamped to ``|kappa| <= (dim - 1) KAPPA_MAX / h``.
* **directions smoothed first.** The unit normals u in the fit are not the particles' own
  ``n/|n|`` but the directions of n after ``SMOOTHING`` (2) Shepard passes
  ``n_i <- sum_j V_j W_ij n_j`` (self included; :meth:`Mueller2003.smoothed_directions`). The
  raw normals of a disordered surface carry the particle-scale roughness: a particle that sticks
  out has a large |n| (so it is a surface-layer particle) and its neighbours' normals lean
  towards it, so its ``-div u`` reads a curvature of the bump, not of the drop. This bias is
  always positive (the sunken particles, whose bias is negative, fall below SURFACE) and, in
  units of the drop's curvature, grows like R/h: on relaxed 3D drops (jittered start) the raw
  estimate read ``kappa d / 2`` = 1.19 / 1.28 / 1.56 at R = 4 / 6 / 8 h (std 0.19-0.38), which
  made the mode-2 stiffness fall with resolution until the 7 h drop no longer oscillated and
  jittered 6 h drops never came to rest (validation/README.md). With the smoothed directions:
  1.005 / 1.028 / 1.062 (std 0.03-0.07) on drops that relax with this model. Smoothing pulls
  in the directions of the second layer as well, which would add their larger curvature
  ``1/(d - 2r)`` to the fit; that is why only neighbours with ``|n_j| h >= NEIGHBOUR`` = 0.4
  enter it (with 0.1 the Laplace jump of sampled discs rose by 1-3 %, see the tests).
* **the interface, one particle radius out.** Eq. (19) needs the curvature of the fluid's
  surface, the colour field's ``c = 1/2`` contour (the surface Müller et al. render). A particle
  fills the cell of half-width r around its centre, so that contour lies about r outside the
  centres of the surface layer (measured on sampled discs: 1.0-1.2 r; the drop's volume radius:
  1.0 r). The curvature measured on the layer of centres is therefore moved to the interface as
  for a parallel curve (surface): ``K_s = K / (1 + r K / (dim - 1))`` (exact for circles and
  spheres); without it the curvature is that of a circle r smaller, +6 % at R = 4h.
* **curvature and depth carried into the band.** K_s, the unit normal ``u = n/|n|`` and the
  offset ``e = -r u`` from the particle to its interface point are interpolated (Shepard, two
  passes, i.e. up to 2h deep) from the surface layer to the particles below it (the carried
  offset is the mean of ``x_j + e_j - x_i``), so that every particle of the band gets the
  curvature of *its* surface and its depth below it, ``s_i = -u_i . e_i``.
* **signed delta, normalized to the jump.** The force is ``f_i = sigma K_i n_i g_i / phi_i`` on
  every particle with ``|n_i| h >= THRESHOLD`` that the carry reached. Outward-pointing n on the
  second layer subtract, as they must: the signed sum of ``V_i n_i`` over the band is the colour
  drop from the interior to the edge times the interface area, so

  - ``phi_i = 1/2 + M K_i / (2 (dim - 1))`` is the fluid side's share of the colour jump: 1/2 for
    a flat surface in the continuum limit, more on a convex one, whose edge colour lies below
    1/2 by the kernel's weight in the sliver between surface and tangent plane,
    ``M = int_plane W(rho) rho^2 dA`` (:func:`tangent_plane_moment`; 0.114 h in 2D, 0.221 h
    in 3D for the cubic spline); the paper's two-phase CSF has the whole jump, phi = 1;
  - ``g_i = (1 - K_i s_i / (dim - 1))^(dim - 1)`` is the area of the parallel surface at depth
    s_i per interface area. In a fluid at rest ``grad p = f``, so the pressure jump across the
    band is the integral of the force density along the normal, ``int f . u ds``, while the band
    sums of ``V_i n_i`` measure the force per *interface* area: a particle at depth s carries
    the force of interface area ``dA / g``, and g makes the depth integral sigma K_s.

  On sampled discs (R = 2.75-9.75 h) the depth integral ``sum_i m_i a_i . (-r_hat_i) /
  (2 pi d_i)`` is sigma/R within 0.4 %, on sampled balls 2 sigma/R within 3 % (R = 2.7 h) and
  0.5 % (R = 4.75 h) (tests/test_surface_tension_mueller.py); with the earlier constant factor
  2 and the curvature of the layer of centres it was 5-20 % (2D) and 17-31 % (3D) too large.

Acceleration ``a_i = f_i / rho_i``. The force is not a pair force: linear momentum is conserved
only as far as the discrete normals and curvatures are symmetric (a closed drop: to a small
fraction of the total surface force). There is no adhesion term (``boundary_coefficient`` must be
0); walls do not enter the colour field.
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from sphkit.core.kernels import kernel_dw, kernel_w
from sphkit.core.methods import NonPressureForce
from sphkit.core.operators import interpolate, surface_normals
from sphkit.core.pairs import distance, pair_slots, point, separation
from sphkit.core.params import checked_number
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
#: curvatures are clamped to ``|kappa| <= (dim - 1) KAPPA_MAX / h``: no radius of curvature
#: below h (two particle spacings) is resolved, and without the clamp single particles at the
#: corners of a sampled lattice get forces that eject them (3D drop, sigma = 5 N/m, r = 2.5 mm)
KAPPA_MAX = 1.0
#: Shepard smoothing passes of the normals' directions before the curvature is measured
#: (module docstring: removes the roughness bias of the raw normals)
SMOOTHING = 2
#: neighbours enter a curvature where ``|n_j| h >= NEIGHBOUR`` (the surface layer and the
#: particles just under it; not the second layer, whose smoothed normals are inward too)
NEIGHBOUR = 0.4


@numba.njit(inline="always", cache=True, fastmath=True)
def curvature_body(i, x, m, rho, n, off, idx, thr_i, thr, h, kid, dim, L=0.0):
    """``kappa_i = -div(n/|n|)`` at fluid particle i from the tangential derivatives of the unit
    normal over the neighbours with ``|n_j| >= thr`` (0 where ``|n_i| < thr`` or the neighbours
    do not span the tangent plane); see the module docstring."""
    ni0, ni1, ni2 = point(n, i, dim)
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
    xi0, xi1, xi2 = point(x, i, dim)
    # weighted least squares of the tangential unit-normal components over the tangential
    # offsets: M = sum w s s^T, B = sum w s e^T (s = (t, q) . (x_j - x_i), e = (t, q) . (u_j - u_i))
    mtt = mtq = mqq = 0.0
    btt = btq = bqt = bqq = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        nj0, nj1, nj2 = point(n, j, dim)
        lj = math.sqrt(nj0 * nj0 + nj1 * nj1 + nj2 * nj2)
        if lj < thr or nj0 * u0 + nj1 * u1 + nj2 * u2 < COS_MAX * lj:
            continue
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
        d0, d1, d2 = -d0, -d1, -d2  # the offsets of the fit are x_j - x_i
        w = -m[j] / rho[j] * kernel_dw(kid, r, h, dim)
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
        xi0, xi1, xi2 = point(x, i, dim)
        w = w_src[i] * m[i] / rho[i] * kernel_w(kid, 0.0, h, dim)
        num = w * k_src[i]
        den = w
        for k in pair_slots(off, i):
            j = idx[k]
            if w_src[j] == 0.0:
                continue
            w = m[j] / rho[j] * kernel_w(kid, distance(xi0, xi1, xi2, x, j, dim, L), h, dim)
            num += w * k_src[j]
            den += w
        if den > 0.0:
            k_out[i] = num / den
            w_out[i] = 1.0
        else:
            k_out[i] = 0.0
            w_out[i] = 0.0


@numba.njit(parallel=True, cache=True, fastmath=True)
def extend_band_cpu(x, m, rho, k_src, e_src, u_src, w_src, off, idx, h, kid, dim, k_out, e_out,
                    u_out, w_out, L=0.0):
    """One Shepard pass (self included, weights ``V_j W_ij`` over the neighbours with
    ``w_src[j]`` = 1) that carries the interface's curvature ``k``, the offset ``e`` from a
    particle to its interface point and the interface's unit normal ``u`` one support radius
    further into the fluid: ``k_out_i = <k_j>``, ``e_out_i = <(x_j - x_i) + e_j>`` (minimum image
    along x when L > 0), ``u_out_i = <u_j> / |<u_j>|``; ``w_out`` = 1 where the sum has a term."""
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        w = w_src[i] * m[i] / rho[i] * kernel_w(kid, 0.0, h, dim)
        den = w
        nk = w * k_src[i]
        ne0 = w * e_src[0, i]
        ne1 = w * e_src[1, i]
        ne2 = w * e_src[2, i] if dim == 3 else 0.0
        nu0 = w * u_src[0, i]
        nu1 = w * u_src[1, i]
        nu2 = w * u_src[2, i] if dim == 3 else 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            if w_src[j] == 0.0:
                continue
            d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
            d0, d1, d2 = -d0, -d1, -d2  # x_j - x_i
            w = m[j] / rho[j] * kernel_w(kid, r, h, dim)
            den += w
            nk += w * k_src[j]
            ne0 += w * (d0 + e_src[0, j])
            ne1 += w * (d1 + e_src[1, j])
            nu0 += w * u_src[0, j]
            nu1 += w * u_src[1, j]
            if dim == 3:
                ne2 += w * (d2 + e_src[2, j])
                nu2 += w * u_src[2, j]
        lu = math.sqrt(nu0 * nu0 + nu1 * nu1 + nu2 * nu2)
        if den > 0.0 and lu > 0.0:
            k_out[i] = nk / den
            e_out[0, i] = ne0 / den
            e_out[1, i] = ne1 / den
            u_out[0, i] = nu0 / lu
            u_out[1, i] = nu1 / lu
            if dim == 3:
                e_out[2, i] = ne2 / den
                u_out[2, i] = nu2 / lu
            w_out[i] = 1.0
        else:
            k_out[i] = 0.0
            for c in range(dim):
                e_out[c, i] = 0.0
                u_out[c, i] = 0.0
            w_out[i] = 0.0


@numba.njit(parallel=True, cache=True, fastmath=True)
def surface_layer_cpu(n, k_raw, r, kmax, dim, surf, k_s, e, u, w):
    """Sources of the band carry on the surface layer (``|n_i| >= surf``): the curvature of the
    interface one particle radius r outside the particle centres,
    ``K_s = K / (1 + r K / (dim - 1))`` (exact for circles and spheres), the interface point's
    offset ``e_i = -r u_i`` and the unit normal ``u_i = n_i / |n_i|``; ``w_i`` = 1 there, else 0."""
    for i in numba.prange(n.shape[1]):
        n0 = n[0, i]
        n1 = n[1, i]
        n2 = n[2, i] if dim == 3 else 0.0
        ln = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if ln < surf or ln == 0.0:
            k_s[i] = 0.0
            for c in range(dim):
                e[c, i] = 0.0
                u[c, i] = 0.0
            w[i] = 0.0
            continue
        kap = min(max(k_raw[i], -kmax), kmax)
        k_s[i] = kap / (1.0 + r * kap / (dim - 1))
        u[0, i] = n0 / ln
        u[1, i] = n1 / ln
        e[0, i] = -r * n0 / ln
        e[1, i] = -r * n1 / ln
        if dim == 3:
            u[2, i] = n2 / ln
            e[2, i] = -r * n2 / ln
        w[i] = 1.0


@numba.njit(parallel=True, cache=True, fastmath=True)
def _csf_cpu(rho, n, kappa, e, u, w, sigma, moment, thr, dim, depth, a):
    """``a_i += sigma kappa_i n_i g_i / (phi_i rho_i)`` where ``|n_i| >= thr`` and the band carry
    reached i (``w_i`` = 1): the fluid-side share of the colour jump
    ``phi_i = 1/2 + moment kappa_i / (2 (dim - 1))`` and the area factor of the parallel surface
    at the depth ``s_i = -u_i . e_i`` below the interface, ``g_i = (1 - kappa_i s_i /
    (dim - 1))^(dim - 1)`` (stored in ``depth``: s_i)."""
    for i in numba.prange(rho.shape[0]):
        n0 = n[0, i]
        n1 = n[1, i]
        n2 = n[2, i] if dim == 3 else 0.0
        s = -(u[0, i] * e[0, i] + u[1, i] * e[1, i])
        if dim == 3:
            s -= u[2, i] * e[2, i]
        depth[i] = s
        if w[i] == 0.0 or n0 * n0 + n1 * n1 + n2 * n2 < thr * thr:
            continue
        kap = kappa[i]
        g = max(1.0 - kap * s / (dim - 1), 0.0)
        if dim == 3:
            g *= g
        phi = 0.5 + moment * kap / (2.0 * (dim - 1))
        c = sigma * kap * g / (max(phi, 0.25) * rho[i])
        a[0, i] += c * n0
        a[1, i] += c * n1
        if dim == 3:
            a[2, i] += c * n2


def tangent_plane_moment(kid: int, h: float, dim: int, samples: int = 4001) -> float:
    """``M = int_{tangent plane} W(rho) rho^2 dA`` [m]: the colour at the edge of a convex fluid
    of curvature K lies below 1/2 by ``K M / (2 (dim - 1))`` (the kernel's weight in the sliver
    between the tangent plane and the surface); 0.1137 h (2D) and 0.2214 h (3D) for the cubic
    spline."""
    q = np.linspace(0.0, h, samples)
    wq = np.array([kernel_w(kid, float(v), h, dim) for v in q])
    f = wq * q * q * (2.0 if dim == 2 else 2.0 * np.pi * q)  # both sides / the ring 2 pi rho
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(q)))


class Mueller2003(NonPressureForce):
    """Continuum surface force of Müller et al. 2003 with the free-surface corrections of the
    module docstring.

    ``coefficient``: the surface tension sigma [N/m in 3D, N in 2D]; ``boundary_coefficient``:
    must be 0 (the model has no adhesion). Registers the fluid fields ``normal`` (colour
    gradient [1/m], 'vector'), ``curvature_raw`` (kappa measured on the surface layer, 0
    elsewhere), ``curvature`` (the interface's curvature K_s carried into the band; the one the
    force uses) [1/m] and ``surface_depth`` (s, the depth below the interface [m]; meaningful
    where ``curvature`` is set). The
    time step must resolve capillary waves, ``dt < sqrt(rho dx^3 / (2 pi sigma))``; the solvers'
    CFL/acoustic steps do not check it.
    """

    name = "mueller2003"
    repeatable = True  #: apply adds to a (normals, curvatures it writes are made from x, m, rho)

    @classmethod
    def from_config(cls, p: Any) -> Mueller2003:
        """The Mueller2003 of a material's ``surface_tension`` (scene model)."""
        return cls(p.coefficient, p.boundary_coefficient)

    def __init__(self, coefficient: float = 0.05, boundary_coefficient: float = 0.0) -> None:
        sigma = checked_number("surface tension (mueller2003): coefficient", coefficient,
                               expected="a finite surface tension sigma >= 0 [N/m]")
        if float(boundary_coefficient) != 0.0:
            raise ValueError(
                f"surface tension (mueller2003): boundary_coefficient: {boundary_coefficient!r};"
                " expected 0 (Müller et al. 2003 has no adhesion term)")
        self.coefficient = sigma
        self.boundary_coefficient = 0.0

    def init(self, state: SimState) -> None:
        """Register the ``normal``, ``curvature``, ``curvature_raw`` and ``surface_depth`` fluid
        fields."""
        if state.dim not in (2, 3):
            raise ValueError(
                f"surface tension (mueller2003): dimension {state.dim}; expected 2 or 3")
        state.fluid.register("normal", "vector")
        state.fluid.register("curvature")
        state.fluid.register("curvature_raw")
        state.fluid.register("surface_depth")
        self._moment = tangent_plane_moment(state.kid, state.h, state.dim)

    def smoothed_directions(self, state: SimState) -> np.ndarray:
        """The colour-gradient normals ``n`` (computed) with their directions smoothed by
        ``SMOOTHING`` Shepard passes and their own lengths: what the curvature is measured
        from (module docstring)."""
        f = state.fluid
        nrm = f["normal"]
        V = f["m"] / f["rho"]
        a = nrm
        for _ in range(SMOOTHING):  # n_i <- sum_j V_j W_ij n_j
            a = interpolate(f["x"], V, a, state.nl_ff, state.h, state.kid, state.period)
        ln = np.sqrt((nrm * nrm).sum(axis=0))
        la = np.sqrt((a * a).sum(axis=0))
        return a * np.divide(ln, la, out=np.zeros_like(ln), where=la > 0.0)

    def apply(self, state: SimState, dt: float) -> None:
        """Colour-field normals, surface-layer curvature, the band carry, then the force."""
        f = state.fluid
        if f.n == 0:
            return
        if "surface_depth" not in f or not hasattr(self, "_moment"):
            self.init(state)
        nl = state.nl_ff
        h = state.h
        dim = state.dim
        thr = THRESHOLD / h
        x, m, rho, nrm = f["x"], f["m"], f["rho"], f["normal"]
        surface_normals(x, m, rho, nl.offsets, nl.indices, 1.0, h, state.kid, dim, nrm,
                            state.period)
        nd = self.smoothed_directions(state)
        curvature_cpu(x, m, rho, nd, nl.offsets, nl.indices, SURFACE / h, NEIGHBOUR / h, h,
                      state.kid, dim, f["curvature_raw"], state.period)
        n = f.n
        k0, w0, w1 = np.empty(n), np.empty(n), np.empty(n)
        e0, u0 = np.empty((dim, n)), np.empty((dim, n))
        e1, u1 = np.empty((dim, n)), np.empty((dim, n))
        kmax = (dim - 1) * KAPPA_MAX / h
        surface_layer_cpu(nrm, f["curvature_raw"], state.r, kmax, dim, SURFACE / h, k0, e0, u0,
                          w0)
        k1 = f["curvature"]
        extend_band_cpu(x, m, rho, k0, e0, u0, w0, nl.offsets, nl.indices, h, state.kid, dim,
                        k1, e1, u1, w1, state.period)
        extend_band_cpu(x, m, rho, k1, e1, u1, w1, nl.offsets, nl.indices, h, state.kid, dim,
                        k0, e0, u0, w0, state.period)
        k1[:] = k0
        _csf_cpu(rho, nrm, k1, e0, u0, w0, self.coefficient, self._moment, thr, dim,
                 f["surface_depth"], f["a"])


__all__ = ["KAPPA_MAX", "NEIGHBOUR", "SMOOTHING", "SURFACE", "THRESHOLD", "Mueller2003",
           "curvature_body", "curvature_cpu",
           "extend_band_cpu", "surface_layer_cpu", "tangent_plane_moment"]
