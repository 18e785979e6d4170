"""MLS pressure extrapolation to boundary particles (Band et al. 2018).

Band, Gissler, Ihmsen, Cornelis, Peer, Teschner 2018, "MLS pressure extrapolation for the
boundary handling in divergence-free SPH", VRIPHYS; see also the survey (Koschier et al. 2022,
Sec. 5.1) on pressure mirroring versus extrapolation.

Pressure mirroring (``p_b = p_i``, Akinci et al. 2012) gives every boundary neighbour of a fluid
particle i the pressure of i. Where the pressure has a gradient -- the hydrostatic pressure along
a side wall, or under a column on the floor -- the wall then pushes with the wrong pressure:
along a vertical wall the boundary term has no vertical component at all, so the fluid next to
the wall lacks the support that the missing fluid neighbours would give and the column settles
with a pressure slope above ``rho0 g``. Band et al. instead give each boundary sample b the value
at ``x_b`` of the linear field fitted to the pressures of its fluid neighbours f by moving least
squares with weights ``W_bf`` (their Sec. 3):

    minimise  sum_f W_bf (p_f - beta_0 - beta . (x_f - x_b))^2,     p_b = beta_0,

i.e. ``[beta_0, beta] = M^-1 sum_f W_bf [1, d_f] p_f`` with ``d_f = x_f - x_b`` and the moment
matrix ``M = sum_f W_bf [1, d_f] [1, d_f]^T``. ``p_b`` is therefore linear in the fluid
pressures, ``p_b = sum_f c_bf p_f`` with ``c_bf = W_bf (u_0 + u . d_f)`` and ``u`` the first row
of ``M^-1``: the coefficients depend only on positions, so they are computed once per step and
each solver iteration extrapolates with one multiply-add per boundary-fluid pair. Where M is
singular (no fluid neighbour spread) the fit falls back to the Shepard average ``c_bf = W_bf /
sum_f W_bf``. A small Tikhonov term ``RIDGE sum_f W_bf`` on the gradient block of M (positions in
units of h) takes a gradient the neighbours do not determine -- all of them on one row, as under
a single fluid layer, where the exact fit turns particle noise into wild boundary pressures -- as
zero; measured, 1e-3 let PCISPH's 2D column blow up, 1e-2 is stable in every solver and biases a
well-determined gradient by a few percent. Negative extrapolated pressures are clamped to 0 like
the fluid's.

The boundary sample's pressure then enters the symmetric pressure force of the fluid,
``a_i = ... - sum_b V_b (k_i + k_b) grad W_ib`` with ``k_b = p_b / rho0`` (``rho_b = rho0``;
:func:`sphkit.core.ppe.kappa_accel_cached`). The solvers' variables are ``k = p / (rho0
rho_hat^2)``, so the fit is applied to ``k_f rho_hat_f^2 = p_f / rho0`` (the factor is folded
into ``c_bf``). The Jacobi diagonals keep the mirrored form (``1 + 1`` per boundary term): the
extrapolated ``k_b`` moves with ``k_i`` about as the mirrored one does, and the diagonal only sets
the step size of the iteration.

Several rest densities (sphkit's extension; Band et al. treat one fluid). Where two fluids of
different rest density meet, the hydrostatic pressure is continuous across the interface but its
gradient jumps (``rho0_heavy g`` below, ``rho0_light g`` above), so one linear fit over a wall
sample's neighbours of both phases reproduces neither side. Each phase's neighbours are then
fitted on their own (:func:`mls_coefficients` with the fluid's ``phase``), the sample holds one
value per phase, ``k_b[q, b]`` (:func:`mls_extrapolate_phases`), and a fluid particle's boundary
term reads its own phase's (:func:`sphkit.core.ppe.kappa_accel_cached`, WCSPH's
:func:`sphkit.core.operators.replace_mirrored`): each phase sees the wall pressure that
continues its own field, as with one fluid. With one fluid, or fluids of equal rest density, the
fit is the single one as before (the same arithmetic, bit for bit). What it changes at rest and
in the overturning columns: validation/README.md, "MLS wall pressure per phase".

Scene option ``configuration.boundary.pressure: "mls"``, the default of ``akinci2012`` (the
registry's ``boundary_pressure``; ``"mirror"`` selects mirroring), for its static boundary
particles (boxes, static meshes); moving rigid bodies keep their mirrored / one-sided term. All
pressure solvers with a boundary pressure use it: DFSPH, IISPH and PCISPH inside every
iteration, WCSPH once per step (:meth:`MLSPressureExtrapolation.correct_mirrored`, which solves
the fit for ``beta`` directly, :func:`mls_values`, instead of forming the coefficients: one pass
over the pairs instead of three); PBF has no boundary pressure and gets no extrapolation.
"""

