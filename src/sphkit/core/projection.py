"""Position projection of clamped density constraints: the two pair loops of position based
fluids (Macklin & Mueller 2013, "Position based fluids", ACM TOG 32(4), Eq. 8-12), shared by
PBF's solver (:mod:`sphkit.pressure.pbf`) and the start-up's density relaxation
(:mod:`sphkit.core.relaxation`).

With normalized densities ``rho_hat_i = V_i W(0) + sum_j V_j W_ij + sum_b V_b W_ib`` (``V = m /
rho0``, each particle's own rest density: number densities of several fluids) at the displaced
positions ``xp = x + dx`` (passed summed: three values gathered a pair instead of six) and a
target ``t_i`` per particle (1 for PBF):

* :func:`constraint_lambda` -- ``C_i = rho_hat_i / t_i - 1``, counted where it exceeds ``tol``
  (else 0: the clamp), and ``lambda_i = -C_i / (sum_k |grad_k rho_hat_i|^2 + eps)`` (Eq. 11 with
  Eq. 8's gradients; boundary particles are not moved, so they enter only ``grad_i``, unless
  given weights ``bw``: PBF's yielding bodies; several fluids: neighbour k's term weighed by
  ``rho0_i / rho0_k``, as the correction moves it);
* :func:`constraint_correction` -- ``dx_i = sum_j (lambda_i + (rho0_j / rho0_i) lambda_j +
  s_corr,ij) V_j grad
  W_ij + lambda_i sum_b V_b grad W_ib`` (Eq. 12/14, Akinci boundary as SPlisHSPlasH), with the
  optional artificial pressure ``s_corr,ij = -k (W_ij / W(dq))^n d0_inv`` (Eq. 13).

The pair loops use :mod:`sphkit.core.pairs` (minimum image along x with a period L > 0). Both
passes are per-particle bodies (``constraint_lambda_body``, ``constraint_correction_body``) run
through :func:`sphkit.backend.launch_reduce` / :func:`sphkit.backend.launch`: a ``prange`` loop
on the CPU, a CUDA kernel where the arrays are on the device.
"""

from __future__ import annotations

import math
from typing import Any

import numba

from sphkit.backend import launch, launch_reduce, specialize
from sphkit.core import arrays
from sphkit.core.kernels import kernel_dw, kernel_w
from sphkit.core.pairs import (
    delta,
    dot,
    norm,
    pair_slots,
    period_arg,
    point,
    separation,
    set_vector,
)

_JIT = dict(cache=True, fastmath=True)


@numba.njit(**_JIT, inline="always")
def constraint_lambda_body(i, xp, V, t, off, idx, bx, bV, boff, bidx, h, kid, dim, L, eps,
                           tol, lam, rho_hat, bw, c, inv_c):
    """Particle i of :func:`constraint_lambda`: ``rho_hat[i]``, ``lam[i]``; returns the clamped
    ``C_i`` (0 where the constraint is met). ``bw``: the boundary samples' weights in the
    denominator (empty: none); ``c``, ``inv_c``: the neighbours' weights ``rho0_i / rho0_j``
    (empty: one fluid)."""
    weighs = bw.shape[0] > 0
    ratios = c.shape[0] > 0
    ci = c[i] if ratios else 1.0
    xi0, xi1, xi2 = point(xp, i, dim)
    rho = V[i] * kernel_w(kid, 0.0, h, dim)
    g0 = g1 = g2 = 0.0
    sq = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2 = delta(xi0, xi1, xi2, xp, j, dim, L)
        r2 = dot(d0, d1, d2, d0, d1, d2)
        rr = math.sqrt(r2)
        rho += V[j] * kernel_w(kid, rr, h, dim)
        f = V[j] * kernel_dw(kid, rr, h, dim)
        g0 += f * d0
        g1 += f * d1
        g2 += f * d2
        if ratios:
            sq += f * f * r2 * (ci * inv_c[j])
        else:
            sq += f * f * r2
    for k in pair_slots(boff, i):
        b = bidx[k]
        d0, d1, d2, rr = separation(xi0, xi1, xi2, bx, b, dim, L)
        rho += bV[b] * kernel_w(kid, rr, h, dim)
        f = bV[b] * kernel_dw(kid, rr, h, dim)
        g0 += f * d0
        g1 += f * d1
        g2 += f * d2
        if weighs:
            sq += bw[b] * f * f * rr * rr
    rho_hat[i] = rho
    c = rho / t[i] - 1.0
    if c > tol:
        lam[i] = -c / (sq + g0 * g0 + g1 * g1 + g2 * g2 + eps)
        return c
    lam[i] = 0.0
    return 0.0


