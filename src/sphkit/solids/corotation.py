"""Compiled passes of the corotated SPH solids, shared by their models.

Becker, Ihmsen & Teschner 2009, "Corotated SPH for deformable solids" (Eurographics Workshop
on Natural Phenomena), Sec. 3-4, as SPlisHSPlasH's ``Elasticity_Becker2009.cpp`` evaluates it
(reference: ``reference/methods.md`` N1). All passes walk the rest lists of
:class:`sphkit.solids.rest.RestConfiguration` in slot order; ``pos[s]`` is the current index of
slot s in the fluid set. Vectors are padded to three components (zero beyond dim), so 2D is
plane strain: ``F_zz = 1``, ``eps_zz = 0``, and the rotation turns about z only.

* rotation: ``A_i = sum_j m_j W(x0_ji) x_ji x0_ji^T`` and its rotational part R_i by
  Müller, Bender, Chentanez & Macklin 2016 ("A robust method to extract the rotational part of
  deformations", MIG), 10 iterations warm-started from the last step's R_i (a unit
  quaternion, fields ``solid_qw``, ``solid_q``);
* or, with ``rotation="gradient"`` (:func:`gradient_rotations`), R_i the polar rotation of
  the deformation gradient ``H_i = sum_j x_ji G_ij^T``, by the same iteration run to
  convergence: then ``R^T H`` is symmetric and the torques of the force below cancel
  (:mod:`sphkit.solids.becker2009`, "Conservation");
* displacement gradient ``grad u_i = sum_j (R_i^T x_ji - x0_ji) G_ij^T`` with the gradient
  weights ``G_ij`` of :mod:`sphkit.solids.gradients` (SPlisHSPlasH's Becker:
  ``G_ij = -V0_j grad W(x0_ji)``, the kernel gradient taken along ``x0_ji``; sphkit's default
  a second-order least-squares gradient), ``F_i = I + grad u_i``; strain
  ``eps = (grad u + grad u^T) / 2``; stress ``sigma = 2 mu eps + lambda tr(eps) I``, with a
  yield stress that of the elastic part ``eps - eps_p`` after the return mapping of
  :mod:`sphkit.solids.plasticity`.

  Face clamp (``elasticity.clamp="face"``, :mod:`sphkit.solids.rest`): a free particle's fit
  samples a pinned neighbour j at ``d_ji = x0_ji - s_ji``, on the clamp's face; the sample
  moves with the pinned body, at ``x_ji - s_ji``. The deformation gradient is then
  ``H_i - C_i`` with the constant ``C_i = sum_j s_ji G_ij^T`` (:func:`clamp_shifts`), and
  ``grad u_i = R_i^T (H_i - C_i) - (sum_j x0_ji G_ij^T - C_i)``: the stresses add
  ``C_i - R_i^T C_i`` to the pass's sum, and the gradient's rotation is that of
  ``H_i - C_i``. Shifting the one and not the other leaves ``R_i^T (H_i - C_i)`` unsymmetric
  near the face, so the rotation is not stationary for the energy and the force is not its
  gradient (15 % off on a block clamped by a face, tests/test_solids.py); ``C = 0`` without
  the face clamp.

  SPlisHSPlasH multiplies the tensor shear strain eps_01 by C_33 = mu in Voigt form, which
  gives half the shear stress of Hooke's law (Voigt notation needs the engineering strain
  2 eps_01); sphkit uses Hooke's law ``2 mu eps``;
* force ``f_i = sum_j (V0_i P_i G_ij - V0_j P_j G_ji)``, ``P = R sigma``: the derivative
  ``-dU/dx_i`` of the strain energy ``U = sum_j V0_j sigma_j : eps_j / 2`` with the rotations
  held (``d grad u_j / d x_i = R_j^T G_ji``, ``d grad u_i / d x_i = -R_i^T sum_j G_ij``). With
  the plain SPH weights it is SPlisHSPlasH's ``sum_j [R_j (-V0_j sigma_j d_ji) - R_i (-V0_i
  sigma_i d_ij)]``, ``d_ji = V0_i grad W(x0_ji)``, ``d_ij = -V0_j grad W(x0_ji)``. It is
  antisymmetric in the pair, so with symmetric rest lists the elastic forces sum to zero
  (linear momentum to round-off). SPlisHSPlasH (and the paper's Eq. 12) halve this sum, which
  makes the material half as stiff as its E: a stretched bar then pulls with about
  ``E eps A / 2`` (tests/test_solids.py);
* zero-energy modes (Ganzenmüller 2015, "An hourglass control algorithm for Lagrangian SPH",
  CMAME 286, Eq. 20-22): with ``x_ij = x_j - x_i`` (his convention), the position of j that
  particle i predicts, ``R_i F_i x0_ij``, misses the actual one by ``e_ij``;
  ``delta_ij = e_ij . x_ij / |x_ij|`` and likewise ``delta_ji``, and
  ``f_i^hg = -alpha E V0_i sum_j V0_j W(x0_ij) / |x0_ij|^2 (delta_ij + delta_ji) x_ij/|x_ij|``,
  a central pair force (linear and angular momentum kept). SPlisHSPlasH predicts with
  ``F_i R_i x0_ij``; F is measured in the rest frame (``R_i^T x_ji``), so the prediction in the
  current frame is ``R_i F_i x0_ij``, which sphkit uses (the two agree for small rotations).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sphkit.core.kernels import kernel_w
from sphkit.core.pairs import pair_slots
from sphkit.solids.plasticity import radial_return

_JIT = dict(cache=True, fastmath=True)


@numba.njit(inline="always", **_JIT)
def _quat_matrix(w, x, y, z, R):
    """The rotation matrix (row-major 9-vector ``R``) of the unit quaternion (w, x, y, z)."""
    R[0] = 1.0 - 2.0 * (y * y + z * z)
    R[1] = 2.0 * (x * y - w * z)
    R[2] = 2.0 * (x * z + w * y)
    R[3] = 2.0 * (x * y + w * z)
    R[4] = 1.0 - 2.0 * (x * x + z * z)
    R[5] = 2.0 * (y * z - w * x)
    R[6] = 2.0 * (x * z - w * y)
    R[7] = 2.0 * (y * z + w * x)
    R[8] = 1.0 - 2.0 * (x * x + y * y)


@numba.njit(inline="always", **_JIT)
def _extract_rotation(a00, a01, a02, a10, a11, a12, a20, a21, a22, qw, qv, i, r, iterations,
                      tol):
    """The rotational part ``r`` (row-major) of the matrix ``a..`` by Müller et al. 2016's
    iteration warm-started from particle i's quaternion ``qw[i]``, ``qv[:, i]`` (written back);
    at most ``iterations``, ending when the correction's angle is below ``tol`` [rad]."""
    w, qx, qy, qz = qw[i], qv[0, i], qv[1, i], qv[2, i]
    for _ in range(iterations):
        _quat_matrix(w, qx, qy, qz, r)
        # omega = sum_c R_c x A_c / (|sum_c R_c . A_c| + 1e-9), columns c
        o0 = (r[3] * a20 - r[6] * a10) + (r[4] * a21 - r[7] * a11) + (r[5] * a22 - r[8] * a12)
        o1 = (r[6] * a00 - r[0] * a20) + (r[7] * a01 - r[1] * a21) + (r[8] * a02 - r[2] * a22)
        o2 = (r[0] * a10 - r[3] * a00) + (r[1] * a11 - r[4] * a01) + (r[2] * a12 - r[5] * a02)
        tr = (r[0] * a00 + r[3] * a10 + r[6] * a20 + r[1] * a01 + r[4] * a11 + r[7] * a21
              + r[2] * a02 + r[5] * a12 + r[8] * a22)
        inv = 1.0 / (abs(tr) + 1e-9)
        o0 *= inv
        o1 *= inv
        o2 *= inv
        ang = math.sqrt(o0 * o0 + o1 * o1 + o2 * o2)
        if ang < tol:
            break
        sh = math.sin(0.5 * ang) / ang
        pw, px, py, pz = math.cos(0.5 * ang), o0 * sh, o1 * sh, o2 * sh
        # q <- p q
        nw = pw * w - px * qx - py * qy - pz * qz
        nx = pw * qx + px * w + py * qz - pz * qy
        ny = pw * qy + py * w + pz * qx - px * qz
        nz = pw * qz + pz * w + px * qy - py * qx
        nn = 1.0 / math.sqrt(nw * nw + nx * nx + ny * ny + nz * nz)
        w, qx, qy, qz = nw * nn, nx * nn, ny * nn, nz * nn
    _quat_matrix(w, qx, qy, qz, r)
    qw[i] = w
    qv[0, i] = qx
    qv[1, i] = qy
    qv[2, i] = qz