from __future__ import annotations

from typing import Any

import numba
import numpy as np

from sphkit.backend import device_of, exclusive_scan, histogram, launch, to_device
from sphkit.core import arrays
from sphkit.core.kernels import kernel_w
from sphkit.core.methods import BoundaryPressure
from sphkit.core.neighbors import INDEX
from sphkit.core.operators import replace_mirrored
from sphkit.core.pairs import delta, pair_slots, point, separation, unsigned_range
from sphkit.core.state import SimState
from sphkit.core.viscous import outer_add

_JIT = dict(cache=True, fastmath=True)
#: Tikhonov weight of the gradient block of the moment matrix, relative to sum_f W_bf (positions
#: in units of h); see :func:`mls_coefficients`
RIDGE = 1e-2


@numba.njit(**_JIT)
def _transpose(boff, bidx, nb, use):
    """CSR lists boundary -> fluid pairs: ``toff`` (nb + 1), ``tfluid`` (the fluid particle of
    each pair, in fluid-index order within each sample) and the samples that are extrapolated
    (``use``) and have fluid neighbours, found in the counts' scan. One serial pass over the
    pairs to count, one to place (a parallel form, each thread counting and placing the pairs
    of a range of fluid particles, took twice as long at 6,859 particles: the scan of the
    per-range counts and the launches cost more than the halved passes)."""
    nf = boff.shape[0] - 1
    count = np.zeros(nb + 1, dtype=np.int64)
    for k in range(bidx.shape[0]):
        count[bidx[k] + 1] += 1
    rows = np.empty(nb, dtype=np.int64)
    m = 0
    for b in range(nb):
        if use[b] and count[b + 1] > 0:
            rows[m] = b
            m += 1
        count[b + 1] += count[b]
    fill = count[:nb].copy()
    tfluid = np.empty(bidx.shape[0], dtype=INDEX)  # fluid indices, as the lists'
    for i in range(nf):
        for k in pair_slots(boff, i):
            b = bidx[k]
            t = fill[b]
            tfluid[t] = i
            fill[b] += 1
    return count, tfluid, rows[:m].copy()


def mls_coefficients(x: np.ndarray, rho_hat: np.ndarray, bx: np.ndarray, toff: np.ndarray,
                     tfluid: np.ndarray, rows: np.ndarray, h: float, kid: int, dim: int,
                     L: float | tuple, ridge: float, coef: np.ndarray, phase: np.ndarray,
                     nphase: int) -> None:
    """``coef[t] = c_bf rho_hat_f^2`` for the t-th boundary -> fluid pair (module docstring).

    Only the samples ``rows`` (those extrapolated, with fluid neighbours: :func:`transposed`) are
    fitted, one launch of :func:`coefficients_body` over them; the other samples'
    coefficients are left as they are (never read). Positions are scaled by 1/h in the moment
    matrix for its conditioning; ``ridge`` (:data:`RIDGE`) is the Tikhonov weight of its
    gradient block; a pivot below 1e-6 of the matrix' largest diagonal entry selects the
    Shepard fallback. ``phase`` (N,) and ``nphase``: each phase's fluid neighbours of b are
    fitted on their own ("Several rest densities" in the module docstring; one fluid: zeros
    and 1)."""
    launch(coefficients_body, rows.shape[0], rows, toff, tfluid, x, rho_hat, bx, h, kid,
           int(dim), L, ridge, phase, int(nphase), coef)