def constraint_lambda(xp: Any, V: Any, t: Any, off: Any, idx: Any, bx: Any, bV: Any,
                      boff: Any, bidx: Any, h: float, kid: int, dim: int,
                      L: float | tuple[float, ...], eps: float, tol: float, lam: Any,
                      rho_hat: Any, bw: Any = None, c: Any = None,
                      inv_c: Any = None) -> tuple[float, float]:
    """Density ``rho_hat`` at the displaced positions ``xp = x + dx`` and ``lambda`` of the
    clamped constraints (module docstring); returns (mean, max) of the clamped ``C``. ``bw``
    (N_b,): boundary samples that yield (PBF's dynamic bodies) add ``bw_b |V_b grad W_ib|^2``
    to the denominator as a fluid neighbour of weight ``bw_b`` would (None: none). Several
    fluids (``c``, ``inv_c`` of :class:`sphkit.core.state.RestArrays`; None: one fluid): each
    neighbour's term of the denominator weighs ``rho0_i / rho0_j = c_i inv_c_j``, the weight
    with which :func:`constraint_correction` moves neighbour j by lambda_i, so that lambda_i is
    the Newton step of C_i (as the ratio-weighted PPE diagonal of
    :func:`sphkit.core.ppe.diagonal_cached`; without it a heavy particle among light ones is
    corrected up to ``rho0_i / rho0_j`` times too far). The pass is
    :func:`constraint_lambda_body` through :func:`sphkit.backend.launch_reduce`."""
    n = xp.shape[1]
    if bw is None:
        bw = arrays.empty(0, xp.dtype, like=xp)
    if c is None or inv_c is None:
        c = inv_c = arrays.empty(0, xp.dtype, like=xp)
    tot, mx = launch_reduce(constraint_lambda_body, n, xp, V, t, off, idx, bx, bV, boff, bidx,
                            float(h), int(kid), int(dim), period_arg(L), float(eps), float(tol),
                            lam, rho_hat, bw, c, inv_c)
    return tot / max(n, 1), mx


@numba.njit(**_JIT, inline="always")
def constraint_correction_body(i, xp, V, lam, off, idx, bx, bV, boff, bidx, h, kid, dim, L,
                               s_corr, k_corr, n_corr, w_dq, d0_inv, out, c, inv_c):
    """Particle i of :func:`constraint_correction`: ``out[:, i]``. Every pair is summed, also
    those with ``lambda_i + lambda_j = 0`` (a skip of those made the pass 12 % slower: the
    branch is unpredictable). ``c``, ``inv_c`` empty: one fluid."""
    ratios = c.shape[0] > 0
    xi0, xi1, xi2 = point(xp, i, dim)
    li = lam[i]
    ici = inv_c[i] if ratios else 1.0
    c0 = c1 = c2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        s = li + (lam[j] * (c[j] * ici) if ratios else lam[j])
        d0, d1, d2 = delta(xi0, xi1, xi2, xp, j, dim, L)
        rr = norm(d0, d1, d2)
        if s_corr:
            s -= k_corr * (kernel_w(kid, rr, h, dim) / w_dq) ** n_corr * d0_inv
        f = s * V[j] * kernel_dw(kid, rr, h, dim)
        c0 += f * d0
        c1 += f * d1
        c2 += f * d2
    if li != 0.0:
        for k in pair_slots(boff, i):
            b = bidx[k]
            d0, d1, d2, r = separation(xi0, xi1, xi2, bx, b, dim, L)
            f = li * bV[b] * kernel_dw(kid, r, h, dim)
            c0 += f * d0
            c1 += f * d1
            c2 += f * d2
    set_vector(out, i, dim, c0, c1, c2)


#: the artificial pressure's switch compiled in with the kernel id: with it an argument, the
#: loop the constant id vectorises kept its code and ran 1.8x slower than with the id an
#: argument; with both constants 0.87 -> 0.47 ms (6,859 particles, two threads)
specialize(constraint_correction_body, "kid", "s_corr")


def constraint_correction(xp: Any, V: Any, lam: Any, off: Any, idx: Any, bx: Any,
                          bV: Any, boff: Any, bidx: Any, h: float, kid: int, dim: int,
                          L: float | tuple[float, ...], s_corr: bool, k_corr: float,
                          n_corr: float, w_dq: float, d0_inv: float, out: Any, c: Any = None,
                          inv_c: Any = None) -> None:
    """``out_i`` = the position correction of the module docstring at ``xp = x + dx``
    (``s_corr``: with the artificial pressure term). Several fluids: the neighbour's lambda
    weighs ``rho0_j / rho0_i = c_j inv_c_i`` (SPlisHSPlasH's ``TimeStepPBF``; c, inv_c of
    :class:`sphkit.core.state.RestArrays`; None: one fluid, or lambdas unweighted). The pass is
    :func:`constraint_correction_body` through :func:`sphkit.backend.launch`."""
    if c is None or inv_c is None:
        c = inv_c = arrays.empty(0, xp.dtype, like=xp)
    launch(constraint_correction_body, xp.shape[1], xp, V, lam, off, idx, bx, bV, boff, bidx,
           float(h), int(kid), int(dim), period_arg(L), bool(s_corr), float(k_corr),
           float(n_corr), float(w_dq), float(d0_inv), out, c, inv_c)
