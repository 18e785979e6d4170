"""The static walls' own pressures ``k_b``, solved in the pressure Poisson equation where the
scene asks for them (``configuration.boundary.solved``,
:meth:`sphkit.core.coupling.BoundaryCoupling.solved_walls`; the constraint and its use in the
Jacobi iterations: :func:`sphkit.core.solver.jacobi_ppe` and PCISPH's loop).

Serial passes over the fluid-boundary pairs (listed by fluid particle; a wall particle collects
from several) with the step's cached ``gwb = V_b grad W_ib`` (:mod:`sphkit.core.ppe`):

* :func:`wall_sums` -- the fluid's density rate at each wall particle;
* :func:`wall_diagonal` -- its Jacobi scale;
* :func:`wall_update` -- its clamped update;
* :func:`wall_density` -- the fluid's density at it (``solved: "density"``).
"""

from __future__ import annotations

import numba
import numpy as np

from sphkit.core.kernels import kernel_w
from sphkit.core.pairs import distance, pair_slots, point
from sphkit.core.ppe import _JIT, _JIT_GATHER


@numba.njit(**_JIT_GATHER)
def wall_sums(v, vb, Vf, Vb, boff, bidx, gwb, dim, use, out):
    """``out[b] = sum_f (V_f / V_b) gwb_fb . (v_f - v_b)`` for the static boundary particles b
    with ``use[b]`` (0 elsewhere), over the fluid-boundary pairs ``(boff, bidx)`` with the
    cached ``gwb = V_b grad_f W_fb``: for velocities v (``vb`` the wall particles' velocities,
    0 unless a script moves the walls) the rate of the fluid's normalized density at the wall
    particle, ``D rho_hat_b / Dt = sum_f V_f (v_f - v_b) . grad_f W_fb`` (positive when the
    fluid approaches it), for pressure accelerations (``vb`` = 0: pressure does not accelerate
    the walls) its change per dt^2. One serial pass (the pairs are listed by fluid particle; a
    boundary particle collects from several)."""
    out[:] = 0.0
    for i in range(boff.shape[0] - 1):
        wi = Vf[i]
        for kk in pair_slots(boff, i):
            b = bidx[kk]
            t = (v[0, i] - vb[0, b]) * gwb[0, kk]
            if dim > 1:
                t += (v[1, i] - vb[1, b]) * gwb[1, kk]
            if dim > 2:
                t += (v[2, i] - vb[2, b]) * gwb[2, kk]
            out[b] += wi * t
    for b in range(out.shape[0]):
        out[b] = out[b] / Vb[b] if use[b] else 0.0


@numba.njit(**_JIT_GATHER)
def wall_diagonal(Vf, Vb, inv_c, boff, bidx, gwb, dim, use, out):
    """The Jacobi scale of the solved walls: ``out[b] = sum_f (V_f / V_b) (1 / c_f)
    max(gwb_fb . B_f, |gwb_fb|^2)`` with ``B_f = sum_b' gwb_fb'`` over fluid f's solved wall
    neighbours. ``|gwb_fb|^2`` alone is minus the derivative of the wall particle's
    :func:`wall_sums` of the pressure accelerations with respect to its own ``k_b`` (the
    pressure acceleration of fluid f holds ``-k_b gwb_fb / c_f``), but the wall particles next
    to one fluid particle all act on it through nearly parallel gradients (about nine on a flat
    3D floor), so the plain Jacobi update overshoots by about that count and diverged (a 3D
    column at density ratio 1:10 blew up within 14 ms); with ``gwb_fb . B_f`` the scale is the
    sum of the row of the wall block (Gershgorin), for which the walls' Jacobi converges."""
    n = boff.shape[0] - 1
    B = np.zeros((3, n))
    for i in range(n):
        for kk in pair_slots(boff, i):
            if use[bidx[kk]]:
                for d in range(dim):
                    B[d, i] += gwb[d, kk]
    out[:] = 0.0
    for i in range(n):
        wi = Vf[i] * inv_c[i]
        for kk in pair_slots(boff, i):
            b = bidx[kk]
            t = gwb[0, kk] * gwb[0, kk]
            tb = gwb[0, kk] * B[0, i]
            if dim > 1:
                t += gwb[1, kk] * gwb[1, kk]
                tb += gwb[1, kk] * B[1, i]
            if dim > 2:
                t += gwb[2, kk] * gwb[2, kk]
                tb += gwb[2, kk] * B[2, i]
            out[b] += wi * max(t, tb)
    for b in range(out.shape[0]):
        out[b] = out[b] / Vb[b] if use[b] else 0.0


@numba.njit(**_JIT_GATHER)
def wall_update(ap, s, D, ap_factor, omega, kb, k, boff, bidx, cap, kmax):
    """The walls' Jacobi update ``k_b <- min(max(k_b - omega (s_b - f Ap_b) / (f D_b), 0),
    cap max_f k_f)`` (Ap_b: :func:`wall_sums` of the pressure accelerations; D_b:
    :func:`wall_diagonal`; no update where D_b = 0: no fluid neighbour, or a wall particle that
    is not solved). The bound ``cap`` times the largest ``k_f`` of the wall particle's fluid
    neighbours (``kmax``, a work array) keeps the wall from pushing harder than mirroring
    (``cap = 1``: ``k_b <= max_f k_f``) where the walls' velocity-level constraint and the
    fluid's density-level one cannot both hold (fluid compressed against a wall)."""
    kmax[:] = 0.0
    for i in range(boff.shape[0] - 1):
        for kk in pair_slots(boff, i):
            b = bidx[kk]
            if k[i] > kmax[b]:
                kmax[b] = k[i]
    for b in range(kb.shape[0]):
        if D[b] > 0.0:
            r = s[b] - ap_factor * ap[b]
            kb[b] = min(max(kb[b] - omega * r / (ap_factor * D[b]), 0.0), cap * kmax[b])


@numba.njit(**_JIT)
def wall_density(x, Vf, bx, boff, bidx, h, kid, dim, L, use, out):
    """``out[b] = sum_f V_f W(x_f - x_b)``, the fluid's normalized (number) density at the
    static boundary particles b with ``use[b]`` (0 elsewhere), over the fluid-boundary pairs
    ``(boff, bidx)`` (``L``: the period argument of the pair loops). The density-level solved
    walls (``configuration.boundary.solved: "density"``) hold it at each wall particle's rest
    value (:meth:`sphkit.core.coupling.BoundaryCoupling.wall_rest`). One serial pass, as
    :func:`wall_sums`."""
    out[:] = 0.0
    for i in range(boff.shape[0] - 1):
        xi0, xi1, xi2 = point(x, i, dim)
        wi = Vf[i]
        for kk in pair_slots(boff, i):
            b = bidx[kk]
            if use[b]:
                out[b] += wi * kernel_w(kid, distance(xi0, xi1, xi2, bx, b, dim, L), h, dim)