@numba.njit(inline="always", **_JIT)
def _moments(x, bx, b, t0, t1, tfluid, h, kid, dim, L, phase, ph, nphase, q, w_out):
    """The sums of the moment matrix ``M = sum_f W_bf [1, d_f] [1, d_f]^T`` of boundary sample
    b's fluid neighbours f of phase ``ph`` (its pairs t0..t1; ``d_f = (x_f - x_b) / h``; every
    pair where ``nphase`` is 1), as its upper triangle ``m00, m01, m02, m03, m11, m12, m13,
    m22, m23, m33`` (the rows beyond ``dim + 1`` zero; ``m00 = sum_f W_bf``), followed by the
    right-hand side ``r0 .. r3 = sum_f W_bf [1, d_f] q_f`` of the fluid values ``q`` (N,), or
    zeros for an empty q: fourteen scalars (a flat tuple: the pair loops inline it).
    ``w_out`` (pairs,) or empty: where given, each pair's ``W_bf`` is kept in it."""
    m00 = m01 = m02 = m03 = m11 = m12 = m13 = m22 = m23 = m33 = 0.0
    r0 = r1 = r2 = r3 = 0.0
    inv_h = 1.0 / h
    with_q = q.shape[0] > 0
    keep = w_out.shape[0] > 0
    for t in unsigned_range(t0, t1):
        f = tfluid[t]
        if nphase > 1 and phase[f] != ph:
            continue
        xf0, xf1, xf2 = point(x, f, dim)
        d0, d1, d2, r = separation(xf0, xf1, xf2, bx, b, dim, L)  # x_f - x_b
        e1, e2, e3 = d0 * inv_h, d1 * inv_h, d2 * inv_h  # 0 beyond dim
        w = kernel_w(kid, r, h, dim)
        if keep:
            w_out[t] = w
        m00 += w
        m01 += w * e1
        m02 += w * e2
        m03 += w * e3
        m11, m12, m13, m22, m23, m33 = outer_add(w, e1, e2, e3, m11, m12, m13, m22, m23, m33)
        if with_q:
            wq = w * q[f]
            r0 += wq
            r1 += wq * e1
            r2 += wq * e2
            r3 += wq * e3
    return m00, m01, m02, m03, m11, m12, m13, m22, m23, m33, r0, r1, r2, r3


@numba.njit(**_JIT)
def _solve(m, r, ridge, dim):
    """``(ok, y)``: the solution y (4,) of ``M y = r`` for the symmetric moment matrix m of
    :func:`_moments` (its first ``dim + 1`` rows; y 0 beyond) with the Tikhonov term ``ridge
    m00`` added to its gradient block (a gradient the neighbours do not determine -- all of
    them on one row, as under a single fluid layer -- is taken as 0 instead of noise), by its
    factorisation ``L D L^T`` (M is positive definite where the neighbours determine the fit:
    the Tikhonov term makes its gradient block so), ok False where a pivot of D falls below
    1e-6 of M's largest diagonal entry (M singular: the neighbours do not determine the fit).
    A function of its own (not inlined): Numba's parallel loops do not take the tuples
    inlined."""
    m00, m01, m02, m03, m11, m12, m13, m22, m23, m33 = m
    r0, r1, r2, r3 = r
    t = ridge * m00
    m11 += t
    m22 += t
    m33 += t
    big = max(m00, m11)
    if dim > 1:
        big = max(big, m22)
    if dim > 2:
        big = max(big, m33)
    if dim < 3:  # the rows beyond dim + 1 decouple (y 0 there)
        m33 = big
        r3 = 0.0
    if dim < 2:
        m22 = big
        r2 = 0.0
    tol = 1e-6 * big
    ok = big > 0.0
    d0 = m00
    ok = ok and d0 >= tol
    d0 = d0 if ok else 1.0  # (the factors of a failed fit are not used)
    l10, l20, l30 = m01 / d0, m02 / d0, m03 / d0
    d1 = m11 - l10 * l10 * d0
    ok = ok and d1 >= tol
    d1 = d1 if ok else 1.0
    l21 = (m12 - l20 * l10 * d0) / d1
    l31 = (m13 - l30 * l10 * d0) / d1
    d2 = m22 - l20 * l20 * d0 - l21 * l21 * d1
    ok = ok and d2 >= tol
    d2 = d2 if ok else 1.0
    l32 = (m23 - l30 * l20 * d0 - l31 * l21 * d1) / d2
    d3 = m33 - l30 * l30 * d0 - l31 * l31 * d1 - l32 * l32 * d2
    ok = ok and d3 >= tol
    d3 = d3 if ok else 1.0
    z1 = r1 - l10 * r0  # L z = r, then D L^T y = z
    z2 = r2 - l20 * r0 - l21 * z1
    z3 = r3 - l30 * r0 - l31 * z1 - l32 * z2
    y3 = z3 / d3
    y2 = z2 / d2 - l32 * y3
    y1 = z1 / d1 - l21 * y2 - l31 * y3
    y0 = r0 / d0 - l10 * y1 - l20 * y2 - l30 * y3
    return ok, (y0, y1, y2, y3)


