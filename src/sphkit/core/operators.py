"""SPH discretizations of differential operators (survey Sec. 2; Koschier et al. 2019 tutorial).

Notation: ``x_ij = x_i - x_j``, ``A_ij = A_i - A_j``, ``grad W_ij = grad_i W(x_ij)``,
``V_j = m_j / rho_j``. Neighbour lists are CSR (see :mod:`sphkit.core.neighbors`) without self.

* interpolation  ``A_i = sum_j V_j A_j W_ij`` (self term included)
* density        ``rho_i = rho0_i sum_j V0_j W_ij`` (+ boundary ``rho0_i sum_b V_b W_ib``,
                 Akinci 2012; number density, Solenthaler & Pajarola 2008; one fluid:
                 ``sum_j m_j W_ij``)
* gradient       direct ``sum_j V_j A_j grad W_ij``;
                 difference ``sum_j V_j (A_j - A_i) grad W_ij`` (0th-order consistent), optionally
                 renormalized by ``L_i^-1``, ``L_i = sum_j V_j grad W_ij (x) x_ji``
                 (Bonet & Lok 1999),
                 which makes it exact for linear fields;
                 symmetric ``rho_i sum_j m_j (A_i/rho_i^2 + A_j/rho_j^2) grad W_ij``
                 (conserves momentum)
* divergence     ``-(1/rho_i) sum_j m_j A_ij . grad W_ij``
* curl           ``(1/rho_i) sum_j m_j A_ij x grad W_ij`` (with A_ij = A_i - A_j this sign
                 pairs with the divergence above; survey notation uses A_ji)
* Laplacian      Brookshaw 1985 / Morris 1997:
                 ``2 sum_j V_j A_ij (x_ij . grad W_ij) / (|x_ij|^2 + 0.01 h^2)``

The per-particle *body* functions (``density_body``, ``pressure_accel_body``) hold the physics of
one particle; :func:`sphkit.backend.launch` runs them as a CPU ``prange`` loop
(:func:`density_cpu`, :func:`pressure_accel_cpu`) or as CUDA kernels (``device="cuda"``), as
DESIGN.md prescribes. The other passes here are ``prange`` loops written with the same inline
pair helpers (:mod:`sphkit.core.pairs`).
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from sphkit.backend import launch
from sphkit.core import arrays
from sphkit.core.kernels import kernel_dw, kernel_w
from sphkit.core.neighbors import NeighborList
from sphkit.core.pairs import (
    add_vector,
    delta,
    distance,
    pair_slots,
    period_arg,
    point,
    separation,
    set_vector,
)

_JIT = dict(cache=True, fastmath=True)


# ---------------------------------------------------------------------------------------------
# per-particle bodies (CPU + CUDA, :mod:`sphkit.backend.launch`)


@numba.njit(**_JIT, inline="always")
def density_body(i, x, mu, off, idx, bx, bV, boff, bidx, rho0, h, kid, dim, rho, L, c):
    """``rho[i]`` = density of fluid particle i by number density (Solenthaler & Pajarola
    2008): ``rho_i = c_i (mu_i W_0 + sum_j mu_j W_ij + sum_b rho0 V_b W_ib)`` =
    ``rho0_i (V0_i W_0 + sum_j V0_j W_ij + sum_b V_b W_ib)`` with ``mu = m / c`` and ``c_i =
    rho0_i / rho0`` (:class:`sphkit.core.state.RestArrays`; ``rho0`` the reference rest
    density). For one fluid (c = 1) this is ``sum_j m_j W_ij + sum_b rho0 V_b W_ib``.

    ``L`` > 0: periodic along x with period L [m] (minimum-image distances)."""
    # the coordinates of i are hoisted into scalars and the dim branches are loop invariant
    # (twice as fast as d-loops); the scalar pair helpers also compile for CUDA
    xi0, xi1, xi2 = point(x, i, dim)
    s = mu[i] * kernel_w(kid, 0.0, h, dim)
    for k in pair_slots(off, i):
        j = idx[k]
        s += mu[j] * kernel_w(kid, distance(xi0, xi1, xi2, x, j, dim, L), h, dim)
    for k in pair_slots(boff, i):
        b = bidx[k]
        s += rho0 * bV[b] * kernel_w(kid, distance(xi0, xi1, xi2, bx, b, dim, L), h, dim)
    rho[i] = c[i] * s


@numba.njit(**_JIT, inline="always")
def pressure_accel_body(i, x, m, rho, p, off, idx, bx, bV, boff, bidx, rho0, h, kid, dim, a,
                        L, c, inv_c):
    """Add the symmetric pressure acceleration of fluid particle i to ``a[:, i]``.

    ``a_i = -sum_j m_j (rho0_i/rho0_j p_i/rho_i^2 + rho0_j/rho0_i p_j/rho_j^2) grad W_ij
            - sum_b rho0_i V_b (p_i/rho_i^2 + p_i/rho0_i^2) grad W_ib``
    (Solenthaler & Pajarola 2008's number-density force of several fluids, ``-rho0_i sum_j V_j
    (p_i/rho_i^2 + p_j/rho~_j^2)`` with the neighbour's density taken to i's rest density,
    ``rho~_j = rho_j rho0_i / rho0_j``, as SPlisHSPlasH's WCSPH, written with masses: near rest
    ``-sum_j V_j (p_i + p_j) / rho0_i grad W_ij``, the pair's forces equal and opposite; with
    ``p_j / rho_j^2`` alone, the neighbour's pressure over its own rest density, a heavy
    particle took a light neighbour's pressure 4 times (1:4) and the heavy layer under a light
    one carried 4 times its weight, validation/README.md, "A body between two layers";
    ``rho0`` the reference rest density, ``rho0_i = c_i rho0``, ``rho0_i/rho0_j = c_i
    inv_c_j``, :class:`sphkit.core.state.RestArrays`; boundary pressure mirrored, p_b = p_i,
    rho_b = rho0_i; Akinci et al. 2012). ``L`` > 0: periodic along x with period L [m].
    """
    xi0, xi1, xi2 = point(x, i, dim)
    dpi = p[i] / (rho[i] * rho[i])
    ci = c[i]
    ici = inv_c[i]
    dpc = dpi * ci
    a0 = a1 = a2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
        s = -m[j] * (dpc * inv_c[j] + p[j] / (rho[j] * rho[j]) * (c[j] * ici)) * kernel_dw(
            kid, r, h, dim)
        a0 += s * d0
        a1 += s * d1
        a2 += s * d2
    dpb = dpi + p[i] / (rho0 * rho0) * (ici * ici)
    r0 = rho0 * ci
    for k in pair_slots(boff, i):
        b = bidx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, bx, b, dim, L)
        s = -r0 * bV[b] * dpb * kernel_dw(kid, r, h, dim)
        a0 += s * d0
        a1 += s * d1
        a2 += s * d2
    add_vector(a, i, dim, a0, a1, a2)


# ---------------------------------------------------------------------------------------------
# the bodies on the CPU


def _per_particle(value: np.ndarray | None, n: int, fill: float, dtype: np.dtype) -> np.ndarray:
    """``value``, or (n,) times ``fill`` when it is None."""
    return np.full(n, fill, dtype=dtype) if value is None else value


def density_cpu(x: np.ndarray, m: np.ndarray, off: np.ndarray, idx: np.ndarray, bx: np.ndarray,
                bV: np.ndarray, boff: np.ndarray, bidx: np.ndarray, rho0: float, h: float,
                kid: int, dim: int, rho: np.ndarray, L: float = 0.0,
                c: np.ndarray | None = None) -> None:
    """``rho[i]`` = :func:`density_body` for all fluid particles, a ``prange`` loop
    (:func:`sphkit.backend.launch`); ``rho0``: the reference rest density; ``L``: period
    along x [m], 0 = none. Several fluids: ``m`` is ``mu = m / c`` and ``c = rho0_i / rho0``
    of :class:`sphkit.core.state.RestArrays` (None: one fluid, c = 1)."""
    c = _per_particle(c, x.shape[1], 1.0, rho.dtype)
    launch(density_body, x.shape[1], x, m, off, idx, bx, bV, boff, bidx, float(rho0),
           float(h), int(kid), int(dim), rho, period_arg(L), c)


def pressure_accel_cpu(x: np.ndarray, m: np.ndarray, rho: np.ndarray, p: np.ndarray,
                       off: np.ndarray, idx: np.ndarray, bx: np.ndarray, bV: np.ndarray,
                       boff: np.ndarray, bidx: np.ndarray, rho0: float, h: float, kid: int,
                       dim: int, a: np.ndarray, L: float = 0.0, c: np.ndarray | None = None,
                       inv_c: np.ndarray | None = None) -> None:
    """``a[:, i] +=`` :func:`pressure_accel_body` for all fluid particles, a ``prange`` loop
    (:func:`sphkit.backend.launch`); ``rho0``: the reference rest density; ``c``, ``inv_c``:
    the per-particle ratios to it of :class:`sphkit.core.state.RestArrays` (None: one fluid,
    1); ``L``: period along x [m], 0 = none."""
    n = x.shape[1]
    c = _per_particle(c, n, 1.0, rho.dtype)
    inv_c = _per_particle(inv_c, n, 1.0, rho.dtype)
    launch(pressure_accel_body, n, x, m, rho, p, off, idx, bx, bV, boff, bidx, float(rho0),
           float(h), int(kid), int(dim), a, period_arg(L), c, inv_c)


@numba.njit(inline="always", **_JIT)
def replace_mirrored_body(i, x, p, rho0, inv_c, bx, bV, boff, bidx, use, kb, phase, h, kid, dim,
                          L, a):
    """Particle i of :func:`replace_mirrored`."""
    xi0, xi1, xi2 = point(x, i, dim)
    ki = p[i] / rho0[i]
    ici = inv_c[i]
    ph = phase[i] if phase.shape[0] > 0 else 0
    a0 = a1 = a2 = 0.0
    for k in pair_slots(boff, i):
        b = bidx[k]
        if not use[b]:
            continue
        d0, d1, d2, r = separation(xi0, xi1, xi2, bx, b, dim, L)
        s = -bV[b] * (kb[ph, b] * ici - ki) * kernel_dw(kid, r, h, dim)
        a0 += s * d0
        a1 += s * d1
        a2 += s * d2
    add_vector(a, i, dim, a0, a1, a2)


def replace_mirrored(x: Any, p: Any, rho0: Any, inv_c: Any, bx: Any, bV: Any, boff: Any,
                     bidx: Any, use: Any, kb: Any, phase: Any, h: float, kid: int, dim: int,
                     L: Any, a: Any) -> None:
    """WCSPH: swap the mirrored boundary pressure ``p_b = p_i`` of :func:`pressure_accel_body`'s
    boundary term ``-sum_b rho0_i V_b (p_i / rho_i^2 + p_b / rho0_i^2) grad W_ib`` for another,
    ``a_i -= sum_b V_b (k_b / c_i - p_i / rho0_i) grad W_ib`` over the samples with ``use[b]``
    (``k_b = p_b / rho0_ref``: the MLS-extrapolated one of :mod:`sphkit.boundary.band2018`, or
    0, which leaves the symmetric term ``V_b k_i`` alone; ``rho0`` (N,) each particle's rest
    density, ``inv_c`` = ``rho0_ref / rho0_i``, :class:`sphkit.core.state.RestArrays`). ``kb``
    holds a row per phase (``kb[phase[i], b]``: the phases fitted on their own; one row and
    an empty ``phase`` otherwise)."""
    launch(replace_mirrored_body, x.shape[1], x, p, rho0, inv_c, bx, bV, boff, bidx, use, kb,
           phase, h, kid, int(dim), L, a)


# ---------------------------------------------------------------------------------------------
# general operators on one particle set (analysis, tests and non-pressure methods)


@numba.njit(parallel=True, **_JIT)
def _interpolate(x, V, A, off, idx, h, kid, dim, out, L=0.0):
    """``out[c, i] = sum_j V_j A[c, j] W_ij`` for every row c of A (one kernel value per
    pair for all rows)."""
    nc = A.shape[0]
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        w = V[i] * kernel_w(kid, 0.0, h, dim)
        for c in range(nc):
            out[c, i] = w * A[c, i]
        for k in pair_slots(off, i):
            j = idx[k]
            w = V[j] * kernel_w(kid, distance(xi0, xi1, xi2, x, j, dim, L), h, dim)
            for c in range(nc):
                out[c, i] += w * A[c, j]


@numba.njit(parallel=True, **_JIT)
def _gradient(x, V, m, rho, A, off, idx, h, kid, dim, mode, renorm, out):
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        g = np.zeros(3)
        L = np.zeros((3, 3))
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, 0.0)
            dd = (d0, d1, d2)
            f = kernel_dw(kid, r, h, dim)
            if mode == 0:
                s = V[j] * A[j] * f
            elif mode == 1:
                s = V[j] * (A[j] - A[i]) * f
            else:
                s = rho[i] * m[j] * (A[i] / (rho[i] * rho[i]) + A[j] / (rho[j] * rho[j])) * f
            for d in range(dim):
                g[d] += s * dd[d]
            if renorm:
                for d in range(dim):
                    for e in range(dim):
                        L[d, e] += V[j] * f * dd[d] * -dd[e]
        if renorm:
            Li = np.linalg.inv(L[:dim, :dim])
            for d in range(dim):
                s = 0.0
                for e in range(dim):
                    s += Li[e, d] * g[e]
                out[d, i] = s
        else:
            for d in range(dim):
                out[d, i] = g[d]


@numba.njit(parallel=True, **_JIT)
def _divergence(x, m, rho, A, off, idx, h, kid, dim, out):
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        s = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, 0.0)
            dd = (d0, d1, d2)
            f = kernel_dw(kid, r, h, dim)
            for d in range(dim):
                s += m[j] * (A[d, i] - A[d, j]) * f * dd[d]
        out[i] = -s / rho[i]


@numba.njit(inline="always", **_JIT)
def curl_sum(i, x, m, A, off, idx, h, kid, dim, L):
    """``sum_j m_j A_ij x grad W_ij`` of particle i (``A_ij = A_i - A_j``, fluid neighbours) as
    three scalars: the SPH curl times ``rho_i``. In 2D (dim 2, A in the plane) only the z
    component is set, the others are 0. ``L`` > 0: periodic along x with period L [m].

    Shared by :func:`curl` and the vorticity of :mod:`sphkit.vorticity.confinement`."""
    xi0, xi1, xi2 = point(x, i, dim)
    ai0, ai1, ai2 = point(A, i, dim)
    c0 = c1 = c2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
        f = m[j] * kernel_dw(kid, r, h, dim)
        g0 = f * d0
        g1 = f * d1
        u0, u1, u2 = delta(ai0, ai1, ai2, A, j, dim, 0.0)
        if dim == 3:
            g2 = f * d2
            c0 += u1 * g2 - u2 * g1
            c1 += u2 * g0 - u0 * g2
        c2 += u0 * g1 - u1 * g0
    return c0, c1, c2


@numba.njit(parallel=True, **_JIT)
def _curl(x, m, rho, A, off, idx, h, kid, out):
    for i in numba.prange(x.shape[1]):
        c0, c1, c2 = curl_sum(i, x, m, A, off, idx, h, kid, 3, 0.0)
        out[0, i] = c0 / rho[i]
        out[1, i] = c1 / rho[i]
        out[2, i] = c2 / rho[i]


@numba.njit(parallel=True, **_JIT)
def _laplacian(x, V, A, off, idx, h, kid, dim, out):
    eps = 0.01 * h * h
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        s = 0.0
        for k in pair_slots(off, i):
            j = idx[k]
            r = distance(xi0, xi1, xi2, x, j, dim, 0.0)
            f = kernel_dw(kid, r, h, dim)
            # x_ij . grad W_ij = f r^2
            s += V[j] * (A[i] - A[j]) * f * r * r / (r * r + eps)
        out[i] = 2.0 * s


def interpolate(x: np.ndarray, V: np.ndarray, A: np.ndarray, nl: NeighborList, h: float,
                kid: int, period: float = 0.0) -> np.ndarray:
    """SPH interpolation ``sum_j V_j A_j W_ij`` (self included) of a scalar field A (N,), or of
    each row of A (k, N) in one pass over the pairs; ``period`` > 0: periodic along x with that
    period [m] (minimum-image distances)."""
    A2 = np.ascontiguousarray(A, dtype=np.float64).reshape(-1, x.shape[1])
    out = np.empty_like(A2)
    _interpolate(x, V, A2, nl.offsets, nl.indices, h, kid, x.shape[0], out, period)
    return out.reshape(np.shape(A))


def gradient(x: np.ndarray, m: np.ndarray, rho: np.ndarray, A: np.ndarray, nl: NeighborList,
             h: float, kid: int, form: str = "difference", renormalize: bool = False) -> np.ndarray:
    """Gradient (dim, N) of scalar field A: ``form`` is 'direct', 'difference' or 'symmetric'.

    ``renormalize`` multiplies by ``L_i^-1`` (Bonet & Lok 1999; 'direct'/'difference' only).
    """
    modes = {"direct": 0, "difference": 1, "symmetric": 2}
    if form not in modes:
        raise ValueError(f"form: {form!r}; expected one of {sorted(modes)}")
    if renormalize and form == "symmetric":
        raise ValueError("renormalize: the symmetric gradient cannot be renormalized")
    out = np.empty_like(x)
    V = m / rho
    _gradient(x, V, m, rho, A, nl.offsets, nl.indices, h, kid, x.shape[0], modes[form],
              renormalize, out)
    return out


def divergence(x: np.ndarray, m: np.ndarray, rho: np.ndarray, A: np.ndarray, nl: NeighborList,
               h: float, kid: int) -> np.ndarray:
    """Divergence of the vector field A (dim, N): ``-(1/rho_i) sum_j m_j A_ij . grad W_ij``."""
    out = np.empty(x.shape[1])
    _divergence(x, m, rho, A, nl.offsets, nl.indices, h, kid, x.shape[0], out)
    return out


def curl(x: np.ndarray, m: np.ndarray, rho: np.ndarray, A: np.ndarray, nl: NeighborList,
         h: float, kid: int) -> np.ndarray:
    """Curl of a 3D vector field A (3, N): ``(1/rho_i) sum_j m_j A_ij x grad W_ij``."""
    if x.shape[0] != 3:
        raise ValueError(f"curl: needs 3D positions, got dim {x.shape[0]}")
    out = np.empty_like(x)
    # one compiled layout for every caller's field (a transposed view would compile again)
    _curl(x, m, rho, np.ascontiguousarray(A), nl.offsets, nl.indices, h, kid, out)
    return out


def laplacian(x: np.ndarray, V: np.ndarray, A: np.ndarray, nl: NeighborList, h: float,
              kid: int) -> np.ndarray:
    """Brookshaw/Morris Laplacian of a scalar field."""
    out = np.empty(x.shape[1])
    _laplacian(x, V, A, nl.offsets, nl.indices, h, kid, x.shape[0], out)
    return out


# ---------------------------------------------------------------------------------------------
# surface quantities (surface tension, drag): colour field and unnormalized surface normals


@numba.njit(parallel=True, **_JIT)
def color_field_cpu(x, m, rho, off, idx, bx, bV, boff, bidx, h, kid, dim, c, L=0.0):
    """Colour field ``c_i = sum_j (m_j/rho_j) W_ij`` (self included) ``+ sum_b V_b W_ib``.

    ``c = 1`` inside the fluid (next to walls too, as the boundary counts) and falls to about
    1/2 at a free surface (He et al. 2014, Eq. 4, as SPlisHSPlasH evaluates it). ``L`` > 0:
    periodic along x with period L [m] (minimum-image distances).
    """
    for i in numba.prange(x.shape[1]):
        xi0, xi1, xi2 = point(x, i, dim)
        s = m[i] / rho[i] * kernel_w(kid, 0.0, h, dim)
        for k in pair_slots(off, i):
            j = idx[k]
            s += m[j] / rho[j] * kernel_w(kid, distance(xi0, xi1, xi2, x, j, dim, L), h, dim)
        for k in pair_slots(boff, i):
            b = bidx[k]
            s += bV[b] * kernel_w(kid, distance(xi0, xi1, xi2, bx, b, dim, L), h, dim)
        c[i] = s


@numba.njit(inline="always", **_JIT)
def color_gradient_sum(i, x, m, rho, c, off, idx, h, kid, dim, L):
    """``sum_j (m_j/rho_j) c_j grad W_ij`` of particle i over its fluid neighbours, as three
    scalars; an empty ``c`` means ``c_j = 1``, the gradient of the colour field (the
    unnormalized surface normal of :func:`surface_normals`). He et al. 2014 weight it with
    the colour itself (:mod:`sphkit.surface_tension.he2014`). ``L`` > 0: periodic along x with
    period L [m]."""
    weighted = c.shape[0] > 0
    xi0, xi1, xi2 = point(x, i, dim)
    n0 = n1 = n2 = 0.0
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
        s = m[j] / rho[j]
        if weighted:
            s *= c[j]
        s *= kernel_dw(kid, r, h, dim)
        n0 += s * d0
        n1 += s * d1
        n2 += s * d2
    return n0, n1, n2


@numba.njit(inline="always", **_JIT)
def surface_normals_body(i, x, m, rho, c, off, idx, scale, h, kid, dim, n, L):
    """``n[:, i] = scale * sum_j (m_j/rho_j) c_j grad W_ij`` (a kernel body,
    :func:`sphkit.backend.launch`; ``c`` empty: the colour gradient, :func:`surface_normals`)."""
    n0, n1, n2 = color_gradient_sum(i, x, m, rho, c, off, idx, h, kid, dim, L)
    set_vector(n, i, dim, scale * n0, scale * n1, scale * n2)


def surface_normals(x, m, rho, off, idx, scale: float, h: float, kid: int, dim: int, n,
                    L: float = 0.0) -> None:
    """Unnormalized surface normals ``n_i = scale * sum_j (m_j/rho_j) grad W_ij`` (fluid only),
    on the device the arrays are on.

    This is the gradient of the colour field: it vanishes in a full neighbourhood and at a free
    surface it points *into* the fluid with length about ``scale / h`` times a kernel-dependent
    constant. Akinci et al. 2013 use ``scale = h`` so that ``n`` is dimensionless. ``L`` > 0:
    periodic along x with period L [m].
    """
    ones = arrays.empty(0, rho.dtype, like=rho)  # no weights: c_j = 1
    launch(surface_normals_body, x.shape[1], x, m, rho, ones, off, idx, scale, h, kid, dim, n, L)


def kirkwood_buff(force, n: float, h: float, breaks: list[float], dim: int
                  ) -> tuple[float, float]:
    """``(sigma, p_int)`` of a uniform continuum of number density ``n`` [1/m^dim] with a sharp
    planar surface whose particles attract with the pair force magnitude ``force(s)`` [N] at
    distance s < h (Kirkwood-Buff): in 3D ``sigma = pi n^2 / 8 int f s^4 ds`` and ``p_int =
    2 pi n^2 / 3 int f s^3 ds``, in 2D ``sigma = n^2 / 3 int f s^3 ds`` and ``p_int = pi n^2 / 2
    int f s^2 ds``. ``breaks``: where ``force`` has kinks (quadrature points). Used by the
    pairwise cohesion models to name the surface tension their coefficient gives."""
    from scipy.integrate import quad

    def moment(k: int) -> float:
        return quad(lambda s: force(s) * s**k, 0, h, points=breaks)[0]

    if dim == 3:
        return math.pi * n * n / 8.0 * moment(4), 2.0 * math.pi * n * n / 3.0 * moment(3)
    return n * n / 3.0 * moment(3), math.pi * n * n / 2.0 * moment(2)
