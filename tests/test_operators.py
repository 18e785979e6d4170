"""SPH differential operators on regular lattices, checked against exact calculus.

Setting (2D and 3D): cubic spline, h = 2 * spacing, mass m = rho0 * lattice_volume(...), density
from the SPH sum rho_i = sum_j m_j W_ij (``interpolate`` of rho0 with V = m / rho0). The interior
is the set of particles at least h from the lattice edge, whose kernel support is full.

Expected values are exact derivatives of polynomial fields (grad(a + b.x) = b, lap |x|^2 = 2 dim,
div(G x) = trace G, curl(omega x x) = 2 omega). The tolerances are the discretization errors of the
operators on this lattice, stated per test; ``test_lattice_moments`` pins those errors down exactly
with an independent NumPy evaluation of the cubic spline.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from sphkit.core.kernels import CUBIC, lattice_volume
from sphkit.core.neighbors import neighbor_lists
from sphkit.core.operators import curl, divergence, gradient, interpolate, laplacian

SPACING = 0.1
H = 2 * SPACING
RHO0 = 1000.0
SIDE = {2: 24, 3: 12}  # particles per axis: 576 in 2D (400 interior), 1728 in 3D (512 interior)


class Lattice:
    """A regular lattice with SPH masses, densities, neighbour lists and the interior mask."""

    def __init__(self, dim: int, jitter: float = 0.0, seed: int = 0) -> None:
        n = SIDE[dim]
        idx = np.stack(np.meshgrid(*[np.arange(n)] * dim, indexing="ij")).reshape(dim, -1)
        rng = np.random.default_rng(seed)
        # an origin away from 0 so that no field below is accidentally centred on the lattice
        self.x = idx * SPACING + np.array([0.31, -0.17, 0.05][:dim])[:, None]
        self.x += jitter * SPACING * rng.uniform(-1.0, 1.0, size=self.x.shape)
        self.dim = dim
        self.n = self.x.shape[1]
        self.nl = neighbor_lists(self.x, H)
        self.m = np.full(self.n, RHO0 * lattice_volume(SPACING, "cubic", H, dim))
        self.rho = interpolate(self.x, self.m / RHO0, np.full(self.n, RHO0), self.nl, H, CUBIC)
        k = round(H / SPACING)  # position >= h from the edge <=> index in [k, n - 1 - k]
        self.interior = np.all((idx >= k) & (idx <= n - 1 - k), axis=0)
        self.face = np.any((idx == 0) | (idx == n - 1), axis=0)


@pytest.fixture(scope="module", params=[2, 3], ids=["2d", "3d"])
def lat(request: pytest.FixtureRequest) -> Lattice:
    return Lattice(request.param)


@pytest.fixture(scope="module")
def lat3() -> Lattice:
    return Lattice(3)


def test_interior_density_is_rest_density(lat: Lattice) -> None:
    # m = rho0 V with V the inverse lattice sum of W: rho = rho0 exactly up to rounding (1e-12)
    np.testing.assert_allclose(lat.rho[lat.interior], RHO0, rtol=1e-12, atol=0)
    # particles on the lattice's faces miss neighbours (offsets of one spacing lie inside h):
    # their sums are deficient, by far more than rounding
    assert np.all(lat.rho[lat.face] < 0.9 * RHO0)


def test_interpolation_of_a_constant(lat: Lattice) -> None:
    c = 3.7
    out = interpolate(lat.x, lat.m / RHO0, np.full(lat.n, c), lat.nl, H, CUBIC)
    # sum_j V W_ij = 1 on the full interior support by the definition of V: exact to rounding
    np.testing.assert_allclose(out[lat.interior], c, rtol=1e-12, atol=0)


@pytest.mark.parametrize("jitter", [0.0, 0.3], ids=["lattice", "perturbed"])
def test_renormalized_difference_gradient_is_exact_for_linear_fields(
    lat: Lattice, jitter: float
) -> None:
    pts = lat if jitter == 0.0 else Lattice(lat.dim, jitter=jitter, seed=5)
    rng = np.random.default_rng(1)
    a = 2.5
    b = rng.normal(size=pts.dim)
    field = a + b @ pts.x
    g = gradient(
        pts.x, pts.m, pts.rho, field, pts.nl, H, CUBIC, form="difference", renormalize=True
    )
    # the difference form gives L_i b for a linear field and L_i^-1 undoes it (Bonet & Lok 1999),
    # so the result is b on every particle -- edges, corners and disordered particles included --
    # up to rounding amplified by cond(L_i): 1e-10 relative to |b|
    err = np.abs(g - b[:, None]).max()
    assert err <= 1e-10 * np.linalg.norm(b)


def test_unrenormalized_difference_gradient_is_first_order_in_the_interior(lat: Lattice) -> None:
    b = np.array([1.0, -2.0, 0.5][: lat.dim])
    field = 2.5 + b @ lat.x
    g = gradient(lat.x, lat.m, lat.rho, field, lat.nl, H, CUBIC, form="difference")
    # without L^-1 the result is c b with c the lattice moment of grad W (see test_lattice_moments:
    # +1.22 % in 2D, +2.01 % in 3D), exact direction; 2.5 % bounds it
    gi = g[:, lat.interior]
    np.testing.assert_allclose(gi, np.repeat(b[:, None], gi.shape[1], axis=1), rtol=0.025, atol=0)


def test_laplacian_of_quadratic(lat: Lattice) -> None:
    centre = np.array([0.9, 1.3, 0.7][: lat.dim])[:, None]
    field = ((lat.x - centre) ** 2).sum(axis=0)  # lap = 2 dim exactly
    lap = laplacian(lat.x, lat.m / lat.rho, field, lat.nl, H, CUBIC)
    # Brookshaw/Morris on the cubic lattice at h = 2 spacing: the lattice quadrature of the second
    # moment plus the 0.01 h^2 regularization of 1/|x_ij|^2 give -0.84 % in 3D and -2.05 % in 2D
    # (measured; see test_lattice_moments). 3D is held to 2 %, 2D to 2.5 % because the 2D error of
    # this discretization itself exceeds 2 %.
    tol = {2: 0.025, 3: 0.02}[lat.dim]
    rel = lap[lat.interior] / (2 * lat.dim) - 1.0
    assert np.abs(rel).max() <= tol


def test_divergence_of_linear_vector_field(lat: Lattice) -> None:
    rng = np.random.default_rng(2)
    G = np.diag(np.arange(1.0, lat.dim + 1.0)) + 0.3 * rng.normal(size=(lat.dim, lat.dim))
    div = divergence(lat.x, lat.m, lat.rho, G @ lat.x, lat.nl, H, CUBIC)
    # the divergence is not renormalized: for A = G x it returns c trace(G), with c the lattice
    # quadrature of the first moment of grad W (no L^-1 to remove it): measured c - 1 = +1.22 % in
    # 2D and +2.007 % in 3D, so 3D cannot meet 2 %; 2.5 % (both dims) bounds the measured values
    tol = 0.025
    rel = div[lat.interior] / np.trace(G) - 1.0
    assert np.abs(rel).max() <= tol


def test_curl_of_gradient_field_vanishes(lat3: Lattice) -> None:
    rng = np.random.default_rng(3)
    S = rng.normal(size=(3, 3))
    S = S + S.T  # A = S x = grad(x.S x / 2) is irrotational
    c = curl(lat3.x, lat3.m, lat3.rho, S @ lat3.x, lat3.nl, H, CUBIC)
    # on the cubic lattice the pair sum is eps_abc S_bd M_dc with M = c I isotropic, which is zero
    # for symmetric S: exact to rounding, 1e-10 of |S|
    assert np.abs(c[:, lat3.interior]).max() <= 1e-10 * np.abs(S).max()


def test_curl_of_rigid_rotation(lat3: Lattice) -> None:
    omega = np.array([0.3, -1.2, 0.7])
    vel = np.cross(omega[:, None], lat3.x, axis=0)  # rigid rotation, curl = 2 omega
    c = curl(lat3.x, lat3.m, lat3.rho, vel, lat3.nl, H, CUBIC)
    # the same unrenormalized first-moment factor as the divergence (+2.007 % in 3D), hence 2.5 %
    ci = c[:, lat3.interior]
    exact = np.repeat(2 * omega[:, None], ci.shape[1], axis=1)
    assert np.abs(ci - exact).max() <= 0.025 * np.linalg.norm(2 * omega)


@pytest.mark.parametrize("dim", [2, 3])
def test_symmetric_gradient_conserves_momentum(dim: int) -> None:
    pts = Lattice(dim, jitter=0.35, seed=7)
    rng = np.random.default_rng(8)
    m = pts.m * rng.uniform(0.8, 1.2, pts.n)  # unequal masses: conservation must not rely on them
    rho = interpolate(pts.x, m / RHO0, np.full(pts.n, RHO0), pts.nl, H, CUBIC)
    p = rng.uniform(-1e3, 1e4, pts.n)
    g = gradient(pts.x, m, rho, p, pts.nl, H, CUBIC, form="symmetric")
    force = (
        m * g / rho
    )  # m_i (grad p)_i / rho_i = sum_j m_i m_j (p_i/rho_i^2 + p_j/rho_j^2) gradW_ij
    total = force.sum(axis=1)
    scale = np.linalg.norm(force, axis=0).sum()
    # the pair terms are exactly antisymmetric (gradW_ji = -gradW_ij, same prefactor), so the sum
    # cancels to rounding of ~N^(1/2) eps of the terms: 1e-12 relative to sum |terms|
    assert np.linalg.norm(total) <= 1e-12 * scale
    assert scale > 0


# -- the exact lattice errors, from an independent evaluation of the cubic spline ---------------
def _cubic_numpy(r: np.ndarray, h: float, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Monaghan's cubic spline W(r) and W'(r) (support h), written out again in NumPy."""
    sigma = {2: 40.0 / (7.0 * math.pi * h**2), 3: 8.0 / (math.pi * h**3)}[dim]
    q = r / h
    w = np.where(q <= 0.5, 6 * (q**3 - q**2) + 1, np.where(q < 1, 2 * (1 - q) ** 3, 0.0))
    dw = np.where(q <= 0.5, (18 * q**2 - 12 * q) / h, np.where(q < 1, -6 * (1 - q) ** 2 / h, 0.0))
    return sigma * w, sigma * dw


