"""Compiled passes of isotropic hyperelastic SPH solids (not a method): used by
:mod:`sphkit.solids.kee2023`.

The total Lagrangian deformation gradient of the gradient weights ``G_ij`` of
:mod:`sphkit.solids.gradients` (:func:`gradients`), the energy densities

* corotated: ``Psi = mu |F - R|^2 + lambda/2 (tr(R^T F) - 3)^2`` (R: F's rotation);
* stable neo-Hookean (Smith, de Goes & Kim 2018, Eq. 14):
  ``Psi = mu/2 (I_C - 3) + lambda/2 (J - a)^2 - mu/2 log(I_C + 1)``, ``a = 1 + 3 mu/(4 lambda)``
  (written minus its value at rest, so that Psi(I) = 0),

each as a function of the signed singular values of F (a reflection goes to the smallest one),
their first Piola-Kirchhoff stress ``P = U diag(dPsi/dsigma) V^T`` and the positive part of
their Hessian ``d^2 Psi / dF^2`` (:func:`material`) from the analytic eigensystem of an
isotropic energy (Smith, de Goes & Kim 2019, "Analytic eigensystems for isotropic distortion
energies"): three scaling modes ``U diag(q) V^T`` with (q, eigenvalue) the eigenpairs of the
3 x 3 Hessian in the singular values, and per pair (a, b) a twist mode
``U (e_a e_b^T - e_b e_a^T) V^T / sqrt(2)`` with eigenvalue ``(psi_a + psi_b) / (sigma_a +
sigma_b)`` and a flip mode (``+``) with ``(psi_a - psi_b) / (sigma_a - sigma_b)`` (its limit
``Psi_aa - Psi_ab`` at equal singular values); negative eigenvalues are dropped. Then the pieces
of a matrix-free Newton step: ``dP = H dF`` (:func:`hessian_apply`) and the inverse 3 x 3
diagonal blocks of ``M + dt^2 (K + Z)`` (:func:`block_jacobi`, :func:`block_apply`).
Matrices per particle are row-major 9-vectors (``F[a, c]`` at ``3 a + c``; the Hessian
9 x 9 at ``9 (3 a + c) + 3 a' + c'``); in 2D the vectors are padded to three components and F
has ``F_zz = 1`` (plane strain).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sphkit.core.pairs import pair_slots

_JIT = dict(cache=True, fastmath=True)

#: the energy densities (``material_model``) -> the compiled passes' ids
MATERIAL_MODELS = {"corotated": 0, "stable_neo_hookean": 1}


@numba.njit(parallel=True, **_JIT)
def gradients(y, off, idx, G, out):
    """``out[s]`` (row-major 3 x 3) ``= sum_j (y_j - y_s) G_sj^T`` for the (3, n) field y in
    slot order."""
    for s in numba.prange(y.shape[1]):
        g = out[s]
        for c in range(9):
            g[c] = 0.0
        for k in pair_slots(off, s):
            t = idx[k]
            g0, g1, g2 = G[k, 0], G[k, 1], G[k, 2]
            for a in range(3):
                d = y[a, t] - y[a, s]
                g[3 * a] += d * g0
                g[3 * a + 1] += d * g1
                g[3 * a + 2] += d * g2


@numba.njit(inline="always", cache=True)
def _add_mode(h, lam, U, Vt, M):
    """``h += lam vec(Q) vec(Q)^T`` with ``Q = U M V^T`` (row-major vec)."""
    q = np.empty(9)
    for a in range(3):
        for c in range(3):
            acc = 0.0
            for p in range(3):
                for r in range(3):
                    acc += U[a, p] * M[p, r] * Vt[r, c]
            q[3 * a + c] = acc
    for k in range(9):
        for l in range(9):
            h[9 * k + l] += lam * q[k] * q[l]


@numba.njit(parallel=True, cache=True)
def material(F, mu, lam, snh_a, model, hessian, P, psi, H):
    """Per particle: the energy density ``psi``, the stress ``P = U diag(dPsi/dsigma) V^T``
    and (``hessian``) the positive part of ``d^2 Psi / dF^2`` (81 entries, row-major vec)
    through the analytic eigensystem of an isotropic energy (module docstring); ``model`` 0
    corotated, 1 stable neo-Hookean (``snh_a``: its rest-stable ``a``)."""
    r2 = 1.0 / math.sqrt(2.0)
    for s in numba.prange(F.shape[0]):
        A = np.empty((3, 3))
        for a in range(3):
            for c in range(3):
                A[a, c] = F[s, 3 * a + c]
        U, sig, Vt = np.linalg.svd(A)
        if np.linalg.det(U) * np.linalg.det(Vt) < 0.0:  # signed SVD: R = U V^T a rotation
            for a in range(3):
                U[a, 2] = -U[a, 2]
            sig[2] = -sig[2]
        g = np.zeros(3)
        A3 = np.zeros((3, 3))
        if model == 0:
            t = sig[0] + sig[1] + sig[2] - 3.0
            psi[s] = mu * ((sig[0] - 1.0) ** 2 + (sig[1] - 1.0) ** 2 + (sig[2] - 1.0) ** 2) \
                + 0.5 * lam * t * t
            for a in range(3):
                g[a] = 2.0 * mu * (sig[a] - 1.0) + lam * t
                for b in range(3):
                    A3[a, b] = lam + (2.0 * mu if a == b else 0.0)
        else:
            ic = sig[0] * sig[0] + sig[1] * sig[1] + sig[2] * sig[2]
            J = sig[0] * sig[1] * sig[2]
            Ja = np.array([sig[1] * sig[2], sig[0] * sig[2], sig[0] * sig[1]])
            ja = J - snh_a
            psi[s] = 0.5 * mu * (ic - 3.0) + 0.5 * lam * ja * ja - 0.5 * mu * math.log(ic + 1.0) \
                - (0.5 * lam * (1.0 - snh_a) ** 2 - 0.5 * mu * math.log(4.0))  # 0 at rest
            w = 1.0 / (ic + 1.0)
            for a in range(3):
                g[a] = mu * sig[a] * (1.0 - w) + lam * ja * Ja[a]
                for b in range(3):
                    v = 2.0 * mu * sig[a] * sig[b] * w * w + lam * Ja[a] * Ja[b]
                    if a == b:
                        v += mu * (1.0 - w)
                    else:
                        v += lam * ja * sig[3 - a - b]
                    A3[a, b] = v
        p = P[s]
        for a in range(3):
            for c in range(3):
                p[3 * a + c] = U[a, 0] * g[0] * Vt[0, c] + U[a, 1] * g[1] * Vt[1, c] \
                    + U[a, 2] * g[2] * Vt[2, c]
        if not hessian:
            continue
        h = H[s]
        for k in range(81):
            h[k] = 0.0
        ev, Q = np.linalg.eigh(A3)
        M = np.zeros((3, 3))
        for k in range(3):  # scaling modes
            if ev[k] > 0.0:
                for a in range(3):
                    M[a, a] = Q[a, k]
                _add_mode(h, ev[k], U, Vt, M)
        for a in range(3):
            M[a, a] = 0.0
        for pair in range(3):  # twist and flip modes of the pairs (0,1), (1,2), (0,2)
            a = 0 if pair != 1 else 1
            b = 1 if pair == 0 else 2
            ssum = sig[a] + sig[b]
            if abs(ssum) < 1e-12:
                ssum = 1e-12
            twist = (g[a] + g[b]) / ssum
            sdif = sig[a] - sig[b]
            if abs(sdif) > 1e-6 * (abs(sig[a]) + abs(sig[b]) + 1e-12):
                flip = (g[a] - g[b]) / sdif
            else:
                flip = A3[a, a] - A3[a, b]
            if twist > 0.0:
                M[a, b], M[b, a] = r2, -r2
                _add_mode(h, twist, U, Vt, M)
            if flip > 0.0:
                M[a, b], M[b, a] = r2, r2
                _add_mode(h, flip, U, Vt, M)
            M[a, b], M[b, a] = 0.0, 0.0


@numba.njit(parallel=True, **_JIT)
def hessian_apply(H, dF, dP):
    """``dP[s] = H[s] dF[s]`` (9 x 9 times 9)."""
    for s in numba.prange(H.shape[0]):
        h = H[s]
        for k in range(9):
            acc = 0.0
            for l in range(9):
                acc += h[9 * k + l] * dF[s, l]
            dP[s, k] = acc


@numba.njit(inline="always", cache=True)
def _block_add(B, h, w, sc):
    """``B[a, a2] += sc sum_(c, c2) w_c h[(a, c), (a2, c2)] w_c2``."""
    for a in range(3):
        for a2 in range(3):
            acc = 0.0
            for c in range(3):
                for c2 in range(3):
                    acc += w[c] * h[9 * (3 * a + c) + 3 * a2 + c2] * w[c2]
            B[a, a2] += sc * acc


@numba.njit(parallel=True, cache=True)
def block_jacobi(off, idx, G, rev, V0, H, dt2, m, zdiag, dim, fixed, out):
    """The inverse of each particle's dim x dim diagonal block of ``M + dt^2 (K + Z)``
    (row-major 3 x 3, identity beyond dim and at pinned particles): the particle's own
    ``w = -sum_l G_sl`` and, for each rest neighbour t, the reverse pair's ``G_ts``."""
    for s in numba.prange(off.shape[0] - 1):
        B = np.zeros((3, 3))
        w = np.zeros(3)
        for k in pair_slots(off, s):
            for c in range(3):
                w[c] -= G[k, c]
        _block_add(B, H[s], w, dt2 * V0[s])
        for k in pair_slots(off, s):
            t = idx[k]
            _block_add(B, H[t], G[rev[k]], dt2 * V0[t])
        for a in range(3):
            B[a, a] += m[s] + zdiag[s]
        for a in range(3):
            for a2 in range(3):
                if a >= dim or a2 >= dim or fixed[s]:
                    B[a, a2] = 1.0 if a == a2 else 0.0
        Bi = np.linalg.inv(B)
        for a in range(3):
            for a2 in range(3):
                out[s, 3 * a + a2] = Bi[a, a2]


@numba.njit(parallel=True, **_JIT)
def block_apply(Binv, r, z, dim):
    """``z[:, s] = Binv[s] r[:, s]`` over the dim components ((dim, n) arrays)."""
    for s in numba.prange(r.shape[1]):
        b = Binv[s]
        for a in range(dim):
            acc = 0.0
            for c in range(dim):
                acc += b[3 * a + c] * r[c, s]
            z[a, s] = acc
