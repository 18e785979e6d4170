"""Surface tension (Becker 2007, Akinci 2013, He 2014), drag (Macklin 2014, Gissler 2017) and
vorticity confinement: SPlisHSPlasH's formulas against brute-force sums, momentum conservation,
zero force in a uniform interior, drag direction and location, the sign of confinement, scene
fields, and runs with every pressure solver."""

from __future__ import annotations

import numpy as np
import pytest

from sphkit.core.kernels import Kernel, kernel_id, lattice_volume
from sphkit.core.neighbors import Grid, NeighborList, neighbor_lists
from sphkit.core.operators import density_cpu
from sphkit.core.particles import ParticleSet
from sphkit.core.state import SimState
from sphkit.drag import Gissler2017, Macklin2014
from sphkit.scene.schema import Material, Scene, SceneError
from sphkit.scene.splishsplash import from_splishsplash
from sphkit.simulation import Simulation
from sphkit.surface_tension import Akinci2013, BeckerTeschner2007, He2014
from sphkit.surface_tension.akinci2013 import adhesion_kernel, cohesion_kernel
from sphkit.vorticity import VorticityConfinement

RHO0 = 1000.0
R_P = 0.01
ST_MODELS = [BeckerTeschner2007, Akinci2013, He2014]


def _lattice(dim: int, n: int, r: float = R_P) -> np.ndarray:
    axes = [np.arange(n) * 2.0 * r] * dim
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dim)


def _disc(dim: int, radius: float, r: float = R_P) -> np.ndarray:
    s = 2.0 * r
    n = int(np.ceil(radius / s)) + 1
    axes = [np.arange(-n, n + 1) * s] * dim
    g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dim)
    return g[np.linalg.norm(g, axis=1) <= radius + 1e-12]


def _state(x: np.ndarray, bx: np.ndarray | None = None, r: float = R_P) -> SimState:
    """Fluid at x (M, dim) with lattice masses, optional boundary particles; neighbour lists
    and densities computed."""
    dim = x.shape[1]
    h = 4.0 * r
    kid = kernel_id("cubic")
    vol = lattice_volume(2.0 * r, kid, h, dim)
    f = ParticleSet(dim)
    for name in ("v", "a"):
        f.register(name, "vector")
    for name in ("m", "rho", "p"):
        f.register(name)
    f.add(x, m=RHO0 * vol, rho=RHO0)
    b = ParticleSet(dim)
    b.register("V")
    b.register("v", "vector")
    if bx is not None:
        b.add(bx, V=vol)
    st = SimState(fluid=f, boundary=b, dim=dim, h=h, kid=kid, r=r, rho0=RHO0,
                  gravity=np.zeros(dim))
    st.nl_ff = neighbor_lists(f["x"], h)
    st.nl_fb = Grid(b["x"], h).query(f["x"]) if b.n else NeighborList.empty(f.n)
    density_cpu(f["x"], f["m"], st.nl_ff.offsets, st.nl_ff.indices, b["x"], b["V"],
                st.nl_fb.offsets, st.nl_fb.indices, RHO0, h, kid, dim, f["rho"])
    return st


def _accel(model, st: SimState) -> np.ndarray:
    if hasattr(model, "init"):
        model.init(st)
    st.fluid["a"][...] = 0.0
    model.apply(st, 1e-3)
    return st.fluid["a"].T.copy()


