"""Building blocks of the pressure Poisson solvers (survey Sec. 4.2-4.4).

The survey shows that PCISPH, IISPH, DFSPH (and PBF) are relaxed Jacobi iterations on a pressure
Poisson equation ``A q = s`` and differ in the source term s, the diagonal, the accumulated
quantity and boundary details. These compiled passes are the shared pieces; the solvers in
:mod:`sphkit.pressure` combine them, and :func:`sphkit.core.solver.jacobi_ppe` runs the loop.

Notation (SPlisHSPlasH's normalized units): ``V_j = m_j / rho0_j`` is the rest volume of fluid
particle j (each particle has its own rest density rho0_i: several fluids, Solenthaler & Pajarola
2008; :class:`sphkit.core.state.RestArrays`), ``V_b`` the volume of boundary particle b
(Akinci 2012), ``rho_hat = rho / rho0``.

The iterations walk the same pairs many times per step, so :func:`pair_gradients` stores
``V_j grad W_ij`` (and ``V_b grad W_ib``) once per step (as SPlisHSPlasH's
USE_PERFORMANCE_OPTIMIZATION does) and the other passes are multiply-adds over it:

* :func:`kappa_accel_cached` -- the pressure acceleration of a "kappa" field
  (kappa = p / (rho0 rho_hat^2)):
  ``a_i = -sum_j V_j (k_i + k_j) grad W_ij - sum_b V_b ((1 + m_b) k_i + k_b) grad W_ib`` (a
  solver whose variable is q passes ``k = w q``; ``k_b`` is an extrapolated boundary pressure
  ``p_b / rho0`` where the scene asks for one, :mod:`sphkit.boundary.band2018`, else 0).
  ``m_b`` is the boundary field ``pressure_mirror``: 0 gives
  SPlisHSPlasH's boundary term ``V_b k_i`` (DFSPH, IISPH), which balances the about twice too
  large Akinci volumes of a *single* surface layer (meshes, maps); 1 mirrors the boundary
  pressure fully (Akinci et al. 2012, ``p_b = p_i``) in the symmetric form of the fluid pairs, as
  sphkit's WCSPH force does, which is right for walls whose volumes reproduce the missing fluid
  (the two-layer lattice walls of scene ``boxes``). With the factor 1 there, a net pull towards
  the wall of ``k_i sum_b V_b grad W_ib`` grows with the pressure: measured, the fluid crept into
  the corners of a 3D dam break and left them as jets along the vertical edges (6-7 m/s against
  a 4 m/s front), and a settled 2D column (DFSPH, width 0.3 m) had a pressure slope of 1.06-1.08
  rho0 g (IISPH 1.09) against 1.025 (IISPH 1.037) with full mirroring;
* :func:`pair_divergence_cached` -- ``sum_j V_j (u_i - u_j) . grad W_ij
  + sum_b V_b (u_i - u_b) . grad W_ib``: for velocities ``D rho_hat_i / Dt`` (positive when
  compressing), for accelerations (u_b = 0) the change of normalized density per dt^2 they cause;
* :func:`diagonal_cached` -- ``D_i = (G_i + B_i) . (G_i + M_i) + sum_j V_j^2 |grad W_ij|^2``
  with ``G_i = sum_j V_j grad W_ij``, ``B_i = sum_b V_b grad W_ib``, ``M_i = sum_b (1 + m_b) V_b
  grad W_ib``: minus the diagonal (for equal volumes V_i = V_j) of the divergence of
  ``kappa_accel(k)`` with respect to k_i (the papers' ``|G_i + B_i|^2 + ...`` when m_b = 0).
  DFSPH's factor is ``alpha_i = 1 / D_i`` (Bender & Koschier 2017, Eq. 9) and IISPH's
  ``a_ii = -D_i / rho_hat_i^2`` (Ihmsen et al. 2014, Eq. 12, in these units);
* :func:`jacobi_sweep` -- ``Ap_i`` (the divergence above, of the pressure accelerations) and
  ``q_i <- max(q_i - omega * scale_i * (s_i - f Ap_i), 0)`` in one pass, with the error of the
  residual before the update;
* :func:`density_at` -- PCISPH's / PBF's density at predicted positions;
* the boundary sums ``B_i = sum_b V_b grad W_ib`` (:func:`diagonal_cached` adds them up), with
  which a boundary that takes no pressure acceleration enters :func:`jacobi_sweep` without a
  pass over its pairs.

The static walls' own pressures (``configuration.boundary.solved``) have their passes in
:mod:`sphkit.core.solved_walls`.

:func:`density_pair_gradients`, :func:`kappa_accel_cached`, :func:`jacobi_sweep`,
:func:`diagonal_cached`, :func:`pair_divergence_cached` and :func:`density_at` are per-particle
bodies (``density_pair_gradients_body``, ``kappa_accel_body``, ``jacobi_body``,
``diagonal_body``, ``divergence_body``, ``density_at_body``) run through
:func:`sphkit.backend.launch` / :func:`sphkit.backend.launch_reduce`: a ``prange`` loop on the
CPU, a CUDA kernel with ``device="cuda"``; the bodies carry their fast-math flags.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numba
import numpy as np

from sphkit.backend import launch, launch_reduce, specialize
from sphkit.core import arrays
from sphkit.core.kernels import kernel_dw, kernel_w
from sphkit.core.neighbors import INDEX
from sphkit.core.pairs import (
    add_vector,
    displaced_delta,
    distance,
    norm,
    pair_slots,
    period_arg,
    point,
    separation,
    set_vector,
)

if TYPE_CHECKING:
    from sphkit.core.state import SimState

_JIT = dict(cache=True, fastmath=True)

#: Fast-math flags of the passes over the *cached* pair gradients (:func:`kappa_accel_cached`,
#: :func:`pair_divergence_cached`, :func:`jacobi_sweep`, :func:`diagonal_cached`): all of
#: ``fastmath=True`` except ``reassoc``. Without reassociation LLVM keeps each particle's pair
#: sum in order and does not vectorize it; vectorized, the sum over the ~30 pairs of a particle
#: became AVX-512 gathers of the neighbours' values plus remainder loops, and each of these
#: passes ran about twice as slow (measured on the DFSPH benchmark scene, one thread, AMD EPYC
#: with AVX-512: kappa_accel_cached 466 -> 242 us, pair_divergence_cached 568 -> 273 us,
#: jacobi_sweep 598 -> 327 us, diagonal_cached 346 -> 212 us). The passes that evaluate the
#: kernel (density, gradients, viscosity) keep ``fastmath=True``: there vectorizing the kernel
#: pays (10-30 % faster). In-order sums are also independent of the vector width.
GATHER_FASTMATH = frozenset({"nnan", "ninf", "nsz", "arcp", "contract", "afn"})
_JIT_GATHER = dict(cache=True, fastmath=set(GATHER_FASTMATH))


@numba.njit(**_JIT_GATHER, inline="always")
def jacobi_body(i, a, ab, off, idx, boff, bidx, gw, gwb, bsum, dim, q, s, ap_factor, scale,
                omega, active, w, k, shift, lo, err):
    """Particle i of :func:`jacobi_sweep`: updates ``q[i]``, ``k[i]`` and returns the compressive
    residual ``max(-r_i, 0)`` before the update if i is active, else 0 (the value
    :func:`sphkit.backend.launch_reduce` sums and maximizes). ``shift``: the diagonal term
    ``+ shift q_i`` of a compressible PPE (0: incompressible); ``lo``: the clamp ``q >= lo`` (0:
    pressure clamping; -1e300: none, finite because of fast math's no-infinities flag).
    ``bsum`` (dim, N): the boundary sums ``B_i`` of a boundary that takes no acceleration (the
    boundary pairs' share is then ``a_i . B_i``, no pass over them); (dim, 0): the pairs with
    the boundary accelerations ``ab``. An empty ``w``: k is q itself (weight 1, nothing written
    to k); an empty ``active``: every particle is active; ``err`` with entries: the returned
    residual is also written to ``err[i]`` (several rest densities: each class's mean,
    :func:`sphkit.core.solver.group_error`)."""
    if bsum.shape[1] > 0:
        ai0, ai1, ai2 = point(a, i, dim)
        b0, b1, b2 = point(bsum, i, dim)
        div = _fluid_divergence_i(i, a, off, idx, gw, dim) + (ai0 * b0 + ai1 * b1 + ai2 * b2)
    else:
        div = _divergence_i(i, a, ab, off, idx, boff, bidx, gw, gwb, dim)
    r = s[i] - ap_factor * div + shift * q[i]
    qi = max(q[i] - omega * scale[i] * r, lo)
    q[i] = qi
    if w.shape[0] > 0:  # weighted: k is its own array (else k is q itself)
        k[i] = w[i] * qi
    e = max(-r, 0.0) if active.shape[0] == 0 or active[i] else 0.0
    if err.shape[0] > 0:
        err[i] = e
    return e


#: run in every iteration of the pressure solvers: a driver per dimension (9-12 % faster)
specialize(jacobi_body, "dim")


def jacobi_sweep(a: np.ndarray, ab: np.ndarray, off: np.ndarray, idx: np.ndarray,
                 boff: np.ndarray, bidx: np.ndarray, gw: np.ndarray, gwb: np.ndarray, dim: int,
                 q: np.ndarray, s: np.ndarray, ap_factor: float, scale: np.ndarray, omega: float,
                 active: np.ndarray | None, w: np.ndarray | None, k: np.ndarray,
                 shift: float = 0.0, lo: float = 0.0,
                 bsum: np.ndarray | None = None,
                 err: np.ndarray | None = None) -> tuple[float, float]:
    """The second half of one Jacobi iteration, in one pass: for every particle the product
    ``Ap_i`` = :func:`pair_divergence_cached` of the pressure accelerations a (boundary
    accelerations ab), the residual ``r_i = s_i - f Ap_i`` (f = ap_factor), the update of q and
    the weighted variable ``k_i = w_i q_i`` that the next :func:`kappa_accel_cached` reads (the
    pass reads only a, so writing q and k in place keeps it a Jacobi sweep). The update is
    ``q_i <- max(q_i - omega scale_i r_i, 0)`` (IISPH, and DFSPH with omega 0.5 as
    SPlisHSPlasH's ``TimeStepDFSPH``; the one-sided update DFSPH used before 2026-11-26 is
    described in :mod:`sphkit.pressure.dfsph`). A compressible PPE (ICSPH,
    :mod:`sphkit.pressure.icsph`) adds the diagonal term ``shift q_i`` to the residual,
    ``r_i = s_i - f Ap_i + shift q_i``, and may clamp at ``lo`` = -1e300 (no clamping) instead of 0.

    Returns (mean over all particles, max) of the compressive residual ``max(-r_i, 0)`` of active
    particles, before the update. (One pass instead of a divergence pass, an update pass and a
    multiplication: 3-4 % of a DFSPH step on the benchmark scene.) The pass is
    :func:`jacobi_body` through :func:`sphkit.backend.launch_reduce`, which reduces the residuals
    in the same ``prange`` loop.

    ``bsum``: the boundary sums ``B_i = sum_b V_b grad W_ib`` (:meth:`sphkit.core.solver.
    PairGradients.boundary_sums`) where the boundary takes no pressure acceleration (ab = 0):
    the boundary pairs' share of ``Ap_i`` is then ``a_i . B_i``, and the pass reads the fluid
    pairs only (the DFSPH benchmark scene's pass 0.110 -> 0.099 ms at 6,859 particles, two
    threads); None: the pairs with ab.

    ``w`` None: the weight is 1 and k is q itself (DFSPH with one rest density: no weight read
    and no k written a particle, 0.08-0.15 ms of a 1.5 ms sweep at 59,319 particles, two
    threads); ``active`` None: every particle counts; ``err`` (N,): each particle's residual
    as well (several rest densities; None: not written).
    """
    n = q.shape[0]
    if bsum is None:
        bsum = arrays.absent((a.shape[0], 0), a.dtype, like=a)
    if w is None:
        w = arrays.absent(0, q.dtype, like=q)
    if active is None:
        active = arrays.absent(0, np.bool_, like=q)
    if err is None:
        err = arrays.absent(0, q.dtype, like=q)
    tot, mx = launch_reduce(jacobi_body, n, a, ab, off, idx, boff, bidx, gw, gwb, bsum, int(dim),
                            q, s, float(ap_factor), scale, float(omega), active, w, k,
                            float(shift), float(lo), err)
    return tot / max(n, 1), mx


@numba.njit(**_JIT, inline="always")
def density_at_body(i, xp, m, off, idx, bx, bdx, bV, boff, bidx, rho0, h, kid, dim, one, out):
    """Particle i of :func:`density_at`: ``out[i]`` (``one``: every mass is ``m[0]``)."""
    moving = bdx.shape[1] > 0
    xi0, xi1, xi2 = point(xp, i, dim)
    s = m[0 if one else i] / rho0 * kernel_w(kid, 0.0, h, dim)
    for k in pair_slots(off, i):
        j = idx[k]
        mj = m[0] if one else m[j]
        s += mj / rho0 * kernel_w(kid, distance(xi0, xi1, xi2, xp, j, dim, 0.0), h, dim)
    for k in pair_slots(boff, i):
        b = bidx[k]
        if moving:
            d0, d1, d2 = displaced_delta(xi0, xi1, xi2, bx, bdx, b, dim, 0.0)
            rb = norm(d0, d1, d2)
        else:
            rb = distance(xi0, xi1, xi2, bx, b, dim, 0.0)
        s += bV[b] * kernel_w(kid, rb, h, dim)
    out[i] = s


def density_at(xp: np.ndarray, m: np.ndarray, off: np.ndarray, idx: np.ndarray,
               bx: np.ndarray, bdx: np.ndarray, bV: np.ndarray, boff: np.ndarray,
               bidx: np.ndarray, rho0: float, h: float, kid: int, dim: int,
               out: np.ndarray, one_mass: bool = False) -> None:
    """Normalized density at the predicted positions ``xp = x + dx`` with the neighbour lists
    of x (PCISPH's prediction): ``sum_j V_j W(x*_i - x*_j) + sum_b V_b W(x*_i - x*_b)``, self
    included (``V_j = m_j / rho0``; several fluids: pass ``mu = m / c`` of
    :class:`sphkit.core.state.RestArrays` as m and the reference rest density, which gives the
    number density ``rho_i / rho0_i`` with ``V_j = m_j / rho0_j``), with the boundary displaced
    by ``bdx`` (boundary particles that yield to the pressure,
    :meth:`sphkit.core.coupling.BoundaryCoupling.displacement`); an empty bdx (dim, 0) leaves
    the boundary where it is. The positions come summed (three values gathered a pair instead
    of six: 0.36 -> 0.25 ms a call at 6,859 particles). ``one_mass``: every entry of m is the
    same (:attr:`sphkit.core.state.RestArrays.one_mass`), a constant of the compiled pass, which
    then gathers no mass (2.01 -> 1.67 ms a call at 59,319 particles, two threads). The pass is
    :func:`density_at_body` through :func:`sphkit.backend.launch`."""
    launch(density_at_body, xp.shape[1], xp, m, off, idx, bx, bdx, bV, boff, bidx,
           float(rho0), float(h), int(kid), int(dim), bool(one_mass), out)


#: the kernel and whether the masses are one value, compiled in (PCISPH: every iteration)
specialize(density_at_body, "kid", "one")


def neighbor_counts(off: np.ndarray, boff: np.ndarray) -> np.ndarray:
    """Fluid plus boundary neighbours of every fluid particle."""
    return np.diff(off) + np.diff(boff)


@numba.njit(cache=True, inline="always")
def surrounded_body(i, off, boff, least, out):
    """``out[i]``: particle i has at least ``least`` fluid plus boundary neighbours."""
    out[i] = (off[i + 1] - off[i]) + (boff[i + 1] - boff[i]) >= least


def surrounded(off: np.ndarray, boff: np.ndarray, least: int) -> np.ndarray:
    """Which fluid particles have at least ``least`` neighbours (fluid plus boundary; bool (N,),
    where the lists are)."""
    n = off.shape[0] - 1
    out = arrays.empty(n, np.bool_, like=off)
    launch(surrounded_body, n, off, boff, int(least), out)
    return out


@numba.njit(cache=True, inline="always")
def held_body(i, animated, active, out):
    """``out[i]``: particle i is one a pressure solve holds: not animated (``animated[i]`` 0)
    and, where ``active`` has entries, active."""
    out[i] = animated[i] == 0 and (active.shape[0] == 0 or active[i])


def held(state: SimState, active: np.ndarray | None = None) -> np.ndarray | None:
    """The fluid particles a pressure solve holds (bool (N,)): those of ``active`` (None: all)
    that no emitter moves in this step (``state.animated``; SPlisHSPlasH's solvers leave its
    ``AnimatedByEmitter`` particles out, DFSPH of the solve, the others of the integration);
    ``active`` itself where no emitter animates. A solve keeps the others' pressure at 0 and
    leaves their residual out of its error."""
    if state.animated is None:
        return active
    n = state.fluid.n
    out = arrays.empty(n, np.bool_, like=state.animated)
    act = active if active is not None else arrays.absent(0, np.bool_, like=state.animated)
    launch(held_body, n, state.animated, act, out)
    return out


@numba.njit(cache=True, inline="always")
def release_body(i, rows, x):
    """``x[i] = 0`` where particle i is not held (``rows[i]`` false)."""
    if not rows[i]:
        x[i] = 0.0


@numba.njit(parallel=True, **_JIT)
def pair_gradients(x, V, off, idx, bx, bV, boff, bidx, h, kid, dim, gw, gwb, L=0.0):
    """gw[:, k] = V_j grad W_ij for the k-th fluid pair, gwb[:, k] = V_b grad W_ib (``L`` > 0:
    periodic along x with period L, minimum-image differences)."""
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
            f = V[j] * kernel_dw(kid, r, h, dim)
            set_vector(gw, k, dim, f * d0, f * d1, f * d2)
        for k in pair_slots(boff, i):
            b = bidx[k]
            d0, d1, d2, r = separation(xi0, xi1, xi2, bx, b, dim, L)
            f = bV[b] * kernel_dw(kid, r, h, dim)
            set_vector(gwb, k, dim, f * d0, f * d1, f * d2)


@numba.njit(**_JIT, inline="always")
def density_pair_gradients_body(i, x, m, off, idx, bx, bV, boff, bidx, rho0, h, kid, dim, rho,
                                gw, gwb, L, V, c):
    """Particle i of :func:`density_pair_gradients`: ``rho[i]`` and the pair gradients of its
    fluid pairs ``gw[:, off[i]:off[i + 1]]`` and boundary pairs ``gwb[:, boff[i]:boff[i + 1]]``
    (its own CSR rows). ``m`` is ``mu = m / c``, ``V`` the rest volumes, ``c`` the rest-density
    ratios of :class:`sphkit.core.state.RestArrays`."""
    xi0, xi1, xi2 = point(x, i, dim)
    s = m[i] * kernel_w(kid, 0.0, h, dim)
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
        s += m[j] * kernel_w(kid, r, h, dim)
        f = V[j] * kernel_dw(kid, r, h, dim)
        set_vector(gw, k, dim, f * d0, f * d1, f * d2)
    sb = 0.0
    for k in pair_slots(boff, i):
        b = bidx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, bx, b, dim, L)
        sb += bV[b] * kernel_w(kid, r, h, dim)
        f = bV[b] * kernel_dw(kid, r, h, dim)
        set_vector(gwb, k, dim, f * d0, f * d1, f * d2)
    rho[i] = c[i] * (s + rho0 * sb)


def density_pair_gradients(x: np.ndarray, m: np.ndarray, off: np.ndarray, idx: np.ndarray,
                           bx: np.ndarray, bV: np.ndarray, boff: np.ndarray, bidx: np.ndarray,
                           rho0: float, h: float, kid: int, dim: int, rho: np.ndarray,
                           gw: np.ndarray, gwb: np.ndarray, L: float = 0.0,
                           V: np.ndarray | None = None, c: np.ndarray | None = None) -> None:
    """:func:`sphkit.core.operators.density_body` and :func:`pair_gradients` in one pass over
    the pairs (one distance per pair for both): ``rho_i = c_i (m_i W_0 + sum_j m_j W_ij + sum_b
    rho0 V_b W_ib)``, ``gw[:, k] = V_j grad W_ij``, ``gwb[:, k] = V_b grad W_ib``; ``L`` > 0:
    periodic along x with period L. Several fluids: ``m`` is ``mu``, ``V`` the rest volumes
    ``m / rho0_j`` and ``c`` the ratios ``rho0_i / rho0`` of
    :class:`sphkit.core.state.RestArrays` (None: one fluid, ``V = m (1 / rho0)``, c = 1;
    ``rho0`` is the reference rest density). The pass is :func:`density_pair_gradients_body`
    through :func:`sphkit.backend.launch`."""
    n = x.shape[1]
    if V is None:
        V = arrays.scaled(m, 1.0 / float(rho0))
    if c is None:
        c = arrays.full(n, 1.0, rho.dtype, like=rho)
    launch(density_pair_gradients_body, n, x, m, off, idx, bx, bV, boff, bidx,
           float(rho0), float(h), int(kid), int(dim), rho, gw, gwb, period_arg(L), V, c)


@numba.njit(**_JIT_GATHER, inline="always")
def kappa_accel_body(i, k, kb, off, idx, boff, bidx, bmirror, gw, gwb, dim, a, inv_c):
    """Particle i of :func:`kappa_accel_cached`: ``a[:, i]``."""
    with_kb = kb.shape[0] > 0
    ki = k[i]
    a0 = a1 = a2 = 0.0
    for kk in pair_slots(off, i):
        s = ki + k[idx[kk]]
        a0 -= s * gw[0, kk]
        if dim > 1:
            a1 -= s * gw[1, kk]
        if dim > 2:
            a2 -= s * gw[2, kk]
    for kk in pair_slots(boff, i):
        b = bidx[kk]
        sb = ki * (1.0 + bmirror[b])
        if with_kb:
            sb += kb[b]
        a0 -= sb * gwb[0, kk]
        if dim > 1:
            a1 -= sb * gwb[1, kk]
        if dim > 2:
            a2 -= sb * gwb[2, kk]
    if inv_c.shape[0] > 0:  # several rest densities (empty: one fluid, 1 / c_i = 1)
        ic = inv_c[i]
        a0, a1, a2 = a0 * ic, a1 * ic, a2 * ic
    set_vector(a, i, dim, a0, a1, a2)


specialize(kappa_accel_body, "dim")  # as jacobi_body: every iteration


@numba.njit(**_JIT_GATHER, inline="always")
def phase_kb_body(i, kb, phase, boff, bidx, gwb, dim, a, inv_c):
    """Particle i: ``a[:, i] -= (1 / c_i) sum_b kb[phase_i, b] V_b grad W_ib``, the boundary
    values of its own phase (:func:`kappa_accel_cached` with a row of kb per phase)."""
    ph = phase[i]
    a0 = a1 = a2 = 0.0
    for kk in pair_slots(boff, i):
        sb = kb[ph, bidx[kk]]
        g0, g1, g2 = point(gwb, kk, dim)  # V_b grad W_ib (0 beyond dim)
        a0, a1, a2 = a0 - sb * g0, a1 - sb * g1, a2 - sb * g2
    ic = inv_c[i]
    add_vector(a, i, dim, a0 * ic, a1 * ic, a2 * ic)


def kappa_accel_cached(k: np.ndarray, kb: np.ndarray, off: np.ndarray, idx: np.ndarray,
                       boff: np.ndarray, bidx: np.ndarray, bmirror: np.ndarray, gw: np.ndarray,
                       gwb: np.ndarray, dim: int, a: np.ndarray,
                       inv_c: np.ndarray | None = None,
                       phase: np.ndarray | None = None) -> None:
    """a[:, i] = pressure acceleration of the field k (overwrites a); the boundary term is
    ``-sum_b V_b (k_i (1 + bmirror[b]) + kb[b]) grad W_ib`` (see the module docstring): kb is
    the extrapolated boundary value ``p_b / rho0`` where a boundary model sets one (Band et al.
    2018, :mod:`sphkit.boundary.band2018`); an empty kb means 0 (no gather).

    A solver whose variable is q with weights w passes ``k = w * q`` (one gather per pair
    instead of two: a fifth faster). Several fluids (SPlisHSPlasH's neighbour weight
    ``rho0_j / rho0_i``: ``a_i = -sum_j V_j (k_i + rho0_j / rho0_i k_j) grad W_ij - ...``):
    pass ``k c`` and ``inv_c`` of :class:`sphkit.core.state.RestArrays` (the sums of particle
    i are multiplied by ``1 / c_i``; then kb is ``p_b / rho0`` of the reference rest density);
    None: one fluid. A kb of shape (phases, N_boundary) holds a value per phase (the MLS
    extrapolation with the phases fitted on their own, :mod:`sphkit.boundary.band2018`):
    particle i reads row ``phase[i]`` (:func:`phase_kb_body`, a second pass over the boundary
    pairs). The pass is :func:`kappa_accel_body` through :func:`sphkit.backend.launch`."""
    if kb.ndim == 2:
        if inv_c is None:
            inv_c = arrays.full(k.shape[0], 1.0, a.dtype, like=a)
        if phase is None:
            raise ValueError("kappa_accel_cached: a kb per phase needs the fluid's phases")
        launch(kappa_accel_body, k.shape[0], k, kb.reshape(-1)[:0], off, idx, boff, bidx,
               bmirror, gw, gwb, int(dim), a, inv_c)
        launch(phase_kb_body, k.shape[0], kb, phase, boff, bidx, gwb, int(dim), a, inv_c)
        return
    if inv_c is None:  # one fluid: no factor read a particle
        inv_c = arrays.absent(0, a.dtype, like=a)
    launch(kappa_accel_body, k.shape[0], k, kb, off, idx, boff, bidx, bmirror, gw, gwb, int(dim),
           a, inv_c)


def diagonal_cached(off: np.ndarray, boff: np.ndarray, bidx: np.ndarray, bmirror: np.ndarray,
                    gw: np.ndarray, gwb: np.ndarray, dim: int, out: np.ndarray,
                    idx: np.ndarray | None = None, c: np.ndarray | None = None,
                    inv_c: np.ndarray | None = None, bsum: np.ndarray | None = None,
                    v: np.ndarray | None = None, bv: np.ndarray | None = None,
                    div: np.ndarray | None = None) -> None:
    """out[i] = (G + B) . (G + M) + sum_j (rho0_i / rho0_j) V_j^2 |grad W_ij|^2,
    G = sum_j V_j grad W_ij, B = sum_b V_b grad W_ib, M = sum_b (1 + bmirror[b]) V_b grad W_ib.

    The ratio ``rho0_i / rho0_j = c_i inv_c_j`` (several fluids: c and inv_c of
    :class:`sphkit.core.state.RestArrays`, ``idx`` the fluid neighbours; None: one fluid, ratio
    1) is the neighbour weight of the pressure sums acting back on particle i: the neighbour j
    feels ``rho0_i / rho0_j`` times particle i's pressure variable, so the derivative of
    ``Ap_i`` with respect to it carries that factor. Without it a heavy particle next to light
    ones has a diagonal far too small, and the Jacobi iteration overshoots (measured: DFSPH
    blew up within 0.1 s in a 2D column of rest densities 1000 and 100).

    The same pass can give, from the pairs it reads anyway, ``bsum`` (dim, N): the boundary
    sums ``B_i = sum_b V_b grad W_ib``, and ``div`` (N,): :func:`pair_divergence_cached` of
    the velocities v (boundary velocities bv; needs ``idx``), to round-off (the compiler
    contracts the products of the two sums differently; DFSPH's factor and divergence source:
    0.231 -> 0.155 ms at 6,859 particles, two threads)."""
    n = off.shape[0] - 1
    weighted = c is not None and inv_c is not None
    if not weighted:  # not read
        c = inv_c = arrays.absent(0, out.dtype, like=out)
    if idx is None:
        idx = arrays.absent(0, INDEX, like=out)
    if bsum is None:
        bsum = arrays.absent((gwb.shape[0], 0), out.dtype, like=out)
    if div is None:
        v, bv = bsum, bsum  # unread
        div = arrays.absent(0, out.dtype, like=out)
    launch(diagonal_body, n, off, idx, boff, bidx, bmirror, gw, gwb, int(dim), weighted, c, inv_c,
           out, bsum, v, bv, div)


@numba.njit(inline="always", **_JIT_GATHER)
def diagonal_body(i, off, idx, boff, bidx, bmirror, gw, gwb, dim, weighted, c, inv_c, out, bsum,
                  v, bv, div):
    """``out[i]`` = the diagonal ``D_i`` of :func:`diagonal_cached` (a kernel body);
    ``bsum[:, i]`` = B_i where bsum has columns, ``div[i]`` = :func:`_divergence_i` of v where
    div has entries."""
    with_div = div.shape[0] > 0
    g0 = g1 = g2 = 0.0
    sq = 0.0
    ci = c[i] if weighted else 1.0
    s = vi0 = vi1 = vi2 = 0.0
    if with_div:
        vi0, vi1, vi2 = point(v, i, dim)
    for k in pair_slots(off, i):
        t0 = gw[0, k]
        t1 = gw[1, k] if dim > 1 else 0.0
        t2 = gw[2, k] if dim > 2 else 0.0
        g0 += t0
        g1 += t1
        g2 += t2
        if weighted:
            sq += (t0 * t0 + t1 * t1 + t2 * t2) * (ci * inv_c[idx[k]])
        else:
            sq += t0 * t0 + t1 * t1 + t2 * t2
        if with_div:
            s += _rate(vi0, vi1, vi2, v, idx[k], gw, k, dim)
    b0 = b1 = b2 = 0.0
    m0 = m1 = m2 = 0.0
    for k in pair_slots(boff, i):
        b = bidx[k]
        f = 1.0 + bmirror[b]
        b0 += gwb[0, k]
        m0 += f * gwb[0, k]
        if dim > 1:
            b1 += gwb[1, k]
            m1 += f * gwb[1, k]
        if dim > 2:
            b2 += gwb[2, k]
            m2 += f * gwb[2, k]
        if with_div:
            s += _rate(vi0, vi1, vi2, bv, b, gwb, k, dim)
    out[i] = ((g0 + b0) * (g0 + m0) + (g1 + b1) * (g1 + m1) + (g2 + b2) * (g2 + m2) + sq)
    if bsum.shape[1] > 0:
        set_vector(bsum, i, dim, b0, b1, b2)
    if with_div:
        div[i] = s


@numba.njit(inline="always", **_JIT_GATHER)
def _rate(vi0, vi1, vi2, v, j, g, k, dim):
    """``(v_i - v_j) . g[:, k]``, the pair's term of the divergences.

    Written out (one dim branch per component): through the pair helpers (a difference, then a
    product with its own branches) :func:`jacobi_sweep` ran 5-13 % slower."""
    t = (vi0 - v[0, j]) * g[0, k]
    if dim > 1:
        t += (vi1 - v[1, j]) * g[1, k]
    if dim > 2:
        t += (vi2 - v[2, j]) * g[2, k]
    return t


@numba.njit(inline="always", **_JIT_GATHER)
def _fluid_divergence_i(i, v, off, idx, gw, dim):
    """``sum_j (v_i - v_j) . gw_ij`` of particle i (its fluid pairs)."""
    vi0, vi1, vi2 = point(v, i, dim)
    s = 0.0
    for k in pair_slots(off, i):
        s += _rate(vi0, vi1, vi2, v, idx[k], gw, k, dim)
    return s


@numba.njit(inline="always", **_JIT_GATHER)
def _divergence_i(i, v, bv, off, idx, boff, bidx, gw, gwb, dim):
    """``sum_j (v_i - v_j) . gw_ij + sum_b (v_i - v_b) . gwb_ib`` of particle i."""
    vi0, vi1, vi2 = point(v, i, dim)
    s = _fluid_divergence_i(i, v, off, idx, gw, dim)
    for k in pair_slots(boff, i):
        s += _rate(vi0, vi1, vi2, bv, bidx[k], gwb, k, dim)
    return s


@numba.njit(inline="always", **_JIT_GATHER)
def divergence_body(i, v, bv, off, idx, boff, bidx, gw, gwb, dim, out):
    """``out[i]`` = :func:`_divergence_i` (a kernel body)."""
    out[i] = _divergence_i(i, v, bv, off, idx, boff, bidx, gw, gwb, dim)


def pair_divergence_cached(v: np.ndarray, bv: np.ndarray, off: np.ndarray, idx: np.ndarray,
                           boff: np.ndarray, bidx: np.ndarray, gw: np.ndarray, gwb: np.ndarray,
                           dim: int, out: np.ndarray) -> None:
    """``sum_j (v_i - v_j) . V_j grad W_ij + sum_b (v_i - v_b) . V_b grad W_ib`` from cached
    pair gradients: ``D rho_hat / Dt`` for velocities (bv: boundary velocities), and the density
    change per dt^2 for accelerations (bv = 0: pressure does not accelerate the boundary);
    :func:`divergence_body` through :func:`sphkit.backend.launch`."""
    launch(divergence_body, v.shape[1], v, bv, off, idx, boff, bidx, gw, gwb, int(dim), out)


def lattice_diagonal(spacing: float, h: float, kid: int, dim: int, V: float) -> float:
    """:func:`diagonal` of a template particle with a filled neighbourhood (PCISPH, PBF).

    The neighbours are the points of the cubic lattice of the given spacing (the sampling
    lattice, 2r) closer than h to the template at the origin, each of rest volume V:
    ``D0 = V^2 (|S1|^2 + S2)`` with ``S1 = sum_k grad W(x_0 - x_k)``, ``S2 = sum_k
    |grad W(x_0 - x_k)|^2`` [1/m^2]. PCISPH's factor is ``delta = 1 / (2 D0)`` (Solenthaler &
    Pajarola 2009, Eq. 8, in normalized units; SPlisHSPlasH ``SimulationDataPCISPH::init``).
    """
    from sphkit.core.kernels import Kernel, cubic_lattice_points

    grid = cubic_lattice_points(spacing, h, dim)
    d = np.linalg.norm(grid, axis=1)
    g = Kernel(kid, h, dim).grad(-grid[(d > 0.0) & (d < h)])
    s1 = g.sum(axis=0)
    return float(V * V * (s1 @ s1 + (g * g).sum()))
