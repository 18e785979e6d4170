"""Compiled pieces shared by the implicit viscosity models (``sphkit.viscosity``).

Methods never import each other, so what two of them share lives here:

* :func:`velocity_gradient` -- the SPH velocity gradient
  ``(grad v)_i = sum_j w_ij (v_j - v_i) (x) grad W_ij`` with ``w_ij = m_j / rho_j`` (Takahashi et
  al. 2015) or ``m_j / rho_i`` (Peer et al. 2015, 2016), stored row-major as (dim * dim, N):
  row ``a * dim + b`` holds ``d v_a / d x_b``;
* :func:`kernel_sum_diagonal`, :func:`kernel_sum_matvec`, :func:`target_gradient_rhs` -- the
  linear system of the velocity reconstruction of Peer et al. 2015 (also used for the vorticity
  of Peer & Teschner 2016):
  ``(A x)_i = d_i x_i - sum_j m_j W_ij x_j`` with ``d_i = sum_j m_j W_ij + rho0 sum_b V_b W_ib``
  (the density without the self term; the boundary term optional), and the right-hand side
  ``b_i = sum_j m_j (T_i + T_j)/2 x_ij W_ij`` of target gradients T;
* :func:`decompose_target` -- Peer et al.'s target gradient: ``grad v = R + V + S`` (spin,
  expansion ``V = (div v / dim) I``, shear) and ``T = R + V + xi S``, with V left out where a
  particle is below rest density and not expanding (SPlisHSPlasH's rule);
* :func:`target_gradients`, :func:`kernel_sum_solve`, :func:`reconstruct_velocity` -- the
  drivers of Peer et al.'s steps: gradients and targets, the Jacobi-preconditioned CG solves of the
  kernel-sum system per component (:func:`sphkit.core.krylov.cg`), the velocity reconstruction;
* :func:`wall_friction` -- SPlisHSPlasH's XSPH-type wall friction of the strain-rate models,
  ``a_i -= (c / dt) sum_b (rho0 V_b / rho_i) (v_i - v_b) W_ib``;
* :func:`add_velocity_change` -- ``a += (v_new - v) / dt`` (an implicit model's result as an
  acceleration), optionally keeping ``v_new - v`` for the next warm start.
* :func:`morris_beta` -- the no-slip wall of Morris, Fox & Zhu 1997 for the Laplacian
  viscosities' boundary term (``standard``, ``weiler2018``): the factor ``beta`` in
  ``v_i - v_b = beta (v_i - v_wall)`` (see its docstring); :func:`wall_pair` is the preamble of
  their boundary pair loops (difference, squared distance, beta) and :func:`laplacian_pair` the
  pair factor of their Laplacian; :func:`register_wall_fields` adds the boundary fields it reads
  (``wall_normal``, ``wall_distance``);
* :func:`laplacian_diagonal_pair`, :func:`outer_add`, :func:`write_blocks` -- the diagonal
  3x3 blocks of an implicit Laplacian (``weiler2018``, and the viscosity inside ``jeske2023``'s
  solve): a pair's coefficient ``c W'(r) / (r (r^2 + eps))``, its symmetric outer-product sum
  ``sum s x_ij x_ij^T`` and the blocks ``diag I - f G``.

All loops take ``L`` > 0 for periodic x (minimum-image differences, ``configuration.periodic_x``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sphkit.backend import launch
from sphkit.core.kernels import kernel_dr, kernel_dw, kernel_w
from sphkit.core.krylov import JacobiPreconditioner, KrylovStats, cg
from sphkit.core.pairs import delta, distance, dot, pair_slots, point, separation
from sphkit.core.state import SimState

_JIT = dict(cache=True, fastmath=True)


@numba.njit(parallel=True, **_JIT)
def velocity_gradient(x, v, m, rho, off, idx, h, kid, dim, L, own_density, out):
    """``out[a * dim + b, i] = sum_j w_ij (v_j - v_i)_a (grad W_ij)_b``; ``w_ij = m_j / rho_i``
    if ``own_density`` else ``m_j / rho_j``."""
    for i in numba.prange(x.shape[1]):
        for c in range(dim * dim):
            out[c, i] = 0.0
        xi0, xi1, xi2 = point(x, i, dim)
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
            w = m[j] / (rho[i] if own_density else rho[j])
            f = w * kernel_dw(kid, r, h, dim)
            g = (f * d0, f * d1, f * d2)
            for a in range(dim):
                dva = v[a, j] - v[a, i]
                for b in range(dim):
                    out[a * dim + b, i] += dva * g[b]


@numba.njit(parallel=True, **_JIT)
def kernel_sum_diagonal(x, m, off, idx, bx, bV, boff, bidx, rho0, with_boundary, h, kid, dim,
                        L, out):
    """``out_i = sum_j m_j W_ij (+ rho0 sum_b V_b W_ib)``: the density without the self term."""
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        s = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            s += m[j] * kernel_w(kid, distance(xi0, xi1, xi2, x, j, dim, L), h, dim)
        if with_boundary:
            for k in pair_slots(boff, i):
                b = bidx[k]
                s += rho0 * bV[b] * kernel_w(kid, distance(xi0, xi1, xi2, bx, b, dim, L), h, dim)
        out[i] = s


@numba.njit(parallel=True, **_JIT)
def kernel_sum_matvec(x, m, off, idx, diag, h, kid, dim, L, u, out):
    """``out_i = diag_i u_i - sum_j m_j W_ij u_j`` for scalar unknowns u (N,)."""
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        s = diag[i] * u[i]
        for k in pair_slots(off, i):
            j = idx[k]
            s -= m[j] * kernel_w(kid, distance(xi0, xi1, xi2, x, j, dim, L), h, dim) * u[j]
        out[i] = s


@numba.njit(parallel=True, **_JIT)
def target_gradient_rhs(x, m, off, idx, T, h, kid, dim, L, out):
    """``out[:, i] = sum_j m_j (T_i + T_j) / 2 x_ij W_ij`` with gradients T (dim * dim, N),
    row-major like :func:`velocity_gradient`; out (dim, N)."""
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        for a in range(dim):
            out[a, i] = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
            f = 0.5 * m[j] * kernel_w(kid, r, h, dim)
            d = (d0, d1, d2)
            for a in range(dim):
                s = 0.0
                for b in range(dim):
                    s += (T[a * dim + b, i] + T[a * dim + b, j]) * d[b]
                out[a, i] += f * s


@numba.njit(parallel=True, **_JIT)
def decompose_target(G, rho, rho0, xi, dim, spin, T):
    """``T_i = [R_i] + V_i + xi S_i`` from velocity gradients G (dim * dim, N) (row-major, see
    :func:`velocity_gradient`); R_i is included if ``spin``; V_i is left out where
    ``rho_i < rho0`` and ``div v_i <= 0``."""
    for i in numba.prange(G.shape[1]):
        div = 0.0
        for a in range(dim):
            div += G[a * dim + a, i]
        keep_v = rho[i] >= rho0 or div > 0.0
        ev = div / dim
        for a in range(dim):
            for b in range(dim):
                gab = G[a * dim + b, i]
                gba = G[b * dim + a, i]
                vab = ev if a == b else 0.0
                t = xi * (0.5 * (gab + gba) - vab)
                if keep_v:
                    t += vab
                if spin:
                    t += 0.5 * (gab - gba)
                T[a * dim + b, i] = t


@numba.njit(parallel=True, **_JIT)
def wall_friction(x, v, rho, bx, bv, bV, boff, bidx, c, rho0, h, kid, dim, L, inv_dt, a):
    """``a_i -= (c / dt) sum_b (rho0 V_b / rho_i) (v_i - v_b) W_ib`` (Akinci 2012 particles)."""
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        vi0, vi1, vi2 = point(v, i, dim)
        f0 = f1 = f2 = 0.0
        for k in pair_slots(boff, i):
            b = bidx[k]
            s = (c * inv_dt * rho0 * bV[b] / rho[i]
                 * kernel_w(kid, distance(xi0, xi1, xi2, bx, b, dim, L), h, dim))
            w0, w1, w2 = delta(vi0, vi1, vi2, bv, b, dim, 0.0)
            f0 += s * w0
            f1 += s * w1
            f2 += s * w2
        a[0, i] -= f0
        if dim > 1:
            a[1, i] -= f1
        if dim > 2:
            a[2, i] -= f2


@numba.njit(inline="always", **_JIT)
def velocity_change_body(i, v, vnew, inv_dt, a, dv, keep, dim):
    """``a[:, i] += (v_new - v)[:, i] / dt``; with ``keep`` also ``dv[:, i] = (v_new - v)[:, i]``
    (a kernel body, :func:`add_velocity_change`)."""
    for d in range(dim):
        t = vnew[d, i] - v[d, i]
        a[d, i] += t * inv_dt
        if keep:
            dv[d, i] = t


@numba.njit(inline="always", **_JIT)
def lone_body(i, off, boff, with_boundary, dv, dim):
    """Zero the warm start ``dv[:, i]`` of a particle that the viscous term couples to nothing
    (no fluid neighbour, and no boundary neighbour where the wall term acts; a kernel body,
    :func:`forget_lone`)."""
    if off[i + 1] > off[i] or (with_boundary and boff[i + 1] > boff[i]):
        return
    for d in range(dim):
        dv[d, i] = 0.0


def forget_lone(state: SimState, dv: np.ndarray, with_boundary: bool) -> None:
    """Drop the implicit viscosities' warm start (the last step's velocity change ``dv``) of the
    particles their system does not couple: such a row is the identity, its exact solution no
    change at all, but the conjugate gradient's stopping test is on the relative residual of all
    rows together, so a lone particle's stale change can pass it with no iteration and is then
    applied again in every step -- a constant acceleration. Found in SPlisHSPlasH's
    ``ReadWriteStateTest.json`` with density maps (Weiler 2018, ``viscoMaxError`` 7.5 %, 2
    iterations): a splash particle with no neighbour accelerated at 400-500 m/s^2 along its own
    velocity to 40 m/s (validation/README.md, "SPlisHSPlasH's scenes with another solver and
    boundary model"). ``with_boundary``: boundary neighbours couple too (the wall term acts)."""
    launch(lone_body, dv.shape[1], state.nl_ff.offsets, state.nl_fb.offsets, bool(with_boundary),
           dv, dv.shape[0])


def add_velocity_change(v, vnew, inv_dt: float, a, dv, keep: bool) -> None:
    """``a += (v_new - v) / dt``; with ``keep`` also ``dv = v_new - v`` (next warm start); on the
    device the arrays are on."""
    launch(velocity_change_body, v.shape[1], v, vnew, inv_dt, a, dv, keep, v.shape[0])


# ---------------------------------------------------------------------------------------------
# drivers of the Peer et al. velocity reconstruction


def kernel_sum_solve(state: SimState, diag: np.ndarray, rhs: np.ndarray, guess: np.ndarray,
                     tol: float, max_iter: int, name: str) -> tuple[np.ndarray, KrylovStats]:
    """Solve ``d_i u_i - sum_j m_j W_ij u_j = rhs`` per row of rhs (k, N) by Jacobi-preconditioned
    CG from ``guess`` (k, N); a row whose solve takes no iteration keeps its guess. Returns the
    solution (k, N) and the stats (iterations summed, the largest residual)."""
    f = state.fluid
    x, m, nl = f["x"], f["m"], state.nl_ff

    def matvec(u: np.ndarray, out: np.ndarray) -> None:
        kernel_sum_matvec(x, m, nl.offsets, nl.indices, diag, state.h, state.kid, state.dim,
                          state.pair_period, u, out)

    pre = JacobiPreconditioner(diag)
    out = np.empty(rhs.shape)
    its, res, ok = 0, 0.0, True
    for c in range(rhs.shape[0]):
        g = np.ascontiguousarray(guess[c], dtype=np.float64)
        sol, st = cg(matvec, rhs[c], g, precond=pre, tol=tol, max_iter=max_iter,
                     name=f"{name} (component {c})", step=state.step)
        out[c] = g if st.iterations == 0 else sol
        its += st.iterations
        res = max(res, st.residual)
        ok = ok and st.converged
    return out, KrylovStats(its, res, ok)


def target_gradients(state: SimState, xi: float, spin: bool) -> tuple[np.ndarray, np.ndarray]:
    """Velocity gradients G and targets T (both (dim * dim, N), row-major)."""
    f = state.fluid
    n, dim = f.n, state.dim
    G = np.empty((dim * dim, n))
    velocity_gradient(f["x"], f["v"], f["m"], f["rho"], state.nl_ff.offsets, state.nl_ff.indices,
                      state.h, state.kid, dim, state.pair_period, True, G)
    T = np.empty_like(G)
    decompose_target(G, f["rho"], state.rho0, xi, dim, spin, T)
    return G, T


def reconstruct_velocity(state: SimState, T: np.ndarray, tol: float, max_iter: int,
                         name: str) -> tuple[np.ndarray, KrylovStats]:
    """The velocities whose Taylor expansion matches the target gradients T, warm-started with
    the current velocities."""
    f, b = state.fluid, state.boundary
    n, dim = f.n, state.dim
    x, m = f["x"], f["m"]
    nl, nb = state.nl_ff, state.nl_fb
    diag = np.empty(n)
    kernel_sum_diagonal(x, m, nl.offsets, nl.indices, b["x"], b["V"], nb.offsets, nb.indices,
                        state.rho0, True, state.h, state.kid, dim, state.pair_period, diag)
    rhs = np.empty((dim, n))
    target_gradient_rhs(x, m, nl.offsets, nl.indices, T, state.h, state.kid, dim, state.pair_period,
                        rhs)
    return kernel_sum_solve(state, diag, rhs, f["v"], tol, max_iter, name)


#: ``boundary_velocity`` options of the Laplacian viscosities' wall term: ``zero`` uses the wall
#: particle's own velocity (SPlisHSPlasH), ``morris1997`` Morris et al.'s extrapolated velocity
BOUNDARY_VELOCITIES = ("zero", "morris1997")
#: the Laplacians' regularisation eps in ``|x_ij|^2 + eps h^2`` (h = support radius):
#: SPlisHSPlasH's 0.01. Morris et al. 1997 (and Monaghan) write 0.01 of the *smoothing length*
#: squared, i.e. 0.0025 h^2 for the cubic spline (support 2 smoothing lengths). In the continuum
#: the term weakens the 2D shear Laplacian of the cubic spline by 4.9 % at 0.01, 1.35 % at
#: 0.0025 (integral of the kernel's W'(q) q^5 / (q^2 + eps) over q; Wendland: 5.8 %, 1.6 %).
LAPLACIAN_EPS = 0.01
#: Morris et al. 1997's bound on beta (beta_max = 1.5, their boundary-condition section)
MORRIS_BETA_MAX = 1.5


#: Morris, Fox & Zhu 1997's viscous diffusion condition ``dt <= 0.125 h^2 / nu`` (their Eq. 23,
#: h the smoothing length: sphkit's h_s = 2r, half the support radius)
VISCOUS_DT_FACTOR = 0.125


def viscous_time_step(nu: float, r: float) -> float:
    """The explicit viscosity's stability bound ``0.125 (2r)^2 / nu`` [s] (inf for nu = 0).
    A 2D column at r = 5 mm with nu = 0.01 m^2/s (bound 1.25 ms) ran at rest at 1 and 1.25 ms
    and grew 3.8 m/s from rest at 2 ms."""
    return VISCOUS_DT_FACTOR * (2.0 * r) ** 2 / nu if nu > 0.0 else float("inf")


def check_wall_options(boundary_velocity: str, beta_max: float, eps: float) -> None:
    """Validate the wall options shared by the Laplacian viscosities (standard, Weiler 2018):
    ``boundary_velocity`` in :data:`BOUNDARY_VELOCITIES`, ``beta_max >= 1``, ``eps > 0``;
    raises ValueError naming the option, its value and what was expected."""
    if boundary_velocity not in BOUNDARY_VELOCITIES:
        raise ValueError(f"viscosity: boundary_velocity {boundary_velocity!r}; expected one "
                         f"of {', '.join(BOUNDARY_VELOCITIES)}")
    if not beta_max >= 1.0:
        raise ValueError(f"viscosity: beta_max {beta_max!r}; expected a value >= 1")
    if not eps > 0.0:
        raise ValueError(f"viscosity: eps {eps!r}; expected a value > 0")


def register_wall_fields(boundary) -> None:
    """Register the boundary fields of :func:`morris_beta` (no-op if present): ``wall_normal``
    (unit normal of the wall surface at the particle, pointing from the fluid into the wall) and
    ``wall_distance`` [m] (the particle's distance behind that surface; 0 = unknown); and
    ``viscosity_factor``, the standard viscosity's factor on its wall term (1 by default; set
    per face by ``boxes[].viscosity_factors``)."""
    boundary.register("wall_normal", "vector")
    boundary.register("wall_distance")
    boundary.register("viscosity_factor", fill=1.0, optional=True)


@numba.njit(cache=True, fastmath=True, inline="always")
def morris_beta(d0, d1, d2, n0, n1, n2, db, beta_max):
    """No-slip walls of Morris, Fox & Zhu 1997 (J. Comput. Phys. 136, 214-226).

    The paper's boundary-condition treatment, in the section before its test problems (whose
    Poiseuille case has the series solution Eq. 21); the section and equation numbers of the
    boundary treatment could not be checked here. Each boundary particle b gets, for the fluid
    particle i it interacts with, the artificial velocity extrapolated antisymmetrically across
    the wall surface, ``v_b = v_wall - (d_b / d_i) (v_i - v_wall)`` (the paper writes it for
    v_wall = 0: ``v_B = -(d_B / d_A) v_A``), so that the linear profile through v_i and v_b is
    v_wall on the surface; the relative velocity in the viscous term becomes
    ``v_i - v_b = beta (v_i - v_wall)`` with ``beta = min(beta_max, 1 + d_b / d_i)`` (Morris:
    beta_max = 1.5, which bounds the artificial velocity of particles close to the wall).

    ``(d0, d1, d2) = x_i - x_b``; ``n`` is b's wall normal (from the fluid into the wall) and
    ``db`` its distance behind the surface; the surface is the plane through ``x_b - d_b n``
    with normal n (Morris' tangent plane), so ``d_i = -(x_i - x_b) . n - d_b``. Returns 1 (the
    wall velocity itself) when ``beta_max <= 0`` (option ``zero``) or ``db <= 0`` (no wall
    distance known for b), and beta_max when i is on or behind the surface (``d_i <= 0``).
    Linear in v_i, so an implicit solve stays linear.
    """
    if beta_max <= 0.0 or db <= 0.0:
        return 1.0
    di = -(d0 * n0 + d1 * n1 + d2 * n2) - db
    if di <= 0.0:
        return beta_max
    beta = 1.0 + db / di
    return beta if beta < beta_max else beta_max


@numba.njit(cache=True, fastmath=True, inline="always")
def wall_pair(xi0, xi1, xi2, bx, b, bn, bd, beta_max, dim, L):
    """``(d0, d1, d2, r2, beta)`` of a fluid particle at ``xi`` and boundary particle b: the
    difference ``x_i - x_b`` (minimum image along x with period ``L`` > 0), its squared length
    and the Morris factor :func:`morris_beta` from b's wall normal ``bn[:, b]`` and wall distance
    ``bd[b]`` (1 unless ``beta_max`` > 0). The preamble of the boundary loops of the Laplacian
    viscosities (:mod:`sphkit.viscosity.standard`, :mod:`sphkit.viscosity.weiler2018`)."""
    d0, d1, d2 = delta(xi0, xi1, xi2, bx, b, dim, L)
    n0, n1, n2 = point(bn, b, dim)
    beta = morris_beta(d0, d1, d2, n0, n1, n2, bd[b], beta_max)
    return d0, d1, d2, dot(d0, d1, d2, d0, d1, d2), beta


#: the distance of a map wall's tangential samples from its virtual particle, in h
#: (SPlisHSPlasH's ``Viscosity_Weiler2018::m_tangentialDistanceFactor``)
TANGENTIAL_DISTANCE = 0.5


@numba.njit(cache=True, fastmath=True, inline="always")
def wall_samples(c, r2, spread, eps, kid, h, dim):
    """The wall term of a virtual boundary particle (density and volume maps) spread over
    samples at distance ``sqrt(spread)`` beside it in the wall's tangent plane, with the
    volume shared equally: four in 3D (``+-t_1``, ``+-t_2``), two in 2D. With ``d = x_i - x_b``
    along the normal and each sample's ``x_k = d -+ sqrt(spread) t``, the samples' sum of the
    Monaghan Laplacian's ``c W'(r_k)/r_k / (r_k^2 + eps) x_k x_k^T`` is
    ``g (cd d d^T + ct I)`` with ``r_k^2 = |d|^2 + spread`` for all of them, returned as
    ``(g, cd, ct)``: ``ct = spread / (dim - 1)`` (the tangential outer products sum to
    ``I - n n^T`` whichever tangents are taken) and ``cd = 1 - ct / |d|^2``. A term
    ``(w . x_k) x_k`` sums to ``g (cd (w . d) d + ct w)``. Zero (``g = 0``) for a virtual
    particle closer than 1e-4 h (no normal: SPlisHSPlasH skips it)."""
    if not r2 > 1e-8 * h * h:
        return 0.0, 0.0, 0.0
    rs2 = r2 + spread
    ct = spread / (dim - 1)
    return laplacian_diagonal_pair(c, rs2, eps, kid, h, dim), 1.0 - ct / r2, ct


@numba.njit(cache=True, fastmath=True, inline="always")
def laplacian_pair(kid, w0, w1, w2, d0, d1, d2, r2, eps, h, dim, den):
    """``(w . x_ij) / (|x_ij|^2 + eps) W'(r) / r / den`` with ``r^2 = |x_ij|^2 = r2``: the pair
    factor of the Monaghan 2005 projected Laplacian that the Laplacian viscosities share
    (:mod:`sphkit.viscosity.standard`, :mod:`sphkit.viscosity.weiler2018`); times the pair's
    coefficient and ``x_ij`` it is the pair's term (``w = v_i - v_j``; ``eps`` = the
    regularisation times h^2, :data:`LAPLACIAN_EPS`). ``den``: a divisor of the pair's
    coefficient (e.g. ``rho_j``; 1 where it has none), folded into the factor's one division
    (with :func:`sphkit.core.kernels.kernel_dr`: the standard viscosity's pair pass 0.449 ->
    0.408 ms at 6,859 particles against three divisions)."""
    r = math.sqrt(r2)
    return (dot(w0, w1, w2, d0, d1, d2) * kernel_dr(kid, r, h, dim)
            / ((r2 + eps) * max(r, 1e-9 * h) * den))


@numba.njit(cache=True, fastmath=True, inline="always")
def laplacian_factor(c, r2, eps, dW):
    """``c / (r2 + eps) dW``: :func:`laplacian_diagonal_pair` with the pair's ``dW = W'(r) / r``
    already evaluated (a pass that needs it for another term too)."""
    return c / (r2 + eps) * dW


@numba.njit(cache=True, fastmath=True, inline="always")
def laplacian_diagonal_pair(c, r2, eps, kid, h, dim):
    """``c / (r2 + eps) W'(r) / r`` with ``r = sqrt(r2)``: the pair's factor s of the diagonal
    block ``sum_j s x_ij x_ij^T`` of the Monaghan Laplacian (:func:`laplacian_pair` without the
    velocity; ``c``: the pair's coefficient, e.g. ``c_f m_j / rho_j``)."""
    return laplacian_factor(c, r2, eps, kernel_dw(kid, math.sqrt(r2), h, dim))


@numba.njit(cache=True, fastmath=True, inline="always")
def outer_add(s, d0, d1, d2, g00, g01, g02, g11, g12, g22):
    """The six entries of the symmetric sum ``G + s d d^T`` (``G`` as g00 .. g22)."""
    return (g00 + s * d0 * d0, g01 + s * d0 * d1, g02 + s * d0 * d2, g11 + s * d1 * d1,
            g12 + s * d1 * d2, g22 + s * d2 * d2)


@numba.njit(cache=True, fastmath=True, inline="always")
def write_blocks(blocks, i, diag, f, g00, g01, g02, g11, g12, g22, dim):
    """``blocks[:, :, i] = diag I - f G`` for the symmetric G (g00 .. g22), dim x dim."""
    blocks[0, 0, i] = diag - f * g00
    if dim > 1:
        blocks[0, 1, i] = -f * g01
        blocks[1, 0, i] = -f * g01
        blocks[1, 1, i] = diag - f * g11
    if dim > 2:
        blocks[0, 2, i] = -f * g02
        blocks[2, 0, i] = -f * g02
        blocks[1, 2, i] = -f * g12
        blocks[2, 1, i] = -f * g12
        blocks[2, 2, i] = diag - f * g22
