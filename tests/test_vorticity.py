"""Micropolar vorticity model (Bender et al. 2017): formulas, equilibrium, angular momentum,
scene loading and a SPlisHSPlasH scene that uses it."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from _wheel import wheel_scene

from sphkit.core.kernels import Kernel, kernel_id, lattice_volume
from sphkit.core.neighbors import Grid, NeighborList, neighbor_lists
from sphkit.core.operators import density_cpu
from sphkit.core.particles import ParticleSet
from sphkit.core.state import SimState
from sphkit.scene.schema import Material, Scene, SceneError
from sphkit.scene.splishsplash import from_splishsplash
from sphkit.simulation import Simulation
from sphkit.vorticity import MicropolarBender2017

RHO0 = 1000.0


def _ball(dim: int, radius: float, r: float) -> np.ndarray:
    """Lattice points (spacing 2r) of a disc/ball of the given radius about the origin."""
    s = 2.0 * r
    n = int(np.ceil(radius / s)) + 1
    axes = [np.arange(-n, n + 1) * s] * dim
    g = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, dim)
    return g[np.linalg.norm(g, axis=1) <= radius + 1e-12]


def _block(counts: list[int], r: float) -> np.ndarray:
    """Lattice points i * 2r, i = 0 .. counts[d] - 1 on each axis."""
    axes = [np.arange(c) * 2.0 * r for c in counts]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(counts))


def _state(x: np.ndarray, r: float, bx: np.ndarray | None = None) -> SimState:
    """Fluid at lattice positions x (M, dim), masses rho0 V (lattice volume), optional boundary
    particles bx with unit-ish Akinci volumes; neighbour lists and densities computed."""
    dim = x.shape[1]
    h = 4.0 * r
    kid = kernel_id("cubic")
    f = ParticleSet(dim)
    for name in ("v", "a"):
        f.register(name, "vector")
    for name in ("m", "rho", "p"):
        f.register(name)
    f.add(x, m=RHO0 * lattice_volume(2.0 * r, kid, h, dim), rho=RHO0)
    b = ParticleSet(dim)
    b.register("V")
    b.register("v", "vector")
    if bx is not None:
        b.add(bx, V=lattice_volume(2.0 * r, kid, h, dim))
    st = SimState(fluid=f, boundary=b, dim=dim, h=h, kid=kid, r=r, rho0=RHO0,
                  gravity=np.zeros(dim))
    _neighbors_and_density(st)
    return st


def _neighbors_and_density(st: SimState) -> None:
    f, b = st.fluid, st.boundary
    st.nl_ff = neighbor_lists(f["x"], st.h)
    st.nl_fb = Grid(b["x"], st.h).query(f["x"]) if b.n else NeighborList.empty(f.n)
    density_cpu(f["x"], f["m"], st.nl_ff.offsets, st.nl_ff.indices, b["x"], b["V"],
                st.nl_fb.offsets, st.nl_fb.indices, st.rho0, st.h, st.kid, st.dim, f["rho"])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of (..., 3) arrays."""
    return np.cross(a, b)