@numba.njit(inline="always", **_JIT)
def coefficients_body(a, rows, toff, tfluid, x, rho_hat, bx, h, kid, dim, L, ridge, phase,
                      nphase, coef):
    """The coefficients of the pairs of boundary sample ``rows[a]`` (:func:`mls_coefficients`),
    each phase's fluid neighbours fitted on their own: the moving least-squares fit (``u``, the
    first row of ``M^-1``, from ``M u = e_0``: M is symmetric), then ``c_bf = W_bf (u_0 + u .
    d_f)`` times ``rho_hat_f^2`` (the Shepard weight where the fit fails)."""
    b = rows[a]
    t0 = toff[b]
    t1 = toff[b + 1]
    inv_h = 1.0 / h
    for ph in range(nphase):
        # the pairs' W_bf wait in coef (the second loop only scales them)
        m00, m01, m02, m03, m11, m12, m13, m22, m23, m33, _, _, _, _ = _moments(
            x, bx, b, t0, t1, tfluid, h, kid, dim, L, phase, ph, nphase, rho_hat[:0], coef)
        ok, u = _solve((m00, m01, m02, m03, m11, m12, m13, m22, m23, m33),
                       (1.0, 0.0, 0.0, 0.0), ridge, dim)
        u0, u1, u2, u3 = u
        for t in unsigned_range(t0, t1):
            f = tfluid[t]
            if nphase > 1 and phase[f] != ph:
                continue
            xf0, xf1, xf2 = point(x, f, dim)
            d0, d1, d2 = delta(xf0, xf1, xf2, bx, b, dim, L)  # x_f - x_b
            w = coef[t]
            lin = u0 + (u1 * d0 + u2 * d1 + u3 * d2) * inv_h
            c_bf = w * lin if ok else (w / m00 if m00 > 0.0 else 0.0)
            coef[t] = c_bf * rho_hat[f] * rho_hat[f]


@numba.njit(inline="always", **_JIT)
def values_body(a, rows, toff, tfluid, x, q, bx, h, kid, dim, L, ridge, phase, out):
    """``out[ph, b] = max(beta_0, 0)`` at boundary sample ``b = rows[a]`` for every phase ph
    (:func:`mls_values`)."""
    b = rows[a]
    t0 = toff[b]
    t1 = toff[b + 1]
    nphase = out.shape[0]
    for ph in range(nphase):
        m00, m01, m02, m03, m11, m12, m13, m22, m23, m33, r0, r1, r2, r3 = _moments(
            x, bx, b, t0, t1, tfluid, h, kid, dim, L, phase, ph, nphase, q, q[:0])
        ok, y = _solve((m00, m01, m02, m03, m11, m12, m13, m22, m23, m33), (r0, r1, r2, r3),
                       ridge, dim)
        value = y[0] if ok else (r0 / m00 if m00 > 0.0 else 0.0)
        out[ph, b] = max(value, 0.0)