@numba.njit(parallel=True, **_JIT)
def rotations(x, pos, x0, m, off, idx, h, kid, dim, qw, qv, R, iterations):
    """``R[s]`` (row-major) from the moment matrix ``A_s`` by the warm-started iteration of
    Müller et al. 2016; the quaternion fields ``qw``, ``qv`` (per particle) carry it to the
    next step."""
    for s in numba.prange(pos.shape[0]):
        i = pos[s]
        a00 = a01 = a02 = a10 = a11 = a12 = a20 = a21 = a22 = 0.0
        xi0 = x[0, i]
        xi1 = x[1, i] if dim > 1 else 0.0
        xi2 = x[2, i] if dim > 2 else 0.0
        for k in pair_slots(off, s):
            t = idx[k]
            j = pos[t]
            e0 = x0[0, t] - x0[0, s]
            e1 = x0[1, t] - x0[1, s]
            e2 = x0[2, t] - x0[2, s]
            c = m[t] * kernel_w(kid, math.sqrt(e0 * e0 + e1 * e1 + e2 * e2), h, dim)
            d0 = x[0, j] - xi0
            d1 = (x[1, j] - xi1) if dim > 1 else 0.0
            d2 = (x[2, j] - xi2) if dim > 2 else 0.0
            a00 += c * d0 * e0
            a01 += c * d0 * e1
            a02 += c * d0 * e2
            a10 += c * d1 * e0
            a11 += c * d1 * e1
            a12 += c * d1 * e2
            a20 += c * d2 * e0
            a21 += c * d2 * e1
            a22 += c * d2 * e2
        _extract_rotation(a00, a01, a02, a10, a11, a12, a20, a21, a22, qw, qv, i, R[s],
                          iterations, 1e-9)


