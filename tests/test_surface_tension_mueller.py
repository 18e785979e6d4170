"""Müller et al. 2003 continuum surface force (surface_tension/mueller2003.py): the curvature of
sampled circles and spheres, the Laplace pressure of a 2D drop, and the scene fields (the long
study is validation/surface_tension.py)."""

from __future__ import annotations

import numpy as np
import pytest
from _validation import load_validation

from sphkit import registry
from sphkit.core.kernels import kernel_id
from sphkit.core.neighbors import NeighborList, neighbor_lists
from sphkit.core.operators import color_field_cpu, density_cpu, laplacian, surface_normals
from sphkit.core.particles import ParticleSet
from sphkit.core.state import SimState
from sphkit.scene.schema import Scene
from sphkit.simulation import Simulation
from sphkit.surface_tension.mueller2003 import SURFACE, THRESHOLD, Mueller2003, curvature_cpu

val = load_validation("surface_tension.py", "surface_tension_validation_csf")


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
    # the period L = 0.0 passed as the simulation passes it: no second compiled signature
    surface_normals(x, m, rho, nl.offsets, nl.indices, 1.0, h, kid, dim, n, 0.0)
    k = np.empty(N)
    curvature_cpu(x, m, rho, n, nl.offsets, nl.indices, SURFACE / h, THRESHOLD / h, h, kid, dim,
                  k, 0.0)
    c = np.empty(N)
    color_field_cpu(x, m, rho, nl.offsets, nl.indices, bx, bV, e.offsets, e.indices, h, kid, dim,
                    c, 0.0)
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


def _jump_of_sampled_drop(x: np.ndarray, r: float, sigma: float) -> tuple[float, float]:
    """Apply the model once to the particles x (dim, N) at rest (masses rho0 (2r)^dim) and
    return (depth integral of the force density along the radius, ``sum_i m_i a_i . (-r_hat_i)
    / (2 pi d_i)`` in 2D or ``/(4 pi d_i^2)`` in 3D; the drop's volume radius R)."""
    dim, N = x.shape
    h, kid = 4 * r, kernel_id("cubic")
    f = ParticleSet(dim)
    for name in ("v", "a"):
        f.register(name, "vector")
    for name in ("m", "rho", "p"):
        f.register(name)
    f.add(np.ascontiguousarray(x.T), m=1000.0 * (2 * r) ** dim, rho=1000.0)
    b = ParticleSet(dim)
    b.register("V")
    st = SimState(fluid=f, boundary=b, dim=dim, h=h, kid=kid, r=r, rho0=1000.0,
                  gravity=np.zeros(dim))
    st.nl_ff = neighbor_lists(f["x"], h)
    st.nl_fb = NeighborList.empty(N)
    density_cpu(f["x"], f["m"], st.nl_ff.offsets, st.nl_ff.indices, b["x"], b["V"],
                st.nl_fb.offsets, st.nl_fb.indices, 1000.0, h, kid, dim, f["rho"])
    model = Mueller2003(sigma)
    model.init(st)
    f["a"][:] = 0.0
    model.apply(st, 0.0)
    xx = f["x"]
    d = xx - xx.mean(axis=1, keepdims=True)
    dist = np.maximum(np.linalg.norm(d, axis=0), 1e-12)
    a_in = f["m"] * (-(f["a"] * d).sum(axis=0) / dist)
    vol = N * (2 * r) ** dim
    if dim == 2:
        return float((a_in / (2 * np.pi * dist)).sum()), float(np.sqrt(vol / np.pi))
    return float((a_in / (4 * np.pi * dist**2)).sum()), float((3 * vol / (4 * np.pi)) ** (1 / 3))


@pytest.mark.parametrize("dim,radii,r,tol", [(2, (0.055, 0.075, 0.11, 0.155), 0.005, 0.01),
                                             (3, (0.03, 0.04), 0.0025, 0.04)])
