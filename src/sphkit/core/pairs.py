"""Inline pair helpers: the preamble of every pair loop, written once.

A pair loop visits, for particle i, the neighbours j of its CSR list and needs the difference
``x_ij = x_i - y_j`` (minimum image along the periodic axes), the distance ``r_ij``
and the kernel ``W(r_ij)`` or its gradient ``grad_i W_ij = W'(r_ij) / r_ij x_ij``. These scalar
helpers are compiled with ``inline="always"``: Numba splices them into the caller before type
inference, so a loop written with them compiles to the same machine code as the hand-written
preamble (coordinates of i hoisted into scalars, loop-invariant ``dim`` branches, no arrays
allocated). They take and return scalars only, so the same calls compile inside CUDA device
functions (DESIGN.md, "Compute backend").

The period ``L`` of the helpers is the scene's :attr:`sphkit.core.state.SimState.pair_period`:
a float, the period along x (0: none), or a tuple ``(L_x, L_y)`` when y is periodic too
(:func:`axis_period`; Numba compiles each kind once, and the float kind is the code of a scene
periodic along x at most, unchanged).

Vectors are passed as three scalars ``(c0, c1, c2)``; components beyond ``dim`` are 0, so
2D and 3D share one source (1D: only ``c0``).

Typical use::

    xi0, xi1, xi2 = point(x, i, dim)
    for k in pair_slots(off, i):
        j = idx[k]
        d0, d1, d2, r = separation(xi0, xi1, xi2, x, j, dim, L)
        g0, g1, g2 = grad_w(kid, d0, d1, d2, r, h, dim)

A loop that only needs the distance calls :func:`distance`; one that needs ``|x_ij|^2`` itself
takes :func:`delta` and :func:`dot` (``sqrt(r^2)^2`` would round differently). A loop that folds a
coefficient into the kernel derivative keeps ``c * kernel_dw(kid, r, h, dim)`` times the
difference (one product per component instead of two). Velocity differences ``v_i - v_j`` are
``delta(vi0, vi1, vi2, v, j, dim, 0.0)`` (no minimum image).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sphkit.backend import register_typed
from sphkit.core.kernels import kernel_dw

_INLINE = dict(inline="always", fastmath=True, cache=True)


@numba.njit(**_INLINE)
def min_image(d: float, L: float) -> float:
    """``d - L round(d / L)`` for a periodic axis of length ``L`` > 0; ``d`` when L <= 0."""
    if L > 0.0:
        return d - L * math.floor(d / L + 0.5)
    return d


def axis_period(L, a):  # noqa: ANN001, ANN201 - a float or a tuple; compiled by its type
    """The period along axis ``a`` (0 or 1) of the pair loops' period argument ``L``: a float
    is the period along x (none along y), a tuple ``(L_x, L_y)`` gives both (0: not periodic).

    Compiled code chooses the branch by ``L``'s type at compile time (:func:`_axis_period_typed`,
    :func:`sphkit.backend.register_typed`: numba-cuda does not prune an ``isinstance`` branch,
    so the float kind would type ``L[a]``); this Python body runs under the CUDA simulator."""
    if isinstance(L, tuple):
        return L[a]
    return L if a == 0 else 0.0


def _axis_period_typed(L, a):  # noqa: ANN001, ANN202 - Numba types in, an implementation out
    """The implementation of :func:`axis_period` for ``L``'s Numba type."""
    if isinstance(L, numba.types.BaseTuple):
        def by_tuple(L, a):  # noqa: ANN001, ANN202
            return L[a]
        return by_tuple

    def by_float(L, a):  # noqa: ANN001, ANN202
        if a == 0:
            return L
        return 0.0
    return by_float


register_typed(axis_period, _axis_period_typed)


def period_arg(L: float | tuple[float, ...]) -> float | tuple[float, ...]:
    """The period argument of a pair loop as the wrappers pass it (:func:`axis_period`): a float,
    or a tuple of floats."""
    return tuple(float(v) for v in L) if isinstance(L, tuple) else float(L)


def min_image_rows(d: np.ndarray, L: float | tuple[float, float]) -> np.ndarray:
    """:func:`min_image` of an array of differences ``d`` (dim, M) along the periodic axes of
    ``L`` (:func:`axis_period`), in place, for NumPy code outside the pair loops (start-up);
    ``d`` unchanged when L <= 0."""
    periods = L if isinstance(L, tuple) else (L,)
    for a, La in enumerate(periods):
        if La > 0.0:
            d[a] -= La * np.floor(d[a] / La + 0.5)
    return d


@numba.njit(**_INLINE)
def unsigned_range(start, stop):
    """``range(start, stop)`` counting in unsigned integers (``0 <= start``).

    Numba indexes an array with a signed integer through a negative-index fix-up (a compare and
    a select on every access) unless it can prove the index non-negative, which it cannot for
    a loop that starts at a value read from memory (a CSR offset, a cell's first slot). With an
    unsigned counter the fix-up is gone: a pass over the cached pair gradients ran 20 % faster,
    the neighbour search's scan 25 %. Arithmetic of the counter with a signed integer would give
    a float in Numba: index with it, compare it, do not add signed numbers to it."""
    return range(np.uint64(start), np.uint64(stop))