@numba.njit(parallel=True, **_JIT)
def gradient_rotations(x, pos, off, idx, G, C, dim, qw, qv, R, iterations, tol):
    """``R[s]`` (row-major): the rotation of the polar decomposition of the deformation
    gradient ``H_s = sum_j x_ji G_ij^T - C_s`` (``C``: the face clamp's shift of
    :func:`clamp_shifts`, zero without it; ``H_zz = 1`` in 2D), by the warm-started iteration
    of Müller et al. 2016 run to the angle ``tol`` (at most ``iterations``). With it
    ``R^T H`` is symmetric, and with linearly consistent weights (``sum_j x0_ji G_ij^T = I``)
    the corotated force is the gradient of a rotation-invariant energy: angular momentum is
    kept (module docstring)."""
    for s in numba.prange(pos.shape[0]):
        i = pos[s]
        a00 = a01 = a02 = a10 = a11 = a12 = a20 = a21 = a22 = 0.0
        xi0 = x[0, i]
        xi1 = x[1, i] if dim > 1 else 0.0
        xi2 = x[2, i] if dim > 2 else 0.0
        for k in pair_slots(off, s):
            j = pos[idx[k]]
            g0, g1, g2 = G[k, 0], G[k, 1], G[k, 2]
            d0 = x[0, j] - xi0
            d1 = (x[1, j] - xi1) if dim > 1 else 0.0
            d2 = (x[2, j] - xi2) if dim > 2 else 0.0
            a00 += d0 * g0
            a01 += d0 * g1
            a02 += d0 * g2
            a10 += d1 * g0
            a11 += d1 * g1
            a12 += d1 * g2
            a20 += d2 * g0
            a21 += d2 * g1
            a22 += d2 * g2
        cs = C[s]  # the face clamp's shift (zero without it)
        a00 -= cs[0]
        a01 -= cs[1]
        a02 -= cs[2]
        a10 -= cs[3]
        a11 -= cs[4]
        a12 -= cs[5]
        a20 -= cs[6]
        a21 -= cs[7]
        a22 -= cs[8]
        if dim < 3:
            a22 = 1.0
        if dim < 2:
            a11 = 1.0
        _extract_rotation(a00, a01, a02, a10, a11, a12, a20, a21, a22, qw, qv, i, R[s],
                          iterations, tol)