def mls_values(x: np.ndarray, q: np.ndarray, bx: np.ndarray, toff: np.ndarray,
               tfluid: np.ndarray, rows: np.ndarray, h: float, kid: int, dim: int,
               L: float | tuple, ridge: float, phase: np.ndarray, out: np.ndarray) -> None:
    """``out[ph, b] = max(beta_0, 0)``: the value at boundary sample b of the linear field fitted
    to the fluid values q (N,) of phase ph (the module docstring's fit, solved for ``beta``
    directly: the one-shot form of :func:`mls_coefficients` then :func:`mls_extrapolate`, for a
    solver that extrapolates once a step), at the samples ``rows`` (:func:`transposed`); 0 where b
    has no fluid neighbour of the phase; the other samples' entries are left as they are.
    ``out`` (phases, N_boundary)."""
    launch(values_body, rows.shape[0], rows, toff, tfluid, x, q, bx, h, kid, int(dim), L, ridge,
           phase, out)


@numba.njit(inline="always", **_JIT)
def extrapolate_body(a, rows, toff, tfluid, coef, k, out):
    """``out[b] = max(sum_f c_bf rho_hat_f^2 k_f, 0)`` at boundary sample ``b = rows[a]``."""
    b = rows[a]
    s = 0.0
    for t in unsigned_range(toff[b], toff[b + 1]):
        s += coef[t] * k[tfluid[t]]
    out[b] = max(s, 0.0)


@numba.njit(inline="always", **_JIT)
def extrapolate_phases_body(a, rows, toff, tfluid, coef, phase, k, out):
    """``out[q, b] = max(sum_f c_bf rho_hat_f^2 k_f, 0)`` over the fluid neighbours f of phase
    q of boundary sample ``b = rows[a]``, for every phase q (0 where none)."""
    b = rows[a]
    nq = out.shape[0]
    for q in range(nq):
        out[q, b] = 0.0
    for t in unsigned_range(toff[b], toff[b + 1]):
        f = tfluid[t]
        out[phase[f], b] += coef[t] * k[f]
    for q in range(nq):
        out[q, b] = max(out[q, b], 0.0)


def mls_extrapolate(k: np.ndarray, toff: np.ndarray, tfluid: np.ndarray, rows: np.ndarray,
                    coef: np.ndarray, out: np.ndarray) -> None:
    """``out[b] = max(sum_f c_bf rho_hat_f^2 k_f, 0)``: the boundary value ``p_b / rho0`` of the
    fluid field k at the samples ``rows`` (:func:`transposed`; the other samples' entries are left
    as they are)."""
    launch(extrapolate_body, rows.shape[0], rows, toff, tfluid, coef, k, out)


def mls_extrapolate_phases(k: np.ndarray, toff: np.ndarray, tfluid: np.ndarray,
                           rows: np.ndarray, coef: np.ndarray, phase: np.ndarray,
                           out: np.ndarray) -> None:
    """``out[q, b] = max(sum_f c_bf rho_hat_f^2 k_f, 0)`` over b's fluid neighbours f of phase
    q (coefficients of :func:`mls_coefficients` with the phases fitted on their own): one
    boundary value per phase (0 for a phase without fluid neighbours at b), at the samples
    ``rows`` (:func:`transposed`)."""
    launch(extrapolate_phases_body, rows.shape[0], rows, toff, tfluid, coef, phase, k, out)


@numba.njit(inline="always", cache=True)
def transpose_body(i, boff, bidx, toff, rank, tfluid):
    """Fluid particle i into the boundary -> fluid lists: ``tfluid[toff[b] + rank[k]] = i`` for
    each of its pairs k with boundary sample ``b = bidx[k]`` (``rank``: the pair's place among
    b's pairs, :func:`sphkit.backend.histogram`; the slots are distinct)."""
    for k in unsigned_range(boff[i], boff[i + 1]):
        tfluid[toff[bidx[k]] + rank[k]] = i