@numba.njit(**_INLINE)
def pair_slots(off, i):
    """The slots ``off[i] .. off[i + 1] - 1`` of row i of CSR lists, as an
    :func:`unsigned_range`: the loop of every pair pass, ``for k in pair_slots(off, i):
    j = idx[k]``."""
    return unsigned_range(off[i], off[i + 1])


@numba.njit(**_INLINE)
def point(x, i, dim):
    """The coordinates of column i of a (dim, N) array as three scalars (0 beyond dim)."""
    x0 = x[0, i]
    x1 = x[1, i] if dim > 1 else 0.0
    x2 = x[2, i] if dim > 2 else 0.0
    return x0, x1, x2


@numba.njit(**_INLINE)
def delta(xi0, xi1, xi2, y, j, dim, L):
    """``x_i - y_j`` (minimum image along the periodic axes of ``L``) as three scalars."""
    d0 = min_image(xi0 - y[0, j], axis_period(L, 0))
    d1 = min_image(xi1 - y[1, j], axis_period(L, 1)) if dim > 1 else 0.0
    d2 = xi2 - y[2, j] if dim > 2 else 0.0
    return d0, d1, d2


@numba.njit(**_INLINE)
def delta2(xi0, xi1, xi2, y, ui0, ui1, ui2, u, j, dim, L):
    """``(x_i - y_j, u_i - u_j)`` as six scalars: :func:`delta` of the positions and the
    difference of a vector field (velocities, no minimum image) to neighbour j, loaded under one
    dim branch per component for both (two calls of :func:`delta` branch twice as often, which
    made the standard viscosity's pair loop about 5 % slower)."""
    d0 = min_image(xi0 - y[0, j], axis_period(L, 0))
    w0 = ui0 - u[0, j]
    d1 = d2 = w1 = w2 = 0.0
    if dim > 1:
        d1 = min_image(xi1 - y[1, j], axis_period(L, 1))
        w1 = ui1 - u[1, j]
    if dim > 2:
        d2 = xi2 - y[2, j]
        w2 = ui2 - u[2, j]
    return d0, d1, d2, w0, w1, w2


@numba.njit(**_INLINE)
def delta2_r(xi0, xi1, xi2, y, ui0, ui1, ui2, u, j, dim, L):
    """:func:`delta2` and the distance ``|x_i - y_j|``: ``(d0, d1, d2, w0, w1, w2, r)``."""
    d0, d1, d2, w0, w1, w2 = delta2(xi0, xi1, xi2, y, ui0, ui1, ui2, u, j, dim, L)
    return d0, d1, d2, w0, w1, w2, math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@numba.njit(**_INLINE)
def norm(d0, d1, d2):
    """``|d|`` of a vector given as three scalars."""
    return math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@numba.njit(**_INLINE)
def dot(a0, a1, a2, b0, b1, b2):
    """``a . b`` of two vectors given as three scalars."""
    return a0 * b0 + a1 * b1 + a2 * b2


@numba.njit(**_INLINE)
def separation(xi0, xi1, xi2, y, j, dim, L):
    """``(d0, d1, d2, r)``: the difference ``x_i - y_j`` (:func:`delta`) and its length."""
    d0, d1, d2 = delta(xi0, xi1, xi2, y, j, dim, L)
    return d0, d1, d2, math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@numba.njit(**_INLINE)
def distance(xi0, xi1, xi2, y, j, dim, L):
    """``|x_i - y_j|`` (minimum image along the periodic axes of ``L``)."""
    d0, d1, d2 = delta(xi0, xi1, xi2, y, j, dim, L)
    return math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@numba.njit(**_INLINE)
def displaced_delta(xi0, xi1, xi2, y, dy, j, dim, L):
    """``x_i - (y_j + dy_j)``, evaluated as ``(x_i - y_j) - dy_j``, to a displaced neighbour
    (minimum image along the periodic axes of ``L``) as three scalars."""
    d0 = min_image(xi0 - y[0, j] - dy[0, j], axis_period(L, 0))
    d1 = min_image(xi1 - y[1, j] - dy[1, j], axis_period(L, 1)) if dim > 1 else 0.0
    d2 = xi2 - y[2, j] - dy[2, j] if dim > 2 else 0.0
    return d0, d1, d2


@numba.njit(**_INLINE)
def grad_w(kid, d0, d1, d2, r, h, dim):
    """``grad_i W_ij = W'(r) / r (x_i - x_j)`` as three scalars, for the difference ``d`` of
    length ``r`` (:func:`sphkit.core.kernels.kernel_dw`)."""
    f = kernel_dw(kid, r, h, dim)
    return f * d0, f * d1, f * d2


@numba.njit(**_INLINE)
def add_vector(a, i, dim, c0, c1, c2):
    """``a[:, i] += (c0, c1, c2)`` for the first ``dim`` components."""
    a[0, i] += c0
    if dim > 1:
        a[1, i] += c1
    if dim > 2:
        a[2, i] += c2


@numba.njit(**_INLINE)
def set_vector(a, i, dim, c0, c1, c2):
    """``a[:, i] = (c0, c1, c2)`` for the first ``dim`` components."""
    a[0, i] = c0
    if dim > 1:
        a[1, i] = c1
    if dim > 2:
        a[2, i] = c2
