"""Position projection of clamped density constraints: the two pair loops of position based
fluids (Macklin & Mueller 2013, "Position based fluids", ACM TOG 32(4), Eq. 8-12), shared by
PBF's solver (:mod:`sphkit.pressure.pbf`) and the start-up's density relaxation
(:mod:`sphkit.core.relaxation`).

With normalized densities ``rho_hat_i = V_i W(0) + sum_j V_j W_ij + sum_b V_b W_ib`` (``V = m /
rho0``, each particle's own rest density: number densities of several fluids) at the displaced
positions ``x + dx`` and a target ``t_i`` per particle (1 for PBF):

* :func:`constraint_lambda` -- ``C_i = rho_hat_i / t_i - 1``, counted where it exceeds ``tol``
  (else 0: the clamp), and ``lambda_i = -C_i / (sum_k |grad_k rho_hat_i|^2 + eps)`` (Eq. 11 with
  Eq. 8's gradients; boundary particles are not moved, so they enter only ``grad_i``);
* :func:`constraint_correction` -- ``dx_i = sum_j (lambda_i + (rho0_j / rho0_i) lambda_j +
  s_corr,ij) V_j grad
  W_ij + lambda_i sum_b V_b grad W_ib`` (Eq. 12/14, Akinci boundary as SPlisHSPlasH), with the
  optional artificial pressure ``s_corr,ij = -k (W_ij / W(dq))^n d0_inv`` (Eq. 13).

The pair loops use :mod:`sphkit.core.pairs` (minimum image along x with a period L > 0).
"""

from __future__ import annotations

import math

import numba

from sphkit.core.kernels import kernel_dw, kernel_w
from sphkit.core.pairs import (
    displaced_delta,
    displaced_point,
    dot,
    norm,
    separation,
    set_vector,
)

_JIT = dict(cache=True, fastmath=True)


@numba.njit(parallel=True, **_JIT)
def constraint_lambda(x, dx, V, t, off, idx, bx, bV, boff, bidx, h, kid, dim, L, eps, tol,
                      lam, rho_hat):
    """Density ``rho_hat`` at ``x + dx`` and ``lambda`` of the clamped constraints (module
    docstring); returns (mean, max) of the clamped ``C``."""
    n = x.shape[1]
    tot = 0.0
    mx = 0.0
    w0 = kernel_w(kid, 0.0, h, dim)
    for i in numba.prange(n):
        xi0, xi1, xi2 = displaced_point(x, dx, i, dim)
        rho = V[i] * w0
        g0 = g1 = g2 = 0.0
        sq = 0.0
        for k in range(off[i], off[i + 1]):
            j = idx[k]
            d0, d1, d2 = displaced_delta(xi0, xi1, xi2, x, dx, j, dim, L)
            r2 = dot(d0, d1, d2, d0, d1, d2)
            rr = math.sqrt(r2)
            rho += V[j] * kernel_w(kid, rr, h, dim)
            f = V[j] * kernel_dw(kid, rr, h, dim)
            g0 += f * d0
            g1 += f * d1
            g2 += f * d2
            sq += f * f * r2
        for k in range(boff[i], boff[i + 1]):
            b = bidx[k]
            d0, d1, d2, rr = separation(xi0, xi1, xi2, bx, b, dim, L)
            rho += bV[b] * kernel_w(kid, rr, h, dim)
            f = bV[b] * kernel_dw(kid, rr, h, dim)
            g0 += f * d0
            g1 += f * d1
            g2 += f * d2
        rho_hat[i] = rho
        c = rho / t[i] - 1.0
        if c > tol:
            lam[i] = -c / (sq + g0 * g0 + g1 * g1 + g2 * g2 + eps)
        else:
            lam[i] = 0.0
            c = 0.0
        tot += c
        mx = max(mx, c)
    return tot / max(n, 1), mx


@numba.njit(parallel=True, **_JIT)
def constraint_correction(x, dx, V, lam, off, idx, bx, bV, boff, bidx, h, kid, dim, L, s_corr,
                          k_corr, n_corr, w_dq, d0_inv, out, c, inv_c):
    """``out_i`` = the position correction of the module docstring at ``x + dx``
    (``s_corr``: with the artificial pressure term). Several fluids: the neighbour's lambda
    weighs ``rho0_j / rho0_i = c_j inv_c_i`` (SPlisHSPlasH's ``TimeStepPBF``; c, inv_c of
    :class:`sphkit.core.state.RestArrays`, ones for one fluid)."""
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = displaced_point(x, dx, i, dim)
        li = lam[i]
        ici = inv_c[i]
        c0 = c1 = c2 = 0.0
        for k in range(off[i], off[i + 1]):
            j = idx[k]
            s = li + lam[j] * (c[j] * ici)
            if not s_corr and s == 0.0:
                continue
            d0, d1, d2 = displaced_delta(xi0, xi1, xi2, x, dx, j, dim, L)
            rr = norm(d0, d1, d2)
            if s_corr:
                s -= k_corr * (kernel_w(kid, rr, h, dim) / w_dq) ** n_corr * d0_inv
            f = s * V[j] * kernel_dw(kid, rr, h, dim)
            c0 += f * d0
            c1 += f * d1
            c2 += f * d2
        if li != 0.0:
            for k in range(boff[i], boff[i + 1]):
                b = bidx[k]
                d0, d1, d2, r = separation(xi0, xi1, xi2, bx, b, dim, L)
                f = li * bV[b] * kernel_dw(kid, r, h, dim)
                c0 += f * d0
                c1 += f * d1
                c2 += f * d2
        set_vector(out, i, dim, c0, c1, c2)
