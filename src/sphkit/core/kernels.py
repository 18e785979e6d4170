"""SPH smoothing kernels: value and gradient, normalized in 1D, 2D and 3D.

All kernels are written for the *support radius* ``h`` (the kernel vanishes for ``r >= h``),
as in the survey (Koschier et al. 2022, Sec. 2.1) and SPlisHSPlasH's ``SPHKernels.h``.
With ``q = r / h``:

* ``CUBIC`` -- cubic spline, Monaghan 1992, "Smoothed particle hydrodynamics", ARA&A 30:
  ``W = s_d * (6 (q^3 - q^2) + 1)`` for ``q <= 1/2``,
  ``W = s_d * 2 (1 - q)^3`` for ``1/2 < q <= 1``,
  ``s_1 = 4/(3h)``, ``s_2 = 40/(7 pi h^2)``, ``s_3 = 8/(pi h^3)``.
* ``WENDLAND`` -- Wendland quintic C2 (Wendland 1995): ``W = s_d (1 - q)^4 (4q + 1)``,
  ``s_1 = 3/(2h)``, ``s_2 = 7/(pi h^2)``, ``s_3 = 21/(2 pi h^3)``.
* ``POLY6`` -- Mueller et al. 2003, "Particle-based fluid simulation for interactive applications":
  ``W = s_d (h^2 - r^2)^3``, ``s_1 = 35/(32 h^7)``, ``s_2 = 4/(pi h^8)``, ``s_3 = 315/(64 pi h^9)``.
* ``SPIKY`` -- Mueller et al. 2003: ``W = s_d (h - r)^3``, ``s_1 = 2/h^4``, ``s_2 = 10/(pi h^5)``,
  ``s_3 = 15/(pi h^6)``.
* ``QUINTIC`` -- the quintic spline (Schoenberg's M6) that Morris, Fox & Zhu 1997 (J. Comput.
  Phys. 136, 214-226) use, support ``h = 3 s`` for smoothing length s, ``u = 3q``:
  ``W = s_d [(3 - u)^5 - 6 (2 - u)^5 + 15 (1 - u)^5]`` with each term only where its bracket is
  positive, ``s_1 = 1/(120 s)``, ``s_2 = 7/(478 pi s^2)``, ``s_3 = 1/(120 pi s^3)`` (the
  3/(359 pi s^3) found in the literature integrates to 1.0028). It is
  smoother than the cubic spline (lattice sums converge faster) but wide: at sphkit's h = 4r it
  spans only 2 particle spacings, so use it with a larger support (Morris: 3 spacings).

The compiled scalar functions are the physics building blocks used by every per-particle loop
(CPU and CUDA, see DESIGN.md): :func:`kernel_w` gives ``W(r)`` and :func:`kernel_dw` gives
``W'(r) / r``, so that ``grad_i W_ij = kernel_dw(r_ij) * (x_i - x_j)``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

CUBIC = 0
WENDLAND = 1
POLY6 = 2
SPIKY = 3
QUINTIC = 4

KERNEL_IDS: dict[str, int] = {
    "cubic": CUBIC,
    "wendland": WENDLAND,
    "poly6": POLY6,
    "spiky": SPIKY,
    "quintic": QUINTIC,
}

_PI = math.pi


@numba.njit(cache=True, fastmath=True, inline="always")
def _cubic_sigma(h: float, dim: int) -> float:
    if dim == 3:
        return 8.0 / (_PI * h * h * h)
    if dim == 2:
        return 40.0 / (7.0 * _PI * h * h)
    return 4.0 / (3.0 * h)


@numba.njit(cache=True, fastmath=True)
def kernel_sigma(kid: int, h: float, dim: int) -> float:
    """Normalization constant s_d of kernel ``kid`` in ``dim`` dimensions."""
    if kid == CUBIC:
        return _cubic_sigma(h, dim)
    if kid == WENDLAND:
        if dim == 3:
            return 21.0 / (2.0 * _PI * h * h * h)
        if dim == 2:
            return 7.0 / (_PI * h * h)
        return 3.0 / (2.0 * h)
    if kid == POLY6:
        h2 = h * h
        h4 = h2 * h2
        if dim == 3:
            return 315.0 / (64.0 * _PI * h4 * h4 * h)
        if dim == 2:
            return 4.0 / (_PI * h4 * h4)
        return 35.0 / (32.0 * h4 * h2 * h)
    if kid == QUINTIC:  # smoothing length s = h / 3
        if dim == 3:
            return 9.0 / (40.0 * _PI * h * h * h)
        if dim == 2:
            return 63.0 / (478.0 * _PI * h * h)
        return 1.0 / (40.0 * h)
    # SPIKY
    h2 = h * h
    if dim == 3:
        return 15.0 / (_PI * h2 * h2 * h2)
    if dim == 2:
        return 10.0 / (_PI * h2 * h2 * h)
    return 2.0 / (h2 * h2)


@numba.njit(cache=True, fastmath=True, inline="always")
def _cubic_w(r: float, h: float, dim: int) -> float:
    q = r * (1.0 / h)
    t = 1.0 - q if r < h else 0.0  # exactly 0 from r = h on, whatever r * (1/h) rounds to
    near = 6.0 * (q * q * q - q * q) + 1.0
    far = 2.0 * t * t * t
    return _cubic_sigma(h, dim) * (near if q <= 0.5 else far)


@numba.njit(cache=True, fastmath=True, inline="always")
def _cubic_dw(r: float, h: float, dim: int) -> float:
    inv_h = 1.0 / h
    q = r * inv_h
    t = 1.0 - q if r < h else 0.0
    near = (18.0 * q - 12.0) * inv_h * inv_h
    far = -6.0 * t * t * inv_h / max(r, 1e-9 * h)
    return _cubic_sigma(h, dim) * (near if q <= 0.5 else far)


@numba.njit(cache=True, fastmath=True, inline="always")
def _cubic_dr(r: float, h: float, dim: int) -> float:
    inv_h = 1.0 / h
    q = r * inv_h
    t = 1.0 - q if r < h else 0.0
    near = (18.0 * q - 12.0) * inv_h * inv_h * r
    far = -6.0 * t * t * inv_h
    return _cubic_sigma(h, dim) * (near if q <= 0.5 else far)


@numba.njit(cache=True, fastmath=True)
def _other_w(kid: int, r: float, h: float, dim: int) -> float:
    """W(r) of the kernels other than the cubic spline (a call, not inlined)."""
    s = kernel_sigma(kid, h, dim)
    q = r * (1.0 / h)
    t = 1.0 - q if r < h else 0.0
    if kid == WENDLAND:
        t2 = t * t
        return s * t2 * t2 * (4.0 * q + 1.0)
    if kid == POLY6:
        d = h * h - r * r if r < h else 0.0
        return s * d * d * d
    if kid == QUINTIC:
        t3 = 3.0 * t
        t2 = max(t3 - 1.0, 0.0)
        t1 = max(t3 - 2.0, 0.0)
        a3 = t3 * t3
        a2 = t2 * t2
        a1 = t1 * t1
        return s * (a3 * a3 * t3 - 6.0 * a2 * a2 * t2 + 15.0 * a1 * a1 * t1)
    d = t * h
    return s * d * d * d


@numba.njit(cache=True, fastmath=True)
def _other_dw(kid: int, r: float, h: float, dim: int) -> float:
    """W'(r) / r of the kernels other than the cubic spline (a call, not inlined)."""
    s = kernel_sigma(kid, h, dim)
    inv_h = 1.0 / h
    q = r * inv_h
    t = 1.0 - q if r < h else 0.0
    if kid == WENDLAND:
        return -20.0 * s * t * t * t * inv_h * inv_h
    if kid == POLY6:
        d = h * h - r * r if r < h else 0.0
        return -6.0 * s * d * d
    if kid == QUINTIC:  # the bracket vanishes like r at r = 0, so the factor stays finite
        t3 = 3.0 * t
        t2 = max(t3 - 1.0, 0.0)
        t1 = max(t3 - 2.0, 0.0)
        a3 = t3 * t3
        a2 = t2 * t2
        a1 = t1 * t1
        return (-15.0 * s * inv_h * (a3 * a3 - 6.0 * a2 * a2 + 15.0 * a1 * a1)
                / max(r, 1e-9 * h))
    d = t * h
    v = -3.0 * s * d * d / max(r, 1e-9 * h)
    return v if r >= 1e-9 * h else 0.0