def test_lattice_moments(lat: Lattice) -> None:
    """Interior values equal the exact derivative times the lattice moment of the kernel.

    On a full lattice neighbourhood with V = 1 / sum W: div(G x) = c trace(G) and the Laplacian of
    |x|^2 is 2 dim l, with c = sum V (-W') r / dim and l = sum V (-W') r^3 / (r^2 + 0.01 h^2) / dim.
    c and l are computed here without sphkit; they give the percentages quoted above.
    """
    dim = lat.dim
    offsets = np.array(list(itertools.product(range(-3, 4), repeat=dim)), dtype=float) * SPACING
    r = np.linalg.norm(offsets, axis=1)
    w, dw = _cubic_numpy(r, H, dim)
    v = 1.0 / w.sum()
    c = (v * -dw * r).sum() / dim
    lap_factor = (v * -dw * r**3 / (r**2 + 0.01 * H * H)).sum() / dim
    # measured: 2D c = 1.012227, l = 0.979531; 3D c = 1.020070, l = 0.991577
    assert abs(c - 1) < 0.025 and abs(lap_factor - 1) < 0.025

    G = np.array([[1.0, 0.2, -0.4], [0.3, 2.0, 0.1], [0.5, -0.6, 3.0]])[:dim, :dim]
    div = divergence(lat.x, lat.m, lat.rho, G @ lat.x, lat.nl, H, CUBIC)
    lap = laplacian(lat.x, lat.m / lat.rho, (lat.x**2).sum(axis=0), lat.nl, H, CUBIC)
    # same sums in another order and with W from another implementation: 1e-10 relative
    np.testing.assert_allclose(div[lat.interior], c * np.trace(G), rtol=1e-10, atol=0)
    np.testing.assert_allclose(lap[lat.interior], 2 * dim * lap_factor, rtol=1e-10, atol=0)


# -- argument checks ------------------------------------------------------------------------------
def test_argument_errors(lat: Lattice) -> None:
    a = np.ones(lat.n)
    with pytest.raises(ValueError, match="^form"):
        gradient(lat.x, lat.m, lat.rho, a, lat.nl, H, CUBIC, form="upwind")
    with pytest.raises(ValueError, match="^renormalize"):
        gradient(lat.x, lat.m, lat.rho, a, lat.nl, H, CUBIC, form="symmetric", renormalize=True)
    if lat.dim == 2:
        with pytest.raises(ValueError, match="3D"):
            curl(lat.x, lat.m, lat.rho, lat.x, lat.nl, H, CUBIC)