def _reference(st: SimState, nu: float, zeta: float, inv_theta: float, dt: float):
    """SPlisHSPlasH's formulas (MicropolarModel_Bender2017.cpp, Akinci boundary) by brute force
    over all pairs, in 3-vectors (2D: z = 0). Returns (a, alpha) as (N, 3) arrays."""
    f, b = st.fluid, st.boundary
    dim = st.dim
    k = Kernel("cubic", st.h, dim)

    def pad(a):
        out = np.zeros((a.shape[1], 3))
        out[:, : a.shape[0]] = a.T
        return out

    x, v, w = pad(f["x"]), pad(f["v"]), f["omega"].T.copy()
    m, rho = f["m"], f["rho"]
    xij = x[:, None, :] - x[None, :, :]
    rij = np.linalg.norm(xij, axis=-1)
    near = (rij < st.h) & ~np.eye(len(x), dtype=bool)
    gw = np.where(near[..., None], k.dw_over_r(rij)[..., None] * xij, 0.0)
    wv = np.where(near, k.w(rij), 0.0)
    wij = w[:, None, :] - w[None, :, :]
    vij = v[:, None, :] - v[None, :, :]
    a = nu / rho[:, None] * (m[None, :, None] * _cross(wij, gw)).sum(axis=1)
    alpha = nu * inv_theta / rho[:, None] * (m[None, :, None] * _cross(vij, gw)).sum(axis=1)
    alpha -= zeta * inv_theta / dt * ((m / rho)[None, :, None] * wij * wv[..., None]).sum(axis=1)
    if b.n:
        bx, bv, psi = pad(b["x"]), pad(b["v"]), RHO0 * b["V"]
        xib = x[:, None, :] - bx[None, :, :]
        rib = np.linalg.norm(xib, axis=-1)
        gb = np.where((rib < st.h)[..., None], k.dw_over_r(rib)[..., None] * xib, 0.0)
        wi = np.broadcast_to(w[:, None, :], gb.shape)
        a += nu / rho[:, None] * (psi[None, :, None] * _cross(wi, gb)).sum(axis=1)
        vib = v[:, None, :] - bv[None, :, :]
        alpha += nu * inv_theta / rho[:, None] * (psi[None, :, None] * _cross(vib, gb)).sum(axis=1)
    alpha -= 2.0 * inv_theta * nu * w
    return a, alpha


@pytest.mark.parametrize("dim", [2, 3])
def test_matches_splishsplash_formulas_with_boundary(dim: int) -> None:
    """A jittered block with random v and omega next to a wall of boundary particles (moving
    with random v_b): the compiled model equals a brute-force evaluation of SPlisHSPlasH's
    formulas, boundary terms included, to 1e-10 relative (round-off; the same sums in another
    order), and omega advances by dt alpha. In 2D omega's x and y rows stay exactly zero."""
    r = 0.02
    rng = np.random.default_rng(1)
    n = 6 if dim == 3 else 12
    x = _block([n] * dim, r) + 0.15 * r * rng.standard_normal((n**dim, dim))
    wall = _block([n + 4, 1, n + 4][:dim], r) - 2 * 2 * r  # one layer at y = -4r, wider
    wall[:, 1] = -2 * r
    st = _state(x, r, wall)
    st.boundary["v"][...] = rng.normal(0.0, 0.3, st.boundary["v"].shape)
    nu, zeta, inv_theta, dt = 0.1, 0.05, 0.5, 1e-3
    model = MicropolarBender2017(nu, zeta, inv_theta)
    model.init(st)
    f = st.fluid
    f["v"][...] = rng.normal(0.0, 1.0, f["v"].shape)
    if dim == 3:
        f["omega"][...] = rng.normal(0.0, 5.0, f["omega"].shape)
    else:
        f["omega"][2] = rng.normal(0.0, 5.0, f.n)
    assert st.nl_fb.indices.size > 0
    a_ref, alpha_ref = _reference(st, nu, zeta, inv_theta, dt)
    omega0 = f["omega"].copy()
    f["a"][...] = 0.0
    model.apply(st, dt)
    scale_a = np.abs(a_ref).max()
    scale_al = np.abs(alpha_ref).max()
    assert np.abs(f["a"].T - a_ref[:, :dim]).max() < 1e-10 * scale_a
    if dim == 2:
        assert np.abs(a_ref[:, 2]).max() == 0.0
    assert np.abs(f["angular_acceleration"].T - alpha_ref).max() < 1e-10 * scale_al
    np.testing.assert_allclose(f["omega"], omega0 + dt * f["angular_acceleration"], rtol=0,
                               atol=1e-12 * np.abs(omega0).max())
    if dim == 2:
        assert not f["omega"][:2].any()