def transposed(boff: Any, bidx: Any, nb: int, use: Any) -> tuple[Any, Any, Any]:
    """CSR lists boundary -> fluid of the fluid -> boundary lists ``(boff, bidx)``: ``toff``
    (nb + 1) and ``tfluid`` (the fluid particle of each pair), where the lists are, and on the
    CPU the samples to fit: those of ``use`` (extrapolated) with fluid neighbours (most wall
    samples are far from the fluid, and the passes skip them). On the CPU in fluid-index order
    within each sample (:func:`_transpose`, serial, faster there than the counting sort's three
    passes); on a device by the counting sort's histogram and scan and
    :func:`transpose_body` (the order within a sample is that of the atomic increments), and
    None for the samples (the device fits every sample of ``use``; those without fluid
    neighbours get 0)."""
    dev = device_of(bidx)
    if dev == "cpu":
        return _transpose(boff, bidx, nb, use)
    pairs = bidx.shape[0]
    counts, rank = arrays.empty(nb, np.int64, like=bidx), arrays.empty(pairs, np.int64, like=bidx)
    toff = arrays.empty(nb + 1, np.int64, like=bidx)
    tfluid = arrays.empty(pairs, INDEX, like=bidx)
    histogram(bidx, counts, rank, device=dev)
    exclusive_scan(counts, toff, device=dev)
    launch(transpose_body, boff.shape[0] - 1, boff, bidx, toff, rank, tfluid)
    return toff, tfluid, None