def _jittered_drop(dim: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """A jittered drop resting on a wall (boundary particles below it)."""
    rng = np.random.default_rng(seed)
    x = _disc(dim, 6 * R_P) + rng.uniform(-0.3, 0.3, size=(1, dim)) * R_P
    x = x + rng.uniform(-0.25, 0.25, size=x.shape) * R_P
    wall = _lattice(dim, 12) - 11 * R_P
    wall[:, -1] = -7.5 * R_P
    return x, np.unique(wall, axis=0)


# ---------------------------------------------------------------------------------------------
# brute-force references (SPlisHSPlasH's formulas, all pairs, no neighbour lists)


def _pairs(x: np.ndarray, y: np.ndarray):
    d = x[:, None, :] - y[None, :, :]
    r = np.linalg.norm(d, axis=2)
    return d, r


def _reference(name: str, st: SimState, k: float, kb: float) -> np.ndarray:
    f, b = st.fluid, st.boundary
    x, m, rho = f["x"].T, f["m"], f["rho"]
    bx, bV = b["x"].T, b["V"]
    h, dim = st.h, st.dim
    K = Kernel("cubic", h, dim)
    d, r = _pairs(x, x)
    db, rb = _pairs(x, bx)
    near = (r < h) & (r > 0)
    nearb = rb < h
    gW = K.dw_over_r(r)[..., None] * d * near[..., None]
    gWb = K.dw_over_r(rb)[..., None] * db * nearb[..., None]
    if name == "becker2007":
        w = np.where(r > 2 * R_P, K.w(r), K.w(np.full_like(r, 2 * R_P))) * near
        wb = np.where(rb > 2 * R_P, K.w(rb), K.w(np.full_like(rb, 2 * R_P))) * nearb
        a = -k / m[:, None] * (m[None, :, None] * d * w[..., None]).sum(1)
        a -= kb / m[:, None] * (RHO0 * bV[None, :, None] * db * wb[..., None]).sum(1)
        return a
    if name == "akinci2013":
        n = h * ((m / rho)[None, :, None] * gW).sum(1)
        C = np.vectorize(lambda s: cohesion_kernel(s, h))(r) * near
        A = np.vectorize(lambda s: adhesion_kernel(s, h))(rb) * nearb
        kij = 2 * RHO0 / (rho[:, None] + rho[None, :])
        with np.errstate(invalid="ignore", divide="ignore"):
            u = np.where(near[..., None], d / r[..., None], 0.0)
            ub = np.where(nearb[..., None], db / rb[..., None], 0.0)
        acc = -k * m[None, :, None] * u * C[..., None] - k * (n[:, None, :] - n[None, :, :])
        a = (kij[..., None] * acc * near[..., None]).sum(1)
        a -= kb * (RHO0 * bV[None, :, None] * ub * A[..., None]).sum(1)
        return a
    # he2014
    V = m / rho
    c = V * K.w(np.zeros(1))[0] + (V[None, :] * K.w(r) * near).sum(1)
    c += (bV[None, :] * K.w(rb) * nearb).sum(1)
    gc = ((V * c)[None, :, None] * gW).sum(1) / c[:, None]
    G = (gc**2).sum(1)
    a = 0.25 * k / rho[:, None] * (V[None, :, None] * (G[:, None] + G[None, :])[..., None]
                                   * gW).sum(1)
    a += 0.25 * kb / rho[:, None] * (bV[None, :, None] * G[:, None, None] * gWb).sum(1)
    return a


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("model", ST_MODELS)
def test_surface_tension_matches_splishsplash_formulas(model, dim: int) -> None:
    """The compiled loops agree with brute-force sums of SPlisHSPlasH's formulas (jittered drop
    on a wall, fluid and boundary terms) to round-off (1e-9 relative: float64 sums in another
    order)."""
    x, wall = _jittered_drop(dim)
    st = _state(x, wall)
    k, kb = (0.3, 0.2) if model is not Akinci2013 else (2e-4, 5e-4)
    a = _accel(model(k, kb), st)
    ref = _reference(model.name, st, k, kb)
    scale = np.abs(ref).max()
    assert scale > 0
    np.testing.assert_allclose(a, ref, rtol=0, atol=1e-9 * scale)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("model", ST_MODELS)
def test_fluid_surface_forces_conserve_momentum(model, dim: int) -> None:
    """Fluid-fluid surface forces are pairwise equal and opposite: sum_i m_i a_i = 0 up to
    round-off (1e-12 of sum |m_i a_i|), on a jittered drop without boundary. Becker and He are
    central forces, so the torque vanishes too (Akinci's curvature term is not central)."""
    x, _ = _jittered_drop(dim, seed=3)
    st = _state(x)
    a = _accel(model(0.3 if model is not Akinci2013 else 2e-4, 0.0), st)
    F = st.fluid["m"][:, None] * a
    total = np.abs(F).sum()
    assert total > 0
    assert np.abs(F.sum(axis=0)).max() < 1e-12 * total
    if model is not Akinci2013:
        xc = st.fluid["x"].T
        if dim == 2:
            torque = (xc[:, 0] * F[:, 1] - xc[:, 1] * F[:, 0]).sum()
        else:
            torque = np.cross(xc, F).sum(axis=0)
        assert np.abs(torque).max() < 1e-12 * total * 10 * R_P


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("model", ST_MODELS)
def test_no_force_in_a_uniform_interior(model, dim: int) -> None:
    """A particle whose whole neighbourhood (and the neighbours' neighbourhoods: normals and
    colour gradients reach one support further) is uniform lattice feels no surface force (the
    lattice sums cancel by symmetry; 1e-10 of the largest surface acceleration)."""
    n = 11 if dim == 2 else 9
    st = _state(_lattice(dim, n))
    a = _accel(model(0.3 if model is not Akinci2013 else 2e-4, 0.0), st)
    x = st.fluid["x"].T
    centre = x.mean(axis=0)
    depth = np.min(np.minimum(x - x.min(0), x.max(0) - x), axis=1)
    deep = depth > 2.0 * st.h - 1e-9
    assert deep.sum() >= 1
    amax = np.abs(a).max()
    assert amax > 0
    assert np.abs(a[deep]).max() < 1e-10 * amax
    # and the surface particles are pulled inwards on average (cohesion)
    surf = depth < 1e-9
    inward = ((centre - x[surf]) * a[surf]).sum(axis=1)
    assert inward.mean() > 0


def test_akinci_kernels() -> None:
    """Cohesion kernel (Akinci 2013, Eq. 2): continuous at h/2, zero at h, repulsive below
    about h/4 (the -h^6/64 offset), attractive between; adhesion kernel (Eq. 9): zero up to h/2
    and at h, positive between."""
    h = 0.04
    k = 32.0 / (np.pi * h**9)
    assert cohesion_kernel(0.5 * h, h) == pytest.approx(k * (0.5 * h) ** 6, rel=1e-12)
    assert cohesion_kernel(0.5 * h - 1e-12, h) == pytest.approx(k * (0.5 * h) ** 6, rel=1e-6)
    assert cohesion_kernel(h, h) == 0.0
    assert cohesion_kernel(0.05 * h, h) < 0.0 < cohesion_kernel(0.4 * h, h)
    assert adhesion_kernel(0.5 * h, h) == 0.0 and adhesion_kernel(0.3 * h, h) == 0.0
    assert adhesion_kernel(0.75 * h, h) == pytest.approx(0.007 / h**3.25 * (0.25 * h) ** 0.25)


def test_becker_equivalent_sigma_scales_with_kappa() -> None:
    """The Kirkwood-Buff tension and internal pressure of the Becker cohesion are linear in
    kappa, positive, and independent of the resolution at fixed h/r (sigma ~ kappa rho0 h^d /
    V0 ... all lengths scale together: 2D sigma [N] scales like r^1 * r^2 / r^2)."""
    r = 0.005
    h = 4 * r
    for dim in (2, 3):
        m = RHO0 * (2 * r) ** dim
        s1, p1 = BeckerTeschner2007(0.05).equivalent_sigma(RHO0, m, r, h, 0, dim)
        s2, p2 = BeckerTeschner2007(0.10).equivalent_sigma(RHO0, m, r, h, 0, dim)
        assert s1 > 0 and p1 > 0
        assert s2 == pytest.approx(2 * s1, rel=1e-9) and p2 == pytest.approx(2 * p1, rel=1e-9)


# ---------------------------------------------------------------------------------------------
# drag


@pytest.mark.parametrize("dim", [2, 3])
def test_macklin_drag_acts_on_surface_against_relative_velocity(dim: int) -> None:
    """Macklin et al. 2014: exactly -(k/m)(v - v_air) max(0, 1 - rho/rho0), i.e. along the
    relative air velocity; in the interior of a lattice block (full neighbourhoods, rho = rho0
    up to round-off) it is zero to 1e-12 of the surface drag, at the surface it is not."""
    st = _state(_lattice(dim, 8))
    v = np.zeros(dim)
    v[0] = 1.0
    va = np.zeros(dim)
    va[-1] = 0.5
    st.fluid["v"][...] = v[:, None]
    a = _accel(Macklin2014(0.02, va), st)
    rho, m = st.fluid["rho"], st.fluid["m"]
    w = np.maximum(0.0, 1.0 - rho / RHO0)
    np.testing.assert_allclose(a, -(0.02 / m * w)[:, None] * (v - va)[None, :], atol=1e-15)
    x = st.fluid["x"].T
    depth = np.min(np.minimum(x - x.min(0), x.max(0) - x), axis=1)
    inner = depth > st.h - 1e-9
    amax = np.abs(a).max()
    assert inner.sum() > 0 and np.abs(a[inner]).max() < 1e-12 * amax
    assert (np.abs(a[depth < 1e-9]).sum(axis=1) > 0.1 * amax).all()


@pytest.mark.parametrize("dim", [2, 3])
def test_gissler_drag_hits_only_the_upstream_face(dim: int) -> None:
    """Gissler et al. 2017: a block moving along +x through still air. Each particle with a
    neighbour straight ahead (+x) is occluded (w = 0) and feels no drag; the front face feels a
    drag parallel to the relative air velocity (-x) with the magnitude of Eqs. 8-14 computed
    here from the constants."""
    st = _state(_lattice(dim, 6))
    st.fluid["v"][0] = 2.0
    a = _accel(Gissler2017(1.0), st)
    x = st.fluid["x"].T
    front = x[:, 0] > x[:, 0].max() - 1e-9
    assert not a[~front].any()
    assert (a[front, 0] < 0).all()
    np.testing.assert_array_equal(a[front, 1:], 0.0)
    # magnitude on the front face, from the paper's equations with SPlisHSPlasH's constants
    from sphkit.drag import gissler2017 as g

    L = (0.75 / np.pi) ** (1 / 3) * 2 * R_P
    u = 2.0
    y = min(1.0, g.deformation_coefficient(L, RHO0) * u * u)
    re = 2 * max(g.RHO_AIR * u * L / g.MU_AIR, 0.1)
    cd_s = 24 / re * (1 + re ** (2 / 3) / 6) if re <= 1000 else 0.424
    cd_liu = cd_s * (1 + 2.632 * y)
    V0 = st.fluid["m"][0] / RHO0
    ball = np.pi * st.h**2 if dim == 2 else 4 / 3 * np.pi * st.h**3
    nf = (ball / V0 - 1) * 2 / 3
    nn = np.diff(st.nl_ff.offsets)[front]
    fn = np.minimum(nf, nn) / nf
    cd = (1 - fn) * cd_liu + fn
    area = (1 - fn) * np.pi * (L + 0.5 * L * y) ** 2 + fn * (2 * R_P) ** 2
    expect = 0.5 / st.fluid["m"][front] * g.RHO_AIR * u * u * cd * area
    np.testing.assert_allclose(-a[front, 0], expect, rtol=1e-12)


# ---------------------------------------------------------------------------------------------
# vorticity confinement


@pytest.mark.parametrize("dim", [2, 3])
def test_confinement_spins_a_vortex_up(dim: int) -> None:
    """A Gaussian vortex about the z axis (omega_z > 0, largest on the axis): the confinement
    acceleration eps N x omega points along the rotation (+theta) wherever it is not negligible,
    so it feeds the vortex (Fedkiw et al. 2001; Macklin & Mueller 2013, Eq. 16). The stored
    vorticity is curl v: 2 Omega for the nearly rigid core."""
    x = _disc(dim, 14 * R_P) if dim == 2 else _lattice(3, 15) - 14 * R_P
    st = _state(x)
    xy = st.fluid["x"][:2].T
    rr2 = (xy**2).sum(axis=1)
    a0 = (12 * R_P) ** 2
    om = 3.0
    vt = om * np.exp(-rr2 / a0)  # v = om exp(-r^2/a^2) (-y, x): core angular velocity om
    st.fluid["v"][0] = -vt * xy[:, 1]
    st.fluid["v"][1] = vt * xy[:, 0]
    a = _accel(VorticityConfinement(0.05), st)
    theta = np.stack([-xy[:, 1], xy[:, 0]], axis=1)
    along = (a[:, :2] * theta).sum(axis=1)
    big = np.abs(a).sum(axis=1) > 1e-3 * np.abs(a).max()
    inside = np.sqrt(rr2) < 8 * R_P  # away from the free surface / the block's faces
    assert (along[big & inside] > 0).all()
    # vorticity on the axis: curl v = om e^(-r^2/a^2) (2 - 2 r^2/a^2) -> 2 om; the kernel
    # averages r^2 over the support (about (h/2)^2), which lowers it by about 2 (h/2)^2/a^2 =
    # 6 %: 10 % tolerance
    centre = np.argmin(rr2 + (st.fluid["x"][2] ** 2 if dim == 3 else 0))
    assert st.fluid["vorticity"][2, centre] == pytest.approx(2 * om, rel=0.10)


# ---------------------------------------------------------------------------------------------
# scenes


def _sph(mat: dict) -> dict:
    base = {"id": "Fluid"}
    base.update(mat)
    return {"Configuration": {"sim2D": True, "simulationMethod": 4},
            "Materials": [base], "FluidBlocks": [{"start": [0, 0, 0], "end": [0.5, 0.5, 0]}]}


def test_loader_maps_methods_numbers_and_defaults() -> None:
    for num, name, block in [(1, "becker2007", "Becker & Teschner 2007"),
                             (2, "akinci2013", "Akinci et al. 2013"),
                             (3, "he2014", "He et al. 2014")]:
        st = from_splishsplash(_sph({"surfaceTensionMethod": num, block: {
            "surfaceTension": 0.2, "surfaceTensionBoundary": 0.03}}))
        st = st.materials[0].surface_tension
        assert (st.method, st.coefficient, st.boundary_coefficient) == (name, 0.2, 0.03)
        d = from_splishsplash(_sph({"surfaceTensionMethod": num})).materials[0].surface_tension
        assert (d.method, d.coefficient, d.boundary_coefficient) == (name, 0.05, 0.01)
    flat = from_splishsplash(_sph({"surfaceTensionMethod": 1, "surfaceTension": 0.3}))
    assert flat.materials[0].surface_tension.coefficient == 0.3  # scenes before 2.16
    for num, name, block in [(1, "macklin2014", "Macklin et al. 2014"),
                             (2, "gissler2017", "Gissler et al. 2017")]:
        dr = from_splishsplash(_sph({"dragMethod": num, block: {"drag": 0.5}})).materials[0].drag
        assert (dr.method, dr.coefficient) == (name, 0.5)
        assert from_splishsplash(_sph({"dragMethod": num})).materials[0].drag.coefficient == 0.01
    vc = from_splishsplash(_sph({"vorticityMethod": 2, "Vorticity confinement": {
        "vorticity": 0.2}})).materials[0].vorticity
    assert (vc.method, vc.coefficient) == ("confinement", 0.2)
    none = from_splishsplash(_sph({})).materials[0]
    assert none.surface_tension.method == none.drag.method == "none"


@pytest.mark.parametrize(
    ("mat", "expected"),
    [
        ({"surfaceTensionMethod": 5, "Zorilla, Ritter, et al. 2020": {"surfTZRnormal-mode": 7}},
         r"Materials\[0\]\.Zorilla, Ritter, et al\. 2020\.surfTZRnormal-mode: got 7"),
        ({"surfaceTensionMethod": 9}, r"surfaceTensionMethod: 9 \(unknown method\)"),
        ({"dragMethod": 3}, r"Materials\[0\]\.dragMethod: 3 \(unknown method\)"),
        ({"surfaceTensionMethod": 2, "Akinci et al. 2013": {"surfaceTension": -1}},
         r"Materials\[0\]\.Akinci et al\. 2013\.surfaceTension: got -1: expected a number >= 0"),
        ({"dragMethod": 1, "Macklin et al. 2014": {"drag": "x"}},
         r"Macklin et al\. 2014\.drag: got 'x': expected a finite number"),
        ({"vorticityMethod": 2, "Vorticity confinement": {"vorticity": -0.5}},
         r"Vorticity confinement\.vorticity: got -0\.5"),
    ],
)
def test_loader_errors_name_the_field(mat: dict, expected: str) -> None:
    with pytest.raises(SceneError, match=expected):
        from_splishsplash(_sph(mat))


def test_loader_warns_about_unknown_keys_in_a_method_block() -> None:
    with pytest.warns(UserWarning, match=r"He et al\. 2014\.surfaceTensionFoo"):
        from_splishsplash(_sph({"surfaceTensionMethod": 3,
                                "He et al. 2014": {"surfaceTensionFoo": 1}}))


def test_schema_validates_the_material_fields() -> None:
    with pytest.raises(Exception, match=r"surface_tension\.method"):
        Material.model_validate({"surface_tension": {"method": "tension2099"}})
    with pytest.raises(Exception, match=r"surface_tension\.coefficient"):
        Material.model_validate({"surface_tension": {"method": "he2014", "coefficient": -1}})
    with pytest.raises(Exception, match=r"drag\.coefficient"):
        Material.model_validate({"drag": {"method": "macklin2014", "coefficient": float("inf")}})
    with pytest.raises(Exception, match=r"air_velocity .* must have 2 components"):
        Scene.model_validate({"configuration": {"dim": 2, "gravity": [0, 0]},
                              "materials": [{"drag": {"method": "macklin2014",
                                                      "air_velocity": [1, 0, 0]}}]})
    with pytest.raises(ValueError, match=r"drag \(macklin2014\): coefficient: -1\.0; expected"):
        Macklin2014(-1.0)
    with pytest.raises(ValueError, match=r"boundary_coefficient: nan"):
        He2014(0.1, float("nan"))


@pytest.mark.parametrize("solver", ["wcsph", "pcisph", "pbf", "iisph", "dfsph"])
def test_every_solver_runs_the_models_2d(solver: str) -> None:
    """A small 2D drop on a floor with Akinci surface tension and adhesion, Macklin drag and
    vorticity confinement: the simulation builds the forces from the scene and stays finite
    and in its box for 20 steps with each pressure solver."""
    sc = Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": 0.01, "gravity": [0.0, -9.81],
                          "pressure": {"method": solver}, "time": {"dt_max": 0.002}},
        "materials": [{"surface_tension": {"method": "akinci2013", "coefficient": 2e-4,
                                           "boundary_coefficient": 1e-3},
                       "drag": {"method": "macklin2014", "coefficient": 0.01},
                       "vorticity": {"method": "confinement", "coefficient": 0.01}}],
        "fluid_blocks": [{"start": [0.1, 0.02], "end": [0.3, 0.22]}],
        "boxes": [{"min": [0.0, 0.0], "max": [0.4, 0.4]}],
    })
    sim = Simulation(sc)
    names = [type(f).__name__ for f in sim.forces]
    assert names == ["VorticityConfinement", "Akinci2013", "Macklin2014"]
    for _ in range(20):
        sim.step()
    x = sim.positions
    assert np.isfinite(x).all() and x.min() > -0.05 and x.max() < 0.45


