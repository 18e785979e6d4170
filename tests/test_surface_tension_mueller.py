"""Müller et al. 2003 continuum surface force (surface_tension/mueller2003.py): the curvature of
sampled circles and spheres, the Laplace pressure of a 2D drop, and the scene fields (the long
study is validation/surface_tension.py)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from sphkit.core.kernels import kernel_id
from sphkit.core.neighbors import NeighborList, neighbor_lists
from sphkit.core.operators import color_field_cpu, density_cpu, laplacian, surface_normals_cpu
from sphkit.scene.schema import Scene
from sphkit.simulation import SURFACE_TENSION_MODELS, Simulation
from sphkit.surface_tension.mueller2003 import SURFACE, THRESHOLD, Mueller2003, curvature_cpu

_PATH = Path(__file__).resolve().parent.parent / "validation" / "surface_tension.py"
_spec = importlib.util.spec_from_file_location("surface_tension_validation_csf", _PATH)
val = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(val)


def _disc(R: float, dx: float) -> np.ndarray:
    """A disc of concentric rings of spacing dx (about dx along each ring), (2, N)."""
    pts = [np.zeros((2, 1))]
    for k in range(1, int(round(R / dx))):
        rk = k * dx
        n = int(round(2 * np.pi * rk / dx))
        a = np.arange(n) * 2 * np.pi / n + 0.5 * k
        pts.append(np.stack([rk * np.cos(a), rk * np.sin(a)]))
    return np.ascontiguousarray(np.concatenate(pts, axis=1))


def _ball(R: float, dx: float) -> np.ndarray:
    """A ball of concentric Fibonacci-sampled spheres of spacing dx, (3, N)."""
    pts = [np.zeros((3, 1))]
    for k in range(1, int(round(R / dx))):
        rk = k * dx
        n = int(round(4 * np.pi * rk * rk / dx**2))
        i = np.arange(n) + 0.5
        phi = np.arccos(1 - 2 * i / n)
        th = np.pi * (1 + 5**0.5) * i
        pts.append(rk * np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi),
                                  np.cos(phi)]))
    return np.ascontiguousarray(np.concatenate(pts, axis=1))


def _fields(x: np.ndarray, r: float):
    dim, N = x.shape
    dx, h, kid = 2 * r, 4 * r, kernel_id("cubic")
    m = np.full(N, 1000.0 * dx**dim)
    nl = neighbor_lists(x, h)
    e = NeighborList.empty(N)
    bx, bV = np.zeros((dim, 0)), np.zeros(0)
    rho = np.empty(N)
    density_cpu(x, m, nl.offsets, nl.indices, bx, bV, e.offsets, e.indices, 1000.0, h, kid, dim,
                rho)
    n = np.empty((dim, N))
    surface_normals_cpu(x, m, rho, nl.offsets, nl.indices, 1.0, h, kid, dim, n)
    k = np.empty(N)
    curvature_cpu(x, m, rho, n, nl.offsets, nl.indices, SURFACE / h, THRESHOLD / h, h, kid, dim,
                  k)
    c = np.empty(N)
    color_field_cpu(x, m, rho, nl.offsets, nl.indices, bx, bV, e.offsets, e.indices, h, kid, dim,
                    c)
    lap = laplacian(x, m / rho, c, nl, h, kid)
    return m, rho, n, k, lap, h


@pytest.mark.parametrize("dim,R,r", [(2, 0.1, 0.005), (3, 0.04, 0.0025)])
def test_surface_layer_curvature_of_circle_and_sphere(dim: int, R: float, r: float) -> None:
    """On a disc (sphere) of concentric rings the surface layer (|n| h >= SURFACE: the outer
    ring) must get the curvature (dim - 1)/d of its own radius d. Measured mean of
    kappa d/(dim - 1): 1.000 (2D, std 0.022, all within 3.5 %) and 1.003 (3D, std 0.052; the
    Fibonacci points are less regular): 2 % on the mean and 0.1 on the spread cover them with
    room for round-off and kernel changes, but not a bias of the estimator."""
    x = _disc(R + r, 2 * r) if dim == 2 else _ball(R + r, 2 * r)
    _, _, n, k, lap, h = _fields(x, r)
    d = np.linalg.norm(x, axis=0)
    ln = np.linalg.norm(n, axis=0)
    surf = ln * h >= SURFACE
    assert surf.sum() > 40
    q = k[surf] * d[surf] / (dim - 1)
    assert abs(q.mean() - 1.0) < 0.02, q.mean()
    assert q.std() < 0.1, q.std()
    # the deeper particles of the sampled ball carry no curvature of their own
    assert np.all(k[~surf] == 0.0)


def test_literal_mueller_curvature_fails_at_a_free_surface() -> None:
    """Why the module does not use Eq. (17) as written: ``-lap c/|n|`` of the truncated colour
    field on the same circle is dominated by the flat-surface term ``|n|_edge`` (module
    docstring), not the curvature: measured ``kappa d`` = -0.95 (R = 0.1 m) and -2.17
    (R = 0.2 m), i.e. the wrong sign and growing with R. Checked: the sign is wrong for both."""
    for R in (0.1, 0.2):
        x = _disc(R + 0.005, 0.01)
        _, _, n, _, lap, h = _fields(x, 0.005)
        d = np.linalg.norm(x, axis=0)
        ln = np.linalg.norm(n, axis=0)
        surf = ln * h >= SURFACE
        assert np.mean(-lap[surf] / ln[surf] * d[surf]) < 0.0


def test_drop_holds_the_laplace_pressure() -> None:
    """A 2D square (0.28 m, 784 particles, r = 5 mm, sigma = 1 N, no gravity, WCSPH linear
    k = 200) relaxes for 1 s to a circle of R = 0.158 m. Its interior pressure (deeper than
    2h, last third) must be sigma/R within the 15 % target of issue 6 (measured here p R/sigma
    = 1.03; in validation/surface_tension.py, 2 s: 1.045 for this drop, 1.05-1.18 for R >= 0.079
    m, the spread coming from how the interior particles happen to pack), and the model force
    alone pushed onto the circle must give sigma/R within 10 % (measured 0.99; 0.98-1.09 for
    all drops in the validation): that part does not depend on the pressure solver."""
    e = val.drop_2d_csf(1.0, 0.28, 0.005, 1.0, nsamp=12)
    assert e["roundness"] < 1.0  # the outer particles lie within R: the square is gone
    assert abs(e["p"] * e["R"] - 1.0) < 0.15, e["p"] * e["R"]
    assert abs(e["pF"] * e["R"] - 1.0) < 0.10, e["pF"] * e["R"]


def test_scene_fields() -> None:
    """Scene name, the default and rejected boundary_coefficient, bad sigma."""
    assert SURFACE_TENSION_MODELS["mueller2003"] is Mueller2003

    def mat(st: dict) -> Scene:
        return Scene.model_validate({"materials": [{"surface_tension": st}],
                                     "fluid_blocks": [{"start": [0, 0, 0], "end": [0.1] * 3}]})

    sc = mat({"method": "mueller2003", "coefficient": 0.072})
    assert sc.materials[0].surface_tension.boundary_coefficient == 0.0
    with pytest.raises(ValueError, match="boundary_coefficient 0.1: mueller2003 has no adhesion"):
        mat({"method": "mueller2003", "boundary_coefficient": 0.1})
    with pytest.raises(ValueError, match="coefficient"):
        Mueller2003(float("nan"))


def test_flat_periodic_slab_feels_no_force() -> None:
    """A flat lattice slab periodic in x has straight surfaces: its unit normals are uniform
    along each surface, so the curvature and the force vanish everywhere (round-off: measured
    |a| 7e-15 m/s^2, kappa 1e-13 1/m, while |n| h = 1.01 on the surface layer). Without
    minimum-image distances the particles at the seam would see a corner."""
    sim = Simulation(val.scene("mueller2003", 1.0, [{"start": [0.0, -0.04], "end": [0.1, 0.04]}],
                               0.005, periodic=[0.0, 0.1]))
    st = sim.state
    sim._neighbors()
    sim.compute_density()
    a = st.fluid["a"]
    a[:] = 0.0
    sim.forces[-1].apply(st, 1e-3)
    assert np.abs(st.fluid["normal"]).max() * st.h > 0.9  # there is a surface layer
    assert np.abs(st.fluid["curvature"]).max() < 1e-9
    assert np.abs(a).max() < 1e-9