def test_force_holds_the_laplace_jump_on_sampled_drops(dim: int, radii: tuple, r: float,
                                                       tol: float) -> None:
    """In a fluid at rest ``grad p = f``: the pressure jump the surface force holds is the
    integral of its density along the radius, which must be the Laplace pressure (dim - 1)
    sigma / R (R: the drop's volume radius). On discs of concentric rings (R = 2.75-7.75 h)
    and Fibonacci-sampled balls (R = 2.7 and 3.7 h) the model's jump R / ((dim - 1) sigma)
    measured 1.004 / 1.001 / 1.000 / 0.998 (2D) and 1.031 / 1.014 (3D). Tolerances 1 % (2D)
    and 4 % (3D) hold those with room for round-off, not the earlier form (constant factor 2,
    curvature of the layer of particle centres: 1.20 / 1.14 / 1.09 / 1.07 and 1.31 / 1.22)."""
    sigma = 0.5
    for R in radii:
        x = _disc(R + r, 2 * r) if dim == 2 else _ball(R + r, 2 * r)
        jump, Rv = _jump_of_sampled_drop(x, r, sigma)
        assert abs(jump * Rv / ((dim - 1) * sigma) - 1.0) < tol, (dim, R, jump * Rv)


@pytest.mark.parametrize("R", [0.04, 0.06])
def test_laplace_jump_of_rough_balls(R: float, monkeypatch: pytest.MonkeyPatch) -> None:
    """A rough surface must not read as extra curvature. Fibonacci balls of R = 4 h and 6 h
    (r = 2.5 mm) with every particle displaced by normal noise of std 0.05 dx (three seeds): the
    force's Laplace jump R / (2 sigma) measured 1.007-1.010 (4 h) and 1.006-1.007 (6 h) with the
    smoothed directions; with each particle's own normal (``SMOOTHING = 0``, the earlier model)
    1.057-1.068 and 1.099-1.105, a bias that grows with R/h (module docstring). 3 % holds the
    first with room for round-off and is below the smallest biased value."""
    import sphkit.surface_tension.mueller2003 as mod

    def jumps() -> list[float]:
        out = []
        for seed in range(3):
            x = _ball(R + 0.0025, 0.005)
            x = x + np.random.default_rng(seed).normal(0.0, 0.05 * 0.005, x.shape)
            jump, Rv = _jump_of_sampled_drop(x, 0.0025, 0.5)
            out.append(jump * Rv)
        return out

    smoothed = jumps()
    assert all(abs(q - 1.0) < 0.03 for q in smoothed), smoothed
    monkeypatch.setattr(mod, "SMOOTHING", 0)
    monkeypatch.setattr(mod, "NEIGHBOUR", THRESHOLD)
    raw = jumps()
    assert all(q - 1.0 > 0.03 for q in raw), raw


def test_3d_drop_oscillates_with_the_rayleigh_frequency() -> None:
    """Issue 6: a 3D drop (R = 0.04 m = 5 h, r = 2 mm, 4169 particles, sigma = 5 N/m,
    nu = 1e-3 m^2/s, no gravity, DFSPH) relaxes at rest for 0.3 s from a lattice ball jittered by
    0.05 particle spacings (seed 0) and is kicked with the mode-2 flow ``v = A (-x, -y, 2z)``,
    A = 0.8 1/s; the signal is ``q = <z^2> - (<x^2> + <y^2>)/2``, sampled every 5 ms for 0.5 s
    (1.8 periods: maxima at 0.07 and 0.35 s, minima at 0.22 and 0.49 s). Its period must be
    Rayleigh's ``2 pi / sqrt(8 sigma / (rho R^3))`` within 15 % (the issue's target on omega,
    here held on the period, which is stricter for a slow drop). Measured 1.115 (like extrema;
    damped-cosine fit 1.119); without the last minimum (one gap of maxima) 1.122. Relaxed
    0.4 s and sampled 0.6 s (this test's earlier, longer form): 1.109 (fit 1.115; fitted over
    its first 0.5 s, 1.114); relaxed 0.4 s in validation/surface_tension.py: the part of q odd
    in A, from kicks with +A and -A, 1.108 / 1.111; seed 2: 1.109, the lattice start 1.098;
    resolution study 4 / 5 / 6 / 7 h: 1.156 / 1.108 / 1.076 / 1.051 (the remaining excess is
    the force acting in a band under the surface, an O(h/R) lever; validation/README.md). The
    fit must also be a decaying cosine (damping > 0, residual < 5 % of the amplitude: measured
    1.90 1/s and 2.7 %; the longer form 1.70 1/s and 2.8 %, odd part 1.64 1/s and 1.8 %): the
    earlier curvature estimator fed energy into finer drops."""
    res = val.rayleigh_3d(5.0, 0.04, 0.002, 0.5, 0.8, 200.0, nu=1e-3, nsamp=100,
                          name="mueller2003", relax=0.3, jitter=0.05, seed=0, solver="dfsph",
                          dt_max=0.7 * val.capillary_dt(5.0, 0.002), antisym=False)
    ratio = res["T_extrema"] / res["T_rayleigh"]
    assert abs(ratio - 1.0) <= 0.15, ratio
    assert abs(res["T_fit"] / res["T_rayleigh"] - ratio) < 0.03, res["T_fit"]
    assert res["gamma"] > 0.0 and res["fit_resid"] < 0.05, (res["gamma"], res["fit_resid"])