@numba.njit(cache=True, fastmath=True, inline="always")
def kernel_w(kid: int, r: float, h: float, dim: int) -> float:
    """Kernel value W(r) for support radius h (zero for r >= h).

    Written without data-dependent branches (the cubic spline's two pieces are both evaluated
    and one is selected; ``1 - q`` is clamped at 0 beyond the support). The cubic spline (the
    default of sphkit and SPlisHSPlasH) is inlined into every pair loop, so that its constants
    are hoisted and no branch mispredicts (several times faster than the branching form); the
    other kernels are one call away (:func:`_other_w`): inlining all five at every call site
    made Numba's compilation of a pair loop with four kernel calls take 30 s instead of 8 s.
    """
    if kid == CUBIC:
        return _cubic_w(r, h, dim)
    return _other_w(kid, r, h, dim)


@numba.njit(cache=True, fastmath=True, inline="always")
def kernel_dw(kid: int, r: float, h: float, dim: int) -> float:
    """``W'(r) / r``: multiply by ``x_i - x_j`` to get ``grad_i W_ij``. Zero for r >= h.

    At ``r -> 0`` the factor stays finite for cubic, Wendland and poly6 (the gradient itself is 0
    there because the distance vector is 0); spiky's factor is singular, so it is set to 0 for
    ``r < 1e-9 h``. Branch-free, the cubic spline inlined, like :func:`kernel_w`.
    """
    if kid == CUBIC:
        return _cubic_dw(r, h, dim)
    return _other_dw(kid, r, h, dim)


