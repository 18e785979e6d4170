"""Fast corotated elastic SPH solids with implicit zero-energy-mode control (SPlisHSPlasH
``elasticityMethod`` 3).

Kugelstadt, Bender, Fernández-Fernández, Jeske, Löschner & Longva 2021, "Fast Corotated Elastic
SPH Solids with Implicit Zero-Energy Mode Control", PACMCGIT 4(3) (SPlisHSPlasH's
``Elasticity_Kugelstadt2021.cpp``; ``reference/methods.md`` N3). Backward Euler in the
positions, ``x' = argmin |x - x~|_M^2 / (2 dt^2) + U(x)`` with ``x~ = x + dt (v + dt a)`` (``a``:
the other accelerations of the stage), the corotated energy split into

* the stretch part ``U_s = mu sum_i V0_i |F_i - R_i|^2`` (Sec. 4 of the paper), with the
  rotations R_i of the deformation gradients of the predicted positions ``x~`` (Müller et al.
  2016's iteration, warm-started) held: ``F_i = grad x`` is linear in the positions, so
  the Hessian ``2 mu K``, ``K = sum_c D_c^T V0 D_c``
  (``D_c`` the sparse operator of the c-th component of the gradient, the weights of
  :mod:`sphkit.solids.gradients`), is constant and the same for every coordinate; the
  rotations only enter the right-hand side ``2 mu sum_c D_c^T (V0 R[:, a, c])``;
* the zero-energy-mode term (Sec. 5, "implicit zero-energy mode control"): the energy
  ``alpha E / 2 sum_(i,j) V0_i V0_j W(x0_ij) / |x0_ij|^2 |x_ij - F_i x0_ij|^2`` (the miss of
  the position of j predicted by i's deformation gradient, Ganzenmüller 2015's error vector,
  over the rest pairs), quadratic in the positions with a constant Hessian, so it joins the
  factorised matrix;
* the volume part ``U_v = lambda / 2 sum_i V0_i (tr(R_i^T F_i) - dim)^2``, whose Hessian
  depends on the rotations: a second solve on the result of the first (operator splitting),
  ``(M / dt^2 + H_v) dx = -grad U_v(x_1)``, by the shared CG (:func:`sphkit.core.krylov.cg`,
  ``max_iterations``/``max_error``: SPlisHSPlasH's ``volumeMaxIter`` 100 and
  ``volumeMaxError`` 1e-4), started from the last two steps' corrections extrapolated.

Together ``U_s + U_v`` is corotated linear elasticity, ``sigma = 2 mu eps + lambda tr(eps) I``
(``mu |F - R|^2 = mu |eps|^2`` when R is the polar rotation), the model of
:mod:`sphkit.solids.becker2009`; so a stretched bar pulls with ``E eps A``
(tests/test_solids.py).

The constant matrix ``A = M / dt^2 + 2 mu K + alpha E H_z`` (one scalar n x n matrix per elastic
material, the pinned particles eliminated; the objects of one material, such as
DeformableBunnies' two bunnies, are its uncoupled diagonal blocks, which SuperLU's ordering
keeps apart; SPlisHSPlasH factorises each object on its own) is factorised once per time-step
size (:class:`sphkit.core.ldlt.LDLT`: a Cholesky factor in the reverse Cuthill-McKee envelope
for the narrow bodies, else ``L D L^T`` from SuperLU's symmetric mode through scipy, each with
compiled triangular solves; the issue asked for CHOLMOD through scikit-sparse, which is a
source package needing the system's SuiteSparse, not installed here, so not a dependency);
:attr:`Kugelstadt2021.factor_stats` reports the factorisation's time and memory. SPlisHSPlasH
factorises with its own AVX Cholesky and caches it on disk. The matrix is refactorised when
the time step changes (fixed-step scenes, as SPlisHSPlasH's, factorise once).

Plasticity (``yield_stress``, ``hardening``; :mod:`sphkit.solids.plasticity`): the return
mapping acts on the corotated strain of the step's start; the plastic strain ``eps_p`` (in the
particle's corotated frame, deviatoric) moves the stretch energy's target to
``mu |F_i - R_i (I + eps_p,i)|^2``, which changes its right-hand side only (the Hessian stays
``2 mu K``, the factorisation is kept), and leaves the volume part alone (``tr eps_p = 0``).
The moment-matrix option ``rotation`` does not apply (the rotations are F's).

Face clamp (``clamp="face"``, :mod:`sphkit.solids.rest`): a free particle's fit samples a
pinned neighbour on the clamp's face, a constant shift per pair, so the deformation gradient is
``F_i = (D x)_i - C_i`` with the constant ``C_i`` of
:func:`sphkit.solids.corotation.clamp_shifts` (``D x0 = I + C`` next to the face, not I; zero
elsewhere and without the face clamp). The matrix keeps its form; three constants enter the
right-hand sides: the rotations are those of ``D x~ - C``; the stretch energy
``mu |D x - C - R|^2`` has the target ``R + C`` for ``D x``
(``2 mu sum_c D_c^T V0 (R + C)[:, a, c]``); the zero-energy term, whose error vectors carry
the same shift, is ``1/2 (x - x0)^T alpha E Z (x - x0)`` (``Z x0`` is the shift's error
vectors, so this is the energy of ``F = D x - C``), which adds ``alpha E Z x0`` per
coordinate; and the volume term's ``tr(R^T F)`` loses ``tr(R^T C)``. The rest state is then
free of force (tests/test_solids.py), and the response at small steps is becker2009's
face-clamped force.

The solid's acceleration of the stage becomes ``(v' - v) / dt`` with ``v' = (x' - x) / dt``;
pinned particles keep ``x' = x0``. The pressure solver then acts on the result. No time-step
bound of its own. The elastic forces of the step, ``M (x~ - x') / dt^2``, are sums of pair
terms antisymmetric on the symmetric rest lists (each Hessian has zero row sums), so linear
momentum is kept to round-off (the volume solve's residual aside).

Accuracy (validation/README.md, "Elastic cantilevers"): the splitting costs an error of order
``dt^2 c^2 / h^2`` (each sub-solve sees the other energy's large internal forces only through
the positions it starts from): the clamped plate's first mode is 14 % slow at 10 times the
explicit step, 12 % at 3 times, against 9.5 % for the monolithic peer2018 on the same
discretisation.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any, ClassVar

import numba
import numpy as np
import scipy.sparse as sp

from sphkit.core.krylov import JacobiPreconditioner, cg
from sphkit.core.ldlt import LDLT
from sphkit.core.pairs import pair_slots
from sphkit.core.state import SimState
from sphkit.solids.base import ROTATION_ITERATIONS, ImplicitCorotatedSolid
from sphkit.solids.corotation import _extract_rotation, stresses
from sphkit.solids.operators import (
    gradient_laplacian,
    gradient_operators,
    zero_energy_operator,
)

log = logging.getLogger("sphkit")


@numba.njit(parallel=True, cache=True, fastmath=True)
def _extract_rotations(A, qw, qv, pos, iterations, R):
    """``R[s]`` (row-major 9-vector): the rotational part of ``A[s]`` (3 x 3) by the iteration
    of Müller, Bender, Chentanez & Macklin 2016 (:mod:`sphkit.solids.corotation`'s, compiled,
    per particle until the correction is below 1e-9 rad), warm-started from and written back
    to the quaternion fields ``qw``, ``qv`` at the particles ``pos``."""
    for s in numba.prange(pos.shape[0]):
        a = A[s]
        _extract_rotation(a[0, 0], a[0, 1], a[0, 2], a[1, 0], a[1, 1], a[1, 2], a[2, 0],
                          a[2, 1], a[2, 2], qw, qv, pos[s], R[s], iterations, 1e-9)


# compiled passes over the common pattern of the D_c (CSR ``indptr``, ``indices``; data
# ``Dd`` (dim, nnz)) and its transpose (``tindptr``, ``tindices``; ``tperm[k]``: the entry of
# the pattern at the transposed pattern's entry k), which replace scipy's matrix-vector
# products and NumPy's temporaries in the step (each a gather: no races when parallel)


@numba.njit(parallel=True, cache=True, fastmath=True)
def _deformation_gradients(indptr, indices, Dd, y, dim, F):
    """``F[i, a, c] = (D_c y_a)_i`` for a, c < dim (the rest of F untouched); one sweep over
    row i's entries accumulates all dim^2 sums (each in the entries' order)."""
    for i in numba.prange(indptr.shape[0] - 1):
        f00 = f01 = f02 = f10 = f11 = f12 = f20 = f21 = f22 = 0.0
        for k in pair_slots(indptr, i):
            j = indices[k]
            d0 = Dd[0, k]
            d1 = Dd[1, k] if dim > 1 else 0.0
            d2 = Dd[2, k] if dim > 2 else 0.0
            y0 = y[0, j]
            f00 += d0 * y0
            f01 += d1 * y0
            f02 += d2 * y0
            if dim > 1:
                y1 = y[1, j]
                f10 += d0 * y1
                f11 += d1 * y1
                f12 += d2 * y1
            if dim > 2:
                y2 = y[2, j]
                f20 += d0 * y2
                f21 += d1 * y2
                f22 += d2 * y2
        Fi = F[i]
        Fi[0, 0] = f00
        if dim > 1:
            Fi[0, 1] = f01
            Fi[1, 0] = f10
            Fi[1, 1] = f11
        if dim > 2:
            Fi[0, 2] = f02
            Fi[1, 2] = f12
            Fi[2, 0] = f20
            Fi[2, 1] = f21
            Fi[2, 2] = f22


@numba.njit(parallel=True, cache=True, fastmath=True)
def _stretch_rhs(tindptr, tindices, DdT, V0, Rs, xt, m, inv_dt2, two_mu, dim, b):
    """``b[a] = m xt[a] / dt^2 + 2 mu sum_c D_c^T (V0 Rs[:, a, c])`` (the stretch solve's
    right-hand side before the pinned particles are eliminated; ``DdT``: the D_c's entries on
    the transposed pattern)."""
    for j in numba.prange(tindptr.shape[0] - 1):
        s0 = s1 = s2 = 0.0
        for k in pair_slots(tindptr, j):
            i = tindices[k]
            Ri = Rs[i]
            d0 = DdT[0, k]
            d1 = DdT[1, k] if dim > 1 else 0.0
            d2 = DdT[2, k] if dim > 2 else 0.0
            v = V0[i]
            r = d0 * Ri[0, 0]
            if dim > 1:
                r += d1 * Ri[0, 1]
            if dim > 2:
                r += d2 * Ri[0, 2]
            s0 += v * r
            if dim > 1:
                r = d0 * Ri[1, 0] + d1 * Ri[1, 1]
                if dim > 2:
                    r += d2 * Ri[1, 2]
                s1 += v * r
            if dim > 2:
                r = d0 * Ri[2, 0] + d1 * Ri[2, 1] + d2 * Ri[2, 2]
                s2 += v * r
        b[0, j] = m[j] * xt[0, j] * inv_dt2 + two_mu * s0
        if dim > 1:
            b[1, j] = m[j] * xt[1, j] * inv_dt2 + two_mu * s1
        if dim > 2:
            b[2, j] = m[j] * xt[2, j] * inv_dt2 + two_mu * s2


@numba.njit(parallel=True, cache=True, fastmath=True)
def _volume_data(indptr, tperm, Dd, R, dim, Bd, BTd):
    """The entries of ``B_a = sum_c diag(R[:, a, c]) D_c`` on the pattern (``Bd``) and on the
    transposed pattern (``BTd``)."""
    for i in numba.prange(indptr.shape[0] - 1):
        for k in pair_slots(indptr, i):
            for a in range(dim):
                s = 0.0
                for c in range(dim):
                    s += R[i, a, c] * Dd[c, k]
                Bd[a, k] = s
    for k in numba.prange(tperm.shape[0]):
        for a in range(dim):
            BTd[a, k] = Bd[a, tperm[k]]


@numba.njit(parallel=True, cache=True, fastmath=True)
def _volume_system(indptr, indices, tindptr, tindices, Bd, BTd, x1, lv, md, pinned, dim, t0, t,
                   g, diag):
    """The volume solve's ``t = tr(R^T F(x1)) - dim`` (``F = D x1 - C``: ``t0 = tr(R^T C)``),
    right-hand side ``g_a = -B_a^T (lv t)`` and Jacobi diagonal ``m / dt^2 + sum_i lv_i
    B_a[i, j]^2`` (pinned: g 0, diagonal 1)."""
    n = indptr.shape[0] - 1
    for i in numba.prange(n):
        s0 = s1 = s2 = 0.0
        for k in pair_slots(indptr, i):
            j = indices[k]
            s0 += Bd[0, k] * x1[0, j]
            if dim > 1:
                s1 += Bd[1, k] * x1[1, j]
            if dim > 2:
                s2 += Bd[2, k] * x1[2, j]
        t[i] = lv[i] * (s0 + s1 + s2 - dim - t0[i])
    for j in numba.prange(n):
        if pinned[j]:
            for a in range(dim):
                g[a, j] = 0.0
                diag[a, j] = 1.0
            continue
        s0 = s1 = s2 = d0 = d1 = d2 = 0.0
        for k in pair_slots(tindptr, j):
            i = tindices[k]
            ti = t[i]
            li = lv[i]
            b = BTd[0, k]
            s0 += b * ti
            d0 += b * b * li
            if dim > 1:
                b = BTd[1, k]
                s1 += b * ti
                d1 += b * b * li
            if dim > 2:
                b = BTd[2, k]
                s2 += b * ti
                d2 += b * b * li
        g[0, j] = -s0
        diag[0, j] = md[j] + d0
        if dim > 1:
            g[1, j] = -s1
            diag[1, j] = md[j] + d1
        if dim > 2:
            g[2, j] = -s2
            diag[2, j] = md[j] + d2


@numba.njit(parallel=True, cache=True, fastmath=True)
def _volume_matvec(indptr, indices, tindptr, tindices, Bd, BTd, lv, md, free, dim, y, s,
                   out):
    """``out = (M / dt^2 + lambda B^T V0 B) y`` with the pinned unknowns held (their rows the
    identity, their columns dropped: ``free`` is 1 for a free particle, 0 for a pinned one);
    y, out: flat (dim, n), s: n scratch. Written for dim <= 3 without branches in the pair
    loops."""
    n = indptr.shape[0] - 1
    n1 = n if dim > 1 else 0
    n2 = 2 * n if dim > 2 else 0
    for i in numba.prange(n):
        r = 0.0
        for k in pair_slots(indptr, i):
            j = indices[k]
            t = Bd[0, k] * y[j]
            if dim > 1:
                t += Bd[1, k] * y[n1 + j]
            if dim > 2:
                t += Bd[2, k] * y[n2 + j]
            r += free[j] * t
        s[i] = lv[i] * r
    for j in numba.prange(n):
        r0 = r1 = r2 = 0.0
        for k in pair_slots(tindptr, j):
            sv = s[tindices[k]]
            r0 += BTd[0, k] * sv
            if dim > 1:
                r1 += BTd[1, k] * sv
            if dim > 2:
                r2 += BTd[2, k] * sv
        if free[j] == 0.0:
            r0 = r1 = r2 = 0.0
        c = md[j] if free[j] != 0.0 else 1.0
        out[j] = c * y[j] + r0
        if dim > 1:
            out[n1 + j] = c * y[n1 + j] + r1
        if dim > 2:
            out[n2 + j] = c * y[n2 + j] + r2


def _plastic_tensors(diag: np.ndarray, shear: np.ndarray) -> np.ndarray:
    """(n, 3, 3) symmetric plastic strains from their diagonal (3, n: 00, 11, 22) and
    off-diagonal (3, n: 01, 02, 12) components."""
    e = np.zeros((diag.shape[1], 3, 3))
    for a in range(3):
        e[:, a, a] = diag[a]
    for k, (a, b) in enumerate(((0, 1), (0, 2), (1, 2))):
        e[:, a, b] = e[:, b, a] = shear[k]
    return e


class Kugelstadt2021(ImplicitCorotatedSolid):
    """Operator-split implicit corotated elasticity with a pre-factorised constant matrix
    (module docstring)."""

    name: ClassVar[str] = "kugelstadt2021"

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.D: list[sp.csr_matrix] = []
        self.K = sp.csr_matrix((0, 0))  #: 2 mu K + alpha E H_z (constant part of the matrix)
        self._dt = -1.0
        self._lu: Any = None
        self._free = np.zeros(0, np.int64)
        self._Afp = sp.csr_matrix((0, 0))
        self._dx = np.zeros(0)
        self._dx_prev = np.zeros(0)
        #: per factorisation: ``{"n": unknowns, "nnz": matrix nonzeros, "factor_nnz": entries
        #: of the kept factor (its envelope, or L D L^T's strict lower L and D), "bytes": its
        #: memory [B], "seconds": wall time, "dt": the step}``
        self.factor_stats: list[dict[str, float]] = []

    def init(self, state: SimState) -> None:
        """The base's rest configuration and gradient weights, then the constant matrices."""
        super().init(state)
        rest = self.rest
        dim = state.dim
        off, idx = rest.lists.offsets, rest.lists.indices
        self.D = gradient_operators(off, idx, self.G, dim)
        K = gradient_laplacian(self.D, rest.V0)
        A = 2.0 * self.mu * K
        if self.alpha > 0:
            A = A + self.alpha * self.youngs_modulus * zero_energy_operator(
                rest.x0, rest.V0, off, idx, self.D, rest.h, state.kid, dim)
        self.K = sp.csr_matrix(A)
        # the face clamp (module docstring): F = D x - C, and the zero-energy term's constant
        # force alpha E Z x0 (Z x0 = -c, the error vectors' shift); none without it
        self._face = bool(np.abs(self.C).any())
        self._Cm = self.C.reshape(rest.n, 3, 3)[:, :dim, :dim]
        self._z0 = np.zeros((dim, rest.n))
        if self._face and self.alpha > 0:
            Kz = A - 2.0 * self.mu * K
            self._z0 = np.stack([Kz @ rest.x0[a] for a in range(dim)])
        self._free = np.flatnonzero(~rest.pinned)
        self._dt = -1.0
        self._lu = None
        self._dx = np.zeros(dim * rest.n)
        self._dx_prev = np.zeros(dim * rest.n)  #: the volume correction before the last
        # the common pattern of the D_c (one per component, built from the same pairs) and
        # the permutation of its entries into the transposed pattern (the volume passes)
        D0 = self.D[0]
        for Dc in self.D[1:]:
            if not (np.array_equal(Dc.indptr, D0.indptr)
                    and np.array_equal(Dc.indices, D0.indices)):
                raise RuntimeError("kugelstadt2021: the gradient operators' patterns differ")
        self._indptr, self._indices = D0.indptr.astype(np.int64), D0.indices.astype(np.int64)
        self._Ddata = np.stack([Dc.data for Dc in self.D])
        T = sp.csr_matrix((np.arange(1.0, D0.nnz + 1.0), D0.indices, D0.indptr),
                          shape=D0.shape).T.tocsr()
        self._tperm = (T.data - 1.0).astype(np.int64)
        self._DdT = np.ascontiguousarray(self._Ddata[:, self._tperm])
        self._tindices, self._tindptr = T.indices.astype(np.int64), T.indptr.astype(np.int64)
        self._freew = np.where(rest.pinned, 0.0, 1.0)  #: 1 free, 0 pinned (the volume matvec)
        self._Bd = np.zeros((dim, D0.nnz))
        self._BTd = np.zeros((dim, D0.nnz))

    def _factorise(self, dt: float) -> None:
        """The factorisation of ``M / dt^2 + K`` on the free particles (:class:`LDLT`); its
        time and memory into :attr:`factor_stats`."""
        rest = self.rest
        A = (self.K + sp.diags(rest.m / (dt * dt))).tocsr()
        fr = self._free
        pinned = rest.fixed
        Aff = A[fr][:, fr].tocsc()
        t0 = time.perf_counter()
        self._lu = LDLT(Aff) if fr.size else None
        secs = time.perf_counter() - t0
        self._Afp = A[fr][:, pinned].tocsr()
        self._dt = dt
        lu = self._lu
        fnnz = lu.nnz if lu is not None else 0
        stats = {"n": float(fr.size), "nnz": float(Aff.nnz), "factor_nnz": float(fnnz),
                 "bytes": float(lu.bytes if lu is not None else 0), "seconds": secs, "dt": dt}
        self.factor_stats.append(stats)
        log.info("kugelstadt2021: factorised %d unknowns (%d nonzeros -> %d in the factor, "
                 "%s, %.1f MB) in %.3f s", fr.size, Aff.nnz, fnnz,
                 lu.kind if lu is not None else "none", stats["bytes"] / 1e6, secs)

    def max_time_step(self, state: SimState) -> float:
        """Implicit: no bound of its own."""
        return math.inf

    def apply(self, state: SimState, dt: float) -> None:
        """Rotations, the factorised stretch solve, the CG volume solve; the solid's
        acceleration becomes ``(v' - v) / dt``."""
        rest = self.rest
        if rest is None or rest.n == 0:
            return
        f = state.fluid
        dim = state.dim
        pos = rest.update(state)
        off, idx = rest.lists.offsets, rest.lists.indices
        w = self.work
        x = f["x"][:, pos]
        v = f["v"][:, pos]
        xt = x + dt * (v + dt * f["a"][:, pos])
        # R_i: the rotation of F_i(x~), the deformation gradient of the predicted positions,
        # by Müller et al. 2016's iteration warm-started from the last step (as SPlisHSPlasH
        # extracts it from F). Rotations held from the step's start dragged a spinning body
        # back to its old orientation (mu |F - R|^2, a drag of rate ~ c^2 dt / h^2: the
        # plate's first mode died within a quarter period); the moment matrix's rotation
        # (the corotated models') differs from F's by O(strain) at the surface, so
        # mu |F - R|^2 is not mu |eps|^2, and the plate went unstable at 3 times the
        # explicit step; a plain SVD polar(F) jumps where F is degenerate (Beam.json's capped
        # lists), the warm-started iteration does not.
        Fp = np.zeros((rest.n, 3, 3))
        Fp[:, 2, 2] = 1.0
        if dim < 2:
            Fp[:, 1, 1] = 1.0
        _deformation_gradients(self._indptr, self._indices, self._Ddata, xt, dim, Fp)
        if self._face:
            Fp[:, :dim, :dim] -= self._Cm
        _extract_rotations(Fp, f["solid_qw"], f["solid_q"], pos, ROTATION_ITERATIONS, w["R"])
        # von Mises stress for output; with a yield stress, the return mapping of the
        # step's start (solids.plasticity)
        stresses(f["x"], pos, rest.x0, off, idx, self.G, self.C, dim, self.mu, self.lam, w["R"],
                 w["F"], w["P"], w["M"], f["solid_stress"], *self.plastic_state(state),
                 self.yield_stress, self.hardening, self.plastic)
        if dt != self._dt:
            self._factorise(dt)
        Rm = w["R"].reshape(rest.n, 3, 3)
        Rs = Rm  # the stretch energy's target mu |F - R (I + eps_p)|^2
        if self.plastic:
            Rs = Rm @ (np.eye(3) + _plastic_tensors(f["solid_plastic"][:, pos],
                                                    f["solid_plastic_shear"][:, pos]))
        if self._face:  # the stretch target of D x: R (I + eps_p) + C
            Rs = Rs.copy()
            Rs[:, :dim, :dim] += self._Cm
        V0 = rest.V0
        m = rest.m
        fr, pinned = self._free, rest.fixed
        xp = rest.x0[:dim, pinned]
        x1 = np.empty_like(x)
        x1[:, pinned] = xp
        inv_dt2 = 1.0 / (dt * dt)
        n = rest.n
        ip, ix, tip, tix = self._indptr, self._indices, self._tindptr, self._tindices
        # stretch + zero-energy modes: one factorisation, the dim right-hand sides at once
        b = np.empty((dim, n))
        _stretch_rhs(tip, tix, self._DdT, V0, Rs, xt, m, inv_dt2,
                     2.0 * self.mu, dim, b)
        if self._face:
            b += self._z0
        if fr.size:
            rhs = b[:, fr].T - self._Afp @ xp.T
            x1[:, fr] = self._lu.solve(rhs).T
        # volume: (M / dt^2 + H_v) dx = -grad U_v(x1), H_v = lambda B^T V0 B, pinned dx = 0
        if self.lam > 0:
            Bd, BTd, pin = self._Bd, self._BTd, rest.pinned
            _volume_data(ip, self._tperm, self._Ddata, Rm, dim, Bd, BTd)
            lv = self.lam * V0
            md = m * inv_dt2
            t = np.empty(n)
            g = np.empty((dim, n))
            diag = np.empty((dim, n))
            # tr(R^T (D x - C)): the face clamp's constant part tr(R^T C) (0 without it)
            t0 = (np.einsum("nac,nac->n", Rm[:, :dim, :dim], self._Cm) if self._face
                  else np.zeros(n))
            _volume_system(ip, ix, tip, tix, Bd, BTd, x1, lv, md, pin, dim, t0, t, g, diag)
            scratch = np.empty(n)

            def matvec(y: np.ndarray, out: np.ndarray) -> None:
                _volume_matvec(ip, ix, tip, tix, Bd, BTd, lv, md, self._freew, dim, y, scratch,
                               out)

            # started from the last two corrections extrapolated, 2 dx(n-1) - dx(n-2)
            # (Beam.json: about half the iterations of a start from dx(n-1) alone)
            dx, stats = cg(matvec, g.ravel(), 2.0 * self._dx - self._dx_prev,
                           precond=JacobiPreconditioner(diag.ravel()), tol=self.max_error,
                           max_iter=self.max_iterations, name="kugelstadt2021 volume",
                           step=state.step)
            self.stats = stats
            self._dx_prev = self._dx
            self._dx = dx
            x1 += dx.reshape(dim, n)
        vnew = (x1 - x) / dt
        vnew[:, pinned] = 0.0
        f["a"][:, pos] = (vnew - v) / dt