@numba.njit(parallel=True, **_JIT)
def stresses(x, pos, x0, off, idx, G, C, dim, mu, lam, R, F, P, M, von_mises, ep, ep_s, alpha,
             yield_stress, hardening, plastic):
    """Per slot: ``F = I + grad u`` (row-major) with ``grad u_i = sum_j u_ji G_ij^T + C_i -
    R_i^T C_i`` (the gradient weights of :mod:`sphkit.solids.gradients`; ``C`` the face
    clamp's shift of :func:`clamp_shifts`, zero without it, module docstring), the stress
    term ``P = R sigma`` of the force and the predictor ``M = R F`` of the zero-energy-mode
    control; the von Mises
    stress per particle. ``plastic``: the strain is first returned onto the yield surface by
    :func:`sphkit.solids.plasticity.radial_return` (the per-particle plastic state ``ep``,
    ``ep_s``, ``alpha`` updated in place) and sigma is that of the elastic strain; otherwise
    the plastic arrays are not read (they may be empty)."""
    for s in numba.prange(pos.shape[0]):
        i = pos[s]
        r = R[s]
        g = F[s]  # grad u accumulates in F[s]
        for c in range(9):
            g[c] = 0.0
        xi0 = x[0, i]
        xi1 = x[1, i] if dim > 1 else 0.0
        xi2 = x[2, i] if dim > 2 else 0.0
        for k in pair_slots(off, s):
            t = idx[k]
            j = pos[t]
            e0 = x0[0, t] - x0[0, s]
            e1 = x0[1, t] - x0[1, s]
            e2 = x0[2, t] - x0[2, s]
            d0 = x[0, j] - xi0
            d1 = (x[1, j] - xi1) if dim > 1 else 0.0
            d2 = (x[2, j] - xi2) if dim > 2 else 0.0
            # u_ji = R^T x_ji - x0_ji
            u0 = r[0] * d0 + r[3] * d1 + r[6] * d2 - e0
            u1 = r[1] * d0 + r[4] * d1 + r[7] * d2 - e1
            u2 = r[2] * d0 + r[5] * d1 + r[8] * d2 - e2
            g0, g1, g2 = G[k, 0], G[k, 1], G[k, 2]
            g[0] += u0 * g0
            g[1] += u0 * g1
            g[2] += u0 * g2
            g[3] += u1 * g0
            g[4] += u1 * g1
            g[5] += u1 * g2
            g[6] += u2 * g0
            g[7] += u2 * g1
            g[8] += u2 * g2
        # the face clamp's shift: grad u += C - R^T C (zero without it; module docstring)
        cs = C[s]
        for a in range(3):
            for b in range(3):
                g[3 * a + b] += cs[3 * a + b] - (r[a] * cs[b] + r[3 + a] * cs[3 + b]
                                                 + r[6 + a] * cs[6 + b])
        s00, s11, s22 = g[0], g[4], g[8]
        s01 = 0.5 * (g[1] + g[3])
        s02 = 0.5 * (g[2] + g[6])
        s12 = 0.5 * (g[5] + g[7])
        if plastic:
            s00, s11, s22, s01, s02, s12 = radial_return(s00, s11, s22, s01, s02, s12, ep,
                                                         ep_s, alpha, i, mu, yield_stress,
                                                         hardening)
        ltr = lam * (s00 + s11 + s22)
        t00 = 2.0 * mu * s00 + ltr
        t11 = 2.0 * mu * s11 + ltr
        t22 = 2.0 * mu * s22 + ltr
        t01 = 2.0 * mu * s01
        t02 = 2.0 * mu * s02
        t12 = 2.0 * mu * s12
        von_mises[i] = math.sqrt(0.5 * ((t00 - t11) ** 2 + (t11 - t22) ** 2 + (t22 - t00) ** 2)
                                 + 3.0 * (t01 * t01 + t02 * t02 + t12 * t12))
        g[0] += 1.0
        g[4] += 1.0
        g[8] += 1.0
        p = P[s]
        mm = M[s]
        for a in range(3):
            r0, r1, r2 = r[3 * a], r[3 * a + 1], r[3 * a + 2]
            p[3 * a] = r0 * t00 + r1 * t01 + r2 * t02  # R sigma
            p[3 * a + 1] = r0 * t01 + r1 * t11 + r2 * t12
            p[3 * a + 2] = r0 * t02 + r1 * t12 + r2 * t22
            for b in range(3):
                mm[3 * a + b] = r0 * g[b] + r1 * g[3 + b] + r2 * g[6 + b]