@numba.njit(cache=True, fastmath=True, inline="always")
def kernel_dr(kid: int, r: float, h: float, dim: int) -> float:
    """``W'(r)``, the radial derivative (zero for r >= h): :func:`kernel_dw` times
    ``max(r, 1e-9 h)``, for a pair term that divides by the distance together with other
    factors (one division instead of two: :func:`sphkit.core.viscous.laplacian_pair`). The
    cubic spline inlined without a division; the other kernels through :func:`kernel_dw`."""
    if kid == CUBIC:
        return _cubic_dr(r, h, dim)
    return _other_dw(kid, r, h, dim) * max(r, 1e-9 * h)


@numba.njit(cache=True, parallel=True, fastmath=True)
def _w_array(kid, r, h, dim, out):
    for i in numba.prange(r.shape[0]):
        out[i] = kernel_w(kid, r[i], h, dim)


@numba.njit(cache=True, parallel=True, fastmath=True)
def _dw_array(kid, r, h, dim, out):
    for i in numba.prange(r.shape[0]):
        out[i] = kernel_dw(kid, r[i], h, dim)


def kernel_id(name: str | int) -> int:
    """Map a kernel name ('cubic', 'wendland', 'poly6', 'spiky', 'quintic') or id to its id."""
    if isinstance(name, (int, np.integer)):
        if int(name) in KERNEL_IDS.values():
            return int(name)
        raise ValueError(f"kernel: {name!r} is not a kernel id; expected one of 0, 1, 2, 3, 4")
    try:
        return KERNEL_IDS[str(name).lower()]
    except KeyError:
        raise ValueError(
            f"kernel: {name!r} is not a known kernel; expected one of {sorted(KERNEL_IDS)}"
        ) from None


class Kernel:
    """A kernel bound to a support radius and dimension, evaluated on NumPy arrays.

    Example: ``Kernel("cubic", h=0.1, dim=3).w(np.array([0.0, 0.05]))``.
    """

    def __init__(self, name: str | int, h: float, dim: int) -> None:
        if dim not in (1, 2, 3):
            raise ValueError(f"dim: {dim!r} is not a dimension; expected 1, 2 or 3")
        if not h > 0:
            raise ValueError(f"h: {h!r} is not a support radius; expected a positive number")
        self.kid = kernel_id(name)
        self.h = float(h)
        self.dim = int(dim)

    def w(self, r: np.ndarray) -> np.ndarray:
        """W at distances ``r`` (any shape)."""
        r = np.asarray(r, dtype=np.float64)
        out = np.empty(r.size)
        _w_array(self.kid, np.ascontiguousarray(r.ravel()), self.h, self.dim, out)
        return out.reshape(r.shape)

    def dw_over_r(self, r: np.ndarray) -> np.ndarray:
        """W'(r)/r at distances ``r`` (any shape)."""
        r = np.asarray(r, dtype=np.float64)
        out = np.empty(r.size)
        _dw_array(self.kid, np.ascontiguousarray(r.ravel()), self.h, self.dim, out)
        return out.reshape(r.shape)

    def grad(self, xij: np.ndarray) -> np.ndarray:
        """grad W for difference vectors ``xij`` of shape (..., dim)."""
        xij = np.asarray(xij, dtype=np.float64)
        r = np.linalg.norm(xij, axis=-1)
        return self.dw_over_r(r)[..., None] * xij