@pytest.mark.parametrize(("st_method", "drag", "vort"), [
    ("becker2007", "gissler2017", "micropolar"), ("he2014", "macklin2014", "confinement")])
def test_3d_drop_runs(st_method: str, drag: str, vort: str) -> None:
    sc = Scene.model_validate({
        "configuration": {"dim": 3, "particle_radius": 0.02, "gravity": [0.0, -9.81, 0.0],
                          "pressure": {"method": "dfsph"}, "time": {"dt_max": 0.002}},
        "materials": [{"surface_tension": {"method": st_method, "coefficient": 0.05},
                       "drag": {"method": drag, "coefficient": 0.01},
                       "vorticity": {"method": vort}}],
        "fluid_blocks": [{"start": [0.1, 0.04, 0.1], "end": [0.3, 0.24, 0.3]}],
        "boxes": [{"min": [0.0, 0.0, 0.0], "max": [0.4, 0.4, 0.4]}],
    })
    sim = Simulation(sc)
    assert len(sim.forces) == 3
    for _ in range(10):
        sim.step()
    assert np.isfinite(sim.positions).all()


def _vortex_energy(vort: dict, steps: int = 60, n: int = 16) -> float:
    """Kinetic energy / initial after ``steps`` DFSPH steps of a Gaussian vortex in a free
    square of fluid (no gravity), as validation/vorticity.py runs it."""
    r = 1.0 / (2 * n)
    sc = Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": r, "gravity": [0.0, 0.0],
                          "pressure": {"method": "dfsph"}, "time": {"dt_max": 0.004}},
        "materials": [{"viscosity": {"method": "standard", "coefficient": 1e-3},
                       "vorticity": vort}],
        "fluid_blocks": [{"start": [0.0, 0.0], "end": [1.0, 1.0]}],
    })
    sim = Simulation(sc)
    x = sim.positions - 0.5
    vt = 2.0 * np.exp(-(x**2).sum(axis=1) / 0.04)
    sim.velocities[:, 0] = -vt * x[:, 1]
    sim.velocities[:, 1] = vt * x[:, 0]
    m = sim.fluid["m"]
    e0 = 0.5 * (m * (sim.velocities**2).sum(axis=1)).sum()
    for _ in range(steps):
        sim.step()
    return float(0.5 * (m * (sim.velocities**2).sum(axis=1)).sum() / e0)


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_vorticity_models_keep_more_kinetic_energy() -> None:
    """A decaying 2D vortex keeps more kinetic energy with confinement (it feeds the rotation)
    and with the micropolar model (spin exchange) than without a vorticity model. Measured: none
    0.957, micropolar 0.957 (+2e-4: at SPlisHSPlasH's default nu_t = 0.01 the effect is tiny
    over 0.24 s), confinement (eps 0.1 m/s) 1.22; the runs are deterministic, so the ordering
    itself is asserted."""
    none = _vortex_energy({"method": "none"})
    conf = _vortex_energy({"method": "confinement", "coefficient": 0.1})
    micro = _vortex_energy({"method": "micropolar", "coefficient": 0.01})
    assert none < 1.0
    assert conf > none + 0.1
    assert micro > none