def _lattice_curl_factor(dim: int, r: float) -> float:
    """-S/d with S = sum_j V_j x_ij . grad W_ij over a full lattice neighbourhood (-d in the
    continuum): the SPH curl of a linear field on the lattice is the exact curl times this."""
    h = 4.0 * r
    k = Kernel("cubic", h, dim)
    g = _ball(dim, 2.0 * h, r)
    rr = np.linalg.norm(g, axis=1)
    f = np.where(rr > 0, k.dw_over_r(rr), 0.0)
    return float(-(lattice_volume(2.0 * r, "cubic", h, dim) * f * rr**2).sum() / dim)


@pytest.mark.parametrize("dim", [2, 3])
def test_rigid_rotation_is_an_equilibrium(dim: int) -> None:
    """A disc/ball in rigid rotation v = Omega x x with omega = Omega everywhere: curl v = 2 omega,
    so the coupling vanishes. Linear accelerations are exactly zero (omega_ij = 0; no boundary).
    Angular accelerations of interior particles (farther than h from the surface, full
    neighbourhoods) are below 3% of the coupling scale 2 nu_t |Omega| / Theta; what remains is
    the lattice error of the SPH curl (the curl of a linear field comes out times -S/d = 1.012
    in 2D and 1.020 in 3D for the cubic spline at h = 4r), which the test predicts to 1e-9.
    Surface particles miss neighbours, their curl is too small, and they are excluded."""
    r = 0.01
    radius = 0.2 if dim == 2 else 0.1
    st = _state(_ball(dim, radius, r), r)
    nu, zeta, inv_theta = 0.1, 0.05, 0.5
    model = MicropolarBender2017(nu, zeta, inv_theta)
    model.init(st)
    f = st.fluid
    omega = np.array([0.0, 0.0, 3.0]) if dim == 2 else np.array([0.6, -1.0, 3.0])
    f["v"][...] = np.cross(omega, np.pad(f["x"].T, ((0, 0), (0, 3 - dim))))[:, :dim].T
    f["omega"][...] = omega[:, None]
    f["a"][...] = 0.0
    model.apply(st, 1e-3)
    assert not f["a"].any()
    inner = np.linalg.norm(f["x"], axis=0) < radius - st.h
    assert inner.sum() > 100
    alpha = f["angular_acceleration"][:, inner]
    scale = 2.0 * nu * inv_theta * np.linalg.norm(omega)
    assert np.linalg.norm(alpha, axis=0).max() < 0.03 * scale
    predicted = 2.0 * nu * inv_theta * omega * (_lattice_curl_factor(dim, r) - 1.0)
    np.testing.assert_allclose(alpha, np.broadcast_to(predicted[:, None], alpha.shape),
                               rtol=0, atol=1e-9 * scale)


def _run_model_only(st: SimState, model: MicropolarBender2017, steps: int, dt: float) -> None:
    """Advance v and omega with the micropolar model as the only force, positions frozen (no
    pressure, no advection: the exchange between v and omega alone, on the regular lattice)."""
    f = st.fluid
    for _ in range(steps):
        f["a"][...] = 0.0
        model.apply(st, dt)
        f["v"] += dt * f["a"]