def lattice_volume(spacing: float, name: str | int, h: float, dim: int) -> float:
    """Particle volume that reproduces the rest density on a regular lattice.

    On an infinite cubic lattice of the given spacing, ``rho_i = sum_j m W_ij`` equals ``rho0``
    exactly when ``m = rho0 * V`` with ``V = 1 / sum_k W(|k| * spacing)`` (the sum over all
    lattice points k, self included). This differs from ``spacing^dim`` by the kernel's
    discretization error (a few percent for the cubic spline at h = 2 * spacing) and is what
    sphkit uses for the mass of lattice-sampled fluid (instead of SPlisHSPlasH's fixed factor 0.8).
    """
    return _volume_on(cubic_lattice_points(spacing, h, dim), name, h, dim)


def _volume_on(points: np.ndarray, name: str | int, h: float, dim: int) -> float:
    """``1 / sum_k W(|x_k|)`` over lattice points (N, dim) around the origin, self included."""
    return float(1.0 / Kernel(name, h, dim).w(np.linalg.norm(points, axis=1)).sum())


def cubic_lattice_points(spacing: float, h: float, dim: int) -> np.ndarray:
    """Points (N, dim) of the cubic lattice of the given spacing around the origin (included),
    covering the ball of radius h."""
    n = int(np.ceil(h / spacing)) + 1
    axes = [np.arange(-n, n + 1) * spacing] * dim
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dim)


def _hexagonal_points(spacing: float, h: float) -> np.ndarray:
    """Points of the 2D hexagonal (triangular) lattice of the given spacing within ``h``."""
    n = int(np.ceil(h / (0.5 * np.sqrt(3.0) * spacing))) + 2
    i, j = np.meshgrid(np.arange(-2 * n, 2 * n + 1), np.arange(-n, n + 1), indexing="ij")
    pts = np.stack([(i + 0.5 * (j % 2)) * spacing, j * 0.5 * np.sqrt(3.0) * spacing], axis=-1)
    return pts.reshape(-1, 2)


def block_volume(points: np.ndarray, name: str | int, h: float) -> float:
    """The rule of :func:`lattice_volume` for a sampled block of particles (M, dim) whose
    points are not all alike (SPlisHSPlasH's denser lattices): ``V = 1 / mean_i sum_j W_ij``
    over the points i at least h inside the block's bounding box (all points j counted)."""
    pts = np.asarray(points, dtype=np.float64)
    dim = pts.shape[1]
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    inner = pts[np.all((pts >= lo + h) & (pts <= hi - h), axis=1)]
    if len(inner) == 0:
        raise ValueError(f"block_volume: no point of the block is {h} m inside it")
    k = Kernel(name, h, dim)
    sums = [k.w(np.linalg.norm(pts - q, axis=1)).sum() for q in inner]
    return 1.0 / float(np.mean(sums))


def hexagonal_volume(spacing: float, name: str | int, h: float) -> float:
    """Particle volume that reproduces the rest density on the 2D hexagonal lattice.

    The rule of :func:`lattice_volume` applied to the hexagonal (triangular) lattice of the
    given nearest-neighbour spacing: ``V = 1 / sum_k W(|k|)`` over its points (self included),
    so that ``rho_i = sum_j rho0 V W_ij = rho0`` on the lattice. For the cubic spline at
    h = 2 spacings (spacing 2r, h = 4r) ``V = 0.8696 (2r)^2`` (the lattice's cell is
    ``sqrt(3)/2 (2r)^2 = 0.8660 (2r)^2``), and the lattice's gradient normalisation
    ``sum_j V grad W_ij (x_j - x_i)^T`` is ``1.0004 I`` (square lattice of spacing 2r: 1.012).
    """
    return _volume_on(_hexagonal_points(spacing, h), name, h, 2)