@numba.njit(parallel=True, **_JIT)
def forces(x, pos, x0, V0, m, off, idx, G, rev, h, kid, dim, P, M, alpha_e, a):
    """``a_i += (f_i + f_i^hg) / m_i`` with ``f_i = sum_j (V0_i P_i G_ij - V0_j P_j G_ji)``
    and the hourglass force (module docstring; ``alpha_e = alpha E`` [Pa])."""
    for s in numba.prange(pos.shape[0]):
        i = pos[s]
        p = P[s]
        mi = M[s]
        vi = V0[s]
        f0 = f1 = f2 = 0.0
        h0 = h1 = h2 = 0.0
        xi0 = x[0, i]
        xi1 = x[1, i] if dim > 1 else 0.0
        xi2 = x[2, i] if dim > 2 else 0.0
        for k in pair_slots(off, s):
            t = idx[k]
            q = P[t]
            vj = V0[t]
            a0, a1, a2 = vi * G[k, 0], vi * G[k, 1], vi * G[k, 2]
            kr = rev[k]
            b0, b1, b2 = vj * G[kr, 0], vj * G[kr, 1], vj * G[kr, 2]
            f0 += p[0] * a0 + p[1] * a1 + p[2] * a2 - q[0] * b0 - q[1] * b1 - q[2] * b2
            f1 += p[3] * a0 + p[4] * a1 + p[5] * a2 - q[3] * b0 - q[4] * b1 - q[5] * b2
            f2 += p[6] * a0 + p[7] * a1 + p[8] * a2 - q[6] * b0 - q[7] * b1 - q[8] * b2
            if alpha_e != 0.0:
                e0 = x0[0, t] - x0[0, s]
                e1 = x0[1, t] - x0[1, s]
                e2 = x0[2, t] - x0[2, s]
                r0 = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
                j = pos[t]
                d0 = x[0, j] - xi0
                d1 = (x[1, j] - xi1) if dim > 1 else 0.0
                d2 = (x[2, j] - xi2) if dim > 2 else 0.0
                dl = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                if dl > 1e-9 * h:
                    mj = M[t]
                    # e_ij = R_i F_i x0_ij - x_ij;  e_ji = -R_j F_j x0_ij + x_ij
                    p0 = mi[0] * e0 + mi[1] * e1 + mi[2] * e2
                    p1 = mi[3] * e0 + mi[4] * e1 + mi[5] * e2
                    p2 = mi[6] * e0 + mi[7] * e1 + mi[8] * e2
                    n0 = mj[0] * e0 + mj[1] * e1 + mj[2] * e2
                    n1 = mj[3] * e0 + mj[4] * e1 + mj[5] * e2
                    n2 = mj[6] * e0 + mj[7] * e1 + mj[8] * e2
                    dij = ((p0 - d0) * d0 + (p1 - d1) * d1 + (p2 - d2) * d2) / dl
                    dji = ((n0 - d0) * d0 + (n1 - d1) * d1 + (n2 - d2) * d2) / dl
                    w = vj * kernel_w(kid, r0, h, dim) / (r0 * r0) * (dij + dji) / dl
                    h0 -= w * d0
                    h1 -= w * d1
                    h2 -= w * d2
        inv = 1.0 / m[s]
        c = alpha_e * vi
        a[0, i] += inv * (f0 + c * h0)
        if dim > 1:
            a[1, i] += inv * (f1 + c * h1)
        if dim > 2:
            a[2, i] += inv * (f2 + c * h2)