def test_spin_transfers_to_the_flow_and_total_angular_momentum_is_kept() -> None:
    """A 2D disc at rest with a Gaussian spot of spin omega_z = exp(-|x|^2 / 0.06^2) 1/s in its
    middle (nu_t = 0.01 m^2/s, 1/Theta = 250 1/m^2, so omega relaxes at 2 nu_t/Theta = 5/s;
    zeta = 4e-4 m^2, XSPH weight 0.1). After 0.3 s: the spin angular momentum sum m Theta omega
    has dropped below 30% of its initial value, the linear part sum m x x v has gained more than
    70% of it, with the same sign, and the flow in the middle rotates with omega (its SPH curl is
    positive). The total (linear + spin, the paper's angular momentum) is kept within 2%: the
    interior exchange balances up to the lattice error of the SPH curl (1.2%, see the rigid
    rotation test) times the transferred fraction; the spot stays far from the free surface,
    where the difference curl would not see the jump of omega to zero."""
    r = 0.01
    st = _state(_ball(2, 0.3, r), r)
    model = MicropolarBender2017(0.01, 4e-4, 250.0)
    model.init(st)
    f = st.fluid
    x = f["x"]
    f["omega"][2] = np.exp(-(x[0] ** 2 + x[1] ** 2) / 0.06**2)
    theta = 1.0 / model.inertia_inverse
    spin0 = (f["m"] * f["omega"][2]).sum() * theta
    total0 = model.angular_momentum(st)[2]
    assert total0 == pytest.approx(spin0)
    _run_model_only(st, model, 100, 3e-3)
    spin = (f["m"] * f["omega"][2]).sum() * theta
    total = model.angular_momentum(st)[2]
    linear = total - spin
    assert spin < 0.3 * spin0
    assert linear > 0.7 * spin0
    assert abs(total / total0 - 1.0) < 0.02
    # curl of v at the particles nearest the centre: (1/rho) sum m v_ij x grad W_ij > 0
    centre = np.argsort(np.hypot(f["x"][0], f["x"][1]))[:5]
    print(f"spin {spin / spin0:.4f}, linear {linear / spin0:.4f}, total {total / total0:.5f} "
          f"of the initial angular momentum")
    f["omega"][...] = 0.0
    f["a"][...] = 0.0
    MicropolarBender2017(1.0, 0.0, 1.0).apply(st, 1.0)  # omega = 0: alpha = curl v
    print("curl v near the centre [1/s]:", f["angular_acceleration"][2, centre])
    assert np.all(f["angular_acceleration"][2, centre] > 0.5)


def test_uniform_spin_at_a_free_surface_is_not_conserved() -> None:
    """Known property of the difference-curl discretization (as in SPlisHSPlasH): a fluid at rest
    with uniform omega feels no linear acceleration anywhere (omega_ij = 0, and the free surface
    is not seen), so its spin decays at 2 nu_t/Theta without any counterpart in the flow."""
    r = 0.01
    st = _state(_ball(2, 0.1, r), r)
    model = MicropolarBender2017(0.1, 0.05, 0.5)
    model.init(st)
    st.fluid["omega"][2] = 2.0
    st.fluid["a"][...] = 0.0
    model.apply(st, 1e-3)
    assert not st.fluid["a"].any()
    np.testing.assert_allclose(st.fluid["omega"][2], 2.0 * (1.0 - 2 * 0.1 * 0.5 * 1e-3), rtol=1e-12)


def test_parameters_are_validated() -> None:
    with pytest.raises(ValueError, match="micropolar model: vorticity: -0.1"):
        MicropolarBender2017(-0.1, 0.1, 0.5)
    with pytest.raises(ValueError, match="micropolar model: inertia_inverse: nan"):
        MicropolarBender2017(0.1, 0.1, float("nan"))
    with pytest.raises(ValueError, match="viscosity_omega"):
        Material.model_validate({"vorticity": {"method": "micropolar", "viscosity_omega": -1}})
    m = Material.model_validate({"vorticity": {"method": "micropolar"}})
    assert (m.vorticity.coefficient, m.vorticity.viscosity_omega,
            m.vorticity.inertia_inverse) == (0.01, 0.1, 0.5)


def _splishsplash_scene(vorticity: dict | None, method: int = 1) -> dict:
    mat: dict = {"id": "Fluid", "vorticityMethod": method}
    if vorticity is not None:
        mat["Bender et al. 2017"] = vorticity
    return {
        "Configuration": {"sim2D": True, "simulationMethod": 0, "boundaryHandlingMethod": 0},
        "Materials": [mat],
        "FluidBlocks": [{"start": [0, 0, 0], "end": [0.5, 0.5, 0]}],
    }