class MLSPressureExtrapolation(BoundaryPressure):
    """Boundary pressure by MLS extrapolation (Band et al. 2018) for the iterative solvers.

    The step calls :meth:`prepare` once per step after the densities; the solvers call
    :meth:`extrapolate` (through :meth:`sphkit.core.coupling.BoundaryCoupling.boundary_kappa`)
    before every evaluation of the pressure acceleration. ``use`` marks the boundary samples
    that are extrapolated; their ``pressure_mirror`` is set to 0 (the extrapolated value
    replaces the mirrored one) and :meth:`diagonal_mirror` is 1 there.

    On a device (the boundary's fields device arrays) every pass runs there on the same bodies;
    the samples fitted are then all of ``use``'s (those without fluid neighbours get 0), where
    the CPU skips the ones without fluid neighbours (:func:`transposed`).
    """

    name = "mls"

    def __init__(self, use: np.ndarray, ridge: float = RIDGE) -> None:
        self.ridge = float(ridge)
        self.use = np.ascontiguousarray(use, dtype=np.bool_)
        self.toff = np.zeros(self.use.shape[0] + 1, dtype=np.int64)
        self.rows = np.zeros(0, dtype=np.int64)  # the samples fitted this step (:func:`transposed`)
        self.tfluid = np.empty(0, dtype=INDEX)
        self.coef: Any = np.empty(0)  # this step's, once computed (:meth:`prepare`)
        self._fit_args: tuple = ()
        self.phase: np.ndarray | None = None  # the fluid's phases where fitted on their own
        #: ``use`` where the boundary's fields are: (the flags, the share of
        #: :meth:`diagonal_mirror`, the flagged samples), made once per device and dtype
        self._on: dict[tuple[str, Any], tuple[Any, Any, Any]] = {}
        self._share: Any = None  # :meth:`diagonal_mirror`'s, as of the last :meth:`prepare`

    def init(self, state: SimState) -> None:
        """Turn mirroring off where the extrapolation replaces it."""
        b = state.boundary
        if b.n != self.use.shape[0]:
            raise ValueError(f"MLS pressure extrapolation: {self.use.shape[0]} flags for "
                             f"{b.n} boundary particles")
        b["pressure_mirror"][self.use] = 0.0

    def _flags(self, like: Any) -> tuple[Any, Any, Any]:
        """``use``, its share (1 where extrapolated, in ``like``'s dtype) and the indices of
        the samples it flags, on ``like``'s device."""
        key = (device_of(like), like.dtype)
        if key not in self._on:
            dev = key[0]
            self._on[key] = (to_device(self.use, dev), to_device(self.use.astype(like.dtype), dev),
                             to_device(np.flatnonzero(self.use).astype(np.int64), dev))
        return self._on[key]

    def diagonal_mirror(self) -> np.ndarray:
        """Mirror share used in the Jacobi diagonals (the mirrored form, see the docstring):
        1 where extrapolated, where the boundary's fields are (as of :meth:`prepare`)."""
        return self._share if self._share is not None else self.use.astype(np.float64)

    def prepare(self, state: SimState) -> None:
        """This step's boundary -> fluid lists; the coefficients follow at the first
        :meth:`extrapolate` of the step (a solver that extrapolates once, WCSPH through
        :meth:`correct_mirrored`, fits the values directly and needs none)."""
        f, b = state.fluid, state.boundary
        if b.n != self.use.shape[0]:
            raise ValueError(f"MLS pressure extrapolation: {self.use.shape[0]} flags for "
                             f"{b.n} boundary particles (the boundary changed after the model "
                             "was made)")
        nb = state.nl_fb
        use, self._share, flagged = self._flags(b["x"])
        self.toff, self.tfluid, rows = transposed(nb.offsets, nb.indices, b.n, use)
        self.rows = flagged if rows is None else rows
        self.phase = per_phase(state)
        self._fit_args = (f["x"], arrays.divided_by(f["rho"], f["rho0"]), b["x"], state.h,
                          state.kid, state.dim, state.pair_period, self._phase_rows(f))
        self.coef = None

    def _coefficients(self) -> Any:
        """This step's coefficients (:func:`mls_coefficients`), computed at the first call."""
        if self.coef is None:
            x, rho_hat, bx, h, kid, dim, L, phase = self._fit_args
            self.coef = arrays.empty(self.tfluid.shape[0], x.dtype, like=x)
            mls_coefficients(x, rho_hat, bx, self.toff, self.tfluid, self.rows, h,
                             kid, dim, L, self.ridge, self.coef, phase, self.phases)
        return self.coef

    @property
    def phases(self) -> int:
        """How many boundary values each sample takes: the phases when they are fitted on their
        own (:meth:`extrapolate` then fills ``out`` of shape (phases, N_boundary)), else 1."""
        return int(self.phase.max()) + 1 if self.phase is not None else 1

    def _phase_rows(self, fluid: Any) -> Any:
        """The row of each fluid particle in the per-phase passes: :attr:`phase`, or an empty
        array where one fit serves all (one row: the passes read no phase), where the fluid's
        fields are."""
        if self.phase is not None:
            return self.phase
        return arrays.absent(0, np.int64, like=fluid["x"])

    def correct_mirrored(self, state: SimState, a: Any) -> None:
        """For a state-equation solver (WCSPH) whose boundary term mirrored ``p_b = p_i``:
        add to ``a`` the change to the extrapolated boundary pressure
        (:func:`sphkit.core.operators.replace_mirrored`)."""
        f, b = state.fluid, state.boundary
        kb = arrays.zeros((self.phases, b.n), f.dtype, like=f["x"])
        rest = state.rest()
        phase = self._phase_rows(f)
        # kb = p_b / rho0_ref, one row per phase fitted on its own: the fit of p / rho0_ref
        mls_values(f["x"], arrays.divided(f["p"], state.rho0), b["x"], self.toff, self.tfluid,
                   self.rows, state.h, state.kid, state.dim, state.pair_period, self.ridge,
                   phase, kb)
        replace_mirrored(f["x"], f["p"], rest.rho0, rest.inv_c, b["x"], b["V"],
                         state.nl_fb.offsets, state.nl_fb.indices, self._flags(b["x"])[0], kb,
                         phase, state.h, state.kid, state.dim, state.pair_period, a)

    def extrapolate(self, k: Any, out: Any) -> None:
        """``out[b] = p_b / rho0`` of the fluid field k (see :func:`mls_extrapolate`); with the
        phases fitted on their own ``out[q, b]``, (phases, N_boundary)
        (:func:`mls_extrapolate_phases`)."""
        coef = self._coefficients()
        if out.ndim == 2:
            mls_extrapolate_phases(k, self.toff, self.tfluid, self.rows, coef, self.phase, out)
        else:
            mls_extrapolate(k, self.toff, self.tfluid, self.rows, coef, out)


def per_phase(state: SimState) -> np.ndarray | None:
    """The fluid's phase indices (N,) when the extrapolation fits each phase on its own (a
    scene whose fluids differ in rest density), else None."""
    f = state.fluid
    if "phase" not in f.specs or f.n == 0 or state.rest().uniform:
        return None
    return f["phase"]