def test_tangent_plane_moment_of_the_cubic_spline() -> None:
    """M = int_plane W rho^2 dA: 2D int_{-h}^{h} W(|y|) y^2 dy, 3D int_0^h W(q) q^2 2 pi q dq;
    the cubic spline's closed forms (q = rho/h, W = s (6q^3 - 6q^2 + 1) for q <= 1/2 and
    2 s (1 - q)^3 above, s = 40/(7 pi h^2) in 2D, 8/(pi h^3) in 3D) give M = 2 s h^3 / 32 =
    5/(14 pi) h = 0.11368 h (2D) and 31/140 h = 0.22143 h (3D); the trapezoid rule of the
    module must agree to 1e-5 relative."""
    from sphkit.surface_tension.mueller2003 import tangent_plane_moment

    h = 0.02
    kid = kernel_id("cubic")
    assert abs(tangent_plane_moment(kid, h, 3) / (31 / 140 * h) - 1) < 1e-5
    assert abs(tangent_plane_moment(kid, h, 2) / (5 / (14 * np.pi) * h) - 1) < 1e-5


def test_drop_holds_the_laplace_pressure() -> None:
    """A 2D square (0.20 m, 400 particles, r = 5 mm, sigma = 1 N, no gravity, WCSPH linear
    k = 200, random start velocities of std 0.01 m/s, seed 0) relaxes for 1.2 s to a circle of
    R = 0.113 m = 5.6 h (roundness max(d)/R 0.955 at 1.2 s; p R/sigma is past 0.93 from 0.27 s
    on and then rises slowly, 0.96 at 0.6 s, 1.03 at 1.2 s, so the average over the last third,
    0.8-1.2 s, is of the relaxed drop). Its interior
    pressure (particles deeper than 2h, last third) must be sigma/R within the 15 % target of
    issue 6: measured p R/sigma = 1.025 here (1.060 averaged over 1.33-2 s of a 2 s run, the
    earlier end: it creeps up by about 0.05 per second); in validation/surface_tension.py
    0.95-1.08 over R = 3.95-7.9 h, three solvers and three seeds (seed spread <= 0.02), the
    spread coming from how the interior particles pack into shells (validation/README.md); 15 %
    is the issue's target. The force's own jump (p_jump, integrated along the radius; measured
    1.010 here, 1.042 over 1.33-2 s, 0.98-1.07 in the validation) must be within 5 %: that part
    does not depend on the pressure solver. (At nu = 0.005 the drop's surface row buckles after
    4-5 s; 1.2 s is well before that.)"""
    e = val.drop_2d_csf(1.0, 0.20, 0.005, 1.2, nsamp=18, seed=0)
    assert e["roundness"] < 1.0  # the outer particles lie within R: the square is gone
    assert abs(e["p"] * e["R"] - 1.0) < 0.15, e["p"] * e["R"]
    assert abs(e["pJ"] * e["R"] - 1.0) < 0.05, e["pJ"] * e["R"]


def test_scene_fields() -> None:
    """Scene name, the default and rejected boundary_coefficient, bad sigma."""
    assert registry.get("surface_tension", "mueller2003").load() is Mueller2003

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