def test_loader_maps_vorticity_method_1() -> None:
    scene = from_splishsplash(_splishsplash_scene(
        {"vorticity": 0.15, "viscosityOmega": 0.05, "inertiaInverse": 0.4}))
    v = scene.materials[0].vorticity
    assert (v.method, v.coefficient, v.viscosity_omega, v.inertia_inverse) == (
        "micropolar", 0.15, 0.05, 0.4)
    d = from_splishsplash(_splishsplash_scene(None)).materials[0].vorticity  # SPlisHSPlasH's
    assert (d.method, d.coefficient, d.viscosity_omega, d.inertia_inverse) == (
        "micropolar", 0.01, 0.1, 0.5)
    flat = _splishsplash_scene(None)
    flat["Materials"][0].update(vorticity=0.2, inertiaInverse=0.25)  # scenes before 2.16
    f = from_splishsplash(flat).materials[0].vorticity
    assert (f.coefficient, f.viscosity_omega, f.inertia_inverse) == (0.2, 0.1, 0.25)
    assert from_splishsplash(_splishsplash_scene(None, 0)).materials[0].vorticity.method == "none"
    with pytest.raises(SceneError, match=r"Bender et al\. 2017\.vorticity: got -1"):
        from_splishsplash(_splishsplash_scene({"vorticity": -1}))
    assert from_splishsplash(_splishsplash_scene(None, 2)).materials[0].vorticity.method == (
        "confinement")
    with pytest.raises(SceneError, match=r"vorticityMethod: 3 \(Liu et al\. 2021"):
        from_splishsplash(_splishsplash_scene(None, 3))
    with pytest.warns(UserWarning, match=r"Bender et al\. 2017\.omega"):
        from_splishsplash(_splishsplash_scene({"omega": 1}))


def test_simulation_builds_the_model_and_inits_omega() -> None:
    sc = Scene.model_validate({
        "configuration": {"dim": 2, "particle_radius": 0.02, "time": {"until": 0.01}},
        "materials": [{"vorticity": {"method": "micropolar", "coefficient": 0.1}}],
        "fluid_blocks": [{"start": [0, 0], "end": [0.3, 0.3]}],
        "boxes": [{"min": [0, 0], "max": [0.4, 0.4]}],
    })
    sim = Simulation(sc)
    (model,) = [fc for fc in sim.forces if isinstance(fc, MicropolarBender2017)]
    assert model.vorticity == 0.1
    assert sim.fluid["omega"].shape == (3, sim.fluid.n)
    sim.run()
    assert np.all(np.isfinite(sim.fluid["omega"]))


def test_splishsplash_dambreak_2d_with_micropolar_runs() -> None:
    """SPlisHSPlasH's DamBreakModel_2D.json (standard viscosity 0.01 + micropolar 0.1/0.05/0.5)
    with WCSPH (B = 50000 Pa, gamma 7), Akinci boundary, fixed dt = 1 ms: it loads with the
    micropolar model and runs 50 steps without instability; the collapse creates spin (omega
    non-zero, z row only) and every particle stays in the tank [-2, 2] x [0, 4]."""
    path = wheel_scene("DamBreakModel_2D.json")
    data = copy.deepcopy(json.loads(path.read_text()))
    data["Configuration"].update(simulationMethod=0, boundaryHandlingMethod=0, cflMethod=0,
                                 timeStepSize=0.001, WCSPH={"stiffness": 50000, "exponent": 7})
    scene = from_splishsplash(data, path)
    vort = scene.materials[0].vorticity
    assert (vort.method, vort.coefficient, vort.viscosity_omega, vort.inertia_inverse) == (
        "micropolar", 0.1, 0.05, 0.5)
    sim = Simulation(scene)
    assert any(isinstance(fc, MicropolarBender2017) for fc in sim.forces)
    for _ in range(50):
        sim.step()  # raises InstabilityError on NaN or speeds above the scene's limit
    omega = sim.fluid["omega"]
    assert np.all(np.isfinite(omega)) and not omega[:2].any() and np.abs(omega[2]).max() > 0
    x = sim.positions
    assert x[:, 0].min() > -2.0 and x[:, 0].max() < 2.0
    assert x[:, 1].min() > 0.0 and x[:, 1].max() < 4.0
    assert sim.last.max_velocity < 2.0
