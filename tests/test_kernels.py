"""Smoothing kernels: normalization, gradient, symmetry, support, validation, lattice volume.

Every expected value below comes from mathematics (the integral of a normalized kernel is 1, the
gradient is the derivative of W, ...) evaluated independently of sphkit (SciPy quadrature, finite
differences, brute-force lattice sums); each tolerance is stated with its reason.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from sphkit.core.kernels import KERNEL_IDS, Kernel, kernel_dw, kernel_w, lattice_volume

NAMES = ["cubic", "wendland", "poly6", "spiky", "quintic"]
DIMS = [1, 2, 3]
H = 0.7  # a support radius that is not 1, so that every power of h in s_d is exercised


def _radial_measure(r: float, dim: int) -> float:
    """Surface of the sphere of radius r in ``dim`` dimensions (1D: the two points +-r)."""
    if dim == 1:
        return 2.0
    if dim == 2:
        return 2.0 * math.pi * r
    return 4.0 * math.pi * r * r


def _lattice(spacing: float, extent: float, dim: int, offset: np.ndarray) -> np.ndarray:
    """Points ``k * spacing + offset`` (rows) covering the cube [-extent, extent]^dim."""
    n = int(math.ceil(extent / spacing)) + 2
    axes = [np.arange(-n, n + 1) * spacing] * dim
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dim) + offset


# -- normalization ------------------------------------------------------------------------------
@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("name", NAMES)
def test_integral_over_support_is_one(name: str, dim: int) -> None:
    k = Kernel(name, H, dim)
    value, abserr = integrate.quad(
        lambda r: _radial_measure(r, dim) * float(k.w(r)),
        0.0,
        H,
        points=[H / 3, H / 2, 2 * H / 3],  # the cubic's and the quintic's breaks
        epsabs=1e-13,
        epsrel=1e-13,
        limit=200,
    )
    # the integrands are piecewise polynomials, so quad is accurate to ~1e-14: a 1e-6 miss can only
    # be a wrong normalization constant (those are exact rationals times powers of pi and h)
    assert abserr < 1e-10
    assert value == pytest.approx(1.0, abs=1e-6)


# Fine-lattice quadrature (the check in SPlisHSPlasH's Tests/KernelTests): sum_k W(x_k) dV ~ 1 and
# sum_k grad W(x_k) dV ~ 0, on a lattice of spacing h/20 shifted off the origin. The gradient sum is
# compared with sum_k |grad W(x_k)| dV (~ 1/h). Measured: cubic, Wendland and poly6 (smooth enough
# that the lattice rule converges fast) |sum W dV - 1| <= 2e-6 and relative |sum grad| <= 7.6e-5
# (1D Wendland is worst); spiky has a kink of W at r = 0 (W'(0) != 0), i.e. a jump of grad W, so its
# sums converge only at O(spacing^2) and O(spacing): measured 1.0e-3 and 2.0e-2 (1D is worst).
# The quintic spline (C4) is smoother than the cubic and gets the cubic's tolerances.
SUM_TOL = {"cubic": 2e-5, "wendland": 2e-5, "poly6": 2e-5, "spiky": 5e-3, "quintic": 2e-5}
GRAD_SUM_TOL = {"cubic": 5e-4, "wendland": 5e-4, "poly6": 5e-4, "spiky": 5e-2, "quintic": 5e-4}


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("name", NAMES)
def test_lattice_sum_of_w_is_one_and_of_grad_is_zero(name: str, dim: int) -> None:
    k = Kernel(name, H, dim)
    spacing = H / 20
    dv = spacing**dim
    # an offset that is no symmetry of the lattice: the gradient terms do not cancel pairwise
    offset = np.array([0.37, 0.61, 0.13][:dim]) * spacing
    pts = _lattice(spacing, H, dim, offset)
    total = k.w(np.linalg.norm(pts, axis=1)).sum() * dv
    grad = k.grad(pts)
    scale = np.linalg.norm(grad, axis=1).sum() * dv
    assert abs(total - 1.0) <= SUM_TOL[name]
    assert np.abs(grad.sum(axis=0) * dv).max() <= GRAD_SUM_TOL[name] * scale

    # on the lattice centred on the origin the gradient terms cancel in +-x pairs (W is radial and
    # -x_k is a lattice point too), so the sum is zero to rounding: 1e-12 of the sum of |terms|
    centred = _lattice(spacing, H, dim, np.zeros(dim))
    grad = k.grad(centred)
    assert np.abs(grad.sum(axis=0)).max() <= 1e-12 * np.linalg.norm(grad, axis=1).sum()


# -- gradient -----------------------------------------------------------------------------------
@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("name", NAMES)
def test_gradient_equals_central_difference_of_w(name: str, dim: int) -> None:
    k = Kernel(name, H, dim)
    rng = np.random.default_rng(1234 + 10 * dim + KERNEL_IDS[name])
    directions = rng.normal(size=(400, dim))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    r = rng.uniform(0.05 * H, 0.97 * H, size=400)
    keep = np.abs(r - H / 2) > 1e-3 * H  # away from the cubic spline's break
    x = directions[keep] * r[keep, None]
    grad = k.grad(x)

    delta = 1e-5 * H
    fd = np.empty_like(x)
    for d in range(dim):
        e = np.zeros(dim)
        e[d] = delta
        wp = k.w(np.linalg.norm(x + e, axis=1))
        wm = k.w(np.linalg.norm(x - e, axis=1))
        fd[:, d] = (wp - wm) / (2 * delta)
    # central differences of a piecewise polynomial: truncation ~ delta^2 W'''/6 ~ 1e-10 relative,
    # rounding ~ 1e-16 W / delta ~ 1e-11 relative; 1e-6 leaves room and still catches any wrong
    # factor or power in W'(r)/r
    err = np.linalg.norm(grad - fd, axis=1)
    assert np.all(err <= 1e-6 * np.linalg.norm(grad, axis=1))


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("name", NAMES)
def test_gradient_at_origin_is_zero(name: str, dim: int) -> None:
    # grad W = (W'/r) x: a finite W'/r (spiky's singular one is set to 0) times x = 0 is exactly 0
    g = Kernel(name, H, dim).grad(np.zeros((1, dim)))
    assert np.all(np.isfinite(g))
    assert np.all(g == 0.0)


@pytest.mark.parametrize("name", NAMES)
def test_compiled_scalar_functions_agree_with_kernel_class(name: str) -> None:
    # the same compiled code path, so equal to rounding (1e-14 relative; 2e-14 for the quintic,
    # whose fifth powers near the support edge round differently in the vectorised array loop
    # under fastmath: measured 1.1e-14)
    k = Kernel(name, H, 3)
    r = np.linspace(0.0, 1.2 * H, 37)
    w = np.array([kernel_w(KERNEL_IDS[name], ri, H, 3) for ri in r])
    dw = np.array([kernel_dw(KERNEL_IDS[name], ri, H, 3) for ri in r])
    rtol = 2e-14 if name == "quintic" else 1e-14
    np.testing.assert_allclose(w, k.w(r), rtol=rtol, atol=0)
    np.testing.assert_allclose(dw, k.dw_over_r(r), rtol=rtol, atol=0)


# -- symmetry, sign, support -------------------------------------------------------------------
@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("name", NAMES)
def test_symmetry(name: str, dim: int) -> None:
    k = Kernel(name, H, dim)
    x = np.random.default_rng(7).uniform(-1.1 * H, 1.1 * H, size=(500, dim))
    # |-x| is bitwise |x| and negation is exact, so both identities hold exactly (tolerance 0)
    np.testing.assert_array_equal(k.w(np.linalg.norm(x, axis=1)), k.w(np.linalg.norm(-x, axis=1)))
    np.testing.assert_array_equal(k.grad(x), -k.grad(-x))


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("name", NAMES)
def test_w_is_nonnegative(name: str, dim: int) -> None:
    w = Kernel(name, H, dim).w(np.linspace(0.0, 2.0 * H, 20001))
    assert np.all(w >= 0.0)  # a density kernel must never give negative mass: tolerance 0


@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("name", NAMES)
def test_zero_outside_support(name: str, dim: int) -> None:
    k = Kernel(name, H, dim)
    r = np.array([H, np.nextafter(H, np.inf), 1.0001 * H, 1.5 * H, 10 * H, 1e300])
    # compact support with the strict convention r < h: exactly 0 (tolerance 0) for r >= h
    assert np.all(k.w(r) == 0.0)
    assert np.all(k.dw_over_r(r) == 0.0)
    on_axis = np.zeros((r.size - 1, dim))
    on_axis[:, 0] = -r[:-1]  # |x| = r exactly (1e300 left out: its square overflows in the norm)
    assert np.all(k.grad(on_axis) == 0.0)
    directions = np.random.default_rng(3).normal(size=(3, dim))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    x = directions * r[2:5, None]  # |x| = r to rounding, and r >= 1.0001 h
    assert np.all(k.grad(x) == 0.0)
    # and strictly positive just inside (the support is not smaller than h)
    assert np.all(k.w(np.array([0.0, 0.5 * H, 0.99 * H])) > 0.0)


# -- validation ---------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["gaussian", "", "Cubic spline", 5, -1])
def test_bad_kernel_name_raises(name: object) -> None:
    with pytest.raises(ValueError, match="^kernel"):
        Kernel(name, H, 3)  # type: ignore[arg-type]


@pytest.mark.parametrize("dim", [0, 4, -3, 2.5])
def test_bad_dim_raises(dim: object) -> None:
    with pytest.raises(ValueError, match="^dim"):
        Kernel("cubic", H, dim)  # type: ignore[arg-type]


@pytest.mark.parametrize("h", [0.0, -0.1, float("nan"), -float("inf")])
def test_bad_h_raises(h: float) -> None:
    with pytest.raises(ValueError, match="^h"):
        Kernel("cubic", h, 3)


@pytest.mark.parametrize("name", ["CUBIC", "Wendland", 2, np.int64(3)])
def test_names_are_case_insensitive_and_ids_accepted(name: object) -> None:
    assert Kernel(name, H, 2).kid in KERNEL_IDS.values()  # type: ignore[arg-type]


# -- lattice volume -----------------------------------------------------------------------------
@pytest.mark.parametrize("ratio", [2.0, 2.6, 3.0])
@pytest.mark.parametrize("dim", DIMS)
@pytest.mark.parametrize("name", NAMES)
def test_lattice_volume_gives_rest_density_in_the_interior(
    name: str, dim: int, ratio: float
) -> None:
    spacing = 0.05
    h = ratio * spacing
    rho0 = 1000.0
    mass = rho0 * lattice_volume(spacing, name, h, dim)
    k = Kernel(name, h, dim)
    n = int(math.ceil(h / spacing)) + 3
    axes = [np.arange(-n, n + 1)] * dim
    idx = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dim)
    x = idx * spacing
    # interior: at least h from the lattice's edge, so the whole support is filled
    inner = np.all(np.abs(idx) <= n - math.ceil(h / spacing), axis=1)
    assert inner.sum() >= 3**dim
    for i in np.flatnonzero(inner):
        rho = mass * k.w(np.linalg.norm(x - x[i], axis=1)).sum()  # brute force over all points
        # the same lattice sum as the one that defines V, reordered: equal to rounding (1e-12)
        assert rho == pytest.approx(rho0, rel=1e-12)


@pytest.mark.parametrize("dim", DIMS)
def test_lattice_volume_close_to_spacing_power_for_cubic(dim: int) -> None:
    spacing = 0.02
    v = lattice_volume(spacing, "cubic", 2 * spacing, dim)
    # the cubic spline at h = 2 spacing is a good lattice quadrature: V differs from spacing^dim
    # by its discretization error only (measured: 1D 0, 2D -0.09 %, 3D +0.003 %); 5 % bounds it
    assert v == pytest.approx(spacing**dim, rel=0.05)