@numba.njit(**_JIT)
def energy(F, pos, V0, mu, lam, ep, ep_s, alpha, plastic):
    """``sum_s V0_s (mu |eps_e|^2 + lam / 2 tr(eps_e)^2)`` with ``eps_e = sym(F_s) - I`` (less
    the plastic strain ``ep``, ``ep_s`` of particle ``pos[s]`` when ``plastic``): the strain
    energy of the stresses pass's ``F`` [J]."""
    u = 0.0
    for s in range(pos.shape[0]):
        g = F[s]
        e00, e11, e22 = g[0] - 1.0, g[4] - 1.0, g[8] - 1.0
        e01, e02, e12 = 0.5 * (g[1] + g[3]), 0.5 * (g[2] + g[6]), 0.5 * (g[5] + g[7])
        if plastic:
            i = pos[s]
            e00 -= ep[0, i]
            e11 -= ep[1, i]
            e22 -= ep[2, i]
            e01 -= ep_s[0, i]
            e02 -= ep_s[1, i]
            e12 -= ep_s[2, i]
        tr = e00 + e11 + e22
        u += V0[s] * (mu * (e00 * e00 + e11 * e11 + e22 * e22
                            + 2.0 * (e01 * e01 + e02 * e02 + e12 * e12)) + 0.5 * lam * tr * tr)
    return u


def clamp_shifts(x0: np.ndarray, offsets: np.ndarray, indices: np.ndarray, G: np.ndarray,
                 dim: int, samples: np.ndarray | None) -> np.ndarray:
    """The face clamp's shift per particle, ``C_i = sum_j s_ji G_ij^T`` (n, 9: row-major
    3 x 3), with ``s_ji = x0_ji - d_ji`` the pair's shift from the pinned neighbour's rest
    vector to the fit's sample ``d_ji`` on the clamp's face
    (:meth:`sphkit.solids.rest.RestConfiguration.clamp_vectors`; zero for every other pair);
    all zero when ``samples`` is None (no face clamp). The sample's current position is
    ``x_j - s_ji`` (the pinned body, carried rigidly by its particle), so the deformation
    gradient is ``H_i - C_i`` (module docstring)."""
    n = offsets.shape[0] - 1
    C = np.zeros((n, 9))
    if samples is None or indices.size == 0:
        return C
    rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(offsets))
    cols = indices.astype(np.int64)
    s = np.zeros((rows.size, 3))
    s[:, :dim] = (x0[:dim, cols] - x0[:dim, rows]).T - samples
    np.add.at(C, rows, np.einsum("ka,kb->kab", s, G).reshape(-1, 9))
    return C


def lame(youngs_modulus: float, poisson_ratio: float) -> tuple[float, float]:
    """Lamé's ``(mu, lambda)`` [Pa] of Young's modulus E [Pa] and Poisson's ratio nu."""
    e, nu = youngs_modulus, poisson_ratio
    return e / (2.0 * (1.0 + nu)), e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))


def work_arrays(n: int) -> dict[str, np.ndarray]:
    """Per-slot work arrays of the passes (row-major 3x3 matrices)."""
    return {name: np.zeros((n, 9)) for name in ("R", "F", "P", "M")}
